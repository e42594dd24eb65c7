//! Helpers shared by the end-to-end tests: temporary scenes made with `host-sim scene` and the
//! localizer's output for them. Nothing here needs `../shared/`.

use host_sim::io::ground_truth::wrap180;
use host_sim::localization::frame_estimates::{read_csv, CsvEstimate};
use std::path::{Path, PathBuf};

/// Runs `host-sim` in-process with `args` (without the program name).
pub fn host_sim(args: &[&str]) -> Result<(), host_sim::error::SimError> {
    let mut v = vec!["host-sim"];
    v.extend_from_slice(args);
    host_sim::run(v)
}

/// Path of `name` inside `dir` as a `String`.
#[must_use]
pub fn path_in(dir: &Path, name: &str) -> String {
    dir.join(name).to_string_lossy().into_owned()
}

/// A configuration file `name` in `dir` holding `text` (TOML), its path.
pub fn config_file(dir: &Path, name: &str, text: &str) -> String {
    let path = path_in(dir, name);
    std::fs::write(&path, text).unwrap();
    path
}

/// Makes a scene with `host-sim scene` (synthetic talker) and returns the WAV path.
pub fn make_scene(dir: &Path, name: &str, extra: &[&str]) -> PathBuf {
    let out = path_in(dir, name);
    let mut args = vec!["scene", "--out", out.as_str()];
    args.extend_from_slice(extra);
    host_sim(&args).unwrap_or_else(|e| panic!("scene {name}: {e}"));
    PathBuf::from(out)
}

/// Localizes `wav` with `host-sim locate` (extra flags allowed) and reads the CSV back.
pub fn locate(wav: &Path, extra: &[&str]) -> Vec<CsvEstimate> {
    let csv = wav.with_extension("csv");
    let (w, c) = (
        wav.to_string_lossy().into_owned(),
        csv.to_string_lossy().into_owned(),
    );
    let mut args = vec!["locate", w.as_str(), "--csv", c.as_str()];
    args.extend_from_slice(extra);
    host_sim(&args).unwrap_or_else(|e| panic!("locate: {e}"));
    read_csv(&csv).expect("locate writes a readable CSV")
}

/// Absolute wrapped error of each estimate after `from_s` against a fixed truth.
#[must_use]
pub fn errors_after(rows: &[CsvEstimate], from_s: f64, truth_deg: f64) -> Vec<f64> {
    errors_against(rows, from_s, |_| truth_deg)
}

/// Absolute wrapped error of each estimate after `from_s` against the truth `truth_deg(t_s)`.
#[must_use]
pub fn errors_against(
    rows: &[CsvEstimate],
    from_s: f64,
    truth_deg: impl Fn(f64) -> f64,
) -> Vec<f64> {
    rows.iter()
        .filter(|r| r.t_s >= from_s)
        .map(|r| wrap180(r.azimuth_deg - truth_deg(r.t_s)).abs())
        .collect()
}

/// Median of a non-empty slice.
#[must_use]
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s[s.len() / 2]
}
