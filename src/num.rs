//! Numeric helpers shared across the core.
//!
//! - [`sqrtf`]: the Cortex-M4F `VSQRT.F32` instruction on the target (DESIGN §6: `libm::sqrtf` is
//!   ~80 soft instructions on ARMv7E-M, `micromath`'s is ~6 % off), `libm` on the host;
//!   [`fmaf`] likewise `VFMA.F32` (`libm::fmaf` is soft-float through f64).
//! - [`sin_cos`], [`sin`], [`cos`]: f64 sine and cosine for angles up to ±8·10⁵ rad (fdlibm's
//!   kernels with a three-part Cody–Waite reduction). Hand-written because `libm::sin`'s
//!   reduction for any argument (`rem_pio2`, `rem_pio2_large`) is ~6 KB of the 206 KiB flash
//!   budget, and no angle of the pod is beyond a few turns.
//! - [`acos`]: f64 arc cosine on `atan2` (one inverse-trigonometric family in flash).
//! - [`crc32`]: CRC-32/ISO-HDLC (the zlib/Ethernet CRC) from the `crc` crate, for encodings.

// Cortex-M4F hardware square root. `f32::sqrt` is not in `core` on stable, and inline `asm!`
// with `sreg` operands is rejected on thumbv7em-none-eabihf, so this is a two-instruction
// global_asm function (see design/spec/embedded-toolchain.md §2, item 8). The `.fpu`
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

// Cortex-M4F fused multiply-add (FPv4-SP `VFMA.F32`), as `ballpod_vsqrtf`: a, b, c in s0–s2.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
core::arch::global_asm!(
    ".section .text.ballpod_vfmaf,\"ax\",%progbits",
    ".global ballpod_vfmaf",
    ".type ballpod_vfmaf,%function",
    ".thumb_func",
    ".fpu fpv4-sp-d16",
    "ballpod_vfmaf:",
    "vfma.f32 s2, s0, s1",
    "vmov.f32 s0, s2",
    "bx lr",
);

#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
unsafe extern "C" {
    fn ballpod_vsqrtf(x: f32) -> f32;
    fn ballpod_vfmaf(a: f32, b: f32, c: f32) -> f32;
}

/// a·b + c with one rounding (the M4F's `VFMA.F32`; `libm::fmaf` on the host): the exact error
/// of a product is `fmaf(a, b, −a·b)`.
#[inline(always)]
pub fn fmaf(a: f32, b: f32, c: f32) -> f32 {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        // SAFETY: `ballpod_vfmaf` is the three-instruction function above; it reads s0–s2 and
        // writes s0 (clobbering s2, a caller-saved register), as the eabihf ABI allows for
        // `extern "C" fn(f32, f32, f32) -> f32`.
        unsafe { ballpod_vfmaf(a, b, c) }
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        libm::fmaf(a, b, c)
    }
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

/// The `k`-th smallest value of `v` (0-based, ordered by `total_cmp`: positive NaNs last),
/// reordering `v`; `None` if `k` is out of range. Hoare's selection with a median-of-three
/// pivot and a three-way partition (equal values, such as a noiseless profile's, end it at
/// once): O(n) on average, for the median of a bin profile's few hundred values, which the
/// live circle u takes every 1 024 samples. Written here: core's `select_nth_unstable` brings
/// a panic path, and a median sorted by insertion is O(n²) on a 360-bin profile.
pub fn select_f32(v: &mut [f32], k: usize) -> Option<f32> {
    use core::cmp::Ordering::{Equal, Greater, Less};
    let at = |v: &[f32], i: usize| v.get(i).copied().unwrap_or(f32::NAN);
    let (mut lo, mut hi) = (0, v.len().checked_sub(1)?);
    if k > hi {
        return None;
    }
    while lo < hi {
        let mid = lo + (hi - lo) / 2;
        let [a, b, c] = [at(v, lo), at(v, mid), at(v, hi)];
        let pivot = if a.total_cmp(&b) == Less {
            if b.total_cmp(&c) == Less {
                b
            } else if a.total_cmp(&c) == Less {
                c
            } else {
                a
            }
        } else if a.total_cmp(&c) == Less {
            a
        } else if b.total_cmp(&c) == Less {
            c
        } else {
            b
        };
        // [lo, lt) < pivot, [lt, i) = pivot, [gt, hi] > pivot
        let (mut lt, mut i, mut gt) = (lo, lo, hi + 1);
        while i < gt {
            match at(v, i).total_cmp(&pivot) {
                Less => {
                    swap(v, lt, i);
                    lt += 1;
                    i += 1;
                }
                Greater => {
                    gt -= 1;
                    swap(v, i, gt);
                }
                Equal => i += 1,
            }
        }
        if k < lt {
            hi = lt - 1;
        } else if k >= gt {
            lo = gt;
        } else {
            return Some(pivot);
        }
    }
    v.get(k).copied()
}

/// Swaps `v[i]` and `v[j]` (nothing if either is out of range: no panic path).
fn swap(v: &mut [f32], i: usize, j: usize) {
    if let (Some(&a), Some(&b)) = (v.get(i), v.get(j)) {
        if let Some(x) = v.get_mut(i) {
            *x = b;
        }
        if let Some(x) = v.get_mut(j) {
            *x = a;
        }
    }
}

/// True if every value is finite (no NaN, no infinity): the input check of the core's
/// methods (arrays of points: `all_finite(points.as_flattened())`).
// one copy in flash for the many input checks
#[inline(never)]
pub fn all_finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Arc cosine of `x` ∈ [−1, 1], rad (NaN outside): `atan2(√((1 − x)(1 + x)), x)`, the
/// factored form keeping full precision next to ±1. Hand-written on `atan2` because `libm::acos`
/// is another ~0.9 KB of flash beside the `atan2` the core already links.
pub fn acos(x: f64) -> f64 {
    if !(-1.0..=1.0).contains(&x) {
        return f64::NAN;
    }
    libm::atan2(sqrt((1.0 - x) * (1.0 + x)), x)
}

/// `v` as eight upper-case hexadecimal digits (ASCII): the serial number in `*IDN?` and the USB
/// descriptor.
pub fn hex8(v: u32) -> [u8; 8] {
    let mut out = [b'0'; 8];
    for (i, o) in (0u32..).zip(out.iter_mut()) {
        let nibble = ((v >> (28 - 4 * i)) & 0xF) as u8;
        *o = if nibble < 10 {
            b'0' + nibble
        } else {
            b'A' + nibble - 10
        };
    }
    out
}

/// Square root of an `f64`, within 1 ulp of the correctly rounded root (software on the M4F:
/// fine at per-test rates, DESIGN §6): two Newton steps from the f32 root ([`sqrtf`], VSQRT on
/// the target) of the argument scaled by an even power of two into [1, 4). Hand-written because
/// `libm::sqrt` is 0.8 KB of flash (a bit-by-bit loop and a 256-byte table); it is slower (the
/// seed 002 identification takes 1.97 s instead of 1.82 s on the pod, between runs). The same
/// code runs on the host, so host and pod agree bit for bit.
#[inline(never)]
pub fn sqrt(x: f64) -> f64 {
    if !(x > 0.0 && x < f64::INFINITY) {
        // 0 and −0 are their own roots, +∞ too; NaN and x < 0 give NaN
        return if x >= 0.0 { x } else { f64::NAN };
    }
    // x = xs·2^s with s even and xs in [1, 4) (a subnormal x first scaled by 2^54): √x =
    // √xs·2^(s/2), every scaling a power of two, exact
    let (x, post) = if x < f64::MIN_POSITIVE {
        (x * TWO_POW_54, 1.0 / TWO_POW_27)
    } else {
        (x, 1.0)
    };
    let s = (((x.to_bits() >> 52) & 0x7ff) as i64 - 1023) & !1;
    let xs = x * f64::from_bits(((1023 - s) as u64) << 52);
    let root_scale = f64::from_bits(((1023 + s / 2) as u64) << 52);
    // relative error ≤ 2^-23 (the f32 root of the f32-rounded xs) → 2^-47 → rounding
    let mut y = f64::from(sqrtf(xs as f32));
    y = 0.5 * (y + xs / y);
    y = 0.5 * (y + xs / y);
    y * root_scale * post
}

/// 2^54 and 2^27 (exact).
const TWO_POW_54: f64 = 18_014_398_509_481_984.0;
const TWO_POW_27: f64 = 134_217_728.0;

/// √(a² + b²) without libm's overflow scaling (flash: 600 B on the pod): every caller's
/// magnitudes (µm, mm, arc-seconds, rotation tangents ≤ 1) are far from f64 overflow.
pub fn hypot(a: f64, b: f64) -> f64 {
    sqrt(a * a + b * b)
}

/// Largest |angle| (rad) [`sin_cos`] reduces exactly (2¹⁹ quarter turns: the quadrant count
/// times the first part of π/2 stays exact in f64).
pub const SIN_COS_MAX_RAD: f64 = 823_549.6;

/// Sine and cosine of `x` (rad) for |x| ≤ [`SIN_COS_MAX_RAD`], within 2 ulp of the exact
/// values (within 1e-28·|x| absolute in the ~1e-18 rad next to a root, where the neglected
/// fourth part of π/2 is the error; test host-tests/tests/num_trig.rs); NaN beyond that
/// and for NaN or infinite `x`.
///
/// Reduction r = x − k·π/2 (`reduce_pio2`), then fdlibm's `__kernel_sin`/`__kernel_cos`
/// polynomials on |r| ≤ π/4 and the quadrant k mod 4.
pub fn sin_cos(x: f64) -> (f64, f64) {
    let Some((k, r)) = reduce_pio2(x) else {
        return (f64::NAN, f64::NAN);
    };
    let (s, c) = (kernel_sin(r), kernel_cos(r));
    match k & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// Sine of `x` (rad); see [`sin_cos`].
pub fn sin(x: f64) -> f64 {
    match reduce_pio2(x) {
        Some((k, r)) => match k & 3 {
            0 => kernel_sin(r),
            1 => kernel_cos(r),
            2 => -kernel_sin(r),
            _ => -kernel_cos(r),
        },
        None => f64::NAN,
    }
}

/// Cosine of `x` (rad); see [`sin_cos`].
pub fn cos(x: f64) -> f64 {
    match reduce_pio2(x) {
        Some((k, r)) => match k & 3 {
            0 => kernel_cos(r),
            1 => -kernel_sin(r),
            2 => -kernel_cos(r),
            _ => kernel_sin(r),
        },
        None => f64::NAN,
    }
}

/// `x = k·π/2 + r` with |r| ≤ π/4 (about), or `None` beyond [`SIN_COS_MAX_RAD`] or for NaN.
/// π/2 in three parts of 33 bits (fdlibm `__ieee754_rem_pio2`'s pio2_1/pio2_2/pio2_3): each
/// k·part is exact in f64 for |k| ≤ 2¹⁹.
#[allow(clippy::excessive_precision)] // fdlibm's constants as published
fn reduce_pio2(x: f64) -> Option<(i32, f64)> {
    const PIO2_1: f64 = 1.570_796_326_734_125_614_17;
    const PIO2_2: f64 = 6.077_100_506_303_965_976_60e-11;
    const PIO2_3: f64 = 2.022_266_248_711_166_455_80e-21;
    let a = libm::fabs(x);
    if a <= core::f64::consts::FRAC_PI_4 {
        return Some((0, x));
    }
    if !(a <= SIN_COS_MAX_RAD) {
        return None;
    }
    let fk = x * core::f64::consts::FRAC_2_PI;
    // |fk| < 2^19 + 1: the casts are exact and cannot saturate.
    let k = if fk >= 0.0 {
        (fk + 0.5) as i32
    } else {
        (fk - 0.5) as i32
    };
    let kf = f64::from(k);
    Some((k, ((x - kf * PIO2_1) - kf * PIO2_2) - kf * PIO2_3))
}

/// sin r for |r| ≤ π/4 (fdlibm k_sin.c without the tail term).
#[allow(clippy::excessive_precision)] // fdlibm's constants as published
fn kernel_sin(r: f64) -> f64 {
    const S1: f64 = -1.666_666_666_666_663_243_48e-1;
    const S2: f64 = 8.333_333_333_322_489_461_24e-3;
    const S3: f64 = -1.984_126_982_985_794_931_34e-4;
    const S4: f64 = 2.755_731_370_707_006_767_89e-6;
    const S5: f64 = -2.505_076_025_340_686_341_95e-8;
    const S6: f64 = 1.589_690_995_211_550_102_21e-10;
    let z = r * r;
    let p = S2 + z * (S3 + z * (S4 + z * (S5 + z * S6)));
    r + r * z * (S1 + z * p)
}

/// cos r for |r| ≤ π/4 (fdlibm k_cos.c without the tail term).
#[allow(clippy::excessive_precision)] // fdlibm's constants as published
fn kernel_cos(r: f64) -> f64 {
    const C1: f64 = 4.166_666_666_666_660_190_37e-2;
    const C2: f64 = -1.388_888_888_887_410_957_49e-3;
    const C3: f64 = 2.480_158_728_947_672_941_78e-5;
    const C4: f64 = -2.755_731_435_139_066_330_35e-7;
    const C5: f64 = 2.087_572_321_298_174_827_90e-9;
    const C6: f64 = -1.135_964_755_778_819_482_65e-11;
    let z = r * r;
    let p = z * (C1 + z * (C2 + z * (C3 + z * (C4 + z * (C5 + z * C6)))));
    let hz = 0.5 * z;
    let w = 1.0 - hz;
    w + (((1.0 - w) - hz) + z * p)
}

/// The CRC used by every binary encoding of the pod: CRC-32/ISO-HDLC
/// (poly 0x04C11DB7 reflected, init and xorout 0xFFFFFFFF; check value of "123456789" is
/// 0xCBF43926). Bit by bit (`NoTable`): the pod checks a few hundred bytes at boot and at a
/// save, and the byte table would be 1 KiB of flash.
pub const CRC32: crc::Crc<u32, crc::NoTable> =
    crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);

/// CRC-32/ISO-HDLC of `bytes`.
pub fn crc32(bytes: &[u8]) -> u32 {
    CRC32.checksum(bytes)
}
