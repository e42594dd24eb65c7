//! Counters shared between the DSP task and the UART task (overruns, frame and calibration lines dropped).
//!
//! Relaxed atomics suffice: each counter has one writer and is only reported, never used to order
//! other memory accesses.

use core::sync::atomic::{AtomicU32, Ordering};

/// Link and capture counters (all wrap at 2³²).
#[derive(Debug, Default)]
pub struct Counters {
    overruns: AtomicU32,
    dropped: AtomicU32,
    calibration_dropped: AtomicU32,
}

impl Counters {
    /// All counters at 0.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            overruns: AtomicU32::new(0),
            dropped: AtomicU32::new(0),
            calibration_dropped: AtomicU32::new(0),
        }
    }

    /// Counts one DMA overrun (the capture lost samples and was resynchronised).
    pub fn count_overrun(&self) {
        self.overruns.fetch_add(1, Ordering::Relaxed);
    }

    /// Counts one estimate dropped because the UART queue was full.
    pub fn count_dropped(&self) {
        self.dropped.fetch_add(1, Ordering::Relaxed);
    }

    /// Counts one calibration line dropped because the UART queue was full.
    pub fn count_calibration_dropped(&self) {
        self.calibration_dropped.fetch_add(1, Ordering::Relaxed);
    }

    /// Calibration lines dropped by UART backpressure so far.
    #[must_use]
    pub fn calibration_dropped(&self) -> u32 {
        self.calibration_dropped.load(Ordering::Relaxed)
    }

    /// DMA overruns so far.
    #[must_use]
    pub fn overruns(&self) -> u32 {
        self.overruns.load(Ordering::Relaxed)
    }

    /// Estimates dropped by UART backpressure so far.
    #[must_use]
    pub fn dropped(&self) -> u32 {
        self.dropped.load(Ordering::Relaxed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_independently() {
        let c = Counters::new();
        c.count_overrun();
        c.count_dropped();
        c.count_dropped();
        c.count_calibration_dropped();
        assert_eq!(
            (c.overruns(), c.dropped(), c.calibration_dropped()),
            (1, 2, 1)
        );
    }
}
