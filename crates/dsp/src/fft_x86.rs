//! The windowed 512-point real FFT of [`crate::spectrum::windowed_spectrum`] on x86_64, in SSE2:
//! bit for bit the values of `microfft::real::rfft_512` (which the Cortex-M4F runs), faster.
//!
//! microfft packs the 512 real samples as 256 complex ones, reorders them by bit reversal, runs the
//! radix-2 butterflies of its 256-point complex FFT stage by stage (its recursion does each stage's
//! butterflies on values of the stage before only, so the order across a stage does not matter) and
//! recombines the result into the real spectrum. Here the same butterflies run in three passes over
//! the data, each keeping its values in registers across several stages: the window, the
//! bit-reversal reorder and stages m = 1, 2, 4 ([`first_stages`]), then stages 8, 16, 32
//! ([`three_stages`]), then 64 and 128 ([`two_stages`]), each pass on the groups of points that its
//! stages close over. Each butterfly does microfft's operations on each value: the complex product
//! (t.re·x.re − t.im·x.im, t.re·x.im + t.im·x.re) with its exact twiddles (`FFT_TWIDDLE_*`, from
//! build.rs), a − b computed as a + (−b), which IEEE 754 defines as the same operation, and the
//! k = 0 butterfly takes x unmultiplied, as microfft does; no fused multiply-add. The transform runs
//! in the output array, and the recombination ([`recombine`]) does microfft's operations on every
//! value, four k at a time, in place (x/2 as x·0.5: both the correctly rounded exact half). The test
//! below compares every bin with microfft's, bit for bit, on random frames with huge, tiny,
//! subnormal, signed-zero, infinite and NaN samples and on frames that overflow.

use crate::tables::{FFT_SINE_512, FFT_TWIDDLE_IM2, FFT_TWIDDLE_RE2, HAMMING_512};
use crate::{FRAME_LEN, NUM_BINS};
use core::arch::x86_64::{
    __m128, _mm_add_ps, _mm_castpd_ps, _mm_castps_pd, _mm_loadu_ps, _mm_move_sd, _mm_movehl_ps,
    _mm_movelh_ps, _mm_mul_ps, _mm_set1_ps, _mm_set_ps, _mm_shuffle_ps, _mm_storeu_ps, _mm_sub_ps,
    _mm_unpackhi_ps, _mm_unpacklo_ps, _mm_xor_ps,
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
    // The complex transform runs in `out[..256]` (always there: checked at compile time, so the
    // `else` is dead code, not a panic path).
    const { assert!(NUM_BINS > POINTS) };
    let Some(x) = out.first_chunk_mut::<POINTS>() else {
        return;
    };
    first_stages(frame, x);
    three_stages::<8>(x);
    two_stages::<64>(x);
    recombine(out);
}

/// Loads the four f32 `v[i..i + 4]`.
///
/// SAFETY (of the body): the bounds-checked slice `v[i..i + 4]` is 16 valid bytes; the unaligned
/// load needs no alignment.
#[allow(unsafe_code)]
#[inline(always)]
fn load4(v: &[f32], i: usize) -> __m128 {
    unsafe { _mm_loadu_ps(v[i..i + 4].as_ptr()) }
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

/// Offset in `FFT_TWIDDLE_*2` of the twiddles of stage m (m = 2, 4, …, 128; see build.rs).
const fn twiddles_of(m: usize) -> usize {
    2 * (m - 2)
}

/// t·x of each complex of `x` with the twiddles `tre`, `tim` (re and im of each lane's twiddle):
/// (t.re·x.re − t.im·x.im, t.re·x.im + t.im·x.re), the subtraction as the addition of
/// (−t.im)·x.im, which is −(t.im·x.im) exactly (a product's sign is that of its factors and its
/// magnitude rounds the same).
// SAFETY: SSE2 is enabled on every x86_64 target; the intrinsics work on registers.
#[allow(unsafe_code)]
#[inline(always)]
fn twiddled(x: __m128, tre: __m128, tim: __m128) -> __m128 {
    unsafe {
        let neg_re = _mm_set_ps(0.0, -0.0, 0.0, -0.0);
        // (im, re) of each complex.
        let swapped = _mm_shuffle_ps::<0b10_11_00_01>(x, x);
        _mm_add_ps(
            _mm_mul_ps(tre, x),
            _mm_mul_ps(_mm_xor_ps(tim, neg_re), swapped),
        )
    }
}

/// The radix-2 butterflies of two consecutive k (one complex per half of `lo` and `hi`), the
/// twiddles of k, k + 1 at `FFT_TWIDDLE_*2[t..t + 4]`: (lo + t·hi, lo − t·hi) with t·hi of
/// [`twiddled`]. With `K0` the low half is a k = 0 butterfly, whose twiddle is 1: as in microfft its
/// x enters unmultiplied.
// SAFETY: SSE2 is enabled on every x86_64 target; the intrinsics work on registers, apart from the
// loads of `load4`.
#[allow(unsafe_code)]
#[inline(always)]
fn butterfly<const K0: bool>(lo: __m128, hi: __m128, t: usize) -> (__m128, __m128) {
    unsafe {
        let tre = load4(&FFT_TWIDDLE_RE2, t);
        let tim = load4(&FFT_TWIDDLE_IM2, t);
        let mut y = twiddled(hi, tre, tim);
        if K0 {
            y = _mm_castpd_ps(_mm_move_sd(_mm_castps_pd(y), _mm_castps_pd(hi)));
        }
        (_mm_add_ps(lo, y), _mm_sub_ps(lo, y))
    }
}

/// The radix-2 butterflies of one k in both halves of `lo` and `hi` (two transforms side by side),
/// the twiddle of k of stage m; k = 0 (twiddle 1) takes `hi` unmultiplied, as microfft.
// SAFETY: SSE2 is enabled on every x86_64 target; the intrinsics work on registers.
#[allow(unsafe_code)]
#[inline(always)]
fn butterfly_both(lo: __m128, hi: __m128, m: usize, k: usize) -> (__m128, __m128) {
    let t = twiddles_of(m) + 2 * k;
    unsafe {
        let y = if k == 0 {
            hi
        } else {
            twiddled(
                hi,
                _mm_set1_ps(FFT_TWIDDLE_RE2[t]),
                _mm_set1_ps(FFT_TWIDDLE_IM2[t]),
            )
        };
        (_mm_add_ps(lo, y), _mm_sub_ps(lo, y))
    }
}

/// Windowing, the bit-reversal reorder and stages m = 1, 2, 4, with contiguous loads. For r even
/// and below 32, the packed point r + 32q (q < 8) goes to position rev(r) + rev(32q), rev(32q) < 8,
/// and the next point r + 1 + 32q to 128 more. So one vector of the windowed points r + 32q,
/// r + 1 + 32q holds the same position d of the two groups of 8 points at rev(r) and rev(r) + 128;
/// the eight such vectors run stages 1, 2, 4 of both groups at once, each butterfly with the one
/// twiddle of its d ([`butterfly_both`]), and are then interleaved into pairs of consecutive
/// positions and stored. Stage 1 makes (a + b, a − b) of a = point r' and b = point r' + 128
/// (q and q + 4).
// SAFETY: SSE2 is enabled on every x86_64 target; the intrinsics work on registers, apart from the
// loads of `load4` and the stores of `store2`.
#[allow(unsafe_code)]
fn first_stages(frame: &[f32; FRAME_LEN], x: &mut [Complex32; POINTS]) {
    for r in (0..32).step_by(2) {
        // SAFETY: as of the function.
        unsafe {
            let w = |q: usize| {
                let i = 2 * (r + 32 * q);
                _mm_mul_ps(load4(frame, i), load4(&HAMMING_512, i))
            };
            // Stage 1, vd being position rev(r) + d: point r + 32q (q < 4) is at d = (0, 4, 2, 6)[q],
            // its partner r + 32q + 128 at d + 1.
            let (v0, v1) = (w(0), w(4));
            let (v0, v1) = (_mm_add_ps(v0, v1), _mm_sub_ps(v0, v1));
            let (v4, v5) = (w(1), w(5));
            let (v4, v5) = (_mm_add_ps(v4, v5), _mm_sub_ps(v4, v5));
            let (v2, v3) = (w(2), w(6));
            let (v2, v3) = (_mm_add_ps(v2, v3), _mm_sub_ps(v2, v3));
            let (v6, v7) = (w(3), w(7));
            let (v6, v7) = (_mm_add_ps(v6, v7), _mm_sub_ps(v6, v7));
            // Stage 2: k = d mod 2 on (d, d + 2).
            let (v0, v2) = butterfly_both(v0, v2, 2, 0);
            let (v1, v3) = butterfly_both(v1, v3, 2, 1);
            let (v4, v6) = butterfly_both(v4, v6, 2, 0);
            let (v5, v7) = butterfly_both(v5, v7, 2, 1);
            // Stage 4: k = d on (d, d + 4).
            let (v0, v4) = butterfly_both(v0, v4, 4, 0);
            let (v1, v5) = butterfly_both(v1, v5, 4, 1);
            let (v2, v6) = butterfly_both(v2, v6, 4, 2);
            let (v3, v7) = butterfly_both(v3, v7, 4, 3);
            let p = BITREV_256[r] as usize;
            for (d, (lo, hi)) in [(v0, v1), (v2, v3), (v4, v5), (v6, v7)]
                .into_iter()
                .enumerate()
            {
                store2(x, p + 2 * d, _mm_movelh_ps(lo, hi));
                store2(x, p + POINTS / 2 + 2 * d, _mm_movehl_ps(hi, lo));
            }
        }
    }
}

/// Stages `M`, 2`M` and 4`M` (`M` ≥ 2): the butterflies k, k + 1 of the three on the points
/// pj = i + j`M` (j < 8, i = base + k), which they close over: stage `M` on (p0, p1), (p2, p3), …
/// with twiddle k, stage 2`M` on (p0, p2), (p4, p6) with twiddle k and on (p1, p3), (p5, p7) with
/// k + `M`, stage 4`M` on (pj, pj+4) with twiddle k + j`M`.
fn three_stages<const M: usize>(x: &mut [Complex32; POINTS]) {
    for base in (0..POINTS).step_by(8 * M) {
        octet::<M, true>(x, base, 0);
        for k in (2..M).step_by(2) {
            octet::<M, false>(x, base, k);
        }
    }
}

/// One group of [`three_stages`]: k, k + 1 from `base` (`K0`: k = 0).
#[inline(always)]
fn octet<const M: usize, const K0: bool>(x: &mut [Complex32; POINTS], base: usize, k: usize) {
    let i = base + k;
    let mut v: [__m128; 8] = core::array::from_fn(|j| load2(x, i + j * M));
    let t = twiddles_of(M) + 2 * k;
    for j in (0..8).step_by(2) {
        (v[j], v[j + 1]) = butterfly::<K0>(v[j], v[j + 1], t);
    }
    let t = twiddles_of(2 * M) + 2 * k;
    for j in [0, 4] {
        (v[j], v[j + 2]) = butterfly::<K0>(v[j], v[j + 2], t);
        (v[j + 1], v[j + 3]) = butterfly::<false>(v[j + 1], v[j + 3], t + 2 * M);
    }
    let t = twiddles_of(4 * M) + 2 * k;
    (v[0], v[4]) = butterfly::<K0>(v[0], v[4], t);
    for j in 1..4 {
        (v[j], v[j + 4]) = butterfly::<false>(v[j], v[j + 4], t + 2 * j * M);
    }
    for (j, v) in v.into_iter().enumerate() {
        store2(x, i + j * M, v);
    }
}

/// Stages `M` and 2`M` (`M` ≥ 2): the butterflies k, k + 1 of both on the points
/// {i, i + M, i + 2M, i + 3M} (i = base + k), which they close over: stage `M` on (i, i + M) and
/// (i + 2M, i + 3M), both with twiddle k, then stage 2`M` on (i, i + 2M) with twiddle k and on
/// (i + M, i + 3M) with twiddle k + `M`.
fn two_stages<const M: usize>(x: &mut [Complex32; POINTS]) {
    for base in (0..POINTS).step_by(4 * M) {
        quad::<M, true>(x, base, 0);
        for k in (2..M).step_by(2) {
            quad::<M, false>(x, base, k);
        }
    }
}

/// One group of [`two_stages`]: k, k + 1 from `base` (`K0`: k = 0).
#[inline(always)]
fn quad<const M: usize, const K0: bool>(x: &mut [Complex32; POINTS], base: usize, k: usize) {
    let i = base + k;
    let (a, b) = (load2(x, i), load2(x, i + M));
    let (c, d) = (load2(x, i + 2 * M), load2(x, i + 3 * M));
    let t = twiddles_of(M) + 2 * k;
    let (a, b) = butterfly::<K0>(a, b, t);
    let (c, d) = butterfly::<K0>(c, d, t);
    let t = twiddles_of(2 * M) + 2 * k;
    let (a, c) = butterfly::<K0>(a, c, t);
    let (b, d) = butterfly::<false>(b, d, t + 2 * M);
    store2(x, i, a);
    store2(x, i + M, b);
    store2(x, i + 2 * M, c);
    store2(x, i + 3 * M, d);
}

/// microfft's recombination of the packed complex transform in `out[..256]` into the real one, in
/// place, Nyquist unpacked to `out[256]`: DC x0.re + x0.im, Nyquist x0.re − x0.im, bin 128 the
/// conjugate of x128, and for k in 1..128 from x_k and x_{256−k}, with sum = (x_k + x_{256−k})/2,
/// diff = (x_k − x_{256−k})/2 and the twiddle (tr, ti) = (−S[127 − k], S[k − 1]), S = `FFT_SINE_512`:
/// bin k = (sum.re + tr·sum.im + ti·diff.re, diff.im + ti·sum.im − tr·diff.re) and
/// bin 256 − k = (sum.re − tr·sum.im − ti·diff.re, −diff.im + ti·sum.im − tr·diff.re), each left to
/// right. k = 4…127 go four at a time ([`recombine4`]), k = 1, 2, 3 one at a time; each reads its
/// x_k, x_{256−k} before writing bins k, 256 − k in their place, and no two share a position.
fn recombine(out: &mut [Complex32; NUM_BINS]) {
    const L: usize = FFT_SINE_512.len();
    let x0 = out[0];
    out[0] = Complex32::new(x0.re + x0.im, 0.0);
    out[NUM_BINS - 1] = Complex32::new(x0.re - x0.im, 0.0);
    let u = POINTS / 2;
    out[u] = Complex32::new(out[u].re, -out[u].im);
    for g in 1..u / 4 {
        recombine4(out, 4 * g);
    }
    for k in 1..4 {
        let tr = -FFT_SINE_512[L - k];
        let ti = FFT_SINE_512[k - 1];
        let (xk, xnk) = (out[k], out[POINTS - k]);
        let sum = Complex32::new((xk.re + xnk.re) / 2.0, (xk.im + xnk.im) / 2.0);
        let diff = Complex32::new((xk.re - xnk.re) / 2.0, (xk.im - xnk.im) / 2.0);
        out[k] = Complex32::new(
            sum.re + tr * sum.im + ti * diff.re,
            diff.im + ti * sum.im - tr * diff.re,
        );
        out[POINTS - k] = Complex32::new(
            sum.re - tr * sum.im - ti * diff.re,
            -diff.im + ti * sum.im - tr * diff.re,
        );
    }
}

/// The bins k…k + 3 and 256 − k…253 − k of [`recombine`], in place, their real and imaginary parts
/// in separate vectors. With s = −tr = S[127 − k], tr·v is −(s·v) exactly (a product's sign is
/// that of its factors, its magnitude rounds the same), so adding it is subtracting s·v and
/// subtracting it adding s·v; −diff.im + p is p − diff.im.
// SAFETY: SSE2 is enabled on every x86_64 target; the intrinsics work on registers, apart from the
// loads of `load2`/`load4` and the stores of `store2`.
#[allow(unsafe_code)]
#[inline(always)]
fn recombine4(x: &mut [Complex32; NUM_BINS], k: usize) {
    const L: usize = FFT_SINE_512.len();
    // SAFETY: as of the function.
    unsafe {
        let half = _mm_set1_ps(0.5);
        // x_k … x_{k+3}, and x_{256−k} … x_{253−k}, split into re and im.
        let (a0, a1) = (load2(x, k), load2(x, k + 2));
        let (b0, b1) = (load2(x, POINTS - 3 - k), load2(x, POINTS - 1 - k));
        let a_re = _mm_shuffle_ps::<0b10_00_10_00>(a0, a1);
        let a_im = _mm_shuffle_ps::<0b11_01_11_01>(a0, a1);
        let b_re = _mm_shuffle_ps::<0b00_10_00_10>(b1, b0);
        let b_im = _mm_shuffle_ps::<0b01_11_01_11>(b1, b0);
        let sum_re = _mm_mul_ps(_mm_add_ps(a_re, b_re), half);
        let sum_im = _mm_mul_ps(_mm_add_ps(a_im, b_im), half);
        let diff_re = _mm_mul_ps(_mm_sub_ps(a_re, b_re), half);
        let diff_im = _mm_mul_ps(_mm_sub_ps(a_im, b_im), half);
        // s = S[127 − k…124 − k] (reversed load) and ti = S[k − 1…k + 2].
        let s = load4(&FFT_SINE_512, L - 3 - k);
        let s = _mm_shuffle_ps::<0b00_01_10_11>(s, s);
        let ti = load4(&FFT_SINE_512, k - 1);
        let (s_sum_im, ti_sum_im) = (_mm_mul_ps(s, sum_im), _mm_mul_ps(ti, sum_im));
        let (s_diff_re, ti_diff_re) = (_mm_mul_ps(s, diff_re), _mm_mul_ps(ti, diff_re));
        let k_re = _mm_add_ps(_mm_sub_ps(sum_re, s_sum_im), ti_diff_re);
        let k_im = _mm_add_ps(_mm_add_ps(diff_im, ti_sum_im), s_diff_re);
        let n_re = _mm_sub_ps(_mm_add_ps(sum_re, s_sum_im), ti_diff_re);
        let n_im = _mm_add_ps(_mm_sub_ps(ti_sum_im, diff_im), s_diff_re);
        store2(x, k, _mm_unpacklo_ps(k_re, k_im));
        store2(x, k + 2, _mm_unpackhi_ps(k_re, k_im));
        // Bins 256 − k, 255 − k and 254 − k, 253 − k, each pair stored in ascending order.
        let (n01, n23) = (_mm_unpacklo_ps(n_re, n_im), _mm_unpackhi_ps(n_re, n_im));
        store2(x, POINTS - 1 - k, _mm_shuffle_ps::<0b01_00_11_10>(n01, n01));
        store2(x, POINTS - 3 - k, _mm_shuffle_ps::<0b01_00_11_10>(n23, n23));
    }
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
                    // Overflow to ±inf and inf − inf in the butterflies.
                    4 => f32::MAX * [1.0, -1.0, 0.5][n % 3],
                    // Subnormal sums, products and halvings.
                    5 => 1e-40 * (((r >> 20) % 5) as f32 - 2.0),
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
