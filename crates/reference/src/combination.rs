//! Combination rule 2 (thesis §5.1.4, eq. 5.13): one azimuth per spectral peak (the argmax of that
//! peak's own similarity row, eq. 5.10), combined over the peaks by the circular mean (eq. 2.33, as
//! corrected in `docs/algorithm.md`: atan2(Σ sin, Σ cos)) or the circular median. Rule 1 (mean curve,
//! eq. 5.11–5.12) is the localizer's default.
//!
//! Also the FDIV frame quality of §5.2.2: the circular standard deviation s = √(−2 ln R̄) of the per-bin
//! azimuths (R̄ the mean resultant length), mapped to b = clip(1 − s/s_max, 0, 1) or, binary, to
//! b = 1 when s ≤ s_max.

use crate::bformat::{intensity, xy_complex};
use crate::cartesian_filter::CartesianFilter;
use crate::interpolation::argmax_parabolic;
use crate::reference_table::ReferenceTable;
use crate::similarity::CurveBuilder;
use crate::spectrum::power;
use crate::tdiv::IvEstimate;
use crate::{CHANNELS, MAX_AZIMUTHS, MAX_PEAKS, NUM_BINS};
use microfft::Complex32;

/// How a frame's peaks become one azimuth.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum Combination {
    /// Rule 1: mean similarity curve over the peaks, then argmax (eq. 5.11–5.12). Default.
    MeanCurve,
    /// Rule 2: per-peak argmax, circular mean over the peaks (eq. 5.13).
    PeakCircularMean,
    /// Rule 2: per-peak argmax, circular median over the peaks.
    PeakCircularMedian,
}

/// FDIV frame reliability from the circular standard deviation over bins (§5.2.2).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct FdivSpread {
    /// Scale s_max in degrees; 0 or less switches the option off (FDIV's own smoothing only).
    pub max_std_deg: f32,
    /// Binary: b = 1 when s ≤ s_max, else 0 (the thesis's example threshold is 30°).
    pub binary: bool,
}

impl FdivSpread {
    /// Off.
    pub const OFF: FdivSpread = FdivSpread {
        max_std_deg: 0.0,
        binary: false,
    };

    /// `true` when the option is on.
    #[must_use]
    pub fn enabled(&self) -> bool {
        self.max_std_deg > 0.0 && self.max_std_deg.is_finite()
    }

    /// b from a circular standard deviation in degrees.
    #[must_use]
    pub fn coefficient(&self, std_deg: f32) -> f32 {
        if !std_deg.is_finite() {
            return 0.0;
        }
        if self.binary {
            if std_deg <= self.max_std_deg {
                1.0
            } else {
                0.0
            }
        } else {
            (1.0 - std_deg / self.max_std_deg).clamp(0.0, 1.0)
        }
    }

    /// FDIV with this quality measure on one frame: the circular mean over bins `lo..=hi` of the
    /// frame's per-bin intensity azimuths ([`fdiv_bin_spread`] of `spectra`), filtered in Cartesian
    /// form (eq. 5.30, state `filter`) with b from their spread.
    pub fn frame(
        &self,
        filter: &mut CartesianFilter,
        spectra: &[[Complex32; NUM_BINS]; CHANNELS],
        lo: usize,
        hi: usize,
    ) -> IvEstimate {
        let (mean, std) = fdiv_bin_spread(spectra, lo, hi);
        let b = self.coefficient(std);
        let az = filter.update(b, mean).unwrap_or(mean);
        IvEstimate {
            azimuth_deg: az,
            azimuth_raw_deg: mean,
            confidence: b,
        }
    }
}

/// Circular mean of angles in degrees (eq. 2.33 corrected): atan2(Σ sin, Σ cos); `None` when empty or
/// when the resultant vanishes.
#[must_use]
pub fn circular_mean_deg(angles: &[f32]) -> Option<f32> {
    let (mut s, mut c) = (0.0f32, 0.0f32);
    for a in angles {
        let r = a.to_radians();
        let (sr, cr) = crate::trig::sin_cos(r);
        s += sr;
        c += cr;
    }
    if s == 0.0 && c == 0.0 {
        return None;
    }
    Some(libm::atan2f(s, c).to_degrees())
}

/// Circular median (CircStat's definition restricted to the samples): the sample angle whose summed
/// absolute circular distance to all others is smallest; `None` when empty.
#[must_use]
pub fn circular_median_deg(angles: &[f32]) -> Option<f32> {
    let mut best: Option<(f32, f32)> = None;
    for a in angles {
        let d: f32 = angles
            .iter()
            .map(|b| crate::angle::wrap_deg(a - b).abs())
            .sum();
        if best.is_none_or(|(_, bd)| d < bd) {
            best = Some((*a, d));
        }
    }
    best.map(|(a, _)| crate::angle::wrap_deg(a))
}

/// Circular standard deviation √(−2 ln R̄) of unit vectors summed into (Σcos, Σsin) over `n`
/// samples, in degrees; +∞ when n = 0 or R̄ = 0.
#[must_use]
pub fn circular_std_deg(sum_cos: f32, sum_sin: f32, n: usize) -> f32 {
    if n == 0 {
        return f32::INFINITY;
    }
    let r = libm::sqrtf(sum_cos * sum_cos + sum_sin * sum_sin) / n as f32;
    if r.is_nan() || r <= 0.0 {
        return f32::INFINITY;
    }
    libm::sqrtf((-2.0 * libm::logf(r.min(1.0))).max(0.0)).to_degrees()
}

/// Rule 2 on one frame: per-peak argmax of the similarity row (with parabolic interpolation), combined
/// by `rule`. `bin_rows[k]` is the table's frequency row of bin k. Returns `None` for rule 1 or when no
/// peak gave an estimate.
#[must_use]
pub fn per_peak_estimate(
    rule: Combination,
    builder: &CurveBuilder,
    table: &ReferenceTable<'_>,
    omni: &[Complex32; NUM_BINS],
    cardioids_at: impl Fn(usize) -> [Complex32; 3],
    peak_bins: &[u16],
    bin_rows: &[u16; NUM_BINS],
) -> Option<f32> {
    if rule == Combination::MeanCurve {
        return None;
    }
    let q = table.num_azimuths().min(MAX_AZIMUTHS);
    let mut row = [0.0f32; MAX_AZIMUTHS];
    let mut est = [0.0f32; MAX_PEAKS];
    let mut n = 0usize;
    for &k in peak_bins.iter().take(MAX_PEAKS) {
        let k = k as usize;
        if k >= NUM_BINS {
            continue;
        }
        let xc = cardioids_at(k);
        let Some(y) = builder.features.of_bin(omni[k], power(omni[k]), xc) else {
            continue;
        };
        row[..q].fill(0.0);
        builder.accumulate(table, bin_rows[k] as usize, y, 1.0, &mut row[..q]);
        if let Some((a, _)) = argmax_parabolic(&row[..q], table.azimuths_deg()) {
            est[n] = a;
            n += 1;
        }
    }
    match rule {
        Combination::MeanCurve => None,
        Combination::PeakCircularMean => circular_mean_deg(&est[..n]),
        Combination::PeakCircularMedian => circular_median_deg(&est[..n]),
    }
}

/// FDIV per-bin azimuths of the current frame's (unsmoothed) intensity over bins `lo..=hi`:
/// returns (circular mean azimuth in degrees, circular standard deviation in degrees).
#[must_use]
pub fn fdiv_bin_spread(
    spectra: &[[Complex32; NUM_BINS]; CHANNELS],
    lo: usize,
    hi: usize,
) -> (f32, f32) {
    let (mut sc, mut ss, mut n) = (0.0f32, 0.0f32, 0usize);
    let hi = hi.min(NUM_BINS - 1);
    let bins = |c: usize| spectra[c].get(lo..=hi).unwrap_or(&[]);
    let cards = bins(1).iter().zip(bins(2)).zip(bins(3));
    for (w, ((c1, c2), c3)) in bins(0).iter().zip(cards) {
        let [x, y] = xy_complex([*c1, *c2, *c3]);
        let [ix, iy] = intensity(*w, x, y);
        let m = libm::sqrtf(ix * ix + iy * iy);
        if m > 0.0 && m.is_finite() {
            sc += ix / m;
            ss += iy / m;
            n += 1;
        }
    }
    let mean = libm::atan2f(ss, sc).to_degrees();
    (mean, circular_std_deg(sc, ss, n))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noisy_reference::{NoiseMixing, NoisyReferences};
    use crate::similarity::SimilarityMeasure;

    #[test]
    fn circular_statistics() {
        let m = circular_mean_deg(&[170.0, -170.0]).unwrap();
        assert!((m.abs() - 180.0).abs() < 1e-3);
        assert_eq!(circular_mean_deg(&[]), None);
        assert!((circular_mean_deg(&[10.0, 30.0]).unwrap() - 20.0).abs() < 1e-4);
        // the median ignores one outlier, the mean does not
        let a = [10.0, 12.0, 14.0, 16.0, -150.0];
        assert_eq!(circular_median_deg(&a), Some(12.0));
        assert!(circular_mean_deg(&a).unwrap() < 9.0);
        assert_eq!(circular_median_deg(&[]), None);
        // std: identical angles → 0; uniform spread → ∞
        assert!(circular_std_deg(3.0, 0.0, 3) < 1e-3);
        assert_eq!(circular_std_deg(0.0, 0.0, 4), f32::INFINITY);
        // R̄ = cos 30° for ±30° → s = √(−2 ln cos 30°) ≈ 30.7°
        let c = 30f32.to_radians().cos();
        assert!((circular_std_deg(2.0 * c, 0.0, 2) - 30.7).abs() < 0.2);
    }

    #[test]
    fn spread_coefficient() {
        let s = FdivSpread {
            max_std_deg: 40.0,
            binary: false,
        };
        assert!(s.enabled() && !FdivSpread::OFF.enabled());
        assert!((s.coefficient(10.0) - 0.75).abs() < 1e-6);
        assert_eq!(s.coefficient(80.0), 0.0);
        assert_eq!(s.coefficient(f32::INFINITY), 0.0);
        let b = FdivSpread { binary: true, ..s };
        assert_eq!(b.coefficient(39.0), 1.0);
        assert_eq!(b.coefficient(41.0), 0.0);
    }

    #[test]
    fn rule_2_finds_a_plane_wave_and_fdiv_spread_is_small() {
        let table = ReferenceTable::ideal_5deg();
        let builder = CurveBuilder {
            measure: SimilarityMeasure::Euclidean,
            noisy: NoisyReferences::new(NoiseMixing::Off, 0.0, 0.0, 10.0).unwrap(),
            mean_free: false,
            features: crate::features::FeatureKind::Magnitude,
        };
        let mut spectra = [[Complex32::new(0.0, 0.0); NUM_BINS]; CHANNELS];
        let az = 65f32.to_radians();
        for k in 10..100 {
            let s = Complex32::new(1.0 + k as f32 * 0.01, 0.3);
            spectra[0][k] = s;
            for (m, ch) in spectra.iter_mut().skip(1).enumerate() {
                let l = (m as f32 * 120.0).to_radians();
                ch[k] = s * (0.5 + 0.5 * libm::cosf(az - l));
            }
        }
        let bins: [u16; 5] = [12, 30, 47, 60, 88];
        let mut rows = [0u16; NUM_BINS];
        for (k, r) in rows.iter_mut().enumerate() {
            *r = table.freq_index(k as f32 * 10.0) as u16;
        }
        // Both feature kinds: rule 2 computes the features the builder compares.
        let kinds = [
            crate::features::FeatureKind::Magnitude,
            crate::features::FeatureKind::Active,
        ];
        for (rule, features) in [
            Combination::PeakCircularMean,
            Combination::PeakCircularMedian,
        ]
        .into_iter()
        .flat_map(|r| kinds.map(|f| (r, f)))
        {
            let a = per_peak_estimate(
                rule,
                &CurveBuilder {
                    features,
                    ..builder
                },
                &table,
                &spectra[0],
                |k| [spectra[1][k], spectra[2][k], spectra[3][k]],
                &bins,
                &rows,
            )
            .unwrap();
            assert!((a - 65.0).abs() < 1.5, "{rule:?} {features:?}: {a}");
        }
        assert_eq!(
            per_peak_estimate(
                Combination::MeanCurve,
                &builder,
                &table,
                &spectra[0],
                |k| [spectra[1][k], spectra[2][k], spectra[3][k]],
                &bins,
                &rows
            ),
            None
        );
        let (m, s) = fdiv_bin_spread(&spectra, 10, 99);
        assert!((m - 65.0).abs() < 0.1 && s < 0.5, "{m} {s}");
    }
}
