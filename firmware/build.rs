//! Build steps of the firmware:
//! * the capsule estimate the self-calibration starts from: the file named by `CMA_SELFCAL` (written
//!   by `host-sim locate --selfcal-out`; an absolute path or one relative to the `firmware` directory)
//!   is parsed with the core's own parser into `OUT_DIR/stored_capsules.rs` (see
//!   `src/stored_capsules.rs`); a bad file fails the build with the parser's message (no panic); without the
//!   variable the start is the ideal capsule. For every target, so the host tests see it too.
//! * the localizer configuration: the file named by `CMA_CONFIG` (a configuration file as `host-sim
//!   config` prints it, complete or only some keys over the default preset; an absolute path or one
//!   relative to the `firmware` directory) is read and checked with `cma-config`, the parser and
//!   check `host-sim --config` uses, and written as a Rust constant into
//!   `OUT_DIR/embedded_config.rs` (see `src/embedded_config.rs`); a bad file fails the build with
//!   the key named (a `cargo:warning` line and exit status 1, no panic); without the variable the configuration is `LocatorConfig::default()`.
//! * link arguments, for the target only: the board's memory layout as `memory.x` (`memory.x` for
//!   the STM32F411CE, `memory-f446.x` for the STM32F446RE, `memory-mps2.x` for the emulated board;
//!   the `board-*` feature selects it)
//!   found from any directory, cortex-m-rt's `link.x`, defmt's `defmt.x`.

use cma_core::capsule_calibration::{BandModel, CapsuleEstimate};
use std::env;
use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

fn main() {
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=memory-mps2.x");
    println!("cargo:rerun-if-changed=memory-f446.x");
    println!("cargo:rerun-if-changed=build.rs");
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("OUT_DIR"));
    stored_capsules(&out);
    embedded_config(&out);
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }
    let f411 = env::var_os("CARGO_FEATURE_BOARD_F411").is_some();
    let mps2 = env::var_os("CARGO_FEATURE_BOARD_MPS2").is_some();
    let f446 = env::var_os("CARGO_FEATURE_BOARD_F446").is_some();
    let layout = match (f411, mps2, f446) {
        (true, false, false) => "memory.x",
        (false, true, false) => "memory-mps2.x",
        (false, false, true) => "memory-f446.x",
        _ => fail(
            "select exactly one board: the default features (board-f411) or \
             `--no-default-features --features board-mps2` or `… --features board-f446`",
        ),
    };
    fs::copy(layout, out.join("memory.x")).expect("copy the memory layout");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg-bins=--nmagic");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}

/// Ends the build with `message`: a bad build variable is the user's error, not the build script's,
/// so it is reported as one line (a cargo warning, which cargo shows even when the script's output is
/// hidden, and on stderr) and exit status 1, without a panic's backtrace.
fn fail(message: &str) -> ! {
    // Cargo reads its directives line by line: one line per directive.
    for line in message.lines() {
        println!("cargo:warning={line}");
    }
    eprintln!("error: {message}");
    std::process::exit(1)
}

/// The path a build variable names: absolute, or relative to the `firmware` directory.
fn variable_path(var: &std::ffi::OsStr) -> PathBuf {
    let path = Path::new(var);
    if path.is_absolute() {
        path.to_path_buf()
    } else {
        Path::new(&env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR")).join(path)
    }
}

/// Writes `OUT_DIR/embedded_config.rs`: `CONFIG` (the configuration) and `SOURCE` (the file, if any).
fn embedded_config(out: &Path) {
    println!("cargo:rerun-if-env-changed=CMA_CONFIG");
    let default = cma_core::LocatorConfig::default();
    let (config, source) = match env::var_os("CMA_CONFIG").filter(|v| !v.is_empty()) {
        Some(var) => {
            let path = variable_path(&var);
            println!("cargo:rerun-if-changed={}", path.display());
            let text = fs::read_to_string(&path).unwrap_or_else(|e| {
                fail(&format!(
                    "CMA_CONFIG={}: cannot read the configuration file: {e}",
                    path.display()
                ))
            });
            let config = cma_config::parse_over(&default, &text).unwrap_or_else(|e| {
                fail(&format!(
                    "CMA_CONFIG={}: {e} (expected a configuration file as `host-sim config` prints it)",
                    path.display()
                ))
            });
            (config, Some(path.display().to_string()))
        }
        None => (default, None),
    };
    let code = cma_config::to_rust(&config)
        .unwrap_or_else(|e| fail(&format!("CMA_CONFIG: the configuration as Rust: {e}")));
    let about = source.as_deref().map_or(
        "`LocatorConfig::default()`: CMA_CONFIG was not set".to_string(),
        |s| format!("from `{s}`"),
    );
    let text = format!(
        "// generated by firmware/build.rs — do not edit\n\n\
         /// The localizer configuration the board runs ({about}).\n\
         pub const CONFIG: cma_core::LocatorConfig = {code};\n\n\
         /// The file [`CONFIG`] was read from (`CMA_CONFIG`), `None` for the default.\n\
         pub const SOURCE: Option<&str> = {source:?};\n"
    );
    fs::write(out.join("embedded_config.rs"), text).expect("write embedded_config.rs");
}

/// Writes `OUT_DIR/stored_capsules.rs`: `STORED` (the estimate) and `SOURCE` (the file, if any).
fn stored_capsules(out: &Path) {
    println!("cargo:rerun-if-env-changed=CMA_SELFCAL");
    let mut code = String::from("// generated by firmware/build.rs — do not edit\n\n");
    let source = env::var_os("CMA_SELFCAL").filter(|v| !v.is_empty());
    let (est, source) = match source {
        Some(var) => {
            let path = variable_path(&var);
            println!("cargo:rerun-if-changed={}", path.display());
            let text = fs::read_to_string(&path).unwrap_or_else(|e| {
                fail(&format!(
                    "CMA_SELFCAL={}: cannot read the self-calibration file: {e}",
                    path.display()
                ))
            });
            let est = cma_core::capsule_estimate_file::parse(&text).unwrap_or_else(|e| {
                fail(&format!(
                    "CMA_SELFCAL={}: {e} (expected a file written by `host-sim locate --selfcal-out`)",
                    path.display()
                ))
            });
            (est, Some(path.display().to_string()))
        }
        None => (CapsuleEstimate::IDEAL, None),
    };
    let band = |b: &BandModel| {
        format!(
            "BandModel {{ omni_part: [{:?}, {:?}, {:?}], dipole_part: [{:?}, {:?}, {:?}], peaks: {:?} }}",
            b.omni_part[0],
            b.omni_part[1],
            b.omni_part[2],
            b.dipole_part[0],
            b.dipole_part[1],
            b.dipole_part[2],
            b.peaks
        )
    };
    let bands: Vec<String> = est.bands.iter().map(band).collect();
    writeln!(
        code,
        "/// The estimate the self-calibration starts from ({}).\n\
         pub const STORED: CapsuleEstimate = CapsuleEstimate {{\n    bands: [\n        {},\n    ],\n    held: false,\n    talker_shift: [{:?}, {:?}],\n}};",
        source.as_deref().map_or("the ideal capsule: CMA_SELFCAL was not set".to_string(), |s| format!("from `{s}`")),
        bands.join(",\n        "),
        est.talker_shift[0],
        est.talker_shift[1]
    )
    .unwrap();
    writeln!(
        code,
        "/// The file [`STORED`] was read from (`CMA_SELFCAL`), `None` for the ideal capsule.\n\
         pub const SOURCE: Option<&str> = {source:?};"
    )
    .unwrap();
    fs::write(out.join("stored_capsules.rs"), code).expect("write stored_capsules.rs");
}
