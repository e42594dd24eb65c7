//! Noise-floor gate of the frame reliability: a frame whose power does not stand out from the
//! tracked background carries no localization weight, however peaked its curve happens to be.
//!
//! Diffuse noise alone now and then gives a frame a curve with enough variance to pass the
//! reliability weighting, and before the first words such a frame is all the tracker has seen: it
//! captures the track. The floor follows the minimum of the frame power (it drops at once and
//! rises by at most [`NoiseGate::rise_db_per_s`]), and the gate ramps b linearly in power from 0 at
//! [`NoiseGate::open_db`] above the floor to 1 at [`NoiseGate::full_db`].
//!
//! A recording, or a board's power-on, that starts inside a steady background opens with frames
//! whose power is still building up: a room's response to a source switched on with the recording
//! grows for about 0.11·RT60 (to within 1 dB of its steady power), so the first analysis frames sit
//! 2–4 dB below the background. A minimum started there keeps the floor that low for seconds (it
//! rises 1 dB/s), the background itself then opens the gate, and a fan or a loudspeaker captures the
//! track before the talker's first word. For the first [`START_UP_S`] the floor may therefore rise
//! by up to 1 dB a frame (`starting` in [`NoiseFloor::update`]): it follows a build-up, while a
//! talker, whose syllables rise faster, still opens the gate.

use crate::power_ramp::{power_ratio_from_db, PowerRamp};

/// Length of the floor's start-up, s: longer than a room's build-up to within 1 dB up to an RT60
/// of about 1.9 s, plus one analysis frame (see the module documentation).
pub const START_UP_S: f32 = 0.25;

/// The floor's largest rise per frame in its start-up: 1 dB (10^0.1), fast enough to follow a
/// room's build-up, slow enough that a talker's syllables stand out of it (and a talker speaking
/// from the first frame lifts it only until his first pause, where it drops at once).
const START_UP_RISE: f32 = 1.258_925_4;

/// Gate settings.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(deny_unknown_fields))]
pub struct NoiseGate {
    /// Whether the gate applies.
    pub enabled: bool,
    /// Largest rise of the floor, dB per second.
    pub rise_db_per_s: f32,
    /// Frame power above the floor (dB) where the gate starts to open.
    pub open_db: f32,
    /// Frame power above the floor (dB) where the gate is fully open.
    pub full_db: f32,
    /// Added to both while the stationary background is a directional source's (a fan, a
    /// projector, a loudspeaker; the background field's measure): a frame that barely stands out
    /// from such a background carries the source's direction, not merely none, and a tracker
    /// that follows it leaves the talker in his pauses.
    pub directional_db: f32,
}

impl NoiseGate {
    /// The gate off (b unchanged).
    pub const OFF: Self = Self {
        enabled: false,
        rise_db_per_s: 3.0,
        open_db: 1.0,
        full_db: 4.0,
        directional_db: 0.0,
    };

    /// Whether the settings are usable: finite, a non-negative rise, `open_db < full_db` and a
    /// directional shift of 0–20 dB.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.rise_db_per_s >= 0.0
            && self.rise_db_per_s.is_finite()
            && self.open_db.is_finite()
            && self.full_db.is_finite()
            && self.open_db < self.full_db
            && self.directional_db >= 0.0
            && self.directional_db <= 20.0
    }
}

/// The floor's state, with the per-frame constants of a [`NoiseGate`] at one frame rate.
#[derive(Debug, Clone, Copy)]
pub struct NoiseFloor {
    floor: f32,
    rise: f32,
    /// From the gate's `open_db` to its `full_db`.
    ramp: PowerRamp,
    /// 10^(−`directional_db`/10): a power ratio times this meets the ramp `directional_db` higher.
    directional: f32,
}

impl NoiseFloor {
    /// A floor for `gate` at `frames_per_s` analysis frames per second (no frame seen yet).
    #[must_use]
    pub fn new(gate: &NoiseGate, frames_per_s: f32) -> Self {
        Self {
            floor: f32::NAN,
            rise: power_ratio_from_db(gate.rise_db_per_s / frames_per_s),
            ramp: PowerRamp::from_db(gate.open_db, gate.full_db),
            directional: power_ratio_from_db(-gate.directional_db),
        }
    }

    /// A floor that gates nothing yet (placeholder until [`NoiseFloor::new`]).
    #[must_use]
    pub const fn idle() -> Self {
        Self {
            floor: f32::NAN,
            rise: 1.0,
            ramp: PowerRamp::UNIT,
            directional: 1.0,
        }
    }

    /// Sets the tracked floor to `floor` (NaN forgets it: the next frame with positive power
    /// starts it over).
    pub fn set(&mut self, floor: f32) {
        self.floor = floor;
    }

    /// The tracked floor (mean-square power; NaN before the first frame with positive power).
    #[must_use]
    pub fn floor(&self) -> f32 {
        self.floor
    }

    /// Takes a frame's mean-square power and returns its gate factor in [0, 1] (0 for a frame
    /// without positive finite power, which leaves the floor as it is); `directional`: the
    /// background is a directional source's ([`NoiseGate::directional_db`]); `starting`: the frame
    /// is in the floor's start-up ([`START_UP_S`]), where the floor rises by up to 1 dB a frame.
    pub fn update(&mut self, power: f32, directional: bool, starting: bool) -> f32 {
        if !(power > 0.0 && power.is_finite()) {
            return 0.0;
        }
        let rise = if starting { START_UP_RISE } else { self.rise };
        let risen = self.floor * rise;
        self.floor = if power < risen || !risen.is_finite() {
            power
        } else {
            risen
        };
        let shift = if directional { self.directional } else { 1.0 };
        self.ramp.at(power / self.floor * shift)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GATE: NoiseGate = NoiseGate {
        enabled: true,
        rise_db_per_s: 3.0,
        open_db: 1.0,
        full_db: 4.0,
        directional_db: 0.0,
    };

    #[test]
    fn background_is_gated_and_louder_frames_open_it() {
        let still = NoiseGate {
            rise_db_per_s: 0.0,
            ..GATE
        };
        let mut f = NoiseFloor::new(&still, 50.0);
        assert!(f.floor().is_nan());
        assert_eq!(f.update(1.0, false, false), 0.0);
        assert_eq!(f.floor(), 1.0);
        // 0.5 dB above the floor: closed; half-way (in power) between 1 and 4 dB: half open; 6 dB:
        // open.
        assert_eq!(f.update(1.122, false, false), 0.0);
        let mid = 0.5 * (libm::powf(10.0, 0.1) + libm::powf(10.0, 0.4));
        let g = f.update(mid, false, false);
        assert!((g - 0.5).abs() < 1e-5, "{g}");
        assert_eq!(f.update(4.0, false, false), 1.0);
        assert_eq!(f.floor(), 1.0);
        // The floor drops at once and rises 3 dB per second at most.
        let mut f = NoiseFloor::new(&GATE, 50.0);
        f.update(0.5, false, false);
        assert_eq!(f.floor(), 0.5);
        for _ in 0..50 {
            f.update(100.0, false, false);
        }
        let db = 10.0 * libm::log10f(f.floor() / 0.5);
        assert!((db - 3.0).abs() < 0.01, "{db}");
    }

    /// A background that builds up over its first frames (a source switched on with the
    /// recording, its room's response growing by 3 dB) is not taken for a talker once it is steady:
    /// the floor follows it through the start-up and the steady background stays gated; a minimum
    /// started from the first frame would be 3 dB low and open the gate for seconds. A talker 10 dB
    /// above the background opens the gate in the start-up too.
    #[test]
    fn a_background_building_up_at_start_is_not_a_talker() {
        let fps = 62.5;
        let start_up = (START_UP_S * fps) as usize;
        let ramp = |i: usize| libm::powf(10.0, 0.3 * (i.min(6) as f32) / 6.0);
        // The product's gate (core-nostd's default configuration).
        let gate = NoiseGate {
            rise_db_per_s: 1.0,
            open_db: 0.5,
            full_db: 2.0,
            ..GATE
        };
        for (with_start_up, want_open) in [(true, false), (false, true)] {
            let mut f = NoiseFloor::new(&gate, fps);
            let mut open = 0.0f32;
            for i in 0..start_up + 60 {
                let starting = with_start_up && i < start_up;
                let g = f.update(ramp(i), false, starting);
                if i >= start_up {
                    open = open.max(g);
                }
            }
            assert_eq!(
                open > 0.5,
                want_open,
                "start-up {with_start_up}: gate {open}"
            );
        }
        let mut f = NoiseFloor::new(&gate, fps);
        for i in 0..4 {
            f.update(ramp(i), false, true);
        }
        assert_eq!(f.update(20.0, false, true), 1.0);
    }

    #[test]
    fn bad_power_is_closed_and_does_not_move_the_floor() {
        let mut f = NoiseFloor::new(&GATE, 50.0);
        f.update(2.0, false, false);
        for p in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert_eq!(f.update(p, false, false), 0.0);
            assert_eq!(f.floor(), 2.0);
        }
        assert!(GATE.is_valid());
        assert!(!NoiseGate {
            full_db: 1.0,
            ..GATE
        }
        .is_valid());
        for bad in [-1.0, 21.0, f32::NAN] {
            assert!(!NoiseGate {
                directional_db: bad,
                ..GATE
            }
            .is_valid());
        }
    }

    /// Beside a directional source the gate opens `directional_db` higher: a frame 4 dB above the
    /// floor, open before, is closed; one more than 4 + 4 dB above is open.
    #[test]
    fn a_directional_background_opens_the_gate_higher() {
        let g = NoiseGate {
            rise_db_per_s: 0.0,
            directional_db: 4.0,
            ..GATE
        };
        let mut f = NoiseFloor::new(&g, 50.0);
        f.update(1.0, true, false);
        let db = |d: f32| libm::powf(10.0, d / 10.0);
        assert_eq!(f.update(db(4.0), false, false), 1.0);
        assert_eq!(f.update(db(4.0), true, false), 0.0);
        assert_eq!(f.update(db(8.5), true, false), 1.0);
        let mid = 0.5 * (db(5.0) + db(8.0));
        assert!((f.update(mid, true, false) - 0.5).abs() < 1e-5);
        // Off (0 dB): the same gate either way.
        let mut same = NoiseFloor::new(
            &NoiseGate {
                directional_db: 0.0,
                ..g
            },
            50.0,
        );
        same.update(1.0, false, false);
        assert_eq!(
            same.update(db(2.5), true, false),
            same.update(db(2.5), false, false)
        );
    }
}
