//! The `host-sim` binary as a shell sees it: exit statuses, what goes to stderr, standard input.

use std::io::Write;
use std::process::{Command, Output, Stdio};

fn host_sim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_host-sim"))
}

fn run(args: &[&str]) -> Output {
    host_sim().args(args).output().expect("host-sim runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn usage_errors_exit_2_with_one_error_prefix() {
    for args in [
        vec!["frobnicate"],
        vec!["scene", "--out", "x.wav", "--synth", "NaN"],
        vec!["eval", ".", "--threads", "18446744073709551615"],
    ] {
        let o = run(&args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert_eq!(e.matches("error:").count(), 1, "{args:?}: {e}");
    }
    let o = run(&["locate", "/nonexistent/x.wav"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).starts_with("host-sim: error: /nonexistent/x.wav"));
}

#[test]
fn a_wav_on_standard_input_is_read_once_and_whole() {
    let dir = tempfile::tempdir().unwrap();
    let wav = dir.path().join("s.wav");
    let w = wav.to_str().unwrap();
    let o = run(&["scene", "--out", w, "--synth", "1.5", "--azimuth", "-50"]);
    assert!(o.status.success());
    let said = stderr(&o);
    assert!(
        said.starts_with("scene: wrote") && said.contains("s.pos.csv") && said.lines().count() == 1,
        "{said}"
    );
    let from_file = run(&["locate", w]);
    assert!(from_file.status.success());
    let summary = stderr(&from_file);
    assert!(
        summary.contains("frames from 1.") && summary.contains("with history"),
        "{summary}"
    );
    let bytes = std::fs::read(&wav).unwrap();
    let mut child = host_sim()
        .args(["locate", "/dev/stdin", "--quiet"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || stdin.write_all(&bytes));
    let from_pipe = child.wait_with_output().unwrap();
    writer.join().unwrap().unwrap();
    assert!(from_pipe.status.success(), "{}", stderr(&from_pipe));
    assert_eq!(stderr(&from_pipe), "", "--quiet prints nothing");
    assert_eq!(from_pipe.stdout, from_file.stdout);
}

/// A scene of `seconds` written by `host-sim scene` into `dir`.
fn scene(dir: &std::path::Path, name: &str, seconds: &str) -> String {
    let wav = dir.join(name);
    let w = wav.to_str().unwrap().to_string();
    let o = run(&["scene", "--out", &w, "--synth", seconds, "--azimuth", "40"]);
    assert!(o.status.success(), "{}", stderr(&o));
    w
}

#[test]
fn a_dash_reads_standard_input_and_writes_standard_output() {
    let dir = tempfile::tempdir().unwrap();
    let w = scene(dir.path(), "s.wav", "1");
    let from_file = run(&["locate", &w, "--quiet"]);
    assert!(from_file.status.success());
    let mut child = host_sim()
        .args(["locate", "-", "--quiet", "--csv", "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let bytes = std::fs::read(&w).unwrap();
    let writer = std::thread::spawn(move || stdin.write_all(&bytes));
    let from_dash = child.wait_with_output().unwrap();
    writer.join().unwrap().unwrap();
    assert!(from_dash.status.success(), "{}", stderr(&from_dash));
    assert_eq!(from_dash.stdout, from_file.stdout);
}

#[test]
fn flags_are_refused_before_any_output() {
    let dir = tempfile::tempdir().unwrap();
    let w = scene(dir.path(), "s.wav", "1");
    let tracks = dir.path().join("t.csv");
    let o = run(&[
        "locate",
        &w,
        "--method",
        "tdiv",
        "--tracks",
        tracks.to_str().unwrap(),
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(o.stdout.is_empty(), "no estimates before the error");
    assert!(
        e.starts_with("error: --tracks") && e.contains("similarity"),
        "{e}"
    );
    assert!(!e.contains("self-calibration"), "{e}");
    // An output into a folder that does not exist: named as given, before any work.
    let missing = dir.path().join("nodir").join("x.csv");
    let o = run(&["locate", &w, "--csv", missing.to_str().unwrap()]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(o.stdout.is_empty());
    assert!(
        e.contains(missing.to_str().unwrap()) && e.contains("nodir does not exist"),
        "{e}"
    );
    assert!(
        !e.contains(".partial") && !e.contains("self-calibration"),
        "{e}"
    );
    let o = run(&["scene", "--out", missing.to_str().unwrap(), "--synth", "1"]);
    let e = stderr(&o);
    assert!(
        e.contains("nodir does not exist") && !e.contains(".partial"),
        "{e}"
    );
}

#[test]
fn non_finite_input_is_counted_and_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let wav = dir.path().join("nan.wav");
    let spec = hound::WavSpec {
        channels: 4,
        sample_rate: 16000,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    let mut wr = hound::WavWriter::create(&wav, spec).unwrap();
    for i in 0..16000 * 4 {
        // All NaN but the last tenth: there a sound without direction (each cardioid half the
        // omni, as an array hears a pressure-only field).
        let x = if i < 16000 * 4 * 9 / 10 {
            f32::NAN
        } else {
            ((i / 4) as f32 * 0.05).sin() * 0.1 * [1.0, 0.5, 0.5, 0.5][i % 4]
        };
        wr.write_sample(x).unwrap();
    }
    wr.finalize().unwrap();
    let o = run(&["locate", wav.to_str().unwrap()]);
    let e = stderr(&o);
    assert!(o.status.success(), "exit 0, as documented: {e}");
    assert!(
        e.contains("locate: warning:") && e.contains("NaN or infinite"),
        "{e}"
    );
    let summary = e.lines().last().unwrap();
    assert!(summary.contains("NON_FINITE (flags 4, "), "{summary}");
    // The warning stays with --quiet.
    let o = run(&["locate", wav.to_str().unwrap(), "--quiet"]);
    assert_eq!(stderr(&o).lines().count(), 1, "{}", stderr(&o));
}

#[test]
fn a_stereo_talker_source_is_refused_with_its_channel_count() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("stereo.wav");
    let spec = hound::WavSpec {
        channels: 2,
        sample_rate: 16000,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let mut wr = hound::WavWriter::create(&src, spec).unwrap();
    for i in 0..32000 {
        wr.write_sample(((i as f32 * 0.01).sin() * 3000.0) as i16)
            .unwrap();
    }
    wr.finalize().unwrap();
    let out = dir.path().join("s.wav");
    let o = run(&[
        "scene",
        "--source",
        src.to_str().unwrap(),
        "--azimuth",
        "10",
        "--out",
        out.to_str().unwrap(),
    ]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("--source") && e.contains("has 2 channels") && e.contains("mono"),
        "{e}"
    );
    assert!(!out.exists());
}

#[test]
fn frames_without_history_carry_their_own_estimate_as_the_help_says() {
    let help = String::from_utf8(run(&["locate", "--help"]).stdout).unwrap();
    assert!(!help.contains("start value"), "{help}");
    assert!(help.contains("untracked estimate"), "{help}");
    let dir = tempfile::tempdir().unwrap();
    let w = scene(dir.path(), "s.wav", "2");
    let o = run(&["locate", &w]);
    let csv = String::from_utf8_lossy(&o.stdout).into_owned();
    let mut seen = 0;
    for line in csv.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let flags: u8 = f[6].parse().unwrap();
        // NO_HISTORY (16) with a peak (no NO_PEAKS, 8): the azimuth is the frame's raw one.
        if flags & 16 != 0 && flags & 8 == 0 {
            assert_eq!(f[2], f[3], "{line}");
            seen += 1;
        }
    }
    assert!(seen > 0, "{csv}");
    let summary = stderr(&o);
    assert!(!summary.contains("start value"), "{summary}");
}

#[test]
fn eval_help_defines_its_columns_with_an_example_a_clone_can_run() {
    let help = String::from_utf8(run(&["eval", "--help"]).stdout).unwrap();
    for column in ["trACC10", "trMAE", "rawACC10", "jump-reach", "jump-settle"] {
        assert!(
            help.lines().any(|l| l.trim_start().starts_with(column)),
            "{column} undefined: {help}"
        );
    }
    assert!(!help.contains("shared/data"), "{help}");
}

/// Writes the CMA1 scene at `cma1` as a first-order AmbiX file (W, Y, Z, X; Z silent) at `out`, its
/// first-order channels scaled by `first_order` (1 SN3D, √3 N3D).
fn as_ambix(cma1: &str, out: &std::path::Path, first_order: f32) {
    let mut r = hound::WavReader::open(cma1).unwrap();
    let spec = r.spec();
    let s: Vec<f32> = r
        .samples::<i16>()
        .map(|v| f32::from(v.unwrap()) / 32768.0)
        .collect();
    let mut w = hound::WavWriter::create(
        out,
        hound::WavSpec {
            channels: 4,
            sample_rate: spec.sample_rate,
            bits_per_sample: 32,
            sample_format: hound::SampleFormat::Float,
        },
    )
    .unwrap();
    let (c, s3) = (-0.5f32, 3f32.sqrt() / 2.0);
    for f in s.chunks_exact(4) {
        // The cardioids' dipole parts D_m = 2·C_m − W; X = ⅔ Σ D_m cos φ_m, Y = ⅔ Σ D_m sin φ_m.
        let d = [2.0 * f[1] - f[0], 2.0 * f[2] - f[0], 2.0 * f[3] - f[0]];
        let x = (2.0 / 3.0) * (d[0] + c * d[1] + c * d[2]);
        let y = (2.0 / 3.0) * (s3 * d[1] - s3 * d[2]);
        for v in [f[0], y * first_order, 0.0, x * first_order] {
            w.write_sample(v).unwrap();
        }
    }
    w.finalize().unwrap();
}

#[test]
fn ambix_input_is_read_as_its_powers_say_and_the_summary_names_it() {
    let dir = tempfile::tempdir().unwrap();
    let cma1 = scene(dir.path(), "s.wav", "3");
    let (sn3d, n3d) = (dir.path().join("sn3d.wav"), dir.path().join("n3d.wav"));
    as_ambix(&cma1, &sn3d, 1.0);
    as_ambix(&cma1, &n3d, 3f32.sqrt());
    let locate = |p: &std::path::Path, layout: &str| {
        let o = run(&["locate", p.to_str().unwrap(), "--input-layout", layout]);
        assert!(o.status.success(), "{}", stderr(&o));
        o
    };
    let auto_n3d = locate(&n3d, "ambix");
    assert_eq!(auto_n3d.stdout, locate(&n3d, "ambix-n3d").stdout);
    assert!(
        stderr(&auto_n3d).starts_with("input: AmbiX read as N3D (first-order power 3.0"),
        "{}",
        stderr(&auto_n3d)
    );
    let auto_sn3d = locate(&sn3d, "ambix");
    assert_eq!(auto_sn3d.stdout, locate(&sn3d, "ambix-sn3d").stdout);
    assert!(stderr(&auto_sn3d).starts_with("input: AmbiX read as SN3D (first-order power 1.0"));
    // Forced against its powers: a warning, printed also with --quiet.
    let o = run(&[
        "locate",
        n3d.to_str().unwrap(),
        "--input-layout",
        "ambix-sn3d",
        "--quiet",
    ]);
    assert!(o.status.success());
    assert!(
        stderr(&o).starts_with("warning: input read as SN3D") && stderr(&o).contains("looks N3D")
    );
    assert_ne!(o.stdout, auto_n3d.stdout);
}

#[test]
fn a_disconnected_cardioid_is_named_even_with_quiet() {
    let dir = tempfile::tempdir().unwrap();
    let wired = scene(dir.path(), "s.wav", "3");
    let o = run(&["locate", &wired, "--quiet"]);
    assert!(o.status.success());
    assert_eq!(stderr(&o), "", "a wired array raises no warning");
    let mut r = hound::WavReader::open(&wired).unwrap();
    let spec = r.spec();
    let samples: Vec<i16> = r.samples::<i16>().map(|v| v.unwrap()).collect();
    let dead = dir.path().join("dead.wav");
    let mut w = hound::WavWriter::create(&dead, spec).unwrap();
    for (i, v) in samples.iter().enumerate() {
        // Channel 3: the cardioid looking 120°.
        w.write_sample(if i % 4 == 2 { 0 } else { *v }).unwrap();
    }
    w.finalize().unwrap();
    let o = run(&["locate", dead.to_str().unwrap(), "--quiet"]);
    assert!(o.status.success());
    let e = stderr(&o);
    assert!(
        e.starts_with("warning: input: the cardioid looking 120° (channel 3)")
            && e.contains("connected"),
        "{e}"
    );
}

/// No output overwrites an input or another output of the same command, whatever name leads to it
/// (the file itself, a link, `./`): refused as a usage error before anything is written.
#[test]
fn outputs_never_overwrite_inputs_or_each_other() {
    let dir = tempfile::tempdir().unwrap();
    let wav = scene(dir.path(), "in.wav", "1");
    let before = std::fs::read(&wav).unwrap();
    let link = dir.path().join("link.csv");
    std::os::unix::fs::symlink(&wav, &link).unwrap();
    let dotted = dir.path().join(".").join("in.wav");
    let (l, d) = (link.to_str().unwrap(), dotted.to_str().unwrap());
    let t = dir.path().join("t.csv");
    let t = t.to_str().unwrap();
    for (args, says) in [
        (
            vec!["locate", &wav, "-q", "--csv", &wav],
            "would overwrite the input",
        ),
        (
            vec!["locate", &wav, "-q", "--csv", l],
            "would overwrite the input",
        ),
        (vec!["beam", &wav, "--out", d], "would overwrite the input"),
        (
            vec!["beam", &wav, "--out", t, "--steering-csv", &wav],
            "would overwrite",
        ),
        (
            vec!["locate", &wav, "--tracks", t, "--csv", t],
            "are the same file",
        ),
        (
            vec!["scene", "--synth", "1", "--out", t, "--manifest", t],
            "are the same file",
        ),
        (
            vec!["scene", "--rir", &wav, "--out", &wav, "--synth", "1"],
            "would overwrite",
        ),
    ] {
        let o = run(&args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(e.contains(says), "{args:?}: {e}");
        assert_eq!(std::fs::read(&wav).unwrap(), before, "{args:?}");
        assert!(!std::path::Path::new(t).exists(), "{args:?}");
    }
    // Two outputs to /dev/null are fine.
    let o = run(&[
        "locate",
        &wav,
        "-q",
        "--csv",
        "/dev/null",
        "--tracks",
        "/dev/null",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A scene is not appended to a manifest of the other kind, and a missing manifest folder is
/// refused before the scene is written; a sweep's absurd rate is a usage error, not an abort.
#[test]
fn scene_manifests_and_sweep_rates_are_checked_before_any_output() {
    let dir = tempfile::tempdir().unwrap();
    let multi = dir.path().join("m");
    std::fs::create_dir(&multi).unwrap();
    let manifest = multi.join("manifest.csv");
    std::fs::write(&manifest, "file,set,talkers,note\n").unwrap();
    let out = dir.path().join("s.wav");
    let (o_, m) = (out.to_str().unwrap(), manifest.to_str().unwrap());
    let missing = dir.path().join("nowhere").join("manifest.csv");
    for (args, says) in [
        (
            vec!["scene", "--synth", "1", "--out", o_, "--manifest", m],
            "not the single-talker",
        ),
        (
            vec![
                "scene",
                "--synth",
                "1",
                "--out",
                o_,
                "--manifest",
                missing.to_str().unwrap(),
            ],
            "does not exist",
        ),
    ] {
        let o = run(&args);
        let e = stderr(&o);
        assert_ne!(o.status.code(), Some(0), "{args:?}: {e}");
        assert!(e.contains(says), "{args:?}: {e}");
        assert!(!out.exists(), "{args:?}");
    }
    assert_eq!(
        std::fs::read_to_string(&manifest).unwrap(),
        "file,set,talkers,note\n"
    );
    let o = run(&["sweep", "--out", o_, "--rate", "4000000000"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--rate"), "{}", stderr(&o));
    assert!(!out.exists());
}

/// Re-rendering a scene under the same name leaves no truth file of the old one behind: a noise
/// truth without noise sources now, a third talker's truth for a scene of two.
#[test]
fn a_re_rendered_scene_leaves_no_stale_truth() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.wav");
    let o_ = out.to_str().unwrap();
    let noise = dir.path().join("x.noise.csv");
    let args = ["scene", "--synth", "1", "--out", o_, "--azimuth", "10"];
    let o = run(&[&args[..], &["--noise-source", "fan,az=40"]].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(noise.exists());
    let o = run(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!noise.exists());
    let third = dir.path().join("x.talker3.csv");
    let multi = ["scene", "--synth", "3", "--out", o_, "--talkers"];
    assert!(run(&[&multi[..], &["3"]].concat()).status.success());
    assert!(third.exists());
    assert!(run(&[&multi[..], &["2"]].concat()).status.success());
    assert!(!third.exists());
    // A file of that name that is not a truth file is left alone.
    std::fs::write(&noise, "mine\n").unwrap();
    assert!(run(&args).status.success());
    assert_eq!(std::fs::read_to_string(&noise).unwrap(), "mine\n");
}

/// A scene's capsule and motion flags out of range are refused naming the flag and its value.
#[test]
fn scene_array_and_motion_errors_name_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("s.wav");
    let o_ = out.to_str().unwrap();
    for (args, says) in [
        (
            vec!["--capsule-beta", "2,0.5,0.5"],
            "--capsule-beta: expected",
        ),
        (
            vec!["--capsule-gain-db=1,30,0"],
            "--capsule-gain-db: expected",
        ),
        (vec!["--beta-drift", "5"], "--beta-drift: expected"),
        (vec!["--drift-corner", "0"], "--drift-corner: expected"),
        (
            vec!["--talkers", "2", "--move-first", "nan"],
            "--move-first",
        ),
    ] {
        let o = run(&[&["scene", "--synth", "1", "--out", o_][..], &args[..]].concat());
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(
            e.contains(says) && !e.contains("ArrayModel"),
            "{args:?}: {e}"
        );
        assert!(!out.exists(), "{args:?}");
    }
}

/// Settings the core would run with and mishandle (a threshold on b above 1, an L_p power of 0)
/// are refused before any work: from a file naming the key, its value and the range; from a flag
/// as a usage error naming the flag.
#[test]
fn settings_out_of_range_are_refused_with_key_value_and_range() {
    let dir = tempfile::tempdir().unwrap();
    for (text, says) in [
        (
            "measure = { Lp = 0 }\n",
            "`measure.Lp`: 0 is out of range; valid: p from 0.25 to 32",
        ),
        (
            "[quality]\nbinary_threshold = 2\n",
            "`quality.binary_threshold`: 2 is out of range; valid: at most 1",
        ),
    ] {
        let file = dir.path().join("bad.toml");
        std::fs::write(&file, text).unwrap();
        let o = run(&[
            "locate",
            "/nonexistent.wav",
            "--config",
            file.to_str().unwrap(),
        ]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{text}: {e}");
        assert!(e.contains("bad.toml") && e.contains(says), "{text}: {e}");
        assert!(
            !e.contains("nonexistent"),
            "checked before the input is read: {e}"
        );
    }
    for (flags, says) in [
        (
            vec!["--binary-threshold", "2"],
            "--binary-threshold: 2 is out of range",
        ),
        (
            vec!["--reliability-exponent", "0"],
            "--reliability-exponent: 0 is out of range",
        ),
        (
            vec!["--measure", "l0"],
            "--measure: expected euclid, cosine or lP with P from 0.25 to 32",
        ),
    ] {
        let o = run(&[&["locate", "/nonexistent.wav"][..], &flags[..]].concat());
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{flags:?}: {e}");
        assert!(
            e.starts_with("error: ") && e.contains(says),
            "{flags:?}: {e}"
        );
    }
}

/// Flags that contradict each other, or set a stage another flag switches off, are refused as a
/// usage error naming both before any work (no output, not even a missing input is noticed).
#[test]
fn conflicting_flags_are_refused_naming_both() {
    let dir = tempfile::tempdir().unwrap();
    let t = dir.path().join("t.csv");
    let t = t.to_str().unwrap();
    let missing = "/nonexistent/in.wav";
    for (args, names) in [
        (
            vec!["locate", missing, "--tracks", t, "--multi-talker", "off"],
            vec!["--tracks", "--multi-talker off"],
        ),
        (
            vec!["locate", missing, "--table", "x.cmat", "--grid", "15"],
            vec!["--table", "--grid"],
        ),
        (
            vec!["eval", missing, "--grid", "5", "--table", "x.cmat"],
            vec!["--table", "--grid"],
        ),
        (
            vec!["beam", missing, "--out", t, "--table", "x.cmat"],
            vec!["--table", "beam"],
        ),
        (
            vec!["locate", missing, "--no-reliability", "--vmax", "0.01"],
            vec!["--no-reliability", "--vmax"],
        ),
        (
            vec![
                "locate",
                missing,
                "--tracker",
                "onepole",
                "--sharpness",
                "40",
            ],
            vec!["--sharpness", "--tracker onepole"],
        ),
        (
            vec!["eval", missing, "--preset", "thesis", "--jump-prob", "0.1"],
            vec!["--jump-prob", "one-pole"],
        ),
        (
            vec!["locate", missing, "--noise-gate", "off", "--gate-open", "1"],
            vec!["--gate-open", "--noise-gate off"],
        ),
        (
            vec![
                "beam",
                missing,
                "--out",
                t,
                "--frame-onset",
                "off",
                "--frame-onset-low",
                "1",
            ],
            vec!["--frame-onset-low", "--frame-onset off"],
        ),
        (
            vec![
                "locate",
                missing,
                "--selfcal",
                "off",
                "--selfcal-adapt",
                "on",
            ],
            vec!["--selfcal-adapt", "--selfcal off"],
        ),
        (
            vec![
                "locate",
                missing,
                "--preset",
                "thesis",
                "--selfcal-in",
                "x.selfcal",
            ],
            vec!["--selfcal-in", "self-calibration is off"],
        ),
        (
            vec!["locate", missing, "--fdiv-std-binary"],
            vec!["--fdiv-std-binary", "--fdiv-std"],
        ),
        (
            vec![
                "emit",
                missing,
                "--port",
                "/nonexistent/pty",
                "--selfcal",
                "off",
                "--selfcal-in",
                "x.selfcal",
            ],
            vec!["--selfcal-in", "self-calibration is off"],
        ),
    ] {
        let o = run(&args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(o.stdout.is_empty(), "{args:?}");
        assert!(
            e.starts_with("error: ") && !e.contains("nonexistent"),
            "{args:?}: {e}"
        );
        for name in names {
            assert!(e.contains(name), "{args:?} should name {name}: {e}");
        }
        assert!(!std::path::Path::new(t).exists(), "{args:?}");
    }
    // An eval of a multi-talker folder runs the tracks: --multi-talker off is refused there.
    let multi = dir.path().join("m");
    std::fs::create_dir(&multi).unwrap();
    std::fs::write(multi.join("manifest.csv"), "file,set,talkers,note\n").unwrap();
    let o = run(&["eval", multi.to_str().unwrap(), "--multi-talker", "off"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("--multi-talker off") && e.contains("multi-talker folder"),
        "{e}"
    );
}

/// `options-eval --base` is one argument split as a shell splits it, checked before the table's
/// first line; `distance-report --help` describes its own flags (not the localizer's file keys).
#[test]
fn options_eval_base_and_distance_report_help() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    for (base, says) in [
        (
            "--frobnicate",
            "--base `--frobnicate`: unexpected argument '--frobnicate'",
        ),
        ("--config 'my room.toml", "--base: the quote ' in"),
        ("--config 'no such room.toml'", "no such room.toml"),
        ("--json", "--base `--json`: unexpected argument"),
    ] {
        let o = run(&["options-eval", d, "--base", base]);
        let e = stderr(&o);
        assert_ne!(o.status.code(), Some(0), "{base}: {e}");
        assert!(
            o.stdout.is_empty(),
            "{base}: nothing printed before the error"
        );
        assert!(e.contains(says), "{base}: {e}");
        assert!(e.matches("For more information").count() <= 1, "{e}");
    }
    // A folder without a manifest: an error naming it, and no table header before it.
    let o = run(&["options-eval", d]);
    let e = stderr(&o);
    assert_ne!(o.status.code(), Some(0), "{e}");
    assert!(o.stdout.is_empty(), "nothing printed before the error: {e}");
    assert!(e.contains("manifest.csv"), "{e}");
    let help = String::from_utf8(run(&["options-eval", "--help"]).stdout).unwrap();
    assert!(help.contains("'my room.toml'"), "{help}");
    let help = String::from_utf8(run(&["distance-report", "--help"]).stdout).unwrap();
    assert!(
        !help.contains("[file:") && !help.contains("band_lo_hz"),
        "{help}"
    );
    assert!(
        help.contains("[default: 80]") && help.contains("Markdown table"),
        "{help}"
    );
    for args in [
        vec!["--band-lo", "600"],
        vec!["--band-hi", "9000"],
        vec!["--peaks", "0"],
    ] {
        let o = run(&[&["distance-report", d][..], &args[..]].concat());
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(args[0]), "{args:?}: {}", stderr(&o));
    }
}

/// An input that cannot be read and an output that cannot be written are named with the operation
/// that failed, by the path the user gave (not a temporary file's).
#[test]
fn io_errors_name_the_path_and_the_operation() {
    let dir = tempfile::tempdir().unwrap();
    let w = scene(dir.path(), "s.wav", "1");
    for (args, says) in [
        (
            vec!["locate", "/nonexistent/x.wav"],
            "host-sim: error: /nonexistent/x.wav: cannot read: no such file",
        ),
        (
            vec!["locate", &w, "--config", "/nonexistent/room.toml"],
            "host-sim: error: /nonexistent/room.toml: cannot read: ",
        ),
        (
            vec!["locate", &w, "-q", "--csv", "/dev/full"],
            "host-sim: error: /dev/full: cannot write: ",
        ),
    ] {
        let o = run(&args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert!(e.starts_with(says), "{args:?}: {e}");
        assert!(
            !e.contains(".partial") && !e.contains("/tmp/."),
            "{args:?}: {e}"
        );
    }
}
