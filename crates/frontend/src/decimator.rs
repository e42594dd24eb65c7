//! Anti-alias decimator: a cascade of polyphase IIR half-band stages (elliptic, two all-pass paths),
//! fed sample by sample (so any block size works) and computing only the samples it keeps.
//!
//! | input rate (Hz)        | factor | stages        | analysis rate (Hz)    |
//! |------------------------|--------|---------------|-----------------------|
//! | 11025, 12000, 16000    | 1      | —             | unchanged             |
//! | 22050, 24000, 32000    | 2      | long          | 11025, 12000, 16000   |
//! | 44100, 48000           | 4      | short, long   | 11025, 12000          |
//! | 88200, 96000           | 8      | short ×2, long| 11025, 12000          |
//!
//! Each stage is H(z) = ½[A₀(z²) + z⁻¹·A₁(z²)] with A₀, A₁ cascades of first-order all-pass sections
//! (a + z⁻²)/(1 + a·z⁻²); decimating by two, every path runs at the output rate on every other input,
//! one multiply per section and output. The long stage (order 7, 3 sections) keeps 0–⅙ of its input
//! rate flat within 10⁻⁶ and stops ⅓–½ by ≈ 68 dB; the short stage (order 5, 2 sections) only has to
//! stop what folds onto 0–4 kHz at its output (≈ 81 dB above 5/12 of its input rate). Together, at
//! 48 kHz, they reject everything that would alias into 0–4 kHz at 12 kHz by ≥ 68 dB (design value,
//! f64; the test `aliases_into_the_band_are_rejected_by_50_db` measures the f32 implementation at 250 Hz
//! steps; measured 68.6 dB) — 1.75 all-pass multiplies per input sample and channel, plus 0.75 for
//! the ½ of the path sums.
//!
//! The phase is not linear: the group delay depends on frequency (at 48 kHz 5.65 input samples at
//! 1 kHz and 5.53 at DC, against 23 for the FIR pair before; see [`Decimator::time_offset`]), but it is
//! the same filter on every channel, so the magnitude
//! ratios between channels (the features) do not change. The block path
//! ([`crate::block_decimator::BlockDecimator`]) runs the cascade over whole pieces of input with the same
//! arithmetic (`pair_out`) in the same order, so its outputs are bit-identical to the per-sample path.

use crate::error::Error;
use crate::tables::{HALFBAND_LONG, HALFBAND_SHORT};

/// Most all-pass sections of a stage (the long stage's).
pub(crate) const MAX_SECTIONS: usize = HALFBAND_LONG.len();

/// One half-band stage's design.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HalfbandKind {
    /// Order 5 (2 all-pass sections), for a first halving where the band of interest is far below the
    /// transition.
    Short,
    /// Order 7 (3 all-pass sections), for the last halving to the analysis rate.
    Long,
}

impl HalfbandKind {
    fn coefs(self) -> &'static [f32] {
        match self {
            HalfbandKind::Short => &HALFBAND_SHORT,
            HalfbandKind::Long => &HALFBAND_LONG,
        }
    }

    /// Number of all-pass sections (multiplies per output) of the stage.
    #[must_use]
    pub fn sections(self) -> usize {
        self.coefs().len()
    }

    /// Group delay of the stage at angular frequency `w` (radians per input sample), in input samples.
    ///
    /// A section (a + z⁻²)/(1 + a·z⁻²) delays by 2(1 − a²)/(1 + 2a·cos 2ω + a²); in the pass band the two
    /// unit-magnitude paths A₀ and z⁻¹A₁ are nearly in phase, so the phase of their sum is the mean of
    /// theirs and the delay is (τ₀ + τ₁ + 1)/2.
    #[must_use]
    pub fn group_delay(self, w: f64) -> f64 {
        let c2 = libm::cos(2.0 * w);
        let sum: f64 = self
            .coefs()
            .iter()
            .map(|a| {
                let a = f64::from(*a);
                2.0 * (1.0 - a * a) / (1.0 + 2.0 * a * c2 + a * a)
            })
            .sum();
        (sum + 1.0) / 2.0
    }
}

/// State of one half-band stage of `L` channels run in lockstep (one channel: `L = 1`).
#[derive(Debug, Clone, Copy)]
pub struct HalfbandState<const L: usize = 1> {
    /// Per section and channel: its previous input and output.
    pub(crate) x: [[f32; L]; MAX_SECTIONS],
    pub(crate) y: [[f32; L]; MAX_SECTIONS],
    /// The first input of an incomplete pair.
    held: [f32; L],
    /// An input is held (the next one completes an output).
    pub(crate) odd: bool,
}

impl<const L: usize> HalfbandState<L> {
    /// A zeroed state.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            x: [[0.0; L]; MAX_SECTIONS],
            y: [[0.0; L]; MAX_SECTIONS],
            held: [0.0; L],
            odd: false,
        }
    }
}

impl<const L: usize> Default for HalfbandState<L> {
    fn default() -> Self {
        Self::new()
    }
}

/// One output of a stage with `N` sections from the input pair (`first`, `second`), `second` the newer,
/// for `L` channels at once: path 0 (even sections) takes `second`, path 1 (odd sections) `first`; the
/// output is their sum times `scale`. The half-band's ½ is deferred: inner stages pass `scale` = 1
/// (the multiply folds away) and the last stage of a cascade of n applies 2⁻ⁿ once. Scaling by a
/// power of two commutes with every rounding in the normal range, so the output equals that of a ½
/// per stage bit for bit there (only subnormal intermediates, below 10⁻³⁸, could differ). Each section computes y = a·(u − y₋₁) + u₋₁ (multiply and add, never fused, so
/// every target rounds alike); each channel sees the same operations in the same order whatever `L`.
/// The sizes are constants, so the loops unroll and the state stays in registers (on x86_64 the four
/// channels of `L = 4` become one SSE register).
#[inline(always)]
pub(crate) fn pair_out<const N: usize, const L: usize>(
    coefs: &[f32; N],
    x: &mut [[f32; L]; MAX_SECTIONS],
    y: &mut [[f32; L]; MAX_SECTIONS],
    first: [f32; L],
    second: [f32; L],
    scale: f32,
) -> [f32; L] {
    let mut p = [second, first];
    for (k, a) in coefs.iter().enumerate() {
        let u = p[k % 2];
        let mut v = [0.0; L];
        for l in 0..L {
            v[l] = a * (u[l] - y[k][l]) + x[k][l];
        }
        x[k] = u;
        y[k] = v;
        p[k % 2] = v;
    }
    let mut out = [0.0; L];
    for l in 0..L {
        out[l] = scale * (p[0][l] + p[1][l]);
    }
    out
}

/// Runs one half-band stage on one input sample (of `L` channels); returns an output on every second
/// input.
#[inline]
fn halfband_step<const L: usize>(
    kind: HalfbandKind,
    state: &mut HalfbandState<L>,
    x: [f32; L],
    scale: f32,
) -> Option<[f32; L]> {
    if !state.odd {
        state.held = x;
        state.odd = true;
        return None;
    }
    state.odd = false;
    let held = state.held;
    Some(match kind {
        HalfbandKind::Short => {
            pair_out(&HALFBAND_SHORT, &mut state.x, &mut state.y, held, x, scale)
        }
        HalfbandKind::Long => pair_out(&HALFBAND_LONG, &mut state.x, &mut state.y, held, x, scale),
    })
}

/// Decimator configuration: which stages run for the input rate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Decimator {
    stages: [HalfbandKind; 3],
    n_stages: usize,
    input_rate: u32,
}

/// Decimator state of one channel, or of `L` channels run in lockstep.
#[derive(Debug, Clone, Copy, Default)]
pub struct DecimatorState<const L: usize = 1> {
    pub(crate) stages: [HalfbandState<L>; 3],
}

impl<const L: usize> DecimatorState<L> {
    /// A zeroed state.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            stages: [HalfbandState::new(); 3],
        }
    }

    /// No stage holds the first input of a pair: the inputs so far are a multiple of the factor.
    #[must_use]
    pub fn aligned(&self) -> bool {
        !(self.stages[0].odd | self.stages[1].odd | self.stages[2].odd)
    }
}

/// Frequency at which [`Decimator::time_offset`] compensates the group delay, in Hz.
pub const DELAY_REFERENCE_HZ: f64 = 1000.0;

impl Decimator {
    /// The decimator for an input rate, or [`Error::UnsupportedSampleRate`].
    pub fn for_rate(input_rate: u32) -> Result<Self, Error> {
        use HalfbandKind::{Long, Short};
        let (stages, n_stages) = match input_rate {
            11025 | 12000 | 16000 => ([Long, Long, Long], 0),
            22050 | 24000 | 32000 => ([Long, Long, Long], 1),
            44100 | 48000 => ([Short, Long, Long], 2),
            88200 | 96000 => ([Short, Short, Long], 3),
            got => return Err(Error::UnsupportedSampleRate { got }),
        };
        Ok(Self {
            stages,
            n_stages,
            input_rate,
        })
    }

    /// The factor-1 decimator at 12 kHz (a placeholder for constant initialisers).
    #[must_use]
    pub const fn passthrough() -> Self {
        Self {
            stages: [HalfbandKind::Long; 3],
            n_stages: 0,
            input_rate: 12_000,
        }
    }

    /// Decimation factor (1, 2, 4 or 8).
    #[must_use]
    pub fn factor(&self) -> u32 {
        1 << self.n_stages
    }

    /// Input sample rate in Hz.
    #[must_use]
    pub fn input_rate(&self) -> u32 {
        self.input_rate
    }

    /// Analysis (output) sample rate in Hz.
    #[must_use]
    pub fn output_rate(&self) -> u32 {
        self.input_rate / self.factor()
    }

    /// Total group delay of the cascade at [`DELAY_REFERENCE_HZ`], in input samples.
    #[must_use]
    pub fn group_delay(&self) -> f64 {
        let mut delay = 0.0f64;
        let mut s = 1.0f64;
        for kind in &self.stages[..self.n_stages] {
            let w =
                2.0 * core::f64::consts::PI * DELAY_REFERENCE_HZ * s / f64::from(self.input_rate);
            delay += s * kind.group_delay(w);
            s *= 2.0;
        }
        delay
    }

    /// Input-sample time of output sample 0 (group delay at [`DELAY_REFERENCE_HZ`] compensated): output
    /// sample `j` stands for input time `offset() + factor() · j`, in input samples.
    #[must_use]
    pub fn time_offset(&self) -> f64 {
        // Stage i keeps the output completed by its input 2m + 1 (input sample period s = 2^i).
        let mut a = 0.0f64;
        let mut s = 1.0f64;
        for _ in &self.stages[..self.n_stages] {
            a += s;
            s *= 2.0;
        }
        a - self.group_delay()
    }

    /// Feeds one input sample; returns an analysis-rate sample when one is complete.
    #[inline]
    pub fn process(&self, state: &mut DecimatorState, x: f32) -> Option<f32> {
        self.process_lanes(state, [x]).map(|[y]| y)
    }

    /// [`Decimator::process`] for `L` channels at once (one sample of each).
    #[inline]
    pub fn process_lanes<const L: usize>(
        &self,
        state: &mut DecimatorState<L>,
        x: [f32; L],
    ) -> Option<[f32; L]> {
        // Unrolled over the (at most three) stages: a loop over `stages[..n_stages]` made the front end
        // ≈ 14 % dearer on the Cortex-M4F.
        let [s0, s1, s2] = &mut state.stages;
        let [k0, k1, k2] = self.stages;
        if self.n_stages == 0 {
            return Some(x);
        }
        // The ½ of every stage is applied at the last one (see `pair_out`).
        let n = self.n_stages;
        let v = halfband_step(k0, s0, x, if n == 1 { 0.5 } else { 1.0 })?;
        if n == 1 {
            return Some(v);
        }
        let v = halfband_step(k1, s1, v, if n == 2 { 0.25 } else { 1.0 })?;
        if n == 2 {
            return Some(v);
        }
        halfband_step(k2, s2, v, 0.125)
    }

    /// The stages that run, first to last.
    #[must_use]
    pub fn stages(&self) -> &[HalfbandKind] {
        &self.stages[..self.n_stages]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tone_gain(rate: u32, freq: f64) -> f64 {
        let d = Decimator::for_rate(rate).unwrap();
        let mut st = DecimatorState::new();
        let mut out = [0.0f32; 4096];
        let mut n_out = 0;
        for n in 0..(4096 * d.factor() as usize) {
            let x = (2.0 * core::f64::consts::PI * freq * n as f64 / rate as f64).sin() as f32;
            if let Some(y) = d.process(&mut st, x) {
                out[n_out] = y;
                n_out += 1;
            }
        }
        let tail = &out[1024..n_out];
        let p: f64 = tail.iter().map(|v| (*v as f64).powi(2)).sum::<f64>() / tail.len() as f64;
        (2.0 * p).sqrt()
    }

    #[test]
    fn passband_is_flat_and_aliases_are_rejected() {
        for f in [200.0, 1000.0, 3000.0, 4000.0] {
            let g = tone_gain(48000, f);
            assert!((g - 1.0).abs() < 0.01, "48k passband {f} Hz: gain {g}");
        }
        // Components that would alias into 0–4 kHz at 12 kHz output.
        for f in [8500.0, 11000.0, 13000.0, 16000.0, 20500.0, 23000.0] {
            let g = tone_gain(48000, f);
            assert!(g < 0.0032, "48k alias {f} Hz: gain {g} (> −50 dB)");
        }
        assert!((tone_gain(16000, 1000.0) - 1.0).abs() < 1e-3);
    }

    #[test]
    fn aliases_into_the_band_are_rejected_by_50_db() {
        let mut worst = 0.0f64;
        for i in 0..=16 {
            let fo = 250.0 * i as f64;
            for f in [12000.0 - fo, 12000.0 + fo, 24000.0 - fo] {
                worst = worst.max(tone_gain(48000, f));
            }
        }
        let db = 20.0 * worst.log10();
        assert!(db < -50.0, "worst alias into 0–4 kHz: {db:.1} dB");
    }

    /// Phase (radians) of the output against a 1 kHz cosine placed at the times `time_offset`
    /// assigns: 0 when the delay is compensated.
    fn phase_error_at(rate: u32, freq: f64) -> f64 {
        let d = Decimator::for_rate(rate).unwrap();
        let mut st = DecimatorState::new();
        let (mut re, mut im) = (0.0f64, 0.0f64);
        let mut j = 0usize;
        let w = 2.0 * core::f64::consts::PI * freq / f64::from(rate);
        for n in 0..(2048 * d.factor() as usize) {
            let x = (w * n as f64).cos() as f32;
            if let Some(y) = d.process(&mut st, x) {
                if j >= 512 {
                    // Hann-weighted, so the negative frequency does not leak into the estimate.
                    let h = libm::sin(core::f64::consts::PI * (j - 512) as f64 / 1536.0).powi(2);
                    let t = d.time_offset() + f64::from(d.factor()) * j as f64;
                    re += h * f64::from(y) * (w * t).cos();
                    im += h * f64::from(y) * (w * t).sin();
                }
                j += 1;
            }
        }
        libm::atan2(im, re)
    }

    #[test]
    fn group_delay_matches_time_offset() {
        for rate in [24_000, 44_100, 48_000, 96_000] {
            // At the reference frequency the group delay (the slope of the phase) is compensated …
            let df = 20.0;
            let slope = (phase_error_at(rate, DELAY_REFERENCE_HZ + df)
                - phase_error_at(rate, DELAY_REFERENCE_HZ - df))
                / (2.0 * core::f64::consts::PI * 2.0 * df)
                * f64::from(rate);
            assert!(
                slope.abs() < 1e-3,
                "{rate} Hz: delay error {slope} samples at 1 kHz"
            );
            // … and across the band the delay stays within a fraction of an input sample of it.
            for f in [200.0, 2000.0, 3000.0] {
                let e = phase_error_at(rate, f);
                let samples = e / (2.0 * core::f64::consts::PI * f) * f64::from(rate);
                assert!(samples.abs() < 1.0, "{rate} Hz, {f} Hz: {samples} samples");
            }
        }
        let d = Decimator::for_rate(48_000).unwrap();
        assert!(
            (d.group_delay() - 5.647).abs() < 1e-3,
            "{}",
            d.group_delay()
        );
    }

    #[test]
    fn unknown_rate_is_an_error() {
        assert_eq!(
            Decimator::for_rate(8000),
            Err(Error::UnsupportedSampleRate { got: 8000 })
        );
    }
}
