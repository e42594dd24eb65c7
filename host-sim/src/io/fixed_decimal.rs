//! Fixed-point decimal text of a float (`{:.N}` of `format!`), the same characters, written without
//! the general formatter: the CSV of `locate` formats five numbers per analysis frame, and the
//! exact-digit machinery of `format!` cost about as much as the rest of the row.
//!
//! A value x with |x| < 2³¹ / 10^N is scaled by 10^N in f64 and rounded to the nearest integer. That
//! is the decimal `format!` prints whenever the scaled value lies clearly between two half-integers:
//! f32 values are scaled exactly (24 + 14 significant bits fit in 53), and an f64 product is within
//! one rounding (≤ 2⁻⁵² relative) of x·10^N. Values near a tie (x·10^N within 10⁻⁶ of n + ½, where
//! the rounding of the product or the tie rule could decide), non-finite values and large ones are
//! handed to `format!` itself.

use std::io::{self, Write};

/// Most decimals [`write_fixed`] takes without handing over to `format!`.
const MAX_DECIMALS: usize = 6;

/// Powers of ten up to 10^[`MAX_DECIMALS`].
const POW10: [f64; MAX_DECIMALS + 1] = [1.0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6];

/// Writes `x` with `decimals` digits after the point, exactly as `write!(out, "{:.decimals$}", x)`.
pub fn write_fixed(out: &mut impl Write, x: f64, decimals: usize) -> io::Result<()> {
    match fixed_digits(x, decimals) {
        Some((buf, len)) => out.write_all(&buf[..len]),
        None => write!(out, "{x:.decimals$}"),
    }
}

/// The text of `x` to `decimals` places in a buffer (and its length), or `None` where `format!` must
/// decide (see the module documentation).
fn fixed_digits(x: f64, decimals: usize) -> Option<([u8; 32], usize)> {
    let scale = *POW10.get(decimals)?;
    let scaled = x.abs() * scale;
    if !(scaled < 2_147_483_648.0) {
        return None;
    }
    let n = scaled.round();
    if ((scaled - n).abs() - 0.5).abs() < 1e-6 {
        return None;
    }
    // In range and finite: n < 2³¹ is an exact integer.
    let mut n = n as u64;
    let mut digits = [0u8; 32];
    let mut len = 0;
    // Least significant digit first, at least one digit before the point.
    while len < decimals + 1 || n > 0 {
        if len == decimals && decimals > 0 {
            digits[len] = b'.';
            len += 1;
        }
        digits[len] = b'0' + (n % 10) as u8;
        n /= 10;
        len += 1;
    }
    // `format!` keeps the sign of negative values (and of −0) that round to zero.
    if x.is_sign_negative() {
        digits[len] = b'-';
        len += 1;
    }
    digits[..len].reverse();
    Some((digits, len))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(x: f64, d: usize) -> String {
        let mut v = Vec::new();
        write_fixed(&mut v, x, d).unwrap();
        String::from_utf8(v).unwrap()
    }

    #[test]
    fn equals_format_on_edges() {
        let cases = [
            0.0,
            -0.0,
            0.004,
            -0.004,
            0.005,
            0.015,
            0.125,
            -0.125,
            0.5,
            1.5,
            2.5,
            -2.5,
            9.995,
            99.995,
            179.999,
            -180.0,
            180.0,
            1e-30,
            -1e-30,
            123456.789,
            2147.4836,
            1e300,
            -1e300,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MIN_POSITIVE,
        ];
        for x in cases {
            for d in 0..=8 {
                assert_eq!(text(x, d), format!("{x:.d$}"), "{x} to {d} places");
            }
        }
    }

    #[test]
    fn equals_format_on_random_values() {
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        let mut fast = 0;
        for i in 0..400_000 {
            let r = next();
            let x = match i % 4 {
                // f32 values as the estimates have them, azimuths and confidences.
                0 => f64::from((r >> 40) as f32 / (1u64 << 24) as f32 * 360.0 - 180.0),
                1 => f64::from(f32::from_bits((r >> 32) as u32)),
                // Decibels and times as f64.
                2 => (r >> 11) as f64 / (1u64 << 53) as f64 * 400.0 - 300.0,
                _ => (r % 100_000_000) as f64 * 256.0 / 12_000.0 + 0.021_25,
            };
            for d in [1, 2, 4, 6] {
                assert_eq!(text(x, d), format!("{x:.d$}"), "{x:e} to {d} places");
                fast += usize::from(fixed_digits(x, d).is_some());
            }
        }
        // The fast path is the common one (else this module would be pointless).
        assert!(fast > 1_000_000, "fast path taken {fast} times");
    }
}
