//! Tracking: the similarity curve over frames ([`curve_tracker`]), the product's Bayesian grid tracker and its sub-grid refinement, and the
//! multi-talker tracks.

pub mod curve_tracker;
pub mod grid_tracker;
pub mod multi_track;
pub mod refine_curve;
pub mod running_curve;
