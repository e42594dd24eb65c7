//! The core on the emulated Cortex-M4F gives the same estimates as on the host, to the last bit.
//!
//! Builds `qemu-check` for `thumbv7em-none-eabihf` (release), runs it on `qemu-system-arm -machine
//! mps2-an386` under `timeout`, and compares its output line by line with the same scene run through
//! the host build of the core, for each variant of `qemu_check::run_check`: the scene through each
//! configuration of `qemu_check::check_config` (the default, the default with active-ratio features,
//! the thesis configuration, the default with the multi-talker tracks on: their decided tracks too),
//! and each input kind of `qemu_check::inputs` (speech, clipping bursts,
//! NaN bursts, silence, full-scale noise) through the default in the firmware's blocks. Without
//! `qemu-system-arm` the test is skipped with a message, except when `CI` is set: then it fails.

use qemu_check::{run_check, CHECK_VARIANTS, MODE_ADDR};
use std::path::PathBuf;
use std::process::Command;

const TARGET: &str = "thumbv7em-none-eabihf";
/// Wall-clock limit for one QEMU run (it takes well under a second).
const QEMU_TIMEOUT_S: &str = "120";

fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace root")
        .to_path_buf()
}

fn target_elf() -> PathBuf {
    let target_dir = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target"));
    target_dir.join(TARGET).join("release").join("qemu-check")
}

fn have_qemu() -> bool {
    Command::new("qemu-system-arm")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

fn host_lines(variant: usize) -> Vec<String> {
    let mut lines = Vec::new();
    assert!(run_check(variant, |line| lines.push(line.to_string())));
    lines.push(format!("END {}", lines.len()));
    lines
}

#[test]
fn target_estimates_equal_host_estimates_bit_for_bit() {
    if !have_qemu() {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but qemu-system-arm is not installed"
        );
        eprintln!(
            "SKIPPED: qemu-system-arm not found (install it, e.g. apt-get install qemu-system-arm)"
        );
        return;
    }
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .current_dir(workspace_root())
        .args(["build", "-p", "qemu-check", "--release", "--target", TARGET])
        .status()
        .expect("run cargo");
    assert!(status.success(), "building qemu-check for {TARGET} failed");

    for variant in 0..CHECK_VARIANTS {
        compare_variant(variant);
    }
}

/// Runs configuration `variant` on QEMU and compares its estimates with the host's.
fn compare_variant(variant: usize) {
    let out = Command::new("timeout")
        .arg(QEMU_TIMEOUT_S)
        .args([
            "qemu-system-arm",
            "-cpu",
            "cortex-m4",
            "-machine",
            "mps2-an386",
            "-nographic",
        ])
        .args(["-semihosting-config", "enable=on,target=native", "-kernel"])
        .arg(target_elf())
        .arg("-device")
        .arg(format!(
            "loader,addr={:#x},data={variant},data-len=4",
            MODE_ADDR + 4
        ))
        .output()
        .expect("run qemu-system-arm");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "configuration {variant}: QEMU run failed ({:?}):\n{stdout}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );

    let target: Vec<&str> = stdout.lines().map(str::trim_end).collect();
    let host = host_lines(variant);
    assert!(
        host.len() > 100,
        "the scene yields {} estimates",
        host.len()
    );
    let mismatches: Vec<String> = host
        .iter()
        .zip(&target)
        .enumerate()
        .filter(|(_, (h, t))| h.as_str() != **t)
        .map(|(i, (h, t))| format!("line {i}: host {h} / target {t}"))
        .collect();
    assert!(
        mismatches.is_empty() && host.len() == target.len(),
        "configuration {variant}: {} of {} lines differ (host {} lines, target {}):\n{}",
        mismatches.len(),
        host.len(),
        host.len(),
        target.len(),
        mismatches
            .iter()
            .take(10)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n")
    );
}
