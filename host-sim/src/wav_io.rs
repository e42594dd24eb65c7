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
    let mut out = Vec::with_capacity(declared);
    match (spec.sample_format, spec.bits_per_sample) {
        (hound::SampleFormat::Float, 32) => {
            for s in reader.into_samples::<f32>() {
                out.push(s.map_err(|e| bad(format!("truncated or corrupt sample data ({e})")))?);
            }
        }
        (hound::SampleFormat::Int, bits @ (8 | 16 | 24 | 32)) => {
            let scale = 1.0 / (1u64 << (bits - 1)) as f64;
            for s in reader.into_samples::<i32>() {
                let v = s.map_err(|e| bad(format!("truncated or corrupt sample data ({e})")))?;
                out.push((v as f64 * scale) as f32);
            }
        }
        (fmt, bits) => {
            return Err(SimError::SampleFormat {
                path: path.to_path_buf(),
                format: format!("{fmt:?} {bits}-bit"),
            })
        }
    }
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

/// Reads a 4-channel recording and converts it to CMA1 order.
pub fn read_recording(path: &Path, layout: InputLayout) -> Result<Recording> {
    let (spec, data) = read_interleaved(path)?;
    if spec.channels != 4 {
        return Err(SimError::ChannelCount {
            path: path.to_path_buf(),
            expected: 4,
            got: spec.channels,
            layout: match layout {
                InputLayout::Cma1 => "omni, cardioid 0°, cardioid 120°, cardioid 240°",
                _ => "AmbiX W, Y, Z, X",
            },
        });
    }
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
