//! Masking of the ADCs' restart transient: after the board restarts the capture (at start and
//! after every overrun), the ADCs output zeros and then fade in, and these samples must not reach
//! the localizer as audio.
//!
//! PCM1808 (TI SLES177A), the F411 board's ADCs:
//! * "Clock-halt power-down and reset function": SCKI halted ≥ 4 µs resets the ADC; DOUT is zero
//!   until 1024 SCKI + 8960/fs after SCKI resumes (≈ 0.56 s at 16 kHz);
//! * "Synchronization with digital audio system": LRCK/SCKI out of step → zero data until 32/fs
//!   after resynchronization;
//! * "Fade-in and fade-out functions": after either, the output fades in over 48/fin (zero-cross
//!   detection), by force over 48/fs when no zero crossing comes within 8192/fs.
//!
//! The board's restart stops the I2S master, and with it BCK and LRCK (and MCK, the ADCs' SCKI,
//! if the master clock output stops with I2SE: to be checked on the bench), so either case may
//! follow. The TLV320ADC5140 (F446 board) mutes on a clock error and resumes; its ramp is not
//! documented here, so the same windows are used.
//!
//! [`RestartMask`] turns every sample frame into NaN (the core's input guard turns NaN into 0 and
//! flags every analysis frame it touches `NON_FINITE`: not used for estimates or
//! self-calibration) from a restart while any ADC outputs exact zeros, then for the longest fade-in
//! ([`FADE_IN_FRAMES`]); if an ADC shows no zeros within [`ZEROS_WAIT_FRAMES`] of the restart
//! (its clocks did not stop long enough to reset it) its masking ends there.

use cma_core::CHANNELS;

/// Frames masked after the zeros end: the forced fade-in, 8192/fs without a zero crossing plus
/// 48/fs (PCM1808 "Fade-in and fade-out functions").
pub const FADE_IN_FRAMES: u32 = 8192 + 48;
/// Frames after a restart in which the zeros must begin for the transient to be recognized
/// (the ADC resets 4 µs after its clocks stop; the zeros start at once): beyond this, an ADC that
/// kept delivering audio is taken as not disturbed.
pub const ZEROS_WAIT_FRAMES: u32 = 64;

/// One ADC's state after a restart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum AdcState {
    /// Delivering audio.
    Running,
    /// Restarted: waiting for its zeros (`seen`) or for their end; `left` frames before an ADC
    /// that showed none is taken as undisturbed.
    Restarted { seen: bool, left: u32 },
    /// Fading in: `left` frames to go.
    FadingIn { left: u32 },
}

/// The restart transient masks of `ADCS` ADCs, each delivering `CHANNELS / ADCS` consecutive
/// channels of a sample frame.
#[derive(Debug, Clone)]
pub struct RestartMask<const ADCS: usize> {
    adcs: [AdcState; ADCS],
}

impl<const ADCS: usize> Default for RestartMask<ADCS> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const ADCS: usize> RestartMask<ADCS> {
    const PER_ADC: usize = {
        assert!(ADCS > 0 && CHANNELS.is_multiple_of(ADCS));
        CHANNELS / ADCS
    };

    /// No ADC restarted.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            adcs: [AdcState::Running; ADCS],
        }
    }

    /// The capture was (re)started: every ADC may be in its transient.
    pub fn restarted(&mut self) {
        self.adcs = [AdcState::Restarted {
            seen: false,
            left: ZEROS_WAIT_FRAMES,
        }; ADCS];
    }

    /// Whether no ADC is masked.
    #[must_use]
    pub fn is_clear(&self) -> bool {
        self.adcs.iter().all(|&s| s == AdcState::Running)
    }

    /// Masks the frames of `block` (consecutive frames, as captured) that belong to a transient:
    /// all their samples become NaN. Returns the number of frames masked.
    pub fn apply(&mut self, block: &mut [[f32; CHANNELS]]) -> usize {
        if self.is_clear() {
            return 0;
        }
        let mut masked = 0;
        for frame in block.iter_mut() {
            let mut mask = false;
            for (adc, state) in self.adcs.iter_mut().enumerate() {
                let samples = &frame[adc * Self::PER_ADC..(adc + 1) * Self::PER_ADC];
                let zeros = samples.iter().all(|&v| v == 0.0);
                mask |= *state != AdcState::Running;
                *state = state.next(zeros);
            }
            if mask {
                *frame = [f32::NAN; CHANNELS];
                masked += 1;
            }
        }
        masked
    }
}

impl AdcState {
    /// The state after a frame that was all zeros (`zeros`) or not; the frame itself is masked
    /// when the state before it was not [`AdcState::Running`].
    const fn next(self, zeros: bool) -> Self {
        match self {
            AdcState::Running => AdcState::Running,
            AdcState::Restarted { .. } if zeros => AdcState::Restarted {
                seen: true,
                left: 0,
            },
            // The first frame after the zeros is the first of the fade-in.
            AdcState::Restarted { seen: true, .. } => AdcState::FadingIn {
                left: FADE_IN_FRAMES - 1,
            },
            AdcState::Restarted { seen: false, left } if left > 1 => AdcState::Restarted {
                seen: false,
                left: left - 1,
            },
            AdcState::Restarted { seen: false, .. } => AdcState::Running,
            AdcState::FadingIn { left } if left > 1 => AdcState::FadingIn { left: left - 1 },
            AdcState::FadingIn { .. } => AdcState::Running,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::{vec, vec::Vec};

    /// A block of `n` frames: ADC `adc`'s channels from `adc_value(frame)`.
    fn frames(n: usize, value: impl Fn(usize, usize) -> f32) -> Vec<[f32; CHANNELS]> {
        (0..n)
            .map(|f| core::array::from_fn(|ch| value(f, ch)))
            .collect()
    }

    fn masked(frame: &[f32; CHANNELS]) -> bool {
        frame.iter().all(|v| v.is_nan())
    }

    #[test]
    fn zeros_after_a_restart_and_the_fade_in_are_masked_then_audio_passes() {
        let mut m = RestartMask::<2>::new();
        m.restarted();
        // ADC 1 (channels 2, 3) outputs zeros for 8960 frames, ADC 0 for 32.
        let zeros_until = [32, 8960];
        let total = 8960 + FADE_IN_FRAMES as usize + 100;
        let mut block = frames(total, |f, ch| {
            if f < zeros_until[ch / 2] {
                0.0
            } else {
                0.01 * (1 + ch) as f32
            }
        });
        let n = m.apply(&mut block);
        let last_masked = 8960 + FADE_IN_FRAMES as usize;
        assert_eq!(n, last_masked);
        assert!(block[..last_masked].iter().all(masked));
        assert!(block[last_masked..].iter().all(|f| !masked(f)));
        assert!(m.is_clear());
    }

    #[test]
    fn an_adc_without_zeros_is_released_after_the_wait() {
        let mut m = RestartMask::<1>::new();
        m.restarted();
        let mut block = frames(200, |f, ch| 0.001 * (f + ch + 1) as f32);
        assert_eq!(m.apply(&mut block), ZEROS_WAIT_FRAMES as usize);
        assert!(block[ZEROS_WAIT_FRAMES as usize..]
            .iter()
            .all(|f| !masked(f)));
        // Without a restart nothing is touched, zeros included.
        let mut zeros = vec![[0.0f32; CHANNELS]; 10];
        assert_eq!(m.apply(&mut zeros), 0);
        assert!(zeros.iter().all(|f| *f == [0.0; CHANNELS]));
    }

    #[test]
    fn masking_spans_blocks_and_a_new_restart_starts_over() {
        let mut m = RestartMask::<2>::new();
        m.restarted();
        let mut zeros = vec![[0.0f32; CHANNELS]; 32];
        for _ in 0..10 {
            assert_eq!(m.apply(&mut zeros), 32);
        }
        let mut audio = frames(32, |_, _| 0.5);
        assert_eq!(m.apply(&mut audio), 32);
        // A restart during the fade-in: zeros again, then the whole fade-in again.
        m.restarted();
        let mut block = frames(
            FADE_IN_FRAMES as usize + 64,
            |f, _| if f < 40 { 0.0 } else { 0.5 },
        );
        assert_eq!(m.apply(&mut block), 40 + FADE_IN_FRAMES as usize);
    }
}
