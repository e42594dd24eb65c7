//! Sine and cosine in single precision for the angles the pipeline uses (a few turns at most).
//!
//! `libm::sinf`/`cosf` reduce any argument exactly, which pulls a multi-precision reduction and
//! double-precision software arithmetic into a Cortex-M4F image (about 9 KB of flash). The angles
//! here are directions and steering angles, within a few turns, so a three-part Cody–Waite
//! reduction by π/2 in `f32` is exact enough, followed by minimax polynomials on [−π/4, π/4]
//! (Cephes `sinf`/`cosf`): within 2 ulp of the correctly rounded value for |x| ≤ 10⁴, and the
//! same bits on every target (plain `f32` arithmetic).

/// π/2 in three parts; the first two have 8 and 11 significant bits, so that `k`·part is exact
/// for |k| < 2¹³ (|x| up to about 12 000), the third carries the rest.
const PIO2_1: f32 = 1.570_312_5;
const PIO2_2: f32 = 4.837_513e-4;
const PIO2_3: f32 = 7.549_79e-8;

/// Sine and cosine of `x` (radians): `(sin x, cos x)`; NaN for a non-finite `x`. Accurate for
/// |x| ≤ 10⁴ (see the module documentation); beyond, still a point of the unit circle.
#[must_use]
pub fn sin_cos(x: f32) -> (f32, f32) {
    if !x.is_finite() {
        return (f32::NAN, f32::NAN);
    }
    // Far outside the working range the reduction below would lose every bit (and overflow):
    // bring such an argument within a turn first (the result is then a sine and cosine of some
    // angle, as good as the argument's own precision allows).
    let x = if x.abs() > 1.0e5 {
        libm::fmodf(x, core::f32::consts::TAU)
    } else {
        x
    };
    // Nearest multiple of π/2 (round half away from zero).
    let k = x * core::f32::consts::FRAC_2_PI;
    let k = if k >= 0.0 {
        (k + 0.5) as i32
    } else {
        (k - 0.5) as i32
    };
    let kf = k as f32;
    let r = ((x - kf * PIO2_1) - kf * PIO2_2) - kf * PIO2_3;
    let z = r * r;
    let s = ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1) * z * r + r;
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    match k & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Cosine of `x` (radians), as [`sin_cos`].
#[must_use]
pub fn cos(x: f32) -> f32 {
    sin_cos(x).1
}

/// Sine of `x` (radians), as [`sin_cos`].
#[must_use]
pub fn sin(x: f32) -> f32 {
    sin_cos(x).0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Distance in units of the last place of the exact value.
    fn ulps(got: f32, want: f64) -> f64 {
        let w = want as f32;
        let ulp = (f32::from_bits(w.abs().to_bits() + 1) - w.abs()) as f64;
        // Near zero the absolute error matters: measure it in the ulp of 1e-7.
        ((got as f64 - want).abs() / ulp.max(1e-7 * f64::from(f32::EPSILON))).min(1e9)
    }

    #[test]
    fn agrees_with_double_precision_over_the_working_range() {
        let mut worst = 0.0f64;
        let mut worst_abs = 0.0f64;
        for i in -200_000..=200_000 {
            let x = i as f32 * 0.05;
            let (s, c) = sin_cos(x);
            let (ws, wc) = (f64::from(x).sin(), f64::from(x).cos());
            worst_abs = worst_abs.max((f64::from(s) - ws).abs().max((f64::from(c) - wc).abs()));
            if ws.abs() > 1e-3 {
                worst = worst.max(ulps(s, ws));
            }
            if wc.abs() > 1e-3 {
                worst = worst.max(ulps(c, wc));
            }
        }
        assert!(worst <= 2.0, "worst {worst} ulp");
        assert!(worst_abs < 1e-6, "worst absolute error {worst_abs}");
    }

    #[test]
    fn quadrants_and_special_values() {
        assert_eq!(sin_cos(0.0), (0.0, 1.0));
        let (s, c) = sin_cos(core::f32::consts::FRAC_PI_2);
        assert!((s - 1.0).abs() < 1e-7 && c.abs() < 1e-7);
        let (s, c) = sin_cos(-core::f32::consts::PI);
        assert!(s.abs() < 1e-6 && (c + 1.0).abs() < 1e-7);
        assert!(sin(f32::NAN).is_nan() && cos(f32::INFINITY).is_nan());
        for x in [1.0e5f32, -3.0e7, 1.0e30, -f32::MAX] {
            let (s, c) = sin_cos(x);
            assert!((s * s + c * c - 1.0).abs() < 1e-5, "{x}: {s} {c}");
        }
        assert_eq!(cos(1.0), sin_cos(1.0).1);
        assert_eq!(sin(1.0), sin_cos(1.0).0);
    }
}
