//! The background line: the stationary background per band ([`BackgroundBand`], the background
//! field's summary) as one ASCII line, sent by the board every
//! [`CALIBRATION_PERIOD_S`](super::CALIBRATION_PERIOD_S) seconds, one analysis hop after the
//! calibration line. It shows an installer where the room's steady sources (a projector's fan, an
//! air vent) are and how loud. Version 1, byte by byte:
//!
//! ```text
//! $BGF,<ver>,<seq>,<t>,<band 0>,<band 1>*<crc>\r\n
//! <band k> = <n>,<az>,<dir>,<db>
//! ```
//!
//! | bytes  | meaning                                                                                 |
//! |--------|-----------------------------------------------------------------------------------------|
//! | `$`    | start of line (0x24)                                                                    |
//! | `BGF`  | tag (0x42 0x47 0x46)                                                                    |
//! | `,`    | field separator (0x2C), between every two fields (3 + 4·[`BG_BANDS`] = 11 after the tag) |
//! | `ver`  | version of the background line, `1` ([`BACKGROUND_VERSION`])                            |
//! | `seq`  | background lines sent, `u32` decimal, +1 per line, wraps; its own count                 |
//! | `t`    | board sample clock: `centre_sample` of the last estimate before the snapshot, `u64`     |
//! | `n`    | per band ([`BG_BANDS`] = 2: below 1 kHz, from 1 kHz): background frames behind it, rounded, `u32`; `0` = no evidence yet, and then the band's other fields are `0` |
//! | `az`   | per band: [`BackgroundBand::direction_deg`] in tenths of a degree, `-1799..=1800`       |
//! | `dir`  | per band: [`BackgroundBand::directivity`] in per mille, `0..=1000`                      |
//! | `db`   | per band: [`BackgroundBand::level_db`] in tenths of a dB (re full-scale mean square), `-2000..=2000` |
//! | `*`    | end of the checksummed part (0x2A)                                                      |
//! | `crc`  | CRC-16/CCITT-FALSE of every byte strictly between `$` and `*`, 4 upper-case hex digits  |
//! | `\r\n` | end of line                                                                             |
//!
//! Numbers are canonical as in the frame line (`-` only before a non-zero `az` or `db`), so a line
//! that decodes is exactly what [`encode_background`] writes. The longest line is
//! [`MAX_BGF_LINE`] = 101 bytes; a typical one is about 50 (4 ms at 115200 baud).
//!
//! The other decoders ([`decode`](super::decode), [`decode_calibration`](super::decode_calibration),
//! [`decode_tracks`](super::decode_tracks)) reject a background line with
//! [`DecodeError::BackgroundLine`]; [`decode_line`](super::decode_line) decodes all four. A decoder
//! built before this line existed rejects it as an unknown line ([`DecodeError::BadPrefix`]): a
//! monitor of that age counts one corrupt line per background line and goes on.

use super::{
    checked_payload, parse_signed, parse_tenths, parse_u32, parse_unsigned, split_fields,
    DecodeError, Field, Writer, BACKGROUND_TAG, CONFIDENCE_MAX_PERMILLE, FRAME_TAG,
};
use crate::background_field::{BackgroundBand, BG_BANDS};

/// Version of the background line written by [`encode_background`] and the only one
/// [`decode_background`] accepts.
pub const BACKGROUND_VERSION: u32 = 1;

/// Fields per band: `n`, `az`, `dir`, `db`.
const BAND_FIELDS: usize = 4;

/// Number of comma-separated fields after the `BGF` tag.
pub const BACKGROUND_FIELDS: usize = 3 + BG_BANDS * BAND_FIELDS;

/// Lowest level on the wire, tenths of a dB (−200 dB).
pub const LEVEL_MIN_TENTHS: i16 = -2000;
/// Highest level on the wire, tenths of a dB (+200 dB).
pub const LEVEL_MAX_TENTHS: i16 = 2000;

/// Length of the longest possible background line in bytes, `$` to `\n` inclusive.
pub const MAX_BGF_LINE: usize = 1 // $
    + 4 // BGF,
    + 1 // 1
    + 1 + 10 // ,seq
    + 1 + 20 // ,t
    + BG_BANDS * (1 + 10 + 1 + 5 + 1 + 4 + 1 + 5) // ,n,az,dir,db
    + 1 + 4 // *crc
    + 2; // \r\n

/// One band of a background line: integers only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WireBackgroundBand {
    /// Background frames behind the band, rounded; 0 = no evidence (the other fields are 0).
    pub frames: u32,
    /// Direction in tenths of a degree, `-1799..=1800`.
    pub direction_tenths: i16,
    /// Directivity in per mille, `0..=1000`.
    pub directivity_permille: u16,
    /// Level in tenths of a dB re full-scale mean square,
    /// [`LEVEL_MIN_TENTHS`]`..=`[`LEVEL_MAX_TENTHS`].
    pub level_tenths_db: i16,
}

impl WireBackgroundBand {
    /// The band of a summary (`None`: no evidence, all 0): rounded, wrapped and clamped to the
    /// wire's ranges; NaN gives 0.
    #[must_use]
    pub fn from_summary(b: Option<&BackgroundBand>) -> Self {
        let Some(b) = b else {
            return Self::default();
        };
        // Rounded half away from zero by `as` (which saturates and maps NaN to 0): no software
        // `roundf` in the firmware's flash.
        let round = |v: f32| (v + 0.5f32.copysign(v)) as i32;
        let tenths = round(b.direction_deg * 10.0).rem_euclid(3600);
        Self {
            // At least 1: the band has evidence.
            frames: ((b.frames + 0.5) as u32).max(1),
            direction_tenths: (if tenths > 1800 { tenths - 3600 } else { tenths }) as i16,
            directivity_permille: round(b.directivity * 1000.0)
                .clamp(0, i32::from(CONFIDENCE_MAX_PERMILLE))
                as u16,
            level_tenths_db: round(b.level_db * 10.0)
                .clamp(i32::from(LEVEL_MIN_TENTHS), i32::from(LEVEL_MAX_TENTHS))
                as i16,
        }
    }

    /// Whether the band has evidence (`n` > 0).
    #[must_use]
    pub fn has_evidence(&self) -> bool {
        self.frames > 0
    }

    /// Direction in degrees.
    #[must_use]
    pub fn direction_deg(&self) -> f32 {
        f32::from(self.direction_tenths) / 10.0
    }

    /// Directivity in 0..=1.
    #[must_use]
    pub fn directivity(&self) -> f32 {
        f32::from(self.directivity_permille) / 1000.0
    }

    /// Level in dB re full-scale mean square.
    #[must_use]
    pub fn level_db(&self) -> f32 {
        f32::from(self.level_tenths_db) / 10.0
    }

    /// Whether a source stands out of the band's diffuse noise
    /// ([`DIRECTIONAL_MIN`](crate::background_field::DIRECTIONAL_MIN), as
    /// [`BackgroundBand::is_directional`]).
    #[must_use]
    pub fn is_directional(&self) -> bool {
        self.has_evidence() && self.directivity() > crate::background_field::DIRECTIONAL_MIN
    }
}

/// The stationary background as it travels on the wire.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BackgroundLine {
    /// Background lines sent before this one (wrapping).
    pub seq: u32,
    /// Board sample clock of the snapshot (input samples).
    pub centre_sample: u64,
    /// Per band, lowest first.
    pub bands: [WireBackgroundBand; BG_BANDS],
}

impl BackgroundLine {
    /// The line of the summaries of `Locator::background_field` (`cma-core`).
    #[must_use]
    pub fn from_summary(
        bands: &[Option<BackgroundBand>; BG_BANDS],
        seq: u32,
        centre_sample: u64,
    ) -> Self {
        Self {
            seq,
            centre_sample,
            bands: core::array::from_fn(|b| WireBackgroundBand::from_summary(bands[b].as_ref())),
        }
    }
}

/// Writes `line` as one background line (with `\r\n`) into `out`, which it empties first
/// (`out` holds at least [`MAX_BGF_LINE`] bytes: checked at compile time). Fields
/// out of range are clamped and a band without evidence is written as `0,0,0,0`, so every line
/// written decodes. Not inlined, like [`encode_calibration`](super::encode_calibration).
#[inline(never)]
pub fn encode_background<const N: usize>(line: &BackgroundLine, out: &mut heapless::Vec<u8, N>) {
    const { assert!(N >= MAX_BGF_LINE, "the buffer must hold the longest line") };
    let mut w = Writer::new(out.as_mut_view());
    w.byte(b'$');
    w.bytes(BACKGROUND_TAG);
    w.unsigned(u64::from(BACKGROUND_VERSION));
    for v in [u64::from(line.seq), line.centre_sample] {
        w.byte(b',');
        w.unsigned(v);
    }
    for b in &line.bands {
        let b = if b.has_evidence() {
            *b
        } else {
            WireBackgroundBand::default()
        };
        for v in [
            i64::from(b.frames),
            i64::from(
                b.direction_tenths
                    .clamp(super::AZIMUTH_MIN_TENTHS, super::AZIMUTH_MAX_TENTHS),
            ),
            i64::from(b.directivity_permille.min(CONFIDENCE_MAX_PERMILLE)),
            i64::from(b.level_tenths_db.clamp(LEVEL_MIN_TENTHS, LEVEL_MAX_TENTHS)),
        ] {
            w.field(v);
        }
    }
    w.finish();
}

/// Checks and parses one background line, with or without its `\r\n`.
///
/// Checks in this order: `$`, `BGF,` tag (a `$CMA,` frame line gives [`DecodeError::FrameLine`]),
/// length ([`MAX_BGF_LINE`]), `*` and the 4 hex checksum digits, nothing after them, checksum,
/// field count ([`BACKGROUND_FIELDS`]), version ([`BACKGROUND_VERSION`]), then each field
/// (canonical number, range; a band with `n` = 0 has all its fields 0).
pub fn decode_background(line: &[u8]) -> Result<BackgroundLine, DecodeError> {
    let payload = checked_payload(
        line,
        BACKGROUND_TAG,
        MAX_BGF_LINE,
        FRAME_TAG,
        DecodeError::FrameLine,
    )?;
    let mut fields: [&[u8]; BACKGROUND_FIELDS] = [&[]; BACKGROUND_FIELDS];
    let n = split_fields(payload, &mut fields);
    if n != BACKGROUND_FIELDS {
        return Err(DecodeError::FieldCount {
            expected: BACKGROUND_FIELDS,
            got: n,
        });
    }
    let version = parse_u32(fields[0], Field::Version)?;
    if version != BACKGROUND_VERSION {
        return Err(DecodeError::UnsupportedVersion {
            expected: BACKGROUND_VERSION,
            got: version,
        });
    }
    let mut out = BackgroundLine {
        seq: parse_u32(fields[1], Field::Seq)?,
        centre_sample: parse_unsigned(fields[2], u64::MAX).ok_or(DecodeError::BadNumber {
            field: Field::CentreSample,
        })?,
        ..BackgroundLine::default()
    };
    for (k, (band, f)) in out
        .bands
        .iter_mut()
        .zip(fields[3..].chunks_exact(BAND_FIELDS))
        .enumerate()
    {
        let k = k as u8;
        band.frames = parse_u32(f[0], Field::BackgroundFrames { band: k })?;
        band.direction_tenths = parse_tenths(f[1], Field::BackgroundDirection { band: k })?;
        let dir = parse_unsigned(f[2], u64::MAX).ok_or(DecodeError::BadNumber {
            field: Field::BackgroundDirectivity { band: k },
        })?;
        if dir > u64::from(CONFIDENCE_MAX_PERMILLE) {
            return Err(DecodeError::OutOfRange {
                field: Field::BackgroundDirectivity { band: k },
            });
        }
        band.directivity_permille = dir as u16;
        band.level_tenths_db = parse_signed(
            f[3],
            LEVEL_MIN_TENTHS,
            LEVEL_MAX_TENTHS,
            Field::BackgroundLevel { band: k },
        )?;
        if band.frames == 0 && *band != WireBackgroundBand::default() {
            return Err(DecodeError::OutOfRange {
                field: Field::BackgroundFrames { band: k },
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::wire::{
        crc16, decode, decode_calibration, decode_line, decode_tracks, Line, MAX_ANY_LINE,
    };
    use proptest::prelude::*;
    use std::vec::Vec;

    fn sample() -> BackgroundLine {
        BackgroundLine {
            seq: 3,
            centre_sample: 480_256,
            bands: [
                WireBackgroundBand {
                    frames: 100,
                    direction_tenths: 312,
                    directivity_permille: 450,
                    level_tenths_db: -523,
                },
                WireBackgroundBand::default(),
            ],
        }
    }

    fn encoded(l: &BackgroundLine) -> Vec<u8> {
        let mut buf = heapless::Vec::<u8, MAX_BGF_LINE>::new();
        encode_background(l, &mut buf);
        buf[..].to_vec()
    }

    #[test]
    fn a_known_line_byte_for_byte_and_back() {
        let bytes = encoded(&sample());
        let crc = crc16(b"BGF,1,3,480256,100,312,450,-523,0,0,0,0");
        assert_eq!(
            bytes,
            std::format!("$BGF,1,3,480256,100,312,450,-523,0,0,0,0*{crc:04X}\r\n").as_bytes()
        );
        assert_eq!(decode_background(&bytes), Ok(sample()));
        assert_eq!(decode_line(&bytes), Ok(Line::Background(sample())));
        const { assert!(MAX_BGF_LINE <= MAX_ANY_LINE) };
        // The examples of docs/wire-format.md.
        let doc = BackgroundLine {
            bands: [
                sample().bands[0],
                WireBackgroundBand {
                    frames: 100,
                    direction_tenths: -1234,
                    directivity_permille: 120,
                    level_tenths_db: -601,
                },
            ],
            ..sample()
        };
        assert_eq!(
            encoded(&doc),
            b"$BGF,1,3,480256,100,312,450,-523,100,-1234,120,-601*E403\r\n"
        );
        let first = BackgroundLine {
            seq: 0,
            centre_sample: 256,
            ..BackgroundLine::default()
        };
        assert_eq!(encoded(&first), b"$BGF,1,0,256,0,0,0,0,0,0,0,0*466B\r\n");
        let widest = BackgroundLine {
            seq: u32::MAX,
            centre_sample: u64::MAX,
            bands: [WireBackgroundBand {
                frames: u32::MAX,
                direction_tenths: -1799,
                directivity_permille: 1000,
                level_tenths_db: -2000,
            }; BG_BANDS],
        };
        let w = encoded(&widest);
        assert_eq!(w.len(), MAX_BGF_LINE);
        assert_eq!(decode_background(&w), Ok(widest));
    }

    #[test]
    fn a_corrupted_line_is_rejected_by_its_checksum() {
        let good = encoded(&sample());
        for i in 1..good.len() - 7 {
            let mut bad = good.clone();
            bad[i] ^= 0x01;
            assert!(decode_background(&bad).is_err(), "byte {i}");
            assert!(decode_line(&bad).is_err(), "byte {i}");
        }
        let mut bad = good.clone();
        bad[20] = if bad[20] == b'7' { b'8' } else { b'7' };
        assert!(matches!(
            decode_background(&bad),
            Err(DecodeError::Checksum { .. })
        ));
    }

    #[test]
    fn the_other_decoders_name_the_background_line() {
        let bytes = encoded(&sample());
        assert_eq!(decode(&bytes), Err(DecodeError::BackgroundLine));
        assert_eq!(decode_calibration(&bytes), Err(DecodeError::BackgroundLine));
        assert_eq!(decode_tracks(&bytes), Err(DecodeError::BackgroundLine));
        assert_eq!(
            decode_background(b"$CMA,1*0000\r\n"),
            Err(DecodeError::FrameLine)
        );
    }

    #[test]
    fn bad_fields_are_rejected_with_their_reason() {
        let with_crc = |payload: &str| {
            let crc = crc16(payload.as_bytes());
            std::format!("${payload}*{crc:04X}\r\n").into_bytes()
        };
        let band = |band| Field::BackgroundFrames { band };
        let cases: [(&str, DecodeError); 6] = [
            (
                "BGF,2,0,0,0,0,0,0,0,0,0,0",
                DecodeError::UnsupportedVersion {
                    expected: 1,
                    got: 2,
                },
            ),
            (
                "BGF,1,0,0,0,0,0,0,0,0,0",
                DecodeError::FieldCount {
                    expected: 11,
                    got: 10,
                },
            ),
            (
                "BGF,1,0,0,5,0,1001,0,0,0,0,0",
                DecodeError::OutOfRange {
                    field: Field::BackgroundDirectivity { band: 0 },
                },
            ),
            (
                "BGF,1,0,0,5,0,0,-2001,0,0,0,0",
                DecodeError::OutOfRange {
                    field: Field::BackgroundLevel { band: 0 },
                },
            ),
            (
                "BGF,1,0,0,5,0,0,-0,0,0,0,0",
                DecodeError::BadNumber {
                    field: Field::BackgroundLevel { band: 0 },
                },
            ),
            (
                "BGF,1,0,0,5,0,0,0,0,10,0,0",
                DecodeError::OutOfRange { field: band(1) },
            ),
        ];
        for (payload, err) in cases {
            assert_eq!(decode_background(&with_crc(payload)), Err(err), "{payload}");
        }
    }

    #[test]
    fn from_the_core_summary() {
        let b = BackgroundBand {
            direction_deg: -179.96,
            directivity: 0.4567,
            level_db: -52.34,
            frames: 37.4,
        };
        let l = BackgroundLine::from_summary(&[Some(b), None], 1, 2);
        assert_eq!(
            l.bands[0],
            WireBackgroundBand {
                frames: 37,
                direction_tenths: 1800,
                directivity_permille: 457,
                level_tenths_db: -523,
            }
        );
        assert!(l.bands[0].is_directional() && !l.bands[1].is_directional());
        assert_eq!(l.bands[1], WireBackgroundBand::default());
        let odd = BackgroundBand {
            direction_deg: f32::NAN,
            directivity: f32::NAN,
            level_db: -1e9,
            frames: 0.2,
        };
        let w = WireBackgroundBand::from_summary(Some(&odd));
        assert_eq!(
            (w.frames, w.direction_tenths, w.level_tenths_db),
            (1, 0, -2000)
        );
    }

    proptest! {
        #[test]
        fn every_line_round_trips(
            seq in any::<u32>(),
            t in any::<u64>(),
            bands in proptest::collection::vec((any::<u32>(), any::<i16>(), any::<u16>(), any::<i16>()), BG_BANDS),
        ) {
            let mut l = BackgroundLine { seq, centre_sample: t, ..BackgroundLine::default() };
            for (slot, &(n, az, d, db)) in l.bands.iter_mut().zip(&bands) {
                *slot = WireBackgroundBand {
                    frames: n,
                    direction_tenths: az,
                    directivity_permille: d,
                    level_tenths_db: db,
                };
            }
            let bytes = encoded(&l);
            prop_assert!(bytes.len() <= MAX_BGF_LINE);
            let d = decode_background(&bytes).unwrap();
            for (a, b) in d.bands.iter().zip(&l.bands) {
                if b.frames == 0 {
                    prop_assert_eq!(*a, WireBackgroundBand::default());
                } else {
                    prop_assert_eq!(a.frames, b.frames);
                    prop_assert_eq!(a.direction_tenths, b.direction_tenths.clamp(-1799, 1800));
                    prop_assert_eq!(a.directivity_permille, b.directivity_permille.min(1000));
                    prop_assert_eq!(a.level_tenths_db, b.level_tenths_db.clamp(-2000, 2000));
                }
            }
            prop_assert_eq!(encoded(&d), bytes);
        }

        #[test]
        fn arbitrary_bytes_never_panic_and_accepted_lines_are_canonical(
            tail in proptest::collection::vec(
                proptest::sample::select(&b"0123456789,-BGF$*\r\n"[..]), 0..80),
        ) {
            let line = [b"$BGF,1,".as_slice(), &tail].concat();
            if let Ok(d) = decode_background(&line) {
                let body = line.strip_suffix(b"\n").unwrap_or(&line);
                let body = body.strip_suffix(b"\r").unwrap_or(body);
                let e = encoded(&d);
                prop_assert_eq!(&e[..e.len() - 2], body);
            }
            let _ = decode_line(&line);
        }
    }
}
