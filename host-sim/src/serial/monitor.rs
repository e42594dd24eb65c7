//! The host side of a board's serial stream: the byte-stream [`Decoder`] (line assembly with the
//! core's [`cma_core::wire`] decoder, and counters for corrupt lines, lost frames — sequence gaps —
//! and the board's own overrun/drop counters), the text of each line (`--plain`), the live compass
//! view ([`render`]), the frame-rate meter and the `--record` writer. No port and no terminal:
//! `host-sim monitor` (`commands::monitor`) drives them.
//!
//! The board's calibration lines (`$CAL`, the self-calibration's state, one every 10 s) are decoded
//! too: the live view shows the last one in one line ([`calibration_summary`]), `--plain` prints
//! each as a `selfcal …` line ([`calibration_plain_line`]) between the frame lines. `--record` keeps
//! recording frames only (its CSV is `locate`'s); a calibration line is not a frame and does not
//! count in the frame counters.
//!
//! The board's background lines (`$BGF`, the stationary background per band, one every 10 s) are
//! decoded too: the live view marks each band's stationary source on the compass (`L`
//! below 1 kHz, `H` from 1 kHz, when its directivity is above
//! [`DIRECTIONAL_MIN`](cma_core::background_field::DIRECTIONAL_MIN), else the band is called
//! diffuse) and prints the bands in one line ([`background_summary`]); `--plain` prints each as a
//! `background …` line ([`background_plain_line`]).
//!
//! Counter definitions (exact, the serial round-trip test checks them):
//! - *frames*: frame lines that decoded;
//! - *calibration lines*: calibration lines that decoded;
//! - *corrupt lines*: candidate lines (`$` … `\n`) that did not decode, plus partial lines cut short
//!   by a `$` and lines longer than [`MAX_LINE`] ([`LineAssembler`]'s `interrupted` and `overlong`);
//! - *lost frames*: sequence numbers missing between consecutive decoded frames (`seq` steps of 2 or
//!   more, modulo 2³²); a step backwards (by 2³¹ or more, a board restart) counts as a *restart*, a
//!   repeated `seq` as a *duplicate*, neither as lost;
//! - *garbage bytes*: bytes outside any line (before a `$`).

use crate::error::{Result, SimError};
use crate::io::estimate_output::{flag_names, Format};
use crate::io::serial_link::DEFAULT_BAUD;
use crate::localization::frame_estimates::CSV_HEADER;
use cma_core::background_field::{BG_BANDS, BG_BAND_EDGES_HZ};
use cma_core::capsule_calibration::CAL_BANDS;
use cma_core::wire::{
    self, AssemblerStats, BackgroundLine, CalibrationLine, DecodeError, Frame, Line, LineAssembler,
    TracksLine, WireBackgroundBand, MAX_ANY_LINE, MAX_LINE, PART_SCALE,
};
use cma_core::Flags;
use cma_core::CARDIOIDS;
use std::collections::VecDeque;
use std::fmt::Write as _;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Monitor counters (see the module documentation for the exact definitions).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Bytes received.
    pub bytes: u64,
    /// Frames decoded.
    pub frames: u64,
    /// Calibration lines decoded.
    pub calibration_lines: u64,
    /// Multi-talker track lines decoded.
    pub track_lines: u64,
    /// Background lines decoded.
    pub background_lines: u64,
    /// Candidate lines rejected by the decoder, cut short by a `$`, or too long.
    pub corrupt_lines: u64,
    /// Sequence numbers missing between consecutive decoded frames.
    pub lost_frames: u64,
    /// Number of sequence gaps (one gap may lose several frames).
    pub gap_events: u64,
    /// Frames whose `seq` repeated the previous one.
    pub duplicates: u64,
    /// Frames whose `seq` went backwards (board restarted).
    pub restarts: u64,
    /// Bytes outside any line.
    pub garbage_bytes: u64,
    /// The board's DMA overrun counter, from the last frame.
    pub board_overruns: u32,
    /// The board's UART backpressure drop counter, from the last frame.
    pub board_dropped: u32,
}

impl Counters {
    /// `key=value` pairs on one line (the monitor's summary; stable for scripts).
    pub fn summary(&self, reopens: u64) -> String {
        format!(
            "frames={} corrupt_lines={} lost_frames={} gap_events={} duplicates={} restarts={} \
             garbage_bytes={} bytes={} board_overruns={} board_dropped={} reopens={} \
             calibration_lines={}",
            self.frames,
            self.corrupt_lines,
            self.lost_frames,
            self.gap_events,
            self.duplicates,
            self.restarts,
            self.garbage_bytes,
            self.bytes,
            self.board_overruns,
            self.board_dropped,
            reopens,
            self.calibration_lines
        ) + &if self.track_lines > 0 {
            format!(" track_lines={}", self.track_lines)
        } else {
            String::new()
        } + &if self.background_lines > 0 {
            format!(" background_lines={}", self.background_lines)
        } else {
            String::new()
        }
    }
}

/// Bytes without a decoded frame after which the monitor says why (wrong baud rate or noise).
pub const WRONG_BAUD_BYTES: u64 = 8 * MAX_LINE as u64;

/// Share of text bytes (printable ASCII, CR, LF) below which bytes without frames look like a wrong
/// baud rate: the frame lines are ASCII, and at the right rate even a noisy line stays mostly text,
/// while bytes sampled at the wrong rate spread over all 256 values.
pub const WRONG_BAUD_TEXT_SHARE: f64 = 0.75;

/// The byte-stream decoder of the monitor: line assembly, decoding, counters. No I/O.
#[derive(Debug, Clone, Default)]
pub struct Decoder {
    asm: LineAssembler<MAX_ANY_LINE>,
    seen: AssemblerStats,
    counters: Counters,
    last_seq: Option<u32>,
    bytes_since_frame: u64,
    text_since_frame: u64,
    last_error: Option<DecodeError>,
}

impl Decoder {
    /// A decoder waiting for the first `$`.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Feeds received bytes; `on_frame` gets each decoded frame (calibration lines are counted but
    /// not passed on).
    pub fn feed(&mut self, bytes: &[u8], mut on_frame: impl FnMut(&Frame)) {
        self.feed_lines(bytes, |l| {
            if let Line::Frame(f) = l {
                on_frame(f);
            }
        });
    }

    /// Feeds received bytes; `on_line` gets each decoded line, frame or calibration.
    pub fn feed_lines(&mut self, bytes: &[u8], mut on_line: impl FnMut(&Line)) {
        let Decoder {
            asm,
            counters,
            last_seq,
            bytes_since_frame,
            text_since_frame,
            last_error,
            ..
        } = self;
        counters.bytes += bytes.len() as u64;
        for &b in bytes {
            *bytes_since_frame += 1;
            if b.is_ascii_graphic() || matches!(b, b' ' | b'\r' | b'\n') {
                *text_since_frame += 1;
            }
            let Some(line) = asm.push(b) else { continue };
            match wire::decode_line(line) {
                Ok(l) => {
                    match &l {
                        Line::Frame(f) => {
                            count_seq(counters, last_seq, f.seq);
                            counters.frames += 1;
                            counters.board_overruns = f.overruns;
                            counters.board_dropped = f.dropped;
                        }
                        Line::Calibration(_) => counters.calibration_lines += 1,
                        Line::Tracks(_) => counters.track_lines += 1,
                        Line::Background(_) => counters.background_lines += 1,
                    }
                    *bytes_since_frame = 0;
                    *text_since_frame = 0;
                    on_line(&l);
                }
                Err(e) => {
                    counters.corrupt_lines += 1;
                    *last_error = Some(e);
                }
            }
        }
        self.absorb_assembler_stats();
    }

    /// Drops a partial line (after the port was reopened: its rest is lost).
    pub fn reset_line(&mut self) {
        self.asm.reset();
        self.absorb_assembler_stats();
    }

    fn absorb_assembler_stats(&mut self) {
        let s = self.asm.stats();
        let d = |now: u32, before: u32| u64::from(now.wrapping_sub(before));
        self.counters.corrupt_lines += d(s.interrupted, self.seen.interrupted);
        self.counters.corrupt_lines += d(s.overlong, self.seen.overlong);
        self.counters.garbage_bytes += d(s.garbage_bytes, self.seen.garbage_bytes);
        self.seen = s;
    }

    /// The counters so far.
    #[must_use]
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// Why the last rejected line was rejected.
    #[must_use]
    pub fn last_error(&self) -> Option<DecodeError> {
        self.last_error
    }

    /// Bytes received since the last decoded frame (or since the start).
    #[must_use]
    pub fn bytes_since_frame(&self) -> u64 {
        self.bytes_since_frame
    }

    /// Share of text bytes since the last decoded frame (1 when none arrived).
    #[must_use]
    pub fn text_share_since_frame(&self) -> f64 {
        if self.bytes_since_frame == 0 {
            1.0
        } else {
            self.text_since_frame as f64 / self.bytes_since_frame as f64
        }
    }

    /// The wrong-baud hint, when [`WRONG_BAUD_BYTES`] or more arrived without a decoded frame and
    /// they do not look like text ([`WRONG_BAUD_TEXT_SHARE`]).
    #[must_use]
    pub fn baud_hint(&self, baud: u32) -> Option<String> {
        let garbled = self.text_share_since_frame() < WRONG_BAUD_TEXT_SHARE;
        (self.bytes_since_frame >= WRONG_BAUD_BYTES && garbled).then(|| {
            let suggestion = if baud == DEFAULT_BAUD {
                "check the board's UART setting; common rates: 9600, 57600, 230400, 460800, 921600"
                    .to_string()
            } else {
                format!("try --baud {DEFAULT_BAUD}")
            };
            format!(
                "no valid frames in {} bytes — wrong baud rate? ({suggestion})",
                self.bytes_since_frame
            )
        })
    }
}

impl Decoder {
    /// The hint for many bytes of text without a decoded frame: the baud rate is right but the lines
    /// do not decode (line noise, or another program's output on the port).
    #[must_use]
    pub fn noise_hint(&self) -> Option<String> {
        let text = self.text_share_since_frame() >= WRONG_BAUD_TEXT_SHARE;
        (self.bytes_since_frame >= WRONG_BAUD_BYTES && text).then(|| {
            let why = self
                .last_error
                .map_or_else(|| "no frame line".to_string(), |e| format!("last: {e}"));
            format!(
                "no valid frames in {} bytes of text — line noise or another sender? ({why})",
                self.bytes_since_frame
            )
        })
    }
}

fn count_seq(c: &mut Counters, last: &mut Option<u32>, seq: u32) {
    if let Some(prev) = *last {
        let step = seq.wrapping_sub(prev);
        if step == 0 {
            c.duplicates += 1;
        } else if step >= 1 << 31 {
            c.restarts += 1;
        } else if step > 1 {
            c.lost_frames += u64::from(step - 1);
            c.gap_events += 1;
        }
    }
    *last = Some(seq);
}

/// One `--plain` line for a frame.
#[must_use]
pub fn plain_line(f: &Frame) -> String {
    let t = f
        .time_s()
        .map_or_else(|| "?".to_string(), |t| format!("{t:.6}"));
    format!(
        "seq={} t_s={t} az={:.1} raw={:.1} conf={:.3} flags={}{} ovr={} drop={}",
        f.seq,
        f64::from(f.azimuth_tenths) / 10.0,
        f64::from(f.raw_tenths) / 10.0,
        f64::from(f.confidence_permille) / 1000.0,
        f.flags,
        bracketed_names(f.flags()),
        f.overruns,
        f.dropped
    )
}

/// Gains (dB) and patterns β of the three cardioids, each the mean over the line's bands.
#[must_use]
pub fn calibration_means(c: &CalibrationLine) -> ([f64; CARDIOIDS], [f64; CARDIOIDS]) {
    let est = c.capsules();
    let (mut gain_db, mut beta) = ([0.0; CARDIOIDS], [0.0; CARDIOIDS]);
    for m in 0..CARDIOIDS {
        for b in &est.bands {
            gain_db[m] += f64::from(b.gain_db(m)) / CAL_BANDS as f64;
            beta[m] += f64::from(b.beta(m)) / CAL_BANDS as f64;
        }
    }
    (gain_db, beta)
}

/// The live view's line for a calibration line (at most 74 characters): confidence, each
/// cardioid's gain (dB) and pattern β as means over the bands, `held` when the estimate is held,
/// and the size of the talker's shift when it has one (`CapsuleEstimate::talker_shift`, plane
/// units). E.g. `selfcal 0.83  gain +0.42 -0.80 +0.20 dB  β .470 .550 .500  held  shift .09`.
#[must_use]
pub fn calibration_summary(c: &CalibrationLine) -> String {
    let (gain_db, beta) = calibration_means(c);
    // ".470": β lies in (0, 1); a value of 1 or more (not a plausible cardioid) keeps its digit.
    let b = |v: f64| {
        let s = format!("{:.3}", v.clamp(0.0, 9.999));
        s.strip_prefix('0').map(str::to_string).unwrap_or(s)
    };
    let shift = if c.has_talker_shift() {
        let [x, y] = c.capsules().talker_shift.map(f64::from);
        // Within 0…0.71 (each component within ±0.5): ".09".
        let s = format!("{:.2}", x.hypot(y).min(0.99));
        format!("  shift {}", s.strip_prefix('0').unwrap_or(&s))
    } else {
        String::new()
    };
    format!(
        "selfcal {:.2}  gain {:+.2} {:+.2} {:+.2} dB  β {} {} {}{}{shift}",
        c.confidence(),
        gain_db[0].clamp(-99.0, 99.0),
        gain_db[1].clamp(-99.0, 99.0),
        gain_db[2].clamp(-99.0, 99.0),
        b(beta[0]),
        b(beta[1]),
        b(beta[2]),
        if c.held { "  held" } else { "" }
    )
}

/// One `--plain` line for a calibration line: `selfcal`, the line's fields (`t` in board samples),
/// the mean gains and patterns, then per band `n` and the omni and dipole parts exactly as sent.
#[must_use]
/// The plain text of a track line: `tracks seq=… t=… n=…` and `id<ID>=<azimuth>@<confidence>` per
/// active talker.
pub fn tracks_plain_line(t: &TracksLine) -> String {
    let mut s = format!(
        "tracks seq={} t={} n={}",
        t.seq,
        t.centre_sample,
        t.tracks.len()
    );
    for k in t.active() {
        s.push_str(&format!(
            " id{}={:.1}@{:.3}",
            k.id,
            k.azimuth_deg(),
            k.confidence()
        ));
    }
    s
}

/// The plain text of a calibration line: the estimate's mean gain and pattern per cardioid, the
/// talker's shift, then each band's parts.
pub fn calibration_plain_line(c: &CalibrationLine) -> String {
    let (gain_db, beta) = calibration_means(c);
    let [sx, sy] = c.capsules().talker_shift;
    let mut s = format!(
        "selfcal seq={} t={} conf={:.3} held={} drop={} gain_db={:+.2},{:+.2},{:+.2} \
         beta={:.3},{:.3},{:.3} shift={sx:+.4},{sy:+.4}",
        c.seq,
        c.centre_sample,
        c.confidence(),
        u8::from(c.held),
        c.dropped,
        gain_db[0],
        gain_db[1],
        gain_db[2],
        beta[0],
        beta[1],
        beta[2]
    );
    let part = |v: u16| f64::from(v) / f64::from(PART_SCALE);
    for (k, b) in c.bands.iter().enumerate() {
        let _ = write!(
            s,
            " band{k}=n:{},a:{:.4}/{:.4}/{:.4},b:{:.4}/{:.4}/{:.4}",
            b.peaks,
            part(b.omni_part[0]),
            part(b.omni_part[1]),
            part(b.omni_part[2]),
            part(b.dipole_part[0]),
            part(b.dipole_part[1]),
            part(b.dipole_part[2])
        );
    }
    s
}

/// Name of background band `band` from the band edges: `<1 kHz`, `≥1 kHz` (a middle band
/// `1–2 kHz`).
#[must_use]
pub fn background_band_name(band: usize) -> String {
    let khz = |hz: f32| format!("{}", f64::from(hz) / 1000.0);
    let lower = band.checked_sub(1).and_then(|b| BG_BAND_EDGES_HZ.get(b));
    match (lower, BG_BAND_EDGES_HZ.get(band)) {
        (None, Some(hi)) => format!("<{} kHz", khz(*hi)),
        (Some(lo), None) => format!("≥{} kHz", khz(*lo)),
        (Some(lo), Some(hi)) => format!("{}–{} kHz", khz(*lo), khz(*hi)),
        (None, None) => "all".to_string(),
    }
}

/// The mark of background band `band` on the compass: `L` for the lowest band, `H` for the
/// highest (`M` between).
#[must_use]
pub fn background_mark(band: usize) -> char {
    if band == 0 {
        'L'
    } else if band + 1 == BG_BANDS {
        'H'
    } else {
        'M'
    }
}

/// One band of [`background_summary`]: `-123° dir 0.45 -52 dBFS` for a dominant source,
/// `diffuse (0.12) -60 dBFS` at or below the threshold, `--` without evidence.
fn background_band_text(b: &WireBackgroundBand) -> String {
    if !b.has_evidence() {
        return "--".to_string();
    }
    let level = f64::from(b.level_db());
    if b.is_directional() {
        format!(
            "{:.0}° dir {:.2} {level:.0} dBFS",
            b.direction_deg(),
            b.directivity()
        )
    } else {
        format!("diffuse ({:.2}) {level:.0} dBFS", b.directivity())
    }
}

/// The live view's line for a background line (at most 80 characters for levels above −200
/// dBFS): per band its compass mark, its name, and its stationary source's direction,
/// directivity and level (dB re full-scale mean square), or `diffuse` when the directivity is
/// at most [`DIRECTIONAL_MIN`](cma_core::background_field::DIRECTIONAL_MIN). E.g.
/// `background: L <1 kHz 31° dir 0.45 -52 dBFS; H ≥1 kHz diffuse (0.12) -60 dBFS`.
#[must_use]
pub fn background_summary(l: &BackgroundLine) -> String {
    let bands: Vec<String> = l
        .bands
        .iter()
        .enumerate()
        .map(|(k, b)| {
            format!(
                "{} {} {}",
                background_mark(k),
                background_band_name(k),
                background_band_text(b)
            )
        })
        .collect();
    format!("background: {}", bands.join("; "))
}

/// The plain text of a background line: `background seq=… t=…` and per band
/// `band<k>=n:<frames>,az:<deg>,dir:<directivity>,db:<level>` exactly as sent.
#[must_use]
pub fn background_plain_line(l: &BackgroundLine) -> String {
    let mut s = format!("background seq={} t={}", l.seq, l.centre_sample);
    for (k, b) in l.bands.iter().enumerate() {
        let _ = write!(
            s,
            " band{k}=n:{},az:{:.1},dir:{:.3},db:{:.1}",
            b.frames,
            b.direction_deg(),
            b.directivity(),
            b.level_db()
        );
    }
    s
}

/// The compass marks of a background line's directional bands: ([`background_mark`], direction).
#[must_use]
pub fn background_marks(l: &BackgroundLine) -> Vec<(char, f64)> {
    l.bands
        .iter()
        .enumerate()
        .filter(|(_, b)| b.is_directional())
        .map(|(k, b)| (background_mark(k), f64::from(b.direction_tenths) / 10.0))
        .collect()
}

/// `(NAME|NAME)` of the set flags, or nothing.
fn bracketed_names(flags: Flags) -> String {
    let names = flag_names(flags);
    if names.is_empty() {
        String::new()
    } else {
        format!("({})", names.join("|"))
    }
}

/// One `--record` CSV row (columns [`CSV_HEADER`]): `frame` is the line's `seq` (the core's frame
/// index when the board starts at 0 and drops nothing), `t_s` = `t / rate_hz` formatted as by
/// `locate`, azimuths and confidence at the wire's resolution, `power_db` empty (not transmitted),
/// `flags` decimal. `None` if the frame's sample rate is 0 (no time).
#[must_use]
pub fn csv_row(f: &Frame) -> Option<String> {
    let t = f.time_s()?;
    Some(format!(
        "{},{:.6},{:.2},{:.2},{:.4},,{}",
        f.seq,
        t,
        f64::from(f.azimuth_tenths) / 10.0,
        f64::from(f.raw_tenths) / 10.0,
        f64::from(f.confidence_permille) / 1000.0,
        f.flags
    ))
}

/// One `--record --format jsonl` line: the keys of `locate --format jsonl`, with the values of
/// [`csv_row`] (`power_db` null: not transmitted). `None` if the frame's sample rate is 0.
#[must_use]
pub fn jsonl_row(f: &Frame) -> Option<String> {
    let t = f.time_s()?;
    let names: Vec<String> = flag_names(f.flags())
        .iter()
        .map(|n| format!("\"{n}\""))
        .collect();
    Some(format!(
        "{{\"frame\":{},\"t_s\":{:.6},\"azimuth_deg\":{:.2},\"azimuth_raw_deg\":{:.2},\
         \"confidence\":{:.4},\"power_db\":null,\"flags\":{},\"flag_names\":[{}]}}",
        f.seq,
        t,
        f64::from(f.azimuth_tenths) / 10.0,
        f64::from(f.raw_tenths) / 10.0,
        f64::from(f.confidence_permille) / 1000.0,
        f.flags,
        names.join(",")
    ))
}

/// Writes `--record` rows incrementally, flushed after each row. The file is written in place as
/// the frames come (a FIFO or a symbolic link works like a regular file).
#[derive(Debug)]
pub struct Recorder {
    path: PathBuf,
    out: std::io::BufWriter<std::fs::File>,
    format: Format,
    skipped_no_rate: u64,
}

impl Recorder {
    /// Creates (truncates) `path` and writes the CSV header if `format` is CSV.
    pub fn create(path: &Path, format: Format) -> Result<Recorder> {
        let f = std::fs::File::create(path).map_err(|e| SimError::io(path, e))?;
        let mut r = Recorder {
            path: path.to_path_buf(),
            out: std::io::BufWriter::new(f),
            format,
            skipped_no_rate: 0,
        };
        if format == Format::Csv {
            writeln!(r.out, "{CSV_HEADER}")
                .and_then(|()| r.out.flush())
                .map_err(|e| SimError::io(path, e))?;
        }
        Ok(r)
    }

    /// Writes the row of `f` and flushes it; a frame without a rate (no time) is skipped and
    /// counted ([`Recorder::skipped_no_rate`]).
    pub fn write(&mut self, f: &Frame) -> Result<()> {
        let row = match self.format {
            Format::Csv => csv_row(f),
            Format::Jsonl => jsonl_row(f),
        };
        let Some(row) = row else {
            self.skipped_no_rate += 1;
            return Ok(());
        };
        writeln!(self.out, "{row}")
            .and_then(|()| self.out.flush())
            .map_err(|e| SimError::io(&self.path, e))
    }

    /// Frames not recorded because their rate was 0 (no time).
    #[must_use]
    pub fn skipped_no_rate(&self) -> u64 {
        self.skipped_no_rate
    }
}

/// Arrival rate of frames over the last few seconds.
#[derive(Debug, Default)]
pub struct RateMeter {
    arrivals: VecDeque<Instant>,
}

impl RateMeter {
    const WINDOW: Duration = Duration::from_secs(3);

    /// Counts a frame that arrived at `now`.
    pub fn tick(&mut self, now: Instant) {
        self.arrivals.push_back(now);
        while self
            .arrivals
            .front()
            .is_some_and(|t| now.duration_since(*t) > Self::WINDOW)
        {
            self.arrivals.pop_front();
        }
    }

    /// Frames per second over the last few seconds, as of `now` (0 when frames stopped).
    #[must_use]
    pub fn per_second(&self, now: Instant) -> f64 {
        match (self.arrivals.front(), self.arrivals.back()) {
            (Some(first), Some(_)) if self.arrivals.len() >= 2 => {
                if now.duration_since(*first) > Self::WINDOW * 2 {
                    return 0.0;
                }
                let span = now.duration_since(*first).as_secs_f64();
                if span > 0.0 {
                    (self.arrivals.len() - 1) as f64 / span
                } else {
                    0.0
                }
            }
            _ => 0.0,
        }
    }
}

/// Half-height of the compass rose in rows (its width is twice as many columns each side, since
/// terminal cells are about twice as tall as wide).
const ROSE_R: i32 = 8;

/// Draws the compass rose: 0° up, counter-clockwise positive (90° to the left, as seen from above),
/// the weighted azimuth as a needle of `*` ending in `@`, the single-frame azimuth as `x` on the
/// ring. Returns `2 R + 1` rows of `4 R + 1 + 8` characters (labels included).
#[must_use]
pub fn draw_rose(azimuth_deg: Option<f64>, raw_deg: Option<f64>, confidence: f64) -> Vec<String> {
    draw_rose_with_talkers(azimuth_deg, raw_deg, confidence, &[])
}

/// Radius (share of the ring's) of the lowest band's background mark; each higher band's is
/// [`BACKGROUND_RADIUS_STEP`] further out, so that the bands' marks of one source do not cover each
/// other. Inside the talkers' (0.7), under the needle, which is drawn over them.
const BACKGROUND_RADIUS: f64 = 0.4;
/// Radius step between the bands' background marks.
const BACKGROUND_RADIUS_STEP: f64 = 0.15;

/// [`draw_rose`] with one mark per active talker of a track line: the last digit of its ID at
/// 0.7 of the radius in its direction.
#[must_use]
pub fn draw_rose_with_talkers(
    azimuth_deg: Option<f64>,
    raw_deg: Option<f64>,
    confidence: f64,
    talkers: &[(u16, f64)],
) -> Vec<String> {
    draw_rose_with_marks(azimuth_deg, raw_deg, confidence, talkers, &[])
}

/// [`draw_rose_with_talkers`] with the background sources' marks ([`background_marks`]) in their
/// directions, `L` at 0.4 of the radius and `H` at 0.55, drawn first (the needle and the talkers
/// cover them).
#[must_use]
pub fn draw_rose_with_marks(
    azimuth_deg: Option<f64>,
    raw_deg: Option<f64>,
    confidence: f64,
    talkers: &[(u16, f64)],
    background: &[(char, f64)],
) -> Vec<String> {
    let r = ROSE_R;
    let (w, h) = ((4 * r + 1 + 8) as usize, (2 * r + 1) as usize);
    let (cx, cy) = (2 * r + 4, r);
    let mut grid = vec![vec![' '; w]; h];
    let put = |grid: &mut Vec<Vec<char>>, a_deg: f64, radius: f64, ch: char| {
        let a = a_deg.to_radians();
        let col = cx + (-a.sin() * radius * 2.0 * f64::from(r)).round() as i32;
        let row = cy + (-a.cos() * radius * f64::from(r)).round() as i32;
        if let Some(cell) = grid
            .get_mut(row as usize)
            .and_then(|line| line.get_mut(col as usize))
        {
            *cell = ch;
        }
    };
    for step in 0..120 {
        let a = f64::from(step) * 3.0;
        put(&mut grid, a, 1.0, if step % 10 == 0 { '+' } else { '.' });
    }
    let label = |grid: &mut Vec<Vec<char>>, row: i32, col: i32, text: &str| {
        for (i, ch) in text.chars().enumerate() {
            if let Some(cell) = grid
                .get_mut(row as usize)
                .and_then(|l| l.get_mut(col as usize + i))
            {
                *cell = ch;
            }
        }
    };
    label(&mut grid, 0, cx - 1, " 0 ");
    label(&mut grid, cy, 0, "90");
    label(&mut grid, cy, cx + 2 * r + 2, "-90");
    label(&mut grid, 2 * r, cx - 1, "180");
    grid[cy as usize][cx as usize] = 'o';
    for &(mark, az) in background {
        let step = match mark {
            'L' => 0.0,
            'M' => 0.5,
            _ => 1.0,
        };
        put(
            &mut grid,
            az,
            BACKGROUND_RADIUS + step * BACKGROUND_RADIUS_STEP,
            mark,
        );
    }
    if let Some(az) = azimuth_deg {
        // A confident needle is drawn solid, a doubtful one dotted.
        let ch = if confidence >= 0.5 { '*' } else { ':' };
        for i in 2..=8 {
            put(&mut grid, az, f64::from(i) / 10.0, ch);
        }
        put(&mut grid, az, 0.9, '@');
    }
    if let Some(raw) = raw_deg {
        put(&mut grid, raw, 1.0, 'x');
    }
    for &(id, az) in talkers {
        let digit = char::from_digit(u32::from(id % 10), 10).unwrap_or('#');
        put(&mut grid, az, 0.7, digit);
    }
    grid.into_iter().map(|l| l.into_iter().collect()).collect()
}

/// What the live view shows.
#[derive(Debug, Clone)]
pub struct View<'a> {
    /// The serial port.
    pub port: &'a Path,
    /// Its baud rate.
    pub baud: u32,
    /// Whether the port is open.
    pub connected: bool,
    /// The last frame decoded.
    pub last: Option<&'a Frame>,
    /// The last calibration line decoded.
    pub calibration: Option<&'a CalibrationLine>,
    /// The last track line decoded.
    pub tracks: Option<&'a TracksLine>,
    /// The last background line decoded.
    pub background: Option<&'a BackgroundLine>,
    /// The decoder's counters.
    pub counters: Counters,
    /// Times the port was reopened.
    pub reopens: u64,
    /// Frames per second ([`RateMeter::per_second`]).
    pub fps: f64,
    /// A status message (port lost, a wrong-baud hint).
    pub status: Option<String>,
    /// The `--record` file, if recording.
    pub recording: Option<&'a Path>,
}

/// Terminal size (columns, rows) the full live view needs: the rose beside the numbers.
pub const FULL_VIEW: (usize, usize) = (80, 24);

/// Legend of the rose's symbols (fits [`FULL_VIEW`]'s width).
pub const LEGEND: &str =
    "@ azimuth (needle * confident, : not)  x last frame alone  + every 30°  o array";

/// Width of the rose column of the full view (the rose and two spaces).
const ROSE_COLUMN: usize = (4 * ROSE_R + 1 + 8 + 2) as usize;

/// The live view of `v` for a terminal of `cols`×`rows`: the whole screen, from the cursor's home
/// position; the rose beside the numbers from [`FULL_VIEW`] on, the numbers alone below it.
#[must_use]
pub fn render(v: &View<'_>, cols: usize, rows: usize) -> String {
    let (az, raw, conf) = match v.last {
        Some(f) => (
            Some(f64::from(f.azimuth_tenths) / 10.0),
            Some(f64::from(f.raw_tenths) / 10.0),
            f64::from(f.confidence_permille) / 1000.0,
        ),
        None => (None, None, 0.0),
    };
    let c = &v.counters;
    let mut info: Vec<String> = Vec::new();
    let deg = |x: Option<f64>| x.map_or_else(|| "   --".to_string(), |a| format!("{a:7.1}°"));
    info.push(format!("azimuth     {}", deg(az)));
    info.push(format!("raw (x)     {}", deg(raw)));
    let bar = ((conf * 10.0).round() as usize).min(10);
    info.push(format!(
        "confidence  {conf:7.3}  [{}{}]",
        "#".repeat(bar),
        " ".repeat(10 - bar)
    ));
    if let Some(f) = v.last {
        info.push(format!(
            "flags       {}{}",
            f.flags,
            bracketed_names(f.flags())
        ));
        info.push(format!(
            "board time  {} (seq {})",
            f.time_s()
                .map_or_else(|| "?".to_string(), |t| format!("{t:.3} s")),
            f.seq
        ));
        info.push(format!("sample rate {} Hz", f.rate_hz));
    } else {
        info.push("waiting for frames…".into());
    }
    info.push(String::new());
    info.push(format!("frame rate  {:7.1} /s", v.fps));
    info.push(format!("frames      {:7}", c.frames));
    info.push(format!("corrupt     {:7} lines", c.corrupt_lines));
    info.push(format!(
        "lost        {:7} in {} gaps",
        c.lost_frames, c.gap_events
    ));
    info.push(format!(
        "board       overruns {} dropped {}",
        c.board_overruns, c.board_dropped
    ));
    info.push(format!("port        {}", v.port.display()));
    info.push(format!(
        "            {} baud, {}{}",
        v.baud,
        if v.connected {
            "connected"
        } else {
            "DISCONNECTED"
        },
        if v.reopens > 0 {
            format!(", reopened {}×", v.reopens)
        } else {
            String::new()
        }
    ));
    if let Some(p) = v.recording {
        info.push(format!("recording   {}", p.display()));
    }
    if let Some(t) = v.tracks {
        let mut s = String::from("talkers    ");
        // A board decides a frame's tracks some frames after its frame line: say how long before
        // the last frame the talkers line holds.
        if let Some(f) = v
            .last
            .filter(|f| f.rate_hz > 0 && f.centre_sample >= t.centre_sample)
        {
            let lag = (f.centre_sample - t.centre_sample) as f64 / f64::from(f.rate_hz);
            if lag > 0.0 {
                s = format!("talkers {lag:.2} s before:");
            }
        }
        if t.tracks.is_empty() {
            s.push_str(" none speaking");
        }
        for k in t.active() {
            s.push_str(&format!(" {}:{:.0}°", k.id, k.azimuth_deg()));
        }
        info.push(s);
    }
    let selfcal = v.calibration.map_or_else(
        || "selfcal --  (no calibration line yet)".to_string(),
        calibration_summary,
    );
    let background = v.background.map_or_else(
        || "background --  (no background line yet)".to_string(),
        background_summary,
    );
    let mut lines =
        vec!["host-sim monitor — talker azimuth (0° = cardioid 1, counter-clockwise)".to_string()];
    if cols >= FULL_VIEW.0 && rows >= FULL_VIEW.1 {
        let talkers: Vec<(u16, f64)> = v
            .tracks
            .map(|t| {
                t.active()
                    .iter()
                    .map(|k| (k.id, f64::from(k.azimuth_deg())))
                    .collect()
            })
            .unwrap_or_default();
        let marks = v.background.map(background_marks).unwrap_or_default();
        let rose = draw_rose_with_marks(az, raw, conf, &talkers, &marks);
        lines.push(String::new());
        for i in 0..rose.len().max(info.len()) {
            let left = rose.get(i).map_or("", String::as_str);
            let right = info.get(i).map_or("", String::as_str);
            lines.push(format!("{left:<w$}{right}", w = ROSE_COLUMN));
        }
        lines.push(selfcal);
        lines.push(background);
        lines.push(LEGEND.to_string());
    } else {
        lines.extend(info);
        lines.push(selfcal);
        lines.push(background);
    }
    lines.push(v.status.clone().unwrap_or_default());
    // Never wrap (a wrapped line scrolls the view), never scroll: cut to the terminal.
    let keep = rows.saturating_sub(1).max(1);
    if lines.len() > keep {
        let status = lines.pop().unwrap_or_default();
        lines.truncate(keep - 1);
        lines.push(status);
    }
    let mut out = String::from("\x1b[H");
    for l in &lines {
        let cut: String = l.chars().take(cols).collect();
        let _ = writeln!(out, "{cut}\x1b[K");
    }
    out.push_str("\x1b[J");
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(seq: u32) -> Vec<u8> {
        let f = Frame {
            seq,
            rate_hz: 48000,
            centre_sample: 1024 * u64::from(seq),
            azimuth_tenths: 300,
            confidence_permille: 900,
            ..Frame::default()
        };
        let mut buf = heapless::Vec::<u8, MAX_LINE>::new();
        wire::encode(&f, &mut buf);
        buf[..].to_vec()
    }

    /// A calibration line: band 1 of cardioid 0 is 1 dB hot with β 0.45, the rest ideal; a held
    /// one also carries a talker's shift.
    fn calibration(held: bool) -> CalibrationLine {
        use cma_core::capsule_calibration::CapsuleEstimate;
        let mut est = CapsuleEstimate::IDEAL;
        let g = 10f32.powf(1.0 / 20.0);
        est.bands[1].omni_part[0] = 0.55 * g;
        est.bands[1].dipole_part[0] = 0.45 * g;
        for b in &mut est.bands {
            b.peaks = 1234.0;
        }
        est.held = held;
        if held {
            est.talker_shift = [0.084_1, -0.031];
        }
        CalibrationLine::from_capsules(&est, 0.834, 2, 960_000, 0)
    }

    fn calibration_bytes(c: &CalibrationLine) -> Vec<u8> {
        let mut buf = heapless::Vec::<u8, { wire::MAX_CAL_LINE }>::new();
        wire::encode_calibration(c, &mut buf);
        buf[..].to_vec()
    }

    #[test]
    fn calibration_lines_are_decoded_shown_and_not_counted_as_frames() {
        let mut d = Decoder::new();
        let mut stream = calibration_bytes(&calibration(false));
        stream.extend_from_slice(&line(1));
        stream.extend_from_slice(&calibration_bytes(&calibration(true)));
        stream.extend_from_slice(&line(2));
        let mut got = Vec::new();
        d.feed_lines(&stream, |l| got.push(l.clone()));
        assert_eq!(got.len(), 4);
        assert_eq!(got[0], Line::Calibration(calibration(false)));
        assert!(matches!(got[1], Line::Frame(Frame { seq: 1, .. })));
        let c = d.counters();
        assert_eq!((c.frames, c.calibration_lines), (2, 2));
        assert_eq!((c.corrupt_lines, c.lost_frames, c.garbage_bytes), (0, 0, 0));
        assert!(c.summary(0).ends_with(" reopens=0 calibration_lines=2"));
        // `feed` passes frames only.
        let mut frames = Vec::new();
        Decoder::new().feed(&stream, |f| frames.push(f.seq));
        assert_eq!(frames, [1, 2]);

        let summary = calibration_summary(&calibration(false));
        assert_eq!(
            summary,
            "selfcal 0.83  gain +0.25 +0.00 +0.00 dB  β .487 .500 .500"
        );
        let held = calibration_summary(&calibration(true));
        assert!(held.ends_with(".500  held  shift .09"), "{held}");
        assert!(held.chars().count() <= 74);
        let plain = calibration_plain_line(&calibration(true));
        assert!(
            plain.starts_with(
                "selfcal seq=2 t=960000 conf=0.834 held=1 drop=0 gain_db=+0.25,+0.00,+0.00 \
                 beta=0.487,0.500,0.500 shift=+0.0841,-0.0310 band0=n:1234,a:0.5000/0.5000/0.5000,b:0.5000/0.5000/0.5000 \
                 band1=n:1234,a:0.6171/0.5000/0.5000,b:0.5049/0.5000/0.5000 band2="
            ),
            "{plain}"
        );
    }

    #[test]
    fn counts_gaps_duplicates_restarts_and_corruption() {
        let mut d = Decoder::new();
        let mut stream = b"junk".to_vec();
        for seq in [5, 6, 9, 9, 10, 14, 2] {
            stream.extend_from_slice(&line(seq));
        }
        let mut bad = line(15);
        bad[10] ^= 1;
        stream.extend_from_slice(&bad);
        stream.extend_from_slice(&line(16)[..20]);
        stream.extend_from_slice(&line(3));
        let mut seqs = Vec::new();
        d.feed(&stream, |f| seqs.push(f.seq));
        assert_eq!(seqs, [5, 6, 9, 9, 10, 14, 2, 3]);
        let c = d.counters();
        assert_eq!(c.frames, 8);
        assert_eq!(c.lost_frames, 2 + 3);
        assert_eq!(c.gap_events, 2);
        assert_eq!(c.duplicates, 1);
        assert_eq!(c.restarts, 1);
        assert_eq!(c.corrupt_lines, 2);
        assert_eq!(c.garbage_bytes, 4);
        assert_eq!(c.bytes, stream.len() as u64);
        assert!(matches!(d.last_error(), Some(DecodeError::Checksum { .. })));
    }

    #[test]
    fn seq_wraps_without_a_gap() {
        let mut d = Decoder::new();
        let mut s = line(u32::MAX);
        s.extend_from_slice(&line(0));
        d.feed(&s, |_| {});
        assert_eq!(d.counters().lost_frames, 0);
        assert_eq!(d.counters().restarts, 0);
    }

    #[test]
    fn wrong_baud_hint_after_many_bytes_without_a_frame() {
        let mut d = Decoder::new();
        // What 115200-baud text looks like when read at 9600: bytes, but no lines.
        let noise: Vec<u8> = (0..WRONG_BAUD_BYTES)
            .map(|i| (i * 37 % 251) as u8)
            .collect();
        d.feed(&noise[..100], |_| {});
        assert!(d.baud_hint(9600).is_none());
        d.feed(&noise[100..], |_| {});
        assert!(d.noise_hint().is_none());
        let hint = d.baud_hint(9600).unwrap();
        assert!(
            hint.contains("wrong baud rate? (try --baud 115200)"),
            "{hint}"
        );
        assert!(hint.starts_with(&format!("no valid frames in {WRONG_BAUD_BYTES} bytes")));
        d.feed(&line(1), |_| {});
        assert!(d.baud_hint(9600).is_none());
    }

    #[test]
    fn csv_row_matches_locate_formatting() {
        let f = Frame {
            seq: 7,
            rate_hz: 48000,
            centre_sample: 7 * 1024 + 256,
            azimuth_tenths: -1234,
            raw_tenths: 1800,
            confidence_permille: 5,
            flags: 0x12,
            ..Frame::default()
        };
        assert_eq!(
            csv_row(&f).unwrap(),
            format!(
                "7,{:.6},-123.40,180.00,0.0050,,18",
                (7.0 * 1024.0 + 256.0) / 48000.0
            )
        );
        assert_eq!(csv_row(&Frame::default()), None);
        assert_eq!(
            plain_line(&f),
            "seq=7 t_s=0.154667 az=-123.4 raw=180.0 conf=0.005 flags=18(CLIPPED|NO_HISTORY) ovr=0 drop=0"
        );
        let json: serde_json::Value = serde_json::from_str(&jsonl_row(&f).unwrap()).unwrap();
        assert_eq!(json["flags"], 18);
        assert_eq!(json["azimuth_deg"], -123.4);
        assert_eq!(json["flag_names"][1], "NO_HISTORY");
        assert!(json["power_db"].is_null());
    }

    #[test]
    fn rose_puts_the_needle_where_the_azimuth_points() {
        let up = draw_rose(Some(0.0), None, 1.0);
        let cx = (2 * ROSE_R + 4) as usize;
        assert_eq!(up[1].chars().nth(cx), Some('@'));
        let left = draw_rose(Some(90.0), Some(-90.0), 0.2);
        let row: Vec<char> = left[ROSE_R as usize].chars().collect();
        assert_eq!(row[cx - (2.0 * 0.9 * ROSE_R as f64).round() as usize], '@');
        assert_eq!(row[cx + 2 * ROSE_R as usize], 'x');
        assert!(row.contains(&':'));
        let v = View {
            port: Path::new("/dev/null"),
            baud: 115200,
            connected: true,
            last: None,
            calibration: None,
            tracks: None,
            background: None,
            counters: Counters::default(),
            reopens: 0,
            fps: 0.0,
            status: None,
            recording: None,
        };
        assert!(render(&v, 80, 24).contains("waiting for frames"));
        assert!(render(&v, 80, 24).contains("selfcal --  (no calibration line yet)"));
    }

    #[test]
    fn talkers_are_marked_on_the_rose_with_their_ids() {
        let plain = draw_rose(None, None, 0.0);
        let marked = draw_rose_with_talkers(None, None, 0.0, &[(1, 0.0), (12, 90.0)]);
        // ID 1 straight up (0°), ID 12 as its last digit to the left (90°).
        let up = &marked[(ROSE_R - (0.7 * f64::from(ROSE_R)).round() as i32) as usize];
        assert!(up.contains('1'), "{up}");
        let left = &marked[ROSE_R as usize];
        let col = left.find('2').expect("a 2 on the middle row");
        assert!(col < left.find('o').unwrap(), "{left}");
        let changed = plain.iter().zip(&marked).filter(|(a, b)| a != b).count();
        assert_eq!(changed, 2);
        let line = TracksLine::from_tracks(
            [cma_core::multi_track::TalkerTrack {
                id: 3,
                azimuth_deg: -45.0,
                confidence: 0.25,
                active: true,
            }],
            9,
            1024,
        );
        assert_eq!(
            tracks_plain_line(&line),
            "tracks seq=9 t=1024 n=1 id3=-45.0@0.250"
        );
    }

    #[test]
    fn live_view_fits_80_by_24_and_degrades_below() {
        let f = Frame {
            seq: 123_456,
            rate_hz: 48000,
            centre_sample: 48000 * 1000,
            azimuth_tenths: -1234,
            raw_tenths: 455,
            confidence_permille: 870,
            flags: 0x1F,
            overruns: 12,
            dropped: 3456,
        };
        let counters = Counters {
            frames: 9_999_999,
            corrupt_lines: 1234,
            lost_frames: 99_999,
            gap_events: 4321,
            ..Counters::default()
        };
        // The widest summary: every gain at its clamp, held.
        let mut cal = calibration(true);
        for b in &mut cal.bands {
            b.omni_part = [wire::PART_MAX, 1, 3000];
            b.dipole_part = [wire::PART_MAX, 1, 7000];
        }
        let bg = widest_background();
        // Three talkers with the widest numbers, decided 0.26 s before the last frame.
        let widest = cma_core::multi_track::TalkerTrack {
            id: u16::MAX,
            azimuth_deg: -179.9,
            confidence: 1.0,
            active: true,
        };
        let talkers = TracksLine::from_tracks(
            [widest; cma_core::multi_track::MAX_TRACKS],
            u32::MAX,
            f.centre_sample - 3 * 16 * 256,
        );
        let v = View {
            port: Path::new("/dev/serial/by-id/usb-FTDI_FT232R_USB_UART_A50285BI-if00-port0"),
            baud: 921_600,
            connected: false,
            last: Some(&f),
            calibration: Some(&cal),
            tracks: Some(&talkers),
            background: Some(&bg),
            counters,
            reopens: 17,
            fps: 62.5,
            status: Some(
                "no valid frames in 100000 bytes — wrong baud rate? (try --baud 115200)".repeat(2),
            ),
            recording: Some(Path::new(
                "/a/very/long/path/to/the/recording/of/this/session.csv",
            )),
        };
        for (cols, rows) in [(80, 24), (60, 20), (40, 12), (20, 5)] {
            let text = render(&v, cols, rows);
            let lines: Vec<&str> = text
                .trim_start_matches("\x1b[H")
                .trim_end_matches("\x1b[J")
                .split_terminator('\n')
                .map(|l| l.trim_end_matches("\x1b[K"))
                .collect();
            assert!(lines.len() < rows, "{cols}×{rows}: {} lines", lines.len());
            for l in &lines {
                assert!(l.chars().count() <= cols, "{cols}×{rows}: `{l}`");
            }
            let has_rose = lines.iter().any(|l| l.contains('@'));
            assert_eq!(has_rose, cols >= 80 && rows >= 24, "{cols}×{rows}");
            if cols >= 80 {
                assert!(
                    lines
                        .iter()
                        .any(|l| l.contains("talkers 0.26 s before: 65535:-180°")),
                    "{text}"
                );
            }
            assert_eq!(lines.contains(&LEGEND), has_rose);
            assert!(lines.last().unwrap().starts_with("no valid frames"));
            if has_rose {
                // Title, blank, 17 rows of rose, self-calibration, background, legend, status.
                assert_eq!(lines.len(), 23);
                assert!(
                    lines[20].starts_with("background: L <1 kHz "),
                    "{}",
                    lines[20]
                );
                assert!(
                    lines[19].starts_with("selfcal 0.83  gain "),
                    "{}",
                    lines[19]
                );
                assert!(lines[19].ends_with("held  shift .09"), "{}", lines[19]);
            }
        }
    }

    /// A background line with both bands at their widest text.
    fn widest_background() -> BackgroundLine {
        BackgroundLine {
            seq: 0,
            centre_sample: 0,
            bands: [WireBackgroundBand {
                frames: 100,
                direction_tenths: -1234,
                directivity_permille: 450,
                level_tenths_db: -1519,
            }; BG_BANDS],
        }
    }

    #[test]
    fn background_lines_are_decoded_shown_and_marked_on_the_rose() {
        let mut l = widest_background();
        l.bands[0] = WireBackgroundBand {
            frames: 100,
            direction_tenths: 312,
            directivity_permille: 450,
            level_tenths_db: -523,
        };
        l.bands[1].directivity_permille = 120;
        l.bands[1].level_tenths_db = -601;
        assert_eq!(
            background_summary(&l),
            "background: L <1 kHz 31° dir 0.45 -52 dBFS; H ≥1 kHz diffuse (0.12) -60 dBFS"
        );
        assert_eq!(
            background_plain_line(&l),
            "background seq=0 t=0 band0=n:100,az:31.2,dir:0.450,db:-52.3 \
             band1=n:100,az:-123.4,dir:0.120,db:-60.1"
        );
        assert_eq!(
            background_summary(&BackgroundLine::default()),
            "background: L <1 kHz --; H ≥1 kHz --"
        );
        assert!(background_summary(&widest_background()).chars().count() <= 80);
        // Only the directional band is marked: `L` at half the radius toward 31°.
        assert_eq!(background_marks(&l), [('L', 31.2)]);
        let rose = draw_rose_with_marks(None, None, 0.0, &[], &background_marks(&l));
        let plain = draw_rose(None, None, 0.0);
        let changed: Vec<usize> = (0..rose.len()).filter(|&i| rose[i] != plain[i]).collect();
        assert_eq!(changed.len(), 1);
        let row = &rose[changed[0]];
        assert!(changed[0] < ROSE_R as usize && row.contains('L'), "{row}");
        assert!(row.find('L').unwrap() < (2 * ROSE_R + 4) as usize, "{row}");
        // Both bands' marks of one source stay visible.
        let both = draw_rose_with_marks(None, None, 0.0, &[], &[('L', 90.0), ('H', 90.0)]);
        let middle = &both[ROSE_R as usize];
        assert!(middle.contains('L') && middle.contains('H'), "{middle}");
        // Decoded and counted, not as frames.
        let mut buf = heapless::Vec::<u8, { wire::MAX_BGF_LINE }>::new();
        wire::encode_background(&l, &mut buf);
        let mut stream = buf[..].to_vec();
        stream.extend_from_slice(&line(1));
        let mut d = Decoder::new();
        let mut got = Vec::new();
        d.feed_lines(&stream, |x| got.push(x.clone()));
        assert_eq!(got[0], Line::Background(l));
        let c = d.counters();
        assert_eq!((c.frames, c.background_lines, c.corrupt_lines), (1, 1, 0));
        assert!(c.summary(0).ends_with(" background_lines=1"));
    }

    #[test]
    fn noise_at_the_right_baud_rate_is_not_called_a_wrong_baud_rate() {
        // Frame lines with bit errors: text, but nothing decodes.
        let mut d = Decoder::new();
        let mut stream = Vec::new();
        let mut seq = 0;
        while (stream.len() as u64) < WRONG_BAUD_BYTES {
            let mut l = line(seq);
            l[12] ^= 0x04;
            stream.extend_from_slice(&l);
            seq += 1;
        }
        d.feed(&stream, |_| panic!("a corrupted line decoded"));
        assert!(d.text_share_since_frame() > 0.99);
        assert!(d.baud_hint(115_200).is_none());
        let hint = d.noise_hint().unwrap();
        assert!(hint.contains("line noise"), "{hint}");
    }
}
