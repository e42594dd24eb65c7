//! The full chain without hardware: `qemu-demo` (cma-core on a synthetic talker circling at 20°/s,
//! wire lines on the mps2-an386 UART) under `qemu-system-arm -serial pty`, read by `host-sim monitor`
//! through the pseudo-terminal QEMU creates.
//!
//! Ignored by default: it needs `qemu-system-arm` (Debian `qemu-system-arm`) and the
//! `thumbv7em-none-eabihf` Rust target, and cross-builds `qemu-demo/` (~1 min the first time).
//! Run it with `cargo test -p host-sim --test qemu_chain -- --ignored`.

use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_host-sim");

struct KillOnDrop(Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

#[test]
#[ignore = "needs qemu-system-arm and the thumbv7em-none-eabihf target; run with --ignored"]
fn qemu_firmware_to_monitor() {
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("../qemu-demo");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let st = Command::new(cargo)
        .current_dir(&demo)
        .args(["build", "--release"])
        .status()
        .expect("run cargo for qemu-demo");
    assert!(st.success(), "building qemu-demo failed");
    let kernel = demo.join("target/thumbv7em-none-eabihf/release/qemu-demo");
    let mut qemu = KillOnDrop(
        Command::new("qemu-system-arm")
            .args(["-M", "mps2-an386", "-nographic", "-monitor", "none"])
            .args(["-serial", "pty", "-kernel"])
            .arg(&kernel)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("cannot run qemu-system-arm (apt-get install qemu-system-arm)"),
    );
    // QEMU announces the pty on stdout or stderr depending on the version: read both.
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    for pipe in [
        Box::new(qemu.0.stdout.take().unwrap()) as Box<dyn std::io::Read + Send>,
        Box::new(qemu.0.stderr.take().unwrap()),
    ] {
        let tx = tx.clone();
        std::thread::spawn(move || {
            for l in BufReader::new(pipe).lines().map_while(Result::ok) {
                let _ = tx.send(l);
            }
        });
    }
    let t0 = Instant::now();
    let pty = loop {
        let l = rx
            .recv_timeout(Duration::from_secs(10).saturating_sub(t0.elapsed()))
            .expect("QEMU did not announce its pty within 10 s");
        if let Some(i) = l.find("/dev/pts/") {
            break l[i..].split_whitespace().next().unwrap().to_string();
        }
    };
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("qemu.csv");
    let out = Command::new(BIN)
        .args([
            "monitor",
            "--plain",
            "--frames",
            "300",
            "--exit-after-idle",
            "10",
        ])
        .args(["--port", &pty, "--record"])
        .arg(&rec)
        .output()
        .expect("run host-sim monitor");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("frames=300 corrupt_lines=0 lost_frames=0"),
        "{err}"
    );
    // The demo's talker circles at 20°/s from 0°: the recorded azimuths follow it (the tracker's
    // lag behind a moving talker is a few degrees; what the chain could break — lines lost, fields
    // swapped or garbled — gives errors of tens of degrees).
    let rows = host_sim::localization::frame_estimates::read_csv(&rec).unwrap();
    assert_eq!(rows.len(), 300);
    let mut errors: Vec<f64> = rows
        .iter()
        .map(|r| host_sim::io::ground_truth::wrap180(r.azimuth_deg - 20.0 * r.t_s).abs())
        .collect();
    errors.sort_by(f64::total_cmp);
    let (median, worst) = (errors[errors.len() / 2], errors[errors.len() - 1]);
    eprintln!("qemu chain: 300 frames, median azimuth error {median:.1}°, worst {worst:.1}°");
    assert!(median < 3.0, "median azimuth error {median}°");
    assert!(worst < 10.0, "worst azimuth error {worst}°");
}
