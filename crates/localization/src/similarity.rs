//! Similarity between observed and reference features (thesis eq. 4.17–4.19) and the mean
//! similarity curve over the picked peaks (eq. 5.9, 5.11, with the noisy references of eq. 5.20).

use crate::curve_kernel::CurveKernel;
use crate::curve_kernel::DistancePower;
use crate::error::Error;
use crate::fast_math::{
    clamp_nonneg, pow_three_halves_nonneg2, sqrt_nonneg, sqrt_nonneg2, sqrtf, sqrtf2,
};
use crate::features::FeatureKind;
use crate::noisy_reference::{nearest_in, NoiseMixing, NoisyReferences, LUT_LEN};

/// Bucket scale of the α tables of [`NoisyReferences`].
const LUT_SCALE: f32 = LUT_LEN as f32;
use crate::reference_table::{Feature, FeatureRows, ReferenceTable};
use crate::MAX_SNR_SETS;

/// Similarity measure.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub enum SimilarityMeasure {
    /// 1 / (1 + ‖a − b‖₂) (eq. 4.18 with p = 2), the default.
    Euclidean,
    /// aᵀb / (‖a‖‖b‖) (eq. 4.19).
    Cosine,
    /// 1 / (1 + ‖a − b‖_p), p > 0.
    Lp(f32),
}

impl SimilarityMeasure {
    /// Similarity of two feature vectors, in [0, 1] (cosine: [−1, 1], 0 for a zero vector).
    #[must_use]
    pub fn similarity(&self, a: Feature, b: Feature) -> f32 {
        match *self {
            SimilarityMeasure::Euclidean => {
                let d2: f32 = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
                1.0 / (1.0 + libm::sqrtf(d2))
            }
            SimilarityMeasure::Cosine => {
                let dot: f32 = a.iter().zip(b).map(|(x, y)| x * y).sum();
                let na: f32 = a.iter().map(|x| x * x).sum();
                let nb: f32 = b.iter().map(|x| x * x).sum();
                let den = libm::sqrtf(na * nb);
                if den > 0.0 {
                    dot / den
                } else {
                    0.0
                }
            }
            SimilarityMeasure::Lp(p) => {
                let s: f32 = a
                    .iter()
                    .zip(b)
                    .map(|(x, y)| libm::powf(libm::fabsf(x - y), p))
                    .sum();
                1.0 / (1.0 + libm::powf(s, 1.0 / p))
            }
        }
    }
}

/// "Mean-free" features (appendix A `meanFree`): Y − mean(Y) + ½.
#[must_use]
pub fn mean_free(y: Feature) -> Feature {
    let m = (y[0] + y[1] + y[2]) / 3.0;
    [y[0] - m + 0.5, y[1] - m + 0.5, y[2] - m + 0.5]
}

/// Most peaks of one row that [`CurveBuilder::accumulate_peaks`] takes in one pass.
const GROUP: usize = 2;

/// Azimuths a [`RowCache`] holds (tables with more azimuths take the uncached path).
pub const ROW_CACHE_LEN: usize = 128;

/// The per-azimuth constants of one frequency row of the fast Euclidean path of
/// [`CurveBuilder::accumulate_cached`]: with r = Y_ref(q) − Y_η, the vector −2r, ‖r‖² and
/// −64/‖r‖² (−½·128/‖r‖², 128 buckets of the α table), computed once per row instead of once per peak
/// and azimuth.
///
/// On x86_64 the constants are stored as five arrays over the azimuths (structure of arrays), for the
/// SSE2 kernel that takes four azimuths at a time; elsewhere (the Cortex-M4F) as one array of
/// five-element entries.
#[derive(Debug, Clone, Copy)]
pub struct RowCache {
    /// Row the entries belong to (`usize::MAX`: none).
    fi: usize,
    /// The row's omni-noise feature Y_η, which the entries are relative to.
    noise: Feature,
    /// Per azimuth: −2r₀, −2r₁, −2r₂, ‖r‖², −64/‖r‖² (see [`row_constants`]).
    #[cfg(not(target_arch = "x86_64"))]
    rows: [[f32; 5]; ROW_CACHE_LEN],
    /// Per constant (−2r₀, −2r₁, −2r₂, ‖r‖², −64/‖r‖², see [`row_constants`]): its value per azimuth.
    #[cfg(target_arch = "x86_64")]
    soa: [[f32; ROW_CACHE_LEN]; 5],
}

impl RowCache {
    /// An empty cache.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            fi: usize::MAX,
            noise: [0.0; 3],
            #[cfg(not(target_arch = "x86_64"))]
            rows: [[0.0; 5]; ROW_CACHE_LEN],
            #[cfg(target_arch = "x86_64")]
            soa: [[0.0; ROW_CACHE_LEN]; 5],
        }
    }

    /// Forgets the cached row (call when the table or the feature kind changes).
    pub fn clear(&mut self) {
        self.fi = usize::MAX;
    }
}

impl Default for RowCache {
    fn default() -> Self {
        Self::new()
    }
}

/// One picked peak as the similarity curve needs it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeakFeature {
    /// Frequency row of the reference table.
    pub fi: usize,
    /// Observed features.
    pub y: Feature,
    /// Weight of the peak in the mean curve.
    pub weight: f32,
}

impl PeakFeature {
    /// An unused slot: row 0, zero features and weight.
    pub const NONE: PeakFeature = PeakFeature {
        fi: 0,
        y: [0.0; 3],
        weight: 0.0,
    };
}

/// Where [`CurveBuilder::accumulate_peaks_with_distance`] adds the peaks' weighted distance powers
/// Σ w·d^p (for the grid tracker's refinement curve and [`crate::curve_kernel::CurveKernel`]) next
/// to the similarity curve.
#[derive(Debug)]
pub struct DistanceSum<'a> {
    /// The power p of the distance.
    pub power: DistancePower,
    /// Per azimuth: Σ w·d^p (added to, like the similarity curve).
    pub curve: &'a mut [f32],
    /// Only the distance sums are wanted: the fast cached path then leaves the similarity curve
    /// unchanged, the others zero it and add to it, so the caller must treat it as scratch.
    pub sums_only: bool,
}

impl DistanceSum<'_> {
    /// The same sums, borrowed for one call.
    pub fn reborrow(&mut self) -> DistanceSum<'_> {
        DistanceSum {
            power: self.power,
            curve: &mut *self.curve,
            sums_only: self.sums_only,
        }
    }
}

/// How one peak's similarity row is computed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveBuilder {
    /// Similarity measure.
    pub measure: SimilarityMeasure,
    /// Noisy reference sets.
    pub noisy: NoisyReferences,
    /// Apply [`mean_free`] to observed and reference features.
    pub mean_free: bool,
    /// Which features are compared: the table's rows for this kind ([`ReferenceTable::rows`]) are
    /// the references, and their noisy references mix toward that kind's omni-noise row.
    pub features: FeatureKind,
}

/// The settings of the similarity curve: the measure, the noisy references and the features (in
/// the configuration file, top-level keys of the same names).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CurveSettings {
    /// Similarity measure.
    pub measure: SimilarityMeasure,
    /// Noisy reference features: mixing rule.
    pub noise_mixing: NoiseMixing,
    /// Noisy reference features: lowest SNR set, dB.
    pub snr_from_db: f32,
    /// Noisy reference features: highest SNR set, dB.
    pub snr_to_db: f32,
    /// Noisy reference features: SNR step, dB.
    pub snr_step_db: f32,
    /// Mean-free features (appendix A `meanFree`).
    pub mean_free: bool,
    /// Which ratio the peak features are (the thesis: magnitudes).
    pub features: FeatureKind,
}

impl CurveBuilder {
    /// A placeholder of an unconfigured localizer: Euclidean magnitude features, clean references.
    pub const IDLE: CurveBuilder = CurveBuilder {
        measure: SimilarityMeasure::Euclidean,
        noisy: NoisyReferences::off(),
        mean_free: false,
        features: FeatureKind::Magnitude,
    };

    /// The similarity-curve builder of `config`, or the error of its SNR sets.
    pub fn from_config(config: &CurveSettings) -> Result<Self, Error> {
        Ok(CurveBuilder {
            measure: config.measure,
            noisy: NoisyReferences::new(
                config.noise_mixing,
                config.snr_from_db,
                config.snr_to_db,
                config.snr_step_db,
            )?,
            mean_free: config.mean_free,
            features: config.features,
        })
    }

    /// Adds `weight · max_i Sim(y, Y_ref(q, i))` to `curve[q]` for every azimuth q of frequency row `fi`.
    ///
    /// Euclidean similarity with clean or magnitude-mixed references takes a fast path: all mixed
    /// references lie on the segment between Y_ref(q) and Y_η, so
    /// ‖y − Y_i‖² = ‖d‖² − 2α_i·d·r + α_i²·‖r‖² with d = y − Y_η, r = Y_ref(q) − Y_η, and only the
    /// smallest distance needs a square root. That distance is a parabola in α_i, symmetric about its
    /// vertex α* = d·r/‖r‖², so the best α_i is the one nearest to α* ([`NoisyReferences::nearest`],
    /// evaluated at α*·128, computed as (−2r·d)·(−64/‖r‖²)); when that table is not valid, the two α_i
    /// bracketing α* are evaluated and the smaller distance kept (the α_i ascend: [`NoisyReferences`]
    /// builds them from ascending SNRs). It equals the direct evaluation up to rounding (at a near-tie
    /// of two α_i either may be taken; their distances then agree to rounding).
    pub fn accumulate(
        &self,
        table: &ReferenceTable<'_>,
        fi: usize,
        y: Feature,
        weight: f32,
        curve: &mut [f32],
    ) {
        self.accumulate_into(table, fi, y, weight, curve, None);
    }

    /// [`CurveBuilder::accumulate`], and with `distance` also `weight · d^p` into its curve, d the
    /// distance to the nearest reference (the fast paths' minimum; from the similarity s as 1/s − 1
    /// for the Euclidean and L_p measures, 1 − s for the cosine).
    pub fn accumulate_into(
        &self,
        table: &ReferenceTable<'_>,
        fi: usize,
        y: Feature,
        weight: f32,
        curve: &mut [f32],
        mut distance: Option<DistanceSum<'_>>,
    ) {
        let rows = table.rows(self.features);
        let row = rows.row(fi);
        let noise_mag = rows.noise(fi);
        let noise_pow = table.noise_power(fi);
        let fast = self.measure == SimilarityMeasure::Euclidean
            && !self.mean_free
            && self.noisy.mixing() != NoiseMixing::Power;
        if fast {
            let d = minus(y, noise_mag);
            let dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
            let alphas = self.noisy.alphas();
            let n = alphas.len();
            if self.noisy.nearest_ok() {
                for (q, (c, r)) in curve.iter_mut().zip(row).enumerate() {
                    let r = minus(*r, noise_mag);
                    let [m0, m1, m2, rr, sc] = row_constants(r);
                    let m2dr = d[0] * m0 + d[1] * m1 + d[2] * m2;
                    let a = alphas[self.noisy.nearest(m2dr * sc)];
                    let best = dd + a * (a * rr + m2dr);
                    let root = sqrt_nonneg(best);
                    *c += weight / (1.0 + root);
                    add_distance(&mut distance, q, weight, clamp_nonneg(best), root);
                }
                return;
            }
            for (q, (c, r)) in curve.iter_mut().zip(row).enumerate() {
                let r = minus(*r, noise_mag);
                let dr = d[0] * r[0] + d[1] * r[1] + d[2] * r[2];
                let rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
                // ‖d − α·r‖² is a parabola in α with its minimum at α* = d·r / ‖r‖², so the best of the
                // ascending α_i is one of the two that bracket α* (found by a bucket table, see
                // `NoisyReferences::bracket`); keep the smaller of their two distances.
                let best = if n == 1 {
                    let a = alphas[0];
                    dd + a * (a * rr - 2.0 * dr)
                } else {
                    let lo = self.noisy.bracket(dr, rr);
                    let (a, b) = (alphas[lo], alphas[lo + 1]);
                    let da = dd + a * (a * rr - 2.0 * dr);
                    let db = dd + b * (b * rr - 2.0 * dr);
                    if db < da {
                        db
                    } else {
                        da
                    }
                };
                // `if` rather than `f32::max`, which is a library call on the Cortex-M4F.
                let best = if best > 0.0 { best } else { 0.0 };
                let root = sqrtf(best);
                *c += weight / (1.0 + root);
                add_distance(&mut distance, q, weight, best, root);
            }
            return;
        }
        let y = if self.mean_free { mean_free(y) } else { y };
        for (q, (c, r)) in curve.iter_mut().zip(row).enumerate() {
            let sim = self.max_similarity(y, *r, noise_mag, noise_pow);
            *c += weight * sim;
            if distance.is_some() {
                let d = if self.measure == SimilarityMeasure::Cosine {
                    clamp_nonneg(1.0 - sim)
                } else {
                    crate::curve_kernel::distance_of_similarity(sim)
                };
                add_distance(&mut distance, q, weight, d * d, d);
            }
        }
    }

    /// [`CurveBuilder::accumulate`] with the per-azimuth constants of row `fi` kept in `cache` (which
    /// must have been cleared since the table last changed): the same arithmetic in the same order, so
    /// the curve is bit-identical, but the inner loop only does what depends on the peak (no division:
    /// 128/‖r‖² is cached).
    pub fn accumulate_cached(
        &self,
        cache: &mut RowCache,
        table: &ReferenceTable<'_>,
        fi: usize,
        y: Feature,
        weight: f32,
        curve: &mut [f32],
    ) {
        let Some(q) = self.cached_len(table, curve) else {
            self.accumulate(table, fi, y, weight, curve);
            return;
        };
        let noise_mag = self.fill_cache(cache, table, fi);
        self.accumulate_group(cache, noise_mag, [y], [weight], &mut curve[..q], None);
    }

    /// [`CurveBuilder::accumulate_cached`] for each peak in order, with two consecutive peaks of the
    /// same frequency row taken in one pass over the azimuths (each azimuth's constants loaded and its
    /// curve value read and written once for both). The additions into each `curve[q]` happen in the
    /// same order, so the curve is bit-identical to calling [`CurveBuilder::accumulate_cached`] per peak.
    pub fn accumulate_peaks(
        &self,
        cache: &mut RowCache,
        table: &ReferenceTable<'_>,
        peaks: &[PeakFeature],
        curve: &mut [f32],
    ) {
        self.accumulate_peaks_with_distance(cache, table, peaks, curve, None);
    }

    /// [`CurveBuilder::accumulate_peaks`], and with `distance` also Σ w·d^p per azimuth into its
    /// curve (see [`CurveBuilder::accumulate_into`]), in the same pass: the distance of each peak and
    /// azimuth is computed once for both. The similarity curve is bit-identical to
    /// [`CurveBuilder::accumulate_peaks`].
    pub fn accumulate_peaks_with_distance(
        &self,
        cache: &mut RowCache,
        table: &ReferenceTable<'_>,
        peaks: &[PeakFeature],
        curve: &mut [f32],
        mut distance: Option<DistanceSum<'_>>,
    ) {
        let Some(q) = self.cached_len(table, curve) else {
            if distance.as_ref().is_some_and(|d| d.sums_only) {
                curve.fill(0.0);
            }
            for p in peaks {
                let ds = distance.as_mut().map(DistanceSum::reborrow);
                self.accumulate_into(table, p.fi, p.y, p.weight, curve, ds);
            }
            return;
        };
        let curve = &mut curve[..q];
        let mut rest = peaks;
        while let Some(p) = rest.first() {
            let noise_mag = self.fill_cache(cache, table, p.fi);
            let run = rest.iter().take(GROUP).take_while(|x| x.fi == p.fi).count();
            let ds = distance.as_mut().map(DistanceSum::reborrow);
            if run == 2 {
                let (p2, ws) = (rest[1], [p.weight, rest[1].weight]);
                self.accumulate_group(cache, noise_mag, [p.y, p2.y], ws, curve, ds);
            } else {
                self.accumulate_group(cache, noise_mag, [p.y], [p.weight], curve, ds);
            }
            rest = &rest[run..];
        }
    }

    /// The frame's curve sums from its peaks, both buffers zeroed first: with the
    /// [`CurveKernel::Reciprocal`] kernel the similarity sums into `curve` and, with `refine`, Σ w·d^p
    /// into `distance` (the grid tracker's refinement curve); with a distance
    /// kernel Σ w·d^p into `curve`, and `distance` is scratch (not zeroed: the fast path does not
    /// touch it). [`normalise_frame_curve`] turns the sums into the curves.
    #[allow(clippy::too_many_arguments)]
    pub fn frame_curve(
        &self,
        cache: &mut RowCache,
        table: &ReferenceTable<'_>,
        peaks: &[PeakFeature],
        kernel: CurveKernel,
        refine: Option<DistancePower>,
        curve: &mut [f32],
        distance: &mut [f32],
    ) {
        curve.fill(0.0);
        if let Some((power, _)) = kernel.distance() {
            let sums = DistanceSum {
                power,
                curve,
                sums_only: true,
            };
            self.accumulate_peaks_with_distance(cache, table, peaks, distance, Some(sums));
        } else {
            let sums = refine.map(|power| {
                distance.fill(0.0);
                DistanceSum {
                    power,
                    curve: distance,
                    sums_only: false,
                }
            });
            self.accumulate_peaks_with_distance(cache, table, peaks, curve, sums);
        }
    }

    /// The number of curve entries to update when the cached nearest-α path applies (Euclidean,
    /// magnitude mixing, valid tables, at most [`ROW_CACHE_LEN`] azimuths), else `None`.
    fn cached_len(&self, table: &ReferenceTable<'_>, curve: &[f32]) -> Option<usize> {
        let q = table.num_azimuths().min(curve.len());
        let ok = self.measure == SimilarityMeasure::Euclidean
            && !self.mean_free
            && self.noisy.mixing() != NoiseMixing::Power
            && self.noisy.nearest_ok()
            && self.noisy.alphas().len() >= 2
            && q <= ROW_CACHE_LEN;
        ok.then_some(q)
    }

    /// Makes `cache` hold row `fi` of the table's rows for this builder's feature kind; returns the
    /// row's omni-noise feature Y_η.
    #[inline(always)]
    fn fill_cache(&self, cache: &mut RowCache, table: &ReferenceTable<'_>, fi: usize) -> Feature {
        if cache.fi == fi {
            return cache.noise;
        }
        self.refill_cache(cache, &table.rows(self.features), fi)
    }

    /// [`CurveBuilder::fill_cache`] when the cache holds another row (with the ideal tables, which
    /// have one row, only once), out of line so that the per-peak loop keeps its registers (a
    /// [`FeatureRows`] live across it cost the Cortex-M4F ≈ 360 instructions per hop).
    #[inline(never)]
    fn refill_cache(&self, cache: &mut RowCache, rows: &FeatureRows<'_>, fi: usize) -> Feature {
        let noise_mag = rows.noise(fi);
        let entries = rows
            .row(fi)
            .iter()
            .take(ROW_CACHE_LEN)
            .map(|r| row_constants(minus(*r, noise_mag)));
        #[cfg(not(target_arch = "x86_64"))]
        for (e, c) in cache.rows.iter_mut().zip(entries) {
            *e = c;
        }
        #[cfg(target_arch = "x86_64")]
        for (q, e) in entries.enumerate() {
            for k in 0..5 {
                cache.soa[k][q] = e[k];
            }
        }
        cache.fi = fi;
        cache.noise = noise_mag;
        noise_mag
    }

    /// The inner loop of the cached path for G peaks of the row in `cache` (Y_η = `noise_mag`): per
    /// azimuth, `curve[q] += w_g / (1 + min_i ‖y_g − Y_i‖)` for g = 0, 1, … in this order.
    #[inline(always)]
    fn accumulate_group<const G: usize>(
        &self,
        cache: &RowCache,
        noise_mag: Feature,
        ys: [Feature; G],
        weights: [f32; G],
        curve: &mut [f32],
        distance: Option<DistanceSum<'_>>,
    ) {
        let Some(ds) = distance else {
            self.group_loop::<G, true, false, 0>(cache, noise_mag, ys, weights, curve, &mut []);
            return;
        };
        let n = curve.len().min(ds.curve.len());
        let (curve, dist) = (&mut curve[..n], &mut ds.curve[..n]);
        if ds.sums_only {
            self.power_loop::<G, false>(cache, noise_mag, ys, weights, curve, dist, ds.power);
        } else {
            self.power_loop::<G, true>(cache, noise_mag, ys, weights, curve, dist, ds.power);
        }
    }

    /// [`CurveBuilder::group_loop`] with distance sums of power `power`: one instance per power, so
    /// that the loop holds no branch on it.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn power_loop<const G: usize, const S: bool>(
        &self,
        cache: &RowCache,
        noise_mag: Feature,
        ys: [Feature; G],
        weights: [f32; G],
        curve: &mut [f32],
        dist: &mut [f32],
        power: DistancePower,
    ) {
        let (c, w) = (cache, noise_mag);
        match power {
            DistancePower::One => self.group_loop::<G, S, true, 2>(c, w, ys, weights, curve, dist),
            DistancePower::ThreeHalves => {
                self.group_loop::<G, S, true, 3>(c, w, ys, weights, curve, dist)
            }
            DistancePower::Two => self.group_loop::<G, S, true, 4>(c, w, ys, weights, curve, dist),
        }
    }

    /// The loop of [`CurveBuilder::accumulate_group`]; with `S` the similarity sums into `curve`, with
    /// `D` also Σ w·d^p into `dist` (as long as `curve`), p = `P2`/2 ([`DistancePower`]: 2, 3 or 4).
    /// At least one of `S` and `D` is set.
    #[inline(always)]
    fn group_loop<const G: usize, const S: bool, const D: bool, const P2: u8>(
        &self,
        cache: &RowCache,
        noise_mag: Feature,
        ys: [Feature; G],
        weights: [f32; G],
        curve: &mut [f32],
        dist: &mut [f32],
    ) {
        let power = match P2 {
            3 => DistancePower::ThreeHalves,
            4 => DistancePower::Two,
            _ => DistancePower::One,
        };
        let d: [Feature; G] = ys.map(|y| minus(y, noise_mag));
        let dd: [f32; G] = core::array::from_fn(|g| {
            let d = d[g];
            d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        });
        // Fixed-size copies: the indices are masked into range, so no bounds checks.
        let padded = self.noisy.alphas_padded();
        let mut alphas = [padded[MAX_SNR_SETS - 1]; MAX_SNR_SETS + 1];
        alphas[..MAX_SNR_SETS].copy_from_slice(&padded);
        let mids = self.noisy.mids();
        let near = self.noisy.near();
        // x86_64: four azimuths at a time in SSE2 lanes (the same operations per azimuth), the rest
        // (fewer than four) below.
        #[cfg(target_arch = "x86_64")]
        let (curve, first) = {
            let n = self.noisy.alphas().len();
            let done = sse::group::<G, S, D>(
                &cache.soa, &d, &dd, &weights, &alphas, mids, n, curve, dist, power,
            );
            (&mut curve[done..], done)
        };
        #[cfg(target_arch = "x86_64")]
        let dist = if D { &mut dist[first..] } else { dist };
        #[cfg(not(target_arch = "x86_64"))]
        let entries = cache.rows.iter().copied();
        #[cfg(target_arch = "x86_64")]
        let entries =
            (first..ROW_CACHE_LEN).map(|q| core::array::from_fn::<f32, 5, _>(|k| cache.soa[k][q]));
        // One azimuth: its similarity sum and distance sum after the G peaks.
        let body = |acc: f32, dacc: f32, e: [f32; 5]| -> (f32, f32) {
            let [m0, m1, m2, rr, sc] = e;
            let best: [f32; G] = core::array::from_fn(|g| {
                let d = d[g];
                let m2dr = d[0] * m0 + d[1] * m1 + d[2] * m2;
                // `NoisyReferences::nearest`, inlined (index ≤ 16; index n is a copy of α_{n−1}).
                let a = alphas[nearest_in(near, mids, m2dr * sc)];
                dd[g] + a * (a * rr + m2dr)
            });
            let (mut acc, mut dacc) = (acc, dacc);
            if !S && power == DistancePower::ThreeHalves {
                // Only d^1.5: one FPU block for both powers of a pair.
                for g in (0..G).step_by(2) {
                    // A lone peak goes through the pair block twice (a group of one is rare).
                    let p = pow_three_halves_nonneg2([best[g], best[(g + 1).min(G - 1)]]);
                    for (k, h) in (g..G.min(g + 2)).enumerate() {
                        dacc += weights[h] * p[k];
                    }
                }
                return (acc, dacc);
            }
            for g in (0..G).step_by(2) {
                // Square roots two at a time (one register transfer each way on the M4F).
                let pair = g + 1 < G;
                let root = if pair {
                    sqrt_nonneg2([best[g], best[g + 1]])
                } else {
                    [sqrt_nonneg(best[g]), 0.0]
                };
                // `root` is ≥ 0 (or a positive NaN) already: no clamp.
                let root2 = if D && power == DistancePower::ThreeHalves {
                    if pair {
                        sqrtf2(root)
                    } else {
                        [sqrtf(root[0]), 0.0]
                    }
                } else {
                    [0.0; 2]
                };
                for (k, h) in (g..G.min(g + 2)).enumerate() {
                    if S {
                        acc += weights[h] / (1.0 + root[k]);
                    }
                    if D {
                        let p = match power {
                            DistancePower::One => root[k],
                            DistancePower::ThreeHalves => root[k] * root2[k],
                            DistancePower::Two => clamp_nonneg(best[h]),
                        };
                        dacc += weights[h] * p;
                    }
                }
            }
            (acc, dacc)
        };
        if !S {
            for (v, e) in dist.iter_mut().zip(entries) {
                *v = body(0.0, *v, e).1;
            }
        } else if D {
            for ((c, v), e) in curve.iter_mut().zip(dist.iter_mut()).zip(entries) {
                (*c, *v) = body(*c, *v, e);
            }
        } else {
            for (c, e) in curve.iter_mut().zip(entries) {
                *c = body(*c, 0.0, e).0;
            }
        }
    }

    /// max over the SNR sets of Sim(y, mix_i(r)) — the direct evaluation.
    #[must_use]
    pub fn max_similarity(
        &self,
        y: Feature,
        r: Feature,
        noise_mag: Feature,
        noise_pow: Feature,
    ) -> f32 {
        let mut best = f32::NEG_INFINITY;
        for i in 0..self.noisy.alphas().len() {
            let mut ref_i = self.noisy.mix(i, r, noise_mag, noise_pow);
            if self.mean_free {
                ref_i = mean_free(ref_i);
            }
            let s = self.measure.similarity(y, ref_i);
            if s > best {
                best = s;
            }
        }
        best
    }
}

/// Divides the sums of [`CurveBuilder::frame_curve`] by the total peak weight `weight_sum` > 0:
/// the mean similarity curve (1 − k·Σ w·d^p / Σ w for a distance kernel) and, with `refine`, the
/// negated mean distance curve −Σ w·d^p / Σ w, which like the similarity curve peaks at the talker.
/// Returns the sum of the similarity curve, added in order from 0 (for
/// [`crate::reliability::curve_variance_with_sum`]).
pub fn normalise_frame_curve(
    kernel: CurveKernel,
    refine: bool,
    weight_sum: f32,
    curve: &mut [f32],
    distance: &mut [f32],
) -> f32 {
    let inv = 1.0 / weight_sum;
    let mut sum = 0.0f32;
    if let Some((_, scale)) = kernel.distance() {
        let m = scale * inv;
        for c in curve.iter_mut() {
            *c = 1.0 - *c * m;
            sum += *c;
        }
    } else {
        for c in curve.iter_mut() {
            *c *= inv;
            sum += *c;
        }
        if refine {
            let neg = -inv;
            for v in distance.iter_mut() {
                *v *= neg;
            }
        }
    }
    sum
}

/// Adds `weight · d^p` at azimuth `q` of the distance sum, if there is one (d² = `squared`, d = `root`).
#[inline(always)]
fn add_distance(
    distance: &mut Option<DistanceSum<'_>>,
    q: usize,
    weight: f32,
    squared: f32,
    root: f32,
) {
    if let Some(ds) = distance.as_mut() {
        if let Some(v) = ds.curve.get_mut(q) {
            *v += weight * ds.power.of(squared, root);
        }
    }
}

/// a − b per component.
#[inline(always)]
fn minus(a: Feature, b: Feature) -> Feature {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// The per-azimuth constants of the nearest-α fast path for r = Y_ref(q) − Y_η: −2r, ‖r‖² and
/// −(128/2)/‖r‖². Then m = d·(−2r) = −2·d·r exactly (scaling by 2 is exact), the vertex of the parabola
/// in buckets is α*·128 = m·(−64/‖r‖²), and ‖d − α·r‖² = ‖d‖² + α(α‖r‖² + m).
#[inline(always)]
fn row_constants(r: Feature) -> [f32; 5] {
    let rr = r[0] * r[0] + r[1] * r[1] + r[2] * r[2];
    [
        -2.0 * r[0],
        -2.0 * r[1],
        -2.0 * r[2],
        rr,
        -(LUT_SCALE / 2.0) / rr,
    ]
}

/// The SSE2 kernel of [`CurveBuilder::accumulate_group`] on x86_64 (SSE2 is part of the x86_64
/// baseline): four azimuths per step, each lane doing exactly the scalar path's IEEE operations in the
/// same order (no FMA, no reassociation; `sqrtps`/`divps` are correctly rounded like `sqrtss`/`divss`),
/// so the curve is bit-identical to the scalar loop.
///
/// The bucket-table look-up of [`nearest_in`] (a gather) becomes a compare/select chain over the
/// midpoints: with ascending midpoints `mids[0..n]` (+∞ from n − 1 on) the number c of midpoints whose
/// bits are ≤ the bits of ts is the index `nearest_in` returns, and α_c is built by XOR-ing the bit
/// differences α_j ^ α_{j+1} of the first c steps into α_0. The cases where the two indices differ
/// give the same weight: ts = +∞ (c = n, `nearest_in` n − 1 or n; slot n repeats α_{n−1}); a positive
/// NaN (all bits compare ≥, `nearest_in` gives 1) is mapped to α_1 explicitly.
#[cfg(target_arch = "x86_64")]
mod sse {
    use super::{DistancePower, Feature, ROW_CACHE_LEN};
    use crate::MAX_SNR_SETS;
    use core::arch::x86_64::{
        __m128, __m128i, _mm_add_ps, _mm_and_ps, _mm_andnot_ps, _mm_andnot_si128, _mm_castps_si128,
        _mm_castsi128_ps, _mm_cmpgt_epi32, _mm_div_ps, _mm_loadu_ps, _mm_mul_ps, _mm_or_ps,
        _mm_set1_epi32, _mm_set1_ps, _mm_setzero_ps, _mm_setzero_si128, _mm_sqrt_ps,
        _mm_srai_epi32, _mm_storeu_ps, _mm_xor_ps,
    };

    /// `f32::INFINITY.to_bits()`.
    const INF_BITS: i32 = 0x7f80_0000;

    /// For the first ⌊len/4⌋·4 azimuths of `curve`: `curve[q] += w_g / (1 + √max(best_g(q), 0))` for
    /// g = 0, 1, … in order, with `best_g(q)` = dd_g + α(α‖r‖² + m) as in the scalar loop. `soa` holds
    /// the row constants per azimuth, `alphas`/`mids` the padded weights and midpoint bits of
    /// `NoisyReferences` (2 ≤ n < 16 weights, valid nearest-α tables). Returns the number of azimuths
    /// done.
    #[allow(unsafe_code, clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn group<const G: usize, const S: bool, const D: bool>(
        soa: &[[f32; ROW_CACHE_LEN]; 5],
        d: &[Feature; G],
        dd: &[f32; G],
        weights: &[f32; G],
        alphas: &[f32; MAX_SNR_SETS + 1],
        mids: &[i32; MAX_SNR_SETS],
        n: usize,
        curve: &mut [f32],
        dist: &mut [f32],
        power: DistancePower,
    ) -> usize {
        let len = curve.len().min(ROW_CACHE_LEN) / 4 * 4;
        let len = if D { len.min(dist.len() / 4 * 4) } else { len };
        let n = n.min(MAX_SNR_SETS);
        // SAFETY: SSE2 is enabled on every x86_64 target, so the intrinsics exist; all of them work
        // on registers only, except `_mm_loadu_ps`/`_mm_storeu_ps`, which read or write four f32
        // through the pointer of a slice `[i..i + 4]` (bounds-checked, so four valid elements; the
        // unaligned forms need no alignment).
        unsafe {
            let mut steps = [_mm_setzero_ps(); MAX_SNR_SETS];
            let mut mid = [_mm_setzero_si128(); MAX_SNR_SETS];
            for j in 0..n {
                steps[j] = _mm_xor_ps(_mm_set1_ps(alphas[j]), _mm_set1_ps(alphas[j + 1]));
                mid[j] = _mm_set1_epi32(mids[j]);
            }
            let (a0, a1) = (_mm_set1_ps(alphas[0]), _mm_set1_ps(alphas[1]));
            let inf = _mm_set1_epi32(INF_BITS);
            let one = _mm_set1_ps(1.0);
            let mut i = 0;
            while i < len {
                let ld = |k: usize| -> __m128 { _mm_loadu_ps(soa[k][i..i + 4].as_ptr()) };
                let (m0, m1, m2, rr, sc) = (ld(0), ld(1), ld(2), ld(3), ld(4));
                let mut acc = if S {
                    _mm_loadu_ps(curve[i..i + 4].as_ptr())
                } else {
                    _mm_setzero_ps()
                };
                let mut dacc = if D {
                    _mm_loadu_ps(dist[i..i + 4].as_ptr())
                } else {
                    _mm_setzero_ps()
                };
                for g in 0..G {
                    let [d0, d1, d2] = d[g];
                    let m2dr = _mm_add_ps(
                        _mm_add_ps(
                            _mm_mul_ps(_mm_set1_ps(d0), m0),
                            _mm_mul_ps(_mm_set1_ps(d1), m1),
                        ),
                        _mm_mul_ps(_mm_set1_ps(d2), m2),
                    );
                    let ts: __m128i = _mm_castps_si128(_mm_mul_ps(m2dr, sc));
                    let mut a = a0;
                    for j in 0..n {
                        // Lanes with ts ≥ mid (bits as i32): not (mid > ts).
                        let below = _mm_castsi128_ps(_mm_cmpgt_epi32(mid[j], ts));
                        a = _mm_xor_ps(a, _mm_andnot_ps(below, steps[j]));
                    }
                    let nan = _mm_castsi128_ps(_mm_cmpgt_epi32(ts, inf));
                    a = _mm_or_ps(_mm_and_ps(nan, a1), _mm_andnot_ps(nan, a));
                    let best = _mm_add_ps(
                        _mm_set1_ps(dd[g]),
                        _mm_mul_ps(a, _mm_add_ps(_mm_mul_ps(a, rr), m2dr)),
                    );
                    // `clamp_nonneg`: clear the lanes with the sign bit set.
                    let bits = _mm_castps_si128(best);
                    let best = _mm_castsi128_ps(_mm_andnot_si128(_mm_srai_epi32(bits, 31), bits));
                    let root = _mm_sqrt_ps(best);
                    if S {
                        acc = _mm_add_ps(
                            acc,
                            _mm_div_ps(_mm_set1_ps(weights[g]), _mm_add_ps(one, root)),
                        );
                    }
                    if D {
                        // `DistancePower::of` in lanes.
                        let p = match power {
                            DistancePower::One => root,
                            DistancePower::ThreeHalves => _mm_mul_ps(root, _mm_sqrt_ps(root)),
                            DistancePower::Two => best,
                        };
                        dacc = _mm_add_ps(dacc, _mm_mul_ps(_mm_set1_ps(weights[g]), p));
                    }
                }
                if S {
                    _mm_storeu_ps(curve[i..i + 4].as_mut_ptr(), acc);
                }
                if D {
                    _mm_storeu_ps(dist[i..i + 4].as_mut_ptr(), dacc);
                }
                i += 4;
            }
        }
        len
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn measures_at_known_points() {
        let e = SimilarityMeasure::Euclidean;
        assert_eq!(e.similarity([1.0, 0.25, 0.25], [1.0, 0.25, 0.25]), 1.0);
        assert!((e.similarity([0.0; 3], [3.0, 4.0, 0.0]) - 1.0 / 6.0).abs() < 1e-7);
        let c = SimilarityMeasure::Cosine;
        assert!((c.similarity([1.0, 0.0, 0.0], [2.0, 0.0, 0.0]) - 1.0).abs() < 1e-7);
        assert_eq!(c.similarity([0.0; 3], [1.0; 3]), 0.0);
        let l1 = SimilarityMeasure::Lp(1.0);
        assert!((l1.similarity([0.0; 3], [1.0, 1.0, 1.0]) - 0.25).abs() < 1e-6);
    }

    #[test]
    fn fast_path_equals_direct_evaluation() {
        let table = ReferenceTable::ideal_5deg();
        for mixing in [NoiseMixing::Off, NoiseMixing::Magnitude] {
            let b = CurveBuilder {
                measure: SimilarityMeasure::Euclidean,
                noisy: NoisyReferences::new(mixing, -30.0, 40.0, 10.0).unwrap(),
                mean_free: false,
                features: FeatureKind::Magnitude,
            };
            let mut ys = [[0.0f32; 3]; 204];
            ys[..4].copy_from_slice(&[
                [0.9, 0.3, 0.2],
                [0.5, 0.5, 0.5],
                [0.0, 1.2, 0.1],
                [2.0, 0.0, 0.0],
            ]);
            let mut rng = crate::test_rng::Lcg(99);
            for y in ys[4..].iter_mut().flatten() {
                *y = rng.unit() * 1.5;
            }
            let mut cache = RowCache::new();
            for y in ys {
                let mut fast = [0.0f32; 72];
                b.accumulate(&table, 0, y, 1.0, &mut fast);
                let mut cached = [0.25f32; 72];
                let mut plain = [0.25f32; 72];
                b.accumulate_cached(&mut cache, &table, 0, y, 0.7, &mut cached);
                b.accumulate(&table, 0, y, 0.7, &mut plain);
                assert_eq!(cached.map(f32::to_bits), plain.map(f32::to_bits), "{y:?}");
                for (q, r) in table.row(0).iter().enumerate() {
                    let direct = b.max_similarity(y, *r, [0.5; 3], [0.5; 3]);
                    assert!((fast[q] - direct).abs() < 2e-6, "{mixing:?} {y:?} q {q}");
                }
            }
        }
    }

    /// A batch of peaks (runs of equal and differing rows, weights ≠ 1) gives the bit-identical curve
    /// of one `accumulate_cached` call per peak, and both match the direct evaluation against the
    /// rows of the builder's feature kind: the active ratios compare with the table's active rows and
    /// mix toward its active noise row, the magnitudes with the magnitude rows and noise.
    #[test]
    fn peak_batches_equal_single_peaks() {
        let ideal = ReferenceTable::ideal_5deg();
        let q = ideal.num_azimuths();
        // Three rows: the ideal row, scaled by 0.8 and 1.1 (other noise features per row).
        let mut features = [[0.0f32; 3]; 3 * 72];
        for (f, scale) in [1.0f32, 0.8, 1.1].iter().enumerate() {
            for (o, r) in features[f * q..(f + 1) * q].iter_mut().zip(ideal.row(0)) {
                *o = r.map(|v| v * scale);
            }
        }
        let noise = [[0.5f32; 3], [0.4, 0.5, 0.6], [0.7, 0.3, 0.5]];
        let freqs = [500.0f32, 1000.0, 2000.0];
        // Active rows: shifted down by 0.1 (negative behind the capsules), their own noise rows.
        let active = features.map(|r| r.map(|v| v - 0.1));
        let noise_active = [[0.45f32; 3], [0.35, 0.55, 0.5], [0.6, 0.4, 0.45]];
        let table = ReferenceTable::new(ideal.azimuths_deg(), &freqs, &features, &noise, &noise)
            .and_then(|t| t.with_active(&active, &noise_active))
            .unwrap();
        for kind in [FeatureKind::Magnitude, FeatureKind::Active] {
            batches_of_peaks(&table, kind);
        }
    }

    fn batches_of_peaks(table: &ReferenceTable<'_>, kind: FeatureKind) {
        let b = CurveBuilder {
            measure: SimilarityMeasure::Euclidean,
            noisy: NoisyReferences::new(NoiseMixing::Magnitude, -30.0, 40.0, 10.0).unwrap(),
            mean_free: false,
            features: kind,
        };
        let table = *table;
        let rows_of_kind = table.rows(kind);
        let mut rng = crate::test_rng::Lcg(5);
        let mut rnd = || rng.unit();
        let rows = [0usize, 0, 0, 1, 2, 2, 0, 1, 1, 1, 1, 2];
        let peaks: [PeakFeature; 12] = core::array::from_fn(|i| PeakFeature {
            fi: rows[i],
            y: [rnd() * 1.5, rnd() * 1.5, rnd() * 1.5],
            weight: 0.2 + rnd(),
        });
        for n in 0..=peaks.len() {
            let (mut batch, mut single) = ([0.125f32; 72], [0.125f32; 72]);
            let (mut cache_a, mut cache_b) = (RowCache::new(), RowCache::new());
            b.accumulate_peaks(&mut cache_a, &table, &peaks[..n], &mut batch);
            for p in &peaks[..n] {
                b.accumulate_cached(&mut cache_b, &table, p.fi, p.y, p.weight, &mut single);
            }
            assert_eq!(
                batch.map(f32::to_bits),
                single.map(f32::to_bits),
                "{n} peaks"
            );
            let mut direct = [0.125f32; 72];
            for p in &peaks[..n] {
                let (row, nm) = match kind {
                    FeatureKind::Magnitude => (table.row(p.fi), table.noise_magnitude(p.fi)),
                    FeatureKind::Active => (
                        &table.active_features()[p.fi * 72..(p.fi + 1) * 72],
                        table.noise_active(p.fi),
                    ),
                };
                assert_eq!(row, rows_of_kind.row(p.fi));
                for (c, r) in direct.iter_mut().zip(row) {
                    *c += p.weight * b.max_similarity(p.y, *r, nm, nm);
                }
            }
            for (x, y) in batch.iter().zip(direct) {
                assert!((x - y).abs() < 1e-5, "{kind:?}, {n} peaks: {x} vs {y}");
            }
        }
    }

    /// The distance sums of every power: the batched, cached pass (on x86_64 the SSE2 kernel plus
    /// the scalar tail) equals one uncached scalar `accumulate_into` per peak bit for bit, leaves the
    /// similarity curve bit-identical to `accumulate_peaks`, and equals d^p of the direct
    /// evaluation (d = 1/max Sim − 1), on random features including special values.
    #[test]
    fn distance_sums_equal_scalar_and_direct_evaluation() {
        let mut rng = crate::test_rng::Lcg(0x5eed_0001);
        let mut rnd = move || rng.unit();
        let special = [0.0, 1e-30, 1e30, -2.0, f32::INFINITY, f32::NAN];
        for (qn, power) in [
            (72usize, DistancePower::One),
            (73, DistancePower::ThreeHalves),
            (72, DistancePower::Two),
            (7, DistancePower::ThreeHalves),
        ] {
            let b = CurveBuilder {
                measure: SimilarityMeasure::Euclidean,
                noisy: NoisyReferences::new(NoiseMixing::Magnitude, -30.0, 40.0, 10.0).unwrap(),
                mean_free: false,
                features: FeatureKind::Magnitude,
            };
            let az: [f32; 128] = core::array::from_fn(|i| i as f32 * 360.0 / qn as f32);
            let noise = [[0.5f32; 3], [0.4, 0.5, 0.6]];
            let mut features = [[0.0f32; 3]; 256];
            for f in features[..2 * qn].iter_mut() {
                *f = [rnd() * 1.5, rnd() * 1.5, rnd() * 1.5];
            }
            let table = ReferenceTable::new(
                &az[..qn],
                &[500.0, 1000.0],
                &features[..2 * qn],
                &noise,
                &noise,
            )
            .unwrap();
            for i in 0..60 {
                let peaks: [PeakFeature; 5] = core::array::from_fn(|k| {
                    let mut y = [rnd() * 1.2, rnd() * 1.2, rnd() * 1.2];
                    if (i + k) % 7 == 0 {
                        y[k % 3] = special[(i + k) % special.len()];
                    }
                    PeakFeature {
                        fi: usize::from(k >= 2),
                        y,
                        weight: 0.2 + rnd(),
                    }
                });
                let start: [f32; 128] = core::array::from_fn(|_| rnd());
                let (mut curve, mut plain_curve, mut reference) = (start, start, start);
                let (mut dist, mut single) = ([0.25f32; 128], [0.25f32; 128]);
                let mut cache = RowCache::new();
                b.accumulate_peaks_with_distance(
                    &mut cache,
                    &table,
                    &peaks,
                    &mut curve[..qn],
                    Some(DistanceSum {
                        power,
                        curve: &mut dist[..qn],
                        sums_only: false,
                    }),
                );
                // Only the sums: the same bits, and the cached path leaves the curve alone.
                let (mut untouched, mut only) = (start, [0.25f32; 128]);
                b.accumulate_peaks_with_distance(
                    &mut cache,
                    &table,
                    &peaks,
                    &mut untouched[..qn],
                    Some(DistanceSum {
                        power,
                        curve: &mut only[..qn],
                        sums_only: true,
                    }),
                );
                b.accumulate_peaks(&mut RowCache::new(), &table, &peaks, &mut reference[..qn]);
                for p in &peaks {
                    let sums = DistanceSum {
                        power,
                        curve: &mut single[..qn],
                        sums_only: false,
                    };
                    b.accumulate_into(
                        &table,
                        p.fi,
                        p.y,
                        p.weight,
                        &mut plain_curve[..qn],
                        Some(sums),
                    );
                }
                let bits = |v: &[f32; 128]| v.map(f32::to_bits);
                assert_eq!(bits(&curve), bits(&reference), "q {qn} {power:?}");
                assert_eq!(bits(&curve), bits(&plain_curve), "q {qn} {power:?}");
                assert_eq!(bits(&dist), bits(&single), "q {qn} {power:?}");
                assert_eq!(bits(&only), bits(&dist), "q {qn} {power:?}");
                assert_eq!(bits(&untouched), bits(&start), "q {qn} {power:?}");
                if peaks
                    .iter()
                    .any(|p| p.y.iter().any(|v| !v.is_finite() || v.abs() > 10.0))
                {
                    continue;
                }
                for q in 0..qn {
                    let mut want = 0.25f64;
                    for p in &peaks {
                        let nm = table.noise_magnitude(p.fi);
                        let sim = b.max_similarity(p.y, table.row(p.fi)[q], nm, nm);
                        let d = f64::from(crate::curve_kernel::distance_of_similarity(sim));
                        let e = match power {
                            DistancePower::One => 1.0,
                            DistancePower::ThreeHalves => 1.5,
                            DistancePower::Two => 2.0,
                        };
                        want += f64::from(p.weight) * d.powf(e);
                    }
                    let got = f64::from(dist[q]);
                    assert!(
                        (got - want).abs() < 2e-5 * (1.0 + want),
                        "q {q}: {got} vs {want}"
                    );
                }
            }
        }
    }

    /// The cached path (on x86_64 the SSE2 kernel plus the scalar tail) equals the scalar
    /// `accumulate` bit for bit on random rows and features, including rows equal to the noise
    /// feature (‖r‖ = 0), tiny, huge, infinite and NaN features, for several SNR sets and azimuth
    /// counts that are not multiples of four.
    #[test]
    fn cached_kernel_equals_scalar_bit_for_bit() {
        let mut rng = crate::test_rng::Lcg(0x1234_5678);
        let mut rnd = move || rng.unit();
        let special = [
            0.5,
            0.0,
            -0.0,
            1e-30,
            1e30,
            -2.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
        ];
        for (qn, (from, to, step)) in [
            (72usize, (-30.0f32, 40.0f32, 10.0f32)),
            (73, (-10.0, 20.0, 5.0)),
            (7, (0.0, 10.0, 10.0)),
            (128, (-30.0, 40.0, 10.0)),
        ] {
            let b = CurveBuilder {
                measure: SimilarityMeasure::Euclidean,
                noisy: NoisyReferences::new(NoiseMixing::Magnitude, from, to, step).unwrap(),
                mean_free: false,
                features: FeatureKind::Magnitude,
            };
            assert!(b.noisy.nearest_ok());
            let az: [f32; 128] = core::array::from_fn(|i| i as f32 * 360.0 / qn as f32);
            let noise = [[0.5f32, 0.4, 0.6], [0.3, 0.3, 0.3]];
            let mut features = [[0.0f32; 3]; 256];
            for (i, f) in features[..2 * qn].iter_mut().enumerate() {
                *f = match i % 11 {
                    // r = 0: ‖r‖² = 0, the bucket scale −∞, ts NaN or ±∞.
                    0 => noise[i / qn],
                    1 => [noise[i / qn][0] + 1e-20, noise[i / qn][1], noise[i / qn][2]],
                    _ => [rnd() * 1.5, rnd() * 1.5, rnd() * 1.5],
                };
            }
            let table = ReferenceTable::new(
                &az[..qn],
                &[500.0, 1000.0],
                &features[..2 * qn],
                &noise,
                &noise,
            )
            .unwrap();
            let mut cache = RowCache::new();
            for i in 0..400 {
                let mut y = [rnd() * 1.5, rnd() * 1.5, rnd() * 1.5];
                if i % 3 == 0 {
                    y[i % 3] = special[(i / 3) % special.len()];
                }
                if i % 5 == 0 {
                    y = noise[i % 2];
                }
                let fi = i % 2;
                let start: [f32; 128] = core::array::from_fn(|_| rnd());
                let (mut cached, mut plain) = (start, start);
                b.accumulate_cached(&mut cache, &table, fi, y, 0.7, &mut cached[..qn]);
                b.accumulate(&table, fi, y, 0.7, &mut plain[..qn]);
                assert_eq!(
                    cached.map(f32::to_bits),
                    plain.map(f32::to_bits),
                    "q {qn} y {y:?}"
                );
                // Two peaks of one row in one pass.
                let y2 = [rnd(), rnd() * 2.0, rnd()];
                let peaks = [
                    PeakFeature { fi, y, weight: 0.3 },
                    PeakFeature {
                        fi,
                        y: y2,
                        weight: 1.7,
                    },
                ];
                let (mut batch, mut single) = (start, start);
                b.accumulate_peaks(&mut cache, &table, &peaks, &mut batch[..qn]);
                b.accumulate(&table, fi, y, 0.3, &mut single[..qn]);
                b.accumulate(&table, fi, y2, 1.7, &mut single[..qn]);
                assert_eq!(batch.map(f32::to_bits), single.map(f32::to_bits), "q {qn}");
            }
        }
    }
}
