//! Input sanitation: NaN/±Inf samples become 0 and clipped samples are clamped to full scale, and
//! both are remembered long enough to flag every analysis frame they touch. Nothing downstream ever
//! sees a non-finite value.

use crate::estimate::Flags;
use crate::{CHANNELS, FRAME_LEN};

/// Thresholds of the guard.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InputGuard {
    /// |x| at or above this counts as clipped (full scale is 1.0).
    pub clip_level: f32,
    /// How many input samples a bad sample keeps its flag alive (≥ one analysis frame plus the
    /// decimator's delay, in input samples).
    pub hold_samples: u32,
}

/// Countdowns of the guard.
#[derive(Debug, Clone, Copy, Default)]
pub struct InputGuardState {
    clip_hold: u32,
    nonfinite_hold: u32,
}

impl InputGuardState {
    /// Both countdowns at zero.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            clip_hold: 0,
            nonfinite_hold: 0,
        }
    }
}

impl InputGuard {
    /// A placeholder of an unconfigured localizer: nothing counts as clipped, no hold.
    pub const IDLE: InputGuard = InputGuard {
        clip_level: 1.0,
        hold_samples: 0,
    };

    /// The guard for clip level `clip_level` ahead of a decimation by `factor`: bad samples flag the
    /// analysis frames that contain them (a frame plus the decimator's transient, in input samples).
    #[must_use]
    pub fn for_decimation(clip_level: f32, factor: u32) -> Self {
        InputGuard {
            clip_level,
            hold_samples: (FRAME_LEN as u32 + 64) * factor,
        }
    }

    /// Cleans one sample frame in place and updates the countdowns.
    #[inline]
    pub fn process(&self, state: &mut InputGuardState, x: &mut [f32; CHANNELS]) {
        state.clip_hold = state.clip_hold.saturating_sub(1);
        state.nonfinite_hold = state.nonfinite_hold.saturating_sub(1);
        for v in x.iter_mut() {
            if !v.is_finite() {
                *v = 0.0;
                state.nonfinite_hold = self.hold_samples;
            } else if v.abs() >= self.clip_level {
                *v = v.clamp(-1.0, 1.0);
                state.clip_hold = self.hold_samples;
            }
        }
    }

    /// Cleans one sample frame's values as [`InputGuard::process`] does; returns whether one was
    /// clipped (finite, |v| ≥ the clip level) and whether one was not finite.
    #[inline]
    fn clean_values(&self, x: &mut [f32; CHANNELS]) -> (bool, bool) {
        let (mut clipped, mut non_finite) = (false, false);
        for v in x.iter_mut() {
            if !v.is_finite() {
                *v = 0.0;
                non_finite = true;
            } else if v.abs() >= self.clip_level {
                *v = v.clamp(-1.0, 1.0);
                clipped = true;
            }
        }
        (clipped, non_finite)
    }

    /// [`InputGuard::process`] on the sample frames at the start of `block`; returns them cleaned:
    /// `block` itself where cleaning changes no value (the common case, and also clipping at full
    /// scale, |v| ≤ 1, as 24-bit ADCs deliver it: such values are only flagged);
    /// else a cleaned copy of its first `scratch.len()` frames (or fewer) in `scratch`. The
    /// countdowns end as after the per-sample calls on the returned frames; the caller continues
    /// with the rest of `block`.
    ///
    /// Integer scans (|v| ≥ level ⟺ 2·abs_bits(v) ≥ 2·bits(level) for a level > 0, NaN and ±Inf
    /// included): the first frame with a value at or above the clip level (`first_at_or_above`,
    /// the common case's only scan); from there one pass (`scan_block`) that tests each clipped
    /// frame for a value that cleaning changes (beyond full scale, or not finite) and ends at the
    /// first such frame, or at the end of `block` with the last clipped frame.
    #[inline]
    pub fn clean_block<'a>(
        &self,
        state: &mut InputGuardState,
        block: &'a [[f32; CHANNELS]],
        scratch: &'a mut [[f32; CHANNELS]],
    ) -> &'a [[f32; CHANNELS]] {
        let n = block.len();
        let level = self.clip_level;
        if !(level > 0.0) {
            return self.clean_copy(state, block, scratch, (0, 0));
        }
        let limit = level.to_bits() << 1;
        let minus_limit = limit.wrapping_neg();
        let first = first_at_or_above(block, minus_limit);
        if first == n {
            self.pass_clean(state, n);
            return block;
        }
        // Cleaning changes v iff it is not finite, or |v| ≥ level and |v| > 1 (the clamp to ±1): iff
        // u = 2·abs_bits(v) ≥ max(limit, 2·bits(1) + 2) (u is even).
        let minus_change = limit.max((1.0f32.to_bits() << 1) + 2).wrapping_neg();
        let (change, last) = scan_block(&block[first..], minus_limit, minus_change);
        // Frame `first` clips: `last` is 0 only when it is also the first that changes.
        let (change, last_clip) = (first + change, if last == 0 { 0 } else { first + last });
        if change == n {
            // Nothing changes: the block stays as it is; the last clipped frame sets the hold.
            self.count_down(state, n, last_clip, 0);
            return block;
        }
        // (A copy of the whole block rather than its unchanged start in place: the decimator's
        // per-call cost, and its sample-by-sample path where a piece ends inside a group, would be
        // paid twice.) The frames before `change` are copied as they are when the copy reaches it.
        let done = if change <= scratch.len() {
            (change, last_clip)
        } else {
            (0, 0)
        };
        self.clean_copy(state, block, scratch, done)
    }

    /// [`InputGuard::clean_block`]'s copy: the first `scratch.len()` frames of `block` (or fewer)
    /// cleaned into `scratch`, for any clip level (also ≤ 0 or NaN). `done` = (s, c): the first s
    /// frames (s ≤ `scratch.len()`) are known to need no cleaning, and the last clipped one among
    /// them has index c − 1 (0: none); (0, 0) knows nothing.
    fn clean_copy<'a>(
        &self,
        state: &mut InputGuardState,
        block: &[[f32; CHANNELS]],
        scratch: &'a mut [[f32; CHANNELS]],
        done: (usize, usize),
    ) -> &'a [[f32; CHANNELS]] {
        let n = block.len().min(scratch.len());
        let (block, out) = (&block[..n], &mut scratch[..n]);
        let (start, mut last_clip) = done;
        let start = start.min(n);
        copy_frames(&mut out[..start], &block[..start]);
        let level = self.clip_level;
        // Frames found by the scan are cleaned value by value, the runs between them copied.
        let minus_limit = if level > 0.0 {
            (level.to_bits() << 1).wrapping_neg()
        } else {
            // Every value is suspect (at a NaN level, only the non-finite ones change).
            0
        };
        let mut last_nonfinite = 0usize;
        let mut i = start;
        while i < n {
            let j = if minus_limit == 0 {
                i
            } else {
                i + copy_below(&mut out[i..], &block[i..], minus_limit)
            };
            if j == n {
                break;
            }
            let mut x = block[j];
            let (clipped, non_finite) = self.clean_values(&mut x);
            if clipped {
                last_clip = j + 1;
            }
            if non_finite {
                last_nonfinite = j + 1;
            }
            out[j] = x;
            i = j + 1;
        }
        self.count_down(state, n, last_clip, last_nonfinite);
        out
    }

    /// The countdowns after `n` sample frames whose last clipped / non-finite frame had index
    /// `last_clip − 1` / `last_nonfinite − 1` (0: none).
    #[inline]
    fn count_down(
        &self,
        state: &mut InputGuardState,
        n: usize,
        last_clip: usize,
        last_nonfinite: usize,
    ) {
        // After a bad sample frame at index i the hold restarts and counts down n − 1 − i times.
        let count = |hold: u32, last: usize| -> u32 {
            let n = n as u32;
            if last == 0 {
                hold.saturating_sub(n)
            } else {
                self.hold_samples.saturating_sub(n - last as u32)
            }
        };
        state.clip_hold = count(state.clip_hold, last_clip);
        state.nonfinite_hold = count(state.nonfinite_hold, last_nonfinite);
    }

    /// Counts down `n` sample frames that needed no cleaning (as [`InputGuard::process`] on each).
    #[inline]
    pub fn pass_clean(&self, state: &mut InputGuardState, n: usize) {
        let n = u32::try_from(n).unwrap_or(u32::MAX);
        state.clip_hold = state.clip_hold.saturating_sub(n);
        state.nonfinite_hold = state.nonfinite_hold.saturating_sub(n);
    }

    /// The test of [`InputGuard::clean_block`]'s fast path as a
    /// [`FrameCheck`](crate::block_decimator::FrameCheck), to run in the decimator's pass over the
    /// input ([`crate::block_decimator::BlockDecimator::run_checked`]); `None` for a clip level ≤ 0
    /// or NaN (every value suspect).
    #[cfg(target_arch = "x86_64")]
    #[must_use]
    pub(crate) fn level_check(&self) -> Option<sse::LevelCheck> {
        (self.clip_level > 0.0).then(|| sse::LevelCheck::new(self.clip_level.to_bits() << 1))
    }

    /// Flags for the analysis frame that ends now.
    #[must_use]
    pub fn flags(&self, state: &InputGuardState) -> Flags {
        let mut f = Flags::NONE;
        if state.clip_hold > 0 {
            f.insert(Flags::CLIPPED);
        }
        if state.nonfinite_hold > 0 {
            f.insert(Flags::NON_FINITE);
        }
        f
    }
}

/// `dst.copy_from_slice(src)` (equal lengths) two sample frames (32 bytes) at a time: inline block
/// moves on the Cortex-M4F, where the library `memcpy` that `copy_from_slice` calls there moves a
/// word in ≈ 4 instructions.
#[inline]
fn copy_frames(dst: &mut [[f32; CHANNELS]], src: &[[f32; CHANNELS]]) {
    let mut d = dst.chunks_exact_mut(2);
    let mut s = src.chunks_exact(2);
    for (d, s) in (&mut d).zip(&mut s) {
        d.copy_from_slice(s);
    }
    for (d, s) in d.into_remainder().iter_mut().zip(s.remainder()) {
        *d = *s;
    }
}

/// Copies the sample frames of `src` into `dst` (at least as long) up to the first one with a value
/// whose u = 2·abs_bits(v) carries in u + `minus_limit` (as in [`first_at_or_above`]), which is not
/// copied; returns its index, or `src.len()` when there is none (all copied).
#[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
#[inline]
fn copy_below(dst: &mut [[f32; CHANNELS]], src: &[[f32; CHANNELS]], minus_limit: u32) -> usize {
    let j = first_at_or_above(src, minus_limit);
    copy_frames(&mut dst[..j], &src[..j]);
    j
}

/// [`copy_below`] on the hard-float Arm targets (the Cortex-M4F): the loop of [`first_at_or_above`]
/// with an `STM` of the frame's four values once they passed, 3 instructions per value; one pass
/// over the input for the scan and the copy.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline]
#[allow(unsafe_code)]
fn copy_below(dst: &mut [[f32; CHANNELS]], src: &[[f32; CHANNELS]], minus_limit: u32) -> usize {
    let n = src.len();
    if n == 0 {
        return 0;
    }
    let dst = &mut dst[..n];
    let start = src.as_ptr();
    let end = start.wrapping_add(n);
    let mut p = start;
    // Note(unsafe): reads the 16 bytes of each frame of `src` (a valid slice, `p` from its first to
    // its last frame) and writes those of the frame at the same index of `dst` (a valid slice of
    // the same length, `q` following `p`), for every frame before the one found, and nothing else;
    // `p` ends one frame past the frame found, or two past the last frame (`end` + 1) when none is
    // found; no stack; `r0`–`r3` and the flags are declared clobbered.
    unsafe {
        core::arch::asm!(
            "2:",
            "ldm {p}!, {{r0, r1, r2, r3}}",
            "adds {t}, {m}, r0, lsl #1",
            "bcs 3f",
            "adds {t}, {m}, r1, lsl #1",
            "bcs 3f",
            "adds {t}, {m}, r2, lsl #1",
            "bcs 3f",
            "adds {t}, {m}, r3, lsl #1",
            "bcs 3f",
            "stm {q}!, {{r0, r1, r2, r3}}",
            "cmp {p}, {end}",
            "bne 2b",
            "add {p}, {p}, #16",
            "3:",
            p = inout(reg) p,
            q = inout(reg) dst.as_mut_ptr() => _,
            m = in(reg) minus_limit,
            end = in(reg) end,
            t = out(reg) _,
            out("r0") _,
            out("r1") _,
            out("r2") _,
            out("r3") _,
            options(nostack)
        );
    }
    (p as usize - start as usize) / core::mem::size_of::<[f32; CHANNELS]>() - 1
}

/// Whether u = 2·abs_bits(`v`) carries in u + `minus_limit` (u ≥ limit for `minus_limit` = −limit).
#[cfg(any(not(all(target_arch = "arm", target_abi = "eabihf")), test))]
#[inline(always)]
fn at_or_above(v: f32, minus_limit: u32) -> bool {
    (v.to_bits() << 1).overflowing_add(minus_limit).1
}

/// Index of the first sample frame of `block` with a value v whose u = 2·abs_bits(v) carries in
/// u + `minus_limit` (i.e. u ≥ limit for `minus_limit` = −limit: |v| at or above the clip level, or v
/// not finite), or `block.len()` if there is none.
///
/// For a level > 0 the IEEE order of non-negative floats is the order of their bits, and NaN and ±Inf
/// are above every finite level: |v| ≥ level ⟺ abs_bits(v) ≥ abs_bits(level). With the bits shifted
/// left by one (dropping the sign), u = 2·abs_bits(v) and t = 2·abs_bits(level), u ≥ t ⟺
/// u + (2³² − t) carries out of 32 bits.
#[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
#[inline]
fn first_at_or_above(block: &[[f32; CHANNELS]], minus_limit: u32) -> usize {
    block
        .iter()
        .position(|x| x.iter().any(|v| at_or_above(*v, minus_limit)))
        .unwrap_or(block.len())
}

/// The scan of [`InputGuard::clean_block`], with u = 2·abs_bits(v) of each value v and the limits
/// as in [`first_at_or_above`]: the index of the first sample frame with a value whose u carries in
/// u + `minus_change` (its cleaning changes it), or `block.len()`; and one past the index of the last
/// frame before that one with a value whose u carries in u + `minus_limit` (0: none). Every value that
/// carries with `minus_change` must carry with `minus_limit` (change ≥ limit).
#[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
#[inline]
fn scan_block(block: &[[f32; CHANNELS]], minus_limit: u32, minus_change: u32) -> (usize, usize) {
    let mut last_clip = 0;
    for (i, x) in block.iter().enumerate() {
        if x.iter().any(|v| at_or_above(*v, minus_limit)) {
            if x.iter().any(|v| at_or_above(*v, minus_change)) {
                return (i, last_clip);
            }
            last_clip = i + 1;
        }
    }
    (block.len(), last_clip)
}

/// [`scan_block`] on the hard-float Arm targets (the Cortex-M4F): the loop of [`first_at_or_above`]
/// (2.75 instructions per value) that, at a frame with a value at or above the limit, tests the
/// frame's four values (still in registers) against the change limit, notes the frame and goes on;
/// one pass over the block however many frames clip.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline]
#[allow(unsafe_code)]
fn scan_block(block: &[[f32; CHANNELS]], minus_limit: u32, minus_change: u32) -> (usize, usize) {
    if block.is_empty() {
        return (0, 0);
    }
    let start = block.as_ptr();
    let end = start.wrapping_add(block.len());
    let mut p = start;
    let mut last = start;
    // Note(unsafe): reads the 16 bytes of each frame of `block` (a valid slice, `p` from its first to
    // its last frame) and nothing else; `p` ends one frame past the frame whose cleaning changes a
    // value, or two past the last frame (`end` + 1) when there is none; `last` is one frame past the
    // last clipped frame before it (or `start`); no stack; `r0`–`r3` and the flags are declared
    // clobbered.
    unsafe {
        core::arch::asm!(
            "2:",
            "ldm {p}!, {{r0, r1, r2, r3}}",
            "adds {t}, {m}, r0, lsl #1",
            "bcs 3f",
            "adds {t}, {m}, r1, lsl #1",
            "bcs 3f",
            "adds {t}, {m}, r2, lsl #1",
            "bcs 3f",
            "adds {t}, {m}, r3, lsl #1",
            "bcs 3f",
            "cmp {p}, {end}",
            "bne 2b",
            "b 4f",
            // A clipped frame: does its cleaning change a value?
            "3:",
            "adds {t}, {mc}, r0, lsl #1",
            "bcs 5f",
            "adds {t}, {mc}, r1, lsl #1",
            "bcs 5f",
            "adds {t}, {mc}, r2, lsl #1",
            "bcs 5f",
            "adds {t}, {mc}, r3, lsl #1",
            "bcs 5f",
            "mov {last}, {p}",
            "cmp {p}, {end}",
            "bne 2b",
            "4:",
            "add {p}, {p}, #16",
            "5:",
            p = inout(reg) p,
            last = inout(reg) last,
            m = in(reg) minus_limit,
            mc = in(reg) minus_change,
            end = in(reg) end,
            t = out(reg) _,
            out("r0") _,
            out("r1") _,
            out("r2") _,
            out("r3") _,
            options(readonly, nostack)
        );
    }
    let frame = core::mem::size_of::<[f32; CHANNELS]>();
    (
        (p as usize - start as usize) / frame - 1,
        (last as usize - start as usize) / frame,
    )
}

/// [`first_at_or_above`] on the hard-float Arm targets (the Cortex-M4F): per sample frame one `LDM` of its four values
/// and per value an add of the shifted bits that sets the carry and a branch on it, 2.75
/// instructions per value (the compiler's form of the same test took 7).
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline]
#[allow(unsafe_code)]
fn first_at_or_above(block: &[[f32; CHANNELS]], minus_limit: u32) -> usize {
    if block.is_empty() {
        return 0;
    }
    let start = block.as_ptr();
    let end = start.wrapping_add(block.len());
    let mut p = start;
    // Note(unsafe): reads the 16 bytes of each frame of `block` (a valid slice, `p` from its first to
    // its last frame) and nothing else; `p` ends one frame past the frame found, or two past the last
    // frame (`end` + 1) when none is found; no stack; `r0`–`r3` and the flags are declared clobbered.
    unsafe {
        core::arch::asm!(
            "2:",
            "ldm {p}!, {{r0, r1, r2, r3}}",
            "adds {t}, {m}, r0, lsl #1",
            "bcs 3f",
            "adds {t}, {m}, r1, lsl #1",
            "bcs 3f",
            "adds {t}, {m}, r2, lsl #1",
            "bcs 3f",
            "adds {t}, {m}, r3, lsl #1",
            "bcs 3f",
            "cmp {p}, {end}",
            "bne 2b",
            "add {p}, {p}, #16",
            "3:",
            p = inout(reg) p,
            m = in(reg) minus_limit,
            end = in(reg) end,
            t = out(reg) _,
            out("r0") _,
            out("r1") _,
            out("r2") _,
            out("r3") _,
            options(readonly, nostack)
        );
    }
    (p as usize - start as usize) / core::mem::size_of::<[f32; CHANNELS]>() - 1
}

/// The x86_64 input test that [`crate::front_end::FrontEnd::feed`] runs inside the decimator's pass
/// over the input (decimation factor > 1): a sample frame is one SSE2 vector, so the test of its four
/// values is a shift, an XOR and a compare, the test of [`first_at_or_above`]. Host only: the
/// Cortex-M4F, and the host at factor 1, scan with [`first_at_or_above`] in
/// [`InputGuard::clean_block`].
#[cfg(target_arch = "x86_64")]
pub(crate) mod sse {
    use crate::block_decimator::FrameCheck;
    use crate::CHANNELS;
    use core::arch::x86_64::{
        __m128i, _mm_add_epi32, _mm_cmpgt_epi32, _mm_loadu_si128, _mm_movemask_epi8, _mm_or_si128,
        _mm_set1_epi32, _mm_setzero_si128, _mm_xor_si128,
    };

    /// Whether sample frames are all finite and below the clip level, seen one at a time inside the
    /// decimator's pass over the input.
    ///
    /// A value v fails when u = 2·abs_bits(v) ≥ `limit` (unsigned). Unsigned u ≥ limit ⟺
    /// u > limit − 1 ⟺ (u ⊕ 2³¹) > (limit − 1) ⊕ 2³¹ as signed integers, which `_mm_cmpgt_epi32`
    /// tests; the lanes that fail are ORed together.
    #[derive(Debug, Clone, Copy)]
    pub struct LevelCheck {
        /// (limit − 1) ⊕ 2³¹ in every lane.
        threshold: __m128i,
        /// Lanes of the values that failed so far, all ones.
        bad: __m128i,
    }

    impl LevelCheck {
        /// A check for the doubled level bits `limit` (≥ 2).
        #[allow(unsafe_code)]
        pub(super) fn new(limit: u32) -> Self {
            // SAFETY: SSE2 is enabled on every x86_64 target; register operations only.
            unsafe {
                Self {
                    threshold: _mm_set1_epi32((limit.wrapping_sub(1) as i32) ^ i32::MIN),
                    bad: _mm_setzero_si128(),
                }
            }
        }

        /// No value seen so far failed: the frames can skip the cleaning of
        /// [`super::InputGuard::clean_block`] (count them down with
        /// [`super::InputGuard::pass_clean`]).
        #[allow(unsafe_code)]
        #[must_use]
        pub fn passed(&self) -> bool {
            // SAFETY: as in `new`.
            unsafe { _mm_movemask_epi8(self.bad) == 0 }
        }
    }

    impl FrameCheck for LevelCheck {
        #[allow(unsafe_code)]
        #[inline(always)]
        fn see(&mut self, x: &[f32; CHANNELS]) {
            // SAFETY: SSE2 is enabled on every x86_64 target, so the intrinsics exist; they work on
            // registers only, except `_mm_loadu_si128`, which reads the 16 bytes of the `[f32; 4]`
            // behind `x` (a valid reference; the unaligned load needs no alignment).
            unsafe {
                let bits = _mm_loadu_si128(x.as_ptr().cast());
                let u = _mm_xor_si128(_mm_add_epi32(bits, bits), _mm_set1_epi32(i32::MIN));
                self.bad = _mm_or_si128(self.bad, _mm_cmpgt_epi32(u, self.threshold));
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cleans_and_holds_flags() {
        let g = InputGuard {
            clip_level: 0.99,
            hold_samples: 3,
        };
        let mut s = InputGuardState::default();
        let mut x = [f32::NAN, f32::INFINITY, 2.0, -0.5];
        g.process(&mut s, &mut x);
        assert_eq!(x, [0.0, 0.0, 1.0, -0.5]);
        assert!(g.flags(&s).contains(Flags::CLIPPED | Flags::NON_FINITE));
        for _ in 0..3 {
            g.process(&mut s, &mut [0.0; 4]);
        }
        assert!(g.flags(&s).is_empty());
    }

    #[test]
    fn block_equals_per_sample() {
        let g = InputGuard {
            clip_level: 0.99,
            hold_samples: 5,
        };
        let mut x = [[0.1f32; CHANNELS]; 12];
        x[2][1] = f32::NAN;
        x[4][3] = 1.5;
        x[9][0] = f32::NEG_INFINITY;
        x[10][2] = -0.995;
        x[11][1] = 0.99;
        for split in 1..12 {
            for scratch_len in [1, 3, 12] {
                let (mut a, mut b) = (InputGuardState::default(), InputGuardState::default());
                for chunk in x.chunks(split) {
                    let mut rest = chunk;
                    while !rest.is_empty() {
                        let mut scratch = [[0.0f32; CHANNELS]; 12];
                        let out = g.clean_block(&mut b, rest, &mut scratch[..scratch_len]);
                        assert!(!out.is_empty());
                        for (v, o) in rest.iter().zip(out) {
                            let mut v = *v;
                            g.process(&mut a, &mut v);
                            assert_eq!(v.map(f32::to_bits), o.map(f32::to_bits));
                        }
                        assert_eq!(
                            (a.clip_hold, a.nonfinite_hold),
                            (b.clip_hold, b.nonfinite_hold)
                        );
                        rest = &rest[out.len()..];
                    }
                }
            }
        }
    }

    /// Clipping at full scale (|v| ≤ 1, what a 24-bit ADC delivers) changes no value: the block is
    /// used in place and only flagged; a value beyond full scale or not finite needs the copy.
    #[test]
    fn full_scale_clipping_is_flagged_in_place() {
        let g = InputGuard {
            clip_level: 0.999,
            hold_samples: 100,
        };
        let mut x = [[0.5f32; CHANNELS]; 8];
        x[3][1] = 1.0;
        x[5][2] = -1.0;
        x[6][0] = 0.9995;
        let mut s = InputGuardState::new();
        let mut scratch = [[0.0f32; CHANNELS]; 2];
        let out = g.clean_block(&mut s, &x, &mut scratch);
        assert!(core::ptr::eq(out, &x[..]));
        assert_eq!((s.clip_hold, s.nonfinite_hold), (99, 0));

        // A NaN at frame 4: a cleaned copy of as many frames as `scratch` holds.
        x[4][3] = f32::NAN;
        let mut s = InputGuardState::new();
        let out = g.clean_block(&mut s, &x, &mut scratch);
        assert_eq!(out, &x[..2]);
        assert_eq!((s.clip_hold, s.nonfinite_hold), (0, 0));
        let out = g.clean_block(&mut s, &x[2..], &mut scratch);
        assert_eq!(out, &x[2..4]);
        assert_eq!((s.clip_hold, s.nonfinite_hold), (100, 0));
        let out = g.clean_block(&mut s, &x[4..], &mut scratch);
        assert_eq!(out, &[[0.5, 0.5, 0.5, 0.0], [0.5, 0.5, -1.0, 0.5]]);
        assert_eq!((s.clip_hold, s.nonfinite_hold), (100, 99));
        let mut scratch = [[0.0f32; CHANNELS]; 8];
        let out = g.clean_block(&mut s, &x[6..], &mut scratch);
        assert!(core::ptr::eq(out, &x[6..]));
        assert_eq!((s.clip_hold, s.nonfinite_hold), (99, 97));
    }

    /// The scan of `clean_block` finds the first frame whose cleaning changes a value and the last
    /// clipped frame before it, as the float tests do, on random blocks of clean, clipped (at and
    /// beyond full scale) and non-finite values.
    #[test]
    fn scan_finds_first_change_and_last_clip() {
        let mut rng = crate::test_rng::XorShift64(0x2545_f491_4f6c_dd1d);
        let level = 0.999f32;
        let minus_limit = (level.to_bits() << 1).wrapping_neg();
        let minus_change = ((1.0f32.to_bits() << 1) + 2).wrapping_neg();
        for _ in 0..2000 {
            let len = (rng.next_u64() % 12) as usize;
            let mut pick = || {
                let r = rng.next_u64();
                match r % 16 {
                    0 => [1.0, -1.0, 0.9995, -level][(r >> 8) as usize % 4],
                    1 if r % 64 == 1 => {
                        [f32::NAN, f32::INFINITY, 1.5, -1.0001][(r >> 8) as usize % 4]
                    }
                    _ => ((r >> 8) % 1999) as f32 / 1000.0 - 0.999,
                }
            };
            let block: [[f32; CHANNELS]; 12] =
                core::array::from_fn(|_| core::array::from_fn(|_| pick()));
            let block = &block[..len];
            let changes = |x: &[f32; CHANNELS]| x.iter().any(|v| !v.is_finite() || v.abs() > 1.0);
            let clips = |x: &[f32; CHANNELS]| x.iter().any(|v| !v.is_finite() || v.abs() >= level);
            let change = block.iter().position(changes).unwrap_or(len);
            let last_clip = block[..change].iter().rposition(clips).map_or(0, |i| i + 1);
            assert_eq!(
                scan_block(block, minus_limit, minus_change),
                (change, last_clip),
                "{block:?}"
            );
        }
    }

    /// `copy_below` copies exactly the frames before the first one at or above the limit.
    #[test]
    fn copy_below_stops_at_the_first_frame_at_or_above() {
        let minus_limit = (0.999f32.to_bits() << 1).wrapping_neg();
        for bad in 0..=6 {
            let mut src = [[0.25f32; CHANNELS]; 6];
            src.iter_mut()
                .enumerate()
                .for_each(|(i, x)| x[i % CHANNELS] = i as f32 / 8.0);
            if let Some(x) = src.get_mut(bad) {
                x[bad % CHANNELS] = f32::NAN;
            }
            let mut dst = [[-1.0f32; CHANNELS]; 6];
            assert_eq!(copy_below(&mut dst, &src, minus_limit), bad);
            assert_eq!(dst[..bad], src[..bad]);
            assert!(dst[bad..].iter().flatten().all(|v| *v == -1.0));
        }
    }

    /// The integer scan (and on x86_64 the test in the decimator's pass) agrees with the float test
    /// on random bit patterns (NaN, ±Inf, subnormals included) and on values at and next to the
    /// level, for random levels.
    #[test]
    fn scan_equals_float_test() {
        let mut rng = crate::test_rng::XorShift64(0x9e37_79b9_7f4a_7c15);
        let mut next = || (rng.next_u64() >> 32) as u32;
        for round in 0..4000 {
            let level_bits = match round % 4 {
                0 => 1.0f32.to_bits(),
                1 => 0.999f32.to_bits(),
                2 => next() & 0x7fff_ffff,
                _ => f32::INFINITY.to_bits(),
            };
            let level = f32::from_bits(level_bits);
            if !(level > 0.0) {
                continue;
            }
            let len = (next() % 9) as usize;
            let block: [[f32; CHANNELS]; 8] = core::array::from_fn(|_| {
                core::array::from_fn(|_| {
                    let r = next();
                    let bits = match r % 5 {
                        0 => r,
                        1 => level_bits.wrapping_add(r % 3).wrapping_sub(1) | (r & 0x8000_0000),
                        2 => [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -0.0]
                            [r as usize % 5]
                            .to_bits(),
                        _ => ((r % 1000) as f32).to_bits() >> (r % 2),
                    };
                    f32::from_bits(bits)
                })
            });
            let block = &block[..len];
            let below = block
                .iter()
                .flatten()
                .all(|v| v.is_finite() && v.abs() < level);
            let minus_limit = (level_bits << 1).wrapping_neg();
            let scan = first_at_or_above(block, minus_limit) == len;
            assert_eq!(scan, below, "level {level} block {block:?}");
            #[cfg(target_arch = "x86_64")]
            {
                use crate::block_decimator::FrameCheck;
                let mut check = sse::LevelCheck::new(level_bits << 1);
                block.iter().for_each(|x| check.see(x));
                assert_eq!(
                    check.passed(),
                    below,
                    "fused: level {level} block {block:?}"
                );
            }
        }
    }

    /// The integer test (the separate scan, and on x86_64 the one in the decimator's pass) agrees
    /// with the float test at the level's neighbours and elsewhere, for any sign and channel, and for
    /// levels ≤ 0 or NaN.
    #[test]
    fn level_test_is_exact() {
        for level in [
            0.99f32,
            1.0,
            1e-30,
            f32::MIN_POSITIVE,
            0.0,
            -0.5,
            f32::NAN,
            f32::INFINITY,
        ] {
            let g = InputGuard {
                clip_level: level,
                hold_samples: 1,
            };
            let near = |v: f32| {
                [
                    v,
                    f32::from_bits(v.to_bits().saturating_sub(1)),
                    f32::from_bits(v.to_bits().saturating_add(1)),
                ]
            };
            let values = [
                level.abs(),
                0.5,
                0.0,
                f32::MAX,
                f32::INFINITY,
                f32::NAN,
                1e-40,
            ]
            .into_iter()
            .flat_map(near);
            for v in values.flat_map(|v| [v, -v]) {
                let below = v.is_finite() && v.abs() < level;
                for ch in 0..CHANNELS {
                    let mut x = [0.0; CHANNELS];
                    x[ch] = v;
                    let minus_limit = (level.to_bits() << 1).wrapping_neg();
                    let pass =
                        level > 0.0 && first_at_or_above(&[[0.0; CHANNELS], x], minus_limit) == 2;
                    assert_eq!(pass, below && level > 0.0, "level {level} v {v} ch {ch}");
                    // The same test inside the decimator's pass (x86_64): `None` where every value
                    // is suspect.
                    #[cfg(target_arch = "x86_64")]
                    {
                        use crate::block_decimator::FrameCheck;
                        let fused = g.level_check().map(|mut c| {
                            c.see(&[0.0; CHANNELS]);
                            c.see(&x);
                            c.passed()
                        });
                        assert_eq!(fused.unwrap_or(false), pass, "fused: level {level} v {v}");
                        assert_eq!(fused.is_none(), !(level > 0.0), "level {level}");
                    }
                }
            }
        }
    }
}
