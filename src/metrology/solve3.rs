//! Hand-written 3×3 symmetric solves: Cholesky factor, solve, inverse, Frobenius condition number
//! and the smallest eigenpair (DESIGN §6: ~150 instructions instead of ~420 for a general LU).
//!
//! f64 throughout: these run once per query (an estimate the CNC reads), not per sample. The
//! per-sample accumulation that feeds them is f32 or integer (see `circle_fit` and `ssm`).

/// Why a 3×3 symmetric system could not be solved.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Solve3Error {
    /// A Cholesky pivot was not positive beyond the relative tolerance: the matrix is singular
    /// (or indefinite) to working precision.
    NotPositiveDefinite,
    /// An entry of the matrix or the right-hand side is NaN or infinite.
    NotFinite,
}

/// A symmetric 3×3 matrix stored by its upper triangle (row-major: 00, 01, 02, 11, 12, 22).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sym3 {
    /// Entry (0,0).
    pub a00: f64,
    /// Entry (0,1) = (1,0).
    pub a01: f64,
    /// Entry (0,2) = (2,0).
    pub a02: f64,
    /// Entry (1,1).
    pub a11: f64,
    /// Entry (1,2) = (2,1).
    pub a12: f64,
    /// Entry (2,2).
    pub a22: f64,
}

/// Lower-triangular Cholesky factor L of a [`Sym3`] (A = L·Lᵀ).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chol3 {
    l00: f64,
    l10: f64,
    l20: f64,
    l11: f64,
    l21: f64,
    l22: f64,
}

/// Relative pivot tolerance of [`Sym3::cholesky`]: a pivot below this times the largest
/// diagonal entry means "singular to working precision" (f64 sums of f32 data carry ~1e-10).
pub const PIVOT_REL_TOL: f64 = 1e-12;

impl Sym3 {
    /// The matrix as rows.
    pub const fn rows(&self) -> [[f64; 3]; 3] {
        [
            [self.a00, self.a01, self.a02],
            [self.a01, self.a11, self.a12],
            [self.a02, self.a12, self.a22],
        ]
    }

    /// Trace (sum of the diagonal).
    pub fn trace(&self) -> f64 {
        self.a00 + self.a11 + self.a22
    }

    /// A·x.
    pub fn mul(&self, x: [f64; 3]) -> [f64; 3] {
        let [x0, x1, x2] = x;
        [
            self.a00 * x0 + self.a01 * x1 + self.a02 * x2,
            self.a01 * x0 + self.a11 * x1 + self.a12 * x2,
            self.a02 * x0 + self.a12 * x1 + self.a22 * x2,
        ]
    }

    /// self += s·v vᵀ.
    pub fn add_outer(&mut self, v: [f64; 3], s: f64) {
        let [v0, v1, v2] = v;
        self.a00 += s * v0 * v0;
        self.a01 += s * v0 * v1;
        self.a02 += s * v0 * v2;
        self.a11 += s * v1 * v1;
        self.a12 += s * v1 * v2;
        self.a22 += s * v2 * v2;
    }

    /// True if every entry is finite.
    pub fn is_finite(&self) -> bool {
        [self.a00, self.a01, self.a02, self.a11, self.a12, self.a22]
            .iter()
            .all(|v| v.is_finite())
    }

    /// Cholesky factorisation A = L·Lᵀ; fails if A is not positive definite to a relative pivot
    /// tolerance of [`PIVOT_REL_TOL`] times the largest diagonal entry.
    pub fn cholesky(&self) -> Result<Chol3, Solve3Error> {
        if !self.is_finite() {
            return Err(Solve3Error::NotFinite);
        }
        let scale = self.a00.abs().max(self.a11.abs()).max(self.a22.abs());
        let tol = PIVOT_REL_TOL * scale;
        let p0 = self.a00;
        if p0 <= tol || scale <= 0.0 {
            return Err(Solve3Error::NotPositiveDefinite);
        }
        let l00 = crate::num::sqrt(p0);
        let l10 = self.a01 / l00;
        let l20 = self.a02 / l00;
        let p1 = self.a11 - l10 * l10;
        if p1 <= tol {
            return Err(Solve3Error::NotPositiveDefinite);
        }
        let l11 = crate::num::sqrt(p1);
        let l21 = (self.a12 - l20 * l10) / l11;
        let p2 = self.a22 - l20 * l20 - l21 * l21;
        if p2 <= tol {
            return Err(Solve3Error::NotPositiveDefinite);
        }
        let l22 = crate::num::sqrt(p2);
        Ok(Chol3 {
            l00,
            l10,
            l20,
            l11,
            l21,
            l22,
        })
    }

    /// Solves A·x = b by Cholesky.
    pub fn solve(&self, b: [f64; 3]) -> Result<[f64; 3], Solve3Error> {
        if !crate::num::all_finite(&b) {
            return Err(Solve3Error::NotFinite);
        }
        Ok(self.cholesky()?.solve(b))
    }

    /// Frobenius condition number ‖A‖_F·‖A⁻¹‖_F of the *square root* of A in the sense used by
    /// seed 000 C.1 (TV-SSM-cond): for A = UᵀU, this returns ‖U‖_F·‖U⁺‖_F =
    /// √(trace A · trace A⁻¹). Invariant to scaling A.
    pub fn cond_frobenius_of_root(&self) -> Result<f64, Solve3Error> {
        let inv = self.cholesky()?.inverse();
        Ok(crate::num::sqrt(self.trace() * inv.trace()))
    }

    /// Eigenvalues in ascending order (closed-form trigonometric method for symmetric 3×3,
    /// O. K. Smith, CACM 4(4) 1961) and a unit eigenvector of the smallest one.
    pub fn eigen_smallest(&self) -> ([f64; 3], [f64; 3]) {
        let p1 = self.a01 * self.a01 + self.a02 * self.a02 + self.a12 * self.a12;
        let q = self.trace() / 3.0;
        let (l_min, l_mid, l_max) = if p1 <= 1e-300 {
            sort3(self.a00, self.a11, self.a22)
        } else {
            let d0 = self.a00 - q;
            let d1 = self.a11 - q;
            let d2 = self.a22 - q;
            let p2 = d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * p1;
            let p = crate::num::sqrt(p2 / 6.0);
            // B = (A − qI)/p; r = det(B)/2 ∈ [−1, 1]
            let det = d0 * (d1 * d2 - self.a12 * self.a12)
                - self.a01 * (self.a01 * d2 - self.a12 * self.a02)
                + self.a02 * (self.a01 * self.a12 - d1 * self.a02);
            let r = (det / (p * p * p) / 2.0).clamp(-1.0, 1.0);
            let phi = crate::num::acos(r) / 3.0;
            let e_max = q + 2.0 * p * crate::num::cos(phi);
            let e_min = q + 2.0 * p * crate::num::cos(phi + 2.0 * core::f64::consts::PI / 3.0);
            let e_mid = 3.0 * q - e_max - e_min;
            (e_min, e_mid, e_max)
        };
        // Eigenvector of l_min: the largest cross product of two rows of (A − λI).
        let [r0, r1, r2] = self.rows();
        let s = |r: [f64; 3], i: usize| -> [f64; 3] {
            let mut o = r;
            if let Some(v) = o.get_mut(i) {
                *v -= l_min;
            }
            o
        };
        let (r0, r1, r2) = (s(r0, 0), s(r1, 1), s(r2, 2));
        let cands = [cross(r0, r1), cross(r0, r2), cross(r1, r2)];
        let mut best = [0.0, 0.0, 1.0];
        let mut best_n = 0.0;
        for c in cands {
            let n = dot(c, c);
            if n > best_n {
                best_n = n;
                best = c;
            }
        }
        let v = if best_n > 0.0 {
            let inv = 1.0 / crate::num::sqrt(best_n);
            [best[0] * inv, best[1] * inv, best[2] * inv]
        } else {
            best
        };
        ([l_min, l_mid, l_max], v)
    }
}

impl Chol3 {
    /// Solves L·Lᵀ·x = b.
    pub fn solve(&self, b: [f64; 3]) -> [f64; 3] {
        let [b0, b1, b2] = b;
        // forward: L y = b
        let y0 = b0 / self.l00;
        let y1 = (b1 - self.l10 * y0) / self.l11;
        let y2 = (b2 - self.l20 * y0 - self.l21 * y1) / self.l22;
        // backward: Lᵀ x = y
        let x2 = y2 / self.l22;
        let x1 = (y1 - self.l21 * x2) / self.l11;
        let x0 = (y0 - self.l10 * x1 - self.l20 * x2) / self.l00;
        [x0, x1, x2]
    }

    /// A⁻¹ (symmetric), column by column.
    pub fn inverse(&self) -> Sym3 {
        let c0 = self.solve([1.0, 0.0, 0.0]);
        let c1 = self.solve([0.0, 1.0, 0.0]);
        let c2 = self.solve([0.0, 0.0, 1.0]);
        Sym3 {
            a00: c0[0],
            a01: c1[0],
            a02: c2[0],
            a11: c1[1],
            a12: c2[1],
            a22: c2[2],
        }
    }
}

fn sort3(a: f64, b: f64, c: f64) -> (f64, f64, f64) {
    let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
    if c <= lo {
        (c, lo, hi)
    } else if c <= hi {
        (lo, c, hi)
    } else {
        (lo, hi, c)
    }
}

/// Cross product a × b.
pub fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Dot product a · b.
pub fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// A float the generic [`cholesky_solve`] runs in: f64 for the host's fits, f32 for the pod's
/// once-per-run diagnostics on the M4F's FPU (a quarter of the f64 soft-float code).
pub trait SolveFloat:
    Copy
    + PartialOrd
    + core::ops::Add<Output = Self>
    + core::ops::Sub<Output = Self>
    + core::ops::Mul<Output = Self>
    + core::ops::Div<Output = Self>
    + core::ops::SubAssign
{
    /// 0.
    const ZERO: Self;
    /// The relative pivot tolerance (a pivot below it × the largest diagonal: singular).
    const PIVOT_TOL: Self;
    /// √x (the M4F's VSQRT for f32).
    fn sqrt(self) -> Self;
    /// |x|.
    fn abs(self) -> Self;
    /// Neither NaN nor infinite.
    fn is_finite(self) -> bool;
}

impl SolveFloat for f64 {
    const ZERO: Self = 0.0;
    const PIVOT_TOL: Self = PIVOT_REL_TOL;
    fn sqrt(self) -> Self {
        crate::num::sqrt(self)
    }
    fn abs(self) -> Self {
        libm::fabs(self)
    }
    fn is_finite(self) -> bool {
        f64::is_finite(self)
    }
}

impl SolveFloat for f32 {
    const ZERO: Self = 0.0;
    /// f32 sums carry ~1e-7: a pivot below 1e-6 of the largest diagonal is singular.
    const PIVOT_TOL: Self = 1e-6;
    fn sqrt(self) -> Self {
        crate::num::sqrtf(self)
    }
    fn abs(self) -> Self {
        libm::fabsf(self)
    }
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
}

/// Solves the symmetric positive definite system `a x = b` (N ≤ 16) by Cholesky, reading only
/// the lower triangle of `a` (the upper may be left unfilled); `None` if `a`
/// is not positive definite to working precision (a pivot below [`SolveFloat::PIVOT_TOL`] × the
/// largest diagonal) or not finite. Hand-written for the same reason as [`Sym3`]: a fixed-size
/// solve in a few hundred bytes of code, where nalgebra's generic one costs kilobytes of flash
/// per size.
pub fn cholesky_solve<T: SolveFloat, const N: usize>(a: [[T; N]; N], b: [T; N]) -> Option<[T; N]> {
    let mut l = [[T::ZERO; N]; N];
    let mut x = b;
    cholesky_in(a.as_flattened(), l.as_flattened_mut(), &mut x)?;
    Some(x)
}

/// [`cholesky_solve`] on row-major `n × n` slices (`n` = `x.len()`), `x` holding `b` in and the
/// solution out: one body per float type whatever the size — each size's own copy cost about
/// 560 bytes of flash. The operations and their order are the array version's.
#[inline(never)]
fn cholesky_in<T: SolveFloat>(a: &[T], l: &mut [T], x: &mut [T]) -> Option<()> {
    let n = x.len();
    let scale = (0..n)
        .filter_map(|i| a.get(i * n + i))
        .fold(T::ZERO, |m, v| if v.abs() > m { v.abs() } else { m });
    if !(scale > T::ZERO && scale.is_finite()) {
        return None;
    }
    // lower factor L, row by row: a = L Lᵀ
    for i in 0..n {
        for j in 0..=i {
            let mut s = *a.get(i * n + j)?;
            for k in 0..j {
                s -= *l.get(i * n + k)? * *l.get(j * n + k)?;
            }
            let v = if i == j {
                if !(s > T::PIVOT_TOL * scale) {
                    return None;
                }
                s.sqrt()
            } else {
                s / *l.get(j * n + j)?
            };
            *l.get_mut(i * n + j)? = v;
        }
    }
    // L y = b, then Lᵀ x = y, each in place in x
    for i in 0..n {
        let mut s = *x.get(i)?;
        for k in 0..i {
            s -= *l.get(i * n + k)? * *x.get(k)?;
        }
        *x.get_mut(i)? = s / *l.get(i * n + i)?;
    }
    for i in (0..n).rev() {
        let mut s = *x.get(i)?;
        for k in (i + 1)..n {
            s -= *l.get(k * n + i)? * *x.get(k)?;
        }
        *x.get_mut(i)? = s / *l.get(i * n + i)?;
    }
    x.iter().all(|v| v.is_finite()).then_some(())
}
