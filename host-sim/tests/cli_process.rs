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
