//! Small std signal tools for the scene simulator: a deterministic PRNG, pink noise, band-limited
//! resampling and FFT convolution.

use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;

/// Deterministic PRNG (SplitMix64) with uniform and Gaussian draws, so scenes are reproducible.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    /// A generator from a seed.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Self(seed ^ 0x9E37_79B9_7F4A_7C15)
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal (Box–Muller).
    pub fn gaussian(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

/// `n` samples of pink (1/f) Gaussian noise with unit variance (Paul Kellet's refined filter).
#[must_use]
pub fn pink_noise(rng: &mut Rng, n: usize) -> Vec<f64> {
    let mut b = [0.0f64; 7];
    let mut out: Vec<f64> = (0..n)
        .map(|_| {
            let w = rng.gaussian();
            b[0] = 0.99886 * b[0] + w * 0.0555179;
            b[1] = 0.99332 * b[1] + w * 0.0750759;
            b[2] = 0.96900 * b[2] + w * 0.1538520;
            b[3] = 0.86650 * b[3] + w * 0.3104856;
            b[4] = 0.55000 * b[4] + w * 0.5329522;
            b[5] = -0.7616 * b[5] - w * 0.0168980;
            let y = b[0] + b[1] + b[2] + b[3] + b[4] + b[5] + b[6] + w * 0.5362;
            b[6] = w * 0.115926;
            y
        })
        .collect();
    normalize_rms(&mut out);
    out
}

/// Scales `x` to unit RMS (no-op for silence).
pub fn normalize_rms(x: &mut [f64]) {
    let p = x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64;
    if p > 0.0 {
        let g = 1.0 / p.sqrt();
        x.iter_mut().for_each(|v| *v *= g);
    }
}

/// Band-limited resampling by windowed-sinc interpolation (32 zero crossings, Blackman window).
#[must_use]
pub fn resample(x: &[f64], from: u32, to: u32) -> Vec<f64> {
    if from == to {
        return x.to_vec();
    }
    let ratio = to as f64 / from as f64;
    let cutoff = ratio.min(1.0) * 0.95;
    let half = 32.0 / cutoff;
    let n_out = (x.len() as f64 * ratio).round() as usize;
    (0..n_out)
        .map(|j| {
            let t = j as f64 / ratio;
            let lo = (t - half).ceil().max(0.0) as usize;
            let hi = ((t + half).floor() as usize).min(x.len().saturating_sub(1));
            let mut acc = 0.0;
            for (i, xi) in x.iter().enumerate().take(hi + 1).skip(lo) {
                let d = i as f64 - t;
                let arg = std::f64::consts::PI * d * cutoff;
                let sinc = if d.abs() < 1e-12 {
                    1.0
                } else {
                    arg.sin() / arg
                };
                let w = 0.42
                    + 0.5 * (std::f64::consts::PI * d / half).cos()
                    + 0.08 * (2.0 * std::f64::consts::PI * d / half).cos();
                acc += xi * sinc * w * cutoff;
            }
            acc
        })
        .collect()
}

/// Linear convolution of `x` with `h` by FFT; output length `x.len() + h.len() − 1`.
#[must_use]
pub fn convolve(x: &[f64], h: &[f64]) -> Vec<f64> {
    if x.is_empty() || h.is_empty() {
        return Vec::new();
    }
    let c = SegmentConvolver::new(x.len(), h.len());
    c.convolve(&c.spectrum(x), &c.spectrum(h), x.len() + h.len() - 1)
}

/// Convolution of many short segments with a few fixed responses (a moving source rendered in
/// short pieces): one FFT size and plan for all of them, each response's and each segment's
/// spectrum computed once ([`SegmentConvolver::spectrum`]), so a piece through k responses costs
/// one forward and k inverse transforms ([`SegmentConvolver::convolve`]).
pub struct SegmentConvolver {
    n: usize,
    fwd: std::sync::Arc<dyn rustfft::Fft<f64>>,
    inv: std::sync::Arc<dyn rustfft::Fft<f64>>,
}

impl SegmentConvolver {
    /// A convolver for segments of up to `segment_len` samples and responses of up to
    /// `response_len` samples.
    #[must_use]
    pub fn new(segment_len: usize, response_len: usize) -> Self {
        let n = (segment_len + response_len)
            .saturating_sub(1)
            .max(1)
            .next_power_of_two();
        // One planner per thread: it keeps its plans, so convolutions of one size share twiddles.
        thread_local! {
            static PLANNER: std::cell::RefCell<FftPlanner<f64>> =
                std::cell::RefCell::new(FftPlanner::new());
        }
        let (fwd, inv) = PLANNER.with(|p| {
            let mut p = p.borrow_mut();
            (p.plan_fft_forward(n), p.plan_fft_inverse(n))
        });
        Self { n, fwd, inv }
    }

    /// The zero-padded spectrum of `x` (a response or a segment; at most the lengths given to
    /// [`SegmentConvolver::new`]).
    #[must_use]
    pub fn spectrum(&self, x: &[f64]) -> Vec<Complex64> {
        debug_assert!(
            x.len() <= self.n,
            "a segment or response longer than the FFT"
        );
        let mut b: Vec<Complex64> = x.iter().map(|r| Complex64::new(*r, 0.0)).collect();
        b.resize(self.n, Complex64::new(0.0, 0.0));
        self.fwd.process(&mut b);
        b
    }

    /// The convolution of a segment (its spectrum) with a response (its spectrum), the first
    /// `len` samples (at most the FFT size; `segment + response − 1` gives the whole of it).
    #[must_use]
    pub fn convolve(&self, segment: &[Complex64], response: &[Complex64], len: usize) -> Vec<f64> {
        let mut a: Vec<Complex64> = segment.iter().zip(response).map(|(p, q)| p * q).collect();
        self.inv.process(&mut a);
        let scale = 1.0 / self.n as f64;
        a.iter().take(len).map(|c| c.re * scale).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_convolver_matches_direct() {
        let mut rng = Rng::new(3);
        let h: Vec<f64> = (0..300).map(|_| rng.gaussian()).collect();
        let seg: Vec<f64> = (0..80).map(|_| rng.gaussian()).collect();
        let c = SegmentConvolver::new(80, 300);
        let h_spectrum = c.spectrum(&h);
        let y = c.convolve(&c.spectrum(&seg), &h_spectrum, 80 + 300 - 1);
        let want: Vec<f64> = (0..80 + 300 - 1)
            .map(|k| {
                (0..80)
                    .filter(|i| k >= *i && k - i < 300)
                    .map(|i| seg[i] * h[k - i])
                    .sum()
            })
            .collect();
        assert_eq!(y.len(), want.len());
        for (a, b) in y.iter().zip(&want) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
    }

    #[test]
    fn convolution_matches_direct() {
        let x = [1.0, 2.0, -1.0, 0.5];
        let h = [0.5, -0.25, 2.0];
        let y = convolve(&x, &h);
        let mut d = [0.0; 6];
        for (i, a) in x.iter().enumerate() {
            for (j, b) in h.iter().enumerate() {
                d[i + j] += a * b;
            }
        }
        for (a, b) in y.iter().zip(d) {
            assert!((a - b).abs() < 1e-12);
        }
    }

    #[test]
    fn resampling_keeps_a_tone() {
        let x: Vec<f64> = (0..16000)
            .map(|n| (2.0 * std::f64::consts::PI * 1000.0 * n as f64 / 16000.0).sin())
            .collect();
        let y = resample(&x, 16000, 48000);
        assert_eq!(y.len(), 48000);
        for n in (1000..47000).step_by(997) {
            let want = (2.0 * std::f64::consts::PI * 1000.0 * n as f64 / 48000.0).sin();
            assert!((y[n] - want).abs() < 2e-3, "n {n}: {} vs {want}", y[n]);
        }
    }

    #[test]
    fn pink_noise_is_unit_rms_and_reproducible() {
        let a = pink_noise(&mut Rng::new(7), 10000);
        let b = pink_noise(&mut Rng::new(7), 10000);
        assert_eq!(a, b);
        let p = a.iter().map(|v| v * v).sum::<f64>() / a.len() as f64;
        assert!((p - 1.0).abs() < 1e-9);
    }
}
