//! # host-sim — the cma-core localizer on the host
//!
//! Runs *the same* `cma-core` code as the firmware on WAV files, block by block, and adds what a
//! desk needs: evaluation against ground truth with plots, and a scene simulator for tests.
//! The binary `host-sim` is a thin wrapper around [`run`]; each subcommand is a module of
//! [`commands`] (its flags and its `run`), thin over the library modules beside it.

pub mod calibration;
pub mod commands;
pub mod error;
pub mod evaluation;
pub mod flags;
pub mod io;
pub mod localization;
pub mod serial;
pub mod simulation;

use clap::{CommandFactory, FromArgMatches, Subcommand};
use error::{Result, SimError};
use std::ffi::OsString;

/// Command line of `host-sim`.
#[derive(Debug, clap::Parser)]
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
    Locate(commands::locate::LocateArgs),
    /// Evaluate against ground truth on a folder with manifest.csv and NAME.pos.csv files.
    #[command(allow_negative_numbers = true)]
    Eval(commands::eval::EvalArgs),
    /// Synthesise a CMA1 scene (WAV + .pos.csv) from a talker, a track, diffuse noise and a room.
    #[command(allow_negative_numbers = true)]
    Scene(commands::scene::SceneArgs),
    /// Show the frame stream of a board on a serial port live (or --plain), optionally --record it.
    #[command(allow_negative_numbers = true)]
    Monitor(commands::monitor::MonitorArgs),
    /// Stand-in board: run the core on a WAV and write the frame lines to a serial port.
    #[command(allow_negative_numbers = true)]
    Emit(commands::emit::EmitArgs),
    /// Score an estimate CSV (e.g. a `monitor --record`) against a truth .pos.csv, like eval.
    #[command(allow_negative_numbers = true)]
    Score(commands::score::ScoreArgs),
    /// Self-steered beamformer: mono beam (and reverse beam) of a 4-channel WAV.
    #[command(allow_negative_numbers = true)]
    Beam(commands::beam::BeamArgs),
    /// Measure the beamformer's SNR gain and front/back ratio on simulated scenes.
    #[command(allow_negative_numbers = true)]
    BeamReport(commands::beam_report::BeamReportArgs),
    /// Evaluate every thesis option against the default on an evaluation folder (Markdown table).
    #[command(allow_negative_numbers = true)]
    OptionsEval(commands::options_eval::OptionsEvalArgs),
    /// Measure the proximity-effect distance estimate on simulated near-field scenes.
    #[command(allow_negative_numbers = true)]
    DistanceReport(commands::distance_report::DistanceReportArgs),
    /// Write the exponential sine sweep (thesis eq. 2.43) to play for a calibration.
    #[command(allow_negative_numbers = true)]
    Sweep(commands::sweep::SweepArgs),
    /// Measure a reference table from sweep recordings at known azimuths, or compute one from a
    /// self-calibration estimate (--selfcal-in).
    #[command(allow_negative_numbers = true)]
    Calibrate(commands::calibrate::CalibrateArgs),
    /// Print the localizer configuration (preset, file and flags applied) as a configuration file.
    #[command(allow_negative_numbers = true)]
    Config(commands::config::ConfigCmdArgs),
}

/// One example per command, shown at the end of its `--help`.
const EXAMPLES: &[(&str, &str)] = &[
    (
        "locate",
        "host-sim locate talk.wav --config room.toml --csv talk.csv",
    ),
    (
        "eval",
        "host-sim eval out/demo --preset thesis --json    (out/demo: written by scripts/demo.sh)",
    ),
    (
        "scene",
        "host-sim scene --synth 5 --azimuth 60 --snr 10 --out s60.wav",
    ),
    (
        "monitor",
        "host-sim monitor --port /dev/ttyUSB0 --record board.csv",
    ),
    (
        "emit",
        "host-sim emit talk.wav --port ./ttyA --config room.toml",
    ),
    ("score", "host-sim score board.csv s60.pos.csv"),
    (
        "beam",
        "host-sim beam talk.wav --out beam.wav --pattern 0.75",
    ),
    (
        "beam-report",
        "host-sim beam-report shared/data/src --snr 0",
    ),
    (
        "options-eval",
        "host-sim options-eval out/demo --base \"--config room.toml\"",
    ),
    (
        "distance-report",
        "host-sim distance-report shared/data/src",
    ),
    ("sweep", "host-sim sweep --out sweep.wav --seconds 5"),
    (
        "calibrate",
        "host-sim calibrate --dir cal/ --sweep sweep.wav --out array.cmat",
    ),
    (
        "config",
        "host-sim config --preset thesis --tracker grid > mine.toml",
    ),
];

/// The command line of `host-sim` as clap parses it: [`Cli`] with every configuration flag's help
/// showing its file key and preset values ([`flags::config_args::flag_notes`]) and an example per command.
#[must_use]
pub fn command() -> clap::Command {
    let mut cmd = Cli::command();
    let notes = flags::config_args::flag_notes();
    for (name, example) in EXAMPLES {
        cmd = cmd.mut_subcommand(*name, |s| {
            let after = s
                .get_after_help()
                .map(|h| format!("{h}\n\n"))
                .unwrap_or_default();
            flags::config_args::annotate(s, &notes)
                .after_help(format!("{after}Example:\n  {example}"))
        });
    }
    cmd
}

/// Parses `args` (including the program name) and runs the command.
pub fn run<I, T>(args: I) -> Result<()>
where
    I: IntoIterator<Item = T>,
    T: Into<OsString> + Clone,
{
    let cli = match command()
        .try_get_matches_from(args)
        .and_then(|m| Cli::from_arg_matches(&m))
    {
        Ok(c) => c,
        Err(e)
            if matches!(
                e.kind(),
                clap::error::ErrorKind::DisplayHelp | clap::error::ErrorKind::DisplayVersion
            ) =>
        {
            return io::stdout_text::print_text(&e.to_string());
        }
        Err(e) => return Err(SimError::Cli(e)),
    };
    match cli.command {
        Command::Locate(a) => commands::locate::run(&a),
        Command::Eval(a) => commands::eval::run(&a),
        Command::Scene(a) => commands::scene::run(&a),
        Command::Monitor(a) => commands::monitor::run(&a),
        Command::Emit(a) => commands::emit::run(&a),
        Command::Score(a) => commands::score::run(&a),
        Command::Beam(a) => commands::beam::run(&a),
        Command::BeamReport(a) => commands::beam_report::run(&a),
        Command::OptionsEval(a) => commands::options_eval::run(&a),
        Command::DistanceReport(a) => commands::distance_report::run(&a),
        Command::Sweep(a) => commands::sweep::run(&a),
        Command::Calibrate(a) => commands::calibrate::run(&a),
        Command::Config(a) => commands::config::run(&a),
    }
}
