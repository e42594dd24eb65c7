//! Framing (thesis eq. 5.1): collects analysis-rate sample frames and hands out overlapping
//! analysis frames of [`FRAME_LEN`] samples every [`HOP`] samples.

use crate::{CHANNELS, FRAME_LEN, HOP};

/// The last [`FRAME_LEN`] sample frames of all channels, oldest first, in a linear buffer: the
/// analysis frame is read in place (no copy), and after it the newest [`HOP`] samples move to the
/// front (one `memmove` per hop, done lazily when the next sample arrives).
#[derive(Debug, Clone)]
pub struct Framer {
    buf: [[f32; FRAME_LEN]; CHANNELS],
    /// Samples in `buf`; `FRAME_LEN` means a complete analysis frame waits to be read.
    fill: usize,
    /// Analysis frames handed out so far.
    frames_out: u32,
}

impl Default for Framer {
    fn default() -> Self {
        Self::new()
    }
}

impl Framer {
    /// An empty framer.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            buf: [[0.0; FRAME_LEN]; CHANNELS],
            fill: 0,
            frames_out: 0,
        }
    }

    /// Empties the framer in place.
    pub fn reset(&mut self) {
        for ch in self.buf.iter_mut() {
            ch.fill(0.0);
        }
        self.fill = 0;
        self.frames_out = 0;
    }

    /// Drops the oldest hop after a complete frame (before new samples go in).
    #[inline]
    fn make_room(&mut self) {
        if self.fill == FRAME_LEN {
            // Eight samples per step: inline block moves, ≈ 4× fewer instructions on the Cortex-M4F
            // than the library `memcpy` that `copy_within` calls there.
            // The newest FRAME_LEN − HOP samples do not overlap their destination (HOP ≥ FRAME_LEN / 2).
            const _: () = assert!(2 * HOP >= FRAME_LEN && (FRAME_LEN - HOP) & 7 == 0);
            for ch in self.buf.iter_mut() {
                let (front, newest) = ch.split_at_mut(HOP);
                for (d, s) in front.chunks_exact_mut(8).zip(newest.chunks_exact(8)) {
                    d.copy_from_slice(s);
                }
            }
            self.fill = FRAME_LEN - HOP;
        }
    }

    /// Sample frames still needed to complete the next analysis frame (1…[`FRAME_LEN`]).
    #[must_use]
    pub fn needed(&self) -> usize {
        if self.fill == FRAME_LEN {
            HOP
        } else {
            FRAME_LEN - self.fill
        }
    }

    /// The free part of each channel's buffer, `needed()` samples long, for writing samples
    /// straight into the framer; then [`Framer::commit`] the number written.
    #[inline]
    pub fn free_mut(&mut self) -> [&mut [f32]; CHANNELS] {
        self.make_room();
        let fill = self.fill;
        self.buf.each_mut().map(|ch| &mut ch[fill..])
    }

    /// Counts `n` samples written through [`Framer::free_mut`]; returns `true` when that completes
    /// an analysis frame.
    #[inline]
    pub fn commit(&mut self, n: usize) -> bool {
        debug_assert!(self.fill + n <= FRAME_LEN);
        self.fill += n;
        self.fill == FRAME_LEN
    }

    /// Pushes one sample frame; returns `true` when a new analysis frame is complete.
    #[inline]
    pub fn push(&mut self, x: [f32; CHANNELS]) -> bool {
        self.make_room();
        for (ch, v) in self.buf.iter_mut().zip(x) {
            ch[self.fill] = v;
        }
        self.commit(1)
    }

    /// The current analysis frame, oldest sample first (valid right after `push`/`commit` returned
    /// `true`).
    #[must_use]
    pub fn frame(&self) -> &[[f32; FRAME_LEN]; CHANNELS] {
        &self.buf
    }

    /// Counts the current analysis frame and returns its index (0 for the first).
    pub fn take_index(&mut self) -> u32 {
        let idx = self.frames_out;
        self.frames_out = self.frames_out.wrapping_add(1);
        idx
    }

    /// Copies the current analysis frame, oldest sample first, into `out` and counts it.
    /// Returns the index of the frame (0 for the first).
    pub fn take_frame(&mut self, out: &mut [[f32; FRAME_LEN]; CHANNELS]) -> u32 {
        out.copy_from_slice(&self.buf);
        self.take_index()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_overlap_by_half() {
        let mut f = Framer::new();
        let mut out = [[0.0; FRAME_LEN]; CHANNELS];
        let mut starts = [0usize; 4];
        let mut n_frames = 0;
        for n in 0..(FRAME_LEN + 3 * HOP) {
            if f.push([n as f32, 0.0, 0.0, -(n as f32)]) {
                let idx = f.take_frame(&mut out) as usize;
                starts[idx] = out[0][0] as usize;
                for (i, v) in out[0].iter().enumerate() {
                    assert_eq!(*v as usize, starts[idx] + i);
                }
                assert_eq!(out[3][5], -out[0][5]);
                n_frames += 1;
            }
        }
        assert_eq!(n_frames, 4);
        assert_eq!(starts, [0, HOP, 2 * HOP, 3 * HOP]);
    }
}
