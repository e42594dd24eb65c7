//! The scene simulator: talker, room, diffuse noise and the imperfect array.

pub mod array_model;
pub mod scene;
pub mod signal;
