//! Tracking of the similarity method over frames: the thesis's one-pole filter on the curve
//! (eq. 5.31) or the product's grid tracker, the history rule (no tracked azimuth before the first
//! reliable frame) and the tracker's velocity from the reported azimuths.

use crate::estimate::Flags;
use crate::grid_tracker::{GridTracker, GridTrackerState};
use crate::interpolation::argmax_parabolic;
use crate::reliability::CurveFilter;

/// How the per-frame similarity curves become the reported azimuth.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub enum Tracking {
    /// The thesis: adaptive one-pole filter on the curve, S̃ = b·S + (1 − b)·S̃ (eq. 5.31).
    OnePole,
    /// Bayesian grid tracker with the curve as a b-tempered likelihood ([`GridTracker`]).
    Grid(GridTracker),
}

/// The grid tracker's settings of the product configuration.
pub const DEFAULT_GRID_TRACKER: GridTracker = GridTracker {
    sharpness: 60.0,
    diffusion_deg: 1.0,
    jump_probability: 0.01,
    velocity_pole: 0.98,
    min_velocity_deg: 0.3,
    velocity_gain: 0.0,
    likelihood_floor: 0.2,
    motion_diffusion: 2.0,
    onset_jump_probability: 0.3,
    pause_frames: 6,
    onset_frames: 3,
    onset_likelihood_floor: 0.05,
    refine_gain: 0.1,
    refine_limit: 0.5,
    refine_curve: crate::refine_curve::RefineCurve::Similarity,
    motion_fit_pole: 0.99,
};

/// State of the tracking stage.
#[derive(Debug, Clone)]
pub struct CurveTracker {
    filter: CurveFilter,
    grid: GridTrackerState,
    /// A frame with b > 0 has been seen.
    have_history: bool,
    /// The last reported azimuth.
    last_azimuth: f32,
}

impl Default for CurveTracker {
    fn default() -> Self {
        Self::new()
    }
}

impl CurveTracker {
    /// No history; the start azimuth is 0°.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            filter: CurveFilter::new(),
            grid: GridTrackerState::new(),
            have_history: false,
            last_azimuth: 0.0,
        }
    }

    /// The last reported azimuth once a reliable frame has been seen.
    #[must_use]
    pub fn talker(&self) -> Option<f32> {
        self.have_history.then_some(self.last_azimuth)
    }

    /// The one-pole filter's curve over the first `q` azimuths.
    #[must_use]
    pub fn filtered_curve(&self, q: usize) -> &[f32] {
        self.filter.current(q)
    }

    /// One frame: the frame's `curve` (and `refine`, the grid tracker's refinement curve) over the
    /// table's `azimuths` with reliability `b`; `raw` is the frame's own azimuth. Returns the
    /// tracked azimuth, or before the first reliable frame the raw one (or the start azimuth) with
    /// [`Flags::NO_HISTORY`].
    #[allow(clippy::too_many_arguments)]
    pub fn track(
        &mut self,
        tracking: &Tracking,
        curve: &[f32],
        refine: &[f32],
        azimuths: &[f32],
        b: f32,
        raw: Option<f32>,
        flags: &mut Flags,
    ) -> f32 {
        let q = curve.len();
        if b > 0.0 {
            self.have_history = true;
        }
        let tracked = match tracking {
            Tracking::OnePole => {
                let filtered = self.filter.update(b, curve);
                argmax_parabolic(filtered, azimuths)
            }
            Tracking::Grid(t) => {
                let spacing = crate::angle::wrap_deg_360(azimuths[1] - azimuths[0]);
                t.update_refined(&mut self.grid, curve, refine, b, spacing);
                t.estimate(&mut self.grid, &azimuths[..q])
            }
        };
        if self.have_history {
            tracked.map_or(self.last_azimuth, |(a, _)| a)
        } else {
            flags.insert(Flags::NO_HISTORY);
            raw.unwrap_or(self.last_azimuth)
        }
    }

    /// Records the azimuth reported for the frame; once tracked estimates exist it teaches the grid
    /// tracker its velocity with reliability `motion_b` (before the first reliable frame the raw
    /// azimuths of noise would).
    pub fn observe(&mut self, tracking: &Tracking, azimuth: f32, raw: Option<f32>, motion_b: f32) {
        if let (Tracking::Grid(t), true) = (tracking, self.have_history) {
            t.observe_estimate(&mut self.grid, azimuth, raw.unwrap_or(f32::NAN), motion_b);
        }
        self.last_azimuth = azimuth;
    }
}
