//! Drivers the STM32 boards share (`boards/f411.rs`, STM32F411CE; `boards/f446.rs`, STM32F446RE): the
//! frame-stream UART and the independent watchdog, over embassy-stm32, and the place of the
//! estimate store in their flash.

use crate::board_api::{self, FrameWriter, WriteError};
use crate::clock_plan::iwdg_setting;
use embassy_stm32::mode::Async;
use embassy_stm32::pac;
use embassy_stm32::pac::iwdg::vals::{Key, Pr};
use embassy_stm32::peripherals;
use embassy_stm32::usart::UartTx;
use embassy_stm32::Peri;

/// Offset of the estimate store in the flash of both STM32 boards (512 KB each, the same sector
/// layout): sectors 6 and 7 (0x0804_0000), which their memory layouts (`memory.x`,
/// `memory-f446.x`) keep out of the image.
pub const ESTIMATE_STORE_OFFSET: u32 = 0x4_0000;
/// Bytes of the estimate store: two 128 KB sectors, one half each (910 records a half).
pub const ESTIMATE_STORE_LEN: u32 = 0x4_0000;

/// The frame-stream UART (transmit only, DMA).
pub struct FrameTx {
    uart: UartTx<'static, Async>,
    /// The peripheral's name, for the log of a failed write.
    name: &'static str,
}

impl FrameTx {
    /// The frame writer on `uart`, named `name` in the log.
    pub fn new(uart: UartTx<'static, Async>, name: &'static str) -> Self {
        Self { uart, name }
    }
}

impl FrameWriter for FrameTx {
    async fn write(&mut self, bytes: &[u8]) -> Result<(), WriteError> {
        let name = self.name;
        self.uart.write(bytes).await.map_err(|e| {
            defmt::warn!("{=str}: {}", name, e);
            WriteError
        })
    }
}

/// Starts the independent watchdog at `timeout_us` with the PAC, before embassy's start-up (so
/// that anything after it that panics or hangs ends in a reset), frozen while a debugger halts the
/// core (RM0383, debug support, DBGMCU_APB1_FZ bit 12 DBG_IWDG_STOP): a breakpoint does not reset the
/// board. Writing the start key also starts the LSI (RM0383, IWDG functional description).
pub fn start_watchdog(timeout_us: u32) {
    pac::DBGMCU.apb1fzr().modify(|w| w.set_iwdg(true));
    pac::IWDG.kr().write(|w| w.set_key(Key::START));
    set_watchdog_timeout(timeout_us);
}

/// Sets the running watchdog's timeout (at least `timeout_us` at the nominal LSI,
/// [`iwdg_setting`]) and reloads it: key 0x5555 unlocks PR and RLR, which take the new values
/// once IWDG_SR.PVU and RVU read 0 (RM0383, IWDG: register access protection, IWDG_SR).
fn set_watchdog_timeout(timeout_us: u32) {
    // Note(unwrap-like): the boards' timeouts are within the IWDG's range (host tested).
    let (pr, rl) = iwdg_setting(timeout_us).unwrap_or((6, 0xFFF));
    let iwdg = pac::IWDG;
    let updating = || {
        let sr = iwdg.sr().read();
        sr.pvu() || sr.rvu()
    };
    // An update takes up to 5 LSI periods (≈ 300 µs at the slowest LSI): far fewer polls.
    const POLLS: u32 = 100_000;
    let _ = (0..POLLS).any(|_| !updating());
    iwdg.kr().write(|w| w.set_key(Key::ENABLE));
    iwdg.pr().write(|w| w.set_pr(Pr::from_bits(pr)));
    iwdg.rlr().write(|w| w.set_rl(rl));
    let _ = (0..POLLS).any(|_| !updating());
    iwdg.kr().write(|w| w.set_key(Key::RESET));
}

/// The independent watchdog, started at boot by [`start_watchdog`].
pub struct Watchdog {
    _iwdg: Peri<'static, peripherals::IWDG>,
    run_timeout_us: u32,
}

impl Watchdog {
    /// The watchdog [`start_watchdog`] started, with `run_timeout_us` as its run-time timeout.
    pub fn new(iwdg: Peri<'static, peripherals::IWDG>, run_timeout_us: u32) -> Self {
        Self {
            _iwdg: iwdg,
            run_timeout_us,
        }
    }
}

impl board_api::Watchdog for Watchdog {
    fn unleash(&mut self) {
        set_watchdog_timeout(self.run_timeout_us);
    }

    fn pet(&mut self) {
        pac::IWDG.kr().write(|w| w.set_key(Key::RESET));
    }

    fn stretch(&mut self, timeout_us: u32) {
        set_watchdog_timeout(timeout_us);
    }
}
