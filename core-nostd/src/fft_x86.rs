//! The windowed 512-point real FFT of [`crate::spectrum::windowed_spectrum`] on x86_64, in SSE2:
//! bit for bit the values of `microfft::real::rfft_512` (which the Cortex-M4F runs), faster.
//!
//! microfft packs the 512 real samples as 256 complex ones, reorders them by bit reversal, runs the
//! radix-2 butterflies of its 256-point complex FFT stage by stage (its recursion does each stage's
//! butterflies on values of the stage before only, so the order across a stage does not matter) and
//! recombines the result into the real spectrum. Here the window is applied while the samples are
//! placed at their bit-reversed index, the butterflies of two consecutive k run in the four lanes of
//! one vector with microfft's complex products — (t.re·x.re − t.im·x.im, t.re·x.im + t.im·x.re), a − b
//! computed as a + (−b), which IEEE 754 defines as the same operation — and its exact twiddles
//! (`FFT_TWIDDLE_*`, from build.rs), and the k = 0 butterfly takes x unmultiplied, as microfft does.
//! The recombination is microfft's scalar loop, operation for operation. The test below compares
//! every bin with microfft's, bit for bit, on random frames with huge, tiny and signed-zero samples.

use crate::tables::{FFT_SINE_512, FFT_TWIDDLE_IM2, FFT_TWIDDLE_RE2, HAMMING_512};
use crate::{FRAME_LEN, NUM_BINS};
use core::arch::x86_64::{
    __m128, _mm_add_ps, _mm_castpd_ps, _mm_castps_pd, _mm_load_sd, _mm_loadu_ps, _mm_move_sd,
    _mm_movehl_ps, _mm_movelh_ps, _mm_mul_ps, _mm_set_ps, _mm_shuffle_ps, _mm_storeu_ps,
    _mm_sub_ps, _mm_xor_ps,
};
use microfft::Complex32;

/// Complex points of the packed transform.
const POINTS: usize = FRAME_LEN / 2;

/// 8-bit reversal of every index below 256.
const BITREV_256: [u8; POINTS] = {
    let mut t = [0u8; POINTS];
    let mut i = 0;
    while i < POINTS {
        t[i] = (i as u8).reverse_bits();
        i += 1;
    }
    t
};

/// Windows `frame`, transforms it and writes the bins DC…Nyquist to `out` (Nyquist unpacked), as
/// [`crate::spectrum::windowed_spectrum`] with microfft does.
pub(crate) fn windowed_spectrum(frame: &[f32; FRAME_LEN], out: &mut [Complex32; NUM_BINS]) {
    let mut x = [Complex32::new(0.0, 0.0); POINTS];
    first_stage(frame, &mut x);
    butterflies(&mut x);
    recombine(&mut x);
    let nyquist = x[0].im;
    out[0] = Complex32::new(x[0].re, 0.0);
    out[1..NUM_BINS - 1].copy_from_slice(&x[1..]);
    out[NUM_BINS - 1] = Complex32::new(nyquist, 0.0);
}

/// Loads the two f32 `v[i]`, `v[i + 1]` into the low half of a vector.
///
/// SAFETY (of the body): the bounds-checked slice `v[i..i + 2]` is 8 valid bytes; `_mm_load_sd`
/// needs no alignment.
#[allow(unsafe_code)]
#[inline(always)]
fn load_pair(v: &[f32], i: usize) -> __m128 {
    unsafe { _mm_castpd_ps(_mm_load_sd(v[i..i + 2].as_ptr().cast::<f64>())) }
}

/// Windowing, the bit-reversal reorder and stage m = 1 in one pass: output pair (2j, 2j + 1) is the
/// butterfly (a + b, a − b) of the windowed packed points a = r and b = r + 128, r the bit reversal
/// of 2j (that of 2j + 1 is r + 128). Each pair is written as one vector, which the next stage reads
/// back whole.
// SAFETY: SSE2 is enabled on every x86_64 target; the intrinsics work on registers, apart from the
// loads of `load_pair` and the stores of `store2`.
#[allow(unsafe_code)]
fn first_stage(frame: &[f32; FRAME_LEN], x: &mut [Complex32; POINTS]) {
    unsafe {
        let neg_hi = _mm_set_ps(-0.0, -0.0, 0.0, 0.0);
        for j in 0..POINTS / 2 {
            let r = BITREV_256[2 * j] as usize;
            let (ia, ib) = (2 * r, 2 * (r + POINTS / 2));
            let s = _mm_movelh_ps(load_pair(frame, ia), load_pair(frame, ib));
            let w = _mm_movelh_ps(load_pair(&HAMMING_512, ia), load_pair(&HAMMING_512, ib));
            // (a, b) windowed; then (a, a) + (b, −b).
            let v = _mm_mul_ps(s, w);
            let a = _mm_movelh_ps(v, v);
            let b = _mm_movehl_ps(v, v);
            store2(x, 2 * j, _mm_add_ps(a, _mm_xor_ps(b, neg_hi)));
        }
    }
}

/// Loads the complex pair `x[i]`, `x[i + 1]` as one vector (re, im, re, im).
///
/// SAFETY (of the body): `Complex32` is `#[repr(C)]` (re, im), so the bounds-checked slice
/// `x[i..i + 2]` is four consecutive f32; the unaligned load needs no alignment.
#[allow(unsafe_code)]
#[inline(always)]
fn load2(x: &[Complex32], i: usize) -> __m128 {
    unsafe { _mm_loadu_ps(x[i..i + 2].as_ptr().cast::<f32>()) }
}

/// Stores a vector (re, im, re, im) to `x[i]`, `x[i + 1]` (safety as [`load2`]).
#[allow(unsafe_code)]
#[inline(always)]
fn store2(x: &mut [Complex32], i: usize, v: __m128) {
    unsafe { _mm_storeu_ps(x[i..i + 2].as_mut_ptr().cast::<f32>(), v) }
}

/// The radix-2 butterflies of stages m = 2, 4, …, 128 of the 256-point complex FFT, stage by stage.
// SAFETY: SSE2 is enabled on every x86_64 target, so the intrinsics exist; all of them work on
// registers, except the loads and stores of `load2`/`store2` and `_mm_loadu_ps` of four f32 of a
// bounds-checked slice of a twiddle table.
#[allow(unsafe_code)]
fn butterflies(x: &mut [Complex32; POINTS]) {
    unsafe {
        // Sign bits of the real lanes: a − b as a + (b with its sign flipped).
        let neg_re = _mm_set_ps(0.0, -0.0, 0.0, -0.0);
        let mut m = 2;
        while m < POINTS {
            let tw = 2 * (m - 2);
            for base in (0..POINTS).step_by(2 * m) {
                for k in (0..m).step_by(2) {
                    let lo = load2(x, base + k);
                    let hi = load2(x, base + k + m);
                    let t = tw + 2 * k;
                    let tre = _mm_loadu_ps(FFT_TWIDDLE_RE2[t..t + 4].as_ptr());
                    let tim = _mm_loadu_ps(FFT_TWIDDLE_IM2[t..t + 4].as_ptr());
                    // (im, re) of each complex.
                    let swapped = _mm_shuffle_ps::<0b10_11_00_01>(hi, hi);
                    let mut y = _mm_add_ps(
                        _mm_mul_ps(tre, hi),
                        _mm_xor_ps(_mm_mul_ps(tim, swapped), neg_re),
                    );
                    if k == 0 {
                        // Twiddle 1: microfft adds x itself, unmultiplied.
                        y = _mm_castpd_ps(_mm_move_sd(_mm_castps_pd(y), _mm_castps_pd(hi)));
                    }
                    store2(x, base + k, _mm_add_ps(lo, y));
                    store2(x, base + k + m, _mm_sub_ps(lo, y));
                }
            }
            m *= 2;
        }
    }
}

/// microfft's recombination of the packed complex transform into the real one (DC in `x[0].re`,
/// Nyquist in `x[0].im`), operation for operation.
fn recombine(x: &mut [Complex32; POINTS]) {
    const L: usize = FFT_SINE_512.len();
    let x0 = x[0];
    x[0] = Complex32::new(x0.re + x0.im, x0.re - x0.im);
    let u = POINTS / 2;
    for k in 1..u {
        let tr = -FFT_SINE_512[L - k];
        let ti = FFT_SINE_512[k - 1];
        let (xk, xnk) = (x[k], x[POINTS - k]);
        let sum = Complex32::new((xk.re + xnk.re) / 2.0, (xk.im + xnk.im) / 2.0);
        let diff = Complex32::new((xk.re - xnk.re) / 2.0, (xk.im - xnk.im) / 2.0);
        x[k] = Complex32::new(
            sum.re + tr * sum.im + ti * diff.re,
            diff.im + ti * sum.im - tr * diff.re,
        );
        x[POINTS - k] = Complex32::new(
            sum.re - tr * sum.im - ti * diff.re,
            -diff.im + ti * sum.im - tr * diff.re,
        );
    }
    x[u] = Complex32::new(x[u].re, -x[u].im);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// microfft's path: window, `rfft_512`, Nyquist unpacked.
    fn reference(frame: &[f32; FRAME_LEN]) -> [Complex32; NUM_BINS] {
        let mut s = [0.0f32; FRAME_LEN];
        for ((s, x), w) in s.iter_mut().zip(frame).zip(HAMMING_512.iter()) {
            *s = x * w;
        }
        let bins = microfft::real::rfft_512(&mut s);
        let mut out = [Complex32::new(0.0, 0.0); NUM_BINS];
        out[0] = Complex32::new(bins[0].re, 0.0);
        out[1..NUM_BINS - 1].copy_from_slice(&bins[1..]);
        out[NUM_BINS - 1] = Complex32::new(bins[0].im, 0.0);
        out
    }

    #[test]
    fn equals_microfft_bit_for_bit() {
        let mut rng = crate::test_rng::XorShift64(0x5851_f42d_4c95_7f2d);
        let same = |a: f32, b: f32| a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan());
        for round in 0..300 {
            let mut frame = [0.0f32; FRAME_LEN];
            for (n, v) in frame.iter_mut().enumerate() {
                let r = rng.next_u64();
                let unit = ((r >> 8) as u32 as f32 / u32::MAX as f32) * 2.0 - 1.0;
                *v = match round {
                    0 => 0.0,
                    1 => -0.0,
                    2 => {
                        if n == 3 {
                            1.0
                        } else {
                            0.0
                        }
                    }
                    3 => 0.25,
                    _ => match (r >> 40) % 64 {
                        0 if round % 5 == 0 => f32::NAN,
                        1 if round % 5 == 0 => f32::INFINITY,
                        2 => 1e-40,
                        3 => -3e37,
                        4 => -0.0,
                        5 => 0.0,
                        _ => unit,
                    },
                };
            }
            let mut got = [Complex32::new(7.0, 7.0); NUM_BINS];
            windowed_spectrum(&frame, &mut got);
            let want = reference(&frame);
            for (k, (g, w)) in got.iter().zip(&want).enumerate() {
                assert!(
                    same(g.re, w.re) && same(g.im, w.im),
                    "round {round} bin {k}: {g:?} vs {w:?}"
                );
            }
        }
    }
}
