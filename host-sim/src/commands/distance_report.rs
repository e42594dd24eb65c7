//! `host-sim distance-report`: the proximity-effect distance estimate on simulated near-field scenes.

use crate::error::{Result, SimError};
use std::path::PathBuf;

/// Sample rate of the report's scenes, Hz.
const RATE_HZ: f32 = 16_000.0;

/// `host-sim distance-report`.
#[derive(Debug, clap::Args)]
#[command(after_help = DISTANCE_REPORT_AFTER_HELP)]
pub struct DistanceReportArgs {
    /// Source-material folder holding speech/cmu_arctic_us_aew_a0001.wav and
    /// speech/cmu_arctic_us_axb_a0004.wav (e.g. `shared/data/src`).
    pub data: PathBuf,
    /// Lower edge of the band the distance features are taken from, Hz (its own band, not the
    /// localizer's analysis band).
    #[arg(long, default_value_t = 80.0)]
    pub band_lo: f32,
    /// Upper edge of that band, Hz (at most 8000, the scenes' Nyquist frequency).
    #[arg(long, default_value_t = 500.0)]
    pub band_hi: f32,
    /// Strongest peaks of the omni spectrum in the band used per long frame (at least 1).
    #[arg(long, default_value_t = 5)]
    pub peaks: usize,
}

/// The end of `distance-report --help`: what the command renders and prints.
const DISTANCE_REPORT_AFTER_HELP: &str = "Renders the two talkers of DATA/speech at 0°, 70°, 150° \
     and −100° as near-field point sources at 0.5, 1 and 2 m (anechoic, 16 kHz), clean and with \
     diffuse noise at 20, 10 and 0 dB SNR; the azimuth is given, as the thesis's eq. 5.15 assumes. \
     Each 128 ms frame (2048 samples) less than 30 dB below a scene's loudest is classified as the \
     nearest reference distance, and each scene by its summed scores. Prints a Markdown table: per \
     SNR and true distance, the share of frames classified as 0.5 / 1 / 2 m, the frame accuracy and \
     the scene counts. Nothing is written to files; the localizer's configuration flags do not \
     apply.";

/// Runs `host-sim distance-report`.
pub fn run(a: &DistanceReportArgs) -> Result<()> {
    let (lo, hi) = (a.band_lo, a.band_hi);
    if !(lo >= 0.0 && lo < hi && hi <= RATE_HZ / 2.0) {
        return Err(SimError::Usage(format!(
            "--band-lo {lo}, --band-hi {hi}: need 0 ≤ --band-lo < --band-hi ≤ {} Hz",
            RATE_HZ / 2.0
        )));
    }
    if a.peaks == 0 {
        return Err(SimError::Usage(
            "--peaks: need at least 1 peak, got 0".into(),
        ));
    }
    let snrs = [None, Some(20.0), Some(10.0), Some(0.0)];
    let rows = crate::evaluation::distance_eval::distance_report(
        &a.data,
        &snrs,
        (a.band_lo, a.band_hi),
        a.peaks,
    )?;
    crate::io::stdout_text::print_text(&crate::evaluation::distance_eval::format_report(&rows))
}
