//! The array-board firmware on the STM32F446RE board: the same application ([`cma_firmware::app`])
//! on a NUCLEO-F446RE with one 4-channel TDM ADC on SAI1 (`src/boards/f446.rs`), frame lines on the
//! ST-LINK virtual COM port (USART2).
//!
//! ```text
//! cargo build -p firmware --release --target thumbv7em-none-eabihf --no-default-features --features board-f446
//! probe-rs run --chip STM32F446RETx target/thumbv7em-none-eabihf/release/firmware-f446
//! ```
//!
//! On the host this binary is an empty stub so that workspace-wide commands keep working.
#![cfg_attr(target_os = "none", no_std, no_main)]

/// Starts the application on embassy's thread-mode executor (sleeps with `WFE`).
#[cfg(target_os = "none")]
#[embassy_executor::main]
async fn main(spawner: embassy_executor::Spawner) {
    cma_firmware::app::run(spawner).await;
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("firmware-f446: build for the NUCLEO-F446RE with --target thumbv7em-none-eabihf");
}
