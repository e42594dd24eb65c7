//! Localization: reference tables, noisy references, the similarity curve (one frame of the similarity method: [`similarity_frame`]), its reliability and the interpolated argmax.

pub mod curve_kernel;
pub mod embedded_table;
pub mod frame_onset;
pub mod interpolation;
pub mod noise_floor;
pub mod noisy_reference;
pub mod power_ramp;
pub mod reference_table;
pub mod reliability;
pub mod similarity;
pub mod similarity_frame;
pub mod tables;
