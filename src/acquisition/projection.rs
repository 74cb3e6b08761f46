//! The per-ADC-sample work of the AC demodulation ([`super::lvdt`]): both secondaries' 12-bit
//! blocks projected on the excitation's sine and cosine in integer arithmetic, two samples per
//! 32-bit word. On the Cortex-M4F this is a hand-scheduled loop of its DSP instructions (`SMLAD`:
//! two 16×16 multiply-accumulates; `USUB16`/`UQSUB16`/`UADD16`: the rail test on two samples);
//! elsewhere the portable Rust below, which gives the same sums bit for bit (`cargo bench-m4`
//! runs both on the M4 and compares). Assembly because the DSP intrinsics of `core::arch::arm`
//! are not stable and the loop needs all 14 free registers.
//!
//! **Rail test.** Per code in the kernel ([`RailTest::PerCode`], 6 of its 13 instructions per
//! two sample pairs), or not at all when the converters' analog watchdogs watched every
//! conversion of the block and stayed quiet ([`RailTest::WatchdogQuiet`]: the pod's ADCs flag a
//! code outside 1…4094 in hardware, at no CPU cost); then a leaner kernel loads four codes and
//! four reference words per instruction (`LDM`, word-aligned blocks).
//!
//! **Reference.** Q14: s_k = round(2¹⁴·sin(2πk/P)), c_k likewise, antisymmetric
//! (s_{k+P/2} = −s_k) so that Σ s_k = Σ c_k = 0 exactly: the ADC's mid-scale offset cancels
//! without rounding residue. The table's rounding (≤ 3·10⁻⁵ of full scale) is a gain error that
//! both secondaries share, which the ratio cancels (the host tests bound it against an f64
//! projection of the same codes).
//!
//! **Range.** With codes ≤ 4095 one period adds at most 4095·2¹⁴·cot(π/P) < 4095·2¹⁴·P/π to a
//! sum, so an `i32` holds [`MAX_CHUNK_SAMPLES`] samples (2.14·10⁹ < 2³¹); the caller converts
//! per chunk. A code above 4095 is not from a 12-bit converter: it is a rail (the block is
//! flagged clipped) and the sums wrap, as `SMLAD` does.

/// Scale of the Q14 reference (2¹⁴ = 1.0).
pub const Q14_ONE: f32 = 16_384.0;

/// Samples per channel whose sums an `i32` holds (see the module doc).
pub const MAX_CHUNK_SAMPLES: usize = 100;

/// Running sums of one chunk: the projections Σ v·s and Σ v·c of secondaries a and b (Q14 ×
/// counts), and per 16-bit lane the largest (v − 1) mod 2¹⁶ seen (a code 0 or ≥ 4095 makes it
/// ≥ 4094: the rail test).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(C)]
pub struct Q14Sums {
    /// Σ a·s.
    pub ia: i32,
    /// Σ a·c.
    pub qa: i32,
    /// Σ b·s.
    pub ib: i32,
    /// Σ b·c.
    pub qb: i32,
    /// Lane-wise maximum of (v − 1) mod 2¹⁶ over both channels.
    pub rail_max: u32,
    /// Loop counts of the M4 kernel (sample quads per period, periods); not sums.
    quads: u32,
    periods: u32,
}

impl Q14Sums {
    /// The sums of `a` and `b` ([`add_periods`] from zero; zero for a block it refuses).
    #[inline(always)]
    pub fn of(a: &[u16], b: &[u16], words: &[u32], rails: RailTest) -> Self {
        let mut acc = Self::zero();
        add_periods(&mut acc, a, b, words, rails);
        acc
    }

    /// All zero, from a zero the optimiser cannot see: a struct of constant zeros this size
    /// is a `memset` call at opt-level "z" (LLVM merges the stores), 36 instructions per LVDT
    /// block on the pod against these seven stores. `black_box` is only a hint here: the
    /// value is zero whatever it does.
    #[inline(always)]
    fn zero() -> Self {
        let z = core::hint::black_box(0);
        Self {
            ia: z,
            qa: z,
            ib: z,
            qb: z,
            rail_max: z as u32,
            quads: z as u32,
            periods: z as u32,
        }
    }

    /// True if a code at a rail (0 or ≥ 4095) was seen.
    pub fn clipped(&self) -> bool {
        let lo = self.rail_max & 0xFFFF;
        let hi = self.rail_max >> 16;
        lo >= 4094 || hi >= 4094
    }
}

/// The Q14 reference words of one period of `P` samples (`P` a multiple of 4) from the
/// period's sine and cosine: word 2j holds (s_2j, s_2j+1), word 2j + 1 holds (c_2j, c_2j+1), low
/// half first. Rounding is half away from zero, symmetric in sign, so a table with
/// sin(x + π) = −sin x gives an exactly antisymmetric reference (the host tests check Σ = 0).
pub fn reference_words<const P: usize>(sin: &[f32; P], cos: &[f32; P]) -> [u32; P] {
    let q = |x: f32| -> u32 {
        let half = if x < 0.0 { -0.5 } else { 0.5 };
        ((x * Q14_ONE + half) as i32 as u32) & 0xFFFF
    };
    let mut w = [0u32; P];
    for ((pair, s), c) in w
        .chunks_exact_mut(2)
        .zip(sin.chunks_exact(2))
        .zip(cos.chunks_exact(2))
    {
        if let ([ws, wc], [s0, s1], [c0, c1]) = (pair, s, c) {
            *ws = q(*s0) | (q(*s1) << 16);
            *wc = q(*c0) | (q(*c1) << 16);
        }
    }
    w
}

/// Who tests a block's codes for the converter rails (0 or ≥ 4095).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RailTest {
    /// The kernel, per code (into [`Q14Sums::rail_max`]): the exact test, wherever no hardware
    /// watched the conversions.
    PerCode,
    /// Nobody: the converters' analog watchdogs (window 1…4094 codes) watched every conversion
    /// of the block and did not trip, so no code is at a rail; `rail_max` is left as it was.
    WatchdogQuiet,
}

/// The periods of `a` and `b` (whole periods of `words`), or `None` for lengths the kernel
/// cannot take (unequal blocks, not whole periods, a period not a multiple of 4 samples).
fn periods(a: &[u16], b: &[u16], words: &[u32]) -> Option<u32> {
    let n = words.len();
    let ok = a.len() == b.len() && n != 0 && n.is_multiple_of(4) && a.len().is_multiple_of(n);
    u32::try_from(a.len() / n.max(1))
        .ok()
        .filter(|&p| ok && p > 0)
}

/// Adds whole periods to `acc`: `a`, `b` the two secondaries' codes, `words` the reference of
/// one period ([`reference_words`]); at most [`MAX_CHUNK_SAMPLES`] codes per channel between
/// conversions of the sums (the `i32` range); the rail maximum as `rails` says. Unequal
/// blocks, blocks not of whole periods or a period not a multiple of 4 samples add nothing and
/// return `false`. On the M4 the DSP kernels: with the per-code rail test one that reads the
/// codes with `LDR` (unaligned addresses work, at a cycle's cost, while `CCR.UNALIGN_TRP` keeps
/// its reset value 0), without it one that reads them with `LDM` (word-aligned blocks only:
/// an unaligned block takes the first kernel, whose sums are the same); elsewhere
/// [`add_periods_portable`]: the same sums.
pub fn add_periods(
    acc: &mut Q14Sums,
    a: &[u16],
    b: &[u16],
    words: &[u32],
    rails: RailTest,
) -> bool {
    let Some(periods) = periods(a, b, words) else {
        return false;
    };
    #[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
    {
        acc.quads = (words.len() / 4) as u32;
        acc.periods = periods;
        let aligned =
            a.as_ptr().cast::<u32>().is_aligned() && b.as_ptr().cast::<u32>().is_aligned();
        // SAFETY: both kernels read `4·quads·periods` = a.len() codes from `a` and from `b`
        // (`ballpod_q14_periods`: LDR, any alignment; `ballpod_q14_periods_sums`: LDM, called
        // only on word-aligned blocks), `words.len()` words from `words` per period (LDRD/LDM;
        // a `u32` slice is word-aligned) and read/write the seven words of `acc` (`repr(C)`);
        // they save and restore every callee-saved register they use (AAPCS) and call nothing.
        unsafe {
            if rails == RailTest::WatchdogQuiet && aligned {
                ballpod_q14_periods_sums(acc, a.as_ptr(), b.as_ptr(), words.as_ptr());
            } else {
                ballpod_q14_periods(acc, a.as_ptr(), b.as_ptr(), words.as_ptr());
            }
        }
        true
    }
    #[cfg(not(all(target_arch = "arm", target_abi = "eabihf")))]
    {
        let _ = periods;
        add_periods_portable(acc, a, b, words, rails)
    }
}

/// [`add_periods`] in portable Rust, exactly as the M4 kernels compute it (signed 16-bit
/// operands, wrapping 32-bit sums, the lane-wise rail maximum when `rails` asks for it).
pub fn add_periods_portable(
    acc: &mut Q14Sums,
    a: &[u16],
    b: &[u16],
    words: &[u32],
    rails: RailTest,
) -> bool {
    let Some(periods) = periods(a, b, words) else {
        return false;
    };
    // as the kernels leave them
    acc.quads = (words.len() / 4) as u32;
    acc.periods = periods;
    // SMLAD: acc + lo(x)·lo(y) + hi(x)·hi(y), 16-bit signed operands, wrapping
    fn smlad(acc: i32, x: u32, y: u32) -> i32 {
        let p = |u: u32| i32::from(u as u16 as i16);
        let lo = p(x) * p(y);
        let hi = p(x >> 16) * p(y >> 16);
        acc.wrapping_add(lo).wrapping_add(hi)
    }
    fn lane_max(m: u32, v: u32) -> u32 {
        let t = |x: u32| (x as u16).wrapping_sub(1);
        let lo = (m as u16).max(t(v));
        let hi = ((m >> 16) as u16).max(t(v >> 16));
        u32::from(lo) | (u32::from(hi) << 16)
    }
    let word = |s: &[u16]| match s {
        [lo, hi] => u32::from(*lo) | (u32::from(*hi) << 16),
        _ => 0,
    };
    let reference = words.chunks_exact(2).cycle();
    for ((pa, pb), w) in a.chunks_exact(2).zip(b.chunks_exact(2)).zip(reference) {
        let (xa, xb) = (word(pa), word(pb));
        let (s, c) = match w {
            [s, c] => (*s, *c),
            _ => (0, 0),
        };
        acc.ia = smlad(acc.ia, xa, s);
        acc.ib = smlad(acc.ib, xb, s);
        acc.qa = smlad(acc.qa, xa, c);
        acc.qb = smlad(acc.qb, xb, c);
        if rails == RailTest::PerCode {
            acc.rail_max = lane_max(acc.rail_max, xa);
            acc.rail_max = lane_max(acc.rail_max, xb);
        }
    }
    true
}

#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
unsafe extern "C" {
    /// r0 = &mut Q14Sums (ia, qa, ib, qb, rail_max, quads, periods), r1 = a, r2 = b,
    /// r3 = words (one period).
    fn ballpod_q14_periods(acc: *mut Q14Sums, a: *const u16, b: *const u16, words: *const u32);
    /// As `ballpod_q14_periods`, the sums only (`rail_max` untouched); `a`, `b` word-aligned.
    fn ballpod_q14_periods_sums(acc: *mut Q14Sums, a: *const u16, b: *const u16, words: *const u32);
}

// One kernel: the prologue loads the sums, the quad count and the period count from `acc`
// (the period count and the quad count then live on the stack with `acc` and the reference's
// start), `$setup` runs once, `$quad` once per quad of four samples per channel, then the
// reference rewinds per period (7 instructions) and `$store` writes the sums back.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
macro_rules! q14_kernel {
    ($name:literal, [$($setup:literal),*], [$($quad:literal),+], $store:literal) => {
        core::arch::global_asm!(
            concat!(".section .text.", $name, ",\"ax\",%progbits"),
            concat!(".global ", $name),
            concat!(".type ", $name, ",%function"),
            ".syntax unified",
            ".thumb",
            ".thumb_func",
            concat!($name, ":"),
            "push {{r0, r3, r4-r11, lr}}",
            "ldm r0, {{r4-r9}}",
            "ldr r0, [r0, #24]",
            "push {{r0, r9}}",
            $($setup,)*
            "2:",
            $($quad,)+
            "subs r9, r9, #1",
            "bne 2b",
            "ldr r3, [sp, #12]",
            "ldr r9, [sp, #4]",
            "ldr r0, [sp]",
            "subs r0, r0, #1",
            "str r0, [sp]",
            "bne 2b",
            "add sp, sp, #8",
            "pop {{r0, r3}}",
            $store,
            "pop {{r4-r11, pc}}",
        );
    };
}

// Per pair of samples of both channels: two word loads, one LDRD of the (sin, cos) reference
// pair, four SMLAD and the rail maximum (USUB16 v − 1, UQSUB16 + UADD16 = lane max) of each
// channel word; unrolled twice (`.rept 2`), so 28 instructions per 8 ADC sample·channels plus 2 for the
// loop, and 7 per period to rewind the reference.
// Registers: r4–r7 the sums, r8 the rail maximum, r9 the quad count, r1–r3 the pointers,
// r10/r11 the a/b words, r0/lr the reference pair, r12 the constant 0x0001_0001; on the stack
// the period count, the quads per period, `acc` and the reference's start.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
q14_kernel!(
    "ballpod_q14_periods",
    ["movw r12, #1", "movt r12, #1"],
    [
        ".rept 2",
        "ldr r10, [r1], #4",
        "ldr r11, [r2], #4",
        "ldrd r0, lr, [r3], #8",
        "smlad r4, r10, r0, r4",
        "smlad r6, r11, r0, r6",
        "smlad r5, r10, lr, r5",
        "smlad r7, r11, lr, r7",
        "usub16 r10, r10, r12",
        "uqsub16 r0, r10, r8",
        "uadd16 r8, r8, r0",
        "usub16 r11, r11, r12",
        "uqsub16 r0, r11, r8",
        "uadd16 r8, r8, r0",
        ".endr"
    ],
    "stm r0, {{r4-r8}}"
);

// The sums alone, per quad (four samples of each channel): one LDM of the quad's four
// reference words (s01, c01, s23, c23), one LDM of two code words per channel, eight SMLAD:
// 11 instructions per 8 ADC sample·channels plus 2 for the loop, and 7 per period to rewind
// the reference. Registers: r4–r7 the sums, r9 the quad count, r1–r3 the pointers, r0/r8/r12/lr
// the reference words (the rail maximum the prologue loads into r8 is not stored back), r10/r11
// the code words.
#[cfg(all(target_arch = "arm", target_abi = "eabihf"))]
q14_kernel!(
    "ballpod_q14_periods_sums",
    [],
    [
        "ldm r3!, {{r0, r8, r12, lr}}",
        "ldm r1!, {{r10, r11}}",
        "smlad r4, r10, r0, r4",
        "smlad r5, r10, r8, r5",
        "smlad r4, r11, r12, r4",
        "smlad r5, r11, lr, r5",
        "ldm r2!, {{r10, r11}}",
        "smlad r6, r10, r0, r6",
        "smlad r7, r10, r8, r7",
        "smlad r6, r11, r12, r6",
        "smlad r7, r11, lr, r7"
    ],
    "stm r0, {{r4-r7}}"
);
