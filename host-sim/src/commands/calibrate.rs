//! `host-sim calibrate`: argument parsing and the reading of the recordings and the sweep. The
//! table is computed by [`crate::calibration::measured_table`] (from sweeps) or
//! [`crate::calibration::selfcal_table`] (from a self-calibration estimate, `--selfcal-in`) and
//! drawn by [`crate::calibration::table_plot`].

use crate::calibration::measured_table::{self, CalibrationOptions, Measurement};
use crate::calibration::selfcal_table;
use crate::calibration::sweep::SweepSpec;
use crate::error::{Result, SimError};
use crate::io::selfcal_file;
use crate::io::table_io::OwnedTable;
use crate::io::wav_io::{read_four_channels, read_mono};
use cma_core::ReferenceTable;
use std::path::{Path, PathBuf};

/// `host-sim calibrate`.
#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    /// Output reference-table file (`.cmat`).
    #[arg(long)]
    pub out: PathBuf,
    /// A recording: AZIMUTH=FILE.wav (4 channels, CMA1 order); repeat for every azimuth.
    #[arg(long = "rec", allow_hyphen_values = true)]
    pub recordings: Vec<String>,
    /// The list of recordings: a manifest CSV with the columns `file,azimuth_deg` (one recording
    /// per line, paths relative to the manifest), or a folder holding one named `calibration.csv`.
    #[arg(long, visible_alias = "manifest")]
    pub dir: Option<PathBuf>,
    /// The sweep as played (mono WAV). A sweep written by `host-sim sweep` carries its f1/f2
    /// (in the WAV's comment); default: generated from --f1/--f2/--seconds/--rate.
    #[arg(long)]
    pub sweep: Option<PathBuf>,
    /// Start frequency of the sweep, Hz (default: from the sweep file, else 50).
    #[arg(long)]
    pub f1: Option<f64>,
    /// Stop frequency of the sweep, Hz (default: from the sweep file, else 20000).
    #[arg(long)]
    pub f2: Option<f64>,
    /// Duration of a generated sweep, s (without --sweep; default 5).
    #[arg(long)]
    pub seconds: Option<f64>,
    /// Rate of a generated sweep, Hz (without --sweep; default 48000).
    #[arg(long)]
    pub rate: Option<u32>,
    /// Impulse-response window, ms (thesis: 512 samples at 44.1 kHz).
    #[arg(long, default_value_t = 512.0 / 44.1)]
    pub window_ms: f64,
    /// Part of the window before the direct peak, ms.
    #[arg(long, default_value_t = 1.0)]
    pub pre_ms: f64,
    /// Lowest frequency row, Hz.
    #[arg(long, default_value_t = 187.5)]
    pub freq_lo: f64,
    /// Highest frequency row, Hz.
    #[arg(long, default_value_t = 4031.25)]
    pub freq_hi: f64,
    /// Spacing of the frequency rows, Hz.
    #[arg(long, default_value_t = 93.75)]
    pub freq_step: f64,
    /// Smoothing coefficient over frequency rows, 0 ≤ b < 1 (0 = off).
    #[arg(long, default_value_t = 0.0)]
    pub smooth: f64,
    /// Recordings cover [0°, 120°); build the full circle from the 120° symmetry (matched capsules only).
    #[arg(long)]
    pub symmetry: bool,
    /// Also draw the table (features vs azimuth per capsule at four frequencies) into this PNG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Compute the table from a self-calibration estimate (a `locate --selfcal-out` file, or an
    /// image of a board's estimate store) instead
    /// of measuring it from sweeps: each frequency row (--freq-lo/--freq-hi/--freq-step) takes the
    /// capsule model of its band, on the azimuth grid of --grid, with the noise rows of a 3-D
    /// diffuse field. Not with --rec/--dir or the sweep's flags.
    #[arg(long, value_name = "FILE", conflicts_with_all = SWEEP_ONLY)]
    pub selfcal_in: Option<PathBuf>,
    /// With --selfcal-in: azimuth grid of the table, degrees, 5 or 15 (default 5, the ideal table's
    /// grid; 15 for a table small enough for the firmware's flash, with --freq-step 187.5).
    #[arg(long, value_name = "DEG", requires = "selfcal_in", conflicts_with_all = SWEEP_ONLY)]
    pub grid: Option<u32>,
}

/// The flags (argument ids) of a calibration from sweeps, which `--selfcal-in` and `--grid` do not
/// take. (A flag that conflicts with one given is not required, so `--grid` needs both its
/// `requires` and these conflicts.)
const SWEEP_ONLY: [&str; 11] = [
    "recordings",
    "dir",
    "sweep",
    "f1",
    "f2",
    "seconds",
    "rate",
    "window_ms",
    "pre_ms",
    "smooth",
    "symmetry",
];

/// Reads one 4-channel recording.
pub fn read_measurement(path: &Path, azimuth_deg: f64) -> Result<Measurement> {
    let (spec, data) = read_four_channels(path, "omni, cardioid 0°, 120°, 240°")?;
    Ok(Measurement {
        label: path.display().to_string(),
        azimuth_deg,
        rate: spec.sample_rate,
        frames: data
            .chunks_exact(4)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect(),
    })
}

/// Name of the manifest `--dir FOLDER` looks for.
pub const MANIFEST_NAME: &str = "calibration.csv";

/// What a manifest holds, for messages.
const MANIFEST_COLUMNS: &str = "a CSV with the columns `file,azimuth_deg` (a header line naming them is optional; one recording per line: its path relative to the manifest and the source azimuth in degrees, counter-clockwise from cardioid 0°)";

/// The manifest `--dir` names: the file itself, or `calibration.csv` inside a folder.
fn manifest_path(dir: &Path) -> Result<PathBuf> {
    if dir.is_dir() {
        let path = dir.join(MANIFEST_NAME);
        if !path.is_file() {
            return Err(SimError::Usage(format!(
                "--dir {}: looked for the manifest {}, which does not exist; a manifest is {MANIFEST_COLUMNS}. Name the manifest file itself with --dir FILE, or list the recordings with --rec AZIMUTH=FILE",
                dir.display(),
                path.display()
            )));
        }
        Ok(path)
    } else if dir.is_file() {
        Ok(dir.to_path_buf())
    } else {
        Err(SimError::Usage(format!(
            "--dir {}: no such file or folder; expected a manifest ({MANIFEST_COLUMNS}) or a folder holding one named {MANIFEST_NAME}",
            dir.display()
        )))
    }
}

/// The (azimuth, file) entries of a manifest; paths relative to its folder.
pub fn read_manifest(path: &Path) -> Result<Vec<(f64, PathBuf)>> {
    let text = std::fs::read_to_string(path).map_err(|e| SimError::reading(path, e))?;
    let base = path.parent().unwrap_or(Path::new(""));
    let mut list = Vec::new();
    // Column positions of (file, azimuth): from a header line, else `file,azimuth_deg`.
    let mut columns = (0usize, 1usize);
    let mut first = true;
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let bad = |reason: String| SimError::BadCsv {
            path: path.to_path_buf(),
            line: i + 1,
            reason,
        };
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if std::mem::take(&mut first) && fields.iter().all(|f| f.parse::<f64>().is_err()) {
            let find = |names: &[&str]| {
                fields
                    .iter()
                    .position(|f| names.iter().any(|n| f.eq_ignore_ascii_case(n)))
            };
            columns = match (find(&["file", "path"]), find(&["azimuth_deg", "azimuth"])) {
                (Some(f), Some(a)) => (f, a),
                _ => {
                    return Err(bad(format!(
                        "header `{line}`: expected the columns `file,azimuth_deg` (in any order)"
                    )))
                }
            };
            continue;
        }
        let (Some(file), Some(az)) = (fields.get(columns.0), fields.get(columns.1)) else {
            return Err(bad(format!(
                "expected `file,azimuth_deg`, got `{line}` ({} field(s))",
                fields.len()
            )));
        };
        let az = az
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| bad(format!("azimuth `{az}` is not a number (degrees)")))?;
        if file.is_empty() {
            return Err(bad("the file name is empty".into()));
        }
        list.push((az, base.join(file)));
    }
    if list.is_empty() {
        return Err(SimError::Usage(format!(
            "{}: no recordings listed; a manifest is {MANIFEST_COLUMNS}",
            path.display()
        )));
    }
    Ok(list)
}

/// Refuses outputs (`--out`, `--plot`) that would overwrite an input (a recording, `--sweep`,
/// `--selfcal-in`) or each other, before any work.
fn check_paths(a: &CalibrateArgs) -> Result<()> {
    let recordings = match a.selfcal_in {
        Some(_) => Vec::new(),
        None => recording_list(a)?,
    };
    let mut inputs: Vec<(&str, &Path)> = recordings
        .iter()
        .map(|(_, p)| ("recording", p.as_path()))
        .collect();
    inputs.extend(a.sweep.as_deref().map(|p| ("--sweep", p)));
    inputs.extend(a.selfcal_in.as_deref().map(|p| ("--selfcal-in", p)));
    let mut outputs = vec![("--out", a.out.as_path())];
    outputs.extend(a.plot.as_deref().map(|p| ("--plot", p)));
    crate::io::output_file::check_distinct(&inputs, &outputs)
}

/// The (azimuth, file) list of `--rec` and `--dir`.
fn recording_list(a: &CalibrateArgs) -> Result<Vec<(f64, PathBuf)>> {
    let mut list = Vec::new();
    for r in &a.recordings {
        let (az, file) = r
            .split_once('=')
            .ok_or_else(|| SimError::Usage(format!("--rec: expected AZIMUTH=FILE, got `{r}`")))?;
        let az = az
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| SimError::Usage(format!("--rec: not an azimuth: `{az}`")))?;
        list.push((az, PathBuf::from(file)));
    }
    if let Some(dir) = &a.dir {
        list.extend(read_manifest(&manifest_path(dir)?)?);
    }
    Ok(list)
}

/// The sweep to deconvolve with, its parameters, and notes for the user: from `--sweep FILE` (its
/// f1/f2 from the file's comment unless `--f1/--f2` override them), or generated.
pub fn resolve_sweep(a: &CalibrateArgs) -> Result<(Vec<f64>, SweepSpec, Vec<String>)> {
    let defaults = SweepSpec::default();
    let mut notes = Vec::new();
    match &a.sweep {
        Some(path) => {
            let (rate, s) = read_mono(path)?;
            let stored = crate::calibration::sweep::read_info_comment(path)?
                .as_deref()
                .and_then(SweepSpec::from_info_comment);
            let (f1, f2) = match (a.f1, a.f2, stored) {
                (Some(f1), Some(f2), _) => (f1, f2),
                (f1, f2, Some(st)) => (f1.unwrap_or(st.f1), f2.unwrap_or(st.f2)),
                (f1, f2, None) => {
                    let (f1, f2) = (f1.unwrap_or(defaults.f1), f2.unwrap_or(defaults.f2));
                    notes.push(format!(
                        "{} does not say its f1/f2 (not written by `host-sim sweep`): assuming f1 = {f1} Hz, f2 = {f2} Hz; pass --f1/--f2 if the sweep was made differently",
                        path.display()
                    ));
                    (f1, f2)
                }
            };
            if let Some(st) = stored {
                if st.rate != rate {
                    notes.push(format!(
                        "{} says it was made at {} Hz but is at {rate} Hz (resampled?)",
                        path.display(),
                        st.rate
                    ));
                }
            }
            let s: Vec<f64> = s.iter().map(|v| f64::from(*v)).collect();
            let spec = SweepSpec {
                f1,
                f2,
                rate,
                seconds: s.len() as f64 / f64::from(rate),
            };
            Ok((s, spec, notes))
        }
        None => {
            let spec = SweepSpec {
                f1: a.f1.unwrap_or(defaults.f1),
                f2: a.f2.unwrap_or(defaults.f2),
                seconds: a.seconds.unwrap_or(defaults.seconds),
                rate: a.rate.unwrap_or(defaults.rate),
            };
            spec.validate()?;
            Ok((spec.generate(), spec, notes))
        }
    }
}

/// The warning for a `--symmetry` calibration whose capsules disagree on mirrored azimuths, if any.
#[must_use]
pub fn symmetry_warning(check: &measured_table::SymmetryCheck) -> Option<String> {
    let Some(worst) = check.worst_db() else {
        return Some(
            "warning: --symmetry could not check that the capsules are matched: record 0° and pairs of azimuths φ and 120° − φ (e.g. 15° and 105°), where cardioids 0° and 120° see the same relative angle".into(),
        );
    };
    if !check.disagrees() {
        return None;
    }
    let mut parts = Vec::new();
    if let Some(d) = check.gain_1_over_0_db {
        parts.push(format!(
            "cardioid 120° vs 0°: {d:+.2} dB over {} mirrored azimuth pair(s)",
            check.pairs_0_1
        ));
    }
    if let Some(d) = check.gain_2_over_1_db {
        parts.push(format!("cardioid 240° vs 120° at 0°: {d:+.2} dB"));
    }
    Some(format!(
        "warning: --symmetry assumes matched capsules, but they disagree by up to {worst:.2} dB (tolerance {:.1} dB) where they see the same relative angle ({}); the rotated thirds copy each capsule's error onto the others. Record the full circle instead",
        measured_table::SYMMETRY_TOLERANCE_DB,
        parts.join("; ")
    ))
}

/// Runs `host-sim calibrate`.
pub fn run(a: &CalibrateArgs) -> Result<()> {
    if let Some(p) = &a.plot {
        if p.extension().and_then(|e| e.to_str()) != Some("png") {
            return Err(SimError::Usage(format!(
                "--plot: expected a .png file, got {}",
                p.display()
            )));
        }
    }
    check_paths(a)?;
    if let Some(path) = &a.selfcal_in {
        return run_from_estimate(a, path);
    }
    let (sweep, spec, notes) = resolve_sweep(a)?;
    for n in notes {
        eprintln!("note: {n}");
    }
    let opts = CalibrationOptions {
        sweep: spec,
        window_s: a.window_ms / 1000.0,
        pre_s: a.pre_ms / 1000.0,
        freq_lo_hz: a.freq_lo,
        freq_hi_hz: a.freq_hi,
        freq_step_hz: a.freq_step,
        smoothing: a.smooth,
        symmetry: a.symmetry,
    };
    let list = recording_list(a)?;
    let measurements = list
        .iter()
        .map(|(az, p)| read_measurement(p, *az))
        .collect::<Result<Vec<_>>>()?;
    let measured_table::Calibration {
        table,
        infos,
        symmetry,
    } = measured_table::calibrate(&measurements, &sweep, &opts)?;
    if let Some(w) = symmetry.as_ref().and_then(symmetry_warning) {
        eprintln!("{w}");
    }
    table.write(&a.out)?;
    let crest = infos
        .iter()
        .map(|i| i.crest_db)
        .fold(f64::INFINITY, f64::min);
    report_table(
        a,
        &table,
        &format!(
            "{} recordings; lowest IR crest factor {crest:.1} dB",
            infos.len()
        ),
    )
}

/// The summary line of a written table (`source`: what it was made from) on stderr, then its plot
/// when `--plot` asks for one.
fn report_table(a: &CalibrateArgs, table: &OwnedTable, source: &str) -> Result<()> {
    eprintln!(
        "{}: {} azimuths × {} frequencies ({}–{} Hz) from {source}; max |feature − ideal| {:.3}",
        a.out.display(),
        table.azimuths_deg.len(),
        table.freqs_hz.len(),
        table.freqs_hz.first().copied().unwrap_or(0.0),
        table.freqs_hz.last().copied().unwrap_or(0.0),
        measured_table::max_deviation_from_ideal(table)
    );
    if let Some(p) = &a.plot {
        crate::calibration::table_plot::table_plot(p, table)?;
    }
    Ok(())
}

/// `calibrate --selfcal-in FILE`: the table of a saved self-calibration estimate
/// ([`crate::calibration::selfcal_table`]), on the azimuth grid of the core's ideal table of `--grid`. Everything
/// is read and checked before the table is written (atomically).
fn run_from_estimate(a: &CalibrateArgs, path: &Path) -> Result<()> {
    let grid = match a.grid.unwrap_or(5) {
        5 => ReferenceTable::ideal_5deg(),
        15 => ReferenceTable::ideal_15deg(),
        g => {
            return Err(SimError::Usage(format!(
                "--grid: expected 5 or 15 (degrees), got {g}"
            )))
        }
    };
    let freqs = measured_table::freq_rows(a.freq_lo, a.freq_hi, a.freq_step)?;
    let est = selfcal_file::read(path)?;
    let table = selfcal_table::table_from_estimate(&est, &freqs, grid.azimuths_deg())?;
    table.write(&a.out)?;
    let confidence = est.overall_confidence();
    eprint!("{}", selfcal_file::summary(&est, confidence));
    let deviates = est.bands.iter().any(|b| {
        b.omni_part
            .iter()
            .chain(&b.dipole_part)
            .any(|v| (v - 0.5).abs() > 1e-3)
    });
    if confidence < 0.5 && deviates {
        eprintln!(
            "note: the estimate rests on few background peaks in some band (confidence {confidence:.2} < 0.5); the table applies its deviations from the ideal capsule in full, where the running self-calibration applies only what clears their sampling error: a longer recording gives a firmer estimate"
        );
    }
    if est.has_talker_shift() {
        eprintln!(
            "note: the table holds the bands' models only, not the estimate's talker shift (what the talker's places added to the omni parts' correction beside a noise source); started from the estimate instead (`locate --selfcal-in`), the localizer applies it"
        );
    }
    report_table(
        a,
        &table,
        &format!("the self-calibration estimate {}", path.display()),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::wav_io::{write_wav, OutFormat};

    /// `d/sweep.wav`: a 0.5 s, 16 kHz sweep up to 7 kHz made by `host-sim sweep`.
    fn short_sweep(d: &Path) -> PathBuf {
        let sweep = d.join("sweep.wav");
        crate::run([
            "host-sim",
            "sweep",
            "--out",
            &s(&sweep),
            "--seconds",
            "0.5",
            "--rate",
            "16000",
            "--f2",
            "7000",
        ])
        .unwrap();
        sweep
    }

    /// A 0.5 s, 16 kHz sweep up to 7 kHz made by `host-sim sweep`, its anechoic recordings at 0°,
    /// 120° and 240° made by `host-sim scene`, and their manifest `cal/list.csv` (with a header in
    /// the other column order).
    fn sweep_and_recordings(d: &Path) -> (PathBuf, PathBuf) {
        let sweep = short_sweep(d);
        let cal = d.join("cal");
        std::fs::create_dir(&cal).unwrap();
        let mut manifest = String::from("azimuth_deg,file\n");
        for az in [0, 120, 240] {
            let name = format!("az{az}.wav");
            crate::run([
                "host-sim",
                "scene",
                "--out",
                &s(&cal.join(&name)),
                "--source",
                &s(&sweep),
                "--rate",
                "16000",
                "--azimuth",
                &az.to_string(),
                "--lead-in",
                "0.05",
                "--snr",
                "40",
                "--format",
                "float",
            ])
            .unwrap();
            manifest.push_str(&format!("{az},{name}\n"));
        }
        let list = cal.join("list.csv");
        std::fs::write(&list, manifest).unwrap();
        (sweep, list)
    }

    /// `--dir` takes a manifest file or a folder; a folder without `calibration.csv` and a bad
    /// manifest are explained. The sweep's f1/f2 come from its file: without them calibration would
    /// assume 20 kHz, above the 8 kHz Nyquist frequency of the recordings, and refuse.
    #[test]
    fn manifest_files_and_sweep_parameters_from_the_sweep_file() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let (sweep, list) = sweep_and_recordings(d);
        let text = crate::calibration::sweep::read_info_comment(&sweep)
            .unwrap()
            .unwrap();
        assert_eq!(text, "cma-sweep f1=50 f2=7000 seconds=0.5 rate=16000");
        let out = d.join("t.cmat");
        let cal = list.parent().unwrap();
        let e = err_of(&[
            "calibrate",
            "--out",
            &s(&out),
            "--sweep",
            &s(&sweep),
            "--dir",
            &s(cal),
        ]);
        assert!(
            e.contains("calibration.csv")
                && e.contains("does not exist")
                && e.contains("file,azimuth_deg"),
            "{e}"
        );
        let e = err_of(&[
            "calibrate",
            "--out",
            &s(&out),
            "--sweep",
            &s(&sweep),
            "--dir",
            &s(&d.join("nowhere")),
        ]);
        assert!(
            e.contains("no such file or folder") && e.contains("file,azimuth_deg"),
            "{e}"
        );
        let bad = d.join("bad.csv");
        std::fs::write(&bad, "name,angle\naz0.wav,0\n").unwrap();
        let e = err_of(&[
            "calibrate",
            "--out",
            &s(&out),
            "--sweep",
            &s(&sweep),
            "--dir",
            &s(&bad),
        ]);
        assert!(
            e.contains("bad.csv:1:") && e.contains("`file,azimuth_deg`"),
            "{e}"
        );
        std::fs::write(&bad, "file,azimuth_deg\naz0.wav,north\n").unwrap();
        let e = err_of(&[
            "calibrate",
            "--out",
            &s(&out),
            "--sweep",
            &s(&sweep),
            "--dir",
            &s(&bad),
        ]);
        assert!(
            e.contains("bad.csv:2:") && e.contains("`north` is not a number"),
            "{e}"
        );
        assert!(!out.exists());

        crate::run([
            "host-sim",
            "calibrate",
            "--out",
            &s(&out),
            "--sweep",
            &s(&sweep),
            "--manifest",
            &s(&list),
            "--freq-hi",
            "3000",
        ])
        .unwrap();
        let t = OwnedTable::read(&out).unwrap();
        assert_eq!(t.azimuths_deg, [0.0, 120.0, 240.0]);
        // The folder form finds calibration.csv.
        std::fs::copy(&list, cal.join(MANIFEST_NAME)).unwrap();
        let out2 = d.join("t2.cmat");
        crate::run([
            "host-sim",
            "calibrate",
            "--out",
            &s(&out2),
            "--sweep",
            &s(&sweep),
            "--dir",
            &s(cal),
            "--freq-hi",
            "3000",
        ])
        .unwrap();
        assert_eq!(OwnedTable::read(&out2).unwrap(), t);
        // --f2 overrides the file (and 20 kHz is refused for a 16 kHz recording).
        let e = err_of(&[
            "calibrate",
            "--out",
            &s(&out2),
            "--sweep",
            &s(&sweep),
            "--dir",
            &s(&list),
            "--f2",
            "20000",
        ]);
        assert!(
            e.contains("--f2: 20000 Hz is above half of --rate 16000"),
            "{e}"
        );
    }

    /// A measured `--table` switches the self-calibration off (it corrects toward the ideal model);
    /// `--selfcal on` keeps it in the configuration, which the localizer then refuses.
    #[test]
    fn a_measured_table_turns_the_self_calibration_off() {
        use clap::Parser;
        let config = |extra: &[&str]| {
            let args = ["host-sim", "locate", "x.wav"].iter().chain(extra);
            match crate::Cli::try_parse_from(args).unwrap().command {
                crate::Command::Locate(a) => a.config.config().unwrap(),
                _ => unreachable!("a locate command"),
            }
        };
        assert!(config(&[]).capsule_calibration.enabled);
        assert!(!config(&["--table", "t.cmat"]).capsule_calibration.enabled);
        let on = config(&["--table", "t.cmat", "--selfcal", "on"]);
        assert!(on.capsule_calibration.enabled);
    }

    /// A sweep from elsewhere (no comment) falls back to the defaults, and says so.
    #[test]
    fn a_foreign_sweep_file_gets_a_note() {
        let dir = tempfile::tempdir().unwrap();
        let sweep = dir.path().join("other.wav");
        let x: Vec<f32> = SweepSpec {
            f1: 50.0,
            f2: 7000.0,
            seconds: 0.2,
            rate: 16_000,
        }
        .generate()
        .iter()
        .map(|v| *v as f32)
        .collect();
        write_wav(&sweep, 16_000, 1, &x, OutFormat::Float).unwrap();
        let parse = |extra: &[&str]| {
            use clap::Parser;
            let mut v: Vec<String> = ["host-sim", "calibrate", "--out", "t.cmat", "--sweep"]
                .map(String::from)
                .to_vec();
            v.push(s(&sweep));
            v.extend(extra.iter().map(|x| x.to_string()));
            match crate::Cli::try_parse_from(v).unwrap().command {
                crate::Command::Calibrate(a) => a,
                _ => unreachable!("a calibrate command"),
            }
        };
        let (_, spec, notes) = resolve_sweep(&parse(&[])).unwrap();
        assert_eq!((spec.f1, spec.f2, spec.rate), (50.0, 20_000.0, 16_000));
        assert!(notes[0].contains("does not say its f1/f2"), "{notes:?}");
        let (_, spec, notes) = resolve_sweep(&parse(&["--f1", "60", "--f2", "7000"])).unwrap();
        assert_eq!((spec.f1, spec.f2), (60.0, 7000.0));
        assert!(notes.is_empty());
        assert!((spec.seconds - 0.2).abs() < 1e-9);
    }

    #[test]
    fn symmetry_warning_says_by_how_much() {
        let check = measured_table::SymmetryCheck {
            gain_1_over_0_db: Some(-2.04),
            pairs_0_1: 7,
            gain_2_over_1_db: Some(0.3),
        };
        let w = symmetry_warning(&check).unwrap();
        assert!(
            w.contains("2.04 dB") && w.contains("7 mirrored") && w.contains("+0.30 dB"),
            "{w}"
        );
        let matched = measured_table::SymmetryCheck {
            gain_1_over_0_db: Some(0.1),
            pairs_0_1: 7,
            gain_2_over_1_db: None,
        };
        assert_eq!(symmetry_warning(&matched), None);
        let none = measured_table::SymmetryCheck {
            gain_1_over_0_db: None,
            pairs_0_1: 0,
            gain_2_over_1_db: None,
        };
        assert!(symmetry_warning(&none).unwrap().contains("could not check"));
    }

    fn s(p: &Path) -> String {
        p.display().to_string()
    }

    /// The error message of `host-sim ARGS…`, which must fail.
    fn err_of(args: &[&str]) -> String {
        crate::run(core::iter::once("host-sim").chain(args.iter().copied()))
            .unwrap_err()
            .to_string()
    }

    /// The error of calibrating from the one recording `rec` at 0° against `sweep`.
    fn calibrate_err(out: &Path, sweep: &Path, rec: &Path) -> String {
        err_of(&[
            "calibrate",
            "--out",
            &s(out),
            "--sweep",
            &s(sweep),
            "--f2",
            "7000",
            "--rec",
            &format!("0={}", s(rec)),
        ])
    }

    #[test]
    fn cli_errors_are_clear_and_write_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let sweep = short_sweep(d);
        // A 2-channel "recording".
        let two = d.join("two.wav");
        write_wav(&two, 16_000, 2, &vec![0.1; 2 * 16_000], OutFormat::Pcm16).unwrap();
        let out = d.join("t.cmat");
        let e = calibrate_err(&out, &sweep, &two);
        assert!(e.contains("expected 4 channels"), "{e}");
        let e = err_of(&["calibrate", "--out", &s(&out), "--rec", "north=x.wav"]);
        assert!(e.contains("not an azimuth"), "{e}");
        // A 4-channel recording of silence: no impulse response in it.
        let four = d.join("four.wav");
        write_wav(&four, 16_000, 4, &vec![0.0; 4 * 16_000], OutFormat::Pcm16).unwrap();
        let e = calibrate_err(&out, &sweep, &four);
        assert!(e.contains("does not match the sweep"), "{e}");
        assert!(!out.exists());
        // A table file with a bad header is refused by locate.
        let bad = d.join("bad.cmat");
        std::fs::write(&bad, b"CMAREFT\0\x07\0\0\0\x48\0\x01\0\0\0\0\0").unwrap();
        let e = err_of(&["locate", &s(&four), "--table", &s(&bad)]);
        assert!(e.contains("bad.cmat") && e.contains("truncated"), "{e}");
        let names: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert!(names.iter().all(|n| !n.contains("partial")), "{names:?}");
    }
}
