//! Numbers in and out, by hand: IEEE 488.2 decimal numeric program data → `f64`, and fixed-point
//! decimal text out of `f32`/`f64` values.
//!
//! Why by hand: `core::fmt`'s float formatting (Grisu/Dragon with its tables) costs several KiB
//! of flash and prints shortest round-trip digits, not the fixed resolution a measurement has.
//! A value is printed by scaling to an integer count of its resolution step (µm × 10⁴ → 0.1 nm)
//! and printing that integer: exact, a few hundred bytes of code, and the printed digits are the
//! value rounded half away from zero to the stated resolution.

/// Largest integer magnitude printed by [`push_fixed`]: the integers below 2⁵³ are exact in
/// `f64`, so the scaled value is still the correctly rounded count of resolution steps.
const MAX_SCALED: f64 = 9.0e15;

/// SCPI-99 Vol 1 §7.2.1.5 representation of "not a number" (9.91E37), sent for a non-finite or
/// unprintably large value in a response.
pub const SCPI_NAN: &[u8] = b"9.91E+37";

/// Powers of ten that `f64` holds exactly (10⁰ … 10²²).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// 10^k as `f64` (exact for k ≤ 22; repeated multiplication beyond, within a few ulp).
fn pow10(k: u32) -> f64 {
    let mut r = 1.0;
    let mut k = k;
    while k > 22 {
        r *= 1e22;
        k -= 22;
    }
    r * POW10.get(k as usize).copied().unwrap_or(1.0)
}

/// A byte sink of fixed capacity (a response or CSV line under construction).
pub type Text<const C: usize> = heapless::Vec<u8, C>;

/// Appends bytes; returns false (and appends nothing) if they do not fit.
pub fn push_bytes<const C: usize>(buf: &mut Text<C>, bytes: &[u8]) -> bool {
    buf.extend_from_slice(bytes).is_ok()
}

/// Appends an unsigned integer in decimal.
pub fn push_u64<const C: usize>(buf: &mut Text<C>, v: u64) -> bool {
    let mut digits = [0u8; 20];
    let i = decimal_digits(v, &mut digits);
    digits.get(i..).is_some_and(|d| push_bytes(buf, d))
}

/// Writes `v`'s decimal digits right-aligned into `digits`; returns where they start. One body
/// for every [`push_u64`] buffer size (flash).
fn decimal_digits(v: u64, digits: &mut [u8; 20]) -> usize {
    let mut n = v;
    let mut i = digits.len();
    loop {
        i -= 1;
        if let Some(d) = digits.get_mut(i) {
            *d = b'0' + (n % 10) as u8;
        }
        n /= 10;
        if n == 0 || i == 0 {
            return i;
        }
    }
}

/// Appends a signed integer in decimal.
pub fn push_i64<const C: usize>(buf: &mut Text<C>, v: i64) -> bool {
    if v < 0 && !push_bytes(buf, b"-") {
        return false;
    }
    push_u64(buf, v.unsigned_abs())
}

/// Appends `v` rounded half away from zero to `decimals` decimals (0…9), e.g. µm with 4
/// decimals = 0.1 nm. No sign is printed when the rounded value is zero. With `trim`, trailing
/// zero decimals (and a bare point) are dropped (`150.0000` → `150`).
///
/// A non-finite value, or one whose scaled magnitude reaches 9·10¹⁵ (beyond exact `f64`
/// integers), is written as `nan_text` instead (SCPI: [`SCPI_NAN`]; CSV: `nan`). Returns false
/// if the buffer is full.
pub fn push_fixed<const C: usize>(
    buf: &mut Text<C>,
    v: f64,
    decimals: u32,
    trim: bool,
    nan_text: &[u8],
) -> bool {
    let decimals = decimals.min(9);
    let scale = pow10(decimals);
    let scaled = v * scale;
    if !(scaled.abs() < MAX_SCALED) {
        return push_bytes(buf, nan_text);
    }
    // Round half away from zero: the cast truncates toward zero, so add 0.5 to the magnitude.
    let n = (scaled.abs() + 0.5) as u64;
    // `max(1)`: decimals <= 9 already, but this lets the compiler drop the division-by-zero
    // panic path (.ci/panic-paths).
    let step = 10u64.pow(decimals).max(1);
    let int_part = n / step;
    let mut frac = n % step;
    if n != 0 && v < 0.0 && !push_bytes(buf, b"-") {
        return false;
    }
    if !push_u64(buf, int_part) {
        return false;
    }
    let mut width = decimals;
    if trim {
        while width > 0 && frac.is_multiple_of(10) {
            frac /= 10;
            width -= 1;
        }
    }
    if width == 0 {
        return true;
    }
    let mut digits = [b'0'; 9];
    let mut f = frac;
    for d in digits.iter_mut().take(width as usize).rev() {
        *d = b'0' + (f % 10) as u8;
        f /= 10;
    }
    push_bytes(buf, b".")
        && digits
            .get(..width as usize)
            .is_some_and(|d| push_bytes(buf, d))
}

/// Appends `v` with `significant` significant digits (at most 9 decimals; trailing zeros
/// dropped): 7 digits show an `f32` as it was typed (`150.0021`, not `150.002106`), since any
/// decimal of ≤ 7 significant digits survives the trip through `f32`.
pub fn push_significant<const C: usize>(
    buf: &mut Text<C>,
    v: f64,
    significant: u32,
    nan_text: &[u8],
) -> bool {
    // e = floor(log10 |v|) by comparison with powers of ten (no libm log on the target).
    let a = v.abs();
    let mut e: i32 = 0;
    if a > 0.0 && a.is_finite() {
        let mut p = 1.0;
        if a >= 1.0 {
            while a >= p * 10.0 && e < 40 {
                p *= 10.0;
                e += 1;
            }
        } else {
            while a < p && e > -40 {
                p /= 10.0;
                e -= 1;
            }
        }
    }
    let decimals = (significant as i32 - 1 - e).clamp(0, 9) as u32;
    push_fixed(buf, v, decimals, true, nan_text)
}

/// Appends `v` with `significant` significant digits (1…17, trailing zeros dropped) in fixed
/// notation for 10⁻⁵ ≤ |v| < 10¹⁵, else as `d.ddde±x`; a non-finite value as `nan_text`;
/// −0 as `-0`.
/// With 9 digits an `f32` reads back to the same `f32` (9 significant digits always do, even
/// with an error of one in the last digit: half an `f32` ulp is ≥ 3·10⁻⁸ of the value, one in
/// the ninth digit ≤ 10⁻⁸), which the logs and the sample stream need for replay bit for bit.
pub fn push_exact<const C: usize>(
    buf: &mut Text<C>,
    v: f64,
    significant: u32,
    nan_text: &[u8],
) -> bool {
    if !v.is_finite() {
        return push_bytes(buf, nan_text);
    }
    if v == 0.0 {
        // the sign of a zero is part of the value read back
        return push_bytes(buf, if v.is_sign_negative() { b"-0" } else { b"0" });
    }
    let sig = significant.clamp(1, 17) as i32;
    let a = v.abs();
    // e = floor(log10 a), estimated by comparison, then corrected on the scaled mantissa
    let mut e: i32 = 0;
    let mut p = 1.0;
    if a >= 1.0 {
        while a >= p * 10.0 && e < 330 {
            p *= 10.0;
            e += 1;
        }
    } else {
        while a < p && e > -330 {
            p /= 10.0;
            e -= 1;
        }
    }
    let lo = pow10((sig - 1) as u32) as u64;
    let hi = lo.saturating_mul(10);
    let mut m = 0u64;
    for _ in 0..3 {
        let k = sig - 1 - e;
        let x = if k >= 0 {
            a * pow10(k as u32)
        } else {
            a / pow10((-k) as u32)
        };
        m = (x + 0.5) as u64;
        if m >= hi {
            e += 1;
        } else if m < lo {
            e -= 1;
        } else {
            break;
        }
    }
    // digits of m, most significant first: the low nine from a u32, the rest (m < 10¹⁷) from
    // another (a hardware division a digit, where a u64's is a library call of ~100
    // instructions: a run header's hundred values)
    let mut digits = [b'0'; 17];
    let (mut high, mut low) = ((m / 1_000_000_000) as u32, (m % 1_000_000_000) as u32);
    for (i, d) in digits.iter_mut().take(sig as usize).rev().enumerate() {
        let t = if i < 9 { &mut low } else { &mut high };
        *d = b'0' + (*t % 10) as u8;
        *t /= 10;
    }
    let mut n = sig as usize;
    while n > 1 && digits.get(n - 1) == Some(&b'0') {
        n -= 1;
    }
    let digits = digits.get(..n).unwrap_or(&[]);
    if v < 0.0 && !push_bytes(buf, b"-") {
        return false;
    }
    if (-5..15).contains(&e) {
        if e >= 0 {
            // the integer part: its digits, then zeros where the digits end before it does
            let int_len = (e + 1) as usize;
            let zeros = [b'0'; 17];
            if !(push_bytes(buf, digits.get(..int_len.min(n)).unwrap_or(&[]))
                && push_bytes(buf, zeros.get(..int_len.saturating_sub(n)).unwrap_or(&[])))
            {
                return false;
            }
            if n > int_len {
                push_bytes(buf, b".") && push_bytes(buf, digits.get(int_len..).unwrap_or(&[]))
            } else {
                true
            }
        } else {
            let zeros = [b'0'; 5];
            push_bytes(buf, b"0.")
                && push_bytes(buf, zeros.get(..(-e - 1) as usize).unwrap_or(&[]))
                && push_bytes(buf, digits)
        }
    } else {
        push_bytes(buf, digits.get(..1).unwrap_or(&[]))
            && (n == 1
                || (push_bytes(buf, b".") && push_bytes(buf, digits.get(1..).unwrap_or(&[]))))
            && push_bytes(buf, b"e")
            && push_i64(buf, i64::from(e))
    }
}

/// Why a decimal numeric program datum was rejected (mapped to SCPI-99 Vol 2 §21.8 error numbers
/// by the caller).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NumberError {
    /// A character that cannot appear in a number (-121).
    InvalidCharacter,
    /// An exponent beyond ±32000 (IEEE 488.2 §7.7.2.4.1; -123).
    ExponentTooLarge,
    /// More than 255 mantissa digits (IEEE 488.2 §7.7.2.4.1; -124).
    TooManyDigits,
    /// A number followed by a suffix (units are not accepted; -131).
    Suffix,
}

/// Parses IEEE 488.2 §7.7.2 decimal numeric program data (NRf: `[+|-] digits [. digits]
/// [E|e [+|-] digits]`, at least one mantissa digit) into an `f64`.
///
/// Up to 19 significant digits are kept exactly (an integer mantissa times an exact power of
/// ten, so values up to 2⁵³ with at most 22 decimals are correctly rounded); further digits are
/// counted but ignored. The whole token must be the number: anything after it is an error.
pub fn parse_decimal(text: &[u8]) -> Result<f64, NumberError> {
    let mut it = text.iter().copied().peekable();
    let mut negative = false;
    if let Some(&s) = it.peek()
        && (s == b'+' || s == b'-')
    {
        negative = s == b'-';
        it.next();
    }
    let mut mantissa: u64 = 0;
    let mut kept = 0u32; // significant digits held in `mantissa`
    let mut digits = 0u32; // all mantissa digits seen
    let mut exp10: i64 = 0;
    let mut seen_point = false;
    while let Some(&c) = it.peek() {
        match c {
            b'0'..=b'9' => {
                digits += 1;
                if digits > 255 {
                    return Err(NumberError::TooManyDigits);
                }
                if mantissa == 0 && c == b'0' {
                    // leading zero: no significant digit yet
                    if seen_point {
                        exp10 -= 1;
                    }
                } else if kept < 19 {
                    mantissa = mantissa * 10 + u64::from(c - b'0');
                    kept += 1;
                    if seen_point {
                        exp10 -= 1;
                    }
                } else if !seen_point {
                    exp10 += 1; // dropped integer digit still scales the value
                }
            }
            b'.' if !seen_point => seen_point = true,
            _ => break,
        }
        it.next();
    }
    if digits == 0 {
        return Err(NumberError::InvalidCharacter);
    }
    if let Some(&e) = it.peek()
        && (e == b'e' || e == b'E')
    {
        it.next();
        let mut exp_negative = false;
        if let Some(&s) = it.peek()
            && (s == b'+' || s == b'-')
        {
            exp_negative = s == b'-';
            it.next();
        }
        let mut exp: i64 = 0;
        let mut exp_digits = 0;
        while let Some(&c) = it.peek() {
            if !c.is_ascii_digit() {
                break;
            }
            exp = exp * 10 + i64::from(c - b'0');
            exp_digits += 1;
            if exp > 32000 {
                return Err(NumberError::ExponentTooLarge);
            }
            it.next();
        }
        if exp_digits == 0 {
            return Err(NumberError::InvalidCharacter);
        }
        exp10 += if exp_negative { -exp } else { exp };
    }
    if let Some(c) = it.next() {
        return Err(if c.is_ascii_alphabetic() {
            NumberError::Suffix
        } else {
            NumberError::InvalidCharacter
        });
    }
    let m = mantissa as f64;
    let magnitude = if mantissa == 0 {
        0.0
    } else if exp10 >= 0 {
        m * pow10(exp10.min(400) as u32)
    } else {
        // Two steps for very small values so the divisor stays finite.
        let k = (-exp10).min(800) as u32;
        if k > 300 {
            m / pow10(300) / pow10(k - 300)
        } else {
            m / pow10(k)
        }
    };
    Ok(if negative { -magnitude } else { magnitude })
}
