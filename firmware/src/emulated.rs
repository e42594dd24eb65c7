//! What the emulated board (QEMU `mps2-an386`, `src/boards/mps2.rs`) and its tests agree on: the
//! fault word, the fault schedule and the report lines it prints on semihosting stdout.
//!
//! QEMU's generic loader writes the fault word before the firmware starts
//! (`-device loader,addr=0x20300000,data=N,data-len=4`); a fault is injected on the first boot
//! only, so that the boot after a watchdog reset runs clean. Its report lines
//! (`mps2: …`, on QEMU's stdout; the frame stream is on the UART):
//!
//! * `mps2: boot B: capture from frame F of N` — boot `B` (1 after power-on) reads the WAV from
//!   sample frame `F` (0 after power-on);
//! * `mps2: fault NAME` — the fault was injected (see [`Fault`]);
//! * `mps2: overrun: frames A..B lost` — the capture ring was lapped: sample frames `A` (inclusive)
//!   to `B` (exclusive) of the WAV never reached the application;
//! * `mps2: end of input at frame F` — the WAV has no further whole block; the firmware exits QEMU
//!   with status 0 after [`DRAIN_US`].

/// Address of the fault word (RAM outside every linked section of `memory-mps2.x`).
pub const FAULT_ADDR: u32 = 0x2030_0000;
/// Address of the state that survives a watchdog reset (boot count, capture position), next to
/// the fault word, outside the linked sections and not written by QEMU's loader.
pub const STATE_ADDR: u32 = 0x2030_0010;

/// Capture frame (from boot) at which the capture faults are injected (1.0 s at 16 kHz).
pub const FAULT_AT_FRAME: u64 = 16_000;
/// How long the DSP task stalls in [`Fault::CaptureStall`], µs (the ring holds 8 ms).
pub const CAPTURE_STALL_US: u64 = 20_000;
/// When the UART transmitter is held in [`Fault::UartStall`], µs after boot.
pub const UART_STALL_FROM_US: u64 = 1_000_000;
/// How long it is held, µs.
pub const UART_STALL_US: u64 = 1_000_000;
/// How long the board waits at the end of the input before it exits, µs: longer than the frame
/// queue takes to drain over the UART.
pub const DRAIN_US: u64 = 500_000;

/// A fault the emulated board injects on its first boot, selected by the fault word.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fault {
    /// No fault (word 0, also any unknown word).
    None,
    /// At capture frame [`FAULT_AT_FRAME`] the DSP task stalls for [`CAPTURE_STALL_US`] inside the
    /// capture's `read`: the ring is lapped, the capture reports an overrun and realigns.
    CaptureStall,
    /// The UART transmitter is held (like a deasserted CTS) from [`UART_STALL_FROM_US`] for
    /// [`UART_STALL_US`]: the frame queue fills and the DSP task drops (and counts) estimates.
    UartStall,
    /// At capture frame [`FAULT_AT_FRAME`] the DSP task hangs (spins without petting the
    /// watchdog): the watchdog resets the board, which boots again and resumes the capture.
    DspHang,
}

impl Fault {
    /// Every fault, by word.
    pub const ALL: [Fault; 4] = [
        Fault::None,
        Fault::CaptureStall,
        Fault::UartStall,
        Fault::DspHang,
    ];

    /// The fault word that selects it.
    #[must_use]
    pub const fn word(self) -> u32 {
        match self {
            Fault::None => 0,
            Fault::CaptureStall => 1,
            Fault::UartStall => 2,
            Fault::DspHang => 3,
        }
    }

    /// The fault a word selects ([`Fault::None`] for unknown words).
    #[must_use]
    pub const fn from_word(word: u32) -> Self {
        match word {
            1 => Fault::CaptureStall,
            2 => Fault::UartStall,
            3 => Fault::DspHang,
            _ => Fault::None,
        }
    }

    /// Its name in the report line.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Fault::None => "none",
            Fault::CaptureStall => "capture-stall",
            Fault::UartStall => "uart-stall",
            Fault::DspHang => "dsp-hang",
        }
    }
}

/// Sample frames captured `elapsed_us` µs after the capture started (rounded down).
#[must_use]
pub const fn frames_after_us(elapsed_us: u64, rate_hz: u32) -> u64 {
    elapsed_us * rate_hz as u64 / 1_000_000
}

/// The first µs at which `frames` sample frames have been captured (rounded up), the inverse of
/// [`frames_after_us`].
#[must_use]
pub const fn us_for_frames(frames: u64, rate_hz: u32) -> u64 {
    (frames * 1_000_000).div_ceil(rate_hz as u64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_round_trip() {
        for f in Fault::ALL {
            assert_eq!(Fault::from_word(f.word()), f);
        }
        assert_eq!(Fault::from_word(99), Fault::None);
    }

    #[test]
    fn capture_clock_inverts() {
        for frames in [0u64, 1, 31, 32, 47_999, 48_000, 1 << 30] {
            let us = us_for_frames(frames, 48_000);
            assert_eq!(frames_after_us(us, 48_000), frames);
            if us > 0 {
                assert!(frames_after_us(us - 1, 48_000) < frames);
            }
        }
    }
}
