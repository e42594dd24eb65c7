//! The per-peak term of the frame's similarity curve: how a peak's feature distance d from an
//! azimuth's nearest (noisy) reference becomes that azimuth's score.
//!
//! The thesis scores 1/(1 + d) (Euclidean similarity, §5.1.5). Near the talker's azimuth that is
//! ≈ 1 − d, an L1 fit: every peak pulls with the same strength whatever its distance, so the mean
//! curve's maximum is a weighted *median* of the peaks' directions, with a corner at each peak's own
//! direction. In a room, where a frame's peaks scatter around the direct sound, the median of ten
//! peaks is a noisy position, and the corners make the curve's parabolic vertex lean towards grid
//! points.
//!
//! [`CurveKernel::Distance`] scores 1 − k·d^p instead (the product uses p = 1.5, between the median
//! of p = 1 and the least-squares mean of p = 2). The mean curve is then 1 − k·Σw·d^p/Σw, smooth at
//! its vertex. Far from the talker it keeps falling where 1/(1 + d) flattens out, so the curve's
//! variance, which rates the frame ([`crate::reliability`]), has another scale: the product
//! configuration's variance floor and scale were measured for this kernel (docs/history.md, "Accuracy").
//!
//! On the Cortex-M4F it costs what the reciprocal costs: per peak and azimuth a square root and a
//! multiplication instead of an addition and a division, and the scale k is applied once per azimuth
//! with the normalisation by Σw.

/// The per-peak term of the similarity curve.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub enum CurveKernel {
    /// The similarity measure's own value: 1/(1 + d) for the Euclidean measure (the thesis).
    Reciprocal,
    /// 1 − k·d^p (Euclidean distance d; the curve is 1 − k·Σw·d^p/Σw).
    Distance {
        /// The power p.
        power: DistancePower,
        /// The scale k > 0.
        scale: f32,
    },
}

impl CurveKernel {
    /// The product's kernel: 1 − 1.5·d^1.5.
    pub const DEFAULT: Self = Self::Distance {
        power: DistancePower::ThreeHalves,
        scale: 1.5,
    };

    /// Whether the settings are usable: a finite scale > 0.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        match *self {
            Self::Reciprocal => true,
            Self::Distance { scale, .. } => scale > 0.0 && scale.is_finite(),
        }
    }

    /// The power and scale of a distance kernel, `None` for [`CurveKernel::Reciprocal`].
    #[must_use]
    pub const fn distance(&self) -> Option<(DistancePower, f32)> {
        match *self {
            Self::Reciprocal => None,
            Self::Distance { power, scale } => Some((power, scale)),
        }
    }
}

/// A power d^p of a peak's feature distance d, computed from d² and d without a library call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum DistancePower {
    /// d.
    One,
    /// d·√d.
    ThreeHalves,
    /// d².
    Two,
}

impl DistancePower {
    /// d^p from `squared` = d² ≥ 0 and `root` = d = √(d²) (both already computed by the similarity
    /// path). Correctly rounded square roots and one multiplication: the same bits on every target.
    #[inline(always)]
    #[must_use]
    pub fn of(self, squared: f32, root: f32) -> f32 {
        match self {
            DistancePower::One => root,
            DistancePower::ThreeHalves => root * crate::fast_math::sqrt_nonneg(root),
            DistancePower::Two => squared,
        }
    }
}

/// The distance d of a similarity s = 1/(1 + d) (the Euclidean and L_p measures): 1/s − 1, at
/// least 0 (and 0 for s ≤ 0 or NaN, which those measures do not give).
#[must_use]
pub fn distance_of_similarity(s: f32) -> f32 {
    let d = if s > 0.0 { 1.0 / s - 1.0 } else { 0.0 };
    if d > 0.0 {
        d
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validity_and_parts() {
        assert!(CurveKernel::Reciprocal.is_valid());
        assert!(CurveKernel::DEFAULT.is_valid());
        for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            let k = CurveKernel::Distance {
                power: DistancePower::One,
                scale: bad,
            };
            assert!(!k.is_valid(), "{bad}");
        }
        assert_eq!(CurveKernel::Reciprocal.distance(), None);
        assert_eq!(
            CurveKernel::DEFAULT.distance(),
            Some((DistancePower::ThreeHalves, 1.5))
        );
    }
}
