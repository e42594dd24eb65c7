//! The error type of every host-sim command: each variant says what was expected and what came.

use std::path::PathBuf;

/// A host-sim failure.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// A command line clap rejected; its text (starting with `error:`) includes the usage and a hint.
    #[error("{0}")]
    Cli(#[from] clap::Error),
    /// A flag value that parsed but makes no sense (a usage error, like [`SimError::Cli`]).
    #[error("{0}")]
    Usage(String),
    /// A file could not be opened, read or written: `PATH: cannot read: …` (or `write`, …, the
    /// operation that failed, where it is known).
    #[error("{path}: {}{source}", op.map(|op| format!("cannot {op}: ")).unwrap_or_default())]
    Io {
        /// The file.
        path: PathBuf,
        /// What was done with it (`read`, `write`, `create the folder`), if known.
        op: Option<&'static str>,
        /// The OS error.
        source: std::io::Error,
    },
    /// The file is not a readable WAV file (not RIFF/WAVE, truncated, corrupt header).
    #[error("{path}: not a valid WAV file: {reason}")]
    BadWav {
        /// The file.
        path: PathBuf,
        /// What the WAV reader said.
        reason: String,
    },
    /// The WAV has the wrong number of channels.
    #[error("{path}: expected {expected} channels ({layout}), got {got}")]
    ChannelCount {
        /// The file.
        path: PathBuf,
        /// Channels needed.
        expected: u16,
        /// Channels found.
        got: u16,
        /// What the channels must be.
        layout: &'static str,
    },
    /// The WAV's sample format is not supported.
    #[error("{path}: unsupported sample format: {format} (supported: PCM 8/16/24/32-bit integer, 32-bit float)")]
    SampleFormat {
        /// The file.
        path: PathBuf,
        /// The format found.
        format: String,
    },
    /// The WAV holds no samples.
    #[error("{path}: the file holds no samples")]
    Empty {
        /// The file.
        path: PathBuf,
    },
    /// A CSV file could not be parsed.
    #[error("{path}:{line}: {reason}")]
    BadCsv {
        /// The file.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        reason: String,
    },
    /// The core refused the configuration or the sample rate.
    #[error("{context}: {source}")]
    Core {
        /// Where (file or option).
        context: String,
        /// The core's error.
        source: cma_core::Error,
    },
    /// Anything else, with a readable message.
    #[error("{0}")]
    Other(String),
}

impl SimError {
    /// Exit status for this error: 2 for usage errors (as clap's), 1 for the rest.
    #[must_use]
    pub fn exit_code(&self) -> u8 {
        match self {
            SimError::Cli(e) => u8::try_from(e.exit_code()).unwrap_or(2),
            SimError::Usage(_) => 2,
            _ => 1,
        }
    }

    /// Wraps an I/O error with its path.
    pub fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        SimError::Io {
            path: path.into(),
            op: None,
            source,
        }
    }

    /// An input that could not be opened or read: `PATH: cannot read: …`.
    pub fn reading(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::doing("read", path, source)
    }

    /// An output that could not be created or written: `PATH: cannot write: …`.
    pub fn writing(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::doing("write", path, source)
    }

    /// An I/O error of operation `op` (`create the folder`) on `path`: `PATH: cannot OP: …`.
    pub fn doing(op: &'static str, path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        SimError::Io {
            path: path.into(),
            op: Some(op),
            source,
        }
    }
}

/// Result of host-sim operations.
pub type Result<T> = std::result::Result<T, SimError>;
