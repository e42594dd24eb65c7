//! # cma-core — similarity localizer for a coincident microphone array
//!
//! `no_std`, heap-free implementation of the *similarity approach* of K. Freiberger's diploma thesis
//! ("Development and Evaluation of Source Localization Algorithms for Coincident Microphone Arrays",
//! IEM Graz, chapters 4–5; K. Freiberger and A. Sontacchi, DAFx-11) for the CMA1 array: channel 0
//! omni, channels 1–3 cardioids looking at 0°, 120°, 240°.
//!
//! ```
//! use cma_core::{Estimate, Locator, LocatorConfig, ReferenceTable};
//!
//! // A talker at 60°: a plane wave of noise, W for the omni and ½W + ½W·cos(60° − φ_m) for the
//! // cardioids, at 16 kHz.
//! let mut locator = Locator::new(LocatorConfig::default(), ReferenceTable::ideal_5deg(), 16_000)?;
//! let mut seed = 1u32;
//! let mut noise = move || {
//!     seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
//!     (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
//! };
//! let gains = [0.0f32, 120.0, 240.0].map(|look| 0.5 + 0.5 * (60.0 - look).to_radians().cos());
//! let block: Vec<[f32; 4]> = (0..16_000)
//!     .map(|_| {
//!         let w = 0.3 * noise();
//!         [w, gains[0] * w, gains[1] * w, gains[2] * w]
//!     })
//!     .collect();
//! let mut last = None;
//! // Any block size works (a DMA half-buffer on the board); one callback per analysis frame.
//! for chunk in block.chunks(256) {
//!     locator.process_block(chunk, |e: &Estimate| last = Some(*e));
//! }
//! let e = last.expect("one second gives many analysis frames");
//! assert!((e.azimuth_deg - 60.0).abs() < 3.0, "{}", e.azimuth_deg);
//! # Ok::<(), cma_core::Error>(())
//! ```
//!
//! The source tree groups the modules by part: [`frontend`], [`analysis`], [`localization`],
//! [`tracking`], [`baselines`], [`thesis_options`], [`formats`], [`arith`]; each module is also
//! reachable at the crate root (`cma_core::spectrum`, …). The pipeline, one module per stage:
//!
//! 1. [`decimator`] — half-band anti-alias cascade, 48 kHz → 12 kHz (44.1 → 11.025, 16 kHz passes);
//!    [`block_decimator`] runs it over pieces of interleaved input, all stages in one pass;
//! 2. [`framer`] — 512-sample analysis frames with a hop of 256 ([`front_end`] runs the input guard,
//!    the decimator and the framer block by block);
//! 3. [`spectrum`] — Hamming window from a table, `microfft` real FFT, Nyquist bin unpacked; for the
//!    similarity method the cardioids only at the picked bins (folded frame + direct DFT);
//! 4. [`peak_picker`] — the N_p strongest peaks of |X_omni| in a band (thesis §5.1.2, with the fill rule);
//! 5. [`features`] — |X_card| / |X_omni| at the peaks (eq. 5.7);
//! 6. [`reference_table`] — reference features in flash (ideal model or measured, per frequency);
//! 7. [`noisy_reference`] — reference features mixed with omni noise at a set of SNRs (eq. 5.16–5.20);
//! 8. [`similarity`] — Euclidean / cosine / L_p similarity and the mean similarity curve;
//! 9. [`reliability`] — curve-variance confidence and the adaptive one-pole filter on the curve (eq. 5.31),
//!    or [`grid_tracker`] — the product's Bayesian tracker on the curve (no lag, fast jumps);
//! 10. [`interpolation`] — wrapped argmax with parabolic interpolation (eq. 4.23–4.29).
//!
//! Per analysis frame, [`frame_level`] measures the frame's power and gate, [`similarity_frame`] runs
//! steps 3–8 and the reliability of step 9, and [`curve_tracker`] the tracking of steps 9–10.
//! [`locator::Locator`] composes the stages: feed it blocks of interleaved 4-channel samples (as a DMA
//! handler receives them) and it calls back once per analysis frame with an [`estimate::Estimate`].
//! The intensity-vector baselines [`tdiv`] and [`fdiv`] sit behind the same interface ([`intensity`]).
//!
//! The thesis's further options: [`beamformer`] (self-steered first-order beam, §3.3),
//! [`frame_quality`] (§5.1.6 quality measures), [`combination`] (rule 2, eq. 5.13; FDIV spread),
//! [`cartesian_filter`] (eq. 5.30); [`alternative_result`] applies rule 2 and eq. 5.30 to the
//! similarity method's result.
//!
//! [`config::LocatorConfig`] holds the settings of all stages as plain data; each stage builds
//! itself from them (e.g. [`peak_picker::PeakPicker::from_config`]).
//!
//! "Frame" has two meanings in this crate, as in the literature: a *sample frame* is one instant across the
//! four channels (`[f32; 4]`), an *analysis frame* is a block of [`FRAME_LEN`] samples per channel.
//! Each name says which one it means.
#![no_std]
#![deny(clippy::float_cmp_const)]

pub mod analysis;
pub mod arith;
pub mod baselines;
pub mod config;
pub mod error;
pub mod estimate;
pub mod formats;
pub mod frontend;
pub mod localization;
pub mod locator;
#[cfg(test)]
mod test_rng;
pub mod thesis_options;
pub mod tracking;

// Every stage module also at the crate root, where the rest of the crate and its users name it.
#[cfg(target_arch = "x86_64")]
pub(crate) use analysis::fft_x86;
pub use analysis::{
    background_field, band_floors, capsule_calibration, direct_sound, features, frame_level,
    frame_spectra, peak_picker, spectrum,
};
pub use arith::{angle, fast_exp, fast_math, trig};
pub use baselines::{bformat, fdiv, intensity, tdiv};
pub use formats::{capsule_estimate_file, capsule_estimate_record, table_file, wire};
pub use frontend::{block_decimator, decimator, framer, front_end, input_guard};
pub use localization::{
    curve_kernel, embedded_table, frame_onset, interpolation, noise_floor, noisy_reference,
    power_ramp, reference_table, reliability, similarity, similarity_frame, tables,
};
pub use thesis_options::{
    alternative_result, beamformer, cartesian_filter, combination, distance, frame_quality,
};
pub use tracking::{curve_tracker, grid_tracker, multi_track, refine_curve, running_curve};

pub use config::{LocatorConfig, Method};
pub use error::Error;
pub use estimate::{Estimate, Flags};
pub use locator::Locator;
pub use reference_table::ReferenceTable;

/// Number of input channels: omni, cardioid 0°, cardioid 120°, cardioid 240°.
pub const CHANNELS: usize = 4;
/// Number of cardioid channels (the feature dimension).
pub const CARDIOIDS: usize = 3;
/// Analysis frame length in samples at the analysis rate (thesis §5.1.1: the power of two ≤ 50 ms).
pub const FRAME_LEN: usize = 512;
/// Hop between analysis frames in samples at the analysis rate (50 % overlap).
pub const HOP: usize = FRAME_LEN / 2;
/// Number of spectral bins of a frame, DC to Nyquist inclusive.
pub const NUM_BINS: usize = FRAME_LEN / 2 + 1;
/// Largest number of spectral peaks per frame ([`LocatorConfig::num_peaks`]).
pub const MAX_PEAKS: usize = 32;
/// Largest number of azimuths in a reference table (a 1° grid).
pub const MAX_AZIMUTHS: usize = 360;
/// Largest number of SNR sets of the noisy reference features.
pub const MAX_SNR_SETS: usize = 16;
/// Look directions of the three cardioids, degrees counter-clockwise from cardioid 1.
pub const CARDIOID_LOOK_DEG: [f32; CARDIOIDS] = [0.0, 120.0, 240.0];
