//! `host-sim eval`: the localizer on an evaluation folder, scored against ground truth.

use super::progress_bar;
use crate::error::{Result, SimError};
use crate::evaluation::{eval, plots};
use crate::flags::arg_values;
use crate::flags::config_args::{ConfigArgs, OnOff};
use crate::io::stdout_text;
use crate::io::wav_io::InputLayout;
use std::path::PathBuf;

/// `host-sim eval`.
#[derive(Debug, clap::Args)]
#[command(after_help = format!("{}\n\n{}", eval::COLUMNS_HELP, crate::evaluation::multi_talker_eval::COLUMNS_HELP))]
pub struct EvalArgs {
    /// Folder with manifest.csv (as `host-sim scene --manifest DIR/manifest.csv` writes it).
    pub dir: PathBuf,
    /// Print the report as JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Write PNG plots into this folder: track vs truth per scene (NAME.png) and accuracy vs
    /// tolerance (accuracy.png); for a multi-talker folder every track in its colour vs each
    /// talker's truth per scene.
    #[arg(long)]
    pub plots: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = arg_values::threads)]
    pub threads: Option<usize>,
    /// Channel layout of the scenes.
    #[arg(long, value_enum, default_value_t = InputLayout::Cma1)]
    pub input_layout: InputLayout,
    /// Localizer configuration.
    #[command(flatten)]
    pub config: ConfigArgs,
}

/// File name of the accuracy-vs-tolerance plot in `--plots DIR`.
const ACCURACY_PLOT: &str = "accuracy.png";

/// Runs `host-sim eval`.
pub fn run(a: &EvalArgs) -> Result<()> {
    if let Some(dir) = &a.plots {
        // Refused before the work, not after the report.
        if dir.exists() && !dir.is_dir() {
            return Err(SimError::Usage(format!(
                "--plots {}: not a folder (the plots go into a folder, made if missing)",
                dir.display()
            )));
        }
    }
    if crate::evaluation::multi_talker_eval::is_multi_talker_folder(&a.dir) {
        if a.config.multi_talker == Some(OnOff::Off) {
            return Err(SimError::Usage(format!(
                "--multi-talker off cannot be used with the multi-talker folder {}: its \
                 evaluation runs the multi-talker tracks (drop --multi-talker off)",
                a.dir.display()
            )));
        }
        return crate::evaluation::multi_talker_eval::run(a);
    }
    let config = a.config.config()?;
    let measured = a.config.measured_table()?;
    let table = a.config.table(measured.as_ref())?;
    let threads = a
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let pb = progress_bar(eval::total_frames(&a.dir));
    let (report, scenes) = eval::evaluate(&a.dir, config, table, a.input_layout, threads, &|n| {
        pb.inc(n)
    })?;
    pb.finish_and_clear();
    if a.json {
        let json =
            serde_json::to_string_pretty(&report).map_err(|e| SimError::Other(e.to_string()))?;
        stdout_text::print_text(&format!("{json}\n"))?;
    } else {
        stdout_text::print_text(&eval::format_table(&report))?;
    }
    if let Some(dir) = &a.plots {
        std::fs::create_dir_all(dir).map_err(|e| SimError::doing("create the folder", dir, e))?;
        plots::accuracy_plot(&dir.join(ACCURACY_PLOT), &report)?;
        for s in &scenes {
            let name = s.entry.name();
            // A scene named like the summary plot does not replace it.
            let file = match format!("{name}.png") {
                f if f == ACCURACY_PLOT => format!("{name}.track.png"),
                f => f,
            };
            plots::track_plot(&dir.join(file), s)?;
        }
    }
    Ok(())
}
