//! The stationary background field: what the room's steady sound — diffuse noise, a fan, a
//! projector, an air vent, mains hum — adds to each peak's features, measured per frequency band.
//!
//! # Why
//! The noisy references (thesis §5.1.5, [`crate::noisy_reference`]) compare a peak's features with
//! each reference mixed toward the feature Y_η of the noise: a peak that holds the talker and some
//! noise lies between the two. The thesis takes Y_η from diffuse noise (the active ratio ½ of an
//! ideal array). A directional source does not pull a peak toward ½ but toward its *own* direction's
//! feature, and a peak that holds only the source then matches the source's azimuth as well as any
//! talker: the estimate is pulled toward the fan, and in pauses the fan is all there is.
//!
//! With the active ratios Y_c = Re(X_c·X_0*)/|X_0|² the mix is exact in expectation: a talker of power
//! S and an uncorrelated background of power N with feature Y_b give
//! E[Re(X_c·X_0*)]/E|X_0|² = α·Y(θ) + (1 − α)·Y_b, α = S/(S + N), whatever the background's
//! directions. So this stage measures Y_b per band from the background alone and, with
//! [`BackgroundField::references`], the similarity mixes the references toward it instead of ½. A peak of the source alone then lies at the common
//! end of every azimuth's mixing segment and adds the same to every azimuth: no vote for the
//! source, no estimate in pauses; a peak of talker and source matches the talker's azimuth at the
//! right α. A diffuse background measures Y_b ≈ ½, which is the thesis's noisy reference again;
//! an imperfect array's diffuse background measures where *its* noise lies.
//!
//! # What it pays, and why it is not the default's reference
//! Measured with `scripts/validate` and `host-sim eval` (the noise kinds: a fan, projector, vent or
//! hum 16–22 or 6–12 dB below the talker; even seeds ideal arrays, odd seeds imperfect ones):
//! * on **ideal arrays** mixing toward the measured background changes little (within about a
//!   point of ACC10, self-calibration on or off): what these scenes lose is mostly the settling after
//!   each change of the talker's place and the room's reflections, not votes for the source;
//! * on **imperfect arrays with the self-calibration off** it pays (full suite, all noise seeds:
//!   16–22 dB below 64.4 → 78.2 % ACC10, 6–12 dB below 65.6 → 73.2 %): the measured point is where
//!   *these* capsules put the noise, which the ideal ½ is not;
//! * with the self-calibration on (the default) it does not pay on the full suite (noise kinds −0.6
//!   to −1.5 points), though the quick suite's short scenes gained before the calibration converged.
//!
//! The default therefore measures (for the noise-field report) and mixes toward the table's row.
//!
//! # Estimate
//! Per band ([`BG_BANDS`]: below and above [`BG_BAND_EDGES_HZ`]): the band's omni power, its floor
//! (the minimum, rising at most [`BackgroundField::rise_db_per_s`]), and in frames where the band is
//! within [`BackgroundField::background_db`] of its floor ("background") the sums of Re(X_c·X_0*)
//! and |X_c|² over its peaks with the cardioids as the similarity sees them (after the
//! self-calibration's correction), relative to Σ|X_0|². Each such frame's ratios join a running
//! mean over about [`BackgroundField::memory_frames`] background frames, and the band's feature is
//! shrunk toward the table's noise row while its evidence is small (weight n/(`memory_frames`/2),
//! at most 1). The similarity gets the means every [`PUBLISH_FRAMES`] frames.
//!
//! State: per band a floor, 7 running values, a count and the published point (≈ 0.2 KB in
//! all). Work per hop: a sum over the analysis band's omni powers, and on background bands six
//! multiply–adds per peak; with the references, each publication makes the similarity recompute
//! one band's per-azimuth constants (its row cache holds one row per band).

use crate::features::FeatureKind;
use crate::noise_floor::{NoiseFloor, NoiseGate};
use crate::power_ramp::power_ratio_from_db;
use crate::reference_table::Feature;
use crate::{CARDIOIDS, NUM_BINS};
use microfft::Complex32;

/// Number of frequency bands with their own background feature.
pub const BG_BANDS: usize = 2;

/// Upper edges of the bands, Hz (the last band runs to Nyquist).
pub const BG_BAND_EDGES_HZ: [f32; BG_BANDS - 1] = [1000.0];

/// The band of frequency `f_hz`: the number of edges at or below it.
fn band_of_frequency(f_hz: f32) -> usize {
    BG_BAND_EDGES_HZ.iter().filter(|e| f_hz >= **e).count()
}

/// Settings of the background field.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct BackgroundField {
    /// Whether the stage measures the background (for the noise-field report, and for `references`).
    pub enabled: bool,
    /// Whether the noisy references mix toward the measured background (off: toward the table's
    /// noise row, as in the thesis). Measured: it pays while the self-calibration is off (a measured
    /// table); with the self-calibration on, whose correction makes the background look diffuse, it
    /// does not (CHANGELOG, docs/validation.md).
    pub references: bool,
    /// A band of a frame is background when its omni power is at most this many dB above the
    /// band's floor.
    pub background_db: f32,
    /// Largest rise of a band's floor, dB per second (how soon a source switched on counts as
    /// background).
    pub rise_db_per_s: f32,
    /// Memory of the running mean, in background frames.
    pub memory_frames: f32,
}

impl BackgroundField {
    /// The stage off: nothing measured, references mix toward the table's noise row.
    pub const OFF: Self = Self {
        enabled: false,
        references: false,
        background_db: 3.0,
        rise_db_per_s: 2.0,
        memory_frames: 100.0,
    };

    /// The product's setting: measured (for the report), the references as in the thesis.
    pub const DEFAULT: Self = Self {
        enabled: true,
        ..Self::OFF
    };

    /// Measured, and the noisy references mix toward it.
    pub const MIXED: Self = Self {
        enabled: true,
        references: true,
        ..Self::OFF
    };

    /// Whether the settings are usable: finite, background dB ≥ 0, rise ≥ 0, memory ≥ 1 frame.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.background_db >= 0.0
            && self.background_db.is_finite()
            && self.rise_db_per_s >= 0.0
            && self.rise_db_per_s.is_finite()
            && self.memory_frames >= 1.0
            && self.memory_frames.is_finite()
    }
}

/// One band's running means: Re(X_c·X_0*)/|X_0|² and |X_c|²/|X_0|², and their evidence.
#[derive(Debug, Clone, Copy, PartialEq)]
struct BandMeans {
    active: Feature,
    power: Feature,
    /// Background frames seen (saturating at the memory).
    n: f32,
}

/// This frame's sums of one band.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FrameSums {
    xw: Feature,
    xx: Feature,
    ww: f32,
}

impl FrameSums {
    const ZERO: Self = Self {
        xw: [0.0; CARDIOIDS],
        xx: [0.0; CARDIOIDS],
        ww: 0.0,
    };
}

/// The stage's state: per band the floor, whether this frame is background, and the means.
#[derive(Debug, Clone, Copy)]
pub struct BackgroundFieldState {
    settings: BackgroundField,
    /// Each band's bins `start..end`.
    band_bins: [(u16, u16); BG_BANDS],
    floor: [NoiseFloor; BG_BANDS],
    background: [bool; BG_BANDS],
    frame: [FrameSums; BG_BANDS],
    means: [BandMeans; BG_BANDS],
    background_ratio: f32,
    pole: f32,
    /// Feature kind of the published points.
    kind: FeatureKind,
    /// Per band: the measured feature the similarity uses and its weight against the table's row.
    published: [(Feature, f32); BG_BANDS],
    /// Frames since the reset (the publication schedule).
    frames: u32,
}

/// Each band's measured feature is handed to the similarity every this many frames, the bands in
/// turn (each publication makes the similarity recompute that band's per-azimuth constants once, so
/// one hop does it for one band at most).
pub const PUBLISH_FRAMES: u32 = 16;
const _: () = assert!(
    (PUBLISH_FRAMES as usize).is_multiple_of(BG_BANDS),
    "bands publish in turn"
);

impl BackgroundFieldState {
    /// An idle state (the stage off).
    #[must_use]
    pub const fn idle() -> Self {
        Self {
            settings: BackgroundField::OFF,
            band_bins: [(0, 0); BG_BANDS],
            floor: [NoiseFloor::idle(); BG_BANDS],
            background: [false; BG_BANDS],
            frame: [FrameSums::ZERO; BG_BANDS],
            means: [BandMeans {
                active: [0.5; CARDIOIDS],
                power: [0.5; CARDIOIDS],
                n: 0.0,
            }; BG_BANDS],
            background_ratio: 1.0,
            pole: 1.0,
            kind: FeatureKind::Active,
            published: [([0.5; CARDIOIDS], 0.0); BG_BANDS],
            frames: 0,
        }
    }

    /// Makes this state a fresh one for `settings` at analysis rate `fs` Hz (`frames_per_s`
    /// analysis frames per second), in place.
    pub fn reset(
        &mut self,
        settings: BackgroundField,
        kind: FeatureKind,
        fs: f32,
        frames_per_s: f32,
    ) {
        *self = Self::idle();
        self.settings = settings;
        self.kind = kind;
        let band_of = |k: usize| band_of_frequency(crate::spectrum::bin_frequency(k, fs));
        for (b, range) in self.band_bins.iter_mut().enumerate() {
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
            rise_db_per_s: settings.rise_db_per_s,
            ..NoiseGate::OFF
        };
        self.floor = [NoiseFloor::new(&gate, frames_per_s); BG_BANDS];
        self.background_ratio = power_ratio_from_db(settings.background_db);
        self.pole = 1.0 / settings.memory_frames;
    }

    /// The settings.
    #[must_use]
    pub fn settings(&self) -> &BackgroundField {
        &self.settings
    }

    /// The band of bin `k`.
    #[inline]
    #[must_use]
    pub fn band_of_bin(&self, k: usize) -> usize {
        let k = k as u16;
        self.band_bins[..BG_BANDS - 1]
            .iter()
            .filter(|(_, end)| *end <= k)
            .count()
    }

    /// Starts a frame from the omni powers of the bins `lo..=hi` (the analysis band): each band's
    /// power, floor and whether it is background (never when not `clean`).
    pub fn begin_frame(&mut self, omni_power: &[f32; NUM_BINS], lo: usize, hi: usize, clean: bool) {
        for b in 0..BG_BANDS {
            let (start, end) = self.band_bins[b];
            let start = (start as usize).max(lo);
            let end = (end as usize).min(hi + 1);
            let p: f32 = omni_power.get(start..end).map_or(0.0, |s| s.iter().sum());
            self.background[b] = false;
            self.frame[b] = FrameSums::ZERO;
            if !(p > 0.0) || !p.is_finite() {
                continue;
            }
            self.floor[b].update(p);
            self.background[b] = clean && p <= self.floor[b].floor() * self.background_ratio;
        }
    }

    /// Adds a peak (bin `k`, omni `w`, cardioids `x` as the similarity sees them) to its band's
    /// sums when the band is background in this frame.
    #[inline]
    pub fn add_peak(&mut self, k: usize, w: Complex32, x: &[Complex32; CARDIOIDS]) {
        let band = self.band_of_bin(k);
        if !self.background[band] {
            return;
        }
        let s = &mut self.frame[band];
        s.ww += w.re * w.re + w.im * w.im;
        for m in 0..CARDIOIDS {
            s.xw[m] += x[m].re * w.re + x[m].im * w.im;
            s.xx[m] += x[m].re * x[m].re + x[m].im * x[m].im;
        }
    }

    /// Ends a frame: each background band's ratios join its running means; every
    /// [`PUBLISH_FRAMES`] frames each band's mean is published, the bands in turn.
    pub fn end_frame(&mut self) {
        self.frames = self.frames.wrapping_add(1);
        let phase = self.frames % PUBLISH_FRAMES;
        if phase.is_multiple_of(PUBLISH_FRAMES / BG_BANDS as u32) {
            self.publish((phase / (PUBLISH_FRAMES / BG_BANDS as u32)) as usize);
        }
        let cap = self.settings.memory_frames;
        for (m, s) in self.means.iter_mut().zip(&self.frame) {
            if !(s.ww > 0.0) || !s.ww.is_finite() {
                continue;
            }
            let inv = 1.0 / s.ww;
            let active = s.xw.map(|v| v * inv);
            let power = s.xx.map(|v| v * inv);
            if !active.iter().chain(&power).all(|v| v.is_finite()) {
                continue;
            }
            // The first frames average equally (1/n), then the memory takes over.
            m.n = if m.n + 1.0 < cap { m.n + 1.0 } else { cap };
            let g = if 1.0 / m.n > self.pole {
                1.0 / m.n
            } else {
                self.pole
            };
            for c in 0..CARDIOIDS {
                m.active[c] += g * (active[c] - m.active[c]);
                m.power[c] += g * (power[c] - m.power[c]);
            }
        }
    }

    /// The noise point of band `band` relative to `table_noise` (the reference table's noise row
    /// of the peak's row): the published measured feature, shrunk toward `table_noise` while its
    /// evidence is small. Constant between two publications ([`PUBLISH_FRAMES`]), so that the
    /// similarity's per-azimuth constants stay valid.
    #[inline]
    #[must_use]
    pub fn noise_point(&self, band: usize, table_noise: Feature) -> Feature {
        let (measured, w) = self.published[band.min(BG_BANDS - 1)];
        if !(w > 0.0) {
            return table_noise;
        }
        [0, 1, 2].map(|c| table_noise[c] + w * (measured[c] - table_noise[c]))
    }

    /// Publishes band `band`'s running mean for features of the configured kind with its weight
    /// against the table's row: n/(`memory_frames`/2), at most 1.
    fn publish(&mut self, band: usize) {
        let kind = self.kind;
        let inv_half = 2.0 / self.settings.memory_frames;
        if let (Some(out), Some(m)) = (self.published.get_mut(band), self.means.get(band)) {
            if !(m.n > 0.0) {
                return;
            }
            let measured = match kind {
                FeatureKind::Active => m.active,
                FeatureKind::Magnitude => m.power.map(|p| crate::fast_math::sqrtf(clamp0(p))),
            };
            let w = m.n * inv_half;
            *out = (measured, if w < 1.0 { w } else { 1.0 });
        }
    }
}

fn clamp0(v: f32) -> f32 {
    if v > 0.0 {
        v
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Lcg;

    const FS: f32 = 12_000.0;

    /// Omni and cardioids of a plane wave from `az` degrees with amplitude `a`.
    fn wave(az: f32, a: Complex32) -> (Complex32, [Complex32; CARDIOIDS]) {
        let c = [0.0f32, 120.0, 240.0].map(|l| a * (0.5 + 0.5 * libm::cosf((az - l).to_radians())));
        (a, c)
    }

    fn state() -> BackgroundFieldState {
        let mut s = BackgroundFieldState::idle();
        s.reset(
            BackgroundField::MIXED,
            FeatureKind::Active,
            FS,
            FS / crate::HOP as f32,
        );
        s
    }

    /// A directional source alone: every band learns its feature, the ideal cardioid's value at
    /// its azimuth; louder frames (a talker) are not learned from.
    #[test]
    fn a_directional_background_measures_its_own_feature() {
        let mut s = state();
        let mut rng = Lcg(3);
        let bins = [15usize, 30, 60, 120];
        for frame in 0..300 {
            let loud = frame % 5 == 0;
            let mut power = [0.0f32; NUM_BINS];
            let mut peaks = [(Complex32::new(0.0, 0.0), [Complex32::new(0.0, 0.0); 3]); 4];
            for (i, &k) in bins.iter().enumerate() {
                // Random phase, amplitude 0.5–1.
                let (ph, r) = (core::f32::consts::TAU * rng.unit(), 0.5 + 0.5 * rng.unit());
                let a = Complex32::new(r * libm::cosf(ph), r * libm::sinf(ph));
                let (w, x) = if loud {
                    let (w1, x1) = wave(170.0, a * 10.0);
                    let (w2, x2) = wave(40.0, a);
                    (w1 + w2, [x1[0] + x2[0], x1[1] + x2[1], x1[2] + x2[2]])
                } else {
                    wave(40.0, a)
                };
                power[k] = w.norm_sqr();
                peaks[i] = (w, x);
            }
            // A steady floor under the peaks.
            for (k, p) in power.iter_mut().enumerate() {
                if *p == 0.0 && (10..=300).contains(&k) {
                    *p = 0.01;
                }
            }
            s.begin_frame(&power, 10, 300, true);
            for (&k, (w, x)) in bins.iter().zip(&peaks) {
                s.add_peak(k, *w, x);
            }
            s.end_frame();
        }
        let (_, want) = wave(40.0, Complex32::new(1.0, 0.0));
        for band in 0..BG_BANDS {
            let y = s.noise_point(band, [0.5; 3]);
            for c in 0..3 {
                assert!(
                    (y[c] - want[c].re).abs() < 0.03,
                    "band {band} c {c}: {y:?} vs {want:?}"
                );
            }
        }
    }

    /// Before any background frame the table's noise row is the noise point; NaN input is
    /// never learned.
    #[test]
    fn without_evidence_the_table_row_stands() {
        let mut s = state();
        let row = [0.5, 0.4, 0.6];
        assert_eq!(s.noise_point(0, row), row);
        let power = [f32::NAN; NUM_BINS];
        s.begin_frame(&power, 10, 300, true);
        let nan = Complex32::new(f32::NAN, 0.0);
        s.add_peak(20, nan, &[nan; 3]);
        s.end_frame();
        assert_eq!(s.noise_point(0, row), row);
        assert!(BackgroundField::DEFAULT.is_valid());
        assert!(!BackgroundField {
            memory_frames: 0.5,
            ..BackgroundField::DEFAULT
        }
        .is_valid());
    }
}
