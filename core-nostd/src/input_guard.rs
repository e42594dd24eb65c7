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

    /// [`InputGuard::process`] on every sample frame of `block`, writing the cleaned channels to
    /// `out[ch][..block.len()]` (de-interleaved). The countdowns end as after the per-sample calls.
    #[inline]
    pub fn process_block(
        &self,
        state: &mut InputGuardState,
        block: &[[f32; CHANNELS]],
        out: [&mut [f32]; CHANNELS],
    ) {
        let n = block.len();
        let [o0, o1, o2, o3] = out;
        let (o0, o1, o2, o3) = (&mut o0[..n], &mut o1[..n], &mut o2[..n], &mut o3[..n]);
        // Index (+1) of the last sample frame with a clipped / a non-finite value, 0 for none.
        let mut last_clip = 0usize;
        let mut last_nonfinite = 0usize;
        let level = self.clip_level;
        // |v| < level ⟺ abs_bits(v) < abs_bits(level) for level > 0 (IEEE order of non-negative
        // floats is the order of their bits; NaN and ±Inf are above every finite level): an integer
        // test per value for the common case. A level ≤ 0 or NaN sends every value to the exact path.
        let limit = if level > 0.0 { level.to_bits() } else { 0 };
        let abs_bits = |v: f32| v.to_bits() & 0x7fff_ffff;
        for (i, x) in block.iter().enumerate() {
            let mut x = *x;
            let suspect = (abs_bits(x[0]) >= limit)
                | (abs_bits(x[1]) >= limit)
                | (abs_bits(x[2]) >= limit)
                | (abs_bits(x[3]) >= limit);
            if suspect {
                for v in x.iter_mut() {
                    if !v.is_finite() {
                        *v = 0.0;
                        last_nonfinite = i + 1;
                    } else if v.abs() >= level {
                        *v = v.clamp(-1.0, 1.0);
                        last_clip = i + 1;
                    }
                }
            }
            o0[i] = x[0];
            o1[i] = x[1];
            o2[i] = x[2];
            o3[i] = x[3];
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
        for split in 1..12 {
            let (mut a, mut b) = (InputGuardState::default(), InputGuardState::default());
            let mut outs = [[0.0f32; 12]; CHANNELS];
            for (c, chunk) in x.chunks(split).enumerate() {
                let [o0, o1, o2, o3] = &mut outs;
                let r = c * split..c * split + chunk.len();
                g.process_block(
                    &mut b,
                    chunk,
                    [
                        &mut o0[r.clone()],
                        &mut o1[r.clone()],
                        &mut o2[r.clone()],
                        &mut o3[r],
                    ],
                );
                for (j, v) in chunk.iter().enumerate() {
                    let mut v = *v;
                    g.process(&mut a, &mut v);
                    for ch in 0..CHANNELS {
                        assert_eq!(outs[ch][c * split + j].to_bits(), v[ch].to_bits());
                    }
                }
                assert_eq!(
                    (a.clip_hold, a.nonfinite_hold),
                    (b.clip_hold, b.nonfinite_hold)
                );
            }
        }
    }
}
