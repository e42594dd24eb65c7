//! # cma-frontend — the front end of the localizer
//!
//! Sample frames in, analysis frames out: [`input_guard`] (NaN, infinities, clipping),
//! [`decimator`] (half-band anti-alias cascade, 48 kHz → 12 kHz; 44.1 → 11.025, 16 kHz passes) and
//! [`block_decimator`] (the cascade over pieces of interleaved input, all stages in one pass),
//! [`framer`] (512-sample analysis frames with a hop of 256), [`front_end`] (the three block by
//! block), and [`frame_level`] (the analysis frame's power, silence flag and gate).
#![no_std]
#![deny(clippy::float_cmp_const)]

pub mod block_decimator;
pub mod decimator;
pub mod frame_level;
pub mod framer;
pub mod front_end;
pub mod input_guard;

// The modules of `cma-dsp` the stages name at this crate's root.
#[cfg(test)]
use cma_dsp::test_rng;
use cma_dsp::{error, estimate, tables};
use cma_dsp::{CHANNELS, FRAME_LEN, HOP};
