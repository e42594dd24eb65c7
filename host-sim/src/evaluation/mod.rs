//! Scoring estimates against ground truth: the evaluation of a folder, its metrics and plots, the
//! score of a recorded estimate CSV, and the reports of the thesis options.

pub mod distance_eval;
pub mod eval;
pub mod metrics;
pub mod multi_talker_eval;
pub mod options_eval;
pub mod plots;
pub mod recorded_score;
