//! Owned reference tables on the host: read and write `.cmat` files (format in
//! [`cma_core::table_file`]) and lend them to the core as a [`ReferenceTable`].

use crate::error::{Result, SimError};
use crate::io::wav_io::write_atomically;
use cma_core::reference_table::Feature;
use cma_core::table_file::{self, TableParts};
use cma_core::ReferenceTable;
use std::path::Path;

/// Largest table file read, bytes: far above a 1° grid of 8 000 frequency rows (35 MB).
pub const MAX_TABLE_BYTES: usize = 64 << 20;

/// A reference table that owns its data (the core's [`ReferenceTable`] only borrows).
#[derive(Debug, Clone, PartialEq)]
pub struct OwnedTable {
    /// Q azimuths, degrees, ascending in [0, 360).
    pub azimuths_deg: Vec<f32>,
    /// F frequencies, Hz, ascending.
    pub freqs_hz: Vec<f32>,
    /// F·Q features, frequency-major.
    pub features: Vec<Feature>,
    /// F omni-noise features for magnitude mixing.
    pub noise_magnitude: Vec<Feature>,
    /// F omni-noise features for power mixing.
    pub noise_power: Vec<Feature>,
    /// F·Q active features Re(H_c/H_0), frequency-major.
    pub active: Vec<Feature>,
    /// F omni-noise features of the active ratios.
    pub noise_active: Vec<Feature>,
    /// Rate of the calibration recordings, Hz (0 = unknown).
    pub rate_hz: u32,
}

impl OwnedTable {
    /// Copies a borrowed table.
    #[must_use]
    pub fn from_table(t: &ReferenceTable<'_>) -> Self {
        let f = t.num_freqs();
        Self {
            azimuths_deg: t.azimuths_deg().to_vec(),
            freqs_hz: t.freqs_hz().to_vec(),
            features: t.features().to_vec(),
            noise_magnitude: (0..f).map(|i| t.noise_magnitude(i)).collect(),
            noise_power: (0..f).map(|i| t.noise_power(i)).collect(),
            active: t.active_features().to_vec(),
            noise_active: (0..f).map(|i| t.noise_active(i)).collect(),
            rate_hz: 0,
        }
    }

    /// The table as the core sees it (validated by [`ReferenceTable::new`] and
    /// [`ReferenceTable::with_active`]).
    pub fn as_table(&self) -> Result<ReferenceTable<'_>> {
        ReferenceTable::new(
            &self.azimuths_deg,
            &self.freqs_hz,
            &self.features,
            &self.noise_magnitude,
            &self.noise_power,
        )
        .and_then(|t| t.with_active(&self.active, &self.noise_active))
        .map_err(|source| SimError::Core {
            context: "reference table".into(),
            source,
        })
    }

    /// Encodes the table file.
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        let mut out =
            vec![0u8; table_file::encoded_len(self.azimuths_deg.len(), self.freqs_hz.len())];
        table_file::serialize(
            &TableParts {
                azimuths_deg: &self.azimuths_deg,
                freqs_hz: &self.freqs_hz,
                features: &self.features,
                noise_magnitude: &self.noise_magnitude,
                noise_power: &self.noise_power,
                active: &self.active,
                noise_active: &self.noise_active,
                rate_hz: self.rate_hz,
            },
            &mut out,
        )
        .map_err(|e| SimError::Other(format!("cannot encode reference table: {e}")))?;
        Ok(out)
    }

    /// Decodes a table file (version 1 or 2; a version-1 file's active rows are its magnitude
    /// features and ½, see [`cma_core::table_file`]).
    pub fn from_bytes(bytes: &[u8]) -> std::result::Result<Self, table_file::TableFileError> {
        let v = table_file::parse(bytes)?;
        let (q, f) = (v.num_azimuths(), v.num_freqs());
        let mut t = Self {
            azimuths_deg: vec![0.0; q],
            freqs_hz: vec![0.0; f],
            features: vec![[0.0; 3]; f * q],
            noise_magnitude: vec![[0.0; 3]; f],
            noise_power: vec![[0.0; 3]; f],
            active: vec![[0.0; 3]; f * q],
            noise_active: vec![[0.0; 3]; f],
            rate_hz: v.rate_hz(),
        };
        v.decode_into(
            &mut t.azimuths_deg,
            &mut t.freqs_hz,
            &mut t.features,
            &mut t.noise_magnitude,
            &mut t.noise_power,
        )?;
        v.decode_active_into(&mut t.active, &mut t.noise_active)?;
        Ok(t)
    }

    /// Reads a table file; a bad header, size or checksum is an error naming the file. At most
    /// [`MAX_TABLE_BYTES`] are read, so an endless input (`/dev/zero`) ends with an error.
    pub fn read(path: &Path) -> Result<Self> {
        use std::io::Read;
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(MAX_TABLE_BYTES as u64 + 1).read_to_end(&mut bytes))
            .map_err(|e| SimError::reading(path, e))?;
        if bytes.len() > MAX_TABLE_BYTES {
            return Err(SimError::Other(format!(
                "{}: larger than {} MiB, more than any reference table",
                path.display(),
                MAX_TABLE_BYTES >> 20
            )));
        }
        let t = Self::from_bytes(&bytes)
            .map_err(|e| SimError::Other(format!("{}: {e}", path.display())))?;
        // The core's own checks (Q ≤ MAX_AZIMUTHS etc.) as well.
        t.as_table()
            .map_err(|e| SimError::Other(format!("{}: {e}", path.display())))?;
        Ok(t)
    }

    /// Writes the table file atomically (nothing is left at `path` on failure).
    pub fn write(&self, path: &Path) -> Result<()> {
        let bytes = self.to_bytes()?;
        write_atomically(path, |tmp| {
            std::fs::write(tmp, &bytes).map_err(|e| SimError::io(tmp, e))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cma_core::features::FeatureKind;

    /// A version-1 file (written before the active rows existed) still reads: its active rows are
    /// its magnitude features, its active noise row ½.
    #[test]
    fn version_1_files_still_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v1.cmat");
        let mut t = OwnedTable::from_table(&ReferenceTable::ideal_15deg());
        t.features[3][0] = 0.9;
        t.noise_magnitude = vec![[0.47; 3]];
        t.active = t.features.iter().map(|f| f.map(|v| v - 0.1)).collect();
        t.noise_active = vec![[0.4; 3]];
        // Cut the version-2 file down to version 1: drop the active blocks, rewrite version and CRC.
        let v2 = t.to_bytes().unwrap();
        let len = table_file::encoded_len_of(1, 24, 1);
        let mut v1 = v2[..len].to_vec();
        v1[8..10].copy_from_slice(&1u16.to_le_bytes());
        let crc = table_file::crc32(&v1[..len - 4]);
        v1[len - 4..].copy_from_slice(&crc.to_le_bytes());
        std::fs::write(&path, &v1).unwrap();
        let back = OwnedTable::read(&path).unwrap();
        assert_eq!(back.features, t.features);
        assert_eq!(back.active, t.features);
        assert_eq!(back.noise_active, vec![[0.5; 3]]);
        assert_eq!(back.noise_magnitude, vec![[0.47; 3]]);
        // Written again, it is a version-2 file with the same meaning.
        back.write(&path).unwrap();
        assert_eq!(std::fs::read(&path).unwrap()[8], 2);
        assert_eq!(OwnedTable::read(&path).unwrap(), back);
    }

    #[test]
    fn file_round_trip_and_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.cmat");
        let mut t = OwnedTable::from_table(&ReferenceTable::ideal_15deg());
        t.freqs_hz = vec![500.0, 1000.0];
        t.features = [t.features.clone(), t.features.clone()].concat();
        t.features[30][1] = 0.123;
        t.noise_magnitude = vec![[0.5; 3], [0.45; 3]];
        t.noise_power = vec![[0.6; 3], [0.61; 3]];
        t.active = t.features.iter().map(|f| f.map(|v| v - 0.2)).collect();
        t.noise_active = vec![[0.48; 3], [0.52; 3]];
        t.write(&path).unwrap();
        let back = OwnedTable::read(&path).unwrap();
        assert_eq!(back, t);
        let table = back.as_table().unwrap();
        assert_eq!(table.row(1)[6][1], 0.123);
        assert_eq!(table.rows(FeatureKind::Active).row(1)[6][1], 0.123 - 0.2);
        assert_eq!(table.rows(FeatureKind::Active).noise(1), [0.52; 3]);

        let mut bytes = std::fs::read(&path).unwrap();
        bytes[100] ^= 0x40;
        std::fs::write(&path, &bytes).unwrap();
        let e = OwnedTable::read(&path).unwrap_err().to_string();
        assert!(e.contains("CRC-32") && e.contains("t.cmat"), "{e}");
        std::fs::write(&path, b"RIFF....WAVEfmt not a table at all").unwrap();
        let e = OwnedTable::read(&path).unwrap_err().to_string();
        assert!(e.contains("bad magic"), "{e}");

        // A table the encoder refuses leaves no file behind.
        let out = dir.path().join("bad.cmat");
        let mut bad = t.clone();
        bad.features[0][0] = f32::NAN;
        assert!(bad.write(&out).is_err());
        assert!(!out.exists());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[cfg(unix)]
    #[test]
    fn endless_input_is_bounded() {
        let e = OwnedTable::read(Path::new("/dev/zero"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("larger than 64 MiB"), "{e}");
    }
}
