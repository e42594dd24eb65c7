//! Short-time spectrum (thesis §5.1.1): Hamming window from a table, `microfft` real FFT,
//! the Nyquist bin unpacked.
//!
//! `microfft::real::rfft_512` returns 256 complex bins and packs the (real) Nyquist bin into the
//! imaginary part of bin 0. [`windowed_spectrum`] unpacks it so that `out[0]` is DC (imaginary 0) and
//! `out[256]` is Nyquist; the test below pins this quirk down.

use crate::tables::{HAMMING_512, TWIDDLE_512};
use crate::{FRAME_LEN, NUM_BINS};
use microfft::Complex32;

/// Windows `frame`, transforms it, and writes the [`NUM_BINS`] bins DC…Nyquist to `out`.
/// `scratch` is overwritten.
pub fn windowed_spectrum(
    frame: &[f32; FRAME_LEN],
    scratch: &mut [f32; FRAME_LEN],
    out: &mut [Complex32; NUM_BINS],
) {
    for ((s, x), w) in scratch.iter_mut().zip(frame.iter()).zip(HAMMING_512.iter()) {
        *s = x * w;
    }
    let bins = microfft::real::rfft_512(scratch);
    let nyquist = bins[0].im;
    out[0] = Complex32::new(bins[0].re, 0.0);
    out[1..NUM_BINS - 1].copy_from_slice(&bins[1..]);
    out[NUM_BINS - 1] = Complex32::new(nyquist, 0.0);
}

/// A quarter frame: the length of the folded sequences of [`fold_windowed`].
const QUARTER: usize = FRAME_LEN / 4;

/// Windows `frame` and folds it into four sequences of [`FRAME_LEN`]/4 samples for [`dft_bins3`]:
/// with a, b, c, d the windowed samples n, n + 128, n + 256, n + 384,
/// `out[n] = (a + b + c + d, a − b + c − d)` and `out[128 + n] = (a − c, b − d)` for n < 128
/// (`out[256]` is unused). Bin k of the frame is then a 128-term sum over the sequence of residue k mod 4,
/// because e^{−j2πk·128m/512} = (−j)^{km}.
pub fn fold_windowed(frame: &[f32; FRAME_LEN], out: &mut [Complex32; NUM_BINS]) {
    for n in 0..QUARTER {
        let a = frame[n] * HAMMING_512[n];
        let b = frame[n + QUARTER] * HAMMING_512[n + QUARTER];
        let c = frame[n + 2 * QUARTER] * HAMMING_512[n + 2 * QUARTER];
        let d = frame[n + 3 * QUARTER] * HAMMING_512[n + 3 * QUARTER];
        let (s1, s2) = (a + c, b + d);
        out[n] = Complex32::new(s1 + s2, s1 - s2);
        out[QUARTER + n] = Complex32::new(a - c, b - d);
    }
    out[NUM_BINS - 1] = Complex32::new(0.0, 0.0);
}

/// Σ_n f(n)·(cos, sin)(2πkn/512) over the 128 samples of one real folded sequence, for three channels.
#[inline(always)]
fn real_sums<const IM: bool>(folds: [&[Complex32; NUM_BINS]; 3], k: usize) -> [Complex32; 3] {
    let mut acc = [Complex32::new(0.0, 0.0); 3];
    let mut idx = 0usize;
    for n in 0..QUARTER {
        let [c, s] = TWIDDLE_512[idx];
        idx = (idx + k) & (FRAME_LEN - 1);
        for (a, f) in acc.iter_mut().zip(folds) {
            let v = if IM { f[n].im } else { f[n].re };
            a.re += v * c;
            a.im += v * s;
        }
    }
    acc
}

/// Bin k (1 ≤ k < 256) of the windowed spectrum of three channels, each folded by
/// [`fold_windowed`]: the same value as [`windowed_spectrum`]'s bin k up to rounding (a direct sum
/// of 128 terms with twiddles from a table; see the test for the tolerance). For the similarity
/// method, which needs the cardioids only at the few picked bins.
#[must_use]
pub fn dft_bins3(folds: [&[Complex32; NUM_BINS]; 3], k: usize) -> [Complex32; 3] {
    match k & 3 {
        0 => real_sums::<false>(folds, k).map(|a| Complex32::new(a.re, -a.im)),
        2 => real_sums::<true>(folds, k).map(|a| Complex32::new(a.re, -a.im)),
        r => {
            // F = (a − c) ∓ j(b − d) for k ≡ 1 / 3 (mod 4); with p = a − c, q = b − d and
            // e^{−jθ} = cos θ − j sin θ: sums P_c = Σp·cos, P_s = Σp·sin, Q_c, Q_s.
            let mut pc = [0.0f32; 3];
            let mut ps = [0.0f32; 3];
            let mut qc = [0.0f32; 3];
            let mut qs = [0.0f32; 3];
            let mut idx = 0usize;
            for n in 0..QUARTER {
                let [c, s] = TWIDDLE_512[idx];
                idx = (idx + k) & (FRAME_LEN - 1);
                for ch in 0..3 {
                    let v = folds[ch][QUARTER + n];
                    pc[ch] += v.re * c;
                    ps[ch] += v.re * s;
                    qc[ch] += v.im * c;
                    qs[ch] += v.im * s;
                }
            }
            core::array::from_fn(|ch| {
                if r == 1 {
                    // (p − jq)(cos − j sin) = p·cos − q·sin − j(p·sin + q·cos)
                    Complex32::new(pc[ch] - qs[ch], -(ps[ch] + qc[ch]))
                } else {
                    // (p + jq)(cos − j sin) = p·cos + q·sin + j(q·cos − p·sin)
                    Complex32::new(pc[ch] + qs[ch], qc[ch] - ps[ch])
                }
            })
        }
    }
}

/// Squared magnitude of a bin.
#[inline]
#[must_use]
pub fn power(c: Complex32) -> f32 {
    c.re * c.re + c.im * c.im
}

/// Frequency in Hz of bin `k` at analysis rate `fs`.
#[inline]
#[must_use]
pub fn bin_frequency(k: usize, fs: f32) -> f32 {
    k as f32 * fs / FRAME_LEN as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference DFT in f64 of the windowed frame.
    fn dft(frame: &[f32; FRAME_LEN], k: usize) -> (f64, f64) {
        let (mut re, mut im) = (0.0, 0.0);
        for (n, x) in frame.iter().enumerate() {
            let w = 0.54
                - 0.46 * (2.0 * core::f64::consts::PI * n as f64 / (FRAME_LEN - 1) as f64).cos();
            let ph = -2.0 * core::f64::consts::PI * (k * n) as f64 / FRAME_LEN as f64;
            re += *x as f64 * w * ph.cos();
            im += *x as f64 * w * ph.sin();
        }
        (re, im)
    }

    #[test]
    fn matches_f64_dft_including_dc_and_nyquist() {
        let mut frame = [0.0f32; FRAME_LEN];
        let mut seed = 12345u32;
        for (n, v) in frame.iter_mut().enumerate() {
            seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
            *v = 0.3
                + ((seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5)
                + if n % 2 == 0 { 0.25 } else { -0.25 };
        }
        let mut scratch = [0.0; FRAME_LEN];
        let mut out = [Complex32::new(0.0, 0.0); NUM_BINS];
        windowed_spectrum(&frame, &mut scratch, &mut out);
        for k in [0usize, 1, 17, 100, 255, 256] {
            let (re, im) = dft(&frame, k);
            let tol = 1e-4 * (1.0 + (re * re + im * im).sqrt());
            assert!(
                (out[k].re as f64 - re).abs() < tol,
                "bin {k} re {} vs {re}",
                out[k].re
            );
            assert!(
                (out[k].im as f64 - im).abs() < tol,
                "bin {k} im {} vs {im}",
                out[k].im
            );
        }
        assert_eq!(out[0].im, 0.0);
        assert_eq!(out[256].im, 0.0);
    }

    /// The direct DFT at chosen bins equals the FFT's bins within 2·10⁻⁶ of the largest bin magnitude
    /// (both are f32 computations of the same sum; the f64 reference above bounds each at ~10⁻⁶).
    #[test]
    fn direct_bins_equal_fft_bins() {
        let mut frames = [[0.0f32; FRAME_LEN]; 3];
        let mut seed = 777u32;
        for (ch, f) in frames.iter_mut().enumerate() {
            for (n, v) in f.iter_mut().enumerate() {
                seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
                let t = n as f32;
                *v = 0.2 * libm::sinf(0.3 * t * (ch + 1) as f32)
                    + ((seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5);
            }
        }
        let mut scratch = [0.0; FRAME_LEN];
        let mut fft = [[Complex32::new(0.0, 0.0); NUM_BINS]; 3];
        let mut folds = [[Complex32::new(0.0, 0.0); NUM_BINS]; 3];
        for ch in 0..3 {
            windowed_spectrum(&frames[ch], &mut scratch, &mut fft[ch]);
            fold_windowed(&frames[ch], &mut folds[ch]);
        }
        let max = fft
            .iter()
            .flatten()
            .map(|c| power(*c))
            .fold(0.0f32, f32::max)
            .sqrt();
        let mut worst = 0.0f32;
        for k in 1..NUM_BINS - 1 {
            let d = dft_bins3([&folds[0], &folds[1], &folds[2]], k);
            for ch in 0..3 {
                let e = power(Complex32::new(
                    d[ch].re - fft[ch][k].re,
                    d[ch].im - fft[ch][k].im,
                ));
                worst = worst.max(e.sqrt() / max);
            }
        }
        assert!(worst < 2e-6, "worst relative difference {worst:e}");
    }
}
