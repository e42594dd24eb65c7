//! The self-calibration's estimate as a small text file (`--selfcal-out` / `--selfcal-in`), and its
//! one-paragraph summary for the terminal.
//!
//! ```text
//! # cma self-calibration v2
//! band,f_lo_hz,f_hi_hz,peaks,a0,a1,a2,b0,b1,b2
//! 0,0,500,5321.4,0.4812,0.5304,0.4950,0.5110,0.4620,0.5391
//! …
//! talker_shift,0.084100,-0.031000
//! ```
//!
//! One row per band (edges [`CAL_BAND_EDGES_HZ`]; the last band runs to Nyquist, written as 0):
//! the background peaks behind the estimate, then each cardioid's omni part a_m and dipole part b_m
//! (X_m = a_m·W + b_m·D_m; the ideal cardioid has a = b = 0.5; gain g = a + b, pattern β = b/g);
//! then the talker's shift of the omni parts' correction
//! ([`CapsuleEstimate::talker_shift`]). Version 1 files (without it) are read too.
//!
//! The parser is the core's [`cma_core::capsule_estimate_file`], which the firmware's build script
//! uses too (`CMA_SELFCAL=path`), so both read the file with the same rules. [`read()`] also takes
//! an image of the firmware's estimate store ([`cma_core::capsule_estimate_record`]).

use crate::error::{Result, SimError};
use cma_core::capsule_calibration::{CapsuleEstimate, CAL_BAND_EDGES_HZ};
use cma_core::capsule_estimate_file;
use cma_core::capsule_estimate_record::{self, Record, RECORD_LEN};
use std::fmt::Write as _;
use std::path::Path;

pub use cma_core::capsule_estimate_file::{HEADER, MAGIC};

/// Band edges (lo, hi) in Hz; hi = 0 for the open top band.
#[must_use]
pub fn band_edges(band: usize) -> (f32, f32) {
    let lo = if band == 0 {
        0.0
    } else {
        CAL_BAND_EDGES_HZ[band - 1]
    };
    let hi = CAL_BAND_EDGES_HZ.get(band).copied().unwrap_or(0.0);
    (lo, hi)
}

/// The file's text for `est`.
#[must_use]
pub fn format(est: &CapsuleEstimate) -> String {
    let mut s = format!("{MAGIC}\n{HEADER}\n");
    for (i, b) in est.bands.iter().enumerate() {
        let (lo, hi) = band_edges(i);
        let _ = write!(s, "{i},{lo},{hi},{:.1}", b.peaks);
        for v in b.omni_part.iter().chain(&b.dipole_part) {
            let _ = write!(s, ",{v:.6}");
        }
        s.push('\n');
    }
    let [x, y] = est.talker_shift;
    let _ = writeln!(s, "{},{x:.6},{y:.6}", capsule_estimate_file::SHIFT_ROW);
    s
}

/// Parses the file's text; `path` names it in errors.
pub fn parse(text: &str, path: &Path) -> Result<CapsuleEstimate> {
    capsule_estimate_file::parse(text).map_err(|e| SimError::BadCsv {
        path: path.to_path_buf(),
        line: e.line,
        reason: e.kind.to_string(),
    })
}

/// Largest store image read, bytes (the STM32 boards' store is one 128 KB flash sector).
const MAX_STORE_BYTES: u64 = 1 << 20;

/// Reads a file written by [`write()`], or an image of the firmware's estimate store (a dump of
/// its flash sector, or the emulated board's store file): then the newest valid record, exactly as
/// the board saved it.
pub fn read(path: &Path) -> Result<CapsuleEstimate> {
    let bytes = crate::io::text_file::read_bytes(path, MAX_STORE_BYTES)?;
    // A store image starts with a record or with erased flash (0xFF, never UTF-8 text).
    if bytes.starts_with(&capsule_estimate_record::MAGIC) || bytes.first() == Some(&0xFF) {
        return newest_record(&bytes, path).map(|r| r.estimate);
    }
    if bytes.len() > 64 * 1024 {
        return Err(SimError::Usage(format!(
            "{}: {} bytes is too large for a self-calibration file",
            path.display(),
            bytes.len()
        )));
    }
    parse(&crate::io::text_file::decode(bytes, path)?, path)
}

/// The newest valid record of a store image (any build's key: a dump does not say which build
/// runs on the board, and the newest record is the running build's once it has saved one).
pub fn newest_record(image: &[u8], path: &Path) -> Result<Record> {
    image
        .chunks_exact(RECORD_LEN)
        .filter_map(|slot| capsule_estimate_record::decode(slot.try_into().ok()?).ok())
        .max_by_key(|r| r.sequence)
        .ok_or_else(|| {
            SimError::Usage(format!(
                "{}: an estimate store image without a valid record (the board has not saved \
                 an estimate yet)",
                path.display()
            ))
        })
}

/// Writes `est` to `path` (atomically for regular files).
pub fn write(path: &Path, est: &CapsuleEstimate) -> Result<()> {
    check_output(path)?;
    let text = format(est);
    crate::io::wav_io::write_atomically(path, |tmp| {
        std::fs::write(tmp, text.as_bytes()).map_err(|e| SimError::io(tmp, e))
    })
}

/// Refuses `path` as an output when it is an estimate store image (a dump of a board's flash),
/// which the text estimate would replace; call it before the work that ends in [`write()`].
pub fn check_output(path: &Path) -> Result<()> {
    if is_store_image(path) {
        return Err(SimError::Usage(format!(
            "{}: an estimate store image (a dump of a board's flash); the text estimate would \
             replace it: name another file",
            path.display()
        )));
    }
    Ok(())
}

/// Whether `path` is a regular file that starts as a store image does (a record's magic, or erased
/// flash).
fn is_store_image(path: &Path) -> bool {
    use std::io::Read;
    let mut head = [0u8; 4];
    std::fs::metadata(path).is_ok_and(|m| m.is_file())
        && std::fs::File::open(path).is_ok_and(|mut f| f.read_exact(&mut head).is_ok())
        && (head == capsule_estimate_record::MAGIC || head[0] == 0xFF)
}

/// Refuses the estimate-file flags of `given` (flag, whether it was given) when `config`'s
/// self-calibration is off (they would do nothing), before any work.
pub fn check_used(given: &[(&str, bool)], config: &cma_core::LocatorConfig) -> Result<()> {
    if config.capsule_calibration.enabled {
        return Ok(());
    }
    let given: Vec<&str> = given
        .iter()
        .filter_map(|(flag, set)| set.then_some(*flag))
        .collect();
    if given.is_empty() {
        return Ok(());
    }
    Err(SimError::Usage(format!(
        "{}: the self-calibration is off (--selfcal off, the thesis preset, the file or a measured \
         --table); give --selfcal on, or drop {}",
        given.join(", "),
        if given.len() == 1 { "it" } else { "them" },
    )))
}

/// A few lines for the terminal: per band the gains (dB) and patterns β of the three cardioids.
#[must_use]
pub fn summary(est: &CapsuleEstimate, confidence: f32) -> String {
    let mut s = format!(
        "self-calibration: confidence {:.2}{}\n",
        confidence,
        if est.held {
            " (held: the background is not diffuse)"
        } else {
            ""
        }
    );
    for (i, b) in est.bands.iter().enumerate() {
        let (lo, hi) = band_edges(i);
        let range = if hi > 0.0 {
            format!("{lo:>4.0}–{hi:<4.0} Hz")
        } else {
            format!("{lo:>4.0}+      Hz")
        };
        let _ = writeln!(
            s,
            "  {range}  gain dB {:+.2} {:+.2} {:+.2}  β {:.3} {:.3} {:.3}  ({:.0} peaks)",
            b.gain_db(0),
            b.gain_db(1),
            b.gain_db(2),
            b.beta(0),
            b.beta(1),
            b.beta(2),
            b.peaks
        );
    }
    if est.has_talker_shift() {
        let [x, y] = est.talker_shift;
        let _ = writeln!(
            s,
            "  the talker's places add a shift of ({x:+.3}, {y:+.3}) to the omni parts' correction \
             (saved with the estimate)"
        );
    }
    let empty = est.bands.iter().filter(|b| !(b.peaks > 0.0)).count();
    if est.held && empty > 0 {
        let _ = writeln!(
            s,
            "  nothing learned in {empty} of {} bands: their background was not diffuse (a steady \
             noise source from the start?); an estimate learned without it corrects them \
             (--selfcal-in FILE, or the board's stored one)",
            est.bands.len()
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A held estimate with bands that never learned says so and what helps; one that learned in
    /// every band, or is not held, does not.
    #[test]
    fn the_summary_names_bands_a_non_diffuse_background_kept_from_learning() {
        let mut est = CapsuleEstimate::IDEAL;
        est.bands[0].peaks = 648.0;
        est.held = true;
        let text = summary(&est, 0.0);
        assert!(text.contains("nothing learned in 3 of 4 bands"), "{text}");
        assert!(text.contains("--selfcal-in"), "{text}");
        est.held = false;
        assert!(!summary(&est, 0.0).contains("nothing learned"));
        est.held = true;
        for b in &mut est.bands {
            b.peaks = 100.0;
        }
        assert!(!summary(&est, 0.5).contains("nothing learned"));
    }

    #[test]
    fn a_store_image_gives_its_newest_record_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("board.store");
        let mut older = CapsuleEstimate::IDEAL;
        older.bands[1].omni_part = [0.45, 0.52, 0.5];
        let mut newer = older;
        newer.bands[1].dipole_part = [0.123_456_79 + 0.4, 0.47, 0.51];
        // Slot 0 the older record, slot 1 a torn one, slot 2 the newer, the rest erased.
        let mut image = vec![0xFF; 16 * 1024];
        image[..RECORD_LEN].copy_from_slice(&capsule_estimate_record::encode(&older, 4, 7));
        image[RECORD_LEN..RECORD_LEN + 16]
            .copy_from_slice(&capsule_estimate_record::encode(&newer, 6, 7)[..16]);
        image[2 * RECORD_LEN..3 * RECORD_LEN]
            .copy_from_slice(&capsule_estimate_record::encode(&newer, 5, 7));
        std::fs::write(&p, &image).unwrap();
        assert_eq!(read(&p).unwrap(), newer);
        // `--selfcal-out` does not turn it into a text file.
        let e = write(&p, &newer).unwrap_err().to_string();
        assert!(e.contains("store image"), "{e}");
        assert_eq!(std::fs::read(&p).unwrap(), image);
        // An erased store says it has nothing yet.
        std::fs::write(&p, vec![0xFF; 16 * 1024]).unwrap();
        let e = read(&p).unwrap_err().to_string();
        assert!(e.contains("without a valid record"), "{e}");
    }

    #[test]
    fn round_trip_and_errors() {
        let mut est = CapsuleEstimate::IDEAL;
        est.bands[2].omni_part = [0.45, 0.52, 0.5];
        est.bands[2].dipole_part = [0.55, 0.47, 0.51];
        est.bands[2].peaks = 1234.5;
        est.talker_shift = [0.0841, -0.031];
        let p = Path::new("x.selfcal");
        let back = parse(&format(&est), p).unwrap();
        assert_eq!(back.talker_shift, est.talker_shift);
        for (a, b) in back.bands.iter().zip(&est.bands) {
            for m in 0..3 {
                assert!((a.omni_part[m] - b.omni_part[m]).abs() < 1e-6);
                assert!((a.dipole_part[m] - b.dipole_part[m]).abs() < 1e-6);
            }
            assert!((a.peaks - b.peaks).abs() < 0.1);
        }
        let with_bom = format!("\u{feff}{}", format(&est));
        assert!(parse(&with_bom, p).is_ok());
        assert!(parse("hello\n", p).is_err());
        let nan = format(&est).replace("0.450000", "NaN");
        assert!(parse(&nan, p).unwrap_err().to_string().contains("NaN"));
        let missing: String = format(&est)
            .lines()
            .take(4)
            .map(|l| format!("{l}\n"))
            .collect();
        assert!(parse(&missing, p)
            .unwrap_err()
            .to_string()
            .contains("missing"));
        let absurd = format(&est).replace("0.450000", "7");
        assert!(parse(&absurd, p).is_err());
    }
}
