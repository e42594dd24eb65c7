//! Baselines: the intensity-vector methods TDIV and FDIV and their B-format conversion.

pub mod bformat;
pub mod fdiv;
pub mod tdiv;
