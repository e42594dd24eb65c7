//! `host-sim calibrate --selfcal-in`: a reference table computed from a self-calibration estimate
//! (a `locate --selfcal-out` file) instead of measured from sweeps, to freeze what the blind
//! self-calibration learned into a table (for `--table`, or for the firmware through `CMA_TABLE`).
//!
//! Each frequency row takes the capsule model X_m = a_m·W + b_m·D_m of the self-calibration band it
//! falls in ([`band_of_frequency`]: an edge belongs to the band above it, as for the spectrum bins).
//! A horizontal plane wave from azimuth θ has D_m = cos(θ − φ_m)·W, so
//!
//! * active feature Re(X_m/W) = a_m + b_m·cos(θ − φ_m), magnitude feature |X_m|/|W| = its absolute value.
//!
//! The omni-noise rows describe a 3-D isotropic diffuse field (D_m uncorrelated with W,
//! E|D_m|² = κ·E|W|², κ = [`KAPPA`] = ⅓), with the definitions of the sweep calibration
//! ([`crate::calibration::measured_table`]) and of the core's ideal table:
//!
//! * active: Re E[X_m·W*]/E|W|² = a_m;
//! * magnitude: the mean gain |E X_m|/|E W| over the field's directions (the dipole part averages
//!   out), |a_m|;
//! * power: √(E|X_m|²/E|W|²) = √(a_m² + κ·b_m²) (the square root is stored).
//!
//! For the ideal estimate (a = b = ½) these are ½ + ½·cos(θ − φ_m), ½, ½ and √⅓: the core's ideal
//! table in every row. A sweep calibration measures a *horizontal* field instead, whose power row
//! is √(a² + ½b²); the other rows agree.

use crate::error::Result;
use crate::io::table_io::OwnedTable;
use cma_core::capsule_calibration::{band_of_frequency, CapsuleEstimate, KAPPA};
use cma_core::reference_table::Feature;
use cma_core::{CARDIOIDS, CARDIOID_LOOK_DEG};

/// The reference table of the capsule model `est` with frequency rows `freqs_hz` (Hz, ascending) and
/// azimuths `azimuths_deg` (ascending in [0, 360)), checked as the core checks a loaded table. Its
/// rate is 0 (unknown: no recording behind it).
pub fn table_from_estimate(
    est: &CapsuleEstimate,
    freqs_hz: &[f64],
    azimuths_deg: &[f32],
) -> Result<OwnedTable> {
    let kappa = f64::from(KAPPA);
    let looks = CARDIOID_LOOK_DEG.map(|l| f64::from(l).to_radians());
    let q = azimuths_deg.len();
    let mut t = OwnedTable {
        azimuths_deg: azimuths_deg.to_vec(),
        freqs_hz: freqs_hz.iter().map(|f| *f as f32).collect(),
        features: Vec::with_capacity(freqs_hz.len() * q),
        noise_magnitude: Vec::with_capacity(freqs_hz.len()),
        noise_power: Vec::with_capacity(freqs_hz.len()),
        active: Vec::with_capacity(freqs_hz.len() * q),
        noise_active: Vec::with_capacity(freqs_hz.len()),
        rate_hz: 0,
    };
    for f in &t.freqs_hz {
        let model = &est.bands[band_of_frequency(*f)];
        let a = model.omni_part.map(f64::from);
        let b = model.dipole_part.map(f64::from);
        for az in azimuths_deg {
            let theta = f64::from(*az).to_radians();
            let mut active: Feature = [0.0; CARDIOIDS];
            for m in 0..CARDIOIDS {
                active[m] = (a[m] + b[m] * (theta - looks[m]).cos()) as f32;
            }
            t.active.push(active);
            t.features.push(active.map(f32::abs));
        }
        t.noise_active.push(a.map(|v| v as f32));
        t.noise_magnitude.push(a.map(|v| v.abs() as f32));
        t.noise_power
            .push([0, 1, 2].map(|m| (a[m] * a[m] + kappa * b[m] * b[m]).sqrt() as f32));
    }
    t.as_table()?;
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::measured_table::{freq_rows, CalibrationOptions};
    use cma_core::capsule_calibration::{BandModel, CAL_BANDS};
    use cma_core::features::FeatureKind;
    use cma_core::ReferenceTable;

    /// The default frequency rows of `calibrate`.
    fn default_rows() -> Vec<f64> {
        let o = CalibrationOptions::default();
        freq_rows(o.freq_lo_hz, o.freq_hi_hz, o.freq_step_hz).unwrap()
    }

    /// The ideal estimate gives the core's ideal table in every frequency row: features of both kinds
    /// and all three noise rows, within 1e-6.
    #[test]
    fn the_ideal_estimate_gives_the_ideal_table() {
        for ideal in [ReferenceTable::ideal_5deg(), ReferenceTable::ideal_15deg()] {
            let rows = default_rows();
            let owned =
                table_from_estimate(&CapsuleEstimate::IDEAL, &rows, ideal.azimuths_deg()).unwrap();
            let t = owned.as_table().unwrap();
            assert_eq!(t.num_freqs(), 42);
            assert_eq!(t.azimuths_deg(), ideal.azimuths_deg());
            let mut worst = 0.0f32;
            let mut diff = |x: Feature, y: Feature| {
                for (p, q) in x.iter().zip(&y) {
                    worst = worst.max((p - q).abs());
                }
            };
            for fi in 0..t.num_freqs() {
                for kind in [FeatureKind::Magnitude, FeatureKind::Active] {
                    let (got, want) = (t.rows(kind), ideal.rows(kind));
                    for (x, y) in got.row(fi).iter().zip(want.row(0)) {
                        diff(*x, *y);
                    }
                    diff(got.noise(fi), want.noise(0));
                }
                diff(t.noise_magnitude(fi), ideal.noise_magnitude(0));
                diff(t.noise_power(fi), ideal.noise_power(0));
                diff(t.noise_active(fi), ideal.noise_active(0));
            }
            assert!(worst < 1e-6, "largest difference {worst}");
        }
    }

    /// Each row takes its band's model (edges belong to the band above), with the plane-wave
    /// features and the 3-D diffuse noise rows of that model.
    #[test]
    fn each_row_takes_its_bands_model() {
        let mut est = CapsuleEstimate::IDEAL;
        for (i, band) in est.bands.iter_mut().enumerate() {
            let d = 0.04 * i as f32;
            *band = BandModel {
                omni_part: [0.45 + d, 0.5, 0.55 - d],
                dipole_part: [0.6 - d, 0.4 + d, 0.5],
                peaks: 1e4,
            };
        }
        let rows = [250.0, 499.0, 500.0, 1500.0, 2000.0, 6000.0];
        let az = [0.0, 90.0, 180.0, 300.0];
        let t = table_from_estimate(&est, &rows, &az).unwrap();
        let bands = [0, 0, 1, 2, 3, 3];
        assert_eq!(t.rate_hz, 0);
        for (fi, band) in bands.iter().enumerate() {
            let BandModel {
                omni_part: a,
                dipole_part: b,
                ..
            } = est.bands[*band];
            for (qi, az) in az.iter().enumerate() {
                for m in 0..CARDIOIDS {
                    let rel = (f64::from(*az) - 120.0 * m as f64).to_radians();
                    let want = f64::from(a[m]) + f64::from(b[m]) * rel.cos();
                    let active = f64::from(t.active[fi * 4 + qi][m]);
                    assert!((active - want).abs() < 1e-6, "row {fi} az {az} m {m}");
                    assert_eq!(t.features[fi * 4 + qi][m], t.active[fi * 4 + qi][m].abs());
                }
            }
            for m in 0..CARDIOIDS {
                assert_eq!(t.noise_active[fi][m], a[m]);
                assert_eq!(t.noise_magnitude[fi][m], a[m]);
                let p = (a[m] * a[m] + b[m] * b[m] / 3.0).sqrt();
                assert!((t.noise_power[fi][m] - p).abs() < 1e-6);
            }
        }
        // β > ½ behind the capsule: a negative active feature, a positive magnitude.
        let back = t.active[2][0];
        assert!(back < 0.0 && t.features[2][0] == -back, "{back}");
        // Axes the core refuses are errors, not panics.
        assert!(table_from_estimate(&est, &rows, &[0.0, 90.0]).is_err());
        assert!(table_from_estimate(&est, &[], &az).is_err());
        let mut nan = est;
        nan.bands[CAL_BANDS - 1].omni_part[1] = f32::NAN;
        assert!(table_from_estimate(&nan, &rows, &az).is_err());
    }
}
