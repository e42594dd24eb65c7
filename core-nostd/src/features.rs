//! Features (thesis eq. 5.7): Y_c = |X_c| / |X_0| for the three cardioids at a picked bin.

use crate::reference_table::Feature;
use crate::CARDIOIDS;

/// Omni power below this (relative to nothing: the input is full-scale normalised) makes a bin unusable.
pub const MIN_OMNI_POWER: f32 = 1e-20;

/// Features from the powers |X_m|² of the four channels at one bin, or `None` when the omni bin is
/// (numerically) empty.
#[inline]
#[must_use]
pub fn feature_from_powers(omni_power: f32, cardioid_power: [f32; CARDIOIDS]) -> Option<Feature> {
    if !(omni_power > MIN_OMNI_POWER) || !omni_power.is_finite() {
        return None;
    }
    let inv = 1.0 / omni_power;
    let mut y = [0.0; CARDIOIDS];
    for (o, p) in y.iter_mut().zip(cardioid_power) {
        *o = crate::fast_math::sqrtf(p * inv);
    }
    if y.iter().all(|v| v.is_finite()) {
        Some(y)
    } else {
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratio_of_magnitudes() {
        let y = feature_from_powers(4.0, [4.0, 0.25, 1.0]).unwrap();
        assert_eq!(y, [1.0, 0.25, 0.5]);
        assert_eq!(feature_from_powers(0.0, [1.0; 3]), None);
        assert_eq!(feature_from_powers(f32::NAN, [1.0; 3]), None);
    }
}
