//! Angle helpers: wrapping (princarg, thesis eq. 2.31) and conversions.

/// Wraps an angle in degrees to (−180, 180].
#[must_use]
pub fn wrap_deg(a: f32) -> f32 {
    if a > -180.0 && a <= 180.0 {
        // Already wrapped (the common case): what the general path returns, without `fmodf`.
        return a;
    }
    if !a.is_finite() {
        return 0.0;
    }
    let mut x = libm::fmodf(a, 360.0);
    if x <= -180.0 {
        x += 360.0;
    } else if x > 180.0 {
        x -= 360.0;
    }
    x
}

/// Wraps an angle in degrees to [0, 360).
#[must_use]
pub fn wrap_deg_360(a: f32) -> f32 {
    let x = wrap_deg(a);
    if x < 0.0 {
        x + 360.0
    } else {
        x
    }
}

/// Degrees to radians.
#[must_use]
pub fn deg_to_rad(a: f32) -> f32 {
    a * (core::f32::consts::PI / 180.0)
}

/// Radians to degrees.
#[must_use]
pub fn rad_to_deg(a: f32) -> f32 {
    a * (180.0 / core::f32::consts::PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wraps_into_half_open_interval() {
        assert_eq!(wrap_deg(180.0), 180.0);
        assert_eq!(wrap_deg(-180.0), 180.0);
        assert_eq!(wrap_deg(190.0), -170.0);
        assert_eq!(wrap_deg(-190.0), 170.0);
        assert_eq!(wrap_deg(720.0 + 5.0), 5.0);
        assert_eq!(wrap_deg(f32::NAN), 0.0);
        assert_eq!(wrap_deg_360(-10.0), 350.0);
    }

    #[test]
    fn fast_path_equals_the_fmod_path() {
        let general = |a: f32| {
            let mut x = libm::fmodf(a, 360.0);
            if x <= -180.0 {
                x += 360.0;
            } else if x > 180.0 {
                x -= 360.0;
            }
            x
        };
        for i in -200_000..=200_000 {
            let a = i as f32 * 0.0017;
            assert_eq!(wrap_deg(a).to_bits(), general(a).to_bits(), "{a}");
        }
        for a in [-0.0f32, 0.0, 180.0, -179.99999, f32::MIN_POSITIVE, -1e-30] {
            assert_eq!(wrap_deg(a).to_bits(), general(a).to_bits(), "{a}");
        }
    }
}
