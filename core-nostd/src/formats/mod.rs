//! File and wire formats: the UART lines, the reference-table file, the self-calibration file and
//! its binary record (the firmware's estimate store).

pub mod capsule_estimate_file;
pub mod capsule_estimate_record;
pub mod table_file;
pub mod wire;
