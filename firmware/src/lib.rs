//! Chip-independent parts of the array-board firmware, built for the host too so they are unit tested.
//!
//! * [`sample`] — 24-bit I2S codes (left-aligned in 32-bit slots, read as 16-bit halves) to `f32`
//!   sample frames in the core's channel order;
//! * [`stats`] — the counters the frame stream reports (DMA overruns, frames dropped by UART backpressure).
//! * [`embedded_config`] — the localizer configuration, embedded at build time (`CMA_CONFIG=path`).
//! * [`stored_capsules`] — the capsule estimate the self-calibration starts from, embedded at build
//!   time (`CMA_SELFCAL=path`).
//!
//! The embassy application itself (`src/main.rs`, `src/app.rs`, `src/board.rs`) only builds for the target.
#![no_std]

pub mod embedded_config;
pub mod sample;
pub mod stats;
pub mod stored_capsules;
