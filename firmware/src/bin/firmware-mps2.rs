//! The array-board firmware on the emulated board: the same application ([`cma_firmware::app`]) on
//! QEMU `mps2-an386` (`src/boards/mps2.rs`): samples from a WAV file over semihosting, frame lines
//! on the CMSDK UART.
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

/// Runs embassy's executor in the board's loop (sleeps with `WFI`, which QEMU emulates as a halt;
/// it treats `WFE` as a no-op, so embassy's own loop would spin).
#[cfg(target_os = "none")]
#[cortex_m_rt::entry]
fn main() -> ! {
    cma_firmware::boards::mps2::run_executor(|spawner| spawner.spawn(start(spawner).unwrap()))
}

/// Starts the application.
#[cfg(target_os = "none")]
#[embassy_executor::task]
async fn start(spawner: embassy_executor::Spawner) {
    cma_firmware::app::run(spawner).await;
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("firmware-mps2: build for QEMU mps2-an386 with --target thumbv7em-none-eabihf");
}
