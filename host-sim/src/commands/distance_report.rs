//! `host-sim distance-report`: the proximity-effect distance estimate on simulated near-field scenes.

use crate::error::Result;
use std::path::PathBuf;

/// `host-sim distance-report`.
#[derive(Debug, clap::Args)]
pub struct DistanceReportArgs {
    /// Source-material folder (`shared/data/src`).
    pub data: PathBuf,
    /// Low band for the distance features, Hz.
    #[arg(long, default_value_t = 80.0)]
    pub band_lo: f32,
    /// Upper edge of the band, Hz.
    #[arg(long, default_value_t = 500.0)]
    pub band_hi: f32,
    /// Peaks per long frame.
    #[arg(long, default_value_t = 5)]
    pub peaks: usize,
}

/// Runs `host-sim distance-report`.
pub fn run(a: &DistanceReportArgs) -> Result<()> {
    let snrs = [None, Some(20.0), Some(10.0), Some(0.0)];
    let rows = crate::evaluation::distance_eval::distance_report(
        &a.data,
        &snrs,
        (a.band_lo, a.band_hi),
        a.peaks.max(1),
    )?;
    crate::io::stdout_text::print_text(&crate::evaluation::distance_eval::format_report(&rows))
}
