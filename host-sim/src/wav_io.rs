//! WAV reading and writing (hound): 4-channel CMA1 or AmbiX input, mono sources, atomic writes.

use crate::error::{Result, SimError};
use cma_core::CARDIOID_LOOK_DEG;
use std::path::{Path, PathBuf};

/// Channel layout of a 4-channel input file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum InputLayout {
    /// omni, cardioid 0°, cardioid 120°, cardioid 240°.
    Cma1,
    /// First-order ambisonics, ACN order (W, Y, Z, X), SN3D normalisation.
    Ambix,
    /// First-order ambisonics, ACN order, N3D normalisation (first-order gains × √3).
    AmbixN3d,
}

/// A decoded 4-channel recording in CMA1 order, full scale ±1.
#[derive(Debug, Clone)]
pub struct Recording {
    /// Sample rate, Hz.
    pub rate: u32,
    /// Sample frames.
    pub frames: Vec<[f32; 4]>,
}

/// Sample frames per chunk a [`WavStream`] reads and decodes at a time (a multiple of the locator's
/// 1024-frame block): memory stays O(chunk) however long the file, and the raw, decoded and converted
/// buffers of a chunk (≤ 64 + 128 + 128 KiB) stay in the L2 cache.
pub const CHUNK_FRAMES: usize = 8 * 1024;

/// An open WAV whose samples are read and decoded chunk by chunk into a reused buffer.
///
/// Header problems (not a WAV, unsupported format, no samples) are reported by [`WavStream::open`];
/// truncated or corrupt sample data by [`WavStream::read_chunk`], only after every complete sample
/// frame before the damage has been delivered.
pub struct WavStream {
    path: PathBuf,
    spec: hound::WavSpec,
    source: Source,
    /// Samples the header declares.
    declared: usize,
    /// Samples delivered so far.
    delivered: usize,
    /// Decoded samples of an incomplete last frame, held back.
    carry: Vec<f32>,
    /// The error to report once the samples before it have been delivered.
    pending: Option<SimError>,
    /// Nothing more to read (end of data or error reported).
    done: bool,
}

enum Source {
    /// Packed little-endian samples (`block_align` = channels × bytes): raw reads, decoded in bulk
    /// (hound's per-sample iterator costs more than the whole localizer).
    Packed {
        inner: std::io::BufReader<std::fs::File>,
        raw: Vec<u8>,
        /// Bytes of sample data read so far.
        got: usize,
    },
    /// Any other layout hound reads: its per-sample iterator.
    Hound(hound::WavReader<std::io::BufReader<std::fs::File>>),
}

impl WavStream {
    /// Opens a WAV and parses its header; the samples are read by [`WavStream::read_chunk`].
    pub fn open(path: &Path) -> Result<Self> {
        let bad = |reason: String| SimError::BadWav {
            path: path.to_path_buf(),
            reason,
        };
        if !path.exists() {
            return Err(SimError::io(
                path,
                std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
            ));
        }
        let file = std::fs::File::open(path).map_err(|e| SimError::io(path, e))?;
        let reader = hound::WavReader::new(std::io::BufReader::new(file)).map_err(|e| match e {
            hound::Error::IoError(io) => bad(format!("header unreadable ({io})")),
            hound::Error::FormatError(msg) if msg.contains("bits per sample") => {
                SimError::SampleFormat {
                    path: path.to_path_buf(),
                    format: msg.to_string(),
                }
            }
            hound::Error::Unsupported => SimError::SampleFormat {
                path: path.to_path_buf(),
                format: "unsupported by the WAV reader".into(),
            },
            other => bad(other.to_string()),
        })?;
        let spec = reader.spec();
        let declared = reader.len() as usize;
        let bytes = (spec.bits_per_sample as usize).div_ceil(8);
        let packed = block_align(path) == Some(spec.channels as usize * bytes);
        let source = match (spec.sample_format, spec.bits_per_sample) {
            (hound::SampleFormat::Float, 32) | (hound::SampleFormat::Int, 8 | 16 | 24 | 32)
                if packed =>
            {
                Source::Packed {
                    inner: reader.into_inner(),
                    raw: Vec::new(),
                    got: 0,
                }
            }
            (hound::SampleFormat::Float, 32) | (hound::SampleFormat::Int, 8 | 16 | 24 | 32) => {
                Source::Hound(reader)
            }
            (fmt, bits) => {
                return Err(SimError::SampleFormat {
                    path: path.to_path_buf(),
                    format: format!("{fmt:?} {bits}-bit"),
                })
            }
        };
        if declared == 0 {
            return Err(SimError::Empty {
                path: path.to_path_buf(),
            });
        }
        Ok(Self {
            path: path.to_path_buf(),
            spec,
            source,
            declared,
            delivered: 0,
            carry: Vec::new(),
            pending: None,
            done: false,
        })
    }

    /// The header's format.
    #[must_use]
    pub fn spec(&self) -> hound::WavSpec {
        self.spec
    }

    /// Sample frames the header declares.
    #[must_use]
    pub fn declared_frames(&self) -> usize {
        self.declared / self.spec.channels.max(1) as usize
    }

    /// Replaces `out` with the next up to [`CHUNK_FRAMES`] complete sample frames, interleaved, as
    /// f32 full scale ±1 (exactly as hound's sample iterator gives them). `out` is left empty at the
    /// end of the data. Truncated or corrupt data is an error, returned after the complete frames
    /// before it.
    pub fn read_chunk(&mut self, out: &mut Vec<f32>) -> Result<()> {
        out.clear();
        if let Some(e) = self.pending.take() {
            self.done = true;
            return Err(e);
        }
        if self.done {
            return Ok(());
        }
        let ch = self.spec.channels.max(1) as usize;
        out.append(&mut self.carry);
        let want = (self.declared - self.delivered).min(CHUNK_FRAMES * ch);
        let bad = |reason: String| SimError::BadWav {
            path: self.path.clone(),
            reason,
        };
        match &mut self.source {
            Source::Packed { inner, raw, got } => {
                use std::io::Read;
                let bytes = (self.spec.bits_per_sample as usize).div_ceil(8);
                raw.resize(want * bytes, 0);
                let mut n = 0;
                while n < raw.len() {
                    match inner.read(&mut raw[n..]) {
                        Ok(0) => break,
                        Ok(k) => n += k,
                        Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                        Err(e) => {
                            self.done = true;
                            return Err(SimError::io(&self.path, e));
                        }
                    }
                }
                *got += n;
                let whole = n - n % bytes;
                decode_packed(
                    &raw[..whole],
                    self.spec.sample_format,
                    self.spec.bits_per_sample,
                    out,
                );
                self.delivered += whole / bytes;
                if n < raw.len() {
                    self.pending = Some(bad(format!(
                        "truncated or corrupt sample data (the header declares {} bytes of samples, the file holds {got})",
                        self.declared * bytes
                    )));
                }
            }
            Source::Hound(reader) => {
                let mut take = |out: &mut Vec<f32>| -> std::result::Result<(), hound::Error> {
                    if self.spec.sample_format == hound::SampleFormat::Float {
                        for s in reader.samples::<f32>().take(want) {
                            out.push(s?);
                        }
                    } else {
                        let scale = 1.0 / (1u64 << (self.spec.bits_per_sample - 1)) as f64;
                        for s in reader.samples::<i32>().take(want) {
                            out.push((s? as f64 * scale) as f32);
                        }
                    }
                    Ok(())
                };
                let before = out.len();
                let r = take(out);
                self.delivered += out.len() - before;
                if let Err(e) = r {
                    self.pending = Some(bad(format!("truncated or corrupt sample data ({e})")));
                }
            }
        }
        let whole = out.len() - out.len() % ch;
        if self.pending.is_none() && self.delivered == self.declared && whole != out.len() {
            self.pending = Some(bad("truncated: the last sample frame is incomplete".into()));
        }
        self.carry.extend_from_slice(&out[whole..]);
        out.truncate(whole);
        if out.is_empty() {
            if let Some(e) = self.pending.take() {
                self.done = true;
                return Err(e);
            }
            self.done = true;
        }
        Ok(())
    }
}

/// Reads all samples of a WAV as f32 (full scale ±1), interleaved, with its spec.
pub fn read_interleaved(path: &Path) -> Result<(hound::WavSpec, Vec<f32>)> {
    let mut stream = WavStream::open(path)?;
    let out = read_all(stream.declared, |chunk| stream.read_chunk(chunk))?;
    Ok((stream.spec, out))
}

/// Collects every chunk that `read_chunk` yields (an empty chunk ends the data) into one vector
/// with room for `declared` items.
fn read_all<T: Copy>(
    declared: usize,
    mut read_chunk: impl FnMut(&mut Vec<T>) -> Result<()>,
) -> Result<Vec<T>> {
    let mut out = Vec::with_capacity(declared);
    let mut chunk = Vec::new();
    loop {
        read_chunk(&mut chunk)?;
        if chunk.is_empty() {
            return Ok(out);
        }
        out.extend_from_slice(&chunk);
    }
}

/// `block_align` of the file's `fmt ` chunk (bytes per sample frame), if the RIFF header can be walked.
fn block_align(path: &Path) -> Option<usize> {
    use std::io::Read;
    let mut head = Vec::new();
    std::fs::File::open(path)
        .ok()?
        .take(4096)
        .read_to_end(&mut head)
        .ok()?;
    let mut pos = 12;
    while pos + 8 <= head.len() {
        let id = &head[pos..pos + 4];
        let len = u32::from_le_bytes(head[pos + 4..pos + 8].try_into().ok()?) as usize;
        if id == b"fmt " {
            let b = head.get(pos + 20..pos + 22)?;
            return Some(u16::from_le_bytes([b[0], b[1]]) as usize);
        }
        pos += 8 + len + (len & 1);
    }
    None
}

/// Appends packed little-endian WAV samples to `out` as f32 full scale ±1, exactly as hound's
/// iterator and `(v as f64 / 2^(bits-1)) as f32` give them (8-bit is unsigned with offset 128).
///
/// Up to 24 bits the integer and the product with the power-of-two scale are exact in f32, so the
/// f32 product equals the rounded f64 one; 32-bit goes through f64.
fn decode_packed(raw: &[u8], format: hound::SampleFormat, bits: u16, out: &mut Vec<f32>) {
    let scale = 1.0 / (1u64 << (bits - 1)) as f64;
    let s32 = scale as f32;
    // Exact-size iterators: `extend` writes in place, without zero-filling first.
    match (format, bits) {
        (hound::SampleFormat::Float, _) => out.extend(
            raw.chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        ),
        (_, 8) => out.extend(raw.iter().map(|b| (*b as i32 - 128) as f32 * s32)),
        (_, 16) => out.extend(
            raw.chunks_exact(2)
                .map(|b| i16::from_le_bytes([b[0], b[1]]) as f32 * s32),
        ),
        (_, 24) => out.extend(
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
    let (spec, data) = read_interleaved(path)?;
    check_four(path, spec, layout)?;
    Ok((spec, data))
}

/// A 4-channel recording read chunk by chunk and converted to CMA1 order.
pub struct RecordingStream {
    wav: WavStream,
    layout: InputLayout,
    raw: Vec<f32>,
    /// Converted frames of an AmbiX chunk.
    frames: Vec<[f32; 4]>,
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
        })
    }

    /// Sample rate, Hz.
    #[must_use]
    pub fn rate(&self) -> u32 {
        self.wav.spec.sample_rate
    }

    /// Sample frames the header declares.
    #[must_use]
    pub fn declared_frames(&self) -> usize {
        self.wav.declared_frames()
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
        self.wav.read_chunk(&mut self.raw)?;
        // `read_chunk` returns whole sample frames of the 4 channels `open` checked.
        let (c, _) = self.raw.as_chunks::<4>();
        let convert = |g: f32| {
            c.iter()
                .map(move |c| ambix_to_cma1(c[0], c[3] * g, c[1] * g))
        };
        match self.layout {
            InputLayout::Cma1 => return Ok(c),
            InputLayout::Ambix => {
                self.frames.clear();
                self.frames.extend(convert(1.0));
            }
            InputLayout::AmbixN3d => {
                self.frames.clear();
                self.frames.extend(convert(1.0 / 3f32.sqrt()));
            }
        }
        Ok(&self.frames)
    }
}

/// Reads a 4-channel recording and converts it to CMA1 order.
pub fn read_recording(path: &Path, layout: InputLayout) -> Result<Recording> {
    let mut stream = RecordingStream::open(path, layout)?;
    let frames = read_all(stream.declared_frames(), |chunk| stream.read_chunk(chunk))?;
    Ok(Recording {
        rate: stream.rate(),
        frames,
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

/// Writes interleaved samples (full scale ±1, clamped for PCM) atomically: to a temporary file next to
/// `path`, renamed into place only when complete.
pub fn write_wav(
    path: &Path,
    rate: u32,
    channels: u16,
    samples: &[f32],
    format: OutFormat,
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
        w.finalize().map_err(wr)
    })
}

/// Runs `write` on a temporary path beside `path` and renames it into place on success; on failure the
/// temporary file is removed and `path` is untouched.
pub fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.partial"));
    match write(&tmp) {
        Ok(()) => std::fs::rename(&tmp, path).map_err(|e| SimError::io(path, e)),
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            Err(e)
        }
    }
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

    /// Writes a 4-channel 16-bit WAV of `frames` frames.
    fn four_channel_wav(p: &Path, frames: usize) {
        let spec = hound::WavSpec {
            channels: 4,
            sample_rate: 48000,
            bits_per_sample: 16,
            sample_format: hound::SampleFormat::Int,
        };
        let mut w = hound::WavWriter::create(p, spec).unwrap();
        for i in 0..frames * 4 {
            w.write_sample(((i * 7919) % 60001) as i32 - 30000).unwrap();
        }
        w.finalize().unwrap();
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

    /// A file cut inside the data: every complete frame before the cut is delivered, then the error.
    #[test]
    fn truncation_is_reported_after_the_frames_before_it() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("cut.wav");
        let n = CHUNK_FRAMES + 100;
        four_channel_wav(&p, n);
        let bytes = std::fs::read(&p).unwrap();
        // Cut 50 frames and 3 bytes before the end: 49 complete frames are missing, one is partial.
        std::fs::write(&p, &bytes[..bytes.len() - 50 * 8 - 3]).unwrap();
        let mut s = RecordingStream::open(&p, InputLayout::Cma1).unwrap();
        let mut chunk = Vec::new();
        s.read_chunk(&mut chunk).unwrap();
        assert_eq!(chunk.len(), CHUNK_FRAMES);
        s.read_chunk(&mut chunk).unwrap();
        assert_eq!(chunk.len(), 49);
        let e = s.read_chunk(&mut chunk).unwrap_err().to_string();
        assert!(
            e.contains("truncated") && e.contains("the file holds"),
            "{e}"
        );
        assert!(read_recording(&p, InputLayout::Cma1).is_err());
    }
}
