//! `host-sim emit`: a stand-in board. Runs the core on a WAV (exactly as `host-sim locate` does) and
//! writes the estimates to a serial port as the firmware would: one [`cma_core::wire`] frame line per
//! analysis frame, `seq` from 0, the WAV's sample rate, no overruns and no drops (the host never
//! falls behind the WAV); and, like the firmware, a calibration line (the self-calibration's state)
//! before the first frame line and then every [`CALIBRATION_PERIOD_S`](wire::CALIBRATION_PERIOD_S)
//! seconds of the WAV ([`CalibrationSchedule`]), after the frame line that made it due. With the
//! multi-talker tracks on (`--multi-talker on`) a track line follows every frame line.

use crate::config_args::ConfigArgs;
use crate::error::{Result, SimError};
use crate::selfcal_file;
use crate::serial_link::{self, DEFAULT_BAUD};
use crate::wav_io::{self, InputLayout};
use cma_core::wire::{
    self, CalibrationLine, CalibrationSchedule, Frame, Line, TracksLine, MAX_CAL_LINE, MAX_LINE,
    MAX_TRK_LINE,
};
use cma_core::Locator;
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

/// Sample frames per block, as on the boards: a block completes at most one analysis hop, so a
/// calibration line follows the frame line that made it due, as the board sends it (the estimates
/// do not depend on the block size).
pub const BOARD_BLOCK: usize = 32;

/// Give up when the port accepted nothing for this long (nobody reading, flow stopped).
const WRITE_STALL: Duration = Duration::from_secs(10);

/// The lines `emit` sends for a WAV, in order: frame lines are `locate`'s estimates (in blocks of
/// [`BOARD_BLOCK`] sample frames) through [`Frame::from_estimate`] with `seq` = row index
/// (wrapping), the WAV's rate, 0 overruns, 0 drops; calibration lines as the firmware sends them
/// (at start, then every [`wire::CALIBRATION_PERIOD_S`] s after the frame line that made one due;
/// their own `seq` from 0, 0 drops). Returns them with the rate.
pub fn lines(a: &EmitArgs) -> Result<(u32, Vec<Line>)> {
    let config = a.config.config()?;
    let table = a.config.ideal_table()?;
    let start = a
        .selfcal_in
        .as_deref()
        .map(selfcal_file::read)
        .transpose()?;
    let rec = wav_io::read_recording(&a.input, a.input_layout)?;
    let mut loc = Locator::new(config, table, rec.rate).map_err(|source| SimError::Core {
        context: "configuration".into(),
        source,
    })?;
    if let Some(start) = &start {
        loc.set_capsule_estimate(start);
    }
    let mut out = Vec::with_capacity(rec.frames.len() / 256 + 2);
    let mut schedule = CalibrationSchedule::new(rec.rate);
    let (mut seq, mut calibration_seq) = (0u32, 0u32);
    let mut calibration = |loc: &Locator<'_>, t: u64, out: &mut Vec<Line>| {
        out.push(Line::Calibration(CalibrationLine::from_capsules(
            loc.capsule_estimate(),
            loc.capsule_confidence(),
            calibration_seq,
            t,
            0,
        )));
        calibration_seq = calibration_seq.wrapping_add(1);
    };
    if schedule.due(0) {
        calibration(&loc, 0, &mut out);
    }
    if config.multi_track.enabled {
        // Sample by sample (the same estimates as in blocks), so the tracks can be read after
        // each estimate.
        let mut tracks_seq = 0u32;
        for x in &rec.frames {
            let Some(e) = loc.process_sample(*x) else {
                continue;
            };
            out.push(Line::Frame(Frame::from_estimate(&e, seq, rec.rate, 0, 0)));
            seq = seq.wrapping_add(1);
            out.push(Line::Tracks(TracksLine::from_tracks(
                loc.talker_tracks(),
                tracks_seq,
                e.centre_sample,
            )));
            tracks_seq = tracks_seq.wrapping_add(1);
            if schedule.due(e.centre_sample) {
                calibration(&loc, e.centre_sample, &mut out);
            }
        }
        return Ok((rec.rate, out));
    }
    for block in rec.frames.chunks(BOARD_BLOCK) {
        let mut due = None;
        loc.process_block(block, |e| {
            out.push(Line::Frame(Frame::from_estimate(e, seq, rec.rate, 0, 0)));
            seq = seq.wrapping_add(1);
            if schedule.due(e.centre_sample) {
                due = Some(e.centre_sample);
            }
        });
        if let Some(t) = due {
            calibration(&loc, t, &mut out);
        }
    }
    Ok((rec.rate, out))
}

/// The frame lines of [`lines`] alone.
pub fn frames(a: &EmitArgs) -> Result<(u32, Vec<Frame>)> {
    let (rate, lines) = lines(a)?;
    let frames = lines
        .into_iter()
        .filter_map(|l| match l {
            Line::Frame(f) => Some(f),
            Line::Calibration(_) | Line::Tracks(_) => None,
        })
        .collect();
    Ok((rate, frames))
}

/// Runs `host-sim emit`.
pub fn run(a: &EmitArgs) -> Result<()> {
    let (rate, lines) = lines(a)?;
    let mut port = serial_link::open(&a.port, a.baud)?;
    let mut frame_buf = [0u8; MAX_LINE];
    let mut cal_buf = [0u8; MAX_CAL_LINE];
    let mut tracks_buf = [0u8; MAX_TRK_LINE];
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
                let n = wire::encode(f, &mut frame_buf);
                &frame_buf[..n]
            }
            Line::Calibration(c) => {
                calibrations += 1;
                let n = wire::encode_calibration(c, &mut cal_buf);
                &cal_buf[..n]
            }
            Line::Tracks(t) => {
                let n = wire::encode_tracks(t, &mut tracks_buf);
                &tracks_buf[..n]
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
