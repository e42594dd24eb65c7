//! The localizer configuration the board runs, embedded at build time.
//!
//! `CMA_CONFIG=path` names a configuration file as `host-sim config` prints it (complete, or only
//! some keys over the default preset; an absolute path or one relative to the `firmware`
//! directory). `build.rs` reads and checks it with `cma-config` — the parser and check of
//! `host-sim --config`, which name the key of an unknown setting or a bad value — and writes it as
//! the constant [`CONFIG`]; a bad file fails the build with that message. Without the variable
//! [`CONFIG`] is `LocatorConfig::default()` and [`SOURCE`] is `None`. Rebuilds follow changes of the
//! variable and of the file.
//!
//! ```text
//! cargo run --release -p host-sim -- config --preset default --peaks 8 --out board.toml
//! CMA_CONFIG=$PWD/board.toml cargo build -p firmware --release --target thumbv7em-none-eabihf
//! ```

include!(concat!(env!("OUT_DIR"), "/embedded_config.rs"));

#[cfg(test)]
mod tests {
    use super::*;
    use cma_core::LocatorConfig;

    #[test]
    fn embedded_configuration_is_the_default_without_a_file() {
        match SOURCE {
            None => assert_eq!(CONFIG, LocatorConfig::default()),
            // CMA_CONFIG=… cargo test -p firmware --lib embedded
            Some(_) => assert!(cma_config_check(&CONFIG)),
        }
    }

    /// The board's localizer accepts the configuration at its rate with the ideal table.
    fn cma_config_check(c: &LocatorConfig) -> bool {
        cma_core::Locator::new(
            *c,
            cma_core::ReferenceTable::ideal_5deg(),
            crate::board_api::SAMPLE_RATE_HZ,
        )
        .is_ok()
    }
}
