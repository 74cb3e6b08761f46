//! SSM total position errors (seed 000 eq 1, generalised; DESIGN §7).
//!
//! Each observation gives u·E = y: u the unit vector from the socket centre P0 to the nominal
//! tool-ball centre P, E the position error (actual − nominal, tool side relative to the socket
//! side) and y the measured minus the nominal bar length:
//! y = (L + ΔL) − |P − P0| (= ΔL when P lies on the bar's sphere). This is the first-order form
//! of the exact sphere equation |P − P0 + E| = L + ΔL (seed 000 B.2); [`station::refine`]
//! removes the |E|²/2L linearisation error by Gauss–Newton.
//!
//! - [`station`]: dwell detection, averaged stations, eq (1) exactly from three stations and
//!   least squares from more, Gauss–Newton refinement (f64, once per test);
//! - [`streaming`]: E at every sample from its neighbourhood, normal equations kept exactly in
//!   integer sums over a fixed sliding window (O(1) per sample).
//!
//! Both report E (µm), the Frobenius condition number of the direction matrix (seed 000 C.1
//! TV-SSM-cond) and which components are observable: a path whose directions u all lie in one
//! plane cannot see the component along the plane's normal, and that component is `None`.

pub mod station;
pub mod streaming;

use super::solve3::{Sym3, dot};

/// Calibrated SSM set-up.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SsmGeometry {
    /// Socket (pivot) centre P0 in machine coordinates, mm.
    pub socket_mm: [f64; 3],
    /// Calibrated bar length L (centre to centre at 20 °C), mm.
    pub bar_length_mm: f64,
}

/// Why no SSM solution is available.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SsmError {
    /// Fewer observations (stations or window samples) than needed.
    TooFewObservations {
        /// Observations available.
        have: u32,
        /// Observations needed.
        need: u32,
    },
    /// The directions span at most a line (e.g. coincident stations): at most one component
    /// of E is observable.
    Degenerate,
    /// A station position is at the socket or not finite, or a value is not finite.
    InvalidInput,
    /// Gauss–Newton did not converge within its iteration limit.
    NotConverged,
}

/// An SSM solution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SsmSolution {
    /// E = actual − nominal position error (x, y, z), µm; `None` for a component the path cannot
    /// observe (not invented: the minimum-norm solution is used for the others).
    pub e_um: [Option<f64>; 3],
    /// Unit normal of the plane of directions when one direction is unobservable, else `None`.
    pub unobservable_direction: Option<[f64; 3]>,
    /// Frobenius condition number ‖U‖_F·‖U⁺‖_F of the unit-direction matrix U (over the
    /// observable subspace when one direction is unobservable).
    pub cond: f64,
    /// Residual RMS of u·E − y over the observations, µm (0 for an exact 3-station solve).
    pub residual_rms_um: f64,
    /// G⁺, the (pseudo-)inverse of the normal matrix G = Σ u uᵀ of the solve (on the observable
    /// subspace when one direction is unobservable): E's covariance is G⁺ (Σ σ_i² u_i u_iᵀ) G⁺
    /// ([`station::station_covariance`]), σ² G⁺ for equal σ.
    pub g_pinv: Sym3,
    /// Observations used.
    pub observations: u32,
    /// Gauss–Newton iterations applied (0 for the linear solution).
    pub iterations: u32,
}

impl SsmSolution {
    /// (observable x, y, z).
    pub fn observable(&self) -> [bool; 3] {
        let [a, b, c] = self.e_um;
        [a.is_some(), b.is_some(), c.is_some()]
    }
}

/// Smallest-to-largest eigenvalue ratio of UᵀU below which a direction counts as unobservable.
/// A planar path gives ~1e-16; a well-spread neighbourhood ~1e-2; 1e-9 leaves 4 decades for
/// genuinely ill-conditioned but non-degenerate layouts (cond ≈ 3e4).
pub const UNOBSERVABLE_EIG_RATIO: f64 = 1e-9;

/// A component of E counts as observable when the unobservable direction has less than this
/// component along its axis: E_k is then determined to |v_k| of the null-space freedom, i.e.
/// within 1e-4 · |E| (0.01 µm for a 100 µm error). Not smaller: on a measured planar arc the
/// fitted direction's in-plane components wobble by a few 1e-6 with the 0.1 µm encoder steps
/// over a 5 mm window, and a tolerance below that made an observable component's validity
/// flicker from sample to sample.
pub const OBSERVABLE_AXIS_TOL: f64 = 1e-4;

/// Solves the SSM normal equations G·E = b (G = Σ u uᵀ, b = Σ u y, `yy` = Σ y²) for `n`
/// observations, with the observability analysis. E in the units of y.
pub fn solve_normal(g: &Sym3, b: [f64; 3], yy: f64, n: u32) -> Result<SsmSolution, SsmError> {
    if n < 2 {
        return Err(SsmError::TooFewObservations { have: n, need: 3 });
    }
    if !g.is_finite() || !crate::num::all_finite(&b) {
        return Err(SsmError::InvalidInput);
    }
    let (lam, v) = g.eigen_smallest();
    let [l_min, l_mid, l_max] = lam;
    if !(l_max > 0.0) || l_mid <= UNOBSERVABLE_EIG_RATIO * l_max {
        return Err(SsmError::Degenerate);
    }
    let deficient = l_min <= UNOBSERVABLE_EIG_RATIO * l_max;
    if !deficient && n < 3 {
        return Err(SsmError::TooFewObservations { have: n, need: 3 });
    }
    let (e, cond, g_pinv) = if deficient {
        // G + λ_max v vᵀ is regular and gives the solution with no component along v
        let [v0, v1, v2] = v;
        let mut gr = *g;
        gr.add_outer(v, l_max);
        // project b onto the observable subspace (b·v ≈ 0 for consistent data)
        let bv = dot(b, v);
        let bp = [b[0] - bv * v0, b[1] - bv * v1, b[2] - bv * v2];
        let chol = gr.cholesky().map_err(|_| SsmError::Degenerate)?;
        let e = chol.solve(bp);
        let cond = crate::num::sqrt((l_mid + l_max) * (1.0 / l_mid + 1.0 / l_max));
        // (G + λ v vᵀ)⁻¹ = G⁺ + v vᵀ/λ (v ⟂ the range of G)
        let mut g_pinv = chol.inverse();
        g_pinv.add_outer(v, -1.0 / l_max);
        (e, cond, g_pinv)
    } else {
        let chol = g.cholesky().map_err(|_| SsmError::Degenerate)?;
        let e = chol.solve(b);
        let g_pinv = chol.inverse();
        let cond = crate::num::sqrt(g.trace() * g_pinv.trace());
        (e, cond, g_pinv)
    };
    let ssr = (yy - dot(e, b)).max(0.0);
    let rms = crate::num::sqrt(ssr / f64::from(n));
    let mask = |k: f64, val: f64| -> Option<f64> {
        if !deficient || k.abs() < OBSERVABLE_AXIS_TOL {
            Some(val)
        } else {
            None
        }
    };
    let sol = SsmSolution {
        e_um: [mask(v[0], e[0]), mask(v[1], e[1]), mask(v[2], e[2])],
        unobservable_direction: if deficient { Some(v) } else { None },
        cond,
        residual_rms_um: rms,
        g_pinv,
        observations: n,
        iterations: 0,
    };
    if crate::num::all_finite(&e) && cond.is_finite() && rms.is_finite() {
        Ok(sol)
    } else {
        Err(SsmError::Degenerate)
    }
}
