//! Making a reference table: the exponential sine sweep and the calibration from its recordings, or
//! the table of a self-calibration estimate.

pub mod calibrate;
pub mod selfcal_table;
pub mod sweep;
