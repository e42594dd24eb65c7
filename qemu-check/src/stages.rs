//! The pipeline's stages one at a time, on a fixed analysis frame of the scene, for per-stage
//! instruction counts (run a stage R times and once; the difference over R − 1 is its cost).
//!
//! Every stage is set up as [`cma_core::Locator`] sets it up for [`LocatorConfig::default`] at the
//! firmware's rate ([`crate::FIRMWARE_RATE_HZ`]).

use crate::scene::{hop_samples, Scene, HOP_SAMPLES, RATE_HZ};
use crate::FIRMWARE_RATE_HZ;
use cma_core::decimator::Decimator;
use cma_core::front_end::FrontEnd;
use cma_core::input_guard::InputGuard;
use cma_core::interpolation::argmax_parabolic;
use cma_core::peak_picker::{PeakPicker, Peaks};
use cma_core::refine_curve::refine_distance_power;
use cma_core::reliability::{curve_variance_with_sum, CurveFilter};
use cma_core::similarity::{normalise_frame_curve, CurveBuilder, PeakFeature, RowCache};
use cma_core::spectrum::{dft_bins3, fold_windowed, power, windowed_spectrum};
use cma_core::{
    LocatorConfig, ReferenceTable, CHANNELS, FRAME_LEN, MAX_AZIMUTHS, MAX_PEAKS, NUM_BINS,
};
use core::hint::black_box;
use microfft::Complex32;

/// One stage of the similarity pipeline, per analysis hop.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Input guard, ×4 decimation of four channels and framing of one hop (1024 input samples).
    FrontEnd,
    /// The omni's windowed FFT and the cardioids' windowed, folded frames.
    Spectra,
    /// Omni power spectrum and peak picking.
    Peaks,
    /// The cardioids' DFT at the peaks, the features and the similarity curve against the noisy
    /// references.
    Similarity,
    /// Curve variance, reliability filter and the two interpolated argmax.
    Reliability,
}

impl Stage {
    /// All stages, in pipeline order.
    pub const ALL: [Stage; 5] = [
        Stage::FrontEnd,
        Stage::Spectra,
        Stage::Peaks,
        Stage::Similarity,
        Stage::Reliability,
    ];

    /// Mode word of the stage (3…7).
    #[must_use]
    pub fn word(self) -> u32 {
        3 + Self::ALL.iter().position(|s| *s == self).unwrap_or(0) as u32
    }

    /// The stage of a mode word.
    #[must_use]
    pub fn from_word(w: u32) -> Option<Self> {
        Self::ALL.get(w.checked_sub(3)? as usize).copied()
    }

    /// Short name for tables.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Stage::FrontEnd => "front-end",
            Stage::Spectra => "spectra",
            Stage::Peaks => "peaks",
            Stage::Similarity => "similarity",
            Stage::Reliability => "reliability",
        }
    }
}

/// Inputs and state of all stages (large: keep it in a `static` or on a big stack).
pub struct Bench {
    /// One hop of input (the first `hop` sample frames).
    input: [[f32; CHANNELS]; HOP_SAMPLES],
    hop: usize,
    frame: [[f32; FRAME_LEN]; CHANNELS],
    scratch: [f32; FRAME_LEN],
    spectra: [[Complex32; NUM_BINS]; CHANNELS],
    omni_power: [f32; NUM_BINS],
    peaks: Peaks,
    curve: [f32; MAX_AZIMUTHS],
    /// The grid tracker's refinement distance sums, or the distance kernel's scratch (default
    /// configuration).
    distance: [f32; MAX_AZIMUTHS],
    /// The curve's sum from its normalisation, for the variance.
    curve_sum: f32,
    filter: CurveFilter,
    front: FrontEnd,
    picker: PeakPicker,
    curves: CurveBuilder,
    row_cache: RowCache,
    table: ReferenceTable<'static>,
}

impl Bench {
    /// Fills the analysis frame with 0.55 s of the scene (a voiced syllable) and prepares each stage's
    /// input by running the stages before it once.
    ///
    /// # Panics
    /// Never for the default configuration (the `expect`s document build-time invariants).
    pub fn new(out: &mut core::mem::MaybeUninit<Bench>) -> &mut Bench {
        let c = LocatorConfig::default();
        let dec = Decimator::for_rate(FIRMWARE_RATE_HZ).expect("the firmware's rate is supported");
        let hop = hop_samples(FIRMWARE_RATE_HZ);
        let fs = dec.output_rate() as f32;
        let b = out.write(Bench {
            input: [[0.0; CHANNELS]; HOP_SAMPLES],
            hop,
            frame: [[0.0; FRAME_LEN]; CHANNELS],
            scratch: [0.0; FRAME_LEN],
            spectra: [[Complex32::new(0.0, 0.0); NUM_BINS]; CHANNELS],
            omni_power: [0.0; NUM_BINS],
            peaks: Peaks::default(),
            curve: [0.0; MAX_AZIMUTHS],
            distance: [0.0; MAX_AZIMUTHS],
            curve_sum: 0.0,
            filter: CurveFilter::new(),
            front: FrontEnd::new(
                dec,
                InputGuard::for_decimation(c.front_end.clip_level, dec.factor()),
            ),
            picker: PeakPicker::from_config(&c.peaks, fs),
            row_cache: RowCache::new(),
            curves: CurveBuilder::from_config(&c.curves).expect("default SNR sets are valid"),
            table: ReferenceTable::ideal_5deg(),
        });
        let mut scene = Scene::at_rate(FIRMWARE_RATE_HZ);
        // 0.55 s of the scene (26 hops at 48 kHz).
        let warm_up = 26 * HOP_SAMPLES * FIRMWARE_RATE_HZ as usize / RATE_HZ as usize / hop;
        for _ in 0..warm_up {
            scene.fill(&mut b.input[..hop]);
            b.front_end();
        }
        b.frame.copy_from_slice(b.front.frame());
        b.spectra();
        b.peaks();
        b.similarity();
        b
    }

    /// Runs `stage` once.
    pub fn run(&mut self, stage: Stage) {
        match stage {
            Stage::FrontEnd => self.front_end(),
            Stage::Spectra => self.spectra(),
            Stage::Peaks => self.peaks(),
            Stage::Similarity => self.similarity(),
            Stage::Reliability => self.reliability(),
        }
    }

    fn front_end(&mut self) {
        let mut rest = &black_box(&self.input)[..self.hop];
        while !rest.is_empty() {
            let (used, ready) = self.front.feed(rest);
            black_box(ready);
            rest = &rest[used..];
        }
    }

    fn spectra(&mut self) {
        windowed_spectrum(
            black_box(&self.frame[0]),
            &mut self.scratch,
            &mut self.spectra[0],
        );
        for ch in 1..CHANNELS {
            fold_windowed(black_box(&self.frame[ch]), &mut self.spectra[ch]);
        }
    }

    fn peaks(&mut self) {
        let bins = self.picker.reads();
        for (p, c) in self.omni_power[bins.clone()]
            .iter_mut()
            .zip(black_box(&self.spectra[0])[bins].iter())
        {
            *p = power(*c);
        }
        self.picker.process(&self.omni_power, &mut self.peaks);
    }

    fn similarity(&mut self) {
        let q = self.table.num_azimuths();
        let curve = &mut self.curve[..q];
        let mut weight_sum = 0.0f32;
        let mut used = [PeakFeature {
            fi: 0,
            y: [0.0; 3],
            weight: 0.0,
        }; MAX_PEAKS];
        let mut n_used = 0;
        for &k in self.peaks.bins() {
            let k = k as usize;
            let [_, f1, f2, f3] = black_box(&self.spectra);
            let xc = dft_bins3([f1, f2, f3], k);
            let Some(y) = self
                .curves
                .features
                .of_bin(self.spectra[0][k], self.omni_power[k], xc)
            else {
                continue;
            };
            used[n_used] = PeakFeature {
                fi: 0,
                y,
                weight: 1.0,
            };
            n_used += 1;
            weight_sum += 1.0;
        }
        // The default kernel and, if the default has one, the refinement curve in the same pass.
        let c = LocatorConfig::default();
        let refine = refine_distance_power(c.kernel, &c.tracking);
        let distance = &mut self.distance[..q];
        self.curves.frame_curve(
            &mut self.row_cache,
            &self.table,
            &used[..n_used],
            c.kernel,
            refine,
            curve,
            distance,
        );
        self.curve_sum =
            normalise_frame_curve(c.kernel, refine.is_some(), weight_sum, curve, distance);
    }

    fn reliability(&mut self) {
        let c = LocatorConfig::default();
        let curve = black_box(&self.curve[..self.table.num_azimuths()]);
        let b = c
            .reliability
            .coefficient(curve_variance_with_sum(curve, black_box(self.curve_sum)));
        black_box(argmax_parabolic(curve, self.table.azimuths_deg()));
        let filtered = self.filter.update(b, curve);
        black_box(argmax_parabolic(filtered, self.table.azimuths_deg()));
    }

    /// Number of peaks the fixed frame yields (for the report).
    #[must_use]
    pub fn num_peaks(&self) -> usize {
        self.peaks.len()
    }
}
