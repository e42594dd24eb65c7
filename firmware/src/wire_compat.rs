//! Stand-in for `cma_core::wire` (issue 2, written concurrently) with the same API, so the firmware
//! builds before that module lands. Encoder only; replace `use cma_firmware::wire_compat as wire` by
//! `use cma_core::wire` once merged and delete this file.
//!
//! Line: `$CMA,1,<seq>,<rate_hz>,<t>,<az>,<raw>,<conf>,<flags>,<ovr>,<drop>*<crc>\r\n`, azimuths in
//! tenths of a degree, confidence in ‰, flags as two hex digits, CRC-16/CCITT-FALSE of the bytes
//! between `$` and `*`. Integers only: no float formatting on the target.

use cma_core::Estimate;

/// Longest encoded line in bytes, `\r\n` included.
pub const MAX_LINE: usize = 96;

/// One frame of the stream in wire units.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame {
    /// Sequence number (wraps).
    pub seq: u32,
    /// Input sample rate, Hz.
    pub rate_hz: u32,
    /// Frame centre on the input sample clock.
    pub centre_sample: u64,
    /// Azimuth, tenths of a degree, −1799…=1800.
    pub azimuth_tenths: i16,
    /// Unfiltered azimuth, tenths of a degree.
    pub raw_tenths: i16,
    /// Confidence, ‰.
    pub confidence_permille: u16,
    /// Estimate flags.
    pub flags: u8,
    /// DMA overruns so far.
    pub overruns: u32,
    /// Frames dropped by UART backpressure so far.
    pub dropped: u32,
}

fn tenths(deg: f32) -> i16 {
    let t = libm::roundf(deg * 10.0) as i32;
    let t = if t <= -1800 { t + 3600 } else { t };
    t.clamp(-1799, 1800) as i16
}

impl Frame {
    /// The wire frame of an estimate.
    #[must_use]
    pub fn from_estimate(
        e: &Estimate,
        seq: u32,
        rate_hz: u32,
        overruns: u32,
        dropped: u32,
    ) -> Self {
        Self {
            seq,
            rate_hz,
            centre_sample: e.centre_sample,
            azimuth_tenths: tenths(e.azimuth_deg),
            raw_tenths: tenths(e.azimuth_raw_deg),
            confidence_permille: libm::roundf(e.confidence.clamp(0.0, 1.0) * 1000.0) as u16,
            flags: e.flags.0,
            overruns,
            dropped,
        }
    }
}

struct Cursor<'a> {
    buf: &'a mut [u8; MAX_LINE],
    len: usize,
}

impl Cursor<'_> {
    fn byte(&mut self, b: u8) {
        self.buf[self.len] = b;
        self.len += 1;
    }
    fn uint(&mut self, mut v: u64) {
        let mut digits = [0u8; 20];
        let mut n = 0;
        loop {
            digits[n] = b'0' + (v % 10) as u8;
            n += 1;
            v /= 10;
            if v == 0 {
                break;
            }
        }
        for d in digits[..n].iter().rev() {
            self.byte(*d);
        }
    }
    fn int(&mut self, v: i16) {
        if v < 0 {
            self.byte(b'-');
        }
        self.uint(v.unsigned_abs() as u64);
    }
    fn hex(&mut self, v: u32, digits: u32) {
        for i in (0..digits).rev() {
            self.byte(b"0123456789ABCDEF"[((v >> (4 * i)) & 0xF) as usize]);
        }
    }
}

fn crc16_ccitt_false(bytes: &[u8]) -> u16 {
    let mut crc = 0xFFFFu16;
    for b in bytes {
        crc ^= (*b as u16) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// Writes the line of `f` to `out`; returns its length.
pub fn encode(f: &Frame, out: &mut [u8; MAX_LINE]) -> usize {
    let mut c = Cursor { buf: out, len: 0 };
    c.byte(b'$');
    for b in b"CMA,1," {
        c.byte(*b);
    }
    c.uint(f.seq as u64);
    c.byte(b',');
    c.uint(f.rate_hz as u64);
    c.byte(b',');
    c.uint(f.centre_sample);
    c.byte(b',');
    c.int(f.azimuth_tenths);
    c.byte(b',');
    c.int(f.raw_tenths);
    c.byte(b',');
    c.uint(f.confidence_permille as u64);
    c.byte(b',');
    c.hex(f.flags as u32, 2);
    c.byte(b',');
    c.uint(f.overruns as u64);
    c.byte(b',');
    c.uint(f.dropped as u64);
    let crc = crc16_ccitt_false(&c.buf[1..c.len]);
    c.byte(b'*');
    c.hex(crc as u32, 4);
    c.byte(b'\r');
    c.byte(b'\n');
    c.len
}
