//! Command-line side of the calibration: `host-sim sweep` and `host-sim calibrate` (argument parsing,
//! file reading, the table plot). The computation is in [`crate::calibrate`].

use crate::calibrate::{self, CalibrationOptions, Measurement};
use crate::error::{Result, SimError};
use crate::sweep::SweepSpec;
use crate::table_io::OwnedTable;
use crate::wav_io::{read_four_channels, read_mono, write_wav, OutFormat};
use cma_core::CARDIOID_LOOK_DEG;
use plotters::prelude::*;
use std::path::{Path, PathBuf};

/// Sweep parameters on the command line.
#[derive(Debug, Clone, clap::Args)]
pub struct SweepParams {
    /// Start frequency f1, Hz.
    #[arg(long, default_value_t = 50.0)]
    pub f1: f64,
    /// Stop frequency f2, Hz.
    #[arg(long, default_value_t = 20_000.0)]
    pub f2: f64,
    /// Duration, s.
    #[arg(long, default_value_t = 5.0)]
    pub seconds: f64,
    /// Sample rate, Hz.
    #[arg(long, default_value_t = 48_000)]
    pub rate: u32,
}

impl SweepParams {
    fn spec(&self) -> SweepSpec {
        SweepSpec {
            f1: self.f1,
            f2: self.f2,
            seconds: self.seconds,
            rate: self.rate,
        }
    }
}

/// `host-sim sweep`.
#[derive(Debug, clap::Args)]
pub struct SweepArgs {
    /// Output WAV (mono).
    #[arg(long)]
    pub out: PathBuf,
    /// Sweep parameters.
    #[command(flatten)]
    pub sweep: SweepParams,
    /// Peak level, dBFS.
    #[arg(long, allow_hyphen_values = true, default_value_t = -6.0)]
    pub peak_dbfs: f64,
    /// Sample format.
    #[arg(long, value_enum, default_value_t = OutFormat::Float)]
    pub format: OutFormat,
}

/// `host-sim calibrate`.
#[derive(Debug, clap::Args)]
pub struct CalibrateArgs {
    /// Output reference-table file (`.cmat`).
    #[arg(long)]
    pub out: PathBuf,
    /// A recording: AZIMUTH=FILE.wav (4 channels, CMA1 order); repeat for every azimuth.
    #[arg(long = "rec", allow_hyphen_values = true)]
    pub recordings: Vec<String>,
    /// A folder with `calibration.csv` (`file,azimuth_deg`, paths relative to the folder).
    #[arg(long)]
    pub dir: Option<PathBuf>,
    /// The sweep as played (mono WAV); default: generated from --f1/--f2/--seconds/--rate.
    #[arg(long)]
    pub sweep: Option<PathBuf>,
    /// Sweep parameters (--f1/--f2 also set the deconvolution's band with --sweep FILE).
    #[command(flatten)]
    pub params: SweepParams,
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
}

/// Runs `host-sim sweep`.
pub fn cmd_sweep(a: &SweepArgs) -> Result<()> {
    let spec = a.sweep.spec();
    spec.validate()?;
    if !(a.peak_dbfs <= 0.0 && a.peak_dbfs > -60.0) {
        return Err(SimError::Usage(format!(
            "--peak-dbfs: expected −60 < level ≤ 0, got {}",
            a.peak_dbfs
        )));
    }
    let g = 10f64.powf(a.peak_dbfs / 20.0);
    let s: Vec<f32> = spec.generate().iter().map(|v| (v * g) as f32).collect();
    write_wav(&a.out, spec.rate, 1, &s, a.format)
}

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
        let path = dir.join("calibration.csv");
        let text = std::fs::read_to_string(&path).map_err(|e| SimError::io(&path, e))?;
        for (i, line) in text.lines().enumerate() {
            let line = line.trim();
            if line.is_empty() || (i == 0 && line.starts_with("file")) {
                continue;
            }
            let bad = |reason: &str| SimError::BadCsv {
                path: path.clone(),
                line: i + 1,
                reason: reason.into(),
            };
            let (file, az) = line
                .split_once(',')
                .ok_or_else(|| bad("expected `file,azimuth_deg`"))?;
            let az = az
                .trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| bad("azimuth is not a number"))?;
            list.push((az, dir.join(file.trim())));
        }
    }
    Ok(list)
}

/// Runs `host-sim calibrate`.
pub fn cmd_calibrate(a: &CalibrateArgs) -> Result<()> {
    if let Some(p) = &a.plot {
        if p.extension().and_then(|e| e.to_str()) != Some("png") {
            return Err(SimError::Usage(format!(
                "--plot: expected a .png file, got {}",
                p.display()
            )));
        }
    }
    let (sweep, spec) = match &a.sweep {
        Some(path) => {
            let (rate, s) = read_mono(path)?;
            let s: Vec<f64> = s.iter().map(|v| f64::from(*v)).collect();
            let spec = SweepSpec {
                rate,
                seconds: s.len() as f64 / f64::from(rate),
                ..a.params.spec()
            };
            (s, spec)
        }
        None => {
            let spec = a.params.spec();
            spec.validate()?;
            (spec.generate(), spec)
        }
    };
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
    let (table, infos) = calibrate::calibrate(&measurements, &sweep, &opts)?;
    table.write(&a.out)?;
    let crest = infos
        .iter()
        .map(|i| i.crest_db)
        .fold(f64::INFINITY, f64::min);
    eprintln!(
        "{}: {} azimuths × {} frequencies ({}–{} Hz) from {} recordings; lowest IR crest factor {crest:.1} dB; max |feature − ideal| {:.3}",
        a.out.display(),
        table.azimuths_deg.len(),
        table.freqs_hz.len(),
        table.freqs_hz.first().copied().unwrap_or(0.0),
        table.freqs_hz.last().copied().unwrap_or(0.0),
        infos.len(),
        calibrate::max_deviation_from_ideal(&table)
    );
    if let Some(p) = &a.plot {
        table_plot(p, &table)?;
    }
    Ok(())
}

/// Draws a table: features vs azimuth per capsule at four frequency rows (near 300, 1000, 2000 and
/// 3500 Hz), with the ideal cardioid model in grey. Written atomically.
pub fn table_plot(path: &Path, t: &OwnedTable) -> Result<()> {
    crate::plots::ensure_font()?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".partial.{name}"));
    let result = draw_table(&tmp, t);
    match result {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|e| SimError::io(path, e)),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
}

fn draw_table(path: &Path, t: &OwnedTable) -> Result<()> {
    let err = |e: &dyn std::fmt::Debug| {
        SimError::Other(format!("{}: plotting failed: {e:?}", path.display()))
    };
    let table = t.as_table()?;
    let q = t.azimuths_deg.len();
    let ymax = t.features.iter().flatten().fold(1.0f32, |m, v| m.max(*v)) as f64 * 1.05;
    let root = BitMapBackend::new(path, (1100, 800)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let root = root
        .titled(
            "calibrated reference table: |H_c| / |H_0| vs azimuth (grey: ideal cardioid)",
            ("sans-serif", 22),
        )
        .map_err(|e| err(&e))?;
    let colors = [
        RGBColor(200, 30, 30),
        RGBColor(30, 140, 30),
        RGBColor(30, 60, 200),
    ];
    for (area, f_want) in root
        .split_evenly((2, 2))
        .iter()
        .zip([300.0, 1000.0, 2000.0, 3500.0])
    {
        let fi = table.freq_index(f_want);
        let row = table.row(fi);
        let mut chart = ChartBuilder::on(area)
            .caption(format!("{:.0} Hz", t.freqs_hz[fi]), ("sans-serif", 18))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(40)
            .build_cartesian_2d(0.0..360.0, 0.0..ymax)
            .map_err(|e| err(&e))?;
        chart
            .configure_mesh()
            .x_desc("azimuth (°)")
            .y_desc("feature")
            .draw()
            .map_err(|e| err(&e))?;
        for (m, color) in colors.iter().enumerate() {
            let look = f64::from(CARDIOID_LOOK_DEG[m]);
            chart
                .draw_series(LineSeries::new(
                    (0..=360).map(|a| {
                        let a = f64::from(a);
                        (a, 0.5 + 0.5 * (a - look).to_radians().cos())
                    }),
                    RGBColor(170, 170, 170).stroke_width(1),
                ))
                .map_err(|e| err(&e))?;
            let pts: Vec<(f64, f64)> = (0..q)
                .map(|qi| (f64::from(t.azimuths_deg[qi]), f64::from(row[qi][m])))
                .collect();
            chart
                .draw_series(LineSeries::new(pts.clone(), color.stroke_width(2)))
                .map_err(|e| err(&e))?
                .label(format!("cardioid {look:.0}°"))
                .legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2))
                });
            chart
                .draw_series(pts.iter().map(|p| Circle::new(*p, 2, color.filled())))
                .map_err(|e| err(&e))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(|e| err(&e))?;
    }
    root.present().map_err(|e| err(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

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
