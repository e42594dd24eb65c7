//! Time-domain intensity vector baseline (thesis §5.2.1): frame RMS of the cardioids → B-format
//! (eq. 5.38) → one-pole smoothing (eq. 5.40) → atan2 (eq. 5.41).

use crate::angle::rad_to_deg;
use crate::bformat::wxy_real;
use crate::{CHANNELS, FRAME_LEN};

/// Output of an intensity-vector method for one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IvEstimate {
    /// Smoothed azimuth, degrees.
    pub azimuth_deg: f32,
    /// Azimuth of this frame alone, degrees.
    pub azimuth_raw_deg: f32,
    /// Directness ∈ [0, 1] (1 for a single plane wave).
    pub confidence: f32,
}

/// TDIV state: the smoothed (W, X, Y).
#[derive(Debug, Clone, Copy, Default)]
pub struct TdivState {
    smoothed: [f32; 3],
}

impl TdivState {
    /// Zeroed state.
    #[must_use]
    pub const fn new() -> Self {
        Self { smoothed: [0.0; 3] }
    }
}

/// TDIV with smoothing pole `pole` (thesis: 0.9 for ≈ 50 ms frames).
pub fn tdiv_process(
    pole: f32,
    state: &mut TdivState,
    frame: &[[f32; FRAME_LEN]; CHANNELS],
) -> IvEstimate {
    let mut rms = [0.0f32; 3];
    for (r, ch) in rms.iter_mut().zip(frame[1..].iter()) {
        let p: f32 = ch.iter().map(|v| v * v).sum::<f32>() / FRAME_LEN as f32;
        *r = crate::fast_math::sqrtf(p);
    }
    let b = wxy_real(rms);
    for (s, v) in state.smoothed.iter_mut().zip(b) {
        *s = (1.0 - pole) * v + pole * *s;
    }
    let [w, x, y] = state.smoothed;
    let conf = if w > 0.0 {
        (crate::fast_math::sqrtf(x * x + y * y) / w).clamp(0.0, 1.0)
    } else {
        0.0
    };
    IvEstimate {
        azimuth_deg: rad_to_deg(libm::atan2f(y, x)),
        azimuth_raw_deg: rad_to_deg(libm::atan2f(b[2], b[1])),
        confidence: conf,
    }
}
