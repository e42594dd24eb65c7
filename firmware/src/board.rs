//! Everything specific to the chip and the board: clocks, pins, DMA streams, interrupts, buffers.
//!
//! Board: STM32F411CE "Black Pill" (25 MHz HSE) with two stereo 24-bit I2S ADCs.
//!
//! | signal            | pin  | peripheral (AF)      | ADC A (omni, card 0°) | ADC B (card 120°, 240°) |
//! |-------------------|------|----------------------|-----------------------|-------------------------|
//! | MCK 4.096 MHz     | PA3  | I2S2_MCK (AF5)       | SCKI                  | SCKI                    |
//! | BCK 1.024 MHz     | PB13 | I2S2_CK (AF5), out   | BCK                   | BCK                     |
//! | BCK, slave input  | PB3  | I2S3_CK (AF6), in    | — (wire to PB13)      | — (wire to PB13)        |
//! | LRCK 16 kHz       | PB12 | I2S2_WS (AF5), out   | LRCK                  | LRCK                    |
//! | LRCK, slave input | PA15 | I2S3_WS (AF6), in    | — (wire to PB12)      | — (wire to PB12)        |
//! | data A            | PB15 | I2S2_SD (AF5), in    | DOUT                  |                         |
//! | data B            | PB5  | I2S3_SD (AF6), in    |                       | DOUT                    |
//! | frame stream TX   | PA9  | USART1_TX (AF7)      |                       |                         |
//!
//! DMA: SPI2_RX on DMA1 stream 3, SPI3_RX on DMA1 stream 0, USART1_TX on DMA2 stream 7.
//!
//! It implements the board interface of [`cma_firmware::board_api`] for the application
//! (`src/app.rs`); another board (e.g. the emulated one in `src/board_mps2.rs`, or an STM32F446 with
//! one 4-channel TDM ADC on SAI) provides the same items: [`init`] returning an [`AudioIn`]
//! ([`SampleSource`]), a [`FrameTx`] ([`FrameWriter`](cma_firmware::board_api::FrameWriter)) and a [`Watchdog`], and the constants
//! [`SAMPLE_RATE_HZ`] and [`BLOCK_FRAMES`].

use cma_core::CHANNELS;
use cma_firmware::board_api::{Overrun, SampleSource};
use cma_firmware::i2s_align::{align, channel_matches, StreamPosition};
use cma_firmware::sample::{interleave_stereo_pairs, WORDS_PER_STEREO_FRAME};
use embassy_stm32::flash::{Blocking, Flash};
use embassy_stm32::i2s::{self, I2S};
use embassy_stm32::time::Hertz;
use embassy_stm32::usart::{self, UartTx};
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::{bind_interrupts, dma, pac, peripherals, rcc, Config};
use static_cell::ConstStaticCell;

/// Input sample rate, Hz (the ADCs' LRCK; nominal: the clock plan gives 15 997 Hz).
pub use cma_firmware::board_api::SAMPLE_RATE_HZ;

#[path = "stm32_drivers.rs"]
mod stm32_drivers;
pub use stm32_drivers::{FrameTx, Watchdog};

/// UART baud rate of the frame stream.
pub const UART_BAUD: u32 = 115_200;
/// Sample frames per DSP block (2 ms at 16 kHz).
pub const BLOCK_FRAMES: usize = 32;
/// Sample frames held by each DMA ring buffer (8 ms at 16 kHz): the longest the DSP task may lag
/// behind before an overrun.
pub const RING_FRAMES: usize = 4 * BLOCK_FRAMES;
/// Watchdog timeout, µs. The DSP task pets it once per block, so a stalled capture or a hung task
/// resets the chip.
pub const WATCHDOG_TIMEOUT_US: u32 = 250_000;

const BLOCK_WORDS: usize = BLOCK_FRAMES * WORDS_PER_STEREO_FRAME;
const RING_WORDS: usize = RING_FRAMES * WORDS_PER_STEREO_FRAME;

bind_interrupts!(struct Irqs {
    DMA1_STREAM3 => dma::InterruptHandler<peripherals::DMA1_CH3>;
    DMA1_STREAM0 => dma::InterruptHandler<peripherals::DMA1_CH0>;
    DMA2_STREAM7 => dma::InterruptHandler<peripherals::DMA2_CH7>;
});

// DMA ring buffers. The F411 has one SRAM, reachable by both DMA controllers, so they stay in `.bss`
// (a named section would need `#[link_section]`, i.e. `unsafe`, and buy nothing on this part).
static RING_A: ConstStaticCell<[u16; RING_WORDS]> = ConstStaticCell::new([0; RING_WORDS]);
static RING_B: ConstStaticCell<[u16; RING_WORDS]> = ConstStaticCell::new([0; RING_WORDS]);

/// Clock plan: HSE 25 MHz → PLL (M 25, N 200, P 2) → SYSCLK 100 MHz, APB1 50 MHz, APB2 100 MHz;
/// PLLI2S (M 25, N 258, R 3) → 86 MHz I2S kernel clock → MCK = 86 MHz / 21 = 4.095 MHz (I2SDIV 10,
/// ODD 1, as embassy computes it), fs = MCK / 256 = 15.997 kHz (−0.019 %; the core runs at its
/// nominal 16 kHz, the azimuth does not depend on it). The PCM1808 class ADCs take SCKI = 256 fs at
/// 16 kHz; BCK = 64 fs = 1.024 MHz.
fn clock_config() -> Config {
    use rcc::{AHBPrescaler, APBPrescaler, Hse, HseMode, Pll, PllMul, PllPDiv, PllPreDiv, PllQDiv};
    use rcc::{PllRDiv, PllSource, Sysclk};
    let mut config = Config::default();
    config.rcc.hse = Some(Hse {
        freq: Hertz::mhz(25),
        mode: HseMode::Oscillator,
    });
    config.rcc.pll_src = PllSource::HSE;
    config.rcc.pll = Some(Pll {
        prediv: PllPreDiv::DIV25,
        mul: PllMul::MUL200,
        divp: Some(PllPDiv::DIV2),
        divq: Some(PllQDiv::DIV4),
        divr: None,
    });
    config.rcc.plli2s = Some(Pll {
        prediv: PllPreDiv::DIV25,
        mul: PllMul::MUL258,
        divp: None,
        divq: None,
        divr: Some(PllRDiv::DIV3),
    });
    config.rcc.sys = Sysclk::PLL1_P;
    config.rcc.ahb_pre = AHBPrescaler::DIV1;
    config.rcc.apb1_pre = APBPrescaler::DIV2;
    config.rcc.apb2_pre = APBPrescaler::DIV1;
    config
}

/// The four capsules: two I2S receivers on shared bit and word clocks (I2S2 master, I2S3 slave).
pub struct AudioIn {
    a: I2S<'static, u16>,
    b: I2S<'static, u16>,
    words_a: [u16; BLOCK_WORDS],
    words_b: [u16; BLOCK_WORDS],
    /// Both receivers were (re)started, master first and the slave armed on WS.
    started: bool,
    /// What lies before the first frame both rings hold has been discarded.
    aligned: bool,
}

impl SampleSource<BLOCK_FRAMES> for AudioIn {
    /// Starts capturing: the master, then the slave armed on the word select
    /// ([`AudioIn::restart_in_step`]); the first `read` discards what lies before the first frame
    /// both hold.
    fn start(&mut self) {
        self.started = self.restart_in_step();
        self.aligned = false;
    }

    /// Waits for the next [`BLOCK_FRAMES`] sample frames and writes them, full scale ±1, in the core's
    /// channel order (omni, card 0°, card 120°, card 240°).
    ///
    /// On a DMA overrun of either receiver, or when a stream's channel side does not match its
    /// position ([`AudioIn::channels_in_place`]), both receivers are halted (I2SE cleared) and
    /// restarted in step ([`AudioIn::resync`]), and [`Overrun`] is returned; `out` is then not
    /// written.
    async fn read(&mut self, out: &mut [[f32; CHANNELS]; BLOCK_FRAMES]) -> Result<(), Overrun> {
        if !self.aligned {
            if !(self.started && self.discard_to_common_frame().await) {
                self.resync().await;
                return Err(Overrun);
            }
            self.aligned = true;
        }
        let (ra, rb) = embassy_futures::join::join(
            self.a.read(&mut self.words_a),
            self.b.read(&mut self.words_b),
        )
        .await;
        if ra.is_err() || rb.is_err() || !Self::channels_in_place() {
            self.resync().await;
            return Err(Overrun);
        }
        interleave_stereo_pairs(&self.words_a, &self.words_b, out);
        Ok(())
    }
}

/// Restarts of the receivers tried before giving up (then the watchdog resets the chip).
const RESYNC_ATTEMPTS: u32 = 8;
/// Polls of the word-select pin before a level is given up on (≥ 10 frames at 100 MHz).
const WS_POLLS: u32 = 20_000;

/// Clears I2SE, the enable bit of the I2S peripheral (the HAL's `stop` method clears only SPE, which in
/// I2S mode leaves the peripheral running), then the receive flags (OVR is cleared by reading DR,
/// then SR).
fn disable_i2s(regs: pac::spi::Spi) {
    regs.i2scfgr().modify(|w| w.set_i2se(false));
    let _ = regs.dr().read();
    let _ = regs.sr().read();
}

/// Waits until the slave's word-select input (PA15, wired to the master's WS) is at `high`.
fn wait_for_ws(high: bool) -> bool {
    let level = if high {
        pac::gpio::vals::Idr::HIGH
    } else {
        pac::gpio::vals::Idr::LOW
    };
    (0..WS_POLLS).any(|_| pac::GPIOA.idr().read().idr(15) == level)
}

/// Halfwords the DMA stream `n` of DMA1 has written into its ring since it started (valid for
/// the first lap of the ring).
fn dma_received(n: usize) -> usize {
    RING_WORDS - usize::from(pac::DMA1.st(n).ndtr().read().ndt())
}

/// Waits (at most [`WS_POLLS`] polls, ≥ one halfword time) for DMA1 stream `n` to move a
/// halfword from `spi`, then reads the channel side of that halfword: `(position in the ring, right
/// channel)`; `None` if nothing moved or another halfword came in between.
fn channel_snapshot(n: usize, spi: pac::spi::Spi) -> Option<(usize, bool)> {
    cortex_m::interrupt::free(|_| {
        let before = pac::DMA1.st(n).ndtr().read().ndt();
        let moved = (0..WS_POLLS)
            .map(|_| pac::DMA1.st(n).ndtr().read().ndt())
            .find(|&ndt| ndt != before)?;
        let right = spi.sr().read().chside() == pac::spi::vals::Chside::RIGHT;
        // The next halfword is ≈ 5 µs away: a change here means the reading straddled it.
        (pac::DMA1.st(n).ndtr().read().ndt() == moved)
            .then(|| ((RING_WORDS - usize::from(moved)) % RING_WORDS, right))
    })
}

impl AudioIn {
    /// Whether both streams' channel sides match their ring positions ([`channel_matches`]): ring
    /// position 0 is a frame start for both after a restart in step.
    fn channels_in_place() -> bool {
        [(3, pac::SPI2), (0, pac::SPI3)]
            .into_iter()
            .all(|(n, spi)| {
                let ok =
                    channel_snapshot(n, spi).is_some_and(|(at, right)| channel_matches(at, right));
                if !ok {
                    defmt::warn!("I2S stream on DMA1 stream {} out of step: restarting", n);
                }
                ok
            })
    }

    /// Halts both receivers for real and restarts them in step, until that succeeds
    /// ([`RESYNC_ATTEMPTS`]; after that the firmware panics and the watchdog resets the chip).
    async fn resync(&mut self) {
        for attempt in 1..=RESYNC_ATTEMPTS {
            self.a.stop().await;
            self.b.stop().await;
            disable_i2s(pac::SPI3);
            disable_i2s(pac::SPI2);
            if self.restart_in_step() && self.discard_to_common_frame().await {
                self.started = true;
                self.aligned = true;
                return;
            }
            defmt::warn!("I2S restart {} not in step", attempt);
        }
        defmt::panic!("I2S receivers cannot be restarted in step");
    }

    /// Starts the master (it begins a frame, left channel first, with its DMA at ring position 0),
    /// then arms the slave while WS is high (the master's right channel): a slave in I2S Philips
    /// mode must be enabled while WS is high, or it starts at once, out of step (STM32F4 errata,
    /// "WS level must be set by the external master when enabling the I2S"); armed so, it starts
    /// at the next left channel, one frame after the master. Returns `false` when WS does not
    /// toggle.
    fn restart_in_step(&mut self) -> bool {
        cortex_m::interrupt::free(|_| {
            self.a.start();
            // The master's first frame: WS low (left), then high (right).
            if !(wait_for_ws(false) && wait_for_ws(true)) {
                return false;
            }
            self.b.start();
            true
        })
    }

    /// Reads both DMA positions at one instant and discards from each ring what lies before the
    /// first frame both hold ([`align`]); the phase of the frame on the wires is the master's.
    async fn discard_to_common_frame(&mut self) -> bool {
        // A few frames in, so that the slave has started.
        embassy_time::Timer::after_micros(200).await;
        let (ra, rb) = loop {
            let (a1, b1) = (dma_received(3), dma_received(0));
            let (a2, b2) = (dma_received(3), dma_received(0));
            if (a1, b1) == (a2, b2) {
                break (a1, b1);
            }
        };
        let master = StreamPosition::from_frame_start(ra);
        let slave = StreamPosition {
            received: rb,
            phase: master.phase,
        };
        // The HAL's ring reads whole frames counted from its DMA start, so only whole frames can
        // be discarded: a slave that started mid-frame is restarted instead.
        let Ok((skip_a, skip_b)) = align(master, slave) else {
            return false;
        };
        if skip_a % WORDS_PER_STEREO_FRAME != 0 || skip_b % WORDS_PER_STEREO_FRAME != 0 {
            return false;
        }
        for (i2s, mut skip) in [(&mut self.a, skip_a), (&mut self.b, skip_b)] {
            while skip > 0 {
                let n = skip.min(BLOCK_WORDS);
                if i2s.read(&mut self.words_a[..n]).await.is_err() {
                    return false;
                }
                skip -= n;
            }
        }
        true
    }
}

/// The board's drivers, ready to be moved into tasks.
pub struct Board {
    /// The four capsules.
    pub audio: AudioIn,
    /// The frame-stream UART.
    pub uart: FrameTx,
    /// The watchdog (not yet started).
    pub watchdog: Watchdog,
    /// The flash that holds the estimate store ([`ESTIMATE_STORE_OFFSET`]).
    pub estimate_flash: Option<EstimateFlash>,
}

/// The flash driver of the estimate store (offsets from the start of flash).
pub type EstimateFlash = Flash<'static, Blocking>;
/// Offset of the estimate store in flash: sector 7 (0x0806_0000), which `memory.x` keeps out of
/// the image.
pub const ESTIMATE_STORE_OFFSET: u32 = 0x6_0000;
/// Bytes of the estimate store: the whole 128 KB sector (910 records).
pub const ESTIMATE_STORE_LEN: u32 = 0x2_0000;

/// Configures clocks and peripherals.
pub fn init() -> Board {
    let p = embassy_stm32::init(clock_config());

    let mut cfg_a = i2s::Config::default();
    cfg_a.mode = i2s::Mode::Master;
    cfg_a.standard = i2s::Standard::Philips;
    cfg_a.format = i2s::Format::Data24Channel32;
    cfg_a.frequency = Hertz::hz(SAMPLE_RATE_HZ);
    cfg_a.master_clock = true;
    let a = I2S::new_rxonly(
        p.SPI2,
        p.PB15,
        p.PB12,
        p.PB13,
        p.PA3,
        p.DMA1_CH3,
        RING_A.take(),
        Irqs,
        cfg_a,
    );

    let mut cfg_b = cfg_a;
    cfg_b.mode = i2s::Mode::Slave;
    cfg_b.master_clock = false;
    let b = I2S::new_rxonly_nomck(
        p.SPI3,
        p.PB5,
        p.PA15,
        p.PB3,
        p.DMA1_CH0,
        RING_B.take(),
        Irqs,
        cfg_b,
    );

    let mut uart_cfg = usart::Config::default();
    uart_cfg.baudrate = UART_BAUD;
    // Note(unwrap): 115200 baud from a 100 MHz APB2 is always reachable.
    let uart = UartTx::new(p.USART1, p.PA9, p.DMA2_CH7, Irqs, uart_cfg).unwrap();

    let watchdog = Watchdog(IndependentWatchdog::new(p.IWDG, WATCHDOG_TIMEOUT_US));

    Board {
        audio: AudioIn {
            a,
            b,
            words_a: [0; BLOCK_WORDS],
            words_b: [0; BLOCK_WORDS],
            started: false,
            aligned: false,
        },
        uart: FrameTx::new(uart, "USART1"),
        watchdog,
        estimate_flash: Some(Flash::new_blocking(p.FLASH)),
    }
}
