//! Literal HTM forward model of the thesis, eqs 2.1–2.21 (spec seed-002 §2).
//!
//! Conventions, as printed and used everywhere in this module:
//! - Machine frame O_M on the C-table surface on the nominal C centreline; lengths in mm.
//! - Deviation HTMs (M_BT, M_XB, M_YZ, M_XY, M_CZ) are the printed first-order matrices
//!   (small angles, no second-order terms); command HTMs (E_B about Y, E_C about Z) use exact
//!   sin/cos; a positive B angle φ moves the T-ball to B-centre + (−R_B sin φ, 0, −R_B cos φ).
//! - T-side chain (2.10): `T = E_Z · M_YZ · E_Y · M_XY · E_X · M_XB · E_B · M_BT · T_T`,
//!   T_T = (0, 0, −R_B) plus the T-ball mounting offset in the spindle frame (2.20). So M_XB
//!   pivots about the B centre, M_XY acts on the X translation and everything right of it, M_YZ
//!   on the Y and X translations; Z is outermost.
//! - W-side (2.13): `W = M_CZ · E_C · W_C`; W_C (2.16) is the actual T-ball position at the
//!   mounting pose (B = 0, C = 0, Y = 0, Z = Z_C + R_B, X = 0 for B set-ups or R_C for C
//!   set-ups; eq 2.14/2.15, **without** the T-ball mounting offset, as printed) mapped by the
//!   printed first-order inverse of M_CZ, plus the W-ball clamping offset in the C frame (2.21).
//! - Bar reading (2.17): ΔL = |T − W| − L_B; positive = bar longer.
//!
//! These are the raw equations and do not validate their inputs; the entry points that take
//! user data ([`super::patterns::simulate_eccentricity`], [`super::model_lsq::ModelLsq`],
//! [`super::compensation::compensate`]) do.
use nalgebra::{Matrix4, Vector3, Vector4};

use super::Deviations;

const UM: f64 = 1e-3; // µm → mm
const URAD: f64 = 1e-6; // µrad → rad

/// Axis positions of the model (Tables 2.2/2.3 frame: mm from O_M, angles in rad).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AxisCommand {
    /// X command (mm).
    pub x_mm: f64,
    /// Y command (mm).
    pub y_mm: f64,
    /// Z command (mm).
    pub z_mm: f64,
    /// B command φ (rad).
    pub b_rad: f64,
    /// C command θ (rad).
    pub c_rad: f64,
}

fn htm(r: [[f64; 3]; 3], t: [f64; 3]) -> Matrix4<f64> {
    let [[a, b, c], [d, e, f], [g, h, i]] = r;
    let [x, y, z] = t;
    Matrix4::new(a, b, c, x, d, e, f, y, g, h, i, z, 0.0, 0.0, 0.0, 1.0)
}

fn translation(x: f64, y: f64, z: f64) -> Matrix4<f64> {
    htm(
        [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        [x, y, z],
    )
}

/// M_BT, eq 2.2 (mm).
pub fn m_bt(d: &Deviations) -> Matrix4<f64> {
    let a = d.alpha_bt_urad * URAD;
    htm(
        [[1.0, 0.0, 0.0], [0.0, 1.0, -a], [0.0, a, 1.0]],
        [d.dx_bt_um * UM, 0.0, d.dz_bt_um * UM],
    )
}

/// M_XB, eq 2.3.
pub fn m_xb(d: &Deviations) -> Matrix4<f64> {
    let (a, b, g) = (
        d.alpha_xb_urad * URAD,
        d.beta_xb_urad * URAD,
        d.gamma_xb_urad * URAD,
    );
    htm([[1.0, -g, b], [g, 1.0, -a], [-b, a, 1.0]], [0.0; 3])
}

/// M_YZ, eq 2.5.
pub fn m_yz(d: &Deviations) -> Matrix4<f64> {
    let (a, b) = (d.alpha_yz_urad * URAD, d.beta_yz_urad * URAD);
    htm([[1.0, 0.0, b], [0.0, 1.0, -a], [-b, a, 1.0]], [0.0; 3])
}

/// M_XY, eq 2.6.
pub fn m_xy(d: &Deviations) -> Matrix4<f64> {
    let g = d.gamma_xy_urad * URAD;
    htm([[1.0, -g, 0.0], [g, 1.0, 0.0], [0.0, 0.0, 1.0]], [0.0; 3])
}

/// M_CZ, eq 2.11 (mm).
pub fn m_cz(d: &Deviations) -> Matrix4<f64> {
    let (a, b) = (d.alpha_cz_urad * URAD, d.beta_cz_urad * URAD);
    htm(
        [[1.0, 0.0, b], [0.0, 1.0, -a], [-b, a, 1.0]],
        [d.dx_cz_um * UM, d.dy_cz_um * UM, 0.0],
    )
}

/// The printed first-order inverse of M_CZ, eqs 2.16 and 3.8 (mm).
pub fn m_cz_inv_first_order(d: &Deviations) -> Matrix4<f64> {
    let (a, b) = (d.alpha_cz_urad * URAD, d.beta_cz_urad * URAD);
    htm(
        [[1.0, 0.0, -b], [0.0, 1.0, a], [b, -a, 1.0]],
        [-d.dx_cz_um * UM, -d.dy_cz_um * UM, 0.0],
    )
}

/// E_B, eq 2.4: rotation φ (rad) about Y.
pub fn e_b(phi_rad: f64) -> Matrix4<f64> {
    let (s, c) = (crate::num::sin(phi_rad), crate::num::cos(phi_rad));
    htm([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]], [0.0; 3])
}

/// E_C, eq 2.12: rotation θ (rad) about Z.
pub fn e_c(theta_rad: f64) -> Matrix4<f64> {
    let (s, c) = (crate::num::sin(theta_rad), crate::num::cos(theta_rad));
    htm([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]], [0.0; 3])
}

fn point(m: &Matrix4<f64>, p: Vector4<f64>) -> Vector3<f64> {
    let q = m * p;
    Vector3::new(q.x, q.y, q.z)
}

/// T-ball centre in machine coordinates (mm), eq 2.10 with T_T of eq 2.20:
/// `T_T = (x_T, y_T, z_T − R_B)`, the mounting offset `t_offset_um` given in the spindle frame (µm).
pub fn t_ball_mm(
    d: &Deviations,
    cmd: &AxisCommand,
    r_b_mm: f64,
    t_offset_um: [f64; 3],
) -> Vector3<f64> {
    let [ox, oy, oz] = t_offset_um;
    let t_t = Vector4::new(ox * UM, oy * UM, oz * UM - r_b_mm, 1.0);
    // Applied right to left to the vector (8 matrix–vector products instead of 7 matrix
    // products: the same chain, a fraction of the soft-float work on the target).
    let v = m_bt(d) * t_t;
    let v = e_b(cmd.b_rad) * v;
    let v = m_xb(d) * v;
    let v = translation(cmd.x_mm, 0.0, 0.0) * v;
    let v = m_xy(d) * v;
    let v = translation(0.0, cmd.y_mm, 0.0) * v;
    let v = m_yz(d) * v;
    let v = translation(0.0, 0.0, cmd.z_mm) * v;
    Vector3::new(v.x, v.y, v.z)
}

/// W-ball centre in machine coordinates (mm), eqs 2.13–2.16 and 2.21.
///
/// `x_mount_mm` is the X of the mounting pose (0 for B set-ups, R_C for C set-ups, eq
/// 2.14/2.15); the W-ball is docked at B = 0, C = 0, Y = 0, Z = Z_C + R_B onto the actual
/// (deviated) T-ball without its mounting offset; `w_offset_um` is the clamping shift in the
/// C frame (µm, eq 2.21); `theta_rad` is the C angle.
#[inline(never)] // flash: one body for the model's callers
pub fn w_ball_mm(
    d: &Deviations,
    theta_rad: f64,
    z_c_mm: f64,
    r_b_mm: f64,
    x_mount_mm: f64,
    w_offset_um: [f64; 3],
) -> Vector3<f64> {
    let mount = AxisCommand {
        x_mm: x_mount_mm,
        y_mm: 0.0,
        z_mm: z_c_mm + r_b_mm,
        b_rad: 0.0,
        c_rad: 0.0,
    };
    let w_prime = t_ball_mm(d, &mount, r_b_mm, [0.0; 3]);
    let [ox, oy, oz] = w_offset_um;
    let w_c = point(
        &m_cz_inv_first_order(d),
        Vector4::new(w_prime.x, w_prime.y, w_prime.z, 1.0),
    ) + Vector3::new(ox * UM, oy * UM, oz * UM);
    point(
        &(m_cz(d) * e_c(theta_rad)),
        Vector4::new(w_c.x, w_c.y, w_c.z, 1.0),
    )
}

/// Ball-bar reading ΔL (µm) between the two ball centres (mm), eq 2.17: `|T − W| − L_B`.
#[inline(never)] // flash: one body for the model's callers
pub fn bar_deviation_um(t_mm: &Vector3<f64>, w_mm: &Vector3<f64>, l_b_mm: f64) -> f64 {
    let d = t_mm - w_mm;
    (crate::num::sqrt(d.dot(&d)) - l_b_mm) * 1e3
}

/// R_BT = √(R_B² + L_B²) (mm), eq 2.18: the radius of the tangential B pattern.
pub fn r_bt_mm(r_b_mm: f64, l_b_mm: f64) -> f64 {
    crate::num::sqrt(r_b_mm * r_b_mm + l_b_mm * l_b_mm)
}

/// R_CT = √(R_C² + L_B²) (mm), eq 2.19: the radius of the tangential C pattern.
pub fn r_ct_mm(r_c_mm: f64, l_b_mm: f64) -> f64 {
    crate::num::sqrt(r_c_mm * r_c_mm + l_b_mm * l_b_mm)
}
