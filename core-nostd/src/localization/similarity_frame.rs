//! The similarity method on one analysis frame (thesis §5.1): omni power → peaks → cardioid DFT at
//! the peaks (self-calibration correction) → features and direct-sound weights → similarity curve →
//! curve variance → reliability b (or the thesis's frame quality measures) → raw argmax.
//!
//! Tracking over frames is not part of it ([`crate::curve_tracker`]).

use crate::capsule_calibration::{CapsuleCalibration, CapsuleCalibrationState, CapsuleEstimate};
use crate::config::LocatorConfig;
use crate::curve_kernel::CurveKernel;
use crate::direct_sound::{DirectSound, OnsetState};
use crate::error::Error;
use crate::estimate::Flags;
use crate::frame_quality::FrameQuality;
use crate::frame_spectra::FrameSpectra;
use crate::interpolation::argmax_parabolic;
use crate::peak_picker::{PeakPicker, Peaks};
use crate::reference_table::ReferenceTable;
use crate::refine_curve::{refine_distance_power, DistancePower};
use crate::reliability::{curve_variance_with_sum, Reliability};
use crate::similarity::{normalise_frame_curve, CurveBuilder, PeakFeature, RowCache};
use crate::spectrum::power;
use crate::{CHANNELS, FRAME_LEN, HOP, MAX_AZIMUTHS, MAX_PEAKS, NUM_BINS};

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
}

/// The settings of the stage, from the [`LocatorConfig`].
#[derive(Debug, Clone, Copy, PartialEq)]
struct Settings {
    direct_sound: DirectSound,
    kernel: CurveKernel,
    /// The power of the separate distance curve of the grid tracker's refinement, if it has one.
    refine: Option<DistancePower>,
    reliability: Reliability,
    quality: FrameQuality,
    calibration: CapsuleCalibration,
    /// Analysis rate, Hz.
    fs: f32,
}

/// The similarity method's per-frame stage and its state (peaks, curves, the direct-sound onset
/// history, the self-calibration).
pub struct SimilarityFrame {
    settings: Settings,
    picker: PeakPicker,
    curves: CurveBuilder,
    /// Per-azimuth constants of the last reference row used by the similarity curve.
    row_cache: RowCache,
    /// Frequency row of the reference table for each bin.
    bin_rows: [u16; NUM_BINS],
    omni_power: [f32; NUM_BINS],
    peaks: Peaks,
    /// The usable peaks of the frame: features, table rows and weights.
    used: [PeakFeature; MAX_PEAKS],
    n_used: usize,
    curve: [f32; MAX_AZIMUTHS],
    /// The last frame's negated mean distance curve −Σ w·d^p / Σ w
    /// ([`crate::refine_curve::RefineCurve`]), when the grid tracker refines its estimate with one.
    distance: [f32; MAX_AZIMUTHS],
    onset: OnsetState,
    /// Blind self-calibration of the cardioids.
    capsules: CapsuleCalibrationState,
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
    /// An unconfigured stage with zeroed state (the thesis settings at 12 kHz without noisy
    /// references): a constant, for a `static`. Configure it with [`SimilarityFrame::configure`].
    #[must_use]
    pub const fn new() -> Self {
        let c = LocatorConfig::thesis();
        Self {
            settings: Settings {
                direct_sound: c.direct_sound,
                kernel: c.kernel,
                refine: None,
                reliability: c.reliability,
                quality: c.quality,
                calibration: c.capsule_calibration,
                fs: 12_000.0,
            },
            picker: PeakPicker::IDLE,
            curves: CurveBuilder::IDLE,
            row_cache: RowCache::new(),
            bin_rows: [0; NUM_BINS],
            omni_power: [0.0; NUM_BINS],
            peaks: Peaks::new(),
            used: [PeakFeature::NONE; MAX_PEAKS],
            n_used: 0,
            curve: [0.0; MAX_AZIMUTHS],
            distance: [0.0; MAX_AZIMUTHS],
            onset: OnsetState::new(),
            capsules: CapsuleCalibrationState::idle(),
            capsule_start: CapsuleEstimate::IDEAL,
            diagnostics: FrameDiagnostics {
                curve_variance: 0.0,
                num_peaks: 0,
                mean_peak_weight: 0.0,
            },
        }
    }

    /// Applies the settings of `config` for `table` at analysis rate `fs` Hz (validated by
    /// [`LocatorConfig::validate`]); on error (the SNR sets of the noisy references) nothing is
    /// changed. Leaves the state alone.
    pub fn configure(
        &mut self,
        config: &LocatorConfig,
        table: &ReferenceTable<'_>,
        fs: f32,
    ) -> Result<(), Error> {
        let picker = PeakPicker::from_config(config, fs);
        let curves = CurveBuilder::from_config(config)?;
        for (k, row) in self.bin_rows.iter_mut().enumerate() {
            *row = table.freq_index(crate::spectrum::bin_frequency(k, fs)) as u16;
        }
        self.settings = Settings {
            direct_sound: config.direct_sound,
            kernel: config.kernel,
            refine: refine_distance_power(config.kernel, &config.tracking),
            reliability: config.reliability,
            quality: config.quality,
            calibration: config.capsule_calibration,
            fs,
        };
        self.picker = picker;
        self.curves = curves;
        self.row_cache.clear();
        Ok(())
    }

    /// Zeroes the per-frame buffers, the onset history and the diagnostics (the settings stay).
    pub fn reset(&mut self) {
        self.omni_power.fill(0.0);
        self.peaks = Peaks::new();
        self.n_used = 0;
        self.curve.fill(0.0);
        self.distance.fill(0.0);
        self.onset = OnsetState::new();
        self.diagnostics = FrameDiagnostics::default();
    }

    /// Restarts the self-calibration from its start estimate ([`SimilarityFrame::set_capsule_start`]).
    pub fn reset_calibration(&mut self) {
        let fs = self.settings.fs;
        self.capsules = CapsuleCalibrationState::new(
            self.settings.calibration,
            fs,
            fs / HOP as f32,
            &self.capsule_start,
        );
    }

    /// Sets the estimate the self-calibration starts from and applies it now.
    pub fn set_capsule_start(&mut self, start: &CapsuleEstimate) {
        self.capsule_start = *start;
        self.capsules.restore(start);
    }

    /// Runs the stage on `frame`: `gate` scales b, `clean` says whether the frame may teach the
    /// self-calibration, `talker` is the tracked azimuth so far (`None` before the first reliable
    /// frame). Sets [`Flags::NO_PEAKS`] when no peak is usable.
    #[allow(clippy::too_many_arguments)]
    pub fn process(
        &mut self,
        frame: &[[f32; FRAME_LEN]; CHANNELS],
        spectra: &mut FrameSpectra,
        table: &ReferenceTable<'_>,
        gate: f32,
        clean: bool,
        talker: Option<f32>,
        flags: &mut Flags,
    ) -> FrameResult {
        spectra.transform_omni_fold_cardioids(frame);
        self.pick_peaks(spectra, clean);
        let weight_sum = self.peak_features(spectra);
        let q = table.num_azimuths();
        let s = self.settings;
        self.curves.frame_curve(
            &mut self.row_cache,
            table,
            &self.used[..self.n_used],
            s.kernel,
            s.refine,
            &mut self.curve[..q],
            &mut self.distance[..q],
        );
        if s.direct_sound.onset_exponent > 0.0 {
            let (lo, hi) = self.picker.band();
            self.onset
                .update(s.direct_sound.onset_pole, &self.omni_power, lo, hi);
        }
        let (b, curve_reliability) = self.reliability(q, gate, weight_sum, &frame[0], flags);
        if s.calibration.enabled {
            // A background whose curve points somewhere is directional: not learned from.
            let directional = curve_reliability > s.calibration.directional_reliability;
            self.capsules.end_frame(talker, directional);
        }
        let n_used = self.n_used;
        self.diagnostics.num_peaks = n_used;
        self.diagnostics.mean_peak_weight = if n_used > 0 {
            weight_sum / n_used as f32
        } else {
            0.0
        };
        let raw = if n_used > 0 {
            argmax_parabolic(&self.curve[..q], table.azimuths_deg()).map(|(a, _)| a)
        } else {
            None
        };
        FrameResult { b, raw }
    }

    /// The omni power in the bins the picker reads and the frame's peaks; starts the
    /// self-calibration's frame.
    fn pick_peaks(&mut self, spectra: &FrameSpectra, clean: bool) {
        // Only the bins the picker reads (every later use is at a picked bin); the rest stay 0.
        let bins = self.picker.reads();
        for (p, c) in self.omni_power[bins.clone()]
            .iter_mut()
            .zip(&spectra.omni()[bins])
        {
            *p = power(*c);
        }
        self.picker.process(&self.omni_power, &mut self.peaks);
        if self.settings.calibration.enabled {
            let (lo, hi) = self.picker.band();
            self.capsules.begin_frame(&self.omni_power, lo, hi, clean);
        }
    }

    /// The features, table rows and weights of the usable peaks; returns the sum of their weights.
    fn peak_features(&mut self, spectra: &FrameSpectra) -> f32 {
        let ds = self.settings.direct_sound;
        let calibrating = self.settings.calibration.enabled;
        let omni = spectra.omni();
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
        for i in 0..self.peaks.len {
            let k = self.peaks.bins[i] as usize;
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
            let fi = self.bin_rows[k] as usize;
            let Some(slot) = self.used.get_mut(n_used) else {
                break;
            };
            *slot = PeakFeature { fi, y, weight: w };
            weight_sum += w;
            n_used += 1;
        }
        self.n_used = n_used;
        weight_sum
    }

    /// Normalises the frame's curve and rates it: returns (b, the curve's own reliability before
    /// any gate). Without usable peaks the curves are zero, b is 0 and [`Flags::NO_PEAKS`] is set.
    fn reliability(
        &mut self,
        q: usize,
        gate: f32,
        weight_sum: f32,
        omni: &[f32; FRAME_LEN],
        flags: &mut Flags,
    ) -> (f32, f32) {
        let s = &self.settings;
        let curve = &mut self.curve[..q];
        let distance = &mut self.distance[..q];
        let mut b = gate;
        let variance;
        let mut curve_reliability = 0.0;
        if self.n_used == 0 || !(weight_sum > 0.0) {
            flags.insert(Flags::NO_PEAKS);
            curve.fill(0.0);
            distance.fill(0.0);
            b = 0.0;
            variance = 0.0;
        } else {
            let sum =
                normalise_frame_curve(s.kernel, s.refine.is_some(), weight_sum, curve, distance);
            variance = curve_variance_with_sum(curve, sum);
            curve_reliability = s.reliability.coefficient(variance);
            b *= curve_reliability;
            // Thesis option: alternative frame quality measures / binary b (frame_quality.rs).
            if !s.quality.is_default() {
                b = gate
                    * s.quality.coefficient(
                        &s.reliability,
                        variance,
                        omni,
                        s.fs,
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
        if self.settings.refine.is_some() {
            &self.distance[..q]
        } else {
            &self.curve[..q]
        }
    }

    /// The usable peaks of the last frame.
    #[must_use]
    pub fn used_peaks(&self) -> &[PeakFeature] {
        &self.used[..self.n_used]
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

    /// The self-calibration's current estimate of the cardioids.
    #[must_use]
    pub fn capsule_estimate(&self) -> &CapsuleEstimate {
        self.capsules.estimate()
    }

    /// The self-calibration's confidence in [0, 1] (0 when it is off).
    #[must_use]
    pub fn capsule_confidence(&self) -> f32 {
        if self.settings.calibration.enabled {
            self.capsules.confidence()
        } else {
            0.0
        }
    }
}
