//! Quadrature encoders: hardware counter → 64-bit count → position in mm or degrees.

use super::MAX_AXES;

/// Extends a wrapping hardware counter of `bits` bits (16 for TIM3/4/8, 32 for TIM2/5) to an
/// exact 64-bit count, and flags jumps no real axis can make (a quadrature glitch or a missed
/// read).
///
/// Exact as long as it is read at least once per half counter range of travel: the difference
/// between two reads is taken modulo 2^bits and interpreted as signed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CountExtender {
    bits: u32,
    last_raw: u32,
    count: i64,
    max_step: u32,
    glitches: u32,
    primed: bool,
}

/// Result of one counter read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CountUpdate {
    /// The extended count after this read.
    pub count: i64,
    /// The step from the previous read exceeded the plausible maximum (the count still
    /// follows the hardware; the sample is flagged).
    pub glitch: bool,
}

impl CountExtender {
    /// The same extender (count, last read, glitch count) with a new plausibility limit.
    pub const fn with_max_step(mut self, max_step: u32) -> Self {
        self.max_step = max_step;
        self
    }

    /// A new extender for a `bits`-bit counter (1…32; larger values are clamped to 32).
    /// `max_step` is the largest plausible change between two reads (axis max speed × read
    /// interval × counts per unit, with margin); 0 disables the check.
    pub const fn new(bits: u32, max_step: u32) -> Self {
        let bits = if bits == 0 {
            1
        } else if bits > 32 {
            32
        } else {
            bits
        };
        Self {
            bits,
            last_raw: 0,
            count: 0,
            max_step,
            glitches: 0,
            primed: false,
        }
    }

    /// Sets the extended count at the counter's last reading to `count` (referencing an axis
    /// that has been read); false, and nothing changes, before the first reading.
    pub fn rebase(&mut self, count: i64) -> bool {
        if self.primed {
            self.count = count;
        }
        self.primed
    }

    /// Sets the extended count to `count` at the hardware value `raw` (homing / reference).
    pub fn set(&mut self, raw: u32, count: i64) {
        self.last_raw = raw & self.mask();
        self.count = count;
        self.primed = true;
    }

    const fn mask(&self) -> u32 {
        if self.bits >= 32 {
            u32::MAX
        } else {
            (1u32 << self.bits) - 1
        }
    }

    /// Feeds the current hardware counter value. The first read defines count 0 unless
    /// [`CountExtender::set`] was called.
    pub fn update(&mut self, raw: u32) -> CountUpdate {
        let raw = raw & self.mask();
        if !self.primed {
            self.set(raw, 0);
            return CountUpdate {
                count: self.count,
                glitch: false,
            };
        }
        if raw == self.last_raw {
            // the axis stands still (most axes, most samples)
            return CountUpdate {
                count: self.count,
                glitch: false,
            };
        }
        // Signed difference modulo 2^bits: shift the value into the top bits of an i32 so the
        // wrap-around of the subtraction is the hardware's.
        let shift = 32 - self.bits;
        let step = ((raw.wrapping_sub(self.last_raw) << shift) as i32) >> shift;
        self.last_raw = raw;
        self.count = self.count.wrapping_add(i64::from(step));
        let glitch = self.max_step != 0 && step.unsigned_abs() > self.max_step;
        if glitch {
            self.glitches = self.glitches.saturating_add(1);
        }
        CountUpdate {
            count: self.count,
            glitch,
        }
    }

    /// The extended count.
    pub const fn count(&self) -> i64 {
        self.count
    }

    /// The plausibility limit, counts per read (0: off).
    pub const fn max_step(&self) -> u32 {
        self.max_step
    }

    /// Implausible steps seen since start.
    pub const fn glitches(&self) -> u32 {
        self.glitches
    }
}

/// The board's first stage of the count extension: the hardware counters
/// ([`ENCODER_COUNTER_BITS`] wide) read [`COUNTER_READS_PER_SAMPLE`] times a sample, in the
/// block-latch interrupt whatever else runs, and each extended to 64 bits there. The pipeline
/// takes the low 32 bits of these counts as a 32-bit counter (`counter_bits` = 32 in
/// [`Acquisition::new`](super::Acquisition::new)): a step of 2³¹ counts in one sample is
/// beyond any axis, so the second stage is exact and the first one decides what the pod
/// follows — the configuration's rule ([`Config::counter_reach`]).
///
/// [`ENCODER_COUNTER_BITS`]: crate::config::ENCODER_COUNTER_BITS
/// [`COUNTER_READS_PER_SAMPLE`]: crate::config::COUNTER_READS_PER_SAMPLE
/// [`Config::counter_reach`]: crate::config::Config::counter_reach
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CounterLatch {
    inputs: [CountExtender; MAX_AXES],
}

/// Width of the counts [`CounterLatch`] hands on, bits (the pipeline's `counter_bits`).
pub const LATCHED_COUNTER_BITS: [u32; MAX_AXES] = [32; MAX_AXES];

impl CounterLatch {
    /// The extension of counters `bits` wide, nothing read yet (the first read is count 0).
    pub const fn new(bits: [u32; MAX_AXES]) -> Self {
        let [b0, b1, b2, b3, b4] = bits;
        Self {
            inputs: [
                CountExtender::new(b0, 0),
                CountExtender::new(b1, 0),
                CountExtender::new(b2, 0),
                CountExtender::new(b3, 0),
                CountExtender::new(b4, 0),
            ],
        }
    }

    /// Feeds one read of the hardware counters; returns each extended count's low 32 bits.
    pub fn read(&mut self, raw: [u32; MAX_AXES]) -> [u32; MAX_AXES] {
        let mut out = [0; MAX_AXES];
        for ((o, e), r) in out.iter_mut().zip(self.inputs.iter_mut()).zip(raw) {
            *o = e.update(r).count as u32;
        }
        out
    }
}

/// Scaling of one axis: counts → mm (linear) or degrees (rotary).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisScale {
    /// Counts per mm (linear axis) or per degree (rotary axis), > 0.
    pub counts_per_unit: f64,
    /// Counting direction: `false` = counts up in the axis' positive direction.
    pub reversed: bool,
    /// ±1/`counts_per_unit` (the sign of the direction) as an unevaluated f32 sum hi + lo: the
    /// per-sample path multiplies, never divides.
    per_count: [f32; 2],
}

impl AxisScale {
    /// The scale of an axis with `counts_per_unit` counts per mm or degree, counting down in
    /// the positive direction if `reversed`.
    pub fn new(counts_per_unit: f64, reversed: bool) -> Self {
        let k = if reversed { -1.0 } else { 1.0 } / counts_per_unit;
        let hi = k as f32;
        Self {
            counts_per_unit,
            reversed,
            per_count: [hi, (k - f64::from(hi)) as f32],
        }
    }

    /// The extended count at `position` (mm / degrees), rounded to the nearest count; `None`
    /// for a position that is not finite or beyond ±[`POS_MM`](crate::config::POS_MM).
    pub fn count_at(&self, position: f64) -> Option<i64> {
        if !(position.abs() <= crate::config::POS_MM) {
            return None;
        }
        let c = libm::round(position * self.counts_per_unit);
        let c = if self.reversed { -c } else { c };
        // |c| ≤ POS_MM × the largest counts_per_unit the configuration accepts (1e8) = 1e12,
        // well inside i64; `as` saturates for a scale built outside the configuration
        Some(c as i64)
    }

    /// Position in mm or degrees of an extended count: the f32 nearest to the exact
    /// count / `counts_per_unit` but in rare near-ties, and within one ulp always, for
    /// |count| < 2⁴⁰ (the host tests check it against f64).
    ///
    /// In f32 on the FPU (no soft-float f64 division per axis and sample): |count| = h·2¹⁶ + l
    /// with h and l exact in f32 and of one sign (no cancellation), the factors as hi + lo
    /// pairs, the two leading products' rounding errors recovered exactly with fused
    /// multiply-adds and the sum's with Fast2Sum, so only the final addition rounds.
    pub fn position(&self, count: i64) -> f32 {
        use crate::num::fmaf;
        let m = count.unsigned_abs();
        let h = (m >> 16) as u32 as f32;
        let l = (m & 0xFFFF) as u32 as f32;
        let [kh, kl] = self.per_count;
        // 2¹⁶·k, exactly (a power of two)
        let (k16h, k16l) = (kh * 65_536.0, kl * 65_536.0);
        let a = h * k16h;
        let ea = fmaf(h, k16h, -a);
        let b = l * kh;
        let eb = fmaf(l, kh, -b);
        // Fast2Sum, exact because |a| ≥ |b| (h ≥ 1 makes a ≥ 2¹⁶·|k| > l·|k|) or a = 0
        let s = a + b;
        let es = b - (s - a);
        let p = s + (es + ea + eb + h * k16l + l * kl);
        let p = if count < 0 { -p } else { p };
        if p.is_finite() { p } else { 0.0 }
    }
}
