//! The scene simulator: talker, room (measured or a shoebox by image sources), diffuse noise,
//! directional noise sources and the imperfect array.

pub mod array_model;
pub mod multi_talker_scene;
pub mod noise_source;
pub mod room;
pub mod scene;
pub mod signal;
