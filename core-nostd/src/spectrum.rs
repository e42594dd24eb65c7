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

/// A sixteenth of a frame: the length of the folded sequences of [`fold_windowed`].
const SIXTEENTH: usize = FRAME_LEN / 16;

/// 8-point DFT of a real sequence: F_0, F_4 (real) and F_1, F_2, F_3 (F_{8−r} = conj F_r).
#[inline(always)]
fn dft8_real(x: [f32; 8]) -> (f32, f32, [Complex32; 3]) {
    const C: f32 = core::f32::consts::FRAC_1_SQRT_2;
    let a: [f32; 4] = core::array::from_fn(|m| x[m] + x[m + 4]);
    let b: [f32; 4] = core::array::from_fn(|m| x[m] - x[m + 4]);
    let (a02, a13) = (a[0] + a[2], a[1] + a[3]);
    let (d, s) = (C * (b[1] - b[3]), C * (b[1] + b[3]));
    (
        a02 + a13,
        a02 - a13,
        [
            Complex32::new(b[0] + d, -(b[2] + s)),
            Complex32::new(a[0] - a[2], -(a[1] - a[3])),
            Complex32::new(b[0] - d, b[2] - s),
        ],
    )
}

/// Windows `frame` and folds it for [`dft_bins3`]: with x_m the windowed sample n + 32m (n < 32,
/// m < 16), the 16-point DFT F_r(n) = Σ_m x_m·e^{−j2πrm/16} for r = 0…8 (F_{16−r} = conj F_r) is
/// stored as `out[n] = (F_0, F_8)` and `out[32r + n] = F_r` for r = 1…7 (`out[256]` is unused). Bin k
/// of the frame is then a 32-term sum Σ_n e^{−j2πkn/512}·F_{k mod 16}(n), because
/// e^{−j2πk·32m/512} = e^{−j2π(k mod 16)m/16}. The 16-point DFT is split into the 8-point DFTs E, O of
/// the even and odd m: F_r = E_r + W^r·O_r and F_{8−r} = conj(E_r − W^r·O_r), W = e^{−j2π/16}.
pub fn fold_windowed(frame: &[f32; FRAME_LEN], out: &mut [Complex32; NUM_BINS]) {
    const C: f32 = core::f32::consts::FRAC_1_SQRT_2;
    // cos(π/8), sin(π/8).
    const C1: f32 = 0.923_879_5;
    const S1: f32 = 0.382_683_43;
    for n in 0..SIXTEENTH {
        let x = |m: usize| frame[n + SIXTEENTH * m] * HAMMING_512[n + SIXTEENTH * m];
        let (e0, e4, e) = dft8_real(core::array::from_fn(|m| x(2 * m)));
        let (o0, o4, o) = dft8_real(core::array::from_fn(|m| x(2 * m + 1)));
        out[n] = Complex32::new(e0 + o0, e0 - o0);
        out[4 * SIXTEENTH + n] = Complex32::new(e4, -o4);
        // W^r·O_r for r = 1, 2, 3: W = C1 − j·S1, W² = C·(1 − j), W³ = S1 − j·C1;
        // (g + jh)(c − js) = (g·c + h·s) + j(h·c − g·s).
        let p = [
            Complex32::new(o[0].re * C1 + o[0].im * S1, o[0].im * C1 - o[0].re * S1),
            Complex32::new(C * (o[1].re + o[1].im), C * (o[1].im - o[1].re)),
            Complex32::new(o[2].re * S1 + o[2].im * C1, o[2].im * S1 - o[2].re * C1),
        ];
        for r in 1..4 {
            let (er, pr) = (e[r - 1], p[r - 1]);
            out[r * SIXTEENTH + n] = Complex32::new(er.re + pr.re, er.im + pr.im);
            out[(8 - r) * SIXTEENTH + n] = Complex32::new(er.re - pr.re, pr.im - er.im);
        }
    }
    out[NUM_BINS - 1] = Complex32::new(0.0, 0.0);
}

/// Bin k (1 ≤ k < 256) of the windowed spectrum of three channels, each folded by
/// [`fold_windowed`]: the same value as [`windowed_spectrum`]'s bin k up to rounding (a Goertzel
/// recursion over 32 terms, in Reinsch's form near θ = 0 and π, or for k ≡ 0, 8 mod 16 a direct sum
/// with twiddles from a table; see the tests for the tolerance). For the similarity
/// method, which needs the cardioids only at the few picked bins.
#[must_use]
pub fn dft_bins3(folds: [&[Complex32; NUM_BINS]; 3], k: usize) -> [Complex32; 3] {
    let r = k & 15;
    let mut acc = [[0.0f32; 4]; 3];
    let mut idx = 0usize;
    if r == 0 || r == 8 {
        // Real sequence F_0 or F_8: Σ F·cos, Σ F·sin.
        let im = r == 8;
        for n in 0..SIXTEENTH {
            let [c, s] = TWIDDLE_512[idx];
            idx = (idx + k) & (FRAME_LEN - 1);
            for ch in 0..3 {
                let f = folds[ch][n];
                let v = if im { f.im } else { f.re };
                acc[ch][0] += v * c;
                acc[ch][1] += v * s;
            }
        }
        return core::array::from_fn(|ch| Complex32::new(acc[ch][0], -acc[ch][1]));
    }
    // Complex sequence G = g + jh (F_r, or conj F_{16−r} for r > 8): a Goertzel recursion per part
    // (see `goertzel3`).
    let (base, sign) = if r < 8 {
        (r * SIXTEENTH, 1.0f32)
    } else {
        ((16 - r) * SIXTEENTH, -1.0)
    };
    let block = |ch: usize| -> &[Complex32] { &folds[ch][base..base + SIXTEENTH] };
    let blocks = [block(0), block(1), block(2)];
    let (c, s) = (
        TWIDDLE_512[k & (FRAME_LEN - 1)][0],
        TWIDDLE_512[k & (FRAME_LEN - 1)][1],
    );
    // s(N−1), s(N−2) per channel and part.
    let last: [[f32; 4]; 3] = if k < FRAME_LEN / 8 {
        goertzel3::<NEAR_ZERO>(blocks, -2.0 * s * s / (1.0 + c))
    } else if k > 3 * FRAME_LEN / 8 {
        goertzel3::<NEAR_PI>(blocks, 2.0 * s * s / (1.0 - c))
    } else {
        goertzel3::<PLAIN>(blocks, c + c)
    };
    let [cn, sn] = TWIDDLE_512[(k * (SIXTEENTH - 1)) & (FRAME_LEN - 1)];
    core::array::from_fn(|ch| {
        let [g1, g2, h1, h2] = last[ch];
        // y = s(N−1) − (c − js)·s(N−2), s = g + j·sign·h.
        let (h1, h2) = (sign * h1, sign * h2);
        let yr = g1 - (c * g2 + s * h2);
        let yi = h1 - (c * h2 - s * g2);
        // X = (cn − j·sn)·y.
        Complex32::new(cn * yr + sn * yi, cn * yi - sn * yr)
    })
}

/// Goertzel forms of [`goertzel3`].
const PLAIN: u8 = 0;
const NEAR_ZERO: u8 = 1;
const NEAR_PI: u8 = 2;

/// Goertzel recursion s(n) = x(n) + 2cos θ·s(n−1) − s(n−2) over the real and the imaginary parts of
/// three complex sequences; returns per sequence [s_re(N−1), s_re(N−2), s_im(N−1), s_im(N−2)]. Then
/// Σ_n x(n)·e^{−jθn} = e^{−jθ(N−1)}·(s(N−1) − e^{−jθ}·s(N−2)). `PLAIN` runs it as written with
/// `coef` = 2cos θ; near θ = 0 and θ = π, where 2cos θ ≈ ±2 makes that form lose precision, Reinsch's
/// forms carry d(n) = s(n) ∓ s(n−1) instead: `NEAR_ZERO`, `coef` = 2cos θ − 2 = −2sin²θ/(1 + cos θ),
/// d(n) = d(n−1) + coef·s(n−1) + x(n), s(n) = s(n−1) + d(n); `NEAR_PI`, `coef` = 2cos θ + 2
/// = 2sin²θ/(1 − cos θ), d(n) = x(n) + coef·s(n−1) − d(n−1), s(n) = d(n) − s(n−1).
#[inline(always)]
fn goertzel3<const M: u8>(x: [&[Complex32]; 3], coef: f32) -> [[f32; 4]; 3] {
    // Per sequence: (s, t) of the real part, then of the imaginary part; t = s(n−1) (PLAIN) or d(n).
    let mut st = [[0.0f32; 4]; 3];
    for (n, f0) in x[0].iter().enumerate() {
        for ch in 0..3 {
            let f = if ch == 0 { *f0 } else { x[ch][n] };
            let [a, b, c, d] = st[ch];
            st[ch] = match M {
                PLAIN => [f.re + (coef * a - b), a, f.im + (coef * c - d), c],
                NEAR_ZERO => {
                    let (b, d) = (b + coef * a + f.re, d + coef * c + f.im);
                    [a + b, b, c + d, d]
                }
                _ => {
                    let (b, d) = (f.re + coef * a - b, f.im + coef * c - d);
                    [b - a, b, d - c, d]
                }
            };
        }
    }
    st.map(|[a, b, c, d]| match M {
        PLAIN => [a, b, c, d],
        NEAR_ZERO => [a, a - b, c, c - d],
        _ => [a, b - a, c, d - c],
    })
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

    /// The folded direct DFT at every bin 1…255 (all 16 residues k mod 16) equals the f64 DFT of the
    /// windowed frame within 5·10⁻⁷ of the largest bin magnitude (measured: 3.3·10⁻⁷, at the lowest bins;
    /// ≤ 9·10⁻⁸ for k ≥ 32; the 64-term direct sum: 6.5·10⁻⁸).
    #[test]
    fn direct_bins_match_f64_dft() {
        let mut frames = [[0.0f32; FRAME_LEN]; 3];
        let mut seed = 4242u32;
        for (ch, f) in frames.iter_mut().enumerate() {
            for (n, v) in f.iter_mut().enumerate() {
                seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
                *v = 0.5 * libm::cosf(0.05 * n as f32 * (ch + 2) as f32)
                    + ((seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5);
            }
        }
        let mut folds = [[Complex32::new(0.0, 0.0); NUM_BINS]; 3];
        for ch in 0..3 {
            fold_windowed(&frames[ch], &mut folds[ch]);
        }
        let reference: [[(f64, f64); NUM_BINS]; 3] =
            core::array::from_fn(|ch| core::array::from_fn(|k| dft(&frames[ch], k)));
        let max = reference
            .iter()
            .flatten()
            .map(|(re, im)| (re * re + im * im).sqrt())
            .fold(0.0f64, f64::max);
        let mut worst = 0.0f64;
        for k in 1..NUM_BINS - 1 {
            let d = dft_bins3([&folds[0], &folds[1], &folds[2]], k);
            for ch in 0..3 {
                let (re, im) = reference[ch][k];
                let e = ((d[ch].re as f64 - re).powi(2) + (d[ch].im as f64 - im).powi(2)).sqrt();
                worst = worst.max(e / max);
            }
        }
        assert!(worst < 5e-7, "worst relative difference {worst:e}");
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
