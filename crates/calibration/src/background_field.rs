//! The stationary background field: what the room's steady sound — diffuse noise, a fan, a
//! projector, an air vent, mains hum — is, measured per frequency band for the installer's
//! noise-field report ([`BackgroundFieldState::band_summary`]: the wire's background line, `host-sim
//! monitor` and `locate`), and per bin for the similarity's front end
//! ([`BackgroundFieldState::excess`]: what a directional source adds to every peak, taken off).
//!
//! # Estimate
//! Per band ([`BG_BANDS`]: below and above [`BG_BAND_EDGES_HZ`]): the band's omni power, its floor
//! (the minimum, rising at most [`BackgroundField::rise_db_per_s`]), and in frames where the band is
//! within [`BackgroundField::background_db`] of its floor ("background") the sums of Re(X_c·X_0*)
//! over its peaks with the cardioids as the similarity sees them (after the self-calibration's
//! correction), relative to Σ|X_0|²: the active ratios. Each such frame's ratios join a running
//! mean over about [`BackgroundField::memory_frames`] background frames. A diffuse background gives
//! ½ for every cardioid; a source from θ alone 0.5 + 0.5·cos(θ − φ_c); a source in diffuse noise lies
//! between, and the zero-mean part of the three ratios points at the source.
//!
//! # The stationary excess, taken off the peaks
//! A talker's peak at bin k holds the background's cross-powers too: in expectation
//! Re(X_c·X_0*) = S_c + N·Y_c, with N·Y_c the background's, which is N/2 for a diffuse one. What
//! a directional source adds beyond that, the excess E_c = N·(Y_c − ½), pulls the peak's active
//! ratios toward the source, the more the weaker the talker is in that bin. So every bin below
//! [`EXCESS_BINS`] keeps a running mean of Re(X_c·X_0*) − ½|X_0|² over its background peaks (the
//! first ten averaged equally, then a memory of about ten; each bin is a peak of a background frame
//! now and then), and while its band's background is directional (directivity above
//! [`BackgroundField::excess_directivity`], with 8 background frames behind the band's means)
//! every peak's cardioids become X_c − (E_c/|X_0|²)·X_0: the active ratios less the excess's
//! share, what the talker and a diffuse background would give. In diffuse
//! backgrounds the excess is noise about 0, which would only add to the features' spread: hence
//! the directivity gate. Measured (`scripts/validate`, full run, CHANGELOG): a white-noise
//! loudspeaker 10 dB below a static talker in a room 68.9 → 97.7 % ACC10; the noise-source kinds
//! 6–12 dB below +0.9 to +1.3 points; the diffuse kinds unchanged.
//!
//! # The recording's first frames
//! A recording that starts with a source switched on with it (a scene rendered from silence, a
//! loudspeaker plugged in with the board) opens with frames far below the background's steady
//! power: the first frame holds the source's first milliseconds only, and the room's response to it
//! grows for about 0.11·RT60 (to within 1 dB), 15–19 dB over the first 4–6 frames. A floor started
//! there stays that low for seconds (it rises [`BackgroundField::rise_db_per_s`]), no frame counts
//! as background meanwhile, and the excess is not taken off while the source pulls the talker's
//! peaks (`scripts/validate`, kind `loudspeaker_late`). So while a band's power has risen in every
//! frame since the first, its floor is the frame's power and the frame is not background; the
//! first frame that does not rise ends that, and the floor is a minimum from there. A recording
//! that opens in its steady background (the usual case) ends it at its first or second frame,
//! and a talker who speaks after it cannot lift the floor. Restarting the floors at a fixed time
//! instead (0.125 s) started them on the first words of a talker who speaks from the start (the
//! eval folder's walker: 1.96 → 2.52° MAE); leaving the first 0.125 s out cost imperfect arrays'
//! cold starts.
//!
//! The first way tried was to mix the noisy references (thesis §5.1.5) toward the band's measured
//! Y_b instead of the diffuse ½; it needed a per-band row cache and paid only with the
//! self-calibration off (docs/history.md).
//!
//! State: per band a floor, 4 running values and a count (≈ 0.1 KB), per bin three bfloat16
//! excesses (≈ 1.1 KB). Work per hop: a sum over the analysis band's omni powers; on background
//! bands seven multiply–adds per peak; on directional bands three complex multiply–adds per peak.

use crate::band_floors::BandFloors;
use crate::features::Feature;
use crate::{CARDIOIDS, NUM_BINS};
use microfft::Complex32;

/// Number of frequency bands with their own background feature.
pub const BG_BANDS: usize = 2;

/// Bins with a stationary excess of their own, the lowest: 187 reach the analysis band's default
/// top, 4 kHz, at every analysis rate (11 025 Hz: bin 186); ≈ 1.1 KB of state.
pub const EXCESS_BINS: usize = 187;

/// `x` as bfloat16: the upper 16 bits of its f32, rounded to nearest, ties to even (finite `x`
/// whose rounding stays finite).
fn to_bf16(x: f32) -> u16 {
    let b = x.to_bits();
    ((b + 0x7FFF + ((b >> 16) & 1)) >> 16) as u16
}

/// The f32 of bfloat16 `h`.
fn from_bf16(h: u16) -> f32 {
    f32::from_bits(u32::from(h) << 16)
}

/// Memory of a bin's excess in background peaks: the first this many average equally, then each
/// weighs 1/this in a running mean.
const EXCESS_PEAKS: f32 = 10.0;

/// Background frames a band's means rest on before its excess is taken off.
const EXCESS_MIN_FRAMES: f32 = 8.0;

/// Upper edges of the bands, Hz (the last band runs to Nyquist).
pub const BG_BAND_EDGES_HZ: [f32; BG_BANDS - 1] = [1000.0];

/// Settings of the background field.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct BackgroundField {
    /// Whether the stage measures the background.
    pub enabled: bool,
    /// A band of a frame is background when its omni power is at most this many dB above the
    /// band's floor.
    pub background_db: f32,
    /// Largest rise of a band's floor, dB per second (how soon a source switched on counts as
    /// background).
    pub rise_db_per_s: f32,
    /// Memory of the running mean, in background frames.
    pub memory_frames: f32,
    /// Directivity of a band's background above which its stationary excess is taken off the
    /// peaks ([`BackgroundFieldState::excess`]); 1 or more: never.
    pub excess_directivity: f32,
}

impl BackgroundField {
    /// The stage off: nothing measured.
    pub const OFF: Self = Self {
        enabled: false,
        background_db: 3.0,
        rise_db_per_s: 2.0,
        memory_frames: 100.0,
        excess_directivity: 0.1,
    };

    /// The product's setting: measured.
    pub const DEFAULT: Self = Self {
        enabled: true,
        ..Self::OFF
    };

    /// Whether the settings are usable: finite, background dB ≥ 0, rise ≥ 0, memory ≥ 1 frame,
    /// excess directivity ≥ 0.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.background_db >= 0.0
            && self.background_db.is_finite()
            && self.rise_db_per_s >= 0.0
            && self.rise_db_per_s.is_finite()
            && self.memory_frames >= 1.0
            && self.memory_frames.is_finite()
            && self.excess_directivity >= 0.0
            && self.excess_directivity.is_finite()
    }
}

/// One band's running means of Re(X_c·X_0*)/|X_0|², and their evidence.
#[derive(Debug, Clone, Copy, PartialEq)]
struct BandMeans {
    active: Feature,
    /// Background frames seen (saturating at the memory).
    n: f32,
}

/// This frame's sums of one band.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FrameSums {
    xw: Feature,
    ww: f32,
}

impl FrameSums {
    const ZERO: Self = Self {
        xw: [0.0; CARDIOIDS],
        ww: 0.0,
    };
}

/// The stage's state: per band the floor, whether this frame is background, and the means.
#[derive(Debug, Clone)]
pub struct BackgroundFieldState {
    settings: BackgroundField,
    /// Each band's power, floor and whether it is background in this frame.
    bands: BandFloors<BG_BANDS>,
    frame: [FrameSums; BG_BANDS],
    means: [BandMeans; BG_BANDS],
    pole: f32,
    /// Whether each band's background is directional enough for its excess to be taken off.
    subtracting: [bool; BG_BANDS],
    /// Whether a source dominates each band's background ([`BackgroundFieldState::source_dominates`]).
    dominated: [bool; BG_BANDS],
    /// Each bin's stationary excess E[Re(X_c·X_0*)] − ½·E|X_0|² over background frames, as
    /// bfloat16 (the upper half of the f32's bits: 8 significant bits are plenty for a running
    /// mean of ten noisy values, and half the RAM).
    excess: [[u16; CARDIOIDS]; EXCESS_BINS],
    /// Background peaks behind each bin's excess, up to [`EXCESS_PEAKS`].
    excess_peaks: [u8; EXCESS_BINS],
    /// Whether each band's power has risen in every frame since the first (its floor follows it).
    rising: [bool; BG_BANDS],
}

impl BackgroundFieldState {
    /// An idle state (the stage off).
    #[must_use]
    pub const fn idle() -> Self {
        Self {
            settings: BackgroundField::OFF,
            bands: BandFloors::idle(),
            frame: [FrameSums::ZERO; BG_BANDS],
            means: Self::idle_means(),
            pole: 1.0,
            subtracting: [false; BG_BANDS],
            dominated: [false; BG_BANDS],
            excess: [[0; CARDIOIDS]; EXCESS_BINS],
            excess_peaks: [0; EXCESS_BINS],
            rising: [true; BG_BANDS],
        }
    }

    /// The means before any background frame.
    const fn idle_means() -> [BandMeans; BG_BANDS] {
        [BandMeans {
            active: [0.5; CARDIOIDS],
            n: 0.0,
        }; BG_BANDS]
    }

    /// Makes this state a fresh one for `settings` at analysis rate `fs` Hz (`frames_per_s`
    /// analysis frames per second), in place.
    pub fn reset(&mut self, settings: BackgroundField, fs: f32, frames_per_s: f32) {
        // Field by field: the excess table is too large for a temporary on the boards' stack.
        self.frame = [FrameSums::ZERO; BG_BANDS];
        self.means = Self::idle_means();
        self.subtracting = [false; BG_BANDS];
        self.dominated = [false; BG_BANDS];
        self.excess.fill([0; CARDIOIDS]);
        self.excess_peaks.fill(0);
        self.rising = [true; BG_BANDS];
        self.settings = settings;
        self.bands = BandFloors::new(
            &BG_BAND_EDGES_HZ,
            fs,
            frames_per_s,
            settings.rise_db_per_s,
            settings.background_db,
        );
        self.pole = 1.0 / settings.memory_frames;
    }

    /// The settings.
    #[must_use]
    pub fn settings(&self) -> &BackgroundField {
        &self.settings
    }

    /// Starts a frame from the omni powers of the bins `lo..=hi` (the analysis band): each band's
    /// power, floor and whether it is background (never when not `clean`). While a band's power
    /// has risen in every frame since the first, its floor is that frame's power and the frame is
    /// not background (module documentation).
    pub fn begin_frame(&mut self, omni_power: &[f32; NUM_BINS], lo: usize, hi: usize, clean: bool) {
        let before = self.bands.power;
        self.bands.begin_frame(omni_power, lo, hi, clean);
        for b in 0..BG_BANDS {
            let p = self.bands.power[b];
            if self.rising[b] && before[b] > 0.0 {
                if p > before[b] {
                    self.bands.floor[b].set(p);
                    self.bands.background[b] = false;
                } else {
                    self.rising[b] = false;
                }
            }
        }
        self.frame = [FrameSums::ZERO; BG_BANDS];
    }

    /// Adds a peak (bin `k`, omni `w`, cardioids `x` as the similarity sees them) to its band's
    /// sums when the band is background in this frame.
    #[inline]
    pub fn add_peak(&mut self, k: usize, w: Complex32, x: &[Complex32; CARDIOIDS]) {
        let band = self.bands.band_of_bin(k);
        if !self.bands.is_background(band) {
            return;
        }
        let s = &mut self.frame[band];
        let ww = w.re * w.re + w.im * w.im;
        s.ww += ww;
        let mut xw = [0.0; CARDIOIDS];
        for m in 0..CARDIOIDS {
            xw[m] = x[m].re * w.re + x[m].im * w.im;
            s.xw[m] += xw[m];
        }
        // Learned only where it can be taken off (a directivity is at most 1).
        let learning = self.settings.excess_directivity < 1.0;
        if let (Some(e), Some(n)) = (
            self.excess.get_mut(k).filter(|_| learning),
            self.excess_peaks.get_mut(k),
        ) {
            // The first peaks average equally (1/n), then the pole takes over.
            if f32::from(*n) < EXCESS_PEAKS {
                *n += 1;
            }
            let g = 1.0 / f32::from(*n);
            for m in 0..CARDIOIDS {
                let old = from_bf16(e[m]);
                let new = old + g * (xw[m] - 0.5 * ww - old);
                if new.is_finite() {
                    e[m] = to_bf16(new);
                }
            }
        }
    }

    /// The stationary excess at bin `k` over what a diffuse background gives the cardioids,
    /// E[Re(X_c·X_0*)] − ½·E|X_0|² (per cardioid, omni power units), when the bin's band has a
    /// directional background (directivity above [`BackgroundField::excess_directivity`]);
    /// `None` otherwise or above [`EXCESS_BINS`]. A peak's cardioids less `excess/|X_0|²·X_0`
    /// have the source's share of the active ratios taken off (see the module documentation).
    #[inline]
    #[must_use]
    pub fn excess(&self, k: usize) -> Option<Feature> {
        let e = self.excess.get(k)?;
        self.subtracting[self.bands.band_of_bin(k)].then(|| e.map(from_bf16))
    }

    /// Whether a stationary source dominates some band's background: its mean active ratios (with
    /// 8 or more background frames behind them) have a directivity above [`DOMINANT_MIN`]. The
    /// noise-floor gate then opens higher above the floor (`NoiseGate::directional_db` of
    /// `cma-analysis`).
    #[must_use]
    pub fn source_dominates(&self) -> bool {
        self.dominated.iter().any(|g| *g)
    }

    /// Ends a frame: each background band's ratios join its running means.
    pub fn end_frame(&mut self) {
        let cap = self.settings.memory_frames;
        for (m, s) in self.means.iter_mut().zip(&self.frame) {
            if !(s.ww > 0.0) || !s.ww.is_finite() {
                continue;
            }
            let inv = 1.0 / s.ww;
            let active = s.xw.map(|v| v * inv);
            if !active.iter().all(|v| v.is_finite()) {
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
            }
        }
        for ((on, dominated), m) in self
            .subtracting
            .iter_mut()
            .zip(&mut self.dominated)
            .zip(&self.means)
        {
            let d = background_direction(&m.active).1;
            *on = m.n >= EXCESS_MIN_FRAMES && d > self.settings.excess_directivity;
            *dominated = *on && d > DOMINANT_MIN;
        }
    }
}

/// Directivity above which a band's background is shown with a direction (a source stands out of
/// the diffuse noise); at or below it the background is shown as diffuse
/// ([`BackgroundBand::is_directional`]). A plane wave mixed with diffuse noise of equal power
/// measures about 0.5, of 4× its power about 0.2. Measured (`scripts/validate`'s scenes, the
/// board's background lines every 10 s from 8 background frames on, docs/history.md): diffuse
/// backgrounds 0.01–0.18 (the highest early, from 29 frames, or through an imperfect array the
/// self-calibration has not corrected yet), a broadband source 6–12 dB below the talker through
/// an ideal array 0.21–0.42 at the end of its scene.
pub const DIRECTIONAL_MIN: f32 = 0.2;

/// Directivity above which a stationary source dominates a band's background
/// ([`BackgroundFieldState::source_dominates`]): the noise-floor gate opens higher above the floor
/// there. Higher than [`DIRECTIONAL_MIN`]: the gate at 0.15 cost the matched array beside a
/// loudspeaker 5 points of ACC10 and moved nothing else (docs/history.md).
pub const DOMINANT_MIN: f32 = 0.3;

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
    /// Whether a source stands out of the band's diffuse noise: directivity above
    /// [`DIRECTIONAL_MIN`].
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
        let floor = self.bands.floor.get(band)?.floor();
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
        s.reset(BackgroundField::DEFAULT, FS, FS / crate::HOP as f32);
        s
    }

    /// A fresh state after 200 background frames, each with two peaks (bins 20 and 100) of random
    /// phase whose active ratios are a source's from `az` degrees for `share` of them and diffuse
    /// noise's ½ for the rest (`share` = 1: the plane wave alone).
    fn learned_from_source(az: f32, share: f32, seed: u32) -> BackgroundFieldState {
        let mut s = state();
        let mut rng = Lcg(seed);
        for _ in 0..200 {
            let mut power = [0.0f32; NUM_BINS];
            let mut peaks = [(Complex32::new(0.0, 0.0), [Complex32::new(0.0, 0.0); 3]); 2];
            for (i, &k) in [20usize, 100].iter().enumerate() {
                let ph = core::f32::consts::TAU * rng.unit();
                let (w, x) = wave(az, Complex32::new(libm::cosf(ph), libm::sinf(ph)));
                let x = x.map(|c| c * share + w * (0.5 * (1.0 - share)));
                power[k] = w.norm_sqr();
                peaks[i] = (w, x);
            }
            s.begin_frame(&power, 10, 300, true);
            for (&k, (w, x)) in [20usize, 100].iter().zip(&peaks) {
                s.add_peak(k, *w, x);
            }
            s.end_frame();
        }
        s
    }

    /// A background switched on with the recording (its first frames 16, 10 and 4 dB below its
    /// steady power, then steady within ±1 dB) is background from its first steady frame on; a
    /// floor started on the first frame, rising 2 dB/s, would count no later frame as background
    /// for seconds. A talker who starts after the first frame whose power fell does not lift it.
    #[test]
    fn a_background_building_up_at_the_start_is_measured_once_it_is_steady() {
        let frames_per_s = (FS / crate::HOP as f32) as usize;
        // The frames within the first second in which every band is background.
        let background_frames = |db_of: &dyn Fn(usize) -> f32| {
            let mut s = state();
            let mut n = 0;
            for i in 0..frames_per_s {
                let power = [libm::powf(10.0, db_of(i) / 10.0); NUM_BINS];
                s.begin_frame(&power, 10, 300, true);
                n += usize::from((0..BG_BANDS).all(|b| s.bands.is_background(b)));
                s.end_frame();
            }
            (n, s.bands.floor(0))
        };
        let steady = |i: usize| [0.0, 1.0, -1.0, 0.5][i % 4];
        let building = |i: usize| match i {
            0 => -16.0,
            1 => -10.0,
            2 => -4.0,
            _ => steady(i),
        };
        // Frames 1–3 rise (not background), then every frame within 3 dB of the floor is.
        let (n, floor) = background_frames(&building);
        assert_eq!(n, frames_per_s - 3);
        // The floor is where a steady start puts it (its quietest frames, 1 dB down).
        let (_, steady_floor) = background_frames(&steady);
        assert!(
            (floor - steady_floor).abs() <= 1e-6 * steady_floor,
            "{floor} against {steady_floor}"
        );
        // Background first (its power falls at frame 2, which ends the start), then a talker
        // 10 dB up for 10 frames: the floor stays, and only his frames (and frame 1, which
        // rose) are not background.
        let talker = |i: usize| {
            if (3..13).contains(&i) {
                10.0
            } else {
                steady(i)
            }
        };
        let (n, _) = background_frames(&talker);
        assert_eq!(n, frames_per_s - 10 - 1);
    }

    /// A directional source alone: every band learns its active ratios, the ideal cardioid's value
    /// at its azimuth, and points at it; louder frames (a talker) are not learned from.
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
            let y = s.means[band].active;
            for c in 0..3 {
                assert!(
                    (y[c] - want[c].re).abs() < 0.03,
                    "band {band} c {c}: {y:?} vs {want:?}"
                );
            }
            let b = s.band_summary(band).unwrap();
            assert!((b.direction_deg - 40.0).abs() < 3.0, "{b:?}");
        }
        // Each peak's bin holds the source's excess over a diffuse background, E|a|²·(y_c − ½)
        // (E|a|² = 7/12 for amplitudes uniform in 0.5–1), within the noise of ten peaks.
        for &k in &bins {
            let e = s
                .excess(k)
                .expect("a directional band's excess is taken off");
            let (dir, _) = background_direction(&e.map(|v| v + 0.5));
            assert!((dir - 40.0).abs() < 3.0, "bin {k}: {e:?}");
            for c in 0..3 {
                let want = 7.0 / 12.0 * (want[c].re - 0.5);
                assert!(
                    (e[c] - want).abs() < 0.4 * want.abs() + 0.02,
                    "bin {k}: {e:?}"
                );
            }
        }
        assert_eq!(s.excess(EXCESS_BINS), None);
        // A plane wave's background is a source's: the noise gate opens higher.
        assert!(s.source_dominates());
        // The gate: a background no more directional than the setting is left alone.
        s.settings.excess_directivity = 1.0;
        s.end_frame();
        assert_eq!(s.excess(bins[0]), None);
        assert!(!s.source_dominates());
    }

    /// A bin's first background peaks average equally (its excess is their mean from the first
    /// one), later ones weigh 1/[`EXCESS_PEAKS`].
    #[test]
    fn a_bins_first_peaks_average_equally() {
        let mut s = state();
        let k = 30;
        let mut power = [0.0f32; NUM_BINS];
        power[k] = 1.0;
        let excess_after = |s: &mut BackgroundFieldState, re: f32| {
            s.begin_frame(&power, 10, 300, true);
            let x = [Complex32::new(re, 0.0); 3];
            s.add_peak(k, Complex32::new(1.0, 0.0), &x);
            s.end_frame();
            s.excess[k].map(from_bf16)
        };
        // Re(X_c·X_0*) − ½|X_0|² of the peaks: 0.25, then 0.75 (mean 0.5), then 0.5.
        assert_eq!(excess_after(&mut s, 0.75), [0.25; 3]);
        assert_eq!(excess_after(&mut s, 1.25), [0.5; 3]);
        for _ in 0..40 {
            excess_after(&mut s, 1.0);
        }
        assert_eq!(s.excess_peaks[k], EXCESS_PEAKS as u8);
        // Past the first ten: one peak of 1.5 moves the mean by a tenth of its distance.
        let e = excess_after(&mut s, 2.0)[0];
        assert!((e - 0.6).abs() < 0.01, "{e}");
    }

    /// The excess's bfloat16 storage: 8 significant bits, rounded to nearest.
    #[test]
    fn bfloat16_keeps_eight_bits() {
        for v in [0.0f32, 1.0, -0.375, 7.123_457, -1234.567, 1e-20] {
            let back = from_bf16(to_bf16(v));
            assert!((back - v).abs() <= v.abs() / 256.0, "{v} → {back}");
        }
        assert_eq!(from_bf16(to_bf16(1.0 + 1.0 / 512.0)), 1.0);
        assert_eq!(
            from_bf16(to_bf16(1.0 + 3.0 / 512.0)),
            1.0 + 1.0 / 64.0 * 0.5
        );
    }

    /// Before any background frame there is no summary; NaN input is never learned.
    #[test]
    fn without_evidence_there_is_no_summary() {
        let mut s = state();
        assert_eq!(s.band_summary(0), None);
        let power = [f32::NAN; NUM_BINS];
        s.begin_frame(&power, 10, 300, true);
        let nan = Complex32::new(f32::NAN, 0.0);
        s.add_peak(20, nan, &[nan; 3]);
        s.end_frame();
        assert_eq!(s.summary(), [None; BG_BANDS]);
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
        assert_eq!(state().band_summary(0), None);
        let s = learned_from_source(40.0, 1.0, 5);
        for b in s.summary() {
            let b = b.expect("evidence in both bands");
            assert!((b.direction_deg - 40.0).abs() < 0.5, "{b:?}");
            assert!(b.directivity > 0.99 && b.is_directional(), "{b:?}");
            assert_eq!(b.frames, 100.0);
            // One bin of power 1: 2/(512·203.08) ≈ −47.16 dB re full-scale mean square.
            assert!((b.level_db + 47.16).abs() < 0.05, "{b:?}");
        }
    }

    /// A source that stands out of diffuse noise without dominating it (directivity between
    /// [`DIRECTIONAL_MIN`] and [`DOMINANT_MIN`]) is shown with its direction, and the noise gate
    /// stays as in diffuse noise; a stronger one is both.
    #[test]
    fn a_weaker_source_is_shown_and_a_dominant_one_also_opens_the_gate_higher() {
        for (share, shown, dominant) in
            [(0.1, false, false), (0.25, true, false), (0.4, true, true)]
        {
            let s = learned_from_source(-70.0, share, 9);
            for b in s.summary() {
                let b = b.expect("evidence in both bands");
                assert!((b.directivity - share).abs() < 1e-3, "{share}: {b:?}");
                assert_eq!(b.is_directional(), shown, "{share}: {b:?}");
                if shown {
                    assert!((b.direction_deg + 70.0).abs() < 0.5, "{share}: {b:?}");
                }
            }
            assert_eq!(s.source_dominates(), dominant, "{share}");
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
        let sum: f32 = (0..crate::FRAME_LEN)
            .map(|n| crate::tables::hamming(n).powi(2))
            .sum();
        assert!((sum - WINDOW_POWER_SUM).abs() < 2e-3, "{sum}");
    }
}
