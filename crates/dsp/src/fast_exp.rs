//! e^x for x ≤ 0 in about 20 instructions on the Cortex-M4F (libm's `expf` takes about twice as
//! many plus a `scalbnf` call): the grid tracker's likelihood needs 72 of them per reliable frame.
//!
//! e^x = 2^t with t = x·log₂e = n + f, n = round(t), |f| ≤ ½; 2^f from Cephes' `exp2f` polynomial
//! (degree 6, relative error ≈ 2·10⁻⁷ on [−½, ½]) and 2ⁿ built from its exponent bits. Only plain
//! f32 multiplies and adds (never fused), so every target gives the same bits.

/// Cephes `exp2f` coefficients, highest degree first: 2^f ≈ 1 + f·P(f).
const P: [f32; 6] = [
    1.535_336_2e-4,
    1.339_887_4e-3,
    9.618_438e-3,
    5.550_332_5e-2,
    2.402_264_8e-1,
    6.931_472e-1,
];

/// e^x for x ≤ 0: relative error below 6·10⁻⁷ for x ≥ −10 and below 4·10⁻⁶ down to −87 (from the
/// rounding of x·log₂e); positive x count as 0 (result 1), x < −87 gives 0, NaN gives NaN.
#[inline]
#[must_use]
pub fn exp_nonpositive(x: f32) -> f32 {
    if !(x >= -87.0) {
        return if x.is_nan() { x } else { 0.0 };
    }
    let x = if x > 0.0 { 0.0 } else { x };
    let t = x * core::f32::consts::LOG2_E;
    // t ∈ [−125.6, 0]: truncating t − ½ toward zero rounds t to the nearest integer n ∈ [−126, 0].
    let n = (t - 0.5) as i32;
    let f = t - n as f32;
    let mut p = P[0];
    for c in &P[1..] {
        p = p * f + c;
    }
    let two_f = p * f + 1.0;
    two_f * f32::from_bits(((n + 127) as u32) << 23)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_f64_exp() {
        let mut worst_near = 0.0f64;
        let mut worst_far = 0.0f64;
        for i in 0..=870_000 {
            let x = -(i as f32) * 1e-4;
            let e = (x as f64).exp();
            let rel = ((exp_nonpositive(x) as f64) - e).abs() / e;
            if x >= -10.0 {
                worst_near = worst_near.max(rel);
            } else {
                worst_far = worst_far.max(rel);
            }
        }
        assert!(worst_near < 6e-7, "{worst_near}");
        assert!(worst_far < 4e-6, "{worst_far}");
    }

    #[test]
    fn edges() {
        assert_eq!(exp_nonpositive(0.0), 1.0);
        assert_eq!(exp_nonpositive(-0.0), 1.0);
        assert_eq!(exp_nonpositive(3.0), 1.0);
        assert_eq!(exp_nonpositive(-87.5), 0.0);
        assert_eq!(exp_nonpositive(f32::NEG_INFINITY), 0.0);
        assert!(exp_nonpositive(f32::NAN).is_nan());
        assert!(exp_nonpositive(-86.9) > 0.0);
    }
}
