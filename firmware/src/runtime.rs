//! Runtime glue, the same for every board: defmt over RTT, a panic handler that logs the panic with
//! defmt and then faults (with a probe attached the debugger stops there; without one the HardFault
//! loop is ended by the watchdog, which resets the board), defmt timestamps, and the entry point
//! that starts the application on embassy's executor.

use defmt_rtt as _;
use panic_probe as _;

// Log lines carry the time since boot (µs, from the board's embassy time driver).
defmt::timestamp!("{=u64:us}", embassy_time::Instant::now().as_micros());

/// What `defmt::panic!` and failed `defmt` assertions end in, after they have logged their
/// message: this only stops (a debugger halts here; without one the watchdog resets the board),
/// instead of handing over to `core::panic!` and panic-probe, which would print it a second time.
#[defmt::panic_handler]
fn defmt_panic() -> ! {
    cortex_m::asm::udf()
}

/// STM32F411CE and STM32F446RE: embassy's thread-mode executor (sleeps with `WFE`).
#[cfg(any(feature = "board-f411", feature = "board-f446"))]
#[embassy_executor::main]
async fn main(spawner: embassy_executor::Spawner) {
    crate::app::run(spawner).await;
}

/// Emulated board: the same executor in the board's loop (sleeps with `WFI`, which QEMU emulates
/// as a halt; it treats `WFE` as a no-op, so embassy's loop would spin).
#[cfg(feature = "board-mps2")]
#[cortex_m_rt::entry]
fn main() -> ! {
    crate::board::run_executor(|spawner| spawner.spawn(start(spawner).unwrap()))
}

/// Starts the application.
#[cfg(feature = "board-mps2")]
#[embassy_executor::task]
async fn start(spawner: embassy_executor::Spawner) {
    crate::app::run(spawner).await;
}
