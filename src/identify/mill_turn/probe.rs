//! Chapter 5 touch-probe method (eqs 5.1–5.19, spec seed-002 §6): measured reference-sphere
//! centres at several C and B positions → C and B deviations.
//!
//! Inputs are sphere centres in machine coordinates (mm) as the probe reports them (how the
//! centre is fitted is the metrology's job). Deviations are errors (actual − nominal).
//!
//! **Corrected mode** (primary) follows the literal HTM model (eqs 2.2, 2.3, 2.11; spec §9.1
//! items 4–5):
//! - the C axis direction under (2.11) is (β_CZ, −α_CZ, 1), so α_CZ = **−**Y_N/Z_N (the
//!   thesis's (5.6) has +);
//! - the probe reports the sphere centre displaced by the **negative** of the tool-tip
//!   displacement d(φ); with the literal model, at B = 0: ΔX = −(δx_BT − R_B β_XB),
//!   ΔY = −R_B(α_BT + α_XB), ΔZ = −δz_BT; at B = 90°: ΔX = −δz_BT, ΔY = −R_B(α_BT − γ_XB),
//!   ΔZ = δx_BT − R_B β_XB. The two tool lengths give δx_BT, δz_BT, β_XB by least squares
//!   (8 equations, 3 unknowns: residual and uncertainties), and from Y only the combinations
//!   α_BT + α_XB and α_BT − γ_XB (so α_XB + γ_XB); α_XB, γ_XB, α_BT separately are not
//!   observable with B = 0/90° alone.
//!
//! **Paper mode** evaluates (5.5), (5.6), (5.12), (5.13), (5.15), (5.17), (5.19) verbatim
//! (TV-12). The thesis's Table 5.3 is not reproducible from its Table 5.2 by either mode.
use nalgebra::Vector3;

use super::ARCSEC_PER_RAD;
use super::lobing::LOBING_COMPONENTS;
use crate::identify::lsq::{DEFAULT_RANK_TOL, GivensLsq, LsqError};
use crate::metrology::solve3::cholesky_solve;

/// Corrected (literal-model signs) or paper (formulas as printed) evaluation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeMode {
    /// Signs of the literal HTM model (primary).
    Corrected,
    /// Eqs 5.1–5.19 as printed.
    Paper,
}

/// Why a probe identification could not be computed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ProbeError {
    /// An input is NaN or infinite.
    NonFinite,
    /// The four C positions do not span a circle: the diagonals P1P3 and P2P4 are parallel or
    /// vanish, or the normal is perpendicular to Z (Z_N ≈ 0).
    DegenerateCircle,
    /// A tool length is ≤ 0 (names which).
    NonPositiveLength {
        /// `"R_B"`, `"R'_B"` or `"X_T"`.
        what: &'static str,
    },
    /// R'_B = R_B: the two styli cannot separate β_XB from δx_BT (eqs 5.12/5.13 divide by
    /// R'_B − R_B).
    SameToolLength,
    /// The least-squares step failed.
    Lsq(LsqError),
}

/// Sphere centres probed at C = 0°, 90°, 180°, 270° (B = 0), machine coordinates (mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CAxisProbe {
    /// P1…P4: centres at C = 0, 90, 180, 270° (mm); C positive counter-clockwise about +Z.
    pub centres_mm: [[f64; 3]; 4],
    /// Nominal C centreline (X, Y) in machine coordinates (mm): the reference of ΔX_c, ΔY_c.
    pub nominal_axis_xy_mm: [f64; 2],
    /// Z_C: sphere centre height above the C table (mm), the lever of (5.7).
    pub z_c_mm: f64,
    /// Standard uncertainties of P1…P4 (X, Y, Z in µm; e.g. the sphere fits'). All > 0: the
    /// result's uncertainties are propagated from them, with the diagonals' mismatch as
    /// [`Self::std_uncertainty_dof`] says; otherwise (e.g. all 0, not known) from the mismatch
    /// alone (the one redundancy of four points on a circle: 3 degrees of freedom).
    pub centres_std_uncertainty_um: [[f64; 3]; 4],
    /// Degrees of freedom behind the stated uncertainties (e.g. the sphere fits' residuals,
    /// pooled): the Z mismatch's scatter, which only the touches' scatter makes, is pooled with
    /// them for the tilts, `k² = (ν + χ²)/(ν + 1)` (larger than they say raises u, smaller
    /// lowers it). 0: the stated u taken as they are, raised by the Birge ratio where the Z
    /// mismatch is larger. The plane's mismatch, which also shows the C axis stopping off its
    /// positions, always raises δx's and δy's u as a Birge ratio where it is larger.
    pub std_uncertainty_dof: f64,
}

/// C-axis result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CAxisResult {
    /// α_CZ (").
    pub alpha_cz_arcsec: f64,
    /// β_CZ (").
    pub beta_cz_arcsec: f64,
    /// δx_CZ (µm), (5.7).
    pub dx_cz_um: f64,
    /// δy_CZ (µm), (5.7).
    pub dy_cz_um: f64,
    /// N = P1P3 × P2P4 (mm²), (5.1)–(5.4).
    pub normal_mm2: [f64; 3],
    /// Trajectory centre error (ΔX_c, ΔY_c) (µm): mean of the four centres − nominal axis.
    pub centre_error_um: [f64; 2],
    /// Quality figure: distance between the midpoints of the two diagonals (µm); zero for a
    /// perfect circle probed at 90° steps (four points over-determine the circle centre).
    pub diagonal_mismatch_um: f64,
    /// Standard uncertainties of (α_CZ ", β_CZ ", δx_CZ µm, δy_CZ µm), first order, from
    /// the centres' (see [`CAxisProbe::centres_std_uncertainty_um`]): the tilts are the slopes
    /// of Z along the two diagonals, `u² = (u_Z1² + u_Z3²)/|P1P3|²` and `(u_Z2² + u_Z4²)/|P2P4|²`
    /// turned into X and Y; δx = ΔX_c − Z_C β and δy = ΔY_c + Z_C α with ΔX_c, ΔY_c the mean of
    /// four X and Y (`u² = Σu²/16`), independent of the Z. The centres' X and Y enter the tilts
    /// in second order only (tilt × their relative error).
    pub std_uncertainty: [f64; 4],
}

/// C-axis deviations from four sphere centres (eqs 5.1–5.7). The trajectory centre is the mean
/// of the four centres (exact for 90° steps; the thesis does not say). (5.7) uses exact
/// rotations: `[δx; δy; ·] = Rx(−α_CZ)·Ry(−β_CZ)·[ΔX_c; ΔY_c; Z_C]`, i.e. to first order
/// δx = ΔX_c − Z_C β_CZ, δy = ΔY_c + Z_C α_CZ (consistent with (2.11)).
pub fn identify_c_axis(input: &CAxisProbe, mode: ProbeMode) -> Result<CAxisResult, ProbeError> {
    let [p1, p2, p3, p4] = input.centres_mm;
    if !(crate::num::all_finite(input.centres_mm.as_flattened())
        && crate::num::all_finite(input.centres_std_uncertainty_um.as_flattened())
        && crate::num::all_finite(&input.nominal_axis_xy_mm)
        && input.z_c_mm.is_finite())
    {
        return Err(ProbeError::NonFinite);
    }
    let v = |p: [f64; 3]| Vector3::new(p[0], p[1], p[2]);
    let (p1, p2, p3, p4) = (v(p1), v(p2), v(p3), v(p4));
    let d13 = p3 - p1;
    let d24 = p4 - p2;
    let n = d13.cross(&d24); // (5.1)–(5.4)
    // The ratios of (5.5)/(5.6) do not depend on the sense of rotation (N flips as a whole),
    // so only |Z_N| ≈ 0 is degenerate.
    if !(libm::fabs(n.z)
        > 1e-9 * crate::num::sqrt(d13.norm_squared()) * crate::num::sqrt(d24.norm_squared()))
        || crate::num::sqrt(d13.norm_squared()) == 0.0
        || crate::num::sqrt(d24.norm_squared()) == 0.0
    {
        return Err(ProbeError::DegenerateCircle);
    }
    let beta = n.x / n.z; // (5.5)
    let alpha = match mode {
        ProbeMode::Paper => n.y / n.z,      // (5.6) as printed
        ProbeMode::Corrected => -n.y / n.z, // axis direction (β, −α, 1) under (2.11)
    };
    let centre = (p1 + p2 + p3 + p4) / 4.0;
    let diff = (p1 + p3) / 2.0 - (p2 + p4) / 2.0;
    let mismatch = crate::num::sqrt(diff.norm_squared()) * 1e3;
    let u = c_axis_uncertainty(
        &input.centres_std_uncertainty_um,
        input.std_uncertainty_dof,
        [diff.x, diff.y, diff.z],
        [d13.x, d13.y, d13.z],
        [d24.x, d24.y, d24.z],
        input.z_c_mm,
    );
    let [nx, ny] = input.nominal_axis_xy_mm;
    let (dxc, dyc) = (centre.x - nx, centre.y - ny);
    // (5.7), mm
    // R_x(−α)·R_y(−β)·(Δx, Δy, Z_C), written out (nalgebra's Rotation3 would link libm's
    // general sin/cos; see crate::num::sin_cos).
    let d = {
        let (sb, cb) = crate::num::sin_cos(-beta);
        let (sa, ca) = crate::num::sin_cos(-alpha);
        let (x1, z1) = (cb * dxc + sb * input.z_c_mm, -sb * dxc + cb * input.z_c_mm);
        Vector3::new(x1, ca * dyc - sa * z1, sa * dyc + ca * z1)
    };
    Ok(CAxisResult {
        alpha_cz_arcsec: alpha * ARCSEC_PER_RAD,
        beta_cz_arcsec: beta * ARCSEC_PER_RAD,
        dx_cz_um: d.x * 1e3,
        dy_cz_um: d.y * 1e3,
        normal_mm2: [n.x, n.y, n.z],
        centre_error_um: [dxc * 1e3, dyc * 1e3],
        diagonal_mismatch_um: mismatch,
        std_uncertainty: u,
    })
}

/// The factor on stated variances from a method's reduced χ² (`reduced`, over `nu_m` degrees of
/// freedom): with `nu` degrees of freedom behind the stated u, the two estimates of the scatter
/// pooled, `(ν + ν_m·χ²/ν_m)/(ν + ν_m)`; with none, the Birge ratio² where above 1.
fn variance_factor(reduced: f64, nu_m: f64, nu: f64) -> f64 {
    if nu > 0.0 {
        (nu + nu_m * reduced) / (nu + nu_m)
    } else {
        reduced.max(1.0)
    }
}

/// [`CAxisResult::std_uncertainty`] from the centres' stated uncertainties `u_um`, the
/// diagonals' midpoint difference `diff_mm`, the diagonals `d13_mm`, `d24_mm` and Z_C. In f32
/// (three significant digits are all an uncertainty needs; f64 here is soft-float on the pod
/// and cost 1.6 KB of flash).
///
/// The centres' variances: stated (× Birge² of the mismatch, the plane's and Z's apart) or
/// from the mismatch. The midpoints' difference has per-component variance Σ u_k²/4 over the
/// four centres (σ² for equal u), so |diff|²/3 estimates σ² from its three components.
#[inline(never)] // inlined into the application's `execute`, its code doubles
fn c_axis_uncertainty(
    u_um: &[[f64; 3]; 4],
    dof: f64,
    diff_mm: [f64; 3],
    d13_mm: [f64; 3],
    d24_mm: [f64; 3],
    z_c_mm: f64,
) -> [f64; 4] {
    let f = |x: f64| x as f32;
    let [[x1, y1, z1], [x2, y2, z2], [x3, y3, z3], [x4, y4, z4]] = u_um.map(|p| p.map(f));
    let sq = |a: f32, b: f32, c: f32, d: f32| a * a + b * b + c * c + d * d;
    let (sx, sy) = (sq(x1, x2, x3, x4), sq(y1, y2, y3, y4));
    let (z13, z24) = (z1 * z1 + z3 * z3, z2 * z2 + z4 * z4);
    let [dx, dy, dz] = diff_mm.map(|v| f(v * 1e3));
    let stated = u_um.iter().flatten().all(|u| *u > 0.0);
    let (sum_x, sum_y, z13, z24) = if stated {
        // the plane and Z apart: the C axis stopping off its positions shifts the spheres
        // across (the plane's mismatch: a Birge ratio where larger), never their Z, so it must
        // not raise the tilts' u (which come from Z alone; its mismatch is the touches' scatter,
        // pooled with the stated u's degrees of freedom)
        let chi2_xy = 2.0 * (dx * dx / sx + dy * dy / sy);
        let b2_xy = variance_factor(f64::from(chi2_xy), 2.0, 0.0) as f32;
        let chi2_z = 4.0 * dz * dz / (z13 + z24);
        let b2_z = variance_factor(f64::from(chi2_z), 1.0, dof) as f32;
        (sx * b2_xy, sy * b2_xy, z13 * b2_z, z24 * b2_z)
    } else {
        let v = (dx * dx + dy * dy + dz * dz) / 3.0;
        (4.0 * v, 4.0 * v, 2.0 * v, 2.0 * v)
    };
    // slopes of Z along the diagonals (rad²), then along X and Y (cos² φ, sin² φ of P1P3)
    let len2 = |d: [f64; 3]| {
        let [a, b, c] = d.map(|v| f(v * 1e3));
        a * a + b * b + c * c
    };
    let (l13, l24) = (len2(d13_mm), len2(d24_mm));
    let (s13, s24) = (z13 / l13, z24 / l24);
    let c2 = {
        let x = f(d13_mm[0] * 1e3);
        x * x / l13
    };
    let var_beta = c2 * s13 + (1.0 - c2) * s24;
    let var_alpha = (1.0 - c2) * s13 + c2 * s24;
    let zc = f(z_c_mm * 1e3); // µm per rad
    let var_dx = sum_x / 16.0 + zc * zc * var_beta;
    let var_dy = sum_y / 16.0 + zc * zc * var_alpha;
    let arcsec = ARCSEC_PER_RAD as f32;
    [
        crate::num::sqrtf(var_alpha) * arcsec,
        crate::num::sqrtf(var_beta) * arcsec,
        crate::num::sqrtf(var_dx),
        crate::num::sqrtf(var_dy),
    ]
    .map(f64::from)
}

/// Sphere centres probed at B = 0° and 90° with two styli (tool lengths R_B, R'_B), and their
/// nominal positions (machine coordinates, mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BAxisProbe {
    /// Measured centres: [B = 0 with R_B, B = 90° with R_B, B = 0 with R'_B, B = 90° with R'_B].
    pub measured_mm: [[f64; 3]; 4],
    /// Nominal centres in the same order (the thesis does not state them; spec §6.6).
    pub nominal_mm: [[f64; 3]; 4],
    /// Standard uncertainties of the measured centres (X, Y, Z in µm, same order; e.g. the
    /// sphere fits'). All > 0: corrected mode weights the equations by them and states
    /// uncertainties propagated from them, with the residual's scatter pooled
    /// ([`Self::std_uncertainty_dof`]) or as a Birge ratio where it is larger; otherwise (e.g.
    /// all 0, not known) from the residual alone (which then holds the lobing too).
    pub measured_std_uncertainty_um: [[f64; 3]; 4],
    /// The measured centres' shifts (X, Y, Z in µm, same order) for one standard uncertainty
    /// of each of the probe's lobing components ([`super::lobing`]; 0: none). Counted
    /// only where the residual is weighed against the stated uncertainties (the Birge ratio):
    /// the lobing moves the spheres of a B position alike but the B = 0° and 90° spheres
    /// differently, so it leaves a residual. Its share of the result is the caller's
    /// ([`super::lobing::lobing_share`]).
    pub lobing_shift_um: [[[f64; 3]; LOBING_COMPONENTS]; 4],
    /// Degrees of freedom behind the stated uncertainties, pooled with the residual's as
    /// [`CAxisProbe::std_uncertainty_dof`] says (0: the Birge ratio where larger).
    pub std_uncertainty_dof: f64,
    /// R_B: B origin → probe sphere along Z (mm), short stylus.
    pub r_b_mm: f64,
    /// R'_B: same with the long stylus (mm).
    pub r_b2_mm: f64,
    /// X_T: nominal X of the reference sphere (mm; paper mode's (5.17) lever only).
    pub x_t_mm: f64,
}

/// B-axis result. In corrected mode `alpha_xb_arcsec` and `gamma_xb_arcsec` are `None` (not
/// separable); in paper mode the combinations are `None`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BAxisResult {
    /// β_XB (").
    pub beta_xb_arcsec: f64,
    /// δx_BT (µm).
    pub dx_bt_um: f64,
    /// δz_BT (µm).
    pub dz_bt_um: f64,
    /// α_XB (") — paper (5.19) only.
    pub alpha_xb_arcsec: Option<f64>,
    /// γ_XB (") — paper (5.17) only.
    pub gamma_xb_arcsec: Option<f64>,
    /// α_BT + α_XB (") — corrected mode.
    pub alpha_bt_plus_alpha_xb_arcsec: Option<f64>,
    /// α_BT − γ_XB (") — corrected mode.
    pub alpha_bt_minus_gamma_xb_arcsec: Option<f64>,
    /// Standard uncertainties of (β_XB ", δx_BT µm, δz_BT µm) from the residual (corrected
    /// mode; 0 in paper mode).
    pub std_uncertainty: [f64; 3],
    /// Standard uncertainties of (α_BT + α_XB ", α_BT − γ_XB ") from the Y residual (corrected
    /// mode; 0 in paper mode).
    pub std_uncertainty_y: [f64; 2],
    /// Weighted RMS residual of the X/Z equations, `sqrt(Σ w r² / Σ w)` with the weights of
    /// the fit (1/u², or 1: the plain RMS) (µm; corrected mode, 0 in paper mode).
    pub residual_rms_um: f64,
}

/// B-axis deviations (eqs 5.8–5.19; see the module doc for the corrected-mode equations).
pub fn identify_b_axis(input: &BAxisProbe, mode: ProbeMode) -> Result<BAxisResult, ProbeError> {
    if !(crate::num::all_finite(input.measured_mm.as_flattened())
        && crate::num::all_finite(input.nominal_mm.as_flattened())
        && crate::num::all_finite(input.measured_std_uncertainty_um.as_flattened())
        && input.r_b_mm.is_finite()
        && input.r_b2_mm.is_finite()
        && input.x_t_mm.is_finite())
    {
        return Err(ProbeError::NonFinite);
    }
    if input.r_b_mm <= 0.0 {
        return Err(ProbeError::NonPositiveLength { what: "R_B" });
    }
    if input.r_b2_mm <= 0.0 {
        return Err(ProbeError::NonPositiveLength { what: "R'_B" });
    }
    if input.r_b2_mm == input.r_b_mm {
        return Err(ProbeError::SameToolLength);
    }
    // Δ = measured − nominal, µm; d[k] = (ΔX, ΔY, ΔZ) of set k.
    let mut d = [[0.0f64; 3]; 4];
    for ((dk, m), n) in d
        .iter_mut()
        .zip(input.measured_mm.iter())
        .zip(input.nominal_mm.iter())
    {
        for ((o, a), b) in dk.iter_mut().zip(m.iter()).zip(n.iter()) {
            *o = (a - b) * 1e3;
        }
    }
    let [[x1, y1, z1], [x2, y2, z2], [x1p, _, _], [_, _, z2p]] = d;
    let (rb, rb2) = (input.r_b_mm, input.r_b2_mm);
    match mode {
        ProbeMode::Paper => {
            if input.x_t_mm <= 0.0 {
                return Err(ProbeError::NonPositiveLength { what: "X_T" });
            }
            let (s, sp) = (x1 - z2, x1p - z2p);
            let beta_rad = (sp - s) / (2.0 * (rb2 - rb)) * 1e-3; // (5.12), µm/mm → rad
            let dx_bt = (rb2 * s - rb * sp) / (2.0 * (rb2 - rb)); // (5.13)
            let dz_bt = (z1 + x2) / 2.0; // (5.15)
            let gamma_rad = (x2 - x1) / input.x_t_mm * 1e-3; // (5.17)
            let alpha_rad = (y1 - y2) / rb * 1e-3; // (5.19)
            Ok(BAxisResult {
                beta_xb_arcsec: beta_rad * ARCSEC_PER_RAD,
                dx_bt_um: dx_bt,
                dz_bt_um: dz_bt,
                alpha_xb_arcsec: Some(alpha_rad * ARCSEC_PER_RAD),
                gamma_xb_arcsec: Some(gamma_rad * ARCSEC_PER_RAD),
                alpha_bt_plus_alpha_xb_arcsec: None,
                alpha_bt_minus_gamma_xb_arcsec: None,
                std_uncertainty: [0.0; 3],
                std_uncertainty_y: [0.0; 2],
                residual_rms_um: 0.0,
            })
        }
        ProbeMode::Corrected => Ok(corrected_b_axis(
            &d,
            &input.measured_std_uncertainty_um,
            &input.lobing_shift_um,
            input.std_uncertainty_dof,
            [rb, rb2],
        )),
    }
}

/// Weighted sums of a straight-line fit `y = c0 + c1·l` (with l = 0 throughout, a weighted
/// mean).
#[derive(Clone, Copy, Default)]
struct LineSums {
    w: f64,
    wl: f64,
    wll: f64,
    wy: f64,
    wly: f64,
    wyy: f64,
}

impl LineSums {
    fn add(&mut self, l: f64, y: f64, w: f64) {
        self.w += w;
        self.wl += w * l;
        self.wll += w * l * l;
        self.wy += w * y;
        self.wly += w * l * y;
        self.wyy += w * y * y;
    }

    /// Σ w (y − c0 − c1 l)², expanded (the readings are µm and the residuals ≳ 1e-3 µm: far
    /// above the cancellation of f64).
    fn rss(&self, c0: f64, c1: f64) -> f64 {
        self.wyy - 2.0 * (c0 * self.wy + c1 * self.wly)
            + c0 * c0 * self.w
            + 2.0 * c0 * c1 * self.wl
            + c1 * c1 * self.wll
    }
}

/// The sums and solution of [`b_fit`].
struct BFit {
    /// The straight line in the lever l (ΔX1 and −ΔZ2).
    line: LineSums,
    /// The δz_BT readings (−ΔZ1, −ΔX2).
    dz: LineSums,
    /// The two Y combinations' readings.
    ys: [LineSums; 2],
    /// The line's determinant.
    det: f64,
    /// β_XB, µrad (the line's slope).
    beta_urad: f64,
    /// The line's intercept (−δx_BT), µm.
    c0: f64,
    /// δz_BT, µm.
    dz_bt: f64,
    /// α_BT + α_XB and α_BT − γ_XB, µrad.
    a: [f64; 2],
    /// Weighted residual sums of squares (X/Z, Y).
    rss: [f64; 2],
}

/// Corrected-mode B-axis least squares (module doc) in closed form. The eight X/Z equations
/// separate into δz_BT (ΔZ1 = ΔX2 = −δz_BT: a weighted mean of four readings) and a straight
/// line in the lever l = R·1e-3 (ΔX1 = −δx_BT + l·β_XB and −ΔZ2 = the same: intercept −δx_BT,
/// slope β_XB µrad); the four Y equations into α_BT + α_XB (ΔY1 = −l·a) and α_BT − γ_XB
/// (ΔY2 = −l·a), weighted means of ΔY/(−l) — so no general solver is needed on the pod.
/// Weights 1/u² of the readings when all are known (> 0), else 1; the residual variance pools
/// the X/Z (8 − 3) and Y (4 − 2) degrees of freedom separately, as the full least squares does.
fn b_fit(d: &[[f64; 3]; 4], sig: &[[f64; 3]; 4], known: bool, r_mm: [f64; 2]) -> BFit {
    let w = |u: f64| if known { 1.0 / (u * u) } else { 1.0 };
    let [mut line, mut dz] = [LineSums::default(); 2];
    let mut ys = [LineSums::default(); 2];
    for (r, set) in r_mm.iter().zip([0usize, 2]) {
        let l = r * 1e-3;
        let (Some(b0), Some(b90), Some(u0), Some(u90)) =
            (d.get(set), d.get(set + 1), sig.get(set), sig.get(set + 1))
        else {
            continue;
        };
        let ([x1, y1, z1], [x2, y2, z2]) = (*b0, *b90);
        let ([ux1, uy1, uz1], [ux2, uy2, uz2]) = (*u0, *u90);
        line.add(l, x1, w(ux1));
        line.add(l, -z2, w(uz2));
        dz.add(0.0, -z1, w(uz1));
        dz.add(0.0, -x2, w(ux2));
        // −l·a = ΔY  ⇔  a = ΔY/(−l), weight w·l²
        let [s1, s2] = &mut ys;
        s1.add(0.0, -y1 / l, w(uy1) * l * l);
        s2.add(0.0, -y2 / l, w(uy2) * l * l);
    }
    let det = line.w * line.wll - line.wl * line.wl;
    let beta_urad = (line.w * line.wly - line.wl * line.wy) / det;
    let c0 = (line.wll * line.wy - line.wl * line.wly) / det;
    let dz_bt = dz.wy / dz.w;
    let a = ys.map(|s| s.wy / s.w);
    let [y1, y2] = ys;
    let [a1, a2] = a;
    BFit {
        line,
        dz,
        ys,
        det,
        beta_urad,
        c0,
        dz_bt,
        a,
        rss: [
            line.rss(c0, beta_urad) + dz.rss(dz_bt, 0.0),
            y1.rss(a1, 0.0) + y2.rss(a2, 0.0),
        ],
    }
}

/// [`b_fit`] with its uncertainties. With known u the residual is weighed ([`variance_factor`])
/// against what the readings' u and the lobing (`lob`: each sphere's shift for one standard uncertainty
/// of each component) leave in it on average: the degrees of freedom plus the weighted residual
/// sum of squares of each component's shifts (every fit here is linear in its readings).
fn corrected_b_axis(
    d: &[[f64; 3]; 4],
    sig: &[[f64; 3]; 4],
    lob: &[[[f64; 3]; LOBING_COMPONENTS]; 4],
    dof: f64,
    r_mm: [f64; 2],
) -> BAxisResult {
    let known = sig.iter().flatten().all(|u| *u > 0.0);
    let f = b_fit(d, sig, known, r_mm);
    let mut expected = [5.0, 2.0];
    if known {
        for j in 0..LOBING_COMPONENTS {
            let shift = lob.map(|s| s.get(j).copied().unwrap_or([0.0; 3]));
            for (e, r) in expected.iter_mut().zip(b_fit(&shift, sig, known, r_mm).rss) {
                // a shift not known (NaN) adds nothing: the residual is then weighed against
                // the readings' u alone
                if r.is_finite() {
                    *e += r;
                }
            }
        }
    }
    // known σ: the propagated u, with the residual's scatter pooled or as a Birge ratio
    // (`variance_factor`); σ not known: the residual's alone
    let scale = |rss: f64, expected: f64, nu_m: f64| {
        let reduced = rss.max(0.0) / expected;
        crate::num::sqrt(if known {
            variance_factor(reduced, nu_m, dof)
        } else {
            reduced
        })
    };
    let [rss_xz, rss_y] = f.rss;
    let k_xz = scale(rss_xz, expected[0], 5.0);
    let k_y = scale(rss_y, expected[1], 2.0);
    let asec = |urad: f64| urad * 1e-6 * ARCSEC_PER_RAD;
    let [a1, a2] = f.a;
    BAxisResult {
        beta_xb_arcsec: asec(f.beta_urad),
        dx_bt_um: -f.c0,
        dz_bt_um: f.dz_bt,
        alpha_xb_arcsec: None,
        gamma_xb_arcsec: None,
        alpha_bt_plus_alpha_xb_arcsec: Some(asec(a1)),
        alpha_bt_minus_gamma_xb_arcsec: Some(asec(a2)),
        std_uncertainty: [
            asec(k_xz * crate::num::sqrt(f.line.w / f.det)),
            k_xz * crate::num::sqrt(f.line.wll / f.det),
            k_xz * crate::num::sqrt(1.0 / f.dz.w),
        ],
        std_uncertainty_y: f.ys.map(|s| asec(k_y * crate::num::sqrt(1.0 / s.w))),
        residual_rms_um: crate::num::sqrt(rss_xz.max(0.0) / (f.line.w + f.dz.w)),
    }
}

/// Why a sphere could not be fitted to probed points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SphereFitError {
    /// Fewer than 4 points.
    TooFewPoints {
        /// Points given.
        points: usize,
    },
    /// A coordinate is NaN or infinite.
    NonFinite,
    /// The points do not determine a sphere (coplanar, collinear or coincident).
    Degenerate,
    /// Gauss–Newton did not converge.
    NoConvergence,
}

/// Least-squares sphere through probed points (e.g. the Fig 5.13 stylus positions).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereFit {
    /// Centre (mm).
    pub centre_mm: [f64; 3],
    /// Radius (mm).
    pub radius_mm: f64,
    /// RMS of the radial residuals (µm).
    pub residual_rms_um: f64,
    /// Standard uncertainties of (centre x, y, z, radius) (µm; 0 with exactly 4 points).
    pub std_uncertainty_um: [f64; 4],
    /// Row j: the centre's shift (X, Y, Z, µm) per µm of component j of the probe's lobing
    /// ([`super::lobing`]), first order, for these touches at this B.
    pub lobing_um_per_um: [[f32; 3]; LOBING_COMPONENTS],
}

/// Geometric least-squares sphere fit: minimises Σ(|p_i − c| − R)² with the metrology core's
/// point fit ([`crate::metrology::point_fit::fit_sphere`]: centred Kåsa start, then
/// Gauss–Newton), plus the standard uncertainties of centre and radius from one Givens pass over
/// the Jacobian at the solution (residual variance × (JᵀJ)⁻¹), and from the same (JᵀJ)⁻¹ the
/// centre's response to the probe's lobing for touches made at B = `probe_b_deg` (NaN: no B
/// axis, 0; [`super::lobing`]).
pub fn fit_sphere(points_mm: &[[f64; 3]], probe_b_deg: f64) -> Result<SphereFit, SphereFitError> {
    use crate::metrology::point_fit::{self, PointFitError};
    let fit = point_fit::fit_sphere(points_mm).map_err(|e| match e {
        PointFitError::TooFewPoints { have, .. } => SphereFitError::TooFewPoints { points: have },
        PointFitError::NotFinite => SphereFitError::NonFinite,
        PointFitError::Degenerate => SphereFitError::Degenerate,
        PointFitError::NotConverged => SphereFitError::NoConvergence,
    })?;
    let c = Vector3::from(fit.centre_mm);
    let b = if probe_b_deg.is_nan() {
        0.0
    } else {
        probe_b_deg
    };
    let (sin_b, cos_b) = crate::num::sin_cos(b.to_radians());
    let mut j = GivensLsq::<4>::new();
    // the parameters' shift per lobing component g (a latched point lies g inside the
    // surface): the least squares J x ≈ g, x = (JᵀJ)⁻¹Jᵀg, by its normal equations (J's
    // columns are unit normals and 1: well conditioned)
    let mut jtj = [[0.0f64; 4]; 4];
    let mut jtg = [[0.0f64; 4]; LOBING_COMPONENTS];
    for p in points_mm {
        let d = Vector3::from(*p) - c;
        let n = crate::num::sqrt(d.norm_squared());
        if !(n > 0.0) {
            return Err(SphereFitError::Degenerate);
        }
        // residual n − r; ∂/∂c = −d/n, ∂/∂r = −1
        let row = [-d.x / n, -d.y / n, -d.z / n, -1.0];
        j.add_row(&row, -(n - fit.radius_mm), 1.0)
            .map_err(|_| SphereFitError::NonFinite)?;
        let g = super::lobing::lobing_basis([d.x / n, d.y / n, d.z / n], sin_b, cos_b);
        for (m, a) in jtj.iter_mut().zip(row) {
            for (v, b) in m.iter_mut().zip(row) {
                *v += a * b;
            }
        }
        for (acc, gk) in jtg.iter_mut().zip(g) {
            for (v, a) in acc.iter_mut().zip(row) {
                *v += a * f64::from(gk);
            }
        }
    }
    let st = j
        .solve_full_rank(DEFAULT_RANK_TOL)
        .map_err(|_| SphereFitError::Degenerate)?;
    let [u0, u1, u2, u3] = st.std_uncertainty;
    let lobing_um_per_um = jtg.map(|h| match cholesky_solve(jtj, h) {
        Some([dx, dy, dz, _]) => [dx as f32, dy as f32, dz as f32],
        None => [f32::NAN; 3],
    });
    Ok(SphereFit {
        centre_mm: fit.centre_mm,
        radius_mm: fit.radius_mm,
        residual_rms_um: fit.residual_rms_um,
        std_uncertainty_um: [u0 * 1e3, u1 * 1e3, u2 * 1e3, u3 * 1e3],
        lobing_um_per_um,
    })
}
