//! `host-sim` command-line entry point; everything lives in the `host_sim` library.

use std::process::ExitCode;

fn main() -> ExitCode {
    match host_sim::run(std::env::args_os()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("host-sim: error: {e}");
            ExitCode::FAILURE
        }
    }
}
