//! # cma-reference — the thesis's further options and the baselines
//!
//! Linked only where they are used (the host programs; `cma-core` runs them with its
//! `thesis-options` feature): the intensity-vector baselines [`tdiv`] and [`fdiv`] behind one stage,
//! [`intensity`] (settings [`intensity::IntensitySettings`]); the thesis's options
//! [`combination`] (rule 2, eq. 5.13; FDIV spread), [`cartesian_filter`] (eq. 5.30) and
//! [`alternative_result`], which applies them to the similarity method's result; and the host-side
//! studies [`beamformer`] (self-steered first-order beam, §3.3) and [`distance`].
#![no_std]
#![deny(clippy::float_cmp_const)]

pub mod alternative_result;
pub mod beamformer;
pub mod cartesian_filter;
pub mod combination;
pub mod distance;
pub mod fdiv;
pub mod intensity;
pub mod tdiv;

// The modules of the lower crates the stages name at this crate's root.
#[cfg(test)]
use cma_analysis::features;
use cma_analysis::peak_picker;
use cma_dsp::{angle, bformat, estimate, fast_math, frame_spectra, spectrum, trig};
use cma_dsp::{CARDIOID_LOOK_DEG, CHANNELS, FRAME_LEN, MAX_AZIMUTHS, MAX_PEAKS, NUM_BINS};
#[cfg(test)]
use cma_localization::noisy_reference;
use cma_localization::{interpolation, reference_table, similarity, similarity_frame};
