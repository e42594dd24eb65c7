//! Error metrics of thesis §6.2: bias, MAE, RMSE, standard deviation and accuracy ACC_Δ for Δ = 1…30°.

use serde::Serialize;

/// Largest tolerance of the accuracy curve, degrees.
pub const MAX_TOLERANCE: usize = 30;

/// Metrics over a set of wrapped angular errors (degrees).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Metrics {
    /// Number of frames.
    pub frames: usize,
    /// ACC_Δ in percent for Δ = 1…30° (`acc[Δ − 1]`): frames with |error| ≤ Δ.
    pub acc: Vec<f64>,
    /// Mean absolute error, degrees.
    pub mae: f64,
    /// Root mean square error, degrees.
    pub rmse: f64,
    /// Mean error, degrees.
    pub bias: f64,
    /// Standard deviation of the error, degrees.
    pub std: f64,
}

impl Metrics {
    /// Metrics of `errors` (already wrapped to (−180, 180]).
    #[must_use]
    pub fn from_errors(errors: &[f64]) -> Self {
        let n = errors.len();
        if n == 0 {
            return Self {
                frames: 0,
                acc: vec![f64::NAN; MAX_TOLERANCE],
                mae: f64::NAN,
                rmse: f64::NAN,
                bias: f64::NAN,
                std: f64::NAN,
            };
        }
        let nf = n as f64;
        let acc = (1..=MAX_TOLERANCE)
            .map(|d| 100.0 * errors.iter().filter(|e| e.abs() <= d as f64).count() as f64 / nf)
            .collect();
        let bias = errors.iter().sum::<f64>() / nf;
        let var = if n > 1 {
            errors.iter().map(|e| (e - bias).powi(2)).sum::<f64>() / (nf - 1.0)
        } else {
            0.0
        };
        Self {
            frames: n,
            acc,
            mae: errors.iter().map(|e| e.abs()).sum::<f64>() / nf,
            rmse: (errors.iter().map(|e| e * e).sum::<f64>() / nf).sqrt(),
            bias,
            std: var.sqrt(),
        }
    }

    /// ACC_Δ for an integer tolerance Δ in 1…30.
    #[must_use]
    pub fn acc_at(&self, tolerance: usize) -> f64 {
        self.acc[tolerance.clamp(1, MAX_TOLERANCE) - 1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values() {
        let m = Metrics::from_errors(&[1.0, -3.0, 5.0, 30.5]);
        assert_eq!(m.frames, 4);
        assert_eq!(m.acc_at(1), 25.0);
        assert_eq!(m.acc_at(5), 75.0);
        assert_eq!(m.acc_at(30), 75.0);
        assert!((m.mae - 39.5 / 4.0).abs() < 1e-12);
        assert!((m.bias - 33.5 / 4.0).abs() < 1e-12);
        assert!((m.rmse - ((1.0 + 9.0 + 25.0 + 930.25) / 4.0f64).sqrt()).abs() < 1e-12);
        assert_eq!(Metrics::from_errors(&[]).frames, 0);
    }
}
