//! `host-sim` command-line entry point; everything lives in the `host_sim` library.
//!
//! Exit status: 0 on success, 1 when a command fails, 2 for a usage error (a flag clap rejects or a
//! value outside its range), as clap's own.

use host_sim::error::SimError;
use std::process::ExitCode;

fn main() -> ExitCode {
    match host_sim::run(std::env::args_os()) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of the output went away (`host-sim eval … | head`): not a failure.
        Err(e) if host_sim::io::stdout_text::is_closed_stdout(&e) => ExitCode::SUCCESS,
        Err(SimError::Cli(e)) => {
            // clap's own text: `error: …`, the usage and a hint, coloured on a terminal.
            let _ = e.print();
            ExitCode::from(u8::try_from(e.exit_code()).unwrap_or(2))
        }
        Err(e @ SimError::Usage(_)) => {
            eprintln!("error: {e}\n\nFor more information, try '--help'.");
            ExitCode::from(e.exit_code())
        }
        Err(e) => {
            eprintln!("host-sim: error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}
