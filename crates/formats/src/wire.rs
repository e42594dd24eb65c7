//! The serial wire format: one ASCII line per estimate, shared by the firmware (encoder) and the host
//! tools (decoder).
//!
//! `no_std`, no allocation, no float formatting (every field is an integer) and no panics on any
//! input. Version 1 of the format, byte by byte:
//!
//! ```text
//! $CMA,<ver>,<seq>,<rate_hz>,<t>,<az>,<raw>,<conf>,<flags>,<ovr>,<drop>*<crc>\r\n
//! ```
//!
//! | bytes        | meaning                                                                              |
//! |--------------|--------------------------------------------------------------------------------------|
//! | `$`          | start of line (0x24); a receiver resynchronises on it                                |
//! | `CMA`        | tag (0x43 0x4D 0x41)                                                                 |
//! | `,`          | field separator (0x2C), between every two fields below                               |
//! | `ver`        | format version, decimal, `1` ([`VERSION`])                                           |
//! | `seq`        | sequence number, `u32` decimal, +1 per line sent, wraps 4294967295 → 0               |
//! | `rate_hz`    | input sample rate in Hz, `u32` decimal                                               |
//! | `t`          | [`Estimate::centre_sample`]: centre of the analysis frame in input samples, `u64`    |
//! | `az`         | [`Estimate::azimuth_deg`] in tenths of a degree, rounded, `-1799..=1800`             |
//! | `raw`        | [`Estimate::azimuth_raw_deg`] likewise                                               |
//! | `conf`       | [`Estimate::confidence`] in per mille, rounded, `0..=1000`                           |
//! | `flags`      | [`Estimate::flags`](crate::estimate::Flags), exactly 2 upper-case hex digits                   |
//! | `ovr`        | DMA overrun count of the board since boot, `u32` decimal                             |
//! | `drop`       | lines the board dropped because the UART was busy (backpressure), `u32` decimal      |
//! | `*`          | end of the checksummed part (0x2A)                                                   |
//! | `crc`        | CRC-16/CCITT-FALSE of every byte strictly between `$` and `*`, 4 upper-case hex digits |
//! | `\r\n`       | end of line (0x0D 0x0A)                                                              |
//!
//! Numbers are canonical: decimal digits only, no `+`, no leading zeros (`0` itself is one digit),
//! `-` only before a non-zero value. A decoder accepts nothing else, so a line that decodes is exactly
//! the line [`encode`] writes for the decoded [`Frame`]: corruption cannot turn one valid spelling into
//! another of the same frame. CRC-16/CCITT-FALSE is poly 0x1021, init 0xFFFF, no reflection, xorout 0
//! (check value: `"123456789"` → `0x29B1`); it detects every single corrupted byte and every burst of up
//! to 16 bits.
//!
//! The longest line is [`MAX_LINE`] = 98 bytes (all numbers at their widest). Example:
//!
//! ```text
//! $CMA,1,42,48000,123456,-1234,905,873,10,0,0*XXXX\r\n
//! ```
//!
//! where `XXXX` is the CRC of `CMA,1,42,…,0,0`. At 115200 baud (11520 bytes/s) a line takes at most
//! 8.5 ms; at 48 kHz the core emits one estimate per 1024 input samples (21.3 ms), so the link has
//! room to spare.
//!
//! On the receiving side [`LineAssembler`] cuts an arbitrary byte stream into candidate lines and
//! [`decode`] checks and parses each one.
//!
//! A second line type, the *calibration line* (`$CAL,…`, its own version), carries the blind
//! self-calibration's state; the board sends one at start and then every
//! [`CALIBRATION_PERIOD_S`] seconds next to the frame lines. Its format is described in
//! [`encode_calibration`]'s module (`wire/calibration.rs`) and in `docs/wire-format.md`;
//! [`decode_line`] decodes either kind, and a [`LineAssembler`] of [`MAX_ANY_LINE`] bytes holds
//! both. [`decode`] rejects a calibration line with [`DecodeError::CalibrationLine`].
//!
//! A third line type, the *track line* (`$TRK,…`, its own version), carries the active
//! multi-talker tracks of a frame ([`encode_tracks`], `wire/tracks.rs`, `docs/wire-format.md`);
//! the frame and calibration decoders reject it with [`DecodeError::TracksLine`].
//!
//! A fourth line type, the *background line* (`$BGF,…`, its own version), carries the stationary
//! background per band — direction, directivity, level and evidence of the room's steady sources
//! ([`encode_background`], `wire/background.rs`, `docs/wire-format.md`); the board sends one every
//! [`CALIBRATION_PERIOD_S`] seconds, and the other decoders reject it with
//! [`DecodeError::BackgroundLine`]. A decoder older than a line type rejects it as
//! [`DecodeError::BadPrefix`] (an unknown line) and goes on with the next line.

use crate::estimate::{Estimate, Flags};
use core::fmt;

mod background;
mod calibration;
mod tracks;
pub use background::{
    decode_background, encode_background, BackgroundLine, WireBackgroundBand, BACKGROUND_FIELDS,
    BACKGROUND_VERSION, LEVEL_MAX_TENTHS, LEVEL_MIN_TENTHS, MAX_BGF_LINE,
};
pub use calibration::{
    decode_calibration, decode_line, encode_calibration, part_to_wire, peaks_to_wire,
    shift_to_wire, CalibrationBand, CalibrationLine, CalibrationSchedule, Line, BAND_FIELDS,
    CALIBRATION_FIELDS, CALIBRATION_FIELDS_V1, CALIBRATION_PERIOD_S, CALIBRATION_VERSION,
    CALIBRATION_VERSION_1, MAX_ANY_LINE, MAX_CAL_LINE, PART_MAX, PART_SCALE, SHIFT_MAX,
};
pub use tracks::{
    decode_tracks, encode_tracks, TracksLine, WireTrack, MAX_TRK_LINE, TRACKS_VERSION,
};

/// Format version written by [`encode`] and the only one [`decode`] accepts.
pub const VERSION: u32 = 1;

/// Number of comma-separated fields after the `CMA` tag.
pub const FIELDS: usize = 10;

/// Smallest azimuth on the wire, tenths of a degree (−179.9°).
pub const AZIMUTH_MIN_TENTHS: i16 = -1799;
/// Largest azimuth on the wire, tenths of a degree (180.0°).
pub const AZIMUTH_MAX_TENTHS: i16 = 1800;
/// Largest confidence on the wire, per mille.
pub const CONFIDENCE_MAX_PERMILLE: u16 = 1000;

/// Length of the longest possible line in bytes, `$` to `\n` inclusive.
pub const MAX_LINE: usize = 1 // $
    + 4 // CMA,
    + 2 // 1,
    + 10 + 1 // seq
    + 10 + 1 // rate
    + 20 + 1 // t
    + 5 + 1 // az
    + 5 + 1 // raw
    + 4 + 1 // conf
    + 2 + 1 // flags
    + 10 + 1 // ovr
    + 10 // drop
    + 1 + 4 // *crc
    + 2; // \r\n

/// One estimate as it travels on the wire: integers only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Frame {
    /// Sequence number, +1 per line sent (wrapping); the receiver counts gaps as lost lines.
    pub seq: u32,
    /// Input sample rate, Hz.
    pub rate_hz: u32,
    /// Centre of the analysis frame in input samples ([`Estimate::centre_sample`]).
    pub centre_sample: u64,
    /// Azimuth in tenths of a degree, [`AZIMUTH_MIN_TENTHS`]`..=`[`AZIMUTH_MAX_TENTHS`].
    pub azimuth_tenths: i16,
    /// Single-frame azimuth in tenths of a degree, same range.
    pub raw_tenths: i16,
    /// Confidence in per mille, `0..=`[`CONFIDENCE_MAX_PERMILLE`].
    pub confidence_permille: u16,
    /// [`Flags`] bits of the estimate.
    pub flags: u8,
    /// DMA overrun count of the board.
    pub overruns: u32,
    /// Lines dropped by the board because the UART was busy.
    pub dropped: u32,
}

impl Frame {
    /// Converts an estimate: azimuths rounded to 0.1° and wrapped into (−180°, 180°], confidence
    /// rounded to 1 ‰ and clamped to 0..=1000; NaN becomes 0 and ±∞ azimuths become 0 (never panics).
    #[must_use]
    pub fn from_estimate(
        e: &Estimate,
        seq: u32,
        rate_hz: u32,
        overruns: u32,
        dropped: u32,
    ) -> Frame {
        Frame {
            seq,
            rate_hz,
            centre_sample: e.centre_sample,
            azimuth_tenths: azimuth_to_tenths(e.azimuth_deg),
            raw_tenths: azimuth_to_tenths(e.azimuth_raw_deg),
            confidence_permille: confidence_to_permille(e.confidence),
            flags: e.flags.0,
            overruns,
            dropped,
        }
    }

    /// Azimuth in degrees.
    #[must_use]
    pub fn azimuth_deg(&self) -> f32 {
        f32::from(self.azimuth_tenths) / 10.0
    }

    /// Single-frame azimuth in degrees.
    #[must_use]
    pub fn raw_deg(&self) -> f32 {
        f32::from(self.raw_tenths) / 10.0
    }

    /// Confidence in 0..=1.
    #[must_use]
    pub fn confidence(&self) -> f32 {
        f32::from(self.confidence_permille) / 1000.0
    }

    /// The estimate's flags.
    #[must_use]
    pub fn flags(&self) -> Flags {
        Flags(self.flags)
    }

    /// Time of the frame centre in seconds, `None` if the sample rate is 0.
    #[must_use]
    pub fn time_s(&self) -> Option<f64> {
        (self.rate_hz != 0).then(|| self.centre_sample as f64 / f64::from(self.rate_hz))
    }

    /// The frame with azimuths wrapped into range and the confidence clamped: what [`encode`] writes.
    #[must_use]
    pub fn normalized(&self) -> Frame {
        Frame {
            azimuth_tenths: wrap_tenths(i32::from(self.azimuth_tenths)),
            raw_tenths: wrap_tenths(i32::from(self.raw_tenths)),
            confidence_permille: self.confidence_permille.min(CONFIDENCE_MAX_PERMILLE),
            ..*self
        }
    }
}

/// Degrees to wire tenths: rounded, wrapped into `-1799..=1800`; non-finite input gives 0.
#[must_use]
pub fn azimuth_to_tenths(deg: f32) -> i16 {
    if !deg.is_finite() {
        return 0;
    }
    // Reduce first so the ×10 keeps its precision; the result lies in (−3600, 3600).
    let tenths = libm::roundf(libm::fmodf(deg, 360.0) * 10.0) as i32;
    wrap_tenths(tenths)
}

/// Confidence in 0..=1 to wire per mille: rounded, clamped to `0..=1000`; NaN gives 0.
#[must_use]
pub fn confidence_to_permille(confidence: f32) -> u16 {
    if confidence.is_nan() {
        return 0;
    }
    let p = libm::roundf(confidence * 1000.0);
    if p <= 0.0 {
        0
    } else if p >= f32::from(CONFIDENCE_MAX_PERMILLE) {
        CONFIDENCE_MAX_PERMILLE
    } else {
        p as u16
    }
}

fn wrap_tenths(tenths: i32) -> i16 {
    let t = tenths.rem_euclid(3600);
    (if t > i32::from(AZIMUTH_MAX_TENTHS) {
        t - 3600
    } else {
        t
    }) as i16
}

/// CRC-16/CCITT-FALSE: poly 0x1021, init 0xFFFF, no reflection, xorout 0.
#[must_use]
pub const fn crc16(bytes: &[u8]) -> u16 {
    let mut crc: u16 = 0xFFFF;
    let mut i = 0;
    while i < bytes.len() {
        crc ^= (bytes[i] as u16) << 8;
        let mut bit = 0;
        while bit < 8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
            bit += 1;
        }
        i += 1;
    }
    crc
}

/// Writes a line into a [`heapless::Vec`] (seen as a [`heapless::VecView`], so one copy of the code
/// serves every capacity); a byte past its capacity is dropped instead of panicking (cannot happen:
/// each encoder checks at compile time that its buffer holds its longest line, and the tests check
/// the longest lines).
struct Writer<'a> {
    line: &'a mut heapless::VecView<u8>,
}

impl<'a> Writer<'a> {
    /// A writer of a new line in `line` (emptied first).
    fn new(line: &'a mut heapless::VecView<u8>) -> Self {
        line.clear();
        Self { line }
    }

    fn byte(&mut self, b: u8) {
        let _ = self.line.push(b);
    }

    fn bytes(&mut self, bs: &[u8]) {
        for &b in bs {
            self.byte(b);
        }
    }

    // Not inlined: called once per field, it would otherwise be copied into every field of the
    // calibration line's unrolled loops (≈ 4 KB of the firmware's flash).
    #[inline(never)]
    fn unsigned(&mut self, mut v: u64) {
        let mut digits = [0u8; 20];
        let mut n = 0;
        loop {
            digits[n] = b'0' + (v % 10) as u8;
            n += 1;
            v /= 10;
            if v == 0 || n == digits.len() {
                break;
            }
        }
        while n > 0 {
            n -= 1;
            self.byte(digits[n]);
        }
    }

    /// `,` and `v` as a canonical signed decimal. Not inlined: one call per field keeps a line's
    /// encoder small (the background line's).
    #[inline(never)]
    fn field(&mut self, v: i64) {
        self.byte(b',');
        if v < 0 {
            self.byte(b'-');
        }
        self.unsigned(v.unsigned_abs());
    }

    fn signed(&mut self, v: i16) {
        if v < 0 {
            self.byte(b'-');
        }
        self.unsigned(u64::from(v.unsigned_abs()));
    }

    /// Ends the line: `*`, the CRC of everything after the `$` at the start, `\r\n`.
    fn finish(mut self) {
        let crc = crc16(self.line.get(1..).unwrap_or(&[]));
        self.byte(b'*');
        self.hex(crc, 4);
        self.bytes(b"\r\n");
    }

    fn hex(&mut self, v: u16, digits: u32) {
        const HEX: &[u8; 16] = b"0123456789ABCDEF";
        let mut shift = digits * 4;
        while shift > 0 {
            shift -= 4;
            self.byte(HEX[usize::from((v >> shift) & 0xF)]);
        }
    }
}

/// Writes `frame` as one line (with `\r\n`) into `out`, which it empties first; `out` holds at
/// least [`MAX_LINE`] bytes (checked at compile time). Out-of-range fields are normalised first
/// ([`Frame::normalized`]), so every line written decodes.
pub fn encode<const N: usize>(frame: &Frame, out: &mut heapless::Vec<u8, N>) {
    const { assert!(N >= MAX_LINE, "the buffer must hold the longest line") };
    let f = frame.normalized();
    let mut w = Writer::new(out.as_mut_view());
    w.byte(b'$');
    w.bytes(b"CMA,");
    w.unsigned(u64::from(VERSION));
    w.byte(b',');
    w.unsigned(u64::from(f.seq));
    w.byte(b',');
    w.unsigned(u64::from(f.rate_hz));
    w.byte(b',');
    w.unsigned(f.centre_sample);
    w.byte(b',');
    w.signed(f.azimuth_tenths);
    w.byte(b',');
    w.signed(f.raw_tenths);
    w.byte(b',');
    w.unsigned(u64::from(f.confidence_permille));
    w.byte(b',');
    w.hex(u16::from(f.flags), 2);
    w.byte(b',');
    w.unsigned(u64::from(f.overruns));
    w.byte(b',');
    w.unsigned(u64::from(f.dropped));
    w.finish();
}

/// A field of the line, for error messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Field {
    /// `ver`.
    Version,
    /// `seq`.
    Seq,
    /// `rate_hz`.
    Rate,
    /// `t`.
    CentreSample,
    /// `az`.
    Azimuth,
    /// `raw`.
    RawAzimuth,
    /// `conf`.
    Confidence,
    /// `flags`.
    Flags,
    /// `ovr`.
    Overruns,
    /// `drop`.
    Dropped,
    /// The 4 hex digits after `*`.
    Checksum,
    /// `held` of a calibration line.
    Held,
    /// `n` (background peaks) of a calibration line's band.
    Peaks {
        /// Band, 0 = lowest.
        band: u8,
    },
    /// `a` (omni part) of a calibration line's band and cardioid.
    OmniPart {
        /// Band, 0 = lowest.
        band: u8,
        /// Cardioid, 0 = the one looking at 0°.
        cardioid: u8,
    },
    /// `b` (dipole part) of a calibration line's band and cardioid.
    DipolePart {
        /// Band, 0 = lowest.
        band: u8,
        /// Cardioid, 0 = the one looking at 0°.
        cardioid: u8,
    },
    /// `sx` (the talker's shift, x) of a calibration line.
    ShiftX,
    /// `sy` (the talker's shift, y) of a calibration line.
    ShiftY,
    /// `n` (number of tracks) of a track line.
    TrackCount,
    /// `id` of a track line's track.
    TrackId {
        /// Track, 0 = first in the line.
        track: u8,
    },
    /// `az` of a track line's track.
    TrackAzimuth {
        /// Track, 0 = first in the line.
        track: u8,
    },
    /// `conf` of a track line's track.
    TrackConfidence {
        /// Track, 0 = first in the line.
        track: u8,
    },
    /// `n` (background frames) of a background line's band.
    BackgroundFrames {
        /// Band, 0 = lowest.
        band: u8,
    },
    /// `az` (direction) of a background line's band.
    BackgroundDirection {
        /// Band, 0 = lowest.
        band: u8,
    },
    /// `dir` (directivity) of a background line's band.
    BackgroundDirectivity {
        /// Band, 0 = lowest.
        band: u8,
    },
    /// `db` (level) of a background line's band.
    BackgroundLevel {
        /// Band, 0 = lowest.
        band: u8,
    },
}

impl Field {
    /// The field's name as in the format description.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Field::Version => "ver",
            Field::Seq => "seq",
            Field::Rate => "rate_hz",
            Field::CentreSample => "t",
            Field::Azimuth => "az",
            Field::RawAzimuth => "raw",
            Field::Confidence => "conf",
            Field::Flags => "flags",
            Field::Overruns => "ovr",
            Field::Dropped => "drop",
            Field::Checksum => "crc",
            Field::Held => "held",
            Field::Peaks { .. } => "n",
            Field::OmniPart { .. } => "a",
            Field::DipolePart { .. } => "b",
            Field::ShiftX => "sx",
            Field::ShiftY => "sy",
            Field::TrackCount => "n",
            Field::TrackId { .. } => "id",
            Field::TrackAzimuth { .. } => "az",
            Field::TrackConfidence { .. } => "conf",
            Field::BackgroundFrames { .. } => "n",
            Field::BackgroundDirection { .. } => "az",
            Field::BackgroundDirectivity { .. } => "dir",
            Field::BackgroundLevel { .. } => "db",
        }
    }
}

impl fmt::Display for Field {
    /// The name, with band and cardioid for the calibration line's per-band fields
    /// (`` `a` of band 2, cardioid 1 ``).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "`{}`", self.name())?;
        match *self {
            Field::Peaks { band }
            | Field::BackgroundFrames { band }
            | Field::BackgroundDirection { band }
            | Field::BackgroundDirectivity { band }
            | Field::BackgroundLevel { band } => write!(f, " of band {band}"),
            Field::OmniPart { band, cardioid } | Field::DipolePart { band, cardioid } => {
                write!(f, " of band {band}, cardioid {cardioid}")
            }
            Field::TrackId { track }
            | Field::TrackAzimuth { track }
            | Field::TrackConfidence { track } => write!(f, " of track {track}"),
            _ => Ok(()),
        }
    }
}

/// Why a line was rejected by [`decode`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum DecodeError {
    /// The line is longer than any valid line.
    TooLong {
        /// [`MAX_LINE`].
        max: usize,
        /// Length of the line given.
        got: usize,
    },
    /// The line does not start with `$`.
    MissingStart,
    /// The line starts with none of `$CMA,`, `$CAL,`, `$TRK,` and `$BGF,`.
    BadPrefix,
    /// [`decode`] was given a calibration line (`$CAL,`, see [`decode_calibration`]).
    CalibrationLine,
    /// [`decode_calibration`] or [`decode_tracks`] was given a frame line (`$CMA,`, see [`decode`]).
    FrameLine,
    /// [`decode`] or [`decode_calibration`] was given a track line (`$TRK,`, see [`decode_tracks`]).
    TracksLine,
    /// [`decode`], [`decode_calibration`] or [`decode_tracks`] was given a background line
    /// (`$BGF,`, see [`decode_background`]).
    BackgroundLine,
    /// No `*` before the checksum.
    MissingChecksum,
    /// The checksum computed over the line differs from the one transmitted.
    Checksum {
        /// CRC of the bytes between `$` and `*` as received.
        expected: u16,
        /// CRC written in the line.
        got: u16,
    },
    /// Wrong number of fields after the tag.
    FieldCount {
        /// [`FIELDS`].
        expected: usize,
        /// Fields found.
        got: usize,
    },
    /// A version this decoder does not know.
    UnsupportedVersion {
        /// [`VERSION`].
        expected: u32,
        /// Version in the line.
        got: u32,
    },
    /// A field is not a canonical number of its type (or, for the checksum, 4 upper-case hex digits).
    BadNumber {
        /// Which field.
        field: Field,
    },
    /// A field is a number outside its range (azimuth, confidence).
    OutOfRange {
        /// Which field.
        field: Field,
    },
    /// Bytes after the checksum other than `\r\n`.
    TrailingBytes,
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            DecodeError::TooLong { max, got } => {
                write!(f, "line too long: {got} bytes, at most {max}")
            }
            DecodeError::MissingStart => f.write_str("line does not start with `$`"),
            DecodeError::BadPrefix => f.write_str(
                "unknown line: starts with none of `$CMA,` (frame), `$CAL,` (calibration), `$TRK,` (tracks) and `$BGF,` (background)",
            ),
            DecodeError::BackgroundLine => {
                f.write_str("not a frame, calibration or track line (a `$BGF` background line)")
            }
            DecodeError::TracksLine => {
                f.write_str("not a frame or calibration line (a `$TRK` multi-talker track line)")
            }
            DecodeError::CalibrationLine => {
                f.write_str("not a frame line (a `$CAL` self-calibration line)")
            }
            DecodeError::FrameLine => f.write_str("not a calibration line (a `$CMA` frame line)"),
            DecodeError::MissingChecksum => f.write_str("no `*` checksum"),
            DecodeError::Checksum { expected, got } => {
                write!(
                    f,
                    "checksum mismatch: computed {expected:04X}, line says {got:04X}"
                )
            }
            DecodeError::FieldCount { expected, got } => {
                write!(f, "expected {expected} fields, got {got}")
            }
            DecodeError::UnsupportedVersion { expected, got } => {
                write!(f, "unsupported version {got}, expected {expected}")
            }
            DecodeError::BadNumber { field } => write!(f, "field {field} is malformed"),
            DecodeError::OutOfRange { field } => write!(f, "field {field} is out of range"),
            DecodeError::TrailingBytes => f.write_str("bytes after the checksum"),
        }
    }
}

impl core::error::Error for DecodeError {}

/// Canonical unsigned decimal: 1..=20 digits, no leading zero unless the value is 0, no overflow.
fn parse_unsigned(s: &[u8], max: u64) -> Option<u64> {
    if s.is_empty() || (s.len() > 1 && s[0] == b'0') {
        return None;
    }
    let mut v: u64 = 0;
    for &b in s {
        if !b.is_ascii_digit() {
            return None;
        }
        v = v.checked_mul(10)?.checked_add(u64::from(b - b'0'))?;
    }
    (v <= max).then_some(v)
}

fn parse_u32(s: &[u8], field: Field) -> Result<u32, DecodeError> {
    parse_unsigned(s, u64::from(u32::MAX))
        .map(|v| v as u32)
        .ok_or(DecodeError::BadNumber { field })
}

/// Canonical signed decimal azimuth in range.
fn parse_tenths(s: &[u8], field: Field) -> Result<i16, DecodeError> {
    parse_signed(s, AZIMUTH_MIN_TENTHS, AZIMUTH_MAX_TENTHS, field)
}

/// Canonical signed decimal (`-` only before a non-zero magnitude, at most `u16::MAX`) within
/// `min..=max`.
fn parse_signed(s: &[u8], min: i16, max: i16, field: Field) -> Result<i16, DecodeError> {
    let (neg, digits) = match s.split_first() {
        Some((b'-', rest)) => (true, rest),
        _ => (false, s),
    };
    let mag =
        parse_unsigned(digits, u64::from(u16::MAX)).ok_or(DecodeError::BadNumber { field })?;
    if neg && mag == 0 {
        return Err(DecodeError::BadNumber { field });
    }
    let v = if neg { -(mag as i64) } else { mag as i64 };
    if v < i64::from(min) || v > i64::from(max) {
        return Err(DecodeError::OutOfRange { field });
    }
    Ok(v as i16)
}

/// Exactly `N` upper-case hex digits.
fn parse_hex(s: &[u8], n: usize, field: Field) -> Result<u16, DecodeError> {
    if s.len() != n {
        return Err(DecodeError::BadNumber { field });
    }
    let mut v: u16 = 0;
    for &b in s {
        let d = match b {
            b'0'..=b'9' => b - b'0',
            b'A'..=b'F' => b - b'A' + 10,
            _ => return Err(DecodeError::BadNumber { field }),
        };
        v = (v << 4) | u16::from(d);
    }
    Ok(v)
}

/// Tag of a frame line, between `$` and the first field.
pub const FRAME_TAG: &[u8] = b"CMA,";
/// Tag of a calibration line ([`decode_calibration`]).
pub const CALIBRATION_TAG: &[u8] = b"CAL,";
/// Tag of a track line ([`decode_tracks`]).
pub const TRACKS_TAG: &[u8] = b"TRK,";
/// Tag of a background line ([`decode_background`]).
pub const BACKGROUND_TAG: &[u8] = b"BGF,";

/// The checked part of a line: after `$`, `tag` and the checksum are verified, the payload
/// `TAG,f1,…,fn` (without `$` and `*crc`). `other_tag` and `other` name the other line type.
///
/// Checks in this order: `$`, tag, length (at most `max` bytes with the terminator), `*` and the 4
/// hex checksum digits, nothing after them, checksum.
fn checked_payload<'a>(
    line: &'a [u8],
    tag: &[u8],
    max: usize,
    other_tag: &[u8],
    other: DecodeError,
) -> Result<&'a [u8], DecodeError> {
    let body = match line.split_first() {
        Some((b'$', body)) => body,
        _ => return Err(DecodeError::MissingStart),
    };
    if !body.starts_with(tag) {
        return Err(if body.starts_with(other_tag) {
            other
        } else if body.starts_with(TRACKS_TAG) {
            DecodeError::TracksLine
        } else if body.starts_with(BACKGROUND_TAG) {
            DecodeError::BackgroundLine
        } else {
            DecodeError::BadPrefix
        });
    }
    if line.len() > max {
        return Err(DecodeError::TooLong {
            max,
            got: line.len(),
        });
    }
    let line = line.strip_suffix(b"\n").unwrap_or(line);
    let line = line.strip_suffix(b"\r").unwrap_or(line);
    let body = line.get(1..).unwrap_or(&[]);
    let star = body
        .iter()
        .position(|&b| b == b'*')
        .ok_or(DecodeError::MissingChecksum)?;
    let (payload, rest) = body.split_at(star);
    let crc_text = rest.get(1..).unwrap_or(&[]);
    let crc_digits = crc_text.get(..4).unwrap_or(crc_text);
    let got = parse_hex(crc_digits, 4, Field::Checksum)?;
    if crc_text.len() > 4 {
        return Err(DecodeError::TrailingBytes);
    }
    let expected = crc16(payload);
    if expected != got {
        return Err(DecodeError::Checksum { expected, got });
    }
    Ok(payload)
}

/// Splits the payload's fields after the tag into `fields`; returns how many there were (also when
/// more than `fields` holds).
fn split_fields<'a>(payload: &'a [u8], fields: &mut [&'a [u8]]) -> usize {
    let mut n = 0;
    for (i, f) in payload.split(|&b| b == b',').skip(1).enumerate() {
        if let Some(slot) = fields.get_mut(i) {
            *slot = f;
        }
        n += 1;
    }
    n
}

/// Checks and parses one frame line, with or without its `\r\n` (a lone `\r` or `\n` is tolerated
/// too).
///
/// Checks in this order: `$`, `CMA,` tag (a `$CAL,` calibration line gives
/// [`DecodeError::CalibrationLine`]), length, `*` and the 4 hex checksum digits, nothing after
/// them, checksum, field count, version, then each field (canonical number, range).
pub fn decode(line: &[u8]) -> Result<Frame, DecodeError> {
    let payload = checked_payload(
        line,
        FRAME_TAG,
        MAX_LINE,
        CALIBRATION_TAG,
        DecodeError::CalibrationLine,
    )?;

    let mut fields: [&[u8]; FIELDS] = [&[]; FIELDS];
    let n = split_fields(payload, &mut fields);
    if n != FIELDS {
        return Err(DecodeError::FieldCount {
            expected: FIELDS,
            got: n,
        });
    }
    let [ver, seq, rate, t, az, raw, conf, flags, ovr, drop] = fields;
    let version = parse_u32(ver, Field::Version)?;
    if version != VERSION {
        return Err(DecodeError::UnsupportedVersion {
            expected: VERSION,
            got: version,
        });
    }
    let confidence_permille =
        parse_unsigned(conf, u64::from(u16::MAX)).ok_or(DecodeError::BadNumber {
            field: Field::Confidence,
        })?;
    if confidence_permille > u64::from(CONFIDENCE_MAX_PERMILLE) {
        return Err(DecodeError::OutOfRange {
            field: Field::Confidence,
        });
    }
    Ok(Frame {
        seq: parse_u32(seq, Field::Seq)?,
        rate_hz: parse_u32(rate, Field::Rate)?,
        centre_sample: parse_unsigned(t, u64::MAX).ok_or(DecodeError::BadNumber {
            field: Field::CentreSample,
        })?,
        azimuth_tenths: parse_tenths(az, Field::Azimuth)?,
        raw_tenths: parse_tenths(raw, Field::RawAzimuth)?,
        confidence_permille: confidence_permille as u16,
        flags: parse_hex(flags, 2, Field::Flags)? as u8,
        overruns: parse_u32(ovr, Field::Overruns)?,
        dropped: parse_u32(drop, Field::Dropped)?,
    })
}

/// Counters of a [`LineAssembler`] (all wrap at `u32::MAX`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AssemblerStats {
    /// Candidate lines yielded (`$` … `\n`).
    pub lines: u32,
    /// Bytes outside any line (before the first `$`, or after a `\n` and before the next `$`).
    pub garbage_bytes: u32,
    /// Partial lines abandoned because a `$` came before their `\n`.
    pub interrupted: u32,
    /// Lines discarded because they did not fit the buffer.
    pub overlong: u32,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AssemblerState {
    /// Waiting for `$`.
    Hunting,
    /// Collecting a line.
    InLine,
    /// The line overflowed: skipping to the next `$` or `\n`.
    Skipping,
}

/// Cuts an arbitrary byte stream into candidate lines for [`decode`].
///
/// A candidate line starts at `$` and ends before the next `\n` (a `\r` before the `\n` is
/// removed). A `$` always starts a new line, abandoning a partial one (a lost `\n`); bytes outside a
/// line are counted and dropped; a line longer than `N` bytes is counted and skipped up to the next
/// `$` or `\n`. `N` = [`MAX_LINE`] holds every valid line.
#[derive(Debug, Clone)]
pub struct LineAssembler<const N: usize> {
    buf: heapless::Vec<u8, N>,
    state: AssemblerState,
    stats: AssemblerStats,
}

impl<const N: usize> Default for LineAssembler<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> LineAssembler<N> {
    /// An empty assembler, hunting for `$`.
    #[must_use]
    pub const fn new() -> Self {
        const { assert!(N > 0, "LineAssembler needs room for at least one byte") };
        LineAssembler {
            buf: heapless::Vec::new(),
            state: AssemblerState::Hunting,
            stats: AssemblerStats {
                lines: 0,
                garbage_bytes: 0,
                interrupted: 0,
                overlong: 0,
            },
        }
    }

    /// Feeds one byte; returns a complete candidate line (without `\r\n`) when `byte` ends one.
    pub fn push(&mut self, byte: u8) -> Option<&[u8]> {
        match (byte, self.state) {
            (b'$', state) => {
                if state == AssemblerState::InLine {
                    self.stats.interrupted = self.stats.interrupted.wrapping_add(1);
                }
                self.buf.clear();
                // Never full: `N` > 0 and the buffer was just emptied.
                let _ = self.buf.push(byte);
                self.state = AssemblerState::InLine;
                None
            }
            (b'\n', AssemblerState::InLine) => {
                self.state = AssemblerState::Hunting;
                self.stats.lines = self.stats.lines.wrapping_add(1);
                let line = self.buf.as_slice();
                Some(line.strip_suffix(b"\r").unwrap_or(line))
            }
            (b'\n', AssemblerState::Skipping) => {
                self.state = AssemblerState::Hunting;
                None
            }
            (_, AssemblerState::InLine) => {
                if self.buf.push(byte).is_err() {
                    self.stats.overlong = self.stats.overlong.wrapping_add(1);
                    self.state = AssemblerState::Skipping;
                }
                None
            }
            (_, AssemblerState::Skipping) => None,
            (_, AssemblerState::Hunting) => {
                self.stats.garbage_bytes = self.stats.garbage_bytes.wrapping_add(1);
                None
            }
        }
    }

    /// Feeds a chunk of any length, calling `on_line` with each complete candidate line.
    pub fn push_chunk(&mut self, chunk: &[u8], mut on_line: impl FnMut(&[u8])) {
        for &b in chunk {
            if let Some(line) = self.push(b) {
                on_line(line);
            }
        }
    }

    /// Drops a partial line (counted as interrupted) and hunts for `$` again, e.g. after the port
    /// was reopened.
    pub fn reset(&mut self) {
        if self.state == AssemblerState::InLine {
            self.stats.interrupted = self.stats.interrupted.wrapping_add(1);
        }
        self.buf.clear();
        self.state = AssemblerState::Hunting;
    }

    /// Bytes of the partial line collected so far.
    #[must_use]
    pub fn pending(&self) -> usize {
        if self.state == AssemblerState::InLine {
            self.buf.len()
        } else {
            0
        }
    }

    /// The counters.
    #[must_use]
    pub fn stats(&self) -> AssemblerStats {
        self.stats
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn line(f: &Frame) -> Vec<u8> {
        let mut buf = heapless::Vec::<u8, MAX_LINE>::new();
        encode(f, &mut buf);
        buf[..].to_vec()
    }

    /// A line with a correct checksum around an arbitrary payload (for error tests).
    fn with_crc(payload: &str) -> Vec<u8> {
        let mut v = Vec::from(&b"$"[..]);
        v.extend_from_slice(payload.as_bytes());
        v.extend_from_slice(std::format!("*{:04X}\r\n", crc16(payload.as_bytes())).as_bytes());
        v
    }

    fn sample() -> Frame {
        Frame {
            seq: 42,
            rate_hz: 48000,
            centre_sample: 123_456,
            azimuth_tenths: -1234,
            raw_tenths: 905,
            confidence_permille: 873,
            flags: 0x10,
            overruns: 0,
            dropped: 0,
        }
    }

    #[test]
    fn crc_check_value() {
        assert_eq!(crc16(b"123456789"), 0x29B1);
        assert_eq!(crc16(b""), 0xFFFF);
    }

    #[test]
    fn example_line() {
        let l = line(&sample());
        let crc = crc16(b"CMA,1,42,48000,123456,-1234,905,873,10,0,0");
        assert_eq!(
            l,
            std::format!("$CMA,1,42,48000,123456,-1234,905,873,10,0,0*{crc:04X}\r\n").as_bytes()
        );
    }

    #[test]
    fn round_trip_with_and_without_terminator() {
        let f = sample();
        let l = line(&f);
        assert_eq!(decode(&l), Ok(f));
        assert_eq!(decode(&l[..l.len() - 2]), Ok(f));
        assert_eq!(decode(&l[..l.len() - 1]), Ok(f));
    }

    #[test]
    fn widest_line_is_max_line() {
        let f = Frame {
            seq: u32::MAX,
            rate_hz: u32::MAX,
            centre_sample: u64::MAX,
            azimuth_tenths: -1799,
            raw_tenths: -1799,
            confidence_permille: 1000,
            flags: 0xFF,
            overruns: u32::MAX,
            dropped: u32::MAX,
        };
        let l = line(&f);
        assert_eq!(l.len(), MAX_LINE);
        assert_eq!(decode(&l), Ok(f));
        let zero = Frame::default();
        assert_eq!(decode(&line(&zero)), Ok(zero));
    }

    #[test]
    fn from_estimate_rounds_wraps_and_clamps() {
        let e = |az: f32, raw: f32, c: f32| Estimate {
            azimuth_deg: az,
            azimuth_raw_deg: raw,
            confidence: c,
            ..Estimate::default()
        };
        let f = Frame::from_estimate(&e(-180.0, 179.96, 0.8735), 1, 16000, 2, 3);
        assert_eq!(f.azimuth_tenths, 1800);
        assert_eq!(f.raw_tenths, 1800);
        assert_eq!(f.confidence_permille, 874);
        assert_eq!((f.seq, f.rate_hz, f.overruns, f.dropped), (1, 16000, 2, 3));
        let f = Frame::from_estimate(&e(f32::NAN, f32::INFINITY, f32::NAN), 0, 0, 0, 0);
        assert_eq!(
            (f.azimuth_tenths, f.raw_tenths, f.confidence_permille),
            (0, 0, 0)
        );
        let f = Frame::from_estimate(&e(359.99, -179.96, 7.0), 0, 0, 0, 0);
        assert_eq!(
            (f.azimuth_tenths, f.raw_tenths, f.confidence_permille),
            (0, 1800, 1000)
        );
        let f = Frame::from_estimate(&e(1e30, -1e30, -3.0), 0, 0, 0, 0);
        assert!((AZIMUTH_MIN_TENTHS..=AZIMUTH_MAX_TENTHS).contains(&f.azimuth_tenths));
        assert_eq!(f.confidence_permille, 0);
        let f = Frame::from_estimate(&e(-0.04, -179.94, f32::NEG_INFINITY), 0, 0, 0, 0);
        assert_eq!(
            (f.azimuth_tenths, f.raw_tenths, f.confidence_permille),
            (0, -1799, 0)
        );
    }

    #[test]
    fn encode_normalizes_out_of_range_fields() {
        let f = Frame {
            azimuth_tenths: -1800,
            raw_tenths: 3599,
            confidence_permille: 5000,
            ..sample()
        };
        let got = decode(&line(&f)).unwrap();
        assert_eq!(got.azimuth_tenths, 1800);
        assert_eq!(got.raw_tenths, -1);
        assert_eq!(got.confidence_permille, 1000);
    }

    #[test]
    fn every_error_kind() {
        use DecodeError::*;
        let good = line(&sample());
        let mut long = good.clone();
        long.resize(MAX_LINE + 1, b'0');
        assert_eq!(
            decode(&long),
            Err(TooLong {
                max: MAX_LINE,
                got: MAX_LINE + 1
            })
        );
        assert_eq!(decode(&good[1..]), Err(MissingStart));
        assert_eq!(decode(b""), Err(MissingStart));
        assert_eq!(decode(&with_crc("GPGGA,1,2")), Err(BadPrefix));
        assert_eq!(decode(b"$CMA,1,2,3"), Err(MissingChecksum));
        assert_eq!(
            decode(b"$CMA,1*12G4"),
            Err(BadNumber {
                field: Field::Checksum
            })
        );
        assert_eq!(
            decode(b"$CMA,1*12a4"),
            Err(BadNumber {
                field: Field::Checksum
            })
        );
        assert_eq!(
            decode(b"$CMA,1*123"),
            Err(BadNumber {
                field: Field::Checksum
            })
        );
        let crc = crc16(b"CMA,1");
        assert_eq!(
            decode(std::format!("$CMA,1*{crc:04X}x").as_bytes()),
            Err(TrailingBytes)
        );
        let mut bad = good.clone();
        bad[8] = b'3'; // seq 42 → 32
        let expected = crc16(&bad[1..bad.iter().position(|&b| b == b'*').unwrap()]);
        assert_eq!(
            decode(&bad),
            Err(Checksum {
                expected,
                got: crc16(b"CMA,1,42,48000,123456,-1234,905,873,10,0,0")
            })
        );
        assert_eq!(
            decode(&with_crc("CMA,1,42,48000,123456,-1234,905,873,10,0")),
            Err(FieldCount {
                expected: 10,
                got: 9
            })
        );
        assert_eq!(
            decode(&with_crc("CMA,1,42,48000,123456,-1234,905,873,10,0,0,0")),
            Err(FieldCount {
                expected: 10,
                got: 11
            })
        );
        assert_eq!(
            decode(&with_crc("CMA,2,42,48000,123456,-1234,905,873,10,0,0")),
            Err(UnsupportedVersion {
                expected: 1,
                got: 2
            })
        );
        let cases: &[(&str, Field)] = &[
            ("CMA,x,42,48000,1,0,0,0,00,0,0", Field::Version),
            ("CMA,1,042,48000,1,0,0,0,00,0,0", Field::Seq),
            ("CMA,1,4294967296,48000,1,0,0,0,00,0,0", Field::Seq),
            ("CMA,1,42,+48000,1,0,0,0,00,0,0", Field::Rate),
            (
                "CMA,1,42,48000,18446744073709551616,0,0,0,00,0,0",
                Field::CentreSample,
            ),
            ("CMA,1,42,48000,,0,0,0,00,0,0", Field::CentreSample),
            ("CMA,1,42,48000,1,-0,0,0,00,0,0", Field::Azimuth),
            ("CMA,1,42,48000,1,0,1.5,0,00,0,0", Field::RawAzimuth),
            ("CMA,1,42,48000,1,0,0,99999,00,0,0", Field::Confidence),
            ("CMA,1,42,48000,1,0,0,0,0a,0,0", Field::Flags),
            ("CMA,1,42,48000,1,0,0,0,000,0,0", Field::Flags),
            ("CMA,1,42,48000,1,0,0,0,00,-1,0", Field::Overruns),
            ("CMA,1,42,48000,1,0,0,0,00,0, 0", Field::Dropped),
        ];
        for &(payload, field) in cases {
            assert_eq!(
                decode(&with_crc(payload)),
                Err(BadNumber { field }),
                "{payload}"
            );
        }
        let ranges: &[(&str, Field)] = &[
            ("CMA,1,42,48000,1,-1800,0,0,00,0,0", Field::Azimuth),
            ("CMA,1,42,48000,1,0,1801,0,00,0,0", Field::RawAzimuth),
            ("CMA,1,42,48000,1,0,0,1001,00,0,0", Field::Confidence),
        ];
        for &(payload, field) in ranges {
            assert_eq!(
                decode(&with_crc(payload)),
                Err(OutOfRange { field }),
                "{payload}"
            );
        }
        // Every message renders.
        let msg = std::format!(
            "{}",
            Checksum {
                expected: 0x29B1,
                got: 1
            }
        );
        assert!(msg.contains("29B1"), "{msg}");
    }

    #[test]
    fn assembler_resyncs_after_garbage() {
        let a = line(&sample());
        let b = line(&Frame {
            seq: 43,
            ..sample()
        });
        let mut stream = Vec::new();
        stream.extend_from_slice(b"\x00\xFFnoise");
        stream.extend_from_slice(&a[..20]); // partial line, interrupted by the next `$`
        stream.extend_from_slice(&a);
        stream.extend_from_slice(b"junk\r\n");
        stream.extend_from_slice(&[b'$'; 1]);
        stream.extend_from_slice(&[b'x'; 300]); // over-long
        stream.extend_from_slice(b"\n");
        stream.extend_from_slice(&b);
        let mut asm = LineAssembler::<MAX_LINE>::new();
        let mut frames = Vec::new();
        for chunk in stream.chunks(7) {
            asm.push_chunk(chunk, |l| frames.push(decode(l)));
        }
        assert_eq!(
            frames,
            [
                Ok(sample()),
                Ok(Frame {
                    seq: 43,
                    ..sample()
                })
            ]
        );
        assert_eq!(
            asm.stats(),
            AssemblerStats {
                lines: 2,
                garbage_bytes: 7 + 6,
                interrupted: 1,
                overlong: 1,
            }
        );
        asm.push_chunk(&a[..10], |_| {});
        assert_eq!(asm.pending(), 10);
        asm.reset();
        assert_eq!(asm.stats().interrupted, 2);
        assert_eq!(asm.pending(), 0);
    }
}
