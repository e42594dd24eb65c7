//! The talker's angular velocity from the frames' own estimates: a straight line fitted by
//! reliability-weighted least squares with exponential forgetting.
//!
//! A moving talker is heard while he speaks, not in his pauses. The grid tracker's reported
//! azimuth is held through a pause (it moves only by the drift) and pulled back after it, so the
//! frame-to-frame change of that azimuth teaches a velocity that trails the talker's, and at a
//! walking pace the tracker falls behind in every pause. The frames' own estimates (each frame's
//! curve maximum) lie on the talker's path whenever he speaks: the slope of a line through them is
//! his velocity, pauses or not. The fit keeps the frames within [`GATE_DEG`] of the reported
//! azimuth (a reflection or noise source elsewhere stays out) and reports its slope only where it
//! is [`SIGNIFICANCE`] standard errors from zero.

/// Half-width in degrees of the window around the reported azimuth whose frame estimates enter
/// the fit.
pub const GATE_DEG: f32 = 20.0;
/// Standard errors the slope must lie from zero to be reported.
pub const SIGNIFICANCE: f32 = 3.0;
/// Least weight (sum of reliabilities) for a slope.
const MIN_WEIGHT: f32 = 10.0;
/// Least weighted variance of the frame times, frames², for a slope.
const MIN_SPREAD: f32 = 100.0;

/// Weighted sums of (t, y): t in frames before now (≤ 0), y the frame estimate's offset in
/// degrees from the latest reported azimuth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionFit {
    w: f32,
    wt: f32,
    wtt: f32,
    wy: f32,
    wty: f32,
    wyy: f32,
}

impl Default for MotionFit {
    fn default() -> Self {
        Self::new()
    }
}

impl MotionFit {
    /// No frames.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            w: 0.0,
            wt: 0.0,
            wtt: 0.0,
            wy: 0.0,
            wty: 0.0,
            wyy: 0.0,
        }
    }

    /// One frame: the reported azimuth moved by `step_deg` since the last frame, the frames seen so
    /// far are forgotten by `pole`, and the frame's own estimate, `offset_deg` from the reported
    /// azimuth, enters with weight `b` when it lies within [`GATE_DEG`] (NaN or b ≤ 0: none).
    pub fn update(&mut self, step_deg: f32, pole: f32, offset_deg: f32, b: f32) {
        // Offsets are measured from the new reported azimuth.
        if step_deg.is_finite() {
            let d = step_deg;
            self.wyy += d * (d * self.w - 2.0 * self.wy);
            self.wy -= d * self.w;
            self.wty -= d * self.wt;
        }
        // One frame later: t → t − 1, weights × pole.
        let pole = pole.clamp(0.0, 1.0);
        let (w, wt, wy) = (self.w, self.wt, self.wy);
        self.wtt = pole * (self.wtt - 2.0 * wt + w);
        self.wt = pole * (wt - w);
        self.wty = pole * (self.wty - wy);
        self.wy = pole * wy;
        self.wyy *= pole;
        self.w = pole * w;
        if b > 0.0 && b <= 1.0 && offset_deg.abs() <= GATE_DEG {
            self.w += b;
            self.wy += b * offset_deg;
            self.wyy += b * offset_deg * offset_deg;
        }
        if !(self.w.is_finite() && self.wtt.is_finite() && self.wyy.is_finite()) {
            *self = Self::new();
        }
    }

    /// The fitted slope in degrees per frame and its standard error, when the weight and the
    /// spread of the frame times suffice.
    #[must_use]
    pub fn slope(&self) -> Option<(f32, f32)> {
        // The centred sums times w: Sxx·w = den, Sxy·w = num, Syy·w = syy.
        let den = self.w * self.wtt - self.wt * self.wt;
        if !(self.w >= MIN_WEIGHT && den >= MIN_SPREAD * self.w * self.w) {
            return None;
        }
        let num = self.w * self.wty - self.wt * self.wy;
        let v = num / den;
        let syy = self.w * self.wyy - self.wy * self.wy;
        let residual = (syy - v * num).max(0.0) / self.w;
        let se = libm::sqrtf(residual / (self.w - 2.0).max(1.0) * self.w / den);
        (v.is_finite() && se.is_finite()).then_some((v, se))
    }

    /// The slope when it lies [`SIGNIFICANCE`] standard errors from zero.
    #[must_use]
    pub fn significant_slope(&self) -> Option<f32> {
        self.slope()
            .and_then(|(v, se)| (v.abs() > SIGNIFICANCE * se).then_some(v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frames of a talker at `v` °/frame heard every frame with `noise` (a fixed pseudo-random
    /// pattern), tracked by a reported azimuth that stays `lag` behind.
    fn run(v: f32, noise: f32, lag: f32, frames: usize) -> MotionFit {
        let mut fit = MotionFit::new();
        let mut rng = crate::test_rng::Lcg(5);
        let mut reported = 0.0f32;
        for i in 0..frames {
            let talker = v * i as f32;
            let next = talker - lag;
            let step = next - reported;
            reported = next;
            let n = ((rng.next_u32() >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 2.0 * noise;
            fit.update(
                if i == 0 { f32::NAN } else { step },
                0.99,
                talker + n - reported,
                1.0,
            );
        }
        fit
    }

    #[test]
    fn finds_the_talkers_velocity_whatever_the_lag() {
        for (v, lag) in [(1.44f32, 0.0f32), (1.44, 12.0), (-0.7, -5.0), (0.0, 3.0)] {
            let (s, se) = run(v, 4.0, lag, 300).slope().unwrap();
            assert!((s - v).abs() < 0.05, "v {v} lag {lag}: {s} ± {se}");
        }
        assert!(run(0.0, 4.0, 0.0, 300).significant_slope().is_none());
        assert!(run(1.0, 4.0, 0.0, 300).significant_slope().is_some());
    }

    #[test]
    fn a_pause_keeps_the_slope() {
        let mut fit = run(1.0, 2.0, 0.0, 200);
        let before = fit.slope().unwrap().0;
        // Forty silent frames in which the reported azimuth drifts on at the fitted speed.
        for _ in 0..40 {
            fit.update(before, 0.99, f32::NAN, 0.0);
        }
        let after = fit.slope().unwrap().0;
        assert!((after - before).abs() < 1e-3, "{before} → {after}");
    }

    #[test]
    fn far_or_unreliable_frames_stay_out() {
        let mut fit = MotionFit::new();
        for _ in 0..50 {
            fit.update(0.0, 0.99, 2.0 * GATE_DEG, 1.0);
            fit.update(0.0, 0.99, 1.0, 0.0);
            fit.update(0.0, 0.99, 1.0, f32::NAN);
        }
        assert_eq!(fit.slope(), None);
        assert_eq!(fit, MotionFit::new());
    }
}
