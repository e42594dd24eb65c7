//! Conversion of I2S receive words to the core's sample frames.
//!
//! The STM32 SPI/I2S data register is 16 bits wide. With 24-bit data in 32-bit channel slots the DMA
//! delivers every channel sample as two halfwords: bits 23…8 of the code first, then bits 7…0 in the
//! upper byte of the second halfword (its lower byte is undefined — the reference manual: "8 LSBs
//! have no meaning and can be anything" — and ignored). One stereo sample frame is therefore four
//! halfwords: left high, left low, right high, right low.

use cma_core::CHANNELS;

/// Halfwords per stereo sample frame (two channels × two halfwords).
pub const WORDS_PER_STEREO_FRAME: usize = 4;

/// Scale from a left-aligned 32-bit code to full scale ±1 (2⁻³¹).
const SCALE: f32 = 1.0 / 2_147_483_648.0;

/// The signed code of one channel sample from its two halfwords, left-aligned in 32 bits
/// (the 24-bit code times 256).
#[inline]
#[must_use]
pub fn code_from_halfwords(high: u16, low: u16) -> i32 {
    (((high as u32) << 16) | (low as u32 & 0xFF00)) as i32
}

/// A code from [`code_from_halfwords`] as a sample of full scale ±1 (exact: 24 bits fit an `f32`).
#[inline]
#[must_use]
pub fn code_to_f32(code: i32) -> f32 {
    code as f32 * SCALE
}

/// Interleaves two stereo streams into sample frames `[a_left, a_right, b_left, b_right]`.
///
/// `a` and `b` hold [`WORDS_PER_STEREO_FRAME`] halfwords per frame; `out.len()` frames are written.
/// With the board's wiring (ADC A: omni + cardioid 0°, ADC B: cardioids 120° + 240°) this is the core's
/// channel order.
///
/// # Panics
/// When `a` or `b` is shorter than `4 · out.len()` halfwords.
pub fn interleave_stereo_pairs(a: &[u16], b: &[u16], out: &mut [[f32; CHANNELS]]) {
    let n = out.len() * WORDS_PER_STEREO_FRAME;
    assert!(
        a.len() >= n && b.len() >= n,
        "need {n} halfwords per stream"
    );
    for ((frame, wa), wb) in out
        .iter_mut()
        .zip(a.chunks_exact(WORDS_PER_STEREO_FRAME))
        .zip(b.chunks_exact(WORDS_PER_STEREO_FRAME))
    {
        *frame = [
            code_to_f32(code_from_halfwords(wa[0], wa[1])),
            code_to_f32(code_from_halfwords(wa[2], wa[3])),
            code_to_f32(code_from_halfwords(wb[0], wb[1])),
            code_to_f32(code_from_halfwords(wb[2], wb[3])),
        ];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Splits a 24-bit code into the two halfwords the I2S peripheral delivers.
    fn halves(code24: i32) -> (u16, u16) {
        let v = (code24 << 8) as u32;
        ((v >> 16) as u16, (v & 0xFFFF) as u16)
    }

    #[test]
    fn codes_round_trip_with_sign_and_full_scale() {
        for code in [0, 1, -1, 0x7F_FFFF, -0x80_0000, 0x12_3456, -0x12_3456] {
            let (h, l) = halves(code);
            assert_eq!(code_from_halfwords(h, l), code << 8);
            assert_eq!(
                code_to_f32(code_from_halfwords(h, l)),
                code as f32 / 8_388_608.0
            );
        }
        let (h, l) = halves(-0x80_0000);
        assert_eq!(code_to_f32(code_from_halfwords(h, l)), -1.0);
        // Noise in the unused low byte is ignored.
        assert_eq!(code_from_halfwords(0x0001, 0x00FF), 0x0001_0000);
    }

    #[test]
    fn interleaves_in_core_channel_order() {
        let (a0, a1, b0, b1) = (halves(100), halves(-200), halves(300), halves(-400));
        let a = [a0.0, a0.1, a1.0, a1.1, a0.0, a0.1, a1.0, a1.1];
        let b = [b0.0, b0.1, b1.0, b1.1, b0.0, b0.1, b1.0, b1.1];
        let mut out = [[0.0f32; CHANNELS]; 2];
        interleave_stereo_pairs(&a, &b, &mut out);
        let s = 8_388_608.0f32;
        assert_eq!(out[1], [100.0 / s, -200.0 / s, 300.0 / s, -400.0 / s]);
    }
}
