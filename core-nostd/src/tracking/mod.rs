//! Tracking: the product's Bayesian grid tracker and its sub-grid refinement.

pub mod grid_tracker;
pub mod refine_curve;
pub mod running_curve;
