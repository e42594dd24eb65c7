//! # cma-localization — similarity localization of one analysis frame
//!
//! The similarity approach (thesis §5.1) from the peaks to the frame's curve and its reliability:
//! [`reference_table`] (reference features in flash, ideal model or measured; [`embedded_table`]
//! for a table built in with `CMA_TABLE`), [`noisy_reference`] (reference features mixed with omni
//! noise, eq. 5.16–5.20), [`similarity`] (Euclidean / cosine / L_p similarity and the mean curve;
//! settings [`similarity::CurveSettings`]) with [`curve_kernel`] (the per-peak term),
//! [`reliability`] (curve-variance confidence b, eq. 5.31; settings
//! [`reliability::Reliability`]) or the thesis's [`frame_quality`] (§5.1.6, with the
//! `thesis-options` feature), [`frame_onset`] (onset weight of b; settings
//! [`frame_onset::FrameOnset`]) and [`interpolation`] (wrapped argmax, eq. 4.23–4.29).
//!
//! [`similarity_frame`] runs them on one frame, with the self-calibration's correction of the
//! cardioids and the background field of `cma-calibration` (settings
//! [`similarity_frame::SimilaritySettings`]).
#![no_std]
#![deny(clippy::float_cmp_const)]

pub mod curve_kernel;
pub mod embedded_table;
pub mod frame_onset;
pub mod frame_quality;
pub mod interpolation;
pub mod noisy_reference;
pub mod reference_table;
pub mod reliability;
pub mod similarity;
pub mod similarity_frame;
pub mod tables;

// The modules of the lower crates the stages name at this crate's root.
use cma_analysis::{direct_sound, features, peak_picker, power_ramp};
use cma_calibration::{background_field, capsule_calibration};
#[cfg(test)]
use cma_dsp::test_rng;
use cma_dsp::{angle, error, estimate, fast_math, frame_spectra, spectrum};
use cma_dsp::{
    CARDIOIDS, CHANNELS, FRAME_LEN, HOP, MAX_AZIMUTHS, MAX_PEAKS, MAX_SNR_SETS, NUM_BINS,
};
