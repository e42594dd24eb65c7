//! WAV reading (one pass, any conforming RIFF layout) and writing (hound): 4-channel CMA1 or AmbiX
//! input, mono sources, outputs through [`crate::io::output_file`].

use crate::error::{Result, SimError};
use cma_core::CARDIOID_LOOK_DEG;
use std::path::{Path, PathBuf};

/// Channel layout of a 4-channel input file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum InputLayout {
    /// omni, cardioid 0°, cardioid 120°, cardioid 240°.
    Cma1,
    /// First-order ambisonics, ACN order (W, Y, Z, X), SN3D normalisation unless the file's first
    /// seconds say N3D: their first-order power is 1 × the omni's for SN3D and 3 × for N3D in any
    /// sound field, and read as N3D from √3 × (the choice is in `locate`'s summary).
    Ambix,
    /// First-order ambisonics, ACN order, SN3D normalisation whatever the file's powers.
    AmbixSn3d,
    /// First-order ambisonics, ACN order, N3D normalisation (first-order gains × √3).
    AmbixN3d,
}

/// Seconds at the start of an AmbiX file whose powers tell its normalisation.
pub const NORMALISATION_PROBE_S: f64 = 2.0;

/// First-order power over the omni's from which an AmbiX file reads as N3D: the geometric mean of
/// SN3D's 1 and N3D's 3. A plane wave from any direction and a diffuse field give those ratios
/// exactly; a recording's own noise moves them (the TAU-2019 clip's N3D background alone: 2.0).
pub const N3D_POWER_RATIO: f64 = 1.732;

/// A cardioid this many dB below what the other three capsules say it should hear is not connected
/// (or its gain is far off): three cardioids 120° apart add up to 1.5 × the omni in any sound field,
/// so C_m = 1.5·W − (the other two) predicts it, even for a cardioid facing away from the only
/// source (both then nearly silent).
pub const DEAD_CARDIOID_DB: f64 = -15.0;

/// A cardioid this many dB above the omni is not a cardioid beside an omni (an ideal one never
/// exceeds it, a capsule 1.5 dB hot by about that): the omni is not on the first channel.
pub const LOUD_CARDIOID_DB: f64 = 3.0;

/// Largest power of C₁ + C₂ + C₃ − 1.5·W relative to that of 1.5·W for a wired array: only the
/// capsules' errors and own noise leave one, at most 0.11 on the validation suite's arrays (gains
/// ±1.5 dB, patterns β 0.38–0.62, capsule noise); a cardioid of reversed polarity leaves about 0.8,
/// the omni on a cardioid's channel more than 1.
pub const WIRING_RESIDUAL: f64 = 0.3;

/// Sums over a CMA1 recording that check its wiring: does it hold an omni and three cardioids
/// looking 0°, 120°, 240° from one point?
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct WiringSums {
    /// Σ x_i·x_j of the four channels (omni, cardioid 0°, 120°, 240°), i ≤ j, row by row.
    products: [f64; 10],
}

impl WiringSums {
    /// Index of Σ x_i·x_j (i ≤ j) in `products`.
    const fn at(i: usize, j: usize) -> usize {
        let (i, j) = if i <= j { (i, j) } else { (j, i) };
        i * 4 - i * (i + 1) / 2 + j
    }

    /// Σ x_i·x_j.
    fn sum(&self, i: usize, j: usize) -> f64 {
        self.products[Self::at(i, j)]
    }

    /// Adds sample frames (omni, cardioid 0°, 120°, 240°); frames with a non-finite sample are
    /// left out.
    pub fn add(&mut self, frames: &[[f32; 4]]) {
        for f in frames {
            let x = f.map(f64::from);
            if x.iter().all(|v| v.is_finite()) {
                for i in 0..4 {
                    for j in i..4 {
                        self.products[Self::at(i, j)] += x[i] * x[j];
                    }
                }
            }
        }
    }

    /// Σ (Σ_k c_k·x_k)² for the channel weights `c`.
    fn power(&self, c: [f64; 4]) -> f64 {
        let mut p = 0.0;
        for i in 0..4 {
            for j in 0..4 {
                p += c[i] * c[j] * self.sum(i, j);
            }
        }
        p
    }

    /// A warning line when the sums do not fit an omni and three cardioids at one point (a dead
    /// or quiet cardioid, the omni on another channel, a reversed polarity); `None` when they fit
    /// or the omni is silent. (Cardioids in mirrored order fit: their azimuths come out mirrored.)
    #[must_use]
    pub fn warning(&self) -> Option<String> {
        let omni = self.sum(0, 0);
        if !(omni > 0.0) {
            return None;
        }
        let db = |p: f64, re: f64| 10.0 * (p / re).log10();
        let residual = |flip: Option<usize>| {
            let mut c = [-1.5, 1.0, 1.0, 1.0];
            if let Some(m) = flip {
                c[m + 1] = -1.0;
            }
            self.power(c) / (2.25 * omni)
        };
        let wired = residual(None);
        // A cardioid whose sign flipped makes the three add up: its polarity is reversed. Checked
        // first: the sum that predicts a capsule from the other three then blames another one
        // (a reversed cardioid facing the talker makes the one beside it look dead).
        if wired > WIRING_RESIDUAL {
            let flipped = (0..3)
                .map(|m| (m, residual(Some(m))))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .filter(|(_, r)| *r <= WIRING_RESIDUAL);
            if let Some((m, _)) = flipped {
                return Some(format!(
                    "warning: input: the cardioid looking {}° (channel {}) reads with reversed \
                     polarity (the three cardioids add up to 1.5 × the omni only with its sign \
                     flipped): are its leads swapped?",
                    cma_core::CARDIOID_LOOK_DEG[m],
                    m + 2
                ));
            }
        }
        for (m, look) in cma_core::CARDIOID_LOOK_DEG.iter().enumerate() {
            let own = self.sum(m + 1, m + 1);
            // What the other three capsules say this one hears: 1.5·W less the other two.
            let mut c = [1.5, -1.0, -1.0, -1.0];
            c[m + 1] = 0.0;
            let predicted = self.power(c);
            if db(predicted, omni) > DEAD_CARDIOID_DB && db(own, predicted) < DEAD_CARDIOID_DB {
                let below = if own > 0.0 {
                    format!("{:.0} dB", -db(own, predicted))
                } else {
                    "infinitely".into()
                };
                return Some(format!(
                    "warning: input: the cardioid looking {look}° (channel {}) reads {below} below \
                     what the omni and the other two cardioids say it hears: is it connected?",
                    m + 2
                ));
            }
            if db(own, omni) > LOUD_CARDIOID_DB {
                return Some(format!(
                    "warning: input: the cardioid looking {look}° (channel {}) reads {:.1} dB above \
                     the omni: is the omni on channel 1 (omni, cardioid 0°, 120°, 240°)?",
                    m + 2,
                    db(own, omni)
                ));
            }
        }
        (wired > WIRING_RESIDUAL).then(|| {
            format!(
                "warning: input: the three cardioids do not add up to 1.5 × the omni as cardioids \
                 looking 0°, 120°, 240° beside it do ({:.0} % of its power is left over, a wired \
                 array leaves under 11 %): is a capsule's polarity reversed, or the omni on another \
                 channel?",
                100.0 * wired
            )
        })
    }
}

/// What an AmbiX file's first seconds say about its normalisation, and how it was read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Normalisation {
    /// First-order power (X² + Y² + Z²) over the omni's (W²) in the probe; `None` without omni
    /// power (silence) or without finite samples.
    pub ratio: Option<f64>,
    /// Seconds of audio the ratio was measured on (at most [`NORMALISATION_PROBE_S`]).
    pub probe_s: f64,
    /// The file is read as N3D (its first-order channels scaled by 1/√3).
    pub n3d: bool,
    /// The layout chose the normalisation from the ratio ([`InputLayout::Ambix`]).
    pub detected: bool,
}

impl Normalisation {
    /// One summary line: how the file was read and why, or a warning when its powers contradict
    /// an explicit layout.
    #[must_use]
    pub fn line(&self) -> String {
        let name = if self.n3d { "N3D" } else { "SN3D" };
        let probe = self.probe_s;
        let Some(r) = self.ratio else {
            return format!(
                "input: AmbiX read as {name} (no signal in the first {probe:.2} s to tell SN3D from N3D)"
            );
        };
        let measured =
            format!("first-order power {r:.2} × the omni's over the first {probe:.2} s; SN3D gives 1, N3D 3");
        if self.detected {
            format!("input: AmbiX read as {name} ({measured}; --input-layout ambix-sn3d or ambix-n3d sets it)")
        } else if self.n3d == (r >= N3D_POWER_RATIO) {
            format!("input: AmbiX read as {name} ({measured})")
        } else {
            let other = if self.n3d { "SN3D" } else { "N3D" };
            format!(
                "warning: input read as {name}, as --input-layout says, but it looks {other} \
                 ({measured}); --input-layout ambix reads it as its powers say"
            )
        }
    }
}

/// A decoded 4-channel recording in CMA1 order, full scale ±1.
#[derive(Debug, Clone)]
pub struct Recording {
    /// Sample rate, Hz.
    pub rate: u32,
    /// Sample frames.
    pub frames: Vec<[f32; 4]>,
    /// How an AmbiX file's normalisation was read (`None` for CMA1).
    pub normalisation: Option<Normalisation>,
}

/// Sample frames per chunk a [`WavStream`] reads and decodes at a time (a multiple of the locator's
/// 1024-frame block): memory stays O(chunk) however long the file, and the raw, decoded and converted
/// buffers of a chunk (≤ 64 + 128 + 128 KiB) stay in the L2 cache.
pub const CHUNK_FRAMES: usize = 8 * 1024;

/// An open WAV whose samples are read and decoded chunk by chunk into a reused buffer.
///
/// The file is opened once and read front to back, never seeked or reopened, so a pipe, a FIFO or
/// `/dev/stdin` works like a regular file. The RIFF header is walked chunk by chunk as the format
/// allows: unknown chunks (`LIST`, `fact`, `bext`, …) before the `data` chunk are skipped with the pad
/// byte after an odd length, the `fmt ` chunk may be PCM, IEEE float or `WAVE_FORMAT_EXTENSIBLE` of any
/// length, integer samples may sit in wider containers (24 bits in 4 bytes), and a `data` length of
/// `0xFFFFFFFF` (written by tools that stream to a pipe) means "until the end of the file".
///
/// Header problems (not a WAV, unsupported format, no samples) are reported by [`WavStream::open`];
/// truncated or corrupt sample data by [`WavStream::read_chunk`], only after every complete sample
/// frame before the damage has been delivered. No allocation is sized by the header's claim alone:
/// the size of the file (when it is a regular file) bounds it.
pub struct WavStream {
    path: PathBuf,
    spec: hound::WavSpec,
    /// Bytes per sample in the file (the container: 3 for packed 24-bit, 4 for 24 bits in 4 bytes).
    container: usize,
    inner: std::io::BufReader<std::fs::File>,
    raw: Vec<u8>,
    /// Samples the header declares (`None`: until the end of the file).
    declared: Option<usize>,
    /// Samples the file can still hold after the header (regular files), an upper bound for buffers.
    available: Option<usize>,
    /// Samples delivered so far.
    delivered: usize,
    /// Bytes of sample data read so far.
    got: usize,
    /// Decoded samples of an incomplete last frame, held back.
    carry: Vec<f32>,
    /// The error to report once the samples before it have been delivered.
    pending: Option<SimError>,
    /// Nothing more to read (end of data or error reported).
    done: bool,
}

/// What the RIFF header says about the samples.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Header {
    spec: hound::WavSpec,
    /// Bytes per sample.
    container: usize,
    /// Bytes of sample data (`None`: until the end of the file).
    data_len: Option<u64>,
    /// Bytes of header before the first sample.
    header_len: u64,
}

/// Why a header was refused.
#[derive(Debug)]
enum HeaderError {
    /// Not a (readable) WAV file.
    Bad(String),
    /// A WAV whose sample format this tool does not decode.
    Format(String),
}

/// The `SubFormat` GUID of `WAVE_FORMAT_EXTENSIBLE` after its first two bytes (the format tag):
/// `xxxx0000-0000-0010-8000-00aa00389b71`.
const KSDATAFORMAT_SUFFIX: [u8; 14] = [
    0x00, 0x00, 0x00, 0x00, 0x10, 0x00, 0x80, 0x00, 0x00, 0xAA, 0x00, 0x38, 0x9B, 0x71,
];

/// Bytes of a `fmt ` chunk that are parsed (the longest known layout, `WAVE_FORMAT_EXTENSIBLE`, is
/// 40); the rest of a longer chunk is skipped.
const FMT_PARSED: usize = 40;

/// Reads exactly `buf.len()` bytes; `Ok(false)` at a clean end of file before the first byte.
fn read_exact_or_eof(r: &mut impl std::io::Read, buf: &mut [u8]) -> std::io::Result<bool> {
    let mut n = 0;
    while n < buf.len() {
        match r.read(&mut buf[n..]) {
            Ok(0) if n == 0 => return Ok(false),
            Ok(0) => return Err(std::io::ErrorKind::UnexpectedEof.into()),
            Ok(k) => n += k,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(true)
}

/// Skips `n` bytes by reading them (works on pipes); an error if the file ends first.
fn skip(r: &mut impl std::io::Read, n: u64) -> std::io::Result<()> {
    let skipped = std::io::copy(
        &mut <&mut _ as std::io::Read>::take(r, n),
        &mut std::io::sink(),
    )?;
    if skipped < n {
        return Err(std::io::ErrorKind::UnexpectedEof.into());
    }
    Ok(())
}

/// Walks the RIFF header up to the first sample of the `data` chunk.
fn read_header(r: &mut impl std::io::Read) -> std::result::Result<Header, HeaderError> {
    let io = |what: &str, e: std::io::Error| {
        HeaderError::Bad(if e.kind() == std::io::ErrorKind::UnexpectedEof {
            format!("the file ends inside the {what}")
        } else {
            format!("header unreadable ({e})")
        })
    };
    let mut riff = [0u8; 12];
    if !read_exact_or_eof(r, &mut riff).map_err(|e| io("RIFF header", e))? {
        return Err(HeaderError::Bad("the file is empty".into()));
    }
    match &riff[..4] {
        b"RIFF" => {}
        b"RIFX" | b"RF64" => {
            return Err(HeaderError::Format(format!(
                "{} container (only little-endian RIFF is read)",
                String::from_utf8_lossy(&riff[..4])
            )))
        }
        _ => return Err(HeaderError::Bad("no RIFF tag found".into())),
    }
    if &riff[8..12] != b"WAVE" {
        return Err(HeaderError::Bad("no WAVE tag found".into()));
    }
    let mut pos = 12u64;
    let mut fmt: Option<(hound::WavSpec, usize)> = None;
    loop {
        let mut head = [0u8; 8];
        if !read_exact_or_eof(r, &mut head).map_err(|e| io("chunk list", e))? {
            return Err(HeaderError::Bad(
                if fmt.is_some() {
                    "no data chunk"
                } else {
                    "no fmt chunk"
                }
                .into(),
            ));
        }
        pos += 8;
        let len = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
        let padded = u64::from(len) + u64::from(len & 1);
        match &head[..4] {
            b"fmt " => {
                let mut b = [0u8; FMT_PARSED];
                let n = (len as usize).min(FMT_PARSED);
                if n < 16 {
                    return Err(HeaderError::Bad(format!(
                        "fmt chunk of {len} bytes, expected at least 16"
                    )));
                }
                read_exact_or_eof(r, &mut b[..n])
                    .and_then(|ok| {
                        ok.then_some(())
                            .ok_or_else(|| std::io::ErrorKind::UnexpectedEof.into())
                    })
                    .map_err(|e| io("fmt chunk", e))?;
                skip(r, padded - n as u64).map_err(|e| io("fmt chunk", e))?;
                fmt = Some(parse_fmt(&b[..n])?);
            }
            b"data" => {
                let Some((spec, container)) = fmt else {
                    return Err(HeaderError::Bad("data chunk before the fmt chunk".into()));
                };
                let data_len = (len != u32::MAX).then_some(u64::from(len));
                let block = container as u64 * u64::from(spec.channels);
                if let Some(l) = data_len {
                    if l % block != 0 {
                        return Err(HeaderError::Bad(format!(
                            "data chunk of {l} bytes is not a whole number of {block}-byte sample frames"
                        )));
                    }
                }
                return Ok(Header {
                    spec,
                    container,
                    data_len,
                    header_len: pos,
                });
            }
            _ => skip(r, padded).map_err(|e| io("chunk list", e))?,
        }
        pos += padded;
    }
}

/// Parses the first up to [`FMT_PARSED`] bytes of a `fmt ` chunk (at least 16).
fn parse_fmt(b: &[u8]) -> std::result::Result<(hound::WavSpec, usize), HeaderError> {
    let u16_at = |i: usize| u16::from_le_bytes([b[i], b[i + 1]]);
    let mut tag = u16_at(0);
    let channels = u16_at(2);
    let sample_rate = u32::from_le_bytes([b[4], b[5], b[6], b[7]]);
    let block_align = usize::from(u16_at(12));
    let mut bits = u16_at(14);
    if tag == 0xFFFE {
        if b.len() < FMT_PARSED || u16_at(16) < 22 {
            return Err(HeaderError::Bad(
                "WAVE_FORMAT_EXTENSIBLE fmt chunk shorter than 40 bytes".into(),
            ));
        }
        if b[26..40] != KSDATAFORMAT_SUFFIX {
            return Err(HeaderError::Format(
                "WAVE_FORMAT_EXTENSIBLE with an unknown SubFormat GUID".into(),
            ));
        }
        let valid = u16_at(18);
        if valid > 0 {
            bits = valid;
        }
        tag = u16_at(24);
    }
    let sample_format = match tag {
        1 => hound::SampleFormat::Int,
        3 => hound::SampleFormat::Float,
        other => {
            return Err(HeaderError::Format(format!(
                "format tag 0x{other:04X} (compressed or unknown)"
            )))
        }
    };
    if channels == 0 {
        return Err(HeaderError::Bad("the fmt chunk declares 0 channels".into()));
    }
    if sample_rate == 0 {
        return Err(HeaderError::Bad(
            "the fmt chunk declares a sample rate of 0 Hz".into(),
        ));
    }
    if block_align == 0 || block_align % usize::from(channels) != 0 {
        return Err(HeaderError::Bad(format!(
            "block align {block_align} is not a multiple of the {channels} channels"
        )));
    }
    let container = block_align / usize::from(channels);
    if bits == 0 || usize::from(bits) > 8 * container {
        return Err(HeaderError::Bad(format!(
            "{bits} bits per sample in {container}-byte samples"
        )));
    }
    let supported = match sample_format {
        hound::SampleFormat::Int => (1..=4).contains(&container),
        hound::SampleFormat::Float => container == 4 && bits == 32,
    };
    if !supported {
        return Err(HeaderError::Format(format!(
            "{sample_format:?} {bits}-bit in {container}-byte samples"
        )));
    }
    Ok((
        hound::WavSpec {
            channels,
            sample_rate,
            bits_per_sample: bits,
            sample_format,
        },
        container,
    ))
}

impl WavStream {
    /// Opens a WAV and parses its header; the samples are read by [`WavStream::read_chunk`].
    pub fn open(path: &Path) -> Result<Self> {
        let file = std::fs::File::open(path).map_err(|e| {
            if e.kind() == std::io::ErrorKind::NotFound {
                SimError::reading(
                    path,
                    std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
                )
            } else {
                SimError::reading(path, e)
            }
        })?;
        // Only a regular file's length says how much can follow (a pipe's or a device's does not).
        let file_len = file
            .metadata()
            .ok()
            .filter(std::fs::Metadata::is_file)
            .map(|m| m.len());
        let mut inner = std::io::BufReader::new(file);
        let header = read_header(&mut inner).map_err(|e| match e {
            HeaderError::Bad(reason) => SimError::BadWav {
                path: path.to_path_buf(),
                reason,
            },
            HeaderError::Format(format) => SimError::SampleFormat {
                path: path.to_path_buf(),
                format,
            },
        })?;
        let samples =
            |bytes: u64| usize::try_from(bytes / header.container as u64).unwrap_or(usize::MAX);
        let declared = header.data_len.map(samples);
        if declared == Some(0) {
            return Err(SimError::Empty {
                path: path.to_path_buf(),
            });
        }
        Ok(Self {
            path: path.to_path_buf(),
            spec: header.spec,
            container: header.container,
            inner,
            raw: Vec::new(),
            declared,
            available: file_len.map(|l| samples(l.saturating_sub(header.header_len))),
            delivered: 0,
            got: 0,
            carry: Vec::new(),
            pending: None,
            done: false,
        })
    }

    /// The header's format (`bits_per_sample`: the valid bits of a sample).
    #[must_use]
    pub fn spec(&self) -> hound::WavSpec {
        self.spec
    }

    /// Sample frames the header declares (for a progress bar; the file may hold fewer, and a
    /// `data` chunk of unknown length declares 0). Not a size to allocate: see
    /// [`WavStream::capacity_frames`].
    #[must_use]
    pub fn declared_frames(&self) -> usize {
        self.declared.unwrap_or(0) / usize::from(self.spec.channels)
    }

    /// Sample frames worth reserving room for: the header's claim, capped by what the file can
    /// hold (a regular file) or by one chunk (a pipe, whose length is unknown).
    #[must_use]
    pub fn capacity_frames(&self) -> usize {
        let ch = usize::from(self.spec.channels);
        let cap = self.available.unwrap_or(CHUNK_FRAMES * ch);
        self.declared.unwrap_or(cap).min(cap) / ch
    }

    /// Replaces `out` with the next up to [`CHUNK_FRAMES`] complete sample frames, interleaved, as
    /// f32 full scale ±1 (for packed samples exactly as hound's sample iterator gives them). `out`
    /// is left empty at the end of the data. Truncated or corrupt data is an error, returned after
    /// the complete frames before it.
    pub fn read_chunk(&mut self, out: &mut Vec<f32>) -> Result<()> {
        out.clear();
        if let Some(e) = self.pending.take() {
            self.done = true;
            return Err(e);
        }
        if self.done {
            return Ok(());
        }
        let ch = usize::from(self.spec.channels);
        out.append(&mut self.carry);
        let bytes = self.container;
        let want = match self.declared {
            Some(d) => (d - self.delivered).min(CHUNK_FRAMES * ch),
            None => CHUNK_FRAMES * ch,
        };
        self.raw.resize(want * bytes, 0);
        let mut n = 0;
        while n < self.raw.len() {
            use std::io::Read;
            match self.inner.read(&mut self.raw[n..]) {
                Ok(0) => break,
                Ok(k) => n += k,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    self.done = true;
                    return Err(SimError::reading(&self.path, e));
                }
            }
        }
        self.got += n;
        let whole = n - n % bytes;
        decode_samples(&self.raw[..whole], self.spec.sample_format, bytes, out);
        self.delivered += whole / bytes;
        let bad = |reason: String| SimError::BadWav {
            path: self.path.clone(),
            reason,
        };
        let at_end = match self.declared {
            Some(d) => {
                if n < self.raw.len() {
                    self.pending = Some(bad(format!(
                        "truncated or corrupt sample data (the header declares {} bytes of samples, the file holds {})",
                        d * bytes,
                        self.got
                    )));
                }
                self.delivered == d
            }
            None => n < self.raw.len(),
        };
        let whole = out.len() - out.len() % ch;
        if self.pending.is_none() && at_end && (whole != out.len() || n % bytes != 0) {
            self.pending = Some(bad("truncated: the last sample frame is incomplete".into()));
        }
        self.carry.extend_from_slice(&out[whole..]);
        out.truncate(whole);
        if out.is_empty() {
            self.done = true;
            if let Some(e) = self.pending.take() {
                return Err(e);
            }
            if self.delivered == 0 {
                return Err(SimError::Empty {
                    path: self.path.clone(),
                });
            }
        }
        Ok(())
    }
}

/// Reads all samples of a WAV as f32 (full scale ±1), interleaved, with its spec.
pub fn read_interleaved(path: &Path) -> Result<(hound::WavSpec, Vec<f32>)> {
    read_rest(WavStream::open(path)?)
}

/// Reads the rest of an open WAV (interleaved) with its spec.
fn read_rest(mut stream: WavStream) -> Result<(hound::WavSpec, Vec<f32>)> {
    let capacity = stream.capacity_frames() * usize::from(stream.spec.channels);
    let out = read_all(capacity, |chunk| stream.read_chunk(chunk))?;
    Ok((stream.spec, out))
}

/// Collects every chunk that `read_chunk` yields (an empty chunk ends the data) into one vector
/// with room for `capacity` items (an estimate; the vector grows if more come).
fn read_all<T: Copy>(
    capacity: usize,
    mut read_chunk: impl FnMut(&mut Vec<T>) -> Result<()>,
) -> Result<Vec<T>> {
    let mut out = Vec::with_capacity(capacity);
    let mut chunk = Vec::new();
    loop {
        read_chunk(&mut chunk)?;
        if chunk.is_empty() {
            return Ok(out);
        }
        out.extend_from_slice(&chunk);
    }
}

/// Appends little-endian WAV samples of `container` bytes each to `out` as f32 full scale ±1: a
/// container's integer over 2^(8·container − 1), so a sample with fewer valid bits than its container
/// (left-justified, as the format prescribes) scales right; for packed samples this is exactly
/// hound's `(v as f64 / 2^(bits-1)) as f32`. 8-bit is unsigned with offset 128.
///
/// Up to 24 bits the integer and the product with the power-of-two scale are exact in f32, so the
/// f32 product equals the rounded f64 one; 32-bit goes through f64.
fn decode_samples(raw: &[u8], format: hound::SampleFormat, container: usize, out: &mut Vec<f32>) {
    let scale = 1.0 / (1u64 << (8 * container - 1)) as f64;
    let s32 = scale as f32;
    // Exact-size iterators: `extend` writes in place, without zero-filling first.
    match (format, container) {
        (hound::SampleFormat::Float, _) => out.extend(
            raw.chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        ),
        (_, 1) => out.extend(raw.iter().map(|b| (*b as i32 - 128) as f32 * s32)),
        (_, 2) => out.extend(
            raw.chunks_exact(2)
                .map(|b| i16::from_le_bytes([b[0], b[1]]) as f32 * s32),
        ),
        (_, 3) => out.extend(
            raw.chunks_exact(3)
                .map(|b| (i32::from_le_bytes([0, b[0], b[1], b[2]]) >> 8) as f32 * s32),
        ),
        _ => out.extend(
            raw.chunks_exact(4)
                .map(|b| (i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64 * scale) as f32),
        ),
    }
}

/// Checks that a WAV has 4 channels (`layout` names them in the error message).
fn check_four(path: &Path, spec: hound::WavSpec, layout: &'static str) -> Result<()> {
    if spec.channels != 4 {
        return Err(SimError::ChannelCount {
            path: path.to_path_buf(),
            expected: 4,
            got: spec.channels,
            layout,
        });
    }
    Ok(())
}

/// Reads a WAV that must have 4 channels (`layout` names them in the error message).
pub fn read_four_channels(path: &Path, layout: &'static str) -> Result<(hound::WavSpec, Vec<f32>)> {
    let stream = WavStream::open(path)?;
    check_four(path, stream.spec, layout)?;
    read_rest(stream)
}

/// A 4-channel recording read chunk by chunk and converted to CMA1 order.
///
/// An AmbiX file's first [`NORMALISATION_PROBE_S`] seconds are read ahead and held (at most
/// 4 × 4 bytes × 2 s × the rate: 1.5 MB at 48 kHz) to measure its normalisation before any frame is
/// converted; they are then delivered chunk by chunk like the rest, so a pipe still works.
pub struct RecordingStream {
    wav: WavStream,
    layout: InputLayout,
    raw: Vec<f32>,
    /// Converted frames of an AmbiX chunk.
    frames: Vec<[f32; 4]>,
    /// Interleaved samples read ahead for the normalisation probe, delivered from `held_at`.
    held: Vec<f32>,
    held_at: usize,
    /// The error the read-ahead met, returned once the samples before it are delivered.
    pending: Option<SimError>,
    /// Gain applied to an AmbiX file's first-order channels (1 for SN3D, 1/√3 for N3D).
    first_order_gain: f32,
    normalisation: Option<Normalisation>,
    wiring: WiringSums,
}

impl RecordingStream {
    /// Opens a 4-channel recording: the header is checked (channels, sample rate supported by the
    /// core), the samples are read by [`RecordingStream::read_chunk`].
    pub fn open(path: &Path, layout: InputLayout) -> Result<Self> {
        let wav = WavStream::open(path)?;
        check_four(
            path,
            wav.spec,
            match layout {
                InputLayout::Cma1 => "omni, cardioid 0°, cardioid 120°, cardioid 240°",
                _ => "AmbiX W, Y, Z, X",
            },
        )?;
        cma_core::decimator::Decimator::for_rate(wav.spec.sample_rate).map_err(|source| {
            SimError::Core {
                context: path.display().to_string(),
                source,
            }
        })?;
        Ok(Self {
            wav,
            layout,
            raw: Vec::new(),
            frames: Vec::new(),
            held: Vec::new(),
            held_at: 0,
            pending: None,
            first_order_gain: 1.0,
            normalisation: None,
            wiring: WiringSums::default(),
        })
    }

    /// The wiring check's sums over the CMA1 frames delivered so far (empty for AmbiX input, whose
    /// conversion makes an ideal array).
    #[must_use]
    pub fn wiring(&self) -> WiringSums {
        self.wiring
    }

    /// How an AmbiX file's normalisation was read (`None` for CMA1, or before the first chunk).
    #[must_use]
    pub fn normalisation(&self) -> Option<Normalisation> {
        self.normalisation
    }

    /// Reads the first [`NORMALISATION_PROBE_S`] seconds ahead into `held`, measures the ratio of
    /// their first-order power to the omni's and sets the first-order gain the layout asks for.
    fn probe(&mut self) {
        let rate = self.wav.spec.sample_rate;
        let want = (NORMALISATION_PROBE_S * f64::from(rate)) as usize * 4;
        while self.held.len() < want {
            match self.wav.read_chunk(&mut self.raw) {
                Ok(()) if self.raw.is_empty() => break,
                Ok(()) => self.held.extend_from_slice(&self.raw),
                Err(e) => {
                    self.pending = Some(e);
                    break;
                }
            }
        }
        let probed = self.held.len().min(want);
        let (frames, _) = self.held[..probed].as_chunks::<4>();
        let (mut omni, mut first) = (0.0f64, 0.0f64);
        for c in frames {
            let [w, y, z, x] = c.map(f64::from);
            let f = x * x + y * y + z * z;
            if w.is_finite() && f.is_finite() {
                omni += w * w;
                first += f;
            }
        }
        let ratio = (omni > 0.0).then(|| first / omni).filter(|r| r.is_finite());
        let n3d = match self.layout {
            InputLayout::Ambix => ratio.is_some_and(|r| r >= N3D_POWER_RATIO),
            InputLayout::AmbixN3d => true,
            InputLayout::AmbixSn3d | InputLayout::Cma1 => false,
        };
        self.first_order_gain = if n3d { 1.0 / 3f32.sqrt() } else { 1.0 };
        self.normalisation = Some(Normalisation {
            ratio,
            probe_s: frames.len() as f64 / f64::from(rate),
            n3d,
            detected: self.layout == InputLayout::Ambix,
        });
    }

    /// Sample rate, Hz.
    #[must_use]
    pub fn rate(&self) -> u32 {
        self.wav.spec.sample_rate
    }

    /// Sample frames the header declares (see [`WavStream::declared_frames`]).
    #[must_use]
    pub fn declared_frames(&self) -> usize {
        self.wav.declared_frames()
    }

    /// Sample frames worth reserving room for (see [`WavStream::capacity_frames`]).
    #[must_use]
    pub fn capacity_frames(&self) -> usize {
        self.wav.capacity_frames()
    }

    /// Replaces `out` with the next up to [`CHUNK_FRAMES`] sample frames in CMA1 order; empty at the
    /// end. Errors as [`WavStream::read_chunk`].
    pub fn read_chunk(&mut self, out: &mut Vec<[f32; 4]>) -> Result<()> {
        let frames = self.next_chunk()?;
        out.clear();
        out.extend_from_slice(frames);
        Ok(())
    }

    /// The next up to [`CHUNK_FRAMES`] sample frames in CMA1 order, borrowed from the stream's buffer
    /// (a CMA1 file's samples are not copied again: the decoded interleaved samples are the frames);
    /// empty at the end. Errors as [`WavStream::read_chunk`].
    pub fn next_chunk(&mut self) -> Result<&[[f32; 4]]> {
        if self.layout == InputLayout::Cma1 {
            self.wav.read_chunk(&mut self.raw)?;
            // `read_chunk` returns whole sample frames of the 4 channels `open` checked.
            let frames = self.raw.as_chunks::<4>().0;
            self.wiring.add(frames);
            return Ok(frames);
        }
        if self.normalisation.is_none() {
            self.probe();
        }
        let source = if self.held_at < self.held.len() {
            let end = (self.held_at + CHUNK_FRAMES * 4).min(self.held.len());
            let range = self.held_at..end;
            self.held_at = end;
            &self.held[range]
        } else {
            if !self.held.is_empty() {
                self.held = Vec::new();
                self.held_at = 0;
            }
            if let Some(e) = self.pending.take() {
                return Err(e);
            }
            self.wav.read_chunk(&mut self.raw)?;
            &self.raw[..]
        };
        let g = self.first_order_gain;
        self.frames.clear();
        self.frames.extend(
            source
                .as_chunks::<4>()
                .0
                .iter()
                .map(|c| ambix_to_cma1(c[0], c[3] * g, c[1] * g)),
        );
        Ok(&self.frames)
    }
}

/// Reads a 4-channel recording and converts it to CMA1 order.
pub fn read_recording(path: &Path, layout: InputLayout) -> Result<Recording> {
    let mut stream = RecordingStream::open(path, layout)?;
    let frames = read_all(stream.capacity_frames(), |chunk| stream.read_chunk(chunk))?;
    Ok(Recording {
        rate: stream.rate(),
        frames,
        normalisation: stream.normalisation(),
    })
}

/// Exact first-order conversion (SN3D): omni = W, cardioid_m = ½W + ½(X cos φ_m + Y sin φ_m).
#[must_use]
pub fn ambix_to_cma1(w: f32, x: f32, y: f32) -> [f32; 4] {
    let mut out = [w, 0.0, 0.0, 0.0];
    for (o, look) in out[1..].iter_mut().zip(CARDIOID_LOOK_DEG) {
        let a = (look as f64).to_radians();
        *o = (0.5 * w as f64 + 0.5 * (x as f64 * a.cos() + y as f64 * a.sin())) as f32;
    }
    out
}

/// Checks that the WAV at `path` is mono, as a talker source (`scene --source`) must be: the error
/// names the channel count it has.
pub fn check_mono(path: &Path, flag: &str) -> Result<()> {
    let channels = WavStream::open(path)?.spec().channels;
    if channels != 1 {
        return Err(SimError::Usage(format!(
            "{flag} {}: a talker is a mono WAV (1 channel), this one has {channels} channels; mix \
             it down first (e.g. `sox IN.wav -c 1 OUT.wav`)",
            path.display()
        )));
    }
    Ok(())
}

/// Reads a mono (or the mean of a multi-channel) source signal.
pub fn read_mono(path: &Path) -> Result<(u32, Vec<f32>)> {
    let (spec, data) = read_interleaved(path)?;
    let ch = spec.channels as usize;
    let mono = data
        .chunks_exact(ch)
        .map(|c| c.iter().sum::<f32>() / ch as f32)
        .collect();
    Ok((spec.sample_rate, mono))
}

/// Sample format of written WAVs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum OutFormat {
    /// 16-bit PCM.
    Pcm16,
    /// 24-bit PCM.
    Pcm24,
    /// 32-bit float.
    Float,
}

/// Writes interleaved samples (full scale ±1, clamped for PCM) as an output file
/// ([`crate::io::output_file`]: complete or not at all).
pub fn write_wav(
    path: &Path,
    rate: u32,
    channels: u16,
    samples: &[f32],
    format: OutFormat,
) -> Result<()> {
    write_wav_with_comment(path, rate, channels, samples, format, None)
}

/// Writes four-channel sample frames (omni, cardioid 0°, 120°, 240°) with [`write_wav`].
pub fn write_frames(path: &Path, rate: u32, frames: &[[f32; 4]], format: OutFormat) -> Result<()> {
    let samples: Vec<f32> = frames.iter().flatten().copied().collect();
    write_wav(path, rate, 4, &samples, format)
}

/// [`write_wav`], with `comment` stored in a `LIST`/`INFO` chunk (`ICMT`) after the samples
/// ([`crate::calibration::sweep::append_info_comment`]).
pub fn write_wav_with_comment(
    path: &Path,
    rate: u32,
    channels: u16,
    samples: &[f32],
    format: OutFormat,
    comment: Option<&str>,
) -> Result<()> {
    let (bits, sample_format) = match format {
        OutFormat::Pcm16 => (16, hound::SampleFormat::Int),
        OutFormat::Pcm24 => (24, hound::SampleFormat::Int),
        OutFormat::Float => (32, hound::SampleFormat::Float),
    };
    let spec = hound::WavSpec {
        channels,
        sample_rate: rate,
        bits_per_sample: bits,
        sample_format,
    };
    write_atomically(path, |tmp| {
        let mut w = hound::WavWriter::create(tmp, spec)
            .map_err(|e| SimError::Other(format!("{}: {e}", path.display())))?;
        let wr = |e: hound::Error| SimError::Other(format!("{}: {e}", path.display()));
        match format {
            OutFormat::Float => {
                for s in samples {
                    w.write_sample(*s).map_err(wr)?;
                }
            }
            _ => {
                let full = ((1i64 << (bits - 1)) - 1) as f64;
                for s in samples {
                    let v = (*s as f64 * full).round().clamp(-full - 1.0, full) as i32;
                    w.write_sample(v).map_err(wr)?;
                }
            }
        }
        w.finalize().map_err(wr)?;
        match comment {
            Some(text) => crate::calibration::sweep::append_info_comment(tmp, text),
            None => Ok(()),
        }
    })
}

/// Writes an output file through a temporary path (see [`crate::io::output_file`]: atomic for regular
/// files, through symbolic links, into device nodes and FIFOs without replacing them).
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    crate::io::output_file::write(path, write)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bulk decoder gives exactly what hound's sample iterator gives, for every supported format,
    /// with the extreme codes, for four channels and (24-bit) for one with an odd sample count.
    #[test]
    fn bulk_decoding_equals_hound() {
        let dir = tempfile::tempdir().unwrap();
        for (bits, float, channels) in [
            (8u16, false, 4u16),
            (16, false, 4),
            (24, false, 4),
            (24, false, 1),
            (32, false, 4),
            (32, true, 4),
        ] {
            let p = dir.path().join(format!("f{bits}{float}{channels}.wav"));
            let spec = hound::WavSpec {
                channels,
                sample_rate: 16000,
                bits_per_sample: bits,
                sample_format: if float {
                    hound::SampleFormat::Float
                } else {
                    hound::SampleFormat::Int
                },
            };
            let mut w = hound::WavWriter::create(&p, spec).unwrap();
            let full = (1i64 << (bits - 1)) - 1;
            let n = if channels == 1 { 4003 } else { 4000i64 };
            for i in 0..n {
                let x = ((i * 7919) % 2001 - 1000) as f64 / 1000.0;
                if float {
                    w.write_sample(x as f32).unwrap();
                } else {
                    // The most negative code too.
                    let code = if i % 97 == 5 {
                        -full - 1
                    } else {
                        (x * full as f64) as i64
                    };
                    w.write_sample(code as i32).unwrap();
                }
            }
            w.finalize().unwrap();
            let via_hound: Vec<f32> = if float {
                hound::WavReader::open(&p)
                    .unwrap()
                    .into_samples::<f32>()
                    .map(|s| s.unwrap())
                    .collect()
            } else {
                let scale = 1.0 / (1u64 << (bits - 1)) as f64;
                hound::WavReader::open(&p)
                    .unwrap()
                    .into_samples::<i32>()
                    .map(|s| (s.unwrap() as f64 * scale) as f32)
                    .collect()
            };
            let (_, ours) = read_interleaved(&p).unwrap();
            assert_eq!(ours.len() as i64, n);
            assert_eq!(
                ours, via_hound,
                "{bits} bit float={float} channels={channels}"
            );
        }
    }

    /// Writes a 4-channel 16-bit WAV of `frames` frames at `rate`, sample i (interleaved) `code(i)`.
    fn four_channel_wav_of(p: &Path, frames: usize, rate: u32, code: impl Fn(usize) -> i32) {
        let spec = hound::WavSpec {
            channels: 4,
            sample_rate: rate,
            bits_per_sample: 16,
            sample_format: hound::SampleFormat::Int,
        };
        let mut w = hound::WavWriter::create(p, spec).unwrap();
        for i in 0..frames * 4 {
            w.write_sample(code(i)).unwrap();
        }
        w.finalize().unwrap();
    }

    /// Writes a 4-channel 16-bit WAV of `frames` frames (48 kHz, a fixed pattern).
    fn four_channel_wav(p: &Path, frames: usize) {
        four_channel_wav_of(p, frames, 48000, |i| ((i * 7919) % 60001) as i32 - 30000);
    }

    /// Chunked reading crosses chunk boundaries without losing or repeating a frame.
    #[test]
    fn chunks_cover_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("long.wav");
        let n = 2 * CHUNK_FRAMES + 1000;
        four_channel_wav(&p, n);
        let mut s = RecordingStream::open(&p, InputLayout::Cma1).unwrap();
        assert_eq!(s.declared_frames(), n);
        let (mut all, mut chunk, mut sizes) = (Vec::new(), Vec::new(), Vec::new());
        loop {
            s.read_chunk(&mut chunk).unwrap();
            if chunk.is_empty() {
                break;
            }
            sizes.push(chunk.len());
            all.extend_from_slice(&chunk);
        }
        assert_eq!(sizes, [CHUNK_FRAMES, CHUNK_FRAMES, 1000]);
        let via_hound: Vec<f32> = hound::WavReader::open(&p)
            .unwrap()
            .into_samples::<i32>()
            .map(|s| (s.unwrap() as f64 / 32768.0) as f32)
            .collect();
        assert_eq!(all.concat(), via_hound);
    }

    /// A file cut inside the data: every complete frame before the cut is delivered, then the error
    /// (for AmbiX too, whose first frames the normalisation probe holds before delivering them).
    #[test]
    fn truncation_is_reported_after_the_frames_before_it() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("cut.wav");
        let n = CHUNK_FRAMES + 100;
        four_channel_wav(&p, n);
        let bytes = std::fs::read(&p).unwrap();
        // Cut 50 frames and 3 bytes before the end: 49 complete frames are missing, one is partial.
        std::fs::write(&p, &bytes[..bytes.len() - 50 * 8 - 3]).unwrap();
        for layout in [InputLayout::Cma1, InputLayout::Ambix] {
            let mut s = RecordingStream::open(&p, layout).unwrap();
            let mut chunk = Vec::new();
            s.read_chunk(&mut chunk).unwrap();
            assert_eq!(chunk.len(), CHUNK_FRAMES);
            s.read_chunk(&mut chunk).unwrap();
            assert_eq!(chunk.len(), 49);
            let e = s.read_chunk(&mut chunk).unwrap_err().to_string();
            assert!(
                e.contains("truncated") && e.contains("the file holds"),
                "{layout:?}: {e}"
            );
            assert!(read_recording(&p, layout).is_err());
        }
    }

    /// Writes a 1-channel-per-component AmbiX file (float) of a sound field: a noise plane wave
    /// from 40° azimuth, 10° up, and weaker 3-D diffuse noise (eight plane waves of independent
    /// noise from the cube's corners), its first-order channels scaled by `first_order` (1 SN3D,
    /// √3 N3D).
    fn ambix_field(p: &Path, frames: usize, first_order: f32) {
        let spec = hound::WavSpec {
            channels: 4,
            sample_rate: 16000,
            bits_per_sample: 32,
            sample_format: hound::SampleFormat::Float,
        };
        let mut w = hound::WavWriter::create(p, spec).unwrap();
        let mut rng = crate::simulation::signal::Rng::new(7);
        let corner = 1.0 / 3f32.sqrt();
        let mut waves = vec![(
            0.25f32,
            [
                40f32.to_radians().cos() * 10f32.to_radians().cos(),
                40f32.to_radians().sin() * 10f32.to_radians().cos(),
                10f32.to_radians().sin(),
            ],
        )];
        for k in 0..8 {
            let sign = |b: usize| if k & b == 0 { corner } else { -corner };
            waves.push((0.05, [sign(1), sign(2), sign(4)]));
        }
        for _ in 0..frames {
            let mut b = [0.0f32; 4];
            for (gain, u) in &waves {
                let x = gain * rng.gaussian() as f32;
                b[0] += x;
                for k in 0..3 {
                    b[k + 1] += x * u[k];
                }
            }
            // ACN order: W, Y, Z, X.
            for v in [
                b[0],
                b[2] * first_order,
                b[3] * first_order,
                b[1] * first_order,
            ] {
                w.write_sample(v).unwrap();
            }
        }
        w.finalize().unwrap();
    }

    /// `ambix` reads an N3D file as N3D and an SN3D one as SN3D, from their powers: both give the
    /// same frames; `ambix-sn3d` forced on the N3D file reads it as SN3D and warns.
    #[test]
    fn ambix_normalisation_is_read_from_the_powers() {
        let dir = tempfile::tempdir().unwrap();
        let (sn3d, n3d) = (dir.path().join("sn3d.wav"), dir.path().join("n3d.wav"));
        // Longer than the probe and than a chunk: the held frames and the streamed ones join.
        let n = 40_000;
        ambix_field(&sn3d, n, 1.0);
        ambix_field(&n3d, n, 3f32.sqrt());
        let read = |p: &Path, layout| {
            let mut s = RecordingStream::open(p, layout).unwrap();
            let frames = read_all(s.capacity_frames(), |c| s.read_chunk(c)).unwrap();
            (frames, s.normalisation().unwrap())
        };
        let (a, na) = read(&sn3d, InputLayout::Ambix);
        let (b, nb) = read(&n3d, InputLayout::Ambix);
        let (forced, nf) = read(&n3d, InputLayout::AmbixSn3d);
        let (explicit, _) = read(&n3d, InputLayout::AmbixN3d);
        assert_eq!(a.len(), n);
        assert_eq!(b.len(), n);
        let ra = na.ratio.unwrap();
        let rb = nb.ratio.unwrap();
        assert!(
            (ra - 1.0).abs() < 0.05 && (rb - 3.0).abs() < 0.15,
            "{ra} {rb}"
        );
        assert!(!na.n3d && nb.n3d && !nf.n3d, "{na:?} {nb:?} {nf:?}");
        assert!((na.probe_s - NORMALISATION_PROBE_S).abs() < 1e-9);
        let worst = a
            .iter()
            .zip(&b)
            .flat_map(|(x, y)| x.iter().zip(y).map(|(p, q)| (p - q).abs()))
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "{worst}");
        assert_eq!(b, explicit);
        assert!(forced.iter().zip(&a).any(|(x, y)| x != y));
        assert!(
            nb.line().starts_with("input: AmbiX read as N3D"),
            "{}",
            nb.line()
        );
        assert!(
            nf.line().starts_with("warning") && nf.line().contains("looks N3D"),
            "{}",
            nf.line()
        );
        // The same file through a pipe-like stream (no declared length) reads the same.
        assert_eq!(read_recording(&n3d, InputLayout::Ambix).unwrap().frames, b);
    }

    /// Silence tells nothing: read as SN3D, and the summary says why.
    #[test]
    fn silent_ambix_reads_as_sn3d() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("silent.wav");
        four_channel_wav_of(&p, 3000, 16000, |_| 0);
        let mut s = RecordingStream::open(&p, InputLayout::Ambix).unwrap();
        let frames = read_all(s.capacity_frames(), |c| s.read_chunk(c)).unwrap();
        assert_eq!(frames.len(), 3000);
        let n = s.normalisation().unwrap();
        assert!(n.ratio.is_none() && !n.n3d, "{n:?}");
        assert!(n.line().contains("no signal"), "{}", n.line());
    }

    /// One frame of an array at field components W, X, Y (X, Y the horizontal dipoles): cardioid
    /// m = g_m·((1 − β_m)·W + β_m·(X cos φ_m + Y sin φ_m)).
    fn capsules(w: f32, x: f32, y: f32, gain_db: [f32; 3], beta: [f32; 3]) -> [f32; 4] {
        let mut f = [w, 0.0, 0.0, 0.0];
        for m in 0..3 {
            let a = cma_core::CARDIOID_LOOK_DEG[m].to_radians();
            let g = 10f32.powf(gain_db[m] / 20.0);
            f[m + 1] = g * ((1.0 - beta[m]) * w + beta[m] * (x * a.cos() + y * a.sin()));
        }
        f
    }

    /// Frames of an array in a field of random W, X, Y (a diffuse-like field).
    fn array_frames(gain_db: [f32; 3], beta: [f32; 3]) -> Vec<[f32; 4]> {
        let mut rng = crate::simulation::signal::Rng::new(3);
        (0..20_000)
            .map(|_| {
                let [w, x, y] = [0; 3].map(|_| rng.gaussian() as f32);
                capsules(w, 0.58 * x, 0.58 * y, gain_db, beta)
            })
            .collect()
    }

    /// Frames of an ideal array hearing one plane wave from `azimuth_deg` over a diffuse field 20 dB
    /// below it.
    fn talker_frames(azimuth_deg: f32) -> Vec<[f32; 4]> {
        let mut rng = crate::simulation::signal::Rng::new(5);
        let t = azimuth_deg.to_radians();
        (0..20_000)
            .map(|_| {
                let s = rng.gaussian() as f32;
                let [w, x, y] = [0; 3].map(|_| 0.1 * rng.gaussian() as f32);
                capsules(
                    w + s,
                    0.58 * x + s * t.cos(),
                    0.58 * y + s * t.sin(),
                    [0.0; 3],
                    [0.5; 3],
                )
            })
            .collect()
    }

    /// The wiring check is silent for ideal and imperfect arrays and names a dead cardioid, the
    /// omni on a cardioid's channel and a reversed polarity.
    #[test]
    fn the_wiring_check_names_what_is_miswired() {
        let check = |frames: &[[f32; 4]]| {
            let mut w = WiringSums::default();
            w.add(frames);
            w.warning()
        };
        let ideal = array_frames([0.0; 3], [0.5; 3]);
        assert_eq!(check(&ideal), None);
        let imperfect = array_frames([1.5, -1.5, 0.5], [0.38, 0.62, 0.45]);
        assert_eq!(check(&imperfect), None);
        let dead: Vec<_> = ideal.iter().map(|f| [f[0], f[1], 0.0, f[3]]).collect();
        let e = check(&dead).unwrap();
        assert!(
            e.contains("120°") && e.contains("channel 3") && e.contains("connected"),
            "{e}"
        );
        let swapped: Vec<_> = ideal.iter().map(|f| [f[1], f[0], f[2], f[3]]).collect();
        let e = check(&swapped).unwrap();
        assert!(e.contains("above the omni"), "{e}");
        let reversed: Vec<_> = ideal.iter().map(|f| [f[0], -f[1], f[2], f[3]]).collect();
        let e = check(&reversed).unwrap();
        assert!(
            e.contains("reversed") && e.contains("0°") && e.contains("channel 2"),
            "{e}"
        );
        // A reversed cardioid facing a talker: named, not the one beside it as dead.
        for m in 0..3 {
            let facing = talker_frames(cma_core::CARDIOID_LOOK_DEG[m]);
            assert_eq!(check(&facing), None);
            let flipped: Vec<_> = facing
                .iter()
                .map(|f| {
                    let mut f = *f;
                    f[m + 1] = -f[m + 1];
                    f
                })
                .collect();
            let e = check(&flipped).unwrap();
            let channel = format!("(channel {})", m + 2);
            assert!(e.contains("reversed") && e.contains(&channel), "{e}");
        }
        // Silence and non-finite samples say nothing.
        assert_eq!(check(&[[0.0; 4]; 100]), None);
        assert_eq!(check(&[[f32::NAN; 4]; 100]), None);
    }
}
