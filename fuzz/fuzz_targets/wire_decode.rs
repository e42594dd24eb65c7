//! cargo-fuzz target: arbitrary bytes through the line assembler and the decoder must never panic,
//! and every accepted line must re-encode to exactly the bytes received (canonical format).
#![no_main]

use cma_core::wire::{decode, encode, LineAssembler, MAX_LINE};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let _ = decode(data);
    let mut asm = LineAssembler::<MAX_LINE>::new();
    asm.push_chunk(data, |line| {
        if let Ok(frame) = decode(line) {
            let mut buf = [0u8; MAX_LINE];
            let n = encode(&frame, &mut buf);
            // The assembler strips "\r\n"; an accepted line without "\r" is also canonical.
            let body = line.strip_suffix(b"\r").unwrap_or(line);
            assert_eq!(&buf[..n - 2], body);
        }
    });
});
