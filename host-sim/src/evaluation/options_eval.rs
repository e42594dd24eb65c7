//! The thesis's alternative options on the command line ([`OptionArgs`], flattened into every
//! configuration) and `host-sim options-eval`: every option against the default on one evaluation
//! folder, as a Markdown table (`docs/options.md`).

use crate::error::{Result, SimError};
use crate::evaluation::eval;
use crate::io::wav_io::InputLayout;
use cma_core::cartesian_filter::Smoothing;
use cma_core::combination::{Combination, FdivSpread};
use cma_core::frame_quality::QualityMeasures;
use cma_core::LocatorConfig;
use std::path::Path;

/// Peak combination rule on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CombinationArg {
    /// Rule 1: mean similarity curve, then argmax (eq. 5.11–5.12).
    MeanCurve,
    /// Rule 2: per-peak argmax, circular mean (eq. 5.13).
    PeakMean,
    /// Rule 2: per-peak argmax, circular median.
    PeakMedian,
}

/// Where b filters, on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum SmoothingArg {
    /// The similarity curve (eq. 5.31).
    Curve,
    /// The result as a unit vector (eq. 5.30).
    Cartesian,
}

/// Flags of the thesis alternatives. Unset flags keep the preset's value.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct OptionArgs {
    /// Frame quality measures multiplied into b (eq. 5.36): comma list of `variance`, `power`,
    /// `peak-power`, `zcr`.
    #[arg(long)]
    pub quality: Option<String>,
    /// Scale P_max of the frame-power measure (full scale = 1).
    #[arg(long, value_parser = crate::flags::arg_values::positive)]
    pub power_max: Option<f32>,
    /// Scale of the peak-frequency-power measure (|X|² of the unnormalised 512-point FFT).
    #[arg(long, value_parser = crate::flags::arg_values::positive)]
    pub peak_power_max: Option<f32>,
    /// ZCR voice-activity threshold, crossings per second.
    #[arg(long, value_parser = crate::flags::arg_values::finite)]
    pub zcr_threshold: Option<f32>,
    /// Binary threshold b_TH on b (eq. 5.27–5.29; 0 = off).
    #[arg(long, value_parser = crate::flags::arg_values::finite)]
    pub binary_threshold: Option<f32>,
    /// Peak combination rule.
    #[arg(long, value_enum)]
    pub combination: Option<CombinationArg>,
    /// Where the reliability coefficient filters.
    #[arg(long, value_enum)]
    pub smoothing: Option<SmoothingArg>,
    /// FDIV: reliability from the circular std over bins, scale s_max in degrees (0 = off).
    #[arg(long, value_parser = crate::flags::arg_values::finite)]
    pub fdiv_std: Option<f32>,
    /// FDIV: make the circular-std reliability binary (b = 1 when s ≤ s_max).
    #[arg(long)]
    pub fdiv_std_binary: bool,
}

impl OptionArgs {
    /// Writes the set flags into `c`.
    pub fn apply(&self, c: &mut LocatorConfig) -> Result<()> {
        if let Some(list) = &self.quality {
            let mut m = QualityMeasures {
                curve_variance: false,
                frame_power: false,
                peak_power: false,
                zcr: false,
            };
            for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
                match item {
                    "variance" => m.curve_variance = true,
                    "power" => m.frame_power = true,
                    "peak-power" => m.peak_power = true,
                    "zcr" => m.zcr = true,
                    other => {
                        return Err(SimError::Usage(format!(
                            "--quality: expected variance, power, peak-power or zcr, got `{other}`"
                        )))
                    }
                }
            }
            c.quality.measures = m;
        }
        if let Some(v) = self.power_max {
            c.quality.power_max = v;
        }
        if let Some(v) = self.peak_power_max {
            c.quality.peak_power_max = v;
        }
        if let Some(v) = self.zcr_threshold {
            c.quality.zcr_threshold_hz = v;
        }
        if let Some(v) = self.binary_threshold {
            c.quality.binary_threshold = v;
        }
        if let Some(v) = self.combination {
            c.alternative.combination = match v {
                CombinationArg::MeanCurve => Combination::MeanCurve,
                CombinationArg::PeakMean => Combination::PeakCircularMean,
                CombinationArg::PeakMedian => Combination::PeakCircularMedian,
            };
        }
        if let Some(v) = self.smoothing {
            c.alternative.smoothing = match v {
                SmoothingArg::Curve => Smoothing::Curve,
                SmoothingArg::Cartesian => Smoothing::Cartesian,
            };
        }
        if let Some(v) = self.fdiv_std {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(SimError::Usage(format!(
                    "--fdiv-std: expected degrees ≥ 0, got {v}"
                )));
            }
            c.intensity.fdiv_spread = FdivSpread {
                max_std_deg: v,
                binary: self.fdiv_std_binary,
            };
        } else if self.fdiv_std_binary {
            c.intensity.fdiv_spread.binary = true;
        }
        if self.fdiv_std_binary && !c.intensity.fdiv_spread.enabled() {
            return Err(SimError::Usage(
                "--fdiv-std-binary needs the circular-std reliability on: give --fdiv-std S_MAX \
                 with S_MAX > 0 (or fdiv_spread.max_std_deg in the file)"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// The variants `options-eval` runs: (label, extra flags). The first is the reference.
pub const VARIANTS: &[(&str, &str)] = &[
    ("default", ""),
    ("no reliability (QMoff)", "--no-reliability"),
    ("quality power", "--quality power"),
    (
        "quality power, P_max ×0.25",
        "--quality power --power-max 0.00625",
    ),
    ("quality peak-power", "--quality peak-power"),
    (
        "quality peak-power, scale ×0.1",
        "--quality peak-power --peak-power-max 0.5",
    ),
    ("quality zcr", "--quality zcr"),
    ("variance × power", "--quality variance,power"),
    ("variance × peak-power", "--quality variance,peak-power"),
    ("variance × zcr", "--quality variance,zcr"),
    ("binary b_TH 0.02", "--binary-threshold 0.02"),
    ("binary b_TH 0.05", "--binary-threshold 0.05"),
    ("binary b_TH 0.1", "--binary-threshold 0.1"),
    ("binary b_TH 0.2", "--binary-threshold 0.2"),
    ("Cartesian filter (5.30)", "--smoothing cartesian"),
    ("rule 2 circular mean", "--combination peak-mean"),
    ("rule 2 circular median", "--combination peak-median"),
    ("FDIV", "--method fdiv"),
    ("FDIV + circ. std 40°", "--method fdiv --fdiv-std 40"),
    ("FDIV + circ. std 90°", "--method fdiv --fdiv-std 90"),
    ("FDIV + circ. std 120°", "--method fdiv --fdiv-std 120"),
    (
        "FDIV + circ. std 30° binary",
        "--method fdiv --fdiv-std 30 --fdiv-std-binary",
    ),
    (
        "FDIV + circ. std 70° binary",
        "--method fdiv --fdiv-std 70 --fdiv-std-binary",
    ),
];

/// The configuration flags of `options-eval --base` (and of each variant): the localizer
/// configuration flags of `eval`, nothing else (`eval`'s own flags would do nothing here).
#[derive(Debug, clap::Parser)]
#[command(
    name = "--base",
    no_binary_name = true,
    allow_negative_numbers = true,
    disable_help_flag = true
)]
struct ConfigFlags {
    #[command(flatten)]
    config: crate::flags::config_args::ConfigArgs,
}

/// Parses `extra` flags on top of `base` (configuration flags as on the `eval` command line) into a
/// configuration and its ideal table's grid. Errors name `--base` and the flags.
pub fn variant_config(base: &[String], extra: &str) -> Result<(LocatorConfig, u32)> {
    let mut args: Vec<String> = base.to_vec();
    args.extend(extra.split_whitespace().map(String::from));
    let context = if extra.is_empty() {
        format!("--base `{}`", base.join(" "))
    } else {
        format!("--base `{}` with the variant `{extra}`", base.join(" "))
    };
    let flags = <ConfigFlags as clap::Parser>::try_parse_from(&args).map_err(|e| {
        // clap's first line says what is wrong; its usage line would show `--base` as a command.
        let e = e.to_string();
        let first = e.lines().next().unwrap_or_default();
        SimError::Usage(format!(
            "{context}: {}",
            first.trim_start_matches("error: ")
        ))
    })?;
    let config = flags.config.config().map_err(|e| match e {
        SimError::Usage(m) => SimError::Usage(format!("{context}: {m}")),
        other => other,
    })?;
    if flags.config.table.is_some() {
        return Err(SimError::Usage(format!(
            "{context}: --table cannot be used with options-eval: it evaluates on the ideal table \
             of --grid (drop --table)"
        )));
    }
    Ok((config, flags.config.grid))
}

/// Splits the text of `--base` into arguments as a POSIX shell would split a command line: at
/// unquoted white space, with '…' (literal) and "…" (where \\ and \" escape) quoting and \ escaping
/// one character outside quotes, so a path with spaces can be given (`--config 'my room.toml'`).
pub fn split_base(text: &str) -> Result<Vec<String>> {
    let mut args = Vec::new();
    let mut arg: Option<String> = None;
    let mut chars = text.chars();
    let unbalanced = |q: char| {
        SimError::Usage(format!(
            "--base: the quote {q} in `{text}` is not closed (quote a flag's value as in a shell: \
             --base \"--config 'my room.toml'\")"
        ))
    };
    while let Some(c) = chars.next() {
        match c {
            c if c.is_whitespace() => {
                if let Some(a) = arg.take() {
                    args.push(a);
                }
            }
            '\'' => {
                let a = arg.get_or_insert_with(String::new);
                loop {
                    match chars.next() {
                        Some('\'') => break,
                        Some(c) => a.push(c),
                        None => return Err(unbalanced('\'')),
                    }
                }
            }
            '"' => {
                let a = arg.get_or_insert_with(String::new);
                loop {
                    match chars.next() {
                        Some('"') => break,
                        Some('\\') => match chars.next() {
                            Some(c @ ('"' | '\\')) => a.push(c),
                            Some(c) => {
                                a.push('\\');
                                a.push(c);
                            }
                            None => return Err(unbalanced('"')),
                        },
                        Some(c) => a.push(c),
                        None => return Err(unbalanced('"')),
                    }
                }
            }
            '\\' => {
                let a = arg.get_or_insert_with(String::new);
                if let Some(c) = chars.next() {
                    a.push(c);
                }
            }
            c => arg.get_or_insert_with(String::new).push(c),
        }
    }
    args.extend(arg);
    Ok(args)
}

/// Runs every variant of [`VARIANTS`] on `dir` and writes the Markdown table to `sink`, a row at a
/// time.
pub fn options_table(
    dir: &Path,
    base: &[String],
    threads: usize,
    mut sink: impl std::io::Write,
) -> Result<()> {
    // Every variant's flags, and the folder's manifest, are checked before the first row is
    // written.
    for (_, extra) in VARIANTS {
        variant_config(base, extra)?;
    }
    crate::io::manifest::read(dir)?;
    let io = |e: std::io::Error| SimError::io("<output>", e);
    write!(sink, "{}", String::from(
        "| variant | flags | anechoic ACC5 / ACC10 / MAE | room ACC5 / ACC10 / MAE | jump ACC10 / settle (mean s) | moving ACC10 / MAE | all ACC5 / ACC10 / MAE |\n|---|---|---|---|---|---|---|\n",
    )).map_err(io)?;
    for (label, extra) in VARIANTS {
        let (config, grid) = variant_config(base, extra)?;
        let table = match grid {
            15 => cma_core::ReferenceTable::ideal_15deg(),
            _ => cma_core::ReferenceTable::ideal_5deg(),
        };
        let (report, _) = eval::evaluate(dir, config, table, InputLayout::Cma1, threads, &|_| {})?;
        let cell = |m: &crate::evaluation::metrics::Metrics| {
            format!("{:.1} / {:.1} / {:.2}", m.acc[4], m.acc[9], m.mae)
        };
        let set = |name: &str| report.sets.iter().find(|s| s.set == name);
        let std_cell = |name: &str| set(name).map_or("–".into(), |s| cell(&s.settled));
        let jump = set("jump").map_or("–".into(), |s| {
            let settles: Vec<f64> = s.jumps.iter().filter_map(|j| j.settle_s).collect();
            let mean = if settles.len() == s.jumps.len() && !settles.is_empty() {
                format!("{:.2}", settles.iter().sum::<f64>() / settles.len() as f64)
            } else {
                format!("{}/{} settled", settles.len(), s.jumps.len())
            };
            format!("{:.1} / {}", s.settled.acc[9], mean)
        });
        let moving = set("moving").map_or("–".into(), |s| {
            format!("{:.1} / {:.2}", s.settled.acc[9], s.settled.mae)
        });
        writeln!(
            sink,
            "| {label} | `{extra}` | {} | {} | {jump} | {moving} | {} |",
            std_cell("anechoic"),
            std_cell("room"),
            cell(&report.overall.settled),
        )
        .map_err(io)?;
        sink.flush().map_err(io)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use cma_core::config::Tracking;
    use cma_core::curve_kernel::CurveKernel;
    use cma_core::refine_curve::{DistancePower, RefineCurve};

    #[test]
    fn base_is_split_as_a_shell_splits_it() {
        let split = |t: &str| split_base(t).unwrap();
        assert_eq!(split(""), Vec::<String>::new());
        assert_eq!(split("  --preset   thesis "), ["--preset", "thesis"]);
        assert_eq!(
            split("--config 'my room.toml' --peaks=8"),
            ["--config", "my room.toml", "--peaks=8"]
        );
        assert_eq!(
            split(r#"--config "a \"b\" c.toml" x\ y ''"#),
            ["--config", r#"a "b" c.toml"#, "x y", ""]
        );
        for bad in ["--config 'room.toml", "--config \"room"] {
            let e = split_base(bad).unwrap_err().to_string();
            assert!(e.starts_with("--base: the quote") && e.contains(bad), "{e}");
        }
    }

    #[test]
    fn base_errors_name_base_and_the_flag() {
        let base = |t: &str| split_base(t).unwrap();
        let e = variant_config(&base("--frobnicate"), "").unwrap_err();
        let e = e.to_string();
        assert!(
            e.starts_with("--base `--frobnicate`: unexpected argument '--frobnicate'"),
            "{e}"
        );
        assert!(!e.contains("Usage") && !e.contains("eval"), "{e}");
        // eval's own flags would do nothing here.
        assert!(variant_config(&base("--json"), "").is_err());
        let e = variant_config(&base("--preset thesis"), "--sharpness 3")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("--base `--preset thesis` with the variant `--sharpness 3`: --sharpness"),
            "{e}"
        );
        let (c, grid) = variant_config(&base("--preset thesis --grid 15"), "").unwrap();
        assert_eq!((c, grid), (LocatorConfig::thesis(), 15));
    }

    #[test]
    fn flags_reach_the_config_and_defaults_are_untouched() {
        let (d, _) = variant_config(&[], "").unwrap();
        assert_eq!(d, LocatorConfig::default());
        let (c, _) = variant_config(
            &[],
            "--quality variance,zcr --binary-threshold 0.4 --combination peak-median --smoothing cartesian --fdiv-std 30 --fdiv-std-binary --power-max 0.5",
        )
        .unwrap();
        assert!(c.quality.measures.zcr && c.quality.measures.curve_variance);
        assert!(!c.quality.measures.frame_power);
        assert_eq!(c.quality.binary_threshold, 0.4);
        assert_eq!(c.quality.power_max, 0.5);
        assert_eq!(c.alternative.combination, Combination::PeakCircularMedian);
        assert_eq!(c.alternative.smoothing, Smoothing::Cartesian);
        assert!(c.intensity.fdiv_spread.enabled() && c.intensity.fdiv_spread.binary);
        let (c, _) = variant_config(&[], "--snr-from=-10 --snr-to 30 --snr-step 5").unwrap();
        assert_eq!(
            (
                c.curves.snr_from_db,
                c.curves.snr_to_db,
                c.curves.snr_step_db
            ),
            (-10.0, 30.0, 5.0)
        );
        for (flag, want) in [
            ("similarity", RefineCurve::Similarity),
            ("distance", RefineCurve::Distance),
            ("distance1.5", RefineCurve::Distance1_5),
            ("distance2", RefineCurve::Distance2),
        ] {
            let (c, _) = variant_config(&[], &format!("--refine-curve {flag}")).unwrap();
            let Tracking::Grid(t) = c.tracking else {
                panic!("grid tracker expected");
            };
            assert_eq!(t.refine_curve, want, "{flag}");
        }
        assert!(variant_config(&[], "--refine-curve distance3").is_err());
        // The curve kernel: the default's d^1.5, the thesis's reciprocal, and the scale.
        let dist = |power, scale| CurveKernel::Distance { power, scale };
        for (flags, want) in [
            ("", dist(DistancePower::ThreeHalves, 1.5)),
            ("--kernel reciprocal", CurveKernel::Reciprocal),
            ("--kernel distance", dist(DistancePower::One, 1.5)),
            (
                "--kernel distance2 --kernel-scale 3",
                dist(DistancePower::Two, 3.0),
            ),
            ("--kernel-scale 2", dist(DistancePower::ThreeHalves, 2.0)),
            ("--preset thesis", CurveKernel::Reciprocal),
            (
                "--preset thesis --kernel distance1.5",
                dist(DistancePower::ThreeHalves, 1.5),
            ),
        ] {
            let (c, _) = variant_config(&[], flags).unwrap();
            assert_eq!(c.kernel, want, "{flags}");
        }
        assert!(variant_config(&[], "--kernel reciprocal --kernel-scale 2").is_err());
        assert!(variant_config(&[], "--preset thesis --kernel-scale 2").is_err());
        assert!(variant_config(&[], "--kernel distance3").is_err());
        assert!(variant_config(&[], "--quality loudness").is_err());
        assert!(variant_config(&[], "--fdiv-std -1").is_err());
        for (_, extra) in VARIANTS {
            assert!(variant_config(&[], extra).is_ok(), "{extra}");
        }
    }
}
