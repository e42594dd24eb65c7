//! Reliability weighting (thesis §5.1.6): the sample variance of the similarity curve rates a frame
//! (eq. 5.26), scaled and clipped to a coefficient b ∈ [0, 1] (eq. 5.33–5.35), which drives the adaptive
//! one-pole filter on the curve S̃_l = b·S_l + (1 − b)·S̃_{l−1} (eq. 5.31).

use crate::MAX_AZIMUTHS;

/// Scaling of the curve variance into the filter coefficient.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct Reliability {
    /// `false` gives b = 1 for every frame (appendix A `QMoff`).
    pub enabled: bool,
    /// Speed factor K (eq. 5.35): larger is faster.
    pub speed: f32,
    /// Scale V_max of the curve variance (eq. 5.33).
    pub v_max: f32,
    /// Variance floor V_0: frames at or below it get b = 0 (0 in the thesis).
    pub v_floor: f32,
    /// Exponent p of the scaled variance: b = clip(K·(V/V_max)^p, 0, 1). The thesis uses p = 1;
    /// p > 1 suppresses the many mediocre frames of a noisy room while keeping good frames fast.
    pub exponent: f32,
}

impl Reliability {
    /// `true` for K ≥ 0 and V_max > V_floor ≥ 0, K and V_max finite.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.speed >= 0.0
            && self.v_max > self.v_floor
            && self.v_floor >= 0.0
            && self.speed.is_finite()
            && self.v_max.is_finite()
    }

    /// b = clip(K · ((V − V_0) / (V_max − V_0))^p, 0, 1); 0 for a non-finite V.
    #[must_use]
    pub fn coefficient(&self, variance: f32) -> f32 {
        if !self.enabled {
            return 1.0;
        }
        let r = ((variance - self.v_floor) / (self.v_max - self.v_floor)).max(0.0);
        let scaled = if self.exponent == 1.0 {
            r
        } else if self.exponent == 2.0 {
            r * r
        } else {
            libm::powf(r, self.exponent)
        };
        unit_reliability(self.speed * scaled)
    }
}

/// A reliability b limited to [0, 1]; NaN and ±∞ count as 0 (no evidence).
#[must_use]
#[inline]
pub fn unit_reliability(b: f32) -> f32 {
    if b.is_finite() {
        b.clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// Sample variance (n − 1 normalisation) of a curve; 0 for fewer than two points.
#[must_use]
pub fn curve_variance(curve: &[f32]) -> f32 {
    curve_variance_with_sum(curve, curve.iter().fold(0.0, |s, v| s + v))
}

/// [`curve_variance`] with the curve's sum (in order from 0, as [`curve_variance`] adds it) already
/// known: the frame curve's normalisation adds it up in the same pass.
#[must_use]
pub fn curve_variance_with_sum(curve: &[f32], sum: f32) -> f32 {
    let n = curve.len();
    if n < 2 {
        return 0.0;
    }
    let mean = sum / n as f32;
    curve.iter().map(|v| (v - mean) * (v - mean)).sum::<f32>() / (n - 1) as f32
}

/// State of the adaptive one-pole filter on the similarity curve.
#[derive(Debug, Clone)]
pub struct CurveFilter {
    state: [f32; MAX_AZIMUTHS],
}

impl Default for CurveFilter {
    fn default() -> Self {
        Self::new()
    }
}

impl CurveFilter {
    /// A filter whose history is a flat (uninformative) curve.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            state: [0.0; MAX_AZIMUTHS],
        }
    }

    /// S̃ ← b·S + (1 − b)·S̃ over the first `curve.len()` points; returns the filtered curve.
    pub fn update(&mut self, b: f32, curve: &[f32]) -> &[f32] {
        let n = curve.len().min(MAX_AZIMUTHS);
        for (s, c) in self.state[..n].iter_mut().zip(curve) {
            *s = b * c + (1.0 - b) * *s;
        }
        &self.state[..n]
    }

    /// The filtered curve over `n` points.
    #[must_use]
    pub fn current(&self, n: usize) -> &[f32] {
        &self.state[..n.min(MAX_AZIMUTHS)]
    }

    /// Forgets the history.
    pub fn reset(&mut self) {
        self.state = [0.0; MAX_AZIMUTHS];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coefficient_is_clipped_and_filter_follows_eq_5_31() {
        let r = Reliability {
            enabled: true,
            speed: 2.0,
            v_max: 0.01,
            v_floor: 0.0,
            exponent: 1.0,
        };
        assert_eq!(r.coefficient(0.0), 0.0);
        assert!((r.coefficient(0.002) - 0.4).abs() < 1e-6);
        assert_eq!(r.coefficient(1.0), 1.0);
        assert_eq!(r.coefficient(f32::NAN), 0.0);
        let sq = Reliability { exponent: 2.0, ..r };
        assert!((sq.coefficient(0.005) - 0.5).abs() < 1e-6);
        assert_eq!(
            Reliability {
                enabled: false,
                ..r
            }
            .coefficient(0.0),
            1.0
        );

        let mut f = CurveFilter::new();
        f.update(1.0, &[1.0, 2.0, 3.0]);
        let out = f.update(0.25, &[5.0, 2.0, -1.0]);
        assert_eq!(out, &[2.0, 2.0, 2.0]);
        assert_eq!(f.update(0.0, &[9.0, 9.0, 9.0]), &[2.0, 2.0, 2.0]);
    }

    #[test]
    fn variance_against_reference() {
        let c = [1.0f32, 2.0, 4.0, 7.0];
        // mean 3.5, squared deviations 6.25 + 2.25 + 0.25 + 12.25 = 21, / 3 = 7
        assert!((curve_variance(&c) - 7.0).abs() < 1e-6);
        assert_eq!(curve_variance(&[3.0]), 0.0);
    }
}
