//! `host-sim emit`: a stand-in board. Runs the core on a WAV (exactly as `host-sim locate` does) and
//! writes the estimates to a serial port as the firmware would: one [`cma_core::wire`] line per
//! analysis frame, `seq` from 0, the WAV's sample rate, no overruns and no drops (the host never
//! falls behind the WAV).

use crate::config_args::ConfigArgs;
use crate::error::Result;
use crate::locate;
use crate::serial_link::{self, DEFAULT_BAUD};
use crate::wav_io::{self, InputLayout};
use cma_core::wire::{self, Frame, MAX_LINE};
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
    /// Localizer configuration.
    #[command(flatten)]
    pub config: ConfigArgs,
}

/// Give up when the port accepted nothing for this long (nobody reading, flow stopped).
const WRITE_STALL: Duration = Duration::from_secs(10);

/// The frames `emit` sends for a WAV: `locate`'s estimates through [`Frame::from_estimate`] with
/// `seq` = row index (wrapping), the WAV's rate, 0 overruns, 0 drops. Returns them with the rate.
pub fn frames(a: &EmitArgs) -> Result<(u32, Vec<Frame>)> {
    let config = a.config.config()?;
    let table = a.config.ideal_table()?;
    let rec = wav_io::read_recording(&a.input, a.input_layout)?;
    let rows = locate::locate(&rec, config, table, |_| {})?;
    let mut seq = 0u32;
    let frames = rows
        .iter()
        .map(|r| {
            let f = Frame::from_estimate(&r.estimate, seq, rec.rate, 0, 0);
            seq = seq.wrapping_add(1);
            f
        })
        .collect();
    Ok((rec.rate, frames))
}

/// Runs `host-sim emit`.
pub fn run(a: &EmitArgs) -> Result<()> {
    let (rate, frames) = frames(a)?;
    let mut port = serial_link::open(&a.port, a.baud)?;
    let mut buf = [0u8; MAX_LINE];
    let start = Instant::now();
    let mut bytes = 0usize;
    for f in &frames {
        if a.realtime {
            if let Some(t) = f.time_s() {
                let due = start + Duration::from_secs_f64(t.max(0.0));
                let now = Instant::now();
                if due > now {
                    std::thread::sleep(due - now);
                }
            }
        }
        let n = wire::encode(f, &mut buf);
        serial_link::write_all(port.as_mut(), &a.port, &buf[..n], WRITE_STALL)?;
        bytes += n;
    }
    // Wait until the last byte has left (tcdrain), so a following close loses nothing.
    port.flush()
        .map_err(|e| crate::error::SimError::io(&a.port, e))?;
    eprintln!(
        "emit: {} frames ({bytes} bytes, {rate} Hz input) to {} at {} baud in {:.2} s",
        frames.len(),
        a.port.display(),
        a.baud,
        start.elapsed().as_secs_f64()
    );
    Ok(())
}
