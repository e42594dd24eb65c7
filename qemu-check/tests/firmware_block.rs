//! The cost check and the bit-for-bit check feed the localizer in blocks of
//! `qemu_check::FIRMWARE_BLOCK` sample frames because that is what the firmware passes it: this test
//! reads every board's `BLOCK_FRAMES` from the firmware's source (the firmware builds only for the
//! target) and compares each; likewise the cost runs use the firmware's sample rate.

use std::path::Path;

/// Every `.rs` file under `dir`.
fn sources(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for entry in std::fs::read_dir(dir).expect("read the firmware's source folder") {
        let path = entry.expect("a folder entry").path();
        if path.is_dir() {
            sources(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

#[test]
fn firmware_block_is_the_firmwares_block_frames() {
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    let prefix = "pub const BLOCK_FRAMES: usize = ";
    let values: Vec<(String, usize)> = files
        .iter()
        .flat_map(|f| {
            let text = std::fs::read_to_string(f).expect("read a firmware source file");
            text.lines()
                .filter_map(|l| l.trim().strip_prefix(prefix))
                .map(|v| {
                    let v = v.trim_end_matches(';').trim();
                    let n = v.parse().unwrap_or_else(|_| {
                        panic!("{}: BLOCK_FRAMES = {v} is not a number", f.display())
                    });
                    (f.display().to_string(), n)
                })
                .collect::<Vec<_>>()
        })
        .collect();
    assert!(
        !values.is_empty(),
        "no `{prefix}N;` in firmware/src (a board's block size)"
    );
    for (file, n) in &values {
        assert_eq!(
            *n,
            qemu_check::FIRMWARE_BLOCK,
            "BLOCK_FRAMES of {file} and qemu_check::FIRMWARE_BLOCK differ"
        );
    }
}

#[test]
fn firmware_rate_is_the_firmwares_sample_rate() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/src/board_api.rs");
    let text = std::fs::read_to_string(&path).expect("read the firmware's board interface");
    let prefix = "pub const SAMPLE_RATE_HZ: u32 = ";
    let rates: Vec<u32> = text
        .lines()
        .filter_map(|l| l.trim().strip_prefix(prefix))
        .map(|v| {
            let v = v.trim_end_matches(';').trim().replace('_', "");
            v.parse()
                .unwrap_or_else(|_| panic!("board_api.rs: SAMPLE_RATE_HZ = {v} is not a number"))
        })
        .collect();
    assert_eq!(
        rates,
        [qemu_check::FIRMWARE_RATE_HZ],
        "board_api.rs's SAMPLE_RATE_HZ and qemu_check::FIRMWARE_RATE_HZ differ"
    );
    // Every board takes the shared rate, none sets its own.
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware/src");
    let mut files = Vec::new();
    sources(&src, &mut files);
    for f in files.iter().filter(|f| !f.ends_with("board_api.rs")) {
        let text = std::fs::read_to_string(f).expect("read a firmware source file");
        assert!(
            !text.lines().any(|l| l.trim().starts_with(prefix)),
            "{} sets its own SAMPLE_RATE_HZ",
            f.display()
        );
    }
}
