//! `host-sim eval`: runs the localizer on every scene of a folder with a `manifest.csv` (as
//! `host-sim scene --manifest` writes it) and scores it against ground truth, per set and overall,
//! for settled frames and for the 0.5 s after each truth change, plus how fast every jump is
//! followed.

use crate::error::{Result, SimError};
use crate::evaluation::metrics::Metrics;
use crate::io::ground_truth::{wrap180, Track};
use crate::io::manifest::{self, Entry};
use crate::io::wav_io::{read_recording, InputLayout};
use crate::localization::frame_estimates::{locate, Row};
use cma_core::{LocatorConfig, ReferenceTable};
use serde::Serialize;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Frames this long after a truth change are scored separately.
pub const TRANSITION_S: f64 = 0.5;
/// Tolerance for "following" a jump, degrees.
pub const JUMP_TOLERANCE_DEG: f64 = 10.0;

/// How fast one jump was followed.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Jump {
    /// Time of the truth change, s.
    pub t_s: f64,
    /// New truth azimuth, degrees.
    pub to_deg: f64,
    /// Time from the change to the first estimate within tolerance, s.
    pub reach_s: Option<f64>,
    /// Time from the change after which every estimate until the next change stays within tolerance, s.
    pub settle_s: Option<f64>,
}

/// One scene's result.
#[derive(Debug, Clone)]
pub struct SceneResult {
    /// The manifest entry.
    pub entry: Entry,
    /// The truth.
    pub track: Track,
    /// All estimates.
    pub rows: Vec<Row>,
    /// Wrapped errors of settled scored frames.
    pub settled: Vec<f64>,
    /// Wrapped errors of scored frames within [`TRANSITION_S`] after a change.
    pub transition: Vec<f64>,
    /// Wrapped errors of the unweighted (raw) azimuth over settled frames.
    pub settled_raw: Vec<f64>,
    /// Jumps of the track.
    pub jumps: Vec<Jump>,
}

/// Summary of a set (or of all scenes).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SetSummary {
    /// Set name (`all` for the overall summary).
    pub set: String,
    /// Number of scenes.
    pub scenes: usize,
    /// Metrics of settled frames.
    pub settled: Metrics,
    /// Metrics of frames within 0.5 s after a truth change.
    pub transition: Metrics,
    /// Metrics of the unweighted azimuth on settled frames.
    pub settled_raw: Metrics,
    /// Jumps of the set's scenes.
    pub jumps: Vec<Jump>,
}

/// Per-scene line of the report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SceneSummary {
    /// Scene name.
    pub name: String,
    /// Set.
    pub set: String,
    /// Settled metrics.
    pub settled: Metrics,
}

/// The whole evaluation.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Report {
    /// Per set, in manifest order of first appearance.
    pub sets: Vec<SetSummary>,
    /// All scenes together.
    pub overall: SetSummary,
    /// Per scene.
    pub scenes: Vec<SceneSummary>,
}

/// Scores one scene's estimates against its truth.
#[must_use]
pub fn score(entry: Entry, track: Track, rows: Vec<Row>) -> SceneResult {
    let changes = track.changes();
    let mut settled = Vec::new();
    let mut transition = Vec::new();
    let mut settled_raw = Vec::new();
    for r in &rows {
        if r.t_s < entry.score_from_s || r.t_s > entry.score_to_s {
            continue;
        }
        let truth = track.azimuth_at(r.t_s);
        let err = wrap180(r.estimate.azimuth_deg as f64 - truth);
        let recent = changes
            .iter()
            .any(|c| r.t_s >= *c && r.t_s - c < TRANSITION_S);
        if recent {
            transition.push(err);
        } else {
            settled.push(err);
            settled_raw.push(wrap180(r.estimate.azimuth_raw_deg as f64 - truth));
        }
    }
    let mut jumps = Vec::new();
    for (i, &tc) in changes.iter().enumerate() {
        let end = changes
            .get(i + 1)
            .copied()
            .unwrap_or(f64::INFINITY)
            .min(entry.score_to_s);
        let to = track.azimuth_at(tc);
        let seg: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.t_s >= tc && r.t_s <= end)
            .map(|r| (r.t_s, wrap180(r.estimate.azimuth_deg as f64 - to).abs()))
            .collect();
        let reach_s = seg
            .iter()
            .find(|(_, e)| *e <= JUMP_TOLERANCE_DEG)
            .map(|(t, _)| t - tc);
        let settle_s = match seg.iter().rposition(|(_, e)| *e > JUMP_TOLERANCE_DEG) {
            None => seg.first().map(|(t, _)| t - tc),
            Some(last_bad) => seg.get(last_bad + 1).map(|(t, _)| t - tc),
        };
        jumps.push(Jump {
            t_s: tc,
            to_deg: to,
            reach_s,
            settle_s,
        });
    }
    SceneResult {
        entry,
        track,
        rows,
        settled,
        transition,
        settled_raw,
        jumps,
    }
}

fn summarize(set: &str, scenes: &[&SceneResult]) -> SetSummary {
    let cat = |f: fn(&SceneResult) -> &Vec<f64>| {
        scenes
            .iter()
            .flat_map(|s| f(s).iter().copied())
            .collect::<Vec<_>>()
    };
    SetSummary {
        set: set.to_string(),
        scenes: scenes.len(),
        settled: Metrics::from_errors(&cat(|s| &s.settled)),
        transition: Metrics::from_errors(&cat(|s| &s.transition)),
        settled_raw: Metrics::from_errors(&cat(|s| &s.settled_raw)),
        jumps: scenes
            .iter()
            .flat_map(|s| s.jumps.iter().cloned())
            .collect(),
    }
}

/// Runs and scores every scene of `dir`; `threads` workers share the scenes.
pub fn evaluate(
    dir: &Path,
    config: LocatorConfig,
    table: ReferenceTable<'_>,
    layout: InputLayout,
    threads: usize,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Report, Vec<SceneResult>)> {
    let entries = manifest::read(dir)?;
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<Result<SceneResult>>>> =
        Mutex::new((0..entries.len()).map(|_| None).collect());
    std::thread::scope(|s| {
        for _ in 0..threads.max(1) {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(entry) = entries.get(i) else { break };
                let r = (|| {
                    let track = Track::read(&entry.truth_path(dir))?;
                    let rec = read_recording(&dir.join(&entry.file), layout)?;
                    let rows = locate(&rec, config, table, |n| progress(n as u64))?;
                    Ok(score(entry.clone(), track, rows))
                })();
                results
                    .lock()
                    .expect("no worker panics while holding the lock")[i] = Some(r);
            });
        }
    });
    let mut scenes = Vec::with_capacity(entries.len());
    for r in results
        .into_inner()
        .map_err(|_| SimError::Other("evaluation worker panicked".into()))?
    {
        scenes.push(r.ok_or_else(|| SimError::Other("scene not evaluated".into()))??);
    }
    let mut set_names: Vec<String> = Vec::new();
    for s in &scenes {
        if !set_names.contains(&s.entry.set) {
            set_names.push(s.entry.set.clone());
        }
    }
    let sets = set_names
        .iter()
        .map(|n| {
            summarize(
                n,
                &scenes
                    .iter()
                    .filter(|s| &s.entry.set == n)
                    .collect::<Vec<_>>(),
            )
        })
        .collect();
    let overall = summarize("all", &scenes.iter().collect::<Vec<_>>());
    let per_scene = scenes
        .iter()
        .map(|s| SceneSummary {
            name: s.entry.name(),
            set: s.entry.set.clone(),
            settled: Metrics::from_errors(&s.settled),
        })
        .collect();
    Ok((
        Report {
            sets,
            overall,
            scenes: per_scene,
        },
        scenes,
    ))
}

/// Total sample frames of the scenes in `dir` (for the progress bar), from the WAV headers.
#[must_use]
pub fn total_frames(dir: &Path) -> u64 {
    manifest::read(dir)
        .map(|es| {
            es.iter()
                .filter_map(|e| hound::WavReader::open(dir.join(&e.file)).ok())
                .map(|r| r.duration() as u64)
                .sum()
        })
        .unwrap_or(0)
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or("never".into(), |x| format!("{x:.2}"))
}

/// `v` with `decimals` right-aligned in `width`, or `-` when it is not a number (no frames).
fn fmt_num(v: f64, width: usize, decimals: usize) -> String {
    if v.is_finite() {
        format!("{v:>width$.decimals$}")
    } else {
        format!("{:>width$}", "-")
    }
}

/// The slowest of `times` (`None`: never), formatted: `-` without jumps, `never` when a jump was
/// never followed.
fn fmt_slowest(times: impl Iterator<Item = Option<f64>>) -> String {
    let slowest = times
        .map(|t| t.unwrap_or(f64::INFINITY))
        .fold(None, |a: Option<f64>, x| Some(a.map_or(x, |a| a.max(x))));
    match slowest {
        None => "-".into(),
        Some(t) if t.is_finite() => format!("{t:.2}s"),
        Some(_) => "never".into(),
    }
}

/// What the columns of [`format_table`] mean: the end of `eval --help`, and the table's footer.
pub const COLUMNS_HELP: &str = "\
Columns (errors are wrapped differences estimate − truth, degrees; `-`: no such frames or jumps):
  frames       settled frames scored: inside the manifest's score window and more than 0.5 s
               after a truth change
  ACCn         share of settled frames with |error| ≤ n°, %
  MAE RMSE     mean absolute and root-mean-square error of the settled frames
  bias std     mean and standard deviation of the settled frames' error
  trACC10      ACC10 of the transition frames: the first 0.5 s after each truth change (a jump)
  trMAE        MAE of the transition frames
  rawACC10     ACC10 of azimuth_raw_deg (each frame's own, untracked estimate) on settled frames
  jump-reach   slowest jump of the set: time from the change to the first estimate within 10°
               of the new azimuth (`never`: not reached before the next change)
  jump-settle  slowest jump of the set: time from the change after which every estimate stays
               within 10° until the next change";

/// The report as a text table.
#[must_use]
pub fn format_table(report: &Report) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<10} {:>6} {:>7} {:>7} {:>7} {:>7} {:>7} {:>6} {:>6} {:>6} {:>6} | {:>7} {:>6} | {:>8} | {:>10} {:>11}",
        "set", "frames", "ACC1", "ACC5", "ACC10", "ACC15", "ACC30", "MAE", "RMSE", "bias", "std", "trACC10", "trMAE", "rawACC10", "jump-reach", "jump-settle"
    );
    for set in report.sets.iter().chain(std::iter::once(&report.overall)) {
        let m = &set.settled;
        let _ = writeln!(
            s,
            "{:<10} {:>6} {} {} {} {} {} {} {} {} {} | {} {} | {} | {:>10} {:>11}",
            set.set,
            m.frames,
            fmt_num(m.acc_at(1), 7, 1),
            fmt_num(m.acc_at(5), 7, 1),
            fmt_num(m.acc_at(10), 7, 1),
            fmt_num(m.acc_at(15), 7, 1),
            fmt_num(m.acc_at(30), 7, 1),
            fmt_num(m.mae, 6, 2),
            fmt_num(m.rmse, 6, 2),
            fmt_num(m.bias, 6, 2),
            fmt_num(m.std, 6, 2),
            fmt_num(set.transition.acc_at(10), 7, 1),
            fmt_num(set.transition.mae, 6, 1),
            fmt_num(set.settled_raw.acc_at(10), 8, 1),
            fmt_slowest(set.jumps.iter().map(|j| j.reach_s)),
            fmt_slowest(set.jumps.iter().map(|j| j.settle_s)),
        );
    }
    let _ = writeln!(
        s,
        "(settled frames; tr: the {TRANSITION_S} s after each jump; raw: untracked per-frame \
         azimuth; jump-*: slowest jump of the set; `-`: none. See `host-sim eval --help`.)"
    );
    let jumps: Vec<&Jump> = report.sets.iter().flat_map(|s| s.jumps.iter()).collect();
    if !jumps.is_empty() {
        let _ = writeln!(s, "\njumps (within {JUMP_TOLERANCE_DEG}°):");
        for j in jumps {
            let _ = writeln!(
                s,
                "  t={:>6.2}s → {:>7.1}°  reach {:>6} s  settle {:>6} s",
                j.t_s,
                j.to_deg,
                fmt_opt(j.reach_s),
                fmt_opt(j.settle_s)
            );
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set(name: &str, transition: &[f64], jumps: Vec<Jump>) -> SetSummary {
        SetSummary {
            set: name.into(),
            scenes: 1,
            settled: Metrics::from_errors(&[1.0, -2.0]),
            transition: Metrics::from_errors(transition),
            settled_raw: Metrics::from_errors(&[3.0]),
            jumps,
        }
    }

    #[test]
    fn sets_without_jumps_print_a_dash_not_nan() {
        let jump = Jump {
            t_s: 1.0,
            to_deg: 30.0,
            reach_s: Some(0.2),
            settle_s: None,
        };
        let report = Report {
            sets: vec![set("static", &[], vec![]), set("jump", &[4.0], vec![jump])],
            overall: set("all", &[4.0], vec![]),
            scenes: vec![],
        };
        let table = format_table(&report);
        assert!(!table.contains("NaN"), "{table}");
        let static_row = table.lines().nth(1).unwrap();
        assert!(static_row.ends_with("-           -"), "{static_row}");
        assert!(
            table.lines().nth(2).unwrap().ends_with("0.20s       never"),
            "{table}"
        );
        assert!(table.contains("See `host-sim eval --help`"), "{table}");
        let json = serde_json::to_value(&report).unwrap();
        assert!(json["sets"][0]["transition"]["mae"].is_null(), "{json}");
    }
}
