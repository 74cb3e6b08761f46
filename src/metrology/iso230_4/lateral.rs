//! Lateral play: an axis's carriage moves across its guideway within its clearance when the
//! force across it reverses with the axis's own direction (a drive line off the guideways'
//! centre, a nut's side load): E_v = (p_u/2)·sign(u̇) for u's carriage, E_u = (p_v/2)·sign(v̇)
//! for v's (p > 0: the carriage runs on the + side of the other axis while it travels +). On
//! the circle the shift is across the bar at the axis's own reversal points, so it does not
//! step the trace there (backlash does) but bends it: radially
//!
//! ΔL_d(θ) = d·(−(p_u/2)·|sin θ| + (p_v/2)·|cos θ|), d = +1 CCW, −1 CW,
//!
//! a cusp at the axis's reversal points whose sign changes with the direction. Every other
//! fault of the diagnostic model is the same in both directions (squareness, scale,
//! straightness, cyclic error, the socket's curvature) or, in the difference of the two runs'
//! profiles, a shape orthogonal to the cusps on a full circle (the reversal steps and servo
//! mismatch: sine series and odd cosine harmonics; the runs' own circles: 1, cos θ, sin θ).
//! So the difference profile
//!
//! D(θ) = ΔL_ccw − ΔL_cw = c₀ + c₁ cos θ + s₁ sin θ + σ sin 2θ + Σ_p B_p g_p(θ)
//!        − p_u·|sin θ| + p_v·|cos θ|
//!
//! (g_p the reversal points' step shapes of [`super::diagnostics`] for d = +1, doubled) is
//! fitted by weighted least squares on every bin both runs hold, each bin weighted by
//! 1/(1/n_ccw + 1/n_cw) (its difference's variance in sample variances). The two cusps share
//! their even harmonics with alternating signs (correlation −0.92 over the circle), so each
//! axis is told apart, with a u about 2.6 times what it would be alone. u: s·√(A⁻¹)_jj, s² the
//! residual's per-sample variance, at least the resolution's q²/12. Why a fit of its own and
//! not a column of each direction's: in one direction the cusp is the scale mismatch's cos 2θ
//! plus 4θ, 6θ, … terms the cyclic order-4 column takes; only the direction's sign tells it.
//! The centre as entered moves both runs' bins alike (first order: the difference cancels it),
//! so no centre's share is taken.

use super::diagnostics::{Diagnosed, RESOLUTION_UM};
use super::{CircularTest, Direction};
use crate::metrology::solve3::cholesky_solve;

/// Unknowns of the difference fit: c₀, c₁, s₁, sin 2θ, the four reversal points' steps,
/// |sin θ|, |cos θ|.
const UNKNOWNS: usize = 10;
/// The columns of |sin θ| (u's play, negated) and |cos θ| (v's play).
const COL_SIN: usize = 8;
const COL_COS: usize = 9;

impl<const BINS: usize> CircularTest<BINS> {
    /// Each axis's lateral play p_u, p_v (µm, the module doc) from the CCW and CW runs, `None`
    /// where the two runs do not share bins in every quadrant or too few for the fit. On a
    /// partial arc the cusps are not orthogonal to the other shapes (a larger u) and a reversal
    /// point's step column is fitted only where the runs hold
    /// [`super::support::REVERSAL_SIDE_DEG`] of bins on its half of the circle.
    pub fn lateral_play(&self) -> Option<[Diagnosed; 2]> {
        let (ccw, cw) = (
            &self.run(Direction::Ccw).bins,
            &self.run(Direction::Cw).bins,
        );
        let per_q = Self::BINS_PER_QUADRANT;
        let both =
            |i: usize| ccw.get(i).is_some_and(|b| b.n > 0) && cw.get(i).is_some_and(|b| b.n > 0);
        let half = |i: usize, k: usize| super::diagnostics::point_of(i, per_q, k);
        let least = ((super::support::REVERSAL_SIDE_DEG * BINS as f32 / 360.0) as usize).max(1);
        let fitted = [0usize, 1, 2, 3]
            .map(|k| (0..BINS).filter(|i| both(*i) && half(*i, k)).count() >= least);
        let every_quadrant = [0usize, 1, 2, 3]
            .iter()
            .all(|q| (q * per_q..(q + 1) * per_q).any(both));
        if !every_quadrant {
            return None;
        }
        let mut a = [[0.0f32; UNKNOWNS]; UNKNOWNS];
        let mut b = [0.0f32; UNKNOWNS];
        let (mut yy, mut bins) = (0.0f32, 0u32);
        for (i, (p, q)) in ccw.iter().zip(cw.iter()).enumerate() {
            let (Some((dl_p, nu_p, nv_p)), Some((dl_q, nu_q, nv_q))) = (p.mean(), q.mean()) else {
                continue;
            };
            let w = 1.0 / (1.0 / p.n as f32 + 1.0 / q.n as f32);
            let y = dl_p - dl_q;
            let (nu, nv) = (nu_p + nu_q, nv_p + nv_q);
            let rn = crate::num::sqrtf(nu * nu + nv * nv).max(1e-12);
            let (c1, s1) = (nu / rn, nv / rn);
            // sign(sin θ), sign(cos θ) are constant within a quadrant's bins
            let quadrant = i / per_q.max(1);
            let ssin = if quadrant < 2 { 1.0 } else { -1.0 };
            let scos = if quadrant == 0 || quadrant == 3 {
                1.0
            } else {
                -1.0
            };
            // a reversal point's step on the half of the circle about it
            let step = |k: usize, g: f32| {
                if half(i, k) && fitted.get(k).copied().unwrap_or(false) {
                    g
                } else {
                    0.0
                }
            };
            let (g_u, g_v) = (c1 * ssin, -s1 * scos);
            let g = [
                1.0,
                c1,
                s1,
                2.0 * c1 * s1,
                step(0, g_u),
                step(1, g_v),
                step(2, g_u),
                step(3, g_v),
                libm::fabsf(s1),
                libm::fabsf(c1),
            ];
            for ((row, bj), gi) in a.iter_mut().zip(b.iter_mut()).zip(g.iter()) {
                let wg = w * gi;
                for (x, gj) in row.iter_mut().zip(g.iter()) {
                    *x += wg * gj;
                }
                *bj += wg * y;
            }
            yy += w * y * y;
            bins += 1;
        }
        if bins <= 2 * UNKNOWNS as u32 {
            return None;
        }
        // a step column not fitted: identity, its parameter 0 (the others untouched)
        for (k, fit) in fitted.iter().enumerate() {
            if *fit {
                continue;
            }
            let c = 4 + k;
            for (r, row) in a.iter_mut().enumerate() {
                for (j, x) in row.iter_mut().enumerate() {
                    if r == c || j == c {
                        *x = if r == j { 1.0 } else { 0.0 };
                    }
                }
            }
            if let Some(bc) = b.get_mut(c) {
                *bc = 0.0;
            }
        }
        let unknowns = UNKNOWNS - fitted.iter().filter(|f| !**f).count();
        let x = cholesky_solve(a, b)?;
        let rss = (yy - x.iter().zip(b).map(|(x, b)| x * b).sum::<f32>()).max(0.0);
        let q = RESOLUTION_UM;
        let s2 = (rss / bins.saturating_sub(unknowns as u32).max(1) as f32).max(q * q / 12.0);
        let play = |col: usize, sign: f32| {
            let mut e = [0.0f32; UNKNOWNS];
            *e.get_mut(col)? = 1.0;
            let c = cholesky_solve(a, e)?;
            let var = s2 * *c.get(col)?;
            let d = Diagnosed {
                value: sign * *x.get(col)?,
                std_uncertainty: crate::num::sqrtf(var),
                centre_um: 0.0,
            };
            (d.value.is_finite() && d.std_uncertainty.is_finite()).then_some(d)
        };
        Some([play(COL_SIN, -1.0)?, play(COL_COS, 1.0)?])
    }
}
