//! The mill-turn machine's geometry (seed 002, Yao 2022 thesis): identification of the inherent
//! geometric deviations of a multi-tasking machine tool `w-C'bZYXB(C1)-t` (turning C axis on
//! the workpiece side, swivel B head on the tool side) from ball-bar patterns and from
//! touch-probe sphere centres.
//!
//! Spec: `design/spec/seed-002.md`. Submodules:
//! - [`model`]: the literal HTM forward model, eqs 2.1–2.21, and the ball-bar reading 2.17;
//! - [`patterns`]: commands of the measuring patterns (Tables 2.2/2.3), NC blocks (TV-6), the
//!   sensitive direction of each pattern (§3.5) and the simulated eccentricity of a pattern;
//! - [`ballbar`]: eqs 4.10–4.18 (thesis mode, Tables 4.5/4.7) and run statistics (TV-1);
//! - [`model_lsq`]: model-based least-squares identification on the literal model, with its
//!   identifiability report;
//! - [`compensation`]: chapter 3 NC-program compensation (eqs 3.4–3.13);
//! - [`probe`]: chapter 5 touch-probe method (eqs 5.1–5.19) with sign fixes and paper mode;
//! - [`lobing`]: the touch probe's lobing in the chapter 5 methods' budget.
//!
//! Units: lengths in mm, positional deviations and eccentricities in µm, angular deviations
//! in µrad (model) or arc-seconds (thesis tables). Error = actual − nominal.
//!
//! Sign convention of every deviation: the one of the HTMs as printed (eqs 2.2, 2.3, 2.5,
//! 2.6, 2.11; small-angle, right-handed). The thesis's own chapter-4 relations contradict
//! these matrices in places (spec §9.1); [`ballbar::identify_thesis`] implements the thesis
//! relations verbatim (it reproduces Tables 4.5/4.7), [`model_lsq::ModelLsq`] the literal model.

pub mod ballbar;
pub mod compensation;
pub mod lobing;
pub mod model;
pub mod model_lsq;
pub mod patterns;
pub mod probe;

/// Arc-seconds per radian (180·3600/π), the conversion used by the thesis tables (TV-4).
pub const ARCSEC_PER_RAD: f64 = 206_264.806_247_096_36;

/// µrad → arc-seconds.
pub fn urad_to_arcsec(urad: f64) -> f64 {
    urad * 1e-6 * ARCSEC_PER_RAD
}

/// Arc-seconds → µrad.
pub fn arcsec_to_urad(arcsec: f64) -> f64 {
    arcsec / ARCSEC_PER_RAD * 1e6
}

/// One of the 13 geometric deviations of thesis Table 2.1, in the canonical order of
/// [`Deviations::to_array`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Parameter {
    /// δx_BT: X offset of the spindle rotation w.r.t. the B origin (µm), in M_BT.
    DxBt,
    /// δz_BT: Z offset of the spindle rotation w.r.t. the B origin (µm; acts as a tool-length
    /// error), in M_BT.
    DzBt,
    /// α_BT: squareness of the B axis w.r.t. the spindle rotation, about X (µrad), in M_BT.
    AlphaBt,
    /// α_XB: squareness of the B axis w.r.t. Z motion, about X (µrad), in M_XB.
    AlphaXb,
    /// β_XB: initial angular position (zero) error of the B axis, about Y (µrad), in M_XB.
    BetaXb,
    /// γ_XB: squareness of the B axis w.r.t. X motion, about Z (µrad), in M_XB.
    GammaXb,
    /// γ_XY: squareness X vs Y (µrad), in M_XY.
    GammaXy,
    /// α_YZ: squareness Y vs Z (µrad), in M_YZ.
    AlphaYz,
    /// β_YZ: squareness Z vs X (µrad), in M_YZ.
    BetaYz,
    /// δx_CZ: X offset of the C origin w.r.t. the machine origin (µm), in M_CZ.
    DxCz,
    /// δy_CZ: Y offset of the C origin w.r.t. the machine origin (µm), in M_CZ.
    DyCz,
    /// α_CZ: parallelism of C to Z, about X (µrad), in M_CZ.
    AlphaCz,
    /// β_CZ: parallelism of C to Z, about Y (µrad), in M_CZ.
    BetaCz,
}

impl Parameter {
    /// All 13, in canonical order (index = position in [`Deviations::to_array`]).
    pub const ALL: [Parameter; 13] = [
        Parameter::DxBt,
        Parameter::DzBt,
        Parameter::AlphaBt,
        Parameter::AlphaXb,
        Parameter::BetaXb,
        Parameter::GammaXb,
        Parameter::GammaXy,
        Parameter::AlphaYz,
        Parameter::BetaYz,
        Parameter::DxCz,
        Parameter::DyCz,
        Parameter::AlphaCz,
        Parameter::BetaCz,
    ];

    /// Canonical index (0..13).
    pub const fn index(self) -> usize {
        self as usize
    }

    /// True for the positional deviations (µm), false for the angular ones (µrad).
    pub const fn is_positional(self) -> bool {
        matches!(
            self,
            Parameter::DxBt | Parameter::DzBt | Parameter::DxCz | Parameter::DyCz
        )
    }

    /// The thesis symbol, e.g. `"alpha_XB"`.
    pub const fn name(self) -> &'static str {
        match self {
            Parameter::DxBt => "dx_BT",
            Parameter::DzBt => "dz_BT",
            Parameter::AlphaBt => "alpha_BT",
            Parameter::AlphaXb => "alpha_XB",
            Parameter::BetaXb => "beta_XB",
            Parameter::GammaXb => "gamma_XB",
            Parameter::GammaXy => "gamma_XY",
            Parameter::AlphaYz => "alpha_YZ",
            Parameter::BetaYz => "beta_YZ",
            Parameter::DxCz => "dx_CZ",
            Parameter::DyCz => "dy_CZ",
            Parameter::AlphaCz => "alpha_CZ",
            Parameter::BetaCz => "beta_CZ",
        }
    }
}

/// The 13 geometric deviations of thesis Table 2.1 (positional in µm, angular in µrad), with
/// the signs of the printed HTMs (eqs 2.2, 2.3, 2.5, 2.6, 2.11).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Deviations {
    /// δx_BT (µm).
    pub dx_bt_um: f64,
    /// δz_BT (µm).
    pub dz_bt_um: f64,
    /// α_BT (µrad).
    pub alpha_bt_urad: f64,
    /// α_XB (µrad).
    pub alpha_xb_urad: f64,
    /// β_XB (µrad).
    pub beta_xb_urad: f64,
    /// γ_XB (µrad).
    pub gamma_xb_urad: f64,
    /// γ_XY (µrad).
    pub gamma_xy_urad: f64,
    /// α_YZ (µrad).
    pub alpha_yz_urad: f64,
    /// β_YZ (µrad).
    pub beta_yz_urad: f64,
    /// δx_CZ (µm).
    pub dx_cz_um: f64,
    /// δy_CZ (µm).
    pub dy_cz_um: f64,
    /// α_CZ (µrad).
    pub alpha_cz_urad: f64,
    /// β_CZ (µrad).
    pub beta_cz_urad: f64,
}

impl Deviations {
    /// The 13 values in the order of [`Parameter::ALL`] (µm / µrad).
    pub const fn to_array(&self) -> [f64; 13] {
        [
            self.dx_bt_um,
            self.dz_bt_um,
            self.alpha_bt_urad,
            self.alpha_xb_urad,
            self.beta_xb_urad,
            self.gamma_xb_urad,
            self.gamma_xy_urad,
            self.alpha_yz_urad,
            self.beta_yz_urad,
            self.dx_cz_um,
            self.dy_cz_um,
            self.alpha_cz_urad,
            self.beta_cz_urad,
        ]
    }

    /// Inverse of [`Deviations::to_array`].
    pub const fn from_array(a: &[f64; 13]) -> Self {
        let [
            dx_bt_um,
            dz_bt_um,
            alpha_bt_urad,
            alpha_xb_urad,
            beta_xb_urad,
            gamma_xb_urad,
            gamma_xy_urad,
            alpha_yz_urad,
            beta_yz_urad,
            dx_cz_um,
            dy_cz_um,
            alpha_cz_urad,
            beta_cz_urad,
        ] = *a;
        Self {
            dx_bt_um,
            dz_bt_um,
            alpha_bt_urad,
            alpha_xb_urad,
            beta_xb_urad,
            gamma_xb_urad,
            gamma_xy_urad,
            alpha_yz_urad,
            beta_yz_urad,
            dx_cz_um,
            dy_cz_um,
            alpha_cz_urad,
            beta_cz_urad,
        }
    }

    /// The value of one deviation (µm or µrad).
    pub fn get(&self, p: Parameter) -> f64 {
        self.to_array().get(p.index()).copied().unwrap_or(0.0)
    }

    /// True when every value is finite.
    pub fn is_finite(&self) -> bool {
        crate::num::all_finite(&self.to_array())
    }
}
