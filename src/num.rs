//! Numeric helpers shared across the core.
//!
//! - [`sqrtf`]: the Cortex-M4F `VSQRT.F32` instruction on the target (DESIGN §6: `libm::sqrtf` is
//!   ~80 soft instructions on ARMv7E-M, `micromath`'s is ~6 % off), `libm` on the host.
//! - [`crc32`]: CRC-32/ISO-HDLC (the zlib/Ethernet CRC) from the `crc` crate, for encodings.

// Cortex-M4F hardware square root. `f32::sqrt` is not in `core` on stable, and inline `asm!`
// with `sreg` operands is rejected on thumbv7em-none-eabihf, so this is a two-instruction
// global_asm function (see ../shared/spec/embedded-toolchain.md §2, item 8). The `.fpu`
// directive is needed because LLVM re-parses module asm without the target's FPU features.
// Under the eabihf calling convention the f32 argument and result are both in s0.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
core::arch::global_asm!(
    ".section .text.ballpod_vsqrtf,\"ax\",%progbits",
    ".global ballpod_vsqrtf",
    ".type ballpod_vsqrtf,%function",
    ".thumb_func",
    ".fpu fpv4-sp-d16",
    "ballpod_vsqrtf:",
    "vsqrt.f32 s0, s0",
    "bx lr",
);

#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
unsafe extern "C" {
    fn ballpod_vsqrtf(x: f32) -> f32;
}

/// Square root of an `f32` (IEEE-754 correctly rounded on both paths; NaN for x < 0).
#[inline(always)]
pub fn sqrtf(x: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        // SAFETY: `ballpod_vsqrtf` is the two-instruction function above; it reads s0 and
        // writes s0 only, as the eabihf ABI expects for `extern "C" fn(f32) -> f32`.
        unsafe { ballpod_vsqrtf(x) }
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::sqrtf(x)
    }
}

/// Square root of an `f64` (software on the M4F: fine at per-test rates, DESIGN §6).
#[inline]
pub fn sqrt(x: f64) -> f64 {
    libm::sqrt(x)
}

/// The CRC used by every binary encoding of the pod: CRC-32/ISO-HDLC
/// (poly 0x04C11DB7 reflected, init and xorout 0xFFFFFFFF; check value of "123456789" is
/// 0xCBF43926).
pub const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// CRC-32/ISO-HDLC of `bytes`.
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}
