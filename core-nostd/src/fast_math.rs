//! Square root that is fast on the Cortex-M4F and bit-identical everywhere.
//!
//! IEEE 754 requires `sqrt` to be correctly rounded, and both implementations used here are:
//! on `arm` with the hard-float ABI (an FPU is present: Cortex-M4F/M7) it is the `VSQRT.F32`
//! instruction (14 cycles), elsewhere `libm::sqrtf` (which is correctly rounded in software, and
//! uses the hardware instruction on x86/aarch64). So the host and the target agree to the last bit;
//! the QEMU check (`qemu-check`) tests that on the whole pipeline.

/// Correctly rounded square root of `x` (NaN for negative `x`, like `libm::sqrtf`).
#[inline(always)]
#[must_use]
pub fn sqrtf(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        vsqrt(x)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

/// √max(x, 0): 0 for negative `x` (and −0); the clamp is one integer operation on the bits (the
/// value is moved to a core register for [`sqrtf`]'s `asm!` on the M4F anyway), where a float compare
/// would cost a compare, a flag transfer and a conditional move. Bit-identical to
/// `sqrtf(if x > 0.0 { x } else { 0.0 })` for every `x` except a positive NaN (NaN instead of 0).
#[inline(always)]
#[must_use]
pub fn sqrt_nonneg(x: f32) -> f32 {
    let b = x.to_bits();
    // Sign bit set: the arithmetic shift gives all ones, so the mask clears every bit (→ +0).
    let b = b & !(((b as i32) >> 31) as u32);
    sqrtf(f32::from_bits(b))
}

/// `VSQRT.F32` on the FPU.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
#[allow(unsafe_code)]
fn vsqrt(x: f32) -> f32 {
    let y: u32;
    // Note(unsafe): register-only FPU code: no memory, no stack. Stable Rust does not let `asm!` name FPU
    // registers (the `vfp2` feature is unstable), so the operands travel in core registers and the
    // instruction borrows `s0`, which the block saves in `{t}` and restores, leaving every register but
    // the outputs as it found them. The hard-float ABI (`eabihf`) guarantees the FPU is present and
    // enabled (cortex-m-rt enables it before `main`). VSQRT.F32 is IEEE correctly rounded
    // (round-to-nearest, the reset mode), like `libm::sqrtf`.
    unsafe {
        core::arch::asm!(
            "vmov {t}, s0",
            "vmov s0, {x}",
            "vsqrt.f32 s0, s0",
            "vmov {y}, s0",
            "vmov s0, {t}",
            x = in(reg) x.to_bits(),
            y = lateout(reg) y,
            t = out(reg) _,
            options(pure, nomem, nostack, preserves_flags)
        );
    }
    f32::from_bits(y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_libm_bit_for_bit() {
        let mut seed = 7u32;
        for _ in 0..10_000 {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let x = f32::from_bits(seed >> 1); // non-negative, all exponents
            assert_eq!(sqrtf(x).to_bits(), libm::sqrtf(x).to_bits(), "{x:e}");
        }
        assert_eq!(sqrtf(0.0), 0.0);
        assert_eq!(sqrtf(4.0), 2.0);
        assert!(sqrtf(-1.0).is_nan());
    }

    #[test]
    fn nonneg_clamps_like_a_float_compare() {
        for x in [
            -1.0f32,
            -0.0,
            0.0,
            1e-45,
            -1e-45,
            2.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -f32::NAN,
        ] {
            let want = sqrtf(if x > 0.0 { x } else { 0.0 });
            assert_eq!(sqrt_nonneg(x).to_bits(), want.to_bits(), "{x:e}");
        }
    }
}
