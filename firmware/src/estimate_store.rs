//! The self-calibration's estimate kept across power cycles: an append-only log of records
//! ([`cma_core::capsule_estimate_record`], 144 bytes each) in two halves of a flash region, each
//! half whole erase units (two 128 KB sectors on the STM32 boards).
//!
//! * **Slots**: slot *k* is at *k* × 144 bytes from the region's start, so a reader that walks the
//!   whole image in records (`host-sim --selfcal-in`) finds every record; the slot across the
//!   boundary of the halves is not used.
//! * **Boot** ([`EstimateStore::open`]): every slot is read; the newest valid record whose key is
//!   this build's ([`key_of`](cma_core::capsule_estimate_record::key_of) the build-time starting
//!   estimate, `CMA_SELFCAL`) is the estimate the self-calibration starts from, and its half is the
//!   *active* half, where records are appended. Torn records (a power cut during a write) and
//!   records of other builds are skipped. The other half, the *spare*, holds nothing newer of this
//!   build: unless it is blank, the application erases it ([`EstimateStore::erase_spare`]) before
//!   the capture starts (erasing stalls the CPU for up to seconds).
//! * **Running** ([`SavePolicy`]): at a calibration snapshot, an estimate that is confident enough
//!   and differs from the last one saved is written ([`EstimateStore::save`]) at most once a
//!   [`SAVE_PERIOD_S`]. The application writes it half-way between two analysis hops, when the
//!   capture ring is empty: programming 36 flash words stalls the CPU for about 0.6 ms (3.6 ms at
//!   the STM32F4's worst word time), and the ring holds 8 ms. When the active half is full, the
//!   record goes to the (blank) spare, which becomes the active half. Only when both halves fill
//!   within one uptime (≥ 2 × 910 saves, 30 hours of an estimate that keeps changing on the STM32
//!   boards) does a save need an erase first ([`EstimateStore::needs_erase`]); the application
//!   then erases the old half at run time (the capture overruns once).
//!
//! A power cut at any moment loses at most the record being written: the newest complete record
//! is never in the half being erased (a half is erased only when the other holds this build's
//! newest record, or when it holds none of this build's records), and the first record of a fresh
//! half is written while the old half is still intact.

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
    /// No free slot is left: the spare half must be erased first ([`EstimateStore::needs_erase`]).
    Full,
    /// The flash refused the write; the slot is skipped.
    Flash(E),
}

/// An append-only log of estimate records in `len` bytes of a flash from `base`, in two halves.
pub struct EstimateStore<F: NorFlash> {
    flash: F,
    base: u32,
    /// Bytes per half.
    half: u32,
    key: u32,
    /// The half records are appended to (0 or 1).
    active: u32,
    /// The first slot of the active half after every written one (its end when full).
    next_slot: u32,
    /// Every slot of the other half is erased.
    spare_blank: bool,
    /// Sequence number of the next record.
    sequence: u32,
}

/// What one half holds.
#[derive(Debug, Clone, Copy, Default)]
struct HalfScan {
    /// The first slot after every written one.
    next_slot: u32,
    /// Every slot is erased.
    blank: bool,
    /// The newest sequence number of any valid record.
    newest: Option<u32>,
}

impl<F: NorFlash> EstimateStore<F> {
    /// The slots of half `h` (absolute slot numbers, counted from `base`).
    fn half_slots(half: u32, h: u32) -> core::ops::Range<u32> {
        let r = RECORD_LEN as u32;
        (h * half).div_ceil(r)..((h + 1) * half) / r
    }

    /// Reads the log in `flash[base .. base + len]` (`len` two halves of whole erase units) for
    /// the build whose starting estimate has key `key`.
    ///
    /// # Errors
    /// A flash read error.
    pub fn open(mut flash: F, base: u32, len: u32, key: u32) -> Result<(Self, Scan), F::Error> {
        let half = len / 2;
        let mut scan = Scan {
            latest: None,
            records: 0,
            skipped: 0,
        };
        let mut latest_half = None;
        let mut halves = [HalfScan::default(); 2];
        let mut bytes = [0u8; RECORD_LEN];
        for (h, hs) in (0..2).zip(halves.iter_mut()) {
            let slots = Self::half_slots(half, h);
            hs.next_slot = slots.start;
            hs.blank = true;
            for slot in slots {
                flash.read(base + slot * RECORD_LEN as u32, &mut bytes)?;
                match capsule_estimate_record::decode(&bytes) {
                    Err(RecordError::Erased) => continue,
                    Ok(r) => {
                        hs.newest = Some(hs.newest.map_or(r.sequence, |s| s.max(r.sequence)));
                        if r.key == key {
                            scan.records += 1;
                            if scan.latest.is_none_or(|l| r.sequence >= l.sequence) {
                                scan.latest = Some(r);
                                latest_half = Some(h);
                            }
                        } else {
                            scan.skipped += 1;
                        }
                    }
                    Err(_) => scan.skipped += 1,
                }
                hs.blank = false;
                hs.next_slot = slot + 1;
            }
        }
        // The half of this build's newest record; without one, the half of the newest record.
        let active = latest_half.unwrap_or(match (halves[0].newest, halves[1].newest) {
            (Some(a), Some(b)) if b > a => 1,
            (None, Some(_)) => 1,
            _ => 0,
        });
        let newest = halves.iter().filter_map(|h| h.newest).max();
        let store = Self {
            flash,
            base,
            half,
            key,
            active,
            next_slot: halves[active as usize].next_slot,
            spare_blank: halves[1 - active as usize].blank,
            sequence: newest.map_or(0, |s| s.wrapping_add(1)),
        };
        Ok((store, scan))
    }

    /// Whether the active half has no free slot.
    fn active_full(&self) -> bool {
        self.next_slot >= Self::half_slots(self.half, self.active).end
    }

    /// Whether the spare half is blank (every slot erased).
    #[must_use]
    pub fn spare_is_blank(&self) -> bool {
        self.spare_blank
    }

    /// Whether the next save needs [`Self::erase_spare`] first: the active half is full and the
    /// spare is not blank.
    #[must_use]
    pub fn needs_erase(&self) -> bool {
        self.active_full() && !self.spare_blank
    }

    /// Records the log can take before an erase.
    #[must_use]
    pub fn free_slots(&self) -> u32 {
        let active = Self::half_slots(self.half, self.active)
            .end
            .saturating_sub(self.next_slot);
        let spare = if self.spare_blank {
            Self::half_slots(self.half, 1 - self.active).len() as u32
        } else {
            0
        };
        active.saturating_add(spare)
    }

    /// Erases the spare half (blocking: a sector erase stalls the CPU for up to seconds). The
    /// active half, which holds this build's newest record, is not touched.
    ///
    /// # Errors
    /// A flash erase error (the spare is then not blank).
    pub fn erase_spare(&mut self) -> Result<(), F::Error> {
        let from = self.base + (1 - self.active) * self.half;
        self.spare_blank = false;
        self.flash.erase(from, from + self.half)?;
        self.spare_blank = true;
        Ok(())
    }

    /// Appends `estimate` as the newest record (blocking: [`RECORD_LEN`] bytes of flash
    /// programming); returns its sequence number. When the active half is full, the record
    /// opens the blank spare half, which becomes the active one.
    ///
    /// # Errors
    /// [`SaveError::Full`] when no slot is free without an erase ([`Self::needs_erase`]);
    /// [`SaveError::Flash`] when the write failed (the slot is then skipped).
    pub fn save(&mut self, estimate: &CapsuleEstimate) -> Result<u32, SaveError<F::Error>> {
        if self.active_full() {
            if !self.spare_blank {
                return Err(SaveError::Full);
            }
            self.active = 1 - self.active;
            self.next_slot = Self::half_slots(self.half, self.active).start;
            self.spare_blank = false;
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

/// A CRC-32 of an estimate's models and the talker's shift (the counts of peaks left out: they
/// grow with every frame).
fn models_digest(estimate: &CapsuleEstimate) -> u32 {
    let mut bytes = [0u8; 4 * (6 * cma_core::capsule_calibration::CAL_BANDS + 2)];
    let values = estimate
        .bands
        .iter()
        .flat_map(|b| b.omni_part.iter().chain(&b.dipole_part))
        .chain(&estimate.talker_shift);
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
    /// when it says yes it counts the save. An estimate whose background confidence is low is
    /// still worth saving with a talker's shift: a noise source from power-on holds the
    /// background's estimate, and the shift ([`CapsuleEstimate::talker_shift`], on which four of
    /// the talker's places had to agree) is then the whole correction.
    pub fn due(&mut self, estimate: &CapsuleEstimate, confidence: f32, centre_sample: u64) -> bool {
        // `!(≥)` also refuses a NaN confidence.
        if !(confidence >= SAVE_CONFIDENCE) && !estimate.has_talker_shift() {
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
            assert!((from as usize).is_multiple_of(ERASE) && (to as usize).is_multiple_of(ERASE));
            self.bytes[from as usize..to as usize].fill(0xFF);
            Ok(())
        }
        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Cut> {
            assert!((offset as usize).is_multiple_of(16) && bytes.len().is_multiple_of(16));
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
            bytes: std::vec![0xFF; 4 * ERASE],
            bytes_left: usize::MAX,
        }
    }

    const BASE: u32 = ERASE as u32;
    /// Two halves of one erase unit each.
    const LEN: u32 = 2 * ERASE as u32;
    /// Slots of the first half (1024 / 144) and of the second (from ⌈1024 / 144⌉ = 8 to
    /// ⌊2048 / 144⌋ = 14): the slot across the boundary is not used.
    const HALF_SLOTS: [u32; 2] = [7, 6];
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
        assert_eq!(store.free_slots(), HALF_SLOTS[0] + HALF_SLOTS[1]);
        assert!(store.spare_is_blank() && !store.needs_erase());
        assert_eq!(save(&mut store, &estimate(0.01)).unwrap(), 0);
        assert_eq!(save(&mut store, &estimate(0.02)).unwrap(), 1);
        let flash = store.release();
        // Nothing outside the region was touched.
        assert!(flash.bytes[..ERASE].iter().all(|&b| b == 0xFF));
        assert!(flash.bytes[3 * ERASE..].iter().all(|&b| b == 0xFF));
        let (store, scan) = EstimateStore::open(flash, BASE, LEN, KEY).unwrap();
        assert_eq!(scan.records, 2);
        let latest = scan.latest.unwrap();
        assert_eq!((latest.sequence, latest.estimate), (1, estimate(0.02)));
        assert_eq!(store.free_slots(), HALF_SLOTS[0] + HALF_SLOTS[1] - 2);
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

    /// The valid records of an image walked in records from the region's start, as
    /// `host-sim --selfcal-in` reads a store image.
    fn image_records(flash: &RamNor) -> std::vec::Vec<Record> {
        flash.bytes[BASE as usize..(BASE + LEN) as usize]
            .chunks_exact(RECORD_LEN)
            .filter_map(|slot| capsule_estimate_record::decode(slot.try_into().ok()?).ok())
            .collect()
    }

    #[test]
    fn a_full_half_continues_in_the_other_and_saving_never_stops() {
        let (mut store, _) = EstimateStore::open(blank(), BASE, LEN, KEY).unwrap();
        let mut sequence = 0;
        // Five rounds of filling a half: the spare is blank after the first, then a save needs
        // an erase each time the active half is full.
        for round in 0..5 {
            let h = round % 2;
            for _ in 0..HALF_SLOTS[h] {
                assert!(!store.needs_erase(), "round {round}");
                let e = estimate(0.001 * sequence as f32);
                assert_eq!(store.save(&e).unwrap(), sequence);
                sequence += 1;
                // Every record is found where a whole-image reader looks, and the newest one is
                // what the next boot starts from.
                let (reopened, scan) =
                    EstimateStore::open(store.release(), BASE, LEN, KEY).unwrap();
                store = reopened;
                assert_eq!(scan.latest.unwrap().estimate, e);
                let newest = image_records(&store.flash)
                    .into_iter()
                    .max_by_key(|r| r.sequence);
                assert_eq!(newest.map(|r| r.estimate), Some(e));
            }
            if round == 0 {
                assert!(store.spare_is_blank());
            } else {
                assert!(store.needs_erase());
                assert!(matches!(store.save(&estimate(0.5)), Err(SaveError::Full)));
                store.erase_spare().unwrap();
            }
        }
        assert_eq!(
            image_records(&store.flash).iter().map(|r| r.sequence).max(),
            Some(sequence - 1)
        );
    }

    /// A flash whose operations stop after `ops_left` erases or 16-byte writes (a power cut): a
    /// cut erase leaves the first `ERASE / 3` bytes erased and the rest as they were.
    struct CutFlash {
        nor: RamNor,
        ops_left: usize,
    }

    impl ErrorType for CutFlash {
        type Error = Cut;
    }

    impl ReadNorFlash for CutFlash {
        const READ_SIZE: usize = 1;
        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Cut> {
            self.nor.read(offset, bytes)
        }
        fn capacity(&self) -> usize {
            self.nor.capacity()
        }
    }

    impl NorFlash for CutFlash {
        const WRITE_SIZE: usize = 16;
        const ERASE_SIZE: usize = ERASE;
        fn erase(&mut self, from: u32, to: u32) -> Result<(), Cut> {
            if self.ops_left == 0 {
                self.nor.bytes[from as usize..from as usize + ERASE / 3].fill(0xFF);
                return Err(Cut);
            }
            self.ops_left -= 1;
            self.nor.erase(from, to)
        }
        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Cut> {
            for (i, cell) in bytes.chunks_exact(16).enumerate() {
                if self.ops_left == 0 {
                    return Err(Cut);
                }
                self.ops_left -= 1;
                self.nor.write(offset + 16 * i as u32, cell)?;
            }
            Ok(())
        }
    }

    #[test]
    fn a_power_cut_at_any_step_keeps_the_last_complete_record() {
        // Boots that erase the spare when it is not blank, and saves that erase it when needed:
        // the application's use. A cut after `cut` flash operations; then the next boot must
        // start from the newest record whose save completed.
        let saves = 3 * (HALF_SLOTS[0] + HALF_SLOTS[1]) as usize;
        for cut in 0..saves * (RECORD_LEN / 16 + 1) {
            let mut flash = CutFlash {
                nor: blank(),
                ops_left: cut,
            };
            let mut last_complete = None;
            'boots: for boot in 0..saves {
                let (mut store, scan) = EstimateStore::open(flash, BASE, LEN, KEY).unwrap();
                assert_eq!(
                    scan.latest.map(|r| r.estimate),
                    last_complete,
                    "cut after {cut} operations, boot {boot}"
                );
                if !store.spare_is_blank() && store.erase_spare().is_err() {
                    flash = store.release();
                    break 'boots;
                }
                // Three saves a boot.
                for i in 0..3 {
                    let e = estimate(0.001 * (boot * 3 + i) as f32);
                    if store.needs_erase() && store.erase_spare().is_err() {
                        flash = store.release();
                        break 'boots;
                    }
                    match store.save(&e) {
                        Ok(_) => last_complete = Some(e),
                        Err(_) => {
                            flash = store.release();
                            break 'boots;
                        }
                    }
                }
                flash = store.release();
            }
            flash.ops_left = usize::MAX;
            let (_, scan) = EstimateStore::open(flash, BASE, LEN, KEY).unwrap();
            assert_eq!(
                scan.latest.map(|r| r.estimate),
                last_complete,
                "cut after {cut} operations"
            );
        }
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
        // Beside a source from power-on: nothing learned from the background, a talker's shift.
        let mut shifted = estimate(0.03);
        shifted.talker_shift = [0.08, -0.03];
        assert!(p.due(&shifted, 0.01, s(300)), "a talker's shift");
        shifted.talker_shift[1] = -0.02;
        assert!(!p.due(&shifted, 0.01, s(310)), "within the period");
        assert!(p.due(&shifted, 0.01, s(400)), "the shift changed");
    }
}
