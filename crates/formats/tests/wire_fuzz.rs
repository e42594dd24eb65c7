//! Property tests of the wire format (run by `cargo test`, fixed seed so failures reproduce):
//! arbitrary bytes never panic the decoder or the assembler, every frame round-trips, and single or
//! double byte corruption of a valid line is never accepted as a different frame; the same for the
//! calibration line.

use cma_formats::wire::{
    decode, decode_calibration, decode_line, encode, encode_calibration, CalibrationBand,
    CalibrationLine, DecodeError, Frame, Line, LineAssembler, MAX_ANY_LINE, MAX_CAL_LINE, MAX_LINE,
    PART_MAX, SHIFT_MAX,
};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

fn config(cases: u32) -> Config {
    Config {
        cases,
        rng_seed: RngSeed::Fixed(0x00C0_FFEE),
        failure_persistence: None,
        ..Config::default()
    }
}

fn any_frame() -> impl Strategy<Value = Frame> {
    (
        any::<u32>(),
        any::<u32>(),
        any::<u64>(),
        -1799i16..=1800,
        -1799i16..=1800,
        0u16..=1000,
        any::<u8>(),
        any::<u32>(),
        any::<u32>(),
    )
        .prop_map(|(seq, rate_hz, t, az, raw, conf, flags, ovr, drop)| Frame {
            seq,
            rate_hz,
            centre_sample: t,
            azimuth_tenths: az,
            raw_tenths: raw,
            confidence_permille: conf,
            flags,
            overruns: ovr,
            dropped: drop,
        })
}

fn encoded(f: &Frame) -> Vec<u8> {
    let mut buf = heapless::Vec::<u8, MAX_LINE>::new();
    encode(f, &mut buf);
    buf[..].to_vec()
}

/// A corrupted line may be rejected, or accepted only as the very same frame (e.g. a damaged
/// `\r\n`), never as another.
fn check_not_different(original: &Frame, corrupted: &[u8]) -> Result<(), TestCaseError> {
    if let Ok(got) = decode(corrupted) {
        prop_assert_eq!(
            &got,
            original,
            "corrupted line {:?}",
            String::from_utf8_lossy(corrupted)
        );
    }
    let mut asm = LineAssembler::<MAX_LINE>::new();
    let mut result = Ok(());
    asm.push_chunk(corrupted, |l| {
        if let Ok(got) = decode(l) {
            if got != *original {
                result = Err(TestCaseError::fail(
                    "assembler line accepted as another frame",
                ));
            }
        }
    });
    result
}

proptest! {
    #![proptest_config(config(20_000))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = decode(&bytes);
        let mut asm = LineAssembler::<MAX_LINE>::new();
        let mut n = 0usize;
        asm.push_chunk(&bytes, |l| { n += 1; let _ = decode(l); });
        prop_assert!(n <= bytes.len());
        let mut tiny = LineAssembler::<1>::new();
        tiny.push_chunk(&bytes, |l| { let _ = decode(l); });
    }

    #[test]
    fn lines_with_garbage_around_never_panic(
        f in any_frame(),
        cut in 0usize..MAX_LINE,
        junk in proptest::collection::vec(any::<u8>(), 0..40),
    ) {
        let l = encoded(&f);
        let mut bytes = l[..cut.min(l.len())].to_vec();
        bytes.extend_from_slice(&junk);
        bytes.extend_from_slice(&l);
        let _ = decode(&bytes);
        let mut asm = LineAssembler::<MAX_LINE>::new();
        let mut got = Vec::new();
        asm.push_chunk(&bytes, |line| got.push(decode(line)));
        // The intact copy at the end is always recovered.
        prop_assert_eq!(got.last().cloned(), Some(Ok(f)));
    }

    #[test]
    fn round_trip(f in any_frame()) {
        let l = encoded(&f);
        prop_assert!(l.len() <= MAX_LINE);
        prop_assert_eq!(decode(&l), Ok(f));
    }

    #[test]
    fn single_byte_corruption_never_accepted_as_another_frame(
        f in any_frame(),
        pos in any::<prop::sample::Index>(),
        value in any::<u8>(),
        delete in any::<bool>(),
    ) {
        let mut l = encoded(&f);
        let i = pos.index(l.len());
        if delete {
            l.remove(i);
        } else {
            prop_assume!(l[i] != value);
            l[i] = value;
        }
        check_not_different(&f, &l)?;
    }

    #[test]
    fn double_byte_corruption_never_accepted_as_another_frame(
        f in any_frame(),
        p1 in any::<prop::sample::Index>(),
        p2 in any::<prop::sample::Index>(),
        v1 in any::<u8>(),
        v2 in any::<u8>(),
        mode in 0u8..3,
    ) {
        let mut l = encoded(&f);
        let i = p1.index(l.len());
        match mode {
            0 => { l[i] ^= v1 | 1; let j = p2.index(l.len()); l[j] ^= v2 | 1; }
            1 => { l.remove(i); let j = p2.index(l.len()); l.remove(j); }
            _ => { l[i] ^= v1 | 1; let j = p2.index(l.len()); l.remove(j); }
        }
        check_not_different(&f, &l)?;
    }
}

// The calibration line (`$CAL`): the same properties, and the dispatching decoder agrees with the
// single-kind ones.

fn any_calibration() -> impl Strategy<Value = CalibrationLine> {
    let band = (
        any::<u32>(),
        prop::array::uniform3(0..=PART_MAX),
        prop::array::uniform3(0..=PART_MAX),
    )
        .prop_map(|(peaks, omni_part, dipole_part)| CalibrationBand {
            peaks,
            omni_part,
            dipole_part,
        });
    (
        any::<u32>(),
        any::<u64>(),
        0u16..=1000,
        any::<bool>(),
        any::<u32>(),
        prop::array::uniform4(band),
        prop::array::uniform2(-SHIFT_MAX..=SHIFT_MAX),
    )
        .prop_map(
            |(seq, t, conf, held, drop, bands, talker_shift)| CalibrationLine {
                seq,
                centre_sample: t,
                confidence_permille: conf,
                held,
                dropped: drop,
                bands,
                talker_shift,
            },
        )
}

fn encoded_calibration(c: &CalibrationLine) -> Vec<u8> {
    let mut buf = heapless::Vec::<u8, MAX_CAL_LINE>::new();
    encode_calibration(c, &mut buf);
    buf[..].to_vec()
}

/// A corrupted calibration line may be rejected, or accepted only as the very same line, never as
/// another calibration line nor as a frame.
fn check_calibration_not_different(
    original: &CalibrationLine,
    corrupted: &[u8],
) -> Result<(), TestCaseError> {
    if let Ok(got) = decode_line(corrupted) {
        prop_assert_eq!(got, Line::Calibration(*original));
    }
    let mut asm = LineAssembler::<MAX_ANY_LINE>::new();
    let mut result = Ok(());
    asm.push_chunk(corrupted, |l| {
        if let Ok(got) = decode_line(l) {
            if got != Line::Calibration(*original) {
                result = Err(TestCaseError::fail(
                    "assembler line accepted as another line",
                ));
            }
        }
    });
    result
}

proptest! {
    #![proptest_config(config(10_000))]

    #[test]
    fn arbitrary_bytes_never_panic_any_decoder(
        bytes in proptest::collection::vec(any::<u8>(), 0..400),
    ) {
        let _ = decode_calibration(&bytes);
        let any = decode_line(&bytes);
        if let Ok(c) = decode_calibration(&bytes) {
            prop_assert_eq!(any, Ok(Line::Calibration(c)));
        }
        let mut asm = LineAssembler::<MAX_ANY_LINE>::new();
        asm.push_chunk(&bytes, |l| { let _ = decode_line(l); });
    }

    #[test]
    fn calibration_round_trip(c in any_calibration()) {
        let l = encoded_calibration(&c);
        prop_assert!(l.len() <= MAX_CAL_LINE);
        prop_assert_eq!(decode_calibration(&l), Ok(c));
        prop_assert_eq!(decode_line(&l), Ok(Line::Calibration(c)));
        prop_assert_eq!(decode(&l), Err(DecodeError::CalibrationLine));
    }

    #[test]
    fn calibration_byte_corruption_never_accepted_as_another_line(
        c in any_calibration(),
        p1 in any::<prop::sample::Index>(),
        p2 in any::<prop::sample::Index>(),
        v1 in any::<u8>(),
        v2 in any::<u8>(),
        mode in 0u8..4,
    ) {
        let mut l = encoded_calibration(&c);
        let i = p1.index(l.len());
        match mode {
            0 => l[i] ^= v1 | 1,
            1 => { l[i] ^= v1 | 1; let j = p2.index(l.len()); l[j] ^= v2 | 1; }
            2 => { l.remove(i); let j = p2.index(l.len()); l.remove(j); }
            _ => { l[i] ^= v1 | 1; let j = p2.index(l.len()); l.remove(j); }
        }
        check_calibration_not_different(&c, &l)?;
    }
}
