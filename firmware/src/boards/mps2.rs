//! The emulated board: QEMU `mps2-an386` (Cortex-M4F, 25 MHz system clock) running the same
//! application as the STM32F411CE board.
//!
//! | board interface   | emulated by                                                              |
//! |-------------------|--------------------------------------------------------------------------|
//! | sample blocks     | a 4-channel 16 kHz WAV file read through semihosting, paced by the clock |
//! | frame writer      | CMSDK APB UART0 (0x4000_4000; QEMU `-serial`), paced at 115 200 baud     |
//! | watchdog          | CMSDK APB watchdog (0x4000_8000, WDOGCLK = 25 MHz), reset enabled        |
//! | time              | SysTick (processor clock) as the `embassy-time` driver, 100 µs ticks     |
//! | estimate store    | a 16 KB host file with NOR flash's rules (optional third argument)       |
//!
//! The executor is embassy's, run by [`run_executor`], whose idle loop sleeps with `WFI`: QEMU
//! treats `WFE` (what embassy's thread-mode executor uses) as a no-op, so that loop would spin.
//!
//! The capture behaves like the F411's DMA rings: block `k` is complete when the clock reaches
//! `(k + 1) · BLOCK_FRAMES` sample frames after the start, and if the DSP task asks for a block
//! the ring ([`RING_FRAMES`]) has already overwritten, the samples in between are lost, the
//! capture continues at the frame being written now and the read returns [`Overrun`]. Run QEMU with
//! `-icount shift=4,sleep=off` (16 ns per instruction, ≈ 62 M instructions per second, the F411's
//! rate at ≈ 1.6 cycles per instruction): emulated time then follows the instructions executed, not
//! the host's load, so every run of the same image on the same WAV gives the same stream.
//!
//! The WAV path is the semihosting command line after the program name
//! (`-semihosting-config enable=on,target=native,arg=firmware-mps2,arg=PATH`; no spaces in PATH);
//! a further `arg=STORE` names the estimate store's file (created erased if missing; a file of
//! another length or with other content is refused), which then keeps the self-calibration's estimate from run to run as
//! flash keeps it on the STM32 boards.
//! Faults are selected by the word at [`FAULT_ADDR`] and reported on QEMU's stdout
//! ([`crate::emulated`]).
#![allow(unsafe_code)] // MMIO registers and semihosting calls, each with a `Note(unsafe)`

use crate::board_api::{self, FrameWriter, Overrun, Parts, SampleSource, WriteError};
use crate::emulated::{
    frames_after_us, us_for_frames, Fault, CAPTURE_STALL_US, DRAIN_US, FAULT_ADDR, FAULT_AT_FRAME,
    STATE_ADDR, UART_STALL_FROM_US, UART_STALL_US,
};
use crate::wav::{self, WavFormat};
use cma_core::capsule_estimate_record::{MAGIC, RECORD_LEN};
use cma_core::CHANNELS;
use core::sync::atomic::{AtomicBool, Ordering};
use cortex_m_semihosting::{debug, hprintln};
use embassy_executor::{raw, Spawner};
use embassy_time::{Duration, Instant, Timer};
use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use static_cell::StaticCell;

/// Sample frames per DSP block (2 ms at 16 kHz), as on every board.
pub use crate::board_api::BLOCK_FRAMES;
/// Input sample rate, Hz (the WAV must have it).
pub use crate::board_api::SAMPLE_RATE_HZ;
// The frame stream's baud rate (the transmitter is paced at it), the emulated DMA ring and the
// watchdog timeout: those of every board.
use crate::board_api::{RING_FRAMES, UART_BAUD, WATCHDOG_TIMEOUT_US};

/// Set by the executor's pender (a task was woken), cleared by [`run_executor`] before it sleeps.
static PENDED: AtomicBool = AtomicBool::new(false);

// Note(unsafe): the pender symbol the raw executor calls when a task is woken (any context).
#[allow(unsafe_code)]
#[export_name = "__pender"]
fn pender(_context: *mut ()) {
    PENDED.store(true, Ordering::Release);
}

/// Runs embassy's raw executor: `init` spawns the first task, then the loop polls whenever a task
/// was woken and otherwise sleeps with `WFI` until an interrupt (SysTick at least every 100 µs).
pub fn run_executor(init: impl FnOnce(Spawner)) -> ! {
    static EXECUTOR: StaticCell<raw::Executor> = StaticCell::new();
    let executor: &'static raw::Executor = EXECUTOR.init(raw::Executor::new(core::ptr::null_mut()));
    init(executor.spawner());
    loop {
        // Note(unsafe): `poll` is called only here, never re-entrantly (the pender only sets a flag).
        unsafe { executor.poll() };
        // With interrupts masked, a wake-up between the check and `WFI` still ends the sleep (the
        // pending interrupt wakes the core and is taken after `free`).
        cortex_m::interrupt::free(|_| {
            if !PENDED.swap(false, Ordering::AcqRel) {
                cortex_m::asm::wfi();
            }
        });
    }
}

/// The system clock of the mps2-an386 (SysTick's processor clock, the watchdog's WDOGCLK).
const SYSCLK_HZ: u32 = 25_000_000;

/// The longest header the capture parses (the data chunk must start within it).
const HEADER_BYTES: usize = 512;

mod time_driver {
    //! SysTick as the `embassy-time` driver: a 100 µs periodic interrupt counts periods (64 bits),
    //! the counter gives the time within a period, and each interrupt wakes the timers that are due
    //! (so a timer fires within 100 µs after its deadline).

    use super::SYSCLK_HZ;
    use core::cell::RefCell;
    use cortex_m::peripheral::{syst::SystClkSource, SCB, SYST};
    use cortex_m_rt::exception;
    use embassy_sync::blocking_mutex::{raw::CriticalSectionRawMutex, Mutex};
    use embassy_time_driver::{Driver, TICK_HZ};
    use embassy_time_queue_utils::Queue;

    /// Processor clock cycles per SysTick period (100 µs).
    const PERIOD_CYCLES: u32 = SYSCLK_HZ / 10_000;
    /// Processor clock cycles per `embassy-time` tick.
    const CYCLES_PER_TICK: u64 = SYSCLK_HZ as u64 / TICK_HZ;
    const _: () = assert!(CYCLES_PER_TICK * TICK_HZ == SYSCLK_HZ as u64);

    struct State {
        periods: u64,
        alarm: u64,
        queue: Queue,
    }

    struct SysTickDriver {
        state: Mutex<CriticalSectionRawMutex, RefCell<State>>,
    }

    impl SysTickDriver {
        /// Cycles since start; inside a critical section, so a pending wrap is not yet counted.
        fn cycles(periods: u64) -> u64 {
            let current = SYST::get_current();
            let (periods, current) = if SCB::is_pendst_pending() {
                // Wrapped after `periods` was counted: the counter is read again after the wrap.
                (periods + 1, SYST::get_current())
            } else {
                (periods, current)
            };
            periods * u64::from(PERIOD_CYCLES) + u64::from(PERIOD_CYCLES - 1 - current)
        }
    }

    impl Driver for SysTickDriver {
        fn now(&self) -> u64 {
            self.state
                .lock(|s| Self::cycles(s.borrow().periods) / CYCLES_PER_TICK)
        }

        fn schedule_wake(&self, at: u64, waker: &core::task::Waker) {
            self.state.lock(|s| {
                let mut s = s.borrow_mut();
                if s.queue.schedule_wake(at, waker) {
                    let now = Self::cycles(s.periods) / CYCLES_PER_TICK;
                    s.alarm = s.queue.next_expiration(now);
                }
            });
        }
    }

    embassy_time_driver::time_driver_impl!(static DRIVER: SysTickDriver = SysTickDriver {
        state: Mutex::new(RefCell::new(State { periods: 0, alarm: u64::MAX, queue: Queue::new() })),
    });

    /// Starts SysTick (before anything reads the time).
    pub fn init(mut syst: SYST) {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(PERIOD_CYCLES - 1);
        syst.clear_current();
        syst.enable_interrupt();
        syst.enable_counter();
    }

    #[exception]
    fn SysTick() {
        DRIVER.state.lock(|s| {
            let mut s = s.borrow_mut();
            s.periods += 1;
            let now = s.periods * u64::from(PERIOD_CYCLES) / CYCLES_PER_TICK;
            if now >= s.alarm {
                s.alarm = s.queue.next_expiration(now);
            }
        });
    }
}

/// Semihosting calls (QEMU `-semihosting-config enable=on,target=native`).
mod host {
    use cortex_m_semihosting::{nr, syscall, syscall1};

    /// The command line (`arg=` items joined by spaces) into `buf`; `None` if unavailable.
    pub fn command_line(buf: &mut [u8]) -> Option<&[u8]> {
        let mut block = [buf.as_mut_ptr() as usize, buf.len()];
        // Note(unsafe): SYS_GET_CMDLINE takes the address of `block` (buffer, size), writes at most
        // `buf.len()` bytes into `buf` and the length into `block[1]`.
        let r = unsafe { syscall1(nr::GET_CMDLINE, block.as_mut_ptr() as usize) };
        // Note(unsafe): the host wrote `block[1]` behind the compiler's back.
        let n = unsafe { core::ptr::read_volatile(&block[1]) };
        (r == 0).then(|| &buf[..n.min(buf.len())])
    }

    /// Opens `path` (NUL-terminated) for binary reading.
    pub fn open(path: &[u8]) -> Option<usize> {
        // Note(unsafe): the host reads `path.len() - 1` bytes of `path`, which ends in a NUL.
        let fd = unsafe { syscall!(OPEN, path.as_ptr(), nr::open::R_BINARY, path.len() - 1) };
        (fd != usize::MAX).then_some(fd)
    }

    /// Opens `path` (NUL-terminated) for binary reading and writing, creating it (empty) when
    /// `create` is set.
    pub fn open_rw(path: &[u8], create: bool) -> Option<usize> {
        let mode = if create {
            nr::open::RW_TRUNC_BINARY
        } else {
            nr::open::RW_BINARY
        };
        // Note(unsafe): as in `open`.
        let fd = unsafe { syscall!(OPEN, path.as_ptr(), mode, path.len() - 1) };
        (fd != usize::MAX).then_some(fd)
    }

    /// Writes `buf` at offset `at`; whether all of it was written.
    pub fn write_at(fd: usize, at: usize, buf: &[u8]) -> bool {
        // Note(unsafe): SYS_SEEK only moves the host's file position.
        if unsafe { syscall!(SEEK, fd, at) } != 0 {
            return false;
        }
        // Note(unsafe): SYS_WRITE reads `buf.len()` bytes of `buf` and returns how many it did not
        // write.
        (unsafe { syscall!(WRITE, fd, buf.as_ptr(), buf.len()) }) == 0
    }

    /// The length of an open file, bytes.
    pub fn len(fd: usize) -> Option<usize> {
        // Note(unsafe): SYS_FLEN only reads its argument.
        let n = unsafe { syscall!(FLEN, fd) };
        (n != usize::MAX).then_some(n)
    }

    /// Reads `buf.len()` bytes from offset `at`; returns how many arrived.
    pub fn read_at(fd: usize, at: usize, buf: &mut [u8]) -> usize {
        // Note(unsafe): SYS_SEEK only moves the host's file position.
        if unsafe { syscall!(SEEK, fd, at) } != 0 {
            return 0;
        }
        // Note(unsafe): SYS_READ writes at most `buf.len()` bytes into `buf` and returns how many
        // it did not read.
        let missing = unsafe { syscall!(READ, fd, buf.as_mut_ptr(), buf.len()) };
        buf.len().saturating_sub(missing)
    }
}

/// The stack's high-water mark, measured: [`stack_watermark::paint`] fills the stack below the
/// current stack pointer with a pattern at boot (before the localizer is built), and
/// [`stack_watermark::used`] finds the deepest word that no longer holds it. flip-link places the
/// stack below the statics, so its top is `_stack_start` and it grows towards the start of RAM.
mod stack_watermark {
    /// The pattern (unlikely as data: not a small integer, not a normal float's common bits).
    const PAINT: u32 = 0xA5C3_5A3C;
    /// Bytes below the stack's top that are painted and scanned (far more than the application
    /// needs; a deeper stack is reported as at least this).
    pub const SPAN: u32 = 64 * 1024;
    /// Bytes left unpainted just below the stack pointer of `paint` (its own frame's callees).
    const GUARD: u32 = 256;

    extern "C" {
        /// Top of the stack (cortex-m-rt's linker script; flip-link moves it below the statics).
        static _stack_start: u32;
    }

    fn top() -> u32 {
        // Note: the address of a linker symbol; its value is never read.
        core::ptr::addr_of!(_stack_start) as u32
    }

    /// Paints `[top − SPAN, sp − GUARD)`.
    pub fn paint() {
        let bottom = top() - SPAN;
        let end = cortex_m::register::msp::read().saturating_sub(GUARD) & !3;
        let mut a = bottom;
        while a < end {
            // Note(unsafe): `a` is word-aligned RAM of the stack region below the live stack
            // (flip-link: nothing else lives there), written only by this loop before anything
            // below the current frame is in use.
            unsafe { core::ptr::write_volatile(a as *mut u32, PAINT) };
            a += 4;
        }
    }

    /// Bytes of stack used since [`paint`]: from the top to the deepest word not holding the
    /// pattern (`SPAN` when none holds it).
    pub fn used() -> u32 {
        let bottom = top() - SPAN;
        let mut a = bottom;
        // Note(unsafe): reads of word-aligned RAM of the stack region below the current frame.
        while a < top() && unsafe { core::ptr::read_volatile(a as *const u32) } == PAINT {
            a += 4;
        }
        top() - a
    }
}

/// Writes a report line and exits QEMU with status 1.
fn fail(what: &str) -> ! {
    hprintln!("mps2: error: {}", what);
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::bkpt();
    }
}

/// The state that survives a watchdog reset (QEMU keeps RAM over a system reset and the loader
/// rewrites only the fault word).
#[repr(C)]
struct Persistent {
    magic: u32,
    boots: u32,
    resume_frame: u32,
}

const PERSISTENT_MAGIC: u32 = 0xC0DE_4D50;

fn persistent() -> *mut Persistent {
    STATE_ADDR as *mut Persistent
}

/// Reads the boot count and the resume frame, counts this boot.
fn count_boot() -> (u32, u64) {
    let p = persistent();
    // Note(unsafe): STATE_ADDR is RAM outside every linked section (memory-mps2.x), used only here
    // and in `remember_resume_frame`, by the one thread of execution.
    unsafe {
        if core::ptr::read_volatile(&(*p).magic) != PERSISTENT_MAGIC {
            core::ptr::write_volatile(
                p,
                Persistent {
                    magic: PERSISTENT_MAGIC,
                    boots: 0,
                    resume_frame: 0,
                },
            );
        }
        let boots = core::ptr::read_volatile(&(*p).boots) + 1;
        core::ptr::write_volatile(&mut (*p).boots, boots);
        (
            boots,
            u64::from(core::ptr::read_volatile(&(*p).resume_frame)),
        )
    }
}

/// Where the next boot resumes the capture.
fn remember_resume_frame(frame: u64) {
    // Note(unsafe): as in `count_boot`.
    unsafe { core::ptr::write_volatile(&mut (*persistent()).resume_frame, frame as u32) }
}

/// The fault word (written by QEMU's generic loader before the start, 0 otherwise).
fn fault_word() -> u32 {
    // Note(unsafe): FAULT_ADDR is RAM outside every linked section (memory-mps2.x).
    unsafe { core::ptr::read_volatile(FAULT_ADDR as *const u32) }
}

/// Offset of the estimate store in [`EstimateFlash`].
pub const ESTIMATE_STORE_OFFSET: u32 = 0;
/// Bytes of the emulated estimate store: two halves of one 8 KB erase unit each (56 records a
/// half; [`crate::estimate_store`]).
pub const ESTIMATE_STORE_LEN: u32 = 16 * 1024;

/// The estimate store's flash: a host file of [`ESTIMATE_STORE_LEN`] bytes named by the third
/// semihosting argument, with NOR flash's rules (a write can only clear bits; an erase sets whole
/// 8 KB units to `0xFF`). A new file starts erased.
pub struct EstimateFlash {
    fd: usize,
}

/// A semihosting read or write of the store file failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub struct HostIoError;

impl NorFlashError for HostIoError {
    fn kind(&self) -> NorFlashErrorKind {
        NorFlashErrorKind::Other
    }
}

impl ErrorType for EstimateFlash {
    type Error = HostIoError;
}

impl ReadNorFlash for EstimateFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), HostIoError> {
        check_range(offset, bytes.len())?;
        if host::read_at(self.fd, offset as usize, bytes) == bytes.len() {
            Ok(())
        } else {
            Err(HostIoError)
        }
    }

    fn capacity(&self) -> usize {
        ESTIMATE_STORE_LEN as usize
    }
}

/// Whether `len` bytes from `offset` lie in the store.
fn check_range(offset: u32, len: usize) -> Result<(), HostIoError> {
    if offset as usize + len <= ESTIMATE_STORE_LEN as usize {
        Ok(())
    } else {
        Err(HostIoError)
    }
}

impl NorFlash for EstimateFlash {
    const WRITE_SIZE: usize = 16;
    const ERASE_SIZE: usize = ESTIMATE_STORE_LEN as usize / 2;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), HostIoError> {
        let unit = Self::ERASE_SIZE as u32;
        if !(from.is_multiple_of(unit) && to.is_multiple_of(unit) && from < to)
            || to > ESTIMATE_STORE_LEN
        {
            return Err(HostIoError);
        }
        let ones = [0xFFu8; 256];
        for at in (from as usize..to as usize).step_by(ones.len()) {
            if !host::write_at(self.fd, at, &ones) {
                return Err(HostIoError);
            }
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), HostIoError> {
        check_range(offset, bytes.len())?;
        if !(offset as usize).is_multiple_of(Self::WRITE_SIZE)
            || !bytes.len().is_multiple_of(Self::WRITE_SIZE)
        {
            return Err(HostIoError);
        }
        for (i, new) in bytes.chunks_exact(Self::WRITE_SIZE).enumerate() {
            let at = offset as usize + i * Self::WRITE_SIZE;
            let mut cell = [0u8; Self::WRITE_SIZE];
            if host::read_at(self.fd, at, &mut cell) != cell.len() {
                return Err(HostIoError);
            }
            for (c, n) in cell.iter_mut().zip(new) {
                *c &= *n;
            }
            if !host::write_at(self.fd, at, &cell) {
                return Err(HostIoError);
            }
        }
        Ok(())
    }
}

/// Opens (or creates, erased) the store file named `arg`; a file of another length, or one holding
/// anything but records and erased bytes, is refused so that a mistyped path is never overwritten. Not inlined: its buffers stay off the boot path's
/// stack frame.
#[inline(never)]
fn open_estimate_flash(arg: &[u8]) -> EstimateFlash {
    let mut buf = [0u8; 256];
    let n = arg.len().min(buf.len() - 1);
    buf[..n].copy_from_slice(&arg[..n]);
    let path = &buf[..n + 1];
    if let Some(fd) = host::open_rw(path, false) {
        match host::len(fd) {
            Some(n) if n == ESTIMATE_STORE_LEN as usize => {
                if !holds_only_records(fd) {
                    fail("the estimate store file holds something other than records: not a store image")
                }
                return EstimateFlash { fd };
            }
            n => {
                hprintln!(
                    "mps2: error: the estimate store file has {:?} bytes, not {}: not a store image",
                    n,
                    ESTIMATE_STORE_LEN
                );
                fail("unsuitable estimate store file")
            }
        }
    }
    let Some(fd) = host::open_rw(path, true) else {
        fail("cannot create the estimate store file")
    };
    let mut flash = EstimateFlash { fd };
    if flash.erase(0, ESTIMATE_STORE_LEN).is_err() {
        fail("cannot write the estimate store file")
    }
    flash
}

/// Whether every slot of the open store file is erased or starts with a record's magic (a record,
/// or one whose write was cut short) and the bytes after the last slot are erased: what only the
/// estimate store writes.
fn holds_only_records(fd: usize) -> bool {
    let mut slot = [0u8; RECORD_LEN];
    let slots = ESTIMATE_STORE_LEN as usize / RECORD_LEN;
    let tail = ESTIMATE_STORE_LEN as usize % RECORD_LEN;
    (0..slots).all(|i| {
        host::read_at(fd, i * RECORD_LEN, &mut slot) == RECORD_LEN
            && (slot.starts_with(&MAGIC) || slot.iter().all(|&b| b == 0xFF))
    }) && host::read_at(fd, slots * RECORD_LEN, &mut slot[..tail]) == tail
        && slot[..tail].iter().all(|&b| b == 0xFF)
}

/// The four capsules: blocks of the WAV file, released at the sample clock's pace.
pub struct AudioIn {
    fd: usize,
    format: WavFormat,
    /// Sample frames in the file.
    file_frames: u64,
    /// WAV frame the capture started from (0 after power-on).
    first_frame: u64,
    /// Start of the capture clock.
    t0: Instant,
    /// Capture frames (since `t0`) delivered or lost so far: the next block starts here.
    next: u64,
    /// The capture fault still to be injected.
    fault: Fault,
    raw: [u8; BLOCK_FRAMES * CHANNELS * 4],
}

impl AudioIn {
    fn elapsed_frames(&self) -> u64 {
        frames_after_us(
            Instant::now().duration_since(self.t0).as_micros(),
            SAMPLE_RATE_HZ,
        )
    }

    /// Injects the capture fault once the capture reaches [`FAULT_AT_FRAME`].
    fn inject(&mut self) {
        if self.next < FAULT_AT_FRAME {
            return;
        }
        match self.fault {
            Fault::CaptureStall => {
                hprintln!("mps2: fault {}", Fault::CaptureStall.name());
                let until = Instant::now() + Duration::from_micros(CAPTURE_STALL_US);
                while Instant::now() < until {}
            }
            Fault::DspHang => {
                // The samples keep coming while the task hangs and the board resets: the next boot
                // resumes one watchdog timeout later.
                let lost = frames_after_us(u64::from(WATCHDOG_TIMEOUT_US), SAMPLE_RATE_HZ);
                remember_resume_frame(self.first_frame + self.next + lost);
                hprintln!("mps2: fault {}", Fault::DspHang.name());
                loop {
                    cortex_m::asm::nop();
                }
            }
            Fault::None | Fault::UartStall => {}
        }
        self.fault = Fault::None;
    }

    /// The input is used up: disables the watchdog, lets the UART drain, exits QEMU with status 0.
    async fn finish(&mut self) -> ! {
        hprintln!(
            "mps2: end of input at frame {}",
            self.first_frame + self.next
        );
        hprintln!(
            "mps2: stack high-water mark {} bytes (of {} watched)",
            stack_watermark::used(),
            stack_watermark::SPAN
        );
        watchdog_registers::disable();
        Timer::after(Duration::from_micros(DRAIN_US)).await;
        debug::exit(debug::EXIT_SUCCESS);
        loop {
            cortex_m::asm::bkpt();
        }
    }
}

impl SampleSource<BLOCK_FRAMES> for AudioIn {
    fn start(&mut self) {
        self.t0 = Instant::now();
        self.next = 0;
    }

    async fn read(&mut self, out: &mut [[f32; CHANNELS]; BLOCK_FRAMES]) -> Result<(), Overrun> {
        let complete = self.next + BLOCK_FRAMES as u64;
        Timer::at(self.t0 + Duration::from_micros(us_for_frames(complete, SAMPLE_RATE_HZ))).await;
        self.inject();
        let written = self.elapsed_frames();
        if written > self.next + RING_FRAMES as u64 {
            hprintln!(
                "mps2: overrun: frames {}..{} lost",
                self.first_frame + self.next,
                self.first_frame + written
            );
            self.next = written;
            return Err(Overrun);
        }
        let at = self.first_frame + self.next;
        if at + BLOCK_FRAMES as u64 > self.file_frames {
            self.finish().await;
        }
        let bytes = BLOCK_FRAMES * self.format.frame_bytes();
        let offset = self.format.data_offset as usize + at as usize * self.format.frame_bytes();
        if host::read_at(self.fd, offset, &mut self.raw[..bytes]) != bytes {
            fail("reading the WAV file failed");
        }
        self.format.encoding.decode_frames(&self.raw[..bytes], out);
        self.next = complete;
        Ok(())
    }
}

/// CMSDK APB UART0 registers.
mod uart_registers {
    const BASE: usize = 0x4000_4000;
    const DATA: *mut u32 = BASE as *mut u32;
    const STATE: *const u32 = (BASE + 0x04) as *const u32;
    const CTRL: *mut u32 = (BASE + 0x08) as *mut u32;
    const BAUDDIV: *mut u32 = (BASE + 0x10) as *mut u32;

    /// Enables the transmitter at `baud` from the 25 MHz peripheral clock.
    pub fn init(baud: u32) {
        // Note(unsafe): fixed MMIO registers of UART0, used only by this module.
        unsafe {
            core::ptr::write_volatile(BAUDDIV, super::SYSCLK_HZ / baud);
            core::ptr::write_volatile(CTRL, 1);
        }
    }

    /// Writes one byte if the transmit buffer has room.
    pub fn try_write(byte: u8) -> bool {
        // Note(unsafe): as above; STATE bit 0 = transmit buffer full.
        unsafe {
            if core::ptr::read_volatile(STATE) & 1 != 0 {
                return false;
            }
            core::ptr::write_volatile(DATA, u32::from(byte));
        }
        true
    }
}

/// The frame-stream UART. QEMU's UART model sends each byte at once; the writer holds each line
/// for its time on the wire at [`UART_BAUD`] (10 bits per byte), so the frame queue drains no
/// faster than on the board.
pub struct FrameTx {
    stalled: bool,
    wire_free: Instant,
}

impl FrameWriter for FrameTx {
    async fn write(&mut self, bytes: &[u8]) -> Result<(), WriteError> {
        if self.stalled {
            let from = Instant::from_micros(UART_STALL_FROM_US);
            let until = from + Duration::from_micros(UART_STALL_US);
            let now = Instant::now();
            if now >= from && now < until {
                hprintln!("mps2: fault {}", Fault::UartStall.name());
                Timer::at(until).await;
            }
            if Instant::now() >= until {
                self.stalled = false;
            }
        }
        for &b in bytes {
            while !uart_registers::try_write(b) {
                Timer::after(Duration::from_micros(100)).await;
            }
        }
        let wire_us = bytes.len() as u64 * 10 * 1_000_000 / u64::from(UART_BAUD);
        self.wire_free = self.wire_free.max(Instant::now()) + Duration::from_micros(wire_us);
        Timer::at(self.wire_free).await;
        Ok(())
    }
}

/// CMSDK APB watchdog registers.
mod watchdog_registers {
    const BASE: usize = 0x4000_8000;
    const LOAD: *mut u32 = BASE as *mut u32;
    const CONTROL: *mut u32 = (BASE + 0x08) as *mut u32;
    const INTCLR: *mut u32 = (BASE + 0x0C) as *mut u32;
    const LOCK: *mut u32 = (BASE + 0xC00) as *mut u32;
    const UNLOCK: u32 = 0x1ACC_E551;
    /// CONTROL: reset enable (the interrupt, wired to NMI, stays off).
    const RESEN: u32 = 1 << 1;

    fn unlocked(f: impl FnOnce()) {
        // Note(unsafe): fixed MMIO registers of the watchdog, used only by this module.
        unsafe {
            core::ptr::write_volatile(LOCK, UNLOCK);
            f();
            core::ptr::write_volatile(LOCK, 0);
        }
    }

    /// Starts it: the counter expires after `load` cycles (internal interrupt flag set), and again
    /// `load` cycles later with the flag still set it resets the system.
    pub fn start(load: u32) {
        // Note(unsafe): as above.
        unlocked(|| unsafe {
            core::ptr::write_volatile(LOAD, load);
            core::ptr::write_volatile(CONTROL, RESEN);
        });
    }

    /// Clears the flag and reloads the counter.
    pub fn pet() {
        // Note(unsafe): as above.
        unlocked(|| unsafe { core::ptr::write_volatile(INTCLR, 1) });
    }

    /// Keeps it from resetting the system.
    pub fn disable() {
        // Note(unsafe): as above.
        unlocked(|| unsafe { core::ptr::write_volatile(CONTROL, 0) });
    }
}

/// The CMSDK watchdog: resets the board [`WATCHDOG_TIMEOUT_US`] after the last pet.
pub struct Watchdog;

/// The CMSDK watchdog's LOAD for a reset `timeout_us` after the last pet (two expiries of LOAD
/// cycles reset the system).
fn watchdog_load(timeout_us: u32) -> u32 {
    (u64::from(SYSCLK_HZ) * u64::from(timeout_us) / 2_000_000) as u32
}

impl board_api::Watchdog for Watchdog {
    fn unleash(&mut self) {
        watchdog_registers::start(watchdog_load(WATCHDOG_TIMEOUT_US));
    }

    fn pet(&mut self) {
        watchdog_registers::pet();
    }

    fn stretch(&mut self, timeout_us: u32) {
        watchdog_registers::start(watchdog_load(timeout_us));
        watchdog_registers::pet();
    }
}

/// The emulated board on QEMU `mps2-an386`.
pub struct Mps2;

/// The board the binary runs.
pub type Selected = Mps2;

impl board_api::Board for Mps2 {
    type Audio = AudioIn;
    type Link = FrameTx;
    type Watchdog = Watchdog;
    type EstimateFlash = EstimateFlash;
    const ESTIMATE_STORE_OFFSET: u32 = ESTIMATE_STORE_OFFSET;
    const ESTIMATE_STORE_LEN: u32 = ESTIMATE_STORE_LEN;
    const WATCHDOG_TIMEOUT_US: u32 = WATCHDOG_TIMEOUT_US;

    fn init() -> Parts<Self> {
        init()
    }
}

/// Starts the clock, the UART and the capture (opens and checks the WAV named on the semihosting
/// command line); a missing or unsuitable WAV ends QEMU with status 1 and a report line.
fn init() -> Parts<Mps2> {
    stack_watermark::paint();
    // Note(unwrap-like): `init` runs once, so the core peripherals are still there.
    let Some(core) = cortex_m::Peripherals::take() else {
        fail("core peripherals taken twice")
    };
    time_driver::init(core.SYST);
    uart_registers::init(UART_BAUD);

    let (boots, first_frame) = count_boot();
    let fault = if boots == 1 {
        Fault::from_word(fault_word())
    } else {
        Fault::None
    };

    let mut cmdline = [0u8; 256];
    let Some(line) = host::command_line(&mut cmdline[..255]) else {
        fail("no semihosting command line (QEMU -semihosting-config ...,arg=firmware-mps2,arg=WAV)")
    };
    let line_len = line.len();
    // Arguments: the program name, the WAV, optionally the estimate store file.
    let mut args = cmdline[..line_len]
        .split(|&c| c == b' ')
        .filter(|a| !a.is_empty())
        .skip(1);
    let mut path = [0u8; 256];
    let Some(wav_arg) = args.next() else {
        fail("no WAV path on the semihosting command line")
    };
    path[..wav_arg.len()].copy_from_slice(wav_arg);
    let Some(fd) = host::open(&path[..wav_arg.len() + 1]) else {
        fail("cannot open the WAV file")
    };
    let estimate_flash = args.next().map(open_estimate_flash);
    let mut head = [0u8; HEADER_BYTES];
    let got = host::read_at(fd, 0, &mut head);
    let format = match wav::parse_header(&head[..got]) {
        Ok(f) => f,
        Err(e) => {
            hprintln!("mps2: error: not a readable WAV file: {:?}", e);
            fail("bad WAV header")
        }
    };
    if format.channels as usize != CHANNELS || format.rate_hz != SAMPLE_RATE_HZ {
        hprintln!(
            "mps2: error: the WAV has {} channels at {} Hz; the board captures {} at {} Hz",
            format.channels,
            format.rate_hz,
            CHANNELS,
            SAMPLE_RATE_HZ
        );
        fail("unsuitable WAV");
    }
    let Some(len) = host::len(fd) else {
        fail("cannot read the WAV file's length")
    };
    let data = (len.saturating_sub(format.data_offset as usize)).min(format.data_len as usize);
    let file_frames = (data / format.frame_bytes()) as u64;
    hprintln!(
        "mps2: boot {}: capture from frame {} of {}",
        boots,
        first_frame,
        file_frames
    );

    Parts {
        audio: AudioIn {
            fd,
            format,
            file_frames,
            first_frame,
            t0: Instant::from_ticks(0),
            next: 0,
            fault: if matches!(fault, Fault::CaptureStall | Fault::DspHang) {
                fault
            } else {
                Fault::None
            },
            raw: [0; BLOCK_FRAMES * CHANNELS * 4],
        },
        uart: FrameTx {
            stalled: fault == Fault::UartStall,
            wire_free: Instant::from_ticks(0),
        },
        watchdog: Watchdog,
        estimate_flash,
    }
}
