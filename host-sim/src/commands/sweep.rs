//! `host-sim sweep`: the exponential sine sweep (thesis eq. 2.43) to play for a calibration.

use crate::calibration::sweep::SweepSpec;
use crate::error::{Result, SimError};
use crate::io::wav_io::{write_wav_with_comment, OutFormat};
use std::path::PathBuf;

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

/// Runs `host-sim sweep`.
pub fn run(a: &SweepArgs) -> Result<()> {
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
    write_wav_with_comment(
        &a.out,
        spec.rate,
        1,
        &s,
        a.format,
        Some(&spec.info_comment()),
    )
}
