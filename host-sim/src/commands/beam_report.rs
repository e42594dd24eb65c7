//! `host-sim beam-report`: the beamformer's SNR gain and front/back ratio on simulated scenes.

use crate::error::Result;
use crate::localization::beam;
use std::path::PathBuf;

/// `host-sim beam-report`.
#[derive(Debug, clap::Args)]
pub struct BeamReportArgs {
    /// Source-material folder (`shared/data/src`: speech/, rir/).
    pub data: PathBuf,
    /// Diffuse-noise SNR on the omni, dB.
    #[arg(long, default_value_t = 0.0, value_parser = crate::flags::arg_values::decibels)]
    pub snr: f64,
}

/// Runs `host-sim beam-report`.
pub fn run(a: &BeamReportArgs) -> Result<()> {
    let rows = beam::beam_report(&a.data, a.snr, 16_000)?;
    crate::io::stdout_text::print_text(&beam::format_report(&rows))
}
