//! The localizer: sample frames in, one [`Estimate`] per analysis frame out.
//!
//! ```text
//! [f32; 4] ─ InputGuard ─ Decimator ×4 ─ Framer ─┬─ Similarity: spectra → peaks → features → curve
//!                                                 │               → reliability filter → argmax
//!                                                 ├─ FDIV: spectra → per-bin intensity → circular mean
//!                                                 └─ TDIV: RMS → B-format → one-pole → atan2
//! ```
//!
//! The same code runs on the host (`host-sim`) and on the Cortex-M4F (`firmware`): feed it whatever
//! block size the DMA delivers.

use crate::angle::wrap_deg;
use crate::capsule_calibration::{CapsuleCalibrationState, CapsuleEstimate};
use crate::cartesian_filter::{CartesianFilter, Smoothing};
use crate::combination::{fdiv_bin_spread, per_peak_estimate, Combination};
use crate::config::{LocatorConfig, Method, Tracking};
use crate::decimator::Decimator;
use crate::direct_sound::{DirectSound, OnsetState};
use crate::error::Error;
use crate::estimate::{Estimate, Flags};
use crate::fdiv::{fdiv_process, FdivState};
use crate::features::FeatureKind;
use crate::frame_onset::FrameOnsetState;
use crate::front_end::FrontEnd;
use crate::grid_tracker::GridTrackerState;
use crate::input_guard::InputGuard;
use crate::interpolation::argmax_parabolic;
use crate::multi_track::{MultiTrackState, TalkerTrack};
use crate::noise_floor::NoiseFloor;
use crate::noisy_reference::{NoiseMixing, NoisyReferences};
use crate::peak_picker::{PeakPicker, Peaks};
use crate::reference_table::ReferenceTable;
use crate::reliability::{curve_variance_with_sum, CurveFilter};
use crate::similarity::{normalise_frame_curve, CurveBuilder, PeakFeature, RowCache};
use crate::spectrum::{dft_bins3, fold_windowed, power, windowed_spectrum};
use crate::tdiv::{tdiv_process, IvEstimate, TdivState};
use crate::{CHANNELS, FRAME_LEN, HOP, MAX_AZIMUTHS, MAX_PEAKS, NUM_BINS};
use core::mem::MaybeUninit;
use microfft::Complex32;

/// Per-frame diagnostics of the similarity method, for plots and studies (not needed to localize).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FrameDiagnostics {
    /// Sample variance of the frame's similarity curve.
    pub curve_variance: f32,
    /// Number of usable peaks.
    pub num_peaks: usize,
    /// Mean direct-sound weight of the peaks (1 when the weighting is off).
    pub mean_peak_weight: f32,
}

/// The localizer and all of its state (≈ 31 KB; build it in place on the target: [`Locator::init_in_place`]).
pub struct Locator<'t> {
    config: LocatorConfig,
    table: ReferenceTable<'t>,
    decimator: Decimator,
    picker: PeakPicker,
    curves: CurveBuilder,
    /// Per-azimuth constants of the last reference row used by the similarity curve.
    row_cache: RowCache,
    /// Frequency row of the reference table for each bin.
    bin_rows: [u16; NUM_BINS],
    /// Twice the decimator's time offset in input samples.
    offset2: i64,

    /// Input guard, decimator and framer (the analysis frame is read in place from it).
    front: FrontEnd,
    scratch: [f32; FRAME_LEN],
    spectra: [[Complex32; NUM_BINS]; CHANNELS],
    omni_power: [f32; NUM_BINS],
    peaks: Peaks,
    curve: [f32; MAX_AZIMUTHS],
    /// The last frame's negated mean distance curve −Σ w·d^p / Σ w ([`RefineCurve`]), when the grid
    /// tracker refines its estimate with one.
    distance: [f32; MAX_AZIMUTHS],
    filter: CurveFilter,
    tracker: GridTrackerState,
    onset: OnsetState,
    fdiv: FdivState,
    tdiv: TdivState,
    have_history: bool,
    last_azimuth: f32,
    /// Frame index and omni energy of the newest hop of the last frame (the next frame's older hop).
    last_hop_energy: (u32, f32),
    diagnostics: FrameDiagnostics,
    /// State of the eq. 5.30 result filter (a thesis option).
    cartesian: CartesianFilter,
    /// Background power for the noise-floor gate.
    noise_floor: NoiseFloor,
    /// Power history for the frame onset weight.
    frame_onset: FrameOnsetState,
    /// Blind self-calibration of the cardioids.
    capsules: CapsuleCalibrationState,
    /// The estimate the self-calibration starts from at every reset.
    capsule_start: CapsuleEstimate,
    /// Talker tracks of the multi-talker stage.
    multi: MultiTrackState,
}

impl<'t> Locator<'t> {
    /// A localizer for input at `input_rate` Hz with `config` and reference `table`.
    ///
    /// The value is ≈ 31 KB: on a microcontroller build it in place instead
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
        let locator = slot.write(Self::empty(table));
        // The large state of `empty` (buffers, spectra, curves, trackers) is already the initial
        // state: only configure and set up the small state that depends on the configuration (no
        // large temporaries).
        locator.configure(config, table, input_rate)?;
        locator.reset_configured_state(&config);
        Ok(locator)
    }

    /// An unconfigured localizer with zeroed state (the thesis configuration at 12 kHz without
    /// decimation and without noisy references): a constant, for a `static`. Configure it with
    /// [`Locator::reset_with`] before use.
    #[must_use]
    pub const fn empty(table: ReferenceTable<'t>) -> Self {
        Self {
            config: LocatorConfig::thesis(),
            table,
            decimator: Decimator::passthrough(),
            picker: PeakPicker {
                lo_bin: 1,
                hi_bin: NUM_BINS - 2,
                num_peaks: 1,
                min_power: 0.0,
                fill: false,
            },
            curves: CurveBuilder {
                measure: crate::similarity::SimilarityMeasure::Euclidean,
                noisy: NoisyReferences::off(),
                mean_free: false,
                features: crate::features::FeatureKind::Magnitude,
            },
            row_cache: RowCache::new(),
            bin_rows: [0; NUM_BINS],
            offset2: 0,
            front: FrontEnd::new(
                Decimator::passthrough(),
                InputGuard {
                    clip_level: 1.0,
                    hold_samples: 0,
                },
            ),
            scratch: [0.0; FRAME_LEN],
            spectra: [[Complex32::new(0.0, 0.0); NUM_BINS]; CHANNELS],
            omni_power: [0.0; NUM_BINS],
            peaks: Peaks::new(),
            curve: [0.0; MAX_AZIMUTHS],
            distance: [0.0; MAX_AZIMUTHS],
            filter: CurveFilter::new(),
            tracker: GridTrackerState::new(),
            onset: OnsetState::new(),
            fdiv: FdivState::new(),
            tdiv: TdivState::new(),
            cartesian: CartesianFilter::new(),
            noise_floor: NoiseFloor::idle(),
            frame_onset: FrameOnsetState::idle(),
            capsules: CapsuleCalibrationState::idle(),
            capsule_start: CapsuleEstimate::IDEAL,
            multi: MultiTrackState::new(),
            have_history: false,
            last_azimuth: 0.0,
            last_hop_energy: (u32::MAX, 0.0),
            diagnostics: FrameDiagnostics {
                curve_variance: 0.0,
                num_peaks: 0,
                mean_peak_weight: 0.0,
            },
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
        self.scratch.fill(0.0);
        for s in self.spectra.iter_mut() {
            s.fill(Complex32::new(0.0, 0.0));
        }
        self.omni_power.fill(0.0);
        self.peaks = Peaks::new();
        self.curve.fill(0.0);
        self.distance.fill(0.0);
        self.filter = CurveFilter::new();
        self.tracker = GridTrackerState::new();
        self.onset = OnsetState::new();
        self.fdiv = FdivState::new();
        self.tdiv = TdivState::new();
        self.cartesian = CartesianFilter::new();
        self.reset_configured_state(&config);
        self.have_history = false;
        self.last_azimuth = 0.0;
        self.last_hop_energy = (u32::MAX, 0.0);
        self.diagnostics = FrameDiagnostics::default();
        self.multi = MultiTrackState::new();
        Ok(())
    }

    /// Resets the state whose initial value depends on the configuration (noise floor, frame onset
    /// history, self-calibration); [`Locator::empty`] holds idle placeholders for them.
    fn reset_configured_state(&mut self, config: &LocatorConfig) {
        self.noise_floor =
            NoiseFloor::new(&config.noise_gate, self.analysis_rate() as f32 / HOP as f32);
        self.frame_onset = FrameOnsetState::new(&config.frame_onset);
        self.capsules = CapsuleCalibrationState::new(
            config.capsule_calibration,
            self.analysis_rate() as f32,
            self.analysis_rate() as f32 / HOP as f32,
            &self.capsule_start,
        );
    }

    /// Validates and applies the configuration and resets the front end (input guard, decimator,
    /// framer); leaves the analysis state alone.
    fn configure(
        &mut self,
        config: LocatorConfig,
        table: ReferenceTable<'t>,
        input_rate: u32,
    ) -> Result<(), Error> {
        let decimator = Decimator::for_rate(input_rate)?;
        let fs = decimator.output_rate() as f32;
        let c = &config;
        if !(c.band_lo_hz >= 0.0 && c.band_hi_hz > c.band_lo_hz && c.band_hi_hz <= fs / 2.0) {
            return Err(Error::InvalidConfig(
                "band: need 0 ≤ lo < hi ≤ analysis Nyquist",
            ));
        }
        if c.num_peaks == 0 || c.num_peaks > MAX_PEAKS {
            return Err(Error::InvalidConfig("num_peaks: 1..=32"));
        }
        let r = c.reliability;
        if !(r.speed >= 0.0
            && r.v_max > r.v_floor
            && r.v_floor >= 0.0
            && r.speed.is_finite()
            && r.v_max.is_finite())
        {
            return Err(Error::InvalidConfig(
                "reliability: need K ≥ 0 and V_max > V_floor ≥ 0",
            ));
        }
        if !(0.0..1.0).contains(&c.tdiv_pole) || !(0.0..1.0).contains(&c.fdiv_pole) {
            return Err(Error::InvalidConfig("poles: need 0 ≤ a < 1"));
        }
        let d = c.direct_sound;
        let direct_ok = d.directness_exponent >= 0.0
            && d.onset_exponent >= 0.0
            && (0.0..1.0).contains(&d.onset_pole)
            && (0.0..=1.0).contains(&d.onset_floor);
        if !direct_ok {
            return Err(Error::InvalidConfig(
                "direct_sound: exponents ≥ 0, 0 ≤ pole < 1, 0 ≤ floor ≤ 1",
            ));
        }
        if !(c.peak_threshold >= 0.0) || !(c.silence_power >= 0.0) || !(c.clip_level > 0.0) {
            return Err(Error::InvalidConfig("thresholds must be ≥ 0"));
        }
        if !table.serves(c.features) {
            return Err(Error::InvalidConfig(
                "the reference table has no rows for this feature kind (CMA_TABLE_FEATURES)",
            ));
        }
        if c.features == FeatureKind::Active && c.noise_mixing == NoiseMixing::Power {
            return Err(Error::InvalidConfig(
                "active features mix noise linearly: use magnitude (or no) noise mixing",
            ));
        }
        if c.noise_gate.enabled && !c.noise_gate.is_valid() {
            return Err(Error::InvalidConfig(
                "noise gate: need a finite rise ≥ 0 and open < full",
            ));
        }
        if c.frame_onset.enabled && !c.frame_onset.is_valid() {
            return Err(Error::InvalidConfig(
                "frame onset: history 1…8 frames, finite low < high, floor in [0, 1]",
            ));
        }
        if c.capsule_calibration.enabled && !table.is_ideal_model() {
            return Err(Error::InvalidConfig(
                "self-calibration maps the capsules to the ideal model: switch it off with a measured table",
            ));
        }
        if c.capsule_calibration.enabled && !c.capsule_calibration.is_valid() {
            return Err(Error::InvalidConfig(
                "self-calibration: finite background dB ≥ 0, memory ≥ 1 frame, prior ≥ 0, anisotropy > 0",
            ));
        }
        if !c.kernel.is_valid() {
            return Err(Error::InvalidConfig("kernel: need a finite scale > 0"));
        }
        if let Tracking::Grid(t) = c.tracking {
            if !t.is_valid() {
                return Err(Error::InvalidConfig(
                    "grid tracker: values finite; probabilities, poles, floors, refine gain in [0, 1]; the rest ≥ 0",
                ));
            }
        }
        if c.multi_track.enabled && !cfg!(feature = "multi-talker") {
            return Err(Error::InvalidConfig(
                "multi-talker tracks: cma-core was built without its `multi-talker` feature",
            ));
        }
        if c.multi_track.enabled && (c.method != Method::Similarity || !c.multi_track.is_valid()) {
            return Err(Error::InvalidConfig(
                "multi-talker tracks: similarity method only; finite gates in (0, 180], poles in [0, 1), gains in [0, 1], 0 ≤ off ≤ on ≤ 1",
            ));
        }
        if !c.quality.is_valid() {
            return Err(Error::InvalidConfig(
                "quality: scales must be > 0 and finite",
            ));
        }
        let picker = c.peak_picker(fs);
        let curves = c.curve_builder()?;
        let mut bin_rows = [0u16; NUM_BINS];
        for (k, row) in bin_rows.iter_mut().enumerate() {
            *row = table.freq_index(crate::spectrum::bin_frequency(k, fs)) as u16;
        }
        let offset2 = libm::round(2.0 * decimator.time_offset()) as i64;
        let guard = c.input_guard(decimator.factor());
        self.config = config;
        self.table = table;
        self.decimator = decimator;
        self.picker = picker;
        self.curves = curves;
        self.row_cache.clear();
        self.bin_rows = bin_rows;
        self.offset2 = offset2;
        self.front.reset(decimator, guard);
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
        self.decimator.input_rate()
    }

    /// Analysis sample rate after decimation, Hz.
    #[must_use]
    pub fn analysis_rate(&self) -> u32 {
        self.decimator.output_rate()
    }

    /// Input samples per analysis hop (the real-time deadline of one estimate).
    #[must_use]
    pub fn input_samples_per_hop(&self) -> usize {
        HOP * self.decimator.factor() as usize
    }

    /// The last frame's unfiltered similarity curve over the table's azimuths.
    #[must_use]
    pub fn curve(&self) -> &[f32] {
        &self.curve[..self.table.num_azimuths()]
    }

    /// The reliability-filtered similarity curve.
    #[must_use]
    pub fn filtered_curve(&self) -> &[f32] {
        self.filter.current(self.table.num_azimuths())
    }

    /// Diagnostics of the last frame.
    #[must_use]
    pub fn diagnostics(&self) -> FrameDiagnostics {
        self.diagnostics
    }

    /// The self-calibration's current estimate of the cardioids (ideal, with no evidence, when
    /// the stage is off).
    #[must_use]
    pub fn capsule_estimate(&self) -> &CapsuleEstimate {
        self.capsules.estimate()
    }

    /// The self-calibration's confidence in [0, 1] (its least certain band; 0 when off).
    #[must_use]
    pub fn capsule_confidence(&self) -> f32 {
        if self.config.capsule_calibration.enabled {
            self.capsules.confidence()
        } else {
            0.0
        }
    }

    /// The multi-talker tracks after the last frame (live tracks, active or not; none when the
    /// stage is off).
    pub fn talker_tracks(&self) -> impl Iterator<Item = TalkerTrack> + '_ {
        self.multi.tracks()
    }

    /// Sets the estimate the self-calibration starts from (a saved [`CapsuleEstimate`]) and applies
    /// it now; it also survives every later reset. Implausible bands start ideal.
    pub fn set_capsule_estimate(&mut self, start: &CapsuleEstimate) {
        self.capsule_start = *start;
        self.capsules.restore(start);
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

    fn analyze(&mut self) -> Estimate {
        let index = self.front.take_index();
        let mut flags = self.front.flags();
        let frame_power = self.frame_power(index);
        if !(frame_power >= self.config.silence_power) {
            flags.insert(Flags::SILENT);
        }
        let usable = !flags.contains(Flags::SILENT) && !flags.contains(Flags::NON_FINITE);
        let gate = if !usable {
            0.0
        } else if flags.contains(Flags::CLIPPED) {
            self.config.clipped_confidence
        } else {
            1.0
        };

        let (azimuth, raw, confidence) = match self.config.method {
            Method::Similarity => {
                let gate = if self.config.noise_gate.enabled {
                    gate * self.noise_floor.update(frame_power)
                } else {
                    gate
                };
                let clean = usable && !flags.contains(Flags::CLIPPED);
                let onset = if self.config.frame_onset.enabled {
                    self.frame_onset.update(frame_power)
                } else {
                    1.0
                };
                self.similarity_frame(gate, onset, clean, &mut flags)
            }
            Method::Fdiv | Method::Tdiv => {
                let iv = self.intensity_frame(usable);
                (iv.azimuth_deg, iv.azimuth_raw_deg, iv.confidence * gate)
            }
        };

        let factor = self.decimator.factor() as i64;
        let centre2 =
            self.offset2 + factor * (2 * index as i64 * HOP as i64 + FRAME_LEN as i64 - 1);
        Estimate {
            frame_index: index,
            centre_sample: ((centre2 + 1) / 2).max(0) as u64,
            azimuth_deg: wrap_deg(azimuth),
            azimuth_raw_deg: wrap_deg(raw),
            confidence,
            power: frame_power,
            flags,
        }
    }

    /// Mean-square omni power of the frame with index `index`: its older hop's energy is the newer
    /// hop's of the frame before, so only one hop is summed per frame.
    fn frame_power(&mut self, index: u32) -> f32 {
        let omni = &self.front.frame()[0];
        let energy = |x: &[f32]| x.iter().map(|v| v * v).sum::<f32>();
        let (last, last_energy) = self.last_hop_energy;
        let older = if index > 0 && last == index - 1 {
            last_energy
        } else {
            energy(&omni[..FRAME_LEN - HOP])
        };
        let newer = energy(&omni[FRAME_LEN - HOP..]);
        self.last_hop_energy = (index, newer);
        (older + newer) / FRAME_LEN as f32
    }

    fn intensity_frame(&mut self, usable: bool) -> IvEstimate {
        if !usable {
            return IvEstimate {
                azimuth_deg: self.last_azimuth,
                azimuth_raw_deg: self.last_azimuth,
                confidence: 0.0,
            };
        }
        let iv = if self.config.method == Method::Tdiv {
            tdiv_process(self.config.tdiv_pole, &mut self.tdiv, self.front.frame())
        } else {
            for ch in 0..CHANNELS {
                windowed_spectrum(
                    &self.front.frame()[ch],
                    &mut self.scratch,
                    &mut self.spectra[ch],
                );
            }
            fdiv_process(
                self.config.fdiv_pole,
                &mut self.fdiv,
                &self.spectra,
                self.picker.lo_bin,
                self.picker.hi_bin,
            )
        };
        // Thesis option: FDIV reliability from the circular std over bins (§5.2.2), off by default.
        let iv = if self.config.method == Method::Fdiv && self.config.fdiv_spread.enabled() {
            self.fdiv_spread_frame(iv)
        } else {
            iv
        };
        self.last_azimuth = iv.azimuth_deg;
        iv
    }

    /// Similarity method on the current frame; returns (azimuth, raw azimuth, b). `onset` is the
    /// frame onset weight (1 when it is off): it scales b everywhere except in the tracker's
    /// velocity estimate (why: [`crate::frame_onset`]).
    fn similarity_frame(
        &mut self,
        gate: f32,
        onset: f32,
        clean: bool,
        flags: &mut Flags,
    ) -> (f32, f32, f32) {
        let q = self.table.num_azimuths();
        let fs = self.decimator.output_rate() as f32;
        windowed_spectrum(
            &self.front.frame()[0],
            &mut self.scratch,
            &mut self.spectra[0],
        );
        // The cardioids are needed only at the picked bins: `spectra[1..]` hold their folded frames
        // for the direct DFT there (`dft_bins3`) instead of full spectra.
        for ch in 1..CHANNELS {
            fold_windowed(&self.front.frame()[ch], &mut self.spectra[ch]);
        }
        // Only the bins the picker reads (every later use is at a picked bin); the rest stay 0.
        let bins = self.picker.reads();
        for (p, c) in self.omni_power[bins.clone()]
            .iter_mut()
            .zip(&self.spectra[0][bins])
        {
            *p = power(*c);
        }
        self.picker.process(&self.omni_power, &mut self.peaks);
        let calibrating = self.config.capsule_calibration.enabled;
        if calibrating {
            let (lo, hi) = self.picker.band();
            self.capsules.begin_frame(&self.omni_power, lo, hi, clean);
        }

        let ds: DirectSound = self.config.direct_sound;
        let curve = &mut self.curve[..q];
        // The grid tracker's refinement curve, when it is a separate distance curve.
        let power = self.config.refine_distance_power();
        let kernel = self.config.kernel;
        let distance = &mut self.distance[..q];
        let mut weight_sum = 0.0f32;
        let mut n_used = 0usize;
        let mut used = [PeakFeature {
            fi: 0,
            y: [0.0; 3],
            weight: 0.0,
        }; MAX_PEAKS];
        // On x86_64 the cardioid bins of all peaks first, two recursions at a time (the Cortex-M4F
        // computes each where it is used).
        #[cfg(target_arch = "x86_64")]
        let xcs = {
            let mut xcs = [[Complex32::new(0.0, 0.0); 3]; MAX_PEAKS];
            let [_, f1, f2, f3] = &self.spectra;
            crate::spectrum::dft_bins3_many([f1, f2, f3], self.peaks.bins(), &mut xcs);
            xcs
        };
        for i in 0..self.peaks.len {
            let k = self.peaks.bins[i] as usize;
            let p0 = self.omni_power[k];
            #[cfg(target_arch = "x86_64")]
            let xc = xcs[i];
            #[cfg(not(target_arch = "x86_64"))]
            let xc = {
                let [_, f1, f2, f3] = &self.spectra;
                dft_bins3([f1, f2, f3], k)
            };
            let xc = if calibrating {
                self.capsules.correct(k, self.spectra[0][k], xc)
            } else {
                xc
            };
            let Some(y) = self.config.features.of_bin(self.spectra[0][k], p0, xc) else {
                continue;
            };
            let w = if ds.enabled() {
                let delta = DirectSound::directness(self.spectra[0][k], xc);
                ds.peak_weight(&self.onset, k, p0, delta)
            } else {
                1.0
            };
            if !(w > 0.0) {
                continue;
            }
            let fi = self.bin_rows[k] as usize;
            let Some(slot) = used.get_mut(n_used) else {
                break;
            };
            *slot = PeakFeature { fi, y, weight: w };
            weight_sum += w;
            n_used += 1;
        }
        self.curves.frame_curve(
            &mut self.row_cache,
            &self.table,
            &used[..n_used],
            kernel,
            power,
            curve,
            distance,
        );
        if ds.onset_exponent > 0.0 {
            let (lo, hi) = self.picker.band();
            self.onset.update(ds.onset_pole, &self.omni_power, lo, hi);
        }

        let mut b = gate;
        let variance;
        // The reliability of the frame's curve, before any gate.
        let mut curve_reliability = 0.0;
        if n_used == 0 || !(weight_sum > 0.0) {
            flags.insert(Flags::NO_PEAKS);
            curve.fill(0.0);
            distance.fill(0.0);
            b = 0.0;
            variance = 0.0;
        } else {
            let sum = normalise_frame_curve(kernel, power.is_some(), weight_sum, curve, distance);
            variance = curve_variance_with_sum(curve, sum);
            curve_reliability = self.config.reliability.coefficient(variance);
            b *= curve_reliability;
            // Thesis option: alternative frame quality measures / binary b (frame_quality.rs).
            if !self.config.quality.is_default() {
                b = gate
                    * self.config.quality.coefficient(
                        &self.config.reliability,
                        variance,
                        &self.front.frame()[0],
                        fs,
                        &self.omni_power,
                        self.peaks.bins(),
                    );
            }
        }
        if calibrating {
            // A background whose curve points somewhere is directional: not learned from.
            let directional =
                curve_reliability > self.config.capsule_calibration.directional_reliability;
            let talker = self.have_history.then_some(self.last_azimuth);
            self.capsules.end_frame(talker, directional);
        }
        let motion_b = b;
        if self.config.frame_onset.enabled {
            b *= onset;
        }
        self.diagnostics = FrameDiagnostics {
            curve_variance: variance,
            num_peaks: n_used,
            mean_peak_weight: if n_used > 0 {
                weight_sum / n_used as f32
            } else {
                0.0
            },
        };

        let raw = if n_used > 0 {
            argmax_parabolic(curve, self.table.azimuths_deg()).map(|(a, _)| a)
        } else {
            None
        };
        if b > 0.0 {
            self.have_history = true;
        }
        let azimuths = self.table.azimuths_deg();
        let tracked = match self.config.tracking {
            Tracking::OnePole => {
                let filtered = self.filter.update(b, &self.curve[..q]);
                argmax_parabolic(filtered, azimuths)
            }
            Tracking::Grid(t) => {
                let spacing = crate::angle::wrap_deg_360(azimuths[1] - azimuths[0]);
                let refine = if power.is_some() {
                    &self.distance[..q]
                } else {
                    &self.curve[..q]
                };
                t.update_refined(&mut self.tracker, &self.curve[..q], refine, b, spacing);
                t.estimate(&mut self.tracker, &azimuths[..q])
            }
        };
        let azimuth = if self.have_history {
            tracked.map_or(self.last_azimuth, |(a, _)| a)
        } else {
            flags.insert(Flags::NO_HISTORY);
            raw.unwrap_or(self.last_azimuth)
        };
        // Thesis options: combination rule 2 and/or Cartesian result filtering (off by default).
        let (azimuth, raw) = if self.config.combination != Combination::MeanCurve
            || self.config.smoothing == Smoothing::Cartesian
        {
            self.alternative_result(raw, b, azimuth, flags)
        } else {
            (azimuth, raw)
        };
        // Only tracked estimates teach the tracker its velocity: before the first reliable frame the
        // raw azimuths of noise would.
        if let (Tracking::Grid(t), true) = (self.config.tracking, self.have_history) {
            t.observe_estimate(&mut self.tracker, azimuth, motion_b);
        }
        self.last_azimuth = azimuth;
        #[cfg(feature = "multi-talker")]
        if self.config.multi_track.enabled {
            let dominant = self.have_history.then_some((azimuth, b));
            let mt = self.config.multi_track;
            self.multi.update(&mt, &used[..n_used], gate, dominant);
        }
        (azimuth, raw.unwrap_or(azimuth), b)
    }

    // ---- Thesis options (combination.rs, cartesian_filter.rs); not reached with the defaults ----

    /// Rule 2 (eq. 5.13) replaces the frame's raw azimuth; the eq. 5.30 filter (the only one that
    /// applies to a rule-2 estimate) replaces the curve filter's azimuth.
    fn alternative_result(
        &mut self,
        raw: Option<f32>,
        b: f32,
        curve_azimuth: f32,
        flags: &mut Flags,
    ) -> (f32, Option<f32>) {
        let raw = if self.config.combination == Combination::MeanCurve {
            raw
        } else if raw.is_some() {
            let [omni, f1, f2, f3] = &self.spectra;
            per_peak_estimate(
                self.config.combination,
                &self.curves,
                &self.table,
                omni,
                |k| dft_bins3([f1, f2, f3], k),
                self.peaks.bins(),
                &self.bin_rows,
            )
        } else {
            None
        };
        let b = if raw.is_some() { b } else { 0.0 };
        match self.cartesian.update(b, raw.unwrap_or(0.0)) {
            Some(a) => {
                flags.0 &= !Flags::NO_HISTORY.0;
                (a, raw)
            }
            None => {
                flags.insert(Flags::NO_HISTORY);
                (raw.unwrap_or(curve_azimuth), raw)
            }
        }
    }

    /// FDIV with the circular-std quality measure: the frame's per-bin circular mean, filtered in
    /// Cartesian form (eq. 5.30) with b from the spread.
    fn fdiv_spread_frame(&mut self, _smoothed: IvEstimate) -> IvEstimate {
        let (mean, std) = fdiv_bin_spread(&self.spectra, self.picker.lo_bin, self.picker.hi_bin);
        let b = self.config.fdiv_spread.coefficient(std);
        let az = self.cartesian.update(b, mean).unwrap_or(mean);
        IvEstimate {
            azimuth_deg: az,
            azimuth_raw_deg: mean,
            confidence: b,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::DEFAULT_GRID_TRACKER;

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
        let magnitude = LocatorConfig {
            features: FeatureKind::Magnitude,
            ..LocatorConfig::default()
        };
        assert!(Locator::new(magnitude, magnitude_only, 48_000).is_ok());
        assert!(Locator::new(LocatorConfig::thesis(), table, 16_000).is_ok());
        let mut bad = [LocatorConfig::default(); 9];
        bad[0].band_hi_hz = 100.0;
        bad[1].num_peaks = 0;
        bad[2].noise_gate.full_db = bad[2].noise_gate.open_db;
        bad[3].tracking = Tracking::Grid(crate::grid_tracker::GridTracker {
            refine_gain: 2.0,
            ..DEFAULT_GRID_TRACKER
        });
        bad[4].tracking = Tracking::Grid(crate::grid_tracker::GridTracker {
            onset_likelihood_floor: f32::NAN,
            ..DEFAULT_GRID_TRACKER
        });
        bad[5].features = crate::features::FeatureKind::Active;
        bad[5].noise_mixing = NoiseMixing::Power;
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
