//! Sample frames from a 4-slot TDM receive stream (one 4-channel ADC on one serial audio bus).
//!
//! A TDM frame carries one sample of every channel in consecutive 32-bit slots, slot 0 first
//! after the frame sync. The receiver (the STM32 SAI with 32-bit data in 32-bit slots) delivers
//! one 32-bit word per slot, MSB first on the wire, so a DMA ring holds [`SLOTS`] words per sample
//! frame. The ADC's 24-bit code is left-aligned in the word; the 8 bits below it are ignored, so
//! the conversion is exact and equal to the I2S boards' ([`crate::sample`]).
//!
//! Which word is which channel follows from the frame sync alone: the receiver starts storing at
//! slot 0 of a frame, and a ring whose length is a whole number of frames keeps slot `k mod 4` at
//! ring position `k` for as long as no word is lost. A word lost (a FIFO overrun, a ring lapped by
//! the DMA) shifts every later slot; [`deinterleave`] of such a stream puts channels in the wrong
//! place, which is why the board restarts the receiver at a frame sync then
//! ([`restart_at_frame_sync`], through the [`TdmReceiver`] trait; tested here on a model of the
//! receiver and embassy's DMA ring reader).

use crate::sample::code_to_f32;
use cma_core::CHANNELS;

/// Slots per TDM frame (one per capsule).
pub const SLOTS: usize = 4;
/// Bits per slot.
pub const SLOT_BITS: u32 = 32;
/// Bit clocks per TDM frame (4 slots of 32 bits).
pub const FRAME_BITS: u32 = SLOTS as u32 * SLOT_BITS;

// One slot per channel of the core.
const _: () = assert!(SLOTS == CHANNELS);

/// The capsule carried by each slot: slot `s` holds channel `SLOT_CHANNEL[s]` of the core's order
/// (omni, cardioid 0°, 120°, 240°). The ADC maps its inputs 1–4 to slots 0–3.
pub const SLOT_CHANNEL: [usize; SLOTS] = [0, 1, 2, 3];

// Every channel appears in exactly one slot.
const _: () = {
    let mut seen = [false; CHANNELS];
    let mut s = 0;
    while s < SLOTS {
        assert!(SLOT_CHANNEL[s] < CHANNELS && !seen[SLOT_CHANNEL[s]]);
        seen[SLOT_CHANNEL[s]] = true;
        s += 1;
    }
};

/// The signed code of one slot word, left-aligned in 32 bits: the 24-bit sample times 256 (the
/// word's low byte, below the 24-bit code, is dropped).
#[inline]
#[must_use]
pub const fn code_from_slot(word: u32) -> i32 {
    (word & 0xFFFF_FF00) as i32
}

/// Writes sample frames, full scale ±1, in the core's channel order from TDM slot words that
/// start at slot 0 of a frame ([`SLOTS`] words per frame, slot `s` → channel [`SLOT_CHANNEL`]`[s]`).
///
/// Writes `min(out.len(), words.len() / SLOTS)` frames and returns that count; a trailing partial
/// frame of `words` is not used.
pub fn deinterleave(words: &[u32], out: &mut [[f32; CHANNELS]]) -> usize {
    let mut n = 0;
    for (frame, slots) in out.iter_mut().zip(words.chunks_exact(SLOTS)) {
        for (s, &w) in slots.iter().enumerate() {
            frame[SLOT_CHANNEL[s]] = code_to_f32(code_from_slot(w));
        }
        n += 1;
    }
    n
}

/// The TLV320ADC5140's ASI_STS register (page 0, address 0x15; TI data sheet SBAS890, register
/// map): bits 7–4 FS_RATE_STS, the sample rate its clock detection found (1: 14.7 or 16 kHz, 3:
/// 29.4 or 32 kHz, 15: none/invalid), bits 3–0 FS_RATIO_STS, the BCLK-to-FSYNC ratio (6: 128,
/// 15: invalid); 0xFF after reset.
pub const ADC_ASI_STS: u8 = 0x15;

/// The sample rate class and BCLK ratio the TLV320ADC5140 detects on this board's bus: 16 kHz
/// ([`ADC_FS_RATE_16K`]) and 128 bit clocks per frame ([`ADC_FS_RATIO_128`]).
pub const ADC_EXPECTED_ASI_STS: u8 = (ADC_FS_RATE_16K << 4) | ADC_FS_RATIO_128;
/// ASI_STS.FS_RATE_STS for 14.7 kHz or 16 kHz.
pub const ADC_FS_RATE_16K: u8 = 1;
/// ASI_STS.FS_RATIO_STS for 128 bit clocks per frame.
pub const ADC_FS_RATIO_128: u8 = 6;

/// The ASI_STS fields: `(FS_RATE_STS, FS_RATIO_STS)`.
#[must_use]
pub const fn asi_status_fields(asi_sts: u8) -> (u8, u8) {
    (asi_sts >> 4, asi_sts & 0x0F)
}

/// Sample frames per second the ASI_STS FS_RATE_STS code stands for (the 48 kHz family; the
/// 44.1 kHz family shares the codes); `None` for a reserved or invalid code.
#[must_use]
pub const fn asi_rate_hz(fs_rate_sts: u8) -> Option<u32> {
    match fs_rate_sts {
        0 => Some(8_000),
        1 => Some(16_000),
        2 => Some(24_000),
        3 => Some(32_000),
        4 => Some(48_000),
        5 => Some(96_000),
        6 => Some(192_000),
        7 => Some(384_000),
        8 => Some(768_000),
        _ => None,
    }
}

/// The BCLK-to-FSYNC ratio the ASI_STS FS_RATIO_STS code stands for; `None` for a reserved or
/// invalid code.
#[must_use]
pub const fn asi_ratio(fs_ratio_sts: u8) -> Option<u32> {
    const RATIOS: [u32; 13] = [16, 24, 32, 48, 64, 96, 128, 192, 256, 384, 512, 1024, 2048];
    if (fs_ratio_sts as usize) < RATIOS.len() {
        Some(RATIOS[fs_ratio_sts as usize])
    } else {
        None
    }
}

/// What restarting a TDM receiver at a frame sync needs from the receiver and its DMA ring
/// ([`restart_at_frame_sync`]). The DMA keeps running in circular mode throughout; the ring's
/// reader is the HAL's, which after a lapped ring continues at the DMA position of that moment.
pub trait TdmReceiver {
    /// Clears the receiver's enable bit and waits until it reads 0 (the frame under way is
    /// completed first); `false` if it does not in time.
    fn stop(&mut self) -> bool;
    /// Discards what the receiver's FIFO holds (those words never reach the ring).
    fn flush_fifo(&mut self);
    /// One read of a block from the ring that does not wait: `Ready(Ok)` a whole block was read,
    /// `Pending` the ring held less (and all of it was taken), `Ready(Err)` the ring was lapped
    /// (the reader then stands at the DMA position).
    fn read_block_now(&mut self) -> core::task::Poll<Result<(), ()>>;
    /// Clears the receiver's error flags.
    fn clear_flags(&mut self);
    /// Sets the enable bit: a master receiver starts a new frame, slot 0 first. `false` if the
    /// bit does not read back as set.
    fn start(&mut self) -> bool;
}

/// Restarts `rx` so that its ring continues at slot 0 of a frame: stop the receiver (the DMA then
/// gets no more requests and stops at some ring position *q*), flush its FIFO, drain the ring
/// (at most `max_blocks` + 1 reads; the first that does not complete leaves the reader at *q*),
/// clear the flags and start the receiver, whose slot 0 the DMA writes at *q*. Returns `false`
/// when the receiver does not stop or does not start.
pub fn restart_at_frame_sync<R: TdmReceiver>(rx: &mut R, max_blocks: usize) -> bool {
    if !rx.stop() {
        return false;
    }
    rx.flush_fifo();
    for _ in 0..=max_blocks {
        if !matches!(rx.read_block_now(), core::task::Poll::Ready(Ok(()))) {
            break;
        }
    }
    rx.clear_flags();
    rx.start()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::{vec, vec::Vec};

    /// The slot word a 24-bit ADC sends for `code24`, with `junk` in the bits below the code.
    fn word(code24: i32, junk: u8) -> u32 {
        ((code24 << 8) as u32) | u32::from(junk)
    }

    /// A distinct 24-bit code per frame and channel (so a frame or slot mix-up shows).
    fn code(frame: usize, channel: usize) -> i32 {
        let v = (frame as i32 * 7919 + channel as i32 * 104_729 + 0x2468) & 0xFF_FFFF;
        v - 0x80_0000
    }

    /// The TDM word stream of `frames` frames as the ADC sends it (slot `s` carries input `s`).
    fn stream(frames: usize) -> Vec<u32> {
        (0..frames)
            .flat_map(|f| {
                (0..SLOTS).map(move |s| word(code(f, SLOT_CHANNEL[s]), (f * 4 + s) as u8))
            })
            .collect()
    }

    #[test]
    fn slot_words_convert_exactly_with_sign_and_full_scale() {
        for c in [0, 1, -1, 0x7F_FFFF, -0x80_0000, 0x12_3456, -0x12_3456] {
            assert_eq!(code_from_slot(word(c, 0xA5)), c << 8);
            assert_eq!(
                code_to_f32(code_from_slot(word(c, 0xFF))),
                c as f32 / 8_388_608.0
            );
        }
        assert_eq!(code_to_f32(code_from_slot(word(-0x80_0000, 0x7F))), -1.0);
        // The same value as the I2S boards' conversion of the same 24-bit code.
        let c = -0x12_3456;
        let v = (c << 8) as u32;
        let halves = ((v >> 16) as u16, (v & 0xFFFF) as u16);
        assert_eq!(
            code_from_slot(word(c, 0x3C)),
            crate::sample::code_from_halfwords(halves.0, halves.1)
        );
    }

    #[test]
    fn adc_status_decodes_the_rate_and_ratio_of_this_bus() {
        let (rate, ratio) = asi_status_fields(ADC_EXPECTED_ASI_STS);
        assert_eq!(asi_rate_hz(rate), Some(crate::board_api::SAMPLE_RATE_HZ));
        assert_eq!(asi_ratio(ratio), Some(FRAME_BITS));
        assert_eq!(ADC_EXPECTED_ASI_STS, 0x16);
        // After reset, or without clocks: both invalid.
        assert_eq!(asi_status_fields(0xFF), (15, 15));
        assert_eq!((asi_rate_hz(15), asi_ratio(15)), (None, None));
        // The code for a 32 kHz bus (the SAI with the MCKDIV field at 3).
        assert_eq!(asi_rate_hz(asi_status_fields(0x36).0), Some(32_000));
    }

    #[test]
    fn frames_come_out_in_core_channel_order() {
        let words = stream(40);
        let mut out = vec![[0.0f32; CHANNELS]; 40];
        assert_eq!(deinterleave(&words, &mut out), 40);
        for (f, frame) in out.iter().enumerate() {
            for (ch, &v) in frame.iter().enumerate() {
                assert_eq!(
                    v,
                    code(f, ch) as f32 / 8_388_608.0,
                    "frame {f} channel {ch}"
                );
            }
        }
    }

    #[test]
    fn short_input_and_partial_frames_are_not_used() {
        let words = stream(3);
        let mut out = vec![[9.0f32; CHANNELS]; 5];
        // 2 whole frames and 3 words of the third.
        assert_eq!(deinterleave(&words[..11], &mut out), 2);
        assert_eq!(out[2], [9.0; CHANNELS]);
        let mut one = [[0.0f32; CHANNELS]; 1];
        assert_eq!(deinterleave(&words, &mut one), 1);
        assert_eq!(one[0][3], code(0, 3) as f32 / 8_388_608.0);
    }

    #[test]
    fn a_stream_not_starting_at_slot_0_puts_channels_in_the_wrong_place() {
        // Why a lost word needs a restart at the frame sync: a ring read from any position but a
        // frame start rotates the channels of every frame that follows.
        let words = stream(20);
        for start in 1..SLOTS {
            let mut out = vec![[0.0f32; CHANNELS]; 16];
            deinterleave(&words[start..], &mut out);
            for (f, frame) in out.iter().enumerate() {
                for (ch, &v) in frame.iter().enumerate() {
                    let want = code(f, ch) as f32 / 8_388_608.0;
                    assert_ne!(v, want, "from slot {start}: frame {f} channel {ch}");
                }
            }
        }
    }

    /// A model of the receiver and its ring for [`restart_at_frame_sync`]: a master TDM receiver
    /// (frame counter, slot within the frame, a FIFO of `fifo` words that a flush discards), a
    /// circular DMA of `cap` words that writes whenever the receiver has a word, and a reader with
    /// the semantics of embassy-stm32's `ReadableDmaRingBuffer` (a lapped ring → error and the
    /// reader jumps to the DMA position; a short ring → what there is is taken, then pending).
    #[derive(Clone)]
    struct Model {
        cap: usize,
        ring: Vec<u32>,
        written: usize,
        read: usize,
        running: bool,
        frame: usize,
        slot: usize,
        fifo: Vec<u32>,
        block: usize,
        out: Vec<u32>,
    }

    impl Model {
        fn new(cap: usize, block: usize) -> Self {
            Self {
                cap,
                ring: vec![0; cap],
                written: 0,
                read: 0,
                running: false,
                frame: 0,
                slot: 0,
                fifo: Vec::new(),
                block,
                out: Vec::new(),
            }
        }

        /// The receiver shifts in `n` slots (kept in the FIFO, `hold` of them not yet moved by
        /// the DMA), the DMA moves the rest to the ring.
        fn run(&mut self, n: usize, hold: usize) {
            for _ in 0..n {
                if !self.running {
                    break;
                }
                self.fifo
                    .push(word(code(self.frame, SLOT_CHANNEL[self.slot]), 0x5A));
                self.slot += 1;
                if self.slot == SLOTS {
                    self.slot = 0;
                    self.frame += 1;
                }
            }
            while self.fifo.len() > hold {
                let w = self.fifo.remove(0);
                self.ring[self.written % self.cap] = w;
                self.written += 1;
            }
        }

        /// The HAL's blocking read of one block (`None`: overrun).
        fn read_block(&mut self) -> Option<Vec<u32>> {
            match self.read_block_now() {
                Poll::Ready(Ok(())) => Some(self.out.clone()),
                Poll::Ready(Err(())) => None,
                Poll::Pending => panic!("the test feeds enough before reading"),
            }
        }
    }

    use core::task::Poll;

    impl TdmReceiver for Model {
        fn stop(&mut self) -> bool {
            // The frame under way is completed (the DMA stays as far behind as it was), then the
            // receiver stops.
            if self.running && self.slot != 0 {
                let hold = self.fifo.len();
                self.run(SLOTS - self.slot, hold);
            }
            self.running = false;
            true
        }

        fn flush_fifo(&mut self) {
            self.fifo.clear();
        }

        fn read_block_now(&mut self) -> Poll<Result<(), ()>> {
            let available = self.written - self.read;
            if available > self.cap {
                self.read = self.written;
                return Poll::Ready(Err(()));
            }
            // A read that does not complete is dropped with what it took.
            let n = available.min(self.block);
            self.out = (0..n)
                .map(|i| self.ring[(self.read + i) % self.cap])
                .collect();
            self.read += n;
            if n == self.block {
                Poll::Ready(Ok(()))
            } else {
                Poll::Pending
            }
        }

        fn clear_flags(&mut self) {}

        fn start(&mut self) -> bool {
            self.running = true;
            // A master starts a new frame, slot 0 first.
            if self.slot != 0 {
                self.slot = 0;
                self.frame += 1;
            }
            true
        }
    }

    /// Whether every frame of `block` holds one frame's samples in channel order.
    fn in_channel_order(block: &[u32]) -> bool {
        let mut out = vec![[0.0f32; CHANNELS]; block.len() / SLOTS];
        deinterleave(block, &mut out);
        out.iter().all(|frame| {
            (0..4096).any(|f| (0..CHANNELS).all(|ch| frame[ch] == code(f, ch) as f32 / 8_388_608.0))
        })
    }

    #[test]
    fn a_restart_after_a_lapped_ring_continues_at_slot_0_in_channel_order() {
        const CAP: usize = 64;
        const BLOCK: usize = 16;
        // Lap the ring by every word count of a frame and more, with the DMA behind the receiver
        // by 0..3 words at the stop; the restart must bring every later block back in order.
        for (lap, extra) in (1..=9).flat_map(|l| (0..6).map(move |e| (l, e))) {
            for hold in 0..SLOTS {
                let mut m = Model::new(CAP, BLOCK);
                m.start();
                m.run(2 * BLOCK, 0);
                assert!(m.read_block().is_some() && in_channel_order(&m.out));
                // The reader falls behind by more than the ring: overrun, reader at the DMA.
                m.run(CAP + BLOCK + lap, hold);
                assert!(m.read_block().is_none(), "lap {lap}");
                if !m.read.is_multiple_of(SLOTS) {
                    // Without a restart, the next block starts mid-frame.
                    let mut probe = m.clone();
                    probe.run(BLOCK, 0);
                    assert!(probe.read_block().is_some_and(|b| !in_channel_order(&b)));
                }
                // The DMA goes on between the overrun and the restart.
                m.run(extra, hold);
                assert!(restart_at_frame_sync(&mut m, CAP / BLOCK));
                for _ in 0..12 {
                    m.run(BLOCK, hold);
                    m.run(0, 0);
                    let b = m.read_block().expect("no overrun after the restart");
                    assert!(
                        in_channel_order(&b),
                        "lap {lap}, extra {extra}, hold {hold}"
                    );
                }
            }
        }
    }
}
