//! # cma-calibration — self-calibration of the cardioids and the background field
//!
//! Learned from the frames' spectra between talkers: [`capsule_calibration`] (the blind
//! self-calibration of the cardioids from the diffuse background and the correction it applies to
//! the features; settings [`capsule_calibration::CapsuleCalibration`]), checked against the
//! talker's own sound by [`speech_check`], and [`background_field`]
//! (the measured stationary background, the noise-field report; settings
//! [`background_field::BackgroundField`]), both on the per-band floors of [`band_floors`].
#![no_std]
#![deny(clippy::float_cmp_const)]

pub mod background_field;
pub mod band_floors;
pub mod capsule_calibration;
pub mod speech_check;

// The modules of the lower crates the stages name at this crate's root.
use cma_analysis::{features, noise_floor, power_ramp};
use cma_dsp::{bformat, fast_math, spectrum, trig};
#[cfg(test)]
use cma_dsp::{tables, test_rng, HOP};
use cma_dsp::{CARDIOIDS, FRAME_LEN, NUM_BINS};
