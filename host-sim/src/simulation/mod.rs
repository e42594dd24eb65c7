//! The scene simulator: talker, room, diffuse noise and the imperfect array.

pub mod array_model;
pub mod multi_talker_scene;
pub mod scene;
pub mod signal;
