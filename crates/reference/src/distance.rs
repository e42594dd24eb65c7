//! Distance from the proximity effect (thesis §3.1.6 eq. 3.10–3.14, §5.1.5 eq. 5.15).
//!
//! A point source at distance r gives each gradient (figure-8) component the factor
//! B̃(kr) = (1 + jkr)/(jkr) = 1 − j/(kr) (eq. 3.12), so cardioid m of CMA1 responds with
//! H_m = ½ + ½·cos(φ − φ_m)·(1 − j/(kr)) (eq. 3.14/3.15) while the omni stays 1. The reference
//! features |H_m|/|H_0| therefore depend on r only where kr ≲ 2, i.e. below a few hundred hertz for
//! r ≤ 2 m: distance analysis needs long frames and a low band (appendix A `Mfact`).
//!
//! With the azimuth already estimated, eq. 5.15 picks the reference distance whose features are most
//! similar: r̂ = argmax_r mean_p Sim(Y(f_p), 𝒴(φ̂, r, f_p)). The thesis found this weak; see
//! `docs/options.md` for what it does on simulated scenes.

use crate::reference_table::Feature;
use crate::CARDIOID_LOOK_DEG;

/// Speed of sound, m/s.
pub const SPEED_OF_SOUND: f32 = 343.0;

/// The thesis's reference distances (§5.1.5: 0.5, 1 and 2 m).
pub const REFERENCE_DISTANCES_M: [f32; 3] = [0.5, 1.0, 2.0];

/// Reference features of CMA1 for a point source at `azimuth_deg`, `distance_m`, frequency `f_hz`
/// (eq. 3.14 in eq. 5.8). A non-positive distance or frequency gives the far-field features.
#[must_use]
pub fn proximity_features(azimuth_deg: f32, distance_m: f32, f_hz: f32) -> Feature {
    let kr = 2.0 * core::f32::consts::PI * f_hz * distance_m / SPEED_OF_SOUND;
    let inv_kr = if kr > 0.0 && kr.is_finite() {
        1.0 / kr
    } else {
        0.0
    };
    let a = azimuth_deg.to_radians();
    core::array::from_fn(|m| {
        let g = 0.5 * crate::trig::cos(a - CARDIOID_LOOK_DEG[m].to_radians());
        // ½ + g·(1 − j/kr): real ½ + g, imaginary −g/kr
        let re = 0.5 + g;
        let im = -g * inv_kr;
        libm::sqrtf(re * re + im * im)
    })
}

/// Euclidean similarity 1/(1 + ‖a − b‖₂) (eq. 4.18).
#[must_use]
pub fn similarity(a: Feature, b: Feature) -> f32 {
    let d: f32 = (0..3).map(|i| (a[i] - b[i]) * (a[i] - b[i])).sum();
    1.0 / (1.0 + libm::sqrtf(d))
}

/// Adds, for every candidate distance i, the mean over `peaks` of Sim(Y(f_p), 𝒴(φ̂, r_i, f_p)) to
/// `scores[i]` (eq. 5.15 before the argmax). `peaks` holds (frequency Hz, observed feature).
/// Returns `false` (and adds nothing) when there are no peaks.
pub fn accumulate_scores(
    azimuth_deg: f32,
    peaks: &[(f32, Feature)],
    distances_m: &[f32],
    scores: &mut [f32],
) -> bool {
    if peaks.is_empty() {
        return false;
    }
    let inv = 1.0 / peaks.len() as f32;
    for (r, s) in distances_m.iter().zip(scores.iter_mut()) {
        let mut sum = 0.0f32;
        for (f, y) in peaks {
            sum += similarity(*y, proximity_features(azimuth_deg, *r, *f));
        }
        *s += sum * inv;
    }
    true
}

/// Index of the most similar distance (eq. 5.15); `None` for empty or non-finite scores.
#[must_use]
pub fn best_distance(scores: &[f32]) -> Option<usize> {
    let mut best: Option<(usize, f32)> = None;
    for (i, s) in scores.iter().enumerate() {
        if s.is_finite() && best.is_none_or(|(_, b)| *s > b) {
            best = Some((i, *s));
        }
    }
    best.map(|(i, _)| i)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn far_field_and_boost() {
        // high kr → the plain cardioid features
        let f = proximity_features(0.0, 2.0, 8000.0);
        assert!((f[0] - 1.0).abs() < 1e-3 && (f[1] - 0.25).abs() < 1e-2);
        assert_eq!(
            proximity_features(30.0, 0.0, 100.0),
            proximity_features(30.0, 1.0, 0.0)
        );
        // kr = 1: the rear cardioid of a source at 0° is boosted: |½ − ¼(1 − j)| = |¼ + j¼|
        let f_kr1 = SPEED_OF_SOUND / (2.0 * core::f32::consts::PI * 0.5);
        let y = proximity_features(0.0, 0.5, f_kr1);
        assert!((y[1] - (0.125f32).sqrt()).abs() < 1e-4, "{y:?}");
    }

    #[test]
    fn recovers_the_distance_of_noise_free_features() {
        for (i, r) in REFERENCE_DISTANCES_M.iter().enumerate() {
            let peaks: [(f32, Feature); 4] = core::array::from_fn(|p| {
                let f = 80.0 + 60.0 * p as f32;
                (f, proximity_features(70.0, *r, f))
            });
            let mut s = [0.0f32; 3];
            assert!(accumulate_scores(
                70.0,
                &peaks,
                &REFERENCE_DISTANCES_M,
                &mut s
            ));
            assert_eq!(best_distance(&s), Some(i));
        }
        let mut s = [0.0f32; 3];
        assert!(!accumulate_scores(0.0, &[], &REFERENCE_DISTANCES_M, &mut s));
        assert_eq!(best_distance(&[f32::NAN]), None);
    }
}
