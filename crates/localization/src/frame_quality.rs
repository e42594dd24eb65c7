//! Alternative frame quality measures of thesis §5.1.6 and how they become the filter coefficient b:
//!
//! - frame power P (eq. 5.21) of the omni analysis frame;
//! - peak-frequency power P_fp = (1/N_p²)·Σ|X₀(f_p)|² (eq. 5.23);
//! - zero-crossing-rate voice activity VA = 1 if ZCR ≤ TH else 0 (eq. 5.24–5.25, TH = 1500 Hz);
//! - the curve variance V_S (eq. 5.26), which the localizer uses by default.
//!
//! Each selected measure Q is scaled to b̃_q = Q / Q_max (eq. 5.33–5.34; VA is already 0/1); the
//! selected factors multiply (eq. 5.36) and b = clip(K·Π b̃_q, 0, 1) (eq. 5.35). Optionally b is made
//! binary with a threshold b_TH — eq. 5.29 *the right way round* (`docs/algorithm.md`): b₀₁ = 1 when
//! b ≥ b_TH (trust the frame), 0 otherwise, so eq. 5.28 reproduces eq. 5.27.
//!
//! The default ([`FrameQuality::DEFAULT`]: curve variance only, no threshold) leaves the localizer
//! bit-identical to the plain reliability weighting; [`FrameQuality::is_default`] lets it skip this
//! module entirely.

use crate::reliability::{unit_reliability, Reliability};

/// Which quality measures are multiplied into b̃ (eq. 5.36). At least one should be set; with none,
/// b̃ = 1 (every frame trusted, like `QMoff`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct QualityMeasures {
    /// Similarity-curve variance V_S / V_max (eq. 5.26).
    pub curve_variance: bool,
    /// Omni frame power P / P_max (eq. 5.21).
    pub frame_power: bool,
    /// Peak-frequency power P_fp / P_fp,max (eq. 5.23).
    pub peak_power: bool,
    /// Zero-crossing-rate voice activity (eq. 5.24–5.25).
    pub zcr: bool,
}

/// Frame quality configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct FrameQuality {
    /// Selected measures.
    pub measures: QualityMeasures,
    /// Scale P_max of the frame power (full scale ±1 → a sine at full scale has P = 0.5). Default
    /// 0.025 (−16 dB): the largest frame power measured on `shared/data/eval` scenes (peak −3 dBFS),
    /// following eq. 5.33.
    pub power_max: f32,
    /// Scale of the peak-frequency power, in units of |X|² of the unnormalised, Hamming-windowed
    /// 512-point FFT. Default 5: estimated from P_max by Parseval (N²·P·0.2 one-sided energy, about
    /// half of it in 10 peaks, / N_p²), not fitted.
    pub peak_power_max: f32,
    /// ZCR threshold TH, crossings per second (thesis: 1500).
    pub zcr_threshold_hz: f32,
    /// Binary threshold b_TH on b (eq. 5.27–5.29); 0 or less disables it.
    pub binary_threshold: f32,
}

impl FrameQuality {
    /// Curve variance only, no threshold: the localizer's default reliability weighting.
    pub const DEFAULT: FrameQuality = FrameQuality {
        measures: QualityMeasures {
            curve_variance: true,
            frame_power: false,
            peak_power: false,
            zcr: false,
        },
        power_max: 0.025,
        peak_power_max: 5.0,
        zcr_threshold_hz: 1500.0,
        binary_threshold: 0.0,
    };

    /// `true` when the configuration is the plain curve-variance weighting (nothing to do here).
    #[must_use]
    pub fn is_default(&self) -> bool {
        self.measures == Self::DEFAULT.measures
            && (self.binary_threshold.is_nan() || self.binary_threshold <= 0.0)
    }

    /// `true` when every scale is positive and finite.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        let ok = |v: f32| v > 0.0 && v.is_finite();
        ok(self.power_max)
            && ok(self.peak_power_max)
            && ok(self.zcr_threshold_hz)
            && self.binary_threshold.is_finite()
    }

    /// The coefficient b ∈ [0, 1] of one frame (eq. 5.33–5.36, then eq. 5.29 if a threshold is set).
    /// `omni` is the omni analysis frame at `rate_hz`, `omni_power` its power spectrum, `peak_bins` the
    /// picked peaks. Non-finite inputs give b = 0.
    #[must_use]
    pub fn coefficient(
        &self,
        reliability: &Reliability,
        curve_variance: f32,
        omni: &[f32],
        rate_hz: f32,
        omni_power: &[f32],
        peak_bins: &[u16],
    ) -> f32 {
        let b = if reliability.enabled {
            let m = self.measures;
            let mut q = 1.0f32;
            if m.curve_variance {
                q *= curve_variance / reliability.v_max;
            }
            if m.frame_power {
                q *= frame_power(omni) / self.power_max;
            }
            if m.peak_power {
                q *= peak_power(omni_power, peak_bins) / self.peak_power_max;
            }
            if m.zcr {
                q *= voice_activity(zero_crossing_rate(omni, rate_hz), self.zcr_threshold_hz);
            }
            unit_reliability(reliability.speed * q)
        } else {
            1.0
        };
        binary(b, self.binary_threshold)
    }
}

impl Default for FrameQuality {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Frame power P = (1/N)·Σx² (eq. 5.21); 0 for an empty frame.
#[must_use]
pub fn frame_power(x: &[f32]) -> f32 {
    if x.is_empty() {
        return 0.0;
    }
    x.iter().map(|v| v * v).sum::<f32>() / x.len() as f32
}

/// Peak-frequency power P_fp = (1/N_p²)·Σ_p |X(f_p)|² (eq. 5.23) from a power spectrum; 0 without
/// peaks. Bins outside the spectrum are skipped.
#[must_use]
pub fn peak_power(power: &[f32], peak_bins: &[u16]) -> f32 {
    let n = peak_bins.len();
    if n == 0 {
        return 0.0;
    }
    let s: f32 = peak_bins
        .iter()
        .filter_map(|k| power.get(*k as usize))
        .sum();
    s / (n * n) as f32
}

/// Zero-crossing rate in crossings per second (eq. 5.25): (f_s / 2N)·Σ|sgn x(n) − sgn x(n−1)|,
/// with sgn 0 = 0 as in Matlab's `sign`.
#[must_use]
pub fn zero_crossing_rate(x: &[f32], rate_hz: f32) -> f32 {
    if x.len() < 2 {
        return 0.0;
    }
    let sgn = |v: f32| -> i32 {
        if v > 0.0 {
            1
        } else if v < 0.0 {
            -1
        } else {
            0
        }
    };
    let s: i32 = x.windows(2).map(|w| (sgn(w[1]) - sgn(w[0])).abs()).sum();
    rate_hz * s as f32 / (2.0 * x.len() as f32)
}

/// Voice activity VA = 1 if ZCR ≤ TH, else 0 (eq. 5.24).
#[must_use]
pub fn voice_activity(zcr_hz: f32, threshold_hz: f32) -> f32 {
    if zcr_hz <= threshold_hz {
        1.0
    } else {
        0.0
    }
}

/// Binary quality coefficient (eq. 5.29 with its cases the right way round): 1 when b ≥ b_TH, else 0;
/// `b` unchanged when b_TH ≤ 0 (thresholding off).
#[must_use]
pub fn binary(b: f32, threshold: f32) -> f32 {
    if threshold.is_nan() || threshold <= 0.0 {
        b
    } else if b >= threshold {
        1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const REL: Reliability = Reliability {
        enabled: true,
        speed: 1.0,
        v_max: 0.02,
        v_floor: 0.0,
        exponent: 1.0,
    };

    #[test]
    fn zcr_counts_crossings_per_second() {
        // A 1 kHz sine at 16 kHz crosses zero 2000 times a second.
        let fs = 16_000.0f32;
        let x: [f32; 512] = core::array::from_fn(|n| {
            libm::sinf(2.0 * core::f32::consts::PI * 1000.0 * (n as f32 + 0.25) / fs)
        });
        let z = zero_crossing_rate(&x, fs);
        assert!((z - 2000.0).abs() < 40.0, "{z}");
        assert_eq!(voice_activity(z, 1500.0), 0.0);
        let y: [f32; 512] = core::array::from_fn(|n| {
            libm::sinf(2.0 * core::f32::consts::PI * 200.0 * (n as f32 + 0.25) / fs)
        });
        assert_eq!(voice_activity(zero_crossing_rate(&y, fs), 1500.0), 1.0);
        assert_eq!(zero_crossing_rate(&[1.0], fs), 0.0);
    }

    #[test]
    fn powers_follow_eq_5_21_and_5_23() {
        assert!((frame_power(&[1.0, -1.0, 0.0, 0.0]) - 0.5).abs() < 1e-7);
        assert_eq!(frame_power(&[]), 0.0);
        let p = [0.0, 4.0, 0.0, 2.0];
        assert!((peak_power(&p, &[1, 3]) - 6.0 / 4.0).abs() < 1e-7);
        assert_eq!(peak_power(&p, &[]), 0.0);
        assert!((peak_power(&p, &[1, 99]) - 1.0).abs() < 1e-7);
    }

    #[test]
    fn binary_coefficient_trusts_frames_at_or_above_threshold() {
        // eq. 5.27: the estimate is updated (b₀₁ = 1) when b ≥ b_TH.
        assert_eq!(binary(0.6, 0.5), 1.0);
        assert_eq!(binary(0.5, 0.5), 1.0);
        assert_eq!(binary(0.4, 0.5), 0.0);
        assert_eq!(binary(0.4, 0.0), 0.4);
    }

    #[test]
    fn default_equals_plain_reliability_and_products_multiply() {
        let q = FrameQuality::DEFAULT;
        assert!(q.is_default() && q.is_valid());
        let x = [0.1f32; 512];
        for v in [0.0f32, 0.001, 0.01, 0.05, f32::NAN] {
            assert_eq!(
                q.coefficient(&REL, v, &x, 12_000.0, &[], &[]),
                REL.coefficient(v)
            );
        }
        // variance × power: 0.01/0.02 · (0.01/0.01) = 0.5
        let q = FrameQuality {
            power_max: 0.01,
            ..q
        };
        let both = FrameQuality {
            measures: QualityMeasures {
                frame_power: true,
                ..q.measures
            },
            ..q
        };
        assert!(!both.is_default());
        let b = both.coefficient(&REL, 0.01, &x, 12_000.0, &[], &[]);
        assert!((b - 0.5).abs() < 1e-5, "{b}");
        // ZCR: a constant frame has no crossings → VA = 1 → b unchanged
        let zcr = FrameQuality {
            measures: QualityMeasures {
                zcr: true,
                ..q.measures
            },
            ..q
        };
        assert!((zcr.coefficient(&REL, 0.01, &x, 12_000.0, &[], &[]) - 0.5).abs() < 1e-6);
        // binary threshold
        let bin = FrameQuality {
            binary_threshold: 0.3,
            ..q
        };
        assert_eq!(bin.coefficient(&REL, 0.01, &x, 12_000.0, &[], &[]), 1.0);
        assert_eq!(bin.coefficient(&REL, 0.002, &x, 12_000.0, &[], &[]), 0.0);
    }
}
