//! The capture run against a model of the F411's SPI/I2S receivers, DMA streams and embassy's
//! ring reader, in bit-clock steps.
//!
//! The model, from RM0383 and embassy-stm32 0.6's sources:
//! * **wire**: the master, while I2SE is set, clocks 64-bit frames (left then right, 32-bit
//!   channels, received as 4 halfwords); enabling it starts a new frame; clearing I2SE ends the
//!   halfword under way, then the clocks stop. WS is high during the right channel.
//! * **SPI/I2S receiver**: RXNE/DR, OVR when a halfword arrives with RXNE still set (the halfword is
//!   lost; with `ovr_blocks` every later one too, until OVR is cleared by a read of DR then SR:
//!   RM0383's SPI overrun text), FRE (injected) cleared by a read of SR, CHSIDE from WS. The slave
//!   enabled while WS is high starts at the next left channel, enabled while WS is low it starts at
//!   once (the errata), mid-halfword. The switch-off rules of the reception sequences are checked:
//!   a violation is recorded.
//! * **DMA stream**: moves DR to `ring[len − NDTR]` when RXNE, EN and RXDMAEN are set; NDTR counts
//!   down, at 0 sets TCIF and reloads (CIRC) or clears EN; clearing EN sets TCIF; setting EN with
//!   NDTR 0 reloads it; NDTR written only with EN clear (a write with EN set fails the test).
//! * **interrupts**: the DMA interrupt (embassy's `on_irq`: a TCIF counts a lap) runs at once
//!   unless masked, then when unmasked if its flag is still set.
//! * **ring reader**: embassy-stm32 0.6's `ReadableDmaRingBuffer` (`dma/ringbuffer/mod.rs`) with
//!   the I2S driver's alignment of 4 halfwords: positions from NDTR and the lap count, overrun when
//!   lapped, `DmaUnsynced` when the write position is behind the read position, a reset of both
//!   positions to the stream's after an error, misaligned halfwords skipped.

use super::*;
use core::future::Future;
use core::pin::pin;
use core::task::{Context, Poll, Waker};
use std::vec::Vec;

/// Bit clocks per halfword.
const HW_BITS: usize = 16;
/// Bit clocks per frame.
const FRAME_BITS: usize = 64;
/// Register accesses per bit clock (≈ 98 CPU cycles at 100 MHz and BCK 1.024 MHz; an access over
/// the bus takes a few).
const ACCESSES_PER_BIT: usize = 8;
/// Halfword values: frame number (13 bits), channel (2 bits), high/low half (1 bit).
const FRAME_MASK: usize = 0x1FFF;

/// The halfword ADC `adc` sends as halfword `h` (0..4) of frame `frame`.
fn wire_word(adc: usize, frame: usize, h: usize) -> u16 {
    (((frame & FRAME_MASK) << 3) | ((2 * adc + h / 2) << 1) | (h % 2)) as u16
}

/// A halfword the model's receivers produce from a word boundary that is not the wire's.
const GARBAGE: u16 = 0xFFFF;

/// Runs a future the model completes without waiting (it never returns `Pending`).
fn run_now<F: Future>(f: F) -> F::Output {
    let mut f = pin!(f);
    match f.as_mut().poll(&mut Context::from_waker(Waker::noop())) {
        Poll::Ready(v) => v,
        Poll::Pending => panic!("the model's futures complete at once"),
    }
}

#[derive(Debug, Clone, Copy, Default)]
struct DmaIndex {
    complete_count: usize,
    pos: usize,
}

/// embassy's `DmaIndex` (`dma/ringbuffer/mod.rs`).
impl DmaIndex {
    fn reset(&mut self) {
        self.pos = 0;
        self.complete_count = 0;
    }

    fn dma_sync(&mut self, cap: usize, count_diff: usize, remaining: usize) {
        let pos = cap - remaining;
        self.pos = if pos < self.pos && count_diff == 0 {
            cap - 1
        } else {
            pos
        };
        self.complete_count += count_diff;
    }

    fn advance(&mut self, cap: usize, steps: usize) {
        let next = self.pos + steps;
        self.complete_count += next / cap;
        self.pos = next % cap;
    }

    fn normalize(lhs: &mut DmaIndex, rhs: &mut DmaIndex) {
        let min_count = lhs.complete_count.min(rhs.complete_count);
        lhs.complete_count -= min_count;
        rhs.complete_count -= min_count;
    }

    fn diff(&self, cap: usize, rhs: &DmaIndex) -> isize {
        (self.complete_count * cap + self.pos) as isize
            - (rhs.complete_count * cap + rhs.pos) as isize
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ReaderError {
    Overrun,
    DmaUnsynced,
}

/// One receiver with its DMA stream and ring reader.
#[derive(Debug, Clone)]
struct Channel {
    // SPI/I2S
    i2se: bool,
    rxdmaen: bool,
    /// Slave: enabled while WS was high, waiting for the left channel.
    armed: bool,
    /// Shifting in (the master: while its clocks run and I2SE is set).
    running: bool,
    /// Slave started mid-halfword: its halfwords straddle the wire's.
    off_grid: bool,
    rxne: bool,
    dr: u16,
    ovr: bool,
    /// DR was read since OVR was set (the first half of OVR's clearing sequence).
    dr_read_in_ovr: bool,
    fre: bool,
    right: bool,
    /// The next halfword finds RXNE still set (an injected DMA latency).
    lose_next: bool,
    /// OVR blocks further reception until cleared (see the module documentation).
    ovr_blocks: bool,
    // DMA stream
    en: bool,
    circ: bool,
    ndtr: usize,
    programmed: usize,
    tcif: bool,
    htif: bool,
    ring: Vec<u16>,
    irq_pending: bool,
    // ring reader
    complete_count: usize,
    write: DmaIndex,
    read: DmaIndex,
    block: Vec<u16>,
}

impl Channel {
    fn new(cap: usize, block: usize) -> Self {
        Self {
            i2se: false,
            rxdmaen: false,
            armed: false,
            running: false,
            off_grid: false,
            rxne: false,
            dr: 0,
            ovr: false,
            dr_read_in_ovr: false,
            fre: false,
            right: false,
            lose_next: false,
            ovr_blocks: false,
            en: false,
            circ: true,
            ndtr: cap,
            programmed: cap,
            tcif: false,
            htif: false,
            ring: std::vec![0; cap],
            irq_pending: false,
            complete_count: 0,
            write: DmaIndex::default(),
            read: DmaIndex::default(),
            block: std::vec![0; block],
        }
    }

    fn cap(&self) -> usize {
        self.ring.len()
    }

    /// The DMA interrupt: embassy's `on_irq` (HTIF acknowledged; TCIF acknowledged and a lap
    /// counted).
    fn service_irq(&mut self) {
        self.htif = false;
        if self.tcif {
            self.tcif = false;
            self.complete_count += 1;
        }
        self.irq_pending = false;
    }

    /// A halfword completes at the receiver.
    fn receive(&mut self, value: u16, right: bool) {
        let value = if self.off_grid { GARBAGE } else { value };
        if self.ovr && self.ovr_blocks {
            return;
        }
        if self.rxne || self.lose_next {
            self.lose_next = false;
            self.ovr = true;
            self.dr_read_in_ovr = false;
            return;
        }
        self.rxne = true;
        self.dr = value;
        self.right = right;
    }

    fn read_dr(&mut self) -> u16 {
        self.rxne = false;
        if self.ovr {
            self.dr_read_in_ovr = true;
        }
        self.dr
    }

    fn read_sr(&mut self) -> SpiStatus {
        let s = SpiStatus {
            overrun: self.ovr,
            frame_error: self.fre,
            right: self.right,
        };
        self.fre = false;
        if self.ovr && self.dr_read_in_ovr {
            self.ovr = false;
        }
        s
    }

    /// The DMA stream serves RXNE.
    fn dma_step(&mut self, masked: bool) {
        if !(self.rxne && self.rxdmaen && self.en && self.ndtr > 0) {
            return;
        }
        let v = self.read_dr();
        let at = self.cap() - self.ndtr;
        self.ring[at] = v;
        self.ndtr -= 1;
        if self.ndtr == self.cap() / 2 {
            self.htif = true;
        }
        if self.ndtr == 0 {
            self.tcif = true;
            if self.circ {
                self.ndtr = self.programmed;
            } else {
                self.en = false;
            }
        }
        self.raise_irq(masked);
    }

    fn raise_irq(&mut self, masked: bool) {
        if masked {
            self.irq_pending = true;
        } else {
            self.service_irq();
        }
    }

    // embassy's ReadableDmaRingBuffer, alignment 4 (the I2S driver's for 32-bit channels).

    fn reset_complete_count(&mut self) -> usize {
        core::mem::take(&mut self.complete_count)
    }

    fn reader_reset(&mut self) {
        self.reset_complete_count();
        self.write.reset();
        let diff = self.reset_complete_count();
        let (cap, ndtr) = (self.cap(), self.ndtr);
        self.write.dma_sync(cap, diff, ndtr);
        self.read = self.write;
    }

    fn reader_len(&mut self) -> Result<usize, ReaderError> {
        let diff = self.reset_complete_count();
        let (cap, ndtr) = (self.cap(), self.ndtr);
        self.write.dma_sync(cap, diff, ndtr);
        DmaIndex::normalize(&mut self.write, &mut self.read);
        let d = self.write.diff(cap, &self.read);
        if d < 0 {
            Err(ReaderError::DmaUnsynced)
        } else if d > cap as isize {
            Err(ReaderError::Overrun)
        } else {
            Ok(d as usize)
        }
    }

    fn read_raw(&mut self, from: usize, to: usize) -> Result<usize, ReaderError> {
        const ALIGNMENT: usize = 4;
        let cap = self.cap();
        let mut available = self.reader_len()?;
        let misalignment = self.read.pos % ALIGNMENT;
        if misalignment != 0 {
            let skip = ALIGNMENT - misalignment;
            if available >= skip {
                self.read.advance(cap, skip);
                available -= skip;
            } else {
                return Ok(0);
            }
        }
        let mut readable = available.min(to - from);
        readable -= readable % ALIGNMENT;
        for i in 0..readable {
            self.block[from + i] = self.ring[(self.read.pos + i) % cap];
        }
        self.reader_len()?;
        self.read.advance(cap, readable);
        Ok(readable)
    }

    /// One poll of `read_exact` into `block[from..to]`: halfwords read, or the error (after
    /// which the reader has reset itself).
    fn reader_read(&mut self, from: usize, to: usize) -> Result<usize, ReaderError> {
        self.read_raw(from, to).inspect_err(|_| self.reader_reset())
    }
}

/// Faults the model can be told to produce.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Injection {
    /// The DSP task stalls for this many halfword times (the rings are lapped).
    Stall(usize),
    /// A halfword of the receiver is lost in the peripheral (OVR).
    LoseHalfword(Receiver),
    /// The slave sees a WS glitch: FRE, and its halfwords no longer fall on the wire's.
    FrameError,
}

struct Model {
    /// Bit clock within the master's frame.
    bit: usize,
    /// Register accesses since the last bit clock.
    access: usize,
    /// The wire's frame number.
    frame: usize,
    /// The master's clocks run.
    clocks: bool,
    /// The master finishes the halfword under way, then stops.
    master_stopping: bool,
    ch: [Channel; 2],
    masked: bool,
    /// Halfword times per wait of the capture (`wait_frames`).
    ticks: u64,
    /// A switch-off rule of the reception sequences was broken.
    violations: Vec<&'static str>,
    /// Ticks a ring read waits before [`RingError::Timeout`].
    read_timeout: u64,
}

fn idx(rx: Receiver) -> usize {
    match rx {
        Receiver::Master => 0,
        Receiver::Slave => 1,
    }
}

impl Model {
    fn new(cap: usize, block: usize) -> Self {
        Self {
            bit: 0,
            access: 0,
            frame: 0,
            clocks: false,
            master_stopping: false,
            ch: [Channel::new(cap, block), Channel::new(cap, block)],
            masked: false,
            ticks: 0,
            violations: Vec::new(),
            read_timeout: 2 * cap as u64 * HW_BITS as u64,
        }
    }

    fn ws_level(&self) -> bool {
        self.clocks && self.bit >= FRAME_BITS / 2
    }

    /// One register access by the CPU.
    fn access(&mut self) {
        self.access += 1;
        if self.access == ACCESSES_PER_BIT {
            self.tick();
        }
    }

    /// One bit clock (or, with the clocks stopped, the same time without one).
    fn tick(&mut self) {
        self.access = 0;
        self.ticks += 1;
        if self.clocks {
            self.bit += 1;
            if self.bit.is_multiple_of(HW_BITS) {
                self.halfword_done(self.bit / HW_BITS - 1);
            }
            if self.bit == FRAME_BITS {
                self.bit = 0;
                self.frame += 1;
                let s = &mut self.ch[1];
                if s.armed && self.clocks {
                    s.armed = false;
                    s.running = true;
                }
            }
        }
        let masked = self.masked;
        for c in &mut self.ch {
            c.dma_step(masked);
        }
    }

    fn halfword_done(&mut self, h: usize) {
        let right = h >= 2;
        let frame = self.frame;
        if self.ch[0].running {
            let v = wire_word(0, frame, h);
            self.ch[0].receive(v, right);
        }
        if self.ch[1].running {
            let v = wire_word(1, frame, h);
            self.ch[1].receive(v, right);
        }
        if self.master_stopping {
            self.master_stopping = false;
            self.clocks = false;
            self.ch[0].running = false;
            self.ch[1].running = false;
            self.ch[1].armed = false;
        }
    }

    fn unmask(&mut self) {
        self.masked = false;
        for c in &mut self.ch {
            if c.irq_pending && (c.tcif || c.htif) {
                c.service_irq();
            }
            c.irq_pending = false;
        }
    }

    fn set_i2se(&mut self, r: usize, on: bool) {
        let in_halfword = self.bit % HW_BITS;
        // Time into the halfword under way, in register accesses.
        let elapsed = in_halfword * ACCESSES_PER_BIT + self.access;
        let h = self.bit / HW_BITS;
        let c = &mut self.ch[r];
        let was = c.i2se;
        c.i2se = on;
        match (r, was, on) {
            (0, false, true) => {
                // The master starts a new frame, left channel first.
                self.bit = 0;
                self.frame += 1;
                self.clocks = true;
                self.ch[0].running = true;
            }
            (0, true, false) => {
                // "Wait for the second to last RXNE, then one I2S clock, then clear I2SE": the
                // halfword under way must be the last of a channel, at least one bit in.
                if self.clocks && !(h % 2 == 1 && elapsed >= ACCESSES_PER_BIT) {
                    self.violations
                        .push("master I2SE cleared outside its switch-off window");
                }
                if self.clocks && elapsed > 0 {
                    self.master_stopping = true;
                } else {
                    self.clocks = false;
                    self.ch[0].running = false;
                }
            }
            (1, false, true) => {
                if self.ws_level() {
                    self.ch[1].armed = true;
                } else if self.clocks {
                    // Errata: enabled while WS is low, the slave starts at once.
                    self.ch[1].running = true;
                    self.ch[1].off_grid = elapsed != 0;
                }
            }
            (1, true, false) => {
                // "I2SE has to be cleared immediately after receiving the last RXNE".
                if self.clocks
                    && self.ch[1].running
                    && !(h.is_multiple_of(2) && elapsed < HW_BITS / 2 * ACCESSES_PER_BIT)
                {
                    self.violations
                        .push("slave I2SE cleared outside its switch-off window");
                }
                let s = &mut self.ch[1];
                s.running = false;
                s.armed = false;
                s.off_grid = false;
            }
            _ => {}
        }
    }

    /// The wire's position in halfwords: which frame every ring position holds is checked
    /// against this.
    fn check_block(&self) -> Result<usize, std::string::String> {
        let (a, b) = (&self.ch[0].block, &self.ch[1].block);
        let first = usize::from(a[0] >> 3);
        for (i, (fa, fb)) in a.chunks_exact(4).zip(b.chunks_exact(4)).enumerate() {
            let want = (first + i) & FRAME_MASK;
            for h in 0..4 {
                if fa[h] != wire_word(0, want, h) || fb[h] != wire_word(1, want, h) {
                    return Err(std::format!(
                        "frame {i} of the block: {:04x?} {:04x?}, want frame {want}",
                        fa,
                        fb
                    ));
                }
            }
        }
        Ok(first)
    }

    /// The HAL's `I2S::start` (embassy-stm32 0.6 `i2s.rs`): ring start (stream EN), RX FIFO
    /// flushed, RXDMAEN, SPE, I2SE.
    fn hal_start(&mut self, r: usize) {
        self.tick();
        let c = &mut self.ch[r];
        if c.ndtr == 0 {
            c.ndtr = c.programmed;
        }
        c.en = true;
        while c.rxne {
            c.read_dr();
        }
        c.rxdmaen = true;
        self.set_i2se(r, true);
    }

    /// The HAL's `I2S::stop`: circular mode off, wait for the stream to finish its lap, RXDMAEN
    /// and SPE cleared (SPE does not stop an I2S), the reader reset (`clear`).
    fn hal_stop(&mut self, r: usize) {
        self.ch[r].circ = false;
        let mut n = 0;
        while self.ch[r].en {
            self.tick();
            n += 1;
            assert!(n < 10_000_000, "stream never stops");
        }
        self.ch[r].rxdmaen = false;
        self.ch[r].reader_reset();
    }

    /// Ticks until the stream of `r` is at ring position `at`.
    fn run_to_position(&mut self, r: usize, at: usize) {
        let cap = self.ch[r].cap();
        let mut n = 0;
        while (cap - self.ch[r].ndtr) % cap != at {
            self.tick();
            n += 1;
            assert!(n < 100 * cap * HW_BITS, "stream does not reach {at}");
        }
    }

    fn inject(&mut self, what: Injection) {
        match what {
            Injection::Stall(halfwords) => {
                for _ in 0..halfwords * HW_BITS {
                    self.tick();
                }
            }
            Injection::LoseHalfword(rx) => self.ch[idx(rx)].lose_next = true,
            Injection::FrameError => {
                self.ch[1].fre = true;
                self.ch[1].off_grid = true;
            }
        }
    }

    fn poll_read(&mut self, r: usize, done: &mut usize, n: usize) -> Option<Result<(), RingError>> {
        match self.ch[r].reader_read(*done, n) {
            Ok(k) => {
                *done += k;
                (*done == n).then_some(Ok(()))
            }
            Err(_) => Some(Err(RingError::Overrun)),
        }
    }
}

impl I2sHardware for Model {
    fn start_driver(&mut self, rx: Receiver) {
        self.hal_start(idx(rx));
    }

    fn status(&mut self, rx: Receiver) -> SpiStatus {
        self.access();
        self.ch[idx(rx)].read_sr()
    }

    fn read_data_register(&mut self, rx: Receiver) {
        self.access();
        self.ch[idx(rx)].read_dr();
    }

    fn set_i2s_enabled(&mut self, rx: Receiver, on: bool) {
        self.access();
        self.set_i2se(idx(rx), on);
    }

    fn dma_remaining(&mut self, rx: Receiver) -> usize {
        self.access();
        self.ch[idx(rx)].ndtr
    }

    fn dma_enabled(&mut self, rx: Receiver) -> bool {
        self.access();
        self.ch[idx(rx)].en
    }

    fn dma_circular(&mut self, rx: Receiver) -> bool {
        self.access();
        self.ch[idx(rx)].circ
    }

    fn set_dma_enabled(&mut self, rx: Receiver, on: bool) {
        self.access();
        let masked = self.masked;
        let c = &mut self.ch[idx(rx)];
        if on {
            if c.ndtr == 0 {
                c.ndtr = c.programmed;
            }
            c.en = true;
        } else if c.en {
            // RM0383 DMA: EN cleared by software during a transfer sets TCIF.
            c.en = false;
            c.tcif = true;
            c.raise_irq(masked);
        }
    }

    fn set_dma_remaining(&mut self, rx: Receiver, n: usize) {
        self.access();
        let c = &mut self.ch[idx(rx)];
        assert!(!c.en, "NDTR written with the stream enabled");
        c.ndtr = n;
        c.programmed = n;
    }

    fn clear_dma_flags(&mut self, rx: Receiver) {
        self.access();
        let c = &mut self.ch[idx(rx)];
        c.tcif = false;
        c.htif = false;
    }

    fn reset_ring_reader(&mut self, rx: Receiver) {
        self.access();
        self.ch[idx(rx)].reader_reset();
    }

    fn ws_high(&mut self) -> bool {
        self.access();
        self.ws_level()
    }

    fn wait_bit_clock(&mut self) {
        for _ in 0..ACCESSES_PER_BIT {
            self.access();
        }
    }

    fn without_interrupts<R>(&mut self, f: impl FnOnce(&mut Self) -> R) -> R {
        let outer = self.masked;
        self.masked = true;
        let r = f(self);
        if !outer {
            self.unmask();
        }
        r
    }

    async fn read_ring(&mut self, rx: Receiver, n: usize) -> Result<(), RingError> {
        let r = idx(rx);
        let mut done = 0;
        let start = self.ticks;
        loop {
            if let Some(result) = self.poll_read(r, &mut done, n) {
                return result;
            }
            if self.ticks - start > self.read_timeout {
                return Err(RingError::Timeout);
            }
            self.tick();
        }
    }

    async fn read_blocks(&mut self) -> (Result<(), RingError>, Result<(), RingError>) {
        let n = self.ch[0].block.len();
        let (mut done, mut result) = ([0, 0], [None, None]);
        let start = self.ticks;
        loop {
            for r in 0..2 {
                if result[r].is_none() {
                    result[r] = self.poll_read(r, &mut done[r], n);
                }
            }
            if let [Some(a), Some(b)] = result {
                return (a, b);
            }
            if self.ticks - start > self.read_timeout {
                let timeout = |x: Option<_>| x.unwrap_or(Err(RingError::Timeout));
                return (timeout(result[0]), timeout(result[1]));
            }
            self.tick();
        }
    }

    async fn wait_frames(&mut self, frames: u32) {
        for _ in 0..frames as usize * FRAME_BITS {
            self.tick();
        }
    }
}

/// A capture as the board drives it: start, then blocks.
trait CaptureUnderTest {
    fn start(&mut self, m: &mut Model) -> bool;
    fn read_block(&mut self, m: &mut Model) -> Result<(), ReadError>;
}

impl CaptureUnderTest for I2sCapture {
    fn start(&mut self, m: &mut Model) -> bool {
        I2sCapture::start(self, m);
        true
    }

    fn read_block(&mut self, m: &mut Model) -> Result<(), ReadError> {
        run_now(I2sCapture::read_block(self, m))
    }
}

/// The board's capture before this module: on a fault, the HAL's `stop()` on both receivers,
/// I2SE cleared and DR/SR read (`disable_i2s`), the HAL's `start()` of the master, the slave
/// started on WS high, then [`discard_to_common_frame`]; 8 attempts.
struct HalStopStartCapture {
    ring_words: usize,
    block_words: usize,
    aligned: bool,
}

impl HalStopStartCapture {
    fn restart(&mut self, m: &mut Model) -> bool {
        m.hal_start(0);
        if !(wait_for_ws(m, false) && wait_for_ws(m, true)) {
            return false;
        }
        m.hal_start(1);
        true
    }

    fn resync(&mut self, m: &mut Model) -> bool {
        for _ in 0..RESYNC_ATTEMPTS {
            m.hal_stop(0);
            m.hal_stop(1);
            for r in [1, 0] {
                m.set_i2se(r, false);
                m.ch[r].read_dr();
                m.ch[r].read_sr();
            }
            if self.restart(m)
                && run_now(discard_to_common_frame(
                    m,
                    self.ring_words,
                    self.block_words,
                ))
            {
                self.aligned = true;
                return true;
            }
        }
        false
    }
}

impl CaptureUnderTest for HalStopStartCapture {
    fn start(&mut self, m: &mut Model) -> bool {
        self.aligned = self.restart(m)
            && run_now(discard_to_common_frame(
                m,
                self.ring_words,
                self.block_words,
            ));
        self.aligned
    }

    fn read_block(&mut self, m: &mut Model) -> Result<(), ReadError> {
        let fault = if !self.aligned {
            Some(Fault::NotStarted)
        } else {
            match run_now(m.read_blocks()) {
                (Err(e), _) => Some(Fault::Ring(Receiver::Master, e)),
                (_, Err(e)) => Some(Fault::Ring(Receiver::Slave, e)),
                _ => Receiver::BOTH
                    .into_iter()
                    .find_map(|rx| receiver_health(m, rx, self.ring_words).err()),
            }
        };
        match fault {
            None => Ok(()),
            Some(f) if self.resync(m) => Err(ReadError::Realigned(f)),
            Some(f) => Err(ReadError::Stuck(f)),
        }
    }
}

/// Blocks read after a recovery and checked.
const BLOCKS_AFTER: usize = 6;

/// Reads a block and checks it against the wire: `Ok(true)` a block of whole frames, both ADCs
/// the same frame, in channel order, continuing `next` (the frame after the last block delivered
/// without a report in between); `Ok(false)` a reported and realigned fault (kept in `fault`).
fn read_checked(
    cap: &mut impl CaptureUnderTest,
    m: &mut Model,
    next: &mut Option<usize>,
    fault: &mut Option<Fault>,
) -> Result<bool, std::string::String> {
    match cap.read_block(m) {
        Ok(()) => {
            let first = m.check_block()?;
            if let Some(n) = *next {
                if first != n {
                    return Err(std::format!("block starts at frame {first}, want {n}"));
                }
            }
            *next = Some((first + m.ch[0].block.len() / 4) & FRAME_MASK);
            Ok(true)
        }
        Err(ReadError::Realigned(f)) => {
            *next = None;
            *fault = Some(f);
            Ok(false)
        }
        Err(ReadError::Stuck(f)) => Err(std::format!("stuck: {f:?}")),
    }
}

/// Starts `cap`, reads two blocks, injects `what` when the stream of `at.0` is at ring position
/// `at.1`, then reads until the fault is reported and [`BLOCKS_AFTER`] blocks more, each checked
/// ([`read_checked`]); the switch-off rules must have been kept. Returns the fault reported, or
/// what went wrong.
fn recovers(
    cap: &mut impl CaptureUnderTest,
    m: &mut Model,
    at: (Receiver, usize),
    what: Injection,
) -> Result<Fault, std::string::String> {
    if !cap.start(m) {
        return Err("start failed".into());
    }
    let mut next = None;
    let mut fault = None;
    for _ in 0..2 {
        if !read_checked(cap, m, &mut next, &mut fault)? {
            return Err("fault before the injection".into());
        }
    }
    // Blocks are read until the stream is less than a block before `at.1`: then it gets there
    // without lapping the reader.
    let (r, ring) = (idx(at.0), m.ch[0].cap());
    while (at.1 + ring - (ring - m.ch[r].ndtr) % ring) % ring > m.ch[0].block.len() {
        if !read_checked(cap, m, &mut next, &mut fault)? {
            return Err("fault before the injection".into());
        }
    }
    m.run_to_position(r, at.1);
    m.inject(what);
    let mut reported = false;
    let mut after = 0;
    for _ in 0..BLOCKS_AFTER + 6 {
        let ok = read_checked(cap, m, &mut next, &mut fault)?;
        if reported && !ok {
            return Err("a second fault after the recovery".into());
        }
        reported |= !ok;
        after += usize::from(reported && ok);
        if after == BLOCKS_AFTER {
            break;
        }
    }
    if after < BLOCKS_AFTER {
        return Err("no recovery".into());
    }
    if !m.violations.is_empty() {
        return Err(std::format!("switch-off rules broken: {:?}", m.violations));
    }
    fault.ok_or_else(|| "the fault was not reported".into())
}

fn capture() -> I2sCapture {
    I2sCapture::new(RING_WORDS, BLOCK_WORDS)
}

fn model() -> Model {
    Model::new(RING_WORDS, BLOCK_WORDS)
}

#[test]
fn starts_in_step_and_delivers_consecutive_aligned_frames() {
    let mut m = model();
    let mut c = capture();
    assert!(CaptureUnderTest::start(&mut c, &mut m));
    let mut next = None;
    for _ in 0..3 * RING_FRAMES / BLOCK_FRAMES {
        CaptureUnderTest::read_block(&mut c, &mut m).expect("no fault");
        let first = m.check_block().unwrap();
        if let Some(n) = next {
            assert_eq!(first, n);
        }
        next = Some((first + BLOCK_FRAMES) & FRAME_MASK);
    }
    assert!(m.ch.iter().all(|c| c.circ && c.en));
    assert!(m.violations.is_empty(), "{:?}", m.violations);
}

#[test]
fn a_lapped_ring_at_every_position_is_realigned() {
    for at in 0..RING_WORDS {
        let mut m = model();
        let stall = RING_WORDS + 1 + at % 7;
        match recovers(
            &mut capture(),
            &mut m,
            (Receiver::Master, at),
            Injection::Stall(stall),
        ) {
            Ok(Fault::Ring(_, RingError::Overrun)) => {}
            other => panic!("lapped at ring position {at}: {other:?}"),
        }
    }
}

#[test]
fn a_lost_halfword_at_every_position_of_either_ring_is_realigned() {
    for ovr_blocks in [false, true] {
        for rx in Receiver::BOTH {
            for at in 0..RING_WORDS {
                let mut m = model();
                for c in &mut m.ch {
                    c.ovr_blocks = ovr_blocks;
                }
                let got = recovers(
                    &mut capture(),
                    &mut m,
                    (rx, at),
                    Injection::LoseHalfword(rx),
                );
                // A receiver that keeps receiving shows OVR; one that stops until OVR is cleared
                // stops its stream, during a block or after one.
                let expected = match got {
                    Ok(Fault::SpiOverrun(r)) => !ovr_blocks && r == rx,
                    Ok(Fault::Ring(r, RingError::Timeout) | Fault::Stalled(r)) => {
                        ovr_blocks && r == rx
                    }
                    _ => false,
                };
                assert!(
                    expected,
                    "{rx:?} lost a halfword at ring position {at} (OVR blocks: {ovr_blocks}): {got:?}"
                );
            }
        }
    }
}

#[test]
fn a_slave_frame_error_is_realigned() {
    for at in (0..RING_WORDS).step_by(3) {
        let mut m = model();
        let got = recovers(
            &mut capture(),
            &mut m,
            (Receiver::Slave, at),
            Injection::FrameError,
        );
        assert_eq!(
            got,
            Ok(Fault::FrameError(Receiver::Slave)),
            "at ring position {at}"
        );
    }
}

#[test]
fn the_hal_stop_start_restart_never_realigns() {
    // The same check on the restart this module replaces: every overrun ends in `Stuck` (the
    // board then panicked and the watchdog reset it).
    for at in (0..RING_WORDS).step_by(37) {
        let mut m = model();
        let mut old = HalStopStartCapture {
            ring_words: RING_WORDS,
            block_words: BLOCK_WORDS,
            aligned: false,
        };
        let result = recovers(
            &mut old,
            &mut m,
            (Receiver::Master, at),
            Injection::Stall(RING_WORDS + 1),
        );
        assert!(
            result.as_ref().is_err_and(|e| e.starts_with("stuck")),
            "at {at}: {result:?}"
        );
        // The stream is no longer circular after the HAL's stop.
        assert!(!m.ch[0].circ);
    }
}

#[test]
fn receivers_started_mid_frame_and_mid_word_are_brought_in_step() {
    // The drivers started as the HAL starts them, the slave at every bit of the master's frame
    // (mid-frame, mid-halfword; while WS is low it starts at once, out of step): the first read
    // restarts both in step and every block is aligned.
    for bit in 0..FRAME_BITS * 2 {
        let mut m = model();
        m.start_driver(Receiver::Master);
        for _ in 0..bit {
            m.tick();
        }
        m.start_driver(Receiver::Slave);
        for _ in 0..3 * FRAME_BITS {
            m.tick();
        }
        let mut c = capture();
        let mut next = None;
        let mut fault = None;
        for _ in 0..4 {
            assert_eq!(
                read_checked(&mut c, &mut m, &mut next, &mut fault),
                Ok(true),
                "slave started {bit} bit clocks after the master"
            );
        }
        assert!(m.violations.is_empty(), "{:?}", m.violations);
    }
}
