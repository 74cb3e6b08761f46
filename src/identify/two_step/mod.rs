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
mod rrttt;
mod rtttr;
mod tttrr;

pub use rrttt::*;
pub use rtttr::*;
pub use tttrr::*;

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
pub(super) fn rot_x(a: f64, v: [f64; 3]) -> [f64; 3] {
    let (s, c) = crate::num::sin_cos(a);
    let [x, y, z] = v;
    [x, c * y - s * z, s * y + c * z]
}

/// Rotation by Ry(b) (right-handed, radians).
pub(super) fn rot_y(b: f64, v: [f64; 3]) -> [f64; 3] {
    let (s, c) = crate::num::sin_cos(b);
    let [x, y, z] = v;
    [c * x + s * z, y, -s * x + c * z]
}

/// Rotation by Rz(g) (right-handed, radians).
pub(super) fn rot_z(g: f64, v: [f64; 3]) -> [f64; 3] {
    let (s, c) = crate::num::sin_cos(g);
    let [x, y, z] = v;
    [c * x - s * y, s * x + c * y, z]
}

pub(super) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let [a0, a1, a2] = a;
    let [b0, b1, b2] = b;
    [a0 + b0, a1 + b1, a2 + b2]
}

pub(super) fn scale(k: f64, a: [f64; 3]) -> [f64; 3] {
    let [a0, a1, a2] = a;
    [k * a0, k * a1, k * a2]
}

/// Wraps an angle difference to (−π, π].
pub(super) fn wrap_pi(a: f64) -> f64 {
    // a − 2π·round(a/2π): exact to rounding for the few turns an angle difference spans, and
    // a tenth of libm::remainder's flash
    let r = a - 2.0 * PI * libm::round(a / (2.0 * PI));
    if r <= -PI { r + 2.0 * PI } else { r }
}

/// Refuses a result with a non-finite figure (DESIGN §9: never a NaN result).
pub(super) fn all_finite(
    angles: &[f64],
    stds: &[f64],
    residual: &[f64; 3],
) -> Result<(), TwoStepError> {
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

pub(super) fn single_result(r: SingleAxisResult) -> Result<SingleAxisResult, TwoStepError> {
    all_finite(&[r.delta_urad], &[r.std_uncertainty_urad], &r.residual_um)?;
    Ok(r)
}

pub(super) fn check_std(dv_std_um: [f64; 2]) -> Result<(), TwoStepError> {
    if dv_std_um.iter().any(|u| *u < 0.0) {
        Err(TwoStepError::NegativeUncertainty)
    } else {
        Ok(())
    }
}

/// First-order standard uncertainty (µrad) of an angle read on a lever arm (mm) from the
/// difference of two independent SSM vectors with component uncertainties σ₁, σ₂ (µm):
/// √(σ₁² + σ₂²)/lever (µm/mm = mrad, hence ×1e3).
pub(super) fn angle_std_urad(dv_std_um: [f64; 2], lever_mm: f64) -> f64 {
    let [a, b] = dv_std_um;
    crate::num::hypot(a, b) / libm::fabs(lever_mm) * 1e3
}

pub(super) fn check_lever(min_lever_arm_mm: f64) -> Result<(), TwoStepError> {
    if min_lever_arm_mm.is_finite() && min_lever_arm_mm > 0.0 {
        Ok(())
    } else {
        Err(TwoStepError::BadMinLeverArm)
    }
}

/// `(measured actual − model actual)` in µm, the residual of the full 3-row model.
pub(super) fn residual_um(measured_rel_mm: [f64; 3], model_rel_mm: [f64; 3]) -> [f64; 3] {
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
