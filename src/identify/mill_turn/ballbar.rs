//! Ball-bar procedure of thesis chapter 4 (spec seed-002 §5): run statistics (Table 4.4, TV-1)
//! and the identification of the 8 identifiable deviations by eqs 4.10–4.18 (**thesis mode**:
//! reproduces Tables 4.5 and 4.7, TV-2/TV-3).
//!
//! Input sign convention (§3.5, shared with the metrology fit): the eccentricity of a pattern is
//! (e1, e2) of `ΔL ≈ r0 + e1·n1 + e2·n2`, ΔL in µm (positive = bar longer), with n = (sin φ,
//! cos φ) in (X, Z) for BX/BY, n = sign(R_C − L_B)(cos θ, sin θ) for CR and (cos θ, sin θ) for
//! CA; each run is the mean of its CW and CCW fits. With that convention δx_CZ = +20 µm gives
//! ex_CR = −20 µm (TV-7).
//!
//! Thesis mode uses the thesis's lever arms Z_T, X_T (spindle-head machine coordinates) and
//! its signs, which contradict the literal HTM model (spec §9.1: Z_C-term signs in CR, R_B vs
//! Z_T levers, δx_BT dropped from ez_BX). For the literal model use
//! [`super::model_lsq::ModelLsq`].
use super::ARCSEC_PER_RAD;

/// Why a ball-bar identification could not be computed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BallBarError {
    /// No run values were given.
    NoRuns,
    /// An input is NaN or infinite.
    NonFinite,
    /// A length that divides (R_B, R_C) is ≤ 0 (names which).
    NonPositiveLength {
        /// `"R_B"` or `"R_C"`.
        what: &'static str,
    },
    /// Z'_T = Z_T: the two CR runs (tool lengths R_B, R'_B) cannot separate α_BT from δy_CZ
    /// (eqs 4.16–4.18 divide by Z'_T − Z_T).
    SameToolLength,
    /// A standard uncertainty is negative.
    NegativeUncertainty,
}

/// Mean and population standard deviation (ddof = 0, as printed in Table 4.4) of repeated runs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RunStatistics {
    /// Mean of the runs (unit of the input, e.g. µm).
    pub mean: f64,
    /// Population standard deviation σ (ddof = 0), same unit.
    pub population_sigma: f64,
    /// Number of runs.
    pub runs: usize,
}

/// Mean and population σ of repeated runs (TV-1). Errors on an empty or non-finite input.
pub fn run_statistics(runs: &[f64]) -> Result<RunStatistics, BallBarError> {
    if runs.is_empty() {
        return Err(BallBarError::NoRuns);
    }
    if !crate::num::all_finite(runs) {
        return Err(BallBarError::NonFinite);
    }
    let n = runs.len() as f64;
    let mean = runs.iter().sum::<f64>() / n;
    let var = runs.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
    Ok(RunStatistics {
        mean,
        population_sigma: crate::num::sqrt(var),
        runs: runs.len(),
    })
}

/// The eccentricities of the five steps of §5.3 (µm, CW/CCW means of the runs).
///
/// Sign convention (spec §3.5; the metrology fit must use it): fit `ΔL ≈ r0 + e1·n1 + e2·n2`
/// over the pattern's samples, ΔL in µm positive when the bar is longer, n the unit direction
/// of the commanded position on its path: BX/BY n = (sin φ, cos φ) in (X, Z), (e1, e2) =
/// (ex, ez); CR n = sign(R_C − L_B)·(cos θ, sin θ) (the T-ball side), CA n = (cos θ, sin θ),
/// (e1, e2) = (ex, ey). Anchor: δx_CZ = +20 µm ⇒ ex_CR = −20 µm.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ThesisEccentricities {
    /// Step 1 BX, ex (µm): δz_BT by eq 4.1 (a tool-length setting figure, not used).
    pub ex_bx_um: f64,
    /// Step 1 BX, ez (µm).
    pub ez_bx_um: f64,
    /// Step 2 BY, ex (µm).
    pub ex_by_um: f64,
    /// Step 2 BY, ez (µm).
    pub ez_by_um: f64,
    /// Step 3 CR with R_B, ex (µm).
    pub ex_cr_um: f64,
    /// Step 3 CR with R_B, ey (µm).
    pub ey_cr_um: f64,
    /// Step 4 CA, ex (µm).
    pub ex_ca_um: f64,
    /// Step 4 CA, ey (µm).
    pub ey_ca_um: f64,
    /// Step 5 CR with R'_B (extension bar), ex (µm; not used by eqs 4.10–4.18).
    pub ex_cr2_um: f64,
    /// Step 5 CR with R'_B, ey' (µm).
    pub ey_cr2_um: f64,
}

impl ThesisEccentricities {
    fn to_array(self) -> [f64; 10] {
        [
            self.ex_bx_um,
            self.ez_bx_um,
            self.ex_by_um,
            self.ez_by_um,
            self.ex_cr_um,
            self.ey_cr_um,
            self.ex_ca_um,
            self.ey_ca_um,
            self.ex_cr2_um,
            self.ey_cr2_um,
        ]
    }

    fn from_array(a: [f64; 10]) -> Self {
        let [
            ex_bx_um,
            ez_bx_um,
            ex_by_um,
            ez_by_um,
            ex_cr_um,
            ey_cr_um,
            ex_ca_um,
            ey_ca_um,
            ex_cr2_um,
            ey_cr2_um,
        ] = a;
        Self {
            ex_bx_um,
            ez_bx_um,
            ex_by_um,
            ez_by_um,
            ex_cr_um,
            ey_cr_um,
            ex_ca_um,
            ey_ca_um,
            ex_cr2_um,
            ey_cr2_um,
        }
    }
}

/// Set-up lengths of the procedure (Table 4.3, mm). Z_T, Z'_T and X_T are the spindle-head
/// machine coordinates the thesis uses as lever arms (Z_T decreases when the tool gets longer).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThesisGeometry {
    /// R_B: B centre → T-ball (mm) of steps 1–4.
    pub r_b_mm: f64,
    /// R_C: W-ball radius about C (mm).
    pub r_c_mm: f64,
    /// Z_C: W-ball height above the C table (mm).
    pub z_c_mm: f64,
    /// Z_T: spindle-head Z coordinate in steps 1–4 (mm).
    pub z_t_mm: f64,
    /// Z'_T: spindle-head Z coordinate in step 5 (long tool R'_B, mm).
    pub z_t2_mm: f64,
    /// X_T: spindle-head X coordinate (mm).
    pub x_t_mm: f64,
}

/// The 8 identifiable deviations (Table 4.5), angles in arc-seconds, positions in µm.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ThesisDeviations {
    /// α_CZ ("), eq 4.10.
    pub alpha_cz_arcsec: f64,
    /// β_CZ ("), eq 4.11.
    pub beta_cz_arcsec: f64,
    /// α_XB ("), eq 4.12.
    pub alpha_xb_arcsec: f64,
    /// β_XB ("), eq 4.13.
    pub beta_xb_arcsec: f64,
    /// γ_XB ("), eq 4.14.
    pub gamma_xb_arcsec: f64,
    /// α_BT ("), eq 4.17.
    pub alpha_bt_arcsec: f64,
    /// δx_CZ − δx_BT (µm), eq 4.15.
    pub dx_cz_minus_dx_bt_um: f64,
    /// δy_CZ (µm), eq 4.18.
    pub dy_cz_um: f64,
}

/// Thesis-mode result: the deviations, their standard uncertainties (same fields and units,
/// propagated linearly from the eccentricity uncertainties; zero if none were given) and the
/// δz_BT setting figure of eq 4.1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThesisResult {
    /// The 8 deviations.
    pub deviations: ThesisDeviations,
    /// Their standard uncertainties (same units).
    pub std_uncertainty: ThesisDeviations,
    /// ex_BX = δz_BT (µm), eq 4.1: tool-length setting error, not compensable (reported only).
    pub dz_bt_setting_um: f64,
}

fn thesis_formulas(e: &ThesisEccentricities, g: &ThesisGeometry) -> [f64; 8] {
    // µm / mm = 1e-3 rad → arc-seconds
    let k = 1e-3 * ARCSEC_PER_RAD;
    let (rb, rc, zc, zt, zt2, xt) = (g.r_b_mm, g.r_c_mm, g.z_c_mm, g.z_t_mm, g.z_t2_mm, g.x_t_mm);
    let alpha_cz = -e.ey_ca_um / rc; // (4.10), µm/mm
    let beta_cz = e.ex_ca_um / rc; // (4.11)
    let alpha_xb = e.ez_by_um / rb; // (4.12)
    let beta_xb = e.ez_bx_um / rb; // (4.13)
    let gamma_xb = -e.ex_by_um / rb; // (4.14)
    // (4.15)
    let dx = -e.ex_cr_um + zc * e.ex_ca_um / rc - zt * e.ez_bx_um / rb;
    // (4.17)
    let alpha_bt = (e.ey_cr2_um - e.ey_cr_um) / (zt2 - zt) - e.ez_by_um / rb;
    // (4.18)
    let dy = zc * e.ey_ca_um / rc
        + (zt * e.ey_cr2_um - zt2 * e.ey_cr_um) / (zt2 - zt)
        + xt * e.ex_by_um / rb;
    [
        alpha_cz * k,
        beta_cz * k,
        alpha_xb * k,
        beta_xb * k,
        gamma_xb * k,
        alpha_bt * k,
        dx,
        dy,
    ]
}

fn deviations_from(a: [f64; 8]) -> ThesisDeviations {
    let [
        alpha_cz_arcsec,
        beta_cz_arcsec,
        alpha_xb_arcsec,
        beta_xb_arcsec,
        gamma_xb_arcsec,
        alpha_bt_arcsec,
        dx_cz_minus_dx_bt_um,
        dy_cz_um,
    ] = a;
    ThesisDeviations {
        alpha_cz_arcsec,
        beta_cz_arcsec,
        alpha_xb_arcsec,
        beta_xb_arcsec,
        gamma_xb_arcsec,
        alpha_bt_arcsec,
        dx_cz_minus_dx_bt_um,
        dy_cz_um,
    }
}

/// Thesis mode: eqs 4.10–4.18 verbatim (spec §5.4). Pass the **unrounded** run means (TV-2:
/// the 2-decimal means do not reproduce α_CZ and α_BT). `sigma` (optional) holds the standard
/// uncertainty of each eccentricity (µm, e.g. population σ/√n of the runs); it is propagated
/// linearly (the formulas are linear in the eccentricities). The system is exactly determined
/// (8 equations 4.2–4.9, 8 unknowns): there is no residual.
pub fn identify_thesis(
    e: &ThesisEccentricities,
    g: &ThesisGeometry,
    sigma: Option<&ThesisEccentricities>,
) -> Result<ThesisResult, BallBarError> {
    let lens = [g.r_b_mm, g.r_c_mm, g.z_c_mm, g.z_t_mm, g.z_t2_mm, g.x_t_mm];
    if !(crate::num::all_finite(&lens) && crate::num::all_finite(&e.to_array())) {
        return Err(BallBarError::NonFinite);
    }
    if g.r_b_mm <= 0.0 {
        return Err(BallBarError::NonPositiveLength { what: "R_B" });
    }
    if g.r_c_mm <= 0.0 {
        return Err(BallBarError::NonPositiveLength { what: "R_C" });
    }
    if g.z_t2_mm == g.z_t_mm {
        return Err(BallBarError::SameToolLength);
    }
    let x = thesis_formulas(e, g);
    let mut var = [0.0f64; 8];
    if let Some(s) = sigma {
        let s = s.to_array();
        if !crate::num::all_finite(&s) {
            return Err(BallBarError::NonFinite);
        }
        if s.iter().any(|v| *v < 0.0) {
            return Err(BallBarError::NegativeUncertainty);
        }
        let base = e.to_array();
        for (i, si) in s.iter().enumerate() {
            let mut p = base;
            if let Some(v) = p.get_mut(i) {
                *v += si;
            }
            let xp = thesis_formulas(&ThesisEccentricities::from_array(p), g);
            for ((v, a), b) in var.iter_mut().zip(xp.iter()).zip(x.iter()) {
                *v += (a - b) * (a - b);
            }
        }
    }
    let mut u = [0.0f64; 8];
    u.iter_mut()
        .zip(var.iter())
        .for_each(|(u, v)| *u = crate::num::sqrt(*v));
    Ok(ThesisResult {
        deviations: deviations_from(x),
        std_uncertainty: deviations_from(u),
        dz_bt_setting_um: e.ex_bx_um,
    })
}
