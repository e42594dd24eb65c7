//! `Locator::process_block` gives bit-identical estimates whatever the block sizes, and equals
//! `Locator::process_sample`.

use cma_core::{Estimate, Locator, LocatorConfig, Method, ReferenceTable, CHANNELS};

const N: usize = 48_000 * 3 / 2;

/// A talker-like tone complex at 70° with ideal cardioid gains, independent noise, one NaN and a
/// clipped burst.
fn signal() -> Vec<[f32; CHANNELS]> {
    let mut seed = 1u32;
    let mut noise = move || {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        ((seed >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 0.02
    };
    let az = 70f32.to_radians();
    let gains = [0.0f32, 120.0, 240.0].map(|l| 0.5 + 0.5 * (az - l.to_radians()).cos());
    (0..N)
        .map(|n| {
            let t = n as f32 / 48_000.0;
            let env = if (n / 6000) % 3 == 2 { 0.0 } else { 1.0 };
            let s = env
                * (0.3 * (2.0 * core::f32::consts::PI * 220.0 * t).sin()
                    + 0.2 * (2.0 * core::f32::consts::PI * 660.0 * t).sin()
                    + 0.1 * (2.0 * core::f32::consts::PI * 1540.0 * t).sin());
            let mut x = [
                s + noise(),
                gains[0] * s + noise(),
                gains[1] * s + noise(),
                gains[2] * s + noise(),
            ];
            if n == 20_011 {
                x[2] = f32::NAN;
            }
            if (40_000..40_050).contains(&n) {
                x[0] *= 8.0;
            }
            x
        })
        .collect()
}

fn bits(e: &Estimate) -> (u32, u64, u32, u32, u32, u32, u8) {
    (
        e.frame_index,
        e.centre_sample,
        e.azimuth_deg.to_bits(),
        e.azimuth_raw_deg.to_bits(),
        e.confidence.to_bits(),
        e.power.to_bits(),
        e.flags.0,
    )
}

fn run(
    method: Method,
    x: &[[f32; CHANNELS]],
    block: usize,
) -> Vec<(u32, u64, u32, u32, u32, u32, u8)> {
    let config = LocatorConfig {
        method,
        ..LocatorConfig::default()
    };
    let mut loc = Locator::new(config, ReferenceTable::ideal_5deg(), 48_000).unwrap();
    let mut out = Vec::new();
    if block == 0 {
        for s in x {
            if let Some(e) = loc.process_sample(*s) {
                out.push(bits(&e));
            }
        }
    } else {
        for b in x.chunks(block) {
            loc.process_block(b, |e| out.push(bits(e)));
        }
    }
    out
}

#[test]
fn estimates_do_not_depend_on_block_size() {
    let x = signal();
    // The baselines are linked only with the `thesis-options` feature.
    let methods: &[Method] = if cfg!(feature = "thesis-options") {
        &[Method::Similarity, Method::Fdiv, Method::Tdiv]
    } else {
        &[Method::Similarity]
    };
    for &method in methods {
        let reference = run(method, &x, 1);
        assert_eq!(reference.len(), (N / 4 - 512) / 256 + 1);
        assert!(
            reference.iter().any(|e| e.6 != 0),
            "some frames are flagged"
        );
        for block in [0usize, 7, 1024, 4096] {
            assert_eq!(
                run(method, &x, block),
                reference,
                "{method:?}, block {block}"
            );
        }
    }
}
