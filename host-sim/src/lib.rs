//! # host-sim — the cma-core localizer on the host
//!
//! Runs *the same* `cma-core` code as the firmware on WAV files, block by block, and adds what a
//! desk needs: evaluation against ground truth with plots, and a scene simulator for tests.
//! The binary `host-sim` is a thin wrapper around [`run`].

pub mod arg_values;
pub mod array_model;
pub mod beam;
pub mod calibrate;
pub mod calibrate_cli;
pub mod config_args;
pub mod distance_eval;
pub mod emit;
pub mod error;
pub mod estimate_output;
pub mod eval;
pub mod fixed_decimal;
pub mod ground_truth;
pub mod locate;
pub mod manifest;
pub mod metrics;
pub mod monitor;
pub mod multi_talker_eval;
pub mod multi_talker_scene;
pub mod options_eval;
pub mod output_file;
pub mod plots;
pub mod scene;
pub mod score;
pub mod selfcal_file;
pub mod serial_link;
pub mod signal;
pub mod stdout_text;
pub mod sweep;
pub mod table_io;
pub mod text_file;
pub mod wav_io;

pub mod thesis_option_commands;

use clap::{Parser, Subcommand};
use config_args::ConfigArgs;
use error::{Result, SimError};
use std::ffi::OsString;
use std::path::PathBuf;
use wav_io::{InputLayout, OutFormat};

/// Command line of `host-sim`.
#[derive(Debug, Parser)]
#[command(
    name = "host-sim",
    version,
    about = "Coincident-array talker localizer: the firmware's core on WAV files"
)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands. Each accepts negative numbers as flag values (`--snr-from -30`) where a
/// number is expected.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Localize the talker in a 4-channel WAV; one CSV row per analysis frame.
    #[command(allow_negative_numbers = true)]
    Locate(LocateArgs),
    /// Evaluate against ground truth on a folder with manifest.csv and NAME.pos.csv files.
    #[command(allow_negative_numbers = true)]
    Eval(EvalArgs),
    /// Synthesise a CMA1 scene (WAV + .pos.csv) from a talker, a track, diffuse noise and a room.
    #[command(allow_negative_numbers = true)]
    Scene(SceneArgs),
    /// Show the frame stream of a board on a serial port live (or --plain), optionally --record it.
    #[command(allow_negative_numbers = true)]
    Monitor(monitor::MonitorArgs),
    /// Stand-in board: run the core on a WAV and write the frame lines to a serial port.
    #[command(allow_negative_numbers = true)]
    Emit(emit::EmitArgs),
    /// Score an estimate CSV (e.g. a `monitor --record`) against a truth .pos.csv, like eval.
    #[command(allow_negative_numbers = true)]
    Score(score::ScoreArgs),
    /// Self-steered beamformer: mono beam (and reverse beam) of a 4-channel WAV.
    #[command(allow_negative_numbers = true)]
    Beam(thesis_option_commands::BeamArgs),
    /// Measure the beamformer's SNR gain and front/back ratio on simulated scenes.
    #[command(allow_negative_numbers = true)]
    BeamReport(thesis_option_commands::BeamReportArgs),
    /// Evaluate every thesis option against the default on an evaluation folder (Markdown table).
    #[command(allow_negative_numbers = true)]
    OptionsEval(thesis_option_commands::OptionsEvalArgs),
    /// Measure the proximity-effect distance estimate on simulated near-field scenes.
    #[command(allow_negative_numbers = true)]
    DistanceReport(thesis_option_commands::DistanceReportArgs),
    /// Write the exponential sine sweep (thesis eq. 2.43) to play for a calibration.
    #[command(allow_negative_numbers = true)]
    Sweep(calibrate_cli::SweepArgs),
    /// Measure a reference table from sweep recordings at known azimuths.
    #[command(allow_negative_numbers = true)]
    Calibrate(calibrate_cli::CalibrateArgs),
}

/// `host-sim locate`.
#[derive(Debug, clap::Args)]
#[command(after_help = LOCATE_AFTER_HELP)]
pub struct LocateArgs {
    /// Input WAV (4 channels); a pipe or /dev/stdin works too.
    pub input: PathBuf,
    /// Write the estimates to this file instead of stdout (in --format; `--out` is the same flag).
    #[arg(long, visible_alias = "out")]
    pub csv: Option<PathBuf>,
    /// Format of the estimates.
    #[arg(long, value_enum, default_value_t = estimate_output::Format::Csv)]
    pub format: estimate_output::Format,
    /// No progress bar and no summary lines on stderr.
    #[arg(long, short)]
    pub quiet: bool,
    /// Channel layout of the input.
    #[arg(long, value_enum, default_value_t = InputLayout::Cma1)]
    pub input_layout: InputLayout,
    /// Start the self-calibration from this saved estimate (written by --selfcal-out).
    #[arg(long)]
    pub selfcal_in: Option<PathBuf>,
    /// Write the self-calibration's final estimate here (to start the next run, or the board, from).
    #[arg(long)]
    pub selfcal_out: Option<PathBuf>,
    /// Also run the multi-talker tracks and write them here: one row per track per frame,
    /// t_s,track_id,azimuth_deg,confidence,active.
    #[arg(long)]
    pub tracks: Option<PathBuf>,
    /// Localizer configuration.
    #[command(flatten)]
    pub config: ConfigArgs,
}

/// The end of `locate --help`: the columns and the flags.
const LOCATE_AFTER_HELP: &str = concat!(
    "Output: one row per analysis frame with frame, t_s (frame centre), azimuth_deg (reliability-\
     weighted, counter-clockwise from cardioid 1), azimuth_raw_deg (this frame alone), confidence \
     (0-1), power_db (omni) and flags. ",
    "Flags: the decimal sum of 1 SILENT, 2 CLIPPED, 4 NON_FINITE, 8 NO_PEAKS, 16 NO_HISTORY. \
     The first frames of a recording carry NO_HISTORY with confidence 0: no reliable frame has \
     been seen yet and the azimuth is the start value, not an estimate. ",
    "A summary line on stderr (unless --quiet) counts them.",
);

/// `host-sim eval`.
#[derive(Debug, clap::Args)]
pub struct EvalArgs {
    /// Folder with manifest.csv.
    pub dir: PathBuf,
    /// Print the report as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Write PNG plots (track vs truth per scene, accuracy vs tolerance) into this folder.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = arg_values::threads)]
    pub threads: Option<usize>,
    /// Channel layout of the scenes.
    #[arg(long, value_enum, default_value_t = InputLayout::Cma1)]
    pub input_layout: InputLayout,
    /// Localizer configuration.
    #[command(flatten)]
    pub config: ConfigArgs,
}

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
    pub multi: multi_talker_scene::MultiTalkerArgs,
}

/// Parses `args` (including the program name) and runs the command.
pub fn run<I, T>(args: I) -> Result<()>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = match Cli::try_parse_from(args) {
        Ok(c) => c,
        Err(e)
            if matches!(
                e.kind(),
                clap::error::ErrorKind::DisplayHelp | clap::error::ErrorKind::DisplayVersion
            ) =>
        {
            return stdout_text::print_text(&e.to_string());
        }
        Err(e) => return Err(SimError::Cli(e)),
    };
    match cli.command {
        Command::Locate(a) => cmd_locate(&a),
        Command::Eval(a) => cmd_eval(&a),
        Command::Scene(a) => cmd_scene(&a),
        Command::Monitor(a) => monitor::run(&a),
        Command::Emit(a) => emit::run(&a),
        Command::Score(a) => score::run(&a),
        Command::Beam(a) => thesis_option_commands::beam(&a),
        Command::BeamReport(a) => thesis_option_commands::beam_report(&a),
        Command::OptionsEval(a) => thesis_option_commands::options_eval(&a),
        Command::DistanceReport(a) => thesis_option_commands::distance_report(&a),
        Command::Sweep(a) => calibrate_cli::cmd_sweep(&a),
        Command::Calibrate(a) => calibrate_cli::cmd_calibrate(&a),
    }
}

fn progress_bar(total: u64) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(total);
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {percent:>3}% {elapsed_precise} eta {eta}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    pb
}

fn cmd_locate(a: &LocateArgs) -> Result<()> {
    let started = std::time::Instant::now();
    let config = a.config.config()?;
    let measured = a.config.measured_table()?;
    let table = a.config.table(measured.as_ref())?;
    let mut stream = wav_io::RecordingStream::open(&a.input, a.input_layout)?;
    let rate = stream.rate();
    let pb = if a.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        progress_bar(stream.declared_frames() as u64)
    };
    let start = match &a.selfcal_in {
        Some(path) => Some(selfcal_file::read(path)?),
        None => None,
    };
    let mut sample_frames = 0usize;
    let located =
        locate::locate_stream_calibrated(&mut stream, config, table, start.as_ref(), |n| {
            sample_frames += n;
            pb.inc(n as u64);
        })?;
    pb.finish_and_clear();
    let rows = located.rows;
    let audio_s = sample_frames as f64 / f64::from(rate);
    if rows.is_empty() {
        return Err(SimError::Other(format!(
            "{}: {sample_frames} sample frames ({audio_s:.3} s at {rate} Hz) are shorter than one \
             analysis frame ({} samples at the analysis rate): no estimate",
            a.input.display(),
            cma_core::FRAME_LEN
        )));
    }
    if config.capsule_calibration.enabled {
        if !a.quiet {
            eprint!(
                "{}",
                selfcal_file::summary(&located.capsules, located.capsule_confidence)
            );
        }
        if let Some(path) = &a.selfcal_out {
            selfcal_file::write(path, &located.capsules)?;
        }
    } else if a.selfcal_out.is_some() {
        return Err(SimError::Usage(
            "--selfcal-out: the self-calibration is off (--selfcal off, the thesis preset or a measured table)".into(),
        ));
    }
    let write = |out: &mut dyn std::io::Write| match a.format {
        estimate_output::Format::Csv => locate::write_csv(out, &rows),
        estimate_output::Format::Jsonl => estimate_output::write_jsonl(out, &rows),
    };
    match &a.csv {
        Some(path) => wav_io::write_atomically(path, |tmp| {
            let f = std::fs::File::create(tmp).map_err(|e| SimError::io(tmp, e))?;
            write(&mut std::io::BufWriter::new(f)).map_err(|e| SimError::io(tmp, e))
        })?,
        None => write(&mut std::io::BufWriter::new(std::io::stdout().lock()))
            .map_err(|e| SimError::io(stdout_text::STDOUT, e))?,
    }
    if let Some(path) = &a.tracks {
        multi_talker_eval::write_tracks_file(&a.input, a.input_layout, config, table, path)?;
    }
    if !a.quiet {
        let summary = estimate_output::Summary::of(&rows, audio_s, started.elapsed().as_secs_f64());
        eprintln!("{}", summary.line());
    }
    Ok(())
}

fn cmd_eval(a: &EvalArgs) -> Result<()> {
    if multi_talker_eval::is_multi_talker_folder(&a.dir) {
        return multi_talker_eval::run(a);
    }
    let config = a.config.config()?;
    let measured = a.config.measured_table()?;
    let table = a.config.table(measured.as_ref())?;
    let threads = a
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let pb = progress_bar(eval::total_frames(&a.dir));
    let (report, scenes) = eval::evaluate(&a.dir, config, table, a.input_layout, threads, &|n| {
        pb.inc(n)
    })?;
    pb.finish_and_clear();
    if a.json {
        let json =
            serde_json::to_string_pretty(&report).map_err(|e| SimError::Other(e.to_string()))?;
        stdout_text::print_text(&format!("{json}\n"))?;
    } else {
        stdout_text::print_text(&eval::format_table(&report))?;
    }
    if let Some(dir) = &a.plots {
        std::fs::create_dir_all(dir).map_err(|e| SimError::io(dir, e))?;
        plots::accuracy_plot(&dir.join("accuracy.png"), &report)?;
        for s in &scenes {
            plots::track_plot(&dir.join(format!("{}.png", s.entry.name())), s)?;
        }
    }
    Ok(())
}

fn cmd_scene(a: &SceneArgs) -> Result<()> {
    cma_core::decimator::Decimator::for_rate(a.rate).map_err(|source| SimError::Core {
        context: "--rate".into(),
        source,
    })?;
    if let Some(n) = a.multi.talkers {
        return multi_talker_scene::run(a, n);
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
