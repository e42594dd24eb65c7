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
}
