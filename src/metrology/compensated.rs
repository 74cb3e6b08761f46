//! Kahan-compensated f32 running sum (DESIGN §6).
//!
//! Why Kahan and not Welford or Givens for the running fits: the quantities summed are already
//! deviations (ΔL minus a reference in µm, unit-vector components), so their magnitudes are
//! bounded and a compensated sum keeps the error near one f32 rounding of the *total*
//! independently of N (plain f32 summation of 100 000 terms loses ~4 decimal digits). It costs
//! 4 flops per term, has no division (Welford needs one per sample) and no square root (a
//! Givens update needs three per sample), and the pair (sum, compensation) read back as f64 at
//! query time carries ~14 significant digits into the f64 solve.

/// A compensated (Kahan) f32 sum.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct KahanF32 {
    sum: f32,
    comp: f32,
}

impl KahanF32 {
    /// An empty sum.
    pub const ZERO: Self = Self {
        sum: 0.0,
        comp: 0.0,
    };

    /// Adds `x` (Kahan 1965; the compiler does not reassociate f32, so the compensation stays).
    #[inline(always)]
    pub fn add(&mut self, x: f32) {
        let y = x - self.comp;
        let t = self.sum + y;
        self.comp = (t - self.sum) - y;
        self.sum = t;
    }

    /// The sum, with its compensation folded in, as f64.
    #[inline]
    pub fn value(&self) -> f64 {
        f64::from(self.sum) - f64::from(self.comp)
    }

    /// The sum, with its compensation folded in, rounded to f32 (the live solves).
    #[inline(always)]
    pub fn value_f32(&self) -> f32 {
        self.sum - self.comp
    }
}
