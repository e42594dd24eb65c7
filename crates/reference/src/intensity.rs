//! The intensity-vector methods on one analysis frame: TDIV ([`crate::tdiv`]) or FDIV
//! ([`crate::fdiv`], optionally with the thesis's circular-spread reliability,
//! [`crate::combination::FdivSpread`]).

use crate::cartesian_filter::CartesianFilter;
use crate::combination::FdivSpread;
use crate::fdiv::{fdiv_process, FdivState};
use crate::frame_spectra::FrameSpectra;
use crate::peak_picker::{PeakPicker, PeakSettings};
use crate::tdiv::{tdiv_process, IvEstimate, TdivState};
use crate::{CHANNELS, FRAME_LEN};

/// Which intensity-vector method runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IvMethod {
    /// Frequency-domain intensity vector (§5.2.2).
    Fdiv,
    /// Time-domain intensity vector (§5.2.1).
    Tdiv,
}

/// The settings of the intensity-vector methods (in the configuration file, the top-level keys
/// `tdiv_pole`, `fdiv_pole` and the table `fdiv_spread`; which method runs is the configuration's
/// `method`, FDIV's band the peak picker's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct IntensitySettings {
    /// TDIV smoothing pole a (eq. 5.40).
    pub tdiv_pole: f32,
    /// FDIV smoothing pole a of the per-bin intensity.
    pub fdiv_pole: f32,
    /// FDIV frame reliability from the circular standard deviation over bins (§5.2.2).
    pub fdiv_spread: FdivSpread,
}

impl IntensitySettings {
    /// The settings of an unconfigured stage.
    pub const IDLE: IntensitySettings = IntensitySettings {
        tdiv_pole: 0.9,
        fdiv_pole: 0.95,
        fdiv_spread: FdivSpread::OFF,
    };
}

/// The intensity-vector stage and its state.
#[derive(Debug, Clone)]
pub struct IntensityVector {
    method: IvMethod,
    settings: IntensitySettings,
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
            method: IvMethod::Fdiv,
            settings: IntensitySettings::IDLE,
            lo_bin: PeakPicker::IDLE.lo_bin,
            hi_bin: PeakPicker::IDLE.hi_bin,
            fdiv: FdivState::new(),
            tdiv: TdivState::new(),
            cartesian: CartesianFilter::new(),
            last_azimuth: 0.0,
        }
    }

    /// Sets the stage's `method` and `settings` and FDIV's band from the peak picker's `band` at
    /// analysis rate `fs` Hz; leaves the state alone.
    pub fn configure(
        &mut self,
        method: IvMethod,
        settings: IntensitySettings,
        band: &PeakSettings,
        fs: f32,
    ) {
        self.method = method;
        self.settings = settings;
        let band = PeakPicker::from_config(band, fs);
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

    /// One frame with the stage's method and settings (`spectra` is FDIV's workspace). An unusable
    /// frame keeps the last azimuth with confidence 0 and leaves the state alone.
    pub fn process(
        &mut self,
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
        let c = &self.settings;
        let iv = if self.method == IvMethod::Tdiv {
            tdiv_process(c.tdiv_pole, &mut self.tdiv, frame)
        } else {
            spectra.transform_all(frame);
            fdiv_process(c.fdiv_pole, &mut self.fdiv, spectra.channels(), lo, hi)
        };
        // Thesis option: FDIV reliability from the circular std over bins (§5.2.2), off by default.
        let iv = if self.method == IvMethod::Fdiv && c.fdiv_spread.enabled() {
            c.fdiv_spread
                .frame(&mut self.cartesian, spectra.channels(), lo, hi)
        } else {
            iv
        };
        self.last_azimuth = iv.azimuth_deg;
        iv
    }
}
