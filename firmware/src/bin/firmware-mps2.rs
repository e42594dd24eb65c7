//! The array-board firmware on the emulated board: the same application (`../app.rs`) on QEMU
//! `mps2-an386` (`../boards/mps2.rs`): samples from a WAV file over semihosting, frame lines on the
//! CMSDK UART.
//!
//! ```text
//! cargo build -p firmware --release --target thumbv7em-none-eabihf --no-default-features --features board-mps2
//! qemu-system-arm -machine mps2-an386 -cpu cortex-m4 -icount shift=4,sleep=off \
//!     -display none -monitor none -serial pty \
//!     -semihosting-config enable=on,target=native,arg=firmware-mps2,arg=/abs/scene.wav \
//!     -kernel target/thumbv7em-none-eabihf/release/firmware-mps2
//! ```
//!
//! On the host this binary is an empty stub so that workspace-wide commands keep working.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
#[path = "../app.rs"]
mod app;
#[cfg(target_os = "none")]
#[path = "../boards/mps2.rs"]
mod board;
#[cfg(target_os = "none")]
#[path = "../runtime.rs"]
mod runtime;

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("firmware-mps2: build for QEMU mps2-an386 with --target thumbv7em-none-eabihf");
}
