//! Frame onset weighting of the reliability: frames whose power has just risen carry more direct
//! sound than frames in a decay, so their b counts more.
//!
//! In a room the direct sound of a syllable arrives first and its reflections pile up behind it:
//! while the frame power rises the direct sound dominates, while it falls the frame is mostly
//! reverberation, whose direction is wherever the strongest reflections come from. On the eval
//! folder's room scenes (frames with b > 0.3) the raw estimate's median error is 5.8–8.7° in frames
//! whose power is below the largest of the three frames before, and 3.6–4.4° in frames 1–6 dB above
//! it.
//! The peak-level onset weight of [`crate::direct_sound`] ranks the peaks inside a frame; this one
//! ranks the frames.
//!
//! The rise is r = P / max(P₋₁ … P₋ₙ) over the last n frame powers; the weight ramps linearly in r
//! from [`FrameOnset::floor`] at [`FrameOnset::low_db`] to 1 at [`FrameOnset::high_db`].
//!
//! The product configuration switches it on (`cma_core::config::DEFAULT_FRAME_ONSET`); the thesis
//! preset leaves it off. The weighted b drives the grid tracker's likelihood, pause detection and
//! running mean curve, but not its velocity estimate: the talker's motion is learned from every
//! reliable frame, decaying ones included (with the weight there too, the eval folder's moving
//! talker got 3.14° MAE instead of 1.76°).

use crate::power_ramp::PowerRamp;

/// Most frames of power history.
pub const MAX_ONSET_HISTORY: usize = 8;

/// Frame onset settings.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct FrameOnset {
    /// Whether the weighting applies.
    pub enabled: bool,
    /// Frames of power history the rise is measured against (1…[`MAX_ONSET_HISTORY`]).
    pub history: usize,
    /// Rise (dB) at and below which a frame gets the floor weight.
    pub low_db: f32,
    /// Rise (dB) at and above which a frame gets weight 1.
    pub high_db: f32,
    /// Weight of frames at or below [`FrameOnset::low_db`], in [0, 1].
    pub floor: f32,
}

impl FrameOnset {
    /// The weighting off (b unchanged).
    pub const OFF: Self = Self {
        enabled: false,
        history: 3,
        low_db: -1.0,
        high_db: 3.0,
        floor: 0.5,
    };

    /// Whether the settings are usable: a history of 1…[`MAX_ONSET_HISTORY`] frames, finite
    /// `low_db < high_db` and a floor in [0, 1].
    #[must_use]
    pub fn is_valid(&self) -> bool {
        (1..=MAX_ONSET_HISTORY).contains(&self.history)
            && self.low_db.is_finite()
            && self.high_db.is_finite()
            && self.low_db < self.high_db
            && (0.0..=1.0).contains(&self.floor)
    }
}

/// The power history, with the per-frame constants of a [`FrameOnset`].
///
/// Aligned to 8 bytes: as a 52-byte field it shifted the `Locator`'s layout so that the
/// default pipeline (weighting off) cost 365 more instructions per hop on the Cortex-M4F
/// (`scripts/cost.sh`: 149 450 against 149 073 aligned).
#[derive(Debug, Clone)]
#[repr(align(8))]
pub struct FrameOnsetState {
    powers: [f32; MAX_ONSET_HISTORY],
    next: usize,
    history: usize,
    /// From the settings' `low_db` to their `high_db`.
    ramp: PowerRamp,
    floor: f32,
}

impl FrameOnsetState {
    /// A state for `onset` with no history yet (settings assumed valid: see
    /// [`FrameOnset::is_valid`]; a history outside 1…[`MAX_ONSET_HISTORY`] is clamped).
    #[must_use]
    pub fn new(onset: &FrameOnset) -> Self {
        Self {
            powers: [0.0; MAX_ONSET_HISTORY],
            next: 0,
            history: onset.history.clamp(1, MAX_ONSET_HISTORY),
            ramp: PowerRamp::from_db(onset.low_db, onset.high_db),
            floor: onset.floor,
        }
    }

    /// A state that weighs nothing (placeholder until [`FrameOnsetState::new`]).
    #[must_use]
    pub const fn idle() -> Self {
        Self {
            powers: [0.0; MAX_ONSET_HISTORY],
            next: 0,
            history: 1,
            ramp: PowerRamp::UNIT,
            floor: 1.0,
        }
    }

    /// Takes a frame's mean-square power and returns its weight in [floor, 1]. A frame without
    /// positive finite power enters the history as 0 and gets the floor; so does any frame while
    /// the history holds no positive power (the first frames, or after digital silence).
    pub fn update(&mut self, power: f32) -> f32 {
        let mut before = 0.0f32;
        for p in &self.powers[..self.history] {
            before = before.max(*p);
        }
        let ok = power > 0.0 && power.is_finite();
        self.powers[self.next] = if ok { power } else { 0.0 };
        self.next = if self.next + 1 >= self.history {
            0
        } else {
            self.next + 1
        };
        if !ok || !(before > 0.0) {
            return self.floor;
        }
        self.floor + (1.0 - self.floor) * self.ramp.at(power / before)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ON: FrameOnset = FrameOnset {
        enabled: true,
        history: 3,
        low_db: -1.0,
        high_db: 3.0,
        floor: 0.25,
    };

    use crate::power_ramp::power_ratio_from_db as db;

    #[test]
    fn rising_frames_weigh_more_than_decaying_ones() {
        let mut s = FrameOnsetState::new(&ON);
        // No history: the floor.
        assert_eq!(s.update(1.0), 0.25);
        // 3 dB above the largest of the history: full weight.
        assert!((s.update(db(3.0)) - 1.0).abs() < 1e-6);
        // 4 dB below the largest (the frame just before): the floor.
        assert_eq!(s.update(db(-1.0)), 0.25);
        // Half-way (in power ratio) between −1 and 3 dB above the largest of the last three:
        // half-way.
        let p = db(3.0) * 0.5 * (db(-1.0) + db(3.0));
        let w = s.update(p);
        assert!((w - (0.25 + 0.75 * 0.5)).abs() < 1e-5, "{w}");
    }

    #[test]
    fn the_history_is_as_long_as_configured() {
        let mut s = FrameOnsetState::new(&FrameOnset { history: 2, ..ON });
        s.update(100.0);
        s.update(1.0);
        s.update(1.0);
        // 100 has left the two-frame history: 1 → 2 is a 3 dB rise.
        assert!((s.update(db(3.0)) - 1.0).abs() < 1e-5);
    }

    #[test]
    fn bad_power_gets_the_floor_and_no_panic() {
        let mut s = FrameOnsetState::new(&ON);
        s.update(1.0);
        for p in [f32::NAN, f32::INFINITY, -1.0, 0.0, f32::NEG_INFINITY] {
            assert_eq!(s.update(p), 0.25);
        }
        // Only zeros in the history now: the floor, then rises are measured again.
        assert_eq!(s.update(1.0), 0.25);
        assert!((s.update(db(3.0)) - 1.0).abs() < 1e-6);
        assert!(!FrameOnset { history: 0, ..ON }.is_valid());
        assert!(!FrameOnset { low_db: 3.0, ..ON }.is_valid());
        assert!(!FrameOnset { floor: 1.5, ..ON }.is_valid());
        assert!(ON.is_valid());
    }
}
