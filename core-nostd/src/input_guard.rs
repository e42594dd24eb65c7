//! Input sanitation: NaN/±Inf samples become 0 and clipped samples are clamped to full scale, and
//! both are remembered long enough to flag every analysis frame they touch. Nothing downstream ever
//! sees a non-finite value.

use crate::estimate::Flags;
use crate::CHANNELS;

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

    /// [`InputGuard::process`] on the sample frames at the start of `block`; returns them cleaned:
    /// all of `block` itself when nothing needs cleaning (the common case: one integer test per value,
    /// no copy), else a cleaned copy of its first `scratch.len()` frames (or fewer, if `block` is
    /// shorter) in `scratch`. The countdowns end as after the per-sample calls on the returned frames;
    /// the caller continues with the rest of `block`.
    #[inline]
    pub fn clean_block<'a>(
        &self,
        state: &mut InputGuardState,
        block: &'a [[f32; CHANNELS]],
        scratch: &'a mut [[f32; CHANNELS]],
    ) -> &'a [[f32; CHANNELS]] {
        let n = block.len();
        if self.all_below_level(block) {
            let n = u32::try_from(n).unwrap_or(u32::MAX);
            state.clip_hold = state.clip_hold.saturating_sub(n);
            state.nonfinite_hold = state.nonfinite_hold.saturating_sub(n);
            return block;
        }
        let n = n.min(scratch.len());
        let out = &mut scratch[..n];
        // Index (+1) of the last sample frame with a clipped / a non-finite value, 0 for none.
        let mut last_clip = 0usize;
        let mut last_nonfinite = 0usize;
        let level = self.clip_level;
        for (i, (x, o)) in block.iter().zip(out.iter_mut()).enumerate() {
            let mut x = *x;
            for v in x.iter_mut() {
                if !v.is_finite() {
                    *v = 0.0;
                    last_nonfinite = i + 1;
                } else if v.abs() >= level {
                    *v = v.clamp(-1.0, 1.0);
                    last_clip = i + 1;
                }
            }
            *o = x;
        }
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
        out
    }

    /// Whether every value of `block` is finite with |v| below the clip level (then the guard leaves
    /// it alone), without a branch per value.
    ///
    /// For level > 0 the IEEE order of non-negative floats is the order of their bits, and NaN and ±Inf
    /// are above every finite level: |v| < level ⟺ abs_bits(v) < abs_bits(level). With the bits
    /// shifted left by one (dropping the sign), u = 2·abs_bits(v) and t = 2·abs_bits(level), u ≥ t
    /// ⟺ u + (2³² − t) carries out of 32 bits: the carries are counted (an add with carry per value on
    /// the Cortex-M4F). A level ≤ 0 or NaN makes every value suspect.
    #[inline]
    fn all_below_level(&self, block: &[[f32; CHANNELS]]) -> bool {
        let level = self.clip_level;
        if !(level > 0.0) {
            return block.is_empty();
        }
        let minus_limit = (level.to_bits() << 1).wrapping_neg();
        // Counted per chunk, so the count cannot wrap.
        block.chunks(1 << 16).all(|chunk| {
            let mut at_or_above = 0u32;
            for x in chunk {
                for v in x {
                    let (_, carry) = (v.to_bits() << 1).overflowing_add(minus_limit);
                    at_or_above += u32::from(carry);
                }
            }
            at_or_above == 0
        })
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

    /// The integer test agrees with the float test at the level's neighbours and elsewhere, for any
    /// sign and channel, and for levels ≤ 0 or NaN.
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
                    let pass = g.all_below_level(&[[0.0; CHANNELS], x]);
                    assert_eq!(pass, below && level > 0.0, "level {level} v {v} ch {ch}");
                }
            }
        }
    }
}
