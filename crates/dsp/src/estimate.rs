//! The per-analysis-frame result record.

/// Status flags of an estimate (a bit set).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Flags(pub u8);

impl Flags {
    /// The omni frame power is below the silence threshold (digital silence or near it).
    pub const SILENT: Flags = Flags(1 << 0);
    /// Some input samples of the frame reached the clipping level.
    pub const CLIPPED: Flags = Flags(1 << 1);
    /// Some input samples of the frame were NaN or ±Inf (replaced by 0).
    pub const NON_FINITE: Flags = Flags(1 << 2);
    /// No usable spectral peak: the frame carried no direction information.
    pub const NO_PEAKS: Flags = Flags(1 << 3);
    /// The estimate has not been informed by any reliable frame yet.
    pub const NO_HISTORY: Flags = Flags(1 << 4);

    /// No flag set.
    pub const NONE: Flags = Flags(0);

    /// `true` if every flag of `other` is set.
    #[must_use]
    pub const fn contains(self, other: Flags) -> bool {
        self.0 & other.0 == other.0
    }

    /// `true` if no flag is set.
    #[must_use]
    pub const fn is_empty(self) -> bool {
        self.0 == 0
    }

    /// Sets the flags of `other`.
    pub fn insert(&mut self, other: Flags) {
        self.0 |= other.0;
    }
}

impl core::ops::BitOr for Flags {
    type Output = Flags;
    fn bitor(self, rhs: Flags) -> Flags {
        Flags(self.0 | rhs.0)
    }
}

/// What the localizer says about one analysis frame.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Estimate {
    /// Analysis frame index, 0 for the first frame.
    pub frame_index: u32,
    /// Time of the frame's centre in input samples, group delay of the decimator removed
    /// (divide by the input rate for seconds).
    pub centre_sample: u64,
    /// Reliability-weighted azimuth in degrees, (−180, 180], counter-clockwise from cardioid 1.
    pub azimuth_deg: f32,
    /// Azimuth of this frame alone (b = 1, the thesis's `pos_noqm`), degrees.
    pub azimuth_raw_deg: f32,
    /// Confidence b ∈ [0, 1] of this frame (the filter coefficient).
    pub confidence: f32,
    /// Mean-square power of the omni channel over the frame (full scale = 1).
    pub power: f32,
    /// Status flags.
    pub flags: Flags,
}

impl Estimate {
    /// Time of the frame's centre in seconds at input rate `rate_hz`.
    #[must_use]
    pub fn time_s(&self, rate_hz: u32) -> f64 {
        self.centre_sample as f64 / rate_hz as f64
    }
}
