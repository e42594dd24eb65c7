//! Features of a picked bin for the three cardioids: the thesis's magnitude ratios (eq. 5.7)
//! Y_c = |X_c| / |X_0|, or the active ratios Y_c = Re(X_c / X_0) (not in the thesis; the product
//! configuration's choice).
//!
//! For one plane wave both equal the reference 0.5 + 0.5·cos(φ − φ_c) of the ideal model. They differ
//! in what noise and reflections do to them:
//!
//! * **Diffuse noise.** Its cardioid part is half omni plus a dipole uncorrelated with the omni, so
//!   E[X_c·X_0*] = ½·E|X_0|²: noise pulls the active ratio straight toward 0.5 (with SNR s, to
//!   (s·Y + ½)/(s + 1), a linear mix — the magnitude mixing of the noisy references with Y_η = ½),
//!   while the magnitude ratio is pulled toward √(⅓) along a curved path that the linear mix only
//!   approximates. Real capsules move that point: a measured table carries the active ratio's own
//!   noise row Re(E[X_c·X_0*])/E|X_0|² (`ReferenceTable::rows` of `cma-localization`), which is ½ for the ideal
//!   model.
//! * **Reflections.** With O = D + R·z and X_c = d_c·D + r_c·R·z (direct and one reflection, z the
//!   phase e^{−jωτ}), X_c / O is analytic in z on the unit disc when |R| < |D|, so its mean over
//!   uniformly spread phases is its value at z = 0: d_c, the direct sound's feature. Averaging over
//!   many bins cancels the reflection in the active ratio to the extent that the bins' phases
//!   spread; the magnitude ratio has no such property. (Picking the strongest peaks favours bins
//!   where D and R add in phase, so the cancellation is partial.)
//!
//! Measured with `host-sim eval` (README): the active ratios lower the anechoic MAE most.

use crate::spectrum::power;
use crate::CARDIOIDS;
use microfft::Complex32;

/// Feature vector of the three cardioids.
pub type Feature = [f32; CARDIOIDS];

/// Which ratio a peak's features are.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum FeatureKind {
    /// |X_c| / |X_0| (thesis eq. 5.7).
    Magnitude,
    /// Re(X_c / X_0) = Re(X_c·X_0*) / |X_0|².
    Active,
}

impl FeatureKind {
    /// The features of one bin from its omni value `omni` (with `omni_power` = |omni|², as the peak
    /// picker already has it) and its three cardioid values, or `None` when the omni bin is
    /// (numerically) empty or a feature is not finite.
    #[inline]
    #[must_use]
    pub fn of_bin(
        self,
        omni: Complex32,
        omni_power: f32,
        cardioids: [Complex32; CARDIOIDS],
    ) -> Option<Feature> {
        match self {
            FeatureKind::Magnitude => feature_from_powers(omni_power, cardioids.map(power)),
            FeatureKind::Active => active_features(omni, omni_power, cardioids),
        }
    }
}

/// Active-ratio features Re(X_c·X_0*) / |X_0|² of one bin (`omni_power` = |X_0|²), or `None` when
/// the omni bin is (numerically) empty or a value is not finite.
#[inline]
#[must_use]
pub fn active_features(
    omni: Complex32,
    omni_power: f32,
    cardioids: [Complex32; CARDIOIDS],
) -> Option<Feature> {
    ratios(omni_power, |inv| {
        cardioids.map(|c| (c.re * omni.re + c.im * omni.im) * inv)
    })
}

/// `features(1/omni_power)` when `omni_power` is usable (finite, above [`MIN_OMNI_POWER`]) and every
/// feature is finite, else `None`.
#[inline]
fn ratios(omni_power: f32, features: impl FnOnce(f32) -> Feature) -> Option<Feature> {
    if !(omni_power > MIN_OMNI_POWER) || !omni_power.is_finite() {
        return None;
    }
    let y = features(1.0 / omni_power);
    if y.iter().all(|v| v.is_finite()) {
        Some(y)
    } else {
        None
    }
}

/// Omni power below this (relative to nothing: the input is full-scale normalised) makes a bin unusable.
pub const MIN_OMNI_POWER: f32 = 1e-20;

/// Features from the powers |X_m|² of the four channels at one bin, or `None` when the omni bin is
/// (numerically) empty.
#[inline]
#[must_use]
pub fn feature_from_powers(omni_power: f32, cardioid_power: [f32; CARDIOIDS]) -> Option<Feature> {
    ratios(omni_power, |inv| {
        cardioid_power.map(|p| crate::fast_math::sqrtf(p * inv))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// CMA1 spectra of a sum of plane waves (azimuth, complex amplitude).
    fn spectra(waves: &[(f32, Complex32)]) -> (Complex32, [Complex32; 3]) {
        let mut o = Complex32::new(0.0, 0.0);
        let mut c = [Complex32::new(0.0, 0.0); 3];
        for &(az, a) in waves {
            o += a;
            for (m, cm) in c.iter_mut().enumerate() {
                let g = 0.5 + 0.5 * libm::cosf((az - 120.0 * m as f32).to_radians());
                *cm += a * g;
            }
        }
        (o, c)
    }

    #[test]
    fn active_ratio_of_a_plane_wave_is_the_model() {
        for az in [0.0f32, 37.0, 170.0, 250.0] {
            let (o, c) = spectra(&[(az, Complex32::new(0.3, -0.7))]);
            let y = active_features(o, o.norm_sqr(), c).unwrap();
            for (m, v) in y.iter().enumerate() {
                let want = 0.5 + 0.5 * libm::cosf((az - 120.0 * m as f32).to_radians());
                assert!((v - want).abs() < 1e-5, "az {az} m {m}: {v} vs {want}");
            }
        }
        assert_eq!(
            active_features(Complex32::new(0.0, 0.0), 0.0, [Complex32::new(1.0, 0.0); 3]),
            None
        );
        let nan = Complex32::new(f32::NAN, 0.0);
        assert_eq!(
            active_features(nan, nan.norm_sqr(), [Complex32::new(1.0, 0.0); 3]),
            None
        );
        assert_eq!(
            active_features(Complex32::new(1.0, 0.0), 1.0, [nan; 3]),
            None
        );
    }

    /// Direct sound at 40° and a reflection at 200° (0.6 of its amplitude): averaged over the
    /// reflection's phase, the active ratio is the direct sound's feature (the mean-value property),
    /// the magnitude ratio is pulled toward the reflection.
    #[test]
    fn reflection_averages_out_of_the_active_ratio_only() {
        let n = 360;
        let (mut act, mut mag) = ([0.0f64; 3], [0.0f64; 3]);
        for k in 0..n {
            let ph = 2.0 * core::f32::consts::PI * k as f32 / n as f32;
            let r = Complex32::new(0.6 * libm::cosf(ph), 0.6 * libm::sinf(ph));
            let (o, c) = spectra(&[(40.0, Complex32::new(1.0, 0.0)), (200.0, r)]);
            let a = active_features(o, o.norm_sqr(), c).unwrap();
            let p = c.map(|x| x.norm_sqr());
            let m = feature_from_powers(o.norm_sqr(), p).unwrap();
            for i in 0..3 {
                act[i] += f64::from(a[i]) / n as f64;
                mag[i] += f64::from(m[i]) / n as f64;
            }
        }
        let mut worst_mag = 0.0f64;
        for (m, (a, g)) in act.iter().zip(&mag).enumerate() {
            let want = 0.5 + 0.5 * libm::cos((40.0 - 120.0 * m as f64).to_radians());
            assert!((a - want).abs() < 1e-4, "active m {m}: {a} vs {want}");
            worst_mag = worst_mag.max((g - want).abs());
        }
        assert!(
            worst_mag > 0.02,
            "magnitude ratio unexpectedly unbiased: {worst_mag}"
        );
    }

    #[test]
    fn ratio_of_magnitudes() {
        let y = feature_from_powers(4.0, [4.0, 0.25, 1.0]).unwrap();
        assert_eq!(y, [1.0, 0.25, 0.5]);
        assert_eq!(feature_from_powers(0.0, [1.0; 3]), None);
        assert_eq!(feature_from_powers(f32::NAN, [1.0; 3]), None);
    }
}
