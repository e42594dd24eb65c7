//! The front end of the localizer: input guard, decimation and framing, block by block.
//!
//! [`FrontEnd::feed`] takes up to [`PIECE`] sample frames at a time, never past the sample that
//! completes an analysis frame, so an analysis can run between two calls exactly where the per-sample
//! pipeline would run it. Within a piece it checks the interleaved input once
//! ([`InputGuard::clean_block`]: the piece itself when nothing needs cleaning, else a cleaned copy of
//! at most 64 sample frames, and the rest of the piece waits for the next call),
//! runs all half-band stages over it in one pass ([`BlockDecimator`]) and writes the last stage's
//! outputs straight into the [`Framer`]. The result does not depend on how the input is split into
//! blocks.

use crate::block_decimator::{BlockDecimator, PIECE};
use crate::decimator::Decimator;
use crate::estimate::Flags;
use crate::framer::Framer;
use crate::input_guard::{InputGuard, InputGuardState};
use crate::{CHANNELS, FRAME_LEN};

/// Sample frames cleaned at a time when a piece needs cleaning (a rare, slower path; a small copy).
const CLEAN_PIECE: usize = 64;

/// The settings of the front end: the input guard's clip level and the frame level's thresholds
/// (in the configuration file, top-level keys of the same names).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrontEndSettings {
    /// Omni mean-square power below which a frame is silent (b = 0).
    pub silence_power: f32,
    /// |sample| at or above which the input counts as clipped.
    pub clip_level: f32,
    /// Confidence factor applied to frames with clipped samples.
    pub clipped_confidence: f32,
}

/// Guard, decimator and framer with their state.
#[derive(Debug, Clone)]
pub struct FrontEnd {
    guard: InputGuard,
    guard_state: InputGuardState,
    decimator: Decimator,
    lines: BlockDecimator,
    /// The cleaned copy of (the start of) a piece that needed cleaning.
    scratch: [[f32; CHANNELS]; CLEAN_PIECE],
    /// Input sample frames so far, modulo the decimation factor.
    phase: usize,
    framer: Framer,
}

impl FrontEnd {
    /// A front end for `decimator` and `guard`, all state zeroed.
    #[must_use]
    pub const fn new(decimator: Decimator, guard: InputGuard) -> Self {
        Self {
            guard,
            guard_state: InputGuardState::new(),
            decimator,
            lines: BlockDecimator::new(),
            scratch: [[0.0; CHANNELS]; CLEAN_PIECE],
            phase: 0,
            framer: Framer::new(),
        }
    }

    /// Reconfigures in place and zeroes all state.
    pub fn reset(&mut self, decimator: Decimator, guard: InputGuard) {
        self.guard = guard;
        self.guard_state = InputGuardState::new();
        self.decimator = decimator;
        self.lines.reset();
        self.phase = 0;
        self.framer.reset();
    }

    /// The decimator's configuration.
    #[must_use]
    pub fn decimator(&self) -> &Decimator {
        &self.decimator
    }

    /// Consumes sample frames from the start of `block`, at most up to the one that completes an
    /// analysis frame; returns how many it consumed and whether an analysis frame is now complete
    /// (then read it with [`FrontEnd::frame`] before the next call).
    pub fn feed(&mut self, block: &[[f32; CHANNELS]]) -> (usize, bool) {
        let factor = self.decimator.factor() as usize;
        let to_frame = self.framer.needed() * factor - self.phase;
        let len = block.len().min(to_frame).min(PIECE);
        if len == 0 {
            return (0, false);
        }
        let piece = &block[..len];
        #[cfg(target_arch = "x86_64")]
        let checked = self.decimate_checked(piece);
        #[cfg(not(target_arch = "x86_64"))]
        let checked = None;
        let (len, produced) = match checked {
            Some(produced) => (len, produced),
            None => self.clean_and_decimate(piece),
        };
        self.phase = (self.phase + len) % factor;
        (len, self.framer.commit(produced))
    }

    /// The guard cleans (the start of) `piece` ([`InputGuard::clean_block`]), and the decimator (or,
    /// at factor 1, a copy) writes it into the framer; returns the sample frames consumed and the
    /// samples written per channel, not yet committed.
    fn clean_and_decimate(&mut self, piece: &[[f32; CHANNELS]]) -> (usize, usize) {
        let block = self
            .guard
            .clean_block(&mut self.guard_state, piece, &mut self.scratch);
        let len = block.len();
        let mut free = self.framer.free_mut();
        let produced = if self.decimator.factor() == 1 {
            for (i, x) in block.iter().enumerate() {
                for (o, v) in free.iter_mut().zip(x) {
                    o[i] = *v;
                }
            }
            len
        } else {
            self.lines.run(&self.decimator, block, free)
        };
        (len, produced)
    }

    /// x86_64: [`FrontEnd::clean_and_decimate`] with the guard's test in the decimator's pass, for a
    /// piece that needs no cleaning (the common case): one pass over the input instead of two. The
    /// decimator's vector recursions are latency-bound, so the test's few integer operations per
    /// sample frame come almost for free. Returns the samples written per channel (all of `piece`
    /// is consumed). If a value fails, the decimator state is put back and `None` sends the piece
    /// down the ordinary path, so the outputs are those of `feed` bit for bit. (The Cortex-M4F keeps
    /// the separate scan: one lane at a time, its decimator passes over each sample frame four times.)
    #[cfg(target_arch = "x86_64")]
    fn decimate_checked(&mut self, piece: &[[f32; CHANNELS]]) -> Option<usize> {
        if self.decimator.factor() == 1 {
            return None;
        }
        let mut check = self.guard.level_check()?;
        let before = self.lines;
        let produced =
            self.lines
                .run_checked(&self.decimator, piece, self.framer.free_mut(), &mut check);
        if !check.passed() {
            self.lines = before;
            return None;
        }
        self.guard.pass_clean(&mut self.guard_state, piece.len());
        Some(produced)
    }

    /// The complete analysis frame, oldest sample first (after [`FrontEnd::feed`] said so).
    #[must_use]
    pub fn frame(&self) -> &[[f32; FRAME_LEN]; CHANNELS] {
        self.framer.frame()
    }

    /// Counts the analysis frame and returns its index (0 for the first).
    pub fn take_index(&mut self) -> u32 {
        self.framer.take_index()
    }

    /// The input guard's flags for the analysis frame that ends now.
    #[must_use]
    pub fn flags(&self) -> Flags {
        self.guard.flags(&self.guard_state)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::decimator::DecimatorState;

    fn signal(n: usize) -> [f32; CHANNELS] {
        let t = n as f32;
        let mut x = [
            libm::sinf(0.01 * t),
            libm::sinf(0.37 * t + 1.0),
            libm::cosf(1.3 * t),
            ((n * 7919) % 1000) as f32 / 500.0 - 1.0,
        ];
        // Bad values in every channel, inside pieces and at their edges (multiples of 64 and 256).
        let below = f32::from_bits(0.999f32.to_bits() - 1);
        match n {
            255 => x[0] = f32::INFINITY,
            256 => x[3] = f32::NEG_INFINITY,
            1023 => x[2] = -1.5,
            1024 => x[1] = 0.999,
            1500 => x = [below, -below, below, -below],
            2047 => x[0] = -0.999,
            2048 => x[3] = f32::NAN,
            3001 => x[1] = f32::NAN,
            4095 => x = [f32::NAN, 2.0, -f32::INFINITY, -0.9995],
            5003 => x[2] = 3.0,
            _ => {}
        }
        x
    }

    /// The block front end equals the per-sample guard → decimator → framer, for every rate and split.
    #[test]
    fn equals_per_sample_pipeline_for_any_split() {
        let guard = InputGuard {
            clip_level: 0.999,
            hold_samples: 700,
        };
        for rate in [12_000u32, 24_000, 48_000, 96_000] {
            let d = Decimator::for_rate(rate).unwrap();
            let n_in = 3 * FRAME_LEN * d.factor() as usize + 37;
            for split in [1usize, 3, 7, 64, 100, 255, 256, 257, 1024] {
                let mut fe = FrontEnd::new(d, guard);
                let mut gs = InputGuardState::new();
                let mut ds = [DecimatorState::new(); CHANNELS];
                let mut framer = Framer::new();
                let mut frames = 0;
                let mut n = 0;
                while n < n_in {
                    let chunk: [[f32; CHANNELS]; 1024] = core::array::from_fn(|i| signal(n + i));
                    let mut rest = &chunk[..split.min(n_in - n)];
                    while !rest.is_empty() {
                        let (used, ready) = fe.feed(rest);
                        // The per-sample reference over the same samples.
                        let mut ref_ready = false;
                        for x in &rest[..used] {
                            let mut x = *x;
                            guard.process(&mut gs, &mut x);
                            let mut y = [0.0; CHANNELS];
                            let mut any = false;
                            for ((o, st), v) in y.iter_mut().zip(ds.iter_mut()).zip(x) {
                                if let Some(s) = d.process(st, v) {
                                    *o = s;
                                    any = true;
                                }
                            }
                            if any {
                                assert!(!ref_ready, "frame completed before the piece ended");
                                ref_ready = framer.push(y);
                            }
                        }
                        assert_eq!(ready, ref_ready, "rate {rate} split {split}");
                        if ready {
                            frames += 1;
                            assert_eq!(fe.frame(), framer.frame());
                            assert_eq!(fe.flags(), guard.flags(&gs));
                        }
                        n += used;
                        rest = &rest[used..];
                    }
                }
                assert_eq!(frames, 5, "rate {rate} split {split}");
            }
        }
    }
}
