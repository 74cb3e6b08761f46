//! Streaming linear least squares in f64 with a rank and conditioning check, in fixed memory.
//!
//! Every identification method of the pod ends in an over-determined linear system
//! `A x ≈ b` (one row per measured value). Rows arrive one at a time, so the system is reduced
//! on the fly to its `N × N` triangular factor `R` by Givens rotations (numerically as good as a
//! batch QR, memory `O(N²)` whatever the number of rows; normal equations would square the
//! condition number). At the end the singular values of `R` — which are those of `A` — give
//! the rank and condition number (DESIGN §6: "QR/SVD for least squares with a rank and
//! conditioning check"), and the solution, its standard uncertainties and, when the system is
//! rank-deficient, the parameter combinations the data cannot separate (the null space).

/// Why a least-squares problem could not be solved.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LsqError {
    /// A row or right-hand side held a NaN or an infinity (row index given).
    NonFinite {
        /// Zero-based index of the offending row.
        row: u32,
    },
    /// Fewer rows than unknowns were added.
    TooFewRows {
        /// Rows added.
        rows: u32,
        /// Unknowns.
        unknowns: usize,
    },
    /// The SVD did not converge (never seen on finite input; reported rather than guessed).
    NoConvergence,
    /// The data cannot separate all unknowns: `rank < N`. The weakest parameter combination
    /// (the right singular vector of the smallest singular value: adding any multiple of it to
    /// the solution changes no residual) is in [`LsqSolution::right_singular_vectors`];
    /// `weakest_param` is the unknown with the largest share in it.
    RankDeficient {
        /// Numerical rank found.
        rank: usize,
        /// Index of the unknown with the largest component in the weakest combination.
        weakest_param: usize,
    },
}

/// The solution of a least-squares problem with its quality figures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LsqSolution<const N: usize> {
    /// The least-squares estimate of the unknowns (minimum-norm where rank-deficient).
    pub x: [f64; N],
    /// Standard uncertainty of each unknown, `s·sqrt((AᵀA)⁻¹_ii)` with `s²` the residual
    /// variance `RSS / (m − N)`; 0 when there is no redundancy (m = N).
    pub std_uncertainty: [f64; N],
    /// Singular values of the design matrix, largest first.
    pub singular_values: [f64; N],
    /// Numerical rank (singular values above `rel_tol · σ_max`).
    pub rank: usize,
    /// Condition number σ_max / σ_min of the design matrix (infinite if rank-deficient).
    pub condition: f64,
    /// Root mean square of the residuals `b − A x`, in the unit of `b`.
    pub residual_rms: f64,
    /// Number of rows used.
    pub rows: u32,
    /// Right singular vectors (rows of Vᵀ), same order as `singular_values`: the trailing
    /// `N − rank` of them span the combinations the data cannot separate.
    pub right_singular_vectors: [[f64; N]; N],
}

impl<const N: usize> LsqSolution<N> {
    /// Correlation coefficient of the errors of unknowns `i` and `j`, from the same
    /// `(AᵀA)⁻¹` as [`Self::std_uncertainty`] (over the resolved singular values); 0 when
    /// either has no variance or an index is out of range.
    pub fn correlation(&self, i: usize, j: usize) -> f64 {
        let d = crate::num::sqrt(self.cofactor(i, i) * self.cofactor(j, j));
        if d > 0.0 {
            self.cofactor(i, j) / d
        } else {
            0.0
        }
    }

    /// Element (i, j) of `(AᵀA)⁻¹` over the resolved singular values, in (unit of x)² per
    /// (unit of b)²: the covariance of unknowns i and j per unit variance of each row's b
    /// (weighted rows: per unit variance at weight 1). 0 when an index is out of range.
    pub fn cofactor(&self, i: usize, j: usize) -> f64 {
        let mut c = 0.0;
        for (sigma, v) in self
            .singular_values
            .iter()
            .zip(self.right_singular_vectors.iter())
            .take(self.rank)
        {
            let (Some(vi), Some(vj)) = (v.get(i), v.get(j)) else {
                return 0.0;
            };
            c += vi * vj / (sigma * sigma);
        }
        c
    }
}

/// Default relative tolerance for the numerical rank: a singular value below
/// `1e-10 · σ_max` counts as zero (f64 carries ~16 digits; identification Jacobians mix mm and
/// µrad scales of ~1e6 at most, so true rank deficiency sits many decades below this).
pub const DEFAULT_RANK_TOL: f64 = 1e-10;

/// The working arrays of [`GivensLsq::solve_in`]'s SVD (3·8·N² bytes; every element is
/// written before it is read).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SvdScratch<const N: usize> {
    cols: [[f64; N]; N],
    v: [[f64; N]; N],
    u_cols: [[f64; N]; N],
}

impl<const N: usize> SvdScratch<N> {
    /// All zero (a memset, not an image in flash).
    pub const EMPTY: Self = Self {
        cols: [[0.0; N]; N],
        v: [[0.0; N]; N],
        u_cols: [[0.0; N]; N],
    };
}

/// Givens-rotation accumulator for `A x ≈ b` with `N` unknowns (state: `8·(N² + N + 1)` bytes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GivensLsq<const N: usize> {
    /// Upper-triangular factor R (row-major; lower part stays zero).
    r: [[f64; N]; N],
    /// First N entries of Qᵀb.
    qtb: [f64; N],
    /// Sum of squares of the part of b no combination of columns can explain (the RSS).
    rss: f64,
    /// Rows added.
    rows: u32,
}

impl<const N: usize> Default for GivensLsq<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> GivensLsq<N> {
    /// An empty problem.
    pub const fn new() -> Self {
        Self {
            r: [[0.0; N]; N],
            qtb: [0.0; N],
            rss: 0.0,
            rows: 0,
        }
    }

    /// Rows added so far.
    pub const fn rows(&self) -> u32 {
        self.rows
    }

    /// Adds the equation `a · x = b` with weight `w` (w = 1/σ² of b for weighted least squares;
    /// 1 for ordinary). Non-finite input is rejected and leaves the state unchanged.
    pub fn add_row(&mut self, a: &[f64; N], b: f64, w: f64) -> Result<(), LsqError> {
        if !(b.is_finite() && w.is_finite() && w >= 0.0 && crate::num::all_finite(a)) {
            return Err(LsqError::NonFinite { row: self.rows });
        }
        let mut x = *a;
        let y = rotate_in(self.r.as_flattened_mut(), &mut self.qtb, &mut x, b, w);
        self.rss += y * y;
        self.rows = self.rows.saturating_add(1);
        Ok(())
    }

    /// Solves the accumulated problem. Rank-deficient problems are solved in the minimum-norm
    /// sense and reported through `rank`, `condition` and `right_singular_vectors`; callers
    /// that need every unknown use [`GivensLsq::solve_full_rank`].
    #[inline(always)] // the SVD's frame is solve_in's; the scratch, 3·8·N² B, the caller's
    pub fn solve(&self, rel_tol: f64) -> Result<LsqSolution<N>, LsqError> {
        let mut scratch = SvdScratch::EMPTY;
        self.solve_in(rel_tol, &mut scratch)
    }

    /// [`GivensLsq::solve`] with the SVD's working arrays in the caller's `scratch` (the seed
    /// 002 identification's: 4 KiB off the worker's deepest chain of calls).
    // (stack: its SVD work stays out of the callers' frames, where the worker's deepest chain,
    // the seed 002 identification, needs the room)
    #[inline(never)]
    pub fn solve_in(
        &self,
        rel_tol: f64,
        scratch: &mut SvdScratch<N>,
    ) -> Result<LsqSolution<N>, LsqError> {
        if (self.rows as usize) < N {
            return Err(LsqError::TooFewRows {
                rows: self.rows,
                unknowns: N,
            });
        }
        let mut out = LsqSolution {
            x: [0.0; N],
            std_uncertainty: [0.0; N],
            singular_values: [0.0; N],
            rank: 0,
            condition: f64::INFINITY,
            residual_rms: crate::num::sqrt(self.rss / f64::from(self.rows.max(1))),
            rows: self.rows,
            right_singular_vectors: [[0.0; N]; N],
        };
        let SvdScratch { cols, v, u_cols } = scratch;
        let mut norms = [0.0f64; N];
        let mut order = [0usize; N];
        let svd = Svd {
            cols: cols.as_flattened_mut(),
            v: v.as_flattened_mut(),
            norms: &mut norms,
            order: &mut order,
            sigma: &mut out.singular_values,
            u_cols: u_cols.as_flattened_mut(),
            v_rows: out.right_singular_vectors.as_flattened_mut(),
        };
        if !svd.of(self.r.as_flattened()) {
            return Err(LsqError::NoConvergence);
        }
        // Residual variance from the rotations' RSS; a minimum-norm solution of a
        // rank-deficient system leaves the same residual.
        let m_minus_n = (self.rows as usize).saturating_sub(N);
        let s2 = if m_minus_n > 0 {
            self.rss / m_minus_n as f64
        } else {
            0.0
        };
        (out.rank, out.condition) = pseudo_inverse(
            &out.singular_values,
            u_cols.as_flattened(),
            out.right_singular_vectors.as_flattened(),
            &self.qtb,
            s2,
            rel_tol,
            &mut out.x,
            &mut out.std_uncertainty,
        );
        Ok(out)
    }

    /// Solves and insists on full rank: a rank-deficient problem is an error naming the
    /// unknown most involved in the weakest parameter combination.
    pub fn solve_full_rank(&self, rel_tol: f64) -> Result<LsqSolution<N>, LsqError> {
        let sol = self.solve(rel_tol)?;
        if sol.rank < N {
            let weakest_param = sol
                .right_singular_vectors
                .last()
                .and_then(|v| {
                    v.iter()
                        .enumerate()
                        .max_by(|a, b| libm::fabs(*a.1).total_cmp(&libm::fabs(*b.1)))
                        .map(|(i, _)| i)
                })
                .unwrap_or(0);
            return Err(LsqError::RankDeficient {
                rank: sol.rank,
                weakest_param,
            });
        }
        Ok(sol)
    }
}

// The arithmetic below works on slices with a run-time size, not on `[f64; N]`: one copy in
// flash serves every N the pod uses (3, 4, 13, …), where a const-generic copy per N cost ~5 KB.

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b.iter()).map(|(x, y)| x * y).sum()
}

/// Rotates the weighted row `√w·(x, b)` into R (`n × n` row-major, n = `x.len()`) and Qᵀb by
/// Givens rotations; returns what is left of `√w·b`, the row's contribution to the RSS.
#[inline(never)] // one copy for every N
fn rotate_in(r: &mut [f64], qtb: &mut [f64], x: &mut [f64], b: f64, w: f64) -> f64 {
    let n = x.len();
    let sw = crate::num::sqrt(w);
    x.iter_mut().for_each(|v| *v *= sw);
    let mut y = b * sw;
    if n == 0 {
        return y;
    }
    for (k, (r_row, qtb_k)) in r.chunks_exact_mut(n).zip(qtb.iter_mut()).enumerate() {
        let (Some(&rkk), Some(&xk)) = (r_row.get(k), x.get(k)) else {
            break;
        };
        if xk == 0.0 {
            continue;
        }
        let h = crate::num::hypot(rkk, xk);
        let (c, s) = (rkk / h, xk / h);
        for (rj, xj) in r_row.iter_mut().zip(x.iter_mut()).skip(k) {
            let t = c * *rj + s * *xj;
            *xj = c * *xj - s * *rj;
            *rj = t;
        }
        let t = c * *qtb_k + s * y;
        y = c * y - s * *qtb_k;
        *qtb_k = t;
    }
    y
}

/// The solution through the SVD of R = U Σ Vᵀ (the pseudo-inverse): x = Σ v (uᵀQᵀb)/σ and
/// var_j = s²·Σ v_j²/σ² over the singular values above `rel_tol·σ_max`. Returns the rank and
/// the condition number (infinite when rank-deficient).
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn pseudo_inverse(
    sigma: &[f64],
    u_cols: &[f64],
    v_rows: &[f64],
    qtb: &[f64],
    s2: f64,
    rel_tol: f64,
    x: &mut [f64],
    std_u: &mut [f64],
) -> (usize, f64) {
    let n = sigma.len();
    if n == 0 {
        return (0, f64::INFINITY);
    }
    let s_max = sigma.first().copied().unwrap_or(0.0);
    let mut rank = 0;
    // std_u holds the variance factors until the end
    for ((&s, u), v) in sigma
        .iter()
        .zip(u_cols.chunks_exact(n))
        .zip(v_rows.chunks_exact(n))
    {
        if s <= rel_tol * s_max || s == 0.0 {
            continue;
        }
        rank += 1;
        let coef = dot(u, qtb) / s;
        for ((xj, vj), &v_j) in x.iter_mut().zip(std_u.iter_mut()).zip(v.iter()) {
            *xj += v_j * coef;
            *vj += v_j * v_j / (s * s);
        }
    }
    std_u
        .iter_mut()
        .for_each(|u| *u = crate::num::sqrt(s2 * *u));
    let s_min = sigma.last().copied().unwrap_or(0.0);
    let condition = if rank == n && s_min > 0.0 {
        s_max / s_min
    } else {
        f64::INFINITY
    };
    (rank, condition)
}

/// SVD of a square `n × n` matrix by one-sided (Hestenes) Jacobi rotations, in the caller's
/// storage (all `n × n` row-major, n = `sigma.len()`).
///
/// Hand-written because nalgebra's SVD cannot be called generically over a const `N` without
/// allocator/typenum bounds leaking into every caller; one-sided Jacobi is short, needs no
/// allocation, and is accurate to working precision for the small `N` (≤ 16) used here.
struct Svd<'a> {
    /// Work: the columns of A, one per row (`cols[j][i] = A[i][j]`), rotated.
    cols: &'a mut [f64],
    /// Work: the accumulated rotations (`v[j]` = column j of V).
    v: &'a mut [f64],
    /// Work: the columns' norms.
    norms: &'a mut [f64],
    /// Work: the columns in order of decreasing norm.
    order: &'a mut [usize],
    /// Singular values, decreasing.
    sigma: &'a mut [f64],
    /// Left singular vectors (as columns, stored one per row), same order.
    u_cols: &'a mut [f64],
    /// Right singular vectors (rows of Vᵀ), same order.
    v_rows: &'a mut [f64],
}

impl Svd<'_> {
    /// Max sweeps; one-sided Jacobi converges quadratically, 30 sweeps is far beyond need.
    const MAX_SWEEPS: usize = 30;

    /// Decomposes `a` (`n × n` row-major); `false` if the sweeps did not converge.
    #[inline(never)]
    fn of(self, a: &[f64]) -> bool {
        let n = self.sigma.len();
        if n == 0 {
            return true;
        }
        let Self {
            cols,
            v,
            norms,
            order,
            sigma,
            u_cols,
            v_rows,
        } = self;
        for (i, row) in a.chunks_exact(n).enumerate() {
            for (j, &x) in row.iter().enumerate() {
                if let Some(c) = cols.get_mut(j * n + i) {
                    *c = x;
                }
            }
        }
        v.iter_mut().for_each(|x| *x = 0.0);
        for j in 0..n {
            if let Some(d) = v.get_mut(j * n + j) {
                *d = 1.0;
            }
        }
        // Columns whose squared norm is below (ε·‖A‖_F)² are rounding noise: rotating them
        // against each other never settles, and they are zero singular values anyway.
        let frob2: f64 = cols.chunks_exact(n).map(|c| dot(c, c)).sum();
        let negligible = f64::EPSILON * f64::EPSILON * frob2;
        let mut converged = false;
        for _ in 0..Self::MAX_SWEEPS {
            let mut off = 0.0f64;
            for p in 0..n {
                for q in (p + 1)..n {
                    let (Some(cp), Some(cq)) =
                        (cols.get(p * n..(p + 1) * n), cols.get(q * n..(q + 1) * n))
                    else {
                        continue;
                    };
                    let (alpha, beta, gamma) = (dot(cp, cp), dot(cq, cq), dot(cp, cq));
                    if alpha <= negligible
                        || beta <= negligible
                        || gamma == 0.0
                        || libm::fabs(gamma) <= f64::EPSILON * crate::num::sqrt(alpha * beta)
                    {
                        continue;
                    }
                    off = off.max(libm::fabs(gamma) / crate::num::sqrt(alpha * beta));
                    let zeta = (beta - alpha) / (2.0 * gamma);
                    let t = libm::copysign(1.0, zeta)
                        / (libm::fabs(zeta) + crate::num::hypot(1.0, zeta));
                    let c = 1.0 / crate::num::hypot(1.0, t);
                    let s = c * t;
                    rotate_pair(cols, n, p, q, c, s);
                    rotate_pair(v, n, p, q, c, s);
                }
            }
            if off <= 4.0 * f64::EPSILON {
                converged = true;
                break;
            }
        }
        if !converged {
            return false;
        }
        for (s, c) in norms.iter_mut().zip(cols.chunks_exact(n)) {
            *s = crate::num::sqrt(dot(c, c));
        }
        // decreasing norm, by insertion (n ≤ 16; core's slice sort would be 2 KB of flash)
        let norm = |j: usize| norms.get(j).copied().unwrap_or(0.0);
        for i in 0..n {
            let mut k = i;
            while let Some(&prev) = k.checked_sub(1).and_then(|p| order.get(p)) {
                if norm(prev).total_cmp(&norm(i)).is_ge() {
                    break;
                }
                if let Some(o) = order.get_mut(k) {
                    *o = prev;
                }
                k -= 1;
            }
            if let Some(o) = order.get_mut(k) {
                *o = i;
            }
        }
        for ((k, &j), s) in order.iter().enumerate().zip(sigma.iter_mut()) {
            let norm = norms.get(j).copied().unwrap_or(0.0);
            *s = norm;
            if let (Some(u), Some(c), true) = (
                u_cols.get_mut(k * n..(k + 1) * n),
                cols.get(j * n..(j + 1) * n),
                norm > 0.0,
            ) {
                u.iter_mut().zip(c.iter()).for_each(|(u, c)| *u = c / norm);
            }
            if let (Some(dst), Some(src)) = (
                v_rows.get_mut(k * n..(k + 1) * n),
                v.get(j * n..(j + 1) * n),
            ) {
                dst.copy_from_slice(src);
            }
        }
        true
    }
}

/// Applies the plane rotation (c, s) to rows p and q of the `n`-column matrix `m`:
/// p' = c p − s q, q' = s p + c q.
fn rotate_pair(m: &mut [f64], n: usize, p: usize, q: usize, c: f64, s: f64) {
    for i in 0..n {
        let (Some(&x), Some(&y)) = (m.get(p * n + i), m.get(q * n + i)) else {
            return;
        };
        if let Some(a) = m.get_mut(p * n + i) {
            *a = c * x - s * y;
        }
        if let Some(b) = m.get_mut(q * n + i) {
            *b = s * x + c * y;
        }
    }
}
