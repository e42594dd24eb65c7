//! Drift-compensated running mean of the similarity curve: where, between two grid points, the
//! grid tracker's estimate lies.
//!
//! The tracker's posterior says which grid point the talker is nearest, but its shape near the peak
//! is set by the random-walk kernel and the likelihood floor, not by the curves: a parabola through
//! the log-posterior pulls the estimate towards the grid point (up to 1.4° on a 5° grid). The mean
//! of recent curves, weighted by their reliability b, has the shape of the curves themselves; each
//! frame it is shifted by the tracker's drift so that it moves with a moving talker instead of
//! trailing behind. The estimate is the vertex of the parabola through this mean at the posterior's
//! maximum and its two neighbours.

use crate::interpolation::{neighbours, vertex};
use crate::MAX_AZIMUTHS;

/// The running mean curve over the azimuth grid.
#[derive(Debug, Clone)]
pub struct RunningCurve {
    mean: [f32; MAX_AZIMUTHS],
}

impl Default for RunningCurve {
    fn default() -> Self {
        Self::new()
    }
}

impl RunningCurve {
    /// All zero (no frame seen).
    #[must_use]
    pub const fn new() -> Self {
        Self {
            mean: [0.0; MAX_AZIMUTHS],
        }
    }

    /// The mean over the first `n` grid points.
    #[must_use]
    pub fn mean(&self, n: usize) -> &[f32] {
        &self.mean[..n.min(MAX_AZIMUTHS)]
    }

    /// Moves the mean by `shift` grid steps (|shift| ≤ 1; positive towards higher indices, circular,
    /// by linear interpolation between neighbours) and then towards `curve` by `gain` ∈ [0, 1].
    /// Only the first `curve.len()` grid points are used.
    pub fn update(&mut self, curve: &[f32], shift: f32, gain: f32) {
        let q = curve.len().min(MAX_AZIMUTHS);
        if q == 0 {
            return;
        }
        let mean = &mut self.mean[..q];
        let curve = &curve[..q];
        let g = if gain > 0.0 { gain.min(1.0) } else { 0.0 };
        let frac = if shift.is_finite() && q > 1 {
            shift.abs().min(1.0)
        } else {
            0.0
        };
        let keep = 1.0 - frac;
        // One pass: shift, then move towards the curve.
        if frac > 0.0 && shift > 0.0 {
            // new[i] = keep·old[i] + frac·old[i − 1], from the top down so old[i − 1] is unread.
            let last = mean[q - 1];
            for i in (1..q).rev() {
                let m = keep * mean[i] + frac * mean[i - 1];
                mean[i] = m + g * (curve[i] - m);
            }
            let m = keep * mean[0] + frac * last;
            mean[0] = m + g * (curve[0] - m);
        } else if frac > 0.0 {
            // new[i] = keep·old[i] + frac·old[i + 1], from the bottom up.
            let first = mean[0];
            for i in 0..q - 1 {
                let m = keep * mean[i] + frac * mean[i + 1];
                mean[i] = m + g * (curve[i] - m);
            }
            let m = keep * mean[q - 1] + frac * first;
            mean[q - 1] = m + g * (curve[q - 1] - m);
        } else if g > 0.0 {
            for (m, c) in mean.iter_mut().zip(curve) {
                *m += g * (c - *m);
            }
        }
    }

    /// Offset of the mean's parabola vertex from grid point `p`, in grid steps, clamped to
    /// ±`limit`, over the first `q` grid points (circular). `None` when the mean has no maximum
    /// there (a flat or upward-curved neighbourhood) or is not finite — the caller then falls back to
    /// another estimate; a non-finite mean is also cleared, so one bad frame cannot stick.
    pub fn vertex_offset(&mut self, p: usize, q: usize, limit: f32) -> Option<f32> {
        let q = q.min(MAX_AZIMUTHS);
        if q < 3 || p >= q {
            return None;
        }
        let (pm1, pp1) = neighbours(p, q);
        let (sm, s0, sp) = (self.mean[pm1], self.mean[p], self.mean[pp1]);
        if !(sm.is_finite() && s0.is_finite() && sp.is_finite()) {
            self.mean = [0.0; MAX_AZIMUTHS];
            return None;
        }
        let limit = if limit.is_finite() {
            limit.max(0.0)
        } else {
            0.0
        };
        vertex(sm, s0, sp)
            .filter(|d| d.is_finite())
            .map(|d| d.clamp(-limit, limit))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A smooth peak (not a parabola) centred at `at` grid steps on a 72-point circle.
    fn peak(at: f64) -> [f32; 72] {
        core::array::from_fn(|i| {
            let d = (i as f64 - at).rem_euclid(72.0);
            let d = d.min(72.0 - d);
            (1.0 / (1.0 + 0.3 * d * d)) as f32
        })
    }

    #[test]
    fn converges_to_the_curve_and_finds_an_off_grid_vertex() {
        let mut r = RunningCurve::new();
        let c = peak(10.3);
        for _ in 0..200 {
            r.update(&c, 0.0, 0.1);
        }
        for (m, v) in r.mean(72).iter().zip(&c) {
            assert!((m - v).abs() < 1e-4);
        }
        let d = r.vertex_offset(10, 72, 1.0).unwrap();
        // The parabola through (9, 10, 11) of this peak puts the vertex at +0.25 (true +0.3).
        assert!((d - 0.2527).abs() < 1e-3, "{d}");
        assert_eq!(r.vertex_offset(10, 72, 0.1), Some(0.1));
    }

    #[test]
    fn drift_shift_moves_the_peak_with_the_talker() {
        // A peak moving by +0.4 grid steps per frame: without the shift the mean trails, with it the
        // mean's vertex stays on the current peak.
        let run = |shift: f32| {
            let mut r = RunningCurve::new();
            let mut at = 20.0f64;
            for _ in 0..40 {
                at += 0.4;
                r.update(&peak(at), shift, 0.1);
            }
            (r, at)
        };
        let (mut r, at) = run(0.4);
        let p = at.round() as usize;
        let v = p as f64 + r.vertex_offset(p, 72, 1.0).unwrap() as f64;
        assert!((v - at).abs() < 0.35, "shifted: {v} vs {at}");
        let (r, at) = run(0.0);
        let top = (0..72)
            .max_by(|a, b| r.mean(72)[*a].total_cmp(&r.mean(72)[*b]))
            .unwrap();
        assert!(
            at - top as f64 > 0.9,
            "unshifted mean should trail: {top} vs {at}"
        );
        // A negative shift wraps around index 0.
        let mut r = RunningCurve::new();
        r.update(&peak(0.0), 0.0, 1.0);
        r.update(&peak(0.0), -1.0, 0.0);
        assert!((r.mean(72)[71] - 1.0).abs() < 1e-6);
    }

    #[test]
    fn degenerate_neighbourhoods_and_non_finite_values_give_none() {
        let mut r = RunningCurve::new();
        assert_eq!(r.vertex_offset(3, 72, 1.0), None); // flat
        assert_eq!(r.vertex_offset(80, 72, 1.0), None);
        assert_eq!(r.vertex_offset(0, 2, 1.0), None);
        let mut c = peak(5.0);
        c[5] = f32::NAN;
        r.update(&c, 0.0, 0.5);
        assert_eq!(r.vertex_offset(5, 72, 1.0), None);
        // Cleared: the next frames rebuild it.
        assert!(r.mean(72).iter().all(|v| *v == 0.0));
        r.update(&peak(5.0), 0.0, 1.0);
        assert_eq!(r.vertex_offset(5, 72, 1.0), Some(0.0));
        r.update(&[], 0.5, 0.5);
    }
}
