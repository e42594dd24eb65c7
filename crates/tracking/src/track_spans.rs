//! Utterance spans of the multi-talker tracks: each track's activity decided again a fixed number
//! of frames late, with the frames that followed.
//!
//! A causal tracker cannot tell the end of an utterance from a pause inside it: a hangover long
//! enough to bridge the pauses between words also runs on after the last word, while nobody
//! speaks (measured: most of the active track frames outside every utterance came in the 0.3 s
//! after its end). Looking ahead separates the two. The tracker releases a track quickly when its
//! evidence falls ([`MultiTrack::tail_off`](crate::multi_track::MultiTrack::tail_off)), and this
//! stage reports each frame [`MultiTrack::span_gap_frames`] frames late:
//!
//! * a pause of at most `span_gap_frames` frames between two active frames of the same track is
//!   reported active (the talker went on speaking: the frames after the pause show it);
//! * a burst of activity shorter than [`MultiTrack::span_min_frames`], pauses closed, is not
//!   reported (a reflection or the other talker's syllable briefly taken for this track).
//!
//! The tracker's activity also lags the talker by its smoothing, at his first word and after his
//! last: each frame gets the activity decided [`MultiTrack::span_lead_frames`] frames after it,
//! so the delay is `span_gap_frames` + `span_lead_frames` frames
//! ([`MultiTrack::span_delay_frames`]; measured: a lead of 6 frames raised the span precision of
//! every set, synthetic and real speech, by 1–3 points at the same recall, docs/history.md).
//!
//! Everything else of a reported track (ID, azimuth, confidence) is the tracker's at that frame.
//! With `span_gap_frames = 0` the frames are reported as the tracker decides them, without delay.
//!
//! State: the last [`MAX_SPAN_FRAMES`] + 1 frames' tracks (≈ 1 KB) and, per track slot, the
//! tracker's activity of the last 64 frames as bits. Work per frame: a few shifts and at most
//! about a hundred bit tests per track.
//!
//! [`MultiTrack::span_gap_frames`]: crate::multi_track::MultiTrack::span_gap_frames
//! [`MultiTrack::span_min_frames`]: crate::multi_track::MultiTrack::span_min_frames
//! [`MultiTrack::span_lead_frames`]: crate::multi_track::MultiTrack::span_lead_frames
//! [`MultiTrack::span_delay_frames`]: crate::multi_track::MultiTrack::span_delay_frames

use crate::multi_track::{MultiTrack, TalkerTrack, MAX_TRACKS};

/// Largest look-ahead (and so delay) of the span decision, frames.
pub const MAX_SPAN_FRAMES: usize = 24;

/// Frames of activity kept per track slot (one bit each).
const HISTORY: usize = 64;

/// The tracks of one analysis frame, as reported (or as the tracker left them, before the
/// decision).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackFrame {
    /// Analysis frame index of the frame ([`Estimate::frame_index`](crate::estimate::Estimate)).
    pub frame_index: u32,
    /// The live tracks in slot order (`None`: no track in that slot).
    pub slots: [Option<TalkerTrack>; MAX_TRACKS],
}

impl TrackFrame {
    const EMPTY: Self = Self {
        frame_index: 0,
        slots: [None; MAX_TRACKS],
    };

    /// The frame's live tracks (active or not).
    pub fn tracks(&self) -> impl Iterator<Item = TalkerTrack> + '_ {
        self.slots.iter().flatten().copied()
    }
}

/// State of the span decision.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackSpans {
    /// The frames not yet reported and the last reported one, oldest at `start`.
    ring: [TrackFrame; MAX_SPAN_FRAMES + 1],
    start: usize,
    len: usize,
    /// Per slot, the ID its bits belong to and the tracker's activity of the last frames (bit i:
    /// the frame i frames before the newest).
    ids: [u16; MAX_TRACKS],
    bits: [u64; MAX_TRACKS],
    /// The last decided frame.
    decided: Option<TrackFrame>,
}

impl Default for TrackSpans {
    fn default() -> Self {
        Self::new()
    }
}

/// Whether the frame `age` frames before the newest lies in a closed span of `active`: active
/// itself, or between two active frames at most `gap` + 1 frames apart (both within the bits).
fn closed(active: u64, age: usize, gap: usize) -> bool {
    if age >= HISTORY {
        return false;
    }
    if active >> age & 1 == 1 {
        return true;
    }
    // Nearest active frame newer than `age` (smaller age) and older (larger age).
    let newer = active & ((1u64 << age) - 1);
    let older = if age + 1 >= HISTORY {
        0
    } else {
        active >> (age + 1)
    };
    if newer == 0 || older == 0 {
        return false;
    }
    let newer_age = HISTORY - 1 - newer.leading_zeros() as usize;
    let older_age = age + 1 + older.trailing_zeros() as usize;
    older_age - newer_age <= gap + 1
}

/// Whether the frame `age` frames before the newest is reported active: in a closed span that is
/// at least `min` frames long (counted within the bits).
fn reported(active: u64, age: usize, gap: usize, min: usize) -> bool {
    if !closed(active, age, gap) {
        return false;
    }
    let mut run = 1;
    let mut a = age;
    while run < min && a > 0 && closed(active, a - 1, gap) {
        run += 1;
        a -= 1;
    }
    let mut a = age + 1;
    while run < min && a < HISTORY && closed(active, a, gap) {
        run += 1;
        a += 1;
    }
    run >= min
}

impl TrackSpans {
    /// No frames.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            ring: [TrackFrame::EMPTY; MAX_SPAN_FRAMES + 1],
            start: 0,
            len: 0,
            ids: [0; MAX_TRACKS],
            bits: [0; MAX_TRACKS],
            decided: None,
        }
    }

    /// The frame decided last (none before the first [`MultiTrack::span_delay_frames`] frames
    /// have passed).
    #[must_use]
    pub fn decided(&self) -> Option<&TrackFrame> {
        self.decided.as_ref()
    }

    /// Adds the tracker's tracks of frame `frame_index` (slot order) and decides the frame
    /// [`MultiTrack::span_delay_frames`] before it, which [`TrackSpans::decided`] then returns.
    pub fn push(
        &mut self,
        cfg: &MultiTrack,
        frame_index: u32,
        slots: [Option<TalkerTrack>; MAX_TRACKS],
    ) {
        for (k, s) in slots.iter().enumerate() {
            let (id, active) = s.map_or((0, false), |t| (t.id, t.active));
            if id != self.ids[k] {
                self.ids[k] = id;
                self.bits[k] = 0;
            }
            self.bits[k] = self.bits[k] << 1 | u64::from(active);
        }
        let delay = Self::delay(cfg);
        let slot = (self.start + self.len) % self.ring.len();
        self.ring[slot] = TrackFrame { frame_index, slots };
        if self.len < self.ring.len() {
            self.len += 1;
        } else {
            self.start = (self.start + 1) % self.ring.len();
        }
        self.decided = if self.len > delay {
            Some(self.decide(cfg, delay))
        } else {
            None
        };
        // Keep the frames not yet decided and the decided one.
        while self.len > delay + 1 {
            self.start = (self.start + 1) % self.ring.len();
            self.len -= 1;
        }
    }

    /// At the end of the input: decides the next frame not yet decided as if no track were
    /// active after the last frame, and returns it (`None` when every frame is decided).
    pub fn flush(&mut self, cfg: &MultiTrack) -> Option<TrackFrame> {
        let delay = Self::delay(cfg);
        // The frames not yet decided are the newest `len − 1` (or all, before the first decision).
        let pending = if self.decided.is_some() {
            self.len.saturating_sub(1)
        } else {
            self.len
        };
        if pending == 0 {
            return None;
        }
        // The next one is `pending − 1` frames before the newest: shift silent frames in until
        // it is `delay` frames back, so its look-ahead is what is known, then silence.
        let age = pending - 1;
        let mut bits = self.bits;
        for b in &mut bits {
            *b <<= delay - age;
        }
        let next = self.len - pending;
        let frame = self.decide_with(cfg, &bits, (self.start + next) % self.ring.len(), delay);
        self.decided = Some(frame);
        // Drop the frames before it.
        self.start = (self.start + next) % self.ring.len();
        self.len -= next;
        Some(frame)
    }

    /// The look-ahead the settings ask for, within what the ring holds.
    fn delay(cfg: &MultiTrack) -> usize {
        cfg.span_delay_frames() as usize
    }

    /// Decides the frame `delay` frames before the newest.
    fn decide(&self, cfg: &MultiTrack, delay: usize) -> TrackFrame {
        let slot = (self.start + self.len - 1 - delay) % self.ring.len();
        self.decide_with(cfg, &self.bits, slot, delay)
    }

    /// The frame in ring slot `slot`, `age` frames before the newest of `bits`, with each track's
    /// activity as [`reported`] says.
    fn decide_with(
        &self,
        cfg: &MultiTrack,
        bits: &[u64; MAX_TRACKS],
        slot: usize,
        age: usize,
    ) -> TrackFrame {
        let mut frame = self.ring[slot];
        if cfg.span_gap_frames == 0 {
            return frame;
        }
        let gap = (cfg.span_gap_frames as usize).min(MAX_SPAN_FRAMES);
        let min = cfg.span_min_frames as usize;
        // The activity `span_lead_frames` later is the talker's at this frame.
        let age = age.saturating_sub(cfg.span_lead_frames as usize);
        for (k, t) in frame.slots.iter_mut().enumerate() {
            if let Some(t) = t {
                // The bits are the slot's current track's; an older track in the slot was
                // decided from its own bits while they lasted.
                t.active = if t.id == self.ids[k] {
                    reported(bits[k], age, gap, min)
                } else {
                    t.active
                };
            }
        }
        frame
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(gap: u32, min: u32) -> MultiTrack {
        MultiTrack {
            span_gap_frames: gap,
            span_min_frames: min,
            span_lead_frames: 0,
            ..MultiTrack::DEFAULT
        }
    }

    fn track(id: u16, active: bool) -> Option<TalkerTrack> {
        Some(TalkerTrack {
            id,
            azimuth_deg: 30.0,
            confidence: 0.5,
            active,
        })
    }

    /// Runs one track with activity `pattern` (1 = active) through the stage and returns the
    /// reported activity of every frame, in order.
    fn run(cfg: &MultiTrack, pattern: &str) -> String {
        let mut spans = TrackSpans::new();
        let mut out = String::new();
        let mut next = 0u32;
        let mut take = |f: &TrackFrame, out: &mut String| {
            assert_eq!(f.frame_index, next, "frames come in order, each once");
            next += 1;
            out.push(if f.slots[0].is_some_and(|t| t.active) {
                '1'
            } else {
                '0'
            });
        };
        for (i, c) in pattern.chars().enumerate() {
            spans.push(cfg, i as u32, [track(1, c == '1'), None, None]);
            if let Some(f) = spans.decided() {
                take(&f.clone(), &mut out);
            }
        }
        while let Some(f) = spans.flush(cfg) {
            take(&f, &mut out);
        }
        out
    }

    extern crate std;
    use std::string::String;

    #[test]
    fn pauses_up_to_the_gap_are_closed_longer_ones_and_the_edges_are_kept() {
        let c = cfg(4, 0);
        assert_eq!(run(&c, "0011000011100000110000"), "0011111111100000110000",);
        // A pause of exactly the gap closes, one frame longer does not.
        assert_eq!(run(&c, "1000011"), "1111111");
        assert_eq!(run(&c, "10000011"), "10000011");
    }

    #[test]
    fn a_lead_reports_the_activity_that_many_frames_earlier() {
        let c = MultiTrack {
            span_lead_frames: 2,
            ..cfg(4, 0)
        };
        assert_eq!(c.span_delay_frames(), 6);
        // The tracker's span 2 frames late on both ends is reported where the talker spoke; the
        // pause is closed as without the lead, and the last frames see the silence after them.
        assert_eq!(run(&c, "00011100001110"), "01111111111000");
        assert_eq!(run(&c, "0000000011"), "0000001100");
        assert_eq!(run(&cfg(4, 0), "00011100001110"), "00011111111110");
    }

    #[test]
    fn short_bursts_are_dropped_after_the_pauses_are_closed() {
        let c = cfg(4, 3);
        assert_eq!(run(&c, "0010000000110000000"), "0000000000000000000");
        assert_eq!(run(&c, "0010010000011100000"), "0011110000011100000");
    }

    #[test]
    fn the_state_is_about_a_kilobyte() {
        assert!(core::mem::size_of::<TrackSpans>() <= 1100);
    }

    #[test]
    fn without_a_gap_the_tracker_s_frames_are_reported_as_they_come() {
        let c = cfg(0, 8);
        let mut spans = TrackSpans::new();
        spans.push(&c, 7, [track(3, true), None, track(4, false)]);
        let f = spans.decided().copied().unwrap();
        assert_eq!(f.frame_index, 7);
        assert_eq!(f.slots, [track(3, true), None, track(4, false)]);
        assert_eq!(spans.flush(&c), None);
    }

    #[test]
    fn every_frame_is_reported_once_in_order_at_the_end_too() {
        for n in 0..30 {
            let pattern: String = (0..n).map(|i| if i % 7 < 3 { '1' } else { '0' }).collect();
            let out = run(&cfg(12, 8), &pattern);
            assert_eq!(out.len(), n);
        }
    }

    #[test]
    fn a_new_track_in_a_slot_does_not_inherit_the_old_one_s_activity() {
        let c = cfg(4, 0);
        let mut spans = TrackSpans::new();
        let mut got = std::vec::Vec::new();
        for i in 0..12u32 {
            let id = if i < 6 { 1 } else { 2 };
            let active = i == 1 || i == 8;
            spans.push(&c, i, [track(id, active), None, None]);
            if let Some(f) = spans.decided() {
                got.push(f.slots[0].unwrap());
            }
        }
        while let Some(f) = spans.flush(&c) {
            got.push(f.slots[0].unwrap());
        }
        let active: std::vec::Vec<u32> = (0..12u32).filter(|i| got[*i as usize].active).collect();
        // Track 1 active at 1 only, track 2 at 8 only: the pause between them is not closed.
        assert_eq!(active, [1, 8]);
        assert_eq!(got[5].id, 1);
        assert_eq!(got[6].id, 2);
    }
}
