//! Subcommands of the thesis's further functions: `beam`, `beam-report`, `options-eval`,
//! `distance-report`.

use crate::beam::{self, Steer};
use crate::config_args::ConfigArgs;
use crate::error::{Result, SimError};
use crate::ground_truth::Track;
use crate::wav_io::{self, InputLayout};
use cma_core::beamformer::{BeamConfig, OmniSource};
use std::path::PathBuf;

/// `host-sim beam`.
#[derive(Debug, clap::Args)]
pub struct BeamArgs {
    /// Input WAV (4 channels).
    pub input: PathBuf,
    /// Output mono WAV (32-bit float).
    #[arg(long)]
    pub out: PathBuf,
    /// Steering: `estimate` (the localizer, one update per hop), `truth` (INPUT's .pos.csv) or a fixed
    /// azimuth in degrees.
    #[arg(long, default_value = "estimate", allow_hyphen_values = true)]
    pub steer: String,
    /// Pattern β: 0 omni, 0.5 cardioid, 0.75 hypercardioid, 1 figure-8.
    #[arg(long, default_value_t = 0.5)]
    pub pattern: f32,
    /// Use the omni capsule as W (appendix A `se.omnibeam = 1`) instead of ⅔·Σ cardioids.
    #[arg(long)]
    pub omni_w: bool,
    /// Also write the reverse-steered beam (`result.sigb`) to this file.
    #[arg(long)]
    pub reverse: Option<PathBuf>,
    /// Steering ramp in input samples (default: one analysis hop).
    #[arg(long)]
    pub ramp: Option<u32>,
    /// Write the steering targets (t_s, azimuth) as CSV here.
    #[arg(long)]
    pub steering_csv: Option<PathBuf>,
    /// Channel layout of the input.
    #[arg(long, value_enum, default_value_t = InputLayout::Cma1)]
    pub input_layout: InputLayout,
    /// Localizer configuration (for `--steer estimate`).
    #[command(flatten)]
    pub config: ConfigArgs,
}

/// `host-sim beam-report`.
#[derive(Debug, clap::Args)]
pub struct BeamReportArgs {
    /// Source-material folder (`shared/data/src`: speech/, rir/).
    pub data: PathBuf,
    /// Diffuse-noise SNR on the omni, dB.
    #[arg(long, default_value_t = 0.0, value_parser = crate::arg_values::decibels)]
    pub snr: f64,
}

/// `host-sim options-eval`.
#[derive(Debug, clap::Args)]
pub struct OptionsEvalArgs {
    /// Folder with manifest.csv.
    pub dir: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = crate::arg_values::threads)]
    pub threads: Option<usize>,
    /// Flags applied to every variant (as on the `eval` command line), e.g. `--preset thesis`.
    #[arg(long, allow_hyphen_values = true)]
    pub base: Option<String>,
}

/// `host-sim distance-report`.
#[derive(Debug, clap::Args)]
pub struct DistanceReportArgs {
    /// Source-material folder (`shared/data/src`).
    pub data: PathBuf,
    /// Low band for the distance features, Hz.
    #[arg(long, default_value_t = 80.0)]
    pub band_lo: f32,
    /// Upper edge of the band, Hz.
    #[arg(long, default_value_t = 500.0)]
    pub band_hi: f32,
    /// Peaks per long frame.
    #[arg(long, default_value_t = 5)]
    pub peaks: usize,
}

pub(crate) fn beam(a: &BeamArgs) -> Result<()> {
    let rec = wav_io::read_recording(&a.input, a.input_layout)?;
    let config = a.config.config()?;
    let table = a.config.ideal_table()?;
    let steer = match a.steer.as_str() {
        "estimate" => Steer::Estimate,
        "truth" => Steer::Truth(Track::read(&a.input.with_extension("pos.csv"))?),
        other => Steer::Fixed(
            other
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    SimError::Usage(format!(
                        "--steer: expected estimate, truth or degrees, got `{other}`"
                    ))
                })?,
        ),
    };
    let hop = cma_core::Locator::new(config, table, rec.rate)
        .map_err(|source| SimError::Core {
            context: "configuration".into(),
            source,
        })?
        .input_samples_per_hop() as u32;
    let cfg = BeamConfig {
        beta: a.pattern,
        omni: if a.omni_w {
            OmniSource::OmniCapsule
        } else {
            OmniSource::CardioidSum
        },
        ramp_len: a.ramp.unwrap_or(hop).max(1),
    };
    let (out, _) = beam::beamform(&rec.frames, rec.rate, &steer, cfg, config, table, &[])?;
    beam::write_mono(&a.out, rec.rate, &out.forward)?;
    if let Some(p) = &a.reverse {
        beam::write_mono(p, rec.rate, &out.reverse)?;
    }
    if let Some(p) = &a.steering_csv {
        let mut s = String::from("t_s,steer_deg\n");
        for (t, az) in &out.steering {
            s.push_str(&format!("{t:.4},{az:.2}\n"));
        }
        std::fs::write(p, s).map_err(|e| SimError::io(p, e))?;
    }
    Ok(())
}

pub(crate) fn beam_report(a: &BeamReportArgs) -> Result<()> {
    let rows = beam::beam_report(&a.data, a.snr, 16_000)?;
    crate::stdout_text::print_text(&beam::format_report(&rows))
}

pub(crate) fn options_eval(a: &OptionsEvalArgs) -> Result<()> {
    let threads = a
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let base: Vec<String> = a
        .base
        .as_deref()
        .unwrap_or("")
        .split_whitespace()
        .map(String::from)
        .collect();
    crate::options_eval::options_table(&a.dir, &base, threads, std::io::stdout().lock())
}

pub(crate) fn distance_report(a: &DistanceReportArgs) -> Result<()> {
    let snrs = [None, Some(20.0), Some(10.0), Some(0.0)];
    let rows = crate::distance_eval::distance_report(
        &a.data,
        &snrs,
        (a.band_lo, a.band_hi),
        a.peaks.max(1),
    )?;
    crate::stdout_text::print_text(&crate::distance_eval::format_report(&rows))
}
