//! # cma-analysis — spectral analysis of each analysis frame
//!
//! On the frame's spectra (`cma-dsp`'s [`cma_dsp::spectrum`]): [`peak_picker`] (the N_p
//! strongest peaks of |X_omni| in a band, thesis §5.1.2, with the fill rule; settings
//! [`peak_picker::PeakSettings`]), [`features`] (|X_card| / |X_omni| at the peaks, eq. 5.7),
//! [`direct_sound`] (the direct-sound weights of the peaks; settings [`direct_sound::DirectSound`]),
//! and the frame's background level: [`noise_floor`] (the noise-floor gate; settings
//! [`noise_floor::NoiseGate`]) with [`power_ramp`].
#![no_std]
#![deny(clippy::float_cmp_const)]

pub mod direct_sound;
pub mod features;
pub mod noise_floor;
pub mod peak_picker;
pub mod power_ramp;

// The modules of `cma-dsp` the stages name at this crate's root.
#[cfg(test)]
use cma_dsp::test_rng;
use cma_dsp::{bformat, fast_math, spectrum};
use cma_dsp::{CARDIOIDS, FRAME_LEN, MAX_PEAKS, NUM_BINS};
