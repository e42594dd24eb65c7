//! Exponential sine sweep (thesis §2.4.2): the excitation of eq. 2.43 and regularised deconvolution of a
//! sweep response into an impulse response (eq. 2.44–2.46).

use crate::error::{Result, SimError};
use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;

/// Parameters of an exponential sine sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepSpec {
    /// Start frequency f₁, Hz.
    pub f1: f64,
    /// Stop frequency f₂, Hz.
    pub f2: f64,
    /// Duration T, s.
    pub seconds: f64,
    /// Sample rate, Hz.
    pub rate: u32,
}

impl Default for SweepSpec {
    /// 50 Hz to 20 kHz in 5 s at 48 kHz.
    fn default() -> Self {
        Self {
            f1: 50.0,
            f2: 20_000.0,
            seconds: 5.0,
            rate: 48_000,
        }
    }
}

impl SweepSpec {
    /// Checks 0 < f₁ < f₂ ≤ rate/2 and 0.1 s ≤ T ≤ 60 s.
    pub fn validate(&self) -> Result<()> {
        let nyq = f64::from(self.rate) / 2.0;
        if !(self.f1 > 0.0 && self.f1 < self.f2 && self.f2 <= nyq) {
            return Err(SimError::Usage(format!(
                "sweep: need 0 < f1 < f2 ≤ rate/2 = {nyq} Hz, got f1 = {} Hz, f2 = {} Hz",
                self.f1, self.f2
            )));
        }
        if !(0.1..=60.0).contains(&self.seconds) {
            return Err(SimError::Usage(format!(
                "sweep: duration must be 0.1–60 s, got {} s",
                self.seconds
            )));
        }
        Ok(())
    }

    /// Number of samples N = T·f_s.
    #[must_use]
    pub fn len(&self) -> usize {
        (self.seconds * f64::from(self.rate)).round() as usize
    }

    /// True if the sweep has no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The sweep of eq. 2.43, s\[n\] = sin(A·(e^{n/(f_s τ)} − 1)) with τ = T / ln(f₂/f₁), A = 2π f₁ τ,
    /// with 10 ms half-Hann fades at both ends so the loudspeaker does not click (the fades only touch
    /// frequencies below f₁·1.01 and near f₂, outside the analysis band of the calibration).
    #[must_use]
    pub fn generate(&self) -> Vec<f64> {
        let fs = f64::from(self.rate);
        let tau = self.seconds / (self.f2 / self.f1).ln();
        let a = 2.0 * PI * self.f1 * tau;
        let n = self.len();
        let fade = ((0.01 * fs) as usize).min(n / 4).max(1);
        (0..n)
            .map(|i| {
                let v = (a * ((i as f64 / (fs * tau)).exp() - 1.0)).sin();
                let edge = i.min(n - 1 - i);
                let g = if edge < fade {
                    0.5 - 0.5 * (PI * edge as f64 / fade as f64).cos()
                } else {
                    1.0
                };
                v * g
            })
            .collect()
    }
}

/// Deconvolves sweep responses with one excitation (eq. 2.44–2.46), regularised:
/// Ĥ\[k\] = X\[k\]·S*\[k\] / (|S\[k\]|² + λ\[k\]) with λ = ε·max|S|², ε = 10⁻⁴ inside [f₁, f₂] and ε = 1 outside,
/// so bins the sweep does not excite are suppressed rather than amplified (plain eq. 2.44 divides by
/// almost nothing there).
pub struct Deconvolver {
    n: usize,
    sweep_len: usize,
    inverse: Vec<Complex64>,
    fwd: std::sync::Arc<dyn rustfft::Fft<f64>>,
    inv: std::sync::Arc<dyn rustfft::Fft<f64>>,
}

impl std::fmt::Debug for Deconvolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Deconvolver")
            .field("n", &self.n)
            .field("sweep_len", &self.sweep_len)
            .finish_non_exhaustive()
    }
}

impl Deconvolver {
    /// Prepares the regularised inverse of `sweep` for responses of up to `max_response_len` samples
    /// (the FFT length N_x of eq. 2.46, rounded up to a power of two).
    #[must_use]
    pub fn new(sweep: &[f64], band_hz: (f64, f64), rate: u32, max_response_len: usize) -> Self {
        let n = max_response_len.max(sweep.len()).max(2).next_power_of_two();
        let mut planner = FftPlanner::<f64>::new();
        let fwd = planner.plan_fft_forward(n);
        let inv = planner.plan_fft_inverse(n);
        let mut s: Vec<Complex64> = sweep.iter().map(|v| Complex64::new(*v, 0.0)).collect();
        s.resize(n, Complex64::new(0.0, 0.0));
        fwd.process(&mut s);
        let peak = s.iter().map(|c| c.norm_sqr()).fold(0.0f64, f64::max);
        let df = f64::from(rate) / n as f64;
        let inverse = s
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let f = k.min(n - k) as f64 * df;
                let eps = if f >= band_hz.0 && f <= band_hz.1 {
                    1e-4
                } else {
                    1.0
                };
                c.conj() / (c.norm_sqr() + eps * peak).max(f64::MIN_POSITIVE)
            })
            .collect();
        Self {
            n,
            sweep_len: sweep.len(),
            inverse,
            fwd,
            inv,
        }
    }

    /// Length of the sweep this deconvolver inverts.
    #[must_use]
    pub fn sweep_len(&self) -> usize {
        self.sweep_len
    }

    /// Longest response it accepts.
    #[must_use]
    pub fn max_response_len(&self) -> usize {
        self.n
    }

    /// The impulse response of one sweep response (`response.len()` ≤ [`Self::max_response_len`]);
    /// N samples long, causal part first, anything the deconvolution puts before t = 0 (loudspeaker
    /// harmonics) wrapped to the end.
    #[must_use]
    pub fn process(&self, response: &[f64]) -> Vec<f64> {
        let mut x: Vec<Complex64> = response
            .iter()
            .take(self.n)
            .map(|v| Complex64::new(*v, 0.0))
            .collect();
        x.resize(self.n, Complex64::new(0.0, 0.0));
        self.fwd.process(&mut x);
        for (a, b) in x.iter_mut().zip(&self.inverse) {
            *a *= b;
        }
        self.inv.process(&mut x);
        x.iter().map(|c| c.re / self.n as f64).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::signal::convolve;

    #[test]
    fn sweep_follows_eq_2_43() {
        let s = SweepSpec {
            f1: 100.0,
            f2: 4000.0,
            seconds: 1.0,
            rate: 16_000,
        };
        let x = s.generate();
        assert_eq!(x.len(), 16_000);
        // Instantaneous frequency f(t) = f1·e^{t/τ}: count zero crossings in 50 ms around t = 0.5 s.
        let fmid = 100.0 * (4000.0f64 / 100.0).sqrt();
        let seg = &x[7600..8400];
        let zc = seg.windows(2).filter(|w| w[0] * w[1] < 0.0).count() as f64;
        let f_est = zc / 2.0 / 0.05;
        assert!((f_est - fmid).abs() < 0.05 * fmid, "{f_est} vs {fmid}");
        assert!(x.iter().all(|v| v.abs() <= 1.0));
        assert!(s.validate().is_ok());
        assert!(SweepSpec { f2: 9000.0, ..s }.validate().is_err());
        assert!(SweepSpec { seconds: 0.0, ..s }.validate().is_err());
    }

    #[test]
    fn deconvolution_recovers_a_known_impulse_response() {
        let spec = SweepSpec {
            f1: 20.0,
            f2: 8000.0,
            seconds: 1.0,
            rate: 16_000,
        };
        let s = spec.generate();
        // A delayed, band-limited system: direct 1.0 at 40, -0.5 at 57, 0.25 at 130.
        let mut h = vec![0.0; 200];
        h[40] = 1.0;
        h[57] = -0.5;
        h[130] = 0.25;
        let x = convolve(&s, &h);
        let d = Deconvolver::new(&s, (spec.f1, spec.f2), spec.rate, x.len());
        let est = d.process(&x);
        // Compare after smoothing both with a short low-pass (the regularisation band-limits to f1..f2).
        let lp = |v: &[f64]| -> Vec<f64> {
            (0..200usize)
                .map(|i| {
                    (i.saturating_sub(2)..=(i + 2).min(199))
                        .map(|j| v[j])
                        .sum::<f64>()
                        / 5.0
                })
                .collect()
        };
        let (a, b) = (lp(&est[..200]), lp(&h));
        let err: f64 = a.iter().zip(&b).map(|(p, q)| (p - q).powi(2)).sum();
        let energy: f64 = b.iter().map(|q| q * q).sum();
        assert!(err / energy < 1e-2, "relative error {}", err / energy);
        assert!((est[40] - 1.0).abs() < 0.05 && (est[57] + 0.5).abs() < 0.05);
        // Nothing of significance after the response.
        let tail = est[300..d.max_response_len() / 2]
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(tail < 0.01, "tail {tail}");
    }
}
