//! The similarity method on one analysis frame (thesis §5.1): omni power → peaks → cardioid DFT at
//! the peaks (the self-calibration's correction; a directional background's stationary excess
//! taken off) → features and direct-sound weights → similarity curve → curve variance →
//! reliability b (or the thesis's frame quality measures) → raw argmax.
//!
//! Tracking over frames is not part of it (the `cma-tracking` crate).

use crate::background_field::{BackgroundField, BackgroundFieldState};
use crate::capsule_calibration::{CapsuleCalibration, CapsuleCalibrationState, CapsuleEstimate};
use crate::curve_kernel::{CurveKernel, DistancePower};
use crate::direct_sound::{DirectSound, OnsetState};
use crate::error::Error;
use crate::estimate::Flags;
use crate::frame_quality::FrameQuality;
use crate::frame_spectra::FrameSpectra;
use crate::interpolation::argmax_parabolic;
use crate::peak_picker::{PeakPicker, PeakSettings, Peaks};
use crate::reference_table::ReferenceTable;
use crate::reliability::{curve_variance_with_sum, Reliability};
use crate::similarity::{
    normalise_frame_curve, CurveBuilder, CurveSettings, PeakFeature, RowCache,
};
use crate::spectrum::power;
use crate::{CARDIOIDS, CHANNELS, FRAME_LEN, HOP, MAX_AZIMUTHS, MAX_PEAKS, NUM_BINS};

/// The cardioids `xc` of a peak (omni `w`, power `p0` > 0) with a stationary background's
/// `excess` (per cardioid, omni power units) taken off their active ratios: X_c − (e_c/|X_0|²)·X_0,
/// the factor clamped to ±½ (a bin far below its background is not turned around).
fn without_excess(
    xc: [microfft::Complex32; CARDIOIDS],
    w: microfft::Complex32,
    excess: &[f32; CARDIOIDS],
    p0: f32,
) -> [microfft::Complex32; CARDIOIDS] {
    let inv = 1.0 / p0;
    core::array::from_fn(|c| {
        let f = (excess[c] * inv).clamp(-0.5, 0.5);
        microfft::Complex32::new(xc[c].re - f * w.re, xc[c].im - f * w.im)
    })
}

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

/// What a frame gives the tracking stages.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameResult {
    /// Reliability b of the frame: the gate times the curve's reliability (or the frame quality
    /// measures); 0 without usable peaks.
    pub b: f32,
    /// Interpolated argmax of the frame's curve (`None` without usable peaks).
    pub raw: Option<f32>,
    /// Number of usable peaks, at the start of the caller's buffer.
    pub num_peaks: usize,
}

/// The settings of the similarity method on one frame (in the configuration file, top-level keys
/// and tables of the same names).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimilaritySettings {
    /// The analysis band and its peaks.
    pub peaks: PeakSettings,
    /// The measure, the noisy references and the features of the similarity curve.
    pub curves: CurveSettings,
    /// What the stage reads on every frame.
    pub frame: FrameSettings,
}

/// The settings [`SimilarityFrame::process`] reads on every frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameSettings {
    /// The per-peak term of the similarity curve ([`CurveKernel`]).
    pub kernel: CurveKernel,
    /// Direct-sound emphasis of peaks (not in the thesis).
    pub direct_sound: DirectSound,
    /// Reliability weighting of the similarity curve.
    pub reliability: Reliability,
    /// The thesis's frame quality measures and binary threshold b_TH (§5.1.6); with the
    /// `thesis-options` feature only.
    pub quality: FrameQuality,
}

impl FrameSettings {
    /// The settings of an unconfigured stage (the thesis's).
    pub const IDLE: FrameSettings = FrameSettings {
        kernel: CurveKernel::Reciprocal,
        direct_sound: DirectSound::OFF,
        reliability: Reliability {
            enabled: true,
            speed: 1.0,
            v_max: 0.02,
            v_floor: 0.0,
            exponent: 1.0,
        },
        quality: FrameQuality::DEFAULT,
    };
}

/// The similarity method's per-frame stage and its state (peaks, curves, the direct-sound onset
/// history, the self-calibration).
pub struct SimilarityFrame {
    /// Analysis rate, Hz.
    fs: f32,
    /// What the stage reads on every frame.
    settings: FrameSettings,
    /// The power of the separate distance curve of the grid tracker's refinement, if it has one.
    refine: Option<DistancePower>,
    picker: PeakPicker,
    curves: CurveBuilder,
    /// Per-azimuth constants of the last reference row used by the similarity curve.
    row_cache: RowCache,
    /// Frequency row of the reference table for each bin.
    bin_rows: [u16; NUM_BINS],
    omni_power: [f32; NUM_BINS],
    peaks: Peaks,
    curve: [f32; MAX_AZIMUTHS],
    /// The last frame's negated mean distance curve −Σ w·d^p / Σ w
    /// (the grid tracker's refinement curve), when the grid tracker refines its estimate with one.
    distance: [f32; MAX_AZIMUTHS],
    onset: OnsetState,
    /// Blind self-calibration of the cardioids.
    capsules: CapsuleCalibrationState,
    /// The measured stationary background (the noise-field report, the stationary excess).
    background: BackgroundFieldState,
    /// Whether a directional background's stationary excess is taken off the peaks: with the
    /// ideal model's table, whose diffuse point the excess is measured from (a measured table
    /// holds the capsules' own).
    take_off_excess: bool,
    /// The estimate the self-calibration starts from at every reset.
    capsule_start: CapsuleEstimate,
    diagnostics: FrameDiagnostics,
}

impl Default for SimilarityFrame {
    fn default() -> Self {
        Self::new()
    }
}

impl SimilarityFrame {
    /// An unconfigured stage with zeroed state (12 kHz, one peak, no noisy references): a
    /// constant, for a `static`. Configure it with [`SimilarityFrame::configure`].
    #[must_use]
    pub const fn new() -> Self {
        Self {
            fs: 12_000.0,
            settings: FrameSettings::IDLE,
            refine: None,
            picker: PeakPicker::IDLE,
            curves: CurveBuilder::IDLE,
            row_cache: RowCache::new(),
            bin_rows: [0; NUM_BINS],
            omni_power: [0.0; NUM_BINS],
            peaks: Peaks::new(),
            curve: [0.0; MAX_AZIMUTHS],
            distance: [0.0; MAX_AZIMUTHS],
            onset: OnsetState::new(),
            capsules: CapsuleCalibrationState::idle(),
            background: BackgroundFieldState::idle(),
            take_off_excess: false,
            capsule_start: CapsuleEstimate::IDEAL,
            diagnostics: FrameDiagnostics {
                curve_variance: 0.0,
                num_peaks: 0,
                mean_peak_weight: 0.0,
            },
        }
    }

    /// Builds the stage from `settings` (validated by the composing `LocatorConfig::validate`) for
    /// `table` at analysis rate `fs` Hz, with the distance curve of power `refine` when the grid
    /// tracker refines its estimate with one; on error (the SNR sets of the noisy references)
    /// nothing is changed. Leaves the state alone.
    pub fn configure(
        &mut self,
        settings: &SimilaritySettings,
        refine: Option<DistancePower>,
        table: &ReferenceTable<'_>,
        fs: f32,
    ) -> Result<(), Error> {
        let picker = PeakPicker::from_config(&settings.peaks, fs);
        let curves = CurveBuilder::from_config(&settings.curves)?;
        for (k, row) in self.bin_rows.iter_mut().enumerate() {
            *row = table.freq_index(crate::spectrum::bin_frequency(k, fs)) as u16;
        }
        self.fs = fs;
        self.take_off_excess = table.is_ideal_model();
        self.settings = settings.frame;
        self.refine = refine;
        self.picker = picker;
        self.curves = curves;
        self.row_cache.clear();
        Ok(())
    }

    /// Zeroes the per-frame buffers, the onset history and the diagnostics (the settings stay).
    pub fn reset(&mut self) {
        self.omni_power.fill(0.0);
        self.peaks = Peaks::new();
        self.curve.fill(0.0);
        self.distance.fill(0.0);
        self.onset = OnsetState::new();
        self.diagnostics = FrameDiagnostics::default();
    }

    /// Restarts the self-calibration with `settings` from its start estimate
    /// ([`SimilarityFrame::set_capsule_start`]).
    pub fn reset_calibration(&mut self, settings: CapsuleCalibration) {
        let fs = self.fs;
        self.capsules
            .reset(settings, fs, fs / HOP as f32, &self.capsule_start);
    }

    /// Whether a stationary source dominates the measured background
    /// ([`BackgroundFieldState::source_dominates`]; never without the `noise-field` feature or with
    /// the background field off, which measures nothing).
    #[must_use]
    pub fn background_source_dominates(&self) -> bool {
        cfg!(feature = "noise-field") && self.background.source_dominates()
    }

    /// Restarts the background field with `settings` (nothing measured yet).
    pub fn reset_background(&mut self, settings: BackgroundField) {
        let fs = self.fs;
        self.background.reset(settings, fs, fs / HOP as f32);
    }

    /// Sets the estimate the self-calibration starts from and applies it now.
    pub fn set_capsule_start(&mut self, start: &CapsuleEstimate) {
        self.capsule_start = *start;
        self.capsules.restore(start);
    }

    /// Runs the stage with its settings on `frame`: `gate` scales b, `clean` says whether the frame may teach the
    /// self-calibration, `talker` is the tracked azimuth so far (`None` before the first reliable
    /// frame). The usable peaks (features, table rows, weights) go to the start of `used` (the
    /// caller's per-frame scratch, also the multi-talker tracks' input). Sets [`Flags::NO_PEAKS`]
    /// when no peak is usable.
    #[allow(clippy::too_many_arguments)]
    pub fn process(
        &mut self,
        frame: &[[f32; FRAME_LEN]; CHANNELS],
        spectra: &mut FrameSpectra,
        table: &ReferenceTable<'_>,
        used: &mut [PeakFeature; MAX_PEAKS],
        gate: f32,
        clean: bool,
        talker: Option<f32>,
        flags: &mut Flags,
    ) -> FrameResult {
        spectra.transform_omni_fold_cardioids(frame);
        let calibrating = self.capsules.settings().enabled;
        self.pick_peaks(spectra, clean, calibrating);
        let (n_used, weight_sum) =
            self.peak_features(spectra, used, self.settings.direct_sound, calibrating);
        let q = table.num_azimuths();
        self.curves.frame_curve(
            &mut self.row_cache,
            table,
            &used[..n_used],
            self.settings.kernel,
            self.refine,
            &mut self.curve[..q],
            &mut self.distance[..q],
        );
        let ds = self.settings.direct_sound;
        if ds.onset_exponent > 0.0 {
            let (lo, hi) = self.picker.band();
            self.onset.update(ds.onset_pole, &self.omni_power, lo, hi);
        }
        let (b, curve_reliability) =
            self.reliability(q, gate, n_used, weight_sum, &frame[0], flags);
        let raw = if n_used > 0 {
            argmax_parabolic(&self.curve[..q], table.azimuths_deg()).map(|(a, _)| a)
        } else {
            None
        };
        if calibrating {
            // A background whose curve points somewhere is directional: not learned from.
            let directional = curve_reliability > self.capsules.settings().directional_reliability;
            self.capsules.end_frame(talker, directional);
            // The talker's frames for the speech check: speech whose own estimate lies within 60°
            // of his track (not the frames of a talker the track has not yet followed to a new
            // place).
            let near = |t: f32| raw.is_some_and(|r| crate::angle::wrap_deg(r - t).abs() <= 60.0);
            self.capsules
                .end_speech_frame(talker.filter(|t| near(*t)), gate > 0.5);
        }
        self.diagnostics.num_peaks = n_used;
        self.diagnostics.mean_peak_weight = if n_used > 0 {
            weight_sum / n_used as f32
        } else {
            0.0
        };
        FrameResult {
            b,
            raw,
            num_peaks: n_used,
        }
    }

    /// The omni power in the bins the picker reads and the frame's peaks; starts the
    /// self-calibration's frame.
    fn pick_peaks(&mut self, spectra: &FrameSpectra, clean: bool, calibrating: bool) {
        // Only the bins the picker reads (every later use is at a picked bin); the rest stay 0.
        let bins = self.picker.reads();
        for (p, c) in self.omni_power[bins.clone()]
            .iter_mut()
            .zip(&spectra.omni()[bins])
        {
            *p = power(*c);
        }
        self.picker.process(&self.omni_power, &mut self.peaks);
        let (lo, hi) = self.picker.band();
        if calibrating {
            self.capsules.begin_frame(&self.omni_power, lo, hi, clean);
        }
        if cfg!(feature = "noise-field") && self.background.settings().enabled {
            self.background.begin_frame(&self.omni_power, lo, hi, clean);
        }
    }

    /// The features, table rows and weights (direct-sound weighting `ds`) of the usable peaks into
    /// `used`, the cardioids corrected when `calibrating`; returns their number and the sum of
    /// their weights.
    fn peak_features(
        &mut self,
        spectra: &FrameSpectra,
        used: &mut [PeakFeature; MAX_PEAKS],
        ds: DirectSound,
        calibrating: bool,
    ) -> (usize, f32) {
        let omni = spectra.omni();
        let measuring = cfg!(feature = "noise-field") && self.background.settings().enabled;
        let mut weight_sum = 0.0f32;
        let mut n_used = 0usize;
        // On x86_64 the cardioid bins of all peaks first, two recursions at a time (the Cortex-M4F
        // computes each where it is used).
        #[cfg(target_arch = "x86_64")]
        let xcs = {
            let mut xcs = [[microfft::Complex32::new(0.0, 0.0); 3]; MAX_PEAKS];
            crate::spectrum::dft_bins3_many(spectra.folds(), self.peaks.bins(), &mut xcs);
            xcs
        };
        for i in 0..self.peaks.len() {
            let k = usize::from(self.peaks.bins()[i]);
            let p0 = self.omni_power[k];
            #[cfg(target_arch = "x86_64")]
            let xc = xcs[i];
            #[cfg(not(target_arch = "x86_64"))]
            let xc = spectra.cardioids_at(k);
            let xc = if calibrating {
                self.capsules.correct(k, omni[k], xc)
            } else {
                xc
            };
            let xc = if measuring {
                self.background.add_peak(k, omni[k], &xc);
                let excess = if self.take_off_excess {
                    self.background.excess(k)
                } else {
                    None
                };
                match excess {
                    Some(e) if p0 > 0.0 => without_excess(xc, omni[k], &e, p0),
                    _ => xc,
                }
            } else {
                xc
            };
            let Some(y) = self.curves.features.of_bin(omni[k], p0, xc) else {
                continue;
            };
            let w = if ds.enabled() {
                let delta = DirectSound::directness(omni[k], xc);
                ds.peak_weight(&self.onset, k, p0, delta)
            } else {
                1.0
            };
            if !(w > 0.0) {
                continue;
            }
            if calibrating {
                self.capsules.speech_peak(y);
            }
            let fi = self.bin_rows[k] as usize;
            let Some(slot) = used.get_mut(n_used) else {
                break;
            };
            *slot = PeakFeature { fi, y, weight: w };
            weight_sum += w;
            n_used += 1;
        }
        if measuring {
            self.background.end_frame();
        }
        (n_used, weight_sum)
    }

    /// Normalises the frame's curve and rates it: returns (b, the curve's own reliability before
    /// any gate). Without usable peaks the curves are zero, b is 0 and [`Flags::NO_PEAKS`] is set.
    #[allow(clippy::too_many_arguments)]
    fn reliability(
        &mut self,
        q: usize,
        gate: f32,
        n_used: usize,
        weight_sum: f32,
        omni: &[f32; FRAME_LEN],
        flags: &mut Flags,
    ) -> (f32, f32) {
        let c = &self.settings;
        let curve = &mut self.curve[..q];
        let distance = &mut self.distance[..q];
        let mut b = gate;
        let variance;
        let mut curve_reliability = 0.0;
        if n_used == 0 || !(weight_sum > 0.0) {
            flags.insert(Flags::NO_PEAKS);
            curve.fill(0.0);
            distance.fill(0.0);
            b = 0.0;
            variance = 0.0;
        } else {
            let sum =
                normalise_frame_curve(c.kernel, self.refine.is_some(), weight_sum, curve, distance);
            variance = curve_variance_with_sum(curve, sum);
            curve_reliability = c.reliability.coefficient(variance);
            b *= curve_reliability;
            // Thesis option: alternative frame quality measures / binary b (frame_quality.rs).
            if cfg!(feature = "thesis-options") && !c.quality.is_default() {
                b = gate
                    * c.quality.coefficient(
                        &c.reliability,
                        variance,
                        omni,
                        self.fs,
                        &self.omni_power,
                        self.peaks.bins(),
                    );
            }
        }
        self.diagnostics.curve_variance = variance;
        (b, curve_reliability)
    }

    /// The last frame's unfiltered similarity curve over the first `q` azimuths.
    #[must_use]
    pub fn curve(&self, q: usize) -> &[f32] {
        &self.curve[..q]
    }

    /// The curve whose running mean refines the grid tracker's estimate: the separate distance
    /// curve when there is one, else the similarity curve (first `q` azimuths).
    #[must_use]
    pub fn refine_curve(&self, q: usize) -> &[f32] {
        if self.refine.is_some() {
            &self.distance[..q]
        } else {
            &self.curve[..q]
        }
    }

    /// The picked bins of the last frame.
    #[must_use]
    pub fn peak_bins(&self) -> &[u16] {
        self.peaks.bins()
    }

    /// The peak picker.
    #[must_use]
    pub fn picker(&self) -> &PeakPicker {
        &self.picker
    }

    /// The similarity-curve builder.
    #[must_use]
    pub fn curve_builder(&self) -> &CurveBuilder {
        &self.curves
    }

    /// Frequency row of the reference table for each bin.
    #[must_use]
    pub fn bin_rows(&self) -> &[u16; NUM_BINS] {
        &self.bin_rows
    }

    /// Diagnostics of the last frame.
    #[must_use]
    pub fn diagnostics(&self) -> FrameDiagnostics {
        self.diagnostics
    }

    /// The self-calibration's state.
    #[must_use]
    pub fn capsule_state(&self) -> &CapsuleCalibrationState {
        &self.capsules
    }

    /// The self-calibration's current estimate of the cardioids.
    #[must_use]
    pub fn capsule_estimate(&self) -> &CapsuleEstimate {
        self.capsules.estimate()
    }

    /// The measured stationary background (read-only; [`BackgroundFieldState::band_summary`]
    /// gives each band's direction, directivity and level).
    #[must_use]
    pub fn background_field(&self) -> &BackgroundFieldState {
        &self.background
    }

    /// The self-calibration's confidence in [0, 1] (0 when it is off).
    #[must_use]
    pub fn capsule_confidence(&self) -> f32 {
        if self.capsules.settings().enabled {
            self.capsules.confidence()
        } else {
            0.0
        }
    }
}
