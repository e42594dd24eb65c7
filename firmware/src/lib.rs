//! Board-independent parts of the array-board firmware, built for the host too so they are unit tested.
//!
//! * [`board_api`] — the board interface the application is written against (sample blocks with
//!   overrun reports, a frame writer, a watchdog);
//! * [`clock_plan`] — the STM32 boards' audio clock plans (the register values they write) and
//!   the sample rates they give;
//! * [`i2s_align`] — frame and channel alignment of the two I2S receive streams after a (re)start,
//!   and the channel-side check that finds a stream that slipped;
//! * [`restart_mask`] — the ADCs' restart transient (zeros, then a fade-in) masked as flagged
//!   (NaN) sample frames;
//! * [`sample`] — 24-bit I2S codes (left-aligned in 32-bit slots, read as 16-bit halves) to `f32`
//!   sample frames in the core's channel order;
//! * [`tdm`] — 4-slot TDM words (one 4-channel ADC on the STM32F446 board's SAI) to `f32`
//!   sample frames in the core's channel order, and the receiver's restart at a frame sync;
//! * [`stats`] — the counters the frame stream reports (DMA overruns, frames dropped by UART backpressure).
//! * [`embedded_config`] — the localizer configuration, embedded at build time (`CMA_CONFIG=path`).
//! * [`stored_capsules`] — the capsule estimate the self-calibration starts from, embedded at build
//!   time (`CMA_SELFCAL=path`);
//! * [`estimate_store`] — the self-calibration's estimate kept in flash across power cycles (an
//!   append-only log of records) and when to save it;
//! * [`wav`] and [`emulated`] — the emulated board's WAV decoding, fault schedule and report lines.
//!
//! Target only (`--target thumbv7em-none-eabihf`):
//! * `app` — the embassy application (capture → core → frame lines), the same on every board;
//! * `boards` — the boards (`boards/f411.rs` for the STM32F411CE, `boards/f446.rs` for the
//!   STM32F446RE, `boards/mps2.rs` for QEMU `mps2-an386`); the `board-*` feature selects one;
//! * the runtime glue (defmt over RTT, the panic handler).
//!
//! One binary per board starts the application: `src/bin/firmware.rs` (STM32F411CE),
//! `src/bin/firmware-f446.rs` and `src/bin/firmware-mps2.rs`.
#![no_std]

// The host tests use `Vec`.
#[cfg(test)]
extern crate std;

#[cfg(target_os = "none")]
pub mod app;
pub mod board_api;
#[cfg(target_os = "none")]
pub mod boards;
pub mod clock_plan;
pub mod embedded_config;
pub mod emulated;
pub mod estimate_store;
pub mod i2s_align;
pub mod i2s_capture;
pub mod restart_mask;
#[cfg(target_os = "none")]
mod runtime;
pub mod sample;
pub mod stats;
pub mod stored_capsules;
pub mod tdm;
pub mod wav;
