//! `host-sim config`: the localizer configuration that the same flags would give `locate` or `eval`
//! (preset, then `--config FILE`, then the flags), printed as a complete configuration file — the
//! file `--config` reads and the firmware embeds (`CMA_CONFIG`). Reading it back gives the same
//! configuration.

use crate::error::{Result, SimError};
use crate::flags::config_args::ConfigArgs;
use crate::io::{output_file, stdout_text};
use std::path::PathBuf;

/// `host-sim config`.
#[derive(Debug, clap::Args)]
pub struct ConfigCmdArgs {
    /// Write the file here instead of stdout.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// The configuration to print.
    #[command(flatten)]
    pub config: ConfigArgs,
}

/// Runs `host-sim config`.
pub fn run(a: &ConfigCmdArgs) -> Result<()> {
    let config = a.config.config()?;
    cma_config::validate(&config).map_err(|e| SimError::Usage(e.to_string()))?;
    let text = cma_config::to_toml(&config);
    match &a.out {
        Some(path) => output_file::write(path, |tmp| {
            std::fs::write(tmp, &text).map_err(|e| SimError::io(tmp, e))
        }),
        None => stdout_text::print_text(&text),
    }
}
