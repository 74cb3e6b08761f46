//! Circle and sphere fits to touch-probe points (issue 3 item 4; seed 002 §6, TV-13).
//!
//! Two stages, f64 and nalgebra fixed-size (one-off, not per sample):
//! 1. the **Taubin** algebraic fit on centred, scaled points: minimise
//!    Σ(A z + b·x + C)² / Σ|∇(A z + b·x + C)|² with z = |x|². With centred data C = −A z̄, and the
//!    problem becomes the smallest generalised eigenpair of M w = η N w, M the covariance of
//!    (z − z̄, x), N = diag(4 z̄, 1, …). Unlike the plain Kåsa fit it is nearly unbiased on arcs
//!    and caps (Kåsa shrinks the radius);
//! 2. **Gauss–Newton** on the geometric distances r_i = |p_i − c| − R from the Taubin start.
//!
//! Residual RMS is the RMS of the geometric distances, µm.

use nalgebra::{SMatrix, SVector};

/// Why a point fit failed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PointFitError {
    /// Fewer points than unknowns (3 for a circle, 4 for a sphere).
    TooFewPoints {
        /// Points given.
        have: usize,
        /// Points needed.
        need: usize,
    },
    /// The points do not determine a circle/sphere (collinear, coplanar for a sphere,
    /// coincident).
    Degenerate,
    /// A coordinate is NaN or infinite.
    NotFinite,
    /// Gauss–Newton did not converge.
    NotConverged,
}

/// A fitted circle (in the plane of the given 2-D coordinates) or sphere.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointFit<const D: usize> {
    /// Centre, mm.
    pub centre_mm: [f64; D],
    /// Radius, mm.
    pub radius_mm: f64,
    /// RMS of the geometric residuals |p − c| − R, µm.
    pub residual_rms_um: f64,
    /// Points used.
    pub points: usize,
    /// Gauss–Newton iterations.
    pub iterations: u32,
}

/// Circle through 2-D points (mm): Taubin, then Gauss–Newton.
pub fn fit_circle(points: &[[f64; 2]]) -> Result<PointFit<2>, PointFitError> {
    fit::<2, 3>(points, jacobi_eigen::<3>)
}

/// Sphere through 3-D points (mm): Taubin, then Gauss–Newton.
pub fn fit_sphere(points: &[[f64; 3]]) -> Result<PointFit<3>, PointFitError> {
    fit::<3, 4>(points, jacobi_eigen::<4>)
}

/// Eigenvalues and eigenvectors (columns) of a symmetric K×K matrix by cyclic Jacobi rotations
/// (Golub & Van Loan §8.5). Written by hand rather than nalgebra's `SymmetricEigen`: for the
/// 3×3 / 4×4 Taubin matrices it is a few hundred bytes of code instead of ~5 KB on the pod,
/// and accurate to working precision. `None` if it does not converge (never seen: 10 sweeps
/// are ample for K ≤ 4) or the matrix is not finite.
fn jacobi_eigen<const K: usize>(
    m: SMatrix<f64, K, K>,
) -> Option<(SVector<f64, K>, SMatrix<f64, K, K>)> {
    if !m.iter().all(|v| v.is_finite()) {
        return None;
    }
    let mut a = m;
    let mut v = SMatrix::<f64, K, K>::identity();
    let scale = a.iter().fold(0.0f64, |acc, x| acc.max(x.abs()));
    for _ in 0..32 {
        let mut off = 0.0f64;
        for p in 0..K {
            for q in (p + 1)..K {
                off = off.max(a.get((p, q)).copied().unwrap_or(0.0).abs());
            }
        }
        if !(off > f64::EPSILON * f64::EPSILON * scale) {
            return Some((a.diagonal(), v));
        }
        for p in 0..K {
            for q in (p + 1)..K {
                let apq = a.get((p, q)).copied().unwrap_or(0.0);
                if apq == 0.0 {
                    continue;
                }
                let app = a.get((p, p)).copied().unwrap_or(0.0);
                let aqq = a.get((q, q)).copied().unwrap_or(0.0);
                let theta = (aqq - app) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + crate::num::sqrt(theta * theta + 1.0));
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / crate::num::sqrt(t * t + 1.0);
                let s = t * c;
                // A ← Jᵀ A J on rows/columns p, q; V ← V J
                for k in 0..K {
                    let (akp, akq) = (
                        a.get((k, p)).copied().unwrap_or(0.0),
                        a.get((k, q)).copied().unwrap_or(0.0),
                    );
                    if let Some(x) = a.get_mut((k, p)) {
                        *x = c * akp - s * akq;
                    }
                    if let Some(x) = a.get_mut((k, q)) {
                        *x = s * akp + c * akq;
                    }
                }
                for k in 0..K {
                    let (apk, aqk) = (
                        a.get((p, k)).copied().unwrap_or(0.0),
                        a.get((q, k)).copied().unwrap_or(0.0),
                    );
                    if let Some(x) = a.get_mut((p, k)) {
                        *x = c * apk - s * aqk;
                    }
                    if let Some(x) = a.get_mut((q, k)) {
                        *x = s * apk + c * aqk;
                    }
                }
                for k in 0..K {
                    let (vkp, vkq) = (
                        v.get((k, p)).copied().unwrap_or(0.0),
                        v.get((k, q)).copied().unwrap_or(0.0),
                    );
                    if let Some(x) = v.get_mut((k, p)) {
                        *x = c * vkp - s * vkq;
                    }
                    if let Some(x) = v.get_mut((k, q)) {
                        *x = s * vkp + c * vkq;
                    }
                }
            }
        }
    }
    None
}

/// Eigen-decomposition of a symmetric K×K matrix: (eigenvalues, eigenvectors as columns).
type EigenFn<const K: usize> =
    fn(SMatrix<f64, K, K>) -> Option<(SVector<f64, K>, SMatrix<f64, K, K>)>;

fn fit<const D: usize, const K: usize>(
    pts: &[[f64; D]],
    eigen: EigenFn<K>,
) -> Result<PointFit<D>, PointFitError> {
    if K != D + 1 {
        return Err(PointFitError::Degenerate);
    }
    let n = pts.len();
    if n < K {
        return Err(PointFitError::TooFewPoints { have: n, need: K });
    }
    if !crate::num::all_finite(pts.as_flattened()) {
        return Err(PointFitError::NotFinite);
    }
    let nf = n as f64;
    // centroid and RMS distance from it (the scale)
    let mut m = SVector::<f64, D>::zeros();
    for p in pts {
        m += SVector::<f64, D>::from(*p);
    }
    m /= nf;
    let mut z_mean = 0.0;
    for p in pts {
        z_mean += (SVector::<f64, D>::from(*p) - m).norm_squared();
    }
    z_mean /= nf;
    if !(z_mean > 0.0) {
        return Err(PointFitError::Degenerate);
    }
    let s = crate::num::sqrt(z_mean);
    // Taubin on scaled points (z̄ = 1): M = cov(z − 1, x), N = diag(4, 1, …)
    let mut mm = SMatrix::<f64, K, K>::zeros();
    for p in pts {
        let x = (SVector::<f64, D>::from(*p) - m) / s;
        // element-wise (`from_iterator` asserts the iterator's length: a panic path)
        let z = x.norm_squared() - 1.0;
        let v = SVector::<f64, K>::from_fn(|r, _| match r {
            0 => z,
            _ => x.get(r - 1).copied().unwrap_or(0.0),
        });
        mm += v * v.transpose();
    }
    mm /= nf;
    // N^{-1/2} M N^{-1/2}: first row and column halved (N_00 = 4)
    let mut ms = mm;
    // element-wise with `get_mut`: nalgebra's `row_mut`/`column_mut` assert their index
    for k in 0..K {
        for idx in [(0, k), (k, 0)] {
            if let Some(v) = ms.get_mut(idx) {
                *v *= 0.5;
            }
        }
    }
    let (values, vectors) = eigen(ms).ok_or(PointFitError::Degenerate)?;
    let mut order: [usize; K] = core::array::from_fn(|i| i);
    order.sort_unstable_by(|a, b| {
        let va = values.get(*a).copied().unwrap_or(f64::INFINITY);
        let vb = values.get(*b).copied().unwrap_or(f64::INFINITY);
        va.total_cmp(&vb)
    });
    let (Some(&i0), Some(&i1)) = (order.first(), order.get(1)) else {
        return Err(PointFitError::Degenerate);
    };
    let lmax = values.amax();
    // a second (near) null direction: a family of circles/spheres fits (coplanar, collinear)
    if !(values.get(i1).copied().unwrap_or(0.0) > 1e-10 * lmax) {
        return Err(PointFitError::Degenerate);
    }
    // element-wise with `get`: nalgebra's `column(i)` asserts its index (a panic path)
    let w = SVector::<f64, K>::from_fn(|r, _| vectors.get((r, i0)).copied().unwrap_or(0.0));
    let a = 0.5 * w.get(0).copied().unwrap_or(0.0);
    let b = SVector::<f64, D>::from_fn(|r, _| w.get(r + 1).copied().unwrap_or(0.0));
    if !(a.abs() > 1e-9 * crate::num::sqrt(b.norm_squared())) {
        return Err(PointFitError::Degenerate); // a line/plane fits better than any circle/sphere
    }
    let c0 = -b / (2.0 * a);
    let r0 = crate::num::sqrt(b.norm_squared() / (4.0 * a * a) + 1.0);
    // Gauss–Newton in mm, centred coordinates
    let mut c = c0 * s;
    let mut r = r0 * s;
    let mut iterations = 0;
    let mut converged = false;
    for it in 1..=50u32 {
        let mut jtj = [[0.0f64; K]; K];
        let mut jtr = [0.0f64; K];
        for p in pts {
            let d = SVector::<f64, D>::from(*p) - m - c;
            let dn = crate::num::sqrt(d.norm_squared());
            if !(dn > 0.0) {
                return Err(PointFitError::Degenerate);
            }
            let mut j = [-1.0f64; K];
            for (ji, di) in j.iter_mut().zip(d.iter()) {
                *ji = -di / dn;
            }
            let res = dn - r;
            for (row, a) in jtj.iter_mut().zip(j) {
                for (x, b) in row.iter_mut().zip(j) {
                    *x += a * b;
                }
            }
            for (x, a) in jtr.iter_mut().zip(j) {
                *x -= a * res;
            }
        }
        let delta = super::solve3::cholesky_solve(jtj, jtr).ok_or(PointFitError::Degenerate)?;
        for (ci, di) in c.iter_mut().zip(delta.iter()) {
            *ci += di;
        }
        r += delta.get(D).copied().unwrap_or(0.0);
        iterations = it;
        let step = delta.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        if step < 1e-12 * (1.0 + r) {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(PointFitError::NotConverged);
    }
    let mut ss = 0.0;
    for p in pts {
        let e = crate::num::sqrt((SVector::<f64, D>::from(*p) - m - c).norm_squared()) - r;
        ss += e * e;
    }
    let centre = c + m;
    let out = PointFit {
        centre_mm: core::array::from_fn(|i| centre.get(i).copied().unwrap_or(f64::NAN)),
        radius_mm: r,
        residual_rms_um: crate::num::sqrt(ss / nf) * 1e3,
        points: n,
        iterations,
    };
    if crate::num::all_finite(&out.centre_mm) && r.is_finite() && r > 0.0 {
        Ok(out)
    } else {
        Err(PointFitError::Degenerate)
    }
}
