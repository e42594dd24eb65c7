//! The cost check and the bit-for-bit check feed the localizer in blocks of
//! `qemu_check::FIRMWARE_BLOCK` sample frames because that is what the firmware passes it: this test
//! reads the firmware's `BLOCK_FRAMES` from its source (the firmware builds only for the target; each
//! board declares its own) and compares every declaration.

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
    // One declaration per board (board.rs, board_f446.rs, board_mps2.rs); every one must agree.
    assert!(!values.is_empty(), "no `{prefix}N;` in firmware/src");
    for (file, n) in &values {
        assert_eq!(
            *n,
            qemu_check::FIRMWARE_BLOCK,
            "firmware BLOCK_FRAMES ({file}) and qemu_check::FIRMWARE_BLOCK differ"
        );
    }
}
