//! Runtime glue, the same for every board: defmt over RTT, a panic handler that logs the panic with
//! defmt and then faults (with a probe attached the debugger stops there; without one the HardFault
//! loop is ended by the watchdog, which resets the board) and defmt timestamps. The entry point,
//! which starts the application on embassy's executor, is each binary's (`src/bin/`).

use core::sync::atomic::{AtomicBool, Ordering};
use defmt_rtt as _;

// Log lines carry the time since boot (µs, from the board's embassy time driver).
defmt::timestamp!("{=u64:us}", embassy_time::Instant::now().as_micros());

/// What `defmt::panic!` and failed `defmt` assertions end in, after they have logged their
/// message: this only stops (a debugger halts here; without one the watchdog resets the board),
/// instead of handing over to `core::panic!` and [`panic`], which would print it a second time.
#[defmt::panic_handler]
fn defmt_panic() -> ! {
    cortex_m::asm::udf()
}

/// The panic handler (what panic-probe's does, without formatting): with interrupts off, logs the
/// panic's place and its message when that is a plain string, once, then faults (`udf`: UsageFault
/// is not enabled, so it is a HardFault, where a debugger stops and shows the backtrace).
///
/// A message with arguments (an index out of bounds, say) is not formatted: that takes `core::fmt`
/// (panic-probe's `print-defmt` cost the F411 image 720 B of flash), for a line only a debugger
/// reads; its place is logged.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    static PANICKED: AtomicBool = AtomicBool::new(false);
    cortex_m::interrupt::disable();
    if !PANICKED.swap(true, Ordering::Relaxed) {
        let message = info
            .message()
            .as_str()
            .unwrap_or("(a message with arguments)");
        match info.location() {
            Some(at) => defmt::error!(
                "panicked at {=str}:{=u32}: {=str}",
                at.file(),
                at.line(),
                message
            ),
            None => defmt::error!("panicked: {=str}", message),
        }
    }
    cortex_m::asm::udf()
}
