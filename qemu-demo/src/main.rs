//! A firmware-like demo for QEMU's `mps2-an386` (Cortex-M4F): no microphones, so it synthesises the
//! four capsule signals of a talker (noise bursts) circling the array at 20°/s, runs `cma-core` on them
//! block by block as the firmware's DMA handler would, and writes each estimate as a `cma_core::wire`
//! line on UART0 (CMSDK APB UART at 0x4000_4000). With QEMU's `-serial pty` (or `-chardev pty`) the
//! UART becomes a pseudo-terminal that `host-sim monitor` reads: the full chain without hardware.
//!
//! ```text
//! cargo build --release      # in qemu-demo/
//! qemu-system-arm -M mps2-an386 -nographic -monitor none -serial pty \
//!     -kernel target/thumbv7em-none-eabihf/release/qemu-demo
//! # QEMU prints: char device redirected to /dev/pts/N (label serial0)
//! host-sim monitor --port /dev/pts/N
//! ```
#![no_std]
#![no_main]

use cma_core::wire::{self, Frame, MAX_LINE};
use cma_core::{Locator, LocatorConfig, ReferenceTable, CHANNELS};
use cortex_m_rt::entry;

/// Input sample rate of the synthetic capsules (passes the decimator unchanged).
const RATE_HZ: u32 = 16_000;
/// Sample frames per DMA half-buffer.
const BLOCK: usize = 256;

/// CMSDK APB UART0 of the MPS2 boards.
mod uart {
    const BASE: usize = 0x4000_4000;
    const DATA: *mut u32 = BASE as *mut u32;
    const STATE: *const u32 = (BASE + 0x04) as *const u32;
    const CTRL: *mut u32 = (BASE + 0x08) as *mut u32;
    const BAUDDIV: *mut u32 = (BASE + 0x10) as *mut u32;

    /// Enables the transmitter (QEMU ignores the divider; a board would set it for 115200).
    pub fn init() {
        // Note(unsafe): fixed MMIO registers of the CMSDK UART, owned by this single-threaded program.
        unsafe {
            core::ptr::write_volatile(BAUDDIV, 16);
            core::ptr::write_volatile(CTRL, 1);
        }
    }

    /// Blocking write of `bytes`.
    pub fn write(bytes: &[u8]) {
        for &b in bytes {
            // Note(unsafe): as above; STATE bit 0 = TX buffer full.
            unsafe {
                while core::ptr::read_volatile(STATE) & 1 != 0 {}
                core::ptr::write_volatile(DATA, u32::from(b));
            }
        }
    }
}

/// xorshift32 noise source.
struct Noise(u32);

impl Noise {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        (self.0 as f32 / u32::MAX as f32) * 2.0 - 1.0
    }
}

#[entry]
fn main() -> ! {
    uart::init();
    let Ok(mut locator) = Locator::new(
        LocatorConfig::default(),
        ReferenceTable::ideal_5deg(),
        RATE_HZ,
    ) else {
        uart::write(b"locator configuration rejected\r\n");
        loop {
            core::hint::spin_loop();
        }
    };
    let mut noise = Noise(0x1234_5678);
    let mut block = [[0.0f32; CHANNELS]; BLOCK];
    let mut n: u64 = 0;
    let mut seq: u32 = 0;
    let mut line = heapless::Vec::<u8, MAX_LINE>::new();
    loop {
        for x in block.iter_mut() {
            let t = n as f32 / RATE_HZ as f32;
            let az = libm::fmodf(20.0 * t, 360.0).to_radians();
            // Talker: 150 ms noise bursts every 250 ms (syllable-like), quiet in between.
            let on = libm::fmodf(t, 0.25) < 0.15;
            let s = if on { 0.3 * noise.next() } else { 0.0 };
            let floor = 0.001 * noise.next();
            *x = [
                s + floor,
                0.5 * (1.0 + libm::cosf(az)) * s + floor,
                0.5 * (1.0 + libm::cosf(az - 120f32.to_radians())) * s + floor,
                0.5 * (1.0 + libm::cosf(az - 240f32.to_radians())) * s + floor,
            ];
            n += 1;
        }
        locator.process_block(&block, |e| {
            let f = Frame::from_estimate(e, seq, RATE_HZ, 0, 0);
            wire::encode(&f, &mut line);
            uart::write(&line);
            seq = seq.wrapping_add(1);
        });
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    uart::write(b"panic\r\n");
    loop {
        core::hint::spin_loop();
    }
}
