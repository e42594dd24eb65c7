//! Blind self-calibration of the cardioid capsules from the room's ambient (diffuse) sound field.
//!
//! # Model
//! A real first-order capsule m (look φ_m) sees, at one frequency,
//!
//! X_m = a_m·W + b_m·D_m,  D_m = X cos φ_m + Y sin φ_m,
//!
//! with W the omni (the reference, X_0 = W) and X, Y the horizontal dipole components of the field:
//! a_m = g_m(1 − β_m) is the capsule's omni part and b_m = g_m·β_m its dipole part (gain g_m, pattern
//! β_m; the ideal cardioid has a = b = ½). Every feature the locator compares assumes the ideal
//! capsule, so the stage maps each picked bin's cardioid values back to it:
//!
//! X'_m = ½·W + ½·D_m = c1_m·X_m + c0_m·W,  c1_m = ½/b_m,  c0_m = ½ − ½·a_m/b_m.
//!
//! # Estimate
//! From the cross-powers of the frames in which only the background is heard (frame power near
//! the tracked noise floor), per frequency band:
//!
//! * b_m, up to a common factor, from the regression of W on the three cardioids. The looks are
//!   120° apart, so Σ_m D_m = 0 in *any* sound field, and W = Σ_m X_m/b_m / Σ_m a_m/b_m exactly:
//!   the least-squares weights w of W on X_1…X_3 are (1/b_m)/(Σ a/b) whatever the field's
//!   directions (an ideal array gives ⅔ each). No assumption about the background enters, so the
//!   talker's reverberation in it does not bias the patterns. Their common scale does not matter
//!   for the direction (it acts like a change of SNR, which the noisy references absorb): it is set
//!   so that Σb = Σa.
//! * a_m = E[Re(X_m W*)] / E|W|²: in an isotropic diffuse field — the ambient noise and the late
//!   reverberation every room has — the dipole part does not correlate with the omni. The linear
//!   structure cannot tell the omni parts' differences from a field whose dipole correlates with
//!   the omni (a mean intensity), so here the field must be diffuse.
//!
//! The talker's reverberation lingers in the background and is not diffuse: it comes mostly from
//! the talker's side. In a frame with a tracked talker at θ it adds to the omni parts a deviation
//! along cos(θ − φ_m); each frame's deviations (zero-mean over the three cardioids, a point in a
//! plane) are therefore learned only across that pattern, and talkers heard from several places fill in the rest (a ridge keeps what was never
//! observed at the ideal capsule). The tracked θ is off now and then (a reflection, a slip), and
//! each such frame lets some of that deviation through; frames in which the band has fallen to its
//! floor (within 1 dB), where little reverberation is left, teach the whole deviation and so
//! outweigh the leak.
//!
//! The capsules' own (electrical) noise is not part of the field: in a quiet room the dipole part
//! of the background, about a twelfth of the omni power, is soon buried in it. Every capsule
//! signal is a combination of the three field components W, X and Y, so without that noise the
//! 4×4 cross-power matrix of (W, X_1, X_2, X_3) is singular; white noise of equal power σ² in the
//! four capsules adds σ² to all its eigenvalues. Its smallest eigenvalue is therefore σ², and
//! every estimate here is made from the sums with σ² taken off their powers (the regression of W
//! on the cardioids so becomes the total least-squares one). The field's share of every power is
//! then the difference of two nearly equal ones, so a band's estimate with capsule noise s times
//! the field's dipole power counts as (1 + s)² times fewer background peaks (its variance grows by
//! that much; the shrinkage below then waits for more of them). A band whose capsule noise is
//! more than [`MAX_NOISE_SHARE`] times the field's dipole power does not learn (held, as below).
//!
//! The cross-powers check the field: with R_mn = E[Re(X_m X_n*)] / E|W|² − a_m·a_n (the dipole
//! parts' cross-powers, κ·b_m·b_n·cos(φ_m − φ_n) in a diffuse field, κ = ⅓ in 3-D) every
//! normalised R_mn / √(R_mm·R_nn) is −½ for an isotropic field whatever the capsules, while a
//! directional noise source (a fan, a loudspeaker) adds a rank-one part and capsule noise the
//! eigenvalue above cannot remove (unequal in the capsules) a diagonal one that move them. When
//! they stray by more than
//! [`CapsuleCalibration::max_anisotropy`] the background is not diffuse, and the accepted estimate
//! is kept as it was (no drift toward the noise source). Speech frames are never used, so a
//! talker, static or moving, cannot pull the estimate.
//!
//! A directional source that runs all the time (a fan, a projector, a loudspeaker) need not fail
//! this check, and its net intensity then moves the omni parts' estimate as capsule errors would,
//! but not the dipole parts'. A real capsule's gain and pattern errors move both alike (a = g(1 − β)
//! and b = g·β: a gain error both the same way, a pattern error oppositely), so their spreads
//! across the cardioids are of a size; the omni parts' spread is applied only up to
//! [`CapsuleCalibration::max_omni_spread`] times the dipole parts' (the omni parts' as estimated,
//! the dipole parts' less part of the sampling noise the shrinkage below assigns them, so that
//! young evidence, whose dipole parts spread by their noise alone, does not open the bound). An
//! ideal array then stays nearly ideal beside a noise source, from the first seconds on; capsules
//! whose gain and pattern errors happen to cancel in the dipole parts keep only part of their omni
//! correction.
//!
//! Capsules matched within a few tenths of a dB have small dipole parts' spreads that still let a
//! source through. There the talker decides ([`CapsuleCalibration::speech_check`],
//! [`crate::speech_check`]): a capsule's omni error moves the talker's own sound as it moves the
//! background, a source does not, and the part of the omni parts' correction that the talker's
//! frames do not support is not applied, and what they ask for beyond the background's
//! correction (consistently over the places the talker was heard from) is added: the whole omni
//! correction where a source from power-on held the background's estimate.
//!
//! # Confidence
//! Each band's estimate rests on n background peaks (a forgetting count), and its sampling error
//! falls as 1/√n. Its deviations from the ideal capsule are applied only in so far as they clear
//! that error (a positive-part James–Stein factor per group of deviations, see
//! [`CapsuleCalibration::shrinkage`]): a cold start begins ideal, an ideal array stays
//! uncorrected, and a real imperfection is corrected more fully as the evidence grows. A real
//! capsule's gain and pattern change little from band to band, while the errors of the bands'
//! estimates (sampling noise, and on an ideal array in a room the talker's lingering
//! reverberation, which differs from band to band) do not agree: so each group is split into its
//! mean over the bands, which clears the noise of all the bands' evidence together, and (for the
//! dipole parts, which need no assumption about the field) each band's own rest, which must clear
//! its band's. A cold start's low band, with the fewest background peaks, is thus corrected with
//! what the other bands learned. The omni parts' evidence is also unequal across the plane —
//! along a talker's direction only quiet frames teach — and each of its principal directions is
//! shrunk with its own evidence. The reported confidence is n/(n + [`CONFIDENT_PEAKS`]).
//!
//! State: per band 15 sums and a count (≈ 0.3 KB in all); [`CapsuleEstimate`] (the model, its
//! counts and the talker's shift) is what is saved and restored. Work per hop: six multiply–adds
//! per cardioid and peak for the correction; on background frames ten cross-products per peak, and
//! every 16th background frame the four bands' capsule noise (a 4×4 factorisation and three solves
//! each), solutions and corrections; the speech check's per-peak and per-frame sums ([`crate::speech_check`]).

use crate::band_floors::BandFloors;
use crate::bformat::plane_vector;
use crate::power_ramp::power_ratio_from_db;
use crate::speech_check::SpeechCheck;
use crate::{CARDIOIDS, NUM_BINS};
use microfft::Complex32;

/// Number of frequency bands with their own capsule model.
pub const CAL_BANDS: usize = 4;

/// Upper edges of the bands, Hz (the last band runs to Nyquist).
pub const CAL_BAND_EDGES_HZ: [f32; CAL_BANDS - 1] = [500.0, 1000.0, 2000.0];

/// Background peaks per band at which the confidence is ½.
pub const CONFIDENT_PEAKS: f32 = 1000.0;

/// E|D_m|² / E|W|² of the diffuse field (3-D isotropic): the dipole part's share of the omni
/// power, ⅓ (only the sums that stand for a restored estimate use it).
pub const KAPPA: f32 = 1.0 / 3.0;

/// The band (index into [`CapsuleEstimate::bands`]) that frequency `f_hz` falls in: the number of
/// edges [`CAL_BAND_EDGES_HZ`] at or below it (an edge belongs to the band above it; NaN gives 0).
#[must_use]
pub fn band_of_frequency(f_hz: f32) -> usize {
    CAL_BAND_EDGES_HZ.iter().filter(|e| f_hz >= **e).count()
}

/// Settings of the self-calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct CapsuleCalibration {
    /// Whether the stage runs (estimates and corrects).
    pub enabled: bool,
    /// Whether the estimate keeps learning (off: the start estimate is applied as it is).
    pub adapt: bool,
    /// A band of a frame is background when its power is at most this many dB above the band's
    /// tracked floor.
    pub background_db: f32,
    /// A frame whose similarity curve has a reliability above this (a direction stands out, e.g. a
    /// fan or a loudspeaker as the background) is not learned from.
    pub directional_reliability: f32,
    /// Memory of the estimate, in background frames (forgetting factor 1 − 1/frames).
    pub memory_frames: f32,
    /// Sampling variance of one background peak's contribution to the estimate, times the margin
    /// a deviation from the ideal capsule must clear (see [`CapsuleCalibrationState`]): larger
    /// values correct later and only larger imperfections.
    pub shrinkage: f32,
    /// Largest deviation of a normalised cross-power from −½ for which the background counts as
    /// diffuse.
    pub max_anisotropy: f32,
    /// Largest spread of the omni parts across the three cardioids (the size of their deviations
    /// about their mean) relative to the dipole parts' spread, in the estimate; a larger omni
    /// spread is applied scaled down to it (0: no bound; see the module documentation).
    pub max_omni_spread: f32,
    /// Whether the talker's frames check the omni parts' correction and withdraw what they do
    /// not support (see [`crate::speech_check`]).
    pub speech_check: bool,
}

impl CapsuleCalibration {
    /// The stage off: features from the raw capsule signals (the thesis).
    pub const OFF: Self = Self {
        enabled: false,
        adapt: true,
        background_db: 3.0,
        directional_reliability: 0.5,
        memory_frames: 10_000.0,
        shrinkage: 0.14,
        max_anisotropy: 0.05,
        max_omni_spread: 8.0,
        speech_check: true,
    };

    /// The product's settings.
    pub const DEFAULT: Self = Self {
        enabled: true,
        ..Self::OFF
    };

    /// Whether the settings are usable.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.background_db.is_finite()
            && self.background_db >= 0.0
            && self.memory_frames.is_finite()
            && self.memory_frames >= 1.0
            && self.shrinkage.is_finite()
            && self.shrinkage >= 0.0
            && self.max_anisotropy.is_finite()
            && self.max_anisotropy > 0.0
            && self.max_omni_spread.is_finite()
            && self.max_omni_spread >= 0.0
    }
}

/// One band's capsule model: X_m = a_m·W + b_m·D_m.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct BandModel {
    /// Omni part a_m of each cardioid.
    pub omni_part: [f32; CARDIOIDS],
    /// Dipole part b_m of each cardioid.
    pub dipole_part: [f32; CARDIOIDS],
    /// Background peaks behind the estimate (forgetting count n).
    pub peaks: f32,
}

impl BandModel {
    /// The ideal cardioid, with no evidence.
    pub const IDEAL: Self = Self {
        omni_part: [0.5; CARDIOIDS],
        dipole_part: [0.5; CARDIOIDS],
        peaks: 0.0,
    };

    /// Gain g = a + b of cardioid `m`, dB.
    #[must_use]
    pub fn gain_db(&self, m: usize) -> f32 {
        20.0 * libm::log10f(self.omni_part[m] + self.dipole_part[m])
    }

    /// Pattern β = b / (a + b) of cardioid `m`.
    #[must_use]
    pub fn beta(&self, m: usize) -> f32 {
        self.dipole_part[m] / (self.omni_part[m] + self.dipole_part[m])
    }

    /// Adds n·(the parts of `model`) to the parts and n to the count (n its count; nothing without
    /// evidence).
    // Not inlined: one copy for every band (less flash on the boards).
    #[inline(never)]
    fn add_weighted(&mut self, model: &Self) {
        let n = model.peaks;
        if n > 0.0 {
            self.peaks += n;
            for k in 0..CARDIOIDS {
                self.omni_part[k] += n * model.omni_part[k];
                self.dipole_part[k] += n * model.dipole_part[k];
            }
        }
    }

    /// Whether the values are a plausible first-order cardioid (finite, 0.3 < a, b < 0.75 — gains
    /// within about ±3 dB, β within about 0.3…0.7 — and n ≥ 0).
    #[must_use]
    pub fn is_plausible(&self) -> bool {
        let ok = |v: f32| v > 0.3 && v < 0.75;
        self.omni_part
            .iter()
            .chain(&self.dipole_part)
            .all(|v| ok(*v))
            && self.peaks >= 0.0
            && self.peaks.is_finite()
    }
}

/// The self-calibration's estimate for every band: what is reported, saved and restored.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CapsuleEstimate {
    /// The accepted model per band (lowest band first, edges [`CAL_BAND_EDGES_HZ`]).
    pub bands: [BandModel; CAL_BANDS],
    /// Whether the last background check found the field anisotropic (estimate held).
    pub held: bool,
    /// The talker's shift: what the talker's frames asked for beyond the bands' omni parts, as a
    /// shift (x, y) of the features' plane vector, added to every band's correction (see
    /// [`crate::speech_check`]). It is measured over the places the talker was heard from, so it
    /// is saved with the bands: a board restarted beside a noise source that holds the background's
    /// estimate then starts corrected instead of waiting for the talker to be heard from four
    /// places again.
    pub talker_shift: [f32; 2],
}

/// Largest component of a plausible [`CapsuleEstimate::talker_shift`] (plane-vector units): the
/// omni parts of a plausible cardioid ([`BandModel::is_plausible`]) shift the plane vector by
/// well under this.
pub const MAX_TALKER_SHIFT: f32 = 0.5;

impl CapsuleEstimate {
    /// Ideal capsules, no evidence.
    pub const IDEAL: Self = Self {
        bands: [BandModel::IDEAL; CAL_BANDS],
        held: false,
        talker_shift: [0.0; 2],
    };

    /// Whether `shift` is a plausible [`CapsuleEstimate::talker_shift`] (finite, each component
    /// within ±[`MAX_TALKER_SHIFT`]).
    #[must_use]
    pub fn is_plausible_talker_shift(shift: [f32; 2]) -> bool {
        shift.iter().all(|v| v.abs() <= MAX_TALKER_SHIFT)
    }

    /// Whether the talker's places added a shift (either component not 0).
    #[must_use]
    pub fn has_talker_shift(&self) -> bool {
        self.talker_shift.iter().any(|v| v.abs() > 0.0)
    }

    /// The confidence n/(n + [`CONFIDENT_PEAKS`]) of band `band`, from its count n of background
    /// peaks: ½ where the omni parts' sampling error is about 0.01.
    #[must_use]
    pub fn confidence(&self, band: usize) -> f32 {
        let n = self.bands[band].peaks;
        n / (n + CONFIDENT_PEAKS)
    }

    /// The overall confidence: the smallest band confidence.
    #[must_use]
    pub fn overall_confidence(&self) -> f32 {
        (0..CAL_BANDS)
            .map(|b| self.confidence(b))
            .fold(1.0, f32::min)
    }
}

/// Cross-power sums of one band (normalised by frame power, with forgetting).
#[derive(Debug, Clone, Copy, PartialEq)]
struct BandSums {
    /// Σ|W|².
    ww: f32,
    /// Σ Re(X_m W*).
    xw: [f32; CARDIOIDS],
    /// Σ Re(X_m X_n*): (0,0), (1,1), (2,2), (0,1), (0,2), (1,2).
    xx: [f32; 6],
    /// Forgetting count of peaks.
    n: f32,
    /// Normal equations of the omni parts' deviation z (in the horizontal plane) with each
    /// frame's component along its talker's direction left out: Σ w·P (xx, xy, yy), Σ w·P·z_f.
    plane: [f32; 5],
}

/// sin 120° = √3/2.
const H: f32 = 0.866_025_4;

/// Plane coordinates (x, y) of a zero-mean per-cardioid vector v_m = x cos φ_m + y sin φ_m.
fn to_plane(v: [f32; CARDIOIDS]) -> [f32; 2] {
    // cos φ_m = 1, −½, −½; sin φ_m = 0, √3/2, −√3/2; x = ⅔Σ v_m cos φ_m, y = ⅔Σ v_m sin φ_m.
    [
        (2.0 / 3.0) * (v[0] - 0.5 * (v[1] + v[2])),
        (2.0 / 3.0) * H * (v[1] - v[2]),
    ]
}

/// The per-cardioid vector of plane coordinates `z` (inverse of [`to_plane`] on zero-mean vectors).
fn from_plane(z: [f32; 2]) -> [f32; CARDIOIDS] {
    [z[0], -0.5 * z[0] + H * z[1], -0.5 * z[0] - H * z[1]]
}

/// `v` less its mean.
fn zero_mean(v: [f32; CARDIOIDS]) -> [f32; CARDIOIDS] {
    let mean = (v[0] + v[1] + v[2]) / 3.0;
    v.map(|x| x - mean)
}

/// Adds plane coordinates `z` with weight `weight` to the normal equations `p` (Σ w·P as xx, xy,
/// yy; Σ w·P·z): all of them, or with `across` only their component along that unit vector (P its
/// projector).
fn accumulate(p: &mut [f32; 5], z: [f32; 2], weight: f32, across: Option<(f32, f32)>) {
    match across {
        Some((nx, ny)) => {
            let along = weight * (nx * z[0] + ny * z[1]);
            p[0] += weight * nx * nx;
            p[1] += weight * nx * ny;
            p[2] += weight * ny * ny;
            p[3] += along * nx;
            p[4] += along * ny;
        }
        None => {
            p[0] += weight;
            p[2] += weight;
            p[3] += weight * z[0];
            p[4] += weight * z[1];
        }
    }
}

/// Solves the symmetric 3×3 system (M − shift·I)·w = v by cofactors, M given as the `xx` sums
/// ((0,0), (1,1), (2,2), (0,1), (0,2), (1,2)); `None` unless M − shift·I is positive definite (its
/// leading minors positive) and the solution finite.
// Not inlined: one copy for the regression and the noise's Newton steps (less flash on the boards).
#[inline(never)]
fn solve3(m: &[f32; 6], shift: f32, v: [f32; 3]) -> Option<[f32; 3]> {
    let [m00, m11, m22, m01, m02, m12] = *m;
    let (m00, m11, m22) = (m00 - shift, m11 - shift, m22 - shift);
    let c00 = m11 * m22 - m12 * m12;
    let c01 = m02 * m12 - m01 * m22;
    let c02 = m01 * m12 - m02 * m11;
    let c11 = m00 * m22 - m02 * m02;
    let c12 = m01 * m02 - m00 * m12;
    let c22 = m00 * m11 - m01 * m01;
    let det = m00 * c00 + m01 * c01 + m02 * c02;
    if !(m00 > 0.0) || !(c22 > 0.0) || !(det > 0.0) || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let w = [
        (c00 * v[0] + c01 * v[1] + c02 * v[2]) * inv,
        (c01 * v[0] + c11 * v[1] + c12 * v[2]) * inv,
        (c02 * v[0] + c12 * v[1] + c22 * v[2]) * inv,
    ];
    w.iter().all(|x| x.is_finite()).then_some(w)
}

/// The zero-mean per-cardioid deviation that solves the normal equations `p` (with a ridge), each
/// principal direction of their evidence shrunk by the sampling noise its weaker evidence adds.
///
/// The normal equations of `n` background peaks hold evidence (their eigenvalues λ₁ ≥ λ₂) unequally
/// spread over the plane: along a talker's direction only quiet frames teach. A direction's
/// estimate then has the sampling noise of n·λ/λ̄ peaks (λ̄ their mean) instead of n, and its
/// component is shrunk by the positive-part factor of that excess, `shrinkage`·(λ̄/λ − 1)/n (the
/// noise of n peaks is left to [`add_shrunk_deviations`]). Without it, a cold start heard from one
/// place applies the talker's leak along its direction to an ideal array (validation scenes,
/// docs/self-calibration.md).
// Not inlined: one copy for every caller (less flash on the boards).
#[inline(never)]
fn plane_deviation(p: &[f32; 5], n: f32, shrinkage: f32) -> Option<[f32; CARDIOIDS]> {
    let [xx, xy, yy, rx, ry] = *p;
    let mean = 0.5 * (xx + yy);
    let (rxx, ryy) = (xx + PLANE_RIDGE * mean, yy + PLANE_RIDGE * mean);
    let det = rxx * ryy - xy * xy;
    if !(det > 0.0) || !det.is_finite() || !(n > 0.0) {
        return None;
    }
    let z = [(ryy * rx - xy * ry) / det, (rxx * ry - xy * rx) / det];
    // Eigenvalues mean ± spread; the projector on the first direction is (P − λ₂·I)/(λ₁ − λ₂).
    let spread = crate::fast_math::sqrtf(0.25 * (xx - yy) * (xx - yy) + xy * xy);
    let (l1, l2) = (mean + spread, mean - spread);
    if !(spread > 1e-6 * mean) || !(l2 > 0.0) {
        return Some(from_plane(z));
    }
    let inv = 1.0 / (2.0 * spread);
    let z1 = [
        ((xx - l2) * z[0] + xy * z[1]) * inv,
        (xy * z[0] + (yy - l2) * z[1]) * inv,
    ];
    let z2 = [z[0] - z1[0], z[1] - z1[1]];
    // |from_plane(z)|² = 1.5·|z|².
    let shrunk = |v: [f32; 2], l: f32| {
        let sq = 1.5 * (v[0] * v[0] + v[1] * v[1]);
        let noise = (shrinkage / n * (mean / l - 1.0)).max(0.0);
        let f = shrink_factor(sq, noise);
        v.map(|x| f * x)
    };
    let (z1, z2) = (shrunk(z1, l1), shrunk(z2, l2));
    Some(from_plane([z1[0] + z2[0], z1[1] + z2[1]]))
}

/// The positive-part James–Stein factor of a group of deviations of squared size `sq` whose
/// sampling noise is `noise` (≥ 0): 1 − noise/sq, at least 0 (0 for no deviation).
fn shrink_factor(sq: f32, noise: f32) -> f32 {
    if sq > 0.0 {
        (1.0 - noise / sq).max(0.0)
    } else {
        0.0
    }
}

/// Ridge of the plane's normal equations, relative to their mean eigenvalue: a direction never
/// observed stays at the ideal capsule.
const PLANE_RIDGE: f32 = 0.02;

impl BandSums {
    const ZERO: Self = Self {
        ww: 0.0,
        xw: [0.0; CARDIOIDS],
        xx: [0.0; 6],
        n: 0.0,
        plane: [0.0; 5],
    };

    /// Sums a model would give with unit omni power per peak (restoring a saved estimate).
    fn of_model(m: &BandModel) -> Self {
        let (a, b, n) = (m.omni_part, m.dipole_part, m.peaks);
        let r = |i: usize, j: usize| {
            let cross = if i == j { KAPPA } else { -0.5 * KAPPA };
            n * (a[i] * a[j] + cross * b[i] * b[j])
        };
        let z = to_plane(zero_mean(a));
        Self {
            ww: n,
            xw: a.map(|v| n * v),
            xx: [r(0, 0), r(1, 1), r(2, 2), r(0, 1), r(0, 2), r(1, 2)],
            n,
            plane: [n, 0.0, n, n * z[0], n * z[1]],
        }
    }

    /// Adds one frame's normal equations: its omni parts `xw / ww`, with weight `weight`; with
    /// `talker` (the tracked direction's cosine and sine), only their component across the
    /// pattern the talker's reverberation, which leaks into the background, gives them: across
    /// its direction, (−sin θ, cos θ).
    fn add_plane(&mut self, frame: &Self, weight: f32, talker: Option<(f32, f32)>) {
        if !(frame.ww > 0.0) {
            return;
        }
        let inv = 1.0 / frame.ww;
        let a = frame.xw.map(|v| v * inv);
        accumulate(
            &mut self.plane,
            to_plane(zero_mean(a)),
            weight,
            talker.map(|(c, s)| (-s, c)),
        );
    }

    fn add_scaled(&mut self, other: &Self, keep: f32, scale: f32) {
        self.ww = keep * self.ww + scale * other.ww;
        for m in 0..CARDIOIDS {
            self.xw[m] = keep * self.xw[m] + scale * other.xw[m];
        }
        for k in 0..6 {
            self.xx[k] = keep * self.xx[k] + scale * other.xx[k];
        }
        self.n = keep * self.n + other.n;
        for k in 0..5 {
            self.plane[k] = keep * self.plane[k] + other.plane[k];
        }
    }

    /// The omni parts a = Σ Re(X_m W*)/Σ|W|² and the residual cross-powers R_mn = Σ Re(X_m X_n*)/Σ|W|²
    /// − a_m·a_n: the diagonal (0,0), (1,1), (2,2) and the pairs (0,1), (0,2), (1,2); `None` without
    /// omni power or with a diagonal that is not positive.
    #[allow(clippy::type_complexity)]
    // Not inlined: one copy for its three callers (less flash on the boards).
    #[inline(never)]
    fn residuals(&self) -> Option<([f32; CARDIOIDS], [f32; 3], [f32; 3])> {
        if !(self.ww > 0.0) {
            return None;
        }
        let inv = 1.0 / self.ww;
        let a = self.xw.map(|v| v * inv);
        let r = |k: usize, i: usize, j: usize| self.xx[k] * inv - a[i] * a[j];
        let diag = [r(0, 0, 0), r(1, 1, 1), r(2, 2, 2)];
        let off = [r(3, 0, 1), r(4, 0, 2), r(5, 1, 2)];
        diag.iter().all(|v| *v > 0.0).then_some((a, diag, off))
    }

    /// The normalised cross-powers R_mn / √(R_mm·R_nn) of the pairs (0,1), (0,2), (1,2) (−½ each in
    /// a diffuse field), or `None` without usable sums.
    fn correlations(&self) -> Option<[f32; 3]> {
        let (_, diag, off) = self.residuals()?;
        let sq = crate::fast_math::sqrtf;
        let rho = [
            off[0] / sq(diag[0] * diag[1]),
            off[1] / sq(diag[0] * diag[2]),
            off[2] / sq(diag[1] * diag[2]),
        ];
        rho.iter().all(|v| v.is_finite()).then_some(rho)
    }

    /// How far the normalised cross-powers stray from the diffuse −½ (the largest of the three),
    /// less twice their sampling error 0.75/√n; +∞ without usable sums.
    fn anisotropy(&self) -> f32 {
        match self.correlations() {
            Some(rho) if self.n > 0.0 => {
                let worst = rho.iter().map(|r| (r + 0.5).abs()).fold(0.0f32, f32::max);
                worst - 1.5 / crate::fast_math::sqrtf(self.n)
            }
            _ => f32::INFINITY,
        }
    }

    /// The power of the capsules' own noise in these sums. The four signals are combinations of
    /// the three field components W, X and Y, so without noise W is exactly a combination of the
    /// cardioids (see [`BandSums::dipole_ratios`]) and the 4×4 cross-power matrix of (W, X_1, X_2,
    /// X_3) is singular whatever the field; white noise of equal power σ² in every capsule adds σ²
    /// to its diagonal. σ² is then its smallest eigenvalue, the smallest root of the secular
    /// equation g(σ²) = Σ|W|² − σ² − c·(M − σ²·I)⁻¹·c = 0 (M the cardioids' cross-powers, c their
    /// cross-powers with W; g(0) is the regression's residual power). Found by three Newton steps
    /// from 0 (g′ = −(1 + |w|²), w = (M − σ²·I)⁻¹·c the regression weights); g is concave, so the
    /// first step lands at or above the root and the next come back down to it. 0 when the sums
    /// give no positive value.
    fn self_noise(&self) -> f32 {
        let mut s2 = 0.0f32;
        for _ in 0..3 {
            let Some(w) = solve3(&self.xx, s2, self.xw) else {
                break;
            };
            let fit = w[0] * self.xw[0] + w[1] * self.xw[1] + w[2] * self.xw[2];
            let slope = 1.0 + w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
            let next = s2 + (self.ww - s2 - fit) / slope;
            if !(next >= 0.0) || !next.is_finite() {
                break;
            }
            s2 = next;
        }
        s2
    }

    /// These sums without capsule noise of `noise` per peak: n·noise off the four powers, and the
    /// omni parts' plane equations scaled up by what that noise took off each frame's omni parts
    /// (a frame's X_m·W*/|W|² is the noise-free one times |W|²₀/|W|², the same for all m).
    // Not inlined: one copy for the batch and the total (less flash on the boards).
    #[inline(never)]
    fn without_noise(&self, noise: f32) -> Self {
        let mut out = *self;
        let remove = noise * self.n;
        if !(remove > 0.0) || !(self.ww > remove) {
            return out;
        }
        out.ww -= remove;
        for k in 0..CARDIOIDS {
            out.xx[k] -= remove;
        }
        let undo = self.ww / out.ww;
        out.plane[3] *= undo;
        out.plane[4] *= undo;
        out
    }

    /// The capsule noise `noise` per peak relative to the field's mean dipole power R_mm of these
    /// (noise-free) sums; +∞ without usable sums.
    fn noise_share(&self, noise: f32) -> f32 {
        match self.residuals() {
            Some((_, diag, _)) if self.ww > 0.0 => {
                noise * self.n / self.ww / ((diag[0] + diag[1] + diag[2]) / 3.0)
            }
            _ => f32::INFINITY,
        }
    }

    /// The dipole parts up to a common positive factor: the reciprocals of the weights w of the
    /// least-squares regression of W on the three cardioids (Σ Re(X_m X_n*)·w_n = Σ Re(X_m W*);
    /// w_m = (1/b_m)/Σ(a/b), see the module documentation); `None` when the cardioids'
    /// cross-powers are singular or a weight is not positive.
    fn dipole_ratios(&self) -> Option<[f32; CARDIOIDS]> {
        let w = solve3(&self.xx, 0.0, self.xw)?;
        w.iter().all(|x| *x > 0.0).then(|| w.map(|x| 1.0 / x))
    }

    /// The model of these sums, or `None` when they do not describe a plausible cardioid in a
    /// diffuse field; `shrinkage` as in [`plane_deviation`].
    ///
    /// The capsules' own noise, `noise_share` times the field's dipole power, leaves the field's
    /// share of every power the difference of two nearly equal ones: the estimate's sampling
    /// variance grows by (1 + share)², so it counts as n/(1 + share)² background peaks (its
    /// shrinkage, its weight among the bands and its confidence).
    fn solve(&self, shrinkage: f32, noise_share: f32) -> Option<BandModel> {
        if !(self.n > 0.0) {
            return None;
        }
        let inflation = 1.0 + noise_share.max(0.0);
        let n = self.n / (inflation * inflation);
        let (a, _, off) = self.residuals()?;
        // A diffuse background's dipole parts correlate negatively (R_mn = −½κ·b_m·b_n).
        if !off.iter().all(|v| *v < 0.0) {
            return None;
        }
        let b = self.dipole_ratios()?;
        // Only the ratios of b are measured. A common factor of the dipole parts acts like a change
        // of SNR (the noisy references absorb it); it is set so that the patterns average a
        // cardioid, Σb = Σa.
        let scale = (a[0] + a[1] + a[2]) / (b[0] + b[1] + b[2]);
        let b = b.map(|v| v * scale);
        let mean = (a[0] + a[1] + a[2]) / 3.0;
        let dev = plane_deviation(&self.plane, n, shrinkage)?;
        let model = BandModel {
            omni_part: [mean + dev[0], mean + dev[1], mean + dev[2]],
            dipole_part: b,
            peaks: n,
        };
        model.is_plausible().then_some(model)
    }
}

/// Per-band correction X'_m = c1_m·X_m + c0_m·W.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Correction {
    c1: [f32; CARDIOIDS],
    c0: [f32; CARDIOIDS],
}

impl Correction {
    const IDENTITY: Self = Self {
        c1: [1.0; CARDIOIDS],
        c0: [0.0; CARDIOIDS],
    };

    /// The corrections for the bands' `models`, into `out`. The deviations from the ideal capsule
    /// (see [`add_shrunk_deviations`]) are their mean over the bands (weighted by their evidence)
    /// plus, for the dipole parts, each band's own rest; each part is shrunk by how far it clears
    /// its sampling noise: the shared part with the evidence of all bands, the rest with its
    /// band's. The omni parts have no band rest: theirs rest on the diffuse-field assumption, and
    /// what the talker's reverberation leaves in them differs from band to band (on validation
    /// scenes, band rests of the omni parts cost an ideal array 0.15° after a cold start and gained
    /// an imperfect one nothing, frequency-dependent patterns included). Without evidence in any
    /// band every correction is the identity.
    fn of_bands(
        out: &mut [Self; CAL_BANDS],
        omni_shift: &mut (f32, f32),
        models: &[BandModel; CAL_BANDS],
        shrinkage: f32,
        max_omni_spread: f32,
        omni_scale: f32,
    ) {
        // The evidence-weighted mean model (the deviations are linear in the parts).
        let mut mean = BandModel {
            omni_part: [0.0; CARDIOIDS],
            dipole_part: [0.0; CARDIOIDS],
            peaks: 0.0,
        };
        for m in models {
            mean.add_weighted(m);
        }
        // Without evidence in any band the mean is not finite, and unused: every band's correction
        // is then the identity (`of_band`).
        let inv = 1.0 / mean.peaks;
        for k in 0..CARDIOIDS {
            mean.omni_part[k] *= inv;
            mean.dipole_part[k] *= inv;
        }
        let mut shared = [[0.0; CARDIOIDS]; 2];
        add_shrunk_deviations(&mean, shrinkage, &mut shared);
        if max_omni_spread > 0.0 {
            bound_omni_spread(&mut shared[0], &mean, max_omni_spread, shrinkage);
        }
        // The omni parts' deviations about their mean: scaled by `omni_scale` as applied, and
        // left out for the shift they give the features (the mean over the bands; see
        // `SpeechCheck`).
        let omni_mean = (shared[0][0] + shared[0][1] + shared[0][2]) / 3.0;
        let mut without = shared;
        let mut scaled = shared;
        for m in 0..CARDIOIDS {
            without[0][m] = omni_mean;
            scaled[0][m] = omni_mean + omni_scale * (shared[0][m] - omni_mean);
        }
        *omni_shift = (0.0, 0.0);
        for (c, m) in out.iter_mut().zip(models) {
            let full = Self::of_band(m, &mean, &shared, shrinkage);
            let base = Self::of_band(m, &mean, &without, shrinkage);
            let (sx, sy) = plane_vector([0, 1, 2].map(|k| full.c0[k] - base.c0[k]));
            omni_shift.0 += sx * (1.0 / CAL_BANDS as f32);
            omni_shift.1 += sy * (1.0 / CAL_BANDS as f32);
            *c = Self::of_band(m, &mean, &scaled, shrinkage);
        }
    }

    /// The correction for one band's `model`: the `shared` deviations (shrunk) and the band's own
    /// rest of the dipole parts about the unshrunk `mean` model, shrunk with the band's evidence.
    // Not inlined: one copy for the four bands (less flash on the boards).
    #[inline(never)]
    fn of_band(
        model: &BandModel,
        mean: &BandModel,
        shared: &[[f32; CARDIOIDS]; 2],
        shrinkage: f32,
    ) -> Self {
        if !(model.peaks > 0.0) {
            return Self::IDENTITY;
        }
        // The band's dipole parts less the mean, about the ideal capsule.
        let mut rest = *model;
        for k in 0..CARDIOIDS {
            rest.omni_part[k] = 0.5;
            rest.dipole_part[k] += 0.5 - mean.dipole_part[k];
        }
        // The shared deviations plus the band's own.
        let mut d = *shared;
        add_shrunk_deviations(&rest, shrinkage, &mut d);
        let mut c = Self::IDENTITY;
        for m in 0..CARDIOIDS {
            let am = 0.5 + d[0][m];
            let bm = 0.5 + d[1][m];
            let half_inv = 0.5 / bm;
            c.c1[m] = half_inv;
            c.c0[m] = 0.5 - am * half_inv;
        }
        c
    }
}

/// Share of the dipole parts' sampling noise (as [`add_shrunk_deviations`] counts it) taken off
/// their spread before it bounds the omni parts' ([`bound_omni_spread`]), down to
/// [`DIPOLE_SPREAD_FLOOR`] of the spread. See docs/history.md for the measurements behind both.
const DIPOLE_NOISE_SHARE: f32 = 0.5;

/// Least share of the dipole parts' estimated spread that [`bound_omni_spread`] keeps after taking
/// the noise off: young evidence tightens the bound's ratio to at most half of
/// [`CapsuleCalibration::max_omni_spread`] (4 of 8; about 6 % of uniform draws of the suite's
/// imperfect capsules spread their omni parts more than 4 times their dipole parts, 1–2 % more
/// than 8). Without it an imperfect array with its capsules' own noise (tests/tests/
/// self_calibration.rs, omni parts spread 6.8 times the dipole parts) waited 24 s for its
/// correction (1.52° → 5.77°).
const DIPOLE_SPREAD_FLOOR: f32 = 0.25;

/// Scales the omni parts' applied deviations about their mean, `omni`, down so that the estimate's
/// omni parts spread at most `ratio` times as much across the cardioids as its dipole parts
/// (`model`: the estimate before shrinkage; spread: the size of the deviations about their mean).
///
/// A capsule's omni and dipole parts come from the same gain and pattern, a = g(1 − β) and
/// b = g·β: a gain error moves both alike, a pattern error moves them oppositely, so across the
/// three cardioids the omni parts spread about as much as the dipole parts. What else moves the
/// omni parts' estimate is the field: a directional source in the background (a fan, a projector,
/// a loudspeaker) gives it a net intensity, which the diffuse-field assumption of the omni parts
/// takes for capsule errors. The dipole parts are measured without that assumption (the
/// regression of W on the cardioids holds in any field), so they bound the omni parts: on an
/// ideal array, whose dipole parts spread only by their sampling noise, the omni parts stay
/// nearly ideal whatever the background (validation scenes with a white-noise loudspeaker 10 dB
/// below the talker: ACC10 as with the self-calibration off, instead of a correction toward the
/// loudspeaker).
///
/// The dipole parts' estimated spread is their true spread plus their sampling noise, which
/// [`add_shrunk_deviations`] puts at `shrinkage`·2/n (two degrees of freedom, n background
/// peaks; `shrinkage` includes a margin); the bound uses the spread less
/// [`DIPOLE_NOISE_SHARE`] of that noise, but at least [`DIPOLE_SPREAD_FLOOR`] of the spread. Young
/// evidence, whose dipole parts spread by their noise alone, so holds a matched array's omni parts
/// nearer the ideal, which a source heard from power-on would otherwise move in the first
/// seconds; as the evidence grows the noise vanishes and the bound is the estimate's. What it
/// costs: capsules whose gain and pattern errors happen to cancel in the dipole parts keep only
/// part of their omni correction, and get it a little later.
fn bound_omni_spread(omni: &mut [f32; CARDIOIDS], model: &BandModel, ratio: f32, shrinkage: f32) {
    let n = model.peaks;
    if !(n > 0.0) {
        return;
    }
    let spread = |v: [f32; CARDIOIDS]| {
        let z = zero_mean(v);
        z[0] * z[0] + z[1] * z[1] + z[2] * z[2]
    };
    let sa = spread(model.omni_part);
    let sb = spread(model.dipole_part);
    let sb = (sb - DIPOLE_NOISE_SHARE * 2.0 * shrinkage / n).max(DIPOLE_SPREAD_FLOOR * sb);
    let limit = ratio * ratio * sb;
    if sa > limit && sa > 0.0 {
        let f = crate::fast_math::sqrtf(limit / sa);
        let mean = (omni[0] + omni[1] + omni[2]) / 3.0;
        for v in omni.iter_mut() {
            *v = mean + f * (*v - mean);
        }
    }
}

/// Adds to `out` the deviations of `model` from the ideal capsule — of its omni parts and of its
/// dipole parts, each including the common gain — with each group shrunk by how far it clears its
/// sampling noise `shrinkage`·dof/n (positive-part James–Stein; n the model's background peaks):
/// the common gain (1 degree of freedom), the omni parts about their mean and the dipole parts
/// about it (2 each).
// Not inlined: one copy for the shared part and every band's rest (less flash on the boards).
#[inline(never)]
fn add_shrunk_deviations(model: &BandModel, shrinkage: f32, out: &mut [[f32; CARDIOIDS]; 2]) {
    let n = model.peaks;
    if !(n > 0.0) {
        return;
    }
    let a = model.omni_part;
    let mean = (a[0] + a[1] + a[2]) / 3.0;
    let noise = shrinkage / n;
    let common = mean - 0.5;
    let common = shrink_factor(3.0 * common * common, noise) * common;
    let groups = [(model.omni_part, 2.0), (model.dipole_part, 2.0)];
    for (out, (parts, dof)) in out.iter_mut().zip(groups) {
        let d = parts.map(|v| v - mean);
        let f = shrink_factor(d[0] * d[0] + d[1] * d[1] + d[2] * d[2], noise * dof);
        for m in 0..CARDIOIDS {
            out[m] += common + f * d[m];
        }
    }
}

/// State of the self-calibration.
#[derive(Debug, Clone)]
pub struct CapsuleCalibrationState {
    settings: CapsuleCalibration,
    /// The accepted long-term sums.
    sums: [BandSums; CAL_BANDS],
    /// The batch of background frames since the last merge, not yet checked for diffuseness.
    batch: [BandSums; CAL_BANDS],
    /// Background frames in the batch.
    batch_frames: u32,
    /// This frame's sums, before normalisation by the band's power.
    frame: [BandSums; CAL_BANDS],
    frame_used: bool,
    /// Each band's power, floor and whether it is background in this frame.
    bands: BandFloors<CAL_BANDS>,
    /// Recent share of all-background frames whose curve pointed somewhere.
    directional_share: f32,
    /// Band power over its floor up to which a background band is quiet ([`QUIET_DB`]).
    quiet_ratio: f32,
    accepted: CapsuleEstimate,
    correction: [Correction; CAL_BANDS],
    /// The shift of the features' plane vector by the omni parts' correction at factor 1 (mean
    /// over the bands).
    omni_shift: (f32, f32),
    /// The factor of the omni parts' correction the talker's frames support.
    omni_scale: f32,
    speech: SpeechCheck,
    /// Speech frames the check has taken.
    speech_frames: u32,
    forget: f32,
}

/// Largest power of the capsules' own noise, relative to the background field's dipole power in
/// a band, at which the band still learns: the field's share then rests on the difference of two
/// nearly equal powers, and what the noise left in it (the four capsules' noise is not quite
/// equal, nor the peaks' selection of it) becomes a capsule error (validation scenes with capsule
/// noise 10 dB below the room noise, docs/self-calibration.md: 1 learns less on imperfect arrays,
/// 4 and more cost ideal ones more).
pub const MAX_NOISE_SHARE: f32 = 2.0;

/// Confidence from which all-background frames are checked for a directional background.
const DIRECTIONAL_CONFIDENCE: f32 = 0.3;

/// Pole of the directional share's average over all-background frames.
const DIRECTIONAL_POLE: f32 = 0.05;

/// Share of directional all-background frames above which the background counts as directional
/// (diffuse backgrounds measured about 0.05, a noise source in a room 0.3–0.4).
const DIRECTIONAL_SHARE: f32 = 0.2;

/// Largest rise of a band's background floor, dB per second.
const FLOOR_RISE_DB_PER_S: f32 = 1.0;

/// A background band within this many dB of its tracked floor is quiet: the talker's reverberation
/// has died away in it (at most about a fifth of its power), and the frame teaches the whole
/// deviation of the capsules (docs/self-calibration.md: on an ideal array, the estimate's early
/// error falls; louder background frames teach only across the talker's patterns).
const QUIET_DB: f32 = 1.0;

/// The batch is checked every this many background frames.
const CHECK_FRAMES: u32 = 16;
/// A batch that passed its check joins the long-term sums at this many background frames.
const BATCH_FRAMES: u32 = 128;
/// Background frames before a band's first estimate is accepted (a multiple of [`CHECK_FRAMES`]).
const FIRST_ESTIMATE_FRAMES: u32 = 32;

impl CapsuleCalibrationState {
    /// An idle state (the stage off).
    #[must_use]
    pub const fn idle() -> Self {
        Self {
            settings: CapsuleCalibration::OFF,
            sums: [BandSums::ZERO; CAL_BANDS],
            batch: [BandSums::ZERO; CAL_BANDS],
            batch_frames: 0,
            frame: [BandSums::ZERO; CAL_BANDS],
            frame_used: false,
            bands: BandFloors::idle(),
            directional_share: 0.0,
            quiet_ratio: 1.0,
            accepted: CapsuleEstimate::IDEAL,
            correction: [Correction::IDENTITY; CAL_BANDS],
            omni_shift: (0.0, 0.0),
            omni_scale: 1.0,
            speech: SpeechCheck::new(),
            speech_frames: 0,
            forget: 1.0,
        }
    }

    /// A fresh state for `settings` at analysis rate `fs` Hz (`frames_per_s` analysis frames per
    /// second), starting from `start`.
    #[must_use]
    pub fn new(
        settings: CapsuleCalibration,
        fs: f32,
        frames_per_s: f32,
        start: &CapsuleEstimate,
    ) -> Self {
        let mut s = Self::idle();
        s.reset(settings, fs, frames_per_s, start);
        s
    }

    /// Makes this state what [`CapsuleCalibrationState::new`] returns, in place (without a
    /// temporary of the state's size on the stack).
    pub fn reset(
        &mut self,
        settings: CapsuleCalibration,
        fs: f32,
        frames_per_s: f32,
        start: &CapsuleEstimate,
    ) {
        // Field by field (`restore` resets the rest): no temporary of the state on the stack.
        self.settings = settings;
        self.bands = BandFloors::new(
            &CAL_BAND_EDGES_HZ,
            fs,
            frames_per_s,
            FLOOR_RISE_DB_PER_S,
            settings.background_db,
        );
        self.quiet_ratio = power_ratio_from_db(QUIET_DB);
        self.forget = 1.0 - 1.0 / settings.memory_frames;
        self.restore(start);
    }

    /// Replaces the estimate with `start` (a saved one): the sums are set to what the model gives
    /// with its count of peaks. Implausible bands start ideal.
    pub fn restore(&mut self, start: &CapsuleEstimate) {
        self.accepted = CapsuleEstimate::IDEAL;
        for (band, model) in start.bands.iter().enumerate() {
            if model.is_plausible() {
                self.accepted.bands[band] = *model;
            }
            self.sums[band] = BandSums::of_model(&self.accepted.bands[band]);
        }
        self.omni_scale = 1.0;
        // The talker's shift is restored with the bands (the estimate's own, not the background's
        // model: nothing rebuilds it but the talker).
        if CapsuleEstimate::is_plausible_talker_shift(start.talker_shift) {
            self.accepted.talker_shift = start.talker_shift;
        }
        self.speech.clear();
        self.speech_frames = 0;
        self.update_corrections();
        self.frame = [BandSums::ZERO; CAL_BANDS];
        self.frame_used = false;
        self.bands.restart();
        self.directional_share = 0.0;
        self.batch = [BandSums::ZERO; CAL_BANDS];
        self.batch_frames = 0;
    }

    fn update_corrections(&mut self) {
        Correction::of_bands(
            &mut self.correction,
            &mut self.omni_shift,
            &self.accepted.bands,
            self.settings.shrinkage,
            self.settings.max_omni_spread,
            self.omni_scale,
        );
        // The talker's further shift, the same in every band (a zero-mean c0 of plane coordinates
        // z moves the features' plane vector by 1.5·z).
        let [ex, ey] = self.accepted.talker_shift;
        let extra = from_plane([ex / 1.5, ey / 1.5]);
        for c in &mut self.correction {
            for (c0, e) in c.c0.iter_mut().zip(extra) {
                *c0 += e;
            }
        }
    }

    /// Adds a used peak (features `y` from the corrected cardioids) to the talker's check of the
    /// omni correction ([`SpeechCheck`]).
    #[inline]
    pub fn speech_peak(&mut self, y: [f32; CARDIOIDS]) {
        if self.settings.speech_check {
            let (vx, vy) = plane_vector(y);
            let k = self.omni_scale;
            let [ex, ey] = self.accepted.talker_shift;
            self.speech.add_peak((
                vx - k * self.omni_shift.0 - ex,
                vy - k * self.omni_shift.1 - ey,
            ));
        }
    }

    /// Ends the speech check's frame: `speech` says the frame holds speech, `talker_deg` is the
    /// tracked talker. Every 16 frames the check takes, the factor of the omni
    /// correction is updated.
    pub fn end_speech_frame(&mut self, talker_deg: Option<f32>, speech: bool) {
        if !self.settings.speech_check {
            return;
        }
        let talker = talker_deg.filter(|_| speech);
        // The frame's background share (of a frame the check takes): the bands' floors over
        // their powers.
        let share = if talker.is_some() {
            let (mut floor, mut power) = (0.0, 0.0);
            for b in 0..CAL_BANDS {
                floor += self.bands.floor(b);
                power += self.bands.power(b);
            }
            floor / power
        } else {
            f32::NAN
        };
        if !self.speech.end_frame(talker, share) {
            return;
        }
        self.speech_frames += 1;
        if !self.speech_frames.is_multiple_of(CHECK_FRAMES) {
            return;
        }
        let (scale, shift) = self.speech.verdict(self.omni_shift);
        // Too few places heard to judge the shift: the one applied (a restored one, or what
        // more places asked for before) stays.
        let [ex, ey] = self.accepted.talker_shift;
        let shift = shift.map_or([ex, ey], |(x, y)| [x, y]);
        let moved = (shift[0] - ex).abs() + (shift[1] - ey).abs();
        if (scale - self.omni_scale).abs() > 0.01 || moved > 0.002 {
            self.omni_scale = scale;
            self.accepted.talker_shift = shift;
            self.update_corrections();
        }
    }

    /// The factor applied to the omni parts' correction (1 unless the talker's frames show that
    /// it does not fit his sound).
    #[must_use]
    pub fn omni_scale(&self) -> f32 {
        self.omni_scale
    }

    /// The accepted estimate.
    #[must_use]
    pub fn estimate(&self) -> &CapsuleEstimate {
        &self.accepted
    }

    /// The settings.
    #[must_use]
    pub fn settings(&self) -> &CapsuleCalibration {
        &self.settings
    }

    /// The overall confidence: the smallest band confidence.
    #[must_use]
    pub fn confidence(&self) -> f32 {
        self.accepted.overall_confidence()
    }

    /// Starts a frame from the omni powers `omni_power` of the bins `lo..=hi` (the analysis band):
    /// each band's power, its tracked floor and whether the band is background in this frame (its
    /// power within [`CapsuleCalibration::background_db`] of the floor; never when not `clean`).
    pub fn begin_frame(&mut self, omni_power: &[f32; NUM_BINS], lo: usize, hi: usize, clean: bool) {
        self.bands.begin_frame(omni_power, lo, hi, clean);
    }

    /// Corrects the cardioid values `x` of bin `k` (omni `w`) to the ideal capsule; when the bin's
    /// band is background in this frame ([`CapsuleCalibrationState::begin_frame`]), first adds the
    /// raw cross-powers to this frame's sums.
    #[inline]
    pub fn correct(
        &mut self,
        k: usize,
        w: Complex32,
        x: [Complex32; CARDIOIDS],
    ) -> [Complex32; CARDIOIDS] {
        let band = self.bands.band_of_bin(k);
        if self.bands.is_background(band) && self.settings.adapt {
            let re = |p: Complex32, q: Complex32| p.re * q.re + p.im * q.im;
            let s = &mut self.frame[band];
            s.ww += w.re * w.re + w.im * w.im;
            for m in 0..CARDIOIDS {
                s.xw[m] += re(x[m], w);
            }
            s.xx[0] += re(x[0], x[0]);
            s.xx[1] += re(x[1], x[1]);
            s.xx[2] += re(x[2], x[2]);
            s.xx[3] += re(x[0], x[1]);
            s.xx[4] += re(x[0], x[2]);
            s.xx[5] += re(x[1], x[2]);
            s.n += 1.0;
            self.frame_used = true;
        }
        let c = &self.correction[band];
        let mut out = x;
        for m in 0..CARDIOIDS {
            out[m] = Complex32::new(
                c.c1[m] * x[m].re + c.c0[m] * w.re,
                c.c1[m] * x[m].im + c.c0[m] * w.im,
            );
        }
        out
    }

    /// Ends a frame: the sums of its background bands, each in units of the band's power, join
    /// the batch — the omni parts across the direction `talker_deg` of the tracked talker only
    /// (its reverberation leaks into the background along it). `directional` says the frame's
    /// curve points somewhere: while that holds for most frames that are background in every band,
    /// the background is directional and nothing is learned. Every 16 background frames each
    /// band's batch is checked: an anisotropic one is dropped (the band's estimate held), a
    /// diffuse one updates the estimate and joins the long-term sums once it holds 128 frames.
    // Not inlined: one copy for every caller (less flash on the boards).
    #[inline(never)]
    pub fn end_frame(&mut self, talker_deg: Option<f32>, directional: bool) {
        if !self.frame_used {
            return;
        }
        self.frame_used = false;
        // A frame that is background in every band is the background's own sound. Once the
        // estimate stands (before, the capsules' own errors make a diffuse background's curve
        // point somewhere too), such frames' curves pointing somewhere mean a directional
        // background (a fan, a loudspeaker switched on): nothing is learned while it lasts, from
        // them or from the background bands of other frames.
        if self.bands.all_background() && self.confidence() >= DIRECTIONAL_CONFIDENCE {
            let hit = if directional { 1.0 } else { 0.0 };
            self.directional_share += DIRECTIONAL_POLE * (hit - self.directional_share);
        }
        if self.directional_share > DIRECTIONAL_SHARE {
            self.accepted.held = true;
            self.frame = [BandSums::ZERO; CAL_BANDS];
            return;
        }
        let talker = talker_deg.map(|d| {
            let r = d.to_radians();
            let (s, c) = crate::trig::sin_cos(r);
            (c, s)
        });
        for band in 0..CAL_BANDS {
            let add = &self.frame[band];
            let p = self.bands.power(band);
            // Each band's sums in units of its power, so that loud and quiet frames weigh alike.
            if add.n > 0.0 && p > 0.0 {
                let inv = 1.0 / p;
                let s = &mut self.batch[band];
                s.add_scaled(add, 1.0, inv);
                // At its floor the band holds little of the talker's reverberation: the frame
                // teaches the whole deviation, not only its part across the talker's patterns.
                let quiet = p <= self.bands.floor(band) * self.quiet_ratio;
                let talker = if quiet { None } else { talker };
                s.add_plane(add, inv * add.ww, talker);
            }
            self.frame[band] = BandSums::ZERO;
        }
        self.batch_frames += 1;
        if !self.batch_frames.is_multiple_of(CHECK_FRAMES) {
            return;
        }
        let merge = self.batch_frames >= BATCH_FRAMES;
        let keep = libm::powf(self.forget, self.batch_frames as f32);
        let mut held = false;
        for band in 0..CAL_BANDS {
            let mut total = self.sums[band];
            total.add_scaled(&self.batch[band], keep, 1.0);
            // The capsules' own noise, per peak, from all the evidence (see `self_noise`).
            let noise = if total.n > 0.0 {
                total.self_noise() / total.n
            } else {
                0.0
            };
            let clean = total.without_noise(noise);
            let share = clean.noise_share(noise);
            if self.batch[band].without_noise(noise).anisotropy() > self.settings.max_anisotropy
                || share > MAX_NOISE_SHARE
            {
                // A directional background in this band, or one the capsules' own noise drowns:
                // drop its batch, keep its estimate.
                held = true;
                self.batch[band] = BandSums::ZERO;
                continue;
            }
            if merge {
                self.sums[band] = total;
            }
            // Never on little evidence: a band's estimate moves only once FIRST_ESTIMATE_FRAMES
            // background frames have passed the diffuseness checks (a second of a real room's
            // ambient noise is no measurement of the capsules).
            if self.sums[band].n <= 0.0 && self.batch_frames < FIRST_ESTIMATE_FRAMES {
                continue;
            }
            if let Some(model) = clean.solve(self.settings.shrinkage, share) {
                self.accepted.bands[band] = model;
            }
        }
        self.update_corrections();
        self.accepted.held = held;
        if merge {
            self.batch = [BandSums::ZERO; CAL_BANDS];
            self.batch_frames = 0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Lcg;

    /// Circular complex Gaussian sample of variance `var` (Box–Muller).
    fn cn(rng: &mut Lcg, var: f32) -> Complex32 {
        let u = 1.0 - rng.unit();
        let r = libm::sqrtf(-var * libm::logf(u));
        let t = 2.0 * core::f32::consts::PI * rng.unit();
        Complex32::new(r * libm::cosf(t), r * libm::sinf(t))
    }

    /// What a background gives: a diffuse field (plus a coherent source of relative power
    /// `directional` from `dir_deg`) through capsules with omni parts `a` and dipole parts `b`,
    /// one peak per band and frame, every band background; `talker` and `directional_curve` as
    /// [`CapsuleCalibrationState::end_frame`] takes them; white noise of power `capsule_noise`
    /// (relative to the field's omni power) in each of the four capsules.
    #[allow(clippy::too_many_arguments)]
    fn feed(
        st: &mut CapsuleCalibrationState,
        a: [f32; 3],
        b: [f32; 3],
        directional: f32,
        dir_deg: f32,
        talker: Option<f32>,
        directional_curve: bool,
        frames: usize,
        seed: u32,
        capsule_noise: f32,
    ) {
        let mut rng = Lcg(seed);
        for _ in 0..frames {
            st.bands.background = [true; CAL_BANDS];
            st.bands.power = [1.0; CAL_BANDS];
            for k in [10usize, 30, 60, 120] {
                let mut w = cn(&mut rng, 1.0);
                let mut x = cn(&mut rng, KAPPA);
                let mut y = cn(&mut rng, KAPPA);
                if directional > 0.0 {
                    let s = cn(&mut rng, directional);
                    let t = dir_deg.to_radians();
                    w += s;
                    x += s * libm::cosf(t);
                    y += s * libm::sinf(t);
                }
                let xs = [0.0f32, 120.0, 240.0].map(|l| {
                    let l = l.to_radians();
                    x * libm::cosf(l) + y * libm::sinf(l)
                });
                let c = [0, 1, 2].map(|m| w * a[m] + xs[m] * b[m]);
                let (w, c) = if capsule_noise > 0.0 {
                    (
                        w + cn(&mut rng, capsule_noise),
                        c.map(|v| v + cn(&mut rng, capsule_noise)),
                    )
                } else {
                    (w, c)
                };
                st.correct(k, w, c);
            }
            st.end_frame(talker, directional_curve);
        }
    }

    fn fresh() -> CapsuleCalibrationState {
        let settings = CapsuleCalibration {
            memory_frames: 1e6,
            ..CapsuleCalibration::DEFAULT
        };
        CapsuleCalibrationState::new(settings, 12_000.0, 46.875, &CapsuleEstimate::IDEAL)
    }

    /// Capsules with unequal gains and patterns whose dipole parts sum to the omni parts' sum (the
    /// scale the estimate reports, see [`BandSums::solve`]).
    const A: [f32; 3] = [0.55, 0.43, 0.5];
    const B: [f32; 3] = [0.46, 0.58, 0.44];

    #[test]
    fn bands_cover_the_spectrum_in_order() {
        let st = fresh();
        assert_eq!(st.bands.bins[0].0, 0);
        assert_eq!(st.bands.bins[CAL_BANDS - 1].1 as usize, NUM_BINS);
        for w in st.bands.bins.windows(2) {
            assert_eq!(w[0].1, w[1].0);
        }
        // 500 Hz at 12 kHz is bin 21.33: bin 21 is below, bin 22 above.
        assert_eq!(st.bands.band_of_bin(21), 0);
        assert_eq!(st.bands.band_of_bin(22), 1);
        assert_eq!(st.bands.band_of_bin(NUM_BINS - 1), CAL_BANDS - 1);
        // An edge belongs to the band above it.
        let bands = [0.0, 499.9, 500.0, 999.0, 1000.0, 2000.0, 8000.0, f32::NAN];
        assert_eq!(bands.map(band_of_frequency), [0, 0, 1, 1, 2, 3, 3, 0]);
    }

    #[test]
    fn capsule_noise_is_taken_off_before_learning() {
        // White noise in each capsule at 0.05 of the omni power, about two thirds of the field's
        // dipole power κ·b² ≈ 0.08: the raw cross-powers look anisotropic (the normalised ones
        // ≈ −0.3 instead of −½), so without taking the noise off nothing would be learned.
        let mut st = fresh();
        feed(&mut st, A, B, 0.0, 0.0, None, false, 20_000, 5, 0.05);
        let raw = st.sums[1].correlations().unwrap();
        assert!(raw.iter().all(|r| *r > -0.4), "{raw:?}");
        assert!(!st.estimate().held);
        for band in st.estimate().bands {
            for m in 0..3 {
                assert!((band.omni_part[m] - A[m]).abs() < 0.015, "{band:?}");
                assert!((band.dipole_part[m] - B[m]).abs() < 0.02, "{band:?}");
            }
        }
        let noise = st.sums[1].self_noise() / st.sums[1].n;
        assert!((noise - 0.05).abs() < 0.005, "{noise}");
    }

    #[test]
    fn capsule_noise_counts_as_less_evidence() {
        // The same background with and without capsule noise of a share s of the field's dipole
        // power (0.6–1.6 across the bands): the noisy estimate rests on the difference of nearly
        // equal powers, its variance is (1 + s)² times larger, and it counts as that many times
        // fewer peaks (less confidence, more shrinkage), which keeps an ideal array's cold start
        // nearer ideal.
        let mut clean = fresh();
        let mut noisy = fresh();
        feed(&mut clean, A, B, 0.0, 0.0, None, false, 20_000, 5, 0.0);
        feed(&mut noisy, A, B, 0.0, 0.0, None, false, 20_000, 5, 0.05);
        for band in 0..CAL_BANDS {
            let sums = noisy.sums[band];
            let noise = sums.self_noise() / sums.n;
            let share = sums.without_noise(noise).noise_share(noise);
            assert!(share > 0.3, "band {band}: share {share}");
            // Against the background peaks behind it (fewer than the clean run's where early
            // batches, the noise not yet known, were held).
            let counted = noisy.estimate().bands[band].peaks / sums.n;
            let expected = 1.0 / ((1.0 + share) * (1.0 + share));
            assert!(
                (counted / expected - 1.0).abs() < 0.1,
                "band {band}: {counted} vs {expected}"
            );
        }
        assert!(noisy.confidence() < clean.confidence());
    }

    #[test]
    fn a_second_of_background_does_not_move_the_estimate() {
        // Fewer background frames than FIRST_ESTIMATE_FRAMES: however much they suggest, the
        // capsules stay ideal (a one-second recording must not be "calibrated").
        let mut st = fresh();
        feed(
            &mut st,
            A,
            B,
            0.0,
            0.0,
            None,
            false,
            FIRST_ESTIMATE_FRAMES as usize - 1,
            3,
            0.0,
        );
        assert_eq!(st.estimate().bands, CapsuleEstimate::IDEAL.bands);
        // The next check after FIRST_ESTIMATE_FRAMES accepts what they taught.
        feed(
            &mut st,
            A,
            B,
            0.0,
            0.0,
            None,
            false,
            CHECK_FRAMES as usize,
            4,
            0.0,
        );
        assert_ne!(st.estimate().bands, CapsuleEstimate::IDEAL.bands);
    }

    #[test]
    fn learns_gains_and_patterns_in_a_diffuse_field() {
        let mut st = fresh();
        feed(&mut st, A, B, 0.0, 0.0, None, false, 20_000, 3, 0.0);
        for band in st.estimate().bands {
            for m in 0..3 {
                assert!((band.omni_part[m] - A[m]).abs() < 0.01, "{band:?}");
                assert!((band.dipole_part[m] - B[m]).abs() < 0.02, "{band:?}");
            }
        }
        assert!(st.confidence() > 0.9);
        // The correction maps the capsules back to the ideal cardioid.
        let w = Complex32::new(0.3, -0.2);
        let d = Complex32::new(-0.1, 0.25);
        let x = [0, 1, 2].map(|m| w * A[m] + d * B[m]);
        let y = st.correct(30, w, x);
        for (m, ym) in y.iter().enumerate() {
            let want = w * 0.5 + d * 0.5;
            assert!((ym - want).norm_sqr() < 1e-4, "{m}: {ym:?} vs {want:?}");
        }
    }

    #[test]
    fn an_ideal_array_stays_uncorrected() {
        let mut st = fresh();
        feed(
            &mut st, [0.5; 3], [0.5; 3], 0.0, 0.0, None, false, 5_000, 5, 0.0,
        );
        let w = Complex32::new(0.3, -0.2);
        let x = [
            Complex32::new(0.1, 0.2),
            Complex32::new(-0.3, 0.05),
            w * 0.5,
        ];
        let y = st.correct(60, w, x);
        for m in 0..3 {
            assert!(
                (y[m] - x[m]).norm_sqr() < 1e-4,
                "{m}: {:?} vs {:?}",
                y[m],
                x[m]
            );
        }
    }

    #[test]
    fn a_talkers_reverberation_does_not_pull_the_estimate() {
        // A coherent part from the talker's direction in the background biases the raw omni parts
        // toward it; with the talker's direction given, that component is not learned. The
        // patterns, from the regression of W on the cardioids, hold in any field: they are not
        // pulled even without the talker's direction.
        let mut st = fresh();
        feed(
            &mut st,
            [0.5; 3],
            [0.5; 3],
            0.3,
            30.0,
            Some(30.0),
            false,
            8_000,
            7,
            0.0,
        );
        for band in st.estimate().bands {
            for m in 0..3 {
                assert!((band.omni_part[m] - 0.5).abs() < 0.015, "{band:?}");
                assert!((band.dipole_part[m] - 0.5).abs() < 0.015, "{band:?}");
            }
        }
        let mut blind = fresh();
        feed(
            &mut blind, [0.5; 3], [0.5; 3], 0.3, 30.0, None, false, 8_000, 7, 0.0,
        );
        let pulled = blind.estimate().bands[1].omni_part[0] - 0.5;
        assert!(pulled > 0.05, "{pulled}");
        for band in blind.estimate().bands {
            for m in 0..3 {
                assert!((band.dipole_part[m] - 0.5).abs() < 0.002, "{band:?}");
            }
        }
    }

    #[test]
    fn a_direction_heard_little_is_shrunk_with_its_own_evidence() {
        // A talker at 30° for 1000 background frames, 20 of them quiet: along its direction only
        // those 20 teach, and what they say (here a leak of 0.02) is shrunk with their evidence;
        // a deviation heard from every direction is left as it is.
        let (s, c) = crate::trig::sin_cos(core::f32::consts::FRAC_PI_6);
        let leak = 0.02;
        let mut p = [0.0f32; 5];
        for _ in 0..980 {
            accumulate(&mut p, [leak * c, leak * s], 1.0, Some((-s, c)));
        }
        for _ in 0..20 {
            accumulate(&mut p, [leak * c, leak * s], 1.0, None);
        }
        let peaks = 4000.0;
        let along = |dev: [f32; CARDIOIDS]| {
            let z = to_plane(dev);
            z[0] * c + z[1] * s
        };
        let raw = along(plane_deviation(&p, peaks, 0.0).unwrap());
        let shrunk =
            along(plane_deviation(&p, peaks, CapsuleCalibration::DEFAULT.shrinkage).unwrap());
        assert!(raw > 0.5 * leak, "{raw}");
        assert!(shrunk.abs() < 0.1 * leak, "{shrunk}");
        let mut everywhere = [0.0f32; 5];
        for _ in 0..1000 {
            accumulate(&mut everywhere, [leak * c, leak * s], 1.0, None);
        }
        let kept = along(
            plane_deviation(&everywhere, peaks, CapsuleCalibration::DEFAULT.shrinkage).unwrap(),
        );
        assert!((kept - leak).abs() < 0.05 * leak, "{kept}");
    }

    #[test]
    fn quiet_frames_teach_the_deviation_along_the_talker() {
        // Omni parts that deviate along the talker's direction: background frames above the floor
        // cannot tell that from the talker's reverberation and leave it, frames at the floor
        // learn it.
        let along =
            [0.0f32, 120.0, 240.0].map(|l| 0.5 + 0.05 * libm::cosf((30.0 - l).to_radians()));
        let learn = |st: &mut CapsuleCalibrationState| {
            feed(
                st,
                along,
                [0.5; 3],
                0.0,
                0.0,
                Some(30.0),
                false,
                8_000,
                11,
                0.0,
            );
        };
        let mut above = fresh();
        learn(&mut above);
        let mut at_floor = fresh();
        for floor in &mut at_floor.bands.floor {
            floor.update(1.0, false, false);
        }
        learn(&mut at_floor);
        for band in 0..CAL_BANDS {
            let learned = at_floor.estimate().bands[band].omni_part;
            let left = above.estimate().bands[band].omni_part;
            for m in 0..3 {
                assert!((learned[m] - along[m]).abs() < 0.01, "{learned:?}");
                assert!((left[m] - 0.5).abs() < 0.01, "{left:?}");
            }
        }
    }

    #[test]
    fn a_band_with_little_evidence_is_corrected_with_what_the_others_learned() {
        // The same imperfect capsules in every band; the lowest band has heard 30 background
        // peaks, too few to clear its own noise, the others 3000.
        let mut model = BandModel::IDEAL;
        model.omni_part = [0.55, 0.47, 0.46];
        model.dipole_part = [0.52, 0.47, 0.50];
        let mut models = [BandModel {
            peaks: 3000.0,
            ..model
        }; CAL_BANDS];
        models[0].peaks = 30.0;
        let mut c = [Correction::IDENTITY; CAL_BANDS];
        Correction::of_bands(&mut c, &mut (0.0, 0.0), &models, 0.2, 0.0, 1.0);
        // The omni part each correction undoes: a = b·(1 − 2·c0) with the applied b = ½/c1.
        let undone = |c: &Correction| [0, 1, 2].map(|m| 0.5 * (1.0 - 2.0 * c.c0[m]) / c.c1[m]);
        for band in 0..CAL_BANDS {
            let a = undone(&c[band]);
            for m in 0..3 {
                let want = model.omni_part[m] - 0.5;
                assert!(
                    (a[m] - 0.5 - want).abs() < 0.1 * want.abs() + 1e-3,
                    "{band} {a:?}"
                );
            }
        }
        // Bands that disagree share nothing: each rest must clear its own band's noise.
        let mut models = [BandModel {
            peaks: 30.0,
            ..model
        }; CAL_BANDS];
        for band in [1, 3] {
            models[band].omni_part = model.omni_part.map(|a| 1.0 - a);
            models[band].dipole_part = model.dipole_part.map(|b| 1.0 - b);
        }
        let mut corrections = [Correction::IDENTITY; CAL_BANDS];
        Correction::of_bands(&mut corrections, &mut (0.0, 0.0), &models, 0.2, 0.0, 1.0);
        for c in corrections {
            for m in 0..3 {
                assert!(
                    (c.c1[m] - 1.0).abs() < 0.02 && c.c0[m].abs() < 0.02,
                    "{c:?}"
                );
            }
        }
    }

    #[test]
    fn young_evidence_does_not_open_the_omni_bound() {
        // A matched array (dipole parts 0.51 / 0.49 / 0.50) beside a noise source from power-on:
        // the omni parts' estimate carries the source's net intensity. With a hundred background
        // peaks per band the dipole parts' spread is no larger than their sampling noise, and the
        // bound holds the omni parts to half the ratio it allows them on much evidence, where the
        // spread is the capsules' own and the omni correction is applied (nearly) in full.
        let undone = |c: &Correction| [0, 1, 2].map(|m| 0.5 * (1.0 - 2.0 * c.c0[m]) / c.c1[m]);
        let spread = |v: [f32; 3]| {
            let m = (v[0] + v[1] + v[2]) / 3.0;
            v.iter().fold(0.0f32, |s, x| s.max((x - m).abs()))
        };
        let applied = |peaks: f32| {
            let mut model = BandModel {
                peaks,
                ..BandModel::IDEAL
            };
            model.omni_part = [0.58, 0.46, 0.46];
            model.dipole_part = [0.51, 0.49, 0.50];
            let mut c = [Correction::IDENTITY; CAL_BANDS];
            let d = CapsuleCalibration::DEFAULT;
            Correction::of_bands(
                &mut c,
                &mut (0.0, 0.0),
                &[model; CAL_BANDS],
                d.shrinkage,
                d.max_omni_spread,
                1.0,
            );
            spread(undone(&c[0]))
        };
        let young = applied(100.0);
        let old = applied(50_000.0);
        // Without the noise taken off: 0.074 young.
        assert!(young < 0.05, "young evidence: omni spread {young}");
        assert!(old > 0.07, "much evidence: omni spread {old}");
    }

    #[test]
    fn the_omni_spread_is_bounded_by_the_dipole_spread() {
        // An ideal array beside a noise source: the omni parts' estimate carries the source's net
        // intensity, the dipole parts are ideal. Applied: the ideal capsule (up to the common gain).
        let mut source = BandModel {
            peaks: 50_000.0,
            ..BandModel::IDEAL
        };
        source.omni_part = [0.58, 0.46, 0.46];
        let models = [source; CAL_BANDS];
        let undone = |c: &Correction| [0, 1, 2].map(|m| 0.5 * (1.0 - 2.0 * c.c0[m]) / c.c1[m]);
        let mut bounded = [Correction::IDENTITY; CAL_BANDS];
        Correction::of_bands(&mut bounded, &mut (0.0, 0.0), &models, 0.2, 4.0, 1.0);
        let mut free = [Correction::IDENTITY; CAL_BANDS];
        Correction::of_bands(&mut free, &mut (0.0, 0.0), &models, 0.2, 0.0, 1.0);
        for band in 0..CAL_BANDS {
            let (a, f) = (undone(&bounded[band]), undone(&free[band]));
            let spread = |v: [f32; 3]| v.iter().fold(0.0f32, |m, x| m.max((x - v[0]).abs()));
            assert!(spread(a) < 1e-4, "{a:?}");
            assert!(spread(f) > 0.1, "{f:?}");
        }
        // Imperfect capsules (gain and pattern errors): their omni spread is within four times
        // their dipole spread, and the bound changes nothing.
        let mut imperfect = BandModel {
            peaks: 50_000.0,
            ..BandModel::IDEAL
        };
        for (m, (g, beta)) in [(1.1f32, 0.52f32), (0.92, 0.47), (1.0, 0.5)]
            .iter()
            .enumerate()
        {
            imperfect.omni_part[m] = g * (1.0 - beta);
            imperfect.dipole_part[m] = g * beta;
        }
        let models = [imperfect; CAL_BANDS];
        Correction::of_bands(&mut bounded, &mut (0.0, 0.0), &models, 0.2, 4.0, 1.0);
        Correction::of_bands(&mut free, &mut (0.0, 0.0), &models, 0.2, 0.0, 1.0);
        assert_eq!(bounded, free);
    }

    #[test]
    fn the_omni_scale_scales_the_omni_parts_spread_and_the_shift_is_its_plane_vector() {
        let model = BandModel {
            omni_part: [0.6, 0.45, 0.45],
            dipole_part: [0.5; CARDIOIDS],
            peaks: 1e6,
        };
        let models = [model; CAL_BANDS];
        let undone = |c: &Correction| [0, 1, 2].map(|m| 0.5 * (1.0 - 2.0 * c.c0[m]) / c.c1[m]);
        let mut full = [Correction::IDENTITY; CAL_BANDS];
        let mut shift = (0.0, 0.0);
        Correction::of_bands(&mut full, &mut shift, &models, 0.2, 0.0, 1.0);
        let mut none = [Correction::IDENTITY; CAL_BANDS];
        let mut shift0 = (0.0, 0.0);
        Correction::of_bands(&mut none, &mut shift0, &models, 0.2, 0.0, 0.0);
        // The shift does not depend on the factor applied.
        assert_eq!(shift, shift0);
        let (a, n) = (undone(&full[0]), undone(&none[0]));
        assert!((a[0] - a[1] - 0.15).abs() < 0.01, "{a:?}");
        assert!((n[0] - n[1]).abs() < 1e-5, "{n:?}");
        // The shift is what the omni correction adds to the features' plane vector: c0 is
        // −(a − mean)/(2b) per cardioid, plane_vector of (−0.1, 0.05, 0.05) is (−0.15, 0).
        let d = [0, 1, 2].map(|m| full[0].c0[m] - none[0].c0[m]);
        assert_eq!(plane_vector(d), shift);
        assert!(
            (shift.0 + 0.15).abs() < 0.01 && shift.1.abs() < 1e-5,
            "{shift:?}"
        );
    }

    #[test]
    fn a_directional_background_holds_the_estimate() {
        let mut st = fresh();
        feed(&mut st, A, B, 0.0, 0.0, None, false, 5_000, 9, 0.0);
        let before = *st.estimate();
        // A loud noise source whose frames' curves point at it.
        feed(&mut st, A, B, 2.0, 70.0, None, true, 5_000, 10, 0.0);
        assert!(st.estimate().held);
        assert_eq!(st.estimate().bands, before.bands);
    }

    #[test]
    fn cold_start_is_ideal_and_a_saved_estimate_restores() {
        let mut st = fresh();
        let w = Complex32::new(1.0, 0.5);
        let x = [Complex32::new(0.2, 0.1); 3];
        assert_eq!(st.correct(40, w, x), x);
        assert_eq!(st.confidence(), 0.0);
        let mut saved = CapsuleEstimate::IDEAL;
        saved.bands[1].omni_part = [0.45, 0.55, 0.5];
        saved.bands[1].dipole_part = [0.5, 0.48, 0.52];
        saved.bands[1].peaks = 5000.0;
        st.restore(&saved);
        assert_eq!(st.estimate().bands[1], saved.bands[1]);
        let m = st.sums[1]
            .solve(CapsuleCalibration::DEFAULT.shrinkage, 0.0)
            .unwrap();
        for i in 0..3 {
            let dev = saved.bands[1].omni_part[i] - 0.5;
            // The plane's ridge shrinks a deviation by 2 %.
            assert!((m.omni_part[i] - 0.5 - dev / (1.0 + PLANE_RIDGE)).abs() < 1e-4);
        }
        // The patterns come back as they were (Σb = Σa = 1.5 already).
        for i in 0..3 {
            let b = saved.bands[1].dipole_part[i];
            assert!((m.dipole_part[i] - b).abs() < 1e-4, "{m:?}");
        }
        // Nonsense is not restored.
        let mut bad = saved;
        bad.bands[2].omni_part[0] = f32::NAN;
        bad.talker_shift = [f32::NAN, 0.0];
        st.restore(&bad);
        assert_eq!(st.estimate().bands[2], BandModel::IDEAL);
        assert_eq!(st.estimate().talker_shift, [0.0; 2]);
    }

    #[test]
    fn a_saved_talkers_shift_is_applied_and_kept_until_the_talker_is_judged_again() {
        // Beside a source from power-on the background learned nothing; the talker's shift is the
        // whole correction, and a restart starts with it.
        let mut st = fresh();
        let mut saved = CapsuleEstimate::IDEAL;
        saved.talker_shift = [0.09, -0.03];
        st.restore(&saved);
        assert_eq!(st.estimate().talker_shift, saved.talker_shift);
        // Every band's c0 moves the features' plane vector by the shift (an ideal cardioid's
        // feature is its value over the omni's, here c0 added to each).
        let w = Complex32::new(1.0, 0.0);
        for k in [10, 40, 100, 200] {
            let y = st
                .correct(k, w, [Complex32::new(0.0, 0.0); 3])
                .map(|v| v.re);
            let (vx, vy) = plane_vector(y);
            assert!(
                (vx - 0.09).abs() < 1e-5 && (vy + 0.03).abs() < 1e-5,
                "bin {k}: {vx} {vy}"
            );
        }
        // A talker heard from one place gives no verdict on the shift: it stays.
        for i in 0..400 {
            st.begin_frame(&[1.0 + (i % 3) as f32; NUM_BINS], 5, 250, true);
            st.speech_peak([0.5; 3]);
            st.end_speech_frame(Some(30.0), true);
        }
        assert!(
            st.speech_frames >= 2 * CHECK_FRAMES,
            "{} frames",
            st.speech_frames
        );
        assert_eq!(st.estimate().talker_shift, saved.talker_shift);
    }
}
