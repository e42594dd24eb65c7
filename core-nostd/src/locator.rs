//! The localizer: sample frames in, one [`Estimate`] per analysis frame out.
//!
//! ```text
//! [f32; 4] ─ FrontEnd ─ FrameLevel ─┬─ Similarity: SimilarityFrame ─ CurveTracker ─ (AlternativeResult)
//!                                   │              ─ (MultiTrackState ─ TrackSpans)
//!                                   └─ FDIV / TDIV: IntensityVector
//! ```
//!
//! The [`Locator`] holds the stages, feeds each analysis frame through them in order and assembles
//! the [`Estimate`]; the stages hold the logic: [`crate::front_end`] (input guard, decimator,
//! framer), [`crate::frame_level`] (power, silence, gate), [`crate::similarity_frame`] (spectra →
//! peaks → features → curve → reliability b), [`crate::noise_floor`] and [`crate::frame_onset`]
//! (weights of b), [`crate::curve_tracker`] (one-pole filter or grid
//! tracker), [`crate::alternative_result`] (thesis options), [`crate::multi_track`] and
//! [`crate::track_spans`] (several talkers) and [`crate::intensity`] (the baselines). The thesis
//! options and the baselines are fields of the localizer only with the `thesis-options` feature,
//! the talker tracks only with `multi-talker`.
//!
//! The same code runs on the host (`host-sim`) and on the Cortex-M4F (`firmware`): feed it whatever
//! block size the DMA delivers.

#[cfg(feature = "thesis-options")]
use crate::alternative_result::AlternativeResult;
use crate::angle::wrap_deg;
use crate::background_field::BackgroundBand;
use crate::capsule_calibration::CapsuleEstimate;
use crate::config::{LocatorConfig, Method};
use crate::curve_tracker::CurveTracker;
use crate::decimator::Decimator;
use crate::error::Error;
use crate::estimate::{Estimate, Flags};
use crate::frame_level::{FrameLevel, Level};
use crate::frame_onset::FrameOnsetState;
use crate::frame_spectra::FrameSpectra;
use crate::front_end::FrontEnd;
use crate::input_guard::InputGuard;
#[cfg(feature = "thesis-options")]
use crate::intensity::IntensityVector;
#[cfg(feature = "multi-talker")]
use crate::multi_track::MultiTrackState;
use crate::noise_floor::{NoiseFloor, START_UP_S};
use crate::reference_table::ReferenceTable;
use crate::similarity::PeakFeature;
use crate::similarity_frame::SimilarityFrame;
use crate::track_spans::TrackFrame;
#[cfg(feature = "multi-talker")]
use crate::track_spans::TrackSpans;
use crate::{CHANNELS, FRAME_LEN, HOP, MAX_PEAKS};
use core::mem::MaybeUninit;

pub use crate::similarity_frame::FrameDiagnostics;

/// The localizer: its stages and all of their state (≈ 37 KB on the Cortex-M4F; build it in place on
/// the target: [`Locator::init_in_place`]).
pub struct Locator<'t> {
    config: LocatorConfig,
    table: ReferenceTable<'t>,
    /// Twice the decimator's time offset in input samples.
    offset2: i64,
    /// Input guard, decimator and framer (the analysis frame is read in place from it).
    front: FrontEnd,
    /// The frame's power, silence flag and gate.
    level: FrameLevel,
    /// The frame's spectra, shared by the methods.
    spectra: FrameSpectra,
    /// Background power for the noise-floor gate.
    noise_floor: NoiseFloor,
    /// Power history for the frame onset weight.
    frame_onset: FrameOnsetState,
    /// The similarity method on one frame: peaks, curve, reliability, self-calibration.
    similarity: SimilarityFrame,
    /// The similarity method over frames.
    tracker: CurveTracker,
    /// The thesis's alternative results (rule 2, eq. 5.30 filter).
    #[cfg(feature = "thesis-options")]
    alternative: AlternativeResult,
    /// TDIV and FDIV.
    #[cfg(feature = "thesis-options")]
    intensity: IntensityVector,
    /// Talker tracks of the multi-talker stage.
    #[cfg(feature = "multi-talker")]
    multi: MultiTrackState,
    /// The talker tracks' utterance spans, decided a fixed number of frames late.
    #[cfg(feature = "multi-talker")]
    spans: TrackSpans,
}

impl<'t> Locator<'t> {
    /// A localizer for input at `input_rate` Hz with `config` and reference `table`.
    ///
    /// The value is ≈ 37 KB: on a microcontroller build it in place instead
    /// ([`Locator::init_in_place`], or [`Locator::empty`] in a `static` plus [`Locator::reset_with`]).
    pub fn new(
        config: LocatorConfig,
        table: ReferenceTable<'t>,
        input_rate: u32,
    ) -> Result<Self, Error> {
        let mut locator = Self::empty(table);
        locator.reset_with(config, table, input_rate)?;
        Ok(locator)
    }

    /// Builds the localizer [`Locator::new`] returns directly in `slot` (no temporary on the stack),
    /// e.g. in a `StaticCell::uninit()`. On error `slot` holds [`Locator::empty`].
    pub fn init_in_place<'s>(
        slot: &'s mut MaybeUninit<Self>,
        config: LocatorConfig,
        table: ReferenceTable<'t>,
        input_rate: u32,
    ) -> Result<&'s mut Self, Error> {
        let locator = Self::write_empty(slot, table);
        // The large state of `empty` (buffers, spectra, curves, trackers) is already the initial
        // state: only configure and set up the small state that depends on the configuration (no
        // large temporaries).
        locator.configure(config, table, input_rate)?;
        locator.reset_configured_state();
        Ok(locator)
    }

    /// Writes [`Locator::empty`] into `slot` one stage at a time. `slot.write(Self::empty(table))`
    /// does the same in safe code, but the compiler builds the whole ≈ 37 KB value on the stack first
    /// and copies it (a 56 KB stack frame at the firmware's boot, measured with `llvm-objdump`);
    /// written field by field, most stages' constructors write into their place. Two would still go
    /// through a temporary (12 KB of stack in all): the spectra (all zeros: as a constant they become
    /// a fill) and the curve tracker (as a constant, a 2.6 KB copy from flash).
    #[allow(unsafe_code)]
    fn write_empty<'s>(slot: &'s mut MaybeUninit<Self>, table: ReferenceTable<'t>) -> &'s mut Self {
        use core::ptr::addr_of_mut;
        // The fields written below are the fields of `empty`: this destructuring (no `..`) stops
        // compiling when a field is added, until it is added here and below.
        let Self {
            config: _,
            table: _,
            offset2: _,
            front: _,
            level: _,
            spectra: _,
            noise_floor: _,
            frame_onset: _,
            similarity: _,
            tracker: _,
            #[cfg(feature = "thesis-options")]
                alternative: _,
            #[cfg(feature = "thesis-options")]
                intensity: _,
            #[cfg(feature = "multi-talker")]
                multi: _,
            #[cfg(feature = "multi-talker")]
                spans: _,
        };
        let p = slot.as_mut_ptr();
        // Note(unsafe): `p` points to memory valid for a `Self` (the slot); each field is written
        // exactly once through a raw pointer to it (`addr_of_mut!`, no reference to uninitialised
        // memory is made), and together the writes initialise every field of the value, as the
        // destructuring above checks, so `assume_init_mut` is then sound.
        unsafe {
            addr_of_mut!((*p).config).write(LocatorConfig::thesis());
            addr_of_mut!((*p).table).write(table);
            addr_of_mut!((*p).offset2).write(0);
            addr_of_mut!((*p).front)
                .write(FrontEnd::new(Decimator::passthrough(), InputGuard::IDLE));
            addr_of_mut!((*p).level).write(FrameLevel::new());
            addr_of_mut!((*p).spectra).write(const { FrameSpectra::new() });
            addr_of_mut!((*p).noise_floor).write(NoiseFloor::idle());
            addr_of_mut!((*p).frame_onset).write(FrameOnsetState::idle());
            addr_of_mut!((*p).similarity).write(SimilarityFrame::new());
            addr_of_mut!((*p).tracker).write(const { CurveTracker::new() });
            #[cfg(feature = "thesis-options")]
            addr_of_mut!((*p).alternative).write(AlternativeResult::new());
            #[cfg(feature = "thesis-options")]
            addr_of_mut!((*p).intensity).write(IntensityVector::new());
            #[cfg(feature = "multi-talker")]
            addr_of_mut!((*p).multi).write(MultiTrackState::new());
            #[cfg(feature = "multi-talker")]
            addr_of_mut!((*p).spans).write(TrackSpans::new());
            slot.assume_init_mut()
        }
    }

    /// An unconfigured localizer with zeroed state (the thesis configuration at 12 kHz without
    /// decimation and without noisy references): a constant, for a `static`. Configure it with
    /// [`Locator::reset_with`] before use.
    #[must_use]
    pub const fn empty(table: ReferenceTable<'t>) -> Self {
        Self {
            config: LocatorConfig::thesis(),
            table,
            offset2: 0,
            front: FrontEnd::new(Decimator::passthrough(), InputGuard::IDLE),
            level: FrameLevel::new(),
            spectra: FrameSpectra::new(),
            noise_floor: NoiseFloor::idle(),
            frame_onset: FrameOnsetState::idle(),
            similarity: SimilarityFrame::new(),
            tracker: CurveTracker::new(),
            #[cfg(feature = "thesis-options")]
            alternative: AlternativeResult::new(),
            #[cfg(feature = "thesis-options")]
            intensity: IntensityVector::new(),
            #[cfg(feature = "multi-talker")]
            multi: MultiTrackState::new(),
            #[cfg(feature = "multi-talker")]
            spans: TrackSpans::new(),
        }
    }

    /// Reconfigures the localizer in place for input at `input_rate` Hz with `config` and `table`,
    /// and resets all of its state: afterwards it is equal to `Locator::new(config, table, input_rate)`.
    /// On error (the same checks as [`Locator::new`]) nothing is changed.
    pub fn reset_with(
        &mut self,
        config: LocatorConfig,
        table: ReferenceTable<'t>,
        input_rate: u32,
    ) -> Result<(), Error> {
        self.configure(config, table, input_rate)?;
        self.level = FrameLevel::new();
        self.spectra.reset();
        self.similarity.reset();
        self.tracker = CurveTracker::new();
        #[cfg(feature = "thesis-options")]
        {
            self.alternative = AlternativeResult::new();
            self.intensity.reset();
        }
        #[cfg(feature = "multi-talker")]
        {
            self.multi = MultiTrackState::new();
            self.spans = TrackSpans::new();
        }
        self.reset_configured_state();
        Ok(())
    }

    /// Resets the state whose initial value depends on the configuration (noise floor, frame onset
    /// history, self-calibration); [`Locator::empty`] holds idle placeholders for them.
    fn reset_configured_state(&mut self) {
        let frames_per_s = self.analysis_rate() as f32 / HOP as f32;
        self.noise_floor = NoiseFloor::new(&self.config.noise_gate, frames_per_s);
        self.frame_onset = FrameOnsetState::new(&self.config.frame_onset);
        self.similarity
            .reset_calibration(self.config.capsule_calibration);
        self.similarity.reset_background(self.config.background);
    }

    /// Validates and applies the configuration and resets the front end (input guard, decimator,
    /// framer); leaves the analysis state alone. On error nothing is changed.
    fn configure(
        &mut self,
        config: LocatorConfig,
        table: ReferenceTable<'t>,
        input_rate: u32,
    ) -> Result<(), Error> {
        let decimator = Decimator::for_rate(input_rate)?;
        let fs = decimator.output_rate() as f32;
        config.validate(fs, &table)?;
        // The last step that can fail; it changes nothing on error.
        self.similarity.configure(
            &config.similarity_settings(),
            config.refine_power(),
            &table,
            fs,
        )?;
        #[cfg(feature = "thesis-options")]
        self.intensity.configure(
            config.intensity_method(),
            config.intensity,
            &config.peaks,
            fs,
        );
        let guard = InputGuard::for_decimation(config.front_end.clip_level, decimator.factor());
        self.offset2 = libm::round(2.0 * decimator.time_offset()) as i64;
        self.front.reset(decimator, guard);
        self.config = config;
        self.table = table;
        Ok(())
    }

    /// The configuration.
    #[must_use]
    pub fn config(&self) -> &LocatorConfig {
        &self.config
    }

    /// The reference table.
    #[must_use]
    pub fn table(&self) -> &ReferenceTable<'t> {
        &self.table
    }

    /// Input sample rate, Hz.
    #[must_use]
    pub fn input_rate(&self) -> u32 {
        self.front.decimator().input_rate()
    }

    /// Analysis sample rate after decimation, Hz.
    #[must_use]
    pub fn analysis_rate(&self) -> u32 {
        self.front.decimator().output_rate()
    }

    /// Input samples per analysis hop (the real-time deadline of one estimate).
    #[must_use]
    pub fn input_samples_per_hop(&self) -> usize {
        HOP * self.front.decimator().factor() as usize
    }

    /// The last frame's unfiltered similarity curve over the table's azimuths.
    #[must_use]
    pub fn curve(&self) -> &[f32] {
        self.similarity.curve(self.table.num_azimuths())
    }

    /// The reliability-filtered similarity curve.
    #[must_use]
    pub fn filtered_curve(&self) -> &[f32] {
        self.tracker.filtered_curve(self.table.num_azimuths())
    }

    /// Diagnostics of the last frame.
    #[must_use]
    pub fn diagnostics(&self) -> FrameDiagnostics {
        self.similarity.diagnostics()
    }

    /// The self-calibration's state (its estimate, correction and speech check).
    #[must_use]
    pub fn capsule_state(&self) -> &cma_calibration::capsule_calibration::CapsuleCalibrationState {
        self.similarity.capsule_state()
    }

    /// The self-calibration's current estimate of the cardioids (ideal, with no evidence, when
    /// the stage is off).
    #[must_use]
    pub fn capsule_estimate(&self) -> &CapsuleEstimate {
        self.similarity.capsule_estimate()
    }

    /// The self-calibration's confidence in [0, 1] (its least certain band; 0 when off).
    #[must_use]
    pub fn capsule_confidence(&self) -> f32 {
        self.similarity.capsule_confidence()
    }

    /// The stationary background per band ([`BG_BANDS`](crate::background_field::BG_BANDS)):
    /// direction, directivity, level and evidence of each band's background, `None` for a band
    /// without evidence (the stage off, or no background frame yet). Read-only.
    #[must_use]
    pub fn background_field(&self) -> [Option<BackgroundBand>; crate::background_field::BG_BANDS] {
        self.similarity.background_field().summary()
    }

    /// The multi-talker tracks of the frame decided after the last frame: with
    /// `multi_track.span_gap_frames` > 0, the tracks of the frame n =
    /// `multi_track.span_delay_frames()` frames before the last (`None` before the first n frames;
    /// [`crate::track_spans`]), else of the last frame. Every
    /// live track, active or not. `None` when the stage is off or not built (feature
    /// `multi-talker`).
    #[must_use]
    pub fn talker_tracks(&self) -> Option<TrackFrame> {
        #[cfg(feature = "multi-talker")]
        if self.config.multi_track.enabled {
            return self.spans.decided().copied();
        }
        None
    }

    /// At the end of the input, the tracks of the next frame not yet reported by
    /// [`Locator::talker_tracks`], decided as if no talker spoke after the last frame; `None` once
    /// every frame has been reported. Call it until `None`.
    pub fn flush_talker_tracks(&mut self) -> Option<TrackFrame> {
        #[cfg(feature = "multi-talker")]
        if self.config.multi_track.enabled {
            return self.spans.flush(&self.config.multi_track);
        }
        None
    }

    /// Time of the centre of analysis frame `index` in input samples (an estimate's
    /// `centre_sample`).
    #[must_use]
    pub fn centre_sample(&self, index: u32) -> u64 {
        let factor = self.front.decimator().factor() as i64;
        let centre2 =
            self.offset2 + factor * (2 * i64::from(index) * HOP as i64 + FRAME_LEN as i64 - 1);
        ((centre2 + 1) / 2).max(0) as u64
    }

    /// Sets the estimate the self-calibration starts from (a saved [`CapsuleEstimate`]) and applies
    /// it now; it also survives every later reset. Implausible bands start ideal.
    pub fn set_capsule_estimate(&mut self, start: &CapsuleEstimate) {
        self.similarity.set_capsule_start(start);
    }

    /// Feeds a block of sample frames (channel order omni, card 0°, card 120°, card 240°; full scale ±1)
    /// and calls `on_estimate` for every analysis frame completed within it.
    pub fn process_block(
        &mut self,
        block: &[[f32; CHANNELS]],
        mut on_estimate: impl FnMut(&Estimate),
    ) {
        let mut rest = block;
        while !rest.is_empty() {
            let (used, ready) = self.front.feed(rest);
            rest = &rest[used..];
            if ready {
                on_estimate(&self.analyze());
            }
        }
    }

    /// Feeds one sample frame; returns an estimate when it completes an analysis frame.
    #[inline]
    pub fn process_sample(&mut self, x: [f32; CHANNELS]) -> Option<Estimate> {
        if self.front.feed(core::slice::from_ref(&x)).1 {
            Some(self.analyze())
        } else {
            None
        }
    }

    /// The completed analysis frame through the level stage and the configured method.
    fn analyze(&mut self) -> Estimate {
        let index = self.front.take_index();
        let mut flags = self.front.flags();
        let c = &self.config;
        let omni = &self.front.frame()[0];
        let level = self.level.process(
            index,
            omni,
            c.front_end.silence_power,
            c.front_end.clipped_confidence,
            &mut flags,
        );
        let (azimuth, raw, confidence) = match self.config.method {
            Method::Similarity => self.similarity_frame(index, &level, &mut flags),
            #[cfg(feature = "thesis-options")]
            Method::Fdiv | Method::Tdiv => {
                let iv =
                    self.intensity
                        .process(level.usable, self.front.frame(), &mut self.spectra);
                (
                    iv.azimuth_deg,
                    iv.azimuth_raw_deg,
                    iv.confidence * level.gate,
                )
            }
            // Not linked: `LocatorConfig::validate` rejects the baselines without the feature.
            #[cfg(not(feature = "thesis-options"))]
            Method::Fdiv | Method::Tdiv => (0.0, 0.0, 0.0),
        };
        Estimate {
            frame_index: index,
            centre_sample: self.centre_sample(index),
            azimuth_deg: wrap_deg(azimuth),
            azimuth_raw_deg: wrap_deg(raw),
            confidence,
            power: level.power,
            flags,
        }
    }

    /// The similarity method on the current frame; returns (azimuth, raw azimuth, b). The frame
    /// onset weight scales b everywhere except in the tracker's velocity estimate (why:
    /// [`crate::frame_onset`]).
    fn similarity_frame(
        &mut self,
        index: u32,
        level: &Level,
        flags: &mut Flags,
    ) -> (f32, f32, f32) {
        let (gate, onset) = self.similarity_gates(level, index);
        let c = &self.config;
        // The frame's usable peaks: per-frame scratch on the stack (static RAM is the scarcer).
        let mut used = [PeakFeature::NONE; MAX_PEAKS];
        let frame = self.similarity.process(
            self.front.frame(),
            &mut self.spectra,
            &self.table,
            &mut used,
            gate,
            level.clean,
            self.tracker.talker(),
            flags,
        );
        let motion_b = frame.b;
        let b = if c.frame_onset.enabled {
            frame.b * onset
        } else {
            frame.b
        };
        let q = self.table.num_azimuths();
        let azimuth = self.tracker.track(
            &c.tracking,
            self.similarity.curve(q),
            self.similarity.refine_curve(q),
            self.table.azimuths_deg(),
            b,
            frame.raw,
            flags,
        );
        // Thesis options: combination rule 2 and/or Cartesian result filtering (off by default).
        #[cfg(feature = "thesis-options")]
        let (azimuth, raw) =
            if AlternativeResult::applies(c.alternative.combination, c.alternative.smoothing) {
                self.alternative.process(
                    c.alternative.combination,
                    &self.similarity,
                    &self.spectra,
                    &self.table,
                    frame.raw,
                    b,
                    azimuth,
                    flags,
                )
            } else {
                (azimuth, frame.raw)
            };
        #[cfg(not(feature = "thesis-options"))]
        let raw = frame.raw;
        self.tracker
            .observe(&c.tracking, azimuth, frame.raw, motion_b);
        #[cfg(feature = "multi-talker")]
        if c.multi_track.enabled {
            let dominant = self.tracker.talker().map(|a| (a, b));
            let peaks = &used[..frame.num_peaks];
            self.multi.update(&c.multi_track, peaks, gate, dominant);
            self.spans
                .push(&c.multi_track, index, self.multi.slot_tracks());
        }
        #[cfg(not(feature = "multi-talker"))]
        let _ = index;
        (azimuth, raw.unwrap_or(azimuth), b)
    }

    /// The similarity method's gate of frame `index` (`level`'s gate times the noise-floor gate,
    /// when on; in the floor's start-up, [`START_UP_S`], the floor rises faster) and its frame
    /// onset weight (1 when off).
    fn similarity_gates(&mut self, level: &Level, index: u32) -> (f32, f32) {
        let c = &self.config;
        let gate = if c.noise_gate.enabled {
            let directional = self.similarity.background_source_dominates();
            let frames_per_s = self.analysis_rate() as f32 * (1.0 / HOP as f32);
            let starting = (index as f32) < START_UP_S * frames_per_s;
            level.gate * self.noise_floor.update(level.power, directional, starting)
        } else {
            level.gate
        };
        let onset = if c.frame_onset.enabled {
            self.frame_onset.update(level.power)
        } else {
            1.0
        };
        (gate, onset)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Tracking, DEFAULT_GRID_TRACKER};
    use crate::features::FeatureKind;
    use crate::noisy_reference::NoiseMixing;

    #[test]
    fn the_baselines_and_thesis_options_need_their_feature() {
        let table = ReferenceTable::ideal_5deg();
        let fdiv = LocatorConfig {
            method: Method::Fdiv,
            ..LocatorConfig::default()
        };
        let mut rule2 = LocatorConfig::thesis();
        rule2.alternative.combination = crate::combination::Combination::PeakCircularMedian;
        for c in [fdiv, rule2] {
            let built = Locator::new(c, table, 48_000);
            assert_eq!(built.is_ok(), cfg!(feature = "thesis-options"), "{c:?}");
        }
    }

    #[test]
    fn invalid_settings_are_errors_not_panics() {
        let table = ReferenceTable::ideal_5deg();
        assert!(Locator::new(LocatorConfig::default(), table, 48_000).is_ok());
        // The self-calibration maps the capsules to the ideal model: not on top of a measured table.
        let az = [0.0f32, 120.0, 240.0];
        let fr = [500.0f32];
        let feats = [[0.5; 3]; 3];
        let noise = [[0.5; 3]; 1];
        let measured = ReferenceTable::new(&az, &fr, &feats, &noise, &noise).unwrap();
        assert!(!measured.is_ideal_model() && table.is_ideal_model());
        assert!(ReferenceTable::ideal_15deg().is_ideal_model());
        assert!(matches!(
            Locator::new(LocatorConfig::default(), measured, 48_000),
            Err(Error::InvalidConfig(_))
        ));
        let mut uncalibrated = LocatorConfig::default();
        uncalibrated.capsule_calibration.enabled = false;
        assert!(Locator::new(uncalibrated, measured, 48_000).is_ok());
        // A table of one feature kind serves only configurations of that kind.
        let magnitude_only = table.only(FeatureKind::Magnitude);
        assert!(matches!(
            Locator::new(LocatorConfig::default(), magnitude_only, 48_000),
            Err(Error::InvalidConfig(_))
        ));
        let mut magnitude = LocatorConfig::default();
        magnitude.curves.features = FeatureKind::Magnitude;
        assert!(Locator::new(magnitude, magnitude_only, 48_000).is_ok());
        assert!(Locator::new(LocatorConfig::thesis(), table, 16_000).is_ok());
        let mut bad = [LocatorConfig::default(); 9];
        bad[0].peaks.band_hi_hz = 100.0;
        bad[1].peaks.num_peaks = 0;
        bad[2].noise_gate.full_db = bad[2].noise_gate.open_db;
        bad[3].tracking = Tracking::Grid(crate::grid_tracker::GridTracker {
            refine_gain: 2.0,
            ..DEFAULT_GRID_TRACKER
        });
        bad[4].tracking = Tracking::Grid(crate::grid_tracker::GridTracker {
            onset_likelihood_floor: f32::NAN,
            ..DEFAULT_GRID_TRACKER
        });
        bad[5].curves.features = crate::features::FeatureKind::Active;
        bad[5].curves.noise_mixing = NoiseMixing::Power;
        bad[6].frame_onset = crate::frame_onset::FrameOnset {
            enabled: true,
            history: 9,
            ..crate::frame_onset::FrameOnset::OFF
        };
        bad[7].frame_onset = crate::frame_onset::FrameOnset {
            enabled: true,
            high_db: -2.0,
            ..crate::frame_onset::FrameOnset::OFF
        };
        bad[8].kernel = crate::curve_kernel::CurveKernel::Distance {
            power: crate::refine_curve::DistancePower::Two,
            scale: f32::NAN,
        };
        for (i, c) in bad.into_iter().enumerate() {
            assert!(
                matches!(Locator::new(c, table, 48_000), Err(Error::InvalidConfig(_))),
                "case {i}"
            );
        }
        // Switched-off gate and frame onset settings are not checked.
        let mut off = LocatorConfig::default();
        off.noise_gate.enabled = false;
        off.noise_gate.full_db = f32::NAN;
        off.frame_onset.enabled = false;
        off.frame_onset.history = 0;
        assert!(Locator::new(off, table, 48_000).is_ok());
    }

    /// A localizer built in place gives the same estimates, bit for bit, as one from
    /// `Locator::new` (the noise-floor gate, the frame onset weight and the self-calibration start
    /// from their configured state in both).
    #[test]
    fn built_in_place_equals_new() {
        fn bits(e: &Estimate) -> [u32; 4] {
            [
                e.azimuth_deg.to_bits(),
                e.azimuth_raw_deg.to_bits(),
                e.confidence.to_bits(),
                u32::from(e.flags.0),
            ]
        }
        let table = ReferenceTable::ideal_5deg();
        for config in [LocatorConfig::default(), LocatorConfig::thesis()] {
            let mut a = Locator::new(config, table, 48_000).unwrap();
            let mut slot = core::mem::MaybeUninit::uninit();
            let b = Locator::init_in_place(&mut slot, config, table, 48_000).unwrap();
            // A source at 40° (cardioids 0.5 + 0.5 cos(θ − φ)) of noise after a quiet start.
            let gain = |phi: f32| 0.5 + 0.5 * libm::cosf((40.0 - phi).to_radians());
            let mut state = 0x1234_5678u32;
            let mut count = 0;
            for block in 0..200 {
                let level = if block < 20 { 0.001 } else { 0.5 };
                let mut frames = [[0.0f32; CHANNELS]; 256];
                for f in frames.iter_mut() {
                    state ^= state << 13;
                    state ^= state >> 17;
                    state ^= state << 5;
                    let s = (state as f32 / u32::MAX as f32 - 0.5) * level;
                    *f = [s, s * gain(0.0), s * gain(120.0), s * gain(240.0)];
                }
                let mut from_new = [[0u32; 4]; 1];
                let mut n = 0;
                a.process_block(&frames, |e| {
                    from_new[n] = bits(e);
                    n += 1;
                });
                let mut m = 0;
                b.process_block(&frames, |e| {
                    assert_eq!(bits(e), from_new[m], "estimate {count}");
                    m += 1;
                    count += 1;
                });
                assert_eq!(m, n);
            }
            assert!(count > 40, "{count} estimates");
        }
    }
}
