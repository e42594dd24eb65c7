//! # cma-formats — the wire and file formats of the localizer
//!
//! What the firmware sends and the host programs read and write, for any program that speaks them
//! (it needs no localizer): [`wire`] (the serial lines: estimates, calibration, background field,
//! talker tracks; framing and CRC), [`table_file`] (`.cmat` reference tables),
//! [`capsule_estimate_file`] and [`capsule_estimate_record`] (a saved self-calibration). The
//! records come from the stages' crates (`cma-dsp`'s estimate, `cma-calibration`'s capsule estimate
//! and background bands, `cma-tracking`'s talker tracks).
#![no_std]
#![deny(clippy::float_cmp_const)]

pub mod capsule_estimate_file;
pub mod capsule_estimate_record;
pub mod table_file;
pub mod wire;

// The modules of the lower crates the formats name at this crate's root.
use cma_calibration::{background_field, capsule_calibration};
use cma_dsp::estimate;
use cma_dsp::CARDIOIDS;
use cma_tracking::multi_track;
