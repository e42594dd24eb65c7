//! Firmware of the coincident-microphone-array board (STM32F411CE): four capsules over two I2S ADCs,
//! the `cma-core` similarity localizer in real time, one `$CMA` frame line per estimate over UART.
//!
//! The application (`app.rs`) on the STM32F411CE board (`boards/f411.rs`); `bin/firmware-mps2.rs` puts
//! the same application on the emulated board. Build with
//! `cargo build -p firmware --release --target thumbv7em-none-eabihf`; on the host this binary is an
//! empty stub so that workspace-wide commands keep working.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod app;
#[cfg(target_os = "none")]
#[path = "boards/f411.rs"]
mod board;
#[cfg(target_os = "none")]
mod runtime;

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("firmware: build for the board with --target thumbv7em-none-eabihf");
}
