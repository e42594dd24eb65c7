//! File and wire formats: the UART lines, the reference-table file and the self-calibration file.

pub mod capsule_estimate_file;
pub mod table_file;
pub mod wire;
