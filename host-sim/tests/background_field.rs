//! `host-sim locate`'s stationary-background line, run as a shell runs the binary: a scene with a
//! white noise source at 90° (1 m from the array in a dry room, where its direct sound dominates
//! its reverberation) reports a source near 90° in both bands; a scene with diffuse noise only
//! reports both bands diffuse. Thresholds are the values measured when the test was written, with
//! margin (measured: 89° and 88°, directivity 0.77 and 0.72; diffuse 0.02 and 0.05).

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_host-sim");

/// The `stationary background:` line of `locate` on a scene made with `scene_args`.
fn background_line(scene_args: &[&str], locate_args: &[&str]) -> String {
    let dir = tempfile::tempdir().expect("tempdir");
    let wav = dir.path().join("scene.wav");
    let st = Command::new(BIN)
        .args([
            "scene",
            "--synth",
            "12",
            "--azimuth",
            "0",
            "--distance",
            "1.5",
        ])
        .args(scene_args)
        .arg("--out")
        .arg(&wav)
        .output()
        .expect("run host-sim scene");
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let out = Command::new(BIN)
        .arg("locate")
        .arg(&wav)
        .args(["--csv", "-"])
        .args(locate_args)
        .output()
        .expect("run host-sim locate");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    stderr
        .lines()
        .find(|l| l.starts_with("stationary background: "))
        .unwrap_or_else(|| panic!("no background line in\n{stderr}"))
        .to_string()
}

/// The azimuths of the sources the line reports, one per band with a source.
fn source_azimuths(line: &str) -> Vec<f64> {
    line.split("source at ")
        .skip(1)
        .map(|rest| rest.split('°').next().unwrap().parse().unwrap())
        .collect()
}

#[test]
fn a_noise_source_is_reported_at_its_azimuth_and_diffuse_noise_as_diffuse() {
    let source = [
        "--room",
        "6x5x3:0.2",
        "--snr",
        "30",
        "--noise-source",
        "white,az=90,el=0,dist=1,level=-10",
    ];
    for selfcal in [&[][..], &["--selfcal", "off"][..]] {
        let line = background_line(&source, selfcal);
        let az = source_azimuths(&line);
        assert_eq!(az.len(), 2, "{line}");
        for a in az {
            assert!((a - 90.0).abs() <= 20.0, "{line}");
        }
        assert!(line.contains("dB re the median frame power"), "{line}");
    }
    let line = background_line(&["--room", "6x5x3:0.45", "--snr", "10"], &[]);
    assert!(source_azimuths(&line).is_empty(), "{line}");
    assert_eq!(line.matches("diffuse (directivity 0.").count(), 2, "{line}");
}
