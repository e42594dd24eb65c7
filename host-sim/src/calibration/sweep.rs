//! Exponential sine sweep (thesis §2.4.2): the excitation of eq. 2.43 and regularised deconvolution of a
//! sweep response into an impulse response (eq. 2.44–2.46).

use crate::error::{Result, SimError};
use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;
use std::f64::consts::PI;

/// Parameters of an exponential sine sweep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SweepSpec {
    /// Start frequency f₁, Hz.
    pub f1: f64,
    /// Stop frequency f₂, Hz.
    pub f2: f64,
    /// Duration T, s.
    pub seconds: f64,
    /// Sample rate, Hz.
    pub rate: u32,
}

impl Default for SweepSpec {
    /// 50 Hz to 20 kHz in 5 s at 48 kHz.
    fn default() -> Self {
        Self {
            f1: 50.0,
            f2: 20_000.0,
            seconds: 5.0,
            rate: 48_000,
        }
    }
}

/// Lowest sample rate of a sweep, Hz.
pub const MIN_RATE_HZ: u32 = 8_000;
/// Highest sample rate of a sweep, Hz (a 60 s sweep at this rate is 46 MB of samples).
pub const MAX_RATE_HZ: u32 = 192_000;

impl SweepSpec {
    /// Checks 0 < f₁ < f₂ ≤ rate/2 and 0.1 s ≤ T ≤ 60 s.
    pub fn validate(&self) -> Result<()> {
        if !(MIN_RATE_HZ..=MAX_RATE_HZ).contains(&self.rate) {
            return Err(SimError::Usage(format!(
                "--rate: expected {MIN_RATE_HZ}–{MAX_RATE_HZ} Hz, got {}",
                self.rate
            )));
        }
        let nyq = f64::from(self.rate) / 2.0;
        if !(self.f1 > 0.0 && self.f1 < self.f2) {
            return Err(SimError::Usage(format!(
                "--f1, --f2: need 0 < f1 < f2, got f1 = {} Hz, f2 = {} Hz",
                self.f1, self.f2
            )));
        }
        if !(self.f2 <= nyq) {
            return Err(SimError::Usage(format!(
                "--f2: {} Hz is above half of --rate {} Hz; give --f2 {nyq} or less",
                self.f2, self.rate
            )));
        }
        if !(0.1..=60.0).contains(&self.seconds) {
            return Err(SimError::Usage(format!(
                "--seconds: expected 0.1–60 s, got {}",
                self.seconds
            )));
        }
        Ok(())
    }

    /// Number of samples N = T·f_s.
    #[must_use]
    pub fn len(&self) -> usize {
        (self.seconds * f64::from(self.rate)).round() as usize
    }

    /// True if the sweep has no samples.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The sweep of eq. 2.43, s\[n\] = sin(A·(e^{n/(f_s τ)} − 1)) with τ = T / ln(f₂/f₁), A = 2π f₁ τ,
    /// with 10 ms half-Hann fades at both ends so the loudspeaker does not click (the fades only touch
    /// frequencies below f₁·1.01 and near f₂, outside the analysis band of the calibration).
    #[must_use]
    pub fn generate(&self) -> Vec<f64> {
        let fs = f64::from(self.rate);
        let tau = self.seconds / (self.f2 / self.f1).ln();
        let a = 2.0 * PI * self.f1 * tau;
        let n = self.len();
        let fade = ((0.01 * fs) as usize).min(n / 4).max(1);
        (0..n)
            .map(|i| {
                let v = (a * ((i as f64 / (fs * tau)).exp() - 1.0)).sin();
                let edge = i.min(n - 1 - i);
                let g = if edge < fade {
                    0.5 - 0.5 * (PI * edge as f64 / fade as f64).cos()
                } else {
                    1.0
                };
                v * g
            })
            .collect()
    }
}

/// Prefix of the comment that stores a sweep's parameters in its WAV file.
const INFO_PREFIX: &str = "cma-sweep";

impl SweepSpec {
    /// The text `host-sim sweep` stores in the WAV's `LIST`/`INFO` chunk as its `ICMT` (comment)
    /// entry, e.g. `cma-sweep f1=50 f2=20000 seconds=5 rate=48000`; audio editors show it as the
    /// file's comment. [`SweepSpec::from_info_comment`] reads it back.
    #[must_use]
    pub fn info_comment(&self) -> String {
        format!(
            "{INFO_PREFIX} f1={} f2={} seconds={} rate={}",
            self.f1, self.f2, self.seconds, self.rate
        )
    }

    /// Parses [`SweepSpec::info_comment`]; `None` for any other text.
    #[must_use]
    pub fn from_info_comment(text: &str) -> Option<Self> {
        let mut words = text.split_whitespace();
        if words.next() != Some(INFO_PREFIX) {
            return None;
        }
        let (mut f1, mut f2, mut seconds, mut rate) = (None, None, None, None);
        for w in words {
            let (k, v) = w.split_once('=')?;
            match k {
                "f1" => f1 = v.parse::<f64>().ok(),
                "f2" => f2 = v.parse::<f64>().ok(),
                "seconds" => seconds = v.parse::<f64>().ok(),
                "rate" => rate = v.parse::<u32>().ok(),
                _ => {}
            }
        }
        Some(Self {
            f1: f1?,
            f2: f2?,
            seconds: seconds?,
            rate: rate?,
        })
    }
}

/// Appends a `LIST`/`INFO` chunk with one `ICMT` (comment) entry to a complete RIFF/WAVE file and
/// updates the RIFF size. Readers that do not know the chunk skip it (it follows the `data` chunk).
pub fn append_info_comment(path: &std::path::Path, text: &str) -> Result<()> {
    use std::io::{Seek, SeekFrom, Write};
    let io = |e| SimError::io(path, e);
    let mut value = text.as_bytes().to_vec();
    value.push(0);
    let icmt_len = value.len() as u32;
    if value.len() % 2 == 1 {
        value.push(0);
    }
    let mut chunk = Vec::with_capacity(value.len() + 20);
    chunk.extend_from_slice(b"LIST");
    chunk.extend_from_slice(&(4 + 8 + value.len() as u32).to_le_bytes());
    chunk.extend_from_slice(b"INFO");
    chunk.extend_from_slice(b"ICMT");
    chunk.extend_from_slice(&icmt_len.to_le_bytes());
    chunk.extend_from_slice(&value);
    let mut f = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .open(path)
        .map_err(io)?;
    let len = f.seek(SeekFrom::End(0)).map_err(io)?;
    if len % 2 == 1 {
        // RIFF chunks start on even offsets.
        f.write_all(&[0]).map_err(io)?;
    }
    f.write_all(&chunk).map_err(io)?;
    let total = f.seek(SeekFrom::End(0)).map_err(io)?;
    let riff = u32::try_from(total - 8)
        .map_err(|_| SimError::Other(format!("{}: too large for RIFF", path.display())))?;
    f.seek(SeekFrom::Start(4)).map_err(io)?;
    f.write_all(&riff.to_le_bytes()).map_err(io)
}

/// The `ICMT` comment of a WAV file's `LIST`/`INFO` chunk, if it has one (a missing or malformed
/// chunk structure gives `None`; reading the file at all is the error).
pub fn read_info_comment(path: &std::path::Path) -> Result<Option<String>> {
    let bytes = std::fs::read(path).map_err(|e| SimError::reading(path, e))?;
    Ok(info_comment_of(&bytes))
}

fn info_comment_of(b: &[u8]) -> Option<String> {
    if b.len() < 12 || &b[0..4] != b"RIFF" || &b[8..12] != b"WAVE" {
        return None;
    }
    let u32_at = |at: usize| -> Option<usize> {
        Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?) as usize)
    };
    let mut at = 12;
    while at + 8 <= b.len() {
        let len = u32_at(at + 4)?;
        let body = b.get(at + 8..(at + 8).checked_add(len)?)?;
        if &b[at..at + 4] == b"LIST" && body.get(0..4) == Some(b"INFO") {
            let mut i = 4;
            while i + 8 <= body.len() {
                let n = u32::from_le_bytes(body[i + 4..i + 8].try_into().ok()?) as usize;
                let value = body.get(i + 8..(i + 8).checked_add(n)?)?;
                if &body[i..i + 4] == b"ICMT" {
                    let text = value.split(|c| *c == 0).next().unwrap_or(&[]);
                    return Some(String::from_utf8_lossy(text).into_owned());
                }
                i += 8 + n + n % 2;
            }
        }
        at += 8 + len + len % 2;
    }
    None
}

/// Deconvolves sweep responses with one excitation (eq. 2.44–2.46), regularised:
/// Ĥ\[k\] = X\[k\]·S*\[k\] / (|S\[k\]|² + λ\[k\]) with λ = ε·max|S|², ε = 10⁻⁴ inside [f₁, f₂] and ε = 1 outside,
/// so bins the sweep does not excite are suppressed rather than amplified (plain eq. 2.44 divides by
/// almost nothing there).
pub struct Deconvolver {
    n: usize,
    sweep_len: usize,
    inverse: Vec<Complex64>,
    fwd: std::sync::Arc<dyn rustfft::Fft<f64>>,
    inv: std::sync::Arc<dyn rustfft::Fft<f64>>,
}

impl std::fmt::Debug for Deconvolver {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Deconvolver")
            .field("n", &self.n)
            .field("sweep_len", &self.sweep_len)
            .finish_non_exhaustive()
    }
}

impl Deconvolver {
    /// Prepares the regularised inverse of `sweep` for responses of up to `max_response_len` samples
    /// (the FFT length N_x of eq. 2.46, rounded up to a power of two).
    #[must_use]
    pub fn new(sweep: &[f64], band_hz: (f64, f64), rate: u32, max_response_len: usize) -> Self {
        let n = max_response_len.max(sweep.len()).max(2).next_power_of_two();
        let mut planner = FftPlanner::<f64>::new();
        let fwd = planner.plan_fft_forward(n);
        let inv = planner.plan_fft_inverse(n);
        let mut s: Vec<Complex64> = sweep.iter().map(|v| Complex64::new(*v, 0.0)).collect();
        s.resize(n, Complex64::new(0.0, 0.0));
        fwd.process(&mut s);
        let peak = s.iter().map(|c| c.norm_sqr()).fold(0.0f64, f64::max);
        let df = f64::from(rate) / n as f64;
        let inverse = s
            .iter()
            .enumerate()
            .map(|(k, c)| {
                let f = k.min(n - k) as f64 * df;
                let eps = if f >= band_hz.0 && f <= band_hz.1 {
                    1e-4
                } else {
                    1.0
                };
                c.conj() / (c.norm_sqr() + eps * peak).max(f64::MIN_POSITIVE)
            })
            .collect();
        Self {
            n,
            sweep_len: sweep.len(),
            inverse,
            fwd,
            inv,
        }
    }

    /// Length of the sweep this deconvolver inverts.
    #[must_use]
    pub fn sweep_len(&self) -> usize {
        self.sweep_len
    }

    /// Longest response it accepts.
    #[must_use]
    pub fn max_response_len(&self) -> usize {
        self.n
    }

    /// The impulse response of one sweep response (`response.len()` ≤ [`Self::max_response_len`]);
    /// N samples long, causal part first, anything the deconvolution puts before t = 0 (loudspeaker
    /// harmonics) wrapped to the end.
    #[must_use]
    pub fn process(&self, response: &[f64]) -> Vec<f64> {
        let mut x: Vec<Complex64> = response
            .iter()
            .take(self.n)
            .map(|v| Complex64::new(*v, 0.0))
            .collect();
        x.resize(self.n, Complex64::new(0.0, 0.0));
        self.fwd.process(&mut x);
        for (a, b) in x.iter_mut().zip(&self.inverse) {
            *a *= b;
        }
        self.inv.process(&mut x);
        x.iter().map(|c| c.re / self.n as f64).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulation::signal::convolve;

    #[test]
    fn sweep_follows_eq_2_43() {
        let s = SweepSpec {
            f1: 100.0,
            f2: 4000.0,
            seconds: 1.0,
            rate: 16_000,
        };
        let x = s.generate();
        assert_eq!(x.len(), 16_000);
        // Instantaneous frequency f(t) = f1·e^{t/τ}: count zero crossings in 50 ms around t = 0.5 s.
        let fmid = 100.0 * (4000.0f64 / 100.0).sqrt();
        let seg = &x[7600..8400];
        let zc = seg.windows(2).filter(|w| w[0] * w[1] < 0.0).count() as f64;
        let f_est = zc / 2.0 / 0.05;
        assert!((f_est - fmid).abs() < 0.05 * fmid, "{f_est} vs {fmid}");
        assert!(x.iter().all(|v| v.abs() <= 1.0));
        assert!(s.validate().is_ok());
        assert!(SweepSpec { f2: 9000.0, ..s }.validate().is_err());
        assert!(SweepSpec { seconds: 0.0, ..s }.validate().is_err());
    }

    /// The sweep's parameters survive in its WAV file, which still reads as before.
    #[test]
    fn parameters_travel_in_the_wav_file() {
        let spec = SweepSpec {
            f1: 63.5,
            f2: 7000.0,
            seconds: 0.25,
            rate: 16_000,
        };
        assert_eq!(
            SweepSpec::from_info_comment(&spec.info_comment()),
            Some(spec)
        );
        assert_eq!(SweepSpec::from_info_comment("recorded in the lab"), None);
        assert_eq!(SweepSpec::from_info_comment("cma-sweep f1=50 f2=x"), None);
        let dir = tempfile::tempdir().unwrap();
        // An odd-length data chunk (8-bit mono, 3 samples) checks the pad byte.
        for (name, samples, bits) in [("a.wav", 4000usize, 32u16), ("b.wav", 3, 8)] {
            let path = dir.path().join(name);
            let wav = hound::WavSpec {
                channels: 1,
                sample_rate: 16_000,
                bits_per_sample: bits,
                sample_format: if bits == 32 {
                    hound::SampleFormat::Float
                } else {
                    hound::SampleFormat::Int
                },
            };
            let mut w = hound::WavWriter::create(&path, wav).unwrap();
            for i in 0..samples {
                if bits == 32 {
                    w.write_sample(i as f32 / 8000.0 - 0.25).unwrap();
                } else {
                    w.write_sample((i as i8) * 3).unwrap();
                }
            }
            w.finalize().unwrap();
            assert_eq!(read_info_comment(&path).unwrap(), None);
            append_info_comment(&path, &spec.info_comment()).unwrap();
            let text = read_info_comment(&path).unwrap().unwrap();
            assert_eq!(SweepSpec::from_info_comment(&text), Some(spec));
            let bytes = std::fs::read(&path).unwrap();
            let riff = u32::from_le_bytes(bytes[4..8].try_into().unwrap()) as usize;
            assert_eq!(riff + 8, bytes.len());
            let (rate, x) = crate::io::wav_io::read_mono(&path).unwrap();
            assert_eq!((rate, x.len()), (16_000, samples));
        }
    }

    #[test]
    fn deconvolution_recovers_a_known_impulse_response() {
        let spec = SweepSpec {
            f1: 20.0,
            f2: 8000.0,
            seconds: 1.0,
            rate: 16_000,
        };
        let s = spec.generate();
        // A delayed, band-limited system: direct 1.0 at 40, -0.5 at 57, 0.25 at 130.
        let mut h = vec![0.0; 200];
        h[40] = 1.0;
        h[57] = -0.5;
        h[130] = 0.25;
        let x = convolve(&s, &h);
        let d = Deconvolver::new(&s, (spec.f1, spec.f2), spec.rate, x.len());
        let est = d.process(&x);
        // Compare after smoothing both with a short low-pass (the regularisation band-limits to f1..f2).
        let lp = |v: &[f64]| -> Vec<f64> {
            (0..200usize)
                .map(|i| {
                    (i.saturating_sub(2)..=(i + 2).min(199))
                        .map(|j| v[j])
                        .sum::<f64>()
                        / 5.0
                })
                .collect()
        };
        let (a, b) = (lp(&est[..200]), lp(&h));
        let err: f64 = a.iter().zip(&b).map(|(p, q)| (p - q).powi(2)).sum();
        let energy: f64 = b.iter().map(|q| q * q).sum();
        assert!(err / energy < 1e-2, "relative error {}", err / energy);
        assert!((est[40] - 1.0).abs() < 0.05 && (est[57] + 0.5).abs() < 0.05);
        // Nothing of significance after the response.
        let tail = est[300..d.max_response_len() / 2]
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()));
        assert!(tail < 0.01, "tail {tail}");
    }
}
