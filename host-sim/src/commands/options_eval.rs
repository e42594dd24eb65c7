//! `host-sim options-eval`: every thesis option against the default on an evaluation folder, as a
//! Markdown table.

use crate::error::Result;
use std::path::PathBuf;

/// `host-sim options-eval`.
#[derive(Debug, clap::Args)]
pub struct OptionsEvalArgs {
    /// Folder with manifest.csv.
    pub dir: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(long, value_parser = crate::flags::arg_values::threads)]
    pub threads: Option<usize>,
    /// Configuration flags applied to every variant (as on the `eval` command line; not eval's own
    /// flags such as --json), as one argument split as a shell splits it, so a value with spaces
    /// is quoted inside: `--base "--preset thesis --config 'my room.toml'"`.
    #[arg(long, allow_hyphen_values = true, value_name = "FLAGS")]
    pub base: Option<String>,
}

/// Runs `host-sim options-eval`.
pub fn run(a: &OptionsEvalArgs) -> Result<()> {
    let threads = a
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    let base = crate::evaluation::options_eval::split_base(a.base.as_deref().unwrap_or(""))?;
    crate::evaluation::options_eval::options_table(&a.dir, &base, threads, std::io::stdout().lock())
}
