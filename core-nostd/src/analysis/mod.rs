//! Analysis of each frame: level and gate, spectra, peak picking, the cardioid correction of the self-calibration, features and the direct-sound weights of the peaks.

pub mod background_field;
pub mod band_floors;
pub mod capsule_calibration;
pub mod direct_sound;
pub mod features;
#[cfg(target_arch = "x86_64")]
pub(crate) mod fft_x86;
pub mod frame_level;
pub mod frame_spectra;
pub mod peak_picker;
pub mod spectrum;
