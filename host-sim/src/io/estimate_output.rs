//! How estimates leave the tool: the output formats of `locate` and `monitor` (CSV or JSON lines),
//! the names of the status flags, and the one-line summary `locate` ends with.
//!
//! Flags are written the same way everywhere a person or a script reads them: as the decimal value
//! of the bit set (`flags` column of the CSV, `"flags"` of a JSON line, `flags=` of `monitor
//! --plain`), with the names of the set bits beside it where there is room. The wire line itself
//! carries them in hexadecimal, like its other fields ([`cma_core::wire`]); the decoder converts.

use crate::io::fixed_decimal::write_fixed;
use crate::localization::frame_estimates::Row;
use cma_core::Flags;
use std::io::Write;

/// Output format of the estimates of `locate` and `monitor`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Comma-separated values with a header line (`frame,t_s,azimuth_deg,…,flags`).
    #[default]
    Csv,
    /// One JSON object per line, the CSV's columns as keys plus `flag_names`.
    Jsonl,
}

/// The status flags with their names, lowest bit first.
pub const FLAG_NAMES: [(Flags, &str); 5] = [
    (Flags::SILENT, "SILENT"),
    (Flags::CLIPPED, "CLIPPED"),
    (Flags::NON_FINITE, "NON_FINITE"),
    (Flags::NO_PEAKS, "NO_PEAKS"),
    (Flags::NO_HISTORY, "NO_HISTORY"),
];

/// What the flags mean, for `--help` texts.
pub const FLAGS_HELP: &str = "flags is the decimal sum of: 1 SILENT (omni below the silence \
threshold), 2 CLIPPED, 4 NON_FINITE (NaN/Inf samples replaced by 0), 8 NO_PEAKS (no usable \
spectral peak), 16 NO_HISTORY (no reliable frame seen yet: nothing is tracked, the azimuth is the frame's own \
untracked estimate, as azimuth_raw_deg, and the confidence 0; normal for the first frames of a \
recording)";

/// Names of the set flags, e.g. `["CLIPPED", "NO_HISTORY"]`.
#[must_use]
pub fn flag_names(flags: Flags) -> Vec<&'static str> {
    FLAG_NAMES
        .iter()
        .filter(|(f, _)| flags.contains(*f))
        .map(|(_, n)| *n)
        .collect()
}

/// Writes rows as JSON lines: the columns of [`crate::localization::frame_estimates::CSV_HEADER`] as keys, numbers formatted
/// as in the CSV, plus `flag_names`.
pub fn write_jsonl(mut out: impl Write, rows: &[Row]) -> std::io::Result<()> {
    for r in rows {
        let e = &r.estimate;
        let db = 10.0 * (e.power.max(1e-30) as f64).log10();
        write!(out, "{{\"frame\":{},\"t_s\":", e.frame_index)?;
        write_fixed(&mut out, r.t_s, 6)?;
        out.write_all(b",\"azimuth_deg\":")?;
        write_fixed(&mut out, f64::from(e.azimuth_deg), 2)?;
        out.write_all(b",\"azimuth_raw_deg\":")?;
        write_fixed(&mut out, f64::from(e.azimuth_raw_deg), 2)?;
        out.write_all(b",\"confidence\":")?;
        write_fixed(&mut out, f64::from(e.confidence), 4)?;
        out.write_all(b",\"power_db\":")?;
        write_fixed(&mut out, db, 1)?;
        write!(out, ",\"flags\":{},\"flag_names\":[", e.flags.0)?;
        for (i, n) in flag_names(e.flags).iter().enumerate() {
            write!(out, "{}\"{n}\"", if i == 0 { "" } else { "," })?;
        }
        out.write_all(b"]}\n")?;
    }
    out.flush()
}

/// What a run of the localizer produced, for the line `locate` ends with on stderr.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Summary {
    /// Analysis frames (rows).
    pub frames: usize,
    /// Frames whose estimate had been informed by a reliable frame (no `NO_HISTORY`).
    pub with_history: usize,
    /// Leading frames with `NO_HISTORY` before the first frame with history.
    pub leading_without_history: usize,
    /// Frames with NaN or infinite input samples (`NON_FINITE`).
    pub non_finite: usize,
    /// Mean confidence over all frames.
    pub mean_confidence: f64,
    /// Duration of the input, s.
    pub audio_s: f64,
    /// Wall-clock time of the run, s.
    pub elapsed_s: f64,
}

impl Summary {
    /// Counts `rows` of a recording of `audio_s` seconds processed in `elapsed_s`.
    #[must_use]
    pub fn of(rows: &[Row], audio_s: f64, elapsed_s: f64) -> Self {
        let no_history = |r: &Row| r.estimate.flags.contains(Flags::NO_HISTORY);
        let sum: f64 = rows.iter().map(|r| f64::from(r.estimate.confidence)).sum();
        Self {
            frames: rows.len(),
            with_history: rows.iter().filter(|r| !no_history(r)).count(),
            leading_without_history: rows.iter().take_while(|r| no_history(r)).count(),
            non_finite: rows
                .iter()
                .filter(|r| r.estimate.flags.contains(Flags::NON_FINITE))
                .count(),
            mean_confidence: if rows.is_empty() {
                0.0
            } else {
                sum / rows.len() as f64
            },
            audio_s,
            elapsed_s,
        }
    }

    /// Share of the frames with non-finite input, %.
    fn non_finite_percent(&self) -> f64 {
        if self.frames == 0 {
            0.0
        } else {
            100.0 * self.non_finite as f64 / self.frames as f64
        }
    }

    /// The warning line (no newline) when some frames had NaN or infinite input samples.
    #[must_use]
    pub fn non_finite_warning(&self) -> Option<String> {
        (self.non_finite > 0).then(|| {
            format!(
                "locate: warning: {} of {} frames ({:.1} %) had NaN or infinite input samples \
                 (flag 4 NON_FINITE; replaced by 0): their estimates say little about the input",
                self.non_finite,
                self.frames,
                self.non_finite_percent()
            )
        })
    }

    /// The summary as one line (no newline).
    #[must_use]
    pub fn line(&self) -> String {
        let share = if self.frames == 0 {
            0.0
        } else {
            100.0 * self.with_history as f64 / self.frames as f64
        };
        let mut s = format!(
            "locate: {} frames from {:.2} s of audio in {:.2} s; {} with history ({share:.1} %), \
             mean confidence {:.3}",
            self.frames, self.audio_s, self.elapsed_s, self.with_history, self.mean_confidence
        );
        let carry = match self.leading_without_history {
            0 => None,
            1 => Some("the first frame carries".to_string()),
            n => Some(format!("the first {n} carry")),
        };
        if self.non_finite > 0 {
            s.push_str(&format!(
                "; {} NON_FINITE (flags 4, {:.1} %): NaN/Inf input replaced by 0",
                self.non_finite,
                self.non_finite_percent()
            ));
        }
        if let Some(carry) = carry {
            s.push_str(&format!(
                "; {carry} NO_HISTORY (flags 16): no reliable frame yet, azimuth is the \
                 frame's own untracked estimate (= azimuth_raw_deg), confidence 0"
            ));
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cma_core::Estimate;

    fn row(frame: u32, confidence: f32, flags: Flags) -> Row {
        Row {
            t_s: f64::from(frame) * 0.016,
            estimate: Estimate {
                frame_index: frame,
                azimuth_deg: -12.345,
                azimuth_raw_deg: 170.0,
                confidence,
                power: 0.01,
                flags,
                ..Estimate::default()
            },
        }
    }

    #[test]
    fn json_lines_carry_the_csv_values_and_flag_names() {
        let rows = [
            row(0, 0.0, Flags(Flags::NO_HISTORY.0 | Flags::CLIPPED.0)),
            row(1, 0.5, Flags(0)),
        ];
        let mut out = Vec::new();
        write_jsonl(&mut out, &rows).unwrap();
        let text = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[0],
            "{\"frame\":0,\"t_s\":0.000000,\"azimuth_deg\":-12.35,\"azimuth_raw_deg\":170.00,\
             \"confidence\":0.0000,\"power_db\":-20.0,\"flags\":18,\
             \"flag_names\":[\"CLIPPED\",\"NO_HISTORY\"]}"
        );
        for l in lines {
            let v: serde_json::Value = serde_json::from_str(l).unwrap();
            assert!(v["azimuth_deg"].is_number(), "{l}");
        }
    }

    #[test]
    fn summary_counts_frames_without_history() {
        let rows = [
            row(0, 0.0, Flags::NO_HISTORY),
            row(1, 0.0, Flags::NO_HISTORY),
            row(2, 0.6, Flags(0)),
            row(3, 0.0, Flags::SILENT),
        ];
        let s = Summary::of(&rows, 1.0, 0.5);
        assert_eq!(
            (s.frames, s.with_history, s.leading_without_history),
            (4, 2, 2)
        );
        assert!((s.mean_confidence - 0.15).abs() < 1e-6);
        let line = s.line();
        assert!(line.contains("2 with history (50.0 %)"), "{line}");
        assert!(line.contains("the first 2 carry NO_HISTORY"), "{line}");
        assert!(!Summary::of(&rows[2..], 1.0, 0.5)
            .line()
            .contains("NO_HISTORY"));
        assert!(
            !line.contains("start value") && line.contains("untracked"),
            "{line}"
        );
        assert_eq!(s.non_finite_warning(), None);
    }

    #[test]
    fn summary_reports_frames_with_non_finite_input() {
        let bad = Flags(Flags::NON_FINITE.0 | Flags::NO_HISTORY.0);
        let rows = [
            row(0, 0.0, bad),
            row(1, 0.0, bad),
            row(2, 0.0, bad),
            row(3, 0.5, Flags(0)),
        ];
        let s = Summary::of(&rows, 1.0, 0.5);
        assert_eq!(s.non_finite, 3);
        let line = s.line();
        assert!(line.contains("3 NON_FINITE (flags 4, 75.0 %)"), "{line}");
        let warning = s.non_finite_warning().unwrap();
        assert!(warning.contains("3 of 4 frames (75.0 %)"), "{warning}");
    }
}
