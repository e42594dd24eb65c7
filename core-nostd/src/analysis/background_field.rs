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

/// Directivity above which a band's background is shown with a direction (a source dominates);
/// at or below it the background is shown as diffuse ([`BackgroundBand::is_directional`]). A plane
/// wave mixed with diffuse noise of equal power measures about 0.5, of 4× its power about 0.2.
pub const DIRECTIONAL_MIN: f32 = 0.3;

/// Σ w(n)² of the analysis window (the symmetric Hamming window of [`crate::FRAME_LEN`] = 512
/// samples: 512·0.54² − 2·0.54·0.46·1 + 0.46²·256.5 = 203.0778).
const WINDOW_POWER_SUM: f32 = 203.0778;

/// Factor from a band's summed omni bin power Σ|X_k|² (the unnormalised FFT of the windowed frame,
/// samples at full scale ±1) to the band's mean-square power: 2/(N·Σw²) by Parseval (each bin
/// stands for itself and its mirror).
const BIN_POWER_TO_MEAN_SQUARE: f32 = 2.0 / (crate::FRAME_LEN as f32 * WINDOW_POWER_SUM);

/// Norm of the zero-mean part of a plane wave's active ratios on the ideal array:
/// ½·√(Σ_c cos²(θ − φ_c)) = ½·√(3/2), whatever θ.
const PLANE_WAVE_NORM: f32 = 0.612_372_4;

/// One band's stationary background as an installer reads it: where its net intensity comes from,
/// how directional it is, how loud, and on how many frames that rests
/// ([`BackgroundFieldState::band_summary`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BackgroundBand {
    /// Direction of the background's net intensity, degrees in (−180, 180], counter-clockwise
    /// from cardioid 1 like the estimates: atan2(y, x) of x = Σ_c z_c·cos φ_c,
    /// y = Σ_c z_c·sin φ_c, where z is the band's mean active ratios minus their mean and
    /// φ_c = 0°, 120°, 240° the cardioids' looks. Meaningless when the directivity is near 0.
    pub direction_deg: f32,
    /// Norm of z relative to a plane wave's (½·√(3/2) ≈ 0.612), clamped to [0, 1]: 1 a single
    /// source (plane wave), 0 diffuse (ideal array: z = 0), between a source in diffuse noise.
    pub directivity: f32,
    /// The band's background level: 10·log10 of its omni power floor, as a mean-square power
    /// relative to full scale (a signal of mean square 1, samples in ±1; a full-scale sine is
    /// −3 dB) — the floor of Σ|X_k|² over the band's bins within the analysis band, converted by
    /// Parseval (2/(N·Σw²)) so that it compares with the estimates' `power` (mean-square omni power
    /// of the frame, all frequencies).
    pub level_db: f32,
    /// Background frames the means rest on (saturates at [`BackgroundField::memory_frames`]).
    pub frames: f32,
}

impl BackgroundBand {
    /// Whether a source dominates the band: directivity above [`DIRECTIONAL_MIN`].
    #[must_use]
    pub fn is_directional(&self) -> bool {
        self.directivity > DIRECTIONAL_MIN
    }
}

/// Direction (degrees) and directivity of mean active ratios `y` of the cardioids looking at 0°,
/// 120°, 240° ([`BackgroundBand`]).
#[must_use]
pub fn background_direction(y: &Feature) -> (f32, f32) {
    const COS: [f32; CARDIOIDS] = [1.0, -0.5, -0.5];
    const SIN: [f32; CARDIOIDS] = [0.0, 0.866_025_4, -0.866_025_4];
    let mean = (y[0] + y[1] + y[2]) * (1.0 / 3.0);
    let (mut x, mut yy, mut norm2) = (0.0f32, 0.0f32, 0.0f32);
    for c in 0..CARDIOIDS {
        let z = y[c] - mean;
        x += z * COS[c];
        yy += z * SIN[c];
        norm2 += z * z;
    }
    let directivity = crate::fast_math::sqrtf(norm2) * (1.0 / PLANE_WAVE_NORM);
    let directivity = if directivity < 1.0 { directivity } else { 1.0 };
    let direction = if norm2 > 0.0 {
        libm::atan2f(yy, x).to_degrees()
    } else {
        0.0
    };
    (
        if direction <= -180.0 {
            180.0
        } else {
            direction
        },
        if directivity.is_finite() {
            directivity
        } else {
            0.0
        },
    )
}

/// 10·log10(`p`) for a positive normal `p`, within 10⁻³ dB: the exponent from the bits and
/// ln of the mantissa m ∈ [1, 2) by 2·atanh((m − 1)/(m + 1)) to the 7th power (a display's
/// level; `libm::log10f` costs ≈ 0.2 KB more of Cortex-M4F flash).
fn power_db(p: f32) -> f32 {
    let bits = p.to_bits();
    let e = ((bits >> 23) & 0xFF) as i32 - 127;
    let m = f32::from_bits((bits & 0x007F_FFFF) | 0x3F80_0000);
    let t = (m - 1.0) / (m + 1.0);
    let t2 = t * t;
    let ln_m = 2.0 * t * (1.0 + t2 * (1.0 / 3.0 + t2 * (1.0 / 5.0 + t2 * (1.0 / 7.0))));
    // 10·log10(2) and 10·log10(e).
    3.010_3 * e as f32 + 4.342_944_8 * ln_m
}

impl BackgroundFieldState {
    /// Band `band`'s background ([`BackgroundBand`]) from its running means and floor; `None`
    /// without evidence (the stage off, no background frame yet, or no such band). Read-only:
    /// reading it changes nothing.
    #[must_use]
    pub fn band_summary(&self, band: usize) -> Option<BackgroundBand> {
        let m = self.means.get(band)?;
        let floor = self.floor.get(band)?.floor();
        if !(m.n > 0.0) || !(floor > 0.0) || !floor.is_finite() {
            return None;
        }
        let (direction_deg, directivity) = background_direction(&m.active);
        Some(BackgroundBand {
            direction_deg,
            directivity,
            level_db: power_db(floor * BIN_POWER_TO_MEAN_SQUARE),
            frames: m.n,
        })
    }

    /// Every band's [`BackgroundFieldState::band_summary`], lowest band first.
    #[must_use]
    pub fn summary(&self) -> [Option<BackgroundBand>; BG_BANDS] {
        core::array::from_fn(|b| self.band_summary(b))
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

    /// The summary of a plane-wave background points at its source with directivity 1; diffuse
    /// means (½ each) have directivity 0; a mix lies between.
    #[test]
    fn the_summary_points_at_a_plane_wave_and_calls_diffuse_diffuse() {
        for az in [40.0f32, -150.0, 180.0, 0.0] {
            let (_, x) = wave(az, Complex32::new(1.0, 0.0));
            let (dir, d) = background_direction(&x.map(|c| c.re));
            let err = libm::fmodf(dir - az + 540.0, 360.0) - 180.0;
            assert!(err.abs() < 0.01, "{az}: {dir}");
            assert!((d - 1.0).abs() < 1e-4, "{az}: {d}");
        }
        let (_, d) = background_direction(&[0.5; 3]);
        assert!(d.abs() < 1e-6);
        // Equal powers of a source from 40° and of diffuse noise: halfway.
        let (_, x) = wave(40.0, Complex32::new(1.0, 0.0));
        let (dir, d) = background_direction(&x.map(|c| 0.5 * c.re + 0.25));
        assert!(
            (dir - 40.0).abs() < 0.01 && (d - 0.5).abs() < 1e-3,
            "{dir} {d}"
        );
        // A learned state: the test background from 40°.
        let mut s = state();
        assert_eq!(s.band_summary(0), None);
        let mut rng = Lcg(5);
        for _ in 0..200 {
            let mut power = [0.0f32; NUM_BINS];
            let mut peaks = [(Complex32::new(0.0, 0.0), [Complex32::new(0.0, 0.0); 3]); 2];
            for (i, &k) in [20usize, 100].iter().enumerate() {
                let ph = core::f32::consts::TAU * rng.unit();
                let (w, x) = wave(40.0, Complex32::new(libm::cosf(ph), libm::sinf(ph)));
                power[k] = w.norm_sqr();
                peaks[i] = (w, x);
            }
            s.begin_frame(&power, 10, 300, true);
            for (&k, (w, x)) in [20usize, 100].iter().zip(&peaks) {
                s.add_peak(k, *w, x);
            }
            s.end_frame();
        }
        for b in s.summary() {
            let b = b.expect("evidence in both bands");
            assert!((b.direction_deg - 40.0).abs() < 0.5, "{b:?}");
            assert!(b.directivity > 0.99 && b.is_directional(), "{b:?}");
            assert_eq!(b.frames, 100.0);
            // One bin of power 1: 2/(512·203.08) ≈ −47.16 dB re full-scale mean square.
            assert!((b.level_db + 47.16).abs() < 0.05, "{b:?}");
        }
    }

    /// The level's logarithm agrees with `log10f` over the range of band powers.
    #[test]
    fn power_db_agrees_with_log10() {
        let mut p = 1e-30f32;
        while p < 1e30 {
            let want = 10.0 * f64::from(p).log10();
            assert!((f64::from(power_db(p)) - want).abs() < 1e-3, "{p}");
            p *= 1.37;
        }
    }

    /// The window constant is the analysis window's Σw².
    #[test]
    fn window_power_sum_is_the_hamming_windows() {
        let sum: f32 = crate::tables::HAMMING_512.iter().map(|w| w * w).sum();
        assert!((sum - WINDOW_POWER_SUM).abs() < 2e-3, "{sum}");
    }
}
