//! Direct-sound emphasis: weights for peaks (and frames) that favour the direct sound over
//! reverberation and diffuse noise. Not in the thesis; switchable and measured against it.
//!
//! * **Directness** of a bin: the first-order sound field at one time–frequency bin is a plane wave
//!   exactly when the active intensity carries all of the energy, |I| = E with
//!   I = Re{W*·(X, Y)} and E = ½(|W|² + |X|² + |Y|²). δ = |I| / E ∈ [0, 1] falls as reflections and
//!   diffuse sound mix in. The weight is δ^γ.
//! * **Onset** of a bin: direct sound arrives first, so bins whose power has just risen above their
//!   recent average carry more of it. With P̄ the one-pole average of the bin's past power, the
//!   weight is max(w_min, 1 − P̄/P)·… raised to the configured strength.

use crate::bformat::{intensity, xy_complex};
use crate::NUM_BINS;
use microfft::Complex32;

/// Direct-sound weighting settings.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct DirectSound {
    /// Exponent γ of the directness weight (0 disables it).
    pub directness_exponent: f32,
    /// Exponent of the onset weight (0 disables it).
    pub onset_exponent: f32,
    /// Pole of the per-bin power average used by the onset weight, per hop.
    pub onset_pole: f32,
    /// Smallest onset weight (keeps steady vowels from vanishing entirely).
    pub onset_floor: f32,
}

impl DirectSound {
    /// No weighting: the thesis method.
    pub const OFF: DirectSound = DirectSound {
        directness_exponent: 0.0,
        onset_exponent: 0.0,
        onset_pole: 0.7,
        onset_floor: 0.1,
    };

    /// `true` for exponents ≥ 0, 0 ≤ pole < 1 and 0 ≤ floor ≤ 1.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.directness_exponent >= 0.0
            && self.onset_exponent >= 0.0
            && (0.0..1.0).contains(&self.onset_pole)
            && (0.0..=1.0).contains(&self.onset_floor)
    }

    /// `true` when any weight is active.
    #[must_use]
    pub fn enabled(&self) -> bool {
        self.directness_exponent > 0.0 || self.onset_exponent > 0.0
    }

    /// Directness δ ∈ [0, 1] of one bin from the omni (W) and the three cardioid spectra.
    #[must_use]
    pub fn directness(w: Complex32, cardioids: [Complex32; 3]) -> f32 {
        let [x, y] = xy_complex(cardioids);
        let i = intensity(w, x, y);
        let e = 0.5 * (w.norm_sqr() + x.norm_sqr() + y.norm_sqr());
        if e > 0.0 {
            (crate::fast_math::sqrtf(i[0] * i[0] + i[1] * i[1]) / e).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// Weight of a peak at bin `k` with omni power `p`, directness `delta`, given the onset state.
    #[must_use]
    pub fn peak_weight(&self, state: &OnsetState, k: usize, p: f32, delta: f32) -> f32 {
        let mut w = 1.0;
        if self.directness_exponent > 0.0 {
            w *= pow_weight(delta, self.directness_exponent);
        }
        if self.onset_exponent > 0.0 {
            let avg = state.avg[k];
            let rise = if p > 0.0 { 1.0 - avg / p } else { 0.0 };
            w *= pow_weight(rise.max(self.onset_floor), self.onset_exponent);
        }
        w
    }
}

/// `x^e` for a weight base `x` in [0, 1]: `x` itself for `e` = 1 (what `libm::powf` returns there,
/// without its ≈ 25 instructions on the Cortex-M4F; tested), else `libm::powf`.
#[inline]
fn pow_weight(x: f32, e: f32) -> f32 {
    if e == 1.0 {
        x
    } else {
        libm::powf(x, e)
    }
}

/// Per-bin power history for the onset weight.
#[derive(Debug, Clone)]
pub struct OnsetState {
    avg: [f32; NUM_BINS],
}

impl Default for OnsetState {
    fn default() -> Self {
        Self::new()
    }
}

impl OnsetState {
    /// Empty history.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            avg: [0.0; NUM_BINS],
        }
    }

    /// Folds this frame's omni power spectrum into the average (after the weights were taken),
    /// for the bins `lo..=hi` only (the peak picker's band: no other bin is ever weighted).
    pub fn update(&mut self, pole: f32, power: &[f32; NUM_BINS], lo: usize, hi: usize) {
        let hi = hi.min(NUM_BINS - 1);
        if lo > hi {
            return;
        }
        for (a, p) in self.avg[lo..=hi].iter_mut().zip(&power[lo..=hi]) {
            *a = pole * *a + (1.0 - pole) * p;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exponent-1 shortcut is `libm::powf` bit for bit on weight bases: every float in [2⁻²⁰, 1]
    /// with a stride, 0, and the onset floor.
    #[test]
    fn unit_exponent_equals_powf() {
        let mut bits = (2.0f32.powi(-20)).to_bits();
        while bits <= 1.0f32.to_bits() {
            let x = f32::from_bits(bits);
            assert_eq!(
                pow_weight(x, 1.0).to_bits(),
                libm::powf(x, 1.0).to_bits(),
                "{x}"
            );
            bits += 97;
        }
        for x in [0.0f32, 0.1, 1.0] {
            assert_eq!(pow_weight(x, 1.0).to_bits(), libm::powf(x, 1.0).to_bits());
            assert_eq!(pow_weight(x, 0.5).to_bits(), libm::powf(x, 0.5).to_bits());
        }
    }

    #[test]
    fn plane_wave_is_fully_direct() {
        let s = Complex32::new(0.3, -0.7);
        for az in [10.0f32, 133.0, 250.0] {
            let a = az.to_radians();
            let c: [Complex32; 3] = core::array::from_fn(|m| {
                s * (0.5 + 0.5 * (a - (m as f32 * 120.0).to_radians()).cos())
            });
            assert!((DirectSound::directness(s, c) - 1.0).abs() < 1e-5);
        }
        // Two equal waves from opposite sides: the intensity cancels.
        let c: [Complex32; 3] = core::array::from_fn(|m| {
            let g0 = 0.5 + 0.5 * (0f32 - (m as f32 * 120.0).to_radians()).cos();
            let g1 = 0.5 + 0.5 * (core::f32::consts::PI - (m as f32 * 120.0).to_radians()).cos();
            s * g0 + Complex32::new(0.0, 1.0) * s * g1
        });
        let w = s + Complex32::new(0.0, 1.0) * s;
        assert!(DirectSound::directness(w, c) < 0.05);
    }
}
