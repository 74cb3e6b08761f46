//! Seed 000 (Wang, Yu & Liao 2013, spec `seed-000-001.md` part B): orientation errors of a
//! five-axis machine's rotary axes from two SSM total-position-error measurements, ΔV1 after the
//! 3-DOF translation and ΔV2 after the 2-DOF rotation ("two-step" method).
//!
//! Machine types (seed 000 Fig. 1):
//! - **RRTTT** ([`identify_rrttt`]): both rotary axes on the spindle head, α about x and β
//!   about y; tip = pivot + R·(0, 0, z_r) (eqs 2–7).
//! - **TTTRR** ([`identify_tttrr`]): both rotary axes in the table, α about x and γ about z with
//!   the two centres z_αγ apart; point = origin + Rx(α)·(Tz(z_αγ)·Rz(γ)·r) (eqs 8–12).
//! - **RTTTR** ([`identify_rtttr_spindle`], [`identify_rtttr_table`]): β about y on the spindle
//!   (eqs 13, 15, 17) and α about x in the table (eqs 14, 16, 18), two separate procedures.
//!
//! Two [`Mode`]s: [`Mode::Exact`] (primary) inverts the non-linear model in closed form
//! (atan2 / acos, spec B.3–B.5 "exact inversion") and has no truncation error;
//! [`Mode::Paper`] evaluates the paper's first-order formulas (eqs 6, 7, 11, 12, 17, 18) with
//! the errata of spec B.9 fixed (eq 11: `x_1 − x_2`; eq 12: `x_1 − x_2 + Δx_V1 − Δx_V2` in
//! numerator and denominator; eq 6 with the *signed* tool length). Paper mode reproduces
//! seed 000 Table 1 (e.g. Δβ′ = 0.07995° for an injected 0.08°). The raw paper formulas are in
//! [`paper`] for callers holding the paper's own inputs (nominal coordinates after rotation).
//!
//! Conventions (spec part D 1, 8), all explicit configuration:
//! - error = actual − nominal; ΔV in µm, positions in mm, nominal angles in degrees, identified
//!   orientation errors in µrad (`Δθ = θ_actual − θ_nominal`);
//! - rotations are right-handed: `Rx(a) = [[1,0,0],[0,c,−s],[0,s,c]]`,
//!   `Ry(b) = [[c,0,s],[0,1,0],[−s,0,c]]`, `Rz(g) = [[c,−s,0],[s,c,0],[0,0,1]]` (rows);
//! - the tool vector is *signed*: seed 000 Table 1 needs the tool along −z of the spindle frame,
//!   i.e. `tool_z_mm = −250` (spec B.7 item 1);
//! - ΔV1 is the translation error and is carried unchanged into the after-rotation state
//!   (eq 4: `Trans(x_1 + Δx_V1, …)`);
//! - [`ReferenceEnd`] says on which member the ball-bar socket (the SSM reference point) sits.
//!
//! Quality figures: both modes report the residual of the full three-row model evaluated with
//! the identified angles against the measured position (the "unused equation": three rows, two
//! unknowns for RRTTT/TTTRR, three rows and one unknown for RTTTR), and the first-order standard
//! uncertainty of each angle propagated from the SSM component uncertainties of ΔV1 and ΔV2,
//! `dv_std_um` (each run its own: the pod states each SSM run's u).

use core::f64::consts::PI;

/// Micro-radians per degree.
pub const URAD_PER_DEG: f64 = PI / 180.0 * 1e6;

/// Default smallest lever arm (mm) below which an orientation error is declared unobservable:
/// a 1 mm lever turns 1 µrad into 1 nm, below the SSM resolution.
pub const DEFAULT_MIN_LEVER_ARM_MM: f64 = 1.0;

/// Which formulas identify the orientation errors.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Closed-form inversion of the non-linear model (atan2/acos; spec B.3–B.5): exact for
    /// noise-free data. The primary result.
    Exact,
    /// The paper's first-order formulas (eqs 6, 7, 11, 12, 17, 18) with the errata of spec B.9
    /// corrected; eq 7 is returned as printed (= tan Δα). Reproduces seed 000 Table 1.
    Paper,
}

/// Where the ball-bar socket (the SSM reference point) is mounted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReferenceEnd {
    /// The socket is on the member that does *not* carry the rotated point (RRTTT: on the table;
    /// TTTRR: on the spindle): the SSM vector E is directly the displacement of the rotated
    /// point (tool tip / table reference point), actual − nominal.
    OtherMember,
    /// The socket is on the rotated member itself: the SSM vector E is the displacement of the
    /// other end relative to it, so ΔV = −E is used.
    RotatedMember,
}

impl ReferenceEnd {
    /// Sign applied to the SSM vectors to get the displacement of the rotated point.
    const fn sign(self) -> f64 {
        match self {
            Self::OtherMember => 1.0,
            Self::RotatedMember => -1.0,
        }
    }
}

/// Order of the two spindle-head rotations of an RRTTT machine applied to the tool vector.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RotationOrder {
    /// tip = pivot + Rx(α)·Ry(β)·t (seed 000 eqs 2 and 4; the paper's order).
    AlphaThenBeta,
    /// tip = pivot + Ry(β)·Rx(α)·t (β axis carries the α axis). Exact mode only.
    BetaThenAlpha,
}

/// The geometric condition that makes an orientation error unobservable (spec part D 9).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Singularity {
    /// RRTTT (α then β): |z_r·cos β| below the minimum lever arm; α cannot be seen (and eq 6
    /// divides by cos β). For β then α, the same with cos α.
    ToolAlongFirstAxis,
    /// RTTTR spindle, paper mode: |z_r·cos β| below the minimum lever arm (eq 17 has sec β).
    SpindleBetaLever,
    /// TTTRR: the rotated reference point has no lever arm for an x displacement,
    /// |x_r sin γ + y_r cos γ| below the minimum (eq 11 denominator; exact acos ill-posed).
    GammaLever,
    /// TTTRR: the A-axis lever arm vanishes — paper mode: |H cos α + Q′ sin α| (eq 12
    /// denominator); exact mode: hypot(H, Q′) — below the minimum.
    AlphaLever,
    /// RTTTR table: paper mode |z_tr cos α + y_tr sin α| (eq 18 denominator), exact mode
    /// hypot(y_tr, z_tr), below the minimum lever arm.
    TableAlphaLever,
}

/// Why an orientation error could not be identified.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TwoStepError {
    /// An input (position, angle, ΔV, configuration value) is NaN or infinite.
    NonFinite,
    /// The tool length / reference-point lever is zero (or the radius about the γ axis is zero).
    ZeroLength,
    /// `min_lever_arm_mm` is not a positive finite number.
    BadMinLeverArm,
    /// An entry of `dv_std_um` is negative.
    NegativeUncertainty,
    /// The geometry makes an error unobservable (see [`Singularity`]).
    Singular(Singularity),
    /// The measured displacement is inconsistent with the model: the x row asks for
    /// |cos(γ′ + φ)| > 1 (TTTRR). `excess` = |v_x/ρ| − 1.
    Inconsistent {
        /// How far |v_x / ρ| exceeds 1.
        excess: f64,
    },
    /// The paper's formulas exist only for the paper's rotation order (Rx·Ry).
    PaperModeUnsupported,
    /// The identified angles put the actual lever arm at zero (data far outside the model):
    /// an uncertainty or residual would not be finite, so nothing is returned.
    NonFiniteResult,
}

/// Nominal rotation of a 3-vector by Rx(a) (right-handed, radians).
fn rot_x(a: f64, v: [f64; 3]) -> [f64; 3] {
    let (s, c) = crate::num::sin_cos(a);
    let [x, y, z] = v;
    [x, c * y - s * z, s * y + c * z]
}

/// Rotation by Ry(b) (right-handed, radians).
fn rot_y(b: f64, v: [f64; 3]) -> [f64; 3] {
    let (s, c) = crate::num::sin_cos(b);
    let [x, y, z] = v;
    [c * x + s * z, y, -s * x + c * z]
}

/// Rotation by Rz(g) (right-handed, radians).
fn rot_z(g: f64, v: [f64; 3]) -> [f64; 3] {
    let (s, c) = crate::num::sin_cos(g);
    let [x, y, z] = v;
    [c * x - s * y, s * x + c * y, z]
}

fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let [a0, a1, a2] = a;
    let [b0, b1, b2] = b;
    [a0 + b0, a1 + b1, a2 + b2]
}

fn scale(k: f64, a: [f64; 3]) -> [f64; 3] {
    let [a0, a1, a2] = a;
    [k * a0, k * a1, k * a2]
}

/// Wraps an angle difference to (−π, π].
fn wrap_pi(a: f64) -> f64 {
    // a − 2π·round(a/2π): exact to rounding for the few turns an angle difference spans, and
    // a tenth of libm::remainder's flash
    let r = a - 2.0 * PI * libm::round(a / (2.0 * PI));
    if r <= -PI { r + 2.0 * PI } else { r }
}

/// Refuses a result with a non-finite figure (DESIGN §9: never a NaN result).
fn all_finite(angles: &[f64], stds: &[f64], residual: &[f64; 3]) -> Result<(), TwoStepError> {
    if angles
        .iter()
        .chain(stds.iter())
        .chain(residual.iter())
        .all(|v| v.is_finite())
    {
        Ok(())
    } else {
        Err(TwoStepError::NonFiniteResult)
    }
}

fn single_result(r: SingleAxisResult) -> Result<SingleAxisResult, TwoStepError> {
    all_finite(&[r.delta_urad], &[r.std_uncertainty_urad], &r.residual_um)?;
    Ok(r)
}

fn check_std(dv_std_um: [f64; 2]) -> Result<(), TwoStepError> {
    if dv_std_um.iter().any(|u| *u < 0.0) {
        Err(TwoStepError::NegativeUncertainty)
    } else {
        Ok(())
    }
}

/// First-order standard uncertainty (µrad) of an angle read on a lever arm (mm) from the
/// difference of two independent SSM vectors with component uncertainties σ₁, σ₂ (µm):
/// √(σ₁² + σ₂²)/lever (µm/mm = mrad, hence ×1e3).
fn angle_std_urad(dv_std_um: [f64; 2], lever_mm: f64) -> f64 {
    let [a, b] = dv_std_um;
    crate::num::hypot(a, b) / libm::fabs(lever_mm) * 1e3
}

fn check_lever(min_lever_arm_mm: f64) -> Result<(), TwoStepError> {
    if min_lever_arm_mm.is_finite() && min_lever_arm_mm > 0.0 {
        Ok(())
    } else {
        Err(TwoStepError::BadMinLeverArm)
    }
}

/// `(measured actual − model actual)` in µm, the residual of the full 3-row model.
fn residual_um(measured_rel_mm: [f64; 3], model_rel_mm: [f64; 3]) -> [f64; 3] {
    let [m0, m1, m2] = measured_rel_mm;
    let [p0, p1, p2] = model_rel_mm;
    [(m0 - p0) * 1e3, (m1 - p1) * 1e3, (m2 - p2) * 1e3]
}

/// The paper's first-order formulas of seed 000, in the paper's own variables, errata fixed.
///
/// Units: positions mm, ΔV µm (converted to mm inside), nominal angles and results in radians.
/// `p1` is the nominal position after the translation (pivot / table origin), `p2` the nominal
/// position of the tool tip / reference point after the rotation (as in Table 1, "(x_2, y_2,
/// z_2)"), `dv1_um`/`dv2_um` the SSM errors before/after the rotation.
pub mod paper {
    use super::{Singularity, TwoStepError};

    /// Eq 6 (= eq 17): Δβ = −sec β·(x_1 − x_2 + Δx_V1 − Δx_V2 + z_r sin β)/z_r, with the
    /// *signed* tool length `z_r_mm` (spec B.3: the printed +z_r only fits a +z tool). First
    /// order: the printed values are Δβ − tan β·Δβ²/2 (Table 1: 0.07995° for 0.08°).
    /// Singular when |z_r cos β| < `min_lever_arm_mm`.
    pub fn eq6_delta_beta_rad(
        x1_mm: f64,
        x2_mm: f64,
        dx_v1_um: f64,
        dx_v2_um: f64,
        z_r_mm: f64,
        beta_rad: f64,
        min_lever_arm_mm: f64,
    ) -> Result<f64, TwoStepError> {
        let lever = z_r_mm * crate::num::cos(beta_rad);
        if !(libm::fabs(lever) >= min_lever_arm_mm) {
            return Err(TwoStepError::Singular(Singularity::SpindleBetaLever));
        }
        let num = x1_mm - x2_mm + (dx_v1_um - dx_v2_um) * 1e-3 + z_r_mm * crate::num::sin(beta_rad);
        Ok(-num / lever)
    }

    /// Eq 7 as printed: Δα ≈ [u cos α + w sin α] / [−w cos α + u sin α], with
    /// u = (y_2 + Δy_V2) − (y_1 + Δy_V1), w = (z_2 + Δz_V2) − (z_1 + Δz_V1). This equals
    /// tan Δα exactly (spec B.3); it is returned as printed (first order, tan Δα ≈ Δα).
    /// Independent of β, z_r and the tool sign. Singular when the denominator
    /// (= −z_r cos β′ cos Δα) is below `min_lever_arm_mm`.
    pub fn eq7_delta_alpha_rad(
        p1_mm: [f64; 3],
        p2_mm: [f64; 3],
        dv1_um: [f64; 3],
        dv2_um: [f64; 3],
        alpha_rad: f64,
        min_lever_arm_mm: f64,
    ) -> Result<f64, TwoStepError> {
        let [_, y1, z1] = p1_mm;
        let [_, y2, z2] = p2_mm;
        let [_, dy1, dz1] = dv1_um;
        let [_, dy2, dz2] = dv2_um;
        let u = y2 - y1 + (dy2 - dy1) * 1e-3;
        let w = z2 - z1 + (dz2 - dz1) * 1e-3;
        let (s, c) = crate::num::sin_cos(alpha_rad);
        let den = -w * c + u * s;
        if !(libm::fabs(den) >= min_lever_arm_mm) {
            return Err(TwoStepError::Singular(Singularity::ToolAlongFirstAxis));
        }
        Ok((u * c + w * s) / den)
    }

    /// Eq 11, **corrected** (`x_1 − x_2`, spec B.4; the printed `x_1 + x_2` gives 118°):
    /// Δγ = (x_1 − x_2 + Δx_V1 − Δx_V2 + x_r cos γ − y_r sin γ)/(x_r sin γ + y_r cos γ).
    /// `r_mm` = (x_r, y_r, z_r), the reference point in the γ-centre frame.
    /// Singular when |x_r sin γ + y_r cos γ| < `min_lever_arm_mm`.
    pub fn eq11_delta_gamma_rad(
        x1_mm: f64,
        x2_mm: f64,
        dx_v1_um: f64,
        dx_v2_um: f64,
        r_mm: [f64; 3],
        gamma_rad: f64,
        min_lever_arm_mm: f64,
    ) -> Result<f64, TwoStepError> {
        let [xr, yr, _] = r_mm;
        let (s, c) = crate::num::sin_cos(gamma_rad);
        let q0 = xr * s + yr * c;
        if !(libm::fabs(q0) >= min_lever_arm_mm) {
            return Err(TwoStepError::Singular(Singularity::GammaLever));
        }
        Ok((x1_mm - x2_mm + (dx_v1_um - dx_v2_um) * 1e-3 + xr * c - yr * s) / q0)
    }

    /// Eq 12, **corrected** (spec B.4: `(x_1 − x_2 + Δx_V1 − Δx_V2)` where the print has
    /// `(x_1 − x_2 + Δx_V2)`, in numerator and denominator), written in its derived form
    /// Δα = (y_1 − y_2 + Δy_V1 − Δy_V2 + Q′ cos α − H sin α)/(H cos α + Q′ sin α), with
    /// H = z_r + z_αγ, Q′ = Q_0 + Δγ·C, Q_0 = x_r sin γ + y_r cos γ, C = x_r cos γ − y_r sin γ
    /// and Δγ from corrected eq 11 (`delta_gamma_rad`). Uses the x and y rows only.
    /// Singular when |H cos α + Q′ sin α| < `min_lever_arm_mm`.
    #[allow(clippy::too_many_arguments)]
    pub fn eq12_delta_alpha_rad(
        y1_mm: f64,
        y2_mm: f64,
        dy_v1_um: f64,
        dy_v2_um: f64,
        r_mm: [f64; 3],
        z_alpha_gamma_mm: f64,
        alpha_rad: f64,
        gamma_rad: f64,
        delta_gamma_rad: f64,
        min_lever_arm_mm: f64,
    ) -> Result<f64, TwoStepError> {
        let [xr, yr, zr] = r_mm;
        let (sg, cg) = crate::num::sin_cos(gamma_rad);
        let q = xr * sg + yr * cg + delta_gamma_rad * (xr * cg - yr * sg);
        let h = zr + z_alpha_gamma_mm;
        let (sa, ca) = crate::num::sin_cos(alpha_rad);
        let den = h * ca + q * sa;
        if !(libm::fabs(den) >= min_lever_arm_mm) {
            return Err(TwoStepError::Singular(Singularity::AlphaLever));
        }
        Ok((y1_mm - y2_mm + (dy_v1_um - dy_v2_um) * 1e-3 + q * ca - h * sa) / den)
    }

    /// Eq 18 (correct as printed): Δα = (y_t1 − y_t2 + Δy_tV1 − Δy_tV2 + y_tr cos α −
    /// z_tr sin α)/(z_tr cos α + y_tr sin α); `r_mm` = (x_tr, y_tr, z_tr) in the table frame.
    /// Singular when |z_tr cos α + y_tr sin α| < `min_lever_arm_mm`.
    pub fn eq18_delta_alpha_rad(
        y1_mm: f64,
        y2_mm: f64,
        dy_v1_um: f64,
        dy_v2_um: f64,
        r_mm: [f64; 3],
        alpha_rad: f64,
        min_lever_arm_mm: f64,
    ) -> Result<f64, TwoStepError> {
        let [_, ytr, ztr] = r_mm;
        let (s, c) = crate::num::sin_cos(alpha_rad);
        let den = ztr * c + ytr * s;
        if !(libm::fabs(den) >= min_lever_arm_mm) {
            return Err(TwoStepError::Singular(Singularity::TableAlphaLever));
        }
        Ok((y1_mm - y2_mm + (dy_v1_um - dy_v2_um) * 1e-3 + ytr * c - ztr * s) / den)
    }
}

// ---------------------------------------------------------------------------------------- RRTTT

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
fn rrttt_tool(cfg: &RrtttConfig, alpha: f64, beta: f64) -> [f64; 3] {
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

// ---------------------------------------------------------------------------------------- TTTRR

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

fn tttrr_offset(cfg: &TttrrConfig, alpha: f64, gamma: f64) -> [f64; 3] {
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

// ---------------------------------------------------------------------------------------- RTTTR

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

fn single_inputs_ok(m: &SingleAxisMeasurement) -> bool {
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
