//! The application: a DSP task (capture → core → estimates) and a UART task (estimates → frame lines).
//!
//! ```text
//! I2S2 + I2S3 ─DMA rings─▶ dsp_task ─ Locator ─▶ ESTIMATES (bounded) ─▶ uart_task ─DMA─▶ USART1
//!                              │ overruns counted,                │ full: frame dropped, counted
//!                              └ watchdog petted per block        └ one `$CMA,…` line per estimate
//! ```

use crate::board::{self, AudioIn, FrameTx, Watchdog, BLOCK_FRAMES, SAMPLE_RATE_HZ};
use cma_core::wire;
use cma_core::{Estimate, Locator, LocatorConfig, ReferenceTable, CHANNELS};
use cma_firmware::stats::Counters;
use embassy_executor::Spawner;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use static_cell::StaticCell;

/// Estimates waiting for the UART (≈ 85 ms of estimates at one per 21.3 ms).
const QUEUE_LEN: usize = 4;

static ESTIMATES: Channel<CriticalSectionRawMutex, Estimate, QUEUE_LEN> = Channel::new();
static COUNTERS: Counters = Counters::new();
/// The localizer (36 776 B, `llvm-nm -S` of the release image), built in place by
/// `Locator::init_in_place` (no stack temporary).
static LOCATOR: StaticCell<Locator<'static>> = StaticCell::new();

/// Starts the board and the tasks.
pub async fn run(spawner: Spawner) {
    let board = board::init();
    defmt::info!(
        "cma firmware: {} Hz, {} sample frames per block",
        SAMPLE_RATE_HZ,
        BLOCK_FRAMES
    );

    let locator = init_locator();

    spawner.spawn(uart_task(board.uart).unwrap());
    spawner.spawn(dsp_task(board.audio, locator, board.watchdog).unwrap());
}

/// Builds the localizer in [`LOCATOR`]. Not inlined, so that its stack frame (≈ 3 KB of small
/// temporaries of the in-place construction) is released before the tasks run and does not add to the
/// main task's frame.
#[inline(never)]
fn init_locator() -> &'static mut Locator<'static> {
    // Note(unwrap-like panic): the default configuration and the built-in table are valid at 48 kHz;
    // a failure here is a build defect and panics at boot.
    match Locator::init_in_place(
        LOCATOR.uninit(),
        LocatorConfig::default(),
        ReferenceTable::ideal_5deg(),
        SAMPLE_RATE_HZ,
    ) {
        Ok(l) => l,
        Err(e) => defmt::panic!("localizer configuration rejected: {}", e),
    }
}

/// Captures blocks, runs the localizer, queues the estimates.
///
/// Real-time contract: each call of `AudioIn::read` returns [`BLOCK_FRAMES`] sample frames (0.67 ms
/// at 48 kHz); every 32nd block completes an analysis hop (1024 input samples, 21.3 ms), whose
/// analysis must end before the DMA rings ([`board::RING_FRAMES`] = 256 sample frames, 5.3 ms) fill. When they do fill, the
/// overrun is counted, both receivers are restarted in step and the count appears in the `ovr` field of
/// the following frames; the localizer keeps its state (its sample clock then runs behind the input by
/// the samples lost). Estimates never wait for the UART: when the queue is full they are dropped and
/// counted in the `drop` field.
#[embassy_executor::task]
async fn dsp_task(
    mut audio: AudioIn,
    locator: &'static mut Locator<'static>,
    mut watchdog: Watchdog,
) {
    let mut block = [[0.0f32; CHANNELS]; BLOCK_FRAMES];
    watchdog.unleash();
    audio.start();
    loop {
        watchdog.pet();
        if audio.read(&mut block).await.is_err() {
            COUNTERS.count_overrun();
            defmt::warn!("I2S overrun #{}: capture realigned", COUNTERS.overruns());
            continue;
        }
        locator.process_block(&block, |e| {
            if ESTIMATES.try_send(*e).is_err() {
                COUNTERS.count_dropped();
            }
        });
    }
}

/// Encodes queued estimates as frame lines and writes them to the UART.
#[embassy_executor::task]
async fn uart_task(mut uart: FrameTx) {
    let mut line = [0u8; wire::MAX_LINE];
    // `seq` counts lines sent (docs/wire-format.md): frames dropped by backpressure show in `drop`.
    let mut seq: u32 = 0;
    loop {
        let e = ESTIMATES.receive().await;
        let frame = wire::Frame::from_estimate(
            &e,
            seq,
            SAMPLE_RATE_HZ,
            COUNTERS.overruns(),
            COUNTERS.dropped(),
        );
        seq = seq.wrapping_add(1);
        let n = wire::encode(&frame, &mut line);
        if let Err(err) = uart.write(&line[..n]).await {
            defmt::warn!("UART write failed: {}", err);
        }
    }
}
