//! Recordings at 48 and 96 kHz brought to the boards' analysis rate, 16 kHz, before the core.
//!
//! The core's own decimator only halves (`cma_core::decimator`): it would analyse 48 and 96 kHz at
//! 12 kHz, one estimate every 21.3 ms instead of 16 ms, with every setting counted in frames (the
//! trackers' memories, the self-calibration's batches) stretched by a third in seconds. The boards
//! sample at 16 kHz, and the product is tuned and validated there; so `locate`, `eval`, `emit` and
//! the multi-talker evaluation bring these rates to 16 kHz first, with this linear-phase FIR
//! decimator (by 3 or 6), and the core then runs as on a board (the same 48 kHz scenes, 12 → 16 kHz:
//! jumps reached within 0.3 s 43.8 → 48.2 %, held-out walkers at 45°/s 4.99 → 4.70° MAE;
//! docs/history.md). 44.1 and 88.2 kHz (no integer factor to 16 kHz) keep the core's halving to
//! 11 025 Hz; `beam` keeps the input rate (its output is for listening).
//!
//! The filter is a Kaiser-windowed sinc designed for 80 dB from 9.5 kHz up, so nothing folds below
//! 6.5 kHz at 16 kHz (measured by `tests` at 250 Hz steps: −82.8 dB at worst from 48 kHz, −82.3 dB
//! from 96 kHz; the pass band to 5 kHz within 0.1 %), designed in f64 when the converter is made.
//! Output sample j is centred on input sample factor·j (the filter's delay is taken off: the first
//! outputs see zeros before the start), so an estimate's time is the same as for the same sound at
//! 16 kHz; the last (taps − 1)/2 input samples, 0.6 ms, make no output.

use std::borrow::Cow;

use crate::io::wav_io::Recording;

/// The rate the converter delivers, Hz (the boards' sample rate).
pub const ANALYSIS_RATE: u32 = 16_000;

/// Pass-band edge, Hz: the analysis band's default top (4 kHz) with a margin.
const PASS_HZ: f64 = 5_000.0;
/// Stop-band edge, Hz: what lies above folds at 16 kHz onto 6.5 kHz and above.
const STOP_HZ: f64 = 9_500.0;
/// Stop-band attenuation of the design, dB.
const STOP_DB: f64 = 80.0;

/// A polyphase FIR decimator of the four channels from 48 or 96 kHz to [`ANALYSIS_RATE`].
#[derive(Debug, Clone)]
pub struct RateConverter {
    factor: usize,
    taps: Vec<f32>,
    /// The last `taps.len()` inputs, written twice (at `pos` and `pos + taps.len()`) so that they
    /// are always one contiguous slice, oldest first, from `pos`.
    history: Vec<[f32; 4]>,
    pos: usize,
    /// Inputs until the next output.
    until: usize,
}

impl RateConverter {
    /// The converter for input rate `rate`, or `None` when the core analyses that rate as it is
    /// (every rate but 48 and 96 kHz).
    #[must_use]
    pub fn for_rate(rate: u32) -> Option<Self> {
        let factor = match rate {
            48_000 => 3,
            96_000 => 6,
            _ => return None,
        };
        let taps = design(f64::from(rate), factor);
        let n = taps.len();
        Some(Self {
            factor,
            history: vec![[0.0; 4]; 2 * n],
            pos: 0,
            // Output 0 is centred on input 0: it is made when input (n − 1)/2 arrives.
            until: (n - 1) / 2 + 1,
            taps,
        })
    }

    /// The decimation factor (3 or 6).
    #[must_use]
    pub fn factor(&self) -> usize {
        self.factor
    }

    /// Number of filter taps.
    #[must_use]
    pub fn taps(&self) -> usize {
        self.taps.len()
    }

    /// Appends to `out` the outputs that `input` completes.
    pub fn process(&mut self, input: &[[f32; 4]], out: &mut Vec<[f32; 4]>) {
        let n = self.taps.len();
        for x in input {
            self.history[self.pos] = *x;
            self.history[self.pos + n] = *x;
            self.pos = if self.pos + 1 == n { 0 } else { self.pos + 1 };
            self.until -= 1;
            if self.until == 0 {
                self.until = self.factor;
                let window = &self.history[self.pos..self.pos + n];
                let mut y = [0.0f32; 4];
                for (h, v) in self.taps.iter().zip(window) {
                    for c in 0..4 {
                        y[c] += h * v[c];
                    }
                }
                out.push(y);
            }
        }
    }
}

/// The rate the core runs at for a recording at `rate`: [`ANALYSIS_RATE`] when [`RateConverter`]
/// converts `rate`, else `rate`.
#[must_use]
pub fn core_rate(rate: u32) -> u32 {
    if matches!(rate, 48_000 | 96_000) {
        ANALYSIS_RATE
    } else {
        rate
    }
}

/// `rec` at [`ANALYSIS_RATE`] when [`RateConverter`] converts its rate, else `rec` itself.
#[must_use]
pub fn analysis_recording(rec: &Recording) -> Cow<'_, Recording> {
    match RateConverter::for_rate(rec.rate) {
        Some(mut conv) => {
            let mut frames = Vec::with_capacity(rec.frames.len() / conv.factor() + 1);
            conv.process(&rec.frames, &mut frames);
            Cow::Owned(Recording {
                rate: ANALYSIS_RATE,
                frames,
                normalisation: rec.normalisation,
            })
        }
        None => Cow::Borrowed(rec),
    }
}

/// The zeroth-order modified Bessel function of the first kind (its power series).
fn bessel_i0(x: f64) -> f64 {
    let (mut sum, mut term, mut k) = (1.0, 1.0, 1.0);
    while term > 1e-12 * sum {
        term *= (x / (2.0 * k)) * (x / (2.0 * k));
        sum += term;
        k += 1.0;
    }
    sum
}

/// The Kaiser-windowed sinc low-pass for input rate `rate` and decimation `factor`: cut-off halfway
/// between [`PASS_HZ`] and [`STOP_HZ`], length from Kaiser's formula for [`STOP_DB`] rounded up so
/// that the delay, (taps − 1)/2, is a whole number of outputs; unit gain at DC.
fn design(rate: f64, factor: usize) -> Vec<f32> {
    let beta = 0.1102 * (STOP_DB - 8.7);
    let width = 2.0 * core::f64::consts::PI * (STOP_HZ - PASS_HZ) / rate;
    let order = ((STOP_DB - 8.0) / (2.285 * width)).ceil() as usize;
    let order = order.div_ceil(2 * factor) * 2 * factor;
    let centre = order as f64 / 2.0;
    let fc = 0.5 * (PASS_HZ + STOP_HZ) / rate;
    let norm = bessel_i0(beta);
    let h: Vec<f64> = (0..=order)
        .map(|i| {
            let t = i as f64 - centre;
            let sinc = if t == 0.0 {
                2.0 * fc
            } else {
                (2.0 * core::f64::consts::PI * fc * t).sin() / (core::f64::consts::PI * t)
            };
            let r = t / centre;
            sinc * bessel_i0(beta * (1.0 - r * r).max(0.0).sqrt()) / norm
        })
        .collect();
    let sum: f64 = h.iter().sum();
    h.iter().map(|v| (v / sum) as f32).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Gain of the converter for a tone at `freq` Hz (the output's RMS after the start, × √2).
    fn tone_gain(rate: u32, freq: f64) -> f64 {
        let mut conv = RateConverter::for_rate(rate).unwrap();
        let input: Vec<[f32; 4]> = (0..rate as usize / 2)
            .map(|n| {
                let v = (2.0 * core::f64::consts::PI * freq * n as f64 / f64::from(rate)).sin();
                [v as f32; 4]
            })
            .collect();
        let mut out = Vec::new();
        conv.process(&input, &mut out);
        let tail = &out[200..];
        let p = tail.iter().map(|v| f64::from(v[0]).powi(2)).sum::<f64>() / tail.len() as f64;
        (2.0 * p).sqrt()
    }

    #[test]
    fn only_48_and_96_khz_are_converted() {
        assert_eq!(RateConverter::for_rate(48_000).unwrap().factor(), 3);
        assert_eq!(RateConverter::for_rate(96_000).unwrap().factor(), 6);
        for rate in [48_000, 96_000] {
            assert_eq!(core_rate(rate), ANALYSIS_RATE);
        }
        for rate in [11_025, 12_000, 16_000, 24_000, 32_000, 44_100, 88_200] {
            assert!(RateConverter::for_rate(rate).is_none(), "{rate}");
            assert_eq!(core_rate(rate), rate);
        }
    }

    #[test]
    fn the_band_passes_flat_and_what_would_fold_into_it_is_stopped() {
        for rate in [48_000, 96_000] {
            for f in [100.0, 1000.0, 3000.0, 4000.0, 5000.0] {
                let g = tone_gain(rate, f);
                assert!((g - 1.0).abs() < 1e-3, "{rate} Hz, {f} Hz: gain {g}");
            }
            // Everything from the stop edge to the input's Nyquist, in 250 Hz steps.
            let mut worst = 0.0f64;
            let mut f = STOP_HZ;
            while f < f64::from(rate) / 2.0 {
                worst = worst.max(tone_gain(rate, f));
                f += 250.0;
            }
            let db = 20.0 * worst.log10();
            assert!(db < -80.0, "{rate} Hz: worst stop-band gain {db:.1} dB");
        }
    }

    #[test]
    fn output_j_is_centred_on_input_factor_times_j() {
        for rate in [48_000, 96_000] {
            let mut conv = RateConverter::for_rate(rate).unwrap();
            let m = conv.factor();
            // A click at input 30·m: the symmetric filter's peak lands on output 30.
            let mut input = vec![[0.0f32; 4]; 100 * m];
            input[30 * m] = [1.0; 4];
            let mut out = Vec::new();
            conv.process(&input, &mut out);
            let peak = (0..out.len())
                .max_by(|a, b| out[*a][0].total_cmp(&out[*b][0]))
                .unwrap();
            assert_eq!(peak, 30, "{rate} Hz");
            assert!(
                (out[29][0] - out[31][0]).abs() < 1e-7,
                "{rate} Hz: symmetric"
            );
            // One output per `factor` inputs, less the last (taps − 1)/2 inputs.
            assert_eq!(out.len(), (100 * m - (conv.taps() - 1) / 2).div_ceil(m));
        }
    }

    #[test]
    fn pieces_give_the_outputs_of_the_whole() {
        let mut whole = RateConverter::for_rate(48_000).unwrap();
        let mut pieces = whole.clone();
        let input: Vec<[f32; 4]> = (0..5000)
            .map(|n| {
                let v = ((n * 7919) % 1000) as f32 / 1000.0 - 0.5;
                [v, -v, 0.5 * v, v * v]
            })
            .collect();
        let (mut a, mut b) = (Vec::new(), Vec::new());
        whole.process(&input, &mut a);
        for piece in input.chunks(1024) {
            pieces.process(piece, &mut b);
        }
        assert_eq!(a, b);
    }
}
