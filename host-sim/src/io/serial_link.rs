//! Opening a serial port (real device or pseudo-terminal) with readable errors, and reopening it after
//! an unplug.

use crate::error::{Result, SimError};
use serialport::SerialPort;
use std::io::{self, Read};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Default baud rate of the firmware's UART.
pub const DEFAULT_BAUD: u32 = 115_200;

/// Smallest and largest baud rate accepted on the command line.
pub const BAUD_RANGE: std::ops::RangeInclusive<i64> = 50..=4_000_000;

/// How long one read waits for bytes before the caller gets control back (redraw, idle checks).
pub const READ_TIMEOUT: Duration = Duration::from_millis(50);

/// Opens `path` at `baud`, 8N1, no flow control, exclusive, with [`READ_TIMEOUT`].
pub fn open(path: &Path, baud: u32) -> Result<Box<dyn SerialPort>> {
    let name = path.to_string_lossy();
    serialport::new(name.as_ref(), baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(READ_TIMEOUT)
        .open()
        .map_err(|e| open_error(path, baud, &e))
}

fn open_error(path: &Path, baud: u32, e: &serialport::Error) -> SimError {
    let hint = match e.kind() {
        serialport::ErrorKind::NoDevice => " (no such device, or it is in use by another program)",
        serialport::ErrorKind::Io(io::ErrorKind::NotFound) => " (no such device)",
        serialport::ErrorKind::Io(io::ErrorKind::PermissionDenied) => {
            " (permission denied: add yourself to the `dialout` group)"
        }
        serialport::ErrorKind::InvalidInput => " (bad path or unsupported baud rate)",
        _ => "",
    };
    SimError::Other(format!(
        "{}: cannot open serial port at {baud} baud: {e}{hint}",
        path.display()
    ))
}

/// What one [`Link::read`] produced.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReadOutcome {
    /// This many bytes were read into the buffer.
    Data(usize),
    /// Nothing arrived within [`READ_TIMEOUT`].
    Idle,
    /// The port is gone (unplugged) and not back yet; the link retries on the next reads.
    Disconnected,
    /// The port came back after a disconnect (no bytes read yet).
    Reopened,
}

/// A serial port that reopens itself after an unplug: reads never fail, they report
/// [`ReadOutcome::Disconnected`] until the device is back.
pub struct Link {
    path: PathBuf,
    baud: u32,
    port: Option<Box<dyn SerialPort>>,
    last_attempt: Option<Instant>,
    /// Why the port was last lost (for the status line).
    pub last_error: Option<String>,
    /// Times the port was reopened after being lost.
    pub reopens: u64,
}

/// Pause between attempts to reopen a lost port.
pub const REOPEN_INTERVAL: Duration = Duration::from_millis(250);

impl Link {
    /// Opens the port once; fails with a readable error if it cannot be opened now.
    pub fn open(path: &Path, baud: u32) -> Result<Link> {
        let port = open(path, baud)?;
        Ok(Link {
            path: path.to_path_buf(),
            baud,
            port: Some(port),
            last_attempt: None,
            last_error: None,
            reopens: 0,
        })
    }

    /// The device path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// `true` while the port is open.
    pub fn is_connected(&self) -> bool {
        self.port.is_some()
    }

    /// Reads what is there (waiting at most [`READ_TIMEOUT`]), reopening a lost port.
    pub fn read(&mut self, buf: &mut [u8]) -> ReadOutcome {
        let Some(port) = self.port.as_mut() else {
            if self
                .last_attempt
                .is_some_and(|t| t.elapsed() < REOPEN_INTERVAL)
            {
                std::thread::sleep(READ_TIMEOUT);
                return ReadOutcome::Disconnected;
            }
            self.last_attempt = Some(Instant::now());
            return match open(&self.path, self.baud) {
                Ok(p) => {
                    self.port = Some(p);
                    self.reopens += 1;
                    ReadOutcome::Reopened
                }
                Err(e) => {
                    self.last_error = Some(e.to_string());
                    std::thread::sleep(READ_TIMEOUT);
                    ReadOutcome::Disconnected
                }
            };
        };
        match port.read(buf) {
            Ok(0) => self.lost("end of stream (hang-up)".into()),
            Ok(n) => ReadOutcome::Data(n),
            Err(e) if is_transient(e.kind()) => ReadOutcome::Idle,
            Err(e) => self.lost(e.to_string()),
        }
    }

    fn lost(&mut self, why: String) -> ReadOutcome {
        self.port = None;
        self.last_error = Some(why);
        self.last_attempt = Some(Instant::now());
        ReadOutcome::Disconnected
    }
}

/// Errors that mean "nothing yet, try again" on a serial port (read/write time-outs, signals).
fn is_transient(kind: io::ErrorKind) -> bool {
    matches!(
        kind,
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
    )
}

/// Writes all of `bytes` to `port`, retrying on write time-outs (a full output buffer) until
/// `stall` has passed without progress.
pub fn write_all(
    port: &mut dyn SerialPort,
    path: &Path,
    mut bytes: &[u8],
    stall: Duration,
) -> Result<()> {
    let mut last_progress = Instant::now();
    while !bytes.is_empty() {
        match port.write(bytes) {
            Ok(0) => {
                return Err(SimError::Other(format!(
                    "{}: the serial port accepts no more bytes",
                    path.display()
                )))
            }
            Ok(n) => {
                bytes = &bytes[n..];
                last_progress = Instant::now();
            }
            Err(e) if is_transient(e.kind()) => {
                if last_progress.elapsed() > stall {
                    return Err(SimError::Other(format!(
                        "{}: nothing could be written for {:.1} s (is anyone reading the port?)",
                        path.display(),
                        stall.as_secs_f64()
                    )));
                }
            }
            Err(e) => return Err(SimError::io(path, e)),
        }
    }
    Ok(())
}
