//! The application: a DSP task (capture → core → estimates) and a UART task (estimates → frame lines,
//! self-calibration snapshots → calibration lines, background-field snapshots → background
//! lines), the same on every board.
//!
//! ```text
//! Board::Audio ─blocks─▶ dsp_task ─ Locator ─▶ OUTGOING (bounded) ─▶ uart_task ─▶ Board::Link
//!  (SampleSource)             │ overruns counted,                │ full: line dropped, counted
//!                             │ watchdog petted per block read   │ one `$CMA,…` line per estimate,
//!                             ├ self-calibration snapshot at     ├ one `$CAL,…` line per snapshot
//!                             │ start and every 10 s             │
//!                             └ background-field snapshot one    └ one `$BGF,…` line per snapshot
//!                               hop after each of those
//! ```
//!
//! It sees the board only through the board contract, [`crate::board_api::Board`], and the
//! traits and constants of [`crate::board_api`]; the board is [`crate::boards::Selected`], the one
//! the build's `board-*` feature selects (`src/boards/f411.rs`: STM32F411CE with two I2S ADCs;
//! `src/boards/f446.rs`: NUCLEO-F446RE with one 4-channel TDM ADC on SAI; `src/boards/mps2.rs`:
//! QEMU `mps2-an386`). Each binary (`src/bin/`) starts [`run`] on its board.
//!
//! The self-calibration starts from the newest estimate the board saved in its flash
//! ([`crate::estimate_store`]), else from the one embedded at build time
//! ([`crate::stored_capsules`], `CMA_SELFCAL=path`; ideal without it), and saves a confident,
//! changed estimate at a calibration snapshot at most once a minute. A build with
//! the `multi-talker` feature runs the multi-talker tracks and sends a `$TRK,…` line after every
//! frame line.

use crate::board_api::{
    Board, FrameWriter, SampleSource, Watchdog as _, BLOCK_FRAMES, ERASE_WATCHDOG_TIMEOUT_US,
    SAMPLE_RATE_HZ,
};
use crate::estimate_store::{EstimateStore, SavePolicy};
use crate::stats::Counters;
use crate::stored_capsules;
use cma_core::capsule_calibration::CapsuleEstimate;
use cma_core::capsule_estimate_record::key_of;
use cma_core::wire::{self, BackgroundLine, CalibrationLine, CalibrationSchedule, TracksLine};
use cma_core::{Estimate, Locator, LocatorConfig, ReferenceTable, CHANNELS};
use embassy_executor::Spawner;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::channel::Channel;
use static_cell::StaticCell;

/// The board this binary runs ([`Board`]).
type ThisBoard = crate::boards::Selected;
/// Its capsules.
type AudioIn = <ThisBoard as Board>::Audio;
/// Its frame link.
type FrameTx = <ThisBoard as Board>::Link;
/// Its watchdog.
type Watchdog = <ThisBoard as Board>::Watchdog;
/// Its estimate store's flash.
type EstimateFlash = <ThisBoard as Board>::EstimateFlash;

/// Lines waiting for the UART (≈ 64 ms of estimates at one per 16 ms; a calibration line, ≈ 15 ms
/// on the wire every 10 s, fits in that slack; with the multi-talker tracks a track line, at most
/// 98 bytes, follows each frame line: a hop of 16 ms carries 184 bytes at 115200 baud, enough for a
/// typical pair, and the queue absorbs the longest ones; what still does not fit is dropped and
/// counted in `drop`).
const QUEUE_LEN: usize = if MULTI_TALKER { 8 } else { 4 };

/// The multi-talker tracks run and track lines are sent: the build enabled the `multi-talker`
/// feature.
const MULTI_TALKER: bool = cfg!(feature = "multi-talker");
/// Whether the board measures the stationary background and sends its background lines (the
/// `noise-field` feature, on for every board; without it the image leaves both out, ≈ 4 KB of
/// flash).
const NOISE_FIELD: bool = cfg!(feature = "noise-field");

/// What the DSP task hands to the UART task: raw values, formatted there.
enum Outgoing {
    /// One estimate → one frame line.
    Estimate(Estimate),
    /// A snapshot of the self-calibration → one calibration line.
    Calibration {
        /// The estimate ([`Locator::capsule_estimate`]).
        capsules: CapsuleEstimate,
        /// Its confidence ([`Locator::capsule_confidence`]).
        confidence: f32,
        /// `centre_sample` of the last estimate before the snapshot (0 at start).
        centre_sample: u64,
    },
    /// The active multi-talker tracks after an estimate → one track line (its `seq` is set when
    /// it is sent).
    Tracks(TracksLine),
    /// The stationary background per band → one background line (its `seq` is set when it is
    /// sent).
    Background(BackgroundLine),
}

static OUTGOING: Channel<CriticalSectionRawMutex, Outgoing, QUEUE_LEN> = Channel::new();
static COUNTERS: Counters = Counters::new();
/// The localizer (36 776 B, `llvm-nm -S` of the release image), built in place by
/// `Locator::init_in_place` (no stack temporary).
static LOCATOR: StaticCell<Locator<'static>> = StaticCell::new();

/// Starts the board and the tasks.
pub async fn run(spawner: Spawner) {
    let board = ThisBoard::init();
    defmt::info!(
        "cma firmware: {} Hz, {} sample frames per block",
        SAMPLE_RATE_HZ,
        BLOCK_FRAMES
    );

    let locator = init_locator();
    let persistence = board
        .estimate_flash
        .and_then(|flash| open_estimate_store(flash, locator));

    spawner.spawn(uart_task(board.uart).unwrap());
    spawner.spawn(dsp_task(board.audio, locator, board.watchdog, persistence).unwrap());
}

/// The estimate store and when to save to it.
type Persistence = (EstimateStore<EstimateFlash>, SavePolicy);

/// The persistence state, built in place by [`open_estimate_store`] (the tasks' futures hold a
/// pointer to it, not a copy, which keeps it off the boot path's stack frames).
static PERSISTENCE: StaticCell<Persistence> = StaticCell::new();

/// Opens the estimate store (when the self-calibration runs): the self-calibration starts from its
/// newest record of this build, and the spare half is erased now, before the capture starts,
/// unless it is blank (it holds nothing newer of this build; the boards' watchdog runs with its
/// boot timeout, [`ERASE_WATCHDOG_TIMEOUT_US`], until the DSP task starts).
#[inline(never)]
fn open_estimate_store(
    flash: EstimateFlash,
    locator: &mut Locator<'_>,
) -> Option<&'static mut Persistence> {
    if !locator.config().capsule_calibration.enabled {
        return None;
    }
    let key = key_of(&stored_capsules::STORED);
    let (mut store, scan) = match EstimateStore::open(
        flash,
        ThisBoard::ESTIMATE_STORE_OFFSET,
        ThisBoard::ESTIMATE_STORE_LEN,
        key,
    ) {
        Ok(opened) => opened,
        Err(e) => {
            defmt::warn!("estimate store unreadable ({}): not used", e);
            return None;
        }
    };
    if let Some(latest) = scan.latest {
        locator.set_capsule_estimate(&latest.estimate);
        defmt::info!(
            "self-calibration starts from stored record {} ({} records, {} skipped)",
            latest.sequence,
            scan.records,
            scan.skipped
        );
    }
    if !store.spare_is_blank() {
        defmt::info!("estimate store: erasing the spare half");
        if let Err(e) = store.erase_spare() {
            defmt::warn!("estimate store: erase failed: {}", e);
        }
    }
    let loaded = scan.latest.map(|r| r.estimate);
    Some(PERSISTENCE.init((store, SavePolicy::new(SAMPLE_RATE_HZ, loaded.as_ref()))))
}

/// Builds the localizer in [`LOCATOR`]. Not inlined, so that its stack frame (the small temporaries
/// of the in-place construction: configuration copies, the curve builder) is released before the
/// tasks run and does not add to the main task's frame.
#[inline(never)]
fn init_locator() -> &'static mut Locator<'static> {
    // The table embedded at build time: measured with `CMA_TABLE`, else the ideal model. A measured
    // table already describes the capsules, so the self-calibration (which maps them to the ideal
    // model) is off with one.
    // The configuration embedded at build time: `CMA_CONFIG`, else `LocatorConfig::default()`.
    let mut config: LocatorConfig = crate::embedded_config::CONFIG;
    if cma_core::embedded_table::HAS_MEASURED_TABLE {
        config.capsule_calibration.enabled = false;
    }
    if MULTI_TALKER {
        config.multi_track = cma_core::multi_track::MultiTrack::DEFAULT;
    }
    // Note(unwrap-like panic): the embedded configuration (checked by build.rs) and the embedded
    // table (checked when it was built in) are valid at 16 kHz; a failure here is a build defect and
    // panics at boot.
    let locator = match Locator::init_in_place(
        LOCATOR.uninit(),
        config,
        ReferenceTable::embedded(),
        SAMPLE_RATE_HZ,
    ) {
        Ok(l) => l,
        Err(e) => defmt::panic!("localizer configuration rejected: {}", e),
    };
    locator.set_capsule_estimate(&stored_capsules::STORED);
    if let Some(source) = stored_capsules::SOURCE {
        defmt::info!("self-calibration starts from {}", source);
    }
    locator
}

/// Queues a snapshot of the self-calibration for a calibration line; a full queue drops it (counted).
fn send_calibration(locator: &Locator<'_>, centre_sample: u64) {
    let snapshot = Outgoing::Calibration {
        capsules: *locator.capsule_estimate(),
        confidence: locator.capsule_confidence(),
        centre_sample,
    };
    if OUTGOING.try_send(snapshot).is_err() {
        COUNTERS.count_calibration_dropped();
    }
}

/// Queues a snapshot of the background field for a background line; a full queue drops it
/// (counted in the frame lines' `drop`). Not inlined: it runs every 10 s, outside the hop's work.
#[inline(never)]
fn send_background(locator: &Locator<'_>, centre_sample: u64) {
    let line = BackgroundLine::from_summary(&locator.background_field(), 0, centre_sample);
    if OUTGOING.try_send(Outgoing::Background(line)).is_err() {
        COUNTERS.count_dropped();
    }
}

/// Captures blocks, runs the localizer, queues the estimates.
///
/// Real-time contract: each call of `AudioIn::read` returns [`BLOCK_FRAMES`] sample frames; the
/// blocks that complete an analysis hop (256 input samples, 16 ms at 16 kHz) carry its analysis,
/// which must end before the board's capture ring ([`crate::board_api::RING_FRAMES`]) fills. When it does fill,
/// the board realigns the capture and reports an overrun, which is counted and appears in the `ovr`
/// field of the following frames; the localizer keeps its state (its sample clock then runs behind
/// the input by the samples lost). Estimates never wait for the UART: when the queue is full they
/// are dropped and counted in the `drop` field.
///
/// Before the first block and then after the first estimate at least
/// [`wire::CALIBRATION_PERIOD_S`] seconds after the previous one ([`CalibrationSchedule`]), the
/// self-calibration's estimate is copied (≈ 0.1 KB, outside the localizer's per-hop work) and queued
/// the same way; a full queue drops it and counts it in the calibration line's `drop` field. The
/// background field's summary follows one hop later (after the next estimate, so that the two
/// lines do not share a hop's slack on the UART) as a background line.
/// At a snapshot the [`SavePolicy`] may decide to save the estimate to the store, which happens
/// [`SAVE_DELAY_BLOCKS`] blocks later.
#[embassy_executor::task]
async fn dsp_task(
    mut audio: AudioIn,
    locator: &'static mut Locator<'static>,
    mut watchdog: Watchdog,
    mut persistence: Option<&'static mut Persistence>,
) {
    let mut block = [[0.0f32; CHANNELS]; BLOCK_FRAMES];
    let mut schedule = CalibrationSchedule::new(SAMPLE_RATE_HZ);
    let mut save_in_blocks: Option<u8> = None;
    // A background line is due at the next estimate after a calibration line.
    let mut background_due = false;
    if schedule.due(0) {
        send_calibration(locator, 0);
        background_due = true;
    }
    watchdog.unleash();
    audio.start();
    loop {
        if audio.read(&mut block).await.is_err() {
            COUNTERS.count_overrun();
            defmt::warn!("capture overrun #{}: realigned", COUNTERS.overruns());
            continue;
        }
        // Only progress pets the watchdog: a capture that fails block after block resets the board.
        watchdog.pet();
        let mut calibration_due = None;
        let mut estimated = None;
        locator.process_block(&block, |e| {
            if OUTGOING.try_send(Outgoing::Estimate(*e)).is_err() {
                COUNTERS.count_dropped();
            }
            if schedule.due(e.centre_sample) {
                calibration_due = Some(e.centre_sample);
            }
            estimated = Some(e.centre_sample);
        });
        // A block (32 sample frames) completes at most one hop (256), so these are the tracks
        // the core decided after that estimate (those of an earlier frame, `t` says which).
        if let Some(decided) = (MULTI_TALKER && estimated.is_some())
            .then(|| locator.talker_tracks())
            .flatten()
        {
            let t = locator.centre_sample(decided.frame_index);
            let tracks = TracksLine::from_tracks(decided.tracks(), 0, t);
            if OUTGOING.try_send(Outgoing::Tracks(tracks)).is_err() {
                COUNTERS.count_dropped();
            }
        }
        if let (true, Some(centre_sample)) = (NOISE_FIELD && background_due, estimated) {
            send_background(locator, centre_sample);
            background_due = false;
        }
        if let Some(centre_sample) = calibration_due {
            send_calibration(locator, centre_sample);
            background_due = true;
            if let Some((_, policy)) = persistence.as_mut() {
                if save_due(policy, locator, centre_sample) {
                    save_in_blocks = Some(SAVE_DELAY_BLOCKS);
                }
            }
        }
        save_in_blocks = match save_in_blocks {
            Some(0) => {
                if let Some((store, _)) = persistence.as_mut() {
                    save_estimate(store, locator.capsule_estimate(), &mut watchdog);
                }
                None
            }
            n => n.map(|n| n - 1),
        };
    }
}

/// Blocks between a calibration snapshot (at the end of an analysis hop) and the save of its
/// estimate: half-way to the next hop (at 16 kHz the core's analysis runs on the input samples, so
/// a hop is [`cma_core::HOP`] sample frames, 8 blocks), when the capture ring holds no late block
/// and the estimate is still the snapshot's.
const SAVE_DELAY_BLOCKS: u8 = (cma_core::HOP / BLOCK_FRAMES / 2) as u8;

// The save happens before the next hop.
const _: () = assert!((SAVE_DELAY_BLOCKS as usize + 1) * BLOCK_FRAMES < cma_core::HOP);

/// Whether the snapshot at `centre_sample` is to be saved ([`SavePolicy::due`]). Not inlined, like
/// [`save_estimate`].
#[inline(never)]
fn save_due(policy: &mut SavePolicy, locator: &Locator<'_>, centre_sample: u64) -> bool {
    policy.due(
        locator.capsule_estimate(),
        locator.capsule_confidence(),
        centre_sample,
    )
}

/// Appends `estimate` to the store (blocking flash programming, ≤ 3.6 ms). When both halves of the
/// store are full (≥ 2 × 910 saves in one uptime on the STM32 boards), the older half is erased
/// first, with the watchdog stretched to [`ERASE_WATCHDOG_TIMEOUT_US`]: the CPU stalls for up to
/// seconds and the capture overruns once. Not inlined: the record's buffer lives in this frame only
/// while it runs, not in the DSP task's.
#[inline(never)]
fn save_estimate(
    store: &mut EstimateStore<EstimateFlash>,
    estimate: &CapsuleEstimate,
    watchdog: &mut Watchdog,
) {
    if store.needs_erase() {
        defmt::info!("estimate store: both halves full, erasing the older");
        watchdog.stretch(ERASE_WATCHDOG_TIMEOUT_US);
        let erased = store.erase_spare();
        watchdog.unleash();
        if let Err(e) = erased {
            defmt::warn!("estimate store: erase failed: {}", e);
        }
    }
    match store.save(estimate) {
        Ok(sequence) => defmt::info!("estimate saved as record {}", sequence),
        Err(e) => defmt::warn!("estimate not saved: {}", e),
    }
}

/// Encodes queued estimates as frame lines and self-calibration snapshots as calibration lines, and
/// writes them to the UART.
#[embassy_executor::task]
async fn uart_task(mut uart: FrameTx) {
    // One line buffer for every kind (each encoder checks at compile time that its longest line fits).
    let mut line = heapless::Vec::<u8, { wire::MAX_ANY_LINE }>::new();
    // `seq` counts frame lines sent (docs/wire-format.md): frames dropped by backpressure show in
    // `drop`. Calibration lines have their own `seq`.
    let mut seq: u32 = 0;
    let mut calibration_seq: u32 = 0;
    let mut tracks_seq: u32 = 0;
    let mut background_seq: u32 = 0;
    loop {
        match OUTGOING.receive().await {
            Outgoing::Estimate(e) => {
                let frame = wire::Frame::from_estimate(
                    &e,
                    seq,
                    SAMPLE_RATE_HZ,
                    COUNTERS.overruns(),
                    COUNTERS.dropped(),
                );
                seq = seq.wrapping_add(1);
                wire::encode(&frame, &mut line);
            }
            Outgoing::Calibration {
                capsules,
                confidence,
                centre_sample,
            } => {
                let cal = CalibrationLine::from_capsules(
                    &capsules,
                    confidence,
                    calibration_seq,
                    centre_sample,
                    COUNTERS.calibration_dropped(),
                );
                calibration_seq = calibration_seq.wrapping_add(1);
                wire::encode_calibration(&cal, &mut line);
            }
            Outgoing::Tracks(mut tracks) => {
                tracks.seq = tracks_seq;
                tracks_seq = tracks_seq.wrapping_add(1);
                wire::encode_tracks(&tracks, &mut line);
            }
            Outgoing::Background(mut background) => {
                background.seq = background_seq;
                background_seq = background_seq.wrapping_add(1);
                wire::encode_background(&background, &mut line);
            }
        };
        if let Err(err) = uart.write(&line).await {
            defmt::warn!("UART write failed: {}", err);
        }
    }
}
