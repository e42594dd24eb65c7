//! Position estimate from a similarity curve: argmax with parabolic interpolation on the wrapped
//! neighbours (thesis eq. 4.23–4.29), for uniform and non-uniform circular grids.

use crate::angle::wrap_deg;

/// The interpolated azimuth (degrees, (−180, 180]) of the maximum of `curve` over the circular grid
/// `azimuths_deg`, and the index of the grid maximum. Returns `None` for an empty curve or a curve
/// without a finite maximum.
#[must_use]
pub fn argmax_parabolic(curve: &[f32], azimuths_deg: &[f32]) -> Option<(f32, usize)> {
    argmax_parabolic_mapped(curve, azimuths_deg, |v| v)
}

/// As [`argmax_parabolic`], but the parabola is fitted to `map` of the maximum and its two neighbours
/// (e.g. `ln` for a posterior, whose logarithm is parabolic near a Gaussian peak). `map` must be
/// increasing.
#[must_use]
pub fn argmax_parabolic_mapped(
    curve: &[f32],
    azimuths_deg: &[f32],
    map: impl Fn(f32) -> f32,
) -> Option<(f32, usize)> {
    let q = curve.len().min(azimuths_deg.len());
    if q == 0 {
        return None;
    }
    let mut p = 0;
    let mut best = f32::NEG_INFINITY;
    for (i, v) in curve[..q].iter().enumerate() {
        if *v > best {
            best = *v;
            p = i;
        }
    }
    if !best.is_finite() {
        return None;
    }
    if q < 3 {
        return Some((wrap_deg(azimuths_deg[p]), p));
    }
    let (pm1, pp1) = neighbours(p, q);
    let (sm, s0, sp) = (map(curve[pm1]), map(curve[p]), map(curve[pp1]));
    // A flat top (no vertex) or a numerically degenerate fit keeps the grid point.
    let delta = vertex(sm, s0, sp).map_or(0.0, |d| d.clamp(-0.5, 0.5));
    Some((offset_azimuth(&azimuths_deg[..q], p, delta), p))
}

/// The circular neighbours (p − 1, p + 1) of grid point `p` among `q` ≥ 1 points.
#[must_use]
#[inline]
pub fn neighbours(p: usize, q: usize) -> (usize, usize) {
    let pm1 = if p == 0 { q - 1 } else { p - 1 };
    let pp1 = if p + 1 >= q { 0 } else { p + 1 };
    (pm1, pp1)
}

/// Vertex of the parabola through (−1, `sm`), (0, `s0`), (1, `sp`), in grid steps from the middle
/// point (eq. 4.27); `None` unless the parabola opens downwards (a maximum).
#[must_use]
#[inline]
pub fn vertex(sm: f32, s0: f32, sp: f32) -> Option<f32> {
    let den = 2.0 * (sm - 2.0 * s0 + sp);
    if den < 0.0 {
        Some((sm - sp) / den)
    } else {
        None
    }
}

/// The azimuth (degrees, (−180, 180]) `delta` grid steps from grid point `p` of the circular grid
/// `azimuths_deg` (at least 3 points), the step measured towards the neighbour on `delta`'s side.
#[must_use]
#[inline]
pub fn offset_azimuth(azimuths_deg: &[f32], p: usize, delta: f32) -> f32 {
    let (pm1, pp1) = neighbours(p, azimuths_deg.len());
    let spacing = if delta < 0.0 {
        wrap_deg(azimuths_deg[p] - azimuths_deg[pm1])
    } else {
        wrap_deg(azimuths_deg[pp1] - azimuths_deg[p])
    };
    wrap_deg(azimuths_deg[p] + delta * spacing)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_a_parabola_exactly_and_wraps() {
        let az: [f32; 24] = core::array::from_fn(|i| i as f32 * 15.0);
        for true_az in [95.0f32, 352.0, 3.0, 180.0] {
            let curve: [f32; 24] = core::array::from_fn(|i| {
                let d = wrap_deg(az[i] - true_az);
                1.0 - d * d / 1e4
            });
            let (est, _) = argmax_parabolic(&curve, &az).unwrap();
            assert!(wrap_deg(est - true_az).abs() < 1e-3, "{true_az}: {est}");
        }
        assert_eq!(
            argmax_parabolic(&[f32::NAN; 4], &[0.0, 90.0, 180.0, 270.0]),
            None
        );
        assert_eq!(argmax_parabolic(&[], &[]), None);
    }
}
