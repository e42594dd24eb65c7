//! Noisy reference features (thesis §5.1.5, eq. 5.16–5.20): each reference vector is also compared
//! after mixing with the omni-noise feature Y_η at a set of SNRs, and the best match counts.
//!
//! With noise gain G = 10^(−SNR/20) (eq. 6.5–6.7 for unit powers):
//! * magnitude mixing (the thesis, eq. 5.19): Y_i = (Y + G·Y_η)/(1 + G) = α·Y + (1 − α)·Y_η, α = 1/(1 + G);
//! * power mixing (physically consistent for incoherent noise): Y_i² = α·Y² + (1 − α)·Y_η², α = 1/(1 + G²).

use crate::error::Error;
use crate::reference_table::Feature;
use crate::MAX_SNR_SETS;

/// How reference features are mixed with omni noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum NoiseMixing {
    /// Clean references only.
    Off,
    /// Linear mixing of magnitudes (thesis eq. 5.19).
    Magnitude,
    /// Mixing of powers.
    Power,
}

/// The SNR sets with their precomputed mixing weights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoisyReferences {
    mixing: NoiseMixing,
    /// Weight α_i of the clean feature per set.
    alphas: [f32; MAX_SNR_SETS],
    n: usize,
    /// For α in bucket b = ⌊α·[`LUT_LEN`]⌋ (α clamped to [0, 1)): the largest i ≤ n − 2 with
    /// α_i < b/[`LUT_LEN`] (0 if none), valid when `lut_ok` (no bucket holds two α_i).
    lut: [u8; LUT_LEN],
    lut_ok: bool,
    /// Midpoints ½(α_i + α_{i+1})·[`LUT_LEN`] for i ≤ n − 2, then +∞, as `f32` bits (positive, so
    /// they order like the floats): the nearest α_i to α* is α_j with j the number of midpoints
    /// ≤ α*·[`LUT_LEN`] (see [`NoisyReferences::nearest`]).
    mids: [i32; MAX_SNR_SETS],
    /// For bucket b (see `lut`): the number of midpoints ≤ b, valid when `near_ok` (no bucket holds
    /// two midpoints, the first midpoint is positive).
    near: [u8; LUT_LEN],
    near_ok: bool,
}

/// Buckets of the bracket table of [`NoisyReferences::bracket`].
pub(crate) const LUT_LEN: usize = 128;

impl NoisyReferences {
    /// Clean references only (the same as `new(NoiseMixing::Off, …)`).
    #[must_use]
    pub const fn off() -> Self {
        Self {
            mixing: NoiseMixing::Off,
            alphas: [1.0; MAX_SNR_SETS],
            n: 1,
            lut: [0; LUT_LEN],
            lut_ok: false,
            mids: [INF_BITS; MAX_SNR_SETS],
            near: [0; LUT_LEN],
            near_ok: false,
        }
    }

    /// Builds the sets for SNRs `from_db, from_db + step_db, …, ≤ to_db`.
    /// With [`NoiseMixing::Off`] there is one set: the clean reference.
    pub fn new(mixing: NoiseMixing, from_db: f32, to_db: f32, step_db: f32) -> Result<Self, Error> {
        let mut s = Self::off();
        s.mixing = mixing;
        if mixing == NoiseMixing::Off {
            return Ok(s);
        }
        if !(step_db > 0.0) || !(to_db >= from_db) || !from_db.is_finite() || !to_db.is_finite() {
            return Err(Error::InvalidConfig(
                "SNR sets: need step > 0 and to ≥ from",
            ));
        }
        let count = libm::floorf((to_db - from_db) / step_db + 1e-3) as usize + 1;
        if count > MAX_SNR_SETS {
            return Err(Error::InvalidConfig("SNR sets: more than 16 sets"));
        }
        for i in 0..count {
            let snr = from_db + step_db * i as f32;
            let g = libm::powf(10.0, -snr / 20.0);
            s.alphas[i] = match mixing {
                NoiseMixing::Magnitude => 1.0 / (1.0 + g),
                NoiseMixing::Power => 1.0 / (1.0 + g * g),
                NoiseMixing::Off => 1.0,
            };
        }
        s.n = count;
        // Padding repeats the last weight, so that index n (see `nearest_in`) means α_{n−1}.
        let last = s.alphas[count - 1];
        s.alphas[count..].fill(last);
        s.build_lut();
        Ok(s)
    }

    fn build_lut(&mut self) {
        let n = self.n;
        if n < 2 {
            return;
        }
        let a = &self.alphas[..n];
        let ascending = a.windows(2).all(|w| w[0] < w[1]);
        let spaced = a.windows(2).all(|w| w[1] - w[0] > 1.0 / LUT_LEN as f32);
        self.lut_ok = ascending && spaced;
        for (b, e) in self.lut.iter_mut().enumerate() {
            let start = b as f32 / LUT_LEN as f32;
            *e = a[..n - 1].iter().rposition(|x| *x < start).unwrap_or(0) as u8;
        }
        let half = LUT_LEN as f32 / 2.0;
        let mut mids = [f32::INFINITY; MAX_SNR_SETS];
        for (m, w) in mids.iter_mut().zip(a.windows(2)) {
            *m = (w[0] + w[1]) * half;
        }
        self.mids = mids.map(|m| m.to_bits() as i32);
        let mids = &mids[..n - 1];
        let bucket = |m: f32| (m as i32).clamp(0, LUT_LEN as i32 - 1);
        // n < 16: `nearest_in` may return n (for ts = +∞), which must stay a valid slot.
        self.near_ok = ascending
            && n < MAX_SNR_SETS
            && mids[0] > 0.0
            && mids.windows(2).all(|w| bucket(w[0]) < bucket(w[1]));
        for (b, e) in self.near.iter_mut().enumerate() {
            *e = mids.iter().filter(|m| **m <= b as f32).count() as u8;
        }
    }

    /// For `ts` = α*·128 (α* = d·r/‖r‖², the unconstrained best mix, see
    /// [`crate::similarity::CurveBuilder::accumulate`]), the index of the α_i nearest to α*: as
    /// ‖d − α·r‖² = ‖r‖²(α − α*)² + const is symmetric about α*, that α_i gives the smallest distance
    /// (at an exact midpoint the upper one; any `ts`, also negative or NaN, gives a valid index).
    /// Needs [`NoisyReferences::nearest_ok`]. One bucket look-up and one midpoint comparison.
    #[inline(always)]
    #[must_use]
    pub fn nearest(&self, ts: f32) -> usize {
        nearest_in(&self.near, &self.mids, ts).min(self.n - 1)
    }

    /// Whether [`NoisyReferences::nearest`] is valid (2 ≤ n < 16 ascending α_i, at most one midpoint
    /// per bucket).
    #[must_use]
    pub fn nearest_ok(&self) -> bool {
        self.near_ok
    }

    /// The midpoint table of [`NoisyReferences::nearest`] (bits; +∞ past the last midpoint).
    #[must_use]
    pub(crate) fn mids(&self) -> &[i32; MAX_SNR_SETS] {
        &self.mids
    }

    /// The bucket table of [`NoisyReferences::nearest`].
    #[must_use]
    pub(crate) fn near(&self) -> &[u8; LUT_LEN] {
        &self.near
    }

    /// For the weight α* = `dr / rr` of the unconstrained best mix, the index i ≤ n − 2 such that
    /// α_i and α_{i+1} bracket α* (0 below α_0, n − 2 above α_{n−1}); needs n ≥ 2 ascending α_i.
    /// `dr`, `rr` as in [`crate::similarity::CurveBuilder::accumulate`]; `rr = 0` gives any valid index.
    #[inline]
    #[must_use]
    pub fn bracket(&self, dr: f32, rr: f32) -> usize {
        let n = self.n;
        if self.lut_ok {
            let t = dr / rr;
            // `as` saturates (NaN → 0), so every t lands in a bucket.
            let b = ((t * LUT_LEN as f32) as usize).min(LUT_LEN - 1);
            let lo = self.lut[b] as usize;
            if lo + 2 < n && self.alphas[lo + 1] <= t {
                lo + 1
            } else {
                lo
            }
        } else {
            let (mut lo, mut hi) = (0usize, n - 1);
            while hi - lo > 1 {
                let mid = (lo + hi) / 2;
                if self.alphas[mid] * rr <= dr {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            lo
        }
    }

    /// All α_i slots (the first n are the weights; the rest repeat α_{n−1}).
    #[must_use]
    pub(crate) fn alphas_padded(&self) -> [f32; MAX_SNR_SETS] {
        self.alphas
    }

    /// The mixing rule.
    #[must_use]
    pub fn mixing(&self) -> NoiseMixing {
        self.mixing
    }

    /// Weights α_i of the clean feature, one per set.
    #[must_use]
    pub fn alphas(&self) -> &[f32] {
        &self.alphas[..self.n]
    }

    /// Reference `y` mixed as set `i`; `noise_mag`/`noise_pow` are the row's Y_η.
    #[must_use]
    pub fn mix(&self, i: usize, y: Feature, noise_mag: Feature, noise_pow: Feature) -> Feature {
        let a = self.alphas[i];
        let mut out = y;
        match self.mixing {
            NoiseMixing::Off => {}
            NoiseMixing::Magnitude => {
                for ((o, r), n) in out.iter_mut().zip(y).zip(noise_mag) {
                    *o = a * r + (1.0 - a) * n;
                }
            }
            NoiseMixing::Power => {
                for ((o, r), n) in out.iter_mut().zip(y).zip(noise_pow) {
                    *o = libm::sqrtf(a * r * r + (1.0 - a) * n * n);
                }
            }
        }
        out
    }
}

/// `f32::INFINITY.to_bits()`.
const INF_BITS: i32 = 0x7f80_0000;

/// [`NoisyReferences::nearest`] on its tables, without bounds checks (the bucket is clamped, the
/// index masked): the result is ≤ 16. `near` ≤ n − 1 and `mids` is +∞ from n − 1 on, so the result is
/// ≤ n − 1, except n for ts = +∞ or a positive NaN (the padded α slots repeat α_{n−1}, so index n means
/// the same weight). The midpoint comparison is on the bits as `i32`: for a positive midpoint that is
/// `ts ≥ mid` for every ts but a positive NaN (negative ts and −0 have negative bits).
#[inline(always)]
pub(crate) fn nearest_in(near: &[u8; LUT_LEN], mids: &[i32; MAX_SNR_SETS], ts: f32) -> usize {
    // `as` saturates (NaN → 0); the clamp also maps negative ts to bucket 0.
    let b = (ts as i32).clamp(0, LUT_LEN as i32 - 1) as usize;
    let lo = near[b & (LUT_LEN - 1)] as usize & (MAX_SNR_SETS - 1);
    lo + usize::from(ts.to_bits() as i32 >= mids[lo])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thesis_sets_and_mixing() {
        let n = NoisyReferences::new(NoiseMixing::Magnitude, -30.0, 40.0, 10.0).unwrap();
        assert_eq!(n.alphas().len(), 8);
        // 0 dB: G = 1, α = ½.
        assert!((n.alphas()[3] - 0.5).abs() < 1e-6);
        let y = n.mix(3, [1.0, 0.25, 0.25], [0.5; 3], [0.5; 3]);
        assert!((y[0] - 0.75).abs() < 1e-6 && (y[1] - 0.375).abs() < 1e-6);
        // −30 dB: nearly all noise.
        let y = n.mix(0, [1.0, 0.25, 0.25], [0.5; 3], [0.5; 3]);
        assert!((y[0] - 0.5).abs() < 0.02);
        let p = NoisyReferences::new(NoiseMixing::Power, 0.0, 0.0, 10.0).unwrap();
        let y = p.mix(0, [1.0, 0.0, 0.0], [0.5; 3], [0.0, 1.0, 0.0]);
        assert!((y[0] - 0.5f32.sqrt()).abs() < 1e-6 && (y[1] - 0.5f32.sqrt()).abs() < 1e-6);
        assert!(NoisyReferences::new(NoiseMixing::Magnitude, 0.0, 100.0, 1.0).is_err());
        assert_eq!(
            NoisyReferences::new(NoiseMixing::Off, 0.0, 0.0, 0.0)
                .unwrap()
                .alphas(),
            &[1.0]
        );
    }

    /// `nearest` equals a linear search for the smallest |α_i − α*| on a dense grid of α*, including
    /// values outside [0, 1].
    #[test]
    fn nearest_is_the_closest_alpha() {
        for mixing in [NoiseMixing::Magnitude, NoiseMixing::Power] {
            for (from, to, step) in [(-30.0, 40.0, 10.0), (-10.0, 20.0, 5.0), (0.0, 10.0, 10.0)] {
                let n = NoisyReferences::new(mixing, from, to, step).unwrap();
                // The thesis sets (magnitude mixing) must take the table path; power mixing packs
                // its high-SNR weights too close to 1 for it at −30…40 dB.
                if mixing == NoiseMixing::Magnitude {
                    assert!(n.nearest_ok(), "{from} {to} {step}");
                }
                if !n.nearest_ok() {
                    continue;
                }
                let a = n.alphas();
                for k in -2000..=4000 {
                    let t = k as f32 / 2000.0 + 1e-4;
                    let ts = t * LUT_LEN as f32;
                    let j = n.nearest(ts);
                    let dj = (a[j] - t).abs();
                    let best = a
                        .iter()
                        .map(|x| (x - t).abs())
                        .fold(f32::INFINITY, f32::min);
                    assert!(dj <= best + 1e-6, "{mixing:?} t {t} got {j}");
                }
                for ts in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -1e30] {
                    assert!(n.nearest(ts) < a.len());
                }
            }
        }
    }
}
