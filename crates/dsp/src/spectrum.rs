//! Short-time spectrum (thesis §5.1.1): Hamming window from a table, `microfft` real FFT,
//! the Nyquist bin unpacked.
//!
//! `microfft::real::rfft_512` returns 256 complex bins and packs the (real) Nyquist bin into the
//! imaginary part of bin 0. [`windowed_spectrum`] unpacks it so that `out[0]` is DC (imaginary 0) and
//! `out[256]` is Nyquist; the test below pins this quirk down.

use crate::tables::{hamming, SINE_QUARTER_512};
use crate::{FRAME_LEN, NUM_BINS};
use microfft::Complex32;

/// Windows `frame`, transforms it, and writes the [`NUM_BINS`] bins DC…Nyquist to `out`.
/// `scratch` is not used (both paths transform in `out`); it stays in the signature for the callers
/// that hold one.
pub fn windowed_spectrum(
    frame: &[f32; FRAME_LEN],
    scratch: &mut [f32; FRAME_LEN],
    out: &mut [Complex32; NUM_BINS],
) {
    let _ = scratch;
    // x86_64: the same values from an SSE2 transform (`fft_x86`, tested bit for bit against this
    // path).
    #[cfg(target_arch = "x86_64")]
    crate::fft_x86::windowed_spectrum(frame, out);
    #[cfg(not(target_arch = "x86_64"))]
    microfft_spectrum(frame, out);
}

/// [`windowed_spectrum`] with `microfft` (the Cortex-M4F's path), in place in `out`: the windowed
/// frame goes into the first 256 bins' memory, where `rfft_512` leaves its 256 bins, so no copy of
/// the spectrum follows (≈ 1.8 k instructions of `memcpy` per hop on the M4F before).
#[cfg(not(target_arch = "x86_64"))]
fn microfft_spectrum(frame: &[f32; FRAME_LEN], out: &mut [Complex32; NUM_BINS]) {
    let buf = bins_as_floats(out);
    // The window's two halves, the second mirrored (w[n] = w[511 − n]).
    let half = &crate::tables::HAMMING_HALF_512;
    let (lo, hi) = buf.split_at_mut(FRAME_LEN / 2);
    let (flo, fhi) = frame.split_at(FRAME_LEN / 2);
    for ((s, x), w) in lo.iter_mut().zip(flo).zip(half) {
        *s = x * w;
    }
    for ((s, x), w) in hi.iter_mut().zip(fhi).zip(half.iter().rev()) {
        *s = x * w;
    }
    let _ = microfft::real::rfft_512(buf);
    let nyquist = out[0].im;
    out[0].im = 0.0;
    out[NUM_BINS - 1] = Complex32::new(nyquist, 0.0);
}

/// The first `FRAME_LEN / 2` bins of `out` as the `FRAME_LEN` floats they consist of.
#[cfg(not(target_arch = "x86_64"))]
#[allow(unsafe_code)]
fn bins_as_floats(out: &mut [Complex32; NUM_BINS]) -> &mut [f32; FRAME_LEN] {
    const { assert!(2 * NUM_BINS > FRAME_LEN) };
    const { assert!(core::mem::size_of::<Complex32>() == 2 * core::mem::size_of::<f32>()) };
    const { assert!(core::mem::align_of::<Complex32>() == core::mem::align_of::<f32>()) };
    // Note(unsafe): `Complex32` is `#[repr(C)]` { re: f32, im: f32 } (asserted: two floats, no
    // padding, alignment of f32), so `[Complex32; NUM_BINS]` is 2·NUM_BINS > FRAME_LEN contiguous
    // floats; the result borrows `out` mutably for its lifetime, so nothing else aliases it.
    unsafe { &mut *out.as_mut_ptr().cast::<[f32; FRAME_LEN]>() }
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
        let x = |m: usize| frame[n + SIXTEENTH * m] * hamming(n + SIXTEENTH * m);
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

/// (cos, sin) of 2πi/512 (any i, taken mod 512) from the quarter-wave table: 0.5 KB of flash
/// instead of a full table's 4 KB.
#[inline(always)]
#[must_use]
pub fn twiddle(i: usize) -> [f32; 2] {
    let i = i & (FRAME_LEN - 1);
    let r = i & (FRAME_LEN / 4 - 1);
    let (c, s) = (SINE_QUARTER_512[FRAME_LEN / 4 - r], SINE_QUARTER_512[r]);
    match i / (FRAME_LEN / 4) {
        0 => [c, s],
        1 => [-s, c],
        2 => [-c, -s],
        _ => [s, -c],
    }
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
            let [c, s] = twiddle(idx);
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
    let [c, s] = twiddle(k);
    // s(N−1), s(N−2) per channel and part.
    let last: [[f32; 4]; 3] = match goertzel_form(k) {
        NEAR_ZERO => goertzel3::<NEAR_ZERO>(blocks, -2.0 * s * s / (1.0 + c)),
        NEAR_PI => goertzel3::<NEAR_PI>(blocks, 2.0 * s * s / (1.0 - c)),
        _ => goertzel3::<PLAIN>(blocks, c + c),
    };
    goertzel_finish(k, sign, last)
}

/// The Goertzel form [`dft_bins3`] uses for bin k (k mod 16 ≠ 0, 8).
#[inline(always)]
fn goertzel_form(k: usize) -> u8 {
    if k < FRAME_LEN / 8 {
        NEAR_ZERO
    } else if k > 3 * FRAME_LEN / 8 {
        NEAR_PI
    } else {
        PLAIN
    }
}

/// Start block, sign of the imaginary part, and recursion coefficient of bin k in the form `M` (as
/// [`dft_bins3`] computes them).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn goertzel_setup<const M: u8>(k: usize) -> (usize, f32, f32) {
    let r = k & 15;
    let (base, sign) = if r < 8 {
        (r * SIXTEENTH, 1.0f32)
    } else {
        ((16 - r) * SIXTEENTH, -1.0)
    };
    let [c, s] = twiddle(k);
    let coef = match M {
        NEAR_ZERO => -2.0 * s * s / (1.0 + c),
        NEAR_PI => 2.0 * s * s / (1.0 - c),
        _ => c + c,
    };
    (base, sign, coef)
}

/// Bin k from the Goertzel recursion's last two states per channel ([`goertzel3`]'s result).
#[inline(always)]
fn goertzel_finish(k: usize, sign: f32, last: [[f32; 4]; 3]) -> [Complex32; 3] {
    let [c, s] = twiddle(k);
    let [cn, sn] = twiddle(k * (SIXTEENTH - 1));
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

/// [`dft_bins3`] at each bin of `bins` (each 1 ≤ k < 256), written to `out[i]` for `bins[i]`
/// (`out` at least as long as `bins`): on x86_64 bins of the same Goertzel form go through the
/// recursion two at a time, as SSE2 vectors, which hides its latency; every value is bit-identical
/// to [`dft_bins3`]'s. Elsewhere one [`dft_bins3`] per bin.
pub fn dft_bins3_many(
    folds: [&[Complex32; NUM_BINS]; 3],
    bins: &[u16],
    out: &mut [[Complex32; 3]],
) {
    #[cfg(target_arch = "x86_64")]
    {
        // Indices of the bins per form; direct sums (k ≡ 0, 8 mod 16) and lone bins one at a time.
        let mut pending: [Option<usize>; 3] = [None; 3];
        for (i, &k) in bins.iter().enumerate().take(out.len()) {
            let k = k as usize;
            if k & 7 == 0 || k == 0 || k >= NUM_BINS - 1 {
                out[i] = dft_bins3(folds, k);
                continue;
            }
            let form = goertzel_form(k);
            match pending[form as usize].take() {
                None => pending[form as usize] = Some(i),
                Some(j) => {
                    let kj = bins[j] as usize;
                    let [a, b] = match form {
                        NEAR_ZERO => sse::goertzel_pair::<NEAR_ZERO>(folds, [kj, k]),
                        NEAR_PI => sse::goertzel_pair::<NEAR_PI>(folds, [kj, k]),
                        _ => sse::goertzel_pair::<PLAIN>(folds, [kj, k]),
                    };
                    out[j] = a;
                    out[i] = b;
                }
            }
        }
        for j in pending.into_iter().flatten() {
            out[j] = dft_bins3(folds, bins[j] as usize);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    for (o, &k) in out.iter_mut().zip(bins) {
        *o = dft_bins3(folds, k as usize);
    }
}

/// SSE2 Goertzel recursions of two bins at once for [`dft_bins3_many`]: per bin, the real and
/// imaginary parts of channels 0 and 1 are one vector and those of channel 2 half of another, so each
/// lane runs exactly [`goertzel3`]'s scalar operations in its order.
#[cfg(target_arch = "x86_64")]
mod sse {
    use super::SIXTEENTH;
    use super::{goertzel_finish, goertzel_setup, Complex32, NEAR_ZERO, NUM_BINS, PLAIN};
    use core::arch::x86_64::{
        __m128, _mm_add_ps, _mm_castpd_ps, _mm_castps_pd, _mm_load_sd, _mm_mul_ps, _mm_set1_ps,
        _mm_setzero_ps, _mm_storeu_ps, _mm_sub_ps, _mm_unpacklo_pd,
    };

    /// `dft_bins3` at the bins `ks` (both of form `M`, neither ≡ 0, 8 mod 16, 1 ≤ k < 256).
    #[allow(unsafe_code)]
    #[inline(never)]
    pub(super) fn goertzel_pair<const M: u8>(
        folds: [&[Complex32; NUM_BINS]; 3],
        ks: [usize; 2],
    ) -> [[Complex32; 3]; 2] {
        let setup = ks.map(goertzel_setup::<M>);
        // Per bin: [s, t] state of channels 0, 1 (lanes re0, im0, re1, im1) and of channel 2
        // (lanes re2, im2, –, –).
        let mut last = [[[0.0f32; 4]; 3]; 2];
        // SAFETY: SSE2 is enabled on every x86_64 target, so the intrinsics exist. They work on
        // registers, except `_mm_load_sd`, which reads 8 bytes through a reference to one
        // `Complex32` (`#[repr(C)]` re, im: 8 valid bytes; the load needs no alignment), and
        // `_mm_storeu_ps`, which writes 16 bytes to a `[f32; 4]`.
        unsafe {
            let load = |c: &Complex32| -> __m128 {
                _mm_castpd_ps(_mm_load_sd((c as *const Complex32).cast()))
            };
            let zero = _mm_setzero_ps();
            let mut st = [[zero; 4]; 2];
            let coef = setup.map(|(_, _, c)| _mm_set1_ps(c));
            let blocks = setup.map(|(base, _, _)| {
                [
                    &folds[0][base..base + SIXTEENTH],
                    &folds[1][base..base + SIXTEENTH],
                    &folds[2][base..base + SIXTEENTH],
                ]
            });
            for n in 0..SIXTEENTH {
                for p in 0..2 {
                    let [b0, b1, b2] = blocks[p];
                    let f01 = _mm_castpd_ps(_mm_unpacklo_pd(
                        _mm_castps_pd(load(&b0[n])),
                        _mm_castps_pd(load(&b1[n])),
                    ));
                    let f2 = load(&b2[n]);
                    let cf = coef[p];
                    for (v, f) in [(0, f01), (2, f2)] {
                        let (a, b) = (st[p][v], st[p][v + 1]);
                        let (na, nb) = match M {
                            PLAIN => (_mm_add_ps(f, _mm_sub_ps(_mm_mul_ps(cf, a), b)), a),
                            NEAR_ZERO => {
                                let b = _mm_add_ps(_mm_add_ps(b, _mm_mul_ps(cf, a)), f);
                                (_mm_add_ps(a, b), b)
                            }
                            _ => {
                                let b = _mm_sub_ps(_mm_add_ps(f, _mm_mul_ps(cf, a)), b);
                                (_mm_sub_ps(b, a), b)
                            }
                        };
                        st[p][v] = na;
                        st[p][v + 1] = nb;
                    }
                }
            }
            for p in 0..2 {
                let mut v = [[0.0f32; 4]; 4];
                for (o, x) in v.iter_mut().zip(st[p]) {
                    _mm_storeu_ps(o.as_mut_ptr(), x);
                }
                let [a01, b01, a2, b2] = v;
                // [s_re(N−1), t_re, s_im(N−1), t_im] per channel, as `goertzel3`'s loop leaves them.
                last[p] = [
                    [a01[0], b01[0], a01[1], b01[1]],
                    [a01[2], b01[2], a01[3], b01[3]],
                    [a2[0], b2[0], a2[1], b2[1]],
                ];
            }
        }
        core::array::from_fn(|p| {
            let l = last[p].map(|[a, b, c, d]| match M {
                PLAIN => [a, b, c, d],
                NEAR_ZERO => [a, a - b, c, c - d],
                _ => [a, b - a, c, d - c],
            });
            goertzel_finish(ks[p], setup[p].1, l)
        })
    }
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

    #[test]
    fn twiddles_from_the_quarter_wave_are_cos_and_sin() {
        for i in 0..2 * FRAME_LEN {
            let t = 2.0 * core::f64::consts::PI * i as f64 / FRAME_LEN as f64;
            let [c, s] = twiddle(i);
            assert!((f64::from(c) - t.cos()).abs() < 1e-7, "cos at {i}");
            assert!((f64::from(s) - t.sin()).abs() < 1e-7, "sin at {i}");
        }
        assert_eq!(twiddle(0), [1.0, 0.0]);
        assert_eq!(twiddle(FRAME_LEN / 4), [0.0, 1.0]);
    }

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
        let mut rng = crate::test_rng::Lcg(12345);
        for (n, v) in frame.iter_mut().enumerate() {
            *v = 0.3 + (rng.unit() - 0.5) + if n % 2 == 0 { 0.25 } else { -0.25 };
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
        let mut rng = crate::test_rng::Lcg(4242);
        for (ch, f) in frames.iter_mut().enumerate() {
            for (n, v) in f.iter_mut().enumerate() {
                *v = 0.5 * libm::cosf(0.05 * n as f32 * (ch + 2) as f32) + (rng.unit() - 0.5);
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
        let mut rng = crate::test_rng::Lcg(777);
        for (ch, f) in frames.iter_mut().enumerate() {
            for (n, v) in f.iter_mut().enumerate() {
                let t = n as f32;
                *v = 0.2 * libm::sinf(0.3 * t * (ch + 1) as f32) + (rng.unit() - 0.5);
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

    /// `dft_bins3_many` equals `dft_bins3` bit for bit (NaN for NaN) at every bin, in random orders
    /// and multiplicities, on random folds with NaN, ±Inf, huge and subnormal values.
    #[test]
    fn many_equals_single() {
        let mut rng = crate::test_rng::XorShift64(0x2545_f491_4f6c_dd1d);
        let mut next = || rng.next_u64();
        let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        for round in 0..300 {
            let mut folds = [[Complex32::new(0.0, 0.0); NUM_BINS]; 3];
            for f in folds.iter_mut().flatten() {
                let mut v = || {
                    let r = next();
                    match (r >> 40) % 50 {
                        0 if round % 3 == 0 => f32::NAN,
                        1 if round % 3 == 0 => f32::INFINITY,
                        2 if round % 3 == 0 => f32::NEG_INFINITY,
                        3 => 1e-40,
                        4 => 3e38,
                        _ => ((r >> 8) as u32 as f32 / u32::MAX as f32) * 2.0 - 1.0,
                    }
                };
                *f = Complex32::new(v(), v());
            }
            let [f1, f2, f3] = &folds;
            let len = (next() % 33) as usize;
            let bins: [u16; 32] = core::array::from_fn(|_| (1 + next() % 255) as u16);
            let mut out = [[Complex32::new(0.0, 0.0); 3]; 32];
            dft_bins3_many([f1, f2, f3], &bins[..len.min(32)], &mut out);
            for (i, &k) in bins[..len.min(32)].iter().enumerate() {
                let want = dft_bins3([f1, f2, f3], k as usize);
                for ch in 0..3 {
                    assert!(
                        same(out[i][ch].re, want[ch].re) && same(out[i][ch].im, want[ch].im),
                        "round {round} bin {k} ch {ch}: {:?} vs {:?}",
                        out[i][ch],
                        want[ch]
                    );
                }
            }
        }
    }
}
