//! `host-sim … | head`: a reader that closes the pipe early ends the command quietly and
//! successfully (no panic, no error message).

use std::io::Read;
use std::process::{Command, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_host-sim");

#[test]
fn closed_stdout_is_a_normal_end() {
    let dir = tempfile::tempdir().unwrap();
    let wav = dir.path().join("scene.wav");
    // 60 s of a static talker: ≈ 170 KB of CSV, more than a pipe buffer (64 KB) holds, so the
    // writer meets the closed pipe.
    let st = Command::new(BIN)
        .args(["scene", "--out"])
        .arg(&wav)
        .args(["--synth", "60", "--azimuth", "40", "--snr", "20"])
        .status()
        .unwrap();
    assert!(st.success());
    {
        let args = ["locate", wav.to_str().unwrap()];
        let mut child = Command::new(BIN)
            .args(args)
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let mut out = child.stdout.take().unwrap();
        let mut first = [0u8; 16];
        out.read_exact(&mut first).unwrap();
        drop(out);
        let res = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&res.stderr);
        assert!(res.status.success(), "{args:?}: {:?} {err}", res.status);
        assert!(
            !err.contains("panicked") && !err.contains("error"),
            "{args:?}: {err}"
        );
    }
}
