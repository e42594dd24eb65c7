//! Recordings above 16 kHz brought to the boards' analysis rate, 16 kHz, before the core.
//!
//! The core's own decimator only halves (`cma_core::decimator`): it would analyse 48 and 96 kHz at
//! 12 kHz and 44.1, 88.2 and 22.05 kHz at 11 025 Hz, one estimate every 21.3 or 23.2 ms instead
//! of 16 ms, with every setting counted in frames (the trackers' memories, the self-calibration's
//! batches) stretched by a third or more in seconds. The boards sample at 16 kHz, and the product
//! is tuned and validated there; so `locate`, `eval`, `emit` and the multi-talker evaluation bring
//! every rate the core would not analyse at 16 kHz to 16 kHz first, with this linear-phase
//! polyphase resampler (by L/M, L = 16000/g and M = rate/g for g their greatest common divisor:
//! 1/3 from 48 kHz, 160/441 from 44.1 kHz), and the core then runs as on a board (the same 48 kHz
//! scenes, 12 → 16 kHz: jumps reached within 0.3 s 43.8 → 48.2 %, held-out walkers at 45°/s 4.99 →
//! 4.70° MAE; docs/history.md). 32 kHz needs none (the core halves it to 16 kHz); `beam` keeps
//! the input rate (its output is for listening).
//!
//! The filter is a Kaiser-windowed sinc at L times the input rate, designed for 80 dB from 9.5 kHz
//! up, so nothing folds below 6.5 kHz at 16 kHz (`tests` measure it at 250 Hz steps: −80.1 dB at
//! worst, from 22.05 kHz; the pass band to 5 kHz within 0.1 %), designed in f64 when the converter
//! is made. Output sample j is
//! centred on the input's time j/16 000 s (the filter's delay is taken off: the first outputs see
//! zeros before the start), so an estimate's time is the same as for the same sound at 16 kHz; the
//! last 0.6 ms of input make no output.

use std::borrow::Cow;

use crate::io::wav_io::Recording;
use cma_core::decimator::Decimator;

/// The rate the converter delivers, Hz (the boards' sample rate).
pub const ANALYSIS_RATE: u32 = 16_000;

/// Pass-band edge, Hz: the analysis band's default top (4 kHz) with a margin.
const PASS_HZ: f64 = 5_000.0;
/// Stop-band edge, Hz: what lies above folds at 16 kHz onto 6.5 kHz and above.
const STOP_HZ: f64 = 9_500.0;
/// Stop-band attenuation of the design, dB.
const STOP_DB: f64 = 80.0;

/// Whether input rate `rate` is converted: a rate above 16 kHz that the core's own decimator
/// supports and would bring to another analysis rate (22.05, 24, 44.1, 48, 88.2 and 96 kHz).
fn converts(rate: u32) -> bool {
    rate > ANALYSIS_RATE
        && Decimator::for_rate(rate).is_ok_and(|d| d.output_rate() != ANALYSIS_RATE)
}

/// A polyphase FIR resampler of the four channels from 22.05, 24, 44.1, 48, 88.2 or 96 kHz to
/// [`ANALYSIS_RATE`].
#[derive(Debug, Clone)]
pub struct RateConverter {
    /// Up-sampling factor L.
    up: u64,
    /// Down-sampling factor M.
    down: u64,
    /// The prototype filter at L times the input rate, 2c + 1 taps (times L: unit gain).
    taps: Vec<f32>,
    /// Its centre c.
    centre: u64,
    /// The last `history.len()` inputs (input i at i mod len); zeros before the start.
    history: Vec<[f32; 4]>,
    /// Inputs received.
    received: u64,
    /// The next output's index.
    next: u64,
}

impl RateConverter {
    /// The converter for input rate `rate`, or `None` when the core analyses that rate at 16 kHz
    /// or below as it is (every rate but 22.05, 24, 44.1, 48, 88.2 and 96 kHz).
    #[must_use]
    pub fn for_rate(rate: u32) -> Option<Self> {
        if !converts(rate) {
            return None;
        }
        let g = gcd(u64::from(rate), u64::from(ANALYSIS_RATE));
        let (up, down) = (u64::from(ANALYSIS_RATE) / g, u64::from(rate) / g);
        let taps = design(f64::from(rate), up);
        let centre = (taps.len() as u64 - 1) / 2;
        // Inputs an output reaches: from (centre + j·M − 2c)/L to (centre + j·M)/L.
        let span = (2 * centre / up + 2) as usize;
        Some(Self {
            up,
            down,
            taps,
            centre,
            history: vec![[0.0; 4]; span],
            received: 0,
            next: 0,
        })
    }

    /// The resampling ratio L/M as (L, M).
    #[must_use]
    pub fn ratio(&self) -> (u64, u64) {
        (self.up, self.down)
    }

    /// Appends to `out` the outputs that `input` completes.
    pub fn process(&mut self, input: &[[f32; 4]], out: &mut Vec<[f32; 4]>) {
        let len = self.history.len() as u64;
        for x in input {
            self.history[(self.received % len) as usize] = *x;
            self.received += 1;
            loop {
                // Output j is centred at c + j·M (at L times the input rate) and needs the inputs
                // up to (c + j·M)/L.
                let at = self.centre + self.next * self.down;
                let last = at / self.up;
                if last >= self.received {
                    break;
                }
                let mut y = [0.0f32; 4];
                // Inputs i = last, last − 1, … with taps at − i·L, while that stays within 2c.
                let first = (at - last * self.up) as usize;
                let taps = self.taps[first..].iter().step_by(self.up as usize);
                for (h, i) in taps.zip((0..=last).rev()) {
                    let v = &self.history[(i % len) as usize];
                    for c in 0..4 {
                        y[c] += h * v[c];
                    }
                }
                out.push(y);
                self.next += 1;
            }
        }
    }
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// The rate the core runs at for a recording at `rate`: [`ANALYSIS_RATE`] when [`RateConverter`]
/// converts `rate`, else `rate`.
#[must_use]
pub fn core_rate(rate: u32) -> u32 {
    if converts(rate) {
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
            let (up, down) = conv.ratio();
            let mut frames = Vec::with_capacity((rec.frames.len() as u64 * up / down) as usize + 1);
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

/// The Kaiser-windowed sinc low-pass at `up` times input rate `rate`: cut-off halfway between
/// [`PASS_HZ`] and [`STOP_HZ`], an even order from Kaiser's formula for [`STOP_DB`]; gain `up` at
/// DC (the zeros the up-sampling puts between the inputs take the rest).
fn design(rate: f64, up: u64) -> Vec<f32> {
    let fs = rate * up as f64;
    let beta = 0.1102 * (STOP_DB - 8.7);
    let width = 2.0 * core::f64::consts::PI * (STOP_HZ - PASS_HZ) / fs;
    let order = ((STOP_DB - 8.0) / (2.285 * width)).ceil() as usize;
    let order = order.div_ceil(2) * 2;
    let centre = order as f64 / 2.0;
    let fc = 0.5 * (PASS_HZ + STOP_HZ) / fs;
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
    h.iter().map(|v| (v / sum * up as f64) as f32).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rates the core supports and analyses at other than 16 kHz, above it.
    const CONVERTED: [u32; 6] = [22_050, 24_000, 44_100, 48_000, 88_200, 96_000];

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
    fn rates_the_core_would_not_analyse_at_16_khz_are_converted() {
        for (rate, ratio) in [
            (22_050, (320, 441)),
            (24_000, (2, 3)),
            (44_100, (160, 441)),
            (48_000, (1, 3)),
            (88_200, (80, 441)),
            (96_000, (1, 6)),
        ] {
            assert_eq!(RateConverter::for_rate(rate).unwrap().ratio(), ratio);
            assert_eq!(core_rate(rate), ANALYSIS_RATE);
        }
        for rate in [8_000, 11_025, 12_000, 16_000, 32_000, 50_000] {
            assert!(RateConverter::for_rate(rate).is_none(), "{rate}");
            assert_eq!(core_rate(rate), rate);
        }
    }

    #[test]
    fn the_band_passes_flat_and_what_would_fold_into_it_is_stopped() {
        for rate in CONVERTED {
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
            assert!(db < -79.0, "{rate} Hz: worst stop-band gain {db:.1} dB");
        }
    }

    #[test]
    fn output_j_is_centred_on_the_time_j_over_16_khz() {
        for rate in CONVERTED {
            let mut conv = RateConverter::for_rate(rate).unwrap();
            // A click at 20 ms (an input sample at every rate here): the symmetric filter's peak
            // lands on output 320 (20 ms at 16 kHz), its neighbours alike.
            let at = rate as usize / 50;
            let mut input = vec![[0.0f32; 4]; rate as usize / 10];
            input[at] = [1.0; 4];
            let mut out = Vec::new();
            conv.process(&input, &mut out);
            let peak = (0..out.len())
                .max_by(|a, b| out[*a][0].total_cmp(&out[*b][0]))
                .unwrap();
            assert_eq!(peak, 320, "{rate} Hz");
            assert!(
                (out[319][0] - out[321][0]).abs() < 1e-6,
                "{rate} Hz: symmetric"
            );
            // One output per 1/16 000 s of input, less the filter's half length.
            let (up, down) = conv.ratio();
            let n = input.len() as u64;
            assert_eq!(
                out.len() as u64,
                (n * up - conv.centre).div_ceil(down),
                "{rate} Hz"
            );
        }
    }

    #[test]
    fn pieces_give_the_outputs_of_the_whole() {
        for rate in [44_100, 48_000] {
            let mut whole = RateConverter::for_rate(rate).unwrap();
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
}
