//! Filtering of the *result* in Cartesian coordinates (thesis eq. 5.30), the alternative to filtering
//! the similarity curve (eq. 5.31): the frame's azimuth estimate φ̂_l becomes the unit vector
//! P̂_l = (cos φ̂_l, sin φ̂_l) and P̃_l = b_l·P̂_l + (1 − b_l)·P̃_{l−1}; the output azimuth is
//! atan2(P̃_y, P̃_x). Averaging unit vectors rather than angles avoids the ±180° wrap error.

/// Where the reliability coefficient b acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Smoothing {
    /// One-pole filter on the similarity curve (eq. 5.31) — the thesis's choice and the default.
    Curve,
    /// One-pole filter on the frame estimate's unit vector (eq. 5.30).
    Cartesian,
}

/// State of the eq. 5.30 filter.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct CartesianFilter {
    p: [f32; 2],
}

impl CartesianFilter {
    /// A filter with no history (P̃ = 0).
    #[must_use]
    pub const fn new() -> Self {
        Self { p: [0.0; 2] }
    }

    /// P̃ ← b·(cos φ̂, sin φ̂) + (1 − b)·P̃; returns the filtered azimuth in degrees, or `None` while
    /// P̃ is still zero (no reliable frame seen). Non-finite inputs leave the state unchanged.
    pub fn update(&mut self, b: f32, azimuth_deg: f32) -> Option<f32> {
        if b.is_finite() && azimuth_deg.is_finite() {
            let b = b.clamp(0.0, 1.0);
            let a = azimuth_deg.to_radians();
            let (s, c) = crate::trig::sin_cos(a);
            self.p[0] = b * c + (1.0 - b) * self.p[0];
            self.p[1] = b * s + (1.0 - b) * self.p[1];
        }
        self.current()
    }

    /// The filtered azimuth in degrees, `None` without history.
    #[must_use]
    pub fn current(&self) -> Option<f32> {
        if self.p[0] == 0.0 && self.p[1] == 0.0 {
            None
        } else {
            Some(libm::atan2f(self.p[1], self.p[0]).to_degrees())
        }
    }

    /// Length of P̃ (≈ 1 after a run of consistent, reliable frames).
    #[must_use]
    pub fn resultant_length(&self) -> f32 {
        libm::sqrtf(self.p[0] * self.p[0] + self.p[1] * self.p[1])
    }

    /// Forgets the history.
    pub fn reset(&mut self) {
        self.p = [0.0; 2];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn averages_across_the_wrap_and_holds_on_b_zero() {
        let mut f = CartesianFilter::new();
        assert_eq!(f.current(), None);
        assert_eq!(f.update(0.0, 10.0), None);
        let a = f.update(1.0, 170.0).unwrap();
        assert!((a - 170.0).abs() < 1e-4);
        // equal weight of 170° and −170° is 180°, not 0° (the error an angle average would make)
        let a = f.update(0.5, -170.0).unwrap();
        assert!((a.abs() - 180.0).abs() < 1e-3, "{a}");
        let held = f.update(0.0, 0.0).unwrap();
        assert!((held - a).abs() < 1e-6);
        assert_eq!(f.update(f32::NAN, 5.0).unwrap(), held);
        f.reset();
        assert_eq!(f.current(), None);
    }
}
