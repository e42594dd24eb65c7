//! The frame's level: mean-square omni power, the silence flag and the gate every method scales its
//! confidence by (0 for silent or non-finite frames, the clipped-frame factor for clipped ones).

use crate::estimate::Flags;
use crate::{FRAME_LEN, HOP};

/// Level and gate of one analysis frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Level {
    /// Mean-square omni power.
    pub power: f32,
    /// Neither silent nor non-finite.
    pub usable: bool,
    /// Usable and not clipped.
    pub clean: bool,
    /// 0 for unusable frames, the clipped-frame confidence for clipped ones, else 1.
    pub gate: f32,
}

/// State of the level stage: the energy of the last frame's newer hop, which is the next frame's
/// older hop (50 % overlap), so only one hop is summed per frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameLevel {
    /// Frame index and omni energy of the newest hop of the last frame.
    last_hop_energy: (u32, f32),
}

impl Default for FrameLevel {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameLevel {
    /// No frame seen yet.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            last_hop_energy: (u32::MAX, 0.0),
        }
    }

    /// Mean-square power of `omni`, the omni channel of the frame with index `index`.
    pub fn power(&mut self, index: u32, omni: &[f32; FRAME_LEN]) -> f32 {
        let energy = |x: &[f32]| x.iter().map(|v| v * v).sum::<f32>();
        let (last, last_energy) = self.last_hop_energy;
        let older = if index > 0 && last == index - 1 {
            last_energy
        } else {
            energy(&omni[..FRAME_LEN - HOP])
        };
        let newer = energy(&omni[FRAME_LEN - HOP..]);
        self.last_hop_energy = (index, newer);
        (older + newer) / FRAME_LEN as f32
    }

    /// The level of the frame with index `index` and omni channel `omni`: marks it
    /// [`Flags::SILENT`] below `silence_power` and gates it by `flags` (`clipped_confidence` for a
    /// clipped frame).
    pub fn process(
        &mut self,
        index: u32,
        omni: &[f32; FRAME_LEN],
        silence_power: f32,
        clipped_confidence: f32,
        flags: &mut Flags,
    ) -> Level {
        let power = self.power(index, omni);
        if !(power >= silence_power) {
            flags.insert(Flags::SILENT);
        }
        let usable = !flags.contains(Flags::SILENT) && !flags.contains(Flags::NON_FINITE);
        let gate = if !usable {
            0.0
        } else if flags.contains(Flags::CLIPPED) {
            clipped_confidence
        } else {
            1.0
        };
        Level {
            power,
            usable,
            clean: usable && !flags.contains(Flags::CLIPPED),
            gate,
        }
    }
}
