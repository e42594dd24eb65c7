//! `host-sim beam`: the self-steered beamformer (thesis §3.3, appendix A `result.sig` /
//! `result.sigb`) on a WAV file.

use crate::error::{Result, SimError};
use crate::flags::config_args::ConfigArgs;
use crate::io::ground_truth::Track;
use crate::io::wav_io::{self, InputLayout};
use crate::localization::beam::{self, Steer};
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

/// Runs `host-sim beam`.
pub fn run(a: &BeamArgs) -> Result<()> {
    if a.config.table.is_some() {
        return Err(SimError::Usage(
            "--table cannot be used with beam: it steers with the localizer on the ideal table of \
             --grid (drop --table)"
                .into(),
        ));
    }
    let mut inputs = vec![("input", a.input.as_path())];
    inputs.extend(a.config.input_files());
    let mut outputs = vec![("--out", a.out.as_path())];
    outputs.extend(a.reverse.as_deref().map(|p| ("--reverse", p)));
    outputs.extend(a.steering_csv.as_deref().map(|p| ("--steering-csv", p)));
    crate::io::output_file::check_distinct(&inputs, &outputs)?;
    // The flags are checked before the input is read.
    let config = a.config.config()?;
    let table = a.config.ideal_table()?;
    let rec = wav_io::read_recording(&a.input, a.input_layout)?;
    if let Some(n) = rec.normalisation {
        eprintln!("{}", n.line());
    }
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
        std::fs::write(p, s).map_err(|e| SimError::writing(p, e))?;
    }
    Ok(())
}
