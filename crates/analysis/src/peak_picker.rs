//! Peak picking (thesis §5.1.2): the N_p strongest local maxima of the omni power spectrum inside a
//! band, filled up with the strongest remaining in-band bins when there are fewer peaks than N_p.

use crate::{FRAME_LEN, MAX_PEAKS, NUM_BINS};

/// The settings of the peak picker: the analysis band and the peaks taken from it (in the
/// configuration file, top-level keys of the same names).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeakSettings {
    /// Lower edge of the analysis band, Hz.
    pub band_lo_hz: f32,
    /// Upper edge of the analysis band, Hz.
    pub band_hi_hz: f32,
    /// Number of peaks N_p (1…[`MAX_PEAKS`]).
    pub num_peaks: usize,
    /// Absolute magnitude threshold for peaks on |X_omni| (0 disables).
    pub peak_threshold: f32,
    /// Fill up to N_p with the strongest non-peak bins (§5.1.2).
    pub fill_peaks: bool,
}

/// Peak picker configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeakPicker {
    /// First bin of the band (inclusive, ≥ 1).
    pub lo_bin: usize,
    /// Last bin of the band (inclusive, ≤ NUM_BINS − 2).
    pub hi_bin: usize,
    /// Number of peaks to pick, 1…[`MAX_PEAKS`].
    pub num_peaks: usize,
    /// Bins whose power is below this are never picked (0 disables the threshold).
    pub min_power: f32,
    /// Fill up with the strongest non-peak bins when fewer than `num_peaks` peaks exist.
    pub fill: bool,
}

/// The picked bins, strongest first.
///
/// Two parallel fixed arrays and a length rather than a `heapless::Vec`: the insertion runs for
/// every candidate bin of every frame, and the vector's capacity checks cost the emulated
/// Cortex-M4F about 200 instructions per hop on speech (347 on the worst hop; `scripts/cost.sh`).
#[derive(Debug, Clone, PartialEq)]
pub struct Peaks {
    /// Bin indices; the first `len` are the peaks.
    bins: [u16; MAX_PEAKS],
    /// Power of the picking channel at each bin: entry i belongs to `bins[i]`.
    power: [f32; MAX_PEAKS],
    /// Number of peaks (≤ [`MAX_PEAKS`]).
    len: usize,
    /// How many of them are true local maxima (the rest are fill bins).
    pub n_maxima: usize,
}

impl Peaks {
    /// No peaks.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            bins: [0; MAX_PEAKS],
            power: [0.0; MAX_PEAKS],
            len: 0,
            n_maxima: 0,
        }
    }
}

impl Default for Peaks {
    fn default() -> Self {
        Self::new()
    }
}

impl Peaks {
    /// Inserts `(bin, p)` keeping the list sorted by descending power and at most `cap` long
    /// (`cap` ≤ [`MAX_PEAKS`]).
    fn insert(&mut self, cap: usize, bin: usize, p: f32) {
        let cap = cap.min(MAX_PEAKS);
        if cap == 0 || (self.len >= cap && p <= self.power[cap - 1]) {
            return;
        }
        let mut i = if self.len < cap { self.len } else { cap - 1 };
        while i > 0 && self.power[i - 1] < p {
            self.power[i] = self.power[i - 1];
            self.bins[i] = self.bins[i - 1];
            i -= 1;
        }
        self.power[i] = p;
        self.bins[i] = bin as u16;
        if self.len < cap {
            self.len += 1;
        }
    }

    /// The bin indices, strongest first.
    #[must_use]
    pub fn bins(&self) -> &[u16] {
        &self.bins[..self.len]
    }

    /// The picking channel's power at each of [`Peaks::bins`].
    #[must_use]
    pub fn power(&self) -> &[f32] {
        &self.power[..self.len]
    }

    /// Number of peaks.
    #[must_use]
    pub fn len(&self) -> usize {
        self.len
    }

    /// No peaks picked.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

impl PeakPicker {
    /// A placeholder of an unconfigured localizer: one peak anywhere in the spectrum.
    pub const IDLE: PeakPicker = PeakPicker {
        lo_bin: 1,
        hi_bin: NUM_BINS - 2,
        num_peaks: 1,
        min_power: 0.0,
        fill: false,
    };

    /// The peak picker of `config` at analysis rate `fs` Hz (band edges rounded to bins, kept
    /// inside 1…Nyquist − 1).
    #[must_use]
    pub fn from_config(config: &PeakSettings, fs: f32) -> Self {
        let bin_of = |f: f32| libm::roundf(f * FRAME_LEN as f32 / fs) as usize;
        PeakPicker {
            lo_bin: bin_of(config.band_lo_hz).max(1),
            hi_bin: bin_of(config.band_hi_hz).min(NUM_BINS - 2),
            num_peaks: config.num_peaks,
            min_power: config.peak_threshold * config.peak_threshold,
            fill: config.fill_peaks,
        }
    }

    /// `true` when bin `k` of `power` is a local maximum (slope sign changes from + to −).
    #[inline]
    fn is_peak(power: &[f32], k: usize) -> bool {
        power[k] > power[k - 1] && power[k] >= power[k + 1]
    }

    /// The bins peaks can come from, `(lo, hi)` inclusive, for spectra of [`crate::NUM_BINS`] bins.
    #[must_use]
    pub fn band(&self) -> (usize, usize) {
        self.band_of(crate::NUM_BINS)
    }

    /// [`PeakPicker::band`] for a spectrum of `len` bins: a peak needs a neighbour on each side.
    fn band_of(&self, len: usize) -> (usize, usize) {
        (self.lo_bin.max(1), self.hi_bin.min(len.saturating_sub(2)))
    }

    /// The bins of the power spectrum that [`PeakPicker::process`] reads: the band and one
    /// neighbour on each side (empty for an empty band). No other bin needs computing.
    #[must_use]
    pub fn reads(&self) -> core::ops::Range<usize> {
        let (lo, hi) = self.band();
        if lo > hi {
            0..0
        } else {
            lo - 1..hi + 2
        }
    }

    /// Picks peaks from `power` (one value per bin, DC…Nyquist) into `out`.
    pub fn process(&self, power: &[f32], out: &mut Peaks) {
        *out = Peaks::default();
        let n = self.num_peaks.clamp(1, MAX_PEAKS);
        let (lo, hi) = self.band_of(power.len());
        if lo > hi {
            return;
        }
        for k in lo..=hi {
            if power[k] >= self.min_power && power[k] > 0.0 && Self::is_peak(power, k) {
                out.insert(n, k, power[k]);
            }
        }
        out.n_maxima = out.len();
        if self.fill && out.len() < n {
            let mut fill = Peaks::default();
            let need = n - out.len();
            for k in lo..=hi {
                if power[k] >= self.min_power && power[k] > 0.0 && !Self::is_peak(power, k) {
                    fill.insert(need, k, power[k]);
                }
            }
            for (&bin, &p) in fill.bins().iter().zip(fill.power()) {
                let i = out.len;
                if i >= MAX_PEAKS {
                    break;
                }
                out.bins[i] = bin;
                out.power[i] = p;
                out.len += 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn picker(n: usize) -> PeakPicker {
        PeakPicker {
            lo_bin: 2,
            hi_bin: 20,
            num_peaks: n,
            min_power: 0.0,
            fill: true,
        }
    }

    #[test]
    fn picks_strongest_maxima_in_band() {
        let mut p = [0.1f32; 30];
        p[1] = 100.0; // out of band peak
        p[5] = 5.0;
        p[9] = 7.0;
        p[14] = 3.0;
        p[25] = 50.0; // out of band
        let mut out = Peaks::default();
        picker(2).process(&p, &mut out);
        assert_eq!(out.bins(), &[9, 5]);
        assert_eq!(out.n_maxima, 2);
    }

    #[test]
    fn fills_with_strongest_remaining_bins() {
        let mut p = [0.0f32; 30];
        for (k, v) in p.iter_mut().enumerate() {
            *v = 1.0 + k as f32 * 0.01; // rising: no maximum inside the band except the edge
        }
        p[10] = 9.0;
        p[11] = 8.0; // shoulder of the peak at 10
        let mut out = Peaks::default();
        picker(3).process(&p, &mut out);
        assert_eq!(out.n_maxima, 1);
        assert_eq!(out.bins(), &[10, 11, 20]);
    }

    /// The locator computes the power spectrum only over `reads()`: whatever the other bins hold
    /// must not change the picked peaks.
    #[test]
    fn reads_only_the_bins_it_names() {
        let mut rng = crate::test_rng::Lcg(7);
        for (lo, hi) in [(1, 255), (9, 171), (2, 20), (0, 300), (30, 29)] {
            let pk = PeakPicker {
                lo_bin: lo,
                hi_bin: hi,
                num_peaks: 10,
                min_power: 0.0,
                fill: true,
            };
            let mut p = [0.0f32; crate::NUM_BINS];
            for v in p.iter_mut() {
                *v = rng.unit();
            }
            let reads = pk.reads();
            let mut masked = [f32::NAN; crate::NUM_BINS];
            masked[reads.clone()].copy_from_slice(&p[reads]);
            let (mut a, mut b) = (Peaks::default(), Peaks::default());
            pk.process(&p, &mut a);
            pk.process(&masked, &mut b);
            assert_eq!(a.bins(), b.bins(), "band {lo}..={hi}");
            assert_eq!(a.n_maxima, b.n_maxima);
        }
    }

    #[test]
    fn threshold_can_leave_fewer_peaks() {
        let mut p = [0.0f32; 30];
        p[5] = 5.0;
        p[9] = 0.5;
        let mut out = Peaks::default();
        PeakPicker {
            min_power: 1.0,
            ..picker(4)
        }
        .process(&p, &mut out);
        assert_eq!(out.bins(), &[5]);
        let zero = [0.0f32; 30];
        picker(4).process(&zero, &mut out);
        assert!(out.is_empty());
    }

    /// The maxima come first, exactly as the plain per-bin scan picks them (the fill bins after
    /// them), on random spectra with plateaus, zeros, NaN and ∞, thresholds and bands over 64 bins.
    #[test]
    fn maxima_scan_equals_plain_scan() {
        let mut rng = crate::test_rng::Lcg(11);
        let mut rnd = move || rng.next_u32() >> 8;
        for round in 0..300 {
            let mut p = [0.0f32; crate::NUM_BINS];
            for v in p.iter_mut() {
                let r = rnd();
                *v = match r % 13 {
                    0 => 0.0,
                    1 => f32::NAN,
                    2 => f32::INFINITY,
                    3 => 0.5,
                    _ => (r % 1000) as f32 / 1000.0,
                };
            }
            let lo = rnd() as usize % 200;
            let pk = PeakPicker {
                lo_bin: lo,
                hi_bin: lo + rnd() as usize % 300,
                num_peaks: 1 + round % MAX_PEAKS,
                min_power: [0.0, 0.3, 0.9, f32::NAN][round % 4],
                fill: round % 2 == 0,
            };
            let mut got = Peaks::default();
            pk.process(&p, &mut got);
            let n = pk.num_peaks.clamp(1, MAX_PEAKS);
            let (lo, hi) = pk.band();
            let mut want = Peaks::default();
            for k in lo..=hi {
                if p[k] >= pk.min_power && p[k] > 0.0 && PeakPicker::is_peak(&p, k) {
                    want.insert(n, k, p[k]);
                }
            }
            let m = want.len();
            assert_eq!(got.n_maxima, m, "round {round}");
            assert_eq!(got.bins()[..m], *want.bins(), "round {round}");
            for (g, w) in got.power()[..m].iter().zip(want.power()) {
                assert_eq!(g.to_bits(), w.to_bits(), "round {round}");
            }
        }
    }
}
