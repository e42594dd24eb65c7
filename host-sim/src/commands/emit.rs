//! `host-sim emit`: a stand-in board. Runs the core on a WAV (exactly as `host-sim locate` does) and
//! writes the lines a board would send to a serial port ([`crate::serial::board_lines`]: frame
//! lines, calibration lines, background lines, and with `--multi-talker on` track lines).

use crate::error::Result;
use crate::flags::config_args::ConfigArgs;
use crate::io::selfcal_file;
use crate::io::serial_link::{self, DEFAULT_BAUD};
use crate::io::wav_io::{self, InputLayout};
use crate::serial::board_lines;
use cma_core::wire::{self, Line};
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// `host-sim emit`.
#[derive(Debug, clap::Args)]
pub struct EmitArgs {
    /// Input WAV (4 channels).
    pub input: PathBuf,
    /// Serial device to write to (e.g. /dev/ttyUSB0 or a socat pty).
    #[arg(long)]
    pub port: PathBuf,
    /// Baud rate (8N1, no flow control).
    #[arg(long, default_value_t = DEFAULT_BAUD,
          value_parser = clap::value_parser!(u32).range(serial_link::BAUD_RANGE))]
    pub baud: u32,
    /// Send each line at its frame's time (centre of the analysis frame) instead of at once.
    #[arg(long)]
    pub realtime: bool,
    /// Channel layout of the input.
    #[arg(long, value_enum, default_value_t = InputLayout::Cma1)]
    pub input_layout: InputLayout,
    /// Start the self-calibration from this saved estimate (written by `locate --selfcal-out`, or
    /// an image of a board's estimate store), as a board built with `CMA_SELFCAL`, or booting with
    /// that store, does.
    #[arg(long)]
    pub selfcal_in: Option<PathBuf>,
    /// Localizer configuration.
    #[command(flatten)]
    pub config: ConfigArgs,
}

/// Give up when the port accepted nothing for this long (nobody reading, flow stopped).
const WRITE_STALL: Duration = Duration::from_secs(10);

/// The lines `emit` sends for the WAV and configuration of `a` ([`board_lines::lines`]), with the
/// WAV's rate.
pub fn lines(a: &EmitArgs) -> Result<(u32, Vec<Line>)> {
    if a.config.table.is_some() {
        return Err(crate::error::SimError::Usage(
            "--table cannot be used with emit: it runs the localizer on the ideal table of --grid, \
             as a board built without CMA_TABLE (drop --table)"
                .into(),
        ));
    }
    let config = a.config.config()?;
    selfcal_file::check_used(&[("--selfcal-in", a.selfcal_in.is_some())], &config)?;
    let table = a.config.ideal_table()?;
    let start = a
        .selfcal_in
        .as_deref()
        .map(selfcal_file::read)
        .transpose()?;
    let rec = wav_io::read_recording(&a.input, a.input_layout)?;
    if let Some(n) = rec.normalisation {
        eprintln!("{}", n.line());
    }
    let lines = board_lines::lines(&rec, config, table, start.as_ref())?;
    Ok((rec.rate, lines))
}

/// Runs `host-sim emit`.
pub fn run(a: &EmitArgs) -> Result<()> {
    let (rate, lines) = lines(a)?;
    let mut port = serial_link::open(&a.port, a.baud)?;
    let mut buf = heapless::Vec::<u8, { wire::MAX_ANY_LINE }>::new();
    let start = Instant::now();
    let (mut bytes, mut frames, mut calibrations) = (0usize, 0usize, 0usize);
    for line in &lines {
        let bytes_of_line: &[u8] = match line {
            Line::Frame(f) => {
                if a.realtime {
                    if let Some(t) = f.time_s() {
                        let due = start + Duration::from_secs_f64(t.max(0.0));
                        let now = Instant::now();
                        if due > now {
                            std::thread::sleep(due - now);
                        }
                    }
                }
                frames += 1;
                wire::encode(f, &mut buf);
                &buf
            }
            Line::Calibration(c) => {
                calibrations += 1;
                wire::encode_calibration(c, &mut buf);
                &buf
            }
            Line::Tracks(t) => {
                wire::encode_tracks(t, &mut buf);
                &buf
            }
            Line::Background(b) => {
                wire::encode_background(b, &mut buf);
                &buf
            }
        };
        serial_link::write_all(port.as_mut(), &a.port, bytes_of_line, WRITE_STALL)?;
        bytes += bytes_of_line.len();
    }
    // Wait until the last byte has left (tcdrain), so a following close loses nothing.
    port.flush()
        .map_err(|e| crate::error::SimError::io(&a.port, e))?;
    eprintln!(
        "emit: {frames} frames and {calibrations} calibration lines ({bytes} bytes, {rate} Hz \
         input) to {} at {} baud in {:.2} s",
        a.port.display(),
        a.baud,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
