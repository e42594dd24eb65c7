//! `host-sim score`: scores an estimate CSV (a `monitor --record` of a hardware session, or a
//! `locate --csv`) against a truth track, with the metrics and table of `host-sim eval`. The
//! scoring is [`crate::evaluation::recorded_score`].

use crate::error::{Result, SimError};
use crate::evaluation::eval;
use crate::evaluation::recorded_score::{report, window};
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
    #[arg(long, value_parser = crate::flags::arg_values::time_seconds)]
    pub from: Option<f64>,
    /// Score frames up to this time, s (default: as `eval`, see below).
    #[arg(long, value_parser = crate::flags::arg_values::time_seconds)]
    pub to: Option<f64>,
    /// Print the report as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// Runs `host-sim score`.
pub fn run(a: &ScoreArgs) -> Result<()> {
    let w = window(a.from, a.to, &a.truth)?;
    let r = report(&a.estimates, &a.truth, &w)?;
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
        crate::io::stdout_text::print_text(&format!("{json}\n"))
    } else {
        crate::io::stdout_text::print_text(&eval::format_table(&r))
    }
}
