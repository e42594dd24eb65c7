//! The self-calibration's estimate as a small text file (`--selfcal-out` / `--selfcal-in`), and its
//! one-paragraph summary for the terminal.
//!
//! ```text
//! # cma self-calibration v1
//! band,f_lo_hz,f_hi_hz,peaks,a0,a1,a2,b0,b1,b2
//! 0,0,500,5321.4,0.4812,0.5304,0.4950,0.5110,0.4620,0.5391
//! …
//! ```
//!
//! One row per band (edges [`CAL_BAND_EDGES_HZ`]; the last band runs to Nyquist, written as 0):
//! the background peaks behind the estimate, then each cardioid's omni part a_m and dipole part b_m
//! (X_m = a_m·W + b_m·D_m; the ideal cardioid has a = b = 0.5; gain g = a + b, pattern β = b/g).

use crate::error::{Result, SimError};
use cma_core::capsule_calibration::{BandModel, CapsuleEstimate, CAL_BANDS, CAL_BAND_EDGES_HZ};
use std::fmt::Write as _;
use std::path::Path;

/// First line of the file.
pub const MAGIC: &str = "# cma self-calibration v1";
/// Column header.
pub const HEADER: &str = "band,f_lo_hz,f_hi_hz,peaks,a0,a1,a2,b0,b1,b2";

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
    s
}

/// Parses the file's text; `path` names it in errors.
pub fn parse(text: &str, path: &Path) -> Result<CapsuleEstimate> {
    let bad = |line: usize, reason: String| SimError::BadCsv {
        path: path.to_path_buf(),
        line,
        reason,
    };
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, l)) if l.trim() == MAGIC => {}
        _ => {
            return Err(bad(
                1,
                format!("not a self-calibration file: the first line must be `{MAGIC}`"),
            ))
        }
    }
    match lines.next() {
        Some((_, l)) if l.trim() == HEADER => {}
        _ => return Err(bad(2, format!("expected the header `{HEADER}`"))),
    }
    let mut est = CapsuleEstimate::IDEAL;
    let mut seen = [false; CAL_BANDS];
    for (i, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        if f.len() != 10 {
            return Err(bad(i + 1, format!("expected 10 fields, got {}", f.len())));
        }
        let band: usize = f[0]
            .parse()
            .ok()
            .filter(|b| *b < CAL_BANDS)
            .ok_or_else(|| bad(i + 1, format!("band `{}` is not 0…{}", f[0], CAL_BANDS - 1)))?;
        let mut v = [0f32; 7];
        for (k, slot) in v.iter_mut().enumerate() {
            let text = f[3 + k];
            *slot = text
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite() && x.abs() <= f64::from(f32::MAX))
                .ok_or_else(|| bad(i + 1, format!("`{text}` is not a finite number")))?
                as f32;
        }
        let model = BandModel {
            peaks: v[0],
            omni_part: [v[1], v[2], v[3]],
            dipole_part: [v[4], v[5], v[6]],
        };
        if !model.is_plausible() {
            return Err(bad(
                i + 1,
                "not a plausible cardioid (need 0.3 < a, b < 0.75 and peaks ≥ 0)".into(),
            ));
        }
        est.bands[band] = model;
        seen[band] = true;
    }
    if let Some(missing) = seen.iter().position(|s| !s) {
        return Err(bad(0, format!("band {missing} is missing")));
    }
    Ok(est)
}

/// Reads a file written by [`write()`].
pub fn read(path: &Path) -> Result<CapsuleEstimate> {
    let meta = std::fs::metadata(path).map_err(|e| SimError::io(path, e))?;
    if meta.is_file() && meta.len() > 64 * 1024 {
        return Err(SimError::Usage(format!(
            "{}: {} bytes is too large for a self-calibration file",
            path.display(),
            meta.len()
        )));
    }
    let text = crate::text_file::read(path)?;
    parse(&text, path)
}

/// Writes `est` to `path` (atomically for regular files).
pub fn write(path: &Path, est: &CapsuleEstimate) -> Result<()> {
    let text = format(est);
    crate::wav_io::write_atomically(path, |tmp| {
        std::fs::write(tmp, text.as_bytes()).map_err(|e| SimError::io(tmp, e))
    })
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
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_errors() {
        let mut est = CapsuleEstimate::IDEAL;
        est.bands[2].omni_part = [0.45, 0.52, 0.5];
        est.bands[2].dipole_part = [0.55, 0.47, 0.51];
        est.bands[2].peaks = 1234.5;
        let p = Path::new("x.selfcal");
        let back = parse(&format(&est), p).unwrap();
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
