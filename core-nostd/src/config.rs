//! Configuration of the localizer: plain values, fixed while the localizer runs.

use crate::capsule_calibration::CapsuleCalibration;
use crate::cartesian_filter::Smoothing;
use crate::combination::{Combination, FdivSpread};
use crate::curve_kernel::CurveKernel;
use crate::direct_sound::DirectSound;
use crate::error::Error;
use crate::features::FeatureKind;
use crate::frame_onset::FrameOnset;
use crate::frame_quality::FrameQuality;
use crate::grid_tracker::GridTracker;
use crate::input_guard::InputGuard;
use crate::multi_track::MultiTrack;
use crate::noise_floor::NoiseGate;
use crate::noisy_reference::{NoiseMixing, NoisyReferences};
use crate::peak_picker::PeakPicker;
use crate::refine_curve::{DistancePower, RefineCurve};
use crate::reliability::Reliability;
use crate::similarity::{CurveBuilder, SimilarityMeasure};
use crate::{FRAME_LEN, NUM_BINS};

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

/// How the per-frame similarity curves become the reported azimuth.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub enum Tracking {
    /// The thesis: adaptive one-pole filter on the curve, S̃ = b·S + (1 − b)·S̃ (eq. 5.31).
    OnePole,
    /// Bayesian grid tracker with the curve as a b-tempered likelihood ([`GridTracker`]).
    Grid(GridTracker),
}

/// The grid tracker's settings of the product configuration.
pub const DEFAULT_GRID_TRACKER: GridTracker = GridTracker {
    sharpness: 60.0,
    diffusion_deg: 1.0,
    jump_probability: 0.01,
    velocity_pole: 0.98,
    min_velocity_deg: 0.3,
    velocity_gain: 0.0,
    likelihood_floor: 0.2,
    motion_diffusion: 2.0,
    onset_jump_probability: 0.3,
    pause_frames: 6,
    onset_frames: 3,
    onset_likelihood_floor: 0.05,
    refine_gain: 0.1,
    refine_limit: 1.0,
    refine_curve: RefineCurve::Similarity,
};

/// The product's noise-floor gate ([`NoiseGate`]).
pub const DEFAULT_NOISE_GATE: NoiseGate = NoiseGate {
    enabled: true,
    rise_db_per_s: 1.0,
    open_db: 0.5,
    full_db: 2.0,
};

/// The product's frame onset weighting of b ([`FrameOnset`]): the settings of
/// [`FrameOnset::OFF`], switched on.
pub const DEFAULT_FRAME_ONSET: FrameOnset = FrameOnset {
    enabled: true,
    ..FrameOnset::OFF
};

/// Everything that can be set. Build one with [`LocatorConfig::default`] (the product) or
/// [`LocatorConfig::thesis`] (the published method) and change fields.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct LocatorConfig {
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
            band_lo_hz: 200.0,
            band_hi_hz: 4000.0,
            num_peaks: 10,
            peak_threshold: 0.0,
            fill_peaks: true,
            measure: SimilarityMeasure::Euclidean,
            kernel: CurveKernel::Reciprocal,
            noise_mixing: NoiseMixing::Magnitude,
            snr_from_db: -30.0,
            snr_to_db: 40.0,
            snr_step_db: 10.0,
            mean_free: false,
            features: FeatureKind::Magnitude,
            reliability: Reliability {
                enabled: true,
                speed: 1.0,
                v_max: 0.02,
                v_floor: 0.0,
                exponent: 1.0,
            },
            tracking: Tracking::OnePole,
            direct_sound: DirectSound::OFF,
            silence_power: 1e-10,
            clip_level: 0.999,
            clipped_confidence: 0.5,
            tdiv_pole: 0.9,
            fdiv_pole: 0.95,
            quality: FrameQuality::DEFAULT,
            noise_gate: NoiseGate::OFF,
            frame_onset: FrameOnset::OFF,
            capsule_calibration: CapsuleCalibration::OFF,
            combination: Combination::MeanCurve,
            smoothing: Smoothing::Curve,
            fdiv_spread: FdivSpread::OFF,
            multi_track: MultiTrack::OFF,
        }
    }

    /// The power of the distance curve whose running mean places the grid tracker's estimate
    /// between grid points (`None`: the similarity curve does, or there is no such refinement).
    /// With a distance [`CurveKernel`] the similarity curve already is a distance curve, so it
    /// places the estimate, and this is `None`.
    #[must_use]
    pub fn refine_distance_power(&self) -> Option<DistancePower> {
        if self.kernel.distance().is_some() {
            return None;
        }
        match self.tracking {
            Tracking::Grid(t) if t.refine_gain > 0.0 => t.refine_curve.power(),
            _ => None,
        }
    }

    /// The peak picker of this configuration at analysis rate `fs` Hz (band edges rounded to bins,
    /// kept inside 1…Nyquist − 1).
    #[must_use]
    pub fn peak_picker(&self, fs: f32) -> PeakPicker {
        let bin_of = |f: f32| libm::roundf(f * FRAME_LEN as f32 / fs) as usize;
        PeakPicker {
            lo_bin: bin_of(self.band_lo_hz).max(1),
            hi_bin: bin_of(self.band_hi_hz).min(NUM_BINS - 2),
            num_peaks: self.num_peaks,
            min_power: self.peak_threshold * self.peak_threshold,
            fill: self.fill_peaks,
        }
    }

    /// The similarity-curve builder of this configuration, or the error of its SNR sets.
    pub fn curve_builder(&self) -> Result<CurveBuilder, Error> {
        Ok(CurveBuilder {
            measure: self.measure,
            noisy: NoisyReferences::new(
                self.noise_mixing,
                self.snr_from_db,
                self.snr_to_db,
                self.snr_step_db,
            )?,
            mean_free: self.mean_free,
            features: self.features,
        })
    }

    /// The input guard of this configuration for a decimation `factor`: bad samples flag the frames
    /// that contain them (a frame plus the decimator's transient, in input samples).
    #[must_use]
    pub fn input_guard(&self, factor: u32) -> InputGuard {
        InputGuard {
            clip_level: self.clip_level,
            hold_samples: (FRAME_LEN as u32 + 64) * factor,
        }
    }
}

impl Default for LocatorConfig {
    /// The product configuration: the thesis method plus the measured improvements (README,
    /// "Accuracy"): onset weighting of peaks, a variance floor and a tighter scale for b, the
    /// Bayesian grid tracker with velocity drift instead of the one-pole curve filter, the
    /// noise-floor gate and the frame onset weighting of b, and active-ratio features.
    fn default() -> Self {
        let mut c = Self::thesis();
        c.kernel = CurveKernel::DEFAULT;
        c.reliability.v_floor = 0.0004;
        c.reliability.v_max = 0.003;
        c.direct_sound.onset_exponent = 1.0;
        c.tracking = Tracking::Grid(DEFAULT_GRID_TRACKER);
        c.noise_gate = DEFAULT_NOISE_GATE;
        c.features = FeatureKind::Active;
        c.frame_onset = DEFAULT_FRAME_ONSET;
        c.capsule_calibration = CapsuleCalibration::DEFAULT;
        c
    }
}
