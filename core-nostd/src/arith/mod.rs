//! Target arithmetic: bit-identical math for host and Cortex-M4F, angles.

pub mod angle;
pub mod fast_exp;
pub mod fast_math;
pub mod trig;
