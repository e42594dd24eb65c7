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
//! * **channel side**: the peripheral reports the channel of the halfword it received last
//!   (SPI_SR.CHSIDE). [`channel_matches`] compares it with the channel a frame-aligned stream has
//!   at that position: a stream off by a channel (left ↔ right) fails at every position, one off by
//!   a halfword at every other position, and the board restarts it.
//!
//! The data cannot show a misalignment by itself: the low byte of a sample's second halfword
//! (the 8 bits after the 24-bit code) is not defined by the peripheral (the reference manual's
//! 24-bit reception figure: "8 LSBs have no meaning and can be anything"), and both channels of an
//! ADC carry the same kind of signal.

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

/// The streams cannot be aligned: the receivers must be restarted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Misaligned {
    /// A position's phase is not within a frame (≥ 4).
    BadPhase,
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

/// Whether `right` (SPI_SR.CHSIDE after the DMA moved the `received`-th halfword of a stream) is
/// the channel of that halfword in a stream that started at a frame start: halfword `k` (from 0)
/// is left for `k mod 4` ∈ {0, 1} and right for {2, 3}. `received` may be counted modulo any
/// multiple of 4 (a ring's length); 0 stands for a multiple of 4 ≥ 4.
#[must_use]
pub const fn channel_matches(received: usize, right: bool) -> bool {
    let last = (received + WORDS_PER_STEREO_FRAME - 1) % WORDS_PER_STEREO_FRAME;
    (last >= 2) == right
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sample::interleave_stereo_pairs;
    use cma_core::CHANNELS;
    use std::{vec, vec::Vec};

    /// The halfwords of 24-bit `code` in a 32-bit slot.
    fn halves(code24: i32) -> [u16; 2] {
        let v = (code24 << 8) as u32;
        [(v >> 16) as u16, (v & 0xFFFF) as u16]
    }

    /// A distinct 24-bit code per frame and channel (so a frame or channel mix-up shows).
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

    /// The channel of wire halfword `k` of a stream (left for the first two of each frame).
    fn right_at(k: usize) -> bool {
        k % 4 >= 2
    }

    #[test]
    fn channel_side_finds_streams_off_by_a_channel_or_a_halfword() {
        for start in 0..8 {
            // A ring that began `start` halfwords into the stream (the `received`-th halfword of
            // the ring is wire halfword `start + received - 1`).
            let matches: Vec<bool> = (1..64)
                .map(|received| channel_matches(received, right_at(start + received - 1)))
                .collect();
            match start % 4 {
                0 => assert!(matches.iter().all(|&m| m), "aligned from {start}"),
                2 => assert!(matches.iter().all(|&m| !m), "left ↔ right from {start}"),
                _ => assert!(
                    matches.windows(2).all(|w| !(w[0] && w[1])),
                    "a halfword off from {start}: found at least every other position"
                ),
            }
        }
        // Counted modulo a ring's length.
        assert!(channel_matches(0, true) && channel_matches(1024, true));
        assert!(channel_matches(1025, false));
    }
}
