//! Vector (sequential-step) body-diagonal method (seed 001 §8.3.2.2; the inversion is derived in
//! spec A.6, `seed001_checks.py` part 3 — the seed prints none).
//!
//! The beam points along body diagonal s ∈ {ppp, npp, pnp, ppn} with direction
//! u_s = (s_x a, s_y b, s_z c)/r, r = √(a² + b² + c²); the machine steps one axis at a time. For a
//! step of axis u the reading is m_s = u_s · dD(u), with dD(u) = (dD_x(u), dD_y(u), dD_z(u)) the
//! *effective* error increments over that step (Abbé terms with the constant offsets of the
//! other axes are absorbed into them). Four diagonals, three unknowns per step: solved by least
//! squares ([`GivensLsq`]), one redundant reading per step is the consistency check
//! (closed form when all four are present: SᵀS = 4I,
//! dD_x = r/(4a)·(m_ppp − m_npp + m_pnp + m_ppn), and cyclically).
//!
//! Readings must be indexed by position: for a diagonal traversed in the negative direction of
//! an axis the executed step's reading is minus the forward increment, so pass its negation at
//! the forward step index (spec A.6).

use super::VolumetricError;
use ballpod::identify::lsq::{DEFAULT_RANK_TOL, GivensLsq, LsqError};

/// Sign patterns (s_x, s_y, s_z) of the four body diagonals, in the order of the readings:
/// ppp, npp, pnp, ppn.
pub const DIAGONAL_SIGNS: [[f64; 3]; 4] = [
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, -1.0],
];

/// Error increments of one axis step identified from the diagonal readings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepIncrements {
    /// (dD_x, dD_y, dD_z) over the step, µm.
    pub increments_um: [f64; 3],
    /// Standard uncertainty of each increment from the redundant reading, µm (0 without
    /// redundancy).
    pub std_uncertainty_um: [f64; 3],
    /// RMS of the reading residuals, µm (0 without redundancy).
    pub residual_rms_um: f64,
    /// Readings used (3 or 4).
    pub readings: u32,
}

/// Inverts the readings of one axis step. `diagonal_mm` = (a, b, c) are the diagonal's
/// per-axis extents (any common scale: only the direction matters), all > 0; `readings_um` =
/// (m_ppp, m_npp, m_pnp, m_ppn), `None` where a diagonal was not measured.
/// Fewer than three diagonals cannot separate the three directions:
/// [`VolumetricError::CannotSeparate`] names the direction most involved.
pub fn invert_step(
    diagonal_mm: [f64; 3],
    readings_um: [Option<f64>; 4],
) -> Result<StepIncrements, VolumetricError> {
    if !ballpod::num::all_finite(&diagonal_mm)
        || readings_um.iter().flatten().any(|m| !m.is_finite())
    {
        return Err(VolumetricError::NonFinite);
    }
    if diagonal_mm.iter().any(|&v| v <= 0.0) {
        return Err(VolumetricError::LengthNotPositive);
    }
    let [a, b, c] = diagonal_mm;
    let r = ballpod::num::sqrt(a * a + b * b + c * c);
    let mut lsq = GivensLsq::<3>::new();
    for (s, m) in DIAGONAL_SIGNS.iter().zip(readings_um.iter()) {
        if let Some(m) = m {
            let [sx, sy, sz] = *s;
            lsq.add_row(&[sx * a / r, sy * b / r, sz * c / r], *m, 1.0)
                .map_err(VolumetricError::Lsq)?;
        }
    }
    if lsq.rows() < 3 {
        // fewer than 3 diagonals: name the direction the missing rows would have fixed
        return Err(VolumetricError::CannotSeparate {
            direction: weakest_missing(&readings_um),
        });
    }
    let sol = lsq.solve_full_rank(DEFAULT_RANK_TOL).map_err(|e| match e {
        LsqError::RankDeficient { weakest_param, .. } => VolumetricError::CannotSeparate {
            direction: weakest_param,
        },
        other => VolumetricError::Lsq(other),
    })?;
    Ok(StepIncrements {
        increments_um: sol.x,
        std_uncertainty_um: sol.std_uncertainty,
        residual_rms_um: sol.residual_rms,
        readings: sol.rows,
    })
}

/// With fewer than 3 diagonals: the direction whose sign pattern the present diagonals do not
/// distinguish (the first one, in x, y, z order, that all present rows share with ppp).
fn weakest_missing(readings_um: &[Option<f64>; 4]) -> usize {
    // diagonal k (k = 1, 2, 3) is the only one that flips direction k − 1 relative to ppp
    readings_um
        .iter()
        .skip(1)
        .position(|m| m.is_none())
        .unwrap_or(0)
}

/// Result of a whole vector-method run along one axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurveQuality {
    /// Steps inverted.
    pub steps: usize,
    /// Largest per-step reading residual RMS, µm.
    pub worst_residual_rms_um: f64,
}

/// Inverts every step of one axis and accumulates the three error curves
/// (D_x(u), D_y(u), D_z(u)) at the step boundaries, µm, zero at the start: `out_um[0]` = 0 and
/// `out_um[k + 1]` = `out_um[k]` + increments of step k. `out_um` must hold `steps.len() + 1`
/// points. Nothing is written unless every step inverts.
pub fn error_curves_um(
    diagonal_mm: [f64; 3],
    steps: &[[Option<f64>; 4]],
    out_um: &mut [[f64; 3]],
) -> Result<CurveQuality, VolumetricError> {
    if steps.is_empty() {
        return Err(VolumetricError::EmptyData);
    }
    let needed = steps.len() + 1;
    if out_um.len() < needed {
        return Err(VolumetricError::TableTooSmall { needed });
    }
    // validate all steps first: nothing computed from half the data
    let mut worst = 0.0f64;
    for s in steps {
        worst = worst.max(invert_step(diagonal_mm, *s)?.residual_rms_um);
    }
    let mut acc = [0.0f64; 3];
    let mut outs = out_um.iter_mut();
    if let Some(o) = outs.next() {
        *o = acc;
    }
    for (s, o) in steps.iter().zip(outs) {
        let inc = invert_step(diagonal_mm, *s)?.increments_um;
        for (a, i) in acc.iter_mut().zip(inc.iter()) {
            *a += i;
        }
        *o = acc;
    }
    Ok(CurveQuality {
        steps: steps.len(),
        worst_residual_rms_um: worst,
    })
}

/// Least-squares straight line through a straightness curve (`positions_mm` and `values_um`
/// pair up; at least two distinct positions).
pub fn line_fit(positions_mm: &[f64], values_um: &[f64]) -> Result<LineFit, VolumetricError> {
    if positions_mm.len() != values_um.len() || positions_mm.len() < 2 {
        return Err(VolumetricError::EmptyData);
    }
    line_fit_pairs(positions_mm.iter().copied().zip(values_um.iter().copied()))
}

/// [`line_fit`] over (position mm, value µm) pairs.
fn line_fit_pairs(pairs: impl Iterator<Item = (f64, f64)>) -> Result<LineFit, VolumetricError> {
    let mut lsq = GivensLsq::<2>::new();
    for (p, v) in pairs {
        lsq.add_row(&[1.0, p], v, 1.0)
            .map_err(|_| VolumetricError::NonFinite)?;
    }
    if lsq.rows() < 2 {
        return Err(VolumetricError::EmptyData);
    }
    let sol = lsq
        .solve_full_rank(DEFAULT_RANK_TOL)
        .map_err(VolumetricError::Lsq)?;
    let [intercept_um, slope] = sol.x;
    Ok(LineFit {
        slope_urad: slope * 1e3,
        intercept_um,
        residual_rms_um: sol.residual_rms,
    })
}

/// A least-squares line through a straightness curve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineFit {
    /// Slope, µrad (= µm/m; 1 µm/mm = 1000 µrad).
    pub slope_urad: f64,
    /// Value of the line at position 0, µm.
    pub intercept_um: f64,
    /// RMS of the straightness about the line, µm.
    pub residual_rms_um: f64,
}

/// Squareness of two axes from the slopes of their crossed straightness curves, µrad
/// (spec A.6: diagonal lengths are invariant to a rigid rotation of the frame, so only the sum
/// is observable). With axis u moving along (1, s_vu) and axis v along (s_uv, 1), the angle
/// between them is 90° − (s_vu + s_uv): S = slope[D_v(u)] + slope[D_u(v)], the value that,
/// folded into D_u(v) by eqs 8.58–8.60 with D_v(u) levelled, gives the same geometry.
/// E.g. S_xy = slope[D_y(x)] + slope[D_x(y)].
pub fn squareness_urad(slope_dv_of_u_urad: f64, slope_du_of_v_urad: f64) -> f64 {
    slope_dv_of_u_urad + slope_du_of_v_urad
}

/// Summary of a complete vector-method run (all three axes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VectorMethodSummary {
    /// Squareness from the crossed straightness slopes ([`squareness_urad`]), µrad:
    /// S_xy = slope[D_y(x)] + slope[D_x(y)], S_yz = slope[D_z(y)] + slope[D_y(z)],
    /// S_zx = slope[D_z(x)] + slope[D_x(z)].
    pub squareness: super::Squareness,
    /// Least-squares slope of each curve, µrad: `slopes_urad[u][i]` = slope of D_i(u). Only the
    /// crossed sums above are independent of the beam alignment (spec A.6).
    pub slopes_urad: [[f64; 3]; 3],
    /// Per-axis inversion quality.
    pub quality: [CurveQuality; 3],
}

/// The whole vector method (spec A.6): for each axis u = x, y, z, `steps[u]` holds the four
/// diagonal readings of every step of u (indexed by position, see the module doc) and
/// `out_um[u]` receives the curves (D_x(u), D_y(u), D_z(u)) at the step boundaries
/// (`steps[u].len() + 1` points, zero at the start). `step_mm` = (a, b, c) are the per-step
/// increments of x, y, z (also the diagonal's direction). The 9 curves are the 3 displacement +
/// 6 straightness errors; the 3 squareness errors come from their slopes. Nothing is written
/// unless every step of every axis inverts.
pub fn identify_vector_method(
    step_mm: [f64; 3],
    steps: [&[[Option<f64>; 4]]; 3],
    out_um: [&mut [[f64; 3]]; 3],
) -> Result<VectorMethodSummary, VolumetricError> {
    // validate everything first
    for (s, o) in steps.iter().zip(out_um.iter()) {
        if s.len() < 2 {
            return Err(VolumetricError::EmptyData);
        }
        let needed = s.len() + 1;
        if o.len() < needed {
            return Err(VolumetricError::TableTooSmall { needed });
        }
        for st in s.iter() {
            invert_step(step_mm, *st)?;
        }
    }
    let mut quality = [CurveQuality {
        steps: 0,
        worst_residual_rms_um: 0.0,
    }; 3];
    let mut slopes_urad = [[0.0f64; 3]; 3];
    for ((((s, o), q), sl), h) in steps
        .iter()
        .zip(out_um)
        .zip(quality.iter_mut())
        .zip(slopes_urad.iter_mut())
        .zip(step_mm.iter())
    {
        *q = error_curves_um(step_mm, s, o)?;
        let n = s.len() + 1;
        for (i, slope) in sl.iter_mut().enumerate() {
            let pairs = o
                .iter()
                .take(n)
                .enumerate()
                .map(|(k, v)| (k as f64 * h, v.get(i).copied().unwrap_or(f64::NAN)));
            *slope = line_fit_pairs(pairs)?.slope_urad;
        }
    }
    let [sx, sy, sz] = slopes_urad;
    let [_, syx, szx] = sx; // D_y(x), D_z(x)
    let [sxy, _, szy] = sy; // D_x(y), D_z(y)
    let [sxz, syz, _] = sz; // D_x(z), D_y(z)
    Ok(VectorMethodSummary {
        squareness: super::Squareness {
            xy_urad: squareness_urad(syx, sxy),
            yz_urad: squareness_urad(szy, syz),
            zx_urad: squareness_urad(szx, sxz),
        },
        slopes_urad,
        quality,
    })
}
