//! The thesis's further options (off in the product configuration).

pub mod alternative_result;
pub mod beamformer;
pub mod cartesian_filter;
pub mod combination;
pub mod distance;
pub mod frame_quality;
