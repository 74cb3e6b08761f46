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

/// Default relative tolerance for the numerical rank: a singular value below
/// `1e-10 · σ_max` counts as zero (f64 carries ~16 digits; identification Jacobians mix mm and
/// µrad scales of ~1e6 at most, so true rank deficiency sits many decades below this).
pub const DEFAULT_RANK_TOL: f64 = 1e-10;

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
        let sw = libm::sqrt(w);
        let mut x = *a;
        x.iter_mut().for_each(|v| *v *= sw);
        let mut y = b * sw;
        for (k, (r_row, qtb_k)) in self.r.iter_mut().zip(self.qtb.iter_mut()).enumerate() {
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
        self.rss += y * y;
        self.rows = self.rows.saturating_add(1);
        Ok(())
    }

    /// Solves the accumulated problem. Rank-deficient problems are solved in the minimum-norm
    /// sense and reported through `rank`, `condition` and `right_singular_vectors`; callers
    /// that need every unknown use [`GivensLsq::solve_full_rank`].
    pub fn solve(&self, rel_tol: f64) -> Result<LsqSolution<N>, LsqError> {
        if (self.rows as usize) < N {
            return Err(LsqError::TooFewRows {
                rows: self.rows,
                unknowns: N,
            });
        }
        let svd = JacobiSvd::of(&self.r).ok_or(LsqError::NoConvergence)?;
        let s_max = svd.sigma.first().copied().unwrap_or(0.0);
        let m_minus_n = (self.rows as usize).saturating_sub(N);
        // Residual variance from the rotations' RSS; a minimum-norm solution of a
        // rank-deficient system leaves the same residual.
        let s2 = if m_minus_n > 0 {
            self.rss / m_minus_n as f64
        } else {
            0.0
        };
        let mut out = LsqSolution {
            x: [0.0; N],
            std_uncertainty: [0.0; N],
            singular_values: svd.sigma,
            rank: 0,
            condition: f64::INFINITY,
            residual_rms: libm::sqrt(self.rss / f64::from(self.rows.max(1))),
            rows: self.rows,
            right_singular_vectors: svd.v_rows,
        };
        let mut var = [0.0f64; N];
        for ((&s, u), v) in svd
            .sigma
            .iter()
            .zip(svd.u_cols.iter())
            .zip(svd.v_rows.iter())
        {
            if s <= rel_tol * s_max || s == 0.0 {
                continue;
            }
            out.rank += 1;
            // x += v (uᵀ Qᵀb) / s ;  var_j += v_j² / s²   (pseudo-inverse through the SVD of R)
            let coef = dot(u, &self.qtb) / s;
            for ((xj, vj), &v_j) in out.x.iter_mut().zip(var.iter_mut()).zip(v.iter()) {
                *xj += v_j * coef;
                *vj += v_j * v_j / (s * s);
            }
        }
        let s_min = svd.sigma.last().copied().unwrap_or(0.0);
        if out.rank == N && s_min > 0.0 {
            out.condition = s_max / s_min;
        }
        out.std_uncertainty
            .iter_mut()
            .zip(var.iter())
            .for_each(|(u, v)| *u = libm::sqrt(s2 * v));
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

fn dot<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
    a.iter().zip(b.iter()).map(|(x, y)| x * y).sum()
}

/// SVD of a square `N × N` matrix by one-sided (Hestenes) Jacobi rotations.
///
/// Hand-written because nalgebra's SVD cannot be called generically over a const `N` without
/// allocator/typenum bounds leaking into every caller; one-sided Jacobi is short, needs no
/// allocation, and is accurate to working precision for the small `N` (≤ 16) used here.
struct JacobiSvd<const N: usize> {
    /// Singular values, decreasing.
    sigma: [f64; N],
    /// Left singular vectors (as columns, stored one per array), same order.
    u_cols: [[f64; N]; N],
    /// Right singular vectors (rows of Vᵀ), same order.
    v_rows: [[f64; N]; N],
}

impl<const N: usize> JacobiSvd<N> {
    /// Max sweeps; one-sided Jacobi converges quadratically, 30 sweeps is far beyond need.
    const MAX_SWEEPS: usize = 30;

    fn of(a: &[[f64; N]; N]) -> Option<Self> {
        // Work on the columns of A: cols[j][i] = A[i][j].
        let mut cols = [[0.0f64; N]; N];
        for (i, row) in a.iter().enumerate() {
            for (j, &v) in row.iter().enumerate() {
                if let Some(c) = cols.get_mut(j).and_then(|c| c.get_mut(i)) {
                    *c = v;
                }
            }
        }
        let mut v = [[0.0f64; N]; N]; // v[j] = column j of V
        v.iter_mut().enumerate().for_each(|(j, c)| {
            if let Some(d) = c.get_mut(j) {
                *d = 1.0;
            }
        });
        // Columns whose squared norm is below (ε·‖A‖_F)² are rounding noise: rotating them
        // against each other never settles, and they are zero singular values anyway.
        let frob2: f64 = cols.iter().map(|c| dot(c, c)).sum();
        let negligible = f64::EPSILON * f64::EPSILON * frob2;
        let mut converged = false;
        for _ in 0..Self::MAX_SWEEPS {
            let mut off = 0.0f64;
            for p in 0..N {
                for q in (p + 1)..N {
                    let (Some(cp), Some(cq)) = (cols.get(p), cols.get(q)) else {
                        continue;
                    };
                    let (alpha, beta, gamma) = (dot(cp, cp), dot(cq, cq), dot(cp, cq));
                    if alpha <= negligible
                        || beta <= negligible
                        || gamma == 0.0
                        || libm::fabs(gamma) <= f64::EPSILON * libm::sqrt(alpha * beta)
                    {
                        continue;
                    }
                    off = off.max(libm::fabs(gamma) / libm::sqrt(alpha * beta));
                    let zeta = (beta - alpha) / (2.0 * gamma);
                    let t = libm::copysign(1.0, zeta)
                        / (libm::fabs(zeta) + crate::num::hypot(1.0, zeta));
                    let c = 1.0 / crate::num::hypot(1.0, t);
                    let s = c * t;
                    rotate_pair(&mut cols, p, q, c, s);
                    rotate_pair(&mut v, p, q, c, s);
                }
            }
            if off <= 4.0 * f64::EPSILON {
                converged = true;
                break;
            }
        }
        if !converged {
            return None;
        }
        let mut norms = [0.0f64; N];
        norms
            .iter_mut()
            .zip(cols.iter())
            .for_each(|(n, c)| *n = libm::sqrt(dot(c, c)));
        let mut order = [0usize; N];
        order.iter_mut().enumerate().for_each(|(i, o)| *o = i);
        order.sort_unstable_by(|&x, &y| {
            let (nx, ny) = (
                norms.get(x).copied().unwrap_or(0.0),
                norms.get(y).copied().unwrap_or(0.0),
            );
            ny.total_cmp(&nx)
        });
        let mut out = Self {
            sigma: [0.0; N],
            u_cols: [[0.0; N]; N],
            v_rows: [[0.0; N]; N],
        };
        for (k, &j) in order.iter().enumerate() {
            let sigma = norms.get(j).copied().unwrap_or(0.0);
            if let Some(s) = out.sigma.get_mut(k) {
                *s = sigma;
            }
            if let (Some(u), Some(c), true) = (out.u_cols.get_mut(k), cols.get(j), sigma > 0.0) {
                u.iter_mut().zip(c.iter()).for_each(|(u, c)| *u = c / sigma);
            }
            if let (Some(dst), Some(src)) = (out.v_rows.get_mut(k), v.get(j)) {
                *dst = *src;
            }
        }
        Some(out)
    }
}

/// Applies the plane rotation (c, s) to vectors p and q of `m`: p' = c p − s q, q' = s p + c q.
fn rotate_pair<const N: usize>(m: &mut [[f64; N]; N], p: usize, q: usize, c: f64, s: f64) {
    let (Some(&vp), Some(&vq)) = (m.get(p), m.get(q)) else {
        return;
    };
    let mut np = vp;
    let mut nq = vq;
    for ((a, b), (&x, &y)) in np
        .iter_mut()
        .zip(nq.iter_mut())
        .zip(vp.iter().zip(vq.iter()))
    {
        *a = c * x - s * y;
        *b = s * x + c * y;
    }
    if let Some(d) = m.get_mut(p) {
        *d = np;
    }
    if let Some(d) = m.get_mut(q) {
        *d = nq;
    }
}
