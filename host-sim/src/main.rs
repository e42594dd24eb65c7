//! `host-sim` command-line entry point; everything lives in the `host_sim` library.

use std::process::ExitCode;

fn main() -> ExitCode {
    match host_sim::run(std::env::args_os()) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of the output went away (`host-sim eval … | head`): not a failure.
        Err(e) if host_sim::stdout_text::is_closed_stdout(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("host-sim: error: {e}");
            ExitCode::FAILURE
        }
    }
}
