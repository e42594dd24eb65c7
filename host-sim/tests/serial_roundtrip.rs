//! `host-sim emit` → pseudo-terminal pair (socat) → `host-sim monitor`, through real serial ports.
//!
//! Needs Debian's `socat` (`apt-get install socat`); without it these tests FAIL on purpose.

use cma_core::wire::Line;
use cma_core::wire::{self, Frame, MAX_LINE};
use host_sim::localization::analysis_rate::core_rate;
use host_sim::localization::frame_estimates::{self, CSV_HEADER};
use host_sim::serial::monitor::{
    background_plain_line, calibration_plain_line, plain_line, tracks_plain_line,
};
use std::collections::{BTreeSet, HashMap};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const BIN: &str = env!("CARGO_BIN_EXE_host-sim");

/// A socat-linked pty pair `DIR/ttyA` ↔ `DIR/ttyB`, killed on drop.
struct PtyPair {
    child: Child,
    a: PathBuf,
    b: PathBuf,
}

impl PtyPair {
    fn start(dir: &Path) -> PtyPair {
        let (a, b) = (dir.join("ttyA"), dir.join("ttyB"));
        let child = Command::new("socat")
            .arg("-d")
            .arg("-d")
            .arg(format!("pty,raw,echo=0,link={}", a.display()))
            .arg(format!("pty,raw,echo=0,link={}", b.display()))
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap_or_else(|e| {
                panic!(
                    "cannot run `socat` ({e}): the serial tests need it — install Debian's socat \
                     (`apt-get install socat`; .ci/run does)"
                )
            });
        let t0 = Instant::now();
        while !(a.exists() && b.exists()) {
            assert!(
                t0.elapsed() < Duration::from_secs(10),
                "socat did not create {} and {} within 10 s",
                a.display(),
                b.display()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        PtyPair { child, a, b }
    }
}

impl Drop for PtyPair {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A running `host-sim monitor` whose stderr lines arrive on a channel.
struct MonitorProc {
    child: Child,
    stderr: mpsc::Receiver<String>,
    stderr_lines: Vec<String>,
}

impl MonitorProc {
    fn start(port: &Path, extra: &[&str]) -> MonitorProc {
        let mut child = Command::new(BIN)
            .arg("monitor")
            .arg("--port")
            .arg(port)
            .arg("--plain")
            .args(extra)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("run host-sim monitor");
        let (tx, rx) = mpsc::channel();
        let err = child.stderr.take().expect("piped stderr");
        std::thread::spawn(move || {
            for line in BufReader::new(err).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let mut m = MonitorProc {
            child,
            stderr: rx,
            stderr_lines: Vec::new(),
        };
        m.wait_for_stderr("monitor: opened", Duration::from_secs(10));
        m
    }

    fn wait_for_stderr(&mut self, needle: &str, timeout: Duration) {
        let t0 = Instant::now();
        while !self.stderr_lines.iter().any(|l| l.contains(needle)) {
            let left = timeout.saturating_sub(t0.elapsed());
            match self.stderr.recv_timeout(left) {
                Ok(l) => self.stderr_lines.push(l),
                Err(_) => panic!(
                    "monitor did not print `{needle}` within {timeout:?}; stderr so far: {:#?}",
                    self.stderr_lines
                ),
            }
        }
    }

    /// Waits for the monitor to exit (it runs with --exit-after-idle); returns stdout and the
    /// summary counters.
    fn finish(mut self) -> (String, HashMap<String, u64>) {
        let mut out = String::new();
        let mut stdout = self.child.stdout.take().expect("piped stdout");
        let reader = std::thread::spawn(move || {
            let mut s = String::new();
            std::io::Read::read_to_string(&mut stdout, &mut s).expect("read monitor stdout");
            s
        });
        let t0 = Instant::now();
        let status = loop {
            if let Some(s) = self.child.try_wait().expect("wait monitor") {
                break s;
            }
            if t0.elapsed() > Duration::from_secs(60) {
                let _ = self.child.kill();
                panic!("monitor did not exit within 60 s");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        out.push_str(&reader.join().expect("stdout reader"));
        while let Ok(l) = self.stderr.recv_timeout(Duration::from_secs(2)) {
            self.stderr_lines.push(l);
        }
        assert!(status.success(), "monitor failed: {:#?}", self.stderr_lines);
        let summary = self
            .stderr_lines
            .iter()
            .find_map(|l| l.strip_prefix("monitor: summary "))
            .unwrap_or_else(|| panic!("no summary line in {:#?}", self.stderr_lines));
        let counters = summary
            .split_whitespace()
            .map(|kv| {
                let (k, v) = kv.split_once('=').expect("key=value");
                (k.to_string(), v.parse().expect("number"))
            })
            .collect();
        (out, counters)
    }
}

/// A moving-talker scene WAV at 48 kHz (`locate` and `emit` run the core on it at 16 kHz, the
/// boards' rate, and the lines carry that rate).
fn scene(dir: &Path, seconds: f64) -> PathBuf {
    let wav = dir.join("scene.wav");
    let st = Command::new(BIN)
        .args(["scene", "--rotate", "45", "--rate", "48000", "--snr", "20"])
        .args(["--synth", &seconds.to_string()])
        .arg("--out")
        .arg(&wav)
        .status()
        .expect("run host-sim scene");
    assert!(st.success());
    wav
}

/// What `locate` computes for the WAV (default configuration), as wire frames with seq = index.
fn locate_frames(wav: &Path) -> (Vec<frame_estimates::Row>, Vec<Frame>) {
    let cli = <host_sim::Cli as clap::Parser>::try_parse_from([
        "host-sim".into(),
        "locate".into(),
        wav.as_os_str().to_owned(),
    ])
    .expect("parse locate args");
    let host_sim::Command::Locate(a) = cli.command else {
        unreachable!("parsed a locate command")
    };
    let rec = host_sim::io::wav_io::read_recording(&a.input, a.input_layout).expect("read wav");
    let rows = frame_estimates::locate(
        &rec,
        a.config.config().expect("config"),
        a.config.ideal_table().expect("table"),
        |_| {},
    )
    .expect("locate");
    let frames = rows
        .iter()
        .enumerate()
        .map(|(i, r)| Frame::from_estimate(&r.estimate, i as u32, core_rate(rec.rate), 0, 0))
        .collect();
    (rows, frames)
}

fn wrap180(a: f64) -> f64 {
    let x = a.rem_euclid(360.0);
    if x > 180.0 {
        x - 360.0
    } else {
        x
    }
}

/// The monitor's record of an emitted WAV equals `locate`'s output:
/// - same number of rows, `frame` = locate's `frame_index`, `t_s` byte-identical to `locate --csv`;
/// - `azimuth_deg`, `azimuth_raw_deg` exactly `Frame::from_estimate(locate's estimate)` (0.1°
///   rounding, wrapped into (−180, 180]), so within 0.05° of locate's value; `confidence` exactly its
///   per-mille rounding (within 0.0005); `flags` identical; `power_db` empty (not on the wire).
#[test]
fn emit_to_monitor_round_trip_equals_locate() {
    let dir = tempfile::tempdir().expect("tempdir");
    let wav = scene(dir.path(), 4.0);
    let pty = PtyPair::start(dir.path());
    let rec = dir.path().join("rec.csv");
    let mon = MonitorProc::start(
        &pty.b,
        &[
            "--record",
            rec.to_str().unwrap(),
            "--exit-after-idle",
            "1.5",
        ],
    );
    let t0 = Instant::now();
    let st = Command::new(BIN)
        .arg("emit")
        .arg(&wav)
        .arg("--port")
        .arg(&pty.a)
        .status()
        .expect("run host-sim emit");
    assert!(st.success());
    let (stdout, counters) = mon.finish();
    eprintln!("emit → monitor took {:.2} s", t0.elapsed().as_secs_f64());

    let (rows, frames) = locate_frames(&wav);
    let loc_csv = dir.path().join("loc.csv");
    let st = Command::new(BIN)
        .arg("locate")
        .arg(&wav)
        .arg("--csv")
        .arg(&loc_csv)
        .status()
        .expect("run host-sim locate");
    assert!(st.success());
    let loc_text = std::fs::read_to_string(&loc_csv).unwrap();
    let rec_text = std::fs::read_to_string(&rec).unwrap();
    let loc_lines: Vec<&str> = loc_text.lines().collect();
    let rec_lines: Vec<&str> = rec_text.lines().collect();
    assert!(rows.len() > 100, "{} frames", rows.len());
    assert_eq!(rec_lines.len(), rows.len() + 1);
    assert_eq!(loc_lines.len(), rows.len() + 1);
    assert_eq!(rec_lines[0], CSV_HEADER);
    for (i, ((row, f), (rl, ll))) in rows
        .iter()
        .zip(&frames)
        .zip(rec_lines[1..].iter().zip(&loc_lines[1..]))
        .enumerate()
    {
        let r: Vec<&str> = rl.split(',').collect();
        let l: Vec<&str> = ll.split(',').collect();
        assert_eq!(r.len(), 7, "{rl}");
        assert_eq!(r[0], row.estimate.frame_index.to_string(), "frame, row {i}");
        assert_eq!(r[0], l[0]);
        assert_eq!(r[1], l[1], "t_s, row {i}");
        let num = |s: &str| s.parse::<f64>().unwrap();
        assert_eq!(
            (num(r[2]) * 10.0).round() as i16,
            f.azimuth_tenths,
            "row {i}"
        );
        assert_eq!((num(r[3]) * 10.0).round() as i16, f.raw_tenths, "row {i}");
        assert_eq!(
            (num(r[4]) * 1000.0).round() as u16,
            f.confidence_permille,
            "row {i}"
        );
        assert!(wrap180(num(r[2]) - f64::from(row.estimate.azimuth_deg)).abs() <= 0.05 + 1e-4);
        assert!(wrap180(num(r[3]) - f64::from(row.estimate.azimuth_raw_deg)).abs() <= 0.05 + 1e-4);
        assert!((num(r[4]) - f64::from(row.estimate.confidence)).abs() <= 0.0005 + 1e-6);
        assert_eq!(r[5], "", "power_db is not transmitted");
        assert_eq!(r[6], l[6], "flags, row {i}");
    }
    // The plain output carries every field, ovr/drop included (calibration lines are checked in
    // `emit_to_monitor_carries_calibration_lines`).
    let plain: Vec<&str> = stdout.lines().filter(|l| l.starts_with("seq=")).collect();
    let want: Vec<String> = frames.iter().map(plain_line).collect();
    assert_eq!(plain, want);
    assert_eq!(counters["frames"], frames.len() as u64);
    for k in ["corrupt_lines", "lost_frames", "garbage_bytes", "reopens"] {
        assert_eq!(counters[k], 0, "{k}");
    }
    // The record reads back as an estimate CSV (what eval/score use).
    let back = frame_estimates::read_csv(&rec).expect("read record");
    assert_eq!(back.len(), frames.len());
    // `host-sim score` of the record matches that of locate's CSV to the wire's resolution.
    let truth = wav.with_extension("pos.csv");
    let score = |csv: &Path| {
        let window = host_sim::evaluation::recorded_score::window(Some(0.0), None, &truth)
            .expect("score window");
        host_sim::evaluation::recorded_score::report(csv, &truth, &window)
            .expect("score")
            .overall
            .settled
    };
    let (m_rec, m_loc) = (score(&rec), score(&loc_csv));
    assert_eq!(m_rec.frames, m_loc.frames);
    assert!(
        (m_rec.mae - m_loc.mae).abs() <= 0.05,
        "{m_rec:?} vs {m_loc:?}"
    );
    eprintln!(
        "round trip: {} frames identical; score MAE {:.3}° (record) vs {:.3}° (locate)",
        frames.len(),
        m_rec.mae,
        m_loc.mae
    );
}

/// The lines `host-sim emit` sends for `wav` (default configuration).
fn emit_lines(wav: &Path) -> Vec<Line> {
    emit_lines_with(wav, &[])
}

/// The lines `host-sim emit` sends for `wav` with `extra` flags.
fn emit_lines_with(wav: &Path, extra: &[&str]) -> Vec<Line> {
    let mut args: Vec<std::ffi::OsString> = vec![
        "host-sim".into(),
        "emit".into(),
        wav.as_os_str().to_owned(),
        "--port".into(),
        "/dev/null".into(),
    ];
    args.extend(extra.iter().map(Into::into));
    let cli = <host_sim::Cli as clap::Parser>::try_parse_from(args).expect("parse emit args");
    let host_sim::Command::Emit(a) = cli.command else {
        unreachable!("parsed an emit command")
    };
    host_sim::commands::emit::lines(&a).expect("emit lines").1
}

/// Calibration lines end to end: `emit` sends one before the first frame and one after the frame
/// that is 10 s into the scene; the monitor decodes both (its `selfcal` plain lines are exactly
/// those of the lines sent, in their place between the frame lines), counts them apart from the
/// frames, and `--record` keeps frames only.
#[test]
fn emit_to_monitor_carries_calibration_lines() {
    let dir = tempfile::tempdir().expect("tempdir");
    let wav = scene(dir.path(), 12.0);
    let pty = PtyPair::start(dir.path());
    let rec = dir.path().join("rec.csv");
    let mon = MonitorProc::start(
        &pty.b,
        &[
            "--record",
            rec.to_str().unwrap(),
            "--exit-after-idle",
            "1.5",
        ],
    );
    let st = Command::new(BIN)
        .arg("emit")
        .arg(&wav)
        .arg("--port")
        .arg(&pty.a)
        .status()
        .expect("run host-sim emit");
    assert!(st.success());
    let (stdout, counters) = mon.finish();

    let sent = emit_lines(&wav);
    let want: Vec<String> = sent
        .iter()
        .map(|l| match l {
            Line::Frame(f) => plain_line(f),
            Line::Calibration(c) => calibration_plain_line(c),
            Line::Tracks(t) => tracks_plain_line(t),
            Line::Background(b) => background_plain_line(b),
        })
        .collect();
    let got: Vec<&str> = stdout.lines().collect();
    assert_eq!(got, want);
    let cals: Vec<_> = sent
        .iter()
        .filter_map(|l| match l {
            Line::Calibration(c) => Some(*c),
            Line::Frame(_) | Line::Tracks(_) | Line::Background(_) => None,
        })
        .collect();
    let backgrounds: Vec<_> = sent
        .iter()
        .filter_map(|l| match l {
            Line::Background(b) => Some(*b),
            _ => None,
        })
        .collect();
    let n_frames = sent.len() - cals.len() - backgrounds.len();
    // A background line one estimate after each calibration line.
    assert_eq!(backgrounds.len(), 2, "{backgrounds:?}");
    assert!(matches!(sent[2], Line::Background(b) if b.seq == 0));
    assert_eq!(backgrounds[1].seq, 1);
    assert!(backgrounds[1].centre_sample > cals[1].centre_sample);
    assert_eq!(counters["background_lines"], 2);
    assert_eq!(cals.len(), 2, "{cals:?}");
    assert!(matches!(sent[0], Line::Calibration(c) if c.seq == 0 && c.centre_sample == 0));
    assert_eq!(cals[1].seq, 1);
    // 10 s at 16 kHz (the 48 kHz scene brought to the boards' rate), within one hop.
    assert!(
        (160_000..160_000 + 256).contains(&cals[1].centre_sample),
        "{}",
        cals[1].centre_sample
    );
    assert!(got[0].starts_with("selfcal seq=0 t=0 "), "{}", got[0]);
    assert_eq!(counters["calibration_lines"], 2);
    assert_eq!(counters["frames"], n_frames as u64);
    for k in ["corrupt_lines", "lost_frames", "garbage_bytes"] {
        assert_eq!(counters[k], 0, "{k}");
    }
    let rec_text = std::fs::read_to_string(&rec).unwrap();
    assert_eq!(rec_text.lines().count(), n_frames + 1, "frames only");
    assert!(!rec_text.contains("selfcal"));
}

/// Track lines end to end: `emit --multi-talker on` on a two-talker conversation sends a track line
/// after every frame line, the frame lines are those of the default (the tracks do not change the
/// single estimate), and the monitor prints exactly the lines sent and counts the track lines.
#[test]
fn emit_to_monitor_carries_track_lines() {
    let dir = tempfile::tempdir().expect("tempdir");
    let wav = dir.path().join("talkers.wav");
    let st = Command::new(BIN)
        .args(["scene", "--talkers", "2", "--synth", "6", "--snr", "10"])
        .args(["--azimuths", "40,-100", "--out"])
        .arg(&wav)
        .status()
        .expect("run host-sim scene");
    assert!(st.success());
    let pty = PtyPair::start(dir.path());
    let mon = MonitorProc::start(&pty.b, &["--exit-after-idle", "1.5"]);
    let st = Command::new(BIN)
        .arg("emit")
        .arg(&wav)
        .arg("--port")
        .arg(&pty.a)
        .args(["--multi-talker", "on"])
        .status()
        .expect("run host-sim emit");
    assert!(st.success());
    let (stdout, counters) = mon.finish();

    let sent = emit_lines_with(&wav, &["--multi-talker", "on"]);
    let want: Vec<String> = sent
        .iter()
        .map(|l| match l {
            Line::Frame(f) => plain_line(f),
            Line::Calibration(c) => calibration_plain_line(c),
            Line::Tracks(t) => tracks_plain_line(t),
            Line::Background(b) => background_plain_line(b),
        })
        .collect();
    assert_eq!(stdout.lines().collect::<Vec<_>>(), want);
    let frames = |lines: &[Line]| -> Vec<Frame> {
        lines
            .iter()
            .filter_map(|l| match l {
                Line::Frame(f) => Some(*f),
                _ => None,
            })
            .collect()
    };
    assert_eq!(frames(&sent), frames(&emit_lines(&wav)));
    let tracks: Vec<_> = sent
        .iter()
        .filter_map(|l| match l {
            Line::Tracks(t) => Some(t.clone()),
            _ => None,
        })
        .collect();
    // A track line follows every frame line once the first frame's activity is decided, and
    // holds the tracks of the frame `span_delay_frames()` frame lines earlier.
    let gap = cma_core::multi_track::MultiTrack::DEFAULT.span_delay_frames() as usize;
    let sent_frames = frames(&sent);
    assert_eq!(tracks.len(), sent_frames.len() - gap);
    assert!(tracks.iter().enumerate().all(|(i, t)| t.seq == i as u32));
    assert!(tracks
        .iter()
        .zip(&sent_frames)
        .all(|(t, f)| t.centre_sample == f.centre_sample));
    let mut frame_lines = 0;
    for l in &sent {
        match l {
            Line::Frame(_) => frame_lines += 1,
            Line::Tracks(t) => assert_eq!(
                frame_lines,
                t.seq as usize + gap + 1,
                "a track line follows the frame line that decided it"
            ),
            _ => {}
        }
    }
    let ids: BTreeSet<u16> = tracks
        .iter()
        .flat_map(|t| t.active().iter().map(|k| k.id))
        .collect();
    assert_eq!(ids, BTreeSet::from([1, 2]), "two talkers, two IDs");
    assert_eq!(counters["track_lines"], tracks.len() as u64);
    for k in ["corrupt_lines", "lost_frames", "garbage_bytes"] {
        assert_eq!(counters[k], 0, "{k}");
    }
}

/// xorshift64*: a small seeded generator, so the corruption is reproducible.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

/// Expected monitor counters for a byte stream, from the framing rule stated in `cma_core::wire`
/// (independent of `LineAssembler`): a candidate line runs from `$` to the next `\n` (one `\r`
/// before it removed); a `$` before the `\n` abandons the partial line; a candidate longer than
/// `MAX_LINE` bytes is rejected; bytes outside lines are garbage.
#[derive(Debug, Default, PartialEq)]
struct Expected {
    accepted: Vec<Frame>,
    corrupt_lines: u64,
    garbage_bytes: u64,
}

fn reference_model(stream: &[u8]) -> Expected {
    let mut e = Expected::default();
    let mut cur: Option<Vec<u8>> = None;
    for &b in stream {
        match (b, cur.as_mut()) {
            (b'$', partial) => {
                if partial.is_some() {
                    e.corrupt_lines += 1;
                }
                cur = Some(vec![b'$']);
            }
            (b'\n', Some(_)) => {
                let mut l = cur.take().unwrap();
                if l.last() == Some(&b'\r') {
                    l.pop();
                }
                match (l.len() <= MAX_LINE).then(|| wire::decode(&l)) {
                    Some(Ok(f)) => e.accepted.push(f),
                    _ => e.corrupt_lines += 1,
                }
            }
            (_, Some(l)) => l.push(b),
            (_, None) => e.garbage_bytes += 1,
        }
    }
    e
}

/// 1 % of the bytes of an emitted stream corrupted (half replaced by another random byte, half
/// dropped), written into one end of the pty pair in random-sized chunks: every intact line is
/// decoded, no damaged line yields a frame other than the one sent, and the monitor's counters equal
/// the reference model's exactly (frames, corrupt lines, lost frames = seq gaps between accepted
/// frames, gap events, garbage bytes, bytes).
#[test]
fn corrupted_stream_counters_are_exact() {
    let dir = tempfile::tempdir().expect("tempdir");
    let wav = scene(dir.path(), 8.0);
    let (_, frames) = locate_frames(&wav);

    let mut rng = Rng(0x5EED_CA5C_ADE5_u64);
    let mut stream = Vec::new();
    let mut intact = Vec::new();
    let (mut replaced, mut dropped) = (0u64, 0u64);
    for f in &frames {
        let mut buf = heapless::Vec::<u8, MAX_LINE>::new();
        wire::encode(f, &mut buf);
        let mut damaged = false;
        for &b in &buf[..] {
            if rng.below(100) == 0 {
                damaged = true;
                if rng.below(2) == 0 {
                    dropped += 1;
                    continue;
                }
                replaced += 1;
                stream.push(b ^ (1 + rng.below(255)) as u8);
            } else {
                stream.push(b);
            }
        }
        intact.push(!damaged);
    }
    stream.push(b'\n'); // closes a line left open by a lost final `\n`
    let expected = reference_model(&stream);

    let pty = PtyPair::start(dir.path());
    let mon = MonitorProc::start(&pty.b, &["--exit-after-idle", "1.5"]);
    {
        let mut port = std::fs::OpenOptions::new()
            .write(true)
            .open(&pty.a)
            .expect("open ttyA");
        let mut rest = &stream[..];
        while !rest.is_empty() {
            let n = (1 + rng.below(200) as usize).min(rest.len());
            port.write_all(&rest[..n]).expect("write ttyA");
            rest = &rest[n..];
        }
        port.flush().unwrap();
        // Keep ttyA open until the monitor has read everything and gone idle.
        let (stdout, counters) = mon.finish();

        let accepted: Vec<&str> = stdout.lines().collect();
        let seqs: Vec<u32> = accepted
            .iter()
            .map(|l| {
                l.strip_prefix("seq=")
                    .and_then(|r| r.split(' ').next())
                    .and_then(|s| s.parse().ok())
                    .unwrap_or_else(|| panic!("bad plain line {l}"))
            })
            .collect();
        // No damaged line became another frame: each accepted line is exactly the frame sent.
        for (l, &s) in accepted.iter().zip(&seqs) {
            assert_eq!(*l, plain_line(&frames[s as usize]));
        }
        // Every intact line was decoded (damage confined to \r\n may still decode: same frame).
        let got: BTreeSet<u32> = seqs.iter().copied().collect();
        assert_eq!(got.len(), seqs.len(), "a frame was accepted twice");
        let n_intact = intact.iter().filter(|&&x| x).count();
        for (i, ok) in intact.iter().enumerate() {
            if *ok {
                assert!(got.contains(&(i as u32)), "intact frame {i} not decoded");
            }
        }
        assert_eq!(
            expected.accepted.iter().map(|f| f.seq).collect::<Vec<_>>(),
            seqs
        );
        let (first, last) = (seqs[0], *seqs.last().unwrap());
        let lost = u64::from(last - first + 1) - seqs.len() as u64;
        let gap_events = seqs.windows(2).filter(|w| w[1] - w[0] > 1).count() as u64;
        eprintln!(
            "corruption test: {} frames sent, {} bytes, {replaced} bytes replaced, {dropped} \
             dropped; {n_intact} lines intact, {} accepted; monitor: {counters:?}",
            frames.len(),
            stream.len(),
            seqs.len()
        );
        assert_eq!(counters["frames"], seqs.len() as u64);
        assert_eq!(counters["lost_frames"], lost);
        assert_eq!(counters["gap_events"], gap_events);
        assert_eq!(counters["corrupt_lines"], expected.corrupt_lines);
        assert_eq!(counters["garbage_bytes"], expected.garbage_bytes);
        assert_eq!(counters["bytes"], stream.len() as u64);
        assert_eq!(counters["duplicates"], 0);
        assert_eq!(counters["restarts"], 0);
        assert!(
            replaced + dropped > 50,
            "too little corruption to mean anything"
        );
        assert!(lost > 0 && expected.corrupt_lines > 0);
    }
}

/// Unplug (socat killed) and replug (new socat on the same paths): the monitor reopens the port and
/// keeps counting; the second session's seq restart is counted as a restart, not as lost frames.
#[test]
fn monitor_survives_unplug_and_replug() {
    let dir = tempfile::tempdir().expect("tempdir");
    let wav = scene(dir.path(), 2.0);
    let (_, frames) = locate_frames(&wav);
    let emit = |port: &Path| {
        let st = Command::new(BIN)
            .arg("emit")
            .arg(&wav)
            .arg("--port")
            .arg(port)
            .status()
            .expect("run host-sim emit");
        assert!(st.success());
    };
    let pty = PtyPair::start(dir.path());
    let mut mon = MonitorProc::start(&pty.b, &["--exit-after-idle", "3"]);
    emit(&pty.a);
    std::thread::sleep(Duration::from_millis(300));
    drop(pty);
    mon.wait_for_stderr("lost", Duration::from_secs(5));
    let pty = PtyPair::start(dir.path());
    mon.wait_for_stderr("reopened", Duration::from_secs(5));
    emit(&pty.a);
    let (stdout, counters) = mon.finish();
    let frame_lines = stdout.lines().filter(|l| l.starts_with("seq=")).count();
    assert_eq!(frame_lines, 2 * frames.len());
    assert_eq!(counters["calibration_lines"], 2, "one at each start");
    assert_eq!(counters["frames"], 2 * frames.len() as u64);
    assert_eq!(counters["reopens"], 1);
    assert_eq!(counters["restarts"], 1);
    assert_eq!(counters["lost_frames"], 0);
    assert_eq!(counters["corrupt_lines"], 0);
}

/// Clear errors, no panics: missing port, bad baud, unreadable WAV.
#[test]
fn clear_errors_for_bad_ports_bauds_and_wavs() {
    let dir = tempfile::tempdir().expect("tempdir");
    let run = |args: &[&str]| {
        let out = Command::new(BIN).args(args).output().expect("run host-sim");
        assert!(!out.status.success(), "{args:?} should fail");
        let err = String::from_utf8_lossy(&out.stderr).to_string();
        assert!(!err.contains("panicked"), "{err}");
        err
    };
    let err = run(&["monitor", "--port", "/dev/does-not-exist"]);
    assert!(
        err.contains("/dev/does-not-exist: cannot open serial port"),
        "{err}"
    );
    let err = run(&["monitor", "--port", "/dev/null", "--baud", "0"]);
    assert!(err.contains("--baud"), "{err}");
    let err = run(&["monitor", "--port", "/dev/null", "--baud", "fast"]);
    assert!(err.contains("--baud"), "{err}");
    let bogus = dir.path().join("bogus.wav");
    std::fs::write(&bogus, b"not a wav").unwrap();
    let err = run(&[
        "emit",
        bogus.to_str().unwrap(),
        "--port",
        "/dev/does-not-exist",
    ]);
    assert!(err.contains("not a valid WAV file"), "{err}");
    let wav = scene(dir.path(), 0.5);
    let err = run(&[
        "emit",
        wav.to_str().unwrap(),
        "--port",
        "/dev/does-not-exist",
    ]);
    assert!(err.contains("cannot open serial port"), "{err}");
}
