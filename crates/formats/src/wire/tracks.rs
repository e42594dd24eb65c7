//! The track line: the active multi-talker tracks ([`TalkerTrack`]) of one analysis frame as one
//! ASCII line, sent by a board with the multi-talker stage on after each frame line, for the frame
//! whose activity the core decided then (`multi_track.span_delay_frames()` frames earlier, see
//! `cma_tracking::track_spans`; `t` names it). Version 1, byte by byte:
//!
//! ```text
//! $TRK,<ver>,<seq>,<t>,<n>[,<id>,<az>,<conf>]…*<crc>\r\n      (n times the bracket)
//! ```
//!
//! | bytes    | meaning                                                                               |
//! |----------|---------------------------------------------------------------------------------------|
//! | `$`      | start of line (0x24)                                                                  |
//! | `TRK`    | tag (0x54 0x52 0x4B)                                                                  |
//! | `,`      | field separator (0x2C), between every two fields (4 + 3·n fields after the tag)       |
//! | `ver`    | version of the track line, `1` ([`TRACKS_VERSION`])                                   |
//! | `seq`    | track lines sent, `u32` decimal, +1 per line, wraps; its own count, not the frames'   |
//! | `t`      | `centre_sample` of the estimate whose tracks these are (that frame line's `t`), `u64` |
//! | `n`      | number of active tracks that follow, `0..=`[`MAX_TRACKS`]                              |
//! | `id`     | per track: persistent ID, `1..=65535`; the IDs of a line differ                       |
//! | `az`     | per track: azimuth in tenths of a degree, `-1799..=1800`, as the frame line's `az`    |
//! | `conf`   | per track: confidence in per mille, `0..=1000`                                        |
//! | `*`      | end of the checksummed part (0x2A)                                                    |
//! | `crc`    | CRC-16/CCITT-FALSE of every byte strictly between `$` and `*`, 4 upper-case hex digits |
//! | `\r\n`   | end of line                                                                           |
//!
//! Only active tracks are sent (a talker who speaks in this frame); a track keeps its ID from line to
//! line. Numbers are canonical as in the frame line, so a line that decodes is exactly what
//! [`encode_tracks`] writes. The longest line is [`MAX_TRK_LINE`] = 98 bytes.
//!
//! The frame and calibration decoders ([`decode`](super::decode),
//! [`decode_calibration`](super::decode_calibration)) reject a track line with
//! [`DecodeError::TracksLine`], naming it; [`decode_line`](super::decode_line) decodes all three.

use super::{
    azimuth_to_tenths, checked_payload, confidence_to_permille, parse_tenths, parse_u32,
    parse_unsigned, split_fields, DecodeError, Field, Writer, CONFIDENCE_MAX_PERMILLE, FRAME_TAG,
    TRACKS_TAG,
};
use crate::multi_track::{TalkerTrack, MAX_TRACKS};

/// Version of the track line written by [`encode_tracks`] and the only one [`decode_tracks`]
/// accepts.
pub const TRACKS_VERSION: u32 = 1;

/// Fields after the tag before the tracks: `ver`, `seq`, `t`, `n`.
const HEAD_FIELDS: usize = 4;

/// Length of the longest possible track line in bytes, `$` to `\n` inclusive.
pub const MAX_TRK_LINE: usize = 1 // $
    + 4 // TRK,
    + 1 // 1
    + 1 + 10 // ,seq
    + 1 + 20 // ,t
    + 1 + 1 // ,n
    + MAX_TRACKS * (1 + 5 + 1 + 5 + 1 + 4) // ,id,az,conf
    + 1 + 4 // *crc
    + 2; // \r\n

/// One track on the wire: integers only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct WireTrack {
    /// Persistent ID, ≥ 1.
    pub id: u16,
    /// Azimuth in tenths of a degree, `-1799..=1800`.
    pub azimuth_tenths: i16,
    /// Confidence in per mille, `0..=1000`.
    pub confidence_permille: u16,
}

impl WireTrack {
    /// Azimuth in degrees.
    #[must_use]
    pub fn azimuth_deg(&self) -> f32 {
        f32::from(self.azimuth_tenths) / 10.0
    }

    /// Confidence in 0..=1.
    #[must_use]
    pub fn confidence(&self) -> f32 {
        f32::from(self.confidence_permille) / 1000.0
    }
}

/// The active tracks of one frame as they travel on the wire.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TracksLine {
    /// Track lines sent before this one (wrapping).
    pub seq: u32,
    /// `centre_sample` of the estimate (input samples).
    pub centre_sample: u64,
    /// The active tracks, at most [`MAX_TRACKS`] (the count held in a `u8`, as on the wire).
    pub tracks: heapless::Vec<WireTrack, MAX_TRACKS, u8>,
}

impl TracksLine {
    /// The active ones of `tracks` (at most [`MAX_TRACKS`]) for the wire.
    pub fn from_tracks(
        tracks: impl IntoIterator<Item = TalkerTrack>,
        seq: u32,
        centre_sample: u64,
    ) -> TracksLine {
        let mut line = TracksLine {
            seq,
            centre_sample,
            ..TracksLine::default()
        };
        for t in tracks.into_iter().filter(|t| t.active && t.id != 0) {
            let track = WireTrack {
                id: t.id,
                azimuth_tenths: azimuth_to_tenths(t.azimuth_deg),
                confidence_permille: confidence_to_permille(t.confidence),
            };
            if line.tracks.push(track).is_err() {
                break;
            }
        }
        line
    }

    /// The tracks of the line.
    #[must_use]
    pub fn active(&self) -> &[WireTrack] {
        &self.tracks
    }
}

/// Writes `line` as one track line (with `\r\n`) into `out`, which it empties first
/// (`out` holds at least [`MAX_TRK_LINE`] bytes: checked at compile time). Fields out of
/// range are clamped (azimuth and confidence to their ranges, ID 0 to 1),
/// so every line written decodes unless two tracks share an ID.
pub fn encode_tracks<const N: usize>(line: &TracksLine, out: &mut heapless::Vec<u8, N>) {
    const { assert!(N >= MAX_TRK_LINE, "the buffer must hold the longest line") };
    let mut w = Writer::new(out.as_mut_view());
    w.byte(b'$');
    w.bytes(TRACKS_TAG);
    w.unsigned(u64::from(TRACKS_VERSION));
    let tracks = line.active();
    for v in [u64::from(line.seq), line.centre_sample, tracks.len() as u64] {
        w.byte(b',');
        w.unsigned(v);
    }
    for t in tracks {
        w.byte(b',');
        w.unsigned(u64::from(t.id.max(1)));
        w.byte(b',');
        w.signed(
            t.azimuth_tenths
                .clamp(super::AZIMUTH_MIN_TENTHS, super::AZIMUTH_MAX_TENTHS),
        );
        w.byte(b',');
        w.unsigned(u64::from(
            t.confidence_permille.min(CONFIDENCE_MAX_PERMILLE),
        ));
    }
    w.finish();
}

/// Checks and parses one track line, with or without its `\r\n`.
///
/// Checks in this order: `$`, `TRK,` tag (a `$CMA,` frame line gives [`DecodeError::FrameLine`]),
/// length ([`MAX_TRK_LINE`]), `*` and the 4 hex checksum digits, nothing after them, checksum,
/// at least the 4 head fields, version ([`TRACKS_VERSION`]), `seq`, `t`, `n` (≤ [`MAX_TRACKS`]),
/// field count 4 + 3·n, then each track's fields (canonical number, range, distinct IDs).
pub fn decode_tracks(line: &[u8]) -> Result<TracksLine, DecodeError> {
    let payload = checked_payload(
        line,
        TRACKS_TAG,
        MAX_TRK_LINE,
        FRAME_TAG,
        DecodeError::FrameLine,
    )?;
    const MAX_FIELDS: usize = HEAD_FIELDS + 3 * MAX_TRACKS;
    let mut fields: [&[u8]; MAX_FIELDS] = [&[]; MAX_FIELDS];
    let n = split_fields(payload, &mut fields);
    if n < HEAD_FIELDS {
        return Err(DecodeError::FieldCount {
            expected: HEAD_FIELDS,
            got: n,
        });
    }
    let version = parse_u32(fields[0], Field::Version)?;
    if version != TRACKS_VERSION {
        return Err(DecodeError::UnsupportedVersion {
            expected: TRACKS_VERSION,
            got: version,
        });
    }
    let mut out = TracksLine {
        seq: parse_u32(fields[1], Field::Seq)?,
        centre_sample: parse_unsigned(fields[2], u64::MAX).ok_or(DecodeError::BadNumber {
            field: Field::CentreSample,
        })?,
        ..TracksLine::default()
    };
    let count = parse_unsigned(fields[3], u64::MAX).ok_or(DecodeError::BadNumber {
        field: Field::TrackCount,
    })?;
    if count > MAX_TRACKS as u64 {
        return Err(DecodeError::OutOfRange {
            field: Field::TrackCount,
        });
    }
    let count = count as usize;
    if n != HEAD_FIELDS + 3 * count {
        return Err(DecodeError::FieldCount {
            expected: HEAD_FIELDS + 3 * count,
            got: n,
        });
    }
    for (k, f) in fields[HEAD_FIELDS..HEAD_FIELDS + 3 * count]
        .chunks_exact(3)
        .enumerate()
    {
        let track = k as u8;
        let id = parse_unsigned(f[0], u64::MAX).ok_or(DecodeError::BadNumber {
            field: Field::TrackId { track },
        })?;
        if id == 0 || id > u64::from(u16::MAX) || out.active().iter().any(|t| u64::from(t.id) == id)
        {
            return Err(DecodeError::OutOfRange {
                field: Field::TrackId { track },
            });
        }
        let azimuth_tenths = parse_tenths(f[1], Field::TrackAzimuth { track })?;
        let conf = parse_unsigned(f[2], u64::MAX).ok_or(DecodeError::BadNumber {
            field: Field::TrackConfidence { track },
        })?;
        if conf > u64::from(CONFIDENCE_MAX_PERMILLE) {
            return Err(DecodeError::OutOfRange {
                field: Field::TrackConfidence { track },
            });
        }
        // Never full: `count` ≤ MAX_TRACKS was checked above.
        let _ = out.tracks.push(WireTrack {
            id: id as u16,
            azimuth_tenths,
            confidence_permille: conf as u16,
        });
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::wire::{decode, decode_calibration, decode_line, Line, MAX_ANY_LINE};
    use proptest::prelude::*;
    use std::vec::Vec;

    fn line_of(tracks: &[(u16, i16, u16)]) -> TracksLine {
        let mut l = TracksLine {
            seq: 7,
            centre_sample: 123_456,
            ..TracksLine::default()
        };
        for &(id, az, c) in tracks {
            l.tracks
                .push(WireTrack {
                    id,
                    azimuth_tenths: az,
                    confidence_permille: c,
                })
                .unwrap();
        }
        l
    }

    fn encoded(l: &TracksLine) -> Vec<u8> {
        let mut buf = heapless::Vec::<u8, MAX_TRK_LINE>::new();
        encode_tracks(l, &mut buf);
        buf[..].to_vec()
    }

    #[test]
    fn a_known_line_byte_for_byte() {
        let l = line_of(&[(1, 305, 812), (4, -1200, 97)]);
        let bytes = encoded(&l);
        let text = core::str::from_utf8(&bytes).unwrap();
        assert!(
            text.starts_with("$TRK,1,7,123456,2,1,305,812,4,-1200,97*"),
            "{text}"
        );
        assert!(text.ends_with("\r\n"));
        assert_eq!(decode_tracks(&bytes), Ok(l.clone()));
        assert_eq!(decode_line(&bytes), Ok(Line::Tracks(l)));
        let empty = line_of(&[]);
        assert_eq!(decode_tracks(&encoded(&empty)), Ok(empty));
        const { assert!(MAX_TRK_LINE <= MAX_ANY_LINE) };
    }

    #[test]
    fn the_other_decoders_name_the_track_line() {
        let bytes = encoded(&line_of(&[(2, 0, 500)]));
        assert_eq!(decode(&bytes), Err(DecodeError::TracksLine));
        assert_eq!(decode_calibration(&bytes), Err(DecodeError::TracksLine));
        assert_eq!(
            decode_tracks(b"$CMA,1*0000\r\n"),
            Err(DecodeError::FrameLine)
        );
    }

    #[test]
    fn bad_lines_are_rejected_with_their_reason() {
        let with_crc = |payload: &str| {
            let crc = crate::wire::crc16(payload.as_bytes());
            std::format!("${payload}*{crc:04X}\r\n").into_bytes()
        };
        let cases: [(&str, DecodeError); 6] = [
            (
                "TRK,2,0,0,0",
                DecodeError::UnsupportedVersion {
                    expected: 1,
                    got: 2,
                },
            ),
            (
                "TRK,1,0,0,4",
                DecodeError::OutOfRange {
                    field: Field::TrackCount,
                },
            ),
            (
                "TRK,1,0,0,1,5,10",
                DecodeError::FieldCount {
                    expected: 7,
                    got: 6,
                },
            ),
            (
                "TRK,1,0,0,2,5,10,10,5,20,20",
                DecodeError::OutOfRange {
                    field: Field::TrackId { track: 1 },
                },
            ),
            (
                "TRK,1,0,0,1,0,10,10",
                DecodeError::OutOfRange {
                    field: Field::TrackId { track: 0 },
                },
            ),
            (
                "TRK,1,0,0,1,3,1801,10",
                DecodeError::OutOfRange {
                    field: Field::TrackAzimuth { track: 0 },
                },
            ),
        ];
        for (payload, err) in cases {
            assert_eq!(decode_tracks(&with_crc(payload)), Err(err), "{payload}");
        }
    }

    #[test]
    fn active_tracks_only_from_the_core() {
        let t = |id, az: f32, active| TalkerTrack {
            id,
            azimuth_deg: az,
            confidence: 0.5,
            active,
        };
        let l = TracksLine::from_tracks(
            [t(1, 10.0, true), t(2, -170.04, false), t(3, 179.96, true)],
            0,
            0,
        );
        assert_eq!(l.tracks.len(), 2);
        assert_eq!(l.active()[1].id, 3);
        assert_eq!(l.active()[1].azimuth_tenths, 1800);
        assert_eq!(l.active()[0].confidence_permille, 500);
    }

    proptest! {
        #[test]
        fn every_line_round_trips(
            seq in any::<u32>(),
            t in any::<u64>(),
            tracks in proptest::collection::vec((any::<u16>(), any::<i16>(), any::<u16>()), 0..=MAX_TRACKS),
        ) {
            let mut l = TracksLine { seq, centre_sample: t, ..TracksLine::default() };
            for (k, &(id, az, c)) in tracks.iter().enumerate() {
                l.tracks.push(WireTrack {
                    // Distinct and ≥ 1: the encoder does not invent IDs.
                    id: (id % 20_000) + 1 + 20_000 * k as u16,
                    azimuth_tenths: az,
                    confidence_permille: c,
                }).unwrap();
            }
            let bytes = encoded(&l);
            prop_assert!(bytes.len() <= MAX_TRK_LINE);
            let d = decode_tracks(&bytes).unwrap();
            // What decodes is the clamped line.
            prop_assert_eq!(d.tracks.len(), l.tracks.len());
            for (a, b) in d.active().iter().zip(l.active()) {
                prop_assert_eq!(a.id, b.id);
                prop_assert_eq!(a.azimuth_tenths, b.azimuth_tenths.clamp(-1799, 1800));
                prop_assert_eq!(a.confidence_permille, b.confidence_permille.min(1000));
            }
            prop_assert_eq!(encoded(&d), bytes);
        }

        #[test]
        fn arbitrary_bytes_never_panic_and_accepted_lines_are_canonical(
            bytes in proptest::collection::vec(any::<u8>(), 0..120),
            tail in proptest::collection::vec(
                proptest::sample::select(&b"0123456789,-TRK$*\r\n"[..]), 0..60),
        ) {
            for line in [bytes.clone(), [b"$TRK,1,".as_slice(), &tail].concat()] {
                if let Ok(d) = decode_tracks(&line) {
                    let body = line.strip_suffix(b"\n").unwrap_or(&line);
                    let body = body.strip_suffix(b"\r").unwrap_or(body);
                    let e = encoded(&d);
                    prop_assert_eq!(&e[..e.len() - 2], body);
                }
                let _ = decode_line(&line);
            }
        }
    }
}
