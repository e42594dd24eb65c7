//! `host-sim scene`: synthesises a CMA1 scene (WAV + `.pos.csv`).

use crate::error::{Result, SimError};
use crate::wav_io::OutFormat;
use crate::{arg_values, array_model, scene};
use std::path::PathBuf;

/// `host-sim scene`.
#[derive(Debug, clap::Args)]
pub struct SceneArgs {
    /// Output WAV; the truth goes to the same name with `.pos.csv`.
    #[arg(long)]
    pub out: PathBuf,
    /// Talker: a mono WAV (resampled to --rate).
    #[arg(long)]
    pub source: Option<PathBuf>,
    /// Talker: a synthetic speech-like signal of this many seconds (at most 3600).
    #[arg(long, value_parser = arg_values::synth_seconds)]
    pub synth: Option<f64>,
    /// Output sample rate, Hz.
    #[arg(long, default_value_t = 16000)]
    pub rate: u32,
    /// Static talker azimuth, degrees.
    #[arg(long, value_parser = arg_values::degrees, conflicts_with_all = ["track", "rotate"])]
    pub azimuth: Option<f64>,
    /// Jumping talker: TIME:AZIMUTH pairs, e.g. `0:30,2:-160,4:95`.
    #[arg(long, allow_hyphen_values = true, conflicts_with = "rotate")]
    pub track: Option<String>,
    /// Circling talker: angular speed in degrees per second (start from --start-azimuth).
    #[arg(long, value_parser = arg_values::degrees)]
    pub rotate: Option<f64>,
    /// Start azimuth of --rotate, degrees.
    #[arg(long, value_parser = arg_values::degrees, default_value_t = 0.0)]
    pub start_azimuth: f64,
    /// Diffuse pink noise at this SNR on the omni, dB (omit for no noise).
    #[arg(long, value_parser = arg_values::decibels)]
    pub snr: Option<f64>,
    /// Measured first-order room response (AmbiX W, Y, Z, X), rotated to the talker azimuth.
    #[arg(long)]
    pub rir: Option<PathBuf>,
    /// The room response is N3D rather than SN3D.
    #[arg(long)]
    pub rir_n3d: bool,
    /// Direct-sound azimuth of the room response, degrees (default: measured from its intensity).
    #[arg(long, value_parser = arg_values::degrees)]
    pub rir_direct: Option<f64>,
    /// Truncate the room response to this many seconds (at most 10).
    #[arg(long, value_parser = arg_values::rir_seconds, default_value_t = 1.0)]
    pub rir_length: f64,
    /// Noise-only lead-in before the talker, s (at most 600).
    #[arg(long, value_parser = arg_values::lead_in_seconds, default_value_t = 0.25)]
    pub lead_in: f64,
    /// Peak level of the file, dBFS.
    #[arg(long, value_parser = arg_values::decibels, default_value_t = -3.0)]
    pub peak_dbfs: f64,
    /// Noise / synthetic source seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Sample format of the WAV.
    #[arg(long, value_enum, default_value_t = OutFormat::Pcm16)]
    pub format: OutFormat,
    /// Append the scene to this manifest.csv (created if missing) under --set.
    #[arg(long)]
    pub manifest: Option<PathBuf>,
    /// Set name for --manifest.
    #[arg(long, default_value = "scenes")]
    pub set: String,
    /// Capsule imperfections of the simulated array.
    #[command(flatten)]
    pub array: array_model::ArrayArgs,
    /// Several talkers.
    #[command(flatten)]
    pub multi: crate::multi_talker_scene::MultiTalkerArgs,
}

/// Runs `host-sim scene`.
pub fn run(a: &SceneArgs) -> Result<()> {
    cma_core::decimator::Decimator::for_rate(a.rate).map_err(|source| SimError::Core {
        context: "--rate".into(),
        source,
    })?;
    if let Some(path) = &a.source {
        crate::wav_io::check_mono(path, "--source")?;
    }
    if let Some(n) = a.multi.talkers {
        return crate::multi_talker_scene::run(a, n);
    }
    let source = scene::load_source(a.source.as_deref(), a.synth, a.rate, a.seed)?;
    let motion = match (a.azimuth, &a.track, a.rotate) {
        (Some(az), None, None) => scene::Motion::Steps(vec![(0.0, az)]),
        (None, Some(t), None) => scene::Motion::parse_steps(t)?,
        (None, None, Some(speed)) => scene::Motion::Rotate {
            start_deg: a.start_azimuth,
            deg_per_s: speed,
        },
        (None, None, None) => scene::Motion::Steps(vec![(0.0, 0.0)]),
        _ => {
            return Err(SimError::Usage(
                "give at most one of --azimuth, --track, --rotate".into(),
            ))
        }
    };
    let room = a
        .rir
        .as_deref()
        .map(|p| scene::RoomResponse::read(p, a.rate, a.rir_n3d, a.rir_length, a.rir_direct))
        .transpose()?;
    let spec = scene::SceneSpec {
        source,
        rate: a.rate,
        lead_in_s: a.lead_in,
        motion,
        snr_db: a.snr,
        room,
        peak_dbfs: a.peak_dbfs,
        seed: a.seed,
        array: a.array.model()?,
    };
    let s = scene::synthesize(&spec);
    scene::write_scene(
        &s,
        &a.out,
        a.format,
        a.manifest.as_deref().map(|m| (m, a.set.as_str())),
    )?;
    eprintln!("{}", scene::written_line(&s, &a.out, a.manifest.as_deref()));
    Ok(())
}
