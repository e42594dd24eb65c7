//! Reference feature table (thesis eq. 5.8, §5.1.5): features for Q azimuths and, for a measured
//! table, for F frequencies (nearest-neighbour frequency alignment).
//!
//! A table holds one set of rows per [`FeatureKind`]: the magnitude features |H_c|/|H_0| (eq. 5.8)
//! with their omni-noise rows for magnitude and power mixing, and the active features Re(H_c/H_0)
//! with their own omni-noise row. [`ReferenceTable::rows`] gives the set the configured feature kind
//! compares with. For the ideal model both sets are the same numbers (½ + ½·cos, noise ½); a
//! measured table of real capsules differs, e.g. a cardioid with β > ½ has a negative active ratio
//! behind it, where its magnitude ratio is positive.
//!
//! The table only borrows its data, so the same type holds the ideal-model `static`s generated at
//! build time (flash on the target) and tables loaded or measured at run time on the host.

use crate::error::Error;
use crate::features::FeatureKind;
use crate::tables::{
    IDEAL_AZIMUTHS_15DEG, IDEAL_AZIMUTHS_5DEG, IDEAL_FEATURES_15DEG, IDEAL_FEATURES_5DEG,
};
use crate::{CARDIOIDS, MAX_AZIMUTHS};

pub use crate::features::Feature;

/// Frequency axis of the ideal tables (one row, valid at every frequency).
static IDEAL_FREQS: [f32; 1] = [0.0];
/// Omni-noise feature of ideal cardioids in magnitude (eq. 5.17: the mean gain, ½).
static IDEAL_NOISE_MAGNITUDE: [Feature; 1] = [[0.5; CARDIOIDS]];
/// Omni-noise feature of ideal cardioids in power, for a 3-D diffuse field:
/// E|card|²/E|omni|² = ¼ + ¼·⅓ = ⅓ (its square root is stored).
static IDEAL_NOISE_POWER: [Feature; 1] = [[0.577_350_26; CARDIOIDS]];

/// The active-ratio noise row of a table without measured active rows: ½ per cardioid, the value of
/// ideal cardioids in any diffuse field (E[X_c·X_0*] = ½·E|X_0|²), valid for every frequency row.
static HALF_NOISE: [Feature; 1] = [[0.5; CARDIOIDS]];

/// A reference feature table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceTable<'a> {
    azimuths_deg: &'a [f32],
    freqs_hz: &'a [f32],
    features: &'a [Feature],
    noise_magnitude: &'a [Feature],
    noise_power: &'a [Feature],
    /// F·Q active features Re(H_c/H_0), frequency-major.
    active: &'a [Feature],
    /// Active-ratio omni-noise rows: F rows, or one row valid for every frequency.
    noise_active: &'a [Feature],
    /// The feature kinds the table has rows for ([`KIND_MAGNITUDE`] | [`KIND_ACTIVE`]).
    kinds: u8,
}

/// [`ReferenceTable`] serves [`FeatureKind::Magnitude`].
const KIND_MAGNITUDE: u8 = 1;
/// [`ReferenceTable`] serves [`FeatureKind::Active`].
const KIND_ACTIVE: u8 = 2;

const fn kind_bit(kind: FeatureKind) -> u8 {
    match kind {
        FeatureKind::Magnitude => KIND_MAGNITUDE,
        FeatureKind::Active => KIND_ACTIVE,
    }
}

/// Checks the axes of a table: Q in 3..=[`MAX_AZIMUTHS`] strictly ascending azimuths within
/// [0, 360) and F ≥ 1 ascending frequencies; returns (Q, F).
fn check_axes(azimuths_deg: &[f32], freqs_hz: &[f32]) -> Result<(usize, usize), Error> {
    let q = azimuths_deg.len();
    let f = freqs_hz.len();
    if !(3..=MAX_AZIMUTHS).contains(&q) {
        return Err(Error::InvalidConfig(
            "reference table needs 3..=360 azimuths",
        ));
    }
    if f == 0 {
        return Err(Error::InvalidConfig(
            "reference table needs at least one frequency",
        ));
    }
    let ascending = azimuths_deg.windows(2).all(|w| w[0] < w[1]);
    let in_range = azimuths_deg.iter().all(|a| (0.0..360.0).contains(a));
    if !ascending || !in_range {
        return Err(Error::InvalidConfig("azimuths must ascend within [0, 360)"));
    }
    if !freqs_hz.windows(2).all(|w| w[0] < w[1]) {
        return Err(Error::InvalidConfig("frequencies must ascend"));
    }
    Ok((q, f))
}

/// Checks the length of one part of a table.
fn check_len(expected: usize, got: usize) -> Result<(), Error> {
    if expected == got {
        Ok(())
    } else {
        Err(Error::TableShape { expected, got })
    }
}

/// The rows of a [`ReferenceTable`] that one [`FeatureKind`] compares with: its features and the
/// omni-noise feature Y_η its noisy references mix toward linearly (magnitude mixing, eq. 5.19).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeatureRows<'a> {
    azimuths: usize,
    features: &'a [Feature],
    noise: &'a [Feature],
}

impl<'a> FeatureRows<'a> {
    /// The Q features of frequency row `fi`.
    #[inline]
    #[must_use]
    pub fn row(&self, fi: usize) -> &'a [Feature] {
        let q = self.azimuths;
        &self.features[fi * q..(fi + 1) * q]
    }

    /// Omni-noise feature Y_η of frequency row `fi` for linear (magnitude) mixing.
    #[inline]
    #[must_use]
    pub fn noise(&self, fi: usize) -> Feature {
        // One stored row (a table without measured active rows) serves every frequency.
        self.noise[fi.min(self.noise.len() - 1)]
    }

    /// All features, frequency-major (`[f·Q + q]`).
    #[must_use]
    pub fn features(&self) -> &'a [Feature] {
        self.features
    }
}

impl<'a> ReferenceTable<'a> {
    /// Builds a table from its magnitude parts; its active rows are the magnitude features and its
    /// active noise row is ½ (what a version-1 table file means, see [`ReferenceTable::with_active`]).
    ///
    /// * `azimuths_deg`: Q ≤ [`MAX_AZIMUTHS`] azimuths, strictly ascending within [0, 360);
    /// * `freqs_hz`: F ≥ 1 frequencies, ascending (F = 1: one row valid at all frequencies);
    /// * `features`: F·Q vectors, frequency-major (`features[f·Q + q]`);
    /// * `noise_magnitude`, `noise_power`: F omni-noise features Y_η (eq. 5.17), for magnitude and
    ///   power mixing respectively (the power one is the square root of the mean power ratio).
    pub fn new(
        azimuths_deg: &'a [f32],
        freqs_hz: &'a [f32],
        features: &'a [Feature],
        noise_magnitude: &'a [Feature],
        noise_power: &'a [Feature],
    ) -> Result<Self, Error> {
        let (q, f) = check_axes(azimuths_deg, freqs_hz)?;
        check_len(f * q, features.len())?;
        check_len(f, noise_magnitude.len())?;
        check_len(f, noise_power.len())?;
        let finite = |v: &Feature| v.iter().all(|x| x.is_finite() && *x >= 0.0);
        if !features.iter().all(finite)
            || !noise_magnitude.iter().all(finite)
            || !noise_power.iter().all(finite)
        {
            return Err(Error::InvalidConfig(
                "features must be finite and non-negative",
            ));
        }
        Ok(Self {
            azimuths_deg,
            freqs_hz,
            features,
            noise_magnitude,
            noise_power,
            active: features,
            noise_active: &HALF_NOISE,
            kinds: KIND_MAGNITUDE | KIND_ACTIVE,
        })
    }

    /// A table with active rows only (`active`: F·Q features Re(H_c/H_0), frequency-major;
    /// `noise_active`: F omni-noise features of the active ratios), for a build that embeds only
    /// what an active-feature configuration compares with (half the flash of both kinds). It does
    /// not serve [`FeatureKind::Magnitude`]: [`ReferenceTable::serves`] says so and the locator
    /// refuses that configuration (the magnitude accessors return the active rows).
    pub fn active_only(
        azimuths_deg: &'a [f32],
        freqs_hz: &'a [f32],
        active: &'a [Feature],
        noise_active: &'a [Feature],
    ) -> Result<Self, Error> {
        let (q, f) = check_axes(azimuths_deg, freqs_hz)?;
        check_len(f * q, active.len())?;
        check_len(f, noise_active.len())?;
        let finite = |v: &Feature| v.iter().all(|x| x.is_finite());
        if !active.iter().all(finite) || !noise_active.iter().all(finite) {
            return Err(Error::InvalidConfig("active features must be finite"));
        }
        Ok(Self {
            azimuths_deg,
            freqs_hz,
            features: active,
            noise_magnitude: noise_active,
            noise_power: noise_active,
            active,
            noise_active,
            kinds: KIND_ACTIVE,
        })
    }

    /// The same table, serving only feature kind `kind` (for a build that embeds only the rows one
    /// configuration compares with); the locator refuses a configuration with the other kind.
    #[must_use]
    pub fn only(self, kind: FeatureKind) -> Self {
        Self {
            kinds: self.kinds & kind_bit(kind),
            ..self
        }
    }

    /// Whether the table has rows for feature kind `kind` (measured, or for a table without measured
    /// active rows the magnitude stand-ins of [`ReferenceTable::new`]).
    #[must_use]
    pub fn serves(&self, kind: FeatureKind) -> bool {
        self.kinds & kind_bit(kind) != 0
    }

    /// The same table with measured active rows: `active` holds F·Q features Re(H_c/H_0),
    /// frequency-major like the magnitude features, and `noise_active` the F omni-noise features of
    /// the active ratio, Re(E[X_c·X_0*])/E|X_0|² (or one row valid for every frequency). Active
    /// features may be negative (a cardioid with β > ½ behind it) but must be finite.
    pub fn with_active(
        self,
        active: &'a [Feature],
        noise_active: &'a [Feature],
    ) -> Result<Self, Error> {
        let (q, f) = (self.num_azimuths(), self.num_freqs());
        if active.len() != f * q {
            return Err(Error::TableShape {
                expected: f * q,
                got: active.len(),
            });
        }
        if noise_active.len() != f && noise_active.len() != 1 {
            return Err(Error::TableShape {
                expected: f,
                got: noise_active.len(),
            });
        }
        let finite = |v: &Feature| v.iter().all(|x| x.is_finite());
        if !active.iter().all(finite) || !noise_active.iter().all(finite) {
            return Err(Error::InvalidConfig("active features must be finite"));
        }
        Ok(Self {
            active,
            noise_active,
            ..self
        })
    }

    /// The ideal-model table on a 5° grid (the default), in flash.
    #[must_use]
    pub fn ideal_5deg() -> ReferenceTable<'static> {
        ReferenceTable {
            azimuths_deg: &IDEAL_AZIMUTHS_5DEG,
            freqs_hz: &IDEAL_FREQS,
            features: &IDEAL_FEATURES_5DEG,
            noise_magnitude: &IDEAL_NOISE_MAGNITUDE,
            noise_power: &IDEAL_NOISE_POWER,
            active: &IDEAL_FEATURES_5DEG,
            noise_active: &HALF_NOISE,
            kinds: KIND_MAGNITUDE | KIND_ACTIVE,
        }
    }

    /// Whether this is one of the built-in ideal-model tables ([`ReferenceTable::ideal_5deg`],
    /// [`ReferenceTable::ideal_15deg`]) rather than a measured one.
    #[must_use]
    pub fn is_ideal_model(&self) -> bool {
        core::ptr::eq(self.features.as_ptr(), IDEAL_FEATURES_5DEG.as_ptr())
            || core::ptr::eq(self.features.as_ptr(), IDEAL_FEATURES_15DEG.as_ptr())
    }

    /// The ideal-model table on the thesis's 15° grid.
    #[must_use]
    pub fn ideal_15deg() -> ReferenceTable<'static> {
        ReferenceTable {
            azimuths_deg: &IDEAL_AZIMUTHS_15DEG,
            freqs_hz: &IDEAL_FREQS,
            features: &IDEAL_FEATURES_15DEG,
            noise_magnitude: &IDEAL_NOISE_MAGNITUDE,
            noise_power: &IDEAL_NOISE_POWER,
            active: &IDEAL_FEATURES_15DEG,
            noise_active: &HALF_NOISE,
            kinds: KIND_MAGNITUDE | KIND_ACTIVE,
        }
    }

    /// The rows feature kind `kind` compares with: the magnitude features with the magnitude-mixing
    /// noise row, or the active features with the active noise row.
    #[inline]
    #[must_use]
    pub fn rows(&self, kind: FeatureKind) -> FeatureRows<'a> {
        let (features, noise) = match kind {
            FeatureKind::Magnitude => (self.features, self.noise_magnitude),
            FeatureKind::Active => (self.active, self.noise_active),
        };
        FeatureRows {
            azimuths: self.azimuths_deg.len(),
            features,
            noise,
        }
    }

    /// Number of azimuths Q.
    #[must_use]
    pub fn num_azimuths(&self) -> usize {
        self.azimuths_deg.len()
    }

    /// Number of frequency rows F.
    #[must_use]
    pub fn num_freqs(&self) -> usize {
        self.freqs_hz.len()
    }

    /// The azimuth grid in degrees.
    #[must_use]
    pub fn azimuths_deg(&self) -> &'a [f32] {
        self.azimuths_deg
    }

    /// The frequency axis in Hz.
    #[must_use]
    pub fn freqs_hz(&self) -> &'a [f32] {
        self.freqs_hz
    }

    /// All magnitude features |H_c|/|H_0|, frequency-major.
    #[must_use]
    pub fn features(&self) -> &'a [Feature] {
        self.features
    }

    /// All active features Re(H_c/H_0), frequency-major (the magnitude features for a table built
    /// without them).
    #[must_use]
    pub fn active_features(&self) -> &'a [Feature] {
        self.active
    }

    /// Index of the frequency row nearest to `f_hz`.
    #[must_use]
    pub fn freq_index(&self, f_hz: f32) -> usize {
        let f = self.freqs_hz;
        let i = f.partition_point(|x| *x < f_hz);
        if i == 0 {
            0
        } else if i == f.len() {
            f.len() - 1
        } else if f_hz - f[i - 1] <= f[i] - f_hz {
            i - 1
        } else {
            i
        }
    }

    /// The Q magnitude features of frequency row `fi`.
    #[must_use]
    pub fn row(&self, fi: usize) -> &'a [Feature] {
        let q = self.azimuths_deg.len();
        &self.features[fi * q..(fi + 1) * q]
    }

    /// Omni-noise feature of row `fi` for magnitude mixing.
    #[must_use]
    pub fn noise_magnitude(&self, fi: usize) -> Feature {
        self.noise_magnitude[fi]
    }

    /// Omni-noise feature of row `fi` for power mixing (√ of the power ratio).
    #[must_use]
    pub fn noise_power(&self, fi: usize) -> Feature {
        self.noise_power[fi]
    }

    /// Omni-noise feature of row `fi` for the active ratios (½ for a table without active rows).
    #[must_use]
    pub fn noise_active(&self, fi: usize) -> Feature {
        self.rows(FeatureKind::Active).noise(fi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ideal_table_matches_model() {
        let t = ReferenceTable::ideal_5deg();
        assert_eq!(t.num_azimuths(), 72);
        for (q, f) in t.row(0).iter().enumerate() {
            let az = (q as f64 * 5.0).to_radians();
            for (m, v) in f.iter().enumerate() {
                let want = 0.5 + 0.5 * (az - (m as f64 * 120.0).to_radians()).cos();
                assert!((*v as f64 - want).abs() < 1e-7, "q {q} m {m}");
            }
        }
        // Thesis eq. 4.5 / 4.6.
        assert_eq!(t.row(0)[0], [1.0, 0.25, 0.25]);
        let back = t.row(0)[36];
        assert!((back[0] - 0.0).abs() < 1e-7 && (back[1] - 0.75).abs() < 1e-6);
        assert_eq!(ReferenceTable::ideal_15deg().num_azimuths(), 24);
    }

    /// Both ideal tables hold the same numbers for both feature kinds: the noisy references of the
    /// active ratios mix toward ½, as the ideal model's diffuse field does.
    #[test]
    fn ideal_tables_serve_both_feature_kinds() {
        for t in [ReferenceTable::ideal_5deg(), ReferenceTable::ideal_15deg()] {
            let (m, a) = (t.rows(FeatureKind::Magnitude), t.rows(FeatureKind::Active));
            assert_eq!(m.row(0), a.row(0));
            assert_eq!(m.noise(0), [0.5; 3]);
            assert_eq!(a.noise(0), [0.5; 3]);
            assert_eq!(a.noise(40), [0.5; 3]);
        }
    }

    #[test]
    fn measured_active_rows_are_served_to_the_active_kind() {
        let az = [0.0, 120.0, 240.0];
        let fr = [100.0, 200.0];
        let feats = [[0.5; 3]; 6];
        let noise = [[0.5; 3]; 2];
        let t = ReferenceTable::new(&az, &fr, &feats, &noise, &noise).unwrap();
        // Without active rows: the magnitude features and ½.
        assert_eq!(t.rows(FeatureKind::Active).row(1), &feats[3..]);
        assert_eq!(t.noise_active(1), [0.5; 3]);
        let mut active = [[0.25; 3]; 6];
        active[4] = [1.0, -0.1, 0.1];
        let na = [[0.4; 3], [0.45; 3]];
        let t = t.with_active(&active, &na).unwrap();
        let rows = t.rows(FeatureKind::Active);
        assert_eq!(rows.row(1)[1], [1.0, -0.1, 0.1]);
        assert_eq!(rows.noise(1), [0.45; 3]);
        assert_eq!(t.rows(FeatureKind::Magnitude).row(1), &feats[3..]);
        assert_eq!(t.rows(FeatureKind::Magnitude).noise(1), [0.5; 3]);
        assert_eq!(
            t.with_active(&active[..5], &na),
            Err(Error::TableShape {
                expected: 6,
                got: 5
            })
        );
        assert!(t.with_active(&active, &[[0.5; 3]; 3]).is_err());
        let mut nan = active;
        nan[2][0] = f32::NAN;
        assert!(t.with_active(&nan, &na).is_err());
    }

    #[test]
    fn tables_of_one_feature_kind() {
        let az = [0.0, 120.0, 240.0];
        let fr = [100.0, 200.0];
        let active = [[-0.1, 0.5, 1.0]; 6];
        let na = [[0.45; 3], [0.5; 3]];
        let t = ReferenceTable::active_only(&az, &fr, &active, &na).unwrap();
        assert!(t.serves(FeatureKind::Active) && !t.serves(FeatureKind::Magnitude));
        assert_eq!(t.rows(FeatureKind::Active).noise(0), [0.45; 3]);
        assert_eq!(t.rows(FeatureKind::Active).row(1), &active[3..]);
        assert_eq!(
            ReferenceTable::active_only(&az, &fr, &active, &na[..1]),
            Err(Error::TableShape {
                expected: 2,
                got: 1
            })
        );
        let ideal = ReferenceTable::ideal_5deg();
        assert!(ideal.serves(FeatureKind::Active) && ideal.serves(FeatureKind::Magnitude));
        let m = ideal.only(FeatureKind::Magnitude);
        assert!(m.serves(FeatureKind::Magnitude) && !m.serves(FeatureKind::Active));
        assert!(!m.only(FeatureKind::Active).serves(FeatureKind::Magnitude));
    }

    #[test]
    fn nearest_frequency_row() {
        let az = [0.0, 120.0, 240.0];
        let fr = [100.0, 200.0, 400.0];
        let feats = [[0.5; 3]; 9];
        let noise = [[0.5; 3]; 3];
        let t = ReferenceTable::new(&az, &fr, &feats, &noise, &noise).unwrap();
        assert_eq!(t.freq_index(0.0), 0);
        assert_eq!(t.freq_index(149.0), 0);
        assert_eq!(t.freq_index(151.0), 1);
        assert_eq!(t.freq_index(310.0), 2);
        assert_eq!(t.freq_index(9e9), 2);
    }

    #[test]
    fn rejects_bad_shapes() {
        let az = [0.0, 120.0, 240.0];
        let fr = [100.0];
        let feats = [[0.5; 3]; 2];
        let noise = [[0.5; 3]; 1];
        assert_eq!(
            ReferenceTable::new(&az, &fr, &feats, &noise, &noise),
            Err(Error::TableShape {
                expected: 3,
                got: 2
            })
        );
        let bad_az = [0.0, 240.0, 120.0];
        let feats3 = [[0.5; 3]; 3];
        assert!(ReferenceTable::new(&bad_az, &fr, &feats3, &noise, &noise).is_err());
        let nan = [[f32::NAN; 3]; 3];
        assert!(ReferenceTable::new(&az, &fr, &nan, &noise, &noise).is_err());
    }
}
