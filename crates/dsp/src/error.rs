//! Errors of the fallible core APIs. None of them can be caused by sample values: bad samples give
//! flagged, low-confidence estimates instead.

/// What went wrong when configuring the core.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// The input sample rate has no supported decimation factor.
    UnsupportedSampleRate {
        /// The rate that was given, in Hz.
        got: u32,
    },
    /// A configuration value is out of range; the string names the field.
    InvalidConfig(&'static str),
    /// A reference table's slices do not fit together.
    TableShape {
        /// Element count the table's dimensions call for.
        expected: usize,
        /// Element count that was given.
        got: usize,
    },
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::UnsupportedSampleRate { got } => write!(
                f,
                "unsupported sample rate {got} Hz (supported: 11025, 12000, 16000, 22050, 24000, 32000, 44100, 48000, 88200, 96000)"
            ),
            Error::InvalidConfig(what) => write!(f, "invalid configuration: {what}"),
            Error::TableShape { expected, got } => {
                write!(f, "reference table shape mismatch: expected {expected} entries, got {got}")
            }
        }
    }
}

impl core::error::Error for Error {}
