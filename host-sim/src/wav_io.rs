//! WAV reading and writing (hound): 4-channel CMA1 or AmbiX input, mono sources, atomic writes.

use crate::error::{Result, SimError};
use cma_core::CARDIOID_LOOK_DEG;
use std::path::Path;

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

/// Reads all samples of a WAV as f32 (full scale ±1), interleaved, with its spec.
pub fn read_interleaved(path: &Path) -> Result<(hound::WavSpec, Vec<f32>)> {
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
    let out = match (spec.sample_format, spec.bits_per_sample) {
        (hound::SampleFormat::Float, 32) | (hound::SampleFormat::Int, 8 | 16 | 24 | 32)
            if packed =>
        {
            // Fast path: the data chunk in one read, decoded in place (hound's per-sample iterator
            // costs more than the whole localizer).
            use std::io::Read;
            let mut raw = vec![0u8; declared * bytes];
            let mut inner = reader.into_inner();
            let mut got = 0;
            while got < raw.len() {
                match inner.read(&mut raw[got..]) {
                    Ok(0) => break,
                    Ok(n) => got += n,
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                    Err(e) => return Err(SimError::io(path, e)),
                }
            }
            if got < raw.len() {
                return Err(bad(format!(
                    "truncated or corrupt sample data (the header declares {} bytes of samples, the file holds {got})",
                    raw.len()
                )));
            }
            decode_packed(&raw, spec.sample_format, spec.bits_per_sample)
        }
        (hound::SampleFormat::Float, 32) => {
            let mut out = Vec::with_capacity(declared);
            for s in reader.into_samples::<f32>() {
                out.push(s.map_err(|e| bad(format!("truncated or corrupt sample data ({e})")))?);
            }
            out
        }
        (hound::SampleFormat::Int, bits @ (8 | 16 | 24 | 32)) => {
            let scale = 1.0 / (1u64 << (bits - 1)) as f64;
            let mut out = Vec::with_capacity(declared);
            for s in reader.into_samples::<i32>() {
                let v = s.map_err(|e| bad(format!("truncated or corrupt sample data ({e})")))?;
                out.push((v as f64 * scale) as f32);
            }
            out
        }
        (fmt, bits) => {
            return Err(SimError::SampleFormat {
                path: path.to_path_buf(),
                format: format!("{fmt:?} {bits}-bit"),
            })
        }
    };
    if out.is_empty() {
        return Err(SimError::Empty {
            path: path.to_path_buf(),
        });
    }
    if out.len() % spec.channels as usize != 0 {
        return Err(bad("truncated: the last sample frame is incomplete".into()));
    }
    Ok((spec, out))
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

/// Decodes packed little-endian WAV samples to f32 full scale ±1, exactly as hound's iterator does
/// (8-bit is unsigned with offset 128).
fn decode_packed(raw: &[u8], format: hound::SampleFormat, bits: u16) -> Vec<f32> {
    let scale = 1.0 / (1u64 << (bits - 1)) as f64;
    let int = |v: i32| (v as f64 * scale) as f32;
    match (format, bits) {
        (hound::SampleFormat::Float, _) => raw
            .chunks_exact(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect(),
        (_, 8) => raw.iter().map(|b| int(*b as i32 - 128)).collect(),
        (_, 16) => raw
            .chunks_exact(2)
            .map(|b| int(i16::from_le_bytes([b[0], b[1]]) as i32))
            .collect(),
        (_, 24) => raw
            .chunks_exact(3)
            .map(|b| int(i32::from_le_bytes([0, b[0], b[1], b[2]]) >> 8))
            .collect(),
        _ => raw
            .chunks_exact(4)
            .map(|b| int(i32::from_le_bytes([b[0], b[1], b[2], b[3]])))
            .collect(),
    }
}

/// Reads a WAV that must have 4 channels (`layout` names them in the error message).
pub fn read_four_channels(path: &Path, layout: &'static str) -> Result<(hound::WavSpec, Vec<f32>)> {
    let (spec, data) = read_interleaved(path)?;
    if spec.channels != 4 {
        return Err(SimError::ChannelCount {
            path: path.to_path_buf(),
            expected: 4,
            got: spec.channels,
            layout,
        });
    }
    Ok((spec, data))
}

/// Reads a 4-channel recording and converts it to CMA1 order.
pub fn read_recording(path: &Path, layout: InputLayout) -> Result<Recording> {
    let (spec, data) = read_four_channels(
        path,
        match layout {
            InputLayout::Cma1 => "omni, cardioid 0°, cardioid 120°, cardioid 240°",
            _ => "AmbiX W, Y, Z, X",
        },
    )?;
    cma_core::decimator::Decimator::for_rate(spec.sample_rate).map_err(|source| {
        SimError::Core {
            context: path.display().to_string(),
            source,
        }
    })?;
    let frames = data
        .chunks_exact(4)
        .map(|c| match layout {
            InputLayout::Cma1 => [c[0], c[1], c[2], c[3]],
            InputLayout::Ambix => ambix_to_cma1(c[0], c[3], c[1]),
            InputLayout::AmbixN3d => {
                let g = 1.0 / 3f32.sqrt();
                ambix_to_cma1(c[0], c[3] * g, c[1] * g)
            }
        })
        .collect();
    Ok(Recording {
        rate: spec.sample_rate,
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

    /// The bulk decoder gives exactly what hound's sample iterator gives, for every supported format.
    #[test]
    fn bulk_decoding_equals_hound() {
        let dir = tempfile::tempdir().unwrap();
        for (bits, float) in [
            (8u16, false),
            (16, false),
            (24, false),
            (32, false),
            (32, true),
        ] {
            let p = dir.path().join(format!("f{bits}{float}.wav"));
            let spec = hound::WavSpec {
                channels: 4,
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
            for i in 0..4000i64 {
                let x = ((i * 7919) % 2001 - 1000) as f64 / 1000.0;
                if float {
                    w.write_sample(x as f32).unwrap();
                } else {
                    w.write_sample((x * full as f64) as i32).unwrap();
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
            assert_eq!(ours, via_hound, "{bits} bit float={float}");
        }
    }
}
