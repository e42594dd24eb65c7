//! Scoring an estimate CSV (a `monitor --record` of a hardware session, or a `locate --csv`)
//! against a truth track, with the metrics and report of [`crate::evaluation::eval`]: the
//! window scored and the one-scene report.

use crate::error::{Result, SimError};
use crate::evaluation::eval::{self, Report, SceneSummary, SetSummary};
use crate::evaluation::metrics::Metrics;
use crate::io::ground_truth::Track;
use crate::io::manifest::Entry;
use crate::localization::frame_estimates::{self, Row};
use cma_core::Estimate;
use std::path::Path;

/// The interval scored and where it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Window {
    /// Start, s.
    pub from_s: f64,
    /// End, s (infinite: to the end).
    pub to_s: f64,
    /// Where the window came from, for the message.
    pub source: String,
}

/// The scoring window: `from`/`to` if either is given (named `--from`/`--to`), else the manifest
/// entry of the scene of `truth` (a `manifest.csv` in its folder or the one above, as `eval` scores
/// it), else everything.
pub fn window(from: Option<f64>, to: Option<f64>, truth: &Path) -> Result<Window> {
    if from.is_some() || to.is_some() {
        let (from_s, to_s) = (from.unwrap_or(0.0), to.unwrap_or(f64::INFINITY));
        if to_s < from_s {
            return Err(SimError::Usage(format!(
                "need --from ≤ --to, got {from_s} and {to_s}"
            )));
        }
        return Ok(Window {
            from_s,
            to_s,
            source: "--from/--to".into(),
        });
    }
    let truth = std::fs::canonicalize(truth).map_err(|e| SimError::io(truth, e))?;
    for dir in truth.ancestors().skip(1).take(2) {
        if !dir.join("manifest.csv").is_file() {
            continue;
        }
        let entries = crate::io::manifest::read(dir)?;
        let listed = entries
            .into_iter()
            .find(|e| std::fs::canonicalize(e.truth_path(dir)).is_ok_and(|p| p == truth));
        if let Some(e) = listed {
            return Ok(Window {
                from_s: e.score_from_s,
                to_s: e.score_to_s,
                source: format!(
                    "the entry {} of {}, as eval",
                    e.file.display(),
                    dir.join("manifest.csv").display()
                ),
            });
        }
    }
    Ok(Window {
        from_s: f64::NEG_INFINITY,
        to_s: f64::INFINITY,
        source: "all frames: no manifest.csv beside the truth lists its scene; --from/--to choose"
            .into(),
    })
}

/// Scores the estimate CSV `estimates` against the truth track `truth` over `w`; the report has one
/// set, `recorded`.
pub fn report(estimates: &Path, truth: &Path, w: &Window) -> Result<Report> {
    let rows: Vec<Row> = frame_estimates::read_csv(estimates)?
        .into_iter()
        .map(|e| Row {
            t_s: e.t_s,
            estimate: Estimate {
                azimuth_deg: e.azimuth_deg as f32,
                azimuth_raw_deg: e.azimuth_raw_deg as f32,
                confidence: e.confidence as f32,
                ..Estimate::default()
            },
        })
        .collect();
    let track = Track::read(truth)?;
    let entry = Entry {
        file: estimates.to_path_buf(),
        set: "recorded".into(),
        score_from_s: w.from_s,
        score_to_s: w.to_s,
        note: String::new(),
    };
    let s = eval::score(entry, track, rows);
    let set = |name: &str| SetSummary {
        set: name.into(),
        scenes: 1,
        settled: Metrics::from_errors(&s.settled),
        transition: Metrics::from_errors(&s.transition),
        settled_raw: Metrics::from_errors(&s.settled_raw),
        jumps: s.jumps.clone(),
    };
    Ok(Report {
        sets: vec![set("recorded")],
        overall: set("all"),
        scenes: vec![SceneSummary {
            name: s.entry.name(),
            set: "recorded".into(),
            settled: Metrics::from_errors(&s.settled),
        }],
    })
}
