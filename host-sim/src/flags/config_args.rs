//! Command-line flags that set the localizer configuration, shared by every command that localizes
//! (`locate`, `eval`, `emit`, `beam`, `config`; `options-eval` through its `--base`).
//!
//! Precedence: the preset (`--preset`), then the configuration file (`--config`, whose keys replace
//! the preset's), then the flags given on the command line. A measured `--table` switches the
//! self-calibration off after the file (it already describes the real capsules) unless `--selfcal`
//! says otherwise. `host-sim config` prints the result as a complete file.
//!
//! Rarely changed tuning settings have no flag and are set in the file only: the grid tracker's
//! velocity drift and likelihood floor (`tracking.Grid.velocity_pole`, `min_velocity_deg`,
//! `velocity_gain`, `likelihood_floor`, `motion_diffusion`), the self-calibration's learning rules
//! (`capsule_calibration.background_db`, `shrinkage`, `directional_reliability`, `memory_frames`,
//! `max_anisotropy`) and the settings that never had one (`silence_power`, `clip_level`, …).

use crate::error::{Result, SimError};
use cma_core::config::{Tracking, DEFAULT_GRID_TRACKER};
use cma_core::curve_kernel::CurveKernel;
use cma_core::noisy_reference::NoiseMixing;
use cma_core::refine_curve::{DistancePower, RefineCurve};
use cma_core::similarity::SimilarityMeasure;
use cma_core::{LocatorConfig, Method, ReferenceTable};

/// Which configuration the flags start from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Preset {
    /// The product defaults (thesis method plus the measured improvements).
    Default,
    /// The thesis's published configuration, for side-by-side reproduction.
    Thesis,
}

impl From<Preset> for cma_config::Preset {
    fn from(p: Preset) -> Self {
        match p {
            Preset::Default => cma_config::Preset::Default,
            Preset::Thesis => cma_config::Preset::Thesis,
        }
    }
}

/// Localization principle on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MethodArg {
    /// Similarity approach.
    Sim,
    /// Frequency-domain intensity vector.
    Fdiv,
    /// Time-domain intensity vector.
    Tdiv,
}

/// Noise mixing of reference features on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum NoiseArg {
    /// Clean references only.
    Off,
    /// Magnitude mixing (thesis eq. 5.19).
    Magnitude,
    /// Power mixing.
    Power,
}

/// How curves are combined over time, on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum TrackerArg {
    /// The thesis's adaptive one-pole filter on the curve (eq. 5.31).
    Onepole,
    /// Bayesian grid tracker.
    Grid,
}

/// A switch on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OnOff {
    /// Switched on.
    On,
    /// Switched off.
    Off,
}

/// Which ratio the peak features are.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum FeaturesArg {
    /// |X_c| / |X_0| (the thesis).
    Magnitude,
    /// Re(X_c / X_0): the active ratio (noise mixes linearly toward ½; reflections average out);
    /// the default preset's choice.
    Active,
}

/// The grid tracker's refinement curve on the command line ([`RefineCurve`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RefineCurveArg {
    /// The similarity curve (the tracker's likelihood; the earlier behaviour).
    Similarity,
    /// The mean peak distance d (an L1 fit).
    Distance,
    /// The mean of d^1.5.
    #[value(name = "distance1.5")]
    Distance15,
    /// The mean of d² (a least-squares fit).
    Distance2,
}

impl From<RefineCurveArg> for RefineCurve {
    fn from(a: RefineCurveArg) -> Self {
        match a {
            RefineCurveArg::Similarity => RefineCurve::Similarity,
            RefineCurveArg::Distance => RefineCurve::Distance,
            RefineCurveArg::Distance15 => RefineCurve::Distance1_5,
            RefineCurveArg::Distance2 => RefineCurve::Distance2,
        }
    }
}

/// The per-peak term of the similarity curve on the command line ([`CurveKernel`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum KernelArg {
    /// The measure's similarity, 1/(1 + d) for `euclid` (the thesis).
    Reciprocal,
    /// 1 − k·d (an L1 fit of the peaks' directions).
    Distance,
    /// 1 − k·d^1.5 (the default).
    #[value(name = "distance1.5")]
    Distance15,
    /// 1 − k·d² (a least-squares fit).
    Distance2,
}

/// Localizer configuration flags. Unset flags keep the preset's value.
#[derive(Debug, Clone, clap::Args)]
pub struct ConfigArgs {
    /// Starting configuration (`host-sim config --preset P` prints it).
    #[arg(long, value_enum, default_value_t = Preset::Default, help_heading = "Configuration")]
    pub preset: Preset,
    /// Configuration file (TOML, as `host-sim config` prints it; may hold only some keys): laid
    /// over the preset; flags given here override it.
    #[arg(long, value_name = "FILE", help_heading = "Configuration")]
    pub config: Option<std::path::PathBuf>,
    /// Localization method.
    #[arg(long, value_enum, help_heading = "Configuration")]
    pub method: Option<MethodArg>,
    /// Azimuth grid of the ideal reference table, degrees (5 or 15); not with a measured --table,
    /// which has its own grid.
    #[arg(
        long,
        default_value_t = 5,
        conflicts_with = "table",
        help_heading = "Configuration"
    )]
    pub grid: u32,
    /// Measured reference table (`host-sim calibrate`); replaces the ideal table of --grid.
    #[arg(long, help_heading = "Configuration")]
    pub table: Option<std::path::PathBuf>,
    /// Number of spectral peaks N_p.
    #[arg(long, value_parser = crate::flags::arg_values::peaks, help_heading = "Analysis: peaks and features")]
    pub peaks: Option<usize>,
    /// Analysis band lower edge, Hz.
    #[arg(long, value_parser = crate::flags::arg_values::non_negative, help_heading = "Analysis: peaks and features")]
    pub band_lo: Option<f32>,
    /// Analysis band upper edge, Hz.
    #[arg(long, value_parser = crate::flags::arg_values::positive, help_heading = "Analysis: peaks and features")]
    pub band_hi: Option<f32>,
    /// Similarity measure: `euclid`, `cosine` or `lP` (L_p norm with P from 0.25 to 32, e.g. `l1`).
    #[arg(long, help_heading = "Similarity: measure, kernel, noisy references")]
    pub measure: Option<String>,
    /// The per-peak term of the similarity curve.
    #[arg(
        long,
        value_enum,
        help_heading = "Similarity: measure, kernel, noisy references"
    )]
    pub kernel: Option<KernelArg>,
    /// Scale k of a distance kernel (1 − k·d^p); the preset's, or 1.5, when unset.
    #[arg(long, value_parser = crate::flags::arg_values::positive, help_heading = "Similarity: measure, kernel, noisy references")]
    pub kernel_scale: Option<f32>,
    /// Noisy reference features: mixing rule.
    #[arg(
        long,
        value_enum,
        help_heading = "Similarity: measure, kernel, noisy references"
    )]
    pub noise: Option<NoiseArg>,
    /// Lowest SNR of the noisy reference sets, dB.
    #[arg(long, value_parser = crate::flags::arg_values::finite, help_heading = "Similarity: measure, kernel, noisy references")]
    pub snr_from: Option<f32>,
    /// Highest SNR of the noisy reference sets, dB.
    #[arg(long, value_parser = crate::flags::arg_values::finite, help_heading = "Similarity: measure, kernel, noisy references")]
    pub snr_to: Option<f32>,
    /// SNR step between the noisy reference sets, dB.
    #[arg(long, value_parser = crate::flags::arg_values::finite, help_heading = "Similarity: measure, kernel, noisy references")]
    pub snr_step: Option<f32>,
    /// Mean-free features.
    #[arg(long, help_heading = "Analysis: peaks and features")]
    pub mean_free: bool,
    /// Peak features: magnitude ratios (the thesis preset) or active ratios (the default preset).
    #[arg(long, value_enum, help_heading = "Analysis: peaks and features")]
    pub features: Option<FeaturesArg>,
    /// Switch reliability weighting off (b = 1 for every frame); not with the weighting's settings
    /// (--speed, --vmax, --vfloor, --reliability-exponent), which then do nothing.
    #[arg(
        long,
        conflicts_with_all = ["speed", "vmax", "vfloor", "reliability_exponent"],
        help_heading = "Reliability: weighting, noise gate, frame onset"
    )]
    pub no_reliability: bool,
    /// Speed factor K of the reliability weighting.
    #[arg(long, value_parser = crate::flags::arg_values::non_negative, help_heading = "Reliability: weighting, noise gate, frame onset")]
    pub speed: Option<f32>,
    /// Curve-variance scale V_max of the reliability weighting.
    #[arg(long, value_parser = crate::flags::arg_values::finite, help_heading = "Reliability: weighting, noise gate, frame onset")]
    pub vmax: Option<f32>,
    /// Curve-variance floor V_0 of the reliability weighting (b = 0 at or below it).
    #[arg(long, value_parser = crate::flags::arg_values::non_negative, help_heading = "Reliability: weighting, noise gate, frame onset")]
    pub vfloor: Option<f32>,
    /// Exponent p of the reliability coefficient b = clip(K·(V/V_max)^p, 0, 1).
    #[arg(long, value_parser = crate::flags::arg_values::finite, help_heading = "Reliability: weighting, noise gate, frame onset")]
    pub reliability_exponent: Option<f32>,
    /// Tracker on the similarity curve.
    #[arg(long, value_enum, help_heading = "Tracking")]
    pub tracker: Option<TrackerArg>,
    /// Grid tracker: likelihood sharpness λ.
    #[arg(long, value_parser = crate::flags::arg_values::non_negative, help_heading = "Tracking")]
    pub sharpness: Option<f32>,
    /// Grid tracker: random-walk step per frame, degrees.
    #[arg(long, value_parser = crate::flags::arg_values::non_negative, help_heading = "Tracking")]
    pub diffusion: Option<f32>,
    /// Grid tracker: jump probability per frame.
    #[arg(long, value_parser = crate::flags::arg_values::unit, help_heading = "Tracking")]
    pub jump_prob: Option<f32>,
    /// Grid tracker: jump probability of the first reliable frames after a pause.
    #[arg(long, value_parser = crate::flags::arg_values::unit, help_heading = "Tracking")]
    pub onset_jump_prob: Option<f32>,
    /// Grid tracker: frames with b = 0 that make a pause (0 = no onset jump probability).
    #[arg(long, help_heading = "Tracking")]
    pub pause_frames: Option<u32>,
    /// Grid tracker: reliable frames after a pause that use the onset jump probability.
    #[arg(long, help_heading = "Tracking")]
    pub onset_frames: Option<u32>,
    /// Grid tracker: likelihood floor of the onset frames (the first reliable frames after a pause).
    #[arg(long, value_parser = crate::flags::arg_values::unit, help_heading = "Tracking")]
    pub onset_floor: Option<f32>,
    /// Grid tracker: gain of the running mean curve that places the estimate between grid points
    /// (0 = parabola through the log-posterior, the earlier behaviour).
    #[arg(long, value_parser = crate::flags::arg_values::unit, help_heading = "Tracking")]
    pub refine_gain: Option<f32>,
    /// Grid tracker: largest distance of the estimate from the posterior's maximum, grid steps, for
    /// a still talker (a moving one: at least one step).
    #[arg(long, value_parser = crate::flags::arg_values::non_negative, help_heading = "Tracking")]
    pub refine_limit: Option<f32>,
    /// Grid tracker: the curve whose running mean places the estimate between grid points.
    #[arg(long, value_enum, help_heading = "Tracking")]
    pub refine_curve: Option<RefineCurveArg>,
    /// Noise-floor gate of the reliability b: on or off.
    #[arg(
        long,
        value_enum,
        help_heading = "Reliability: weighting, noise gate, frame onset"
    )]
    pub noise_gate: Option<OnOff>,
    /// Noise-floor gate: largest rise of the tracked floor, dB per second.
    #[arg(long, value_parser = crate::flags::arg_values::non_negative, help_heading = "Reliability: weighting, noise gate, frame onset")]
    pub gate_rise: Option<f32>,
    /// Noise-floor gate: frame power above the floor (dB) where b starts to pass.
    #[arg(long, value_parser = crate::flags::arg_values::finite, help_heading = "Reliability: weighting, noise gate, frame onset")]
    pub gate_open: Option<f32>,
    /// Noise-floor gate: frame power above the floor (dB) where b passes fully.
    #[arg(long, value_parser = crate::flags::arg_values::finite, help_heading = "Reliability: weighting, noise gate, frame onset")]
    pub gate_full: Option<f32>,
    /// Frame onset weighting of the reliability b: on (the default preset) or off (the thesis).
    #[arg(
        long,
        value_enum,
        help_heading = "Reliability: weighting, noise gate, frame onset"
    )]
    pub frame_onset: Option<OnOff>,
    /// Frame onset: frames of power history the rise is measured against.
    #[arg(long, value_parser = crate::flags::arg_values::onset_history, help_heading = "Reliability: weighting, noise gate, frame onset")]
    pub frame_onset_history: Option<usize>,
    /// Frame onset: rise (dB) at and below which a frame gets the floor weight.
    #[arg(
        long, value_parser = crate::flags::arg_values::finite,
        allow_negative_numbers = true,
        help_heading = "Reliability: weighting, noise gate, frame onset"
    )]
    pub frame_onset_low: Option<f32>,
    /// Frame onset: rise (dB) at and above which a frame gets full weight.
    #[arg(
        long, value_parser = crate::flags::arg_values::finite,
        allow_negative_numbers = true,
        help_heading = "Reliability: weighting, noise gate, frame onset"
    )]
    pub frame_onset_high: Option<f32>,
    /// Frame onset: weight of frames at or below the low rise.
    #[arg(long, value_parser = crate::flags::arg_values::unit, help_heading = "Reliability: weighting, noise gate, frame onset")]
    pub frame_onset_floor: Option<f32>,
    /// Blind self-calibration of the cardioids from the diffuse background: on (the default
    /// preset) or off (the thesis; also off with a measured --table, which already holds the array).
    #[arg(long, value_enum, help_heading = "Self-calibration")]
    pub selfcal: Option<OnOff>,
    /// Self-calibration: keep learning (on) or only apply the start estimate of --selfcal-in (off).
    #[arg(long, value_enum, help_heading = "Self-calibration")]
    pub selfcal_adapt: Option<OnOff>,
    /// Directness exponent γ of the direct-sound peak weighting (0 = off).
    #[arg(long, value_parser = crate::flags::arg_values::non_negative, help_heading = "Analysis: peaks and features")]
    pub directness: Option<f32>,
    /// Onset exponent of the direct-sound peak weighting (0 = off).
    #[arg(long, value_parser = crate::flags::arg_values::non_negative, help_heading = "Analysis: peaks and features")]
    pub onset: Option<f32>,
    /// Absolute peak threshold on |X_omni| (0 = off).
    #[arg(long, value_parser = crate::flags::arg_values::non_negative, help_heading = "Analysis: peaks and features")]
    pub peak_threshold: Option<f32>,
    /// FDIV intensity smoothing pole.
    #[arg(long, value_parser = crate::flags::arg_values::pole, help_heading = "Baselines: FDIV and TDIV")]
    pub fdiv_pole: Option<f32>,
    /// TDIV smoothing pole.
    #[arg(long, value_parser = crate::flags::arg_values::pole, help_heading = "Baselines: FDIV and TDIV")]
    pub tdiv_pole: Option<f32>,
    /// Multi-talker tracks with persistent IDs (similarity method): on or off (the presets;
    /// `locate --tracks` and `eval` of a multi-talker folder switch them on).
    #[arg(long, value_enum)]
    pub multi_talker: Option<OnOff>,
    /// Thesis alternatives (see `docs/options.md`).
    #[command(flatten, next_help_heading = "Thesis options")]
    pub options: crate::evaluation::options_eval::OptionArgs,
}

impl ConfigArgs {
    /// The files these flags read (`--config`, `--table`), for the check that no output overwrites
    /// them ([`crate::io::output_file::check_distinct`]).
    pub fn input_files(&self) -> Vec<(&'static str, &std::path::Path)> {
        let mut files = Vec::new();
        if let Some(p) = &self.config {
            files.push(("--config", p.as_path()));
        }
        if let Some(p) = &self.table {
            files.push(("--table", p.as_path()));
        }
        files
    }

    /// The preset's kernel `preset` with `--kernel` and `--kernel-scale` applied.
    fn kernel(&self, preset: CurveKernel) -> Result<CurveKernel> {
        let scale = self
            .kernel_scale
            .or(preset.distance().map(|(_, k)| k))
            .unwrap_or(1.5);
        let power = match self.kernel {
            None => preset.distance().map(|(p, _)| p),
            Some(KernelArg::Reciprocal) => None,
            Some(KernelArg::Distance) => Some(DistancePower::One),
            Some(KernelArg::Distance15) => Some(DistancePower::ThreeHalves),
            Some(KernelArg::Distance2) => Some(DistancePower::Two),
        };
        match power {
            Some(power) => Ok(CurveKernel::Distance { power, scale }),
            None if self.kernel_scale.is_some() => Err(SimError::Usage(
                "--kernel-scale needs a distance kernel (--kernel distance|distance1.5|distance2)"
                    .into(),
            )),
            None => Ok(CurveKernel::Reciprocal),
        }
    }

    /// The flags given that set a stage switched off by another flag, or by the preset or the file
    /// (`tracker_off`: the configuration has no grid tracker): a usage error naming both, as such a
    /// flag would do nothing.
    fn check_switched_off(&self, tracker_off: bool) -> Result<()> {
        let given = |flags: &[(&'static str, bool)]| -> Vec<&'static str> {
            flags.iter().filter(|(_, g)| *g).map(|(f, _)| *f).collect()
        };
        let grid_flags = given(&[
            ("--sharpness", self.sharpness.is_some()),
            ("--diffusion", self.diffusion.is_some()),
            ("--jump-prob", self.jump_prob.is_some()),
            ("--onset-jump-prob", self.onset_jump_prob.is_some()),
            ("--pause-frames", self.pause_frames.is_some()),
            ("--onset-frames", self.onset_frames.is_some()),
            ("--onset-floor", self.onset_floor.is_some()),
            ("--refine-gain", self.refine_gain.is_some()),
            ("--refine-limit", self.refine_limit.is_some()),
            ("--refine-curve", self.refine_curve.is_some()),
        ]);
        let gate_flags = given(&[
            ("--gate-rise", self.gate_rise.is_some()),
            ("--gate-open", self.gate_open.is_some()),
            ("--gate-full", self.gate_full.is_some()),
        ]);
        let onset_flags = given(&[
            ("--frame-onset-history", self.frame_onset_history.is_some()),
            ("--frame-onset-low", self.frame_onset_low.is_some()),
            ("--frame-onset-high", self.frame_onset_high.is_some()),
            ("--frame-onset-floor", self.frame_onset_floor.is_some()),
        ]);
        let adapt_flags = given(&[("--selfcal-adapt", self.selfcal_adapt.is_some())]);
        let tracker = if self.tracker == Some(TrackerArg::Onepole) {
            "--tracker onepole"
        } else {
            "the one-pole curve filter the preset or the file selects"
        };
        let off = |on: Option<OnOff>| on == Some(OnOff::Off);
        for (switched_off, by, flags, what) in [
            (tracker_off, tracker, grid_flags, "--tracker grid"),
            (
                off(self.noise_gate),
                "--noise-gate off",
                gate_flags,
                "--noise-gate on",
            ),
            (
                off(self.frame_onset),
                "--frame-onset off",
                onset_flags,
                "--frame-onset on",
            ),
            (
                off(self.selfcal),
                "--selfcal off",
                adapt_flags,
                "--selfcal on",
            ),
        ] {
            if switched_off && !flags.is_empty() {
                return Err(SimError::Usage(format!(
                    "{} cannot be used with {by}: {} the stage it switches off (drop one, or give \
                     {what})",
                    flags.join(", "),
                    if flags.len() == 1 {
                        "it sets"
                    } else {
                        "they set"
                    },
                )));
            }
        }
        Ok(())
    }

    /// The configuration these flags describe.
    pub fn config(&self) -> Result<LocatorConfig> {
        let mut c = cma_config::Preset::from(self.preset).config();
        if let Some(path) = &self.config {
            let text = crate::io::text_file::read(path)?;
            c = cma_config::parse_over(&c, &text)
                .map_err(|e| SimError::Other(format!("{}: {e}", path.display())))?;
        }
        let before_flags = c;
        // A measured table already describes the real capsules: the self-calibration (which maps
        // them to the ideal model) is off with one unless --selfcal asks for it.
        if self.table.is_some() {
            c.capsule_calibration.enabled = false;
        }
        if let Some(m) = self.method {
            c.method = match m {
                MethodArg::Sim => Method::Similarity,
                MethodArg::Fdiv => Method::Fdiv,
                MethodArg::Tdiv => Method::Tdiv,
            };
        }
        if let Some(v) = self.peaks {
            c.peaks.num_peaks = v;
        }
        if let Some(v) = self.band_lo {
            c.peaks.band_lo_hz = v;
        }
        if let Some(v) = self.band_hi {
            c.peaks.band_hi_hz = v;
        }
        if let Some(m) = &self.measure {
            c.curves.measure = parse_measure(m)?;
        }
        c.kernel = self.kernel(c.kernel)?;
        if let Some(n) = self.noise {
            c.curves.noise_mixing = match n {
                NoiseArg::Off => NoiseMixing::Off,
                NoiseArg::Magnitude => NoiseMixing::Magnitude,
                NoiseArg::Power => NoiseMixing::Power,
            };
        }
        if let Some(v) = self.snr_from {
            c.curves.snr_from_db = v;
        }
        if let Some(v) = self.snr_to {
            c.curves.snr_to_db = v;
        }
        if let Some(v) = self.snr_step {
            c.curves.snr_step_db = v;
        }
        c.curves.mean_free |= self.mean_free;
        if let Some(f) = self.features {
            c.curves.features = match f {
                FeaturesArg::Magnitude => cma_core::features::FeatureKind::Magnitude,
                FeaturesArg::Active => cma_core::features::FeatureKind::Active,
            };
        }
        if self.no_reliability {
            c.reliability.enabled = false;
        }
        if let Some(v) = self.speed {
            c.reliability.speed = v;
        }
        if let Some(v) = self.vmax {
            c.reliability.v_max = v;
        }
        if let Some(v) = self.vfloor {
            c.reliability.v_floor = v;
        }
        if let Some(v) = self.reliability_exponent {
            c.reliability.exponent = v;
        }
        let mut grid = match c.tracking {
            Tracking::Grid(g) => g,
            Tracking::OnePole => DEFAULT_GRID_TRACKER,
        };
        if let Some(v) = self.sharpness {
            grid.sharpness = v;
        }
        if let Some(v) = self.diffusion {
            grid.diffusion_deg = v;
        }
        if let Some(v) = self.jump_prob {
            grid.jump_probability = v;
        }
        if let Some(v) = self.onset_jump_prob {
            grid.onset_jump_probability = v;
        }
        if let Some(v) = self.pause_frames {
            grid.pause_frames = v;
        }
        if let Some(v) = self.onset_frames {
            grid.onset_frames = v;
        }
        if let Some(v) = self.onset_floor {
            grid.onset_likelihood_floor = v;
        }
        if let Some(v) = self.refine_gain {
            grid.refine_gain = v;
        }
        if let Some(v) = self.refine_limit {
            grid.refine_limit = v;
        }
        if let Some(v) = self.refine_curve {
            grid.refine_curve = v.into();
        }
        c.tracking = match (self.tracker, c.tracking) {
            (Some(TrackerArg::Onepole), _) => Tracking::OnePole,
            (Some(TrackerArg::Grid), _) | (None, Tracking::Grid(_)) => Tracking::Grid(grid),
            (None, Tracking::OnePole) => Tracking::OnePole,
        };
        self.check_switched_off(c.tracking == Tracking::OnePole)?;
        if let Some(v) = self.noise_gate {
            c.noise_gate.enabled = v == OnOff::On;
        }
        if let Some(v) = self.gate_rise {
            c.noise_gate.rise_db_per_s = v;
        }
        if let Some(v) = self.gate_open {
            c.noise_gate.open_db = v;
        }
        if let Some(v) = self.gate_full {
            c.noise_gate.full_db = v;
        }
        if let Some(v) = self.frame_onset {
            c.frame_onset.enabled = v == OnOff::On;
        }
        if let Some(v) = self.frame_onset_history {
            c.frame_onset.history = v;
        }
        if let Some(v) = self.frame_onset_low {
            c.frame_onset.low_db = v;
        }
        if let Some(v) = self.frame_onset_high {
            c.frame_onset.high_db = v;
        }
        if let Some(v) = self.frame_onset_floor {
            c.frame_onset.floor = v;
        }
        if let Some(v) = self.selfcal {
            c.capsule_calibration.enabled = v == OnOff::On;
        }
        if let Some(v) = self.multi_talker {
            // Only the switch: the stage's settings stay what the preset or the file made them.
            c.multi_track.enabled = v == OnOff::On;
        }
        if let Some(v) = self.selfcal_adapt {
            c.capsule_calibration.adapt = v == OnOff::On;
        }
        if let Some(v) = self.directness {
            c.direct_sound.directness_exponent = v;
        }
        if let Some(v) = self.onset {
            c.direct_sound.onset_exponent = v;
        }
        if let Some(v) = self.peak_threshold {
            c.peaks.peak_threshold = v;
        }
        if let Some(v) = self.fdiv_pole {
            c.intensity.fdiv_pole = v;
        }
        if let Some(v) = self.tdiv_pole {
            c.intensity.tdiv_pole = v;
        }
        self.options.apply(&mut c)?;
        check_flags(&before_flags, &c)?;
        Ok(c)
    }

    /// Reads the `--table` file, if any.
    pub fn measured_table(&self) -> Result<Option<crate::io::table_io::OwnedTable>> {
        self.table
            .as_deref()
            .map(crate::io::table_io::OwnedTable::read)
            .transpose()
    }

    /// The reference table to use: `measured` (from [`Self::measured_table`]) or the ideal one.
    pub fn table<'a>(
        &self,
        measured: Option<&'a crate::io::table_io::OwnedTable>,
    ) -> Result<ReferenceTable<'a>> {
        match measured {
            Some(t) => t.as_table(),
            None => self.ideal_table(),
        }
    }

    /// The ideal reference table for `--grid`.
    pub fn ideal_table(&self) -> Result<ReferenceTable<'static>> {
        match self.grid {
            5 => Ok(ReferenceTable::ideal_5deg()),
            15 => Ok(ReferenceTable::ideal_15deg()),
            g => Err(SimError::Usage(format!(
                "--grid: expected 5 or 15 (degrees), got {g}"
            ))),
        }
    }
}

/// The core's check of `config`, made from `before_flags` by the command-line flags: a value it
/// refuses is a usage error naming the flags that set it (`--band-lo: …`), not their file keys.
/// A refusal no flag causes is left to the localizer's own check, with the input's rate and table.
fn check_flags(before_flags: &LocatorConfig, config: &LocatorConfig) -> Result<()> {
    let Err(e) = cma_config::validate_changes(before_flags, config) else {
        return Ok(());
    };
    let flags: Vec<String> = e
        .keys()
        .iter()
        .filter_map(|key| {
            // The flag of the key itself, else of the setting it is part of (`measure` for
            // `measure.Lp`).
            FLAG_KEYS.iter().find(|(_, k)| k == key).or_else(|| {
                FLAG_KEYS
                    .iter()
                    .find(|(_, k)| key.strip_prefix(k).is_some_and(|r| r.starts_with('.')))
            })
        })
        .map(|(id, _)| format!("--{}", id.replace('_', "-")))
        .collect();
    if flags.is_empty() {
        return Ok(());
    }
    let message = e.message();
    let message = message
        .strip_prefix("invalid configuration: ")
        .unwrap_or(message);
    Err(SimError::Usage(format!("{}: {message}", flags.join(", "))))
}

fn parse_measure(s: &str) -> Result<SimilarityMeasure> {
    let (lo, hi) = cma_config::LP_RANGE;
    match s {
        "euclid" | "euclidean" | "l2" => Ok(SimilarityMeasure::Euclidean),
        "cosine" | "cos" => Ok(SimilarityMeasure::Cosine),
        other => other
            .strip_prefix('l')
            .and_then(|p| p.parse::<f32>().ok())
            .filter(|p| (lo..=hi).contains(&f64::from(*p)))
            .map(SimilarityMeasure::Lp)
            .ok_or_else(|| {
                SimError::Usage(format!(
                    "--measure: expected euclid, cosine or lP with P from {lo} to {hi}, got `{other}`"
                ))
            }),
    }
}

/// Which configuration-file key each flag sets (flag id, dotted key): the help of every
/// configuration flag shows the key and its value in each preset ([`annotate`]).
pub const FLAG_KEYS: &[(&str, &str)] = &[
    ("method", "method"),
    ("peaks", "num_peaks"),
    ("band_lo", "band_lo_hz"),
    ("band_hi", "band_hi_hz"),
    ("peak_threshold", "peak_threshold"),
    ("directness", "direct_sound.directness_exponent"),
    ("onset", "direct_sound.onset_exponent"),
    ("features", "features"),
    ("mean_free", "mean_free"),
    ("measure", "measure"),
    ("kernel", "kernel"),
    ("kernel_scale", "kernel.Distance.scale"),
    ("noise", "noise_mixing"),
    ("snr_from", "snr_from_db"),
    ("snr_to", "snr_to_db"),
    ("snr_step", "snr_step_db"),
    ("no_reliability", "reliability.enabled"),
    ("speed", "reliability.speed"),
    ("vmax", "reliability.v_max"),
    ("vfloor", "reliability.v_floor"),
    ("reliability_exponent", "reliability.exponent"),
    ("noise_gate", "noise_gate.enabled"),
    ("gate_rise", "noise_gate.rise_db_per_s"),
    ("gate_open", "noise_gate.open_db"),
    ("gate_full", "noise_gate.full_db"),
    ("frame_onset", "frame_onset.enabled"),
    ("frame_onset_history", "frame_onset.history"),
    ("frame_onset_low", "frame_onset.low_db"),
    ("frame_onset_high", "frame_onset.high_db"),
    ("frame_onset_floor", "frame_onset.floor"),
    ("tracker", "tracking"),
    ("sharpness", "tracking.Grid.sharpness"),
    ("diffusion", "tracking.Grid.diffusion_deg"),
    ("jump_prob", "tracking.Grid.jump_probability"),
    ("onset_jump_prob", "tracking.Grid.onset_jump_probability"),
    ("pause_frames", "tracking.Grid.pause_frames"),
    ("onset_frames", "tracking.Grid.onset_frames"),
    ("onset_floor", "tracking.Grid.onset_likelihood_floor"),
    ("refine_gain", "tracking.Grid.refine_gain"),
    ("refine_limit", "tracking.Grid.refine_limit"),
    ("refine_curve", "tracking.Grid.refine_curve"),
    ("selfcal", "capsule_calibration.enabled"),
    ("selfcal_adapt", "capsule_calibration.adapt"),
    ("fdiv_pole", "fdiv_pole"),
    ("tdiv_pole", "tdiv_pole"),
    ("power_max", "quality.power_max"),
    ("peak_power_max", "quality.peak_power_max"),
    ("zcr_threshold", "quality.zcr_threshold_hz"),
    ("binary_threshold", "quality.binary_threshold"),
    ("combination", "combination"),
    ("smoothing", "smoothing"),
    ("fdiv_std", "fdiv_spread.max_std_deg"),
    ("fdiv_std_binary", "fdiv_spread.binary"),
];

/// The note each configuration flag's help ends with: the file key it sets and its value in each
/// preset, e.g. `[file: num_peaks = 16 (default), 10 (thesis)]`, taken from the presets themselves
/// so the help cannot drift from the code. Pairs of flag id and note, for [`annotate`].
#[must_use]
pub fn flag_notes() -> Vec<(&'static str, String)> {
    let presets = cma_config::Preset::ALL.map(|p| (p.name(), p.config()));
    FLAG_KEYS
        .iter()
        .map(|(id, key)| {
            let values: Vec<String> = presets
                .iter()
                .map(|(name, c)| {
                    let v = cma_config::value_of(c, key).unwrap_or_else(|| "none".into());
                    format!("{v} ({name})")
                })
                .collect();
            (*id, format!("[file: {key} = {}]", values.join(", ")))
        })
        .collect()
}

/// Appends to the help of every configuration flag of `cmd` its note from `notes`
/// ([`flag_notes`]); a command without the configuration flags (no `--preset`, e.g.
/// `distance-report`, whose `--peaks` is its own) is left as it is.
pub fn annotate(mut cmd: clap::Command, notes: &[(&'static str, String)]) -> clap::Command {
    if !cmd.get_arguments().any(|a| a.get_id() == "preset") {
        return cmd;
    }
    // Every argument is touched in its order, as `mut_arg` moves the argument to the end: the
    // help keeps the declaration order (and with it the order of the headings).
    let ids: Vec<clap::Id> = cmd.get_arguments().map(|a| a.get_id().clone()).collect();
    for id in ids {
        let note = notes
            .iter()
            .find(|(f, _)| *f == id.as_str())
            .map(|(_, n)| n);
        cmd = cmd.mut_arg(id, |a| match note {
            Some(note) => {
                let help = a.get_help().map(ToString::to_string).unwrap_or_default();
                a.help(format!("{help} {note}"))
            }
            None => a,
        });
    }
    cmd
}
