//! A deterministic four-channel test scene (48 kHz, or any rate the core takes), generated in code
//! (no fixture files).
//!
//! A talker-like source — noise bursts and a buzzy harmonic voice under a syllable-rate envelope, with
//! pauses — moves between a few azimuths; it reaches the capsules through ideal gains (omni 1,
//! cardioid ½ + ½·cos(φ − θ_m)), and every capsule adds its own low-level noise (a crude diffuse field).
//! Only `+ − ×` and one `cosf` per segment: cheap enough to run on the emulated target.

use cma_core::{CARDIOID_LOOK_DEG, CHANNELS};

/// Input sample rate of the scene of [`Scene::new`], Hz.
pub const RATE_HZ: u32 = 48_000;
/// Input samples per analysis hop of the core at 48 kHz (the longest hop of any rate).
pub const HOP_SAMPLES: usize = 1024;
/// Length of the scene in hops (≈ 3.0 s).
pub const SCENE_HOPS: usize = 141;

/// Input samples per analysis hop of the core at `rate_hz` ([`cma_core::HOP`] times the decimation
/// factor: 1024 at 48 kHz, 256 at 16 kHz); [`HOP_SAMPLES`] for a rate the core does not take.
#[must_use]
pub fn hop_samples(rate_hz: u32) -> usize {
    cma_core::decimator::Decimator::for_rate(rate_hz)
        .map_or(HOP_SAMPLES, |d| cma_core::HOP * d.factor() as usize)
}
/// Source azimuths of the segments, degrees.
const AZIMUTHS_DEG: [f32; 4] = [30.0, 150.0, -100.0, 75.0];

/// xorshift32 pseudo-random generator.
#[derive(Debug, Clone, Copy)]
struct Rng(u32);

impl Rng {
    fn next_u32(&mut self) -> u32 {
        let mut x = self.0;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.0 = x;
        x
    }

    /// Uniform in [−1, 1).
    fn uniform(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (2.0 / 16_777_216.0) - 1.0
    }
}

/// The scene generator; [`Scene::fill`] produces consecutive blocks.
#[derive(Debug, Clone)]
pub struct Scene {
    n: u32,
    /// Samples per syllable (¼ s), per source position segment (¾ s), and the voice's pitch step
    /// per sample per hertz.
    syllable: u32,
    segment: u32,
    per_sample: f32,
    /// One-pole coefficients of the noise band pass and of the voice (their corner frequencies
    /// fixed whatever the rate).
    lp_a: f32,
    hp_a: f32,
    voice_a: f32,
    rng: Rng,
    gains: [f32; CHANNELS],
    /// Band-pass state of the noise component (two one-pole sections).
    lp: f32,
    hp: f32,
    /// Phase of the voice in [0, 1).
    phase: f32,
    /// Low-pass state of the voice.
    voice: f32,
}

impl Default for Scene {
    fn default() -> Self {
        Self::new()
    }
}

impl Scene {
    /// The scene at sample 0, at 48 kHz.
    #[must_use]
    pub fn new() -> Self {
        Self::at_rate(RATE_HZ)
    }

    /// The scene at sample 0, at `rate_hz` (> 0): the same sound, sampled at that rate.
    #[must_use]
    pub fn at_rate(rate_hz: u32) -> Self {
        let rate_hz = rate_hz.max(1);
        // A one-pole with coefficient a at 48 kHz: the coefficient with the same corner at rate_hz.
        let scaled = |a: f32| 1.0 - libm::powf(1.0 - a, RATE_HZ as f32 / rate_hz as f32);
        Self {
            n: 0,
            syllable: (rate_hz / 4).max(1),
            segment: (rate_hz / 4 * 3).max(1),
            per_sample: 1.0 / rate_hz as f32,
            lp_a: scaled(0.3),
            hp_a: scaled(0.04),
            voice_a: scaled(0.2),
            rng: Rng(0x1234_5678),
            gains: [0.0; CHANNELS],
            lp: 0.0,
            hp: 0.0,
            phase: 0.0,
            voice: 0.0,
        }
    }

    fn set_position(&mut self, az_deg: f32) {
        self.gains[0] = 1.0;
        for (g, look) in self.gains[1..].iter_mut().zip(CARDIOID_LOOK_DEG) {
            *g = 0.5 + 0.5 * libm::cosf((az_deg - look) * (core::f32::consts::PI / 180.0));
        }
    }

    /// Syllable envelope in [0, 1]: 4 syllables per second, a pause every fourth, smooth edges.
    fn envelope(&self, n: u32) -> f32 {
        let syl = n / self.syllable;
        if syl % 4 == 3 {
            return 0.0;
        }
        let t = (n % self.syllable) as f32 / self.syllable as f32;
        let tri = 1.0 - libm::fabsf(2.0 * t - 1.0);
        tri * tri * (3.0 - 2.0 * tri)
    }

    /// Writes the next `out.len()` sample frames (omni, card 0°, card 120°, card 240°; full scale ±1).
    pub fn fill(&mut self, out: &mut [[f32; CHANNELS]]) {
        for frame in out.iter_mut() {
            if self.n.is_multiple_of(self.segment) {
                let seg = (self.n / self.segment) as usize % AZIMUTHS_DEG.len();
                self.set_position(AZIMUTHS_DEG[seg]);
            }
            let env = self.envelope(self.n);
            // Unvoiced part: white noise through a band pass of roughly 300 Hz–3 kHz.
            let w = self.rng.uniform();
            self.lp += self.lp_a * (w - self.lp);
            self.hp += self.hp_a * (self.lp - self.hp);
            let noise = self.lp - self.hp;
            // Voiced part: a sawtooth whose pitch glides with the syllable, softened by a one-pole.
            let f0 = 110.0 + 60.0 * env;
            self.phase += f0 * self.per_sample;
            if self.phase >= 1.0 {
                self.phase -= 1.0;
            }
            self.voice += self.voice_a * ((2.0 * self.phase - 1.0) - self.voice);
            let s = env * (0.25 * self.voice + 0.3 * noise);
            for (y, g) in frame.iter_mut().zip(self.gains) {
                *y = g * s + 0.002 * self.rng.uniform();
            }
            self.n += 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn is_deterministic_and_in_range() {
        let (mut a, mut b) = (Scene::new(), Scene::new());
        let mut x = [[0.0f32; CHANNELS]; 4096];
        let mut y = [[0.0f32; CHANNELS]; 4096];
        let mut energy = 0.0f32;
        for _ in 0..12 {
            a.fill(&mut x);
            b.fill(&mut y);
            assert_eq!(x, y);
            assert!(x.iter().flatten().all(|v| v.abs() < 1.0));
            energy += x.iter().map(|f| f[0] * f[0]).sum::<f32>();
        }
        assert!(energy > 10.0, "energy {energy}");
    }
}
