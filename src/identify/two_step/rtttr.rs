//! RTTTR: β about y on the spindle (eqs 13, 15, 17) and α about x in the table (eqs 14, 16,
//! 18), two separate single-axis procedures.

use super::*;

/// RTTTR spindle head (β about y, seed 000 eqs 13, 15, 17): tip = pivot + Ry(β)·(0, 0, z_r).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RtttrSpindleConfig {
    /// Signed tool vector along the spindle-frame z axis, mm (z_r).
    pub tool_z_mm: f64,
    /// Where the SSM socket sits (on the turning table for the β procedure).
    pub reference_end: ReferenceEnd,
    /// Smallest usable lever arm, mm.
    pub min_lever_arm_mm: f64,
}

/// RTTTR table (α about x, seed 000 eqs 14, 16, 18): point = origin + Rx(α)·r_t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RtttrTableConfig {
    /// Reference point (x_tr, y_tr, z_tr) in the table frame, mm.
    pub reference_point_mm: [f64; 3],
    /// Where the SSM socket sits (on the spindle for the α procedure).
    pub reference_end: ReferenceEnd,
    /// Smallest usable lever arm, mm.
    pub min_lever_arm_mm: f64,
}

/// One single-axis two-step measurement (RTTTR spindle β or table α).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SingleAxisMeasurement {
    /// Nominal pivot (spindle) or table-frame origin (table) after the translation, mm.
    pub origin_mm: [f64; 3],
    /// Nominal rotation angle of the second step (β or α), degrees.
    pub angle_deg: f64,
    /// SSM error after the translation (ΔV1 or ΔtV1), µm.
    pub dv1_um: [f64; 3],
    /// SSM error after the rotation (ΔV2 or ΔtV2), µm.
    pub dv2_um: [f64; 3],
    /// Standard uncertainty of each SSM component of ΔV1 and of ΔV2 (independent runs), µm;
    /// 0 if unknown. Propagated to the angles' `std_uncertainty_urad`.
    pub dv_std_um: [f64; 2],
}

/// Identified orientation error of one rotary axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SingleAxisResult {
    /// Δθ = θ_actual − θ_nominal, µrad.
    pub delta_urad: f64,
    /// Standard uncertainty of Δθ from `dv_std_um`, µrad: √(σ₁² + σ₂²) / lever arm (|z_r| for the
    /// spindle, hypot(y_tr, z_tr) for the table).
    pub std_uncertainty_urad: f64,
    /// Measured minus modelled position with the identified angle, µm (three rows, one
    /// unknown: the axial row and the radial length are unused by the inversion).
    pub residual_um: [f64; 3],
    /// The formulas used.
    pub mode: Mode,
}

pub(super) fn single_inputs_ok(m: &SingleAxisMeasurement) -> bool {
    crate::num::all_finite(&m.origin_mm)
        && m.angle_deg.is_finite()
        && crate::num::all_finite(&m.dv1_um)
        && crate::num::all_finite(&m.dv2_um)
        && m.dv_std_um.iter().all(|u| u.is_finite())
}

/// Nominal RTTTR tool-tip position, mm (eq 13).
pub fn rtttr_spindle_nominal_tip_mm(
    cfg: &RtttrSpindleConfig,
    pivot_mm: [f64; 3],
    beta_deg: f64,
) -> [f64; 3] {
    add(
        pivot_mm,
        rot_y(beta_deg.to_radians(), [0.0, 0.0, cfg.tool_z_mm]),
    )
}

/// Nominal RTTTR table reference-point position, mm (eq 14).
pub fn rtttr_table_nominal_point_mm(
    cfg: &RtttrTableConfig,
    origin_mm: [f64; 3],
    alpha_deg: f64,
) -> [f64; 3] {
    add(
        origin_mm,
        rot_x(alpha_deg.to_radians(), cfg.reference_point_mm),
    )
}

/// Identifies Δβ of the RTTTR spindle head. Exact: β′ = atan2(v_x / z_r, v_z / z_r) with v the
/// actual rotated tool vector; paper: eq 17 (= eq 6, signed z_r).
pub fn identify_rtttr_spindle(
    cfg: &RtttrSpindleConfig,
    m: &SingleAxisMeasurement,
    mode: Mode,
) -> Result<SingleAxisResult, TwoStepError> {
    check_lever(cfg.min_lever_arm_mm)?;
    if !(cfg.tool_z_mm.is_finite() && single_inputs_ok(m)) {
        return Err(TwoStepError::NonFinite);
    }
    check_std(m.dv_std_um)?;
    if !(libm::fabs(cfg.tool_z_mm) >= cfg.min_lever_arm_mm) {
        return Err(TwoStepError::ZeroLength);
    }
    let sgn = cfg.reference_end.sign();
    let dv1 = scale(sgn, m.dv1_um);
    let dv2 = scale(sgn, m.dv2_um);
    let beta = m.angle_deg.to_radians();
    let t_nom = rot_y(beta, [0.0, 0.0, cfg.tool_z_mm]);
    let v = add(t_nom, scale(1e-3, add(dv2, scale(-1.0, dv1))));
    let d_beta = match mode {
        Mode::Exact => {
            let [vx, _, vz] = scale(1.0 / cfg.tool_z_mm, v);
            wrap_pi(libm::atan2(vx, vz) - beta)
        }
        Mode::Paper => {
            let [x1, _, _] = m.origin_mm;
            let [tx, _, _] = t_nom;
            let [dx1, _, _] = dv1;
            let [dx2, _, _] = dv2;
            paper::eq6_delta_beta_rad(
                x1,
                x1 + tx,
                dx1,
                dx2,
                cfg.tool_z_mm,
                beta,
                cfg.min_lever_arm_mm,
            )?
        }
    };
    let model = rot_y(beta + d_beta, [0.0, 0.0, cfg.tool_z_mm]);
    single_result(SingleAxisResult {
        delta_urad: d_beta * 1e6,
        std_uncertainty_urad: angle_std_urad(m.dv_std_um, cfg.tool_z_mm),
        residual_um: residual_um(v, model),
        mode,
    })
}

/// Identifies Δα of the RTTTR table. Exact: α′ = atan2(v_z, v_y) − atan2(z_tr, y_tr) with v the
/// actual rotated reference vector; paper: eq 18.
pub fn identify_rtttr_table(
    cfg: &RtttrTableConfig,
    m: &SingleAxisMeasurement,
    mode: Mode,
) -> Result<SingleAxisResult, TwoStepError> {
    check_lever(cfg.min_lever_arm_mm)?;
    if !(crate::num::all_finite(&cfg.reference_point_mm) && single_inputs_ok(m)) {
        return Err(TwoStepError::NonFinite);
    }
    check_std(m.dv_std_um)?;
    let [_, ytr, ztr] = cfg.reference_point_mm;
    let sgn = cfg.reference_end.sign();
    let dv1 = scale(sgn, m.dv1_um);
    let dv2 = scale(sgn, m.dv2_um);
    let alpha = m.angle_deg.to_radians();
    let r_nom = rot_x(alpha, cfg.reference_point_mm);
    let v = add(r_nom, scale(1e-3, add(dv2, scale(-1.0, dv1))));
    let d_alpha = match mode {
        Mode::Exact => {
            if !(crate::num::hypot(ytr, ztr) >= cfg.min_lever_arm_mm) {
                return Err(TwoStepError::Singular(Singularity::TableAlphaLever));
            }
            let [_, vy, vz] = v;
            wrap_pi(libm::atan2(vz, vy) - libm::atan2(ztr, ytr) - alpha)
        }
        Mode::Paper => {
            let [_, y1, _] = m.origin_mm;
            let [_, ry, _] = r_nom;
            let [_, dy1, _] = dv1;
            let [_, dy2, _] = dv2;
            paper::eq18_delta_alpha_rad(
                y1,
                y1 + ry,
                dy1,
                dy2,
                cfg.reference_point_mm,
                alpha,
                cfg.min_lever_arm_mm,
            )?
        }
    };
    let model = rot_x(alpha + d_alpha, cfg.reference_point_mm);
    single_result(SingleAxisResult {
        delta_urad: d_alpha * 1e6,
        std_uncertainty_urad: angle_std_urad(m.dv_std_um, crate::num::hypot(ytr, ztr)),
        residual_um: residual_um(v, model),
        mode,
    })
}
