//! The self-calibration's estimate kept across power cycles: an append-only log of records
//! ([`cma_core::capsule_estimate_record`], 144 bytes each) in one erase unit of flash.
//!
//! * **Boot** ([`EstimateStore::open`]): every slot is read; the newest valid record whose key is
//!   this build's ([`key_of`](cma_core::capsule_estimate_record::key_of) the build-time starting
//!   estimate, `CMA_SELFCAL`) is the estimate the self-calibration starts from. Torn records (a
//!   power cut during a write) and records of other builds are skipped. When no slot is free,
//!   [`EstimateStore::compact`] erases the region and writes the newest record back, still before
//!   the capture starts (erasing stalls the CPU for up to seconds; nothing else erases).
//! * **Running** ([`SavePolicy`]): at a calibration snapshot, an estimate that is confident enough
//!   and differs from the last one saved is written ([`EstimateStore::save`]) at most once a
//!   [`SAVE_PERIOD_S`]. The application writes it half-way between two analysis hops, when the
//!   capture ring is empty: programming 36 flash words stalls the CPU for about 0.6 ms (3.6 ms at
//!   the STM32F4's worst word time), and the ring holds 8 ms. A full log stops saving until the next
//!   boot compacts it.
//!
//! A power cut at any moment loses at most the record being written: the previous one stays valid.
//! A power cut during a compaction loses the stored estimate (the board starts from the build-time
//! one and learns again).

use cma_core::capsule_calibration::CapsuleEstimate;
use cma_core::capsule_estimate_record::{self, crc32, Record, RecordError, RECORD_LEN};
use embedded_storage::nor_flash::NorFlash;

/// Smallest self-calibration confidence ([`CapsuleEstimate::overall_confidence`]) worth saving.
pub const SAVE_CONFIDENCE: f32 = 0.2;

/// Shortest time between two saves, s (the first save of a boot waits for no period): at one
/// record a minute a 128 KB sector lasts 15 hours of changing estimates between erases, so its
/// 10 000 erase cycles last 17 years of an estimate that never settles.
pub const SAVE_PERIOD_S: u32 = 60;

/// What [`EstimateStore::open`] found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scan {
    /// The newest valid record of this build's key.
    pub latest: Option<Record>,
    /// Valid records of this build's key.
    pub records: u32,
    /// Slots that hold something else: torn writes, other builds' records, damaged bytes.
    pub skipped: u32,
}

/// Why a record was not saved.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum SaveError<E> {
    /// No free slot is left (the next boot compacts the log).
    Full,
    /// The flash refused the write; the slot is skipped.
    Flash(E),
}

/// An append-only log of estimate records in `len` bytes of a flash from `base`.
pub struct EstimateStore<F: NorFlash> {
    flash: F,
    base: u32,
    len: u32,
    slots: u32,
    key: u32,
    /// The first slot after every written one (`slots` when full).
    next_slot: u32,
    /// Sequence number of the next record.
    sequence: u32,
}

impl<F: NorFlash> EstimateStore<F> {
    /// Reads the log in `flash[base .. base + len]` (`base` and `len` whole erase units) for the
    /// build whose starting estimate has key `key`.
    ///
    /// # Errors
    /// A flash read error.
    pub fn open(mut flash: F, base: u32, len: u32, key: u32) -> Result<(Self, Scan), F::Error> {
        let slots = len / RECORD_LEN as u32;
        let mut scan = Scan {
            latest: None,
            records: 0,
            skipped: 0,
        };
        let mut next_slot = 0;
        let mut newest_sequence: Option<u32> = None;
        let mut bytes = [0u8; RECORD_LEN];
        for slot in 0..slots {
            flash.read(base + slot * RECORD_LEN as u32, &mut bytes)?;
            match capsule_estimate_record::decode(&bytes) {
                Err(RecordError::Erased) => continue,
                Ok(r) => {
                    newest_sequence =
                        Some(newest_sequence.map_or(r.sequence, |s| s.max(r.sequence)));
                    if r.key == key {
                        scan.records += 1;
                        if scan.latest.is_none_or(|l| r.sequence >= l.sequence) {
                            scan.latest = Some(r);
                        }
                    } else {
                        scan.skipped += 1;
                    }
                }
                Err(_) => scan.skipped += 1,
            }
            next_slot = slot + 1;
        }
        let store = Self {
            flash,
            base,
            len,
            slots,
            key,
            next_slot,
            sequence: newest_sequence.map_or(0, |s| s.wrapping_add(1)),
        };
        Ok((store, scan))
    }

    /// Whether no slot is free.
    #[must_use]
    pub fn is_full(&self) -> bool {
        self.next_slot >= self.slots
    }

    /// Records the log can still take.
    #[must_use]
    pub fn free_slots(&self) -> u32 {
        self.slots.saturating_sub(self.next_slot)
    }

    /// Erases the region and writes `keep` (the newest record, [`Scan::latest`]) back (blocking: a
    /// sector erase stalls the CPU for up to seconds; call it only before the capture starts).
    ///
    /// # Errors
    /// A flash erase or write error (the log is then empty).
    pub fn compact(&mut self, keep: Option<&Record>) -> Result<(), F::Error> {
        self.next_slot = 0;
        self.flash.erase(self.base, self.base + self.len)?;
        if let Some(keep) = keep {
            let bytes = capsule_estimate_record::encode(&keep.estimate, keep.sequence, self.key);
            self.next_slot = 1;
            self.flash.write(self.base, &bytes)?;
        }
        Ok(())
    }

    /// Appends `estimate` as the newest record (blocking: [`RECORD_LEN`] bytes of flash
    /// programming); returns its sequence number.
    ///
    /// # Errors
    /// [`SaveError::Full`] when no slot is free; [`SaveError::Flash`] when the write failed (the
    /// slot is then skipped).
    pub fn save(&mut self, estimate: &CapsuleEstimate) -> Result<u32, SaveError<F::Error>> {
        if self.is_full() {
            return Err(SaveError::Full);
        }
        let sequence = self.sequence;
        let bytes = capsule_estimate_record::encode(estimate, sequence, self.key);
        let at = self.base + self.next_slot * RECORD_LEN as u32;
        self.next_slot += 1;
        self.sequence = sequence.wrapping_add(1);
        self.flash.write(at, &bytes).map_err(SaveError::Flash)?;
        Ok(sequence)
    }

    /// The flash, back.
    pub fn release(self) -> F {
        self.flash
    }
}

/// When to save: a confident estimate that changed, at most once a [`SAVE_PERIOD_S`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SavePolicy {
    sample_rate_hz: u32,
    /// [`models_digest`] of the estimate last saved or loaded.
    last: Option<u32>,
    /// `centre_sample` of the last save of this boot.
    last_save: Option<u64>,
}

/// A CRC-32 of an estimate's models (the counts of peaks left out: they grow with every frame).
fn models_digest(estimate: &CapsuleEstimate) -> u32 {
    let mut bytes = [0u8; 4 * 6 * cma_core::capsule_calibration::CAL_BANDS];
    let values = estimate
        .bands
        .iter()
        .flat_map(|b| b.omni_part.iter().chain(&b.dipole_part));
    for (slot, v) in bytes.chunks_exact_mut(4).zip(values) {
        slot.copy_from_slice(&v.to_le_bytes());
    }
    crc32(&bytes)
}

impl SavePolicy {
    /// A policy at `sample_rate_hz` that knows `loaded` is already stored.
    #[must_use]
    pub fn new(sample_rate_hz: u32, loaded: Option<&CapsuleEstimate>) -> Self {
        Self {
            sample_rate_hz,
            last: loaded.map(models_digest),
            last_save: None,
        }
    }

    /// Whether `estimate` (confidence `confidence`, snapshot at `centre_sample`) should be saved now;
    /// when it says yes it counts the save.
    pub fn due(&mut self, estimate: &CapsuleEstimate, confidence: f32, centre_sample: u64) -> bool {
        // `!(≥)` also refuses a NaN confidence.
        if !(confidence >= SAVE_CONFIDENCE) {
            return false;
        }
        let period = u64::from(SAVE_PERIOD_S) * u64::from(self.sample_rate_hz);
        if self
            .last_save
            .is_some_and(|t| centre_sample < t.saturating_add(period))
        {
            return false;
        }
        let digest = models_digest(estimate);
        if self.last == Some(digest) {
            return false;
        }
        self.last = Some(digest);
        self.last_save = Some(centre_sample);
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_storage::nor_flash::{ErrorType, NorFlashError, NorFlashErrorKind, ReadNorFlash};

    /// NOR flash in RAM: writes can only clear bits, erases set whole units to 0xFF; after
    /// `bytes_left` bytes are written, writes stop there and fail (a power cut).
    struct RamNor {
        bytes: std::vec::Vec<u8>,
        bytes_left: usize,
    }

    const ERASE: usize = 1024;

    #[derive(Debug)]
    struct Cut;

    impl NorFlashError for Cut {
        fn kind(&self) -> NorFlashErrorKind {
            NorFlashErrorKind::Other
        }
    }

    impl ErrorType for RamNor {
        type Error = Cut;
    }

    impl ReadNorFlash for RamNor {
        const READ_SIZE: usize = 1;
        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Cut> {
            let o = offset as usize;
            bytes.copy_from_slice(&self.bytes[o..o + bytes.len()]);
            Ok(())
        }
        fn capacity(&self) -> usize {
            self.bytes.len()
        }
    }

    impl NorFlash for RamNor {
        const WRITE_SIZE: usize = 16;
        const ERASE_SIZE: usize = ERASE;
        fn erase(&mut self, from: u32, to: u32) -> Result<(), Cut> {
            assert!(from as usize % ERASE == 0 && to as usize % ERASE == 0);
            self.bytes[from as usize..to as usize].fill(0xFF);
            Ok(())
        }
        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Cut> {
            assert!(offset as usize % 16 == 0 && bytes.len() % 16 == 0);
            let n = bytes.len().min(self.bytes_left);
            self.bytes_left -= n;
            for (d, s) in self.bytes[offset as usize..].iter_mut().zip(&bytes[..n]) {
                *d &= *s;
            }
            if n < bytes.len() {
                Err(Cut)
            } else {
                Ok(())
            }
        }
    }

    fn blank() -> RamNor {
        RamNor {
            bytes: std::vec![0xFF; 2 * ERASE],
            bytes_left: usize::MAX,
        }
    }

    const BASE: u32 = ERASE as u32;
    const LEN: u32 = ERASE as u32;
    const KEY: u32 = 0x1234_5678;

    fn estimate(x: f32) -> CapsuleEstimate {
        let mut e = CapsuleEstimate::IDEAL;
        for b in &mut e.bands {
            b.omni_part = [0.5 + x, 0.49, 0.51];
            b.peaks = 2000.0;
        }
        e
    }

    fn save(store: &mut EstimateStore<RamNor>, e: &CapsuleEstimate) -> Result<u32, SaveError<Cut>> {
        store.save(e)
    }

    #[test]
    fn a_blank_store_has_nothing_and_keeps_what_it_is_given() {
        let (mut store, scan) = EstimateStore::open(blank(), BASE, LEN, KEY).unwrap();
        assert_eq!(
            scan,
            Scan {
                latest: None,
                records: 0,
                skipped: 0
            }
        );
        assert_eq!(store.free_slots(), LEN / RECORD_LEN as u32);
        assert_eq!(save(&mut store, &estimate(0.01)).unwrap(), 0);
        assert_eq!(save(&mut store, &estimate(0.02)).unwrap(), 1);
        let flash = store.release();
        // Nothing outside the region was touched.
        assert!(flash.bytes[..ERASE].iter().all(|&b| b == 0xFF));
        let (store, scan) = EstimateStore::open(flash, BASE, LEN, KEY).unwrap();
        assert_eq!(scan.records, 2);
        let latest = scan.latest.unwrap();
        assert_eq!((latest.sequence, latest.estimate), (1, estimate(0.02)));
        assert_eq!(store.free_slots(), LEN / RECORD_LEN as u32 - 2);
    }

    #[test]
    fn a_power_cut_loses_only_the_record_being_written() {
        let (mut store, _) = EstimateStore::open(blank(), BASE, LEN, KEY).unwrap();
        save(&mut store, &estimate(0.01)).unwrap();
        let mut flash = store.release();
        flash.bytes_left = 50;
        let (mut store, _) = EstimateStore::open(flash, BASE, LEN, KEY).unwrap();
        assert!(save(&mut store, &estimate(0.02)).is_err());
        let mut flash = store.release();
        flash.bytes_left = usize::MAX;
        let (mut store, scan) = EstimateStore::open(flash, BASE, LEN, KEY).unwrap();
        assert_eq!((scan.records, scan.skipped), (1, 1));
        assert_eq!(scan.latest.unwrap().estimate, estimate(0.01));
        // The next record goes after the torn one, and is the newest.
        assert_eq!(save(&mut store, &estimate(0.03)).unwrap(), 1);
        let (_, scan) = EstimateStore::open(store.release(), BASE, LEN, KEY).unwrap();
        assert_eq!(scan.latest.unwrap().estimate, estimate(0.03));
        assert_eq!((scan.records, scan.skipped), (2, 1));
    }

    #[test]
    fn another_builds_records_are_skipped() {
        let (mut store, _) = EstimateStore::open(blank(), BASE, LEN, KEY + 1).unwrap();
        save(&mut store, &estimate(0.01)).unwrap();
        let (mut store, scan) = EstimateStore::open(store.release(), BASE, LEN, KEY).unwrap();
        assert_eq!((scan.latest, scan.records, scan.skipped), (None, 0, 1));
        // Sequence numbers keep rising across keys.
        assert_eq!(save(&mut store, &estimate(0.02)).unwrap(), 1);
    }

    #[test]
    fn a_full_log_refuses_saves_until_compacted() {
        let (mut store, _) = EstimateStore::open(blank(), BASE, LEN, KEY).unwrap();
        let slots = LEN / RECORD_LEN as u32;
        for i in 0..slots {
            save(&mut store, &estimate(0.001 * i as f32)).unwrap();
        }
        assert!(store.is_full());
        assert!(matches!(store.save(&estimate(0.05)), Err(SaveError::Full)));
        let (mut store, scan) = EstimateStore::open(store.release(), BASE, LEN, KEY).unwrap();
        assert!(store.is_full());
        assert_eq!(scan.latest.unwrap().sequence, slots - 1);
        store.compact(scan.latest.as_ref()).unwrap();
        assert_eq!(store.free_slots(), slots - 1);
        assert_eq!(save(&mut store, &estimate(0.05)).unwrap(), slots);
        let (_, scan) = EstimateStore::open(store.release(), BASE, LEN, KEY).unwrap();
        assert_eq!(scan.records, 2);
        assert_eq!(scan.latest.unwrap().estimate, estimate(0.05));
    }

    #[test]
    fn the_policy_saves_confident_changes_once_a_period() {
        let rate = 16_000;
        let s = |t: u64| t * rate;
        let mut p = SavePolicy::new(rate as u32, Some(&estimate(0.01)));
        assert!(!p.due(&estimate(0.02), 0.1, s(10)), "not confident");
        assert!(!p.due(&estimate(0.02), f32::NAN, s(10)), "NaN confidence");
        assert!(!p.due(&estimate(0.01), 0.5, s(10)), "what was loaded");
        assert!(p.due(&estimate(0.02), 0.5, s(10)));
        assert!(!p.due(&estimate(0.03), 0.5, s(20)), "within the period");
        assert!(p.due(&estimate(0.03), 0.5, s(10 + u64::from(SAVE_PERIOD_S))));
        let mut peaks_only = estimate(0.03);
        peaks_only.bands[0].peaks += 100.0;
        assert!(!p.due(&peaks_only, 0.6, s(200)), "only the counts changed");
    }
}
