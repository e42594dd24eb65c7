//! Which bands of a frame hold only the background: each band's omni power, its tracked floor (the
//! minimum, rising at most a set rate) and whether the band is within a set margin of it. The
//! self-calibration ([`crate::capsule_calibration`]) and the background field
//! ([`crate::background_field`]) learn from such bands, each with its own band edges.

use crate::noise_floor::{NoiseFloor, NoiseGate};
use crate::power_ramp::power_ratio_from_db;
use crate::NUM_BINS;

/// `B` bands' powers, floors and background flags for the current frame.
#[derive(Debug, Clone, Copy)]
pub struct BandFloors<const B: usize> {
    /// Each band's bins `start..end`.
    pub(crate) bins: [(u16, u16); B],
    /// Each band's tracked floor (summed omni power).
    pub(crate) floor: [NoiseFloor; B],
    /// This frame's summed omni power of each band (within the analysis band).
    pub(crate) power: [f32; B],
    /// Whether each band is background in this frame.
    pub(crate) background: [bool; B],
    /// Band power over its floor up to which the band is background (power ratio).
    background_ratio: f32,
}

impl<const B: usize> BandFloors<B> {
    /// Placeholder bands (nothing is background) until [`BandFloors::new`].
    #[must_use]
    pub const fn idle() -> Self {
        Self {
            bins: [(0, 0); B],
            floor: [NoiseFloor::idle(); B],
            power: [0.0; B],
            background: [false; B],
            background_ratio: 1.0,
        }
    }

    /// Bands split at `edges_hz` (B − 1 ascending upper edges; an edge belongs to the band above
    /// it, the last band runs to Nyquist) at analysis rate `fs` Hz and `frames_per_s` frames per
    /// second; floors rising at most `rise_db_per_s`; background within `background_db` of them.
    #[must_use]
    pub fn new(
        edges_hz: &[f32],
        fs: f32,
        frames_per_s: f32,
        rise_db_per_s: f32,
        background_db: f32,
    ) -> Self {
        let mut s = Self::idle();
        let band_of = |k: usize| {
            let f = crate::spectrum::bin_frequency(k, fs);
            edges_hz.iter().filter(|e| f >= **e).count()
        };
        for (b, range) in s.bins.iter_mut().enumerate() {
            let start = (0..NUM_BINS)
                .position(|k| band_of(k) >= b)
                .unwrap_or(NUM_BINS);
            let end = (0..NUM_BINS)
                .position(|k| band_of(k) > b)
                .unwrap_or(NUM_BINS);
            *range = (start as u16, end as u16);
        }
        let gate = NoiseGate {
            enabled: true,
            rise_db_per_s,
            ..NoiseGate::OFF
        };
        s.floor = [NoiseFloor::new(&gate, frames_per_s); B];
        s.background_ratio = power_ratio_from_db(background_db);
        s
    }

    /// Forgets the floors and this frame's flags (the bands stay).
    pub fn restart(&mut self) {
        for f in &mut self.floor {
            f.set(f32::NAN);
        }
        self.background = [false; B];
    }

    /// The band of bin `k`: the number of bands before the last that end at or below it.
    #[inline]
    #[must_use]
    pub fn band_of_bin(&self, k: usize) -> usize {
        let k = k as u16;
        self.bins[..B - 1]
            .iter()
            .filter(|(_, end)| *end <= k)
            .count()
    }

    /// Starts a frame from the omni powers of the bins `lo..=hi` (the analysis band): each band's
    /// power, floor and whether it is background (never when not `clean`; a band without positive
    /// finite power is not, and leaves its floor alone).
    pub fn begin_frame(&mut self, omni_power: &[f32; NUM_BINS], lo: usize, hi: usize, clean: bool) {
        for b in 0..B {
            let (start, end) = self.bins[b];
            let start = (start as usize).max(lo);
            let end = (end as usize).min(hi + 1);
            let p: f32 = omni_power.get(start..end).map_or(0.0, |s| s.iter().sum());
            self.power[b] = p;
            self.background[b] = false;
            if !(p > 0.0) || !p.is_finite() {
                continue;
            }
            self.floor[b].update(p, false, false);
            self.background[b] = clean && p <= self.floor[b].floor() * self.background_ratio;
        }
    }

    /// Whether band `b` is background in this frame.
    #[inline]
    #[must_use]
    pub fn is_background(&self, b: usize) -> bool {
        self.background[b]
    }

    /// Whether every band is background in this frame.
    #[must_use]
    pub fn all_background(&self) -> bool {
        self.background.iter().all(|b| *b)
    }

    /// Band `b`'s power in this frame.
    #[must_use]
    pub fn power(&self, b: usize) -> f32 {
        self.power[b]
    }

    /// Band `b`'s tracked floor (NaN before its first frame with power).
    #[must_use]
    pub fn floor(&self, b: usize) -> f32 {
        self.floor[b].floor()
    }
}
