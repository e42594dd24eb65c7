//! Several talkers at once: up to [`MAX_TRACKS`] talker tracks, each with a persistent ID, an
//! azimuth, a confidence and an "active" state (this talker is speaking in this frame).
//!
//! The single-azimuth estimate (the grid tracker on the frame's similarity curve) follows one
//! talker: a frame's mean curve has one maximum, between two talkers who speak at once. Speech is
//! sparse in frequency, though: most spectral peaks of a frame are dominated by one talker. So this
//! stage works on the *peaks*:
//!
//! 1. **per-peak directions.** Each peak's three cardioid features y_m (magnitude or active ratios)
//!    give a direction vector v = Σ_m y_m·(cos φ_m, sin φ_m) (the ½ of the omni part cancels over
//!    the three looks). For one plane wave |v| = ¾, for diffuse sound |v| is small, so
//!    d = min(|v|/¾, 1) is the peak's *directness*; the peak counts with its weight (the
//!    direct-sound weight of the locator) times d². No reference table and no trigonometry per
//!    peak: only the ideal array model (a measured table's deviations are not used here).
//! 2. **association.** A peak goes to the live track nearest in direction within
//!    [`MultiTrack::gate_deg`] (an active track counts [`MultiTrack::active_preference_deg`]
//!    nearer, so a talker who walks past a silent one keeps his ID). A track's frame evidence E is
//!    its share of the frame's peak weight, times the frame gate (the noise-floor gate: speech
//!    present at all).
//! 3. **update.** The track's activity is a one-pole average of E; the track is active while the
//!    activity is above [`MultiTrack::active_on`] (hysteresis down to [`MultiTrack::active_off`]).
//!    [`MultiTrack::relative_on`] of the most active track's recent activity (its maximum,
//!    decaying by [`MultiTrack::recent_pole`]: a talker's reverberation outlasts his activity; a
//!    larger share, [`MultiTrack::unheard_relative_on`], for a track that has taken no large share
//!    of a frame's peaks lately: fed only by another talker's reverberation) and
//!    [`MultiTrack::own_off`] of its own peak activity are further thresholds: the reverberation of
//!    one talker feeds the other tracks a fraction of his evidence, and a fixed hangover after an
//!    utterance should not depend on how reverberant the room is. A track whose evidence falls
//!    and whose activity is below [`MultiTrack::tail_off`] of its peak ends its activity even
//!    when it is the loudest (the end of the last talker's utterance).
//!    A track is a *talker* only once its activity has reached [`MultiTrack::talker_level`]:
//!    before that it is never active. Speech gives its direction most of the frame's peaks now and
//!    then (the nuclei of its syllables), a stationary source (a fan, a projector, a vent, a hum)
//!    holds a small share of them all the time and its activity stays low, so its track is tracked
//!    (the next talker near it is not born on it) but never reported active.
//!    A track whose last frame of strong evidence ([`MultiTrack::hold_evidence`]) came while
//!    another track was active stays active for [`MultiTrack::overlap_hold_frames`] frames after
//!    that frame, whatever its activity: when two talk at once their shares of the peaks swing
//!    from frame to frame, and the quieter one's activity would otherwise drop out between them.
//!    A talker who speaks alone ends as before (the hold would only lengthen the hangover after
//!    his utterance).
//!    Its direction moves towards the mean direction of its peaks by
//!    [`MultiTrack::azimuth_gain`]·E, and, when it is the most active track and the single-azimuth
//!    estimate lies within the gate, towards that estimate by [`MultiTrack::anchor_gain`]·b (the
//!    single estimate is the more accurate one in a room).
//! 4. **births.** Peaks no track takes feed [`MAX_CANDIDATES`] leaky direction clusters. A cluster
//!    whose mass (decaying by [`MultiTrack::candidate_pole`] per frame) reaches
//!    [`MultiTrack::birth_mass`] — a direction heard consistently — becomes a track with a new ID,
//!    if it is at least [`MultiTrack::min_separation_deg`] from every live track.
//!    The single-azimuth estimate feeds them too, by [`MultiTrack::estimate_birth_gain`]·b, when
//!    it lies more than [`MultiTrack::estimate_birth_deg`] from every live track: in a room a far
//!    talker's peaks can be too weak or scattered to make a track on their own.
//! 5. **deaths.** A track inactive for [`MultiTrack::death_frames`] frames ends; a birth with no free
//!    slot takes the slot of the track silent longest, if it has been silent for at least
//!    [`MultiTrack::replace_frames`].
//!
//! Work per frame is bounded: O(peaks × (tracks + candidates)) dot products, three `atan2` and at
//! most one `sin`/`cos` pair. No heap; no input can panic (non-finite features are skipped).

use crate::bformat::plane_vector;
use crate::fast_math::sqrtf;
use crate::similarity::PeakFeature;

/// Largest number of simultaneous talker tracks.
pub const MAX_TRACKS: usize = 3;
/// Number of birth candidates (direction clusters of the peaks no track takes).
pub const MAX_CANDIDATES: usize = 4;

/// |v| of a single plane wave's peak: ¾ (see the module documentation).
const PLANE_WAVE_LENGTH: f32 = 0.75;

/// Settings of the multi-talker tracker (plain values; frames are analysis hops).
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct MultiTrack {
    /// The stage runs (similarity method only).
    pub enabled: bool,
    /// Association gate: a peak further than this from every track is a birth candidate, degrees.
    pub gate_deg: f32,
    /// An active track counts this much nearer than it is when peaks are associated, degrees.
    pub active_preference_deg: f32,
    /// Pole of the one-pole average of the frame evidence (the activity), per frame.
    pub activity_pole: f32,
    /// Activity at which a track becomes active.
    pub active_on: f32,
    /// Activity below which an active track becomes inactive (≤ `active_on`).
    pub active_off: f32,
    /// Share of the most active track's activity a track that was heard lately (see
    /// [`MultiTrack::heard_evidence`]) needs to become active (and `active_off / active_on` of
    /// that share to stay active): the reverberation and the scattered peaks of one talker give
    /// the silent talkers' tracks some evidence too, a fraction of his (measured: 0.4 cost two
    /// talkers speaking at once, whose shares of the peaks swing, 1–2 points of recall; 0.3 let
    /// the reverberation of three-way conversations activate silent tracks: precision −1.5 points).
    pub relative_on: f32,
    /// Share of the most active track's activity a track that was *not* heard lately needs to
    /// become active (at least `relative_on`). A silent talker's track is fed by the other
    /// talker's reverberation and scattered peaks, a steady small share of every frame; a talker
    /// who speaks takes a large share of some frames (his syllables' nuclei), even when he speaks
    /// at once with a louder one. Measured on the validation's conversations in rooms (a relative
    /// turn-on of 0.55 for every track lifted the span precision of turns beside a noise source
    /// from 89.0 to 94.3 % but cost two talkers at once in the multi-talker rooms 4.5 points of
    /// recall; with the turn-on of 0.35 kept for tracks heard lately, see docs/multi-talker.md).
    pub unheard_relative_on: f32,
    /// Frame evidence (a share of the frame's peak weight) that counts as hearing a track's
    /// talker for [`MultiTrack::unheard_relative_on`] (measured: 0.25 cost two talkers at once
    /// in rooms 1.2 points of recall, 0.2 half a point; 0.15 gave back most of the precision).
    pub heard_evidence: f32,
    /// Frames after a frame of `heard_evidence` during which a track counts as heard lately
    /// (measured: 20 cost two talkers at once in rooms 1.9 points of recall, 60 gave back a third
    /// of the precision).
    pub heard_frames: u32,
    /// Share of the track's own peak activity (a maximum that decays by `peak_pole` per frame)
    /// below which a track whose activity is under the turn-on threshold becomes inactive
    /// (reverberation lowers every activity, so a fixed `active_off` would hold a quiet talker's
    /// track longer in a reverberant room).
    pub own_off: f32,
    /// Share of the track's own peak activity below which a track whose evidence is falling
    /// becomes inactive, loudest or not: the release after the last talker's utterance is then
    /// about ln(share)/ln(`activity_pole`) frames instead of the time its activity takes to fall
    /// to `active_on`. The release is quick (0.4: 9 frames) because [`crate::track_spans`]
    /// bridges the pauses inside an utterance afterwards; without it (`span_gap_frames = 0`)
    /// 0.15 keeps them active (measured on the validation's conversations: with 0.15 and no span
    /// decision, span precision 90.8 %, most of the false frames in the 0.3 s after an utterance).
    pub tail_off: f32,
    /// Pole of the decay of a track's peak activity, per frame.
    pub peak_pole: f32,
    /// Pole of the decay of a track's *recent* activity (its activity's maximum, decaying by this
    /// per frame), per frame: the shares `relative_on` and `unheard_relative_on` are shares of
    /// the largest recent activity, not of the largest activity now (0: of the activity now).
    /// After a talker's last word his activity falls within a few frames, but his reverberation
    /// and scattered peaks go on feeding the other tracks for the room's decay time: against his
    /// activity now they crossed the relative turn-on and the next talker's track went active
    /// before he spoke. Measured on the validation's conversations: 0.98 (a quarter of a second
    /// to fall to 60 %) lifted the span precision of turns beside a noise source from 91.5 to
    /// 96.3 % and of turns in measured rooms from 98.1 to 99.5 %, at 1–2 points of recall of two
    /// talkers at once in rooms; 0.95 gave half the precision (docs/history.md).
    pub recent_pole: f32,
    /// Gain of the move towards the mean direction of the track's peaks, per unit evidence.
    pub azimuth_gain: f32,
    /// Gain of the move of the most active track towards the single-azimuth estimate, per unit of
    /// its reliability b (0: the tracks use their peaks only).
    pub anchor_gain: f32,
    /// Pole of the birth candidates' mass, per frame: a direction becomes a track once the share of
    /// the frame's peak weight no track takes from it stays above (1 − pole)·`birth_mass` for some
    /// 1/(1 − pole) frames (measured: 0.9 left quiet or scattered talkers of three-way
    /// conversations without a track; 0.95 lowers the precision: more tracks of no talker).
    pub candidate_pole: f32,
    /// Candidate mass (sum of decayed frame shares) that makes a new track.
    pub birth_mass: f32,
    /// Smallest distance of a new track from every live track, degrees.
    pub min_separation_deg: f32,
    /// Birth mass the single-azimuth estimate adds per frame, per unit of its reliability b and of
    /// the frame gate, when it lies more than [`MultiTrack::estimate_birth_deg`] from every live
    /// track (0: births from the peaks only). A talker whose peaks are weak or scattered (far
    /// away in a reverberant room) is then born too: measured, a talker at 2 m whose track was
    /// born only after 18 s of turns.
    pub estimate_birth_gain: f32,
    /// Distance from every live track beyond which the single-azimuth estimate feeds the births,
    /// degrees (measured: 45° let a moving talker's estimate, running ahead of his track, start
    /// a second track of him more often than 60°).
    pub estimate_birth_deg: f32,
    /// Activity a track must have reached once before it may be active: a stationary noise
    /// source's track stays below it (measured on the validation's multi-talker scenes with a fan,
    /// projector, vent or hum: tracks on the source peak at 0.07–0.16, talkers' tracks at 0.14 and
    /// more, most above 0.2; 0.1 left no active track on a noise source in the validation's
    /// scenes, 0.125 cost a point of recall in rooms). 0 switches it off.
    pub talker_level: f32,
    /// Frame evidence that counts as strong (a syllable's nucleus) for the overlap hold.
    pub hold_evidence: f32,
    /// Frames a track whose last strong frame came while another track was active stays active
    /// after it (0: no hold). Measured: 20 (0.32 s) raised the recall of two talkers speaking at
    /// once from 87 to 97–98 % on the validation's scenes, 40 cost turn-taking precision.
    pub overlap_hold_frames: u32,
    /// Pauses of at most this many frames between two active frames of a track are reported
    /// active, and the tracks are reported this many frames late, when the frames after a pause
    /// have shown whether the talker went on ([`crate::track_spans`]; at most
    /// [`crate::track_spans::MAX_SPAN_FRAMES`]; 0: the tracker's own activity, without delay).
    pub span_gap_frames: u32,
    /// Bursts of activity shorter than this (pauses closed) are not reported active (at most
    /// `span_gap_frames`; 0 or 1: every burst is).
    pub span_min_frames: u32,
    /// Frames by which the tracker's activity lags the talker (its smoothing,
    /// [`MultiTrack::activity_pole`], rises after his first word and falls after his last): the
    /// span decision gives each frame the activity decided this many frames later, and so reports
    /// the tracks `span_gap_frames` + `span_lead_frames` frames late (with `span_gap_frames` > 0).
    pub span_lead_frames: u32,
    /// Inactive frames after which a track ends.
    pub death_frames: u32,
    /// Inactive frames after which a track's slot may be taken by a new track when none is free.
    pub replace_frames: u32,
}

impl MultiTrack {
    /// The stage switched off (the product default: it costs more than the single-talker budget
    /// allows to spend on a feature few installations need).
    pub const OFF: Self = Self {
        enabled: false,
        ..Self::DEFAULT
    };

    /// The settings measured on reverberant multi-talker scenes (docs/multi-talker.md), switched on.
    pub const DEFAULT: Self = Self {
        enabled: true,
        gate_deg: 40.0,
        active_preference_deg: 20.0,
        activity_pole: 0.9,
        active_on: 0.05,
        active_off: 0.03,
        relative_on: 0.35,
        unheard_relative_on: 0.55,
        heard_evidence: 0.2,
        heard_frames: 40,
        own_off: 0.4,
        tail_off: 0.4,
        peak_pole: 0.998,
        recent_pole: 0.98,
        azimuth_gain: 0.3,
        anchor_gain: 0.3,
        candidate_pole: 0.92,
        birth_mass: 1.0,
        min_separation_deg: 45.0,
        estimate_birth_gain: 0.1,
        estimate_birth_deg: 60.0,
        talker_level: 0.1,
        hold_evidence: 0.3,
        overlap_hold_frames: 20,
        span_gap_frames: 16,
        span_min_frames: 12,
        span_lead_frames: 6,
        death_frames: 3000,
        replace_frames: 150,
    };

    /// Whether the settings are usable: finite; gates and separation in (0, 180]; poles in [0, 1);
    /// gains, `talker_level`, `hold_evidence` and `heard_evidence` in [0, 1]; 0 ≤ `active_off` ≤
    /// `active_on` ≤ 1; `relative_on` ≤ `unheard_relative_on` ≤ 1;
    /// birth mass > 0; `span_gap_frames` + `span_lead_frames` ≤
    /// [`crate::track_spans::MAX_SPAN_FRAMES`] and `span_min_frames` ≤ `span_gap_frames` (or 1).
    #[must_use]
    pub fn is_valid(&self) -> bool {
        let angle = |a: f32| a > 0.0 && a <= 180.0;
        let pole = |p: f32| (0.0..1.0).contains(&p);
        let unit = |g: f32| (0.0..=1.0).contains(&g);
        angle(self.gate_deg)
            && angle(self.min_separation_deg)
            && angle(self.estimate_birth_deg)
            && unit(self.estimate_birth_gain)
            && (0.0..=90.0).contains(&self.active_preference_deg)
            && pole(self.activity_pole)
            && pole(self.candidate_pole)
            && unit(self.azimuth_gain)
            && unit(self.anchor_gain)
            && unit(self.relative_on)
            && unit(self.unheard_relative_on)
            && self.relative_on <= self.unheard_relative_on
            && unit(self.heard_evidence)
            && unit(self.own_off)
            && unit(self.tail_off)
            && pole(self.peak_pole)
            && pole(self.recent_pole)
            && unit(self.talker_level)
            && unit(self.hold_evidence)
            && self.active_off >= 0.0
            && self.active_off <= self.active_on
            && self.active_on <= 1.0
            && self.birth_mass > 0.0
            && self.birth_mass.is_finite()
            && self.span_gap_frames.saturating_add(self.span_lead_frames) as usize
                <= crate::track_spans::MAX_SPAN_FRAMES
            && self.span_min_frames <= self.span_gap_frames.max(1)
    }
}

impl MultiTrack {
    /// Frames by which the span decision reports the tracks late: `span_gap_frames` +
    /// `span_lead_frames` (0 without the decision, `span_gap_frames` = 0; at most
    /// [`crate::track_spans::MAX_SPAN_FRAMES`]).
    #[must_use]
    pub fn span_delay_frames(&self) -> u32 {
        if self.span_gap_frames == 0 {
            return 0;
        }
        (self.span_gap_frames + self.span_lead_frames)
            .min(crate::track_spans::MAX_SPAN_FRAMES as u32)
    }
}

impl Default for MultiTrack {
    fn default() -> Self {
        Self::OFF
    }
}

/// One reported talker track.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TalkerTrack {
    /// Persistent ID (1, 2, …; wraps after 65535, skipping 0).
    pub id: u16,
    /// Azimuth, degrees in (−180, 180], counter-clockwise from cardioid 1.
    pub azimuth_deg: f32,
    /// Confidence in [0, 1]: the track's activity (smoothed share of the frame's peak weight).
    pub confidence: f32,
    /// The talker is speaking in this frame.
    pub active: bool,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Slot {
    live: bool,
    id: u16,
    /// Unit direction vector.
    x: f32,
    y: f32,
    azimuth_deg: f32,
    activity: f32,
    /// Peak activity, decaying.
    peak: f32,
    /// Recent activity (its maximum, decaying by `recent_pole`).
    recent: f32,
    active: bool,
    inactive_frames: u32,
    /// The activity has reached `talker_level` (a talker, not a stationary source).
    talker: bool,
    /// Frames since the last strong frame (saturating).
    since_strong: u16,
    /// Frames since the last frame of `heard_evidence` (saturating).
    since_heard: u16,
    /// Another track was active at the last strong frame.
    overlapped: bool,
}

impl Slot {
    const EMPTY: Self = Self {
        live: false,
        id: 0,
        x: 1.0,
        y: 0.0,
        azimuth_deg: 0.0,
        activity: 0.0,
        peak: 0.0,
        recent: 0.0,
        active: false,
        inactive_frames: 0,
        talker: false,
        since_strong: u16::MAX,
        since_heard: u16::MAX,
        overlapped: false,
    };
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Candidate {
    /// Weighted sum of unit vectors (decayed with the mass).
    x: f32,
    y: f32,
    mass: f32,
}

impl Candidate {
    const EMPTY: Self = Self {
        x: 0.0,
        y: 0.0,
        mass: 0.0,
    };
}

/// State of the multi-talker tracker.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MultiTrackState {
    slots: [Slot; MAX_TRACKS],
    candidates: [Candidate; MAX_CANDIDATES],
    next_id: u16,
    /// Bits of the gate, preference, separation and estimate-birth angles whose cosines `cosines`
    /// holds (`libm`'s cosine costs about 2000 instructions on the Cortex-M4F: once per
    /// configuration, not per frame).
    cosine_key: [u32; 4],
    cosines: [f32; 4],
}

impl Default for MultiTrackState {
    fn default() -> Self {
        Self::new()
    }
}

/// Unit vector and weight of a peak's direction, `None` for a non-finite or direction-less peak.
#[inline]
fn observation(p: &PeakFeature) -> Option<(f32, f32, f32)> {
    let (vx, vy) = plane_vector(p.y);
    let r2 = vx * vx + vy * vy;
    if !(r2 > 1e-12) || !r2.is_finite() || !(p.weight > 0.0) || !p.weight.is_finite() {
        return None;
    }
    let r = sqrtf(r2);
    let d = (r * (1.0 / PLANE_WAVE_LENGTH)).min(1.0);
    Some((vx / r, vy / r, p.weight * d * d))
}

/// Normalises (x, y); `None` when it has no direction.
#[inline]
fn unit(x: f32, y: f32) -> Option<(f32, f32)> {
    let r2 = x * x + y * y;
    if r2 > 1e-20 && r2.is_finite() {
        let r = sqrtf(r2);
        Some((x / r, y / r))
    } else {
        None
    }
}

fn cos_deg(a: f32) -> f32 {
    crate::trig::cos(a * (core::f32::consts::PI / 180.0))
}

impl MultiTrackState {
    /// No tracks.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            slots: [Slot::EMPTY; MAX_TRACKS],
            candidates: [Candidate::EMPTY; MAX_CANDIDATES],
            next_id: 1,
            cosine_key: [u32::MAX; 4],
            cosines: [1.0; 4],
        }
    }

    /// The live tracks (active or not), in slot order.
    pub fn tracks(&self) -> impl Iterator<Item = TalkerTrack> {
        self.slot_tracks().into_iter().flatten()
    }

    /// The live tracks (active or not) by slot: a track keeps its slot while it lives.
    #[must_use]
    pub fn slot_tracks(&self) -> [Option<TalkerTrack>; MAX_TRACKS] {
        self.slots.map(|s| {
            s.live.then_some(TalkerTrack {
                id: s.id,
                azimuth_deg: s.azimuth_deg,
                confidence: s.activity.clamp(0.0, 1.0),
                active: s.active,
            })
        })
    }

    /// One frame: `peaks` are the frame's usable peaks (features and weights), `gate` ∈ [0, 1] says
    /// whether the frame holds sound above the background at all (0 for silent, non-finite or
    /// noise-only frames), `dominant` is the single-azimuth estimate and its reliability b.
    pub fn update(
        &mut self,
        cfg: &MultiTrack,
        peaks: &[PeakFeature],
        gate: f32,
        dominant: Option<(f32, f32)>,
    ) {
        let gate = if gate.is_finite() {
            gate.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let angles = [
            cfg.gate_deg,
            cfg.active_preference_deg,
            cfg.min_separation_deg,
            cfg.estimate_birth_deg,
        ];
        let key = angles.map(f32::to_bits);
        if key != self.cosine_key {
            self.cosine_key = key;
            self.cosines = angles.map(cos_deg);
        }
        let [cos_gate, cos_preference, _, cos_far] = self.cosines;
        let preference = 1.0 - cos_preference;
        let total: f32 = peaks
            .iter()
            .filter(|p| p.weight.is_finite() && p.weight > 0.0)
            .map(|p| p.weight)
            .sum();
        let scale = if total > 0.0 && total.is_finite() {
            gate / total
        } else {
            0.0
        };
        // Per track: weighted sum of its peaks' unit vectors and their weight.
        let mut acc = [(0.0f32, 0.0f32, 0.0f32); MAX_TRACKS];
        for c in self.candidates.iter_mut() {
            c.x *= cfg.candidate_pole;
            c.y *= cfg.candidate_pole;
            c.mass *= cfg.candidate_pole;
        }
        if scale > 0.0 {
            for p in peaks {
                let Some((ux, uy, w)) = observation(p) else {
                    continue;
                };
                let mut best: Option<(usize, f32)> = None;
                for (k, s) in self.slots.iter().enumerate() {
                    if !s.live {
                        continue;
                    }
                    let c = s.x * ux + s.y * uy;
                    if c < cos_gate {
                        continue;
                    }
                    let score = if s.active { c + preference } else { c };
                    if best.is_none_or(|(_, b)| score > b) {
                        best = Some((k, score));
                    }
                }
                match best {
                    Some((k, _)) => {
                        let a = &mut acc[k];
                        a.0 += w * ux;
                        a.1 += w * uy;
                        a.2 += w;
                    }
                    None => self.feed_candidate(cos_gate, ux, uy, w * scale),
                }
            }
        }
        // Update the tracks.
        let mut loudest = 0.0f32;
        for (k, s) in self.slots.iter_mut().enumerate() {
            if s.live {
                let evidence = (acc[k].2 * scale).min(1.0);
                s.activity = cfg.activity_pole * s.activity + (1.0 - cfg.activity_pole) * evidence;
                s.peak = s.activity.max(cfg.peak_pole * s.peak);
                s.recent = s.activity.max(cfg.recent_pole * s.recent);
                loudest = loudest.max(s.recent);
            }
        }
        let hysteresis = if cfg.active_on > 0.0 {
            cfg.active_off / cfg.active_on
        } else {
            1.0
        };
        // Which tracks were active before this frame's decisions (for the overlap hold).
        let was_active = self.slots.map(|s| s.live && s.active);
        let hold = u16::try_from(cfg.overlap_hold_frames).unwrap_or(u16::MAX);
        let heard_frames = u16::try_from(cfg.heard_frames).unwrap_or(u16::MAX);
        for (k, s) in self.slots.iter_mut().enumerate() {
            if !s.live {
                continue;
            }
            let evidence = (acc[k].2 * scale).min(1.0);
            if evidence >= cfg.hold_evidence && evidence > 0.0 {
                s.since_strong = 0;
                s.overlapped = was_active.iter().enumerate().any(|(j, a)| *a && j != k);
            } else {
                s.since_strong = s.since_strong.saturating_add(1);
            }
            if evidence >= cfg.heard_evidence && evidence > 0.0 {
                s.since_heard = 0;
            } else {
                s.since_heard = s.since_heard.saturating_add(1);
            }
            if s.activity >= cfg.talker_level {
                s.talker = true;
            }
            let held = hold > 0 && s.overlapped && s.since_strong <= hold;
            let relative_on = if s.since_heard <= heard_frames {
                cfg.relative_on
            } else {
                cfg.unheard_relative_on
            };
            let on = cfg.active_on.max(relative_on * loudest);
            let own = cfg.own_off * s.peak;
            let off = cfg
                .active_off
                .max(cfg.relative_on * hysteresis * loudest)
                .max(own);
            // Falling (this frame's evidence is below its average) and below `tail_off` of its own
            // peak: the end of an utterance. `off` only lets a track go once its activity is below
            // `on`, and the loudest track's is not until it falls to `active_on`.
            let fading = evidence < s.activity && s.activity < cfg.tail_off * s.peak;
            if s.activity >= on && !fading {
                s.active = true;
            } else if s.activity < off && !held {
                s.active = false;
            }
            if !s.talker {
                s.active = false;
            }
            if let (true, Some((mx, my))) = (evidence > 0.0, unit(acc[k].0, acc[k].1)) {
                let g = cfg.azimuth_gain * evidence;
                if let Some((x, y)) = unit(s.x + g * (mx - s.x), s.y + g * (my - s.y)) {
                    s.x = x;
                    s.y = y;
                }
            }
            if s.active {
                s.inactive_frames = 0;
            } else {
                s.inactive_frames = s.inactive_frames.saturating_add(1);
                if s.inactive_frames > cfg.death_frames {
                    *s = Slot::EMPTY;
                }
            }
        }
        // The single-azimuth estimate as a unit vector, with its reliability.
        let estimate = dominant.and_then(|(az, b)| {
            let b = b.clamp(0.0, 1.0);
            (az.is_finite() && b > 0.0).then(|| {
                let (sy, sx) = crate::trig::sin_cos(az * (core::f32::consts::PI / 180.0));
                (sx, sy, b)
            })
        });
        // The most active track follows the single-azimuth estimate when it lies within the gate.
        let leader = self
            .slots
            .iter()
            .enumerate()
            .filter(|(_, s)| s.live && s.active)
            .fold(None::<(usize, f32)>, |best, (k, s)| match best {
                Some((_, a)) if a >= s.activity => best,
                _ => Some((k, s.activity)),
            });
        if let (Some((k, _)), Some((sx, sy, b))) = (leader, estimate) {
            let g = cfg.anchor_gain * b;
            let s = &mut self.slots[k];
            if g > 0.0 && s.x * sx + s.y * sy >= cos_gate {
                if let Some((x, y)) = unit(s.x + g * (sx - s.x), s.y + g * (sy - s.y)) {
                    s.x = x;
                    s.y = y;
                }
            }
        }
        // An estimate far from every track is a direction heard too: a talker whose peaks are
        // weak or scattered (far away, in a reverberant room) is then born all the same.
        if let Some((sx, sy, b)) = estimate {
            let mass = cfg.estimate_birth_gain * b * gate;
            if mass > 0.0
                && !self
                    .slots
                    .iter()
                    .any(|s| s.live && s.x * sx + s.y * sy > cos_far)
            {
                self.feed_candidate(cos_gate, sx, sy, mass);
            }
        }
        self.birth(cfg);
        for s in self.slots.iter_mut().filter(|s| s.live) {
            s.azimuth_deg =
                crate::angle::wrap_deg(libm::atan2f(s.y, s.x) * (180.0 / core::f32::consts::PI));
        }
    }

    /// Adds a peak no track took to the nearest candidate within the gate, or replaces the lightest
    /// candidate when it is lighter than the peak.
    fn feed_candidate(&mut self, cos_gate: f32, ux: f32, uy: f32, mass: f32) {
        let mut nearest: Option<(usize, f32)> = None;
        let mut lightest = 0usize;
        for (i, c) in self.candidates.iter().enumerate() {
            if c.mass < self.candidates[lightest].mass {
                lightest = i;
            }
            if let Some((cx, cy)) = unit(c.x, c.y) {
                let cos = cx * ux + cy * uy;
                if cos >= cos_gate && nearest.is_none_or(|(_, b)| cos > b) {
                    nearest = Some((i, cos));
                }
            }
        }
        match nearest {
            Some((i, _)) => {
                let c = &mut self.candidates[i];
                c.x += mass * ux;
                c.y += mass * uy;
                c.mass += mass;
            }
            None if self.candidates[lightest].mass < mass => {
                self.candidates[lightest] = Candidate {
                    x: mass * ux,
                    y: mass * uy,
                    mass,
                };
            }
            None => {}
        }
    }

    /// Turns the heaviest candidate into a track when it is heavy enough and far enough from every
    /// live track.
    fn birth(&mut self, cfg: &MultiTrack) {
        let Some((i, c)) = self
            .candidates
            .iter()
            .copied()
            .enumerate()
            .max_by(|a, b| a.1.mass.total_cmp(&b.1.mass))
        else {
            return;
        };
        if !(c.mass >= cfg.birth_mass) {
            return;
        }
        let Some((x, y)) = unit(c.x, c.y) else {
            return;
        };
        let cos_sep = self.cosines[2];
        if self
            .slots
            .iter()
            .any(|s| s.live && s.x * x + s.y * y > cos_sep)
        {
            // A direction a track already covers: forget the cluster.
            self.candidates[i] = Candidate::EMPTY;
            return;
        }
        let free = self.slots.iter().position(|s| !s.live).or_else(|| {
            self.slots
                .iter()
                .enumerate()
                .filter(|(_, s)| !s.active && s.inactive_frames >= cfg.replace_frames)
                .max_by_key(|(_, s)| s.inactive_frames)
                .map(|(k, _)| k)
        });
        let Some(k) = free else {
            return;
        };
        let id = self.next_id;
        self.next_id = self.next_id.checked_add(1).unwrap_or(1);
        self.slots[k] = Slot {
            live: true,
            id,
            x,
            y,
            azimuth_deg: 0.0,
            activity: cfg.active_on,
            peak: cfg.active_on,
            recent: cfg.active_on,
            active: cfg.active_on >= cfg.talker_level,
            inactive_frames: 0,
            talker: cfg.active_on >= cfg.talker_level,
            since_strong: u16::MAX,
            since_heard: u16::MAX,
            overlapped: false,
        };
        self.candidates[i] = Candidate::EMPTY;
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    /// A peak of a plane wave from `az` degrees (ideal cardioid features).
    fn peak(az: f32) -> PeakFeature {
        let y = [0.0f32, 120.0, 240.0].map(|look| 0.5 + 0.5 * libm::cosf((az - look).to_radians()));
        PeakFeature {
            fi: 0,
            y,
            weight: 1.0,
        }
    }

    /// A frame in which a talker at `az` has 40 % of the peak weight, the rest diffuse.
    fn speaking(az: f32) -> [PeakFeature; 10] {
        let mut peaks = [diffuse(); 10];
        peaks[..4].fill(peak(az));
        peaks
    }

    fn frame(state: &mut MultiTrackState, azimuths: &[f32], gate: f32) {
        let peaks: Vec<PeakFeature> = azimuths.iter().map(|a| peak(*a)).collect();
        state.update(&MultiTrack::DEFAULT, &peaks, gate, None);
    }

    fn active(state: &MultiTrackState) -> usize {
        state.tracks().filter(|t| t.active).count()
    }

    fn track_near(state: &MultiTrackState, az: f32) -> Option<TalkerTrack> {
        state
            .tracks()
            .find(|t| crate::angle::wrap_deg(t.azimuth_deg - az).abs() < 2.0)
    }

    #[test]
    fn a_direction_heard_consistently_becomes_one_track() {
        let mut s = MultiTrackState::new();
        for _ in 0..60 {
            frame(&mut s, &[40.0; 8], 1.0);
        }
        let tracks: [Option<TalkerTrack>; 2] = {
            let mut it = s.tracks();
            [it.next(), it.next()]
        };
        let t = tracks[0].expect("a track");
        assert!(tracks[1].is_none());
        assert_eq!(t.id, 1);
        assert!(t.active && t.confidence > 0.5, "{t:?}");
        assert!((t.azimuth_deg - 40.0).abs() < 0.01, "{t:?}");
    }

    #[test]
    fn talkers_taking_turns_keep_their_ids() {
        let mut s = MultiTrackState::new();
        let talkers = [30.0f32, -90.0, 150.0];
        let mut ids = [0u16; 3];
        for round in 0..3 {
            for (k, az) in talkers.iter().enumerate() {
                for _ in 0..80 {
                    frame(&mut s, &[*az; 10], 1.0);
                }
                let t = track_near(&s, *az).expect("the speaking talker has a track");
                assert!(t.active);
                // Only the speaking talker is active at the end of its turn.
                assert_eq!(active(&s), 1, "round {round} talker {k}");
                if round == 0 {
                    ids[k] = t.id;
                } else {
                    assert_eq!(t.id, ids[k], "round {round} talker {k}");
                }
                // A pause: nothing is active after it.
                for _ in 0..40 {
                    frame(&mut s, &[], 0.0);
                }
                assert_eq!(active(&s), 0);
            }
        }
        assert_eq!(ids, [1, 2, 3]);
    }

    #[test]
    fn the_last_talker_s_track_ends_a_fixed_time_after_the_utterance() {
        let cfg = MultiTrack::DEFAULT;
        let mut s = MultiTrackState::new();
        for _ in 0..80 {
            frame(&mut s, &[60.0; 10], 1.0);
        }
        assert_eq!(active(&s), 1);
        // The activity falls by `activity_pole` per silent frame: below `tail_off` of its peak
        // after ln(tail_off)/ln(pole) frames (18), long before it reaches `active_on` (28).
        let hangover = (libm::logf(cfg.tail_off) / libm::logf(cfg.activity_pole)) as usize;
        let to_floor = (libm::logf(cfg.active_on) / libm::logf(cfg.activity_pole)) as usize;
        assert!(hangover + 5 < to_floor);
        for i in 0..hangover + 2 {
            frame(&mut s, &[], 0.0);
            if i + 2 < hangover {
                assert_eq!(
                    active(&s),
                    1,
                    "a short pause keeps the talker active (frame {i})"
                );
            }
        }
        assert_eq!(active(&s), 0, "the talker has stopped");
        // The talker speaks again: active at once, same ID.
        for _ in 0..3 {
            frame(&mut s, &[60.0; 10], 1.0);
        }
        let t = track_near(&s, 60.0).expect("the talker's track");
        assert!(t.active);
        assert_eq!(t.id, 1);
    }

    #[test]
    fn a_talker_the_single_estimate_hears_is_born_though_his_peaks_scatter() {
        // Talker A at 40° has a track; talker B at -100° then speaks, his peaks scattered over
        // the circle (no cluster holds enough of them), the single estimate on him. His track
        // is born near him (the scattered peaks then pull it about a little).
        let run = |cfg: &MultiTrack| {
            let mut s = MultiTrackState::new();
            for _ in 0..60 {
                s.update(cfg, &[peak(40.0); 10], 1.0, Some((40.0, 0.8)));
            }
            for i in 0..60 {
                let peaks: Vec<PeakFeature> = (0..10)
                    .map(|k| peak(((i * 7 + k * 36) % 360) as f32))
                    .collect();
                s.update(cfg, &peaks, 1.0, Some((-100.0, 0.8)));
            }
            s
        };
        let with = run(&MultiTrack::DEFAULT);
        assert!(with.tracks().any(|t| t.id == 1), "talker A keeps his track");
        let b = with
            .tracks()
            .find(|t| crate::angle::wrap_deg(t.azimuth_deg + 100.0).abs() < 15.0);
        assert!(b.is_some(), "{:?}", with.tracks().collect::<Vec<_>>());
        let without = run(&MultiTrack {
            estimate_birth_gain: 0.0,
            ..MultiTrack::DEFAULT
        });
        assert!(
            without
                .tracks()
                .all(|t| crate::angle::wrap_deg(t.azimuth_deg + 100.0).abs() >= 15.0),
            "{:?}",
            without.tracks().collect::<Vec<_>>()
        );
    }

    #[test]
    fn two_talkers_at_once_are_both_active() {
        let mut s = MultiTrackState::new();
        for _ in 0..100 {
            frame(
                &mut s,
                &[
                    20.0, 20.0, 20.0, 20.0, 20.0, -100.0, -100.0, -100.0, -100.0, -100.0,
                ],
                1.0,
            );
        }
        let a = track_near(&s, 20.0).expect("first talker");
        let b = track_near(&s, -100.0).expect("second talker");
        assert!(a.active && b.active);
        assert_ne!(a.id, b.id);
        assert_eq!(s.tracks().count(), 2);
    }

    /// A peak with no direction (diffuse sound): it counts in the frame's peak weight only.
    fn diffuse() -> PeakFeature {
        PeakFeature {
            fi: 0,
            y: [0.5; 3],
            weight: 1.0,
        }
    }

    /// A frame where `azimuths` give one peak each and `diffuse` peaks fill up the frame.
    fn frame_with_diffuse(s: &mut MultiTrackState, cfg: &MultiTrack, azimuths: &[f32], n: usize) {
        let mut peaks: Vec<PeakFeature> = azimuths.iter().map(|a| peak(*a)).collect();
        peaks.resize(peaks.len() + n, diffuse());
        s.update(cfg, &peaks, 1.0, None);
    }

    #[test]
    fn a_stationary_source_gets_no_active_track_and_a_talker_beside_it_does() {
        // A fan at 100°: a steady 9 % of the frame's peak weight, every frame (the rest diffuse).
        let cfg = MultiTrack::DEFAULT;
        let mut s = MultiTrackState::new();
        for _ in 0..400 {
            frame_with_diffuse(&mut s, &cfg, &[100.0; 9], 91);
            assert_eq!(active(&s), 0, "{:?}", s.tracks().collect::<Vec<_>>());
        }
        let fan = track_near(&s, 100.0).expect("the source is tracked");
        assert!(!fan.active && fan.confidence > cfg.active_on, "{fan:?}");
        // Without the talker level its steady activity would make it active.
        let mut old = MultiTrackState::new();
        let without = MultiTrack {
            talker_level: 0.0,
            ..cfg
        };
        for _ in 0..400 {
            frame_with_diffuse(&mut old, &without, &[100.0; 9], 91);
        }
        assert_eq!(active(&old), 1);
        // A talker 60° from the fan speaks (syllables: strong frames and gaps), the fan goes on.
        for i in 0..200 {
            let talker: &[f32] = if i % 10 < 6 { &[160.0; 40] } else { &[] };
            let mut az: Vec<f32> = talker.to_vec();
            az.extend_from_slice(&[100.0; 9]);
            frame_with_diffuse(&mut s, &cfg, &az, 91 - talker.len());
        }
        let t = track_near(&s, 160.0).expect("the talker has a track");
        assert!(t.active, "{t:?}");
        let fan = track_near(&s, 100.0).expect("the source keeps its track");
        assert!(!fan.active, "{fan:?}");
    }

    #[test]
    fn two_talkers_at_once_stay_active_while_their_shares_swing() {
        // Talkers A (20°) and B (-100°) speak at once; then for 15 frames (0.24 s) A has all the
        // peaks, as when B pauses between two words or A's syllables mask his.
        let run = |cfg: &MultiTrack| {
            let mut s = MultiTrackState::new();
            let both = [
                20.0, 20.0, 20.0, 20.0, 20.0, -100.0, -100.0, -100.0, -100.0, -100.0,
            ];
            for _ in 0..100 {
                s.update(cfg, &both.map(peak), 1.0, None);
            }
            let mut b_active = Vec::new();
            for _ in 0..15 {
                s.update(cfg, &[peak(20.0); 10], 1.0, None);
                b_active.push(track_near(&s, -100.0).is_some_and(|t| t.active));
            }
            for _ in 0..5 {
                s.update(cfg, &both.map(peak), 1.0, None);
            }
            let b = track_near(&s, -100.0).expect("B's track");
            (b_active, b.active)
        };
        let (held, active_after) = run(&MultiTrack::DEFAULT);
        assert!(held.iter().all(|a| *a) && active_after);
        let (without, _) = run(&MultiTrack {
            overlap_hold_frames: 0,
            ..MultiTrack::DEFAULT
        });
        assert!(without.iter().any(|a| !*a), "{without:?}");
    }

    #[test]
    fn a_silent_talker_fed_by_the_others_reverberation_stays_inactive() {
        // B (-100°) speaks, then A (20°), each with 40 % of the frames' peak weight (the rest is
        // diffuse). Then A goes on, and B's direction gets a steady 17 % of every frame's peak
        // weight (A's reverberation), or now and then a syllable of B's own (25 % of one frame in
        // ten).
        let weighted = |az: f32, weight: f32| PeakFeature { weight, ..peak(az) };
        let run = |cfg: &MultiTrack, b_speaks: bool| {
            let mut s = MultiTrackState::new();
            for az in [-100.0, 20.0] {
                for _ in 0..80 {
                    s.update(cfg, &speaking(az), 1.0, None);
                }
            }
            let mut b_active = 0;
            for i in 0..100 {
                let b = if b_speaks && i % 10 == 0 { 3.0 } else { 1.8 };
                let mut peaks = speaking(20.0);
                peaks[4] = weighted(-100.0, b);
                s.update(cfg, &peaks, 1.0, None);
                b_active += usize::from(track_near(&s, -100.0).expect("B's track").active);
            }
            b_active
        };
        let d = MultiTrack::DEFAULT;
        assert_eq!(run(&d, false), 0);
        let speaks = run(&d, true);
        assert!(speaks >= 80, "{speaks}");
        let one_threshold = MultiTrack {
            unheard_relative_on: d.relative_on,
            ..d
        };
        let fed = run(&one_threshold, false);
        assert!(fed >= 80, "{fed}");
    }

    #[test]
    fn the_next_talker_is_not_turned_on_by_the_last_ones_reverberation() {
        // B (-100°) speaks, then A (20°), each with 40 % of the frames' peak weight (the rest is
        // diffuse). A stops: for 25 frames his reverberation gives both directions a tenth of the
        // peak weight. Then B speaks again.
        let run = |cfg: &MultiTrack| {
            let mut s = MultiTrackState::new();
            for az in [-100.0, 20.0] {
                for _ in 0..60 {
                    s.update(cfg, &speaking(az), 1.0, None);
                }
            }
            let b_active = |s: &MultiTrackState| track_near(s, -100.0).expect("B's track").active;
            let mut tail = 0;
            let mut tail_peaks = [diffuse(); 10];
            tail_peaks[0] = peak(20.0);
            tail_peaks[1] = peak(-100.0);
            for _ in 0..25 {
                s.update(cfg, &tail_peaks, 1.0, None);
                tail += usize::from(b_active(&s));
            }
            let mut onset = None;
            for i in 0..20 {
                s.update(cfg, &speaking(-100.0), 1.0, None);
                if onset.is_none() && b_active(&s) {
                    onset = Some(i);
                }
            }
            (tail, onset)
        };
        let (tail, onset) = run(&MultiTrack::DEFAULT);
        assert_eq!(tail, 0);
        assert!(onset.is_some_and(|i| i <= 5), "{onset:?}");
        let (tail, _) = run(&MultiTrack {
            recent_pole: 0.0,
            ..MultiTrack::DEFAULT
        });
        assert!(tail >= 5, "{tail}");
    }

    #[test]
    fn noise_and_bad_input_make_no_tracks() {
        let mut s = MultiTrackState::new();
        for i in 0..200 {
            frame(&mut s, &[(i * 37 % 360) as f32; 10], 0.0);
        }
        assert_eq!(s.tracks().count(), 0);
        let bad = [PeakFeature {
            fi: 0,
            y: [f32::NAN, f32::INFINITY, -1.0],
            weight: f32::NAN,
        }; 4];
        for _ in 0..50 {
            s.update(
                &MultiTrack::DEFAULT,
                &bad,
                f32::NAN,
                Some((f32::NAN, f32::INFINITY)),
            );
        }
        assert_eq!(s.tracks().count(), 0);
    }

    #[test]
    fn a_silent_track_ends_after_the_death_time() {
        let cfg = MultiTrack {
            death_frames: 20,
            ..MultiTrack::DEFAULT
        };
        let mut s = MultiTrackState::new();
        let peaks = [peak(-45.0); 8];
        for _ in 0..40 {
            s.update(&cfg, &peaks, 1.0, None);
        }
        assert_eq!(s.tracks().count(), 1);
        for _ in 0..60 {
            s.update(&cfg, &[], 0.0, None);
        }
        assert_eq!(s.tracks().count(), 0);
    }

    #[test]
    fn the_defaults_are_valid_and_bad_settings_are_not() {
        assert!(MultiTrack::DEFAULT.is_valid() && MultiTrack::OFF.is_valid());
        const { assert!(!MultiTrack::OFF.enabled && MultiTrack::DEFAULT.enabled) };
        let bad = [
            MultiTrack {
                gate_deg: f32::NAN,
                ..MultiTrack::DEFAULT
            },
            MultiTrack {
                activity_pole: 1.0,
                ..MultiTrack::DEFAULT
            },
            MultiTrack {
                active_off: 0.5,
                active_on: 0.2,
                ..MultiTrack::DEFAULT
            },
            MultiTrack {
                birth_mass: 0.0,
                ..MultiTrack::DEFAULT
            },
            MultiTrack {
                talker_level: f32::NAN,
                ..MultiTrack::DEFAULT
            },
            MultiTrack {
                hold_evidence: 1.5,
                ..MultiTrack::DEFAULT
            },
            // Frame counts whose sum overflows u32: refused, not a panic.
            MultiTrack {
                span_gap_frames: u32::MAX,
                span_lead_frames: 6,
                ..MultiTrack::DEFAULT
            },
        ];
        for b in bad {
            assert!(!b.is_valid(), "{b:?}");
        }
    }

    proptest! {
        #[test]
        fn any_input_keeps_the_tracks_bounded_and_finite(
            frames in proptest::collection::vec(
                (proptest::collection::vec((any::<f32>(), any::<f32>(), any::<f32>(), any::<f32>()), 0..12),
                 any::<f32>(), any::<f32>(), any::<f32>()),
                1..60),
        ) {
            let mut s = MultiTrackState::new();
            for (peaks, gate, az, b) in frames {
                let peaks: Vec<PeakFeature> = peaks
                    .into_iter()
                    .map(|(a, b, c, w)| PeakFeature {
                        fi: 0,
                        y: [a, b, c],
                        weight: w,
                                })
                    .collect();
                s.update(&MultiTrack::DEFAULT, &peaks, gate, Some((az, b)));
                let mut ids = [0u16; MAX_TRACKS];
                for (n, t) in s.tracks().enumerate() {
                    prop_assert!(t.azimuth_deg.is_finite() && t.azimuth_deg > -180.0 && t.azimuth_deg <= 180.0);
                    prop_assert!((0.0..=1.0).contains(&t.confidence));
                    prop_assert!(t.id != 0 && !ids[..n].contains(&t.id));
                    ids[n] = t.id;
                }
            }
        }
    }
}
