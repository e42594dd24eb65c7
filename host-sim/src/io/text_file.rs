//! Reading the small text files the tool takes (estimate CSVs, truth tracks, manifests): read once
//! (a pipe works), bounded in size, a UTF-8 byte-order mark at the start accepted and dropped.

use crate::error::{Result, SimError};
use std::io::Read;
use std::path::Path;

/// Largest text file read, bytes (an hour of estimates at 60 rows per second is about 15 MB).
pub const MAX_TEXT_BYTES: u64 = 256 << 20;

/// The UTF-8 byte-order mark some editors and spreadsheet programs put at the start of a file.
const BOM: &str = "\u{feff}";

/// Reads a UTF-8 text file of at most [`MAX_TEXT_BYTES`], without a leading byte-order mark.
pub fn read(path: &Path) -> Result<String> {
    decode(read_bytes(path, MAX_TEXT_BYTES)?, path)
}

/// Reads a file of at most `max` bytes once (a pipe works); larger files are an error.
pub fn read_bytes(path: &Path, max: u64) -> Result<Vec<u8>> {
    let file = std::fs::File::open(path).map_err(|e| SimError::reading(path, e))?;
    let mut bytes = Vec::new();
    file.take(max + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| SimError::reading(path, e))?;
    if bytes.len() as u64 > max {
        return Err(SimError::Other(format!(
            "{}: larger than {}, not a file this tool reads here",
            path.display(),
            if max >= 1 << 20 {
                format!("{} MiB", max >> 20)
            } else {
                format!("{} KiB", max >> 10)
            }
        )));
    }
    Ok(bytes)
}

/// The UTF-8 text of `bytes` (read from `path`, which errors name), without a leading byte-order
/// mark.
pub fn decode(bytes: Vec<u8>, path: &Path) -> Result<String> {
    let text = String::from_utf8(bytes).map_err(|e| {
        let line = 1 + e.as_bytes()[..e.utf8_error().valid_up_to()]
            .iter()
            .filter(|b| **b == b'\n')
            .count();
        SimError::BadCsv {
            path: path.to_path_buf(),
            line,
            reason: "not UTF-8 text".into(),
        }
    })?;
    Ok(match text.strip_prefix(BOM) {
        Some(rest) => rest.to_string(),
        None => text,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn byte_order_mark_is_dropped_and_bad_bytes_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.csv");
        std::fs::write(&p, "\u{feff}t_s,x\n1,2\n").unwrap();
        assert_eq!(read(&p).unwrap(), "t_s,x\n1,2\n");
        std::fs::write(&p, b"t_s,x\n1,\xff\n").unwrap();
        let e = read(&p).unwrap_err().to_string();
        assert!(e.contains("a.csv:2: not UTF-8"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn endless_input_is_bounded() {
        let e = read(Path::new("/dev/zero")).unwrap_err().to_string();
        assert!(e.contains("larger than 256 MiB"), "{e}");
    }
}
