//! Firmware of the coincident-microphone-array board (STM32F411CE): four capsules over two I2S ADCs,
//! the `cma-core` similarity localizer in real time, one `$CMA` frame line per estimate over UART.
//!
//! Build with `cargo build -p firmware --release --target thumbv7em-none-eabihf`; on the host this
//! binary is an empty stub so that workspace-wide commands keep working.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod app;
#[cfg(target_os = "none")]
mod board;

/// Runtime glue: defmt over RTT, and a panic handler that logs the panic with defmt and then faults
/// (with a probe attached the debugger stops there; without one the HardFault loop is ended by the
/// watchdog, which resets the chip).
#[cfg(target_os = "none")]
mod runtime {
    use defmt_rtt as _;
    use panic_probe as _;

    // Log lines carry the time since boot (µs, from the embassy time driver).
    defmt::timestamp!("{=u64:us}", embassy_time::Instant::now().as_micros());

    /// What `defmt::panic!` and failed `defmt` assertions end in, after they have logged their
    /// message: this only stops (a debugger halts here; without one the watchdog resets the chip),
    /// instead of handing over to `core::panic!` and panic-probe, which would print it a second time.
    #[defmt::panic_handler]
    fn defmt_panic() -> ! {
        cortex_m::asm::udf()
    }

    #[embassy_executor::main]
    async fn main(spawner: embassy_executor::Spawner) {
        crate::app::run(spawner).await;
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    eprintln!("firmware: build for the board with --target thumbv7em-none-eabihf");
}
