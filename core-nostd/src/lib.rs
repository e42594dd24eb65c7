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
//! ## Reader's map
//!
//! The stages live in crates of their own, each depending only on crates above it in this list
//! (Cargo refuses a cycle, so no stage can reach back up the pipeline). Each stage owns its
//! settings type and builds its state from it; [`LocatorConfig`] composes the settings, one field
//! per stage (the configuration file keeps its flat keys: [`config::ConfigFile`]), and [`Locator`]
//! runs the stages in this order.
//!
//! | # | stage | crate · module | settings (`LocatorConfig` field: type) |
//! |---|-------|----------------|----------|
//! | 0 | arithmetic, records, eigenbeams, window and FFT | `cma-dsp` · [`angle`], [`fast_math`], [`trig`], [`fast_exp`], [`estimate`], [`error`], [`bformat`], [`spectrum`], [`frame_spectra`] | — |
//! | 1 | input guard (NaN, clipping) | `cma-frontend` · [`input_guard`] | `front_end`: [`front_end::FrontEndSettings`] (`clip_level`) |
//! | 2 | half-band decimation 48 → 12 kHz | `cma-frontend` · [`decimator`], [`block_decimator`] | — (the input rate) |
//! | 3 | 512-sample frames, hop 256 | `cma-frontend` · [`framer`], [`front_end`] | — |
//! | 4 | frame level, silence, gate | `cma-frontend` · [`frame_level`] | `front_end` (`silence_power`, `clipped_confidence`) |
//! | 5 | noise-floor gate of b | `cma-analysis` · [`noise_floor`] ([`power_ramp`]) | `noise_gate`: [`noise_floor::NoiseGate`] |
//! | 6 | peaks of \|X_omni\| (§5.1.2) | `cma-analysis` · [`peak_picker`] | `peaks`: [`peak_picker::PeakSettings`] |
//! | 7 | self-calibration of the cardioids, background field (noise-field report; stationary excess taken off the peaks) | `cma-calibration` · [`capsule_calibration`], [`background_field`] ([`band_floors`]) | `capsule_calibration`: [`capsule_calibration::CapsuleCalibration`]; `background`: [`background_field::BackgroundField`] |
//! | 8 | features at the peaks (eq. 5.7), direct-sound weights | `cma-analysis` · [`features`], [`direct_sound`] | `curves.features`: [`features::FeatureKind`]; `direct_sound`: [`direct_sound::DirectSound`] |
//! | 9 | reference tables, noisy references (eq. 5.16–5.20) | `cma-localization` · [`reference_table`], [`embedded_table`], [`noisy_reference`] | the [`ReferenceTable`]; `curves` (`noise_mixing`, `snr_*`) |
//! | 10 | similarity curve | `cma-localization` · [`similarity`], [`curve_kernel`] | `curves`: [`similarity::CurveSettings`]; `kernel`: [`curve_kernel::CurveKernel`] |
//! | 11 | reliability b (eq. 5.31) or frame quality (§5.1.6) | `cma-localization` · [`reliability`], [`frame_quality`] | `reliability`: [`reliability::Reliability`]; `quality`: [`frame_quality::FrameQuality`] |
//! | 12 | frame onset weight of b | `cma-localization` · [`frame_onset`] | `frame_onset`: [`frame_onset::FrameOnset`] |
//! | — | steps 6–11 on one frame | `cma-localization` · [`similarity_frame`] | [`similarity_frame::SimilaritySettings`] ([`LocatorConfig::similarity_settings`]) |
//! | 13 | tracking: one-pole filter or grid tracker (velocity from the [`motion_fit`]), argmax | `cma-tracking` · [`curve_tracker`], [`grid_tracker`], [`motion_fit`], [`running_curve`], [`refine_curve`]; [`interpolation`] | `tracking`: [`curve_tracker::Tracking`] |
//! | 14 | several talkers; their utterance spans, decided a fixed time late | `cma-tracking` · [`multi_track`], [`track_spans`] | `multi_track`: [`multi_track::MultiTrack`] |
//! | — | thesis options: rule 2, Cartesian filter | `cma-reference` · [`combination`], [`cartesian_filter`], [`alternative_result`] | `alternative`: [`alternative_result::AlternativeSettings`] |
//! | — | baselines TDIV / FDIV | `cma-reference` · [`tdiv`], [`fdiv`], [`intensity`] | `method`: [`Method`]; `intensity`: [`intensity::IntensitySettings`] |
//! | — | host studies: beamformer, distance | `cma-reference` · [`beamformer`], [`distance`] | — |
//! | — | wire and file formats | `cma-formats` · [`wire`], [`table_file`], [`capsule_estimate_file`], [`capsule_estimate_record`] | — |
//!
//! The crates' dependencies: `cma-dsp` under all; `cma-frontend` on it alone; `cma-analysis` →
//! `cma-calibration` → `cma-localization` → `cma-tracking` → `cma-formats`, each on the ones before;
//! `cma-reference` on the localization; `cma-core` (this crate: [`config`], [`locator`]) on all of
//! them, naming every module at its root (`cma_core::spectrum`, …). The thesis options and the
//! baselines run only with this crate's `thesis-options` feature (the host programs); without it
//! they are not linked and a configuration that selects one is an error. A program that only reads
//! and writes the formats depends on `cma-formats` alone.
//!
//! "Frame" has two meanings in this crate, as in the literature: a *sample frame* is one instant across the
//! four channels (`[f32; 4]`), an *analysis frame* is a block of [`FRAME_LEN`] samples per channel.
//! Each name says which one it means.
#![no_std]
#![deny(clippy::float_cmp_const)]

pub mod config;
pub mod locator;

// Every stage module at the crate root, where the users of the localizer name it.
pub use cma_analysis::{direct_sound, features, noise_floor, peak_picker, power_ramp};
pub use cma_calibration::{background_field, band_floors, capsule_calibration};
pub use cma_dsp::{
    angle, bformat, error, estimate, fast_exp, fast_math, frame_spectra, spectrum, trig,
};
pub use cma_formats::{capsule_estimate_file, capsule_estimate_record, table_file, wire};
pub use cma_frontend::{block_decimator, decimator, frame_level, framer, front_end, input_guard};
pub use cma_localization::{
    curve_kernel, embedded_table, frame_onset, frame_quality, interpolation, noisy_reference,
    reference_table, reliability, similarity, similarity_frame,
};
pub use cma_reference::{
    alternative_result, beamformer, cartesian_filter, combination, distance, fdiv, intensity, tdiv,
};
pub use cma_tracking::{
    curve_tracker, grid_tracker, motion_fit, multi_track, refine_curve, running_curve, track_spans,
};

pub use cma_dsp::{
    CARDIOIDS, CARDIOID_LOOK_DEG, CHANNELS, FRAME_LEN, HOP, MAX_AZIMUTHS, MAX_PEAKS, MAX_SNR_SETS,
    NUM_BINS,
};
pub use config::{LocatorConfig, Method};
pub use error::Error;
pub use estimate::{Estimate, Flags};
pub use locator::Locator;
pub use reference_table::ReferenceTable;
