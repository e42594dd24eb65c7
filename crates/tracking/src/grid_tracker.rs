//! Bayesian grid tracker on the similarity curve — the product's replacement for the thesis's
//! one-pole curve filter (eq. 5.31), which must trade pause rejection against lag.
//!
//! The azimuth grid of the reference table is the state space of a hidden Markov model. Per frame:
//!
//! 1. **predict**: the posterior diffuses by a small random-walk kernel (the talker moves a little)
//!    and a fraction ε spreads uniformly (the talker may jump anywhere):
//!    p⁻ = (1 − ε)·(p ⊛ k) + ε/Q;
//! 2. **update**: the frame's similarity curve, tempered by its reliability b, is the likelihood:
//!    p ∝ p⁻ · exp(λ · b · (S − max S)).
//!
//! An unreliable frame (b ≈ 0) leaves only the prediction, so pauses are ignored; a run of reliable
//! frames moves the posterior at once, so jumps are followed in a few frames; and because the motion
//! model diffuses instead of averaging old curves, a moving talker is followed without lag.

use crate::interpolation::{argmax_parabolic_mapped, offset_azimuth};
use crate::motion_fit::MotionFit;
use crate::refine_curve::RefineCurve;
use crate::reliability::unit_reliability;
use crate::running_curve::RunningCurve;
use crate::MAX_AZIMUTHS;

/// Largest distance of the estimate from the posterior's maximum, in grid steps, while the talker
/// is seen moving: the drift-compensated running mean follows him between grid points.
pub const MOVING_REFINE_LIMIT: f32 = 1.0;

/// Tracker settings.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct GridTracker {
    /// Likelihood sharpness λ (per unit similarity, at b = 1).
    pub sharpness: f32,
    /// Random-walk standard deviation per frame, degrees.
    pub diffusion_deg: f32,
    /// Probability ε per frame that the talker jumped anywhere.
    pub jump_probability: f32,
    /// Pole of the angular-velocity estimate that drifts the prediction (0 disables the drift).
    /// With it the prior moves with a moving talker, so the estimate does not trail behind. The
    /// estimate averages the frame-to-frame change of the reported azimuth weighted by the frame's
    /// reliability b: in a pause it is kept, not learned from the drift itself.
    pub velocity_pole: f32,
    /// Dead zone of the [`GridTracker::velocity_pole`] estimate, degrees per frame: slower
    /// estimates (noise around a still talker) do not move the prior. The motion fit's slope, where
    /// it is significant, drives the prior whatever its size: its significance test is what tells a
    /// slow walker from a still talker's noise.
    pub min_velocity_deg: f32,
    /// Gain of the innovation-driven velocity estimate (0: the velocity is the `velocity_pole`
    /// average of the frame-to-frame change of the estimate). With a gain g > 0 the velocity follows
    /// the innovation, i.e. the difference between the reported azimuth and the drifted previous one,
    /// weighted by the frame's reliability b: v ← v + b·(g·innovation − (1 − velocity_pole)·v). In
    /// pauses (b ≈ 0) the velocity is kept, so the prior keeps moving with a talker that walks on
    /// while silent, and a static talker's noise averages out instead of being integrated.
    pub velocity_gain: f32,
    /// Floor f of the per-frame likelihood, relative to its maximum:
    /// L = f + (1 − f)·exp(λ·b·(S − max S)). A floor bounds how much one frame can move the
    /// posterior, so a single frame dominated by a reflection cannot capture the track (0 disables).
    pub likelihood_floor: f32,
    /// Extra random-walk standard deviation per unit of drift: while the talker is seen moving at
    /// |v| degrees per frame (beyond the dead zone) the diffusion is √(σ² + (m·v)²), so the prior
    /// widens for a moving talker, whose speed changes, and stays tight for a still one (0 disables).
    pub motion_diffusion: f32,
    /// Jump probability ε for the first [`GridTracker::onset_frames`] reliable frames after a
    /// pause (at least [`GridTracker::pause_frames`] frames with b = 0): a talker changes place, or
    /// another talker starts, between utterances rather than within one, and the first frames of
    /// an utterance carry the most direct sound. Below [`GridTracker::jump_probability`] it has no
    /// effect. An onset is two reliable frames in a row: the first is tracked as any frame and
    /// the onset frames start with the second, so a single reliable frame in a pause (a blip of
    /// the noise that the gate let through) neither moves the estimate nor ends the pause (the
    /// very first reliable frame, with no talker yet to keep, starts the onset at once)
    /// (measured on real speech, whose pauses synthetic speech lacks: such a blip carried a static
    /// talker's estimate 130° away for the rest of a 0.6 s pause).
    pub onset_jump_probability: f32,
    /// Frames with b = 0 that make a pause for [`GridTracker::onset_jump_probability`] (0 disables it).
    pub pause_frames: u32,
    /// Reliable frames after a pause that use [`GridTracker::onset_jump_probability`].
    pub onset_frames: u32,
    /// Likelihood floor of the onset frames (those that use
    /// [`GridTracker::onset_jump_probability`]), in place of [`GridTracker::likelihood_floor`]: the
    /// first frames of an utterance carry the most direct sound, so each may move the posterior
    /// further.
    pub onset_likelihood_floor: f32,
    /// Gain β of the drift-compensated running mean curve ([`RunningCurve`]) that places the
    /// estimate between grid points: each frame the mean moves towards the curve by β·b. 0 disables
    /// it: the estimate is then the parabola through the log-posterior, which leans towards the grid
    /// point.
    pub refine_gain: f32,
    /// Largest distance of the estimate from the posterior's maximum, in grid steps, when
    /// [`GridTracker::refine_gain`] is on and the talker is still (no drift beyond
    /// [`GridTracker::min_velocity_deg`]); while he is seen moving, at least
    /// [`MOVING_REFINE_LIMIT`]. The running mean keeps curves of the talker's last place for a
    /// while: after a jump, or a walk that stopped, a tight limit keeps them from holding the
    /// estimate off the posterior's new maximum (validation suite, docs/history.md).
    pub refine_limit: f32,
    /// The curve whose running mean places the estimate between grid points when
    /// [`GridTracker::refine_gain`] is on: the similarity curve, or a distance curve
    /// ([`RefineCurve`]; the locator computes it and passes it to [`GridTracker::update_refined`]).
    pub refine_curve: RefineCurve,
    /// Forgetting pole per frame of the motion fit ([`MotionFit`]; 0 disables it): a line through
    /// the frames' own estimates near the reported azimuth, whose slope, where it is significant, is
    /// the talker's velocity through his pauses too and drives the prediction in place of the
    /// [`GridTracker::velocity_pole`] estimate.
    pub motion_fit_pole: f32,
}

/// An exponent x below which `floor + (1 − floor)·exp_nonpositive(x)` rounds to `floor` exactly
/// (−∞ for a floor ≤ 0 or NaN). With 2^e ≤ floor < 2^(e+1) (e from the exponent bits) it is
/// (e − 26)·ln 2: then e^x < floor·2⁻²⁶, the computed term (1 − floor)·exp_nonpositive(x) (relative
/// error below 10⁻⁵) stays below floor·2⁻²⁵ < 2^(e−24), half a unit in the last place of the floor,
/// so the sum rounds to the floor. The tracker then skips the exponential of azimuths far below the
/// curve's maximum, and the posterior keeps its bits.
fn negligible_exponent(floor: f32) -> f32 {
    if !(floor > 0.0) {
        return f32::NEG_INFINITY;
    }
    let e = ((floor.to_bits() >> 23) & 0xff) as i32 - 127;
    (e - 26) as f32 * core::f32::consts::LN_2
}

/// Frame-to-frame changes larger than this (degrees) are jumps, not motion, for the velocity estimate.
const MAX_MOTION_STEP_DEG: f32 = 8.0;

/// The posterior over the grid.
#[derive(Debug, Clone)]
pub struct GridTrackerState {
    posterior: [f32; MAX_AZIMUTHS],
    scratch: [f32; MAX_AZIMUTHS],
    initialized: bool,
    /// Estimated angular velocity, degrees per frame.
    velocity: f32,
    /// Previous reported azimuth, degrees (NaN before the first).
    previous: f32,
    /// Drift applied by the last prediction, degrees per frame.
    drift: f32,
    /// Consecutive frames with b = 0 up to the last update.
    quiet: u32,
    /// Reliable frames left that use the onset jump probability.
    onset_left: u32,
    /// The last frame was a reliable one right after a pause: the next reliable frame confirms the
    /// onset.
    onset_pending: bool,
    /// A reliable frame has been seen (before it, the first one starts the track at once).
    heard: bool,
    /// Running mean curve for the position between grid points.
    running: RunningCurve,
    /// Weighted sums of the motion fit.
    fit: MotionFit,
    /// The motion fit's slope where it is significant, degrees per frame (NaN otherwise).
    fit_velocity: f32,
}

impl Default for GridTrackerState {
    fn default() -> Self {
        Self::new()
    }
}

impl GridTrackerState {
    /// A uniform posterior.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            posterior: [0.0; MAX_AZIMUTHS],
            scratch: [0.0; MAX_AZIMUTHS],
            initialized: false,
            velocity: 0.0,
            previous: f32::NAN,
            drift: 0.0,
            quiet: 0,
            onset_left: 0,
            onset_pending: false,
            heard: false,
            running: RunningCurve::new(),
            fit: MotionFit::new(),
            fit_velocity: f32::NAN,
        }
    }

    /// Estimated angular velocity, degrees per frame.
    #[must_use]
    pub fn velocity(&self) -> f32 {
        self.velocity
    }

    /// The posterior over the first `n` grid points.
    #[must_use]
    pub fn posterior(&self, n: usize) -> &[f32] {
        &self.posterior[..n.min(MAX_AZIMUTHS)]
    }
}

impl GridTracker {
    /// Whether the settings are usable: every value finite, probabilities, poles, floors and the
    /// refinement gain in [0, 1], the rest ≥ 0.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        let unit = |v: f32| (0.0..=1.0).contains(&v);
        let non_negative = |v: f32| v >= 0.0 && v.is_finite();
        non_negative(self.sharpness)
            && non_negative(self.diffusion_deg)
            && unit(self.jump_probability)
            && unit(self.velocity_pole)
            && non_negative(self.min_velocity_deg)
            && non_negative(self.velocity_gain)
            && unit(self.likelihood_floor)
            && non_negative(self.motion_diffusion)
            && unit(self.onset_jump_probability)
            && unit(self.onset_likelihood_floor)
            && unit(self.refine_gain)
            && non_negative(self.refine_limit)
            && unit(self.motion_fit_pole)
    }

    /// Side weight of the 3-tap random-walk kernel [a, 1 − 2a, a] for a grid spacing in degrees
    /// (variance 2a bins², capped at a = ⅓).
    #[must_use]
    pub fn kernel_side(&self, spacing_deg: f32) -> f32 {
        if !(spacing_deg > 0.0) {
            return 0.0;
        }
        let s = self.diffusion_deg / spacing_deg;
        (0.5 * s * s).clamp(0.0, 1.0 / 3.0)
    }

    /// The jump probability of this frame and whether it is an onset frame (one of the first
    /// reliable frames after a pause), with the pause/onset bookkeeping of `state`.
    fn jump_probability_for(&self, state: &mut GridTrackerState, b: f32) -> (f32, bool) {
        if self.pause_frames == 0 {
            return (self.jump_probability, false);
        }
        if !(b > 0.0) {
            state.quiet = state.quiet.saturating_add(1);
            state.onset_pending = false;
            return (self.jump_probability, false);
        }
        let first = !state.heard;
        state.heard = true;
        if state.quiet >= self.pause_frames {
            if !state.onset_pending && !first {
                // A single reliable frame in a pause may be a blip of the noise: the pause goes on
                // unless the next frame is reliable too.
                state.onset_pending = true;
                return (self.jump_probability, false);
            }
            state.onset_pending = false;
            state.onset_left = self.onset_frames;
        }
        state.quiet = 0;
        if state.onset_left > 0 {
            state.onset_left -= 1;
            (self.jump_probability.max(self.onset_jump_probability), true)
        } else {
            (self.jump_probability, false)
        }
    }

    /// One predict/update step with the frame's curve and reliability `b`; returns the posterior.
    /// The running mean of [`GridTracker::refine_gain`] averages the same curve.
    pub fn update<'s>(
        &self,
        state: &'s mut GridTrackerState,
        curve: &[f32],
        b: f32,
        spacing_deg: f32,
    ) -> &'s [f32] {
        self.update_refined(state, curve, curve, b, spacing_deg)
    }

    /// [`GridTracker::update`] with `refine` (as long as `curve`; see [`GridTracker::refine_curve`])
    /// in place of `curve` for the running mean that places the estimate between grid points.
    pub fn update_refined<'s>(
        &self,
        state: &'s mut GridTrackerState,
        curve: &[f32],
        refine: &[f32],
        b: f32,
        spacing_deg: f32,
    ) -> &'s [f32] {
        let q = curve.len().min(refine.len()).min(MAX_AZIMUTHS);
        if q == 0 {
            return &state.posterior[..0];
        }
        let uniform = 1.0 / q as f32;
        if !state.initialized {
            state.posterior[..q].fill(uniform);
            state.initialized = true;
        }
        // Predict: circular 3-tap kernel with mean = drift and variance = diffusion (bins), plus
        // the jump floor. Mass moves from bin j to j + 1 with weight `up`.
        // A significant slope of the motion fit drives the prior whatever its size; the
        // `velocity_pole` estimate, which has no significance test, only beyond its dead zone.
        let v = if state.fit_velocity.is_finite() {
            state.fit_velocity
        } else if state.velocity.abs() > self.min_velocity_deg {
            state.velocity
        } else {
            0.0
        };
        let var = if self.motion_diffusion > 0.0 && v != 0.0 && spacing_deg > 0.0 {
            let m = self.motion_diffusion * v;
            let sd = self.diffusion_deg * self.diffusion_deg + m * m;
            (sd / (spacing_deg * spacing_deg)).clamp(0.0, 2.0 / 3.0)
        } else {
            2.0 * self.kernel_side(spacing_deg)
        };
        state.drift = v;
        let b_unit = unit_reliability(b);
        let shift = if spacing_deg > 0.0 {
            (v / spacing_deg).clamp(-0.5, 0.5)
        } else {
            0.0
        };
        if self.refine_gain > 0.0 {
            state
                .running
                .update(&refine[..q], shift, self.refine_gain * b_unit);
        }
        let second = (var + shift * shift).min(1.0);
        let up = (0.5 * (second + shift)).max(0.0);
        let down = (0.5 * (second - shift)).max(0.0);
        let stay = (1.0 - up - down).max(0.0);
        let (eps, onset_frame) = self.jump_probability_for(state, b);
        let eps = eps.clamp(0.0, 1.0);
        // Same arithmetic for every bin; the two wrapped ends apart so the loop over the inner bins
        // needs neither index wrapping nor bounds checks.
        let (keep, add) = (1.0 - eps, eps * uniform);
        let predict = |l: f32, c: f32, r: f32| keep * (up * l + down * r + stay * c) + add;
        {
            let p = &state.posterior[..q];
            let out = &mut state.scratch[..q];
            if q == 1 {
                out[0] = predict(p[0], p[0], p[0]);
            } else {
                out[0] = predict(p[q - 1], p[0], p[1]);
                out[q - 1] = predict(p[q - 2], p[q - 1], p[0]);
                for (o, w) in out[1..q - 1].iter_mut().zip(p.windows(3)) {
                    *o = predict(w[0], w[1], w[2]);
                }
            }
        }
        // Update with the tempered likelihood.
        let gain = self.sharpness * b.clamp(0.0, 1.0);
        // `if` rather than `f32::max`, a library call on the Cortex-M4F (NaNs are skipped alike).
        let s_max = curve[..q]
            .iter()
            .fold(f32::NEG_INFINITY, |m, v| if *v > m { *v } else { m });
        let floor = if onset_frame {
            self.onset_likelihood_floor
        } else {
            self.likelihood_floor
        };
        let floor = floor.clamp(0.0, 1.0);
        let mut sum = 0.0f32;
        let post = &mut state.posterior[..q];
        let prior = &state.scratch[..q];
        if gain > 0.0 && s_max.is_finite() {
            let cut = negligible_exponent(floor);
            for ((o, p), c) in post.iter_mut().zip(prior).zip(&curve[..q]) {
                let x = gain * (c - s_max);
                // Below `cut` the sum rounds to the floor: the same bits without the exponential.
                let like = if x < cut {
                    floor
                } else {
                    floor + (1.0 - floor) * crate::fast_exp::exp_nonpositive(x)
                };
                *o = p * like;
                sum += *o;
            }
        } else {
            // Likelihood 1 everywhere: the prediction is the posterior.
            for (o, p) in post.iter_mut().zip(prior) {
                *o = *p;
                sum += *o;
            }
        }
        if sum > 0.0 && sum.is_finite() {
            let inv = 1.0 / sum;
            for v in state.posterior[..q].iter_mut() {
                *v *= inv;
            }
        } else {
            state.posterior[..q].fill(uniform);
        }
        &state.posterior[..q]
    }

    /// The estimate from the posterior of the last [`GridTracker::update`] over the grid
    /// `azimuths_deg` (degrees), and the index of the posterior's maximum: with
    /// [`GridTracker::refine_gain`] the vertex of the running mean curve next to that maximum,
    /// otherwise (or where the mean has no vertex there) the parabola through the log-posterior.
    /// `None` before the first update or for an empty grid.
    pub fn estimate(
        &self,
        state: &mut GridTrackerState,
        azimuths_deg: &[f32],
    ) -> Option<(f32, usize)> {
        let q = azimuths_deg.len().min(MAX_AZIMUTHS);
        if !state.initialized {
            return None;
        }
        let post = &state.posterior[..q];
        let (base, p) = argmax_parabolic_mapped(post, azimuths_deg, |v| libm::logf(v.max(1e-30)))?;
        if !(self.refine_gain > 0.0) {
            return Some((base, p));
        }
        // A talker seen moving may be up to a whole grid step from the posterior's maximum (the
        // running mean is drift-compensated); a still one only `refine_limit` steps.
        let limit = if state.drift != 0.0 {
            self.refine_limit.max(MOVING_REFINE_LIMIT)
        } else {
            self.refine_limit
        };
        let Some(d) = state.running.vertex_offset(p, q, limit) else {
            return Some((base, p));
        };
        Some((offset_azimuth(&azimuths_deg[..q], p, d), p))
    }

    /// Tells the tracker the azimuth it reported for this frame and the frame's own azimuth
    /// `raw_deg` (its curve's maximum; NaN when it has none), for the velocity estimate and the
    /// motion fit, with the reliability `b` they learn from (usually the b of
    /// [`GridTracker::update`]; the `Locator` leaves the frame onset weight out of it, see
    /// [`cma_localization::frame_onset`]). NaN counts as 0.
    pub fn observe_estimate(
        &self,
        state: &mut GridTrackerState,
        azimuth_deg: f32,
        raw_deg: f32,
        b: f32,
    ) {
        let b = unit_reliability(b);
        if self.motion_fit_pole > 0.0 {
            // `wrap_deg` maps NaN to 0: a missing azimuth is a missing step or offset here.
            let step = if state.previous.is_finite() && azimuth_deg.is_finite() {
                crate::angle::wrap_deg(azimuth_deg - state.previous)
            } else {
                f32::NAN
            };
            let offset = if raw_deg.is_finite() && azimuth_deg.is_finite() {
                crate::angle::wrap_deg(raw_deg - azimuth_deg)
            } else {
                f32::NAN
            };
            state.fit.update(step, self.motion_fit_pole, offset, b);
            state.fit_velocity = match state.fit.velocity() {
                Some((v, changed)) => {
                    let clamped = v.clamp(-MAX_MOTION_STEP_DEG, MAX_MOTION_STEP_DEG);
                    // The talker's motion changed (he stopped, turned or sped up): the previous
                    // estimate, learned from the old motion, starts again from the new one.
                    if changed {
                        state.velocity = clamped;
                    }
                    // The long line's slope (`changed` false) is significant: it drives the
                    // prior whatever its size. The short line's, which speaks after a change of
                    // motion, has no such test: like the plain estimate, only beyond the dead zone.
                    if !changed || v.abs() > self.min_velocity_deg {
                        clamped
                    } else {
                        f32::NAN
                    }
                }
                None => f32::NAN,
            };
        }
        if self.velocity_gain > 0.0 && state.previous.is_finite() && azimuth_deg.is_finite() {
            let innovation = crate::angle::wrap_deg(azimuth_deg - state.previous - state.drift);
            if innovation.abs() <= MAX_MOTION_STEP_DEG {
                let leak = 1.0 - self.velocity_pole.clamp(0.0, 1.0);
                let v =
                    state.velocity + b * (self.velocity_gain * innovation - leak * state.velocity);
                state.velocity = if v.is_finite() {
                    v.clamp(-MAX_MOTION_STEP_DEG, MAX_MOTION_STEP_DEG)
                } else {
                    0.0
                };
            }
        } else if self.velocity_pole > 0.0 && state.previous.is_finite() && azimuth_deg.is_finite()
        {
            // The frame-to-frame change, weighted by the frame's reliability: a pause (b = 0), in
            // which the estimate moves only by the drift, teaches nothing and keeps the velocity.
            let d = crate::angle::wrap_deg(azimuth_deg - state.previous);
            if d.abs() <= MAX_MOTION_STEP_DEG {
                let leak = 1.0 - self.velocity_pole.clamp(0.0, 1.0);
                state.velocity += leak * b * (d - state.velocity);
            }
        }
        state.previous = azimuth_deg;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn negligible_exponent_keeps_the_likelihood_bits() {
        assert_eq!(negligible_exponent(0.0), f32::NEG_INFINITY);
        assert_eq!(negligible_exponent(f32::NAN), f32::NEG_INFINITY);
        let mut rng = crate::test_rng::Lcg(11);
        for floor in [0.2f32, 0.05, 0.5, 1.0, 0.125, 0.999, 1e-3, 1e-30] {
            let cut = negligible_exponent(floor);
            assert!(cut < 0.0 && cut.is_finite(), "{floor}");
            // Every x below the cut: the full expression rounds to the floor.
            for i in 0..20_000 {
                let x = cut - (i as f32) * 0.005 - (rng.next_u32() >> 9) as f32 * 1e-9;
                let full = floor + (1.0 - floor) * crate::fast_exp::exp_nonpositive(x);
                assert_eq!(full.to_bits(), floor.to_bits(), "floor {floor} x {x}");
            }
            // And the cut is within a few natural-log units of where the exponential stops mattering.
            if floor <= 0.5 {
                let above = floor + (1.0 - floor) * crate::fast_exp::exp_nonpositive(cut + 4.0);
                assert_ne!(above.to_bits(), floor.to_bits(), "floor {floor}");
            }
        }
    }

    fn peaked(q: usize, at: usize) -> [f32; 72] {
        core::array::from_fn(|i| {
            let d = (i as i32 - at as i32)
                .rem_euclid(q as i32)
                .min((at as i32 - i as i32).rem_euclid(q as i32));
            1.0 / (1.0 + 0.05 * d as f32)
        })
    }

    fn argmax(p: &[f32]) -> usize {
        p.iter()
            .enumerate()
            .fold(
                (0, f32::MIN),
                |b, (i, v)| if *v > b.1 { (i, *v) } else { b },
            )
            .0
    }

    #[test]
    fn ignores_unreliable_frames_and_follows_jumps() {
        let t = GridTracker {
            sharpness: 20.0,
            diffusion_deg: 2.0,
            ..base()
        };
        let mut s = GridTrackerState::new();
        for _ in 0..20 {
            t.update(&mut s, &peaked(72, 10), 1.0, 5.0);
        }
        assert_eq!(argmax(s.posterior(72)), 10);
        // Unreliable frames pointing elsewhere change nothing.
        for _ in 0..50 {
            t.update(&mut s, &peaked(72, 40), 0.0, 5.0);
        }
        assert_eq!(argmax(s.posterior(72)), 10);
        // Reliable frames at the new place win within a few frames.
        let mut frames = 0;
        while argmax(s.posterior(72)) != 40 {
            t.update(&mut s, &peaked(72, 40), 1.0, 5.0);
            frames += 1;
            assert!(frames < 10);
        }
        let sum: f32 = s.posterior(72).iter().sum();
        assert!((sum - 1.0).abs() < 1e-4);
    }

    /// Frames until the argmax moves from bin 10 to bin 40, after `pause` frames with b = 0.
    fn frames_to_switch(t: GridTracker, pause: usize) -> usize {
        let mut s = GridTrackerState::new();
        for _ in 0..100 {
            t.update(&mut s, &peaked(72, 10), 1.0, 5.0);
        }
        for _ in 0..pause {
            t.update(&mut s, &peaked(72, 40), 0.0, 5.0);
        }
        let mut frames = 0;
        while argmax(s.posterior(72)) != 40 {
            t.update(&mut s, &peaked(72, 40), 0.5, 5.0);
            frames += 1;
            assert!(frames < 100);
        }
        frames
    }

    #[test]
    fn a_new_utterance_after_a_pause_may_come_from_elsewhere() {
        let t = GridTracker {
            likelihood_floor: 0.2,
            ..base()
        };
        let onset = GridTracker {
            onset_jump_probability: 0.3,
            pause_frames: 6,
            onset_frames: 3,
            onset_likelihood_floor: 0.2,
            ..t
        };
        let trusted = GridTracker {
            onset_likelihood_floor: 0.05,
            ..onset
        };
        // Without a pause (or with a shorter one) the onset rules change nothing.
        for o in [onset, trusted] {
            assert_eq!(frames_to_switch(o, 0), frames_to_switch(t, 0));
            assert_eq!(frames_to_switch(o, 5), frames_to_switch(t, 5));
        }
        // After a pause the reliable frames from the second on may jump: the switch comes sooner,
        // and sooner still when each onset frame may move the posterior further.
        let (with, without) = (frames_to_switch(onset, 6), frames_to_switch(t, 6));
        assert!(with < without, "{with} vs {without}");
        let first = frames_to_switch(trusted, 6);
        assert!(first < with, "{first} vs {with}");
    }

    #[test]
    fn a_single_reliable_frame_in_a_pause_does_not_start_an_onset() {
        let t = GridTracker {
            likelihood_floor: 0.2,
            onset_jump_probability: 0.3,
            pause_frames: 6,
            onset_frames: 3,
            onset_likelihood_floor: 0.05,
            ..base()
        };
        // A talker at bin 10, then a pause with `blips` reliable frames from bin 40 in its middle.
        let after = |blips: usize| {
            let mut s = GridTrackerState::new();
            for _ in 0..100 {
                t.update(&mut s, &peaked(72, 10), 1.0, 5.0);
            }
            for _ in 0..30 {
                t.update(&mut s, &peaked(72, 40), 0.0, 5.0);
            }
            for _ in 0..blips {
                t.update(&mut s, &peaked(72, 40), 1.0, 5.0);
            }
            for _ in 0..10 {
                t.update(&mut s, &peaked(72, 40), 0.0, 5.0);
            }
            argmax(s.posterior(72))
        };
        // A blip of the noise leaves the talker where he was; two reliable frames in a row are an
        // onset, and may come from elsewhere.
        assert_eq!(after(1), 10);
        assert_eq!(after(3), 40);
    }

    #[test]
    fn degenerate_inputs_keep_a_valid_posterior() {
        let t = GridTracker {
            sharpness: 20.0,
            diffusion_deg: 2.0,
            ..base()
        };
        let mut s = GridTrackerState::new();
        t.update(&mut s, &[f32::NAN; 72], 1.0, 5.0);
        assert!(s.posterior(72).iter().all(|v| v.is_finite()));
        t.update(&mut s, &[0.5; 72], f32::INFINITY, 0.0);
        assert!(s.posterior(72).iter().all(|v| v.is_finite()));
    }

    fn base() -> GridTracker {
        GridTracker {
            sharpness: 60.0,
            diffusion_deg: 1.0,
            jump_probability: 0.01,
            velocity_pole: 0.0,
            min_velocity_deg: 0.0,
            velocity_gain: 0.0,
            likelihood_floor: 0.0,
            motion_diffusion: 0.0,
            onset_jump_probability: 0.0,
            pause_frames: 0,
            onset_frames: 0,
            onset_likelihood_floor: 0.0,
            refine_gain: 0.0,
            refine_limit: 1.0,
            refine_curve: RefineCurve::Similarity,
            motion_fit_pole: 0.0,
        }
    }

    #[test]
    fn settings_are_checked() {
        assert!(crate::curve_tracker::DEFAULT_GRID_TRACKER.is_valid());
        assert!(base().is_valid());
        let d = crate::curve_tracker::DEFAULT_GRID_TRACKER;
        for bad in [
            GridTracker {
                sharpness: f32::NAN,
                ..d
            },
            GridTracker {
                jump_probability: 1.5,
                ..d
            },
            GridTracker {
                likelihood_floor: -0.1,
                ..d
            },
            GridTracker {
                onset_likelihood_floor: f32::INFINITY,
                ..d
            },
            GridTracker {
                refine_gain: f32::NAN,
                ..d
            },
            GridTracker {
                refine_limit: -1.0,
                ..d
            },
        ] {
            assert!(!bad.is_valid(), "{bad:?}");
        }
    }

    #[test]
    fn velocity_learns_from_the_b_it_is_given_not_the_update_b() {
        let t = GridTracker {
            velocity_pole: 0.9,
            ..base()
        };
        let curve = peaked(72, 10);
        // The same updates (b = 0.2) and estimates moving by 1° per frame; only the b handed to
        // `observe_estimate` differs (as when the frame onset weight is left out of it).
        let learn = |motion_b: f32| {
            let mut s = GridTrackerState::new();
            for i in 0..10 {
                t.update(&mut s, &curve, 0.2, 5.0);
                t.observe_estimate(&mut s, i as f32, f32::NAN, motion_b);
            }
            s.velocity()
        };
        let (weak, full, none) = (learn(0.2), learn(1.0), learn(0.0));
        assert_eq!(none, 0.0);
        assert!(
            weak > 0.0 && full > 2.0 * weak,
            "b 0.2: {weak}, b 1: {full}"
        );
        // With b = 1 the pole-0.9 average of a 1°/frame change after 9 steps: 1 − 0.9⁹.
        assert!((full - (1.0 - 0.9f32.powi(9))).abs() < 1e-4, "{full}");
        // NaN counts as 0.
        assert_eq!(learn(f32::NAN), 0.0);
    }

    #[test]
    fn the_innovation_driven_velocity_learns_too() {
        let t = GridTracker {
            velocity_pole: 0.9,
            velocity_gain: 0.2,
            ..base()
        };
        let curve = peaked(72, 10);
        let mut s = GridTrackerState::new();
        for i in 0..30 {
            t.update(&mut s, &curve, 1.0, 5.0);
            t.observe_estimate(&mut s, i as f32, f32::NAN, 1.0);
        }
        assert!(s.velocity() > 0.3, "{}", s.velocity());
    }

    #[test]
    fn velocity_is_learned_from_reliable_frames_only() {
        let t = GridTracker {
            velocity_pole: 0.9,
            ..base()
        };
        let curve = peaked(72, 10);
        let mut s = GridTrackerState::new();
        // Estimates that move by 1° per frame while b = 0 (a pause, or noise before the talker).
        for i in 0..20 {
            t.update(&mut s, &curve, 0.0, 5.0);
            t.observe_estimate(&mut s, i as f32, f32::NAN, 0.0);
        }
        assert_eq!(s.velocity(), 0.0);
        for i in 20..40 {
            t.update(&mut s, &curve, 1.0, 5.0);
            t.observe_estimate(&mut s, i as f32, f32::NAN, 1.0);
        }
        assert!((s.velocity() - 1.0).abs() < 0.15, "{}", s.velocity());
        // A pause keeps what was learned.
        let v = s.velocity();
        for i in 40..60 {
            t.update(&mut s, &curve, 0.0, 5.0);
            t.observe_estimate(&mut s, 40.0 + (i - 40) as f32 * 3.0, f32::NAN, 0.0);
        }
        assert_eq!(s.velocity(), v);
    }

    #[test]
    fn refinement_curve_places_the_estimate_and_the_likelihood_the_maximum() {
        // The likelihood has a corner at 50° (a cusp the parabola leans from); the refinement curve
        // is smooth with its vertex at 52°: the posterior's maximum comes from the first, the
        // position between grid points from the second. With the likelihood curve in both places
        // `update_refined` is `update`.
        let az: [f32; 72] = core::array::from_fn(|i| i as f32 * 5.0);
        let like: [f32; 72] =
            core::array::from_fn(|i| -crate::angle::wrap_deg(az[i] - 50.0).abs() / 100.0);
        let smooth: [f32; 72] = core::array::from_fn(|i| {
            let d = crate::angle::wrap_deg(az[i] - 52.0);
            -d * d / 1000.0
        });
        let t = GridTracker {
            likelihood_floor: 0.2,
            refine_gain: 0.1,
            ..base()
        };
        let (mut a, mut b) = (GridTrackerState::new(), GridTrackerState::new());
        let mut c = GridTrackerState::new();
        for _ in 0..100 {
            t.update_refined(&mut a, &like, &smooth, 1.0, 5.0);
            t.update(&mut b, &like, 1.0, 5.0);
            t.update_refined(&mut c, &like, &like, 1.0, 5.0);
        }
        let (ra, pa) = t.estimate(&mut a, &az).unwrap();
        let (rb, pb) = t.estimate(&mut b, &az).unwrap();
        let (rc, _) = t.estimate(&mut c, &az).unwrap();
        assert_eq!((pa, pb), (10, 10));
        assert!(
            (ra - 52.0).abs() < 0.05,
            "refined by the smooth curve: {ra}"
        );
        assert!((rb - 50.0).abs() < 1e-3, "refined by the cusp: {rb}");
        assert_eq!(rb.to_bits(), rc.to_bits());
    }

    #[test]
    fn running_mean_refinement_removes_the_pull_towards_the_grid_point() {
        // A still talker 2° off a 5° grid point, with the product's floor: the log-posterior parabola
        // leans to the grid point, the running mean curve's vertex does not.
        let az: [f32; 72] = core::array::from_fn(|i| i as f32 * 5.0);
        let truth = 52.0f32;
        let curve: [f32; 72] = core::array::from_fn(|i| {
            let d = crate::angle::wrap_deg(az[i] - truth);
            1.0 / (1.0 + 0.01 * d * d)
        });
        let run = |t: GridTracker| {
            let mut s = GridTrackerState::new();
            assert_eq!(t.estimate(&mut s, &az), None);
            for _ in 0..100 {
                t.update(&mut s, &curve, 1.0, 5.0);
            }
            t.estimate(&mut s, &az).unwrap()
        };
        let plain = GridTracker {
            likelihood_floor: 0.2,
            ..base()
        };
        let refined = GridTracker {
            refine_gain: 0.1,
            ..plain
        };
        let (a, p) = run(plain);
        let (r, pr) = run(refined);
        assert_eq!((p, pr), (10, 10));
        assert!((a - truth).abs() > 1.0, "log-posterior parabola: {a}");
        assert!((r - truth).abs() < 0.3, "running mean vertex: {r}");
        // The limit keeps the estimate next to the posterior's maximum.
        let (l, _) = run(GridTracker {
            refine_limit: 0.2,
            ..refined
        });
        assert!((l - 51.0).abs() < 1e-3, "{l}");
    }

    #[test]
    fn a_moving_talker_may_be_a_whole_step_from_the_maximum() {
        // The still talker above (2° off a 5° grid point) under a 0.2-step limit: held 1° off the
        // grid point. One frame later with a drift the tracker sees (a talker walking on) the
        // limit is MOVING_REFINE_LIMIT, and the running mean's vertex is reported.
        let az: [f32; 72] = core::array::from_fn(|i| i as f32 * 5.0);
        let curve: [f32; 72] = core::array::from_fn(|i| {
            let d = crate::angle::wrap_deg(az[i] - 52.0);
            1.0 / (1.0 + 0.01 * d * d)
        });
        let t = GridTracker {
            likelihood_floor: 0.2,
            refine_gain: 0.1,
            refine_limit: 0.2,
            min_velocity_deg: 0.3,
            ..base()
        };
        let mut still = GridTrackerState::new();
        for _ in 0..100 {
            t.update(&mut still, &curve, 1.0, 5.0);
        }
        let mut moving = still.clone();
        moving.velocity = 0.5;
        t.update(&mut still, &curve, 1.0, 5.0);
        t.update(&mut moving, &curve, 1.0, 5.0);
        let (e, p) = t.estimate(&mut still, &az).unwrap();
        assert_eq!(p, 10);
        assert!((e - 51.0).abs() < 1e-3, "still: {e}");
        let (e, p) = t.estimate(&mut moving, &az).unwrap();
        assert_eq!(p, 10);
        assert!(e > 51.5 && e <= 55.0, "moving: {e}");
    }

    #[test]
    fn likelihood_floor_limits_what_one_frame_can_do() {
        let contradiction = |t: GridTracker| {
            let mut s = GridTrackerState::new();
            for _ in 0..30 {
                t.update(&mut s, &peaked(72, 10), 1.0, 5.0);
            }
            // One confident frame from a reflection at bin 40.
            t.update(&mut s, &peaked(72, 40), 1.0, 5.0);
            s.posterior(72)[40] / s.posterior(72)[10]
        };
        let without = contradiction(base());
        let with = contradiction(GridTracker {
            likelihood_floor: 0.2,
            ..base()
        });
        assert!(with < without, "floor: {with} vs no floor: {without}");
    }

    /// A talker walking at 0.2° per frame, below `min_velocity_deg`, each frame's curve peaked
    /// a few degrees off his path: the motion fit's slope, significant, drifts the prior all the
    /// same; without the fit the plain velocity estimate stays inside its dead zone and the prior
    /// does not move.
    #[test]
    fn a_slow_walker_drifts_the_prior_through_the_motion_fit() {
        let azimuths: [f32; 72] = core::array::from_fn(|i| i as f32 * 5.0);
        let drift_after = |t: GridTracker| {
            let mut s = GridTrackerState::new();
            let mut rng = crate::test_rng::Lcg(3);
            for f in 0..600 {
                let heard = 20.0 + 0.2 * f as f32 + (rng.unit() - 0.5) * 6.0;
                let curve: [f32; 72] = core::array::from_fn(|i| {
                    let d = crate::angle::wrap_deg(azimuths[i] - heard).abs();
                    1.0 / (1.0 + 0.05 * d)
                });
                t.update(&mut s, &curve, 0.8, 5.0);
                let (est, _) = t.estimate(&mut s, &azimuths).unwrap();
                t.observe_estimate(&mut s, est, heard, 0.8);
            }
            s.drift
        };
        let d = crate::curve_tracker::DEFAULT_GRID_TRACKER;
        assert!(d.min_velocity_deg > 0.2);
        let with_fit = drift_after(d);
        assert!((with_fit - 0.2).abs() < 0.03, "drift {with_fit}° per frame");
        let without_fit = drift_after(GridTracker {
            motion_fit_pole: 0.0,
            ..d
        });
        assert_eq!(without_fit, 0.0);
    }

    #[test]
    fn velocity_drift_follows_a_moving_peak_and_motion_diffusion_keeps_static_tracks() {
        let track = |t: GridTracker, step_bins_per_frame: f32| {
            let mut s = GridTrackerState::new();
            let mut err = 0.0f32;
            let n = 200;
            for f in 0..n {
                let pos = 10.0 + step_bins_per_frame * f as f32;
                let curve: [f32; 72] = core::array::from_fn(|i| {
                    let d = crate::angle::wrap_deg((i as f32 - pos) * 5.0).abs();
                    1.0 / (1.0 + 0.01 * d)
                });
                let post = t.update(&mut s, &curve, 0.3, 5.0);
                let est = argmax(post) as f32 * 5.0;
                t.observe_estimate(&mut s, est, f32::NAN, 0.3);
                if f > n / 2 {
                    err += crate::angle::wrap_deg(est - pos * 5.0);
                }
            }
            err / (n / 2 - 1) as f32
        };
        let moving = 0.15; // bins per frame = 0.75°/frame
        let lag_plain = track(base(), moving);
        let drift = GridTracker {
            velocity_pole: 0.98,
            min_velocity_deg: 0.3,
            ..base()
        };
        let lag_drift = track(drift, moving);
        assert!(
            lag_drift.abs() < lag_plain.abs(),
            "drift {lag_drift} vs plain {lag_plain}"
        );
        // A still talker: the motion-dependent diffusion changes nothing (v = 0 inside the dead zone).
        let with_md = GridTracker {
            motion_diffusion: 2.0,
            ..drift
        };
        assert_eq!(track(drift, 0.0), track(with_md, 0.0));
    }
}
