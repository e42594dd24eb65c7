//! The STM32F446RE board: NUCLEO-F446RE with one 4-channel TDM ADC (TI TLV320ADC5140) on SAI1.
//!
//! | signal              | MCU pin (NUCLEO header) | peripheral (AF)        | TLV320ADC5140        |
//! |---------------------|-------------------------|------------------------|----------------------|
//! | BCLK 2.048 MHz      | PB12 (CN10-16)          | SAI1_SCK_B (AF6), out  | BCLK                 |
//! | FSYNC 15.997 kHz    | PB9 (CN10-5)            | SAI1_FS_B (AF6), out   | FSYNC                |
//! | TDM data            | PA9 (CN10-21, D8)       | SAI1_SD_B (AF6), in    | SDOUT                |
//! | control SCL         | PB8 (CN10-3, D15)       | I2C1_SCL (AF4)         | SCL (2.2 kΩ to 3.3 V) |
//! | control SDA         | PB7 (CN7-21)            | I2C1_SDA (AF4)         | SDA (2.2 kΩ to 3.3 V) |
//! | frame stream TX     | PA2                     | USART2_TX (AF7)        | — (ST-LINK VCP)      |
//!
//! ADC: inputs IN1–IN4 = omni, cardioid 0°, 120°, 240° (differential microphone inputs, MICBIAS
//! for the capsules), ADDR0 = ADDR1 = GND (I2C address 0x4C), AVDD = IOVDD = 3.3 V, AREG from its
//! internal regulator. It is the TDM bus slave: its PLL runs from BCLK (no MCLK wire); slots 0–3
//! carry inputs 1–4 ([`crate::tdm::SLOT_CHANNEL`]).
//!
//! SAI1 block B is the TDM master receiver: 4 slots of 32 bits (128 bit clocks per frame), frame
//! sync a one-bit pulse one bit before slot 0 (the ADC's `TX_OFFSET` = 1), data sampled on the
//! rising edge of BCLK (the ADC drives it on the falling edge), MSB first. Block A's frame-sync
//! pin is PA3 only on this package, which the NUCLEO wires to the ST-LINK's TX (the USART2 RX of
//! the virtual COM port), hence block B.
//!
//! DMA: SAI1_B on DMA2 stream 5 (channel 0), circular, one 32-bit word per slot; USART2_TX on
//! DMA1 stream 6.
//!
//! [`F446`] is the board contract ([`crate::board_api::Board`]) like `boards/f411.rs`
//! (STM32F411CE, two I2S ADCs) and `boards/mps2.rs` (QEMU): an [`AudioIn`] ([`SampleSource`]), a
//! [`FrameTx`], a [`Watchdog`] and the estimate store's flash.

use crate::board_api::{self, Overrun, Parts, SampleSource};
use crate::clock_plan::F446_SAI;
use crate::restart_mask::RestartMask;
use crate::tdm::{self, TdmReceiver, SLOTS};
use cma_core::CHANNELS;
use core::task::Poll;
use embassy_stm32::flash::{self, Flash};
use embassy_stm32::i2c::{self, I2c};
use embassy_stm32::mode::Blocking;
use embassy_stm32::sai::{self, Sai};
use embassy_stm32::time::Hertz;
use embassy_stm32::usart::{self, UartTx};
use embassy_stm32::{bind_interrupts, dma, pac, peripherals, rcc, Config};
use static_cell::ConstStaticCell;

use super::stm32_drivers;
use crate::board_api::ERASE_WATCHDOG_TIMEOUT_US;
pub use stm32_drivers::{FrameTx, Watchdog};

/// Sample frames per DSP block (2 ms at 16 kHz), as on every board.
pub use crate::board_api::BLOCK_FRAMES;
use crate::board_api::{RING_FRAMES, UART_BAUD, WATCHDOG_TIMEOUT_US};

const BLOCK_WORDS: usize = BLOCK_FRAMES * SLOTS;
const RING_WORDS: usize = RING_FRAMES * SLOTS;

bind_interrupts!(struct Irqs {
    DMA2_STREAM5 => dma::InterruptHandler<peripherals::DMA2_CH5>;
    DMA1_STREAM6 => dma::InterruptHandler<peripherals::DMA1_CH6>;
});

/// The DMA ring of the TDM receiver (SRAM1, reachable by DMA2).
static RING: ConstStaticCell<[u32; RING_WORDS]> = ConstStaticCell::new([0; RING_WORDS]);

/// Clock plan: HSE 8 MHz (the ST-LINK's MCO, bypass) → PLL (M 4, N 180, P 2) → SYSCLK/HCLK
/// 180 MHz (embassy enables the over-drive the F446 needs above 168 MHz), APB1 45 MHz, APB2
/// 90 MHz. The SAI clock comes from PLLSAI ([`start_sai_clock`]).
fn clock_config() -> Config {
    use rcc::{AHBPrescaler, APBPrescaler, Hse, HseMode, Pll, PllMul, PllPDiv, PllPreDiv};
    use rcc::{PllSource, Sysclk};
    let mut config = Config::default();
    config.rcc.hse = Some(Hse {
        freq: Hertz::mhz(8),
        mode: HseMode::Bypass,
    });
    config.rcc.pll_src = PllSource::HSE;
    config.rcc.pll = Some(Pll {
        prediv: PllPreDiv::DIV4,
        mul: PllMul::MUL180,
        divp: Some(PllPDiv::DIV2),
        divq: None,
        divr: None,
    });
    config.rcc.sys = Sysclk::PLL1_P;
    config.rcc.ahb_pre = AHBPrescaler::DIV1;
    config.rcc.apb1_pre = APBPrescaler::DIV4;
    config.rcc.apb2_pre = APBPrescaler::DIV2;
    config
}

/// Polls of a ready flag before it is given up on (≫ the longest wait: a PLL lock, ≈ 100 µs, or
/// the end of a TDM frame, 21 µs, at 180 MHz).
const POLLS: u32 = 200_000;

/// Starts PLLSAI and selects it as the SAI1 clock, with the PAC: embassy-stm32 0.6 writes
/// PLLSAICFGR without PLLSAIM on the F446 (its input divider, left at 0, an invalid value) and has
/// no SAI1 clock selection for this chip.
///
/// The values are [`F446_SAI`]'s (host tested to give 16 kHz ± 0.1 %): HSE 8 MHz / M 4 = 2 MHz →
/// × N 172 = 344 MHz → / Q 7 / PLLSAIDIVQ 1 = 49.1429 MHz SAI clock; the SAI's MCKDIV field 6
/// (÷ 12, RM0390 §28.3.8) gives a 4.0952 MHz master clock = 256 fs, so fs = 15 997 Hz (−0.019 %;
/// the core runs at its nominal 16 kHz, the azimuth does not depend on it) and BCLK = 128 fs =
/// 2.048 MHz for 4 slots of 32 bits (a BCLK-to-FSYNC ratio the ADC's automatic clock detection
/// supports at 16 kHz).
fn start_sai_clock() -> bool {
    use pac::rcc::vals::{Pllm, Plln, Pllp, Pllq, Pllsaidivq, Sai1src};
    pac::RCC.cr().modify(|w| w.set_pllsaion(false));
    if !(0..POLLS).any(|_| !pac::RCC.cr().read().pllsairdy()) {
        return false;
    }
    pac::RCC.pllsaicfgr().write(|w| {
        w.set_pllm(Pllm::from_bits(F446_SAI.pllsai_m));
        w.set_plln(Plln::from_bits(F446_SAI.pllsai_n));
        w.set_pllp(Pllp::DIV8); // 43 MHz on the 48 MHz clock path, unused
        w.set_pllq(Pllq::from_bits(F446_SAI.pllsai_q));
    });
    pac::RCC.dckcfgr().modify(|w| {
        // The field holds the division − 1 (RM0390 RCC_DCKCFGR.PLLSAIDIVQ).
        w.set_pllsaidivq(Pllsaidivq::from_bits(F446_SAI.pllsai_div_q - 1));
        w.set_sai1src(Sai1src::PLLSAI);
    });
    pac::RCC.cr().modify(|w| w.set_pllsaion(true));
    (0..POLLS).any(|_| pac::RCC.cr().read().pllsairdy())
}

/// SAI1 block B's registers (the receiver).
fn sai_block() -> pac::sai::Ch {
    pac::SAI1.ch(1)
}

/// The four capsules: one TDM receiver (SAI1 block B) on a circular DMA ring.
pub struct AudioIn {
    sai: Sai<'static, peripherals::SAI1, u32>,
    words: [u32; BLOCK_WORDS],
    /// The ADC's transient after a restart (a clock-error mute, then its ramp; [`RestartMask`]).
    transient: RestartMask<1>,
}

/// Restarts of the receiver tried before giving up (then the watchdog resets the chip).
const RESYNC_ATTEMPTS: u32 = 8;

impl SampleSource<BLOCK_FRAMES> for AudioIn {
    /// Starts the DMA ring, then the receiver at a frame sync ([`AudioIn::restart_at_frame_sync`]).
    fn start(&mut self) {
        if self.sai.start().is_err() {
            defmt::panic!("SAI1 block B is not a receiver");
        }
        self.resync();
    }

    /// Waits for the next [`BLOCK_FRAMES`] sample frames and writes them, full scale ±1, in the core's
    /// channel order ([`tdm::deinterleave`]). After the start and every restart, the ADC's
    /// transient comes as NaN frames, which the localizer flags and does not use
    /// ([`RestartMask`]).
    ///
    /// Returns [`Overrun`] (`out` not written) when samples were lost:
    /// * the DMA lapped the ring (the HAL's overrun): the HAL continues at the DMA position of that
    ///   moment, possibly mid-frame, so the receiver is restarted at a frame sync
    ///   ([`AudioIn::resync`]);
    /// * the SAI's FIFO overflowed (OVRUDR; the DMA fell behind by more than 8 words): whole
    ///   frames are lost, but the SAI keeps the slots in place (it resumes storing, in a later
    ///   frame, at the slot where the overrun began: the reference manual's SAI error flags), so
    ///   the flag is only cleared.
    async fn read(&mut self, out: &mut [[f32; CHANNELS]; BLOCK_FRAMES]) -> Result<(), Overrun> {
        if self.sai.read(&mut self.words).await.is_err() {
            self.resync();
            return Err(Overrun);
        }
        if Self::take_fifo_overrun() {
            return Err(Overrun);
        }
        tdm::deinterleave(&self.words, out);
        self.transient.apply(out);
        Ok(())
    }
}

impl AudioIn {
    /// Whether the SAI's FIFO overflowed since the last call (the flag is cleared).
    fn take_fifo_overrun() -> bool {
        let ch = sai_block();
        let overrun = ch.sr().read().ovrudr();
        if overrun {
            ch.clrfr().write(|w| w.set_covrudr(true));
            defmt::warn!("SAI1_B: FIFO overrun");
        }
        overrun
    }

    /// Restarts the receiver at a frame sync until that succeeds ([`RESYNC_ATTEMPTS`]; after that
    /// the firmware panics and the watchdog resets the chip).
    fn resync(&mut self) {
        self.transient.restarted();
        for attempt in 1..=RESYNC_ATTEMPTS {
            if self.restart_at_frame_sync() {
                return;
            }
            defmt::warn!("SAI1_B restart {} failed", attempt);
        }
        defmt::panic!("SAI1_B cannot be restarted");
    }

    /// Restarts the receiver so that the ring continues at slot 0 of a frame
    /// ([`tdm::restart_at_frame_sync`] on [`SaiRestart`]; the DMA ring keeps running throughout):
    ///
    /// 1. clear SAIEN and wait until it reads 0 (SAIEN stays set until the frame under way is
    ///    complete); flush the FIFO: the SAI requests no more DMA transfers, so the DMA stops at
    ///    some ring position *q*;
    /// 2. drain the ring (the HAL's reads, polled once each, until one does not complete): the
    ///    HAL's read position is then *q*, whatever it was (after a lapped ring the HAL restarts
    ///    it at the DMA position of that moment, possibly mid-frame);
    /// 3. clear the SAI's flags and set SAIEN: as master, the block starts a frame with its frame
    ///    sync and stores slot 0 first, which the DMA writes at *q*.
    ///
    /// Returns `false` when the block does not stop or does not start. The bit clock stops from
    /// the end of the frame until SAIEN is set again (a few µs); how the ADC's clock-error
    /// detection treats such a gap (it mutes and resumes on a clock error) is not verified.
    fn restart_at_frame_sync(&mut self) -> bool {
        let mut rx = SaiRestart {
            sai: &mut self.sai,
            words: &mut self.words,
        };
        tdm::restart_at_frame_sync(&mut rx, RING_WORDS / BLOCK_WORDS)
    }
}

/// SAI1 block B and its DMA ring as a [`TdmReceiver`], with the PAC for the enable bit, the FIFO
/// and the flags (the SAI driver of embassy-stm32 0.6 has no stop, and does not expose the ring's
/// frame alignment) and the HAL's ring reads for the drain.
struct SaiRestart<'a> {
    sai: &'a mut Sai<'static, peripherals::SAI1, u32>,
    words: &'a mut [u32; BLOCK_WORDS],
}

impl TdmReceiver for SaiRestart<'_> {
    fn stop(&mut self) -> bool {
        let ch = sai_block();
        ch.cr1().modify(|w| w.set_saien(false));
        (0..POLLS).any(|_| !ch.cr1().read().saien())
    }

    fn flush_fifo(&mut self) {
        sai_block().cr2().modify(|w| w.set_fflush(true));
    }

    fn read_block_now(&mut self) -> Poll<Result<(), ()>> {
        embassy_futures::poll_once(self.sai.read(&mut self.words[..])).map(|r| r.map_err(|_| ()))
    }

    fn clear_flags(&mut self) {
        sai_block().clrfr().write(|w| {
            w.set_covrudr(true);
            w.set_cmutedet(true);
            w.set_cwckcfg(true);
            w.set_ccnrdy(true);
            w.set_cafsdet(true);
            w.set_clfsdet(true);
        });
    }

    fn start(&mut self) -> bool {
        let ch = sai_block();
        ch.cr1().modify(|w| w.set_saien(true));
        ch.cr1().read().saien()
    }
}

/// The NUCLEO-F446RE board with one TLV320ADC5140 TDM ADC.
pub struct F446;

/// The board the binary runs.
pub type Selected = F446;

impl board_api::Board for F446 {
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
pub type EstimateFlash = Flash<'static, flash::Blocking>;
/// The estimate store: sectors 6 and 7 of the flash, which `memory-f446.x` keeps out of the image.
pub use super::stm32_drivers::{ESTIMATE_STORE_LEN, ESTIMATE_STORE_OFFSET};

/// The TLV320ADC5140's I2C address (ADDR0 = ADDR1 = GND).
const ADC_ADDRESS: u8 = 0x4C;

/// The ADC's register writes, in order (page 0): wake it with its internal regulator, TDM with
/// 32-bit words and data one BCLK after the frame sync, inputs 1–4 to slots 0–3, inputs and
/// outputs 1–4 enabled, then MICBIAS, ADCs and PLL powered.
const ADC_SETUP: [(u8, u8); 11] = [
    (0x00, 0x00), // PAGE_CFG: page 0
    (0x02, 0x81), // SLEEP_CFG: AREG internal, awake
    (0x07, 0x30), // ASI_CFG0: TDM, 32-bit words, FSYNC and BCLK not inverted
    (0x08, 0x01), // ASI_CFG1: TX_OFFSET 1 (slot 0's MSB one BCLK after FSYNC)
    (0x0B, 0x00), // ASI_CH1: slot 0
    (0x0C, 0x01), // ASI_CH2: slot 1
    (0x0D, 0x02), // ASI_CH3: slot 2
    (0x0E, 0x03), // ASI_CH4: slot 3
    (0x73, 0xF0), // IN_CH_EN: inputs 1–4
    (0x74, 0xF0), // ASI_OUT_CH_EN: outputs 1–4
    (0x75, 0xE0), // PWR_CFG: MICBIAS, ADC and PLL powered up
];

/// Resets and configures the ADC over I2C (the bit clock must be running: its PLL locks to it).
/// A failure is logged; the capture then runs on whatever the data line carries.
fn setup_adc(i2c: &mut I2c<'static, Blocking, i2c::Master>) {
    // SW_RESET, then ≥ 1 ms before the next access.
    if let Err(e) = i2c.blocking_write(ADC_ADDRESS, &[0x01, 0x01]) {
        defmt::error!("TLV320ADC5140 at {=u8:#x}: no answer ({})", ADC_ADDRESS, e);
        return;
    }
    embassy_time::block_for(embassy_time::Duration::from_millis(2));
    for (i, &(reg, value)) in ADC_SETUP.iter().enumerate() {
        if let Err(e) = i2c.blocking_write(ADC_ADDRESS, &[reg, value]) {
            defmt::error!("TLV320ADC5140: register {=u8:#x}: {}", reg, e);
            return;
        }
        if i == 1 {
            // ≥ 1 ms after waking before the next access.
            embassy_time::block_for(embassy_time::Duration::from_millis(2));
        }
    }
    check_adc_clocks(i2c);
}

/// Reads back DEV_STS1 (the device mode) and ASI_STS, the sample rate and BCLK ratio the ADC's
/// clock detection found ([`tdm::ADC_ASI_STS`]), and logs an error unless they are 16 kHz and 128
/// ([`tdm::ADC_EXPECTED_ASI_STS`]). The detection needs a few frames after power-up: the status
/// is polled for up to [`ADC_STATUS_WAIT_MS`].
fn check_adc_clocks(i2c: &mut I2c<'static, Blocking, i2c::Master>) {
    let mut asi_sts = 0xFF;
    for _ in 0..ADC_STATUS_WAIT_MS {
        embassy_time::block_for(embassy_time::Duration::from_millis(1));
        let mut status = [0u8; 1];
        if let Err(e) = i2c.blocking_write_read(ADC_ADDRESS, &[tdm::ADC_ASI_STS], &mut status) {
            defmt::error!("TLV320ADC5140: ASI_STS read: {}", e);
            return;
        }
        asi_sts = status[0];
        if asi_sts == tdm::ADC_EXPECTED_ASI_STS {
            break;
        }
    }
    let mut dev_sts1 = [0u8; 1];
    if let Err(e) = i2c.blocking_write_read(ADC_ADDRESS, &[0x77], &mut dev_sts1) {
        defmt::error!("TLV320ADC5140: DEV_STS1 read: {}", e);
    }
    let (rate, ratio) = tdm::asi_status_fields(asi_sts);
    if asi_sts == tdm::ADC_EXPECTED_ASI_STS {
        defmt::info!(
            "TLV320ADC5140: DEV_STS1 {=u8:#x}, ASI_STS {=u8:#x} (16 kHz, BCLK 128 fs)",
            dev_sts1[0],
            asi_sts
        );
    } else {
        defmt::error!(
            "TLV320ADC5140: ASI_STS {=u8:#x}: rate {} Hz, BCLK ratio {} (want 16000 Hz, 128); DEV_STS1 {=u8:#x}",
            asi_sts,
            tdm::asi_rate_hz(rate),
            tdm::asi_ratio(ratio),
            dev_sts1[0]
        );
    }
}

/// Milliseconds the ADC's clock detection is given to report the bus's rate.
const ADC_STATUS_WAIT_MS: u32 = 20;

/// Starts the watchdog, then configures clocks and peripherals.
fn init() -> Parts<F446> {
    stm32_drivers::start_watchdog(ERASE_WATCHDOG_TIMEOUT_US);
    let p = embassy_stm32::init(clock_config());
    if !start_sai_clock() {
        defmt::panic!("PLLSAI does not lock");
    }

    let mut cfg = sai::Config::default();
    cfg.mode = sai::Mode::Master;
    cfg.tx_rx = sai::TxRx::Receiver;
    cfg.protocol = sai::Protocol::Free;
    cfg.slot_size = sai::SlotSize::Channel32;
    cfg.slot_count = sai::word::U4(SLOTS as u8);
    cfg.slot_enable = 0b1111;
    cfg.first_bit_offset = sai::word::U5(0);
    cfg.data_size = sai::DataSize::Data32;
    cfg.stereo_mono = sai::StereoMono::Stereo;
    cfg.bit_order = sai::BitOrder::MsbFirst;
    cfg.frame_sync_offset = sai::FrameSyncOffset::BeforeFirstBit;
    cfg.frame_sync_polarity = sai::FrameSyncPolarity::ActiveHigh;
    cfg.frame_sync_active_level_length = sai::word::U7(1);
    cfg.frame_sync_definition = sai::FrameSyncDefinition::StartOfFrame;
    cfg.frame_length = F446_SAI.frame_bits as u16;
    cfg.clock_strobe = sai::ClockStrobe::Rising;
    // `MasterClockDivider` is stm32-metapac's `Mckdiv`, named by the division: the field value 6
    // is `DIV12` (÷ 12), not `DIV6` (field value 3, which ran the bus at 32 kHz).
    cfg.master_clock_divider = sai::MasterClockDivider::from_bits(F446_SAI.mckdiv);
    cfg.nodiv = F446_SAI.nodiv;
    cfg.fifo_threshold = sai::FifoThreshold::Quarter;
    let (_block_a, block_b) = sai::split_subblocks(p.SAI1);
    // The driver enables the block at once (the bit clock runs from here on, which the ADC's PLL
    // needs); `AudioIn::start` restarts it at a frame sync with the DMA ring running.
    let sai = Sai::new_asynchronous(
        block_b,
        p.PB12,
        p.PA9,
        p.PB9,
        p.DMA2_CH5,
        RING.take(),
        Irqs,
        cfg,
    );

    let mut i2c_cfg = i2c::Config::default();
    i2c_cfg.frequency = Hertz::khz(400);
    let mut i2c = I2c::new_blocking(p.I2C1, p.PB8, p.PB7, i2c_cfg);
    setup_adc(&mut i2c);

    let mut uart_cfg = usart::Config::default();
    uart_cfg.baudrate = UART_BAUD;
    // Note(unwrap): 115200 baud from a 45 MHz APB1 is always reachable.
    let uart = UartTx::new(p.USART2, p.PA2, p.DMA1_CH6, Irqs, uart_cfg).unwrap();

    let watchdog = Watchdog::new(p.IWDG, WATCHDOG_TIMEOUT_US);

    Parts {
        audio: AudioIn {
            sai,
            words: [0; BLOCK_WORDS],
            transient: RestartMask::new(),
        },
        uart: FrameTx::new(uart, "USART2"),
        watchdog,
        estimate_flash: Some(Flash::new_blocking(p.FLASH)),
    }
}
