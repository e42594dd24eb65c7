//! The capture of the STM32F411 board's two I2S receivers (SPI2 master, SPI3 slave on the
//! master's clocks), each emptied by a circular DMA stream into a ring that embassy-stm32's ring
//! reader reads: block reads, the health checks after each block, and the restart in step
//! after an overrun, written against [`I2sHardware`] (the board implements it with the PAC and
//! the HAL's reads; the tests with a model of the peripherals written from RM0383).
//!
//! # Why the restart goes through the registers
//!
//! embassy-stm32 0.6's `I2S::stop` switches the DMA stream's circular mode off, waits for the ring
//! to fill to its end and resets the reader at the stream's remaining count 0; `I2S::start` only
//! sets the stream's EN bit again. Circular mode is never restored, and the reader's position
//! (the ring's end) is ahead of the stream's (its start), so the first read after the restart fails
//! (`DmaUnsynced`), and the stream stops for good at the end of the next lap. [`I2sCapture`]
//! keeps every stream circular and restarts like this ([`I2sCapture::resync`]):
//!
//! 1. **switch-off** ([`stop_receivers`]), RM0383, SPI/I2S, I2S master mode and I2S slave mode, "Reception sequence": the slave's
//!    I2SE is cleared right after its last RXNE of a frame; the master's (24-bit data in 32-bit
//!    channels: "all other combinations") after the second-to-last RXNE and one bit clock, so it
//!    receives the last halfword of the frame and stops. With the DMA serving RXNE, "RXNE" is seen
//!    as the stream's NDTR counting down, and which halfword of the frame it was as SR.CHSIDE;
//! 2. **streams back to the ring's start** ([`reset_streams`]), RM0383, DMA, "Stream configuration
//!    procedure" and DMA_SxNDTR: EN cleared and read back as 0; the data register and SR read (clears OVR:
//!    "a read of SPI_DR then SPI_SR"; FRE: "cleared by a read of SPI_SR"); the stream's flags
//!    cleared ("before setting EN … the event flags … must be cleared"); NDTR written with the
//!    ring's length (writable only with EN = 0); the HAL's reader reset (`I2S::clear`: it takes
//!    its positions from NDTR, now the ring's start); EN set. CIRC is never touched, all this
//!    with interrupts masked (clearing EN sets TCIF, whose interrupt would count a lap);
//! 3. **restart in step** ([`restart_in_step`]): the master first (it begins a frame, left
//!    channel first, at ring position 0), then the slave while WS is high (STM32F4 errata: a
//!    slave in I2S Philips mode enabled while WS is low starts at once, out of step), which starts
//!    at the master's next left channel;
//! 4. **discard to a common frame** ([`discard_to_common_frame`]): both positions read at one
//!    instant, and what lies before the first frame both rings hold is read away
//!    ([`crate::i2s_align::align`]).
//!
//! After each block both receivers are checked ([`receiver_health`]): SR.OVR (a halfword was lost
//! in the peripheral), SR.FRE (the slave saw WS change at an unexpected moment, RM0383, I2S error flags:
//! it must be restarted) and SR.CHSIDE against the ring position
//! ([`crate::i2s_align::channel_matches`]).

use crate::i2s_align::{align, channel_matches, StreamPosition};
use crate::sample::WORDS_PER_STEREO_FRAME;

/// Sample frames per block the F411 board reads (2 ms at 16 kHz): the boards' one block size.
pub use crate::board_api::BLOCK_FRAMES;
/// Sample frames per DMA ring (8 ms at 16 kHz): how far the DSP task may lag behind.
pub use crate::board_api::RING_FRAMES;
/// Halfwords per block of one receiver.
pub const BLOCK_WORDS: usize = BLOCK_FRAMES * WORDS_PER_STEREO_FRAME;
/// Halfwords per DMA ring of one receiver.
pub const RING_WORDS: usize = RING_FRAMES * WORDS_PER_STEREO_FRAME;
/// Restarts tried in a row before [`ReadError::Stuck`].
pub const RESYNC_ATTEMPTS: u32 = 8;
/// Register polls before a level, a DMA move or a stop is given up on. ≥ 10 frames at 100 MHz
/// (a poll is a few bus cycles; a frame is 62.5 µs = 6250 cycles).
pub const POLLS: u32 = 20_000;
/// Polls of a stream's NDTR, with interrupts masked, for the next halfword (15.6 µs at 1.024 MHz
/// BCK ≈ 1560 cycles at 100 MHz): a few halfword times, so that a stalled stream does not hold
/// the interrupts off for long.
pub const MOVE_POLLS: u32 = 2_000;

/// One of the two receivers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Receiver {
    /// SPI2/I2S2, the master (generates MCK, CK, WS): ADC A.
    Master,
    /// SPI3/I2S3, the slave on the master's CK and WS: ADC B.
    Slave,
}

impl Receiver {
    /// Both receivers, the master first.
    pub const BOTH: [Receiver; 2] = [Receiver::Master, Receiver::Slave];
}

/// One read of SPI_SR (the read clears FRE; OVR is cleared by a read of DR then SR).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SpiStatus {
    /// OVR: a halfword came in while the last one was still unread.
    pub overrun: bool,
    /// FRE: WS changed at an unexpected moment (slave mode).
    pub frame_error: bool,
    /// CHSIDE: the last halfword received was of the right channel.
    pub right: bool,
}

/// A ring read that did not deliver its halfwords.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum RingError {
    /// The DMA lapped the reader (or the reader's positions did not fit the stream's): the
    /// HAL's reader has reset itself to the stream's position.
    Overrun,
    /// Nothing came in time: the stream or the peripheral has stopped.
    Timeout,
}

/// Why a block was not delivered.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum Fault {
    /// A ring read failed ([`RingError`]).
    Ring(Receiver, RingError),
    /// SR.OVR: the peripheral lost a halfword.
    SpiOverrun(Receiver),
    /// SR.FRE: the slave saw WS change at an unexpected moment.
    FrameError(Receiver),
    /// SR.CHSIDE does not match the ring position: the stream slipped.
    ChannelSide(Receiver),
    /// The stream's NDTR did not move for [`MOVE_POLLS`] polls.
    Stalled(Receiver),
    /// The first restart in step, after [`I2sCapture::start`], failed.
    NotStarted,
}

/// A failed [`I2sCapture::read_block`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum ReadError {
    /// Samples were lost (the fault), and the capture has been restarted in step: the next
    /// block starts at a frame boundary with every channel in place.
    Realigned(Fault),
    /// Samples were lost and [`RESYNC_ATTEMPTS`] restarts failed.
    Stuck(Fault),
}

/// What the capture needs from the board: register accesses (named after the RM0383 registers),
/// the HAL's ring reads and a timer.
#[allow(async_fn_in_trait)] // single-threaded executor: no `Send` bound wanted
pub trait I2sHardware {
    /// The HAL's `I2S::start`: DMA stream EN, SPI_CR2.RXDMAEN, SPE and I2SE set (the slave not
    /// armed on WS: [`I2sCapture::start`] restarts both in step right after).
    fn start_driver(&mut self, rx: Receiver);
    /// Reads SPI_SR.
    fn status(&mut self, rx: Receiver) -> SpiStatus;
    /// Reads SPI_DR (the value is dropped).
    fn read_data_register(&mut self, rx: Receiver);
    /// Writes SPI_I2SCFGR.I2SE.
    fn set_i2s_enabled(&mut self, rx: Receiver, on: bool);
    /// Reads the stream's DMA_SxNDTR: halfwords left before the ring's end.
    fn dma_remaining(&mut self, rx: Receiver) -> usize;
    /// Reads the stream's DMA_SxCR.EN.
    fn dma_enabled(&mut self, rx: Receiver) -> bool;
    /// Reads the stream's DMA_SxCR.CIRC.
    fn dma_circular(&mut self, rx: Receiver) -> bool;
    /// Writes the stream's DMA_SxCR.EN.
    fn set_dma_enabled(&mut self, rx: Receiver, on: bool);
    /// Writes the stream's DMA_SxNDTR (only while EN is 0).
    fn set_dma_remaining(&mut self, rx: Receiver, n: usize);
    /// Clears the stream's flags in DMA_LIFCR/HIFCR.
    fn clear_dma_flags(&mut self, rx: Receiver);
    /// The HAL's `I2S::clear`: the ring reader takes its positions from NDTR.
    fn reset_ring_reader(&mut self, rx: Receiver);
    /// The level of WS at the slave's input.
    fn ws_high(&mut self) -> bool;
    /// Busy-waits one bit clock.
    fn wait_bit_clock(&mut self);
    /// Runs `f` with interrupts masked.
    fn without_interrupts<R>(&mut self, f: impl FnOnce(&mut Self) -> R) -> R;
    /// The HAL's ring read of `n` halfwords (≤ [`BLOCK_WORDS`], a multiple of 4) of `rx`, into
    /// the receiver's block buffer.
    async fn read_ring(&mut self, rx: Receiver, n: usize) -> Result<(), RingError>;
    /// A block of each receiver into its block buffer, read concurrently: `(master, slave)`.
    async fn read_blocks(&mut self) -> (Result<(), RingError>, Result<(), RingError>);
    /// Waits about `frames` sample frames.
    async fn wait_frames(&mut self, frames: u32);
}

/// The capture state: whether the rings are in step.
#[derive(Debug)]
pub struct I2sCapture {
    ring_words: usize,
    block_words: usize,
    aligned: bool,
}

impl I2sCapture {
    /// A capture over rings of `ring_words` halfwords read in blocks of `block_words` (both
    /// whole frames; the ring a whole number of blocks).
    #[must_use]
    pub const fn new(ring_words: usize, block_words: usize) -> Self {
        assert!(
            ring_words.is_multiple_of(WORDS_PER_STEREO_FRAME)
                && block_words.is_multiple_of(WORDS_PER_STEREO_FRAME)
        );
        assert!(block_words > 0 && ring_words.is_multiple_of(block_words));
        Self {
            ring_words,
            block_words,
            aligned: false,
        }
    }

    /// Starts both drivers (the HAL's `I2S::start`: streams and receivers running, not yet in
    /// step); the first [`Self::read_block`] restarts them in step.
    pub fn start<H: I2sHardware>(&mut self, hw: &mut H) {
        hw.start_driver(Receiver::Master);
        hw.start_driver(Receiver::Slave);
        self.aligned = false;
    }

    /// Reads the next block of both receivers into their block buffers and checks the
    /// receivers ([`receiver_health`]). Receivers not yet in step (after [`Self::start`]) are
    /// restarted in step first. On a fault the receivers are restarted in step
    /// ([`Self::resync`]) and the block is not delivered.
    pub async fn read_block<H: I2sHardware>(&mut self, hw: &mut H) -> Result<(), ReadError> {
        if !self.aligned && !self.resync(hw).await {
            return Err(ReadError::Stuck(Fault::NotStarted));
        }
        let fault = match hw.read_blocks().await {
            (Err(e), _) => Some(Fault::Ring(Receiver::Master, e)),
            (_, Err(e)) => Some(Fault::Ring(Receiver::Slave, e)),
            (Ok(()), Ok(())) => Receiver::BOTH
                .into_iter()
                .find_map(|rx| receiver_health(hw, rx, self.ring_words).err()),
        };
        match fault {
            None => Ok(()),
            Some(f) if self.resync(hw).await => Err(ReadError::Realigned(f)),
            Some(f) => Err(ReadError::Stuck(f)),
        }
    }

    /// Restarts the receivers in step (see the module documentation), up to
    /// [`RESYNC_ATTEMPTS`] times; `false` if none succeeded.
    pub async fn resync<H: I2sHardware>(&mut self, hw: &mut H) -> bool {
        self.aligned = false;
        for _ in 0..RESYNC_ATTEMPTS {
            stop_receivers(hw);
            if reset_streams(hw, self.ring_words)
                && hw.without_interrupts(restart_in_step)
                && discard_to_common_frame(hw, self.ring_words, self.block_words).await
            {
                self.aligned = true;
                return true;
            }
        }
        false
    }
}

/// Halfwords the stream of `rx` has written since the ring's start, modulo the ring.
fn received<H: I2sHardware>(hw: &mut H, rx: Receiver, ring_words: usize) -> usize {
    (ring_words - hw.dma_remaining(rx).min(ring_words)) % ring_words
}

/// Polls (at most [`MOVE_POLLS`]) until the stream of `rx` moves a halfword; `false` if it
/// does not.
fn wait_for_move<H: I2sHardware>(hw: &mut H, rx: Receiver) -> bool {
    let before = hw.dma_remaining(rx);
    (0..MOVE_POLLS).any(|_| hw.dma_remaining(rx) != before)
}

/// Waits until the stream of `rx` moves two halfwords in a row whose SR.CHSIDE (read right
/// after each move) are `sides` (`true`: right), i.e. for a given halfword of the frame on the
/// wire, whatever the ring position; `false` if that does not happen within a frame and a half.
fn wait_for_sides<H: I2sHardware>(hw: &mut H, rx: Receiver, sides: (bool, bool)) -> bool {
    let mut previous = None;
    for _ in 0..3 * WORDS_PER_STEREO_FRAME / 2 + 1 {
        if !wait_for_move(hw, rx) {
            return false;
        }
        let right = hw.status(rx).right;
        if previous == Some(sides.0) && right == sides.1 {
            return true;
        }
        previous = Some(right);
    }
    false
}

/// Switches both receivers off at the end of a frame, following RM0383's reception sequences
/// (module documentation, step 1). The halfwords of the frame are told apart by SR.CHSIDE, which
/// follows WS (the wire), not by ring positions (which a lost halfword shifts): the slave's I2SE
/// is cleared right after its second right-channel halfword in a row (the frame's last RXNE);
/// the master's one bit clock after its first right-channel halfword (the second-to-last), and
/// its last halfword is waited for. OVR is cleared first (a read of DR, then SR), since a
/// receiver may stop receiving while it is set. A receiver that does not move (stopped already,
/// or stalled) is switched off all the same.
pub fn stop_receivers<H: I2sHardware>(hw: &mut H) {
    hw.without_interrupts(|hw| {
        for rx in Receiver::BOTH {
            hw.read_data_register(rx);
            let _ = hw.status(rx);
        }
        let _ = wait_for_sides(hw, Receiver::Slave, (true, true));
        hw.set_i2s_enabled(Receiver::Slave, false);
        let _ = wait_for_sides(hw, Receiver::Master, (false, true));
        hw.wait_bit_clock();
        hw.set_i2s_enabled(Receiver::Master, false);
        let _ = wait_for_move(hw, Receiver::Master);
    });
}

/// Puts both (switched-off) receivers' DMA streams back to the ring's start, circular mode
/// kept, and resets the HAL's readers to it (see the module documentation, step 2). `false` if a
/// stream does not stop or is no longer circular.
pub fn reset_streams<H: I2sHardware>(hw: &mut H, ring_words: usize) -> bool {
    hw.without_interrupts(|hw| {
        Receiver::BOTH.into_iter().all(|rx| {
            hw.set_dma_enabled(rx, false);
            if !(0..POLLS).any(|_| !hw.dma_enabled(rx)) {
                return false;
            }
            hw.read_data_register(rx);
            let _ = hw.status(rx);
            hw.clear_dma_flags(rx);
            if !hw.dma_circular(rx) {
                return false;
            }
            hw.set_dma_remaining(rx, ring_words);
            hw.reset_ring_reader(rx);
            hw.set_dma_enabled(rx, true);
            true
        })
    })
}

/// Waits (at most [`POLLS`] polls) until WS is at `high`.
fn wait_for_ws<H: I2sHardware>(hw: &mut H, high: bool) -> bool {
    (0..POLLS).any(|_| hw.ws_high() == high)
}

/// Starts the master (a frame, left channel first, at ring position 0), waits for its first
/// right channel (WS low, then high) and enables the slave then, which starts at the next left
/// channel. To be called with interrupts masked. `false` when WS does not toggle.
pub fn restart_in_step<H: I2sHardware>(hw: &mut H) -> bool {
    hw.set_i2s_enabled(Receiver::Master, true);
    if !(wait_for_ws(hw, false) && wait_for_ws(hw, true)) {
        return false;
    }
    hw.set_i2s_enabled(Receiver::Slave, true);
    true
}

/// Reads both stream positions at one instant (a few frames after the restart, so that the
/// slave has started) and reads away what lies before the first frame both rings hold
/// ([`align`]). `false` when the slave did not start at a frame boundary of the master (then
/// the receivers are restarted).
pub async fn discard_to_common_frame<H: I2sHardware>(
    hw: &mut H,
    ring_words: usize,
    block_words: usize,
) -> bool {
    hw.wait_frames(3).await;
    // Two readings in a row that agree were taken between two DMA moves (a halfword every
    // 15.6 µs, four register reads take well under 1 µs).
    let positions = hw.without_interrupts(|hw| {
        (0..POLLS).find_map(|_| {
            let first = (
                received(hw, Receiver::Master, ring_words),
                received(hw, Receiver::Slave, ring_words),
            );
            let second = (
                received(hw, Receiver::Master, ring_words),
                received(hw, Receiver::Slave, ring_words),
            );
            (first == second).then_some(first)
        })
    });
    let Some((ra, rb)) = positions else {
        return false;
    };
    let master = StreamPosition::from_frame_start(ra);
    let slave = StreamPosition {
        received: rb,
        phase: master.phase,
    };
    // The HAL's reader reads whole frames counted from the ring's start, so only whole frames
    // can be discarded: a slave that started mid-frame is restarted instead.
    let Ok((skip_master, skip_slave)) = align(master, slave) else {
        return false;
    };
    if skip_master % WORDS_PER_STEREO_FRAME != 0 || skip_slave % WORDS_PER_STEREO_FRAME != 0 {
        return false;
    }
    for (rx, mut skip) in [
        (Receiver::Master, skip_master),
        (Receiver::Slave, skip_slave),
    ] {
        while skip > 0 {
            let n = skip.min(block_words);
            if hw.read_ring(rx, n).await.is_err() {
                return false;
            }
            skip -= n;
        }
    }
    true
}

/// Waits (at most [`MOVE_POLLS`] polls, interrupts masked) for the stream of `rx` to move a
/// halfword, then reads SPI_SR: `(ring position after that halfword, status)`; `None` if
/// nothing moved, or another halfword came in between (then the status might belong to it).
pub fn channel_snapshot<H: I2sHardware>(
    hw: &mut H,
    rx: Receiver,
    ring_words: usize,
) -> Option<(usize, SpiStatus)> {
    hw.without_interrupts(|hw| {
        let before = hw.dma_remaining(rx);
        let moved = (0..MOVE_POLLS)
            .map(|_| hw.dma_remaining(rx))
            .find(|&n| n != before)?;
        let status = hw.status(rx);
        (hw.dma_remaining(rx) == moved)
            .then(|| ((ring_words - moved.min(ring_words)) % ring_words, status))
    })
}

/// Checks one receiver after a block: SR.OVR, SR.FRE and SR.CHSIDE against the ring position
/// (three snapshots are tried before the stream is taken for stalled).
pub fn receiver_health<H: I2sHardware>(
    hw: &mut H,
    rx: Receiver,
    ring_words: usize,
) -> Result<(), Fault> {
    let (at, status) = (0..3)
        .find_map(|_| channel_snapshot(hw, rx, ring_words))
        .ok_or(Fault::Stalled(rx))?;
    if status.overrun {
        Err(Fault::SpiOverrun(rx))
    } else if status.frame_error {
        Err(Fault::FrameError(rx))
    } else if !channel_matches(at, status.right) {
        Err(Fault::ChannelSide(rx))
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests;
