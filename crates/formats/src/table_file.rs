//! Binary reference-table file (`.cmat`): a measured `ReferenceTable` (`cma-localization`) on disk
//! and, through `build.rs` (`CMA_TABLE=path`), in flash.
//!
//! The same module is compiled into the core and, with `#[path]`, into the core's build script, so the
//! host tools (writer), the firmware build (reader) and the tests share one definition of the format.
//! It uses nothing but `core`.
//!
//! # Format, version 2 (all numbers little-endian)
//!
//! | offset | size | field |
//! |---|---|---|
//! | 0 | 8 | magic `b"CMAREFT\0"` |
//! | 8 | 2 | version, `u16` = 2 |
//! | 10 | 2 | flags, `u16`, must be 0 (reserved) |
//! | 12 | 2 | Q, number of azimuths, `u16` |
//! | 14 | 2 | F, number of frequency rows, `u16` |
//! | 16 | 4 | rate of the calibration recordings in Hz, `u32` (informational; 0 = unknown) |
//! | 20 | 4·Q | azimuths, degrees, `f32`, ascending in [0, 360) |
//! | … | 4·F | frequencies, Hz, `f32`, ascending |
//! | … | 12·F·Q | magnitude features \|H_c\|/\|H_0\| (3 × `f32` per entry), frequency-major: entry f·Q + q |
//! | … | 12·F | omni-noise feature for magnitude mixing (3 × `f32` per row) |
//! | … | 12·F | omni-noise feature for power mixing, √ of the power ratio (3 × `f32` per row) |
//! | … | 12·F·Q | active features Re(H_c/H_0), frequency-major (may be negative) |
//! | … | 12·F | omni-noise feature of the active ratios, Re(Σ H_c·H_0*)/Σ\|H_0\|² (3 × `f32` per row) |
//! | end − 4 | 4 | CRC-32 (IEEE 802.3, reflected, as zlib's `crc32`) of all preceding bytes |
//!
//! **Version 1** is the same without the two active blocks. It is still read: its active features
//! are its magnitude features and its active noise row is ½ (the ideal model's value), which is what
//! the core compared active ratios with before version 2 existed. [`serialize`] writes version 2.
//!
//! Values are stored as `f32`, so a file reproduces the calibrated table exactly (no quantisation
//! error). The table is compact because F is small: the calibration stores rows only over the analysis
//! band on a coarse grid (by default 42 rows, 187.5–4031.25 Hz in steps of 93.75 Hz).

/// Feature vector of the three cardioids (the same type as `reference_table::Feature`).
pub type FileFeature = [f32; 3];

/// The file's magic bytes.
pub const MAGIC: [u8; 8] = *b"CMAREFT\0";
/// The format version this module writes (it reads [`VERSION`] and 1).
pub const VERSION: u16 = 2;
/// The active-ratio noise feature of a version-1 file (the ideal model's ½).
pub const V1_NOISE_ACTIVE: FileFeature = [0.5; 3];
/// Size of the fixed header in bytes.
pub const HEADER_LEN: usize = 20;
/// Largest Q a file may hold (a 1° grid; the core's `MAX_AZIMUTHS`).
pub const MAX_FILE_AZIMUTHS: usize = 360;

/// Why a table file was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TableFileError {
    /// The data is shorter than the header or than its header says.
    Truncated {
        /// Bytes the header calls for (or the header size).
        expected: usize,
        /// Bytes present.
        got: usize,
    },
    /// The data is longer than its header says.
    TrailingBytes {
        /// Bytes the header calls for.
        expected: usize,
        /// Bytes present.
        got: usize,
    },
    /// The first 8 bytes are not [`MAGIC`]: not a reference-table file.
    BadMagic,
    /// A version this code does not read.
    UnsupportedVersion {
        /// The version found.
        got: u16,
    },
    /// Reserved flags are set.
    UnsupportedFlags {
        /// The flags found.
        got: u16,
    },
    /// The stored CRC-32 does not match the content: the file is corrupt.
    BadChecksum {
        /// CRC-32 stored in the file.
        stored: u32,
        /// CRC-32 computed over the content.
        computed: u32,
    },
    /// The dimensions are out of range (Q in 3..=360, F ≥ 1).
    BadShape {
        /// Number of azimuths.
        azimuths: usize,
        /// Number of frequency rows.
        freqs: usize,
    },
    /// Azimuths do not ascend within [0, 360), frequencies do not ascend, a magnitude feature is
    /// negative, or a value is not finite; the string says which.
    BadContent(&'static str),
    /// A caller buffer has the wrong length; the string names it.
    BufferSize {
        /// The buffer.
        what: &'static str,
        /// Length needed.
        expected: usize,
        /// Length given.
        got: usize,
    },
}

impl core::fmt::Display for TableFileError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Truncated { expected, got } => write!(
                f,
                "reference-table file truncated: expected {expected} bytes, got {got}"
            ),
            Self::TrailingBytes { expected, got } => write!(
                f,
                "reference-table file has trailing data: expected {expected} bytes, got {got}"
            ),
            Self::BadMagic => write!(
                f,
                "not a reference-table file (bad magic; expected \"CMAREFT\\0\")"
            ),
            Self::UnsupportedVersion { got } => write!(
                f,
                "reference-table file version {got} is not supported (this build reads versions 1 and {VERSION})"
            ),
            Self::UnsupportedFlags { got } => {
                write!(f, "reference-table file has unknown flags {got:#06x}")
            }
            Self::BadChecksum { stored, computed } => write!(
                f,
                "reference-table file is corrupt: CRC-32 stored {stored:#010x}, computed {computed:#010x}"
            ),
            Self::BadShape { azimuths, freqs } => write!(
                f,
                "reference-table file has {azimuths} azimuths and {freqs} frequencies (need 3..=360 and ≥ 1)"
            ),
            Self::BadContent(what) => write!(f, "reference-table file content invalid: {what}"),
            Self::BufferSize {
                what,
                expected,
                got,
            } => write!(f, "buffer `{what}`: expected {expected} entries, got {got}"),
        }
    }
}

impl core::error::Error for TableFileError {}

/// CRC-32 (IEEE 802.3 polynomial, reflected, init and final XOR `0xFFFF_FFFF`, as zlib's
/// `crc32`), bitwise: slow but table-free, which is fine for a file that is checked once and a
/// record written once a minute (the estimate store's records use it too).
#[must_use]
pub fn crc32(bytes: &[u8]) -> u32 {
    !crc32_update(!0, bytes)
}

/// Feeds `bytes` to a running [`crc32`] register (start with `!0`, finish with `!`).
pub(crate) fn crc32_update(mut crc: u32, bytes: &[u8]) -> u32 {
    for b in bytes {
        crc ^= u32::from(*b);
        for _ in 0..8 {
            let mask = (crc & 1).wrapping_neg();
            crc = (crc >> 1) ^ (0xEDB8_8320 & mask);
        }
    }
    crc
}

/// Total size in bytes of a file of the current [`VERSION`] for Q azimuths and F frequency rows.
#[must_use]
pub const fn encoded_len(azimuths: usize, freqs: usize) -> usize {
    encoded_len_of(VERSION, azimuths, freqs)
}

/// Total size in bytes of a file of format `version` (1 or 2) for Q azimuths and F frequency rows.
#[must_use]
pub const fn encoded_len_of(version: u16, azimuths: usize, freqs: usize) -> usize {
    let v1 = HEADER_LEN + 4 * azimuths + 4 * freqs + 12 * freqs * azimuths + 24 * freqs + 4;
    if version >= 2 {
        v1 + 12 * freqs * azimuths + 12 * freqs
    } else {
        v1
    }
}

fn read_u16(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([b[at], b[at + 1]])
}

fn read_u32(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

fn read_f32(b: &[u8], at: usize) -> f32 {
    f32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

/// A validated table file, borrowing its bytes. Values are decoded on access (the bytes need not be
/// aligned), or all at once with [`TableView::decode_into`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TableView<'a> {
    bytes: &'a [u8],
    version: u16,
    azimuths: usize,
    freqs: usize,
    rate_hz: u32,
}

/// Parses and validates a table file: size, magic, version, flags, checksum, shape and content.
pub fn parse(bytes: &[u8]) -> Result<TableView<'_>, TableFileError> {
    if bytes.len() < HEADER_LEN + 4 {
        return Err(TableFileError::Truncated {
            expected: HEADER_LEN + 4,
            got: bytes.len(),
        });
    }
    if bytes[0..8] != MAGIC {
        return Err(TableFileError::BadMagic);
    }
    let version = read_u16(bytes, 8);
    if version != VERSION && version != 1 {
        return Err(TableFileError::UnsupportedVersion { got: version });
    }
    let flags = read_u16(bytes, 10);
    if flags != 0 {
        return Err(TableFileError::UnsupportedFlags { got: flags });
    }
    let q = usize::from(read_u16(bytes, 12));
    let f = usize::from(read_u16(bytes, 14));
    let expected = encoded_len_of(version, q, f);
    if bytes.len() < expected {
        return Err(TableFileError::Truncated {
            expected,
            got: bytes.len(),
        });
    }
    if bytes.len() > expected {
        return Err(TableFileError::TrailingBytes {
            expected,
            got: bytes.len(),
        });
    }
    let stored = read_u32(bytes, expected - 4);
    let computed = crc32(&bytes[..expected - 4]);
    if stored != computed {
        return Err(TableFileError::BadChecksum { stored, computed });
    }
    if !(3..=MAX_FILE_AZIMUTHS).contains(&q) || f == 0 {
        return Err(TableFileError::BadShape {
            azimuths: q,
            freqs: f,
        });
    }
    let view = TableView {
        bytes,
        version,
        azimuths: q,
        freqs: f,
        rate_hz: read_u32(bytes, 16),
    };
    view.validate()?;
    Ok(view)
}

impl TableView<'_> {
    fn off_freqs(&self) -> usize {
        HEADER_LEN + 4 * self.azimuths
    }
    fn off_features(&self) -> usize {
        self.off_freqs() + 4 * self.freqs
    }
    fn off_noise_magnitude(&self) -> usize {
        self.off_features() + 12 * self.freqs * self.azimuths
    }
    fn off_noise_power(&self) -> usize {
        self.off_noise_magnitude() + 12 * self.freqs
    }
    fn off_active(&self) -> usize {
        self.off_noise_power() + 12 * self.freqs
    }
    fn off_noise_active(&self) -> usize {
        self.off_active() + 12 * self.freqs * self.azimuths
    }
    fn feature_at(&self, at: usize) -> FileFeature {
        [
            read_f32(self.bytes, at),
            read_f32(self.bytes, at + 4),
            read_f32(self.bytes, at + 8),
        ]
    }

    fn validate(&self) -> Result<(), TableFileError> {
        let az_ok = (0..self.azimuths).all(|i| {
            let a = self.azimuth_deg(i);
            (0.0..360.0).contains(&a) && (i == 0 || self.azimuth_deg(i - 1) < a)
        });
        if !az_ok {
            return Err(TableFileError::BadContent(
                "azimuths must ascend within [0, 360)",
            ));
        }
        let f_ok = (0..self.freqs).all(|i| {
            let v = self.freq_hz(i);
            v.is_finite() && v >= 0.0 && (i == 0 || self.freq_hz(i - 1) < v)
        });
        if !f_ok {
            return Err(TableFileError::BadContent(
                "frequencies must be finite, non-negative and ascending",
            ));
        }
        let good = |v: FileFeature| v.iter().all(|x| x.is_finite() && *x >= 0.0);
        let feats_ok = (0..self.freqs * self.azimuths).all(|i| good(self.feature(i)))
            && (0..self.freqs).all(|i| good(self.noise_magnitude(i)) && good(self.noise_power(i)));
        if !feats_ok {
            return Err(TableFileError::BadContent(
                "features must be finite and non-negative",
            ));
        }
        let finite = |v: FileFeature| v.iter().all(|x| x.is_finite());
        let active_ok = (0..self.freqs * self.azimuths).all(|i| finite(self.active_feature(i)))
            && (0..self.freqs).all(|i| finite(self.noise_active(i)));
        if !active_ok {
            return Err(TableFileError::BadContent("active features must be finite"));
        }
        Ok(())
    }

    /// Format version of the file (1 or 2).
    #[must_use]
    pub fn version(&self) -> u16 {
        self.version
    }

    /// Whether the file holds measured active rows (version 2); a version-1 file stands in its
    /// magnitude features and ½ for them.
    #[must_use]
    pub fn has_active(&self) -> bool {
        self.version >= 2
    }

    /// Number of azimuths Q.
    #[must_use]
    pub fn num_azimuths(&self) -> usize {
        self.azimuths
    }

    /// Number of frequency rows F.
    #[must_use]
    pub fn num_freqs(&self) -> usize {
        self.freqs
    }

    /// Rate of the calibration recordings, Hz (0 if unknown); informational only.
    #[must_use]
    pub fn rate_hz(&self) -> u32 {
        self.rate_hz
    }

    /// Azimuth `i` in degrees (`i < Q`).
    #[must_use]
    pub fn azimuth_deg(&self, i: usize) -> f32 {
        read_f32(self.bytes, HEADER_LEN + 4 * i)
    }

    /// Frequency of row `i` in Hz (`i < F`).
    #[must_use]
    pub fn freq_hz(&self, i: usize) -> f32 {
        read_f32(self.bytes, self.off_freqs() + 4 * i)
    }

    /// Feature entry `i = f·Q + q` (`i < F·Q`).
    #[must_use]
    pub fn feature(&self, i: usize) -> FileFeature {
        self.feature_at(self.off_features() + 12 * i)
    }

    /// Omni-noise feature of row `i` for magnitude mixing.
    #[must_use]
    pub fn noise_magnitude(&self, i: usize) -> FileFeature {
        self.feature_at(self.off_noise_magnitude() + 12 * i)
    }

    /// Omni-noise feature of row `i` for power mixing.
    #[must_use]
    pub fn noise_power(&self, i: usize) -> FileFeature {
        self.feature_at(self.off_noise_power() + 12 * i)
    }

    /// Active feature entry `i = f·Q + q` (`i < F·Q`): Re(H_c/H_0); the magnitude feature in a
    /// version-1 file.
    #[must_use]
    pub fn active_feature(&self, i: usize) -> FileFeature {
        if self.has_active() {
            self.feature_at(self.off_active() + 12 * i)
        } else {
            self.feature(i)
        }
    }

    /// Omni-noise feature of the active ratios for row `i`; [`V1_NOISE_ACTIVE`] in a version-1 file.
    #[must_use]
    pub fn noise_active(&self, i: usize) -> FileFeature {
        if self.has_active() {
            self.feature_at(self.off_noise_active() + 12 * i)
        } else {
            V1_NOISE_ACTIVE
        }
    }

    /// Decodes the active rows into caller buffers of lengths F·Q and F (checked); for a version-1
    /// file, the magnitude features and ½.
    pub fn decode_active_into(
        &self,
        active: &mut [FileFeature],
        noise_active: &mut [FileFeature],
    ) -> Result<(), TableFileError> {
        let check = |what, expected: usize, got: usize| {
            if expected == got {
                Ok(())
            } else {
                Err(TableFileError::BufferSize {
                    what,
                    expected,
                    got,
                })
            }
        };
        check("active", self.freqs * self.azimuths, active.len())?;
        check("noise_active", self.freqs, noise_active.len())?;
        for (i, v) in active.iter_mut().enumerate() {
            *v = self.active_feature(i);
        }
        for (i, v) in noise_active.iter_mut().enumerate() {
            *v = self.noise_active(i);
        }
        Ok(())
    }

    /// Decodes the magnitude part of the table into caller buffers of lengths Q, F, F·Q, F and F
    /// (checked); the active rows: [`TableView::decode_active_into`].
    pub fn decode_into(
        &self,
        azimuths_deg: &mut [f32],
        freqs_hz: &mut [f32],
        features: &mut [FileFeature],
        noise_magnitude: &mut [FileFeature],
        noise_power: &mut [FileFeature],
    ) -> Result<(), TableFileError> {
        let check = |what, expected: usize, got: usize| {
            if expected == got {
                Ok(())
            } else {
                Err(TableFileError::BufferSize {
                    what,
                    expected,
                    got,
                })
            }
        };
        check("azimuths_deg", self.azimuths, azimuths_deg.len())?;
        check("freqs_hz", self.freqs, freqs_hz.len())?;
        check("features", self.freqs * self.azimuths, features.len())?;
        check("noise_magnitude", self.freqs, noise_magnitude.len())?;
        check("noise_power", self.freqs, noise_power.len())?;
        for (i, a) in azimuths_deg.iter_mut().enumerate() {
            *a = self.azimuth_deg(i);
        }
        for (i, v) in freqs_hz.iter_mut().enumerate() {
            *v = self.freq_hz(i);
        }
        for (i, v) in features.iter_mut().enumerate() {
            *v = self.feature(i);
        }
        for (i, v) in noise_magnitude.iter_mut().enumerate() {
            *v = self.noise_magnitude(i);
        }
        for (i, v) in noise_power.iter_mut().enumerate() {
            *v = self.noise_power(i);
        }
        Ok(())
    }
}

/// The parts of a table to write (the same layout as `ReferenceTable::new` and
/// `ReferenceTable::with_active`).
#[derive(Debug, Clone, Copy)]
pub struct TableParts<'a> {
    /// Q azimuths, degrees, ascending in [0, 360).
    pub azimuths_deg: &'a [f32],
    /// F frequencies, Hz, ascending.
    pub freqs_hz: &'a [f32],
    /// F·Q features, frequency-major.
    pub features: &'a [FileFeature],
    /// F omni-noise features for magnitude mixing.
    pub noise_magnitude: &'a [FileFeature],
    /// F omni-noise features for power mixing.
    pub noise_power: &'a [FileFeature],
    /// F·Q active features Re(H_c/H_0), frequency-major.
    pub active: &'a [FileFeature],
    /// F omni-noise features of the active ratios.
    pub noise_active: &'a [FileFeature],
    /// Rate of the calibration recordings, Hz (0 = unknown).
    pub rate_hz: u32,
}

/// Serialises a table into `out`, which must be exactly [`encoded_len`]`(Q, F)` bytes long. The
/// result is validated as [`parse`] would, so a written file always reads back.
pub fn serialize(parts: &TableParts<'_>, out: &mut [u8]) -> Result<(), TableFileError> {
    let q = parts.azimuths_deg.len();
    let f = parts.freqs_hz.len();
    if !(3..=MAX_FILE_AZIMUTHS).contains(&q) || f == 0 || f > usize::from(u16::MAX) {
        return Err(TableFileError::BadShape {
            azimuths: q,
            freqs: f,
        });
    }
    let shape = [
        ("features", f * q, parts.features.len()),
        ("noise_magnitude", f, parts.noise_magnitude.len()),
        ("noise_power", f, parts.noise_power.len()),
        ("active", f * q, parts.active.len()),
        ("noise_active", f, parts.noise_active.len()),
        ("out", encoded_len(q, f), out.len()),
    ];
    for (what, expected, got) in shape {
        if expected != got {
            return Err(TableFileError::BufferSize {
                what,
                expected,
                got,
            });
        }
    }
    let mut at = 0;
    let mut put = |b: &[u8]| {
        out[at..at + b.len()].copy_from_slice(b);
        at += b.len();
    };
    put(&MAGIC);
    put(&VERSION.to_le_bytes());
    put(&0u16.to_le_bytes());
    // Note: q ≤ 360 and f ≤ u16::MAX were checked above.
    put(&(q as u16).to_le_bytes());
    put(&(f as u16).to_le_bytes());
    put(&parts.rate_hz.to_le_bytes());
    for v in parts.azimuths_deg.iter().chain(parts.freqs_hz) {
        put(&v.to_le_bytes());
    }
    for v in parts
        .features
        .iter()
        .chain(parts.noise_magnitude)
        .chain(parts.noise_power)
        .chain(parts.active)
        .chain(parts.noise_active)
    {
        for x in v {
            put(&x.to_le_bytes());
        }
    }
    let body = encoded_len(q, f) - 4;
    let crc = crc32(&out[..body]);
    out[body..].copy_from_slice(&crc.to_le_bytes());
    parse(out).map(|_| ())
}

#[cfg(test)]
mod tests {
    use super::*;

    const Q: usize = 4;
    const F: usize = 2;
    const LEN: usize = encoded_len(Q, F);

    fn sample() -> [u8; LEN] {
        let az = [0.0, 90.0, 180.0, 270.0];
        let fr = [500.0, 1000.0];
        let mut feats = [[0.0f32; 3]; F * Q];
        for (i, v) in feats.iter_mut().enumerate() {
            *v = [i as f32 * 0.1, 0.5, 1.0 / (i as f32 + 1.0)];
        }
        let nm = [[0.5; 3], [0.4; 3]];
        let np = [[0.6; 3], [0.7; 3]];
        let mut active = [[0.0f32; 3]; F * Q];
        for (i, v) in active.iter_mut().enumerate() {
            *v = [i as f32 * 0.1 - 0.2, 0.45, -1.0 / (i as f32 + 1.0)];
        }
        let na = [[0.52; 3], [0.48; 3]];
        let mut out = [0u8; LEN];
        serialize(
            &TableParts {
                azimuths_deg: &az,
                freqs_hz: &fr,
                features: &feats,
                noise_magnitude: &nm,
                noise_power: &np,
                active: &active,
                noise_active: &na,
                rate_hz: 48_000,
            },
            &mut out,
        )
        .unwrap();
        out
    }

    const LEN_V1: usize = encoded_len_of(1, Q, F);

    /// The version-1 file of the same table: the active blocks cut, the version and CRC rewritten.
    fn sample_v1() -> [u8; LEN_V1] {
        let v2 = sample();
        let mut out = [0u8; LEN_V1];
        out[..LEN_V1 - 4].copy_from_slice(&v2[..LEN_V1 - 4]);
        out[8..10].copy_from_slice(&1u16.to_le_bytes());
        let crc = crc32(&out[..LEN_V1 - 4]);
        out[LEN_V1 - 4..].copy_from_slice(&crc.to_le_bytes());
        out
    }

    #[test]
    fn version_1_files_read_with_magnitudes_as_active_rows() {
        assert_eq!(LEN - LEN_V1, 12 * F * Q + 12 * F);
        let bytes = sample_v1();
        let v = parse(&bytes).unwrap();
        assert_eq!((v.version(), v.has_active()), (1, false));
        let mut active = [[0.0; 3]; F * Q];
        let mut na = [[0.0; 3]; F];
        v.decode_active_into(&mut active, &mut na).unwrap();
        for (i, a) in active.iter().enumerate() {
            assert_eq!(*a, v.feature(i));
        }
        assert_eq!(na, [V1_NOISE_ACTIVE; F]);
        // The same table as version 2 has its own active rows.
        let v2 = sample();
        let v = parse(&v2).unwrap();
        assert_eq!((v.version(), v.has_active()), (2, true));
        v.decode_active_into(&mut active, &mut na).unwrap();
        assert_eq!(active[3], [3.0f32 * 0.1 - 0.2, 0.45, -0.25]);
        assert_eq!(na, [[0.52; 3], [0.48; 3]]);
        // A version-1 length with a version-2 header is truncated, and vice versa trailing.
        let mut b = sample_v1();
        b[8] = 2;
        assert!(matches!(
            parse(&b),
            Err(TableFileError::Truncated { expected, got: LEN_V1 }) if expected == LEN
        ));
        let mut b = sample();
        b[8] = 1;
        assert!(matches!(
            parse(&b),
            Err(TableFileError::TrailingBytes { .. })
        ));
    }

    #[test]
    fn crc_matches_zlib() {
        // zlib.crc32(b"123456789") == 0xCBF43926, the standard check value.
        assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    }

    #[test]
    fn round_trip_is_exact() {
        let bytes = sample();
        let v = parse(&bytes).unwrap();
        assert_eq!(
            (v.num_azimuths(), v.num_freqs(), v.rate_hz()),
            (Q, F, 48_000)
        );
        let mut az = [0.0; Q];
        let mut fr = [0.0; F];
        let mut feats = [[0.0; 3]; F * Q];
        let mut nm = [[0.0; 3]; F];
        let mut np = [[0.0; 3]; F];
        v.decode_into(&mut az, &mut fr, &mut feats, &mut nm, &mut np)
            .unwrap();
        assert_eq!(az, [0.0, 90.0, 180.0, 270.0]);
        assert_eq!(fr, [500.0, 1000.0]);
        assert_eq!(feats[5], [0.5, 0.5, 1.0 / 6.0]);
        assert_eq!(nm[1], [0.4; 3]);
        assert_eq!(np[0], [0.6; 3]);
        let mut short = [0.0; 1];
        assert!(matches!(
            v.decode_into(&mut az, &mut short, &mut feats, &mut nm, &mut np),
            Err(TableFileError::BufferSize {
                what: "freqs_hz",
                ..
            })
        ));
    }

    #[test]
    fn every_header_error_is_reported() {
        let good = sample();
        let mut b = good;
        b[0] = b'X';
        assert_eq!(parse(&b), Err(TableFileError::BadMagic));
        for version in [0u8, 3] {
            let mut b = good;
            b[8] = version;
            assert_eq!(
                parse(&b),
                Err(TableFileError::UnsupportedVersion {
                    got: version.into()
                })
            );
        }
        let mut b = good;
        b[10] = 1;
        assert_eq!(parse(&b), Err(TableFileError::UnsupportedFlags { got: 1 }));
        let mut b = good;
        b[40] ^= 0x01;
        assert!(matches!(parse(&b), Err(TableFileError::BadChecksum { .. })));
        assert_eq!(
            parse(&good[..LEN - 1]),
            Err(TableFileError::Truncated {
                expected: LEN,
                got: LEN - 1
            })
        );
        assert!(matches!(
            parse(&good[..10]),
            Err(TableFileError::Truncated { .. })
        ));
        let mut long = [0u8; LEN + 1];
        long[..LEN].copy_from_slice(&good);
        assert!(matches!(
            parse(&long),
            Err(TableFileError::TrailingBytes { .. })
        ));
    }

    #[test]
    fn serialize_refuses_bad_content() {
        let az = [0.0, 200.0, 100.0];
        let fr = [500.0];
        let feats = [[0.5; 3]; 3];
        let n = [[0.5; 3]];
        let mut out = [0u8; encoded_len(3, 1)];
        let parts = TableParts {
            azimuths_deg: &az,
            freqs_hz: &fr,
            features: &feats,
            noise_magnitude: &n,
            noise_power: &n,
            active: &feats,
            noise_active: &n,
            rate_hz: 0,
        };
        assert!(matches!(
            serialize(&parts, &mut out),
            Err(TableFileError::BadContent(_))
        ));
        let neg = [[-0.5; 3]; 3];
        let az = [0.0, 100.0, 200.0];
        let parts = TableParts {
            azimuths_deg: &az,
            features: &neg,
            ..parts
        };
        assert!(matches!(
            serialize(&parts, &mut out),
            Err(TableFileError::BadContent(_))
        ));
        // Negative active features are valid, non-finite ones are not.
        let parts = TableParts {
            features: &feats,
            active: &neg,
            ..parts
        };
        assert!(serialize(&parts, &mut out).is_ok());
        let inf = [[f32::INFINITY; 3]];
        let parts = TableParts {
            noise_active: &inf,
            ..parts
        };
        assert_eq!(
            serialize(&parts, &mut out),
            Err(TableFileError::BadContent("active features must be finite"))
        );
    }
}
