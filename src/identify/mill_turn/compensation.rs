//! Chapter 3 compensation: corrected NC points from identified deviations (eqs 3.4–3.13,
//! spec seed-002 §4).
//!
//! Conventions (as printed): `[X, Y, Z]` is the NC (machine) position of the spindle head and
//! E_B multiplies it directly, so spindle-side deviations act with lever arms equal to the
//! head coordinates (the X_T/Z_T levers of chapter 4). Squareness (M_YZ, M_XY) is not part of
//! the compensation; B and C words are left unchanged, only X, Y, Z are modified.
//! - ideal:  `P  = E_C⁻¹ · E_B · x`                                    (3.4)
//! - actual: `P' = E_C⁻¹ · M_CZ⁻¹ · M_XB · E_B · M_BT · x = A · x`, M_CZ⁻¹ first order (3.7/3.8)
//!
//! Modes (the thesis text is ambiguous, §4.3):
//! - [`CompensationMode::Once`] (primary): the command `x_c` with `A · x_c = P`, i.e. the
//!   machine reaches the ideal workpiece point once; to first order the correction is
//!   `−G⁻¹(P' − P)` (compensation = −error).
//! - [`CompensationMode::PaperDouble`]: eqs 3.11–3.13 literally (`P^C = P + Δ`, then the
//!   actual inverse with M_CZ of 2.11 as the inverse of 3.8) — applies the correction twice to
//!   first order.
use nalgebra::{Matrix4, Vector4};

use super::model::{e_b, e_c, m_bt, m_cz, m_cz_inv_first_order, m_xb};
use super::patterns::NcBlock;
use super::{ARCSEC_PER_RAD, Deviations, ballbar::ThesisDeviations};

/// How the correction is applied (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CompensationMode {
    /// Exact single correction: `A · x_c = P` (primary).
    Once,
    /// Eqs 3.11–3.13 as printed (double correction to first order).
    PaperDouble,
}

/// Why a point could not be compensated.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CompensationError {
    /// An input is NaN or infinite.
    NonFinite,
    /// The actual chain matrix is singular (deviations far outside the small-angle model).
    SingularChain,
}

/// How δx_CZ − δx_BT (the only identified X combination) is split for compensation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DxSplit {
    /// δx_CZ = difference, δx_BT = 0 (default: a C-centreline shift).
    AllInCz,
    /// δx_BT = −difference, δx_CZ = 0.
    AllInBt,
}

/// Maps the chapter-4 result into [`Deviations`] for compensation: angles " → µrad, the X
/// difference split by `split`, α_BT included only if `include_alpha_bt` (the thesis calls it
/// not compensable: the spindle is not angle-controlled); δz_BT and squareness stay 0.
pub fn deviations_for_compensation(
    t: &ThesisDeviations,
    split: DxSplit,
    include_alpha_bt: bool,
) -> Deviations {
    let u = |arcsec: f64| arcsec / ARCSEC_PER_RAD * 1e6;
    let (dx_cz_um, dx_bt_um) = match split {
        DxSplit::AllInCz => (t.dx_cz_minus_dx_bt_um, 0.0),
        DxSplit::AllInBt => (0.0, -t.dx_cz_minus_dx_bt_um),
    };
    Deviations {
        dx_bt_um,
        alpha_bt_urad: if include_alpha_bt {
            u(t.alpha_bt_arcsec)
        } else {
            0.0
        },
        alpha_xb_urad: u(t.alpha_xb_arcsec),
        beta_xb_urad: u(t.beta_xb_arcsec),
        gamma_xb_urad: u(t.gamma_xb_arcsec),
        dx_cz_um,
        dy_cz_um: t.dy_cz_um,
        alpha_cz_urad: u(t.alpha_cz_arcsec),
        beta_cz_urad: u(t.beta_cz_arcsec),
        ..Deviations::default()
    }
}

/// Corrected NC block for `block` (mm, degrees) and identified deviations `dev` (µm, µrad).
pub fn compensate(
    block: &NcBlock,
    dev: &Deviations,
    mode: CompensationMode,
) -> Result<NcBlock, CompensationError> {
    let v = [block.x_mm, block.y_mm, block.z_mm, block.b_deg, block.c_deg];
    if !(crate::num::all_finite(&v) && dev.is_finite()) {
        return Err(CompensationError::NonFinite);
    }
    let (phi, theta) = (block.b_deg.to_radians(), block.c_deg.to_radians());
    let x = Vector4::new(block.x_mm, block.y_mm, block.z_mm, 1.0);
    // E_C⁻¹ (3.6) is the transpose of the rotation: E_C(−θ).
    let ec_inv = e_c(-theta);
    let p = ec_inv * e_b(phi) * x; // (3.4)
    let a: Matrix4<f64> = ec_inv * m_cz_inv_first_order(dev) * m_xb(dev) * e_b(phi) * m_bt(dev);
    let xc = match mode {
        CompensationMode::Once => a.try_inverse().ok_or(CompensationError::SingularChain)? * p,
        CompensationMode::PaperDouble => {
            let p_act = a * x; // (3.7)
            let mut pc = p + (p - p_act); // (3.11), (3.12)
            pc.w = 1.0;
            let inv = |m: Matrix4<f64>| m.try_inverse().ok_or(CompensationError::SingularChain);
            // (3.13)
            inv(m_bt(dev))? * e_b(-phi) * inv(m_xb(dev))? * m_cz(dev) * e_c(theta) * pc
        }
    };
    if !(xc.x.is_finite() && xc.y.is_finite() && xc.z.is_finite()) {
        return Err(CompensationError::NonFinite);
    }
    Ok(NcBlock {
        x_mm: xc.x,
        y_mm: xc.y,
        z_mm: xc.z,
        b_deg: block.b_deg,
        c_deg: block.c_deg,
    })
}
