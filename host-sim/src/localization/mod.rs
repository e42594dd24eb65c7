//! The core localizer run over a recording block by block, and the beamformer steered by it.

pub mod beam;
pub mod frame_estimates;
