//! A saved [`CapsuleEstimate`] as a fixed-size binary record: what the firmware appends to its
//! estimate store in flash (`cma_firmware::estimate_store`) and what `host-sim --selfcal-in`
//! reads from a dump of that flash. Exact: every value is stored as its `f32` bits, so an estimate
//! restored from a record is the estimate that was saved, bit for bit.
//!
//! | bytes   | field                                                                       |
//! |---------|-----------------------------------------------------------------------------|
//! | 0–3     | magic [`MAGIC`] (`"CMAS"`)                                                  |
//! | 4–5     | format version [`VERSION`], u16                                             |
//! | 6–7     | record length [`RECORD_LEN`], u16                                           |
//! | 8–11    | sequence number, u32 (the newest record has the highest)                    |
//! | 12–15   | key, u32: [`key_of`] the estimate the board was built to start from          |
//! | 16–127  | per band (lowest first): a0 a1 a2 b0 b1 b2 peaks, f32 each                  |
//! | 128–135 | the talker's shift x, y ([`CapsuleEstimate::talker_shift`]), f32 each        |
//! | 136–139 | CRC-32 (IEEE 802.3, as zlib's `crc32`) of bytes 0–135                       |
//! | 140–143 | zero                                                                        |
//!
//! All numbers little-endian. Records of version 1 (no talker's shift: the CRC at 128–131 covers
//! bytes 0–127) are still read, with a shift of 0. `held` is not stored (a restored estimate is
//! not held). A record
//! whose bytes are all `0xFF` is erased flash ([`RecordError::Erased`]); any other record that fails
//! a check was torn by a power cut or is not a record, and is skipped.

use crate::capsule_calibration::{BandModel, CapsuleEstimate, CAL_BANDS};
use crate::CARDIOIDS;
use core::fmt;

/// The records' checksum: the table file's CRC-32 (IEEE 802.3, as zlib's `crc32`).
pub use super::table_file::crc32;
use super::table_file::crc32_update;

/// Bytes of a record (a multiple of 16, the flash write unit of every supported board).
pub const RECORD_LEN: usize = 144;
/// First four bytes of a record.
pub const MAGIC: [u8; 4] = *b"CMAS";
/// Format version.
pub const VERSION: u16 = 2;
/// The version before the talker's shift was stored, still read.
pub const VERSION_1: u16 = 1;
/// Offset of the per-band values.
const VALUES_AT: usize = 16;
/// Values per band: three omni parts, three dipole parts, the count of peaks.
const BAND_VALUES: usize = 2 * CARDIOIDS + 1;
/// Offset of the talker's shift (and of a version 1 record's CRC).
const SHIFT_AT: usize = VALUES_AT + 4 * BAND_VALUES * CAL_BANDS;
/// Offset of the CRC (the end of the checked bytes).
const CRC_AT: usize = SHIFT_AT + 8;

const _: () = assert!(CRC_AT + 4 <= RECORD_LEN && RECORD_LEN.is_multiple_of(16));

/// A decoded record.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Record {
    /// Sequence number: the newest record has the highest.
    pub sequence: u32,
    /// [`key_of`] the starting estimate of the build that wrote it.
    pub key: u32,
    /// The saved estimate (`held` false).
    pub estimate: CapsuleEstimate,
}

/// Why bytes are not a usable record.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RecordError {
    /// Every byte is `0xFF`: erased flash, no record was ever written here.
    Erased,
    /// The magic, version or length is not this format's.
    NotARecord,
    /// The CRC does not match: the write was cut short or the bytes were damaged.
    Checksum,
    /// The values are not a plausible capsule model ([`BandModel::is_plausible`],
    /// [`CapsuleEstimate::is_plausible_talker_shift`]).
    Implausible,
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Erased => "erased (no record)",
            Self::NotARecord => "not a self-calibration record (magic, version or length)",
            Self::Checksum => "checksum mismatch (a cut-short write or damaged bytes)",
            Self::Implausible => "values are not a plausible capsule model",
        })
    }
}

impl core::error::Error for RecordError {}

/// The per-band values of `estimate` in record order.
fn values(estimate: &CapsuleEstimate) -> impl Iterator<Item = f32> + '_ {
    estimate.bands.iter().flat_map(|b| {
        b.omni_part
            .iter()
            .chain(&b.dipole_part)
            .copied()
            .chain(core::iter::once(b.peaks))
    })
}

/// The key of a build's starting estimate: the CRC-32 of its bands' values (counts of peaks
/// included; not the talker's shift, so that stores written before it was saved keep theirs). A
/// store keeps records only for the starting estimate they were learned from, so building the
/// firmware with another one (`CMA_SELFCAL`) starts afresh from it.
#[must_use]
pub fn key_of(estimate: &CapsuleEstimate) -> u32 {
    !values(estimate).fold(!0, |crc, v| crc32_update(crc, &v.to_le_bytes()))
}

/// The record of `estimate` with `sequence` and `key`.
#[must_use]
pub fn encode(estimate: &CapsuleEstimate, sequence: u32, key: u32) -> [u8; RECORD_LEN] {
    let mut r = [0u8; RECORD_LEN];
    r[0..4].copy_from_slice(&MAGIC);
    r[4..6].copy_from_slice(&VERSION.to_le_bytes());
    r[6..8].copy_from_slice(&(RECORD_LEN as u16).to_le_bytes());
    r[8..12].copy_from_slice(&sequence.to_le_bytes());
    r[12..16].copy_from_slice(&key.to_le_bytes());
    for (slot, v) in r[VALUES_AT..SHIFT_AT]
        .chunks_exact_mut(4)
        .zip(values(estimate))
    {
        slot.copy_from_slice(&v.to_le_bytes());
    }
    r[SHIFT_AT..SHIFT_AT + 4].copy_from_slice(&estimate.talker_shift[0].to_le_bytes());
    r[SHIFT_AT + 4..CRC_AT].copy_from_slice(&estimate.talker_shift[1].to_le_bytes());
    let crc = crc32(&r[..CRC_AT]);
    r[CRC_AT..CRC_AT + 4].copy_from_slice(&crc.to_le_bytes());
    r
}

/// Reads a little-endian u32 at `at` of a record.
fn u32_at(bytes: &[u8; RECORD_LEN], at: usize) -> u32 {
    u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}

/// Decodes a record.
///
/// # Errors
/// [`RecordError`]: erased bytes, not this format, a bad checksum or implausible values.
pub fn decode(bytes: &[u8; RECORD_LEN]) -> Result<Record, RecordError> {
    if bytes.iter().all(|&b| b == 0xFF) {
        return Err(RecordError::Erased);
    }
    let version = u16::from_le_bytes([bytes[4], bytes[5]]);
    let crc_at = match version {
        VERSION => CRC_AT,
        VERSION_1 => SHIFT_AT,
        _ => return Err(RecordError::NotARecord),
    };
    if bytes[0..4] != MAGIC || bytes[6..8] != (RECORD_LEN as u16).to_le_bytes() {
        return Err(RecordError::NotARecord);
    }
    if crc32(&bytes[..crc_at]) != u32_at(bytes, crc_at) {
        return Err(RecordError::Checksum);
    }
    let mut estimate = CapsuleEstimate::IDEAL;
    if version == VERSION {
        let v = |i: usize| f32::from_bits(u32_at(bytes, SHIFT_AT + 4 * i));
        estimate.talker_shift = [v(0), v(1)];
        if !CapsuleEstimate::is_plausible_talker_shift(estimate.talker_shift) {
            return Err(RecordError::Implausible);
        }
    }
    for (band, model) in estimate.bands.iter_mut().enumerate() {
        let at = VALUES_AT + 4 * BAND_VALUES * band;
        let v = |i: usize| f32::from_bits(u32_at(bytes, at + 4 * i));
        *model = BandModel {
            omni_part: [v(0), v(1), v(2)],
            dipole_part: [v(3), v(4), v(5)],
            peaks: v(6),
        };
        if !model.is_plausible() {
            return Err(RecordError::Implausible);
        }
    }
    Ok(Record {
        sequence: u32_at(bytes, 8),
        key: u32_at(bytes, 12),
        estimate,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn learned() -> CapsuleEstimate {
        let mut e = CapsuleEstimate::IDEAL;
        for (i, b) in e.bands.iter_mut().enumerate() {
            b.omni_part = [0.48 + 0.01 * i as f32, 0.53, 0.4951];
            b.dipole_part = [0.511, 0.462, 0.539_123_4];
            b.peaks = 5321.4 + i as f32;
        }
        e.talker_shift = [0.084_1, -0.031];
        e
    }

    #[test]
    fn crc32_is_zlibs() {
        // zlib.crc32(b"123456789") == 0xCBF43926
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
        assert_eq!(crc32(b""), 0);
    }

    #[test]
    fn a_record_round_trips_bit_for_bit() {
        let e = learned();
        let r = decode(&encode(&e, 7, 0xDEAD_BEEF)).unwrap();
        assert_eq!(r.sequence, 7);
        assert_eq!(r.key, 0xDEAD_BEEF);
        assert_eq!(r.estimate, e);
        let mut held = e;
        held.held = true;
        assert_eq!(decode(&encode(&held, 0, 0)).unwrap().estimate, e);
    }

    #[test]
    fn every_damaged_byte_is_caught() {
        let good = encode(&learned(), 3, 9);
        for i in 0..CRC_AT + 4 {
            for flip in [0x01u8, 0x80] {
                let mut bad = good;
                bad[i] ^= flip;
                assert!(decode(&bad).is_err(), "byte {i} flip {flip:#x} accepted");
            }
        }
        assert_eq!(decode(&[0xFF; RECORD_LEN]), Err(RecordError::Erased));
        assert_eq!(decode(&[0; RECORD_LEN]), Err(RecordError::NotARecord));
        // A write cut short after the first 16-byte chunk: the rest is still erased.
        let mut torn = [0xFF; RECORD_LEN];
        torn[..16].copy_from_slice(&good[..16]);
        assert_eq!(decode(&torn), Err(RecordError::Checksum));
    }

    #[test]
    fn implausible_values_are_refused_even_with_a_good_checksum() {
        let mut e = learned();
        e.bands[2].dipole_part[1] = f32::NAN;
        assert_eq!(decode(&encode(&e, 0, 0)), Err(RecordError::Implausible));
        let mut e = learned();
        e.bands[0].omni_part[0] = 0.9;
        assert_eq!(decode(&encode(&e, 0, 0)), Err(RecordError::Implausible));
        let mut e = learned();
        e.talker_shift[1] = 0.6;
        assert_eq!(decode(&encode(&e, 0, 0)), Err(RecordError::Implausible));
    }

    #[test]
    fn a_version_1_record_reads_with_no_talkers_shift() {
        // As the firmware wrote it before the shift was stored: the CRC right after the bands.
        let mut r = encode(&learned(), 5, 11);
        r[4..6].copy_from_slice(&VERSION_1.to_le_bytes());
        let crc = crc32(&r[..SHIFT_AT]);
        r[SHIFT_AT..SHIFT_AT + 4].copy_from_slice(&crc.to_le_bytes());
        r[SHIFT_AT + 4..].fill(0);
        let got = decode(&r).unwrap();
        assert_eq!((got.sequence, got.key), (5, 11));
        assert_eq!(got.estimate.bands, learned().bands);
        assert_eq!(got.estimate.talker_shift, [0.0; 2]);
        // Its CRC at the version 2 place is not a version 2 record.
        r[4..6].copy_from_slice(&VERSION.to_le_bytes());
        assert_eq!(decode(&r), Err(RecordError::Checksum));
    }

    #[test]
    fn the_key_tells_starting_estimates_apart() {
        assert_eq!(key_of(&learned()), key_of(&learned()));
        assert_ne!(key_of(&learned()), key_of(&CapsuleEstimate::IDEAL));
        let mut e = learned();
        e.bands[3].peaks += 1.0;
        assert_ne!(key_of(&e), key_of(&learned()));
        // The talker's shift is not part of the key.
        let mut e = learned();
        e.talker_shift = [0.0; 2];
        assert_eq!(key_of(&e), key_of(&learned()));
    }
}
