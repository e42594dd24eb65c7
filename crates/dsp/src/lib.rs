//! # cma-dsp — the arithmetic, records and spectral transform under every stage
//!
//! The bottom of the `cma-core` localizer's crates (no stage of its own): the sizes of the array
//! and of the analysis frame, bit-reproducible arithmetic ([`angle`], [`fast_exp`], [`fast_math`],
//! [`trig`]; `libm` only, so host and Cortex-M give the same bits), the records every stage speaks
//! ([`estimate::Estimate`], [`estimate::Flags`], [`error::Error`]), the eigenbeams of the array
//! ([`bformat`]), and the spectral transform: [`spectrum`] (Hamming window from a table, `microfft`
//! real FFT, direct DFT at picked bins) and [`frame_spectra`] (the spectra of one analysis frame).
//!
//! "Frame" has two meanings here, as in the literature: a *sample frame* is one instant across the
//! four channels (`[f32; 4]`), an *analysis frame* is a block of [`FRAME_LEN`] samples per channel.
#![no_std]
#![deny(clippy::float_cmp_const)]

pub mod angle;
pub mod bformat;
pub mod error;
pub mod estimate;
pub mod fast_exp;
pub mod fast_math;
#[cfg(target_arch = "x86_64")]
mod fft_x86;
pub mod frame_spectra;
pub mod spectrum;
pub mod tables;
#[doc(hidden)]
pub mod test_rng;
pub mod trig;

/// Number of input channels: omni, cardioid 0°, cardioid 120°, cardioid 240°.
pub const CHANNELS: usize = 4;
/// Number of cardioid channels (the feature dimension).
pub const CARDIOIDS: usize = 3;
/// Analysis frame length in samples at the analysis rate (thesis §5.1.1: the power of two ≤ 50 ms).
pub const FRAME_LEN: usize = 512;
/// Hop between analysis frames in samples at the analysis rate (50 % overlap).
pub const HOP: usize = FRAME_LEN / 2;
/// Number of spectral bins of a frame, DC to Nyquist inclusive.
pub const NUM_BINS: usize = FRAME_LEN / 2 + 1;
/// Largest number of spectral peaks per frame (the peak picker's `num_peaks`).
pub const MAX_PEAKS: usize = 32;
/// Largest number of azimuths in a reference table (a 1° grid).
pub const MAX_AZIMUTHS: usize = 360;
/// Largest number of SNR sets of the noisy reference features.
pub const MAX_SNR_SETS: usize = 16;
/// Look directions of the three cardioids, degrees counter-clockwise from cardioid 1.
pub const CARDIOID_LOOK_DEG: [f32; CARDIOIDS] = [0.0, 120.0, 240.0];
