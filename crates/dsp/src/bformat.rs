//! Eigenbeam matrixing of CMA1 (thesis eq. 3.19–3.23): cardioids c_m = ½W + ½(X cos φ_m + Y sin φ_m)
//! at φ_m = 0°, 120°, 240° give W = ⅔·Σc_m, X = ⁴⁄₃·Σc_m cos φ_m, Y = ⁴⁄₃·Σc_m sin φ_m.

use microfft::Complex32;

/// cos φ_m of the three cardioids.
pub const COS_LOOK: [f32; 3] = [1.0, -0.5, -0.5];
/// sin φ_m of the three cardioids.
pub const SIN_LOOK: [f32; 3] = [0.0, 0.866_025_4, -0.866_025_4];

/// (W, X, Y) of real cardioid values (e.g. RMS levels).
#[inline]
#[must_use]
pub fn wxy_real(c: [f32; 3]) -> [f32; 3] {
    let w = (2.0 / 3.0) * (c[0] + c[1] + c[2]);
    let x = (4.0 / 3.0) * (c[0] * COS_LOOK[0] + c[1] * COS_LOOK[1] + c[2] * COS_LOOK[2]);
    let y = (4.0 / 3.0) * (c[0] * SIN_LOOK[0] + c[1] * SIN_LOOK[1] + c[2] * SIN_LOOK[2]);
    [w, x, y]
}

/// (X, Y) figure-of-eight spectra of complex cardioid bins.
#[inline]
#[must_use]
pub fn xy_complex(c: [Complex32; 3]) -> [Complex32; 2] {
    let mut x = Complex32::new(0.0, 0.0);
    let mut y = Complex32::new(0.0, 0.0);
    for m in 0..3 {
        x += c[m] * COS_LOOK[m];
        y += c[m] * SIN_LOOK[m];
    }
    [x * (4.0 / 3.0), y * (4.0 / 3.0)]
}

/// The plane vector Σ_m c_m·(cos φ_m, sin φ_m) of three cardioid values (e.g. a peak's active
/// ratios: ¾ times the unit vector of one plane wave's direction); ¾ of [`wxy_real`]'s (X, Y).
#[inline]
#[must_use]
pub fn plane_vector(c: [f32; 3]) -> (f32, f32) {
    (c[0] - 0.5 * (c[1] + c[2]), SIN_LOOK[1] * (c[1] - c[2]))
}

/// Active intensity components (Re{W*·X}, Re{W*·Y}) of one bin (eq. 4.33).
#[inline]
#[must_use]
pub fn intensity(w: Complex32, x: Complex32, y: Complex32) -> [f32; 2] {
    [w.re * x.re + w.im * x.im, w.re * y.re + w.im * y.im]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plane_wave_matrixes_to_unit_bformat() {
        for az in [0.0f32, 30.0, 100.0, 200.0, 300.0] {
            let a = az.to_radians();
            let c: [f32; 3] =
                core::array::from_fn(|m| 0.5 + 0.5 * (a - (m as f32 * 120.0).to_radians()).cos());
            let [w, x, y] = wxy_real(c);
            assert!((w - 1.0).abs() < 1e-6);
            assert!((x - a.cos()).abs() < 1e-6 && (y - a.sin()).abs() < 1e-6);
        }
    }
}
