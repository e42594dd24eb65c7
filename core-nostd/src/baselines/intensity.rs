//! The intensity-vector methods on one analysis frame: TDIV ([`crate::tdiv`]) or FDIV
//! ([`crate::fdiv`], optionally with the thesis's circular-spread reliability,
//! [`crate::combination::FdivSpread`]).

use crate::cartesian_filter::CartesianFilter;
use crate::config::{LocatorConfig, Method};
use crate::fdiv::{fdiv_process, FdivState};
use crate::frame_spectra::FrameSpectra;
use crate::peak_picker::PeakPicker;
use crate::tdiv::{tdiv_process, IvEstimate, TdivState};
use crate::{CHANNELS, FRAME_LEN};

/// The intensity-vector stage and its state.
#[derive(Debug, Clone)]
pub struct IntensityVector {
    /// FDIV's band, bins `lo_bin..=hi_bin` (the peak picker's).
    lo_bin: usize,
    hi_bin: usize,
    fdiv: FdivState,
    tdiv: TdivState,
    /// The eq. 5.30 filter of the FDIV spread option.
    cartesian: CartesianFilter,
    /// The last reported azimuth.
    last_azimuth: f32,
}

impl Default for IntensityVector {
    fn default() -> Self {
        Self::new()
    }
}

impl IntensityVector {
    /// An unconfigured stage (FDIV over the whole spectrum) with zeroed state.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            lo_bin: PeakPicker::IDLE.lo_bin,
            hi_bin: PeakPicker::IDLE.hi_bin,
            fdiv: FdivState::new(),
            tdiv: TdivState::new(),
            cartesian: CartesianFilter::new(),
            last_azimuth: 0.0,
        }
    }

    /// Sets FDIV's band from `config` at analysis rate `fs` Hz; leaves the state alone.
    /// [`IntensityVector::process`] reads the rest of its settings from the same `config`.
    pub fn configure(&mut self, config: &LocatorConfig, fs: f32) {
        let band = PeakPicker::from_config(config, fs);
        self.lo_bin = band.lo_bin;
        self.hi_bin = band.hi_bin;
    }

    /// Zeroes the state (the settings stay).
    pub fn reset(&mut self) {
        self.fdiv = FdivState::new();
        self.tdiv = TdivState::new();
        self.cartesian = CartesianFilter::new();
        self.last_azimuth = 0.0;
    }

    /// One frame with the method and settings of `c` (`spectra` is FDIV's workspace). An unusable
    /// frame keeps the last azimuth with confidence 0 and leaves the state alone.
    pub fn process(
        &mut self,
        c: &LocatorConfig,
        usable: bool,
        frame: &[[f32; FRAME_LEN]; CHANNELS],
        spectra: &mut FrameSpectra,
    ) -> IvEstimate {
        if !usable {
            return IvEstimate {
                azimuth_deg: self.last_azimuth,
                azimuth_raw_deg: self.last_azimuth,
                confidence: 0.0,
            };
        }
        let (lo, hi) = (self.lo_bin, self.hi_bin);
        let iv = if c.method == Method::Tdiv {
            tdiv_process(c.tdiv_pole, &mut self.tdiv, frame)
        } else {
            spectra.transform_all(frame);
            fdiv_process(c.fdiv_pole, &mut self.fdiv, spectra.channels(), lo, hi)
        };
        // Thesis option: FDIV reliability from the circular std over bins (§5.2.2), off by default.
        let iv = if c.method == Method::Fdiv && c.fdiv_spread.enabled() {
            c.fdiv_spread
                .frame(&mut self.cartesian, spectra.channels(), lo, hi)
        } else {
            iv
        };
        self.last_azimuth = iv.azimuth_deg;
        iv
    }
}
