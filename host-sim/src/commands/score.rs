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
#[command(
    after_help = "Scoring window: --from/--to if given; else the window of the manifest.csv \
    (in the truth file's folder or the one above) that lists NAME.wav, as `eval` scores it; else \
    every frame. The window used is printed on stderr."
)]
pub struct ScoreArgs {
    /// Estimate CSV (`monitor --record` or `locate --csv`).
    pub estimates: PathBuf,
    /// Truth track (`NAME.pos.csv`), on the same time axis as the estimates.
    pub truth: PathBuf,
    /// Score frames from this time on, s (default: as `eval`, see below).
    #[arg(long, value_parser = crate::arg_values::time_seconds)]
    pub from: Option<f64>,
    /// Score frames up to this time, s (default: as `eval`, see below).
    #[arg(long, value_parser = crate::arg_values::time_seconds)]
    pub to: Option<f64>,
    /// Print the report as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

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

/// The scoring window of `a`: its flags, else the manifest entry of the truth's scene (as `eval`
/// scores it), else everything.
pub fn window(a: &ScoreArgs) -> Result<Window> {
    if a.from.is_some() || a.to.is_some() {
        let (from_s, to_s) = (a.from.unwrap_or(0.0), a.to.unwrap_or(f64::INFINITY));
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
    let truth = std::fs::canonicalize(&a.truth).map_err(|e| SimError::io(&a.truth, e))?;
    for dir in truth.ancestors().skip(1).take(2) {
        if !dir.join("manifest.csv").is_file() {
            continue;
        }
        let entries = crate::manifest::read(dir)?;
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

/// Scores the estimates of `a` against its truth; the report has one set, `recorded`.
pub fn report(a: &ScoreArgs) -> Result<Report> {
    report_in(a, &window(a)?)
}

/// Scores the estimates of `a` against its truth over `w`.
fn report_in(a: &ScoreArgs, w: &Window) -> Result<Report> {
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

/// Runs `host-sim score`.
pub fn run(a: &ScoreArgs) -> Result<()> {
    let w = window(a)?;
    let r = report_in(a, &w)?;
    let scored = r.overall.settled.frames + r.overall.transition.frames;
    let span = |t: f64| {
        if t.is_finite() {
            format!("{t:.3} s")
        } else {
            "end".to_string()
        }
    };
    eprintln!(
        "score: {scored} frames scored, {} to {} ({})",
        if w.from_s.is_finite() {
            span(w.from_s)
        } else {
            "start".to_string()
        },
        span(w.to_s),
        w.source
    );
    if a.json {
        let json = serde_json::to_string_pretty(&r).map_err(|e| SimError::Other(e.to_string()))?;
        crate::stdout_text::print_text(&format!("{json}\n"))
    } else {
        crate::stdout_text::print_text(&eval::format_table(&r))
    }
}
