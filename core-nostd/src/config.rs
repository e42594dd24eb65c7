//! Configuration of the localizer: plain values, fixed while the localizer runs. The settings
//! types are the stages' own (in their crates); [`LocatorConfig`] composes them, and its methods
//! give each stage its part ([`LocatorConfig::similarity_settings`], …).

use crate::alternative_result::AlternativeSettings;
use crate::background_field::BackgroundField;
use crate::capsule_calibration::CapsuleCalibration;
use crate::cartesian_filter::Smoothing;
use crate::combination::{Combination, FdivSpread};
use crate::curve_kernel::CurveKernel;
use crate::direct_sound::DirectSound;
use crate::error::Error;
use crate::features::FeatureKind;
use crate::frame_onset::FrameOnset;
use crate::frame_quality::FrameQuality;
use crate::front_end::FrontEndSettings;
use crate::intensity::{IntensitySettings, IvMethod};
use crate::multi_track::MultiTrack;

// The multi-talker tracks' error message names the span decision's limit.
const _: () = assert!(crate::track_spans::MAX_SPAN_FRAMES == 24);
use crate::noise_floor::NoiseGate;
use crate::noisy_reference::NoiseMixing;
use crate::peak_picker::PeakSettings;
use crate::reference_table::ReferenceTable;
use crate::refine_curve::{refine_distance_power, DistancePower};
use crate::reliability::Reliability;
use crate::similarity::{CurveSettings, SimilarityMeasure};
use crate::similarity_frame::{FrameSettings, SimilaritySettings};
use crate::MAX_PEAKS;

pub use crate::curve_tracker::{Tracking, DEFAULT_GRID_TRACKER};

/// Which localization principle runs (appendix A `se.principle`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Method {
    /// The similarity approach (thesis §5.1).
    Similarity,
    /// Frequency-domain intensity vector (§5.2.2).
    Fdiv,
    /// Time-domain intensity vector (§5.2.1).
    Tdiv,
}

/// The product's noise-floor gate ([`NoiseGate`]).
pub const DEFAULT_NOISE_GATE: NoiseGate = NoiseGate {
    enabled: true,
    rise_db_per_s: 1.0,
    open_db: 0.5,
    full_db: 2.0,
    directional_db: 3.0,
};

/// The product's frame onset weighting of b ([`FrameOnset`]): the settings of
/// [`FrameOnset::OFF`], switched on.
pub const DEFAULT_FRAME_ONSET: FrameOnset = FrameOnset {
    enabled: true,
    ..FrameOnset::OFF
};

/// Everything that can be set: the settings of every stage, in the order of the pipeline (each type
/// is its stage's own, in the stage's crate). Build one with [`LocatorConfig::default`] (the
/// product) or [`LocatorConfig::thesis`] (the published method) and change fields.
///
/// The configuration file keeps one flat list of keys ([`ConfigFile`], the serde form of this
/// type): `band_lo_hz` is `peaks.band_lo_hz` here, `measure` is `curves.measure`, and so on.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(from = "ConfigFile", into = "ConfigFile"))]
pub struct LocatorConfig {
    /// Localization principle: the similarity method, or a baseline (`thesis-options` feature).
    pub method: Method,
    /// Input guard and frame level ([`crate::front_end`], [`crate::frame_level`]).
    pub front_end: FrontEndSettings,
    /// Noise-floor gate of the reliability b (similarity method; not in the thesis).
    pub noise_gate: NoiseGate,
    /// The analysis band and its peaks ([`crate::peak_picker`]).
    pub peaks: PeakSettings,
    /// Blind self-calibration of the cardioids from the diffuse background (similarity method; not
    /// in the thesis).
    pub capsule_calibration: CapsuleCalibration,
    /// The measured stationary background the noisy references mix toward
    /// ([`crate::background_field`]).
    pub background: BackgroundField,
    /// Direct-sound emphasis of peaks (not in the thesis).
    pub direct_sound: DirectSound,
    /// The measure, the noisy references and the features of the similarity curve
    /// ([`crate::similarity`]).
    pub curves: CurveSettings,
    /// The per-peak term of the similarity curve: the measure's own value (the thesis) or
    /// 1 − k·d^p of the measure's distance d ([`CurveKernel`]).
    pub kernel: CurveKernel,
    /// Reliability weighting of the similarity curve.
    pub reliability: Reliability,
    /// Frame quality measures and binary threshold b_TH (§5.1.6, eq. 5.21–5.29, 5.36;
    /// `thesis-options` feature).
    pub quality: FrameQuality,
    /// Frame onset weighting of the reliability b (similarity method; not in the thesis).
    pub frame_onset: FrameOnset,
    /// How curves are combined over time.
    pub tracking: Tracking,
    /// Several talkers at once: tracks with persistent IDs (similarity method; off by default).
    pub multi_track: MultiTrack,
    /// The thesis's alternative results: combination rule 2, Cartesian filtering
    /// (`thesis-options` feature).
    pub alternative: AlternativeSettings,
    /// The intensity-vector baselines' poles and FDIV spread (`thesis-options` feature).
    pub intensity: IntensitySettings,
}

/// The configuration file's form of [`LocatorConfig`]: every setting under its key, the stages'
/// settings flattened to the top level as the file has always had them. It is the serde form of
/// [`LocatorConfig`] (with the `serde` feature) and the constant the firmware embeds
/// ([`ConfigFile::into_config`]).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct ConfigFile {
    /// Localization principle.
    pub method: Method,
    /// Lower edge of the analysis band, Hz.
    pub band_lo_hz: f32,
    /// Upper edge of the analysis band, Hz.
    pub band_hi_hz: f32,
    /// Number of peaks N_p (1…[`crate::MAX_PEAKS`]).
    pub num_peaks: usize,
    /// Absolute magnitude threshold for peaks on |X_omni| (0 disables).
    pub peak_threshold: f32,
    /// Fill up to N_p with the strongest non-peak bins (§5.1.2).
    pub fill_peaks: bool,
    /// Similarity measure.
    pub measure: SimilarityMeasure,
    /// The per-peak term of the similarity curve: the measure's own value (the thesis) or
    /// 1 − k·d^p of the measure's distance d ([`CurveKernel`]).
    pub kernel: CurveKernel,
    /// Noisy reference features: mixing rule.
    pub noise_mixing: NoiseMixing,
    /// Noisy reference features: lowest SNR set, dB.
    pub snr_from_db: f32,
    /// Noisy reference features: highest SNR set, dB.
    pub snr_to_db: f32,
    /// Noisy reference features: SNR step, dB.
    pub snr_step_db: f32,
    /// Mean-free features (appendix A `meanFree`).
    pub mean_free: bool,
    /// Which ratio the peak features are (the thesis: magnitudes).
    pub features: FeatureKind,
    /// Reliability weighting of the similarity curve.
    pub reliability: Reliability,
    /// How curves are combined over time.
    pub tracking: Tracking,
    /// Direct-sound emphasis of peaks (not in the thesis).
    pub direct_sound: DirectSound,
    /// Omni mean-square power below which a frame is silent (b = 0).
    pub silence_power: f32,
    /// |sample| at or above which the input counts as clipped.
    pub clip_level: f32,
    /// Confidence factor applied to frames with clipped samples.
    pub clipped_confidence: f32,
    /// TDIV smoothing pole a (eq. 5.40).
    pub tdiv_pole: f32,
    /// FDIV smoothing pole a of the per-bin intensity.
    pub fdiv_pole: f32,
    // Thesis alternatives; the defaults leave the method above unchanged.
    /// Frame quality measures and binary threshold b_TH (§5.1.6, eq. 5.21–5.29, 5.36).
    pub quality: FrameQuality,
    /// Noise-floor gate of the reliability b (similarity method; not in the thesis).
    pub noise_gate: NoiseGate,
    /// Frame onset weighting of the reliability b (similarity method; not in the thesis).
    pub frame_onset: FrameOnset,
    /// Blind self-calibration of the cardioids from the diffuse background (similarity method; not
    /// in the thesis).
    pub capsule_calibration: CapsuleCalibration,
    /// The measured stationary background the noisy references mix toward
    /// ([`crate::background_field`]).
    pub background: BackgroundField,
    /// How the peaks of a frame are combined (§5.1.4: rule 1 mean curve, rule 2 eq. 5.13).
    pub combination: Combination,
    /// Where b filters: the similarity curve (eq. 5.31) or the result in Cartesian form (eq. 5.30).
    pub smoothing: Smoothing,
    /// FDIV frame reliability from the circular standard deviation over bins (§5.2.2).
    pub fdiv_spread: FdivSpread,
    /// Several talkers at once: tracks with persistent IDs (similarity method; off by default).
    pub multi_track: MultiTrack,
}

impl LocatorConfig {
    /// The thesis configuration (§5.1 and appendix A defaults, conventions of `docs/algorithm.md`):
    /// 5° ideal table, 10 peaks in 200–4000 Hz, Euclidean similarity, magnitude-mixed noisy references
    /// −30…40 dB, curve-variance reliability weighting with K = 1, no direct-sound weighting.
    #[must_use]
    pub const fn thesis() -> Self {
        Self {
            method: Method::Similarity,
            front_end: FrontEndSettings {
                silence_power: 1e-10,
                clip_level: 0.999,
                clipped_confidence: 0.5,
            },
            noise_gate: NoiseGate::OFF,
            peaks: PeakSettings {
                band_lo_hz: 200.0,
                band_hi_hz: 4000.0,
                num_peaks: 10,
                peak_threshold: 0.0,
                fill_peaks: true,
            },
            capsule_calibration: CapsuleCalibration::OFF,
            background: BackgroundField::OFF,
            direct_sound: DirectSound::OFF,
            curves: CurveSettings {
                measure: SimilarityMeasure::Euclidean,
                noise_mixing: NoiseMixing::Magnitude,
                snr_from_db: -30.0,
                snr_to_db: 40.0,
                snr_step_db: 10.0,
                mean_free: false,
                features: FeatureKind::Magnitude,
            },
            kernel: CurveKernel::Reciprocal,
            reliability: Reliability {
                enabled: true,
                speed: 1.0,
                v_max: 0.02,
                v_floor: 0.0,
                exponent: 1.0,
            },
            quality: FrameQuality::DEFAULT,
            frame_onset: FrameOnset::OFF,
            tracking: Tracking::OnePole,
            multi_track: MultiTrack::OFF,
            alternative: AlternativeSettings {
                combination: Combination::MeanCurve,
                smoothing: Smoothing::Curve,
            },
            intensity: IntensitySettings {
                tdiv_pole: 0.9,
                fdiv_pole: 0.95,
                fdiv_spread: FdivSpread::OFF,
            },
        }
    }

    /// Checks the values for analysis rate `fs` Hz and reference `table`: the error names the
    /// first setting out of range ([`crate::Locator::new`] runs it; the noisy references' SNR sets
    /// are checked where they are built).
    pub fn validate(&self, fs: f32, table: &ReferenceTable<'_>) -> Result<(), Error> {
        self.validate_analysis(fs, table)?;
        self.validate_stages(table)
    }

    /// The band, peaks, reliability, poles, direct-sound weights, thresholds and features.
    fn validate_analysis(&self, fs: f32, table: &ReferenceTable<'_>) -> Result<(), Error> {
        let c = self;
        let (p, i) = (&c.peaks, &c.intensity);
        if !(p.band_lo_hz >= 0.0 && p.band_hi_hz > p.band_lo_hz && p.band_hi_hz <= fs / 2.0) {
            return invalid("band: need 0 ≤ lo < hi ≤ analysis Nyquist");
        }
        if p.num_peaks == 0 || p.num_peaks > MAX_PEAKS {
            return invalid("num_peaks: 1..=32");
        }
        if !c.reliability.is_valid() {
            return invalid("reliability: need K ≥ 0 and V_max > V_floor ≥ 0");
        }
        if !(0.0..1.0).contains(&i.tdiv_pole) || !(0.0..1.0).contains(&i.fdiv_pole) {
            return invalid("poles: need 0 ≤ a < 1");
        }
        if !c.direct_sound.is_valid() {
            return invalid("direct_sound: exponents ≥ 0, 0 ≤ pole < 1, 0 ≤ floor ≤ 1");
        }
        let f = &c.front_end;
        if !(p.peak_threshold >= 0.0) || !(f.silence_power >= 0.0) || !(f.clip_level > 0.0) {
            return invalid("thresholds must be ≥ 0");
        }
        if !table.serves(c.curves.features) {
            return invalid(
                "the reference table has no rows for this feature kind (CMA_TABLE_FEATURES)",
            );
        }
        if c.curves.features == FeatureKind::Active && c.curves.noise_mixing == NoiseMixing::Power {
            return invalid(
                "active features mix noise linearly: use magnitude (or no) noise mixing",
            );
        }
        Ok(())
    }

    /// The settings of the gates, the self-calibration, the kernel, the tracking and the thesis
    /// options.
    fn validate_stages(&self, table: &ReferenceTable<'_>) -> Result<(), Error> {
        let c = self;
        if c.noise_gate.enabled && !c.noise_gate.is_valid() {
            return invalid("noise gate: need a finite rise ≥ 0 and open < full");
        }
        if c.frame_onset.enabled && !c.frame_onset.is_valid() {
            return invalid("frame onset: history 1…8 frames, finite low < high, floor in [0, 1]");
        }
        if c.capsule_calibration.enabled && !table.is_ideal_model() {
            return invalid(
                "self-calibration maps the capsules to the ideal model: switch it off with a measured table",
            );
        }
        if c.capsule_calibration.enabled && !c.capsule_calibration.is_valid() {
            return invalid(
                "self-calibration: finite background dB ≥ 0, memory ≥ 1 frame, prior ≥ 0, anisotropy > 0, omni spread bound ≥ 0",
            );
        }
        if c.background.enabled && !c.background.is_valid() {
            return invalid("background: finite background dB ≥ 0, rise ≥ 0, memory ≥ 1 frame, excess directivity ≥ 0");
        }
        if !c.kernel.is_valid() {
            return invalid("kernel: need a finite scale > 0");
        }
        if let Tracking::Grid(t) = c.tracking {
            if !t.is_valid() {
                return invalid(
                    "grid tracker: values finite; probabilities, poles, floors, refine gain in [0, 1]; the rest ≥ 0",
                );
            }
        }
        if c.multi_track.enabled && !cfg!(feature = "multi-talker") {
            return invalid(
                "multi-talker tracks: cma-core was built without its `multi-talker` feature",
            );
        }
        if c.multi_track.enabled && (c.method != Method::Similarity || !c.multi_track.is_valid()) {
            return invalid(
                "multi-talker tracks: similarity method only; finite gates in (0, 180], poles in [0, 1), gains, shares and levels in [0, 1], 0 ≤ off ≤ on ≤ 1, relative_on ≤ unheard_relative_on, span_gap_frames + span_lead_frames ≤ 24, span_min_frames ≤ span_gap_frames",
            );
        }
        if !c.quality.is_valid() {
            return invalid("quality: scales must be > 0 and finite");
        }
        if !cfg!(feature = "thesis-options") && c.uses_thesis_options() {
            return invalid(
                "the thesis options and the baselines (method fdiv/tdiv, quality, combination, smoothing, fdiv_spread): cma-core was built without its `thesis-options` feature",
            );
        }
        Ok(())
    }

    /// `true` when the configuration selects a baseline method or a thesis option other than the
    /// thesis's default (the stages of the `thesis-options` feature).
    #[must_use]
    pub fn uses_thesis_options(&self) -> bool {
        self.method != Method::Similarity
            || !self.quality.is_default()
            || self.alternative.combination != Combination::MeanCurve
            || self.alternative.smoothing != Smoothing::Curve
            || self.intensity.fdiv_spread.enabled()
    }

    /// The settings of the similarity method on one frame.
    #[must_use]
    pub fn similarity_settings(&self) -> SimilaritySettings {
        SimilaritySettings {
            peaks: self.peaks,
            curves: self.curves,
            frame: FrameSettings {
                kernel: self.kernel,
                direct_sound: self.direct_sound,
                reliability: self.reliability,
                quality: self.quality,
            },
        }
    }

    /// The power of the distance curve of the grid tracker's refinement, if it has one
    /// ([`refine_distance_power`]).
    #[must_use]
    pub fn refine_power(&self) -> Option<DistancePower> {
        refine_distance_power(self.kernel, &self.tracking)
    }

    /// Which intensity-vector method runs (FDIV for the similarity method, where none runs).
    #[must_use]
    pub fn intensity_method(&self) -> IvMethod {
        if self.method == Method::Tdiv {
            IvMethod::Tdiv
        } else {
            IvMethod::Fdiv
        }
    }
}

/// The error of an invalid setting.
fn invalid(what: &'static str) -> Result<(), Error> {
    Err(Error::InvalidConfig(what))
}

impl Default for LocatorConfig {
    /// The product configuration: the thesis method plus the measured improvements (docs/history.md,
    /// "Accuracy"): onset weighting of peaks, a variance floor and a tighter scale for b, the
    /// Bayesian grid tracker with velocity drift instead of the one-pole curve filter, 16 peaks
    /// instead of 10, the noise-floor gate and the frame onset weighting of b, and active-ratio features.
    fn default() -> Self {
        let mut c = Self::thesis();
        c.kernel = CurveKernel::DEFAULT;
        c.peaks.num_peaks = 16;
        c.reliability.v_floor = 0.0004;
        c.reliability.v_max = 0.0045;
        c.direct_sound.onset_exponent = 1.0;
        c.tracking = Tracking::Grid(DEFAULT_GRID_TRACKER);
        c.noise_gate = DEFAULT_NOISE_GATE;
        c.curves.features = FeatureKind::Active;
        c.frame_onset = DEFAULT_FRAME_ONSET;
        c.capsule_calibration = CapsuleCalibration::DEFAULT;
        c.background = BackgroundField::DEFAULT;
        c
    }
}

impl ConfigFile {
    /// The composed configuration of these settings.
    #[must_use]
    pub const fn into_config(self) -> LocatorConfig {
        let f = self;
        LocatorConfig {
            method: f.method,
            front_end: FrontEndSettings {
                silence_power: f.silence_power,
                clip_level: f.clip_level,
                clipped_confidence: f.clipped_confidence,
            },
            noise_gate: f.noise_gate,
            peaks: PeakSettings {
                band_lo_hz: f.band_lo_hz,
                band_hi_hz: f.band_hi_hz,
                num_peaks: f.num_peaks,
                peak_threshold: f.peak_threshold,
                fill_peaks: f.fill_peaks,
            },
            capsule_calibration: f.capsule_calibration,
            background: f.background,
            direct_sound: f.direct_sound,
            curves: CurveSettings {
                measure: f.measure,
                noise_mixing: f.noise_mixing,
                snr_from_db: f.snr_from_db,
                snr_to_db: f.snr_to_db,
                snr_step_db: f.snr_step_db,
                mean_free: f.mean_free,
                features: f.features,
            },
            kernel: f.kernel,
            reliability: f.reliability,
            quality: f.quality,
            frame_onset: f.frame_onset,
            tracking: f.tracking,
            multi_track: f.multi_track,
            alternative: AlternativeSettings {
                combination: f.combination,
                smoothing: f.smoothing,
            },
            intensity: IntensitySettings {
                tdiv_pole: f.tdiv_pole,
                fdiv_pole: f.fdiv_pole,
                fdiv_spread: f.fdiv_spread,
            },
        }
    }

    /// The file's form of `c`.
    #[must_use]
    pub const fn of_config(c: &LocatorConfig) -> Self {
        ConfigFile {
            method: c.method,
            band_lo_hz: c.peaks.band_lo_hz,
            band_hi_hz: c.peaks.band_hi_hz,
            num_peaks: c.peaks.num_peaks,
            peak_threshold: c.peaks.peak_threshold,
            fill_peaks: c.peaks.fill_peaks,
            measure: c.curves.measure,
            kernel: c.kernel,
            noise_mixing: c.curves.noise_mixing,
            snr_from_db: c.curves.snr_from_db,
            snr_to_db: c.curves.snr_to_db,
            snr_step_db: c.curves.snr_step_db,
            mean_free: c.curves.mean_free,
            features: c.curves.features,
            reliability: c.reliability,
            tracking: c.tracking,
            direct_sound: c.direct_sound,
            silence_power: c.front_end.silence_power,
            clip_level: c.front_end.clip_level,
            clipped_confidence: c.front_end.clipped_confidence,
            tdiv_pole: c.intensity.tdiv_pole,
            fdiv_pole: c.intensity.fdiv_pole,
            quality: c.quality,
            noise_gate: c.noise_gate,
            frame_onset: c.frame_onset,
            capsule_calibration: c.capsule_calibration,
            background: c.background,
            combination: c.alternative.combination,
            smoothing: c.alternative.smoothing,
            fdiv_spread: c.intensity.fdiv_spread,
            multi_track: c.multi_track,
        }
    }
}

impl From<ConfigFile> for LocatorConfig {
    fn from(f: ConfigFile) -> Self {
        f.into_config()
    }
}

impl From<LocatorConfig> for ConfigFile {
    fn from(c: LocatorConfig) -> Self {
        ConfigFile::of_config(&c)
    }
}
