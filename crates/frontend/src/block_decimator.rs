//! Block decimation: the [`Decimator`]'s cascade run over a whole piece of interleaved sample frames
//! at a time, all stages in one pass, the last stage's outputs written straight to their destination
//! (the framer).
//!
//! Where the inputs so far are a multiple of the decimation factor, each group of `factor` input
//! sample frames gives one output per channel, through all stages at once, with the stages' state in
//! locals (registers) for the whole piece. [`LANES`] channels run in lockstep: on x86_64 the four
//! channels of a section are one SSE register; on the Cortex-M4F one channel at a time keeps its state
//! in the FPU's registers. Inputs before the first and after the last whole group go through
//! [`Decimator::process_lanes`] one sample frame at a time. Every channel sees the same operations in
//! the same order as with [`Decimator::process`], so the outputs are bit-identical to the per-sample
//! path, whatever the split of the input.

use crate::decimator::{
    pair_out, Decimator, DecimatorState, HalfbandKind, HalfbandState, MAX_SECTIONS,
};
use crate::tables::{HALFBAND_LONG, HALFBAND_SHORT};
use crate::CHANNELS;

/// Input sample frames the front end passes to [`BlockDecimator::run`] at most at a time.
pub const PIECE: usize = 256;

/// Channels that run in lockstep in whole groups: one on 32-bit Arm (the Cortex-M4F has 32
/// single-precision registers and no vectors; four channels' state, 40 values, would not fit), all
/// four elsewhere (4-wide float vectors).
pub const LANES: usize = if cfg!(target_arch = "arm") {
    1
} else {
    CHANNELS
};

/// Looks at every input sample frame [`BlockDecimator::run_checked`] takes, in the same pass as the
/// decimation (the front end's input check on x86_64, where the decimator's recursions leave the
/// vector units idle most of the time); `()` looks at nothing.
pub trait FrameCheck: Copy {
    /// Takes note of one input sample frame.
    fn see(&mut self, x: &[f32; CHANNELS]);
}

impl FrameCheck for () {
    #[inline(always)]
    fn see(&mut self, _: &[f32; CHANNELS]) {}
}

/// Decimator state of all channels for block processing ([`BlockDecimator::run`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct BlockDecimator {
    state: DecimatorState<CHANNELS>,
}

/// The stage sequences of [`Decimator::for_rate`] that have a whole-group kernel.
#[derive(Debug, Clone, Copy)]
enum Cascade {
    /// ×2: one long stage.
    Long,
    /// ×4: short, long.
    ShortLong,
    /// ×8: short, short, long.
    ShortShortLong,
}

impl Cascade {
    fn of(d: &Decimator) -> Option<Self> {
        use HalfbandKind::{Long, Short};
        match d.stages() {
            [Long] => Some(Self::Long),
            [Short, Long] => Some(Self::ShortLong),
            [Short, Short, Long] => Some(Self::ShortShortLong),
            _ => None,
        }
    }
}

impl BlockDecimator {
    /// Zeroed states.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            state: DecimatorState::new(),
        }
    }

    /// Zeroes the states in place.
    pub fn reset(&mut self) {
        self.state = DecimatorState::new();
    }

    /// Decimates the sample frames `input` into `out` (per channel, room for all outputs); returns the
    /// number of outputs per channel. `d` must have at least one stage (else nothing is written).
    ///
    /// # Panics
    /// If `out` has less room than the outputs.
    pub fn run(
        &mut self,
        d: &Decimator,
        input: &[[f32; CHANNELS]],
        out: [&mut [f32]; CHANNELS],
    ) -> usize {
        self.run_lanes::<LANES, ()>(d, input, out, &mut ())
    }

    /// [`BlockDecimator::run`], with `check` shown every sample frame of `input` (once each, in the
    /// same pass).
    ///
    /// # Panics
    /// If `out` has less room than the outputs.
    pub fn run_checked<C: FrameCheck>(
        &mut self,
        d: &Decimator,
        input: &[[f32; CHANNELS]],
        out: [&mut [f32]; CHANNELS],
        check: &mut C,
    ) -> usize {
        self.run_lanes::<LANES, C>(d, input, out, check)
    }

    /// [`BlockDecimator::run`] with `L` channels in lockstep in whole groups (`L` divides
    /// [`CHANNELS`]); for tests of both layouts on any target.
    pub(crate) fn run_lanes<const L: usize, C: FrameCheck>(
        &mut self,
        d: &Decimator,
        input: &[[f32; CHANNELS]],
        mut out: [&mut [f32]; CHANNELS],
        check: &mut C,
    ) -> usize {
        if d.stages().is_empty() {
            return 0;
        }
        let mut n = 0;
        let mut rest = input;
        while !self.state.aligned() {
            let Some((x, r)) = rest.split_first() else {
                break;
            };
            check.see(x);
            self.step(d, *x, &mut out, &mut n);
            rest = r;
        }
        let factor = d.factor() as usize;
        if let Some(cascade) = Cascade::of(d) {
            let groups = rest.len() / factor;
            let (body, tail) = rest.split_at(groups * factor);
            if groups > 0 {
                let mut outs = out.iter_mut().map(|o| &mut o[n..n + groups]);
                let st = &mut self.state.stages;
                if L == CHANNELS {
                    // One pass with a constant first channel (whole sample frames as vectors).
                    let o = core::array::from_fn(|_| outs.next().unwrap_or_default());
                    *check = run_groups::<L, C>(cascade, st, 0, body, o, *check);
                } else {
                    // The check rides along with the first channel group.
                    for c0 in (0..CHANNELS).step_by(L) {
                        let o = core::array::from_fn(|_| outs.next().unwrap_or_default());
                        if c0 == 0 {
                            *check = run_groups::<L, C>(cascade, st, c0, body, o, *check);
                        } else {
                            run_groups::<L, ()>(cascade, st, c0, body, o, ());
                        }
                    }
                }
                n += groups;
            }
            rest = tail;
        }
        for x in rest {
            check.see(x);
            self.step(d, *x, &mut out, &mut n);
        }
        n
    }

    /// One sample frame through the per-sample cascade; an output goes to `out[..][*n]`.
    #[inline]
    fn step(
        &mut self,
        d: &Decimator,
        x: [f32; CHANNELS],
        out: &mut [&mut [f32]; CHANNELS],
        n: &mut usize,
    ) {
        if let Some(y) = d.process_lanes(&mut self.state, x) {
            for (o, v) in out.iter_mut().zip(y) {
                o[*n] = v;
            }
            *n += 1;
        }
    }
}

/// `c0` (a multiple of `L`) as the compiler can use it: `c0 & (CHANNELS − L)` is `c0` for every valid
/// first channel, provably at most `CHANNELS − L` (no bounds checks), and the constant 0 for
/// `L = CHANNELS`, so that whole sample frames load as vectors.
#[inline(always)]
fn first_lane<const L: usize>(c0: usize) -> usize {
    const { assert!(L.is_power_of_two() && L <= CHANNELS && CHANNELS.is_power_of_two()) };
    c0 & (CHANNELS - L)
}

/// Whole groups of `input` through `cascade`, channels `c0..c0 + L`; `check` sees every sample
/// frame and is returned.
#[inline(always)]
fn run_groups<const L: usize, C: FrameCheck>(
    cascade: Cascade,
    st: &mut [HalfbandState<CHANNELS>; 3],
    c0: usize,
    input: &[[f32; CHANNELS]],
    out: [&mut [f32]; L],
    check: C,
) -> C {
    match cascade {
        Cascade::Long => groups_long(st, c0, input, out, check),
        Cascade::ShortLong => groups_short_long(st, c0, input, out, check),
        Cascade::ShortShortLong => groups_short_short_long(st, c0, input, out, check),
    }
}

/// A stage's section state of channels `c0..c0 + L`, as locals.
#[derive(Clone, Copy)]
struct Lanes<const L: usize> {
    x: [[f32; L]; MAX_SECTIONS],
    y: [[f32; L]; MAX_SECTIONS],
}

impl<const L: usize> Lanes<L> {
    #[inline(always)]
    fn load(s: &HalfbandState<CHANNELS>, c0: usize) -> Self {
        Self {
            x: core::array::from_fn(|k| core::array::from_fn(|l| s.x[k][c0 + l])),
            y: core::array::from_fn(|k| core::array::from_fn(|l| s.y[k][c0 + l])),
        }
    }

    #[inline(always)]
    fn store(&self, s: &mut HalfbandState<CHANNELS>, c0: usize) {
        for k in 0..MAX_SECTIONS {
            for l in 0..L {
                s.x[k][c0 + l] = self.x[k][l];
                s.y[k][c0 + l] = self.y[k][l];
            }
        }
    }

    /// One output from the input pair (`first`, `second`).
    #[inline(always)]
    fn pair<const N: usize>(
        &mut self,
        coefs: &[f32; N],
        first: [f32; L],
        second: [f32; L],
        scale: f32,
    ) -> [f32; L] {
        pair_out(coefs, &mut self.x, &mut self.y, first, second, scale)
    }
}

/// Channels `c0..c0 + L` of a sample frame.
#[inline(always)]
fn lanes<const L: usize>(frame: &[f32; CHANNELS], c0: usize) -> [f32; L] {
    core::array::from_fn(|l| frame[c0 + l])
}

/// Writes output `g` of channels `c0..c0 + L`.
#[inline(always)]
fn put<const L: usize>(out: &mut [&mut [f32]; L], g: usize, v: [f32; L]) {
    for l in 0..L {
        out[l][g] = v[l];
    }
}

// The kernels are functions of their own: vectorised on their own (x86_64), the four channels of a
// section stay one vector; inlined into the front end, the vectoriser grouped lanes of different
// sections together. One call per piece and channel group costs nothing measurable.

/// Whole groups of 2 input sample frames through a long stage, channels `c0..c0 + L`.
#[inline(never)]
fn groups_long<const L: usize, C: FrameCheck>(
    st: &mut [HalfbandState<CHANNELS>; 3],
    c0: usize,
    input: &[[f32; CHANNELS]],
    out: [&mut [f32]; L],
    mut check: C,
) -> C {
    let c0 = first_lane::<L>(c0);
    let groups = input.len() / 2;
    let mut out = out.map(|o| &mut o[..groups]);
    let mut s0 = Lanes::<L>::load(&st[0], c0);
    for (g, f) in (0..groups).zip(input.chunks_exact(2)) {
        for x in f {
            check.see(x);
        }
        let v = s0.pair(&HALFBAND_LONG, lanes(&f[0], c0), lanes(&f[1], c0), 0.5);
        put(&mut out, g, v);
    }
    s0.store(&mut st[0], c0);
    check
}

/// Whole groups of 4 input sample frames through a short and a long stage, channels `c0..c0 + L`.
#[inline(never)]
fn groups_short_long<const L: usize, C: FrameCheck>(
    st: &mut [HalfbandState<CHANNELS>; 3],
    c0: usize,
    input: &[[f32; CHANNELS]],
    out: [&mut [f32]; L],
    mut check: C,
) -> C {
    let c0 = first_lane::<L>(c0);
    let groups = input.len() / 4;
    let mut out = out.map(|o| &mut o[..groups]);
    let mut s0 = Lanes::<L>::load(&st[0], c0);
    let mut s1 = Lanes::<L>::load(&st[1], c0);
    for (g, f) in (0..groups).zip(input.chunks_exact(4)) {
        for x in f {
            check.see(x);
        }
        let a = s0.pair(&HALFBAND_SHORT, lanes(&f[0], c0), lanes(&f[1], c0), 1.0);
        let b = s0.pair(&HALFBAND_SHORT, lanes(&f[2], c0), lanes(&f[3], c0), 1.0);
        let v = s1.pair(&HALFBAND_LONG, a, b, 0.25);
        put(&mut out, g, v);
    }
    s0.store(&mut st[0], c0);
    s1.store(&mut st[1], c0);
    check
}

/// Whole groups of 8 input sample frames through two short stages and a long one, channels
/// `c0..c0 + L`.
#[inline(never)]
fn groups_short_short_long<const L: usize, C: FrameCheck>(
    st: &mut [HalfbandState<CHANNELS>; 3],
    c0: usize,
    input: &[[f32; CHANNELS]],
    out: [&mut [f32]; L],
    mut check: C,
) -> C {
    let c0 = first_lane::<L>(c0);
    let groups = input.len() / 8;
    let mut out = out.map(|o| &mut o[..groups]);
    let mut s0 = Lanes::<L>::load(&st[0], c0);
    let mut s1 = Lanes::<L>::load(&st[1], c0);
    let mut s2 = Lanes::<L>::load(&st[2], c0);
    for (g, f) in (0..groups).zip(input.chunks_exact(8)) {
        for x in f {
            check.see(x);
        }
        let a0 = s0.pair(&HALFBAND_SHORT, lanes(&f[0], c0), lanes(&f[1], c0), 1.0);
        let a1 = s0.pair(&HALFBAND_SHORT, lanes(&f[2], c0), lanes(&f[3], c0), 1.0);
        let b0 = s1.pair(&HALFBAND_SHORT, a0, a1, 1.0);
        let a2 = s0.pair(&HALFBAND_SHORT, lanes(&f[4], c0), lanes(&f[5], c0), 1.0);
        let a3 = s0.pair(&HALFBAND_SHORT, lanes(&f[6], c0), lanes(&f[7], c0), 1.0);
        let b1 = s1.pair(&HALFBAND_SHORT, a2, a3, 1.0);
        let v = s2.pair(&HALFBAND_LONG, b0, b1, 0.125);
        put(&mut out, g, v);
    }
    s0.store(&mut st[0], c0);
    s1.store(&mut st[1], c0);
    s2.store(&mut st[2], c0);
    check
}

#[cfg(test)]
mod tests {
    use super::*;

    fn signal(n: usize) -> [f32; CHANNELS] {
        let t = n as f32;
        [
            libm::sinf(0.01 * t),
            libm::sinf(0.37 * t + 1.0),
            libm::cosf(1.3 * t),
            ((n * 7919) % 1000) as f32 / 500.0 - 1.0,
        ]
    }

    /// A [`FrameCheck`] that counts the sample frames and hashes them in order.
    #[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
    struct Tally {
        frames: usize,
        hash: u64,
    }

    impl FrameCheck for Tally {
        fn see(&mut self, x: &[f32; CHANNELS]) {
            self.frames += 1;
            for v in x {
                self.hash = (self.hash ^ u64::from(v.to_bits())).wrapping_mul(0x100_0000_01b3);
            }
        }
    }

    /// `L` lanes in lockstep equal the per-sample decimator on every channel, bit for bit, for every
    /// rate and split (pieces that start and end anywhere in a group).
    fn equals_per_sample<const L: usize>() {
        const N: usize = 700;
        for rate in [24_000u32, 48_000, 96_000] {
            let d = Decimator::for_rate(rate).unwrap();
            for split in [1usize, 2, 3, 5, 8, 13, 64, 100, 256, N] {
                let mut block = BlockDecimator::new();
                let mut reference = [DecimatorState::<1>::new(); CHANNELS];
                let input: [[f32; CHANNELS]; N] = core::array::from_fn(signal);
                let mut got = [[0.0f32; N]; CHANNELS];
                let mut want = [[0.0f32; N]; CHANNELS];
                let (mut n_got, mut n_want) = (0, 0);
                let mut tally = Tally::default();
                for piece in input.chunks(split) {
                    let [o0, o1, o2, o3] = &mut got;
                    let out = [
                        &mut o0[n_got..],
                        &mut o1[n_got..],
                        &mut o2[n_got..],
                        &mut o3[n_got..],
                    ];
                    n_got += block.run_lanes::<L, Tally>(&d, piece, out, &mut tally);
                    for x in piece {
                        let mut any = false;
                        for (ch, st) in reference.iter_mut().enumerate() {
                            if let Some(y) = d.process(st, x[ch]) {
                                want[ch][n_want] = y;
                                any = true;
                            }
                        }
                        n_want += usize::from(any);
                    }
                    assert_eq!(n_got, n_want, "rate {rate} split {split}");
                }
                assert_eq!(n_got, N / d.factor() as usize);
                // The check saw every input sample frame once, in order.
                let mut want_tally = Tally::default();
                input.iter().for_each(|x| want_tally.see(x));
                assert_eq!(tally, want_tally, "L {L} rate {rate} split {split}");
                for ch in 0..CHANNELS {
                    for i in 0..n_got {
                        assert_eq!(
                            got[ch][i].to_bits(),
                            want[ch][i].to_bits(),
                            "L {L} rate {rate} split {split} ch {ch} i {i}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn one_lane_equals_per_sample() {
        equals_per_sample::<1>();
    }

    #[test]
    fn two_lanes_equal_per_sample() {
        equals_per_sample::<2>();
    }

    #[test]
    fn four_lanes_equal_per_sample() {
        equals_per_sample::<4>();
    }

    #[test]
    fn passthrough_writes_nothing() {
        let d = Decimator::for_rate(16_000).unwrap();
        let mut out = [[0.0f32; 4]; CHANNELS];
        let [o0, o1, o2, o3] = &mut out;
        let n = BlockDecimator::new().run(&d, &[[1.0; CHANNELS]; 4], [o0, o1, o2, o3]);
        assert_eq!(n, 0);
    }
}
