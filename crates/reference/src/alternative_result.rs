//! The thesis's alternatives for the similarity method's result (off by default): combination
//! rule 2 (eq. 5.13, [`crate::combination`]) replaces the frame's raw azimuth, and the eq. 5.30
//! filter in Cartesian form ([`crate::cartesian_filter`], the only filter that applies to a rule-2
//! estimate) replaces the curve filter's azimuth.

use crate::cartesian_filter::{CartesianFilter, Smoothing};
use crate::combination::{per_peak_estimate, Combination};
use crate::estimate::Flags;
use crate::frame_spectra::FrameSpectra;
use crate::reference_table::ReferenceTable;
use crate::similarity_frame::SimilarityFrame;

/// The settings of the thesis's alternative results (in the configuration file, the top-level keys
/// `combination` and `smoothing`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AlternativeSettings {
    /// How the peaks of a frame are combined (§5.1.4: rule 1 mean curve, rule 2 eq. 5.13).
    pub combination: Combination,
    /// Where b filters: the similarity curve (eq. 5.31) or the result in Cartesian form (eq. 5.30).
    pub smoothing: Smoothing,
}

/// State of the stage: the eq. 5.30 result filter.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AlternativeResult {
    cartesian: CartesianFilter,
}

impl AlternativeResult {
    /// No history.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            cartesian: CartesianFilter::new(),
        }
    }

    /// `true` when `combination` and `smoothing` change the result (not with the defaults).
    #[must_use]
    pub fn applies(combination: Combination, smoothing: Smoothing) -> bool {
        combination != Combination::MeanCurve || smoothing == Smoothing::Cartesian
    }

    /// The frame's result under `combination`: `raw` is the frame's azimuth from its mean curve,
    /// `b` its reliability, `curve_azimuth` the tracked azimuth; `frame` and `spectra` hold the
    /// frame's peaks and spectra. Returns the azimuth and the raw azimuth, and sets or clears
    /// [`Flags::NO_HISTORY`] by the filter's history.
    #[allow(clippy::too_many_arguments)]
    pub fn process(
        &mut self,
        combination: Combination,
        frame: &SimilarityFrame,
        spectra: &FrameSpectra,
        table: &ReferenceTable<'_>,
        raw: Option<f32>,
        b: f32,
        curve_azimuth: f32,
        flags: &mut Flags,
    ) -> (f32, Option<f32>) {
        let raw = if combination == Combination::MeanCurve {
            raw
        } else if raw.is_some() {
            per_peak_estimate(
                combination,
                frame.curve_builder(),
                table,
                spectra.omni(),
                |k| spectra.cardioids_at(k),
                frame.peak_bins(),
                frame.bin_rows(),
            )
        } else {
            None
        };
        let b = if raw.is_some() { b } else { 0.0 };
        match self.cartesian.update(b, raw.unwrap_or(0.0)) {
            Some(a) => {
                flags.0 &= !Flags::NO_HISTORY.0;
                (a, raw)
            }
            None => {
                flags.insert(Flags::NO_HISTORY);
                (raw.unwrap_or(curve_azimuth), raw)
            }
        }
    }
}
