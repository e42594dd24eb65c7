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
}
