//! Criterion benchmark of the localizer's cost per analysis hop (1024 input sample frames at 48 kHz:
//! decimation, framing, four spectra, peaks, similarity curve, tracking), for the product and the
//! thesis configuration, on a synthetic talker in diffuse noise; and of the front end alone (input
//! guard, ×4 decimation and framing of the same hop).

use cma_core::decimator::Decimator;
use cma_core::front_end::FrontEnd;
use cma_core::input_guard::InputGuard;
use cma_core::{Locator, LocatorConfig, ReferenceTable};
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use host_sim::simulation::scene::{synthesize, synthetic_speech, Motion, SceneSpec};
use std::hint::black_box;

fn scene() -> Vec<[f32; 4]> {
    let spec = SceneSpec {
        source: synthetic_speech(48_000, 2.0, 3),
        rate: 48_000,
        lead_in_s: 0.1,
        motion: Motion::Steps(vec![(0.0, 40.0)]),
        snr_db: Some(5.0),
        room: None,
        peak_dbfs: -3.0,
        seed: 9,
        array: Default::default(),
        noise_sources: Vec::new(),
        source_room: host_sim::simulation::noise_source::SourceRoom::Free,
    };
    synthesize(&spec).frames
}

fn per_hop(c: &mut Criterion) {
    let frames = scene();
    let hop = 1024;
    let mut g = c.benchmark_group("locator_per_hop_48k");
    g.throughput(Throughput::Elements(hop as u64));
    for (name, cfg) in [
        ("default", LocatorConfig::default()),
        ("thesis", LocatorConfig::thesis()),
    ] {
        let mut loc =
            Locator::new(cfg, ReferenceTable::ideal_5deg(), 48_000).expect("valid config");
        // Warm up past the first frame so every measured hop emits one estimate.
        loc.process_block(&frames[..8192], |_| {});
        let mut pos = 8192;
        g.bench_function(name, |b| {
            b.iter(|| {
                if pos + hop > frames.len() {
                    pos = 8192;
                }
                let mut n = 0;
                loc.process_block(black_box(&frames[pos..pos + hop]), |e| {
                    black_box(e);
                    n += 1;
                });
                pos += hop;
                n
            })
        });
    }
    g.finish();
}

fn front_end_per_hop(c: &mut Criterion) {
    let frames = scene();
    let hop = 1024;
    let mut g = c.benchmark_group("front_end_per_hop_48k");
    g.throughput(Throughput::Elements(hop as u64));
    let guard = InputGuard::for_decimation(LocatorConfig::default().front_end.clip_level, 4);
    let mut fe = FrontEnd::new(Decimator::for_rate(48_000).expect("supported"), guard);
    let mut pos = 0;
    g.bench_function("default", |b| {
        b.iter(|| {
            if pos + hop > frames.len() {
                pos = 0;
            }
            let mut rest = black_box(&frames[pos..pos + hop]);
            let mut ready = 0;
            while !rest.is_empty() {
                let (used, r) = fe.feed(rest);
                ready += usize::from(r);
                rest = &rest[used..];
            }
            pos += hop;
            black_box(fe.frame());
            ready
        })
    });
    g.finish();
}

criterion_group!(benches, per_hop, front_end_per_hop);
criterion_main!(benches);
