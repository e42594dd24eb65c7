//! The board interface: what the application needs from a board, and nothing else.
//!
//! A board provides
//! * a [`SampleSource`]: blocks of sample frames in the core's channel order (omni, cardioid 0°,
//!   120°, 240°; full scale ±1), or an [`Overrun`] when samples were lost;
//! * a [`FrameWriter`]: the byte stream of frame and calibration lines (a UART);
//! * a [`Watchdog`] that resets the board when the DSP task no longer pets it (it is petted only
//!   after a block was delivered, so a capture that fails block after block resets the board);
//! * optionally a flash for the estimate store (`board::EstimateFlash`, an
//!   [`embedded_storage::nor_flash::NorFlash`], with `ESTIMATE_STORE_OFFSET` and
//!   `ESTIMATE_STORE_LEN`; see [`crate::estimate_store`]);
//! * time: an `embassy-time` driver (the application's defmt timestamps).
//!
//! The contract is the [`Board`] trait: the application (`src/app.rs`) uses only it, these traits
//! and the constants here. Embassy tasks cannot be generic, so each binary mounts one board module
//! (`src/boards/f411.rs` for the STM32F411CE, `src/boards/f446.rs` for the STM32F446RE,
//! `src/boards/mps2.rs` for the emulated board) as `crate::board`, whose `Selected` type is the
//! board; the application names the concrete types through the trait (`<board::Selected as
//! Board>::Audio`).

use cma_core::CHANNELS;

/// Sample rate of every board's ADCs, Hz: the core's analysis rate at 16 kHz input, so the ADCs'
/// own decimation filters do the work of the core's decimator (which the core skips at this rate)
/// and the board computes exactly what `host-sim` computes on 16 kHz recordings.
pub const SAMPLE_RATE_HZ: u32 = 16_000;

/// Sample frames per block every board delivers (2 ms at 16 kHz).
pub const BLOCK_FRAMES: usize = 32;

/// Sample frames every board's capture ring holds (8 ms at 16 kHz): the longest the DSP task may
/// lag behind before an overrun.
pub const RING_FRAMES: usize = 4 * BLOCK_FRAMES;

/// UART baud rate of every board's frame stream (8N1).
pub const UART_BAUD: u32 = 115_200;

/// Watchdog timeout while the application runs on every board, µs (each board's
/// [`Board::WATCHDOG_TIMEOUT_US`]). The DSP task pets it after every block delivered, so a stalled
/// capture, a capture that fails block after block, or a hung task resets the chip. From reset
/// until then (start-up, the estimate store's erase at boot) the watchdog runs with
/// [`ERASE_WATCHDOG_TIMEOUT_US`].
pub const WATCHDOG_TIMEOUT_US: u32 = 250_000;

/// A board: what the application needs from it, and nothing else.
pub trait Board {
    /// The four capsules: blocks of [`BLOCK_FRAMES`] sample frames, with overrun reports.
    type Audio: SampleSource<BLOCK_FRAMES>;
    /// The frame link (a UART).
    type Link: FrameWriter;
    /// The watchdog.
    type Watchdog: Watchdog;
    /// The flash of the estimate store (offsets from its start; [`crate::estimate_store`]).
    type EstimateFlash: embedded_storage::nor_flash::NorFlash;
    /// Offset of the estimate store in [`Self::EstimateFlash`].
    const ESTIMATE_STORE_OFFSET: u32;
    /// Bytes of the estimate store: two halves of whole erase units.
    const ESTIMATE_STORE_LEN: u32;
    /// The watchdog's timeout while the application runs, µs ([`Watchdog::unleash`]).
    const WATCHDOG_TIMEOUT_US: u32;

    /// Starts the board: its watchdog if it runs from boot, clocks, pins, peripherals, and the
    /// `embassy-time` driver (the application's timers and its defmt timestamps). Called once.
    fn init() -> Parts<Self>;
}

/// A started board's drivers, ready to be moved into tasks.
pub struct Parts<B: Board + ?Sized> {
    /// The four capsules.
    pub audio: B::Audio,
    /// The frame link.
    pub uart: B::Link,
    /// The watchdog (running with a boot timeout on the STM32 boards, not yet on the emulated one).
    pub watchdog: B::Watchdog,
    /// The flash of the estimate store, when the board has one.
    pub estimate_flash: Option<B::EstimateFlash>,
}

/// The capture lost samples (a DMA ring was lapped, or an I2S receiver overran).
///
/// When a [`SampleSource`] returns it, the source has already realigned itself: the next block starts
/// at a sample-frame boundary with every channel in its place. The samples between the last block
/// delivered and the next one are gone; the caller counts the event.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct Overrun;

/// Writing to the frame link failed (the board has logged the cause).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub struct WriteError;

/// Blocks of `N` sample frames from the capsules.
#[allow(async_fn_in_trait)] // single-threaded executor: no `Send` bound wanted
pub trait SampleSource<const N: usize> {
    /// Starts capturing. Called once, just before the first [`read`](Self::read).
    fn start(&mut self);

    /// Waits for the next block and writes it to `out`, or returns [`Overrun`] (then `out` is
    /// unspecified and the source is realigned; see [`Overrun`]).
    async fn read(&mut self, out: &mut [[f32; CHANNELS]; N]) -> Result<(), Overrun>;
}

/// The byte stream of the frame link.
#[allow(async_fn_in_trait)] // single-threaded executor: no `Send` bound wanted
pub trait FrameWriter {
    /// Writes all of `bytes`, waiting as long as the link needs.
    async fn write(&mut self, bytes: &[u8]) -> Result<(), WriteError>;
}

/// Timeout a board's watchdog is given around a flash erase of the estimate store, µs: a 128 KB
/// sector of the STM32F4 takes up to 4 s (datasheets, sector erase time at ×8 parallelism, the
/// slowest), and the independent watchdog's LSI clock may run fast (up to 47 kHz instead of 32:
/// 8 s nominal is 5.4 s then). The STM32 boards also start their watchdog with it at boot.
pub const ERASE_WATCHDOG_TIMEOUT_US: u32 = 8_000_000;

/// A watchdog that resets the board unless it is petted in time.
pub trait Watchdog {
    /// Sets the run-time timeout (the board's `WATCHDOG_TIMEOUT_US`) and restarts it: from here
    /// on the DSP task pets it after every block delivered. A board may have started it at boot,
    /// with a longer timeout; it cannot be switched off.
    fn unleash(&mut self);
    /// Restarts its timeout.
    fn pet(&mut self);
    /// Sets a longer timeout, `timeout_us`, and restarts it, for a blocking operation that
    /// outlasts the run-time timeout (a flash erase); [`unleash`](Self::unleash) sets the run-time
    /// one again.
    fn stretch(&mut self, timeout_us: u32);
}
