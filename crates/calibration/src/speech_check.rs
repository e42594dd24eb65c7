//! The talker's own sound as a check of the omni parts' correction.
//!
//! The background cannot tell a capsule's omni-part error from a directional noise source that
//! runs from power-on: both make the cardioids' zero-mean part correlate with the omni (module
//! documentation of [`crate::capsule_calibration`]). Speech can. Write a peak's features y_m
//! (active ratios) as the plane vector v = Σ_m y_m·(cos φ_m, sin φ_m); for one plane wave from θ
//! through ideal capsules v = ¾·(cos θ, sin θ), and reverberation and diffuse noise pull it
//! towards the origin. An omni-part error e of the capsules adds e to the vector of every sound,
//! the talker's and the background's alike; a noise source adds its own point only in proportion
//! to its share of the frame.
//!
//! So each speech frame's mean vector without the omni correction, v0, lies near the line
//! e + t·(cos θ, sin θ) of the tracked talker's direction θ, the distance t varying from frame to
//! frame (onsets reach far, reverberant tails stay near e), pulled towards the background's point
//! by the frame's background share σ (the bands' floors over their powers). Per sector of θ the
//! frames' across-track components q are fitted as q = c + b₁·p + b₂·σ (p the along-track
//! component): the intercept c is the talker's own offset across his direction at no distance and
//! no background — the part of an omni error that turns his direction.
//!
//! Only frames whose own estimate lies within 60° of the track count (the locator's caller
//! checks): a talker who has moved, before the track has followed him, is on another line. Where
//! p varies only with σ (no reverberation: p = ¾·(1 − σ) in an anechoic room), the two
//! regressors are one and the fit is made on p alone.
//!
//! The background's correction shifts every v by s. A real capsule error has c ≈ −s⊥ (the
//! talker's sound needs the correction); a source's intensity taken for one has c ≈ 0. The check
//! fits the factor κ of s that makes the sectors' offsets vanish and, where the fit is clearly
//! below 1, the self-calibration applies κ·s: on the validation's imperfect arrays (whole scenes)
//! the fit lies at 0.7–1.3, beside a loudspeaker through matched capsules at −0.1–0.5.
//!
//! The offsets also measure the omni error itself where the background could not: a noise
//! source that runs from power-on holds the background's estimate (it is not diffuse), so there
//! is no shift to judge, and an imperfect array stays uncorrected. Each sector's offset is the
//! error's component across that sector, c_k ≈ e·n_k, so a talker heard from two places or more
//! gives both components: [`SpeechCheck::verdict`] fits the shift d that the sectors still
//! ask for once the background's (scaled) shift is applied, and it is applied on top. It is held
//! to what four sectors or more agree on (a second talker speaking at the same time gives offsets
//! no one shift fits; two or three sectors fit a room's offsets too) and to what clears the
//! offsets a room gives an ideal array. Measured (`scripts/validate`, full run, docs/history.md):
//! broadband sources 6–22 dB below the talker through imperfect arrays, last 40 s, +10 to +22
//! points of ACC10; one scene beside a fan reads worse, as it does from its own stored estimate.
//! The shift is saved with the estimate (`CapsuleEstimate::talker_shift`): until four sectors are
//! heard again the verdict gives none, and a restored shift stays applied.
//!
//! State: six sectors of eleven sums and a frame's three (≈ 0.3 KB). Work per hop: a plane vector
//! and three additions per peak; per speech frame one sector update; every 16 speech frames a
//! 2 × 2 solve per sector and one for the residual shift.

use crate::trig::sin_cos;

/// Number of sectors of the talker's direction with their own regression.
pub const SECTORS: usize = 6;

/// Speech frames a sector needs before its offset counts.
const MIN_SECTOR_FRAMES: f32 = 50.0;

/// Least 1 − r² of p and σ (r their correlation) for the fit with σ: where the talker's distance
/// along his line varies only with the background share (no reverberation: an anechoic room, or
/// a talker near the array), the two regressors are one and the intercept is not determined; the
/// fit is then made on p alone.
const MIN_INDEPENDENCE: f32 = 0.2;

/// Weight (speech frames of the shift's size) of the prior κ = 1.
const PRIOR_FRAMES: f32 = 50.0;

/// Size of the offsets the room's reflections give the sectors without any capsule error
/// (plane-vector units): a shift not clearly larger is left as it is.
const ROOM_OFFSET: f32 = 0.02;

/// A fitted κ at or above this keeps the background's correction whole.
const KEEP_ABOVE: f32 = 0.6;

/// A fitted κ at or below this is applied as it is.
const WITHDRAW_BELOW: f32 = 0.45;

/// One sector's forgetting sums of its frames' (p, q, σ) and across-track direction n: Σ1, Σp,
/// Σq, Σσ, Σp², Σpσ, Σσ², Σpq, Σσq, Σn_x, Σn_y, with p and q the frame's mean plane vector along
/// and across the talker's direction θ, n = (−sin θ, cos θ) and σ the frame's background share.
type SectorSums = [f32; 11];

/// The across-track offset c of the talker's own sound in a sector: the intercept of the
/// least-squares fit q = c + b₁·p + b₂·σ (at p = 0 and without background), `None` below
/// [`MIN_SECTOR_FRAMES`] or without a spread of p.
#[inline(never)]
fn offset(t: &SectorSums) -> Option<f32> {
    let [n, p, q, g, pp, pg, gg, pq, gq, _, _] = *t;
    if !(n >= MIN_SECTOR_FRAMES) {
        return None;
    }
    let inv = 1.0 / n;
    let (mp, mq, mg) = (p * inv, q * inv, g * inv);
    let a11 = pp * inv - mp * mp;
    let a12 = pg * inv - mp * mg;
    let a22 = gg * inv - mg * mg;
    let r1 = pq * inv - mp * mq;
    let r2 = gq * inv - mg * mq;
    if !(a11 > 1e-6) {
        return None;
    }
    let det = a11 * a22 - a12 * a12;
    // Without a spread of σ (a quiet background) the fit on p alone.
    let (b1, b2) = if det > MIN_INDEPENDENCE * a11 * a22 && a22 > 1e-9 {
        ((r1 * a22 - r2 * a12) / det, (r2 * a11 - r1 * a12) / det)
    } else {
        (r1 / a11, 0.0)
    };
    let c = mq - b1 * mp - b2 * mg;
    c.is_finite().then_some(c)
}

/// The check's state: a frame's sums and the sectors' (≈ 0.2 KB).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpeechCheck {
    /// This frame's Σ1, Σv0x, Σv0y (v0: a peak's vector without the omni correction).
    frame: [f32; 3],
    sectors: [SectorSums; SECTORS],
}

/// Forgetting factor of a sector's sums per speech frame of its own (memory ≈ 50 s of speech).
const KEEP: f32 = 1.0 - 1.0 / 3000.0;

impl SpeechCheck {
    /// An empty check.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            frame: [0.0; 3],
            sectors: [[0.0; 11]; SECTORS],
        }
    }

    /// Forgets everything heard.
    pub fn clear(&mut self) {
        self.frame = [0.0; 3];
        for t in &mut self.sectors {
            *t = [0.0; 11];
        }
    }

    /// Adds a peak whose plane vector without the omni correction is `v`.
    #[inline]
    pub fn add_peak(&mut self, v: (f32, f32)) {
        if v.0.is_finite() && v.1.is_finite() {
            self.frame[0] += 1.0;
            self.frame[1] += v.0;
            self.frame[2] += v.1;
        }
    }

    /// Ends a frame. When `talker_deg` is a tracked talker's direction and the frame holds
    /// speech (background share `share` in [0, 1)), the frame's mean vector joins the talker's
    /// sector; returns whether it did.
    #[inline(never)]
    pub fn end_frame(&mut self, talker_deg: Option<f32>, share: f32) -> bool {
        let [n, sx, sy] = self.frame;
        self.frame = [0.0; 3];
        let Some(deg) = talker_deg else {
            return false;
        };
        if !(n > 0.0 && deg.is_finite() && (0.0..1.0).contains(&share)) {
            return false;
        }
        let (vx, vy) = (sx / n, sy / n);
        let (s, c) = sin_cos(deg.to_radians());
        let p = vx * c + vy * s;
        let q = -vx * s + vy * c;
        let g = share;
        let add = [1.0, p, q, g, p * p, p * g, g * g, p * q, g * q, -s, c];
        let t = &mut self.sectors[sector_of(deg)];
        for (v, a) in t.iter_mut().zip(add) {
            *v = KEEP * *v + a;
        }
        true
    }

    /// The talker's verdict on the omni correction whose shift at factor 1 is `shift` (plane
    /// vector): the factor κ of it that his frames support, and the shift d they ask for beyond
    /// κ·`shift`.
    ///
    /// κ in [0, 1]: the sectors' offsets c are what the omni error leaves across the talker, so
    /// with the shift's component s⊥ across each sector, κ is fitted to c ≈ −κ·s⊥ by least
    /// squares, shrunk towards 1 (the background's estimate) by a prior of 50 frames of the
    /// shift's size and one of 0.02 per frame. A real capsule error gives about 1 (0.7–1.3 on the
    /// validation's imperfect arrays, whole scenes), a noise source's intensity learned as one 0.5
    /// and less: the fit is applied only below 0.6, fully from 0.45 down.
    ///
    /// d: the least-squares vector with c_k + (κ·s + d)·n_k ≈ 0 over the sectors k (n_k a
    /// sector's mean across-track direction, each weighing in full from 100 speech frames on),
    /// with a ridge of 0.1 sectors toward 0, shrunk by the room's offsets (0.04, positive-part
    /// James–Stein); `None` (no verdict: the shift applied stays) before four sectors' worth
    /// are heard, and 0 unless they agree on it (rms offset left at most 0.05).
    #[inline(never)]
    #[must_use]
    pub fn verdict(&self, shift: (f32, f32)) -> (f32, Option<(f32, f32)>) {
        let mut num = 0.0f32;
        let mut den = 0.0f32;
        let mut frames = 0.0f32;
        // The sectors' weighted sums for d: Σw, Σw·n·nᵀ (xx, xy, yy), Σw·c·n, Σw·c².
        let (mut weight, mut axx, mut axy, mut ayy) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        let (mut gx, mut gy, mut cc) = (0.0f32, 0.0f32, 0.0f32);
        for t in &self.sectors {
            let Some(offset) = offset(t) else {
                continue;
            };
            let n = t[0];
            let (nx, ny) = (t[9] / n, t[10] / n);
            // The shift across the sector's frames, on average.
            let across = shift.0 * nx + shift.1 * ny;
            // The residual at κ = 1, c + s⊥, against s⊥.
            num += n * (offset + across) * across;
            den += n * across * across;
            frames += n;
            let w = (n / FULL_SECTOR_FRAMES).min(1.0);
            weight += w;
            axx += w * nx * nx;
            axy += w * nx * ny;
            ayy += w * ny * ny;
            gx += w * offset * nx;
            gy += w * offset * ny;
            cc += w * offset * offset;
        }
        let size = shift.0 * shift.0 + shift.1 * shift.1;
        let den = den + PRIOR_FRAMES * size + ROOM_OFFSET * ROOM_OFFSET * frames;
        let fit = if den > 0.0 && num.is_finite() {
            (1.0 - num / den).clamp(0.0, 1.0)
        } else {
            1.0
        };
        let kappa = if fit >= KEEP_ABOVE {
            1.0
        } else if fit <= WITHDRAW_BELOW {
            fit
        } else {
            let u = (fit - WITHDRAW_BELOW) / (KEEP_ABOVE - WITHDRAW_BELOW);
            WITHDRAW_BELOW + u * (1.0 - WITHDRAW_BELOW)
        };
        // The offsets left by the applied shift κ·s: r_k = c_k + κ·s·n_k, so Σw·r·n = g + κ·A·s
        // and Σw·r² = Σw·c² + 2κ·s·g + κ²·sᵀA·s (A = Σw·n·nᵀ, g = Σw·c·n).
        let (sx, sy) = (kappa * shift.0, kappa * shift.1);
        let (asx, asy) = (axx * sx + axy * sy, axy * sx + ayy * sy);
        let (rx, ry) = (gx + asx, gy + asy);
        let rr = cc + 2.0 * (sx * gx + sy * gy) + sx * asx + sy * asy;
        // d solves (A + ridge)·d = −Σw·r·n.
        let (bxx, byy) = (axx + RIDGE, ayy + RIDGE);
        let inv = 1.0 / (bxx * byy - axy * axy);
        let d = ((axy * ry - byy * rx) * inv, (axy * rx - bxx * ry) * inv);
        // What the fit leaves in the sectors, Σw·(r + d·n)², is the room's offsets; a second
        // voice heard at the same time leaves far more, and no one shift fits it.
        let misfit = rr
            + 2.0 * (d.0 * rx + d.1 * ry)
            + d.0 * (axx * d.0 + axy * d.1)
            + d.1 * (axy * d.0 + ayy * d.1);
        let sq = d.0 * d.0 + d.1 * d.1;
        // Two sectors fit any shift exactly, three nearly: the check needs a fourth.
        if !(weight >= MIN_SECTORS) {
            return (kappa, None);
        }
        if !(misfit <= MAX_MISFIT * MAX_MISFIT * weight) || !(sq > 0.0) || !sq.is_finite() {
            return (kappa, Some((0.0, 0.0)));
        }
        let f = (1.0 - RESIDUAL_NOISE * RESIDUAL_NOISE / sq).max(0.0);
        (kappa, Some((f * d.0, f * d.1)))
    }
}

/// Ridge of [`SpeechCheck::verdict`]'s fit, in fully heard sectors: a direction no sector
/// crosses stays unshifted.
const RIDGE: f32 = 0.1;

/// Speech frames (about 1.6 s of speech) at which a sector weighs fully in
/// [`SpeechCheck::verdict`].
const FULL_SECTOR_FRAMES: f32 = 100.0;

/// Size of the residual shift the room's reflections give an ideal array (plane-vector units):
/// [`SpeechCheck::verdict`] applies only what exceeds it (positive-part James–Stein). Measured on
/// the validation scenes: a stored estimate leaves the sectors asking for about 0.02, capsule
/// errors a source from power-on held ask for 0.03–0.15; 0.03 cost ideal arrays beside a source,
/// 0.06 and more left much of the imperfect arrays' gain (docs/history.md).
const RESIDUAL_NOISE: f32 = 0.04;

/// Fully heard sectors (their weights' sum) [`SpeechCheck::verdict`] needs: two fit any shift, and
/// with three the room's offsets of an ideal array still fitted one (another simulator's long
/// scenes, docs/history.md); from the fourth on the sectors' agreement is a check.
const MIN_SECTORS: f32 = 4.0;

/// Largest rms offset the fitted shift may leave in the sectors: capsule errors leave 0.01–0.03,
/// two talkers heard at the same time 0.07–0.27.
const MAX_MISFIT: f32 = 0.05;

/// The sector of direction `deg` (degrees, any turn).
fn sector_of(deg: f32) -> usize {
    let x = (deg + 180.0) * (SECTORS as f32 / 360.0);
    let k = libm::floorf(x) as i32;
    k.rem_euclid(SECTORS as i32) as usize
}

impl Default for SpeechCheck {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_rng::Lcg;

    /// Feeds `frames` speech frames of a talker at `deg` whose mean plane vector (without the
    /// omni correction) is `centre + t·u(deg)` mixed with a background point `background` by the
    /// frame's share σ, t and σ drawn per frame, plus a little noise.
    fn feed(
        check: &mut SpeechCheck,
        deg: f32,
        centre: (f32, f32),
        background: (f32, f32),
        frames: usize,
        rng: &mut Lcg,
    ) {
        let (s, c) = sin_cos(deg.to_radians());
        for _ in 0..frames {
            let t = 0.1 + 0.6 * rng.unit();
            let share = 0.4 * rng.unit();
            let noise = (0.02 * (rng.unit() - 0.5), 0.02 * (rng.unit() - 0.5));
            let talker = (centre.0 + t * c, centre.1 + t * s);
            let v = (
                (1.0 - share) * talker.0 + share * background.0 + noise.0,
                (1.0 - share) * talker.1 + share * background.1 + noise.1,
            );
            check.add_peak(v);
            assert!(check.end_frame(Some(deg), share));
        }
    }

    #[test]
    fn a_capsule_error_is_the_offset_of_the_talkers_frames_and_keeps_its_correction() {
        // An omni error e moves the talker's sound and the background alike: the background's
        // correction shifts by −e, and the talker's frames agree.
        let e = (0.12, -0.05);
        let mut check = SpeechCheck::new();
        let mut rng = Lcg(3);
        for deg in [30.0, 150.0, -100.0] {
            feed(&mut check, deg, e, e, 300, &mut rng);
            let k = sector_of(deg);
            let (s, c) = sin_cos(deg.to_radians());
            let across = -e.0 * s + e.1 * c;
            let got = offset(&check.sectors[k]).unwrap();
            assert!(
                (got - across).abs() < 0.01,
                "{deg}°: {got} against {across}"
            );
        }
        assert_eq!(check.verdict((-e.0, -e.1)).0, 1.0);
    }

    #[test]
    fn a_sources_intensity_taken_for_a_capsule_error_is_withdrawn() {
        // Ideal capsules beside a source whose intensity the background took for an omni error:
        // the talker's own sound has no offset, the background's point does (the σ term of the
        // fit takes it), and the correction's shift is not supported.
        let source = (-0.2, 0.1);
        let mut check = SpeechCheck::new();
        let mut rng = Lcg(5);
        feed(&mut check, 40.0, (0.0, 0.0), source, 400, &mut rng);
        let got = offset(&check.sectors[sector_of(40.0)]).unwrap();
        assert!(got.abs() < 0.01, "offset {got}");
        let kappa = check.verdict((-source.0, -source.1)).0;
        assert!(kappa < 0.2, "κ {kappa}");
    }

    #[test]
    fn a_capsule_error_the_background_did_not_learn_is_measured_from_the_talkers_places() {
        // A source from power-on held the background's estimate: nothing is applied, and the
        // talker's sectors give the whole error (less the room's share), heard from six places.
        let e = (0.12, -0.05);
        let mut check = SpeechCheck::new();
        let mut rng = Lcg(11);
        let places = [-150.0, -90.0, -30.0, 30.0, 90.0, 150.0];
        for deg in places {
            feed(&mut check, deg, e, e, 300, &mut rng);
        }
        let d = check.verdict((0.0, 0.0)).1.unwrap();
        // Six places 60° apart weigh 3 in every direction, 3 + ridge with it: the fit is g·e,
        // then shrunk by the room's share.
        let g = 3.0 / (3.0 + RIDGE);
        let f = g * (1.0 - RESIDUAL_NOISE * RESIDUAL_NOISE / (g * g * (e.0 * e.0 + e.1 * e.1)));
        assert!(
            (d.0 + f * e.0).abs() < 0.01 && (d.1 + f * e.1).abs() < 0.01,
            "{d:?} against {:?}",
            (-f * e.0, -f * e.1)
        );
        // Once the background's correction is in, nothing is left to add.
        let d = check.verdict((-e.0, -e.1)).1;
        assert_eq!(d, Some((0.0, 0.0)));
    }

    #[test]
    fn an_ideal_array_or_offsets_no_one_shift_fits_get_no_residual_shift() {
        let mut rng = Lcg(13);
        let mut ideal = SpeechCheck::new();
        for deg in [-150.0, -90.0, -30.0, 30.0, 90.0, 150.0] {
            feed(&mut ideal, deg, (0.0, 0.0), (0.0, 0.0), 300, &mut rng);
        }
        assert_eq!(ideal.verdict((0.0, 0.0)).1, Some((0.0, 0.0)));
        // Offsets as a second voice heard at the same time leaves them, which no one shift fits:
        // opposite places offset the same way.
        let mut two = SpeechCheck::new();
        for (deg, centre) in [
            (0.0, (0.0, 0.2)),
            (180.0, (0.0, -0.2)),
            (90.0, (0.0, 0.0)),
            (-90.0, (0.0, 0.0)),
        ] {
            feed(&mut two, deg, centre, centre, 300, &mut rng);
        }
        assert_eq!(two.verdict((0.0, 0.0)).1, Some((0.0, 0.0)));
        // Three places fit nearly any shift (a room's offsets too): nothing to check it by, and
        // no verdict (the shift applied stays).
        let mut three = SpeechCheck::new();
        for deg in [-150.0, -30.0, 90.0] {
            feed(&mut three, deg, (0.15, 0.1), (0.15, 0.1), 300, &mut rng);
        }
        assert_eq!(three.verdict((0.0, 0.0)).1, None);
    }

    #[test]
    fn without_evidence_or_a_shift_the_correction_stays() {
        let mut check = SpeechCheck::new();
        assert_eq!(check.verdict((0.2, 0.0)).0, 1.0);
        let mut rng = Lcg(7);
        feed(&mut check, 0.0, (0.0, 0.0), (0.0, 0.0), 20, &mut rng);
        assert_eq!(check.verdict((0.2, 0.0)).0, 1.0, "too few frames");
        feed(&mut check, 0.0, (0.0, 0.0), (0.0, 0.0), 400, &mut rng);
        assert_eq!(check.verdict((0.0, 0.0)).0, 1.0, "no shift");
        // A frame without a talker, speech or a usable share is not taken.
        check.add_peak((0.3, 0.0));
        assert!(!check.end_frame(None, 0.1));
        assert!(!check.end_frame(Some(0.0), f32::NAN));
        check.add_peak((f32::NAN, 0.0));
        assert!(!check.end_frame(Some(0.0), 0.1));
    }
}
