//! The core localizer run over a recording block by block, and the beamformer steered by it.

pub mod analysis_rate;
pub mod beam;
pub mod frame_estimates;
