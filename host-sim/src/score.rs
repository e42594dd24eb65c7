//! `host-sim score`: scores an estimate CSV (a `monitor --record` of a hardware session, or a
//! `locate --csv`) against a truth track, with the metrics and table of `host-sim eval`.

use crate::error::{Result, SimError};
use crate::eval::{self, Report, SceneSummary, SetSummary};
use crate::ground_truth::Track;
use crate::locate::{self, Row};
use crate::manifest::Entry;
use crate::metrics::Metrics;
use cma_core::Estimate;
use std::path::PathBuf;

/// `host-sim score`.
#[derive(Debug, clap::Args)]
pub struct ScoreArgs {
    /// Estimate CSV (`monitor --record` or `locate --csv`).
    pub estimates: PathBuf,
    /// Truth track (`NAME.pos.csv`), on the same time axis as the estimates.
    pub truth: PathBuf,
    /// Score frames from this time on, s.
    #[arg(long, default_value_t = 0.0)]
    pub from: f64,
    /// Score frames up to this time, s (default: all).
    #[arg(long)]
    pub to: Option<f64>,
    /// Print the report as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Scores the estimates of `a` against its truth; the report has one set, `recorded`.
pub fn report(a: &ScoreArgs) -> Result<Report> {
    let to = a.to.unwrap_or(f64::INFINITY);
    if !(a.from.is_finite() && to >= a.from) {
        return Err(SimError::Usage(format!(
            "need a finite --from ≤ --to, got {} and {to}",
            a.from
        )));
    }
    let rows: Vec<Row> = locate::read_csv(&a.estimates)?
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
    let track = Track::read(&a.truth)?;
    let entry = Entry {
        file: a.estimates.clone(),
        set: "recorded".into(),
        score_from_s: a.from,
        score_to_s: to,
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

/// Runs `host-sim score`.
pub fn run(a: &ScoreArgs) -> Result<()> {
    let r = report(a)?;
    if a.json {
        let json = serde_json::to_string_pretty(&r).map_err(|e| SimError::Other(e.to_string()))?;
        crate::stdout_text::print_text(&format!("{json}\n"))
    } else {
        crate::stdout_text::print_text(&eval::format_table(&r))
    }
}
