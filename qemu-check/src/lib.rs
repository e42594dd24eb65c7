//! The part of the QEMU check shared by the host and the emulated Cortex-M4F: a deterministic test
//! scene, the program's modes, and the text form of an estimate that both sides print.
//!
//! The target program (`src/main.rs`) runs a mode and prints over semihosting; the host test
//! (`tests/qemu.rs`) runs the same code natively and compares the output byte for byte, so every
//! `f32` of every estimate must agree to the last bit. `scripts/cost.sh` runs the other modes under an
//! instruction-counting TCG plugin.
#![no_std]

pub mod inputs;
pub mod scene;
pub mod stages;

use cma_core::track_spans::TrackFrame;
use cma_core::Estimate;
use core::fmt;

/// RAM address of the mode word (and of its argument at `+4`), outside everything the program links;
/// QEMU's `-device loader,addr=…,data=…,data-len=4` sets it, and RAM starts zeroed, so 0 is the default.
pub const MODE_ADDR: u32 = 0x2030_0000;

/// What the target program does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Run check variant `arg` ([`run_check`]: the scene through a [`check_config`], or an input
    /// kind in the firmware's blocks) and print every estimate ([`EstimateBits`]).
    Check,
    /// Generate and process `arg` hops of the scene without printing.
    Pipeline,
    /// Only generate `arg` hops of the scene (subtracted from [`Mode::Pipeline`]).
    Generate,
    /// Generate and process `arg` hops of the scene with the multi-talker tracks on
    /// ([`multi_talker_config`]), without printing.
    PipelineMultiTalker,
    /// Run one stage `arg` times on a fixed analysis frame ([`stages::Stage`]).
    Stage(stages::Stage),
    /// Run `(arg >> 8) & 0xfff` hops of input kind `arg & 0xff` ([`inputs::InputKind::from_index`])
    /// in blocks of `(arg >> 20) & 0x7ff` sample frames, or of [`FIRMWARE_BLOCK`] for 0
    /// ([`run_hops`]), through the default localizer, or with bit 31 set through the default with
    /// the multi-talker tracks on ([`multi_talker_config`]), for per-hop instruction counts.
    Hops,
}

impl Mode {
    /// The mode of a mode word.
    #[must_use]
    pub fn from_word(w: u32) -> Option<Self> {
        Some(match w {
            0 => Mode::Check,
            1 => Mode::Pipeline,
            2 => Mode::Generate,
            8 => Mode::Hops,
            9 => Mode::PipelineMultiTalker,
            w => Mode::Stage(stages::Stage::from_word(w)?),
        })
    }
}

/// An estimate with every float as its bit pattern, one line:
/// `<frame> <centre> <az> <raw> <conf> <power> <flags>` (floats as 8 hex digits).
pub struct EstimateBits<'a>(pub &'a Estimate);

impl fmt::Display for EstimateBits<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let e = self.0;
        write!(
            f,
            "{} {} {:08x} {:08x} {:08x} {:08x} {:02x}",
            e.frame_index,
            e.centre_sample,
            e.azimuth_deg.to_bits(),
            e.azimuth_raw_deg.to_bits(),
            e.confidence.to_bits(),
            e.power.to_bits(),
            e.flags.0
        )
    }
}

/// A decided frame's multi-talker tracks with every float as its bit pattern, one line:
/// `T <frame>` and per live track ` <id> <az> <conf> <active>` (floats as 8 hex digits, active 0/1).
pub struct TracksBits<'a>(pub &'a TrackFrame);

impl fmt::Display for TracksBits<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "T {}", self.0.frame_index)?;
        for t in self.0.tracks() {
            write!(
                f,
                " {} {:08x} {:08x} {}",
                t.id,
                t.azimuth_deg.to_bits(),
                t.confidence.to_bits(),
                u8::from(t.active)
            )?;
        }
        Ok(())
    }
}

/// Sample frames per block fed to the localizer (any size gives the same estimates).
pub const BLOCK: usize = 256;

/// Sample frames per block the firmware passes to the localizer (its DMA half-block; a test keeps
/// this equal to the firmware's constant).
pub const FIRMWARE_BLOCK: usize = 32;

/// Sample rate of the firmware's ADCs, Hz (a test keeps this equal to the firmware's constant): the
/// rate of the cost runs ([`run_hops`], [`Mode::Pipeline`], the stage bench).
pub const FIRMWARE_RATE_HZ: u32 = 16_000;

/// The product default with the multi-talker tracks on.
#[must_use]
pub fn multi_talker_config() -> cma_core::LocatorConfig {
    cma_core::LocatorConfig {
        multi_track: cma_core::multi_track::MultiTrack::DEFAULT,
        ..cma_core::LocatorConfig::default()
    }
}

/// Configurations the bit-for-bit check runs (the argument of [`Mode::Check`]): the product default,
/// the default with the active-ratio features, the thesis configuration (one-pole curve filter
/// instead of the grid tracker), and the default with the multi-talker tracks on.
#[must_use]
pub fn check_config(variant: usize) -> Option<cma_core::LocatorConfig> {
    let mut c = cma_core::LocatorConfig::default();
    match variant {
        0 => {}
        1 => c.curves.features = cma_core::features::FeatureKind::Active,
        2 => c = cma_core::LocatorConfig::thesis(),
        3 => c = multi_talker_config(),
        _ => return None,
    }
    Some(c)
}

/// Number of [`check_config`] variants.
pub const CHECK_CONFIGS: usize = 4;

/// Number of variants [`Mode::Check`] runs: the [`check_config`] ones, then each
/// [`inputs::InputKind`] through the default configuration in the firmware's blocks
/// ([`run_check`]).
pub const CHECK_VARIANTS: usize = CHECK_CONFIGS + inputs::InputKind::ALL.len();

/// Hops of an input kind in the bit-for-bit check (2.56 s: six NaN bursts, the scene's first
/// four positions).
pub const CHECK_KIND_HOPS: usize = 120;

/// Runs check variant `variant` (< [`CHECK_VARIANTS`]) and calls `on_line` with every line to
/// compare: each estimate ([`EstimateBits`]) and, with the multi-talker tracks on, after it the
/// tracks the core decided then and at the end the flushed ones ([`TracksBits`]); `false` for an
/// unknown variant.
///
/// # Panics
/// Never for a valid variant.
pub fn run_check(variant: usize, mut on_line: impl FnMut(&dyn fmt::Display)) -> bool {
    if let Some(config) = check_config(variant) {
        // At 48 kHz, so that the check covers the decimator too (the input kinds below run at the
        // firmware's rate).
        if config.multi_track.enabled {
            run_scene_tracks(config, scene::RATE_HZ, scene::SCENE_HOPS, on_line);
        } else {
            run_scene_with(config, scene::RATE_HZ, scene::SCENE_HOPS, true, |e| {
                on_line(&EstimateBits(e));
            });
        }
        return true;
    }
    let Some(kind) = variant
        .checked_sub(CHECK_CONFIGS)
        .and_then(|i| inputs::InputKind::from_index(i as u32))
    else {
        return false;
    };
    /// Forwards the estimates; no marks.
    struct Forward<F>(F);
    impl<F: FnMut(&Estimate)> HopMarks for Forward<F> {
        fn pause(&mut self) {}
        fn resume(&mut self) {}
        fn hop(&mut self, e: &Estimate) {
            (self.0)(e);
        }
    }
    run_hops(
        cma_core::LocatorConfig::default(),
        kind,
        CHECK_KIND_HOPS,
        FIRMWARE_BLOCK,
        &mut Forward(|e: &Estimate| on_line(&EstimateBits(e))),
    );
    true
}

/// The scene through `config` (with the multi-talker tracks on) sample by sample, so the tracks
/// can be read after each estimate: `on_line` gets each estimate, the tracks decided after it, and
/// at the end the flushed ones.
fn run_scene_tracks(
    config: cma_core::LocatorConfig,
    rate_hz: u32,
    hops: usize,
    mut on_line: impl FnMut(&dyn fmt::Display),
) {
    let mut locator =
        cma_core::Locator::new(config, cma_core::ReferenceTable::ideal_5deg(), rate_hz)
            .expect("configuration valid at this rate");
    scene_blocks(rate_hz, hops, |block| {
        for x in block {
            if let Some(e) = locator.process_sample(*x) {
                on_line(&EstimateBits(&e));
                if let Some(t) = locator.talker_tracks() {
                    on_line(&TracksBits(&t));
                }
            }
        }
    });
    while let Some(t) = locator.flush_talker_tracks() {
        on_line(&TracksBits(&t));
    }
}

/// Generates `hops` hops of the scene at the firmware's rate ([`FIRMWARE_RATE_HZ`]) block by block
/// and, when `process` is set, runs them through a default [`cma_core::Locator`], calling
/// `on_estimate` for each estimate.
///
/// # Panics
/// Never for the default configuration (it is valid at the firmware's rate).
pub fn run_scene(hops: usize, process: bool, on_estimate: impl FnMut(&Estimate)) {
    run_scene_with(
        cma_core::LocatorConfig::default(),
        FIRMWARE_RATE_HZ,
        hops,
        process,
        on_estimate,
    );
}

/// [`run_scene`] with the localizer configured by `config`, at `rate_hz`.
///
/// # Panics
/// If `config` is not valid at `rate_hz` (the [`check_config`] variants are valid at 48 kHz and at
/// the firmware's rate).
pub fn run_scene_with(
    config: cma_core::LocatorConfig,
    rate_hz: u32,
    hops: usize,
    process: bool,
    mut on_estimate: impl FnMut(&Estimate),
) {
    let mut locator =
        cma_core::Locator::new(config, cma_core::ReferenceTable::ideal_5deg(), rate_hz)
            .expect("configuration valid at this rate");
    scene_blocks(rate_hz, hops, |block| {
        if process {
            locator.process_block(block, &mut on_estimate);
        } else {
            core::hint::black_box(block);
        }
    });
}

/// Generates `hops` hops of the scene at `rate_hz` in blocks of [`BLOCK`] sample frames and calls
/// `on_block` with each.
fn scene_blocks(rate_hz: u32, hops: usize, mut on_block: impl FnMut(&[[f32; cma_core::CHANNELS]])) {
    let mut scene = scene::Scene::at_rate(rate_hz);
    let mut block = [[0.0f32; cma_core::CHANNELS]; BLOCK];
    let mut left = hops * scene::hop_samples(rate_hz);
    while left > 0 {
        let n = left.min(BLOCK);
        scene.fill(&mut block[..n]);
        on_block(&block[..n]);
        left -= n;
    }
}

/// Marks in a [`run_hops`] run, for an instruction counter that follows the program counter
/// (`scripts/insn-count.c`): input generation is bracketed by `pause` and `resume`, and `hop` is
/// called with every estimate.
pub trait HopMarks {
    /// Input generation starts.
    fn pause(&mut self);
    /// Input generation has ended.
    fn resume(&mut self);
    /// An estimate (one hop) is complete.
    fn hop(&mut self, e: &Estimate);
}

/// Longest block [`run_hops`] takes (one hop).
pub const MAX_BLOCK: usize = scene::HOP_SAMPLES;

/// Runs `hops` hops of `kind` through a [`cma_core::Locator`] of `config` at the firmware's rate
/// ([`FIRMWARE_RATE_HZ`]) in blocks of `block` sample frames (at most [`MAX_BLOCK`]; the firmware's
/// is [`FIRMWARE_BLOCK`]), as the firmware calls it.
///
/// # Panics
/// When `config` is not valid at the firmware's rate (the default and [`multi_talker_config`] are).
pub fn run_hops(
    config: cma_core::LocatorConfig,
    kind: inputs::InputKind,
    hops: usize,
    block: usize,
    marks: &mut impl HopMarks,
) {
    let mut locator = cma_core::Locator::new(
        config,
        cma_core::ReferenceTable::ideal_5deg(),
        FIRMWARE_RATE_HZ,
    )
    .expect("configuration valid at the firmware's rate");
    let mut input = inputs::Input::at_rate(kind, FIRMWARE_RATE_HZ);
    let mut buf = [[0.0f32; cma_core::CHANNELS]; MAX_BLOCK];
    let block = &mut buf[..block.clamp(1, MAX_BLOCK)];
    for _ in 0..hops * scene::hop_samples(FIRMWARE_RATE_HZ) / block.len() {
        marks.pause();
        input.fill(block);
        core::hint::black_box(&*block);
        marks.resume();
        locator.process_block(block, |e| marks.hop(e));
    }
}
