//! Property tests: no input can make the core panic; bad samples give flagged, low-confidence
//! estimates; every estimate is finite and in range.

use cma_core::{Estimate, Flags, Locator, LocatorConfig, Method, ReferenceTable};
use proptest::prelude::*;

fn special() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -1.0f32..1.0,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(0.0f32),
        1 => Just(1.0f32),
        1 => Just(-1.0f32),
        1 => any::<f32>(),
    ]
}

fn check(e: &Estimate) {
    assert!(
        e.azimuth_deg.is_finite() && e.azimuth_deg > -180.0 && e.azimuth_deg <= 180.0,
        "{e:?}"
    );
    assert!(
        e.azimuth_raw_deg.is_finite() && e.azimuth_raw_deg > -180.0 && e.azimuth_raw_deg <= 180.0,
        "{e:?}"
    );
    assert!((0.0..=1.0).contains(&e.confidence), "{e:?}");
    assert!(e.power.is_finite() && e.power >= 0.0, "{e:?}");
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, .. ProptestConfig::default() })]
    #[test]
    fn arbitrary_blocks_never_panic(
        samples in prop::collection::vec(prop::array::uniform4(special()), 0..6000),
        split in 1usize..2000,
        rate in prop::sample::select(vec![16000u32, 44100, 48000]),
        method in prop::sample::select(vec![Method::Similarity, Method::Fdiv, Method::Tdiv]),
        thesis in any::<bool>(),
    ) {
        let mut cfg = if thesis { LocatorConfig::thesis() } else { LocatorConfig::default() };
        cfg.method = method;
        let mut loc = Locator::new(cfg, ReferenceTable::ideal_5deg(), rate).unwrap();
        for block in samples.chunks(split) {
            loc.process_block(block, check);
        }
    }
}

#[test]
fn bad_samples_are_flagged_with_zero_confidence() {
    let mut loc = Locator::new(
        LocatorConfig::default(),
        ReferenceTable::ideal_5deg(),
        16000,
    )
    .unwrap();
    let mut out = Vec::new();
    // Silence, then NaN-riddled noise, then clipping.
    let silence = vec![[0.0f32; 4]; 4096];
    loc.process_block(&silence, |e| out.push(*e));
    assert!(out
        .iter()
        .all(|e| e.flags.contains(Flags::SILENT) && e.confidence == 0.0));
    out.clear();
    let mut seed = 1u32;
    let mut noise = || {
        seed = seed.wrapping_mul(1664525).wrapping_add(1013904223);
        (seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5
    };
    let nan: Vec<[f32; 4]> = (0..4096)
        .map(|i| {
            if i % 100 == 0 {
                [f32::NAN; 4]
            } else {
                [noise(), noise(), noise(), noise()]
            }
        })
        .collect();
    loc.process_block(&nan, |e| out.push(*e));
    assert!(
        out.iter()
            .all(|e| e.flags.contains(Flags::NON_FINITE) && e.confidence == 0.0),
        "{out:?}"
    );
    out.clear();
    let clipped: Vec<[f32; 4]> = (0..4096)
        .map(|i| {
            if i % 50 == 0 {
                [3.0; 4]
            } else {
                [noise(), noise(), noise(), noise()]
            }
        })
        .collect();
    loc.process_block(&clipped, |e| out.push(*e));
    assert!(out.iter().all(|e| e.flags.contains(Flags::CLIPPED)));
    assert!(out
        .iter()
        .all(|e| e.confidence <= LocatorConfig::default().clipped_confidence));
}

#[test]
fn block_size_does_not_change_results() {
    let frames: Vec<[f32; 4]> = (0..20000)
        .map(|n| {
            let s = (n as f32 * 0.07).sin() * (n as f32 * 0.0011).sin();
            let g = |look: f32| 0.5 + 0.5 * (0.7f32 - look.to_radians()).cos();
            [s, s * g(0.0), s * g(120.0), s * g(240.0)]
        })
        .collect();
    let run = |split: usize| {
        let mut loc = Locator::new(
            LocatorConfig::default(),
            ReferenceTable::ideal_5deg(),
            48000,
        )
        .unwrap();
        let mut v = Vec::new();
        for b in frames.chunks(split) {
            loc.process_block(b, |e| v.push(*e));
        }
        v
    };
    let reference = run(1024);
    for split in [1, 7, 333, 4096] {
        assert_eq!(run(split), reference, "block size {split}");
    }
}
