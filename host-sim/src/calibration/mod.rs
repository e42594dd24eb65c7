//! Measuring a reference table: the exponential sine sweep and the calibration from its recordings.

pub mod calibrate;
pub mod sweep;
