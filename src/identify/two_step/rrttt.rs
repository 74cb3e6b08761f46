//! RRTTT: both rotary axes on the spindle head, α about x and β about y (seed 000 eqs 2–7).

use super::*;

/// RRTTT machine geometry and conventions (seed 000 eqs 2–4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RrtttConfig {
    /// Signed tool vector along the spindle-frame z axis, from the pivot (rotation centre) to
    /// the tool-ball centre, mm (z_r of eq 2; −250 for seed 000 Table 1, tool pointing down).
    pub tool_z_mm: f64,
    /// Order of the two head rotations.
    pub rotation_order: RotationOrder,
    /// Where the SSM socket sits (Table 1 / section 3: on the table, [`ReferenceEnd::OtherMember`]).
    pub reference_end: ReferenceEnd,
    /// Smallest usable lever arm, mm (see [`DEFAULT_MIN_LEVER_ARM_MM`]).
    pub min_lever_arm_mm: f64,
}

/// One RRTTT two-step measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RrtttMeasurement {
    /// Nominal pivot (rotation-centre) position after the translation, mm ((x_1, y_1, z_1) of
    /// Table 1 = (−50, −15, 500)).
    pub pivot_mm: [f64; 3],
    /// Nominal α (rotation about x) of the second step, degrees.
    pub alpha_deg: f64,
    /// Nominal β (rotation about y) of the second step, degrees.
    pub beta_deg: f64,
    /// SSM total position error after the translation (ΔV1), µm.
    pub dv1_um: [f64; 3],
    /// SSM total position error after the rotation (ΔV2), µm.
    pub dv2_um: [f64; 3],
    /// Standard uncertainty of each SSM component of ΔV1 and of ΔV2 (independent runs), µm;
    /// 0 if unknown. Propagated to the angles' `std_uncertainty_urad`.
    pub dv_std_um: [f64; 2],
}

/// Identified RRTTT orientation errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RrtttResult {
    /// Δα = α_actual − α_nominal, µrad.
    pub delta_alpha_urad: f64,
    /// Δβ = β_actual − β_nominal, µrad.
    pub delta_beta_urad: f64,
    /// Standard uncertainties of (Δα, Δβ) from `dv_std_um`, µrad: √(σ₁² + σ₂²) / lever arm, the lever
    /// being |z_r| for the inner rotation (β for Rx·Ry) and |z_r|·cos(inner angle) for the
    /// outer one (first order).
    pub std_uncertainty_urad: [f64; 2],
    /// Measured minus modelled tool-tip position with the identified angles, µm (exact mode:
    /// only the radial component, |v| − |z_r|, can be non-zero).
    pub residual_um: [f64; 3],
    /// The formulas used.
    pub mode: Mode,
}

/// Tool vector of an RRTTT head rotated by (α, β) in radians, mm.
pub(super) fn rrttt_tool(cfg: &RrtttConfig, alpha: f64, beta: f64) -> [f64; 3] {
    let t = [0.0, 0.0, cfg.tool_z_mm];
    match cfg.rotation_order {
        RotationOrder::AlphaThenBeta => rot_x(alpha, rot_y(beta, t)),
        RotationOrder::BetaThenAlpha => rot_y(beta, rot_x(alpha, t)),
    }
}

/// Nominal RRTTT tool-tip position, mm: pivot + R(α, β)·(0, 0, z_r) (eq 2).
pub fn rrttt_nominal_tip_mm(
    cfg: &RrtttConfig,
    pivot_mm: [f64; 3],
    alpha_deg: f64,
    beta_deg: f64,
) -> [f64; 3] {
    add(
        pivot_mm,
        rrttt_tool(cfg, alpha_deg.to_radians(), beta_deg.to_radians()),
    )
}

/// Identifies Δα and Δβ of an RRTTT head (seed 000 §2.1.1, eqs 4–7).
///
/// Exact mode: with v = R(α, β)t + ΔV2 − ΔV1 (the actual rotated tool vector, mm) and
/// w = v / z_r (signed), for Rx·Ry: β′ = atan2(w_x, hypot(w_y, w_z)), α′ = atan2(−w_y, w_z);
/// for Ry·Rx: α′ = atan2(−w_y, hypot(w_x, w_z)), β′ = atan2(w_x, w_z).
/// Paper mode: Δβ from eq 6 (signed z_r), Δα from eq 7 as printed (Rx·Ry only).
pub fn identify_rrttt(
    cfg: &RrtttConfig,
    m: &RrtttMeasurement,
    mode: Mode,
) -> Result<RrtttResult, TwoStepError> {
    check_lever(cfg.min_lever_arm_mm)?;
    if !(cfg.tool_z_mm.is_finite()
        && crate::num::all_finite(&m.pivot_mm)
        && m.alpha_deg.is_finite()
        && m.beta_deg.is_finite()
        && crate::num::all_finite(&m.dv1_um)
        && crate::num::all_finite(&m.dv2_um)
        && m.dv_std_um.iter().all(|u| u.is_finite()))
    {
        return Err(TwoStepError::NonFinite);
    }
    check_std(m.dv_std_um)?;
    if cfg.tool_z_mm == 0.0 {
        return Err(TwoStepError::ZeroLength);
    }
    let sgn = cfg.reference_end.sign();
    let dv1 = scale(sgn, m.dv1_um);
    let dv2 = scale(sgn, m.dv2_um);
    let (alpha, beta) = (m.alpha_deg.to_radians(), m.beta_deg.to_radians());
    let t_nom = rrttt_tool(cfg, alpha, beta);
    // actual rotated tool vector: tip_actual − (pivot + ΔV1), with tip_actual = tip_nom + ΔV2
    let v = add(t_nom, scale(1e-3, add(dv2, scale(-1.0, dv1))));
    let (d_alpha, d_beta) = match mode {
        Mode::Exact => {
            let [wx, wy, wz] = scale(1.0 / cfg.tool_z_mm, v);
            let (a1, b1, lever) = match cfg.rotation_order {
                RotationOrder::AlphaThenBeta => (
                    libm::atan2(-wy, wz),
                    libm::atan2(wx, crate::num::hypot(wy, wz)),
                    crate::num::hypot(wy, wz),
                ),
                RotationOrder::BetaThenAlpha => (
                    libm::atan2(-wy, crate::num::hypot(wx, wz)),
                    libm::atan2(wx, wz),
                    crate::num::hypot(wx, wz),
                ),
            };
            if !(lever * libm::fabs(cfg.tool_z_mm) >= cfg.min_lever_arm_mm) {
                return Err(TwoStepError::Singular(Singularity::ToolAlongFirstAxis));
            }
            (wrap_pi(a1 - alpha), wrap_pi(b1 - beta))
        }
        Mode::Paper => {
            if cfg.rotation_order != RotationOrder::AlphaThenBeta {
                return Err(TwoStepError::PaperModeUnsupported);
            }
            let p2 = add(m.pivot_mm, t_nom);
            let [x1, _, _] = m.pivot_mm;
            let [x2, _, _] = p2;
            let [dx1, _, _] = dv1;
            let [dx2, _, _] = dv2;
            let db = paper::eq6_delta_beta_rad(
                x1,
                x2,
                dx1,
                dx2,
                cfg.tool_z_mm,
                beta,
                cfg.min_lever_arm_mm,
            )
            .map_err(|_| TwoStepError::Singular(Singularity::ToolAlongFirstAxis))?;
            let da =
                paper::eq7_delta_alpha_rad(m.pivot_mm, p2, dv1, dv2, alpha, cfg.min_lever_arm_mm)?;
            (da, db)
        }
    };
    let model = rrttt_tool(cfg, alpha + d_alpha, beta + d_beta);
    // ∂v/∂(inner angle) has length |z_r|; ∂v/∂(outer angle) has length |z_r|·cos(inner angle)
    let sd_z = angle_std_urad(m.dv_std_um, cfg.tool_z_mm);
    let std_uncertainty_urad = match cfg.rotation_order {
        RotationOrder::AlphaThenBeta => [
            angle_std_urad(m.dv_std_um, cfg.tool_z_mm * crate::num::cos(beta + d_beta)),
            sd_z,
        ],
        RotationOrder::BetaThenAlpha => [
            sd_z,
            angle_std_urad(
                m.dv_std_um,
                cfg.tool_z_mm * crate::num::cos(alpha + d_alpha),
            ),
        ],
    };
    let out = RrtttResult {
        delta_alpha_urad: d_alpha * 1e6,
        delta_beta_urad: d_beta * 1e6,
        std_uncertainty_urad,
        residual_um: residual_um(v, model),
        mode,
    };
    all_finite(
        &[out.delta_alpha_urad, out.delta_beta_urad],
        &out.std_uncertainty_urad,
        &out.residual_um,
    )?;
    Ok(out)
}
