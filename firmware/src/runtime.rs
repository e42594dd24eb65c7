//! Runtime glue, the same for every board: defmt over RTT, a panic handler that logs the panic with
//! defmt and then faults (with a probe attached the debugger stops there; without one the HardFault
//! loop is ended by the watchdog, which resets the board) and defmt timestamps. The entry point,
//! which starts the application on embassy's executor, is each binary's (`src/bin/`).

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
