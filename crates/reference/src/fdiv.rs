//! Frequency-domain intensity vector baseline (thesis §5.2.2), as corrected in `docs/algorithm.md`:
//! per-bin B-format → active intensity I = Re{W*·(X, Y)} → one-pole smoothing of the *intensity*
//! per bin (x̃_l = (1 − a)·x_l + a·x̃_{l−1}; smoothing the complex B-format across 50 %-overlapping frames
//! would cancel itself) → intensity-weighted circular mean over the band: atan2(ΣĨ_y, ΣĨ_x).
//! The confidence is the mean resultant length |ΣĨ| / Σ|Ĩ| (circular concentration over bins).

use crate::angle::rad_to_deg;
use crate::bformat::{intensity, xy_complex};
use crate::tdiv::IvEstimate;
use crate::{CHANNELS, NUM_BINS};
use microfft::Complex32;

/// Per-bin smoothed intensity.
#[derive(Debug, Clone)]
pub struct FdivState {
    smoothed: [[f32; 2]; NUM_BINS],
}

impl Default for FdivState {
    fn default() -> Self {
        Self::new()
    }
}

impl FdivState {
    /// Zero history.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            smoothed: [[0.0; 2]; NUM_BINS],
        }
    }
}

/// FDIV over bins `lo..=hi` with smoothing pole `pole`.
pub fn fdiv_process(
    pole: f32,
    state: &mut FdivState,
    spectra: &[[Complex32; NUM_BINS]; CHANNELS],
    lo: usize,
    hi: usize,
) -> IvEstimate {
    let (mut sx, mut sy, mut rx, mut ry, mut mag) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for k in lo..=hi.min(NUM_BINS - 1) {
        let w = spectra[0][k];
        let [x, y] = xy_complex([spectra[1][k], spectra[2][k], spectra[3][k]]);
        let i = intensity(w, x, y);
        let s = &mut state.smoothed[k];
        s[0] = (1.0 - pole) * i[0] + pole * s[0];
        s[1] = (1.0 - pole) * i[1] + pole * s[1];
        sx += s[0];
        sy += s[1];
        rx += i[0];
        ry += i[1];
        mag += crate::fast_math::sqrtf(s[0] * s[0] + s[1] * s[1]);
    }
    let conf = if mag > 0.0 {
        (crate::fast_math::sqrtf(sx * sx + sy * sy) / mag).clamp(0.0, 1.0)
    } else {
        0.0
    };
    IvEstimate {
        azimuth_deg: rad_to_deg(libm::atan2f(sy, sx)),
        azimuth_raw_deg: rad_to_deg(libm::atan2f(ry, rx)),
        confidence: conf,
    }
}
