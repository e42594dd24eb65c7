//! # cma-tracking — tracking over analysis frames
//!
//! The similarity curves of the frames become the reported azimuth in [`curve_tracker`] (settings
//! [`curve_tracker::Tracking`]): the thesis's one-pole filter on the curve or the product's
//! Bayesian [`grid_tracker`] (settings [`grid_tracker::GridTracker`]), which places its estimate
//! between grid points with [`running_curve`] and [`refine_curve`] and follows a moving talker
//! through his pauses with [`motion_fit`]. Several talkers at once:
//! [`multi_track`] (tracks with persistent IDs; settings [`multi_track::MultiTrack`]), reported
//! over whole utterances a fixed time late by [`track_spans`].
#![no_std]
#![deny(clippy::float_cmp_const)]

pub mod curve_tracker;
pub mod grid_tracker;
pub mod motion_fit;
pub mod multi_track;
pub mod refine_curve;
pub mod running_curve;
pub mod track_spans;

// The modules of the lower crates the stages name at this crate's root.
#[cfg(test)]
use cma_dsp::test_rng;
use cma_dsp::MAX_AZIMUTHS;
use cma_dsp::{angle, bformat, estimate, fast_exp, fast_math, trig};
use cma_localization::{curve_kernel, interpolation, reliability, similarity};
