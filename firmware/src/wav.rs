//! The WAV header and sample decoding of the emulated board's capture (no_std, no heap).
//!
//! The emulated board reads a 4-channel WAV file through semihosting. [`parse_header`] finds its
//! format and data chunk in the first bytes of the file; [`Encoding::decode_frames`] turns raw
//! sample frames into `f32` full scale ±1 exactly as `host-sim` does (a container's integer times
//! 2^−(bits − 1), float samples unchanged), so that the firmware and `host-sim locate` see the same
//! numbers.

use cma_core::CHANNELS;

/// How the samples of a WAV file are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// 16-bit signed integers.
    Pcm16,
    /// 24-bit signed integers (3 bytes).
    Pcm24,
    /// 32-bit signed integers.
    Pcm32,
    /// 32-bit IEEE floats.
    Float32,
}

impl Encoding {
    /// Bytes per sample.
    #[must_use]
    pub const fn bytes(self) -> usize {
        match self {
            Self::Pcm16 => 2,
            Self::Pcm24 => 3,
            Self::Pcm32 | Self::Float32 => 4,
        }
    }

    /// One sample from its little-endian bytes (`raw.len() == self.bytes()`), full scale ±1.
    ///
    /// Integers are scaled by a power of two after the conversion to `f32`, which rounds once: the
    /// same value as `host-sim`'s decoding (for 32-bit integers it rounds an `f64` product, also once).
    #[must_use]
    pub fn decode(self, raw: &[u8]) -> f32 {
        match self {
            Self::Pcm16 => f32::from(i16::from_le_bytes([raw[0], raw[1]])) * (1.0 / 32_768.0),
            Self::Pcm24 => {
                (i32::from_le_bytes([0, raw[0], raw[1], raw[2]]) >> 8) as f32 * (1.0 / 8_388_608.0)
            }
            Self::Pcm32 => {
                i32::from_le_bytes([raw[0], raw[1], raw[2], raw[3]]) as f32
                    * (1.0 / 2_147_483_648.0)
            }
            Self::Float32 => f32::from_le_bytes([raw[0], raw[1], raw[2], raw[3]]),
        }
    }

    /// Decodes whole 4-channel sample frames from `raw` into `out`; returns how many were written
    /// (the smaller of `out.len()` and the complete frames in `raw`).
    pub fn decode_frames(self, raw: &[u8], out: &mut [[f32; CHANNELS]]) -> usize {
        let b = self.bytes();
        let mut n = 0;
        for (frame, bytes) in out.iter_mut().zip(raw.chunks_exact(b * CHANNELS)) {
            for (x, s) in frame.iter_mut().zip(bytes.chunks_exact(b)) {
                *x = self.decode(s);
            }
            n += 1;
        }
        n
    }
}

/// What [`parse_header`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WavFormat {
    /// Channels per sample frame.
    pub channels: u16,
    /// Sample rate, Hz.
    pub rate_hz: u32,
    /// Sample encoding.
    pub encoding: Encoding,
    /// Offset of the first sample byte in the file.
    pub data_offset: u32,
    /// Length of the data chunk as declared, bytes.
    pub data_len: u32,
}

impl WavFormat {
    /// Bytes per sample frame.
    #[must_use]
    pub const fn frame_bytes(&self) -> usize {
        self.encoding.bytes() * self.channels as usize
    }
}

/// Why a file is not a WAV the emulated board can read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(target_os = "none", derive(defmt::Format))]
pub enum WavError {
    /// No `RIFF`…`WAVE` signature.
    NotWav,
    /// The header ends (or the data chunk starts) beyond the bytes given.
    HeaderTooLong {
        /// Bytes given to [`parse_header`].
        given: usize,
    },
    /// No `fmt ` chunk before the data chunk.
    NoFormat,
    /// An encoding other than 16/24/32-bit integer or 32-bit float.
    Unsupported {
        /// The format tag (1 integer, 3 float; 0xFFFE's sub-format is resolved).
        tag: u16,
        /// Bits per sample.
        bits: u16,
    },
}

fn u16_at(b: &[u8], i: usize) -> Option<u16> {
    Some(u16::from_le_bytes([*b.get(i)?, *b.get(i + 1)?]))
}

fn u32_at(b: &[u8], i: usize) -> Option<u32> {
    Some(u32::from_le_bytes([
        *b.get(i)?,
        *b.get(i + 1)?,
        *b.get(i + 2)?,
        *b.get(i + 3)?,
    ]))
}

/// Parses the header of a WAV file from its first bytes (`head`): the `fmt ` chunk (plain or
/// `WAVE_FORMAT_EXTENSIBLE`, as hound writes for more than two channels) and the position of the
/// `data` chunk, which must start within `head`. Other chunks are skipped.
pub fn parse_header(head: &[u8]) -> Result<WavFormat, WavError> {
    let too_long = WavError::HeaderTooLong { given: head.len() };
    if head.get(0..4) != Some(b"RIFF") || head.get(8..12) != Some(b"WAVE") {
        return Err(WavError::NotWav);
    }
    let mut at = 12usize;
    let mut format: Option<(u16, u32, Encoding)> = None;
    loop {
        let id = head.get(at..at + 4).ok_or(too_long)?;
        let len = u32_at(head, at + 4).ok_or(too_long)?;
        let body = at + 8;
        if id == b"fmt " {
            let tag = u16_at(head, body).ok_or(too_long)?;
            let channels = u16_at(head, body + 2).ok_or(too_long)?;
            let rate = u32_at(head, body + 4).ok_or(too_long)?;
            let bits = u16_at(head, body + 14).ok_or(too_long)?;
            let tag = if tag == 0xFFFE {
                // WAVE_FORMAT_EXTENSIBLE: the sub-format GUID starts with the plain tag.
                u16_at(head, body + 24).ok_or(too_long)?
            } else {
                tag
            };
            let encoding = match (tag, bits) {
                (1, 16) => Encoding::Pcm16,
                (1, 24) => Encoding::Pcm24,
                (1, 32) => Encoding::Pcm32,
                (3, 32) => Encoding::Float32,
                _ => return Err(WavError::Unsupported { tag, bits }),
            };
            format = Some((channels, rate, encoding));
        } else if id == b"data" {
            let (channels, rate_hz, encoding) = format.ok_or(WavError::NoFormat)?;
            if body > head.len() {
                return Err(too_long);
            }
            return Ok(WavFormat {
                channels,
                rate_hz,
                encoding,
                data_offset: body as u32,
                data_len: len,
            });
        }
        // Chunks are padded to an even length.
        at = body
            .checked_add(len as usize + (len as usize & 1))
            .ok_or(too_long)?;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A header as hound writes it for 4 channels (WAVE_FORMAT_EXTENSIBLE), with an extra chunk.
    fn header(tag: u16, bits: u16, extensible: bool) -> ([u8; 128], usize) {
        let mut h = [0u8; 128];
        let mut n = 0;
        let mut put = |bytes: &[u8]| {
            h[n..n + bytes.len()].copy_from_slice(bytes);
            n += bytes.len();
        };
        put(b"RIFF");
        put(&1000u32.to_le_bytes());
        put(b"WAVE");
        put(b"LIST");
        put(&3u32.to_le_bytes());
        put(b"abc\0"); // 3 bytes + pad
        put(b"fmt ");
        put(&(if extensible { 40u32 } else { 16 }).to_le_bytes());
        put(&(if extensible { 0xFFFEu16 } else { tag }).to_le_bytes());
        put(&4u16.to_le_bytes());
        put(&48_000u32.to_le_bytes());
        put(&(48_000u32 * 4 * u32::from(bits / 8)).to_le_bytes());
        put(&(4 * bits / 8).to_le_bytes());
        put(&bits.to_le_bytes());
        if extensible {
            put(&22u16.to_le_bytes());
            put(&bits.to_le_bytes());
            put(&0x33u32.to_le_bytes());
            put(&tag.to_le_bytes());
            put(&[0u8; 14]);
        }
        put(b"data");
        put(&800u32.to_le_bytes());
        (h, n)
    }

    #[test]
    fn finds_format_and_data_in_plain_and_extensible_headers() {
        for (tag, bits, enc) in [
            (1, 16, Encoding::Pcm16),
            (1, 24, Encoding::Pcm24),
            (1, 32, Encoding::Pcm32),
            (3, 32, Encoding::Float32),
        ] {
            for ext in [false, true] {
                let (h, n) = header(tag, bits, ext);
                let f = parse_header(&h).unwrap();
                assert_eq!(
                    f,
                    WavFormat {
                        channels: 4,
                        rate_hz: 48_000,
                        encoding: enc,
                        data_offset: n as u32,
                        data_len: 800
                    }
                );
                assert_eq!(f.frame_bytes(), 4 * usize::from(bits / 8));
            }
        }
    }

    #[test]
    fn rejects_what_it_cannot_read() {
        let (h, n) = header(1, 8, false);
        assert_eq!(
            parse_header(&h),
            Err(WavError::Unsupported { tag: 1, bits: 8 })
        );
        let (h, _) = header(1, 16, true);
        assert_eq!(
            parse_header(&h[..40]),
            Err(WavError::HeaderTooLong { given: 40 })
        );
        assert_eq!(
            parse_header(&h[..n - 8]),
            Err(WavError::HeaderTooLong { given: n - 8 })
        );
        assert_eq!(parse_header(b"RIFX0000WAVE"), Err(WavError::NotWav));
        let mut no_fmt = h;
        no_fmt[24..28].copy_from_slice(b"junk");
        assert_eq!(parse_header(&no_fmt), Err(WavError::NoFormat));
    }

    #[test]
    fn decodes_like_the_host_tools() {
        // host-sim: integer as f32 times 2^-(bits-1); 24-bit sign-extended from 3 bytes.
        assert_eq!(Encoding::Pcm16.decode(&(-32768i16).to_le_bytes()), -1.0);
        assert_eq!(
            Encoding::Pcm16.decode(&12345i16.to_le_bytes()),
            12345.0 / 32768.0
        );
        assert_eq!(
            Encoding::Pcm24.decode(&[0xFF, 0xFF, 0xFF]),
            -1.0 / 8_388_608.0
        );
        assert_eq!(Encoding::Pcm24.decode(&[0x00, 0x00, 0x80]), -1.0);
        let v = 0x7FFF_FFC1i32;
        assert_eq!(
            Encoding::Pcm32.decode(&v.to_le_bytes()),
            (f64::from(v) / 2_147_483_648.0) as f32
        );
        assert_eq!(Encoding::Float32.decode(&0.25f32.to_le_bytes()), 0.25);
        let raw: [u8; 20] = core::array::from_fn(|i| i as u8);
        let mut out = [[0.0f32; CHANNELS]; 4];
        assert_eq!(Encoding::Pcm16.decode_frames(&raw, &mut out), 2);
        assert_eq!(out[1][0], Encoding::Pcm16.decode(&[8, 9]));
    }
}
