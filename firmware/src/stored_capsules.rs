//! The capsule estimate the self-calibration starts from at boot, embedded at build time.
//!
//! `CMA_SELFCAL=path` names a file written by `host-sim locate --selfcal-out` (an absolute path, or
//! one relative to the `firmware` directory); `build.rs` parses it with the core's parser
//! ([`cma_core::capsule_estimate_file`]) into the constant [`STORED`], and a bad file fails the
//! build with the parser's message. Without the variable [`STORED`] is the ideal capsule
//! ([`CapsuleEstimate::IDEAL`]) and [`SOURCE`] is `None`. Rebuilds follow changes of the variable
//! and of the file.
//!
//! ```text
//! cargo run --release -p host-sim -- locate board.wav --selfcal-out board.selfcal
//! CMA_SELFCAL=$PWD/board.selfcal cargo build -p firmware --release --target thumbv7em-none-eabihf
//! ```

use cma_core::capsule_calibration::{BandModel, CapsuleEstimate};

include!(concat!(env!("OUT_DIR"), "/stored_capsules.rs"));

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stored_estimate_is_ideal_without_a_file_and_plausible_with_one() {
        match SOURCE {
            None => assert_eq!(STORED, CapsuleEstimate::IDEAL),
            // CMA_SELFCAL=… cargo test -p firmware --lib stored
            Some(_) => assert!(STORED.bands.iter().all(BandModel::is_plausible)),
        }
        const { assert!(!STORED.held) };
    }
}
