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
//!
//! The line remembers about the last 1.6 s (the grid tracker's pole 0.99), long enough to carry a
//! talker through his pauses and long enough to carry the track on after he has stopped. A second,
//! short line over the last ≈ 0.15 s ([`SHORT_POLE`]) watches for that: when its slope lies
//! [`SIGNIFICANCE`] of its standard errors from the long line's, the talker's motion has changed:
//! the long line starts again, empty, and the short one speaks until the long one holds the weight
//! of frames from after the change. (A long line restarted from the short one held frames from
//! before the change; with the early slope below it could report the old speed on them,
//! drift the reported azimuth out of its own gate and hold that speed for good.)
//!
//! Real speech in a room comes in bursts of two or three reliable frames, too short in time for
//! the short line's slope. A talker who stops shows it differently: the frames of his next bursts
//! lie *behind* the line's extrapolation, further with every burst. The line they are tested
//! against is the long line as it was one to two checkpoints ([`CHECKPOINT_FRAMES`]) ago, carried
//! forward in time: the long line itself holds those frames and bends towards them, and its
//! scatter grows with the bend, so after a short walk it hid the stop for seconds. When the short
//! line's frames lie behind that line by [`RECENT_SIGNIFICANCE`] standard errors and at least
//! [`RECENT_MIN_OFFSET_DEG`], the fit reports rest (the drift holds) and, once frames of weight
//! [`CONFIRM_WEIGHT`] have been seen off the line in a row, both lines start again; frames back on
//! the line end the doubt. (Measured on the validation suite, docs/history.md: talkers who walk
//! 3 s at 45–90°/s and stop are within 10° in 87.9 % of the frames after the stop instead of
//! 82.4 %, those who walk 6 s in 81.9 → 83.0 %; talkers circling at 90°/s lose 1–2 points.)
//!
//! The slope drives the grid tracker's prediction whatever its size where it is significant:
//! the significance test, not a least speed, tells a slow walker from a still talker's noise.
//!
//! A talker who starts walking trails the track until the long line has the evidence for a slope
//! ([`MIN_WEIGHT`] of frame reliability, spread over about 35 frames): that wait is most of the
//! lag of a fast walker. Half that evidence ([`EARLY_MIN_WEIGHT`]) gives a slope early when it
//! carries the talker at least [`EARLY_MIN_TRAVEL_DEG`] over one standard deviation of its frames'
//! times. Over so short a line a still talker's frames lie along the room's reflections, which
//! differ from syllable to syllable (real speech in a room: 10–25° between the first syllables of
//! an utterance): two bursts of speech 10° apart make a significant slope, and a still talker
//! would drift away in the pause after them. A talker seen to stop gets no early slope until he
//! is seen walking on the full evidence: the frames right after a stop scatter the same way.
//! (Measured on the validation suite and real-speech scenes, docs/history.md: talkers at 90°/s
//! +1.1 to +2.2 points within 10° and −0.2 to −0.4° MAE on four seed sets; still talkers within
//! 0.6 point, those who walk and stop unchanged.)

/// Half-width in degrees of the window around the reported azimuth whose frame estimates enter
/// the fit.
pub const GATE_DEG: f32 = 20.0;
/// Standard errors the slope must lie from zero to be reported.
pub const SIGNIFICANCE: f32 = 3.0;
/// Least weight (sum of reliabilities) and least weighted variance of the frame times (frames²)
/// for the long line's slope.
pub const MIN_WEIGHT: f32 = 10.0;
const MIN_SPREAD: f32 = 100.0;
/// The same for an early slope (not after a stop), which must also carry the talker
/// [`EARLY_MIN_TRAVEL_DEG`].
pub const EARLY_MIN_WEIGHT: f32 = 5.0;
const EARLY_MIN_SPREAD: f32 = 50.0;
/// Least travel of an early slope, degrees: its size times the standard deviation of the line's
/// frame times.
pub const EARLY_MIN_TRAVEL_DEG: f32 = 12.0;
/// Forgetting pole per frame of the short line that detects a change of motion, and its least
/// weight and time variance.
pub const SHORT_POLE: f32 = 0.9;
const SHORT_MIN_WEIGHT: f32 = 3.0;
const SHORT_MIN_SPREAD: f32 = 16.0;
/// Least weight of the short line's frames for the test of their offset from the long line.
const RECENT_MIN_WEIGHT: f32 = 1.5;
/// Standard errors by which the short line's frames must lie behind the long line's extrapolation
/// for the talker to be seen slowing down.
pub const RECENT_SIGNIFICANCE: f32 = 3.0;
/// Least mean offset of those frames behind the long line, degrees (a room's reflections move a
/// moving talker's frames off his path by a few degrees for a while).
pub const RECENT_MIN_OFFSET_DEG: f32 = 12.0;
/// Frames between the snapshots of the long line that the recent frames are tested against.
pub const CHECKPOINT_FRAMES: u32 = 16;
/// Weight of the frames seen behind the long line in a row that confirms the change: both lines
/// start again.
pub const CONFIRM_WEIGHT: f32 = 3.0;

/// The long and the short line.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct MotionFit {
    long: LineSums,
    short: LineSums,
    /// The long line restarted and has not yet the weight for a slope: the short one speaks.
    restarting: bool,
    /// Weight of the frames seen behind the long line since they were first seen there.
    doubt: f32,
    /// The weight with which the last frame entered the lines (0: it did not).
    last_b: f32,
    /// The long line as it was between [`CHECKPOINT_FRAMES`] and twice that many frames ago,
    /// carried forward in time without the frames since: what the recent frames are tested
    /// against (a line that holds them bends towards them and hides a stop).
    earlier: LineSums,
    /// The long line at the last checkpoint (the next `earlier`).
    pending: LineSums,
    /// Frames since the last checkpoint.
    age: u32,
    /// The talker was seen to stop and has not been seen walking since: no early slope.
    stopped: bool,
}

impl MotionFit {
    /// No frames.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            long: LineSums::new(),
            short: LineSums::new(),
            restarting: false,
            doubt: 0.0,
            last_b: 0.0,
            earlier: LineSums::new(),
            pending: LineSums::new(),
            age: 0,
            stopped: false,
        }
    }

    /// One frame: the reported azimuth moved by `step_deg` since the last frame (NaN: unknown; a
    /// step beyond [`GATE_DEG`] is a jump to another talker or place, and the fit starts again),
    /// the long line forgets by `pole` (the short one by [`SHORT_POLE`]), and the frame's own
    /// estimate, `offset_deg` from the reported azimuth, enters with weight `b` when it lies
    /// within [`GATE_DEG`] (NaN or b ≤ 0: none).
    pub fn update(&mut self, step_deg: f32, pole: f32, offset_deg: f32, b: f32) {
        if step_deg.abs() > GATE_DEG {
            *self = Self::new();
        }
        self.last_b = self.long.update(step_deg, pole, offset_deg, b);
        self.short.update(step_deg, SHORT_POLE, offset_deg, b);
        self.earlier.update(step_deg, pole, f32::NAN, 0.0);
        self.pending.update(step_deg, pole, f32::NAN, 0.0);
        self.age += 1;
        if self.age >= CHECKPOINT_FRAMES {
            self.earlier = self.pending;
            self.pending = self.long;
            self.age = 0;
        }
    }

    /// The talker's velocity in degrees per frame and whether his motion has just changed: rest
    /// (0, changed) while the recent frames lie behind the long line (module documentation);
    /// after a change, the short line's slope (whatever its significance) until the long line,
    /// started again, has the weight for a slope; otherwise the long line's slope where it is
    /// [`SIGNIFICANCE`] standard errors from zero. `None` when none holds.
    pub fn velocity(&mut self) -> Option<(f32, bool)> {
        let long = self.slope();
        let short = self.short.slope(SHORT_MIN_WEIGHT, SHORT_MIN_SPREAD);
        if long.is_some() {
            self.restarting = false;
        }
        if long.is_some_and(|(v, se)| v.abs() > SIGNIFICANCE * se) {
            self.stopped = false;
        }
        // The recent frames lie behind the long line's extrapolation: the talker slowed down or
        // stopped between bursts of speech too short for the short line's slope (which still
        // holds the old motion). Rest while in doubt; confirmed, both lines start again. Only a
        // talker seen moving (the long line's slope significant) can be seen to stop.
        if long.is_some_and(|(v, se)| v.abs() > SIGNIFICANCE * se) {
            match self.earlier.behind_line(&self.short, RECENT_MIN_WEIGHT) {
                Some(true) => {
                    self.doubt += self.last_b;
                    if self.doubt >= CONFIRM_WEIGHT {
                        *self = Self {
                            stopped: true,
                            ..Self::new()
                        };
                    }
                    return Some((0.0, true));
                }
                Some(false) => self.doubt = 0.0,
                None => {}
            }
        }
        match (long, short) {
            (Some((v, _)), Some((recent, se))) if (recent - v).abs() > SIGNIFICANCE * se => {
                self.long = LineSums::new();
                self.restarting = true;
                Some((recent, true))
            }
            (Some((v, se)), _) => (v.abs() > SIGNIFICANCE * se).then_some((v, false)),
            (None, Some((recent, _))) if self.restarting => Some((recent, true)),
            _ => None,
        }
    }

    /// The long line's slope and its standard error (as [`MotionFit::velocity`] sees it): on
    /// [`MIN_WEIGHT`], or early (module documentation).
    #[must_use]
    pub fn slope(&self) -> Option<(f32, f32)> {
        let full = self.long.slope(MIN_WEIGHT, MIN_SPREAD);
        if full.is_some() || self.stopped {
            return full;
        }
        let (v, se) = self.long.slope(EARLY_MIN_WEIGHT, EARLY_MIN_SPREAD)?;
        // The standard deviation of the frame times: √(Sxx/w) = √den / w.
        let travel = v.abs() * libm::sqrtf(self.long.den()) / self.long.w;
        (travel >= EARLY_MIN_TRAVEL_DEG).then_some((v, se))
    }
}

/// Weighted sums of (t, y): t in frames before now (≤ 0), y the frame estimate's offset in
/// degrees from the latest reported azimuth.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct LineSums {
    w: f32,
    wt: f32,
    wtt: f32,
    wy: f32,
    wty: f32,
    wyy: f32,
}

impl LineSums {
    const fn new() -> Self {
        Self {
            w: 0.0,
            wt: 0.0,
            wtt: 0.0,
            wy: 0.0,
            wty: 0.0,
            wyy: 0.0,
        }
    }

    /// See [`MotionFit::update`].
    /// Returns the weight with which the frame entered (0: it did not).
    fn update(&mut self, step_deg: f32, pole: f32, offset_deg: f32, b: f32) -> f32 {
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
        let entered = b > 0.0 && b <= 1.0 && offset_deg.abs() <= GATE_DEG;
        if entered {
            self.w += b;
            self.wy += b * offset_deg;
            self.wyy += b * offset_deg * offset_deg;
        }
        if !(self.w.is_finite() && self.wtt.is_finite() && self.wyy.is_finite()) {
            *self = Self::new();
        }
        if entered {
            b
        } else {
            0.0
        }
    }

    /// Sxx·w: the centred sum of the frame times, times the weight.
    fn den(&self) -> f32 {
        self.w * self.wtt - self.wt * self.wt
    }

    /// The weighted least-squares line through the sums, given [`LineSums::den`]: its slope v and
    /// the weighted mean squared residual.
    fn fit(&self, den: f32) -> (f32, f32) {
        // The centred sums times w: Sxx·w = den, Sxy·w = num, Syy·w = syy.
        let num = self.w * self.wty - self.wt * self.wy;
        let v = num / den;
        let syy = self.w * self.wyy - self.wy * self.wy;
        let residual = (syy - v * num).max(0.0) / self.w;
        (v, residual)
    }

    /// Whether the frames of `recent` (sums over the same frames, with a shorter memory) lie
    /// behind this line's extrapolation (against its slope): their weighted mean offset from it at
    /// least [`RECENT_MIN_OFFSET_DEG`] and more than [`RECENT_SIGNIFICANCE`] standard errors (the
    /// line's residual scatter over the recent weight, and the line's own uncertainty where they
    /// lie). `None` when `recent` weighs less than `min_weight` (nothing to tell).
    fn behind_line(&self, recent: &LineSums, min_weight: f32) -> Option<bool> {
        let den = self.den();
        if !(recent.w >= min_weight && self.w > 2.0 && den > 0.0) {
            return None;
        }
        let (v, residual) = self.fit(den);
        let a = (self.wy - v * self.wt) / self.w;
        let var = residual / (self.w - 2.0);
        let mean = (recent.wy - a * recent.w - v * recent.wt) / recent.w;
        let dt = recent.wt / recent.w - self.wt / self.w;
        // Sxx = den / w: the slope's variance is var / Sxx.
        let se2 = var * (1.0 / recent.w + 1.0 / self.w + dt * dt * self.w / den);
        Some(
            mean * v < 0.0
                && mean.abs() >= RECENT_MIN_OFFSET_DEG
                && mean * mean > RECENT_SIGNIFICANCE * RECENT_SIGNIFICANCE * se2,
        )
    }

    /// The fitted slope in degrees per frame and its standard error, when the weight and the
    /// variance of the frame times reach `min_weight` and `min_spread`.
    fn slope(&self, min_weight: f32, min_spread: f32) -> Option<(f32, f32)> {
        let den = self.den();
        if !(self.w >= min_weight && den >= min_spread * self.w * self.w) {
            return None;
        }
        let (v, residual) = self.fit(den);
        let se = libm::sqrtf(residual / (self.w - 2.0).max(1.0) * self.w / den);
        (v.is_finite() && se.is_finite()).then_some((v, se))
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
            let n = (rng.unit() - 0.5) * 2.0 * noise;
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
        assert_eq!(run(0.0, 4.0, 0.0, 300).velocity(), None);
        let (v, changed) = run(1.0, 4.0, 0.0, 300).velocity().unwrap();
        assert!((v - 1.0).abs() < 0.05 && !changed, "{v} {changed}");
    }

    #[test]
    fn a_talker_who_stops_is_seen_to_stop() {
        let v = 1.44f32;
        let mut fit = run(v, 2.0, 0.0, 300);
        let mut rng = crate::test_rng::Lcg(9);
        // He stops where he is; the reported azimuth drifts on at the old speed meanwhile.
        let (stop, mut reported) = (v * 299.0, v * 299.0);
        let mut seen = None;
        for i in 0..60 {
            reported += v;
            let n = (rng.unit() - 0.5) * 4.0;
            fit.update(v, 0.99, stop + n - reported, 1.0);
            if let Some((slope, true)) = fit.velocity() {
                seen = Some((i, slope));
                break;
            }
        }
        let (frames, slope) = seen.expect("no change seen");
        assert!(frames <= 15 && slope < v, "{frames} frames, {slope}");
        // The short line speaks until the long one has restarted: soon near 0.
        for _ in 0..20 {
            let d = fit.velocity().map_or(0.0, |(s, _)| s);
            reported += d;
            let n = (rng.unit() - 0.5) * 4.0;
            fit.update(d, 0.99, stop + n - reported, 1.0);
        }
        let (slope, _) = fit.velocity().unwrap_or((0.0, false));
        assert!(slope.abs() < 0.3, "{slope}");
    }

    /// Frames from the first until `fit` reports a significant slope for a talker at 1.44°/frame
    /// (90°/s) heard every frame with ±2° of scatter (`None`: not within 100).
    fn frames_to_a_slope(mut fit: MotionFit) -> Option<usize> {
        let mut rng = crate::test_rng::Lcg(11);
        (0..100).find(|&i| {
            let n = (rng.unit() - 0.5) * 4.0;
            let step = if i == 0 { f32::NAN } else { 1.44 };
            fit.update(step, 0.99, n, 1.0);
            fit.velocity().is_some_and(|(v, _)| v > 0.0)
        })
    }

    /// A fast walk is seen early (29 frames here: the least travel binds, not
    /// [`EARLY_MIN_WEIGHT`]), a walk after a stop only on [`MIN_WEIGHT`] (the time spread binds:
    /// about 35 frames).
    #[test]
    fn a_walk_is_seen_soon_and_a_walk_after_a_stop_on_more_evidence() {
        let first = frames_to_a_slope(MotionFit::new()).expect("no slope");
        assert!(first <= 30, "first walk seen after {first} frames");
        let stopped = MotionFit {
            stopped: true,
            ..MotionFit::new()
        };
        let again = frames_to_a_slope(stopped).expect("no slope after the stop");
        assert!(
            again >= first + 3,
            "{again} frames after a stop, {first} before"
        );
    }

    /// A still talker heard in two bursts whose frames lie 6° apart (a room's reflections differ
    /// from syllable to syllable): their line is significant but carries him less than
    /// [`EARLY_MIN_TRAVEL_DEG`], so it gives no early slope (he would drift in the next pause).
    #[test]
    fn a_still_talkers_two_bursts_give_no_early_slope() {
        let mut fit = MotionFit::new();
        let mut rng = crate::test_rng::Lcg(17);
        for i in 0..22 {
            let (offset, b) = match i {
                0..6 => (3.0, 1.0),
                16..22 => (-3.0, 1.0),
                _ => (f32::NAN, 0.0),
            };
            let n = (rng.unit() - 0.5) * 1.0;
            fit.update(if i == 0 { f32::NAN } else { 0.0 }, 0.99, offset + n, b);
        }
        let (v, se) = fit.long.slope(EARLY_MIN_WEIGHT, EARLY_MIN_SPREAD).unwrap();
        assert!(
            v.abs() > SIGNIFICANCE * se,
            "the line is not significant: {v} ± {se}"
        );
        assert_eq!(fit.velocity(), None);
    }

    /// A change of motion starts the long line again without the frames from before it: a talker
    /// who stopped while the reported azimuth ran on is not given a slope from mixed frames.
    #[test]
    fn a_restarted_line_holds_only_frames_from_after_the_change() {
        let mut fit = run(1.44, 2.0, 0.0, 300);
        let mut reported = 0.0f32;
        let mut rng = crate::test_rng::Lcg(13);
        let restarted = (0..40).any(|_| {
            reported += 1.44;
            fit.update(1.44, 0.99, (rng.unit() - 0.5) * 4.0 - reported, 1.0);
            fit.velocity().is_some_and(|(_, changed)| changed) && fit.restarting
        });
        assert!(restarted, "no change seen");
        assert!(
            fit.long.w < 1.5,
            "the long line kept {} of weight",
            fit.long.w
        );
    }

    /// Reliable frames of each burst in [`bursts`] (one burst every ten frames).
    const BURST: usize = 3;
    /// Share of the way the reported azimuth moves to a reliable frame's estimate in [`bursts`].
    const PULL: f32 = 0.5;

    /// A talker at `v` °/frame heard in bursts ([`BURST`] frames of b = 0.8 every ten) with a
    /// uniform scatter of ±`noise`, who stops after `walk` frames; the reported azimuth drifts by
    /// the fit's velocity and moves [`PULL`] of the way to each reliable frame's estimate. Returns
    /// the frames after the stop at which the fit first reported rest, and the drift of the last
    /// ten frames.
    fn bursts(v: f32, noise: f32, walk: usize, frames: usize) -> (Option<usize>, f32) {
        let mut fit = MotionFit::new();
        let mut rng = crate::test_rng::Lcg(3);
        let (mut reported, mut drift) = (0.0f32, 0.0f32);
        let mut rest = None;
        let mut tail = 0.0;
        for i in 0..frames {
            let talker = v * i.min(walk) as f32;
            let before = reported;
            reported += drift;
            let heard = i % 10 < BURST;
            let estimate = talker + (rng.unit() - 0.5) * 2.0 * noise;
            if heard {
                reported += PULL * (estimate - reported);
            }
            let b = if heard { 0.8 } else { 0.0 };
            fit.update(
                if i == 0 { f32::NAN } else { reported - before },
                0.99,
                estimate - reported,
                b,
            );
            drift = match fit.velocity() {
                Some((d, changed)) => {
                    if changed && d == 0.0 && i >= walk && rest.is_none() {
                        rest = Some(i - walk);
                    }
                    d
                }
                None => 0.0,
            };
            if i + 10 >= frames {
                tail += drift;
            }
        }
        (rest, tail)
    }

    /// A talker at `v` °/frame who stops after `walk` frames ([`bursts`], 400 frames, ±3°) is
    /// seen at rest within `within` frames of the stop and no longer drifts at the end.
    fn seen_to_stop(v: f32, walk: usize, within: usize) {
        let (rest, tail) = bursts(v, 3.0, walk, 400);
        let rest = rest.expect("never seen at rest");
        assert!(rest <= within, "seen at rest {rest} frames after the stop");
        assert!(
            tail.abs() < 2.0,
            "still drifting {tail}° in the last ten frames"
        );
    }

    #[test]
    fn a_talker_who_stops_between_bursts_is_seen_to_stop() {
        seen_to_stop(1.44, 300, 40);
    }

    /// A talker at 0.8°/frame (50°/s) who stops after three seconds: the long line still holds
    /// his walk for a second and more and, tested against itself, bends towards his frames at
    /// rest; the line as it was a checkpoint ago does not.
    #[test]
    fn a_slower_talker_who_stops_after_a_short_walk_is_seen_to_stop() {
        seen_to_stop(0.8, 190, 60);
    }

    #[test]
    fn a_talker_who_walks_on_between_bursts_keeps_his_slope() {
        for noise in [3.0f32, 8.0] {
            let (rest, tail) = bursts(1.44, noise, 600, 600);
            assert_eq!(rest, None, "noise {noise}");
            assert!(
                (tail - 14.4).abs() < 2.0,
                "noise {noise}: drift {tail}° in ten frames"
            );
        }
    }

    #[test]
    fn a_pause_keeps_the_slope() {
        let mut fit = run(1.0, 2.0, 0.0, 200);
        let before = fit.slope().unwrap().0;
        // Forty silent frames in which the reported azimuth drifts on at the fitted speed.
        for _ in 0..40 {
            fit.update(before, 0.99, f32::NAN, 0.0);
            assert_eq!(fit.velocity().map(|(_, changed)| changed), Some(false));
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
        let empty = LineSums::new();
        assert_eq!([fit.long, fit.short, fit.earlier, fit.pending], [empty; 4]);
    }
}
