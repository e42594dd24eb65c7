//! Tracking: the product's Bayesian grid tracker and its sub-grid refinement, and the
//! multi-talker tracks.

pub mod grid_tracker;
pub mod multi_track;
pub mod refine_curve;
pub mod running_curve;
