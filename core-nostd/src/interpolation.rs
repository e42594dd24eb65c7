//! Position estimate from a similarity curve: argmax with parabolic interpolation on the wrapped
//! neighbours (thesis eq. 4.23–4.29), for uniform and non-uniform circular grids.

use crate::angle::wrap_deg;

/// The interpolated azimuth (degrees, (−180, 180]) of the maximum of `curve` over the circular grid
/// `azimuths_deg`, and the index of the grid maximum. Returns `None` for an empty curve or a curve
/// without a finite maximum.
#[must_use]
pub fn argmax_parabolic(curve: &[f32], azimuths_deg: &[f32]) -> Option<(f32, usize)> {
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
    let pm1 = if p == 0 { q - 1 } else { p - 1 };
    let pp1 = if p == q - 1 { 0 } else { p + 1 };
    let (sm, s0, sp) = (curve[pm1], curve[p], curve[pp1]);
    let den = 2.0 * (sm - 2.0 * s0 + sp);
    // A flat top (den = 0) or a numerically degenerate fit keeps the grid point.
    let delta = if den < 0.0 {
        ((sm - sp) / den).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    let spacing = if delta < 0.0 {
        wrap_deg(azimuths_deg[p] - azimuths_deg[pm1])
    } else {
        wrap_deg(azimuths_deg[pp1] - azimuths_deg[p])
    };
    Some((wrap_deg(azimuths_deg[p] + delta * spacing), p))
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
