//! `host-sim locate`: the flags, reading and output of the command that writes one estimate per
//! analysis frame of a recording, as CSV or JSON lines; the estimates are
//! [`crate::localization::frame_estimates`].

use super::progress_bar;
use crate::error::{Result, SimError};
use crate::evaluation::multi_talker_eval;
use crate::flags::config_args::{ConfigArgs, OnOff};
use crate::io::wav_io::InputLayout;
use crate::io::{estimate_output, output_file, selfcal_file, stdout_text, wav_io};
use crate::localization::frame_estimates;
use std::path::PathBuf;

/// `host-sim locate`.
#[derive(Debug, clap::Args)]
#[command(after_help = LOCATE_AFTER_HELP)]
pub struct LocateArgs {
    /// Input WAV (4 channels); `-` (or /dev/stdin, a pipe) reads standard input.
    pub input: PathBuf,
    /// Write the estimates to this file instead of stdout (in --format; `--out` is the same flag;
    /// `-` is stdout).
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
    /// Start the self-calibration from this saved estimate (written by --selfcal-out, or an image
    /// of a board's estimate store: its newest record).
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
     been seen yet, so nothing is tracked and azimuth_deg is that frame's own untracked estimate \
     (equal to azimuth_raw_deg; the previous row's azimuth, 0 at the start, when the frame has no \
     peak): it jumps from row to row and is not to be relied on. ",
    "Unless --quiet, stderr ends with a summary: for AmbiX input how its normalisation was read \
     (SN3D or N3D, from its first-order power over the omni's), then the self-calibration's \
     estimate per band (when it is on, 5 lines; a sixth names the bands that learned nothing because their background was never diffuse, and what helps), then the stationary background per band (when the background field is \
     on: a band with directivity above 0.2 as a source at its azimuth, else diffuse; its level in \
     dBFS, dB re full-scale mean square, and relative to the median power_db of the frames), then \
     one line counting the frames, those with history and those with NaN/Inf input. Input with NaN/Inf samples (replaced by 0, flag 4 NON_FINITE) still exits 0, \
     with a warning line on stderr (also with --quiet); so does a recording whose channels do not \
     fit an omni and three cardioids at one point (a cardioid not connected, the omni on another \
     channel, a reversed polarity).",
);

/// `-` for standard input or output, as a path.
fn is_dash(path: &std::path::Path) -> bool {
    path.as_os_str() == "-"
}

/// Runs `host-sim locate`.
pub fn run(a: &LocateArgs) -> Result<()> {
    let started = std::time::Instant::now();
    if a.tracks.is_some() && a.config.multi_talker == Some(OnOff::Off) {
        return Err(SimError::Usage(
            "--tracks cannot be used with --multi-talker off: --tracks runs the multi-talker \
             tracks (drop one)"
                .into(),
        ));
    }
    let config = a.config.config()?;
    selfcal_file::check_used(
        &[
            ("--selfcal-in", a.selfcal_in.is_some()),
            ("--selfcal-out", a.selfcal_out.is_some()),
        ],
        &config,
    )?;
    let measured = a.config.measured_table()?;
    let table = a.config.table(measured.as_ref())?;
    // Everything that can be refused is, before any output.
    let csv = a.csv.as_deref().filter(|p| !is_dash(p));
    let outputs: Vec<(&str, &std::path::Path)> = [
        ("--csv", csv),
        ("--tracks", a.tracks.as_deref()),
        ("--selfcal-out", a.selfcal_out.as_deref()),
    ]
    .into_iter()
    .filter_map(|(flag, p)| p.map(|p| (flag, p)))
    .collect();
    for (_, path) in &outputs {
        output_file::check_folder(path)?;
    }
    let mut inputs = vec![("input", a.input.as_path())];
    inputs.extend(a.config.input_files());
    if let Some(p) = &a.selfcal_in {
        inputs.push(("--selfcal-in", p.as_path()));
    }
    output_file::check_distinct(&inputs, &outputs)?;
    if a.tracks.is_some() {
        check_tracks(config)?;
    }
    let input = if is_dash(&a.input) {
        std::path::Path::new("/dev/stdin")
    } else {
        a.input.as_path()
    };
    let mut stream = wav_io::RecordingStream::open(input, a.input_layout)?;
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
    if let Some(path) = &a.selfcal_out {
        selfcal_file::check_output(path)?;
    }
    let mut sample_frames = 0usize;
    let located = frame_estimates::locate_stream_calibrated(
        &mut stream,
        config,
        table,
        start.as_ref(),
        |n| {
            sample_frames += n;
            pb.inc(n as u64);
        },
    )?;
    pb.finish_and_clear();
    if let Some(warning) = stream.wiring().warning() {
        eprintln!("{warning}");
    }
    if let Some(n) = stream.normalisation() {
        let line = n.line();
        if !a.quiet || line.starts_with("warning") {
            eprintln!("{line}");
        }
    }
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
            if located.capsule_omni_scale < 1.0 {
                eprintln!(
                    "self-calibration: {:.0} % of the omni parts' correction applied (the talker's \
                     sound does not support the rest: a noise source's intensity, not a capsule error)",
                    100.0 * located.capsule_omni_scale
                );
            }
        }
        if let Some(path) = &a.selfcal_out {
            selfcal_file::write(path, &located.capsules)?;
        }
    }
    if config.background.enabled && !a.quiet {
        eprintln!(
            "{}",
            frame_estimates::background_summary(
                &located.background,
                frame_estimates::median_power_db(&rows)
            )
        );
    }
    let write = |out: &mut dyn std::io::Write| match a.format {
        estimate_output::Format::Csv => frame_estimates::write_csv(out, &rows),
        estimate_output::Format::Jsonl => estimate_output::write_jsonl(out, &rows),
    };
    match csv {
        Some(path) => wav_io::write_atomically(path, |tmp| {
            let f = std::fs::File::create(tmp).map_err(|e| SimError::io(tmp, e))?;
            write(&mut std::io::BufWriter::new(f)).map_err(|e| SimError::io(tmp, e))
        })?,
        None => write(&mut std::io::BufWriter::new(std::io::stdout().lock()))
            .map_err(|e| SimError::writing(stdout_text::STDOUT, e))?,
    }
    if let Some(path) = &a.tracks {
        multi_talker_eval::write_tracks_file(input, a.input_layout, config, table, path)?;
    }
    let summary = estimate_output::Summary::of(&rows, audio_s, started.elapsed().as_secs_f64());
    if let Some(warning) = summary.non_finite_warning() {
        eprintln!("{warning}");
    }
    if !a.quiet {
        eprintln!("{}", summary.line());
    }
    Ok(())
}

/// Refuses a configuration the multi-talker tracks of `--tracks` cannot run with, naming the flag.
fn check_tracks(config: cma_core::LocatorConfig) -> Result<()> {
    if config.method != cma_core::Method::Similarity {
        return Err(SimError::Usage(format!(
            "--tracks: the multi-talker tracks need the similarity method (--method sim), not {:?}",
            config.method
        )));
    }
    cma_config::validate(&multi_talker_eval::with_tracks(config))
        .map_err(|e| SimError::Usage(format!("--tracks: {}", e.message())))
}
