//! Everything specific to the chip and the board: clocks, pins, DMA streams, interrupts, buffers.
//!
//! Board: STM32F411CE "Black Pill" (25 MHz HSE) with two stereo 24-bit I2S ADCs.
//!
//! | signal            | pin  | peripheral (AF)      | ADC A (omni, card 0°) | ADC B (card 120°, 240°) |
//! |-------------------|------|----------------------|-----------------------|-------------------------|
//! | MCK 4.095 MHz     | PA3  | I2S2_MCK (AF5)       | SCKI                  | SCKI                    |
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
//! [`F411`] is the board contract ([`crate::board_api::Board`]) for the application
//! (`src/app.rs`), like `boards/f446.rs` and `boards/mps2.rs`: an [`AudioIn`] ([`SampleSource`],
//! the capture of [`crate::i2s_capture`]), a [`FrameTx`], a [`Watchdog`] and the estimate
//! store's flash.

use crate::board_api::{self, Overrun, Parts, SampleSource};
use crate::clock_plan::{I2sClockPlan, F411_I2S};
use crate::i2s_capture::{
    I2sCapture, I2sHardware, ReadError, Receiver, RingError, SpiStatus, BLOCK_WORDS,
};
use crate::restart_mask::RestartMask;
use crate::sample::{interleave_stereo_pairs, WORDS_PER_STEREO_FRAME};
use cma_core::CHANNELS;
use embassy_stm32::flash::{Blocking, Flash};
use embassy_stm32::i2s::{self, I2S};
use embassy_stm32::time::Hertz;
use embassy_stm32::usart::{self, UartTx};
use embassy_stm32::{bind_interrupts, dma, pac, peripherals, rcc, Config};
use embassy_time::{with_timeout, Duration, Timer};
use static_cell::ConstStaticCell;

/// Input sample rate, Hz (the ADCs' LRCK; nominal: the clock plan gives 15 997 Hz).
pub use crate::board_api::SAMPLE_RATE_HZ;

use super::stm32_drivers;
use crate::board_api::ERASE_WATCHDOG_TIMEOUT_US;
pub use stm32_drivers::{FrameTx, Watchdog};

/// Sample frames per DSP block (2 ms at 16 kHz), as on every board.
pub use crate::board_api::BLOCK_FRAMES;
use crate::board_api::{RING_FRAMES, UART_BAUD, WATCHDOG_TIMEOUT_US};
/// Halfwords of each DMA ring buffer (one per ADC, [`RING_FRAMES`] sample frames each).
const RING_WORDS: usize = RING_FRAMES * WORDS_PER_STEREO_FRAME;

/// SYSCLK, Hz (the clock plan below).
const SYSCLK_HZ: u32 = 100_000_000;
/// CPU cycles per I2S bit clock (BCK 1.0238 MHz), rounded up.
const CYCLES_PER_BIT_CLOCK: u32 = SYSCLK_HZ / (64 * SAMPLE_RATE_HZ) + 1;
/// How long a block read may wait: two rings' worth. Longer means the stream has stopped.
const READ_TIMEOUT: Duration = Duration::from_millis(16);

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
/// PLLI2S from [`F411_I2S`] (M 25, N 258, R 3) → 86 MHz I2S kernel clock → MCK = 86 MHz / 21 =
/// 4.095 MHz (I2SDIV 10, ODD 1, as embassy computes it; [`check_i2s_clocks`] reads them back),
/// fs = MCK / 256 = 15.997 kHz (−0.019 %; the core runs at its nominal 16 kHz, the azimuth does
/// not depend on it). The PCM1808 class ADCs take SCKI = 256 fs at 16 kHz; BCK = 64 fs =
/// 1.024 MHz. The plan is host tested (`clock_plan`): 16 kHz ± 0.1 %.
fn clock_config() -> Config {
    use rcc::{AHBPrescaler, APBPrescaler, Hse, HseMode, Pll, PllMul, PllPDiv, PllPreDiv, PllQDiv};
    use rcc::{PllRDiv, PllSource, Sysclk};
    let mut config = Config::default();
    config.rcc.hse = Some(Hse {
        freq: Hertz(F411_I2S.hse_hz),
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
        prediv: PllPreDiv::from_bits(F411_I2S.plli2s_m),
        mul: PllMul::from_bits(F411_I2S.plli2s_n),
        divp: None,
        divq: None,
        divr: Some(PllRDiv::from_bits(F411_I2S.plli2s_r)),
    });
    config.rcc.sys = Sysclk::PLL1_P;
    config.rcc.ahb_pre = AHBPrescaler::DIV1;
    config.rcc.apb1_pre = APBPrescaler::DIV2;
    config.rcc.apb2_pre = APBPrescaler::DIV1;
    config
}

/// Reads back what embassy wrote to RCC_PLLI2SCFGR and SPI2_I2SPR and logs an error when it is
/// not [`F411_I2S`] (then the ADCs do not run at 16 kHz).
fn check_i2s_clocks() {
    let pll = pac::RCC.plli2scfgr().read();
    let pr = pac::SPI2.i2spr().read();
    let written = I2sClockPlan {
        plli2s_m: pll.pllm().to_bits(),
        plli2s_n: pll.plln().to_bits(),
        plli2s_r: pll.pllr().to_bits(),
        i2sdiv: pr.i2sdiv(),
        odd: pr.odd() == pac::spi::vals::Odd::ODD,
        mckoe: pr.mckoe(),
        ..F411_I2S
    };
    if written != F411_I2S {
        defmt::error!(
            "I2S clocks: PLLI2S M {} N {} R {}, I2SDIV {} ODD {} MCKOE {}: not the 16 kHz plan",
            written.plli2s_m,
            written.plli2s_n,
            written.plli2s_r,
            written.i2sdiv,
            written.odd,
            written.mckoe
        );
    }
}

/// The two I2S receivers (I2S2 master, I2S3 slave on shared bit and word clocks) with their
/// DMA rings and block buffers, as [`I2sHardware`] for [`I2sCapture`]: the HAL for starting and
/// reading the rings, the PAC for the registers.
struct Receivers {
    a: I2S<'static, u16>,
    b: I2S<'static, u16>,
    words_a: [u16; BLOCK_WORDS],
    words_b: [u16; BLOCK_WORDS],
}

/// The SPI/I2S peripheral of a receiver.
fn spi(rx: Receiver) -> pac::spi::Spi {
    match rx {
        Receiver::Master => pac::SPI2,
        Receiver::Slave => pac::SPI3,
    }
}

/// The DMA1 stream of a receiver (SPI2_RX: stream 3, SPI3_RX: stream 0; RM0383 Table 27).
fn stream(rx: Receiver) -> usize {
    match rx {
        Receiver::Master => 3,
        Receiver::Slave => 0,
    }
}

impl I2sHardware for Receivers {
    fn start_driver(&mut self, rx: Receiver) {
        match rx {
            Receiver::Master => self.a.start(),
            Receiver::Slave => self.b.start(),
        }
    }

    fn status(&mut self, rx: Receiver) -> SpiStatus {
        let sr = spi(rx).sr().read();
        SpiStatus {
            overrun: sr.ovr(),
            frame_error: sr.fre(),
            right: sr.chside() == pac::spi::vals::Chside::RIGHT,
        }
    }

    fn read_data_register(&mut self, rx: Receiver) {
        let _ = spi(rx).dr().read();
    }

    fn set_i2s_enabled(&mut self, rx: Receiver, on: bool) {
        spi(rx).i2scfgr().modify(|w| w.set_i2se(on));
    }

    fn dma_remaining(&mut self, rx: Receiver) -> usize {
        usize::from(pac::DMA1.st(stream(rx)).ndtr().read().ndt())
    }

    fn dma_enabled(&mut self, rx: Receiver) -> bool {
        pac::DMA1.st(stream(rx)).cr().read().en()
    }

    fn dma_circular(&mut self, rx: Receiver) -> bool {
        pac::DMA1.st(stream(rx)).cr().read().circ()
    }

    fn set_dma_enabled(&mut self, rx: Receiver, on: bool) {
        pac::DMA1.st(stream(rx)).cr().modify(|w| w.set_en(on));
    }

    fn set_dma_remaining(&mut self, rx: Receiver, n: usize) {
        // Note(cast): the ring (≤ 65535 halfwords) is checked where it is declared.
        pac::DMA1
            .st(stream(rx))
            .ndtr()
            .write(|w| w.set_ndt(n as u16));
    }

    fn clear_dma_flags(&mut self, rx: Receiver) {
        let n = stream(rx);
        pac::DMA1.ifcr(n / 4).write(|w| {
            w.set_tcif(n % 4, true);
            w.set_htif(n % 4, true);
            w.set_teif(n % 4, true);
            w.set_dmeif(n % 4, true);
            w.set_feif(n % 4, true);
        });
    }

    fn reset_ring_reader(&mut self, rx: Receiver) {
        match rx {
            Receiver::Master => self.a.clear(),
            Receiver::Slave => self.b.clear(),
        }
    }

    fn ws_high(&mut self) -> bool {
        // PA15, the slave's WS input, wired to the master's WS (PB12).
        pac::GPIOA.idr().read().idr(15) == pac::gpio::vals::Idr::HIGH
    }

    fn wait_bit_clock(&mut self) {
        cortex_m::asm::delay(CYCLES_PER_BIT_CLOCK);
    }

    fn without_interrupts<R>(&mut self, f: impl FnOnce(&mut Self) -> R) -> R {
        cortex_m::interrupt::free(|_| f(self))
    }

    async fn read_ring(&mut self, rx: Receiver, n: usize) -> Result<(), RingError> {
        let read = match rx {
            Receiver::Master => {
                with_timeout(READ_TIMEOUT, self.a.read(&mut self.words_a[..n])).await
            }
            Receiver::Slave => {
                with_timeout(READ_TIMEOUT, self.b.read(&mut self.words_b[..n])).await
            }
        };
        match read {
            Ok(Ok(())) => Ok(()),
            Ok(Err(_)) => Err(RingError::Overrun),
            Err(_) => Err(RingError::Timeout),
        }
    }

    async fn read_blocks(&mut self) -> (Result<(), RingError>, Result<(), RingError>) {
        let both = embassy_futures::join::join(
            self.a.read(&mut self.words_a),
            self.b.read(&mut self.words_b),
        );
        let ring = |r: Result<(), i2s::Error>| r.map_err(|_| RingError::Overrun);
        match with_timeout(READ_TIMEOUT, both).await {
            Ok((ra, rb)) => (ring(ra), ring(rb)),
            Err(_) => (Err(RingError::Timeout), Err(RingError::Timeout)),
        }
    }

    async fn wait_frames(&mut self, frames: u32) {
        Timer::after_micros(u64::from(frames) * 1_000_000 / u64::from(SAMPLE_RATE_HZ) + 1).await;
    }
}

// NDTR is 16 bits.
const _: () = assert!(RING_WORDS <= u16::MAX as usize);

/// The four capsules: the two receivers, their capture ([`I2sCapture`]) and the masks of the
/// ADCs' restart transients ([`RestartMask`]: the PCM1808s output zeros, then fade in, after
/// their clocks stopped).
pub struct AudioIn {
    receivers: Receivers,
    capture: I2sCapture,
    transient: RestartMask<2>,
}

impl SampleSource<BLOCK_FRAMES> for AudioIn {
    /// Starts both receivers; the first `read` restarts them in step ([`I2sCapture`]).
    fn start(&mut self) {
        self.capture.start(&mut self.receivers);
        self.transient.restarted();
    }

    /// Waits for the next [`BLOCK_FRAMES`] sample frames and writes them, full scale ±1, in the core's
    /// channel order (omni, card 0°, card 120°, card 240°).
    ///
    /// On a lapped ring, a receiver's OVR or FRE, a stopped stream or a stream whose channel side
    /// does not match its position, both receivers are restarted in step through the registers
    /// ([`I2sCapture::read_block`]) and [`Overrun`] is returned; `out` is then not written. When
    /// the restart fails [`crate::i2s_capture::RESYNC_ATTEMPTS`] times in a row, the
    /// firmware panics (and the watchdog resets the chip).
    ///
    /// After the start and every restart, the ADCs' transient (zeros, then the fade-in) comes as
    /// NaN frames, which the localizer flags and does not use ([`RestartMask`]).
    async fn read(&mut self, out: &mut [[f32; CHANNELS]; BLOCK_FRAMES]) -> Result<(), Overrun> {
        match self.capture.read_block(&mut self.receivers).await {
            Ok(()) => {
                interleave_stereo_pairs(&self.receivers.words_a, &self.receivers.words_b, out);
                self.transient.apply(out);
                Ok(())
            }
            Err(ReadError::Realigned(fault)) => {
                defmt::warn!("I2S capture: {}: restarted in step", fault);
                self.transient.restarted();
                Err(Overrun)
            }
            Err(ReadError::Stuck(fault)) => {
                defmt::panic!("I2S receivers cannot be restarted in step ({})", fault)
            }
        }
    }
}

/// The STM32F411CE "Black Pill" board with two PCM1808 I2S ADCs.
pub struct F411;

/// The board the binary runs.
pub type Selected = F411;

impl board_api::Board for F411 {
    type Audio = AudioIn;
    type Link = FrameTx;
    type Watchdog = Watchdog;
    type EstimateFlash = EstimateFlash;
    const ESTIMATE_STORE_OFFSET: u32 = ESTIMATE_STORE_OFFSET;
    const ESTIMATE_STORE_LEN: u32 = ESTIMATE_STORE_LEN;
    const WATCHDOG_TIMEOUT_US: u32 = WATCHDOG_TIMEOUT_US;

    fn init() -> Parts<Self> {
        init()
    }
}

/// The flash driver of the estimate store (offsets from the start of flash).
pub type EstimateFlash = Flash<'static, Blocking>;
/// The estimate store: sectors 6 and 7 of the flash, which `memory.x` keeps out of the image.
pub use super::stm32_drivers::{ESTIMATE_STORE_LEN, ESTIMATE_STORE_OFFSET};

/// Starts the watchdog, then configures clocks and peripherals.
fn init() -> Parts<F411> {
    stm32_drivers::start_watchdog(ERASE_WATCHDOG_TIMEOUT_US);
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

    let watchdog = Watchdog::new(p.IWDG, WATCHDOG_TIMEOUT_US);

    check_i2s_clocks();

    Parts {
        audio: AudioIn {
            receivers: Receivers {
                a,
                b,
                words_a: [0; BLOCK_WORDS],
                words_b: [0; BLOCK_WORDS],
            },
            capture: I2sCapture::new(RING_WORDS, BLOCK_WORDS),
            transient: RestartMask::new(),
        },
        uart: FrameTx::new(uart, "USART1"),
        watchdog,
        estimate_flash: Some(Flash::new_blocking(p.FLASH)),
    }
}
