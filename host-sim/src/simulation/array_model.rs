//! Capsule imperfections of a simulated CMA1 array, for `host-sim scene` and calibration experiments.
//!
//! From the horizontal B-format signals W, X, Y of the sound field, cardioid m (look φ_m) is rendered as
//!
//! c_m = g_m·(W + β_m·(D_m − W) − Δβ·LP{D_m − W}),  D_m = X cos φ_m + Y sin φ_m,
//!
//! i.e. a first-order pattern (1 − β)·W + β·D_m with gain g_m (from dB) and an optional
//! frequency-dependent β(f) = β_m − Δβ·L(f), where L is a one-pole low-pass with corner f_c
//! (L(0) = 1, L(∞) = 0): Δβ > 0 makes the pattern more omni at low frequencies, Δβ < 0 narrower
//! (a proximity-effect-like bass lift of the gradient part). The omni is W (gain 1, the reference).
//!
//! The ideal model (all g = 1, β = ½, Δβ = 0) renders with exactly the arithmetic the scene simulator
//! always used, ½W + ½(X cos φ_m + Y sin φ_m), so ideal scenes stay bit-identical.

use crate::error::{Result, SimError};
use crate::simulation::signal::Rng;
use cma_core::capsule_calibration::{BandModel, CapsuleEstimate, CAL_BANDS};
use cma_core::{CARDIOIDS, CARDIOID_LOOK_DEG};
use std::f64::consts::PI;

/// Mixed into the scene seed for the capsules' own noise, so that it is independent of the
/// diffuse noise drawn from the seed itself.
const SELF_NOISE_SEED: u64 = 0x5e1f_401e_c0de_0001;

/// Capsule model of the three cardioids.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArrayModel {
    /// Gain of each cardioid, dB.
    pub gains_db: [f64; CARDIOIDS],
    /// Pattern parameter β of each cardioid (0 omni, ½ cardioid, 1 figure-8).
    pub betas: [f64; CARDIOIDS],
    /// Low-frequency change of β, Δβ (0 = frequency-independent).
    pub beta_drift: f64,
    /// Corner frequency of the drift's low-pass, Hz.
    pub drift_corner_hz: f64,
    /// The capsules' own noise: white, independent and of equal power in the four capsules, this
    /// many dB relative to the scene's diffuse noise on the omni (to the talker's power in a scene
    /// without diffuse noise); `None`: noiseless capsules.
    pub self_noise_db: Option<f64>,
}

impl Default for ArrayModel {
    fn default() -> Self {
        Self::ideal()
    }
}

impl ArrayModel {
    /// Ideal CMA1: unit gains, β = ½, no drift.
    #[must_use]
    pub const fn ideal() -> Self {
        Self {
            gains_db: [0.0; CARDIOIDS],
            betas: [0.5; CARDIOIDS],
            beta_drift: 0.0,
            drift_corner_hz: 500.0,
            self_noise_db: None,
        }
    }

    /// True for the ideal model (renders with the original arithmetic; the capsules' own noise,
    /// added apart by [`ArrayModel::add_self_noise`], does not count).
    #[must_use]
    pub fn is_ideal(&self) -> bool {
        self.gains_db == [0.0; CARDIOIDS]
            && self.betas == [0.5; CARDIOIDS]
            && self.beta_drift == 0.0
    }

    /// These capsules in the self-calibration's model X_m = a_m·W + b_m·D_m: from the rendering
    /// c_m = g_m·((1 − β_m)·W + β_m·D_m), the omni part a_m = g_m·(1 − β_m) and the dipole part
    /// b_m = g_m·β_m, the same in every band, with `peaks` as each band's count of background peaks.
    /// `None` for a frequency-dependent pattern (Δβ ≠ 0), which no constant per band describes.
    #[must_use]
    pub fn capsule_estimate(&self, peaks: f32) -> Option<CapsuleEstimate> {
        if self.beta_drift != 0.0 {
            return None;
        }
        let mut band = BandModel {
            peaks,
            ..BandModel::IDEAL
        };
        for m in 0..CARDIOIDS {
            let g = 10f64.powf(self.gains_db[m] / 20.0);
            band.omni_part[m] = (g * (1.0 - self.betas[m])) as f32;
            band.dipole_part[m] = (g * self.betas[m]) as f32;
        }
        Some(CapsuleEstimate {
            bands: [band; CAL_BANDS],
            // The bands hold the whole error: nothing for the talker to add.
            ..CapsuleEstimate::IDEAL
        })
    }

    /// Checks ranges: |gain| ≤ 20 dB, 0 ≤ β ≤ 1, |Δβ| ≤ 1, corner > 0, self-noise within ±60 dB;
    /// the error names the `host-sim scene` flag and its value.
    pub fn validate(&self) -> Result<()> {
        let list = |v: &[f64]| {
            v.iter()
                .map(|x| x.to_string())
                .collect::<Vec<_>>()
                .join(",")
        };
        let bad = if !self.gains_db.iter().all(|g| g.abs() <= 20.0) {
            Some((
                "--capsule-gain-db",
                list(&self.gains_db),
                "each within ±20 dB",
            ))
        } else if !self.betas.iter().all(|b| (0.0..=1.0).contains(b)) {
            Some((
                "--capsule-beta",
                list(&self.betas),
                "each 0 (omni) to 1 (figure-8)",
            ))
        } else if !(self.beta_drift.abs() <= 1.0) {
            Some(("--beta-drift", self.beta_drift.to_string(), "within ±1"))
        } else if !(self.drift_corner_hz > 0.0 && self.drift_corner_hz.is_finite()) {
            Some((
                "--drift-corner",
                self.drift_corner_hz.to_string(),
                "a frequency above 0 Hz",
            ))
        } else if !self.self_noise_db.is_none_or(|d| d.abs() <= 60.0) {
            let d = self.self_noise_db.unwrap_or_default();
            Some(("--self-noise", d.to_string(), "within ±60 dB"))
        } else {
            None
        };
        match bad {
            None => Ok(()),
            Some((flag, value, need)) => Err(SimError::Usage(format!(
                "{flag}: expected {need}, got {value}"
            ))),
        }
    }

    /// Adds the capsules' own noise ([`ArrayModel::self_noise_db`] relative to `reference_power`,
    /// the diffuse noise's or the talker's power on the omni) to the four signals of `frames`, from
    /// its own generator seeded by `seed` (the scene's other signals do not change with it).
    pub fn add_self_noise(&self, frames: &mut [[f64; 4]], reference_power: f64, seed: u64) {
        let Some(db) = self.self_noise_db else {
            return;
        };
        let sd = (reference_power * 10f64.powf(db / 10.0)).sqrt();
        let mut rng = Rng::new(seed ^ SELF_NOISE_SEED);
        for f in frames.iter_mut() {
            for v in f.iter_mut() {
                *v += sd * rng.gaussian();
            }
        }
    }

    /// Renders the four capsule signals (omni, cardioids 0°, 120°, 240°) from W, X, Y (equal lengths)
    /// at `rate`.
    #[must_use]
    pub fn render(&self, w: &[f64], x: &[f64], y: &[f64], rate: u32) -> Vec<[f64; 4]> {
        let n = w.len().min(x.len()).min(y.len());
        if self.is_ideal() {
            return (0..n)
                .map(|i| {
                    let mut f = [w[i], 0.0, 0.0, 0.0];
                    for (m, look) in CARDIOID_LOOK_DEG.iter().enumerate() {
                        let a = (*look as f64).to_radians();
                        f[m + 1] = 0.5 * w[i] + 0.5 * (x[i] * a.cos() + y[i] * a.sin());
                    }
                    f
                })
                .collect();
        }
        let mut out: Vec<[f64; 4]> = (0..n).map(|i| [w[i], 0.0, 0.0, 0.0]).collect();
        let alpha = 1.0 - (-2.0 * PI * self.drift_corner_hz / f64::from(rate)).exp();
        for (m, look) in CARDIOID_LOOK_DEG.iter().enumerate() {
            let a = (*look as f64).to_radians();
            let (c, s) = (a.cos(), a.sin());
            let g = 10f64.powf(self.gains_db[m] / 20.0);
            let beta = self.betas[m];
            let mut lp = 0.0;
            for (i, o) in out.iter_mut().enumerate() {
                let diff = x[i] * c + y[i] * s - w[i];
                lp += alpha * (diff - lp);
                o[m + 1] = g * (w[i] + beta * diff - self.beta_drift * lp);
            }
        }
        out
    }
}

/// `host-sim scene` flags of the capsule model.
#[derive(Debug, Clone, clap::Args)]
pub struct ArrayArgs {
    /// Cardioid gains in dB, three comma-separated values (e.g. `1,-1,0.5`); default ideal.
    #[arg(long, allow_hyphen_values = true, value_delimiter = ',')]
    pub capsule_gain_db: Option<Vec<f64>>,
    /// Cardioid pattern β per capsule, three values (0 omni, 0.5 cardioid, 1 figure-8).
    #[arg(long, value_delimiter = ',')]
    pub capsule_beta: Option<Vec<f64>>,
    /// Frequency-dependent pattern: β is lowered by this much at low frequencies (negative: raised).
    #[arg(long, allow_hyphen_values = true, default_value_t = 0.0)]
    pub beta_drift: f64,
    /// Corner frequency of --beta-drift, Hz.
    #[arg(long, default_value_t = 500.0)]
    pub drift_corner: f64,
    /// The capsules' own noise (white, independent, equal in the four capsules), dB relative to
    /// the diffuse noise on the omni (`--snr`), or to the talker without it; e.g. `-15`.
    #[arg(long, allow_hyphen_values = true, value_parser = crate::flags::arg_values::decibels)]
    pub self_noise: Option<f64>,
}

impl ArrayArgs {
    /// The model these flags describe.
    pub fn model(&self) -> Result<ArrayModel> {
        let three = |v: &Option<Vec<f64>>, default: f64, name: &str| -> Result<[f64; 3]> {
            match v {
                None => Ok([default; 3]),
                Some(v) => <[f64; 3]>::try_from(v.as_slice()).map_err(|_| {
                    SimError::Usage(format!("--{name}: expected 3 values, got {}", v.len()))
                }),
            }
        };
        let m = ArrayModel {
            gains_db: three(&self.capsule_gain_db, 0.0, "capsule-gain-db")?,
            betas: three(&self.capsule_beta, 0.5, "capsule-beta")?,
            beta_drift: self.beta_drift,
            drift_corner_hz: self.drift_corner,
            self_noise_db: self.self_noise,
        };
        m.validate()?;
        Ok(m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn imperfect_capsule_has_the_modelled_gain_and_pattern() {
        let m = ArrayModel {
            gains_db: [6.0, 0.0, 0.0],
            betas: [0.3, 0.5, 0.5],
            beta_drift: 0.0,
            drift_corner_hz: 500.0,
            self_noise_db: None,
        };
        // Plane wave from 180°: D_0 = −W, cardioid 0 = g·(1 − 2β)·W.
        let w = vec![1.0; 4];
        let x = vec![-1.0; 4];
        let y = vec![0.0; 4];
        let out = m.render(&w, &x, &y, 16_000);
        let want = 10f64.powf(0.3) * (1.0 - 2.0 * 0.3);
        assert!((out[0][1] - want).abs() < 1e-12);
        assert_eq!(out[0][0], 1.0);
        assert!(ArrayModel::ideal().is_ideal() && !m.is_ideal());
    }

    #[test]
    fn self_noise_has_its_level_and_is_independent_in_each_capsule() {
        let mut frames = vec![[0.0; 4]; 40_000];
        ArrayModel::ideal().add_self_noise(&mut frames, 2.0, 7);
        assert!(frames.iter().all(|f| *f == [0.0; 4]));
        let m = ArrayModel {
            self_noise_db: Some(-10.0),
            ..ArrayModel::ideal()
        };
        m.add_self_noise(&mut frames, 2.0, 7);
        let n = frames.len() as f64;
        for c in 0..4 {
            let p = frames.iter().map(|f| f[c] * f[c]).sum::<f64>() / n;
            assert!((p - 0.2).abs() < 0.01, "capsule {c}: {p}");
            for d in c + 1..4 {
                let r = frames.iter().map(|f| f[c] * f[d]).sum::<f64>() / n;
                assert!(r.abs() < 0.01, "capsules {c}, {d}: {r}");
            }
        }
    }

    /// The self-calibration's model of the capsules renders the same signals: a_m·W + b_m·D_m.
    #[test]
    fn capsule_estimate_is_the_rendered_model() {
        let m = ArrayModel {
            gains_db: [1.0, -1.0, 0.5],
            betas: [0.45, 0.55, 0.5],
            ..ArrayModel::ideal()
        };
        let est = m.capsule_estimate(100.0).unwrap();
        let (w, x, y) = ([0.7, -0.2], [0.3, 0.9], [-0.4, 0.1]);
        let out = m.render(&w, &x, &y, 16_000);
        for band in &est.bands {
            assert_eq!(band.peaks, 100.0);
            for (c, look) in CARDIOID_LOOK_DEG.iter().enumerate() {
                let a = f64::from(*look).to_radians();
                for i in 0..2 {
                    let d = x[i] * a.cos() + y[i] * a.sin();
                    let want =
                        f64::from(band.omni_part[c]) * w[i] + f64::from(band.dipole_part[c]) * d;
                    assert!((out[i][c + 1] - want).abs() < 1e-6, "cardioid {c}");
                }
            }
        }
        assert_eq!(
            ArrayModel::ideal().capsule_estimate(0.0).unwrap(),
            CapsuleEstimate::IDEAL
        );
        let drifting = ArrayModel {
            beta_drift: 0.1,
            ..m
        };
        assert_eq!(drifting.capsule_estimate(0.0), None);
    }

    #[test]
    fn drift_changes_the_pattern_at_low_frequencies_only() {
        let m = ArrayModel {
            beta_drift: 0.2,
            drift_corner_hz: 200.0,
            ..ArrayModel::ideal()
        };
        // DC plane wave from 180°: after settling, β = 0.3 → cardioid 0 = 1 − 2·0.3 = 0.4.
        let n = 4000;
        let out = m.render(&vec![1.0; n], &vec![-1.0; n], &vec![0.0; n], 16_000);
        assert!((out[n - 1][1] - 0.4).abs() < 1e-6);
        // A 4 kHz tone sees almost β = ½ (null at the back).
        let tone: Vec<f64> = (0..n)
            .map(|i| (2.0 * PI * 4000.0 * i as f64 / 16_000.0).sin())
            .collect();
        let neg: Vec<f64> = tone.iter().map(|v| -v).collect();
        let out = m.render(&tone, &neg, &vec![0.0; n], 16_000);
        let rms = (out[n / 2..].iter().map(|f| f[1] * f[1]).sum::<f64>() / (n / 2) as f64).sqrt();
        assert!(rms < 0.02 * std::f64::consts::FRAC_1_SQRT_2 * 2.0, "{rms}");
    }
}
