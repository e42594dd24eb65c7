//! Drivers the STM32 boards share (`board.rs`, STM32F411CE; `board_f446.rs`, STM32F446RE): the
//! frame-stream UART and the independent watchdog, over embassy-stm32.

use cma_firmware::board_api::{self, FrameWriter, WriteError};
use embassy_stm32::mode::Async;
use embassy_stm32::peripherals;
use embassy_stm32::usart::UartTx;
use embassy_stm32::wdg::IndependentWatchdog;

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

/// The independent watchdog.
pub struct Watchdog(pub IndependentWatchdog<'static, peripherals::IWDG>);

impl board_api::Watchdog for Watchdog {
    fn unleash(&mut self) {
        self.0.unleash();
    }

    fn pet(&mut self) {
        self.0.pet();
    }
}
