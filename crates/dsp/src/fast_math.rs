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
        vsqrt2([x, x])[0]
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

/// [`sqrtf`] of two values at once (on the M4F one register transfer each way for both).
#[inline(always)]
#[must_use]
pub fn sqrtf2(x: [f32; 2]) -> [f32; 2] {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        vsqrt2(x)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        x.map(libm::sqrtf)
    }
}

/// Clears negative values (and −0) to +0 with one integer operation on the bits: the value moves to a
/// core register for the `asm!` of [`sqrtf`] on the M4F anyway, where a float compare would cost a
/// compare, a flag transfer and a conditional move. Equal to `if x > 0.0 { x } else { 0.0 }` for every
/// `x` except a positive NaN (kept).
#[inline(always)]
pub fn clamp_nonneg(x: f32) -> f32 {
    let b = x.to_bits();
    // Sign bit set: the arithmetic shift gives all ones, so the mask clears every bit (→ +0).
    f32::from_bits(b & !(((b as i32) >> 31) as u32))
}

/// √max(x, 0) (see `clamp_nonneg`): bit-identical to `sqrtf(if x > 0.0 { x } else { 0.0 })` for
/// every `x` except a positive NaN (NaN instead of 0).
#[inline(always)]
#[must_use]
pub fn sqrt_nonneg(x: f32) -> f32 {
    sqrtf(clamp_nonneg(x))
}

/// [`sqrt_nonneg`] of two values at once (see [`sqrtf2`]).
#[inline(always)]
#[must_use]
pub fn sqrt_nonneg2(x: [f32; 2]) -> [f32; 2] {
    sqrtf2(x.map(clamp_nonneg))
}

/// d·√d for d = √max(x, 0), of two values at once: the distance power d^1.5 from a squared
/// distance. Bit-identical to `let d = sqrt_nonneg(x); d * sqrtf(d)` (the same correctly rounded
/// operations); on the M4F the four square roots and two products run in one FPU block, with one
/// register transfer each way for both values.
#[inline(always)]
#[must_use]
pub fn pow_three_halves_nonneg2(x: [f32; 2]) -> [f32; 2] {
    let x = x.map(clamp_nonneg);
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        vpow3_2(x)
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        x.map(|v| {
            let d = libm::sqrtf(v);
            d * libm::sqrtf(d)
        })
    }
}

/// √x·√√x of two values on the FPU (see [`vsqrt2`] for how the block borrows FPU registers; this
/// one borrows `s0`…`s3`).
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
#[allow(unsafe_code)]
fn vpow3_2(x: [f32; 2]) -> [f32; 2] {
    let (y0, y1): (u32, u32);
    // Note(unsafe): register-only FPU code, as in `vsqrt2`, saving and restoring s0…s3.
    unsafe {
        core::arch::asm!(
            "vmov {t0}, {t1}, s0, s1",
            "vmov {t2}, {t3}, s2, s3",
            "vmov s0, s1, {x0}, {x1}",
            "vsqrt.f32 s0, s0",
            "vsqrt.f32 s1, s1",
            "vsqrt.f32 s2, s0",
            "vsqrt.f32 s3, s1",
            "vmul.f32 s0, s0, s2",
            "vmul.f32 s1, s1, s3",
            "vmov {y0}, {y1}, s0, s1",
            "vmov s0, s1, {t0}, {t1}",
            "vmov s2, s3, {t2}, {t3}",
            x0 = in(reg) x[0].to_bits(),
            x1 = in(reg) x[1].to_bits(),
            y0 = lateout(reg) y0,
            y1 = lateout(reg) y1,
            t0 = out(reg) _,
            t1 = out(reg) _,
            t2 = out(reg) _,
            t3 = out(reg) _,
            options(pure, nomem, nostack, preserves_flags)
        );
    }
    [f32::from_bits(y0), f32::from_bits(y1)]
}

/// Two `VSQRT.F32` on the FPU.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
#[inline(always)]
#[allow(unsafe_code)]
fn vsqrt2(x: [f32; 2]) -> [f32; 2] {
    let (y0, y1): (u32, u32);
    // Note(unsafe): register-only FPU code: no memory, no stack. Stable Rust does not let `asm!` name FPU
    // registers (the `vfp2` feature is unstable), so the operands travel in core registers and the
    // instructions borrow `s0` and `s1`, which the block saves in `{t0}`, `{t1}` and restores, leaving
    // every register but the outputs as it found them (`VMOV` moves two core registers to or from two
    // consecutive single-precision registers in one instruction). The hard-float ABI (`eabihf`)
    // guarantees the FPU is present and enabled (cortex-m-rt enables it before `main`). VSQRT.F32 is
    // IEEE correctly rounded (round-to-nearest, the reset mode), like `libm::sqrtf`.
    unsafe {
        core::arch::asm!(
            "vmov {t0}, {t1}, s0, s1",
            "vmov s0, s1, {x0}, {x1}",
            "vsqrt.f32 s0, s0",
            "vsqrt.f32 s1, s1",
            "vmov {y0}, {y1}, s0, s1",
            "vmov s0, s1, {t0}, {t1}",
            x0 = in(reg) x[0].to_bits(),
            x1 = in(reg) x[1].to_bits(),
            y0 = lateout(reg) y0,
            y1 = lateout(reg) y1,
            t0 = out(reg) _,
            t1 = out(reg) _,
            options(pure, nomem, nostack, preserves_flags)
        );
    }
    [f32::from_bits(y0), f32::from_bits(y1)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_libm_bit_for_bit() {
        let mut rng = crate::test_rng::Lcg(7);
        for _ in 0..10_000 {
            let x = f32::from_bits(rng.next_u32() >> 1); // non-negative, all exponents
            assert_eq!(sqrtf(x).to_bits(), libm::sqrtf(x).to_bits(), "{x:e}");
        }
        assert_eq!(sqrtf(0.0), 0.0);
        assert_eq!(sqrtf(4.0), 2.0);
        assert!(sqrtf(-1.0).is_nan());
        assert_eq!(sqrtf2([4.0, 9.0]), [2.0, 3.0]);
        assert_eq!(sqrt_nonneg2([-4.0, 9.0]), [0.0, 3.0]);
        assert_eq!(pow_three_halves_nonneg2([16.0, -1.0]), [8.0, 0.0]);
        for _ in 0..10_000 {
            let x = f32::from_bits(rng.next_u32() >> 1);
            let d = sqrt_nonneg(x);
            let want = d * sqrtf(d);
            assert_eq!(
                pow_three_halves_nonneg2([x, x])[1].to_bits(),
                want.to_bits(),
                "{x:e}"
            );
        }
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
