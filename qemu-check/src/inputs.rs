//! Input kinds for the per-hop cost of the firmware's configuration: speech, clipping bursts, NaN
//! bursts, silence and full-scale noise, block by block at the board's rate (or any other).
//!
//! Every kind but the NaN bursts is what the board's 24-bit ADCs can deliver: values on the grid of
//! 24-bit codes, saturated to the codes' range (−1 … 1 − 2⁻²³). The NaN bursts cannot come from the
//! ADCs; they are the input guard's other slow path (a host feeding floats).

use crate::scene::Scene;
use cma_core::CHANNELS;

/// What [`Input::fill`] generates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    /// The test scene ([`Scene`]): a talker with pauses at four azimuths, quantised to 24 bits.
    Speech,
    /// The scene 8× louder, saturated at full scale: every voiced syllable clips, the pauses do not.
    ClippingBursts,
    /// The scene with NaN and ±Inf bursts: for 50 ms of every 0.5 s, one value in every 16th sample
    /// frame is not finite (the channel rotates).
    NanBursts,
    /// All zeros.
    Silence,
    /// Independent uniform 24-bit codes over the whole range in every channel.
    FullScaleNoise,
}

impl InputKind {
    /// All kinds, in report order.
    pub const ALL: [InputKind; 5] = [
        InputKind::Speech,
        InputKind::ClippingBursts,
        InputKind::NanBursts,
        InputKind::Silence,
        InputKind::FullScaleNoise,
    ];

    /// The kind with index `i` in [`InputKind::ALL`].
    #[must_use]
    pub fn from_index(i: u32) -> Option<Self> {
        Self::ALL.get(i as usize).copied()
    }

    /// Short name for tables.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            InputKind::Speech => "speech",
            InputKind::ClippingBursts => "clipping bursts",
            InputKind::NanBursts => "NaN bursts",
            InputKind::Silence => "silence",
            InputKind::FullScaleNoise => "full-scale noise",
        }
    }
}

/// 2²³: full scale of a 24-bit code.
const CODE_SCALE: f32 = 8_388_608.0;

/// `v` as the ADC would deliver it: on the grid of 24-bit codes, saturated to their range.
fn quantise(v: f32) -> f32 {
    // `as i32` saturates (and maps NaN to 0); the clamp is the code range.
    let code = ((v * CODE_SCALE) as i32).clamp(-(1 << 23), (1 << 23) - 1);
    code as f32 * (1.0 / CODE_SCALE)
}

/// A generator of one [`InputKind`].
#[derive(Debug, Clone)]
pub struct Input {
    kind: InputKind,
    /// Sample frames per NaN burst period (0.5 s) and per burst (50 ms).
    burst_period: u32,
    burst_len: u32,
    scene: Scene,
    rng: u32,
    n: u32,
}

impl Input {
    /// The start of `kind`'s signal at 48 kHz.
    #[must_use]
    pub fn new(kind: InputKind) -> Self {
        Self::at_rate(kind, crate::scene::RATE_HZ)
    }

    /// The start of `kind`'s signal at `rate_hz` (> 0).
    #[must_use]
    pub fn at_rate(kind: InputKind, rate_hz: u32) -> Self {
        Self {
            kind,
            burst_period: (rate_hz / 2).max(1),
            burst_len: rate_hz / 20,
            scene: Scene::at_rate(rate_hz),
            rng: 0x9e37_79b9,
            n: 0,
        }
    }

    fn next_u32(&mut self) -> u32 {
        let mut x = self.rng;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.rng = x;
        x
    }

    /// Writes the next `out.len()` sample frames.
    pub fn fill(&mut self, out: &mut [[f32; CHANNELS]]) {
        match self.kind {
            InputKind::Silence => out.fill([0.0; CHANNELS]),
            InputKind::FullScaleNoise => {
                for frame in out.iter_mut() {
                    for v in frame.iter_mut() {
                        *v = (self.next_u32() as i32 >> 8) as f32 * (1.0 / CODE_SCALE);
                    }
                }
            }
            InputKind::Speech | InputKind::ClippingBursts | InputKind::NanBursts => {
                self.scene.fill(out);
                let gain = if self.kind == InputKind::ClippingBursts {
                    8.0
                } else {
                    1.0
                };
                for frame in out.iter_mut() {
                    for v in frame.iter_mut() {
                        *v = quantise(gain * *v);
                    }
                }
                if self.kind == InputKind::NanBursts {
                    for (i, frame) in out.iter_mut().enumerate() {
                        let n = self.n + i as u32;
                        if n % self.burst_period < self.burst_len && n.is_multiple_of(16) {
                            let bad = [f32::NAN, f32::INFINITY, f32::NAN, f32::NEG_INFINITY];
                            frame[(n / 16) as usize % CHANNELS] = bad[(n / 64) as usize % 4];
                        }
                    }
                }
            }
        }
        self.n = self.n.wrapping_add(out.len() as u32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds_have_their_properties() {
        let mut buf = [[0.0f32; CHANNELS]; 48_000];
        for rate in [48_000u32, 16_000] {
            let block = &mut buf[..rate as usize];
            for kind in InputKind::ALL {
                let mut input = Input::at_rate(kind, rate);
                input.fill(block);
                let values = block.iter().flatten();
                let non_finite = values.clone().filter(|v| !v.is_finite()).count();
                let at_full_scale = values
                    .clone()
                    .filter(|v| v.is_finite() && v.abs() >= 0.999)
                    .count();
                let on_grid = values
                    .clone()
                    .filter(|v| v.is_finite())
                    .all(|v| (v * CODE_SCALE).fract() == 0.0 && (-1.0..1.0).contains(v));
                assert!(on_grid, "{kind:?} at {rate} Hz");
                // One second: two bursts of 50 ms, one bad value in every 16th sample frame.
                let bursts = 2 * (rate as usize / 20) / 16;
                match kind {
                    InputKind::NanBursts => assert_eq!(non_finite, bursts, "{kind:?} at {rate} Hz"),
                    _ => assert_eq!(non_finite, 0, "{kind:?} at {rate} Hz"),
                }
                let (clipped, extremes) = (rate as usize / 5, rate as usize / 1000);
                match kind {
                    InputKind::ClippingBursts => {
                        assert!(at_full_scale > clipped, "{at_full_scale}")
                    }
                    InputKind::FullScaleNoise => {
                        assert!(at_full_scale > extremes, "{at_full_scale}")
                    }
                    _ => assert_eq!(at_full_scale, 0, "{kind:?} at {rate} Hz"),
                }
            }
        }
    }
}
