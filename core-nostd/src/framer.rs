//! Framing (thesis eq. 5.1): collects analysis-rate sample frames and hands out overlapping
//! analysis frames of [`FRAME_LEN`] samples every [`HOP`] samples.

use crate::{CHANNELS, FRAME_LEN, HOP};

/// Ring buffer of the last [`FRAME_LEN`] sample frames of all channels.
#[derive(Debug, Clone)]
pub struct Framer {
    ring: [[f32; FRAME_LEN]; CHANNELS],
    /// Index where the next sample goes (also the oldest sample once full).
    pos: usize,
    /// Sample frames pushed so far, saturating at `FRAME_LEN` (for the first frame).
    filled: usize,
    /// Sample frames since the last analysis frame.
    since_hop: usize,
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
            ring: [[0.0; FRAME_LEN]; CHANNELS],
            pos: 0,
            filled: 0,
            since_hop: 0,
            frames_out: 0,
        }
    }

    /// Pushes one sample frame; returns `true` when a new analysis frame is complete.
    #[inline]
    pub fn push(&mut self, x: [f32; CHANNELS]) -> bool {
        for (ch, v) in self.ring.iter_mut().zip(x) {
            ch[self.pos] = v;
        }
        self.pos = if self.pos + 1 == FRAME_LEN {
            0
        } else {
            self.pos + 1
        };
        if self.filled < FRAME_LEN {
            self.filled += 1;
            if self.filled == FRAME_LEN {
                self.since_hop = 0;
                return true;
            }
            return false;
        }
        self.since_hop += 1;
        if self.since_hop == HOP {
            self.since_hop = 0;
            return true;
        }
        false
    }

    /// Copies the current analysis frame, oldest sample first, into `out` and counts it.
    /// Returns the index of the frame (0 for the first).
    pub fn take_frame(&mut self, out: &mut [[f32; FRAME_LEN]; CHANNELS]) -> u32 {
        for (dst, src) in out.iter_mut().zip(self.ring.iter()) {
            let (newer, older) = src.split_at(self.pos);
            dst[..older.len()].copy_from_slice(older);
            dst[older.len()..].copy_from_slice(newer);
        }
        let idx = self.frames_out;
        self.frames_out = self.frames_out.wrapping_add(1);
        idx
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
