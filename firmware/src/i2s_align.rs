//! Frame and channel alignment of the two I2S receive streams after a (re)start.
//!
//! Each ADC's DMA ring receives halfwords: per stereo sample frame left high, left low, right
//! high, right low ([`crate::sample`]). Where a stream's first halfword falls in the frame depends
//! on when the receiver started; the two streams may also start frames apart. Two facts pin the
//! streams down:
//!
//! * **positions**: at one instant, each stream's DMA has written `received` halfwords, and the
//!   frame on the wires (the same for both ADCs: they share BCK and WS) is `phase` halfwords in.
//!   [`align`] turns the two positions into the halfwords each stream must discard so that both
//!   continue at the start of the same frame;
//! * **padding**: with 24-bit data in 32-bit slots the peripheral delivers each sample's second
//!   halfword with its low byte 0. [`check_padding`] finds a stream that slipped by a halfword (a
//!   low byte that should be padding is not 0), which the board answers with a restart.
//!
//! A swap of left and right by a whole channel slot keeps the padding in place and cannot be seen
//! in the data; it is excluded by the positions, which must put both streams at the same phase.

use crate::sample::WORDS_PER_STEREO_FRAME;

/// Where one receive stream stands at one instant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StreamPosition {
    /// Halfwords the DMA has written since the stream started.
    pub received: usize,
    /// Halfwords of the current frame on the wires already received (0 = at a frame start, 0..4).
    pub phase: usize,
}

impl StreamPosition {
    /// A stream that started at a frame start and has received `received` halfwords since (the I2S
    /// master, which starts a frame when enabled, and a slave enabled while WS selects the right
    /// channel, which starts at the next left channel).
    #[must_use]
    pub const fn from_frame_start(received: usize) -> Self {
        Self {
            received,
            phase: received % WORDS_PER_STEREO_FRAME,
        }
    }
}

/// The streams cannot be aligned, or slipped: the receivers must be restarted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Misaligned {
    /// A position's phase is not within a frame (≥ 4).
    BadPhase,
    /// A padding byte (the low byte of a sample's second halfword) is not 0 at this halfword of
    /// the checked block: the stream is a halfword off.
    Padding {
        /// Index of the halfword in the block.
        at: usize,
    },
}

/// Halfwords to discard from streams `a` and `b` (in that order) so that both continue at the
/// start of the same frame: the first frame that starts in both buffers at or after their first
/// halfword.
///
/// `a` and `b` must be taken at the same instant (the frame on the wires is the same for both);
/// each stream may have started anywhere in a frame, mid-word included.
pub fn align(a: StreamPosition, b: StreamPosition) -> Result<(usize, usize), Misaligned> {
    const W: isize = WORDS_PER_STEREO_FRAME as isize;
    if a.phase >= WORDS_PER_STEREO_FRAME || b.phase >= WORDS_PER_STEREO_FRAME {
        return Err(Misaligned::BadPhase);
    }
    // Index in each buffer where the current frame started (negative: before the buffer).
    let start_a = a.received as isize - a.phase as isize;
    let start_b = b.received as isize - b.phase as isize;
    // The earliest frame, counted back from the current one, that starts inside both buffers.
    let back = start_a.div_euclid(W).min(start_b.div_euclid(W));
    Ok(((start_a - back * W) as usize, (start_b - back * W) as usize))
}

/// Checks the padding of a block that should start at a frame start: the low byte of every
/// sample's second halfword must be 0.
pub fn check_padding(words: &[u16]) -> Result<(), Misaligned> {
    match words
        .iter()
        .enumerate()
        .skip(1)
        .step_by(2)
        .find(|(_, w)| **w & 0x00FF != 0)
    {
        Some((at, _)) => Err(Misaligned::Padding { at }),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::interleave_stereo_pairs;
    use cma_core::CHANNELS;
    use std::{vec, vec::Vec};

    /// The halfwords of 24-bit `code` in a 32-bit slot (second halfword's low byte 0).
    fn halves(code24: i32) -> [u16; 2] {
        let v = (code24 << 8) as u32;
        [(v >> 16) as u16, (v & 0xFFFF) as u16]
    }

    /// A distinct 24-bit code per frame and channel (low bytes non-zero, so a slip shows).
    fn code(frame: usize, channel: usize) -> i32 {
        let v = (frame as i32 * 7919 + channel as i32 * 104_729 + 0x1357) & 0x7F_FFFF;
        v - 0x40_0000
    }

    /// The halfword stream of ADC `adc` (0: channels 0, 1; 1: channels 2, 3) over `frames` frames.
    fn stream(adc: usize, frames: usize) -> Vec<u16> {
        let mut v = Vec::new();
        for f in 0..frames {
            for ch in [2 * adc, 2 * adc + 1] {
                v.extend_from_slice(&halves(code(f, ch)));
            }
        }
        v
    }

    /// The DMA buffer of a receiver that started `start` halfwords into the stream (any
    /// halfword: mid-frame and mid-word) and the stream's position when `now` halfwords of the
    /// stream had passed.
    fn dma(adc: usize, start: usize, now: usize) -> (Vec<u16>, StreamPosition) {
        let s = stream(adc, 200);
        let buf = s[start..now].to_vec();
        let pos = StreamPosition {
            received: now - start,
            phase: now % WORDS_PER_STEREO_FRAME,
        };
        (buf, pos)
    }

    #[test]
    fn streams_starting_anywhere_continue_at_the_same_frame_in_channel_order() {
        for start_a in 0..12 {
            for start_b in 0..12 {
                for now in [start_a.max(start_b) + 9, 150, 151, 153] {
                    let (a, pa) = dma(0, start_a, now);
                    let (b, pb) = dma(1, start_b, now);
                    let (skip_a, skip_b) = align(pa, pb).unwrap();
                    // Both continue at the first frame that starts in both buffers.
                    let first = start_a.max(start_b).div_ceil(4);
                    assert_eq!(start_a + skip_a, 4 * first, "a from {start_a}");
                    assert_eq!(start_b + skip_b, 4 * first, "b from {start_b}");
                    let (a, b) = (&a[skip_a..], &b[skip_b..]);
                    check_padding(a).unwrap();
                    check_padding(b).unwrap();
                    let n = a.len().min(b.len()) / 4;
                    let mut out = vec![[0.0f32; CHANNELS]; n];
                    interleave_stereo_pairs(a, b, &mut out);
                    for (i, frame) in out.iter().enumerate() {
                        for ch in 0..CHANNELS {
                            let want = code(first + i, ch) as f32 / 8_388_608.0;
                            assert_eq!(frame[ch], want, "frame {i} channel {ch}");
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn master_and_armed_slave_positions() {
        // The master started at a frame start; the slave one frame later (armed during the
        // master's first right channel): 4 more halfwords of the master are discarded.
        let a = StreamPosition::from_frame_start(4 * 10 + 3);
        let b = StreamPosition::from_frame_start(4 * 9 + 3);
        assert_eq!(align(a, b), Ok((4, 0)));
        // A slave that started on a right channel: at the same instant its count is two halfwords
        // off the frame grid; its first two halfwords and two more frames of the master go.
        let b = StreamPosition {
            received: 4 * 9 + 1,
            phase: 3,
        };
        assert_eq!(align(a, b), Ok((8, 2)));
        assert_eq!(
            align(
                StreamPosition {
                    received: 5,
                    phase: 4
                },
                b
            ),
            Err(Misaligned::BadPhase)
        );
    }

    #[test]
    fn a_halfword_slip_is_detected() {
        let s = stream(0, 50);
        check_padding(&s).unwrap();
        for slip in [1, 3] {
            let e = check_padding(&s[slip..]).unwrap_err();
            assert!(matches!(e, Misaligned::Padding { at } if at % 2 == 1));
        }
        // A whole-slot slip (left ↔ right) keeps the padding: only the positions exclude it.
        check_padding(&s[2..]).unwrap();
    }
}
