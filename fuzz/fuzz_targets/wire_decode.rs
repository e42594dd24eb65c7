//! cargo-fuzz target: arbitrary bytes through the line assembler and the decoders (frame line,
//! calibration line, track line, background line, any kind) must never panic, and every accepted line must re-encode to
//! exactly the bytes received (canonical format).
#![no_main]

use cma_core::wire::{
    decode, decode_background, decode_calibration, decode_line, decode_tracks, encode,
    encode_background, encode_calibration, encode_tracks, Line, LineAssembler, MAX_ANY_LINE,
    MAX_BGF_LINE, MAX_CAL_LINE, MAX_LINE, MAX_TRK_LINE,
};
use libfuzzer_sys::fuzz_target;

/// The encoder's bytes for a decoded line, without `\r\n`.
fn reencoded(line: &Line) -> Vec<u8> {
    match line {
        Line::Frame(f) => {
            let mut buf = heapless::Vec::<u8, MAX_LINE>::new();
            encode(f, &mut buf);
            buf[..buf.len() - 2].to_vec()
        }
        Line::Calibration(c) => {
            let mut buf = heapless::Vec::<u8, MAX_CAL_LINE>::new();
            encode_calibration(c, &mut buf);
            buf[..buf.len() - 2].to_vec()
        }
        Line::Tracks(t) => {
            let mut buf = heapless::Vec::<u8, MAX_TRK_LINE>::new();
            encode_tracks(t, &mut buf);
            buf[..buf.len() - 2].to_vec()
        }
        Line::Background(b) => {
            let mut buf = heapless::Vec::<u8, MAX_BGF_LINE>::new();
            encode_background(b, &mut buf);
            buf[..buf.len() - 2].to_vec()
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let _ = decode(data);
    let _ = decode_calibration(data);
    let _ = decode_tracks(data);
    let _ = decode_background(data);
    let _ = decode_line(data);
    let mut asm = LineAssembler::<MAX_ANY_LINE>::new();
    asm.push_chunk(data, |line| {
        // The assembler strips "\r\n"; an accepted line without "\r" is also canonical.
        let body = line.strip_suffix(b"\r").unwrap_or(line);
        let any = decode_line(line);
        if let Ok(l) = &any {
            assert_eq!(reencoded(l), body);
        }
        // The single-kind decoders agree with the dispatching one.
        match decode(line) {
            Ok(f) => assert_eq!(any, Ok(Line::Frame(f))),
            Err(_) => assert!(!matches!(any, Ok(Line::Frame(_)))),
        }
        match decode_calibration(line) {
            Ok(c) => assert_eq!(any, Ok(Line::Calibration(c))),
            Err(_) => assert!(!matches!(any, Ok(Line::Calibration(_)))),
        }
        match decode_tracks(line) {
            Ok(t) => assert_eq!(any, Ok(Line::Tracks(t))),
            Err(_) => assert!(!matches!(any, Ok(Line::Tracks(_)))),
        }
        match decode_background(line) {
            Ok(b) => assert_eq!(any, Ok(Line::Background(b))),
            Err(_) => assert!(!matches!(any, Ok(Line::Background(_)))),
        }
    });
});
