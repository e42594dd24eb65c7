//! Firmware of the coincident-microphone-array board (STM32F411CE): four capsules over two I2S ADCs,
//! the `cma-core` similarity localizer in real time, one `$CMA` frame line per estimate over UART.
//!
//! The application ([`cma_firmware::app`]) on the STM32F411CE board (`src/boards/f411.rs`), started
//! on embassy's thread-mode executor. Build with
//! `cargo build -p firmware --release --target thumbv7em-none-eabihf`; on the host this binary is an
//! empty stub so that workspace-wide commands keep working.
#![cfg_attr(target_os = "none", no_std, no_main)]

/// Starts the application on embassy's thread-mode executor (sleeps with `WFE`).
#[cfg(target_os = "none")]
#[embassy_executor::main]
async fn main(spawner: embassy_executor::Spawner) {
    cma_firmware::app::run(spawner).await;
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("firmware: build for the board with --target thumbv7em-none-eabihf");
}
