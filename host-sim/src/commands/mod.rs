//! The subcommands of `host-sim`, one module each: its flags (a `clap::Args` struct) and its `run`.
//! The work is done by the library modules beside this folder.

pub mod beam;
pub mod beam_report;
pub mod calibrate;
pub mod config;
pub mod distance_report;
pub mod emit;
pub mod eval;
pub mod locate;
pub mod monitor;
pub mod options_eval;
pub mod scene;
pub mod score;
pub mod sweep;

/// The progress bar of the commands that run through many sample frames.
pub(crate) fn progress_bar(total: u64) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(total);
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{bar:40} {percent:>3}% {elapsed_precise} eta {eta}",
        )
        .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    pb
}
