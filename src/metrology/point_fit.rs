//! Circle and sphere fits to touch-probe points (issue 3 item 4; seed 002 §6, TV-13).
//!
//! Two stages, f64 (one-off, not per sample):
//! 1. the **Kåsa** algebraic fit on centred, scaled points: |x − c|² = ρ² is linear in c and
//!    ρ² − |c|², one small normal-equation solve. It shrinks the radius on short arcs and caps,
//!    but it is only the start: the result is stage 2's. (The Taubin fit, nearly unbiased, was
//!    the start before; its eigen-solve cost 1.5 KB of flash and gave the same fits.)
//! 2. **Gauss–Newton** on the geometric distances r_i = |p_i − c| − R.
//!
//! Residual RMS is the RMS of the geometric distances, µm.

use nalgebra::SVector;

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

/// Circle through 2-D points (mm): Kåsa, then Gauss–Newton.
pub fn fit_circle(points: &[[f64; 2]]) -> Result<PointFit<2>, PointFitError> {
    fit::<2, 3>(points)
}

/// Sphere through 3-D points (mm): Kåsa, then Gauss–Newton.
pub fn fit_sphere(points: &[[f64; 3]]) -> Result<PointFit<3>, PointFitError> {
    fit::<3, 4>(points)
}

fn fit<const D: usize, const K: usize>(pts: &[[f64; D]]) -> Result<PointFit<D>, PointFitError> {
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
    // Kåsa on scaled points (z̄ = 1): |x − c|² = ρ² is linear in (c, ρ² − |c|²), and with
    // centred x the normal equations split: (Σ x xᵀ) c = ½ Σ (|x|² − 1) x, ρ² = |c|² + 1.
    // Singular Σ x xᵀ: the points lie on a line or plane.
    let mut xx = [[0.0f64; D]; D];
    let mut xz = [0.0f64; D];
    for p in pts {
        let x = (SVector::<f64, D>::from(*p) - m) / s;
        let z = 0.5 * (x.norm_squared() - 1.0);
        for ((row, t), a) in xx.iter_mut().zip(xz.iter_mut()).zip(x.iter()) {
            for (v, b) in row.iter_mut().zip(x.iter()) {
                *v += a * b;
            }
            *t += a * z;
        }
    }
    let c0 = super::solve3::cholesky_solve(xx, xz).ok_or(PointFitError::Degenerate)?;
    let c0 = SVector::<f64, D>::from(c0);
    let r0 = crate::num::sqrt(c0.norm_squared() + 1.0);
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
