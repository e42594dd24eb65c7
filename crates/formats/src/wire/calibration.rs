//! The calibration line: the blind self-calibration's state ([`CapsuleEstimate`] and its
//! confidence) as one ASCII line, sent by the board next to its frame lines. Version 2, byte by
//! byte:
//!
//! ```text
//! $CAL,<ver>,<seq>,<t>,<conf>,<held>,<drop>,<band 0>,<band 1>,<band 2>,<band 3>,<sx>,<sy>*<crc>\r\n
//! <band k> = <n>,<a0>,<a1>,<a2>,<b0>,<b1>,<b2>
//! ```
//!
//! | bytes    | meaning                                                                               |
//! |----------|---------------------------------------------------------------------------------------|
//! | `$`      | start of line (0x24)                                                                  |
//! | `CAL`    | tag (0x43 0x41 0x4C)                                                                  |
//! | `,`      | field separator (0x2C), between every two fields (36 fields after the tag)            |
//! | `ver`    | version of the calibration line, `2` ([`CALIBRATION_VERSION`])                        |
//! | `seq`    | calibration lines sent, `u32` decimal, +1 per line, wraps; its own count, not the frames' |
//! | `t`      | board sample clock when the snapshot was taken: `centre_sample` of the last estimate before it (`0` at start), `u64` |
//! | `conf`   | `Locator::capsule_confidence` in per mille, rounded, `0..=1000` |
//! | `held`   | [`CapsuleEstimate::held`]: `1` the background was found not diffuse and the estimate is held, else `0` |
//! | `drop`   | calibration lines the board dropped because the UART was busy, `u32` decimal          |
//! | `n`      | per band ([`CAL_BANDS`] = 4, lowest first): [`BandModel::peaks`], rounded, `u32`      |
//! | `a0..a2` | per band: [`BandModel::omni_part`] of cardioids 0°, 120°, 240° in 1/10000, rounded, `0..=20000` |
//! | `b0..b2` | per band: [`BandModel::dipole_part`] likewise                                         |
//! | `sx`,`sy`| [`CapsuleEstimate::talker_shift`] in 1/10000, rounded, signed, `-5000..=5000`         |
//! | `*`      | end of the checksummed part (0x2A)                                                    |
//! | `crc`    | CRC-16/CCITT-FALSE of every byte strictly between `$` and `*`, 4 upper-case hex digits |
//! | `\r\n`   | end of line                                                                           |
//!
//! Numbers are canonical as in the frame line (no `+`, no leading zeros, `-` only before a non-zero
//! `sx` or `sy`), so a line that decodes is exactly what [`encode_calibration`] writes. The longest
//! line is [`MAX_CAL_LINE`] = 263 bytes; a typical one (peaks in the thousands, parts near 5000) is
//! about 180 bytes, 16 ms at 115200 baud.
//!
//! Version 1 (a board built before the talker's shift was saved) is the same line without `sx`
//! and `sy` (34 fields): [`decode_calibration`] still reads it, with a shift of 0.
//!
//! A decoder that knows only frame lines ([`decode`](super::decode)) rejects a calibration line with
//! [`DecodeError::CalibrationLine`]; a monitor built before this line existed assembles lines of at
//! most [`MAX_LINE`](super::MAX_LINE) bytes and counts a longer calibration line as one corrupt
//! (overlong) line, a shorter one as a line that does not start with `$CMA,`.

use super::{
    checked_payload, confidence_to_permille, parse_signed, parse_u32, parse_unsigned, split_fields,
    DecodeError, Field, Frame, Writer, CALIBRATION_TAG, CONFIDENCE_MAX_PERMILLE, FRAME_TAG,
    MAX_LINE,
};
use crate::capsule_calibration::{BandModel, CapsuleEstimate, CAL_BANDS, MAX_TALKER_SHIFT};
use crate::CARDIOIDS;

/// Version of the calibration line written by [`encode_calibration`].
pub const CALIBRATION_VERSION: u32 = 2;

/// The version before the talker's shift ([`CALIBRATION_FIELDS_V1`] fields, no `sx`, `sy`), still
/// read by [`decode_calibration`].
pub const CALIBRATION_VERSION_1: u32 = 1;

/// Fields per band: `n`, three omni parts, three dipole parts.
pub const BAND_FIELDS: usize = 1 + 2 * CARDIOIDS;

/// Number of comma-separated fields after the `CAL` tag (version 2).
pub const CALIBRATION_FIELDS: usize = CALIBRATION_FIELDS_V1 + 2;

/// Number of comma-separated fields after the `CAL` tag of a version 1 line.
pub const CALIBRATION_FIELDS_V1: usize = 6 + CAL_BANDS * BAND_FIELDS;

/// Units of an omni or dipole part on the wire per unit of the model (fixed point, 1/10000).
pub const PART_SCALE: f32 = 10_000.0;

/// Largest omni or dipole part on the wire, in 1/10000 (2.0; plausible parts lie in 0.3…0.75).
pub const PART_MAX: u16 = 20_000;

/// Largest magnitude of a talker's shift component on the wire, in 1/10000 of the plane
/// ([`MAX_TALKER_SHIFT`] = 0.5).
pub const SHIFT_MAX: i16 = (MAX_TALKER_SHIFT * PART_SCALE) as i16;

/// Length of the longest possible calibration line in bytes, `$` to `\n` inclusive.
pub const MAX_CAL_LINE: usize = 1 // $
    + 4 // CAL,
    + 2 // 1,
    + 10 + 1 // seq
    + 20 + 1 // t
    + 4 + 1 // conf
    + 1 + 1 // held
    + 10 + 1 // drop
    + CAL_BANDS * (10 + 1 + 2 * CARDIOIDS * (5 + 1)) // bands
    + 2 * (1 + 5) - 1 // sx, sy (comma, sign and 4 digits), no comma after the last
    + 1 + 4 // *crc
    + 2; // \r\n

/// Length of the longest line of either kind: the buffer size of a [`LineAssembler`](super::LineAssembler)
/// that receives both.
pub const MAX_ANY_LINE: usize = if MAX_CAL_LINE > MAX_LINE {
    MAX_CAL_LINE
} else {
    MAX_LINE
};

/// Seconds between two calibration lines of a sender ([`CalibrationSchedule`]).
pub const CALIBRATION_PERIOD_S: u32 = 10;

/// One band of a calibration line: integers only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalibrationBand {
    /// Background peaks behind the band's estimate, rounded.
    pub peaks: u32,
    /// Omni part a of each cardioid, 1/10000, `0..=`[`PART_MAX`].
    pub omni_part: [u16; CARDIOIDS],
    /// Dipole part b of each cardioid, 1/10000, `0..=`[`PART_MAX`].
    pub dipole_part: [u16; CARDIOIDS],
}

/// The self-calibration's state as it travels on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CalibrationLine {
    /// Calibration lines sent before this one (wrapping).
    pub seq: u32,
    /// Board sample clock of the snapshot (input samples; `centre_sample` of the last estimate).
    pub centre_sample: u64,
    /// Confidence in per mille, `0..=1000`.
    pub confidence_permille: u16,
    /// Whether the estimate is held (background not diffuse).
    pub held: bool,
    /// Calibration lines dropped by the board because the UART was busy.
    pub dropped: u32,
    /// Per band, lowest first.
    pub bands: [CalibrationBand; CAL_BANDS],
    /// The talker's shift x, y ([`CapsuleEstimate::talker_shift`]) in 1/10000,
    /// `-`[`SHIFT_MAX`]`..=`[`SHIFT_MAX`]; 0 in a version 1 line.
    pub talker_shift: [i16; 2],
}

/// A part of the model in 1/10000: rounded, clamped to `0..=`[`PART_MAX`]; NaN gives 0.
#[must_use]
pub fn part_to_wire(v: f32) -> u16 {
    let u = libm::roundf(v * PART_SCALE);
    if u >= f32::from(PART_MAX) {
        PART_MAX
    } else if u > 0.0 {
        u as u16
    } else {
        0
    }
}

/// A talker's shift component in 1/10000: rounded, clamped to ±[`SHIFT_MAX`]; NaN gives 0.
#[must_use]
pub fn shift_to_wire(v: f32) -> i16 {
    // `as` saturates and maps NaN to 0.
    (libm::roundf(v * PART_SCALE) as i16).clamp(-SHIFT_MAX, SHIFT_MAX)
}

/// A peak count on the wire: rounded, clamped to `u32`; NaN and negative values give 0.
#[must_use]
pub fn peaks_to_wire(n: f32) -> u32 {
    // `as` saturates and maps NaN to 0.
    libm::roundf(n) as u32
}

impl CalibrationLine {
    /// Converts the self-calibration's estimate and confidence (0..=1) for the wire.
    #[must_use]
    pub fn from_capsules(
        est: &CapsuleEstimate,
        confidence: f32,
        seq: u32,
        centre_sample: u64,
        dropped: u32,
    ) -> CalibrationLine {
        let mut bands = [CalibrationBand::default(); CAL_BANDS];
        for (w, m) in bands.iter_mut().zip(&est.bands) {
            w.peaks = peaks_to_wire(m.peaks);
            for k in 0..CARDIOIDS {
                w.omni_part[k] = part_to_wire(m.omni_part[k]);
                w.dipole_part[k] = part_to_wire(m.dipole_part[k]);
            }
        }
        CalibrationLine {
            seq,
            centre_sample,
            confidence_permille: confidence_to_permille(confidence),
            held: est.held,
            dropped,
            bands,
            talker_shift: est.talker_shift.map(shift_to_wire),
        }
    }

    /// The estimate the line describes (parts and the talker's shift to 1/10000, peaks to 1), e.g.
    /// to start another localizer from it (`Locator::set_capsule_estimate` of `cma-core`). A
    /// version 1 line has no talker's shift: it is 0 here.
    #[must_use]
    pub fn capsules(&self) -> CapsuleEstimate {
        let mut est = CapsuleEstimate {
            held: self.held,
            talker_shift: self.talker_shift.map(|v| f32::from(v) / PART_SCALE),
            ..CapsuleEstimate::IDEAL
        };
        for (m, w) in est.bands.iter_mut().zip(&self.bands) {
            *m = BandModel {
                omni_part: w.omni_part.map(|v| f32::from(v) / PART_SCALE),
                dipole_part: w.dipole_part.map(|v| f32::from(v) / PART_SCALE),
                peaks: w.peaks as f32,
            };
        }
        est
    }

    /// Confidence in 0..=1.
    #[must_use]
    pub fn confidence(&self) -> f32 {
        f32::from(self.confidence_permille) / 1000.0
    }

    /// Time of the snapshot in seconds at input rate `rate_hz`, `None` if the rate is 0.
    #[must_use]
    pub fn time_s(&self, rate_hz: u32) -> Option<f64> {
        (rate_hz != 0).then(|| self.centre_sample as f64 / f64::from(rate_hz))
    }

    /// Whether the line carries a talker's shift (either component not 0).
    #[must_use]
    pub fn has_talker_shift(&self) -> bool {
        self.talker_shift != [0; 2]
    }

    /// The line with the confidence, the parts and the shift clamped: what [`encode_calibration`]
    /// writes.
    #[must_use]
    pub fn normalized(&self) -> CalibrationLine {
        let mut l = *self;
        l.confidence_permille = l.confidence_permille.min(CONFIDENCE_MAX_PERMILLE);
        l.talker_shift = l.talker_shift.map(|v| v.clamp(-SHIFT_MAX, SHIFT_MAX));
        for b in &mut l.bands {
            for v in b.omni_part.iter_mut().chain(b.dipole_part.iter_mut()) {
                *v = (*v).min(PART_MAX);
            }
        }
        l
    }
}

/// Writes `line` as one calibration line (with `\r\n`) into `out`, which it empties first
/// (`out` holds at least [`MAX_CAL_LINE`] bytes: checked at compile time).
/// Out-of-range fields are clamped first ([`CalibrationLine::normalized`]), so every line written
/// decodes.
///
/// Not inlined: sent every few seconds, so one small out-of-line copy (the firmware's flash) beats
/// an unrolled one in the caller.
#[inline(never)]
pub fn encode_calibration<const N: usize>(line: &CalibrationLine, out: &mut heapless::Vec<u8, N>) {
    const { assert!(N >= MAX_CAL_LINE, "the buffer must hold the longest line") };
    // Clamped as `normalized` does, field by field (no copy of the line: the boards' flash).
    let mut w = Writer::new(out.as_mut_view());
    w.byte(b'$');
    w.bytes(CALIBRATION_TAG);
    w.unsigned(u64::from(CALIBRATION_VERSION));
    for v in [
        u64::from(line.seq),
        line.centre_sample,
        u64::from(line.confidence_permille.min(CONFIDENCE_MAX_PERMILLE)),
        u64::from(line.held),
        u64::from(line.dropped),
    ] {
        w.byte(b',');
        w.unsigned(v);
    }
    for b in &line.bands {
        w.byte(b',');
        w.unsigned(u64::from(b.peaks));
        for &v in b.omni_part.iter().chain(&b.dipole_part) {
            w.byte(b',');
            w.unsigned(u64::from(v.min(PART_MAX)));
        }
    }
    for v in line.talker_shift {
        w.byte(b',');
        w.signed(v.clamp(-SHIFT_MAX, SHIFT_MAX));
    }
    w.finish();
}

/// Checks and parses one calibration line, with or without its `\r\n`.
///
/// Checks in this order: `$`, `CAL,` tag (a `$CMA,` frame line gives [`DecodeError::FrameLine`]),
/// length ([`MAX_CAL_LINE`]), `*` and the 4 hex checksum digits, nothing after them, checksum,
/// version ([`CALIBRATION_VERSION`] or [`CALIBRATION_VERSION_1`]), that version's field count
/// ([`CALIBRATION_FIELDS`], [`CALIBRATION_FIELDS_V1`]), then each field (canonical number, range).
pub fn decode_calibration(line: &[u8]) -> Result<CalibrationLine, DecodeError> {
    let payload = checked_payload(
        line,
        CALIBRATION_TAG,
        MAX_CAL_LINE,
        FRAME_TAG,
        DecodeError::FrameLine,
    )?;
    let mut fields: [&[u8]; CALIBRATION_FIELDS] = [&[]; CALIBRATION_FIELDS];
    let n = split_fields(payload, &mut fields);
    let version = parse_u32(fields[0], Field::Version)?;
    let expected = match version {
        CALIBRATION_VERSION => CALIBRATION_FIELDS,
        CALIBRATION_VERSION_1 => CALIBRATION_FIELDS_V1,
        got => {
            return Err(DecodeError::UnsupportedVersion {
                expected: CALIBRATION_VERSION,
                got,
            })
        }
    };
    if n != expected {
        return Err(DecodeError::FieldCount { expected, got: n });
    }
    let bounded = |s: &[u8], max: u64, field: Field| {
        let v = parse_unsigned(s, u64::MAX).ok_or(DecodeError::BadNumber { field })?;
        if v > max {
            return Err(DecodeError::OutOfRange { field });
        }
        Ok(v)
    };
    let mut line = CalibrationLine {
        seq: parse_u32(fields[1], Field::Seq)?,
        centre_sample: parse_unsigned(fields[2], u64::MAX).ok_or(DecodeError::BadNumber {
            field: Field::CentreSample,
        })?,
        confidence_permille: bounded(
            fields[3],
            u64::from(CONFIDENCE_MAX_PERMILLE),
            Field::Confidence,
        )? as u16,
        held: bounded(fields[4], 1, Field::Held)? == 1,
        dropped: parse_u32(fields[5], Field::Dropped)?,
        bands: [CalibrationBand::default(); CAL_BANDS],
        talker_shift: [0; 2],
    };
    for (k, (band, f)) in line
        .bands
        .iter_mut()
        .zip(fields[6..].chunks_exact(BAND_FIELDS))
        .enumerate()
    {
        let k = k as u8;
        band.peaks = parse_u32(f[0], Field::Peaks { band: k })?;
        for m in 0..CARDIOIDS {
            let cardioid = m as u8;
            band.omni_part[m] = bounded(
                f[1 + m],
                u64::from(PART_MAX),
                Field::OmniPart { band: k, cardioid },
            )? as u16;
            band.dipole_part[m] = bounded(
                f[1 + CARDIOIDS + m],
                u64::from(PART_MAX),
                Field::DipolePart { band: k, cardioid },
            )? as u16;
        }
    }
    if version == CALIBRATION_VERSION {
        let at = CALIBRATION_FIELDS_V1;
        for (k, field) in [Field::ShiftX, Field::ShiftY].into_iter().enumerate() {
            line.talker_shift[k] = parse_signed(fields[at + k], -SHIFT_MAX, SHIFT_MAX, field)?;
        }
    }
    Ok(line)
}

/// A decoded line of either kind ([`decode_line`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Line {
    /// A `$CMA` frame line.
    Frame(Frame),
    /// A `$CAL` calibration line.
    Calibration(CalibrationLine),
    /// A `$TRK` track line.
    Tracks(super::TracksLine),
    /// A `$BGF` background line.
    Background(super::BackgroundLine),
}

/// Checks and parses a line of any kind, chosen by its tag: [`decode_calibration`] for `$CAL,`,
/// [`decode_tracks`](super::decode_tracks) for `$TRK,`,
/// [`decode_background`](super::decode_background) for `$BGF,`, [`decode`](super::decode) for
/// everything else (so its errors are the frame decoder's).
pub fn decode_line(line: &[u8]) -> Result<Line, DecodeError> {
    let body = line.strip_prefix(b"$");
    if body.is_some_and(|b| b.starts_with(CALIBRATION_TAG)) {
        decode_calibration(line).map(Line::Calibration)
    } else if body.is_some_and(|b| b.starts_with(super::TRACKS_TAG)) {
        super::decode_tracks(line).map(Line::Tracks)
    } else if body.is_some_and(|b| b.starts_with(super::BACKGROUND_TAG)) {
        super::decode_background(line).map(Line::Background)
    } else {
        super::decode(line).map(Line::Frame)
    }
}

/// When a sender (the board, `host-sim emit`) sends a calibration line: once at start, before the
/// first frame line, and then after the first estimate whose `centre_sample` is at least
/// [`CALIBRATION_PERIOD_S`] seconds of input samples past the previous calibration line's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CalibrationSchedule {
    period_samples: u64,
    next: Option<u64>,
}

impl CalibrationSchedule {
    /// A schedule at input rate `rate_hz` whose first call of [`CalibrationSchedule::due`] is due.
    #[must_use]
    pub const fn new(rate_hz: u32) -> Self {
        Self {
            period_samples: CALIBRATION_PERIOD_S as u64 * rate_hz as u64,
            next: None,
        }
    }

    /// Whether a calibration line is due at board sample clock `centre_sample`; when it is, the
    /// next one is due [`CALIBRATION_PERIOD_S`] seconds later.
    pub fn due(&mut self, centre_sample: u64) -> bool {
        if self.next.is_some_and(|next| centre_sample < next) {
            return false;
        }
        self.next = Some(centre_sample.saturating_add(self.period_samples));
        true
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::wire::{crc16, decode, encode, LineAssembler};
    use proptest::prelude::*;
    use std::vec::Vec;

    fn line(l: &CalibrationLine) -> Vec<u8> {
        let mut buf = heapless::Vec::<u8, MAX_CAL_LINE>::new();
        encode_calibration(l, &mut buf);
        buf[..].to_vec()
    }

    fn with_crc(payload: &str) -> Vec<u8> {
        let mut v = Vec::from(&b"$"[..]);
        v.extend_from_slice(payload.as_bytes());
        v.extend_from_slice(std::format!("*{:04X}\r\n", crc16(payload.as_bytes())).as_bytes());
        v
    }

    fn sample() -> CalibrationLine {
        let mut est = CapsuleEstimate::IDEAL;
        est.bands[1].omni_part = [0.4812, 0.5304, 0.495];
        est.bands[1].dipole_part = [0.511, 0.462, 0.5391];
        est.bands[1].peaks = 5321.4;
        est.bands[3].peaks = 12.0;
        est.held = true;
        est.talker_shift = [0.084_12, -0.031];
        CalibrationLine::from_capsules(&est, 0.8304, 3, 480_256, 1)
    }

    /// The payload of [`sample`]'s line.
    const SAMPLE_PAYLOAD: &str = "CAL,2,3,480256,830,1,1,\
        0,5000,5000,5000,5000,5000,5000,\
        5321,4812,5304,4950,5110,4620,5391,\
        0,5000,5000,5000,5000,5000,5000,\
        12,5000,5000,5000,5000,5000,5000,\
        841,-310";

    /// [`SAMPLE_PAYLOAD`] as a version 1 line (no talker's shift).
    const SAMPLE_PAYLOAD_V1: &str = "CAL,1,3,480256,830,1,1,\
        0,5000,5000,5000,5000,5000,5000,\
        5321,4812,5304,4950,5110,4620,5391,\
        0,5000,5000,5000,5000,5000,5000,\
        12,5000,5000,5000,5000,5000,5000";

    #[test]
    fn example_line() {
        assert_eq!(line(&sample()), with_crc(SAMPLE_PAYLOAD));
        // The example of docs/wire-format.md.
        let doc = std::format!("${SAMPLE_PAYLOAD}*9167\r\n");
        assert_eq!(line(&sample()), doc.as_bytes());
        assert_eq!(decode_calibration(&with_crc(SAMPLE_PAYLOAD)), Ok(sample()));
    }

    #[test]
    fn a_version_1_line_is_read_without_a_shift() {
        let v1 = with_crc(SAMPLE_PAYLOAD_V1);
        // The version 1 example of docs/wire-format.md.
        assert!(v1.ends_with(b"*6BCE\r\n"));
        let l = decode_calibration(&v1).unwrap();
        assert_eq!(
            l,
            CalibrationLine {
                talker_shift: [0; 2],
                ..sample()
            }
        );
        assert!(!l.has_talker_shift());
        assert_eq!(l.capsules().talker_shift, [0.0; 2]);
        // A version 1 line with version 2's fields, and the reverse, are refused.
        assert_eq!(
            decode_calibration(&with_crc(&SAMPLE_PAYLOAD.replacen("CAL,2,", "CAL,1,", 1))),
            Err(DecodeError::FieldCount {
                expected: CALIBRATION_FIELDS_V1,
                got: CALIBRATION_FIELDS
            })
        );
        assert_eq!(
            decode_calibration(&with_crc(
                &SAMPLE_PAYLOAD_V1.replacen("CAL,1,", "CAL,2,", 1)
            )),
            Err(DecodeError::FieldCount {
                expected: CALIBRATION_FIELDS,
                got: CALIBRATION_FIELDS_V1
            })
        );
    }

    #[test]
    fn round_trip_and_conversion() {
        let l = sample();
        let bytes = line(&l);
        assert_eq!(decode_calibration(&bytes), Ok(l));
        assert_eq!(decode_calibration(&bytes[..bytes.len() - 2]), Ok(l));
        assert_eq!(decode_line(&bytes), Ok(Line::Calibration(l)));
        let est = l.capsules();
        assert!(est.held);
        assert!(l.has_talker_shift());
        assert_eq!(est.talker_shift, [0.0841, -0.031]);
        assert_eq!(est.bands[1].omni_part, [0.4812, 0.5304, 0.495]);
        assert_eq!(est.bands[1].dipole_part, [0.511, 0.462, 0.5391]);
        assert_eq!(est.bands[1].peaks, 5321.0);
        assert_eq!(est.bands[0], BandModel::IDEAL);
        assert!(est.bands.iter().all(BandModel::is_plausible));
        // Converting back gives the same line.
        assert_eq!(
            CalibrationLine::from_capsules(&est, l.confidence(), 3, 480_256, 1),
            l
        );
        assert_eq!(l.time_s(48_000), Some(480_256.0 / 48_000.0));
        assert_eq!(l.time_s(0), None);
    }

    #[test]
    fn widest_line_is_max_cal_line() {
        let widest = CalibrationLine {
            seq: u32::MAX,
            centre_sample: u64::MAX,
            confidence_permille: 1000,
            held: true,
            dropped: u32::MAX,
            bands: [CalibrationBand {
                peaks: u32::MAX,
                omni_part: [PART_MAX; CARDIOIDS],
                dipole_part: [PART_MAX; CARDIOIDS],
            }; CAL_BANDS],
            talker_shift: [-SHIFT_MAX; 2],
        };
        let l = line(&widest);
        assert_eq!(l.len(), MAX_CAL_LINE);
        assert_eq!(MAX_CAL_LINE, 263);
        assert_eq!(decode_calibration(&l), Ok(widest));
        let zero = CalibrationLine::default();
        assert_eq!(decode_calibration(&line(&zero)), Ok(zero));
    }

    #[test]
    fn conversion_rounds_and_clamps() {
        assert_eq!(part_to_wire(0.49996), 5000);
        assert_eq!(part_to_wire(f32::NAN), 0);
        assert_eq!(part_to_wire(-1.0), 0);
        assert_eq!(part_to_wire(7.0), PART_MAX);
        assert_eq!(part_to_wire(f32::INFINITY), PART_MAX);
        assert_eq!(peaks_to_wire(f32::NAN), 0);
        assert_eq!(peaks_to_wire(-3.0), 0);
        assert_eq!(peaks_to_wire(1e20), u32::MAX);
        assert_eq!(peaks_to_wire(2.5), 3);
        assert_eq!(shift_to_wire(-0.031_04), -310);
        assert_eq!(shift_to_wire(f32::NAN), 0);
        assert_eq!(shift_to_wire(-7.0), -SHIFT_MAX);
        assert_eq!(shift_to_wire(f32::INFINITY), SHIFT_MAX);
        assert_eq!(SHIFT_MAX, 5000);
        let mut l = sample();
        l.confidence_permille = 4000;
        l.bands[0].omni_part[2] = u16::MAX;
        l.talker_shift = [i16::MIN, i16::MAX];
        let back = decode_calibration(&line(&l)).unwrap();
        assert_eq!(back.confidence_permille, 1000);
        assert_eq!(back.bands[0].omni_part[2], PART_MAX);
        assert_eq!(back.talker_shift, [-SHIFT_MAX, SHIFT_MAX]);
    }

    #[test]
    fn frame_and_calibration_decoders_reject_each_other_clearly() {
        let cal = line(&sample());
        assert_eq!(decode(&cal), Err(DecodeError::CalibrationLine));
        let msg = std::format!("{}", decode(&cal).unwrap_err());
        assert_eq!(msg, "not a frame line (a `$CAL` self-calibration line)");
        let mut buf = heapless::Vec::<u8, MAX_LINE>::new();
        encode(&Frame::default(), &mut buf);
        assert_eq!(decode_calibration(&buf[..]), Err(DecodeError::FrameLine));
        assert_eq!(decode_line(&buf[..]), Ok(Line::Frame(Frame::default())));
        assert_eq!(
            decode_calibration(&with_crc("GPGGA,1")),
            Err(DecodeError::BadPrefix)
        );
        assert_eq!(decode_line(b"$CA"), Err(DecodeError::BadPrefix));
        assert_eq!(decode_line(b""), Err(DecodeError::MissingStart));
    }

    #[test]
    fn every_error_kind() {
        use DecodeError::*;
        let good = line(&sample());
        let mut long = good.clone();
        long.resize(MAX_CAL_LINE + 1, b'0');
        assert_eq!(
            decode_calibration(&long),
            Err(TooLong {
                max: MAX_CAL_LINE,
                got: MAX_CAL_LINE + 1
            })
        );
        assert_eq!(decode_calibration(&good[1..]), Err(MissingStart));
        assert_eq!(decode_calibration(b"$CAL,1,2"), Err(MissingChecksum));
        assert_eq!(
            decode_calibration(b"$CAL,1*00"),
            Err(BadNumber {
                field: Field::Checksum
            })
        );
        let crc = crc16(b"CAL,1");
        assert_eq!(
            decode_calibration(std::format!("$CAL,1*{crc:04X}!").as_bytes()),
            Err(TrailingBytes)
        );
        let mut bad = good.clone();
        bad[7] = b'4'; // seq 3 → 4
        assert!(matches!(decode_calibration(&bad), Err(Checksum { .. })));
        let short = SAMPLE_PAYLOAD.rsplit_once(',').unwrap().0;
        assert_eq!(
            decode_calibration(&with_crc(short)),
            Err(FieldCount {
                expected: 36,
                got: 35
            })
        );
        assert_eq!(
            decode_calibration(&with_crc(&std::format!("{SAMPLE_PAYLOAD},0"))),
            Err(FieldCount {
                expected: 36,
                got: 37
            })
        );
        assert_eq!(
            decode_calibration(&with_crc(&SAMPLE_PAYLOAD.replacen("CAL,2,", "CAL,3,", 1))),
            Err(UnsupportedVersion {
                expected: 2,
                got: 3
            })
        );
        assert_eq!(
            decode_calibration(&with_crc("CAL,x")),
            Err(BadNumber {
                field: Field::Version
            })
        );
        // Field k (0 = ver) of the payload replaced by `text`.
        let field = |k: usize, text: &str| {
            let mut f: Vec<&str> = SAMPLE_PAYLOAD.split(',').collect();
            f[k + 1] = text;
            with_crc(&f.join(","))
        };
        let malformed: &[(usize, &str, Field)] = &[
            (1, "03", Field::Seq),
            (2, "-1", Field::CentreSample),
            (3, "8.3", Field::Confidence),
            (4, "", Field::Held),
            (5, "+1", Field::Dropped),
            (6, "4294967296", Field::Peaks { band: 0 }),
            (
                15,
                "05304",
                Field::OmniPart {
                    band: 1,
                    cardioid: 1,
                },
            ),
            (
                33,
                "x",
                Field::DipolePart {
                    band: 3,
                    cardioid: 2,
                },
            ),
            (34, "-0", Field::ShiftX),
            (34, "+5", Field::ShiftX),
            (35, "--3", Field::ShiftY),
            (35, "-031", Field::ShiftY),
            (35, "", Field::ShiftY),
            (35, "99999999999999999999", Field::ShiftY),
        ];
        for &(k, text, field_id) in malformed {
            assert_eq!(
                decode_calibration(&field(k, text)),
                Err(BadNumber { field: field_id }),
                "field {k} = `{text}`"
            );
        }
        let ranges: &[(usize, &str, Field)] = &[
            (3, "1001", Field::Confidence),
            (4, "2", Field::Held),
            (
                10,
                "20001",
                Field::DipolePart {
                    band: 0,
                    cardioid: 0,
                },
            ),
            (34, "5001", Field::ShiftX),
            (35, "-5001", Field::ShiftY),
        ];
        for &(k, text, field_id) in ranges {
            assert_eq!(
                decode_calibration(&field(k, text)),
                Err(OutOfRange { field: field_id }),
                "field {k} = `{text}`"
            );
        }
        let msg = std::format!(
            "{}",
            OutOfRange {
                field: Field::DipolePart {
                    band: 0,
                    cardioid: 2
                }
            }
        );
        assert_eq!(msg, "field `b` of band 0, cardioid 2 is out of range");
    }

    #[test]
    fn assembler_of_any_line_carries_both_kinds() {
        let mut f = heapless::Vec::<u8, MAX_LINE>::new();
        encode(&Frame::default(), &mut f);
        let mut stream = line(&sample());
        stream.extend_from_slice(&f[..]);
        stream.extend_from_slice(&line(&sample()));
        let mut asm = LineAssembler::<MAX_ANY_LINE>::new();
        let mut got = Vec::new();
        asm.push_chunk(&stream, |l| got.push(decode_line(l)));
        assert_eq!(
            got,
            [
                Ok(Line::Calibration(sample())),
                Ok(Line::Frame(Frame::default())),
                Ok(Line::Calibration(sample()))
            ]
        );
    }

    #[test]
    fn schedule_sends_at_start_then_every_period() {
        let mut s = CalibrationSchedule::new(48_000);
        assert!(s.due(0));
        assert!(!s.due(0));
        assert!(!s.due(479_999));
        assert!(s.due(480_100));
        assert!(!s.due(960_099));
        assert!(s.due(960_100));
        let mut late = CalibrationSchedule::new(48_000);
        assert!(late.due(5_000_000), "the first call is always due");
        assert!(!late.due(5_000_001));
    }

    fn arb_line() -> impl Strategy<Value = CalibrationLine> {
        let band = (
            any::<u32>(),
            prop::array::uniform3(0..=PART_MAX),
            prop::array::uniform3(0..=PART_MAX),
        )
            .prop_map(|(peaks, omni_part, dipole_part)| CalibrationBand {
                peaks,
                omni_part,
                dipole_part,
            });
        (
            any::<u32>(),
            any::<u64>(),
            0..=CONFIDENCE_MAX_PERMILLE,
            any::<bool>(),
            any::<u32>(),
            prop::array::uniform4(band),
            prop::array::uniform2(-SHIFT_MAX..=SHIFT_MAX),
        )
            .prop_map(
                |(seq, centre_sample, confidence_permille, held, dropped, bands, talker_shift)| {
                    CalibrationLine {
                        seq,
                        centre_sample,
                        confidence_permille,
                        held,
                        dropped,
                        bands,
                        talker_shift,
                    }
                },
            )
    }

    proptest! {
        #[test]
        fn any_line_round_trips(l in arb_line()) {
            let bytes = line(&l);
            prop_assert!(bytes.len() <= MAX_CAL_LINE);
            prop_assert_eq!(decode_calibration(&bytes), Ok(l));
        }

        #[test]
        fn any_estimate_encodes_to_a_line_that_decodes(
            parts in prop::array::uniform32(any::<f32>()),
            conf in any::<f32>(),
            held in any::<bool>(),
        ) {
            let mut est = CapsuleEstimate { held, ..CapsuleEstimate::IDEAL };
            for (k, b) in est.bands.iter_mut().enumerate() {
                b.omni_part = [parts[7 * k], parts[7 * k + 1], parts[7 * k + 2]];
                b.dipole_part = [parts[7 * k + 3], parts[7 * k + 4], parts[7 * k + 5]];
                b.peaks = parts[7 * k + 6];
            }
            let l = CalibrationLine::from_capsules(&est, conf, 1, 2, 3);
            prop_assert_eq!(decode_calibration(&line(&l)), Ok(l));
        }

        #[test]
        fn arbitrary_bytes_never_panic_and_accepted_lines_are_canonical(
            bytes in prop::collection::vec(any::<u8>(), 0..300),
            keep in 0usize..300,
        ) {
            // Half the cases start from a valid line with a corrupted tail, so the deeper checks run.
            let mut input = line(&sample());
            input.truncate(keep.min(input.len()));
            input.extend_from_slice(&bytes);
            for candidate in [&bytes[..], &input[..]] {
                if let Ok(l) = decode_calibration(candidate) {
                    let again = line(&l);
                    let body = candidate.strip_suffix(b"\n").unwrap_or(candidate);
                    let body = body.strip_suffix(b"\r").unwrap_or(body);
                    prop_assert_eq!(&again[..again.len() - 2], body);
                }
                let _ = decode_line(candidate);
            }
        }
    }
}
