//! The firmware's application on the emulated board, end to end and without hardware.
//!
//! Builds `firmware-mps2` (the application of `firmware/src/app.rs` on the QEMU `mps2-an386` board
//! of `firmware/src/boards/mps2.rs`), runs it on `qemu-system-arm` (`-icount shift=4,sleep=off`, so
//! emulated time follows the instructions and every run is the same) on a WAV made by
//! `host-sim scene`, with its UART on one end of a socat pty pair and `host-sim monitor --record`
//! on the other. The reference is `host-sim emit` on the same WAV (the estimates of `host-sim
//! locate`, encoded as the firmware encodes them) through the same pty pair and monitor, so both
//! recordings hold the values exactly as the wire carries them.
//!
//! * no fault: the firmware's recording (CSV and every plain line, calibration lines included)
//!   equals the reference;
//! * a gap in the samples (the DSP task stalls 20 ms, the capture ring is lapped): the overrun is
//!   counted (`ovr` 0 → 1 at the first frame after the gap) and nothing else changes: the
//!   recording equals the reference on the WAV without the lost frames (the board reports which);
//! * a stalled UART (held 1 s): frames are dropped and counted (`drop`), never delayed into an
//!   overrun (`ovr` stays 0): the recording is the reference without one contiguous run of frames,
//!   as many as `drop` counts, and each frame's `drop` is the number dropped before it;
//! * a hung DSP task: the watchdog resets the board, the stream restarts (`seq` 0, a calibration
//!   line, the monitor counts a restart); before it the recording is a prefix of the reference,
//!   after it it equals the reference on the WAV from the frame where the board resumed.
//!
//! Every external process runs under `timeout`. Without `qemu-system-arm` or `socat` the tests
//! fail with a message naming the missing tool (`scripts/setup.sh` installs both), so a machine
//! without them never reports them as passed.

use cma_core::capsule_estimate_record::{self, Record, RECORD_LEN};
use cma_firmware::emulated::{Fault, FAULT_ADDR};
use std::collections::HashMap;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_host-sim");
const TARGET: &str = "thumbv7em-none-eabihf";
/// Wall-clock limit of one QEMU run (6.25 s of audio takes a few seconds).
const QEMU_TIMEOUT_S: &str = "300";
/// Wall-clock limit of one monitor.
const MONITOR_TIMEOUT_S: &str = "400";
/// The monitor exits after this long without a byte (QEMU has ended by then).
const MONITOR_IDLE_S: &str = "8";
/// Largest stack high-water mark of the application on the emulated board that the test accepts.
const STACK_LIMIT_BYTES: u32 = 8 * 1024;

/// The emulated-board tests of this file run one at a time: QEMU emits frames as fast as the host
/// emulates them, and a monitor starved of CPU by a second run lets the pty fill, which the board
/// rightly takes for a stalled UART (frames dropped and counted, so the recording differs).
static EMULATOR: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// Holds [`EMULATOR`] (a test that failed while holding it does not stop the other).
fn one_at_a_time() -> std::sync::MutexGuard<'static, ()> {
    EMULATOR
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("workspace root")
        .to_path_buf()
}

fn firmware_elf() -> PathBuf {
    let target_dir = std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target"));
    target_dir
        .join(TARGET)
        .join("release")
        .join("firmware-mps2")
}

fn have(program: &str, arg: &str) -> bool {
    Command::new(program)
        .arg(arg)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// A child process killed on drop.
struct KillOnDrop(Child);

impl Drop for KillOnDrop {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Reads a pipe's lines into a channel.
fn lines_of(pipe: impl std::io::Read + Send + 'static) -> mpsc::Receiver<String> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(pipe).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

/// One frame line as the monitor prints it (`--plain`): its `key=value` fields.
#[derive(Debug, Clone, PartialEq)]
struct PlainFrame {
    text: String,
    fields: HashMap<String, String>,
}

impl PlainFrame {
    fn parse(line: &str) -> PlainFrame {
        let fields = line
            .split_whitespace()
            .filter_map(|kv| kv.split_once('='))
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
        PlainFrame {
            text: line.to_string(),
            fields,
        }
    }

    fn num(&self, key: &str) -> u64 {
        self.fields[key]
            .parse()
            .unwrap_or_else(|e| panic!("{key} in `{}`: {e}", self.text))
    }

    /// The line with `ovr` and `drop` (the board's counters) and `seq` left out.
    fn values(&self) -> String {
        self.text
            .split_whitespace()
            .filter(|kv| !["seq=", "ovr=", "drop="].iter().any(|k| kv.starts_with(k)))
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// What the monitor recorded from one writer.
struct Recording {
    /// `--record` CSV rows (header left out).
    csv: Vec<String>,
    /// `--plain` stdout: frame lines and `selfcal` lines, in order.
    plain: Vec<String>,
    /// The monitor's summary line.
    summary: String,
    /// The writer's stdout (QEMU: the board's report lines).
    writer_stdout: Vec<String>,
}

impl Recording {
    fn frames(&self) -> Vec<PlainFrame> {
        self.plain
            .iter()
            .filter(|l| l.starts_with("seq="))
            .map(|l| PlainFrame::parse(l))
            .collect()
    }

    /// The CSV rows without the `frame` column (the line's `seq`).
    fn csv_values(&self) -> Vec<String> {
        self.csv
            .iter()
            .map(|r| r.split_once(',').expect("CSV row").1.to_string())
            .collect()
    }

    /// The number in a board report line `mps2: <prefix>N…`.
    fn report(&self, prefix: &str) -> Vec<String> {
        self.writer_stdout
            .iter()
            .filter_map(|l| l.strip_prefix("mps2: "))
            .filter_map(|l| l.strip_prefix(prefix))
            .map(str::to_string)
            .collect()
    }
}

/// Runs `writer(port)` against `host-sim monitor --record` on the other end of a socat pty pair in
/// `dir/name.*`; returns what the monitor recorded and the writer's stdout.
fn record(dir: &Path, name: &str, writer: impl FnOnce(&Path) -> Command) -> Recording {
    let (board_end, host_end) = (
        dir.join(format!("{name}.board")),
        dir.join(format!("{name}.host")),
    );
    let _socat = KillOnDrop(
        Command::new("timeout")
            .arg(MONITOR_TIMEOUT_S)
            .args(["socat", "-d", "-d"])
            .arg(format!("pty,raw,echo=0,link={}", board_end.display()))
            .arg(format!("pty,raw,echo=0,link={}", host_end.display()))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("run socat"),
    );
    let t0 = Instant::now();
    while !(board_end.exists() && host_end.exists()) {
        assert!(
            t0.elapsed() < Duration::from_secs(10),
            "socat made no ptys within 10 s"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let csv = dir.join(format!("{name}.csv"));
    let mut monitor = KillOnDrop(
        Command::new("timeout")
            .arg(MONITOR_TIMEOUT_S)
            .arg(BIN)
            .args([
                "monitor",
                "--plain",
                "--exit-after-idle",
                MONITOR_IDLE_S,
                "--port",
            ])
            .arg(&host_end)
            .arg("--record")
            .arg(&csv)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run host-sim monitor"),
    );
    let stdout = lines_of(monitor.0.stdout.take().expect("piped"));
    let stderr = lines_of(monitor.0.stderr.take().expect("piped"));
    let mut err_lines = Vec::new();
    while !err_lines
        .iter()
        .any(|l: &String| l.starts_with("monitor: opened"))
    {
        match stderr.recv_timeout(Duration::from_secs(20)) {
            Ok(l) => err_lines.push(l),
            Err(_) => panic!("{name}: the monitor did not open its port: {err_lines:#?}"),
        }
    }
    let out = writer(&board_end)
        .stdin(Stdio::null())
        .output()
        .expect("run the writer");
    let writer_stdout: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_string)
        .collect();
    assert!(
        out.status.success(),
        "{name}: the writer failed ({:?}):\n{}\n{}",
        out.status,
        writer_stdout.join("\n"),
        String::from_utf8_lossy(&out.stderr)
    );
    let status = monitor.0.wait().expect("wait for the monitor");
    let plain: Vec<String> = stdout.iter().collect();
    err_lines.extend(stderr.iter());
    assert!(status.success(), "{name}: monitor failed: {err_lines:#?}");
    let summary = err_lines
        .iter()
        .find(|l| l.starts_with("monitor: summary"))
        .cloned()
        .unwrap_or_else(|| panic!("{name}: no monitor summary: {err_lines:#?}"));
    let text = std::fs::read_to_string(&csv).expect("read the recording");
    let mut rows = text.lines().map(str::to_string);
    assert_eq!(
        rows.next().as_deref(),
        Some(host_sim::localization::frame_estimates::CSV_HEADER.trim_end())
    );
    Recording {
        csv: rows.collect(),
        plain,
        summary,
        writer_stdout,
    }
}

/// `host-sim emit WAV` through the pty pair: the reference recording.
fn reference(dir: &Path, name: &str, wav: &Path) -> Recording {
    reference_from(dir, name, wav, None)
}

/// `host-sim emit WAV [--selfcal-in START]` through the pty pair.
fn reference_from(dir: &Path, name: &str, wav: &Path, start: Option<&Path>) -> Recording {
    record(dir, name, |port| {
        let mut c = Command::new("timeout");
        c.arg(QEMU_TIMEOUT_S)
            .arg(BIN)
            .arg("emit")
            .arg(wav)
            .arg("--port")
            .arg(port);
        if let Some(start) = start {
            c.arg("--selfcal-in").arg(start);
        }
        c
    })
}

/// The firmware on QEMU with `fault` through the pty pair.
fn firmware(dir: &Path, name: &str, wav: &Path, fault: Fault) -> Recording {
    record(dir, name, |port| on_port(qemu(wav, fault, None), port))
}

/// `qemu` with its UART on `port`.
fn on_port(mut c: Command, port: &Path) -> Command {
    c.arg("-chardev")
        .arg(format!("serial,id=uart0,path={}", port.display()))
        .args(["-serial", "chardev:uart0"]);
    c
}

/// The QEMU command of the emulated board on `wav` with `fault` and, with `store`, that file as its
/// estimate store (its UART still to be given).
fn qemu(wav: &Path, fault: Fault, store: Option<&Path>) -> Command {
    {
        let mut c = Command::new("timeout");
        c.arg(QEMU_TIMEOUT_S)
            .args([
                "qemu-system-arm",
                "-machine",
                "mps2-an386",
                "-cpu",
                "cortex-m4",
            ])
            .args([
                "-icount",
                "shift=4,sleep=off",
                "-display",
                "none",
                "-monitor",
                "none",
            ])
            .arg("-semihosting-config")
            .arg(format!(
                "enable=on,target=native,arg=firmware-mps2,arg={}{}",
                wav.display(),
                store.map_or(String::new(), |p| format!(",arg={}", p.display()))
            ))
            .arg("-kernel")
            .arg(firmware_elf())
            .arg("-device")
            .arg(format!(
                "loader,addr={FAULT_ADDR:#x},data={},data-len=4",
                fault.word()
            ));
        c
    }
}

/// The scene's samples (16-bit, 4 channels) and spec.
fn read_samples(wav: &Path) -> (hound::WavSpec, Vec<i16>) {
    let mut r = hound::WavReader::open(wav).expect("open the scene");
    let spec = r.spec();
    let s = r
        .samples::<i16>()
        .collect::<Result<_, _>>()
        .expect("read the scene");
    (spec, s)
}

/// Writes the sample frames `ranges` of `samples` as a new WAV `dir/name.wav`.
fn cut(
    dir: &Path,
    name: &str,
    spec: hound::WavSpec,
    samples: &[i16],
    ranges: &[(u64, u64)],
) -> PathBuf {
    let path = dir.join(format!("{name}.wav"));
    let mut w = hound::WavWriter::create(&path, spec).expect("create a cut WAV");
    let ch = u64::from(spec.channels);
    for &(a, b) in ranges {
        for &s in &samples[(a * ch) as usize..(b * ch) as usize] {
            w.write_sample(s).expect("write a sample");
        }
    }
    w.finalize().expect("finish a cut WAV");
    path
}

fn one_number(rec: &Recording, prefix: &str) -> String {
    let v = rec.report(prefix);
    assert_eq!(
        v.len(),
        1,
        "one `mps2: {prefix}…` line expected: {:#?}",
        rec.writer_stdout
    );
    v[0].clone()
}

/// `A..B` of `mps2: overrun: frames A..B lost`.
fn lost_range(rec: &Recording) -> (u64, u64) {
    let s = one_number(rec, "overrun: frames ");
    let (a, b) = s.trim_end_matches(" lost").split_once("..").expect("A..B");
    (a.parse().expect("A"), b.parse().expect("B"))
}

/// `F` of `mps2: end of input at frame F`.
fn end_frame(rec: &Recording) -> u64 {
    one_number(rec, "end of input at frame ")
        .parse()
        .expect("F")
}

fn counters(frames: &[PlainFrame], key: &str) -> Vec<u64> {
    frames.iter().map(|f| f.num(key)).collect()
}

/// Checks that QEMU and socat are here (without them the tests fail, with a message naming the
/// missing tool) and builds `firmware-mps2`.
fn emulator_ready() {
    for (tool, arg) in [("qemu-system-arm", "--version"), ("socat", "-V")] {
        assert!(
            have(tool, arg),
            "{tool} is not installed: the emulated-board tests need it (scripts/setup.sh installs \
             it; .ci/run does)"
        );
    }
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(cargo)
        .current_dir(workspace_root())
        .args(["build", "-p", "firmware", "--release", "--target", TARGET])
        .args(["--no-default-features", "--features", "board-mps2"])
        .status()
        .expect("run cargo");
    assert!(
        status.success(),
        "building firmware-mps2 for {TARGET} failed"
    );
}

/// Makes `dir/name` with `host-sim scene` (16 kHz) and `args`.
fn scene(dir: &Path, name: &str, args: &[&str]) -> PathBuf {
    let wav = dir.join(name);
    let st = Command::new(BIN)
        .arg("scene")
        .args(args)
        .args(["--rate", "16000", "--out"])
        .arg(&wav)
        .output()
        .expect("run host-sim scene");
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    wav
}

#[test]
fn emulated_firmware_matches_the_host_and_survives_faults() {
    let _emulator = one_at_a_time();
    emulator_ready();
    let dir = tempfile::tempdir().expect("temporary directory");
    let dir = dir.path();
    let wav = scene(
        dir,
        "scene.wav",
        &["--synth", "6", "--azimuth", "40", "--snr", "10"],
    );
    let (spec, samples) = read_samples(&wav);
    let n = samples.len() as u64 / 4;

    // The four firmware runs at once (each is deterministic).
    let runs: Vec<(Fault, Recording)> = std::thread::scope(|s| {
        let handles: Vec<_> = Fault::ALL
            .iter()
            .map(|&f| {
                let wav = &wav;
                (f, s.spawn(move || firmware(dir, f.name(), wav, f)))
            })
            .collect();
        handles
            .into_iter()
            .map(|(f, h)| (f, h.join().expect("firmware run")))
            .collect()
    });
    let run = |f: Fault| &runs.iter().find(|(g, _)| *g == f).expect("run").1;
    let (clean, gap, stall, hang) = (
        run(Fault::None),
        run(Fault::CaptureStall),
        run(Fault::UartStall),
        run(Fault::DspHang),
    );

    // The application's stack (painted at boot, before the localizer is built, and scanned at the
    // end): far below what the boards' RAM budget leaves for it (48 KB minus about 44 KB of
    // statics). Building the ≈ 37 KB localizer through a temporary once took 31–56 KB here.
    let stack: u32 = one_number(clean, "stack high-water mark ")
        .split_whitespace()
        .next()
        .and_then(|n| n.parse().ok())
        .expect("mps2: stack high-water mark N bytes");
    assert!(
        stack <= STACK_LIMIT_BYTES,
        "stack high-water mark {stack} B > {STACK_LIMIT_BYTES} B"
    );

    // The references: the WAV as captured (whole blocks), without the frames lost in the gap, and
    // from the frame where the board resumed after the watchdog reset.
    let end = end_frame(clean);
    let captured = if end == n {
        wav.clone()
    } else {
        cut(dir, "captured", spec, &samples, &[(0, end)])
    };
    let (a, b) = lost_range(gap);
    assert!(b > a, "frames {a}..{b}");
    let gapped = cut(
        dir,
        "gapped",
        spec,
        &samples,
        &[(0, a), (b, end_frame(gap))],
    );
    let boots = hang.report("boot ");
    assert_eq!(boots.len(), 2, "{:#?}", hang.writer_stdout);
    let resumed: u64 = boots[1]
        .split_once("capture from frame ")
        .and_then(|(_, r)| r.split_whitespace().next())
        .expect("capture from frame R")
        .parse()
        .expect("R");
    let after_reset = cut(
        dir,
        "resumed",
        spec,
        &samples,
        &[(resumed, end_frame(hang))],
    );
    let [reference_full, reference_gapped, reference_resumed] = std::thread::scope(|s| {
        [
            ("reference", &captured),
            ("reference-gapped", &gapped),
            ("reference-resumed", &after_reset),
        ]
        .map(|(name, w)| s.spawn(move || reference(dir, name, w)))
        .map(|h| h.join().expect("reference run"))
    });

    // No fault: the whole recording equals the reference.
    assert!(
        reference_full.csv.len() > 250,
        "{} reference frames",
        reference_full.csv.len()
    );
    assert_eq!(clean.csv, reference_full.csv, "no fault: recorded CSV");
    assert_eq!(clean.plain, reference_full.plain, "no fault: plain lines");
    assert!(clean.report("overrun").is_empty() && clean.summary.contains("lost_frames=0"));

    // A gap in the samples: counted once, realigned, nothing else changes.
    assert_eq!(gap.csv, reference_gapped.csv, "gap: recorded CSV");
    let (got, want) = (gap.frames(), reference_gapped.frames());
    assert_eq!(got.len(), want.len());
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g.values(), w.values());
        assert_eq!((g.num("seq"), g.num("drop")), (w.num("seq"), 0));
    }
    let ovr = counters(&got, "ovr");
    let first = ovr.iter().position(|&o| o == 1).expect("ovr reaches 1");
    assert!(
        first > 10 && first + 10 < ovr.len(),
        "ovr 0 → 1 at frame {first}"
    );
    assert!(ovr[..first].iter().all(|&o| o == 0) && ovr[first..].iter().all(|&o| o == 1));

    // A stalled UART: frames dropped and counted, the DSP never waits (no overrun).
    let (got, want) = (stall.frames(), reference_full.frames());
    let drops = counters(&got, "drop");
    let dropped = *drops.last().expect("frames");
    assert!(dropped > 10, "{dropped} frames dropped");
    assert_eq!(got.len() as u64 + dropped, want.len() as u64);
    assert!(
        counters(&got, "ovr").iter().all(|&o| o == 0),
        "the DSP task waited"
    );
    assert_eq!(
        counters(&got, "seq"),
        (0..got.len() as u64).collect::<Vec<_>>()
    );
    let (got_csv, want_csv) = (stall.csv_values(), reference_full.csv_values());
    let hole = got_csv
        .iter()
        .zip(&want_csv)
        .position(|(g, w)| g != w)
        .expect("some frames are missing");
    assert!(hole > 10, "frames dropped from frame {hole} on");
    assert_eq!(got_csv[..hole], want_csv[..hole]);
    assert_eq!(got_csv[hole..], want_csv[hole + dropped as usize..]);
    for (i, g) in got.iter().enumerate() {
        let w = &want[if i < hole { i } else { i + dropped as usize }];
        assert_eq!(g.values(), w.values());
    }
    // `drop` counts the frames dropped before a line was encoded: 0 at first, never less later,
    // all of them after the hole.
    assert_eq!(drops[0], 0);
    assert!(drops.windows(2).all(|w| w[0] <= w[1]));
    assert!(drops[hole..].iter().all(|&d| d == dropped));

    // A hung DSP task: watchdog reset, the stream restarts where the board resumed.
    assert!(hang.summary.contains("restarts=1"), "{}", hang.summary);
    let restart = hang
        .csv
        .iter()
        .skip(1)
        .position(|r| r.starts_with("0,"))
        .expect("seq restarts at 0")
        + 1;
    assert!(restart > 10, "{restart} frames before the hang");
    assert_eq!(hang.csv[..restart], reference_full.csv[..restart]);
    assert_eq!(hang.csv[restart..], reference_resumed.csv[..]);
    let calibration_starts = hang
        .plain
        .iter()
        .filter(|l| l.starts_with("selfcal seq=0 "))
        .count();
    assert_eq!(calibration_starts, 2, "a calibration line at each boot");
    assert!(counters(&hang.frames(), "ovr").iter().all(|&o| o == 0));
    assert!(counters(&hang.frames(), "drop").iter().all(|&d| d == 0));
}

/// Asserts `got == want`, naming the first line that differs.
fn assert_same(got: &[String], want: &[String], what: &str) {
    if let Some(i) = (0..got.len().max(want.len())).find(|&i| got.get(i) != want.get(i)) {
        panic!(
            "{what}: line {i} of {}/{} differs:\n got  {:?}\n want {:?}",
            got.len(),
            want.len(),
            got.get(i),
            want.get(i)
        );
    }
}

/// The valid records of an estimate store image, in slot order.
fn records(store: &Path) -> Vec<Record> {
    std::fs::read(store)
        .expect("read the store")
        .chunks_exact(RECORD_LEN)
        .filter_map(|slot| capsule_estimate_record::decode(slot.try_into().ok()?).ok())
        .collect()
}

#[test]
fn emulated_firmware_keeps_its_estimate_across_power_cycles() {
    let _emulator = one_at_a_time();
    emulator_ready();
    let dir = tempfile::tempdir().expect("temporary directory");
    let dir = dir.path();
    // An imperfect array, so that the self-calibration has something to learn; 12 s: one save, at
    // the calibration snapshot at 10 s.
    let wav = scene(
        dir,
        "imperfect.wav",
        &[
            "--synth",
            "12",
            "--track",
            "0:30,4:150,8:-90",
            "--snr",
            "3",
            "--seed",
            "4",
            "--capsule-gain-db",
            "1,-1,0.5",
            "--capsule-beta",
            "0.45,0.57,0.5",
        ],
    );
    let store = dir.join("board.store");

    // First power-up, no store yet: the file is made, the stream is exactly the host's (saving
    // changes nothing in it), and the snapshot at 10 s is saved exactly.
    let cold = record(dir, "cold", |port| {
        on_port(qemu(&wav, Fault::None, Some(&store)), port)
    });
    let cold_reference = reference(dir, "cold-reference", &wav);
    assert_same(
        &cold.plain,
        &cold_reference.plain,
        "cold start: plain lines",
    );
    assert_eq!(cold.csv, cold_reference.csv, "cold start: recorded CSV");
    assert_eq!(
        std::fs::metadata(&store).expect("store made").len(),
        16 * 1024
    );
    let saved = records(&store);
    assert_eq!(saved.len(), 1, "one record after 12 s");
    assert_eq!(saved[0].sequence, 0);
    let snapshot = cold
        .plain
        .iter()
        .find(|l| l.starts_with("selfcal seq=1 t=160000 "))
        .expect("the calibration line at 10 s");
    let band0 = snapshot
        .split_whitespace()
        .find_map(|kv| kv.strip_prefix("band0=n:"))
        .expect("band0 field");
    let printed: Vec<f32> = band0
        .split([',', '/'])
        .map(|v| v.trim_start_matches("a:").trim_start_matches("b:"))
        .map(|v| v.parse().expect("a number"))
        .collect();
    let b = &saved[0].estimate.bands[0];
    let stored: Vec<f32> = std::iter::once(b.peaks)
        .chain(b.omni_part)
        .chain(b.dipole_part)
        .collect();
    assert_eq!(printed.len(), stored.len(), "{band0}");
    assert!(
        (printed[0] - stored[0]).abs() <= 0.5,
        "{band0} vs {stored:?}"
    );
    for (p, s) in printed[1..].iter().zip(&stored[1..]) {
        assert!((p - s).abs() <= 5e-5, "{band0} vs {stored:?}");
    }
    assert!(b.omni_part[0] > 0.55, "learned, not ideal: {b:?}");

    // Second power-up: the board starts from the stored record, exactly as the host does from the
    // same store image (`--selfcal-in`), and appends the next record.
    let after_cold = dir.join("after-cold.store");
    std::fs::copy(&store, &after_cold).expect("copy the store");
    let warm = record(dir, "warm", |port| {
        on_port(qemu(&wav, Fault::None, Some(&store)), port)
    });
    let warm_reference = reference_from(dir, "warm-reference", &wav, Some(&after_cold));
    assert_same(
        &warm.plain,
        &warm_reference.plain,
        "warm start: plain lines",
    );
    assert_eq!(warm.csv, warm_reference.csv, "warm start: recorded CSV");
    assert_ne!(
        warm.plain[0], cold.plain[0],
        "the warm start is not the cold one"
    );
    let saved = records(&store);
    assert_eq!(saved.iter().map(|r| r.sequence).collect::<Vec<_>>(), [0, 1]);

    // A store path that names something else is refused and left alone: the WAV (another length),
    // and 16 KB of it (the store's length, other content).
    let before = std::fs::read(&wav).expect("read the scene");
    let look_alike = dir.join("look-alike.store");
    std::fs::write(&look_alike, &before[..16 * 1024]).expect("write the look-alike");
    for other in [&wav, &look_alike] {
        let before = std::fs::read(other).expect("read the file");
        let out = qemu(&wav, Fault::None, Some(other))
            .args(["-serial", "null"])
            .stdin(Stdio::null())
            .output()
            .expect("run QEMU");
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(!out.status.success(), "{stdout}");
        assert!(stdout.contains("not a store image"), "{stdout}");
        assert_eq!(std::fs::read(other).expect("read the file"), before);
    }
}
