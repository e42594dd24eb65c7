//! Which curve places the grid tracker's estimate between grid points ([`crate::running_curve`]).
//!
//! The tracker's likelihood is the frame's mean similarity curve: per peak 1/(1 + d), d the distance
//! of the peak's features from an azimuth's nearest (noisy) reference. Near the talker's azimuth that
//! is ≈ 1 − d, an L1 fit: each peak pulls with the same strength whatever its distance, so the
//! curve's maximum is a weighted *median* of the peaks' directions. That robustness suits the
//! likelihood (a frame whose peaks split between the direct sound and a reflection must not look
//! sure of either), but the median of a few peaks is a noisy position, and the curve has a corner at
//! each peak's own direction, so the parabola through three grid points of its running mean leans
//! towards the grid point.
//!
//! The refinement can instead average −d^p (the *distance curve*, normalised like the similarity
//! curve): p = 2 is a least-squares fit of the peaks' directions (a mean, smooth at its vertex),
//! p = 1.5 lies between the median and the mean. The grid tracker still decides *where* the talker
//! is from the similarity curve; the distance curve only moves the estimate within
//! [`crate::grid_tracker::GridTracker::refine_limit`] grid steps of the posterior's maximum.

use crate::curve_kernel::CurveKernel;
pub use crate::curve_kernel::{distance_of_similarity, DistancePower};
use crate::curve_tracker::Tracking;

/// The curve whose running mean places the estimate between grid points.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum RefineCurve {
    /// The frame's similarity curve (the tracker's likelihood).
    Similarity,
    /// −Σ w·d / Σ w: the L1 distance curve.
    Distance,
    /// −Σ w·d^1.5 / Σ w.
    Distance1_5,
    /// −Σ w·d² / Σ w: the least-squares curve.
    Distance2,
}

impl RefineCurve {
    /// The power of the distance, `None` for [`RefineCurve::Similarity`].
    #[must_use]
    pub const fn power(self) -> Option<DistancePower> {
        match self {
            RefineCurve::Similarity => None,
            RefineCurve::Distance => Some(DistancePower::One),
            RefineCurve::Distance1_5 => Some(DistancePower::ThreeHalves),
            RefineCurve::Distance2 => Some(DistancePower::Two),
        }
    }
}

/// The power of the distance curve whose running mean places the grid tracker's estimate between
/// grid points, for `kernel` and `tracking` (`None`: the similarity curve does, or there is no such
/// refinement). With a distance [`CurveKernel`] the similarity curve already is a distance curve,
/// so it places the estimate, and this is `None`.
#[must_use]
pub fn refine_distance_power(kernel: CurveKernel, tracking: &Tracking) -> Option<DistancePower> {
    if kernel.distance().is_some() {
        return None;
    }
    match tracking {
        Tracking::Grid(t) if t.refine_gain > 0.0 => t.refine_curve.power(),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn powers_of_a_distance() {
        let d = 0.36f32;
        assert_eq!(DistancePower::One.of(d * d, d), d);
        assert!((DistancePower::ThreeHalves.of(d * d, d) - 0.216).abs() < 1e-7);
        assert_eq!(DistancePower::Two.of(d * d, d), d * d);
        // From a similarity 1/(1 + d).
        assert!((distance_of_similarity(1.0 / 1.25) - 0.25).abs() < 1e-6);
        assert_eq!(distance_of_similarity(1.0), 0.0);
        assert_eq!(distance_of_similarity(0.0), 0.0);
        assert_eq!(distance_of_similarity(f32::NAN), 0.0);
        assert_eq!(RefineCurve::Similarity.power(), None);
        assert_eq!(
            RefineCurve::Distance1_5.power(),
            Some(DistancePower::ThreeHalves)
        );
    }
}
