//! Constant tables generated at build time (`build.rs`): the analysis window, the twiddles of the
//! direct DFT and of the x86_64 FFT, and the half-band decimator's coefficients. They are `static`,
//! so they live once in flash.

include!(concat!(env!("OUT_DIR"), "/tables.rs"));

/// Sample `n` (< 512) of the analysis frame's symmetric Hamming window, from its half table.
#[inline(always)]
#[must_use]
pub fn hamming(n: usize) -> f32 {
    HAMMING_HALF_512[if n < 256 { n } else { 511 - n }]
}

/// The whole window (x86_64's SSE2 transform loads it four samples at a time), mirrored from the
/// half table at compile time: the same values.
#[cfg(any(target_arch = "x86_64", test))]
pub static HAMMING_512: [f32; 512] = {
    let mut w = [0.0f32; 512];
    let mut n = 0;
    while n < 256 {
        w[n] = HAMMING_HALF_512[n];
        w[511 - n] = HAMMING_HALF_512[n];
        n += 1;
    }
    w
};
