//! The text file of a saved [`CapsuleEstimate`] (written by `host-sim locate --selfcal-out`, read by
//! `--selfcal-in` and by the firmware's build script, `CMA_SELFCAL=path`): the parser, `no_std` and
//! without allocation, so the host tools and the firmware build read the format with the same rules.
//!
//! ```text
//! # cma self-calibration v2
//! band,f_lo_hz,f_hi_hz,peaks,a0,a1,a2,b0,b1,b2
//! 0,0,500,5321.4,0.4812,0.5304,0.4950,0.5110,0.4620,0.5391
//! …
//! talker_shift,0.0841,-0.0310
//! ```
//!
//! One row per band (edges [`CAL_BAND_EDGES_HZ`](crate::capsule_calibration::CAL_BAND_EDGES_HZ);
//! the last band runs to Nyquist, written as 0): the background peaks behind the estimate, then each
//! cardioid's omni part a_m and dipole part b_m (X_m = a_m·W + b_m·D_m; the ideal cardioid has
//! a = b = 0.5). Every band must appear once; blank lines are ignored, a UTF-8 byte-order mark is
//! allowed; the frequency columns are informative and not checked. Every band must be a plausible
//! cardioid ([`BandModel::is_plausible`]). The optional `talker_shift` row holds
//! [`CapsuleEstimate::talker_shift`] (each component within ±[`MAX_TALKER_SHIFT`]; 0 without the
//! row). Files of version 1 (without that row) are read as before. `held` is not stored (a restored
//! estimate is not held).

use crate::capsule_calibration::{BandModel, CapsuleEstimate, CAL_BANDS, MAX_TALKER_SHIFT};
use core::fmt;

/// First line of the file.
pub const MAGIC: &str = "# cma self-calibration v2";
/// First line of the files of version 1 (no talker's shift), still read.
pub const MAGIC_V1: &str = "# cma self-calibration v1";
/// First field of the row of the talker's shift (`talker_shift,x,y`).
pub const SHIFT_ROW: &str = "talker_shift";
/// Column header (second line).
pub const HEADER: &str = "band,f_lo_hz,f_hi_hz,peaks,a0,a1,a2,b0,b1,b2";
/// Fields of a band row.
pub const ROW_FIELDS: usize = 10;

/// What is wrong with a file ([`ParseError`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ParseErrorKind<'a> {
    /// The first line is not [`MAGIC`].
    NotASelfCalibrationFile,
    /// The second line is not [`HEADER`].
    BadHeader,
    /// A row without [`ROW_FIELDS`] fields.
    FieldCount {
        /// Fields found.
        got: usize,
    },
    /// The band column is not `0…CAL_BANDS − 1`.
    BadBand {
        /// The text of the column.
        text: &'a str,
    },
    /// A band given twice.
    DuplicateBand {
        /// The band.
        band: usize,
    },
    /// A number column is not a finite `f32`.
    NotANumber {
        /// The text of the column.
        text: &'a str,
    },
    /// The row is not a plausible cardioid ([`BandModel::is_plausible`]).
    Implausible,
    /// A band has no row.
    MissingBand {
        /// The band.
        band: usize,
    },
    /// The `talker_shift` row is not `talker_shift,x,y` with plausible numbers.
    BadShift,
    /// The `talker_shift` row given twice.
    DuplicateShift,
}

/// A file that does not parse: where and why.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ParseError<'a> {
    /// Line number, 1-based; 0 when the error concerns the whole file (a missing band).
    pub line: usize,
    /// What is wrong.
    pub kind: ParseErrorKind<'a>,
}

impl fmt::Display for ParseErrorKind<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ParseErrorKind::NotASelfCalibrationFile => write!(
                f,
                "not a self-calibration file: the first line must be `{MAGIC}`"
            ),
            ParseErrorKind::BadHeader => write!(f, "expected the header `{HEADER}`"),
            ParseErrorKind::FieldCount { got } => {
                write!(f, "expected {ROW_FIELDS} fields, got {got}")
            }
            ParseErrorKind::BadBand { text } => {
                write!(f, "band `{text}` is not 0…{}", CAL_BANDS - 1)
            }
            ParseErrorKind::DuplicateBand { band } => write!(f, "band {band} is given twice"),
            ParseErrorKind::NotANumber { text } => write!(f, "`{text}` is not a finite number"),
            ParseErrorKind::Implausible => {
                f.write_str("not a plausible cardioid (need 0.3 < a, b < 0.75 and peaks ≥ 0)")
            }
            ParseErrorKind::MissingBand { band } => write!(f, "band {band} is missing"),
            ParseErrorKind::BadShift => write!(
                f,
                "expected `{SHIFT_ROW},x,y` with finite x and y within ±{MAX_TALKER_SHIFT}"
            ),
            ParseErrorKind::DuplicateShift => write!(f, "`{SHIFT_ROW}` is given twice"),
        }
    }
}

impl fmt::Display for ParseError<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.line > 0 {
            write!(f, "line {}: {}", self.line, self.kind)
        } else {
            self.kind.fmt(f)
        }
    }
}

impl core::error::Error for ParseError<'_> {}

/// Parses the file's text.
pub fn parse(text: &str) -> Result<CapsuleEstimate, ParseError<'_>> {
    let err = |line: usize, kind| ParseError { line, kind };
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate();
    if lines
        .next()
        .is_none_or(|(_, l)| l.trim() != MAGIC && l.trim() != MAGIC_V1)
    {
        return Err(err(1, ParseErrorKind::NotASelfCalibrationFile));
    }
    if lines.next().is_none_or(|(_, l)| l.trim() != HEADER) {
        return Err(err(2, ParseErrorKind::BadHeader));
    }
    let mut est = CapsuleEstimate::IDEAL;
    let mut seen = [false; CAL_BANDS];
    let mut shift_seen = false;
    for (i, line) in lines {
        let n = i + 1;
        if line.trim().is_empty() {
            continue;
        }
        if line.split(',').next().map(str::trim) == Some(SHIFT_ROW) {
            if shift_seen {
                return Err(err(n, ParseErrorKind::DuplicateShift));
            }
            est.talker_shift = parse_shift(line).ok_or(err(n, ParseErrorKind::BadShift))?;
            shift_seen = true;
            continue;
        }
        let mut f = [""; ROW_FIELDS];
        let mut got = 0;
        for (k, field) in line.split(',').enumerate() {
            if let Some(slot) = f.get_mut(k) {
                *slot = field.trim();
            }
            got += 1;
        }
        if got != ROW_FIELDS {
            return Err(err(n, ParseErrorKind::FieldCount { got }));
        }
        let band = f[0]
            .parse::<usize>()
            .ok()
            .filter(|b| *b < CAL_BANDS)
            .ok_or(err(n, ParseErrorKind::BadBand { text: f[0] }))?;
        if seen[band] {
            return Err(err(n, ParseErrorKind::DuplicateBand { band }));
        }
        let mut v = [0f32; 7];
        for (slot, text) in v.iter_mut().zip(&f[3..]) {
            *slot = text
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite() && x.abs() <= f64::from(f32::MAX))
                .ok_or(err(n, ParseErrorKind::NotANumber { text }))? as f32;
        }
        let model = BandModel {
            peaks: v[0],
            omni_part: [v[1], v[2], v[3]],
            dipole_part: [v[4], v[5], v[6]],
        };
        if !model.is_plausible() {
            return Err(err(n, ParseErrorKind::Implausible));
        }
        est.bands[band] = model;
        seen[band] = true;
    }
    if let Some(band) = seen.iter().position(|s| !s) {
        return Err(err(0, ParseErrorKind::MissingBand { band }));
    }
    Ok(est)
}

/// The talker's shift of a `talker_shift,x,y` row, `None` unless it has three fields and a
/// plausible shift.
fn parse_shift(line: &str) -> Option<[f32; 2]> {
    let mut f = line
        .split(',')
        .skip(1)
        .map(|t| t.trim().parse::<f32>().ok());
    let shift = [f.next()??, f.next()??];
    (f.next().is_none() && CapsuleEstimate::is_plausible_talker_shift(shift)).then_some(shift)
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = "# cma self-calibration v1\n\
        band,f_lo_hz,f_hi_hz,peaks,a0,a1,a2,b0,b1,b2\n\
        0,0,500,5321.4,0.4812,0.5304,0.4950,0.5110,0.4620,0.5391\n\
        \n\
        1,500,1000,0.0,0.5,0.5,0.5,0.5,0.5,0.5\n\
        3,2000,0,10,0.5,0.5,0.5,0.5,0.5,0.5\n\
        2,1000,2000,10,0.5,0.5,0.5,0.5,0.5,0.5\n";

    #[test]
    fn parses_a_good_file() {
        let est = parse(GOOD).unwrap();
        assert_eq!(est.bands[0].omni_part, [0.4812, 0.5304, 0.495]);
        assert_eq!(est.bands[0].dipole_part, [0.511, 0.462, 0.5391]);
        assert_eq!(est.bands[0].peaks, 5321.4);
        assert_eq!(est.bands[1], BandModel::IDEAL);
        assert_eq!(est.bands[3].peaks, 10.0);
        assert!(!est.held);
        assert_eq!(est.talker_shift, [0.0; 2]);
        let with_bom = "\u{feff}".to_owned() + GOOD;
        assert_eq!(parse(&with_bom), Ok(est));
    }

    #[test]
    fn version_2_adds_the_talkers_shift() {
        let v2 = GOOD.replacen("v1", "v2", 1) + "talker_shift,0.0841,-0.031\n";
        let est = parse(&v2).unwrap();
        assert_eq!(est.talker_shift, [0.0841, -0.031]);
        assert_eq!(est.bands, parse(GOOD).unwrap().bands);
        let e = |row: &str| error(&(GOOD.replacen("v1", "v2", 1) + row));
        let bad = "line 8: expected `talker_shift,x,y` with finite x and y within ±0.5";
        assert_eq!(e("talker_shift,0.6,0\n"), bad);
        assert_eq!(e("talker_shift,NaN,0\n"), bad);
        assert_eq!(e("talker_shift,0.1\n"), bad);
        assert_eq!(e("talker_shift,0.1,0,0\n"), bad);
        assert_eq!(
            e("talker_shift,0,0\ntalker_shift,0,0\n"),
            "line 9: `talker_shift` is given twice"
        );
    }

    extern crate std;
    use std::borrow::ToOwned;
    use std::string::{String, ToString};

    fn error(text: &str) -> String {
        parse(text).unwrap_err().to_string()
    }

    #[test]
    fn every_error_names_line_and_reason() {
        assert!(error("hello\n").starts_with("line 1: not a self-calibration file"));
        assert!(
            error("# cma self-calibration v1\nband\n").starts_with("line 2: expected the header")
        );
        let e = |from: &str, to: &str| error(&GOOD.replacen(from, to, 1));
        assert_eq!(e("0.4812", "NaN"), "line 3: `NaN` is not a finite number");
        assert_eq!(e("0.4812", "1e39"), "line 3: `1e39` is not a finite number");
        assert_eq!(
            e("0.4812", "7"),
            "line 3: not a plausible cardioid (need 0.3 < a, b < 0.75 and peaks ≥ 0)"
        );
        assert_eq!(e("5321.4", "-1"), e("0.4812", "7"));
        assert_eq!(
            e("0.5391", "0.5391,9"),
            "line 3: expected 10 fields, got 11"
        );
        assert_eq!(e("3,2000", "4,2000"), "line 6: band `4` is not 0…3");
        assert_eq!(e("3,2000", "2,2000"), "line 7: band 2 is given twice");
        let missing: String = GOOD.lines().take(5).map(|l| l.to_owned() + "\n").collect();
        assert_eq!(error(&missing), "band 2 is missing");
    }
}
