//! A weight that ramps linearly in power ratio between two levels given in dB: the shape of the
//! noise-floor gate ([`crate::noise_floor`]) and of the frame-onset weight
//! (`frame_onset` of `cma-localization`).

/// The power ratio of a level in dB: 10^(dB/10).
#[must_use]
// Out of line: one copy of `powf` for every caller (each gate and ramp at start-up), not one each.
#[inline(never)]
pub fn power_ratio_from_db(db: f32) -> f32 {
    libm::powf(10.0, db / 10.0)
}

/// 0 at and below the power ratio `lo`, 1 at and above `hi`, linear in the ratio between them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PowerRamp {
    lo: f32,
    hi: f32,
}

impl PowerRamp {
    /// The ramp from 0 at ratio 0 to 1 at ratio 1 (a placeholder for `const` contexts).
    pub const UNIT: Self = Self { lo: 0.0, hi: 1.0 };

    /// The ramp from `lo_db` to `hi_db` (dB of power ratio; `lo_db < hi_db` for a ramp).
    #[must_use]
    pub fn from_db(lo_db: f32, hi_db: f32) -> Self {
        Self {
            lo: power_ratio_from_db(lo_db),
            hi: power_ratio_from_db(hi_db),
        }
    }

    /// The ramp's value at the power ratio `r`, in [0, 1] for a number `r`.
    #[must_use]
    pub fn at(&self, r: f32) -> f32 {
        ((r - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ramps_linearly_in_power_between_the_levels() {
        let ramp = PowerRamp::from_db(0.0, 3.0);
        let hi = power_ratio_from_db(3.0);
        assert!((hi - 1.995_262_3).abs() < 1e-6);
        assert_eq!(ramp.at(0.5), 0.0);
        assert_eq!(ramp.at(1.0), 0.0);
        assert_eq!(ramp.at(hi), 1.0);
        assert_eq!(ramp.at(10.0), 1.0);
        assert!((ramp.at(0.5 * (1.0 + hi)) - 0.5).abs() < 1e-6);
        assert_eq!(PowerRamp::UNIT.at(0.25), 0.25);
    }
}
