//! `host-sim monitor`: reads the board's frame lines from a serial port and shows them — a live
//! compass view in a terminal, or one text line per frame (`--plain`, also when stdout is not a
//! terminal) — with the counters of [`crate::serial::monitor`] (which decodes, counts, renders and
//! records; this module holds the flags, the port loop and Ctrl-C). `--record` writes the frames as
//! the CSV of `host-sim locate` for `host-sim eval`/`host-sim score`.
//!
//! Ctrl-C ends the monitor like `--frames` or `--exit-after-idle` do: the summary is printed and the
//! record is complete.

use crate::error::{Result, SimError};
use crate::io::estimate_output::Format;
use crate::io::serial_link::{self, Link, ReadOutcome, DEFAULT_BAUD};
use crate::serial::monitor::{
    background_plain_line, calibration_plain_line, plain_line, render, tracks_plain_line, Decoder,
    RateMeter, Recorder, View, FULL_VIEW,
};
use cma_core::wire::{BackgroundLine, CalibrationLine, Frame, Line, TracksLine};
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// `host-sim monitor`.
#[derive(Debug, clap::Args)]
#[command(after_help = MONITOR_AFTER_HELP)]
pub struct MonitorArgs {
    /// Serial device (e.g. /dev/ttyUSB0, /dev/ttyACM0, or a socat pty).
    #[arg(long)]
    pub port: PathBuf,
    /// Baud rate (8N1, no flow control).
    #[arg(long, default_value_t = DEFAULT_BAUD,
          value_parser = clap::value_parser!(u32).range(serial_link::BAUD_RANGE))]
    pub baud: u32,
    /// One text line per frame instead of the live view (automatic when stdout is not a terminal).
    #[arg(long)]
    pub plain: bool,
    /// Record the frames to this file (the columns of `host-sim locate`; power_db is empty: not sent;
    /// calibration lines are not recorded).
    #[arg(long)]
    pub record: Option<PathBuf>,
    /// Format of --record: CSV, or one JSON object per line.
    #[arg(long, value_enum, default_value_t = Format::Csv)]
    pub format: Format,
    /// Exit after this many seconds without a byte (default: run until Ctrl-C).
    #[arg(long, value_name = "SECONDS", value_parser = crate::flags::arg_values::positive_seconds)]
    pub exit_after_idle: Option<f64>,
    /// Exit after this many decoded frames.
    #[arg(long)]
    pub frames: Option<u64>,
}

/// The end of `monitor --help`.
const MONITOR_AFTER_HELP: &str =
    "Live view: the compass rose has 0° up and angles counter-clockwise \
(90° to the left); @ is the weighted azimuth at the tip of its needle (* when confident, : when \
not), x the azimuth of the last frame alone, + a tick every 30°, o the array. It needs 80×24; a \
smaller terminal gets the numbers without the rose. Flags are printed as in the CSV: the decimal \
sum of 1 SILENT, 2 CLIPPED, 4 NON_FINITE, 8 NO_PEAKS, 16 NO_HISTORY. Ctrl-C ends the monitor with \
its summary.";

/// The terminal's (columns, rows), or [`FULL_VIEW`] if it cannot be asked.
fn terminal_size() -> (usize, usize) {
    console::Term::stdout()
        .size_checked()
        .map_or(FULL_VIEW, |(rows, cols)| {
            (usize::from(cols), usize::from(rows))
        })
}

/// Set by Ctrl-C (SIGINT/SIGTERM); the monitor's loop ends on it and prints its summary.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Installs the Ctrl-C handler once per process (later calls, and a handler installed by someone
/// else, leave the default behaviour: exit without the summary).
fn catch_interrupt() {
    static INSTALL: std::sync::Once = std::sync::Once::new();
    INSTALL.call_once(|| {
        if let Err(e) = ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::SeqCst)) {
            eprintln!("monitor: Ctrl-C will not print the summary ({e})");
        }
    });
    INTERRUPTED.store(false, Ordering::SeqCst);
}

/// Minimum time between two redraws of the live view (at most 20 per second).
const REDRAW_INTERVAL: Duration = Duration::from_millis(50);

/// Runs `host-sim monitor`.
pub fn run(a: &MonitorArgs) -> Result<()> {
    let mut link = Link::open(&a.port, a.baud)?;
    catch_interrupt();
    eprintln!("monitor: opened {} at {} baud", a.port.display(), a.baud);
    let live = !a.plain && std::io::stdout().is_terminal();
    let mut recorder = a
        .record
        .as_deref()
        .map(|p| Recorder::create(p, a.format))
        .transpose()?;
    let mut dec = Decoder::new();
    let mut meter = RateMeter::default();
    let mut last: Option<Frame> = None;
    let mut last_calibration: Option<CalibrationLine> = None;
    let mut last_tracks: Option<TracksLine> = None;
    let mut last_background: Option<BackgroundLine> = None;
    let mut buf = [0u8; 4096];
    let mut last_byte = Instant::now();
    let mut last_draw: Option<Instant> = None;
    let mut status: Option<String> = None;
    let mut hint_shown = false;
    let mut was_connected = true;
    let stdout = std::io::stdout();
    if live {
        print!("\x1b[2J");
    }
    loop {
        let outcome = link.read(&mut buf);
        let now = Instant::now();
        match outcome {
            ReadOutcome::Data(n) => {
                last_byte = now;
                let mut failure = None;
                let mut out = stdout.lock();
                dec.feed_lines(&buf[..n], |line| {
                    let text = match line {
                        Line::Frame(f) => {
                            meter.tick(now);
                            last = Some(*f);
                            if let Some(r) = recorder.as_mut() {
                                if let Err(e) = r.write(f) {
                                    failure.get_or_insert(e);
                                }
                            }
                            (!live).then(|| plain_line(f))
                        }
                        Line::Calibration(c) => {
                            last_calibration = Some(*c);
                            (!live).then(|| calibration_plain_line(c))
                        }
                        Line::Tracks(t) => {
                            last_tracks = Some(t.clone());
                            (!live).then(|| tracks_plain_line(t))
                        }
                        Line::Background(b) => {
                            last_background = Some(*b);
                            (!live).then(|| background_plain_line(b))
                        }
                    };
                    if let Some(text) = text {
                        if let Err(e) = writeln!(out, "{text}") {
                            failure.get_or_insert(SimError::io("<stdout>", e));
                        }
                    }
                });
                if let Err(e) = out.flush() {
                    failure.get_or_insert(SimError::io("<stdout>", e));
                }
                if let Some(e) = failure {
                    return Err(e);
                }
            }
            ReadOutcome::Idle => {}
            ReadOutcome::Disconnected => {
                if was_connected {
                    let msg = format!(
                        "port {} lost ({}); waiting for it to come back",
                        a.port.display(),
                        link.last_error.as_deref().unwrap_or("unknown error")
                    );
                    if !live {
                        eprintln!("monitor: {msg}");
                    }
                    status = Some(msg);
                    was_connected = false;
                    dec.reset_line();
                }
            }
            ReadOutcome::Reopened => {
                let msg = format!("port {} reopened", a.port.display());
                if !live {
                    eprintln!("monitor: {msg}");
                }
                status = Some(msg);
                was_connected = true;
            }
        }
        match dec.baud_hint(a.baud).or_else(|| dec.noise_hint()) {
            Some(h) => {
                if !hint_shown && !live {
                    eprintln!("monitor: {h}");
                }
                hint_shown = true;
                status = Some(h);
            }
            None if hint_shown => {
                hint_shown = false;
                status = None;
            }
            None => {}
        }
        if live && last_draw.is_none_or(|t| now.duration_since(t) >= REDRAW_INTERVAL) {
            let view = View {
                port: &a.port,
                baud: a.baud,
                connected: link.is_connected(),
                last: last.as_ref(),
                calibration: last_calibration.as_ref(),
                tracks: last_tracks.as_ref(),
                background: last_background.as_ref(),
                counters: dec.counters(),
                reopens: link.reopens,
                fps: meter.per_second(now),
                status: status.clone(),
                recording: a.record.as_deref(),
            };
            let (cols, rows) = terminal_size();
            let mut out = stdout.lock();
            let _ = out.write_all(render(&view, cols, rows).as_bytes());
            let _ = out.flush();
            last_draw = Some(now);
        }
        if a.exit_after_idle
            .is_some_and(|s| now.duration_since(last_byte).as_secs_f64() >= s)
        {
            break;
        }
        if a.frames.is_some_and(|n| dec.counters().frames >= n) {
            break;
        }
        if INTERRUPTED.load(Ordering::SeqCst) {
            if live {
                println!();
            }
            eprintln!("monitor: interrupted");
            break;
        }
    }
    if let Some(r) = &recorder {
        if r.skipped_no_rate() > 0 {
            eprintln!(
                "monitor: {} frames with rate_hz 0 not recorded (no time)",
                r.skipped_no_rate()
            );
        }
    }
    eprintln!("monitor: summary {}", dec.counters().summary(link.reopens));
    if let Some(e) = dec.last_error() {
        eprintln!("monitor: last rejected line: {e}");
    }
    Ok(())
}
