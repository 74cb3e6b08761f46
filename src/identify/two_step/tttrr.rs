//! TTTRR: both rotary axes in the table, α about x and γ about z with the two centres z_αγ
//! apart (seed 000 eqs 8–12).

use super::*;

/// TTTRR machine geometry (seed 000 eq 8): table frame at the α (x-axis) rotation centre, the γ
/// (z-axis) centre `z_alpha_gamma_mm` above it along the α-rotated z, rotation order
/// point = origin + Rx(α)·((0, 0, z_αγ) + Rz(γ)·r).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TttrrConfig {
    /// z distance from the α centre to the γ centre, mm (z_αγ).
    pub z_alpha_gamma_mm: f64,
    /// Reference point (x_r, y_r, z_r) in the γ-centre frame, mm.
    pub reference_point_mm: [f64; 3],
    /// Where the SSM socket sits (seed 000 sections 3–4: on the spindle,
    /// [`ReferenceEnd::OtherMember`] for the table point).
    pub reference_end: ReferenceEnd,
    /// Smallest usable lever arm, mm.
    pub min_lever_arm_mm: f64,
}

/// One TTTRR two-step measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TttrrMeasurement {
    /// Nominal position of the α rotation centre after the translation, mm ((x_1, y_1, z_1)).
    pub origin_mm: [f64; 3],
    /// Nominal α (table tilt about x), degrees.
    pub alpha_deg: f64,
    /// Nominal γ (table rotation about z), degrees.
    pub gamma_deg: f64,
    /// SSM error after the translation (ΔV1), µm.
    pub dv1_um: [f64; 3],
    /// SSM error after the rotation (ΔV2), µm.
    pub dv2_um: [f64; 3],
    /// Standard uncertainty of each SSM component of ΔV1 and of ΔV2 (independent runs), µm;
    /// 0 if unknown. Propagated to the angles' `std_uncertainty_urad`.
    pub dv_std_um: [f64; 2],
}

/// Identified TTTRR orientation errors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TttrrResult {
    /// Δα = α_actual − α_nominal, µrad.
    pub delta_alpha_urad: f64,
    /// Δγ = γ_actual − γ_nominal, µrad.
    pub delta_gamma_urad: f64,
    /// Standard uncertainties of (Δα, Δγ) from `dv_std_um`, µrad (first order: Δγ lever
    /// |Q′|; Δα lever hypot(H, Q′) plus the Δγ coupling through Q′).
    pub std_uncertainty_urad: [f64; 2],
    /// Measured minus modelled reference-point position with the identified angles, µm.
    pub residual_um: [f64; 3],
    /// The formulas used.
    pub mode: Mode,
}

pub(super) fn tttrr_offset(cfg: &TttrrConfig, alpha: f64, gamma: f64) -> [f64; 3] {
    rot_x(
        alpha,
        add(
            [0.0, 0.0, cfg.z_alpha_gamma_mm],
            rot_z(gamma, cfg.reference_point_mm),
        ),
    )
}

/// Nominal TTTRR reference-point position, mm (eq 8, rows derived in spec B.4).
pub fn tttrr_nominal_point_mm(
    cfg: &TttrrConfig,
    origin_mm: [f64; 3],
    alpha_deg: f64,
    gamma_deg: f64,
) -> [f64; 3] {
    add(
        origin_mm,
        tttrr_offset(cfg, alpha_deg.to_radians(), gamma_deg.to_radians()),
    )
}

/// Identifies Δα and Δγ of a TTTRR table (seed 000 §2.1.2, eqs 8–12).
///
/// Exact mode (spec B.4): with v = actual offset from the α centre (mm), ρ = hypot(x_r, y_r),
/// φ = atan2(y_r, x_r): γ′ = ±acos(v_x/ρ) − φ (root nearest γ), Q′ = x_r sin γ′ + y_r cos γ′,
/// α′ = atan2(v_z, v_y) − atan2(H, Q′), H = z_r + z_αγ. Paper mode: corrected eqs 11 and 12.
pub fn identify_tttrr(
    cfg: &TttrrConfig,
    m: &TttrrMeasurement,
    mode: Mode,
) -> Result<TttrrResult, TwoStepError> {
    check_lever(cfg.min_lever_arm_mm)?;
    if !(cfg.z_alpha_gamma_mm.is_finite()
        && crate::num::all_finite(&cfg.reference_point_mm)
        && crate::num::all_finite(&m.origin_mm)
        && m.alpha_deg.is_finite()
        && m.gamma_deg.is_finite()
        && crate::num::all_finite(&m.dv1_um)
        && crate::num::all_finite(&m.dv2_um)
        && m.dv_std_um.iter().all(|u| u.is_finite()))
    {
        return Err(TwoStepError::NonFinite);
    }
    check_std(m.dv_std_um)?;
    let [xr, yr, zr] = cfg.reference_point_mm;
    let rho = crate::num::hypot(xr, yr);
    if rho == 0.0 {
        return Err(TwoStepError::ZeroLength);
    }
    let sgn = cfg.reference_end.sign();
    let dv1 = scale(sgn, m.dv1_um);
    let dv2 = scale(sgn, m.dv2_um);
    let (alpha, gamma) = (m.alpha_deg.to_radians(), m.gamma_deg.to_radians());
    let nom = tttrr_offset(cfg, alpha, gamma);
    let v = add(nom, scale(1e-3, add(dv2, scale(-1.0, dv1))));
    let h = zr + cfg.z_alpha_gamma_mm;
    let q0 = xr * crate::num::sin(gamma) + yr * crate::num::cos(gamma);
    if !(libm::fabs(q0) >= cfg.min_lever_arm_mm) {
        return Err(TwoStepError::Singular(Singularity::GammaLever));
    }
    let (d_alpha, d_gamma) = match mode {
        Mode::Exact => {
            let [vx, vy, vz] = v;
            let ratio = vx / rho;
            if libm::fabs(ratio) > 1.0 {
                return Err(TwoStepError::Inconsistent {
                    excess: libm::fabs(ratio) - 1.0,
                });
            }
            let phi = libm::atan2(yr, xr);
            let ac = crate::num::acos(ratio);
            let g_a = wrap_pi(ac - phi - gamma);
            let g_b = wrap_pi(-ac - phi - gamma);
            let d_gamma = if libm::fabs(g_a) <= libm::fabs(g_b) {
                g_a
            } else {
                g_b
            };
            let g1 = gamma + d_gamma;
            let q1 = xr * crate::num::sin(g1) + yr * crate::num::cos(g1);
            if !(crate::num::hypot(h, q1) >= cfg.min_lever_arm_mm) {
                return Err(TwoStepError::Singular(Singularity::AlphaLever));
            }
            let a1 = libm::atan2(vz, vy) - libm::atan2(h, q1);
            (wrap_pi(a1 - alpha), d_gamma)
        }
        Mode::Paper => {
            let p2 = add(m.origin_mm, nom);
            let [x1, y1, _] = m.origin_mm;
            let [x2, y2, _] = p2;
            let [dx1, dy1, _] = dv1;
            let [dx2, dy2, _] = dv2;
            let dg = paper::eq11_delta_gamma_rad(
                x1,
                x2,
                dx1,
                dx2,
                cfg.reference_point_mm,
                gamma,
                cfg.min_lever_arm_mm,
            )?;
            let da = paper::eq12_delta_alpha_rad(
                y1,
                y2,
                dy1,
                dy2,
                cfg.reference_point_mm,
                cfg.z_alpha_gamma_mm,
                alpha,
                gamma,
                dg,
                cfg.min_lever_arm_mm,
            )?;
            (da, dg)
        }
    };
    let model = tttrr_offset(cfg, alpha + d_alpha, gamma + d_gamma);
    let g1 = gamma + d_gamma;
    let q1 = xr * crate::num::sin(g1) + yr * crate::num::cos(g1);
    let c1 = xr * crate::num::cos(g1) - yr * crate::num::sin(g1);
    // the actual lever arm must be usable too (data far off the nominal can drive it to zero)
    if !(libm::fabs(q1) >= cfg.min_lever_arm_mm) {
        return Err(TwoStepError::Singular(Singularity::GammaLever));
    }
    let sd_gamma = angle_std_urad(m.dv_std_um, q1);
    // α′ = atan2(v_z, v_y) − atan2(H, Q′): direct term on hypot(H, Q′), plus Q′ = Q′(γ′)
    let h2q2 = h * h + q1 * q1;
    let sd_direct = angle_std_urad(m.dv_std_um, crate::num::sqrt(h2q2));
    let coupling = h * c1 / h2q2 * sd_gamma;
    let sd_alpha = crate::num::sqrt(sd_direct * sd_direct + coupling * coupling);
    let out = TttrrResult {
        delta_alpha_urad: d_alpha * 1e6,
        delta_gamma_urad: d_gamma * 1e6,
        std_uncertainty_urad: [sd_alpha, sd_gamma],
        residual_um: residual_um(v, model),
        mode,
    };
    all_finite(
        &[out.delta_alpha_urad, out.delta_gamma_urad],
        &out.std_uncertainty_urad,
        &out.residual_um,
    )?;
    Ok(out)
}
