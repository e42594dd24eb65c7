//! Every error path of the CLI gives a clear message (and no panic, no half-written output).

use cma_tests::{host_sim, make_scene, path_in};
use std::path::Path;

fn err_of(args: &[&str]) -> String {
    match host_sim(args) {
        Ok(()) => panic!("{args:?} should fail"),
        Err(e) => e.to_string(),
    }
}

fn write_wav(path: &Path, channels: u16, rate: u32, bits: u16, float: bool, frames: usize) {
    let spec = hound::WavSpec {
        channels,
        sample_rate: rate,
        bits_per_sample: bits,
        sample_format: if float {
            hound::SampleFormat::Float
        } else {
            hound::SampleFormat::Int
        },
    };
    let mut w = hound::WavWriter::create(path, spec).unwrap();
    for i in 0..frames * channels as usize {
        if float {
            w.write_sample((i as f32 * 0.01).sin() * 0.1).unwrap();
        } else {
            w.write_sample(((i as f32 * 0.01).sin() * 1000.0) as i32)
                .unwrap();
        }
    }
    w.finalize().unwrap();
}

#[test]
fn missing_file() {
    let m = err_of(&["locate", "/nonexistent/x.wav"]);
    assert!(
        m.contains("/nonexistent/x.wav") && m.contains("no such file"),
        "{m}"
    );
}

#[test]
fn empty_and_non_wav_files() {
    let dir = tempfile::tempdir().unwrap();
    let empty = path_in(dir.path(), "empty.wav");
    std::fs::write(&empty, b"").unwrap();
    let m = err_of(&["locate", &empty]);
    assert!(m.contains("not a valid WAV"), "{m}");
    let text = path_in(dir.path(), "text.wav");
    std::fs::write(&text, b"this is not audio at all, just some text bytes").unwrap();
    let m = err_of(&["locate", &text]);
    assert!(m.contains("not a valid WAV"), "{m}");
    let zero = path_in(dir.path(), "zero.wav");
    write_wav(Path::new(&zero), 4, 16000, 16, false, 0);
    let m = err_of(&["locate", &zero]);
    assert!(m.contains("no samples"), "{m}");
}

#[test]
fn truncated_file() {
    let dir = tempfile::tempdir().unwrap();
    let wav = make_scene(dir.path(), "t.wav", &["--synth", "1", "--azimuth", "0"]);
    let bytes = std::fs::read(&wav).unwrap();
    let cut = path_in(dir.path(), "cut.wav");
    std::fs::write(&cut, &bytes[..bytes.len() - 3]).unwrap();
    let m = err_of(&["locate", &cut]);
    assert!(m.contains("truncated"), "{m}");
    let header_only = path_in(dir.path(), "hdr.wav");
    std::fs::write(&header_only, &bytes[..30]).unwrap();
    let m = err_of(&["locate", &header_only]);
    assert!(m.contains("not a valid WAV"), "{m}");
}

#[test]
fn wrong_channel_count_and_rate() {
    let dir = tempfile::tempdir().unwrap();
    let stereo = path_in(dir.path(), "stereo.wav");
    write_wav(Path::new(&stereo), 2, 16000, 16, false, 1000);
    let m = err_of(&["locate", &stereo]);
    assert!(
        m.contains("expected 4 channels") && m.contains("got 2"),
        "{m}"
    );
    let odd = path_in(dir.path(), "odd.wav");
    write_wav(Path::new(&odd), 4, 22000, 16, false, 1000);
    let m = err_of(&["locate", &odd]);
    assert!(m.contains("unsupported sample rate 22000"), "{m}");
    let m = err_of(&[
        "scene",
        "--out",
        &path_in(dir.path(), "x.wav"),
        "--synth",
        "1",
        "--rate",
        "8000",
    ]);
    assert!(m.contains("unsupported sample rate 8000"), "{m}");
    assert!(!dir.path().join("x.wav").exists());
}

#[test]
fn unsupported_sample_format() {
    let dir = tempfile::tempdir().unwrap();
    // 64-bit float PCM: a valid WAV, not a format the tool reads.
    let p = path_in(dir.path(), "f64.wav");
    let (ch, rate, bits, n) = (4u16, 16000u32, 64u16, 100u32);
    let block = ch * bits / 8;
    let data = n * block as u32;
    let mut b = Vec::new();
    b.extend_from_slice(b"RIFF");
    b.extend_from_slice(&(36 + data).to_le_bytes());
    b.extend_from_slice(b"WAVEfmt ");
    b.extend_from_slice(&16u32.to_le_bytes());
    b.extend_from_slice(&3u16.to_le_bytes());
    b.extend_from_slice(&ch.to_le_bytes());
    b.extend_from_slice(&rate.to_le_bytes());
    b.extend_from_slice(&(rate * block as u32).to_le_bytes());
    b.extend_from_slice(&block.to_le_bytes());
    b.extend_from_slice(&bits.to_le_bytes());
    b.extend_from_slice(b"data");
    b.extend_from_slice(&data.to_le_bytes());
    b.resize(b.len() + data as usize, 0);
    std::fs::write(&p, b).unwrap();
    let m = err_of(&["locate", &p]);
    assert!(m.contains("unsupported sample format"), "{m}");
}

#[test]
fn bad_flags() {
    let m = err_of(&["locate", "x.wav", "--grid", "7"]);
    assert!(m.contains("--grid") || m.contains("x.wav"), "{m}");
    let m = err_of(&["locate", "x.wav", "--measure", "l-3"]);
    assert!(m.contains("--measure") || m.contains("x.wav"), "{m}");
    let m = err_of(&["frobnicate"]);
    assert!(m.contains("unrecognized subcommand"), "{m}");
    let dir = tempfile::tempdir().unwrap();
    let wav = make_scene(dir.path(), "ok.wav", &["--synth", "1", "--azimuth", "0"]);
    let w = wav.to_string_lossy().into_owned();
    let m = err_of(&["locate", &w, "--peaks", "0"]);
    assert!(m.contains("--peaks") && m.contains("1 to 32"), "{m}");
    assert!(!m.contains("num_peaks"), "{m}");
    let m = err_of(&["locate", &w, "--sharpness", "-5"]);
    assert!(m.contains("--sharpness") && m.contains("≥ 0"), "{m}");
    assert!(
        !m.contains("probabilities"),
        "one rule, not the tracker's list: {m}"
    );
    let m = err_of(&["locate", &w, "--band-lo", "nan"]);
    assert!(
        m.contains("--band-lo") && m.contains("finite number"),
        "{m}"
    );
    let m = err_of(&["locate", &w, "--band-lo", "5000"]);
    assert!(m.contains("--band-lo") && m.contains("band"), "{m}");
    let m = err_of(&["locate", &w, "--vmax", "0.0001", "--vfloor", "0.001"]);
    assert!(m.starts_with("--v") && m.contains("V_max > V_floor"), "{m}");
    let m = err_of(&["locate", &w, "--snr-step=0"]);
    assert!(m.contains("--snr-step") && m.contains("SNR sets"), "{m}");
    let m = err_of(&["locate", &w, "--snr-from=50"]);
    assert!(m.contains("SNR sets"), "{m}");
    let m = err_of(&["locate", &w, "--snr-step=0.5"]);
    assert!(m.contains("more than 16 sets"), "{m}");
    let m = err_of(&["locate", &w, "--band-hi", "9000"]);
    assert!(m.contains("--band-hi") && m.contains("band"), "{m}");
    let m = err_of(&["locate", &w, "--gate-open", "3", "--gate-full", "2"]);
    assert!(m.contains("--gate-") && m.contains("noise gate"), "{m}");
    let m = err_of(&["locate", &w, "--refine-gain", "1.5"]);
    assert!(m.contains("--refine-gain") && m.contains("[0, 1]"), "{m}");
    let m = err_of(&[
        "locate",
        &w,
        "--frame-onset",
        "on",
        "--frame-onset-floor",
        "2",
    ]);
    assert!(
        m.contains("--frame-onset-floor") && m.contains("[0, 1]"),
        "{m}"
    );
    let m = err_of(&["locate", &w, "--noise-gate", "maybe"]);
    assert!(m.contains("--noise-gate"), "{m}");
    let m = err_of(&["locate", &w, "--features", "phase"]);
    assert!(m.contains("--features"), "{m}");
    let m = err_of(&["locate", &w, "--features", "active", "--noise", "power"]);
    assert!(
        m.contains("--noise") && m.contains("active features"),
        "{m}"
    );
    let e = host_sim(&["locate", &w, "--peaks", "0"]).unwrap_err();
    assert_eq!(e.exit_code(), 2, "a flag's value is a usage error: {e}");
    let e = host_sim(&["locate", &w, "--band-lo", "5000"]).unwrap_err();
    assert_eq!(e.exit_code(), 2, "{e}");
    let m = err_of(&[
        "scene",
        "--out",
        &path_in(dir.path(), "y.wav"),
        "--synth",
        "1",
        "--track",
        "0:10,x:20",
    ]);
    assert!(m.contains("--track"), "{m}");
    let m = err_of(&["scene", "--out", &path_in(dir.path(), "y.wav")]);
    assert!(m.contains("--source") && m.contains("--synth"), "{m}");
    let y = path_in(dir.path(), "y.wav");
    let m = err_of(&[
        "scene",
        "--out",
        &y,
        "--synth",
        "1",
        "--rotate-until",
        "0.5",
    ]);
    assert!(
        m.contains("--rotate-until") && m.contains("--rotate"),
        "{m}"
    );
    assert!(!Path::new(&y).exists(), "no scene written");
}

#[test]
fn bad_manifest_and_truth_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_string_lossy().into_owned();
    let m = err_of(&["eval", &d]);
    assert!(m.contains("manifest.csv"), "{m}");
    std::fs::write(dir.path().join("manifest.csv"), "wrong,header\n").unwrap();
    let m = err_of(&["eval", &d]);
    assert!(m.contains("expected header"), "{m}");
    std::fs::write(
        dir.path().join("manifest.csv"),
        "file,set,score_from_s,score_to_s,note\na.wav,x,zero,1,\n",
    )
    .unwrap();
    let m = err_of(&["eval", &d]);
    assert!(m.contains(":2:") && m.contains("not a number"), "{m}");
    make_scene(dir.path(), "a.wav", &["--synth", "1", "--azimuth", "0"]);
    std::fs::write(
        dir.path().join("manifest.csv"),
        "file,set,score_from_s,score_to_s,note\na.wav,x,0.3,1,\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("a.pos.csv"),
        "t_s,azimuth_deg,elevation_deg,distance_m\n0,abc,0,1\n",
    )
    .unwrap();
    let m = err_of(&["eval", &d]);
    assert!(
        m.contains("a.pos.csv:2") && m.contains("not a number"),
        "{m}"
    );
    std::fs::remove_file(dir.path().join("a.pos.csv")).unwrap();
    let m = err_of(&["eval", &d]);
    assert!(m.contains("a.pos.csv"), "{m}");
}

#[test]
fn bad_estimate_csv() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("r.csv");
    std::fs::write(&p, "t_s,azimuth_deg\n0.1,3\n").unwrap();
    let e = host_sim::localization::frame_estimates::read_csv(&p)
        .unwrap_err()
        .to_string();
    assert!(e.contains("missing column `azimuth_raw_deg`"), "{e}");
    std::fs::write(
        &p,
        "t_s,azimuth_deg,azimuth_raw_deg,confidence\n0.1,3,NaN,1\n",
    )
    .unwrap();
    let e = host_sim::localization::frame_estimates::read_csv(&p)
        .unwrap_err()
        .to_string();
    assert!(e.contains(":2:"), "{e}");
}

#[test]
fn usage_errors_are_clap_errors_with_exit_status_2() {
    for args in [
        vec!["frobnicate"],
        vec!["locate"],
        vec!["scene", "--out", "x.wav", "--synth", "NaN"],
        vec!["scene", "--out", "x.wav", "--synth", "1e9"],
        vec![
            "scene",
            "--out",
            "x.wav",
            "--synth",
            "1",
            "--azimuth",
            "NaN",
        ],
        vec!["scene", "--out", "x.wav", "--synth", "1", "--snr", "nan"],
        vec!["eval", ".", "--threads", "18446744073709551615"],
        vec!["monitor", "--port", "/dev/null", "--exit-after-idle", "-1"],
        vec!["score", "a.csv", "b.pos.csv", "--from", "inf"],
    ] {
        let e = host_sim(&args).unwrap_err();
        assert_eq!(e.exit_code(), 2, "{args:?}: {e}");
        let text = e.to_string();
        assert_eq!(text.matches("error:").count(), 1, "{args:?}: {text}");
        assert!(text.starts_with("error:"), "{args:?}: {text}");
    }
    let m = err_of(&["scene", "--out", "x.wav", "--synth", "1e9"]);
    assert!(m.contains("--synth") && m.contains("3600"), "{m}");
    // A failure that is not a usage error exits 1.
    let e = host_sim(&["locate", "/nonexistent/x.wav"]).unwrap_err();
    assert_eq!(e.exit_code(), 1);
}

#[test]
fn negative_numbers_are_flag_values() {
    let dir = tempfile::tempdir().unwrap();
    let wav = make_scene(dir.path(), "n.wav", &["--synth", "1", "--azimuth", "-120"]);
    let w = wav.to_string_lossy().into_owned();
    let csv = path_in(dir.path(), "n.csv");
    host_sim(&[
        "locate",
        &w,
        "--csv",
        &csv,
        "--quiet",
        "--snr-from",
        "-30",
        "--snr-to",
        "0",
    ])
    .unwrap();
    make_scene(
        dir.path(),
        "m.wav",
        &[
            "--synth",
            "1",
            "--track",
            "0:-30,0.5:-160",
            "--peak-dbfs",
            "-6",
            "--snr",
            "-5",
        ],
    );
    // Refused for its value (not parsed as an unknown flag `-1`).
    let m = err_of(&["monitor", "--port", "/dev/null", "--exit-after-idle", "-1"]);
    assert!(m.contains("-1 is outside (0,"), "{m}");
}

#[test]
fn score_uses_the_window_eval_uses_and_names_it() {
    use host_sim::evaluation::recorded_score::{report, window};
    let dir = tempfile::tempdir().unwrap();
    let manifest = path_in(dir.path(), "manifest.csv");
    let wav = make_scene(
        dir.path(),
        "a.wav",
        &[
            "--synth",
            "2",
            "--azimuth",
            "70",
            "--snr",
            "5",
            "--lead-in",
            "0.6",
            "--manifest",
            &manifest,
        ],
    );
    let csv = path_in(dir.path(), "a.csv");
    host_sim(&["locate", &wav.to_string_lossy(), "--csv", &csv, "--quiet"]).unwrap();
    let estimates = std::path::PathBuf::from(&csv);
    let truth = wav.with_extension("pos.csv");
    let w = window(None, None, &truth).unwrap();
    assert!(w.source.contains("manifest.csv"), "{w:?}");
    assert!(w.from_s > 0.6, "{w:?}");
    let (eval_report, _) = host_sim::evaluation::eval::evaluate(
        dir.path(),
        cma_core::LocatorConfig::default(),
        cma_core::ReferenceTable::ideal_5deg(),
        host_sim::io::wav_io::InputLayout::Cma1,
        1,
        &|_| {},
    )
    .unwrap();
    let scored = report(&estimates, &truth, &window(None, None, &truth).unwrap())
        .unwrap()
        .overall
        .settled;
    let evaluated = &eval_report.overall.settled;
    assert_eq!(scored.frames, evaluated.frames);
    assert!(
        (scored.mae - evaluated.mae).abs() < 0.01,
        "{scored:?} {evaluated:?}"
    );
    // The flags win; without a manifest every frame is scored, and that is said.
    assert_eq!(
        window(Some(0.0), None, &truth).unwrap().source,
        "--from/--to"
    );
    std::fs::remove_file(&manifest).unwrap();
    let all = window(None, None, &truth).unwrap();
    assert!(all.source.starts_with("all frames"), "{all:?}");
    assert!(
        report(&estimates, &truth, &window(None, None, &truth).unwrap())
            .unwrap()
            .overall
            .settled
            .frames
            > scored.frames
    );
}

#[test]
fn locate_writes_json_lines() {
    let dir = tempfile::tempdir().unwrap();
    let wav = make_scene(dir.path(), "j.wav", &["--synth", "1", "--azimuth", "10"]);
    let w = wav.to_string_lossy().into_owned();
    let (csv, jsonl) = (path_in(dir.path(), "j.csv"), path_in(dir.path(), "j.jsonl"));
    host_sim(&["locate", &w, "--csv", &csv, "--quiet"]).unwrap();
    host_sim(&[
        "locate", &w, "--out", &jsonl, "--format", "jsonl", "--quiet",
    ])
    .unwrap();
    let csv = std::fs::read_to_string(csv).unwrap();
    let jsonl = std::fs::read_to_string(jsonl).unwrap();
    assert_eq!(csv.lines().count(), jsonl.lines().count() + 1);
    for (c, j) in csv.lines().skip(1).zip(jsonl.lines()) {
        let f: Vec<&str> = c.split(',').collect();
        assert!(
            j.starts_with(&format!("{{\"frame\":{},\"t_s\":{},", f[0], f[1])),
            "{c} / {j}"
        );
        assert!(j.contains(&format!("\"flags\":{},", f[6])), "{c} / {j}");
    }
}
