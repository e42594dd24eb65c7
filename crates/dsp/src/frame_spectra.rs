//! The spectra of one analysis frame, shared by the methods: all four windowed spectra for FDIV, or
//! for the similarity method the omni's windowed spectrum and the cardioids' folded frames (their
//! DFT is computed only at the picked bins, [`crate::spectrum::dft_bins3`]).

use crate::spectrum::{dft_bins3, fold_windowed, windowed_spectrum};
use crate::{CHANNELS, FRAME_LEN, NUM_BINS};
use microfft::Complex32;

/// Spectra of the current analysis frame and the transform's scratch buffer.
#[derive(Debug, Clone)]
pub struct FrameSpectra {
    scratch: [f32; FRAME_LEN],
    channels: [[Complex32; NUM_BINS]; CHANNELS],
}

impl Default for FrameSpectra {
    fn default() -> Self {
        Self::new()
    }
}

impl FrameSpectra {
    /// All zero.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            scratch: [0.0; FRAME_LEN],
            channels: [[Complex32::new(0.0, 0.0); NUM_BINS]; CHANNELS],
        }
    }

    /// Zeroes everything.
    pub fn reset(&mut self) {
        self.scratch.fill(0.0);
        for s in self.channels.iter_mut() {
            s.fill(Complex32::new(0.0, 0.0));
        }
    }

    /// The windowed spectra of all four channels of `frame` (FDIV).
    pub fn transform_all(&mut self, frame: &[[f32; FRAME_LEN]; CHANNELS]) {
        for ch in 0..CHANNELS {
            windowed_spectrum(&frame[ch], &mut self.scratch, &mut self.channels[ch]);
        }
    }

    /// The omni's windowed spectrum and the cardioids' windowed, folded frames of `frame` (the
    /// similarity method: the cardioids are needed only at the picked bins,
    /// [`FrameSpectra::cardioids_at`]).
    pub fn transform_omni_fold_cardioids(&mut self, frame: &[[f32; FRAME_LEN]; CHANNELS]) {
        windowed_spectrum(&frame[0], &mut self.scratch, &mut self.channels[0]);
        for ch in 1..CHANNELS {
            fold_windowed(&frame[ch], &mut self.channels[ch]);
        }
    }

    /// Channel by channel: spectra after [`FrameSpectra::transform_all`]; the omni spectrum and
    /// three folded frames after [`FrameSpectra::transform_omni_fold_cardioids`].
    #[must_use]
    pub fn channels(&self) -> &[[Complex32; NUM_BINS]; CHANNELS] {
        &self.channels
    }

    /// The omni spectrum.
    #[must_use]
    pub fn omni(&self) -> &[Complex32; NUM_BINS] {
        &self.channels[0]
    }

    /// The cardioids' folded frames (after [`FrameSpectra::transform_omni_fold_cardioids`]).
    #[must_use]
    pub fn folds(&self) -> [&[Complex32; NUM_BINS]; 3] {
        let [_, f1, f2, f3] = &self.channels;
        [f1, f2, f3]
    }

    /// The cardioids' spectra at bin `k`, from their folded frames.
    #[must_use]
    pub fn cardioids_at(&self, k: usize) -> [Complex32; 3] {
        dft_bins3(self.folds(), k)
    }
}
