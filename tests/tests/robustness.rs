//! Property tests: no input can make the core panic; bad samples give flagged, low-confidence
//! estimates; every estimate is finite and in range. And the CLI's file handling: conforming WAV
//! layouts, pipes, symbolic links, device nodes, lying headers, endless inputs.

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
        .all(|e| e.confidence <= LocatorConfig::default().front_end.clipped_confidence));
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

/// File handling of the CLI: every way a file can come in or go out that a Unix tool is expected to
/// handle.
mod files {
    use cma_tests::{host_sim, make_scene, path_in};
    use std::path::{Path, PathBuf};

    /// A 1 s scene and locate's CSV of it, as the reference.
    fn scene_and_csv(dir: &Path) -> (PathBuf, String) {
        let wav = make_scene(dir, "s.wav", &["--synth", "1", "--azimuth", "40"]);
        let csv = path_in(dir, "ref.csv");
        host_sim(&["locate", wav.to_str().unwrap(), "--csv", &csv, "--quiet"]).unwrap();
        (wav, std::fs::read_to_string(&csv).unwrap())
    }

    /// The RIFF chunks of a WAV (id, body), the `RIFF`/`WAVE` header dropped.
    fn chunks(bytes: &[u8]) -> Vec<([u8; 4], Vec<u8>)> {
        let mut out = Vec::new();
        let mut pos = 12;
        while pos + 8 <= bytes.len() {
            let id: [u8; 4] = bytes[pos..pos + 4].try_into().unwrap();
            let len = u32::from_le_bytes(bytes[pos + 4..pos + 8].try_into().unwrap()) as usize;
            out.push((id, bytes[pos + 8..pos + 8 + len].to_vec()));
            pos += 8 + len + (len & 1);
        }
        out
    }

    /// A WAV from chunks, each odd-length body followed by its pad byte; `data_len` overrides the
    /// `data` chunk's declared length.
    fn riff(chunks: &[([u8; 4], Vec<u8>)], data_len: Option<u32>) -> Vec<u8> {
        let mut body = b"WAVE".to_vec();
        for (id, c) in chunks {
            body.extend_from_slice(id);
            let len = match (id, data_len) {
                (b"data", Some(l)) => l,
                _ => c.len() as u32,
            };
            body.extend_from_slice(&len.to_le_bytes());
            body.extend_from_slice(c);
            if c.len() % 2 == 1 {
                body.push(0);
            }
        }
        let mut out = b"RIFF".to_vec();
        out.extend_from_slice(&(body.len() as u32).to_le_bytes());
        out.extend(body);
        out
    }

    fn locate_csv(dir: &Path, wav: &Path) -> String {
        let csv = path_in(dir, "out.csv");
        host_sim(&["locate", wav.to_str().unwrap(), "--csv", &csv, "--quiet"]).unwrap();
        std::fs::read_to_string(&csv).unwrap()
    }

    #[test]
    fn padded_odd_chunks_and_other_conforming_layouts_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let (wav, reference) = scene_and_csv(dir.path());
        let parts = chunks(&std::fs::read(&wav).unwrap());
        let fmt = parts.iter().find(|(id, _)| id == b"fmt ").unwrap().clone();
        let data = parts.iter().find(|(id, _)| id == b"data").unwrap().clone();
        let odd = (*b"LIST", b"INFOISFT\x03\0\0\0ab\0".to_vec());
        assert_eq!(odd.1.len() % 2, 1);
        let layouts = [
            // An odd-length chunk (with its pad byte) before and after fmt, a fact chunk of 8 bytes.
            vec![
                odd.clone(),
                fmt.clone(),
                (*b"fact", vec![1, 0, 0, 0, 2, 0, 0, 0]),
                (*b"junk", vec![7]),
                data.clone(),
            ],
            // A fmt chunk with trailing bytes beyond its known layout (odd length).
            vec![
                (*b"fmt ", [fmt.1.clone(), vec![0, 0, 0]].concat()),
                data.clone(),
                odd.clone(),
            ],
        ];
        for (i, layout) in layouts.iter().enumerate() {
            let p = dir.path().join(format!("layout{i}.wav"));
            std::fs::write(&p, riff(layout, None)).unwrap();
            assert_eq!(locate_csv(dir.path(), &p), reference, "layout {i}");
        }
        // A data chunk of unknown length (a WAV written to a pipe): read to the end of the file.
        let p = dir.path().join("streamed.wav");
        std::fs::write(&p, riff(&[fmt, data], Some(u32::MAX))).unwrap();
        assert_eq!(locate_csv(dir.path(), &p), reference);
    }

    #[test]
    fn a_header_claiming_4_gb_allocates_only_what_is_there() {
        let dir = tempfile::tempdir().unwrap();
        let (wav, _) = scene_and_csv(dir.path());
        let parts = chunks(&std::fs::read(&wav).unwrap());
        let huge = path_in(dir.path(), "huge.wav");
        // 0xFFFFFFF0: a multiple of the 8-byte sample frame, ~4 GB declared, 32 kB present.
        std::fs::write(&huge, riff(&parts, Some(0xFFFF_FFF0))).unwrap();
        let out = path_in(dir.path(), "o.wav");
        for args in [
            vec!["locate", huge.as_str(), "--quiet"],
            vec!["beam", huge.as_str(), "--out", out.as_str()],
            vec!["emit", huge.as_str(), "--port", "/nonexistent-port"],
        ] {
            let e = host_sim(&args).unwrap_err().to_string();
            assert!(
                e.contains("truncated") && e.contains("4294967280 bytes"),
                "{args:?}: {e}"
            );
        }
        std::fs::write(
            dir.path().join("manifest.csv"),
            "file,set,score_from_s,score_to_s,note\nhuge.wav,x,0,1,\n",
        )
        .unwrap();
        std::fs::copy(
            wav.with_extension("pos.csv"),
            dir.path().join("huge.pos.csv"),
        )
        .unwrap();
        let e = host_sim(&["eval", dir.path().to_str().unwrap()])
            .unwrap_err()
            .to_string();
        assert!(e.contains("truncated"), "{e}");
        let e = host_sim_read_four(&huge);
        assert!(e.contains("truncated"), "{e}");
    }

    /// `calibrate` reads its recordings with `read_four_channels`.
    fn host_sim_read_four(p: &str) -> String {
        host_sim::io::wav_io::read_four_channels(Path::new(p), "four")
            .unwrap_err()
            .to_string()
    }

    #[cfg(unix)]
    #[test]
    fn a_wav_from_a_fifo_is_read_once_and_whole() {
        let dir = tempfile::tempdir().unwrap();
        let (wav, reference) = scene_and_csv(dir.path());
        let fifo = dir.path().join("in.fifo");
        assert!(std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success());
        let bytes = std::fs::read(&wav).unwrap();
        let writer = {
            let fifo = fifo.clone();
            // A second open of the FIFO by the reader would block or see nothing: one writer, once.
            std::thread::spawn(move || std::fs::write(fifo, bytes))
        };
        assert_eq!(locate_csv(dir.path(), &fifo), reference);
        writer.join().unwrap().unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn outputs_go_through_symlinks_and_into_device_nodes() {
        use std::os::unix::fs::symlink;
        let dir = tempfile::tempdir().unwrap();
        let (wav, reference) = scene_and_csv(dir.path());
        let w = wav.to_str().unwrap();
        let real = dir.path().join("real.csv");
        std::fs::write(&real, "old").unwrap();
        let link = dir.path().join("link.csv");
        symlink(&real, &link).unwrap();
        host_sim(&["locate", w, "--csv", link.to_str().unwrap(), "--quiet"]).unwrap();
        assert!(std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink());
        assert_eq!(std::fs::read_to_string(&real).unwrap(), reference);
        // A scene's WAV through a link too.
        let wav_link = dir.path().join("scene-link.wav");
        let wav_real = dir.path().join("scene-real.wav");
        symlink(&wav_real, &wav_link).unwrap();
        host_sim(&[
            "scene",
            "--out",
            wav_link.to_str().unwrap(),
            "--synth",
            "0.5",
        ])
        .unwrap();
        assert!(wav_real.is_file());
        assert!(std::fs::symlink_metadata(&wav_link)
            .unwrap()
            .file_type()
            .is_symlink());
        // A device node is written into, never replaced.
        host_sim(&["locate", w, "--csv", "/dev/null", "--quiet"]).unwrap();
        use std::os::unix::fs::FileTypeExt;
        assert!(std::fs::metadata("/dev/null")
            .unwrap()
            .file_type()
            .is_char_device());
        // No temporary file left anywhere in the folder.
        let partial = std::fs::read_dir(dir.path())
            .unwrap()
            .filter(|e| {
                e.as_ref()
                    .unwrap()
                    .file_name()
                    .to_string_lossy()
                    .ends_with(".partial")
            })
            .count();
        assert_eq!(partial, 0);
    }

    #[test]
    fn byte_order_marks_are_accepted_in_csv_files() {
        let dir = tempfile::tempdir().unwrap();
        let (wav, reference) = scene_and_csv(dir.path());
        let est = dir.path().join("bom.csv");
        std::fs::write(&est, format!("\u{feff}{reference}")).unwrap();
        let truth = wav.with_extension("pos.csv");
        let truth_text = std::fs::read_to_string(&truth).unwrap();
        std::fs::write(&truth, format!("\u{feff}{truth_text}")).unwrap();
        std::fs::write(
            dir.path().join("manifest.csv"),
            "\u{feff}file,set,score_from_s,score_to_s,note\ns.wav,x,0.3,1,\n",
        )
        .unwrap();
        let rows = host_sim::localization::frame_estimates::read_csv(&est).unwrap();
        assert_eq!(rows.len(), reference.lines().count() - 1);
        host_sim(&[
            "score",
            est.to_str().unwrap(),
            truth.to_str().unwrap(),
            "--json",
        ])
        .unwrap();
        host_sim(&["eval", dir.path().to_str().unwrap(), "--json"]).unwrap();
    }

    #[test]
    fn values_outside_f32_are_errors_with_their_line() {
        let dir = tempfile::tempdir().unwrap();
        let (wav, _) = scene_and_csv(dir.path());
        let est = dir.path().join("big.csv");
        std::fs::write(
            &est,
            "t_s,azimuth_deg,azimuth_raw_deg,confidence\n0.1,3,3,1\n0.2,1e39,3,1\n",
        )
        .unwrap();
        let e = host_sim(&[
            "score",
            est.to_str().unwrap(),
            wav.with_extension("pos.csv").to_str().unwrap(),
        ])
        .unwrap_err()
        .to_string();
        assert!(e.contains("big.csv:3") && e.contains("f32 range"), "{e}");
    }

    #[cfg(unix)]
    #[test]
    fn endless_inputs_are_bounded() {
        let dir = tempfile::tempdir().unwrap();
        let (wav, _) = scene_and_csv(dir.path());
        let e = host_sim(&[
            "locate",
            wav.to_str().unwrap(),
            "--table",
            "/dev/zero",
            "--quiet",
        ])
        .unwrap_err()
        .to_string();
        assert!(e.contains("/dev/zero") && e.contains("MiB"), "{e}");
        let e = host_sim(&[
            "score",
            "/dev/zero",
            wav.with_extension("pos.csv").to_str().unwrap(),
        ])
        .unwrap_err()
        .to_string();
        assert!(e.contains("/dev/zero") && e.contains("MiB"), "{e}");
    }

    #[test]
    fn a_file_shorter_than_one_analysis_frame_says_so() {
        let dir = tempfile::tempdir().unwrap();
        let p = path_in(dir.path(), "short.wav");
        let spec = hound::WavSpec {
            channels: 4,
            sample_rate: 48000,
            bits_per_sample: 16,
            sample_format: hound::SampleFormat::Int,
        };
        let mut w = hound::WavWriter::create(&p, spec).unwrap();
        for i in 0..400 * 4 {
            w.write_sample((i % 100) as i16).unwrap();
        }
        w.finalize().unwrap();
        let e = host_sim(&["locate", &p, "--quiet"])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("short.wav") && e.contains("shorter than one analysis frame"),
            "{e}"
        );
    }
}
