//! The configuration file as a user meets it: `host-sim config` prints it, `--config` reads it on the
//! commands that localize, flags override it, and bad files are refused with the key named.

use std::path::Path;
use std::process::{Command, Output};

fn run(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
        .args(args)
        .output()
        .expect("host-sim runs")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn ok(args: &[&str]) -> String {
    let o = run(args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    stdout(&o)
}

fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn every_preset_prints_a_file_that_reads_back_to_itself() {
    let dir = tempfile::tempdir().unwrap();
    for preset in ["default", "thesis"] {
        let out = dir.path().join(format!("{preset}.toml"));
        let out = out.to_str().unwrap();
        ok(&["config", "--preset", preset, "--out", out]);
        let printed = std::fs::read_to_string(out).unwrap();
        assert_eq!(printed, ok(&["config", "--preset", preset]));
        // Complete: the same over either preset.
        for base in ["default", "thesis"] {
            assert_eq!(
                ok(&["config", "--preset", base, "--config", out]),
                printed,
                "{preset} over {base}"
            );
        }
    }
    assert_ne!(
        ok(&["config", "--preset", "default"]),
        ok(&["config", "--preset", "thesis"])
    );
}

#[test]
fn precedence_is_preset_then_file_then_flags() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(
        dir.path(),
        "partial.toml",
        "num_peaks = 6\nband_hi_hz = 3500.0\n",
    );
    // The file over the preset: its keys change, the rest is the preset's.
    let thesis = ok(&["config", "--preset", "thesis"]);
    let over = ok(&["config", "--preset", "thesis", "--config", &file]);
    assert!(over.contains("\nnum_peaks = 6\n"), "{over}");
    assert!(over.contains("\nband_hi_hz = 3500.0\n"), "{over}");
    assert!(over.contains("\ntracking = \"OnePole\"\n"), "{over}");
    let changed: Vec<_> = thesis
        .lines()
        .zip(over.lines())
        .filter(|(a, b)| a != b)
        .collect();
    assert_eq!(changed.len(), 2, "{changed:?}");
    // A flag over the file.
    let flagged = ok(&["config", "--config", &file, "--peaks", "8"]);
    assert!(flagged.contains("\nnum_peaks = 8\n"), "{flagged}");
    assert!(flagged.contains("\nband_hi_hz = 3500.0\n"), "{flagged}");
    // A switch flag flips only the switch: the stage's settings from the file stay.
    let tracks = write(
        dir.path(),
        "tracks.toml",
        "[multi_track]\ngate_deg = 25.0\n",
    );
    let on = ok(&["config", "--config", &tracks, "--multi-talker", "on"]);
    assert!(on.contains("\ngate_deg = 25.0\n"), "{on}");
    let section = on.split("[multi_track]").nth(1).unwrap_or_default();
    assert!(section.contains("\nenabled = true\n"), "{on}");
}

#[test]
fn unknown_keys_and_bad_values_are_refused_with_the_key_named() {
    let dir = tempfile::tempdir().unwrap();
    for (text, key) in [
        (
            "[tracking.Grid]\nsharpnes = 50.0\n",
            "`tracking.Grid.sharpnes`",
        ),
        ("num_peaks = \"ten\"\n", "`num_peaks`"),
        (
            "[capsule_calibration]\nshrinkage = nan\n",
            "`capsule_calibration.shrinkage`",
        ),
        ("num_peaks = 40\n", "`num_peaks`"),
        ("[noise_gate]\nopen_db = 5.0\n", "`noise_gate.open_db`"),
    ] {
        let file = write(dir.path(), "bad.toml", text);
        for cmd in [
            vec!["config", "--config", &file],
            vec!["locate", "/nonexistent.wav", "--config", &file],
        ] {
            let o = run(&cmd);
            let e = stderr(&o);
            assert_eq!(o.status.code(), Some(1), "{text}: {e}");
            assert!(e.contains(key) && e.contains("bad.toml"), "{text}: {e}");
        }
    }
}

#[test]
fn the_file_reaches_locate() {
    let dir = tempfile::tempdir().unwrap();
    let wav = dir.path().join("s.wav");
    let wav = wav.to_str().unwrap();
    ok(&[
        "scene",
        "--out",
        wav,
        "--synth",
        "3",
        "--azimuth",
        "70",
        "--snr",
        "10",
    ]);
    let plain = ok(&["locate", wav, "--quiet"]);
    // The default printed as a file: the same estimates.
    let full = write(
        dir.path(),
        "default.toml",
        &ok(&["config", "--preset", "default"]),
    );
    assert_eq!(ok(&["locate", wav, "--quiet", "--config", &full]), plain);
    // One setting changed in the file: other estimates; the same change as a flag: the same ones.
    let file = write(dir.path(), "onepole.toml", "tracking = \"OnePole\"\n");
    let from_file = ok(&["locate", wav, "--quiet", "--config", &file]);
    assert_ne!(from_file, plain);
    assert_eq!(
        from_file,
        ok(&["locate", wav, "--quiet", "--tracker", "onepole"])
    );
    // A flag overrides the file.
    assert_eq!(
        ok(&[
            "locate",
            wav,
            "--quiet",
            "--config",
            &file,
            "--tracker",
            "grid"
        ]),
        plain
    );
}

#[test]
fn help_shows_the_file_key_and_preset_values_by_stage_with_an_example() {
    let help = ok(&["locate", "--help"]);
    for want in [
        "[file: num_peaks = 16 (default), 10 (thesis)]",
        "[file: tracking = Grid (default), OnePole (thesis)]",
        "Tracking:",
        "Self-calibration:",
        "Example:\n  host-sim locate",
    ] {
        assert!(help.contains(want), "{want}");
    }
    for cmd in ["eval", "emit", "beam", "config", "scene", "sweep"] {
        assert!(ok(&[cmd, "--help"]).contains("Example:"), "{cmd}");
    }
}
