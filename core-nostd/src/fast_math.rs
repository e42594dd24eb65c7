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
    let y: f32;
    // Note(unsafe): one FPU instruction on registers only: it reads `x`, writes `y`, touches no
    // memory and no stack, and the hard-float ABI (`eabihf`) guarantees the FPU is present and enabled
    // (cortex-m-rt enables it before `main`). Its result is IEEE correctly rounded (round to nearest).
    unsafe {
        core::arch::asm!(
            "vsqrt.f32 {y}, {x}",
            x = in(sreg) x,
            y = lateout(sreg) y,
            options(pure, nomem, nostack, preserves_flags)
        );
    }
    y
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
