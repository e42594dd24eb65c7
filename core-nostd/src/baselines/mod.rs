//! Baselines: the intensity-vector methods TDIV and FDIV, their B-format conversion and their
//! per-frame stage ([`intensity`]).

pub mod bformat;
pub mod fdiv;
pub mod intensity;
pub mod tdiv;
