//! Short-time spectrum (thesis §5.1.1): Hamming window from a table, `microfft` real FFT,
//! the Nyquist bin unpacked.
//!
//! `microfft::real::rfft_512` returns 256 complex bins and packs the (real) Nyquist bin into the
//! imaginary part of bin 0. [`windowed_spectrum`] unpacks it so that `out[0]` is DC (imaginary 0) and
//! `out[256]` is Nyquist; the test below pins this quirk down.

use crate::tables::HAMMING_512;
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
}
