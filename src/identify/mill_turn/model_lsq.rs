//! Model-based least-squares identification on the literal HTM model (eqs 2.1–2.21), with an
//! identifiability report (spec seed-002 §3.7, §9.1 item 7).
//!
//! Each measured pattern contributes two equations: its eccentricity (e1, e2) (µm, §3.5
//! convention, see [`super::patterns`]) equals the eccentricity the literal model predicts for
//! the deviations, simulated over the same sampling ([`super::patterns::simulate_eccentricity`]).
//! The map is solved by a chord Gauss–Newton iteration (one Jacobian by forward differences of
//! the full model, reused while it converges), each step a weighted linear least squares in
//! [`crate::identify::lsq::GivensLsq`] with a rank check. The unknowns are the chosen subset
//! of the 13 deviations (µm / µrad); the others stay at given fixed values.
//!
//! What the literal model can and cannot separate (the report computes it for any set-up):
//! - BX, BY, CR, CA and CR' (second tool length) determine the 10 deviations other than the
//!   squareness errors (δx_BT, δz_BT, α_BT, α_XB, β_XB, γ_XB, δx_CZ, δy_CZ, α_CZ, β_CZ) —
//!   exactly (10 equations) unless patterns are repeated;
//! - α_YZ and β_YZ alias α_XB and β_XB, and γ_XY is seen only by CX (spec §3.4): freeing
//!   them gives [`ModelLsqError::NotSeparable`] naming the combination;
//! - T-ball mounting offsets x_T, y_T, z_T act exactly like δx_BT, −δy_CZ, δz_BT to first
//!   order (they are not unknowns here; what is identified as δx_BT, δy_CZ, δz_BT includes
//!   the first tool length's offset);
//! - the balls' mounting offsets are not identifiable at all (no redundancy): their effect is
//!   budgeted ([`MountingUncertainty`], [`ModelLsq::identify_propagated`]).
//!
//! One file of about a thousand lines on purpose: one solver — the iteration, its propagated
//! uncertainty and the identifiability report share the Jacobian and the scratch it lives in
//! ([`IdentificationScratch`]); split, each part would reach into the others' internals.
use crate::config;
use crate::identify::lsq::{DEFAULT_RANK_TOL, GivensLsq, LsqError, LsqSolution, SvdScratch};
use crate::metrology::bar_budget::BarBudget;

/// Relative damping λ of the free deviations (× the largest weighted sensitivity column).
pub const DAMPING: f64 = 1e-7;

/// A direction counts as separable when its singular value exceeds this fraction of the
/// largest (condition number up to 1e5; a damped null direction sits at ≈ [`DAMPING`]).
pub const RANK_REL_TOL: f64 = 1e-5;

use super::patterns::{
    BallbarLengths, BallbarPattern, Mounting, PatternError, simulate_eccentricity,
};
use super::{Deviations, Parameter};

/// One measured pattern: its eccentricity in the §3.5 sign convention of
/// [`super::patterns`] (the same as [`super::ballbar::ThesisEccentricities`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatternMeasurement {
    /// The pattern (Tables 2.2/2.3).
    pub pattern: BallbarPattern,
    /// Its set-up lengths (mm).
    pub geometry: BallbarLengths,
    /// Number of equally spaced samples the model uses to predict the eccentricity (B arcs
    /// 0..=90°, C circles 0..360°; ≥ 3). Use the sampling of the measurement's fit.
    pub samples: usize,
    /// Measured e1 = ex (µm).
    pub e1_um: f64,
    /// Measured e2 = ez (B patterns) or ey (C patterns) (µm).
    pub e2_um: f64,
    /// Standard uncertainty of each component (µm, > 0): rows are weighted by 1/σ².
    pub sigma_um: f64,
}

/// Why the model-based identification failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ModelLsqError {
    /// No measurements or no free parameters.
    Empty,
    /// More measurements than [`MAX_MEASUREMENTS`].
    TooMany,
    /// A fixed (or start) deviation value is NaN or infinite.
    NonFiniteFixed,
    /// A measurement's σ is ≤ 0 or not finite, or an eccentricity is not finite (index).
    BadMeasurement {
        /// Index of the measurement.
        index: usize,
    },
    /// A pattern could not be simulated (bad geometry, sampling).
    BallbarPattern {
        /// Index of the measurement.
        index: usize,
        /// The cause.
        cause: PatternError,
    },
    /// The least-squares step failed.
    Lsq(LsqError),
    /// The set-up cannot separate the free deviations: `combination` (coefficients over
    /// [`Parameter::ALL`], unit norm, zero on fixed ones) changes no eccentricity to first
    /// order; `dominant` is its largest component.
    NotSeparable {
        /// Numerical rank among the free deviations.
        rank: usize,
        /// Number of free deviations.
        free: usize,
        /// The weakest combination.
        combination: [f64; 13],
        /// The deviation with the largest share in it.
        dominant: Parameter,
        /// The deviation with the second-largest share in it.
        second: Parameter,
    },
    /// Gauss–Newton did not converge within the iteration limit.
    NoConvergence,
    /// A mounting input uncertainty is negative or not finite.
    BadMountingUncertainty {
        /// The input.
        input: MountingInput,
    },
    /// The LVDT scale's uncertainty ([`BarBudget::scale`]) is negative or not finite.
    BadScaleUncertainty,
}

/// What the identified deviations absorb of the first tool length's T-ball offset (x_T, y_T,
/// z_T in the spindle frame): x_T acts as δx_BT, y_T as −δy_CZ, z_T as δz_BT, exactly to first
/// order (`identify_mill_turn_model.rs::t_ball_offsets_alias_spindle_offsets`).
const T_BALL_ALIAS: [(Parameter, f64); 3] = [
    (Parameter::DxBt, 1.0),
    (Parameter::DyCz, -1.0),
    (Parameter::DzBt, 1.0),
];

/// One Type B input of [`MountingUncertainty`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MountingInput {
    /// [`MountingUncertainty::w_clamp_um`].
    WClamp,
    /// [`MountingUncertainty::t_centring_um`].
    TCentring,
    /// [`MountingUncertainty::t_axial_um`].
    TAxial,
    /// [`MountingUncertainty::r_c_um`].
    RC,
    /// [`MountingUncertainty::z_c_um`].
    ZC,
    /// [`MountingUncertainty::r_b_um`].
    RB,
}

/// Type B inputs of the seed 002 set-up: the standard uncertainty of each Cartesian component
/// of the balls' mounting offsets (µm; spec seed-002 §2.7, eqs 2.20–2.21), every clamping and
/// every centring independent. The identification cannot estimate them (five steps, ten
/// deviations: no redundancy), so [`ModelLsq::identify_propagated`] budgets them: each
/// offset component is moved by its u through the full model at the identified deviations.
///
/// Which measurements share an offset (the procedure of §5.3):
/// - one W-ball clamping for the B patterns (W-ball on the C axis: BX, BY) and one for the
///   C patterns (W-ball at R_C: CR, CA and CR′, "not moved after CR");
/// - one T-ball mounting per tool length R_B (BX–CA; CR′ has its own, re-centred on the
///   extension).
///
/// The first measurement's tool length's T-ball offset is absorbed to first order by δx_BT
/// (x_T), δy_CZ (−y_T) and δz_BT (z_T): what is identified includes it, and only its second
/// order is budgeted. Another tool length's offset is an error of first order: the pair of
/// tool lengths separates δx_BT and the tilts over R′_B − R_B, so a re-centring difference of
/// 1 µm moves α_BT and β_XB by about 1/(R′_B − R_B) = 20 µrad at 50 mm.
///
/// The W-ball's position as entered (R_C, Z_C) is the same for every step: a difference
/// between the value entered and the one the runs were made with moves every step's model at
/// once (a lever-arm error, second order: δR/R of what is read over R). A tool length as
/// entered (R_B, R′_B) likewise moves the model of every step run with it. (A tool length
/// *measured* wrong, entered alike in the part program and the pod, is the T-ball's axial
/// offset instead: the program moves the ball where it is not.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MountingUncertainty {
    /// W-ball clamping shift, each clamping, per component of the C frame (µm).
    pub w_clamp_um: f64,
    /// T-ball radial offset left by centring (x_T, y_T), each tool length (µm).
    pub t_centring_um: f64,
    /// T-ball axial offset z_T (the error of the tool length as entered), each tool length
    /// (µm).
    pub t_axial_um: f64,
    /// R_C as entered: standard uncertainty of its difference from the R_C the C steps were
    /// run with (µm).
    pub r_c_um: f64,
    /// Z_C as entered: standard uncertainty of its difference from the Z_C every step was run
    /// with (µm).
    pub z_c_um: f64,
    /// R_B and R′_B as entered: standard uncertainty of each one's difference from the tool
    /// length its steps were run with (µm; the two independent).
    pub r_b_um: f64,
}

impl MountingUncertainty {
    /// The set-up's defaults (the `s002_u_*` configuration fields' defaults: why each, at
    /// [`crate::config::S002_U_W_CLAMP_UM`] and the constants beside it).
    pub const SEED002: Self = Self {
        w_clamp_um: config::S002_U_W_CLAMP_UM,
        t_centring_um: config::S002_U_T_CENTRING_UM,
        t_axial_um: config::S002_U_T_AXIAL_UM,
        r_c_um: config::S002_U_R_C_Z_C_UM,
        z_c_um: config::S002_U_R_C_Z_C_UM,
        r_b_um: config::S002_U_R_B_UM,
    };

    /// No mounting uncertainty: the eccentricities' u alone.
    pub const NONE: Self = Self {
        w_clamp_um: 0.0,
        t_centring_um: 0.0,
        t_axial_um: 0.0,
        r_c_um: 0.0,
        z_c_um: 0.0,
        r_b_um: 0.0,
    };

    /// Every input finite and ≥ 0, or the first one that is not.
    pub fn validate(&self) -> Result<(), MountingInput> {
        for (v, input) in [
            (self.w_clamp_um, MountingInput::WClamp),
            (self.t_centring_um, MountingInput::TCentring),
            (self.t_axial_um, MountingInput::TAxial),
            (self.r_c_um, MountingInput::RC),
            (self.z_c_um, MountingInput::ZC),
            (self.r_b_um, MountingInput::RB),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(input);
            }
        }
        Ok(())
    }
}

/// Standard uncertainty of every deviation by source (order of [`Parameter::ALL`], µm /
/// µrad; 0 for fixed deviations).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DeviationUncertainty {
    /// Combined: the root sum of squares of the sources.
    pub combined: [f64; 13],
    /// By source: `[0]` the eccentricities' standard uncertainties (Type A: bar noise, fit
    /// residuals, repeat scatter); `[1]` the W-ball: its clamping shifts and its position as
    /// entered, R_C and Z_C (Type B, second order);
    /// `[2]` the T-ball: its offsets beyond what the identified deviations absorb and the tool
    /// lengths as entered, R_B and R′_B (Type B); `[3]`
    /// the LVDT's scale (Type B).
    pub by_source: [[f64; 13]; 4],
}

/// Identifiability of a set-up: singular values of the (weighted) sensitivity matrix over the
/// free deviations, and the combinations the set-up cannot separate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifiabilityReport {
    /// Free deviations.
    pub free: usize,
    /// Numerical rank among them.
    pub rank: usize,
    /// Number of measurement equations (2 per pattern).
    pub equations: usize,
    /// Null combinations (coefficients over [`Parameter::ALL`]); the first `free − rank` are
    /// valid.
    pub null_combinations: [[f64; 13]; 13],
    /// Condition number of the free columns (∞ when rank-deficient).
    pub condition: f64,
}

impl IdentifiabilityReport {
    /// The `k`-th inseparable combination, if any.
    pub fn null_combination(&self, k: usize) -> Option<&[f64; 13]> {
        if k < self.free.saturating_sub(self.rank) {
            self.null_combinations.get(k)
        } else {
            None
        }
    }
}

/// Result of the model-based identification.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelLsqResult {
    /// Identified deviations (µm / µrad); fixed ones at their given values.
    pub deviations: Deviations,
    /// Standard uncertainty of each (same order as [`Parameter::ALL`], µm / µrad; 0 for fixed
    /// ones and when the system has no redundancy), from the residual scatter.
    pub std_uncertainty: [f64; 13],
    /// RMS of the eccentricity residuals measured − predicted (µm, unweighted).
    pub residual_rms_um: f64,
    /// Condition number of the last Gauss–Newton step (weighted Jacobian incl. fixing and
    /// damping rows).
    pub condition: f64,
    /// Gauss–Newton iterations used.
    pub iterations: usize,
}

/// Set-up of the model-based identification.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelLsq {
    /// Which of the 13 deviations are unknowns (index = [`Parameter::index`]).
    pub free: [bool; 13],
    /// Values of the fixed deviations (and start values of the free ones).
    pub fixed: Deviations,
    /// Gauss–Newton iteration limit.
    pub max_iterations: usize,
}

impl ModelLsq {
    /// The 10 deviations the literal model separates with BX, BY, CR, CA, CR' (all but the
    /// squareness errors, which are fixed at 0).
    pub fn without_squareness() -> Self {
        let mut free = [true; 13];
        for p in [Parameter::GammaXy, Parameter::AlphaYz, Parameter::BetaYz] {
            if let Some(f) = free.get_mut(p.index()) {
                *f = false;
            }
        }
        Self {
            free,
            fixed: Deviations::default(),
            max_iterations: 10,
        }
    }

    /// Only the listed deviations free, the others fixed at 0.
    pub fn with_free(params: &[Parameter]) -> Self {
        let mut free = [false; 13];
        for p in params {
            if let Some(f) = free.get_mut(p.index()) {
                *f = true;
            }
        }
        Self {
            free,
            fixed: Deviations::default(),
            max_iterations: 10,
        }
    }

    /// The free deviations, in the order of [`Parameter::ALL`].
    pub fn free_parameters(&self) -> impl Iterator<Item = Parameter> + '_ {
        Parameter::ALL
            .into_iter()
            .zip(self.free.iter())
            .filter_map(|(p, f)| f.then_some(p))
    }

    fn free_count(&self) -> usize {
        self.free.iter().filter(|f| **f).count()
    }

    fn check(&self, m: &[PatternMeasurement]) -> Result<(), ModelLsqError> {
        if m.is_empty() || self.free_count() == 0 {
            return Err(ModelLsqError::Empty);
        }
        if m.len() > MAX_MEASUREMENTS {
            return Err(ModelLsqError::TooMany);
        }
        if !self.fixed.is_finite() {
            return Err(ModelLsqError::NonFiniteFixed);
        }
        for (index, p) in m.iter().enumerate() {
            if !(p.sigma_um.is_finite()
                && p.sigma_um > 0.0
                && p.e1_um.is_finite()
                && p.e2_um.is_finite())
            {
                return Err(ModelLsqError::BadMeasurement { index });
            }
            p.geometry
                .validate(p.pattern)
                .map_err(|cause| ModelLsqError::BallbarPattern { index, cause })?;
        }
        Ok(())
    }

    /// The eccentricities the literal model predicts at `x` for each measurement (µm).
    fn predict(
        m: &[PatternMeasurement],
        x: &[f64; 13],
    ) -> Result<[[f64; 2]; MAX_MEASUREMENTS], ModelLsqError> {
        let mut out = [[0.0f64; 2]; MAX_MEASUREMENTS];
        for (index, (p, dst)) in m.iter().zip(out.iter_mut()).enumerate() {
            *dst = predict_one(index, p, x)?;
        }
        Ok(out)
    }

    /// The sensitivity rows at `x` (`pred` = [`Self::predict`] at `x`).
    ///
    /// `Differences::Forward` (the iteration: one simulation per free deviation and pattern;
    /// its accuracy sets only the convergence rate): step 0.01 µm / µrad, truncation error
    /// (step × the model's curvature) and rounding (~1e-11 µm of a 10² mm bar over the step)
    /// both near 1e-8 of a sensitivity. `Differences::Central` (the identifiability report,
    /// whose null combinations need the sensitivities to rounding): step 1 µm / µrad, exact
    /// for the model's quadratic part, twice the simulations.
    #[inline(never)] // stack: out of `solve`'s frame (the worker's deepest chain)
    fn jacobian(
        &self,
        m: &[PatternMeasurement],
        x: &[f64; 13],
        pred: &[[f64; 2]; MAX_MEASUREMENTS],
        differences: Differences,
        jac: &mut Jacobian,
    ) -> Result<(), ModelLsqError> {
        jac.scale = 1.0;
        let h = match differences {
            Differences::Forward => 0.01,
            Differences::Central => 1.0,
        };
        for (j, free) in self.free.iter().enumerate() {
            if !free {
                continue;
            }
            let (mut xp, mut xm) = (*x, *x);
            if let (Some(a), Some(b)) = (xp.get_mut(j), xm.get_mut(j)) {
                *a += h;
                *b -= h;
            }
            for (index, ((p, rows), base)) in m
                .iter()
                .zip(jac.rows.chunks_exact_mut(2))
                .zip(pred.iter())
                .enumerate()
            {
                let ep = predict_one(index, p, &xp)?;
                let (em, span) = match differences {
                    Differences::Forward => (*base, h),
                    Differences::Central => (predict_one(index, p, &xm)?, 2.0 * h),
                };
                for ((row, a), b) in rows.iter_mut().zip(ep.iter()).zip(em.iter()) {
                    if let Some(v) = row.get_mut(j) {
                        *v = (a - b) / span;
                    }
                }
            }
        }
        // Scale of the fixing/damping rows: the largest weighted sensitivity column norm.
        let mut col2 = [0.0f64; 13];
        for (p, rows) in m.iter().zip(jac.rows.chunks_exact(2)) {
            let w = p.weight();
            for row in rows {
                col2.iter_mut()
                    .zip(row.iter())
                    .for_each(|(c, v)| *c += w * v * v);
            }
        }
        let scale = crate::num::sqrt(col2.iter().fold(0.0f64, |a, v| a.max(*v)));
        if scale > 0.0 && scale.is_finite() {
            jac.scale = scale;
        }
        Ok(())
    }

    /// The linear system `J Δx ≈ b` (`b` per measurement and component, µm).
    ///
    /// Rows: the weighted measurement equations; `Δx_j = 0` for every fixed deviation (weight
    /// scaled to the largest weighted sensitivity column, so it never limits the rank test);
    /// and a damping row `λ·Δx_j = 0` for every free deviation, λ = [`DAMPING`] × that column
    /// norm (Levenberg–Marquardt on the step: it vanishes at the fixed point, keeps the SVD
    /// well posed when the set-up is rank-deficient, and puts an inseparable direction at
    /// singular value ≈ λ, far below the rank threshold [`RANK_REL_TOL`]).
    #[inline(never)] // stack: its system is built in its own frame, not in `solve`'s
    fn system(
        &self,
        m: &[PatternMeasurement],
        jac: &Jacobian,
        b: &[[f64; 2]; MAX_MEASUREMENTS],
    ) -> Result<GivensLsq<13>, ModelLsqError> {
        let mut lsq = GivensLsq::<13>::new();
        for ((p, rows), rhs) in m.iter().zip(jac.rows.chunks_exact(2)).zip(b.iter()) {
            for (row, v) in rows.iter().zip(rhs.iter()) {
                lsq.add_row(row, *v, p.weight())
                    .map_err(ModelLsqError::Lsq)?;
            }
        }
        for (j, free) in self.free.iter().enumerate() {
            let mut row = [0.0f64; 13];
            if let Some(v) = row.get_mut(j) {
                *v = 1.0;
            }
            let lambda = if *free {
                DAMPING * jac.scale
            } else {
                jac.scale
            };
            lsq.add_row(&row, 0.0, lambda * lambda)
                .map_err(ModelLsqError::Lsq)?;
        }
        Ok(lsq)
    }

    /// Rank of a solved linearisation among all 13 columns (fixed ones count as resolved).
    fn rank_of(sol: &LsqSolution<13>) -> usize {
        let s_max = sol.singular_values.first().copied().unwrap_or(0.0);
        sol.singular_values
            .iter()
            .filter(|s| **s > RANK_REL_TOL * s_max)
            .count()
    }

    #[inline(never)] // stack: out of `solve`'s frame (the worker's deepest chain)
    fn not_separable(&self, rank: usize, v: &[f64; 13]) -> ModelLsqError {
        let mut order = [0usize; 13];
        order.iter_mut().enumerate().for_each(|(i, o)| *o = i);
        order.sort_unstable_by(|&a, &b| {
            let fa = libm::fabs(v.get(a).copied().unwrap_or(0.0));
            let fb = libm::fabs(v.get(b).copied().unwrap_or(0.0));
            fb.total_cmp(&fa)
        });
        let pick = |k: usize| {
            order
                .get(k)
                .and_then(|&i| Parameter::ALL.get(i))
                .copied()
                .unwrap_or(Parameter::DxBt)
        };
        let fixed = 13 - self.free_count();
        ModelLsqError::NotSeparable {
            rank: rank.saturating_sub(fixed),
            free: self.free_count(),
            combination: *v,
            dominant: pick(0),
            second: pick(1),
        }
    }

    /// Which combinations of the free deviations the measured patterns can separate
    /// (sensitivities at the fixed values; the measured values themselves are not used).
    pub fn identifiability(
        &self,
        m: &[PatternMeasurement],
    ) -> Result<IdentifiabilityReport, ModelLsqError> {
        self.check(m)?;
        let x = self.fixed.to_array();
        let pred = Self::predict(m, &x)?;
        let mut jac = Jacobian::EMPTY;
        self.jacobian(m, &x, &pred, Differences::Central, &mut jac)?;
        let sol = self
            .system(m, &jac, &pred)?
            .solve(DEFAULT_RANK_TOL)
            .map_err(ModelLsqError::Lsq)?;
        let fixed = 13 - self.free_count();
        let rank = Self::rank_of(&sol).saturating_sub(fixed);
        let mut null_combinations = [[0.0f64; 13]; 13];
        let n_null = self.free_count().saturating_sub(rank);
        for (dst, src) in null_combinations
            .iter_mut()
            .zip(sol.right_singular_vectors.iter().rev().take(n_null))
        {
            *dst = *src;
        }
        let condition = if rank == self.free_count() {
            sol.condition
        } else {
            f64::INFINITY
        };
        Ok(IdentifiabilityReport {
            free: self.free_count(),
            rank,
            equations: 2 * m.len(),
            null_combinations,
            condition,
        })
    }

    /// Identifies the free deviations from the measured patterns on the literal model. Rank
    /// deficiency is an error naming the inseparable combination.
    pub fn identify(&self, m: &[PatternMeasurement]) -> Result<ModelLsqResult, ModelLsqError> {
        let mut jac = Jacobian::EMPTY;
        self.solve(m, &mut jac)
    }

    /// [`Self::identify`], plus every deviation's standard uncertainty by source (µm / µrad,
    /// 0 for fixed deviations):
    /// - from the eccentricities: the standard uncertainties `u_um[i]` of measurement `i`'s
    ///   two components (µm; same length as `m`; 0 or NaN for a component without one),
    ///   propagated linearly through the solution's sensitivity, `u(x_j)² = Σ (∂x_j/∂e_k ·
    ///   u_k)²` (GUM §5.1.2, uncorrelated inputs), each `∂x/∂e_k` one product with the
    ///   converged system's SVD, `Δx = V·Σ⁻²·Vᵀ·JᵀW·b`;
    /// - from the balls' mounting offsets (Type B, [`MountingUncertainty`]): see
    ///   [`MountingUncertainty`] for which measurements share a clamping or a centring and
    ///   what the identified deviations absorb;
    /// - from R_C and Z_C as entered (Type B, [`MountingUncertainty::r_c_um`],
    ///   [`MountingUncertainty::z_c_um`]): each moved by its u in every measurement's model at
    ///   once (a secant at the identified deviations), in the W-ball's share;
    /// - from R_B and R′_B as entered (Type B, [`MountingUncertainty::r_b_um`]): each moved by
    ///   its u in the model of every measurement run with it, in the T-ball's share;
    /// - from the LVDT's scale (Type B, [`BarBudget::scale`]): an eccentricity is a shape
    ///   figure of ΔL, so a scale error k moves every measured eccentricity by k times itself —
    ///   all at once (one LVDT), one input; the bar's length and temperature move none.
    pub fn identify_propagated(
        &self,
        m: &[PatternMeasurement],
        u_um: &[[f64; 2]],
        budget: &MountingUncertainty,
        bar: &BarBudget,
    ) -> Result<(ModelLsqResult, DeviationUncertainty), ModelLsqError> {
        let mut scratch = IdentificationScratch::EMPTY;
        self.identify_propagated_in(m, u_um, budget, bar, &mut scratch)
    }

    /// [`Self::identify_propagated`] with its sensitivities and SVD in the caller's `scratch`
    /// (4.8 KiB off the stack: the pod's job slot holds it).
    #[inline(never)] // flash: 0.9 KB smaller than inlined into the application task
    pub fn identify_propagated_in(
        &self,
        m: &[PatternMeasurement],
        u_um: &[[f64; 2]],
        budget: &MountingUncertainty,
        bar: &BarBudget,
        scratch: &mut IdentificationScratch,
    ) -> Result<(ModelLsqResult, DeviationUncertainty), ModelLsqError> {
        self.propagated::<false>(m, u_um, budget, bar, None, &mut scratch.0)
    }

    /// [`Self::identify_propagated`] with the full covariance of the deviations (µm², µm·µrad,
    /// µrad²; rows and columns in [`Parameter::ALL`] order, 0 for fixed deviations): every
    /// input's response `Δx` adds `Δx Δxᵀ`, so its diagonal is the square of
    /// [`DeviationUncertainty::combined`]. What a compensation of several deviations needs:
    /// their errors are correlated (a tilt and the offset it moves).
    pub fn identify_covariance(
        &self,
        m: &[PatternMeasurement],
        u_um: &[[f64; 2]],
        budget: &MountingUncertainty,
        bar: &BarBudget,
    ) -> Result<(ModelLsqResult, DeviationUncertainty, [[f64; 13]; 13]), ModelLsqError> {
        let mut cov = [[0.0f64; 13]; 13];
        let mut jac = Jacobian::EMPTY;
        let (result, u) =
            self.propagated::<true>(m, u_um, budget, bar, Some(&mut cov), &mut jac)?;
        for (row, fi) in cov.iter_mut().zip(self.free) {
            for (c, fj) in row.iter_mut().zip(self.free) {
                if !(fi && fj) {
                    *c = 0.0;
                }
            }
        }
        Ok((result, u, cov))
    }

    /// The body of both: with `COV`, every input's response also goes into `cov` (one copy of
    /// the loop each; the firmware's, without, has no code for it).
    fn propagated<const COV: bool>(
        &self,
        m: &[PatternMeasurement],
        u_um: &[[f64; 2]],
        budget: &MountingUncertainty,
        bar: &BarBudget,
        mut cov: Option<&mut [[f64; 13]; 13]>,
        jac: &mut Jacobian,
    ) -> Result<(ModelLsqResult, DeviationUncertainty), ModelLsqError> {
        if u_um.len() != m.len() {
            return Err(ModelLsqError::BadMeasurement {
                index: m.len().min(u_um.len()),
            });
        }
        budget
            .validate()
            .map_err(|input| ModelLsqError::BadMountingUncertainty { input })?;
        let u_scale = f64::from(bar.scale);
        if !(u_scale >= 0.0 && u_scale.is_finite()) {
            return Err(ModelLsqError::BadScaleUncertainty);
        }
        // (every row and the SVD are written before they are read)
        *jac = Jacobian::EMPTY;
        let result = self.solve(m, jac)?;
        let x = result.deviations.to_array();
        let pred = Self::predict(m, &x)?;
        let mut var = [[0.0f64; 13]; 4];
        // The inputs of measurement i: its two eccentricity components (moved by their u),
        // then the three components of the W-ball's clamping and of the T-ball's mounting
        // that measurement i is the first to share (each moved by its u through the full model
        // at the identified deviations: a secant, all measurements sharing it at once). Each
        // input's eccentricity changes b give the deviations' response ∂x/∂e · b.
        for (i, (p, u_e)) in m.iter().zip(u_um.iter()).enumerate() {
            for input in 0..8usize {
                let mut b = [[0.0f64; 2]; MAX_MEASUREMENTS];
                let k = (input + 1) % 3; // 2, 3, 4 → x, y, z; 5, 6, 7 → x, y, z
                let w_ball = input < 5;
                let shares = |q: &PatternMeasurement| {
                    if w_ball {
                        q.pattern.is_b() == p.pattern.is_b()
                    } else {
                        q.geometry.r_b_mm == p.geometry.r_b_mm
                    }
                };
                let (source, u) = if input < 2 {
                    let uk = u_e.get(input).copied().unwrap_or(0.0);
                    if let Some(v) = b.get_mut(i).and_then(|r| r.get_mut(input)) {
                        *v = uk;
                    }
                    (0, uk)
                } else if m.iter().position(shares) != Some(i) {
                    continue;
                } else {
                    let mut mounting = Mounting::default();
                    let (source, offset, u) = match (w_ball, k) {
                        (true, _) => (1, &mut mounting.w_offset_um, budget.w_clamp_um),
                        (false, 2) => (2, &mut mounting.t_offset_um, budget.t_axial_um),
                        (false, _) => (2, &mut mounting.t_offset_um, budget.t_centring_um),
                    };
                    if u == 0.0 {
                        continue; // validated: ≥ 0 and finite
                    }
                    if let Some(v) = offset.get_mut(k) {
                        *v = u;
                    }
                    for (index, ((q, dst), base)) in
                        m.iter().zip(b.iter_mut()).zip(pred.iter()).enumerate()
                    {
                        if shares(q) {
                            let e = predict_with(index, q, &x, &mounting)?;
                            *dst = [e[0] - base[0], e[1] - base[1]];
                        }
                    }
                    (source, u)
                };
                if !(u > 0.0 && u.is_finite()) {
                    continue; // an eccentricity component without a u
                }
                let mut dx = response(m, jac, &b);
                if source == 2 && i == 0 {
                    // The first tool length's T-ball offset is part of what is identified.
                    if let Some((param, sign)) = T_BALL_ALIAS.get(k)
                        && let Some(v) = dx.get_mut(param.index())
                    {
                        *v -= sign * u;
                    }
                }
                if let Some(v) = var.get_mut(source) {
                    v.iter_mut().zip(dx.iter()).for_each(|(v, d)| *v += d * d);
                }
                if COV {
                    add_outer(&mut cov, &dx);
                }
            }
        }
        // Inputs many steps share: the LVDT's scale (every eccentricity k times itself), R_C,
        // Z_C as entered (every step's model moved by its u: a secant) and each tool length as
        // entered (the model of every step run with it: 3 the first measurement's, 4 the
        // other; a procedure's two tool lengths differ, or δx_BT and the tilts are not
        // separable and `solve` has refused it).
        let first_r_b = m.first().map_or(0.0, |p| p.geometry.r_b_mm);
        for (input, u) in [
            (0, u_scale),
            (1, budget.r_c_um),
            (2, budget.z_c_um),
            (3, budget.r_b_um),
            (4, budget.r_b_um),
        ] {
            if u == 0.0 {
                continue; // validated: ≥ 0 and finite
            }
            let mut b = [[0.0f64; 2]; MAX_MEASUREMENTS];
            for (index, ((q, dst), base)) in m.iter().zip(b.iter_mut()).zip(pred.iter()).enumerate()
            {
                *dst = if input == 0 {
                    [q.e1_um * u, q.e2_um * u]
                } else {
                    let mut q = *q;
                    let g = &mut q.geometry;
                    let length = match input {
                        1 => &mut g.r_c_mm,
                        2 => &mut g.z_c_mm,
                        _ if (g.r_b_mm == first_r_b) == (input == 3) => &mut g.r_b_mm,
                        _ => continue, // the other tool length's step: not moved
                    };
                    *length += u * 1e-3;
                    let e = predict_with(index, &q, &x, &Mounting::default())?;
                    [e[0] - base[0], e[1] - base[1]]
                };
            }
            let dx = response(m, jac, &b);
            // sources: the LVDT's scale, the W-ball (R_C, Z_C), the T-ball (its tool length)
            if let Some(v) = var.get_mut([3, 1, 1, 2, 2].get(input).copied().unwrap_or(2)) {
                v.iter_mut().zip(dx.iter()).for_each(|(v, d)| *v += d * d);
            }
            if COV {
                add_outer(&mut cov, &dx);
            }
        }
        let mut out = DeviationUncertainty::default();
        for (j, free) in self.free.iter().enumerate() {
            let mut sum = 0.0;
            for (v, dst) in var.iter().zip(out.by_source.iter_mut()) {
                let vj = if *free {
                    v.get(j).copied().unwrap_or(0.0)
                } else {
                    0.0
                };
                sum += vj;
                if let Some(d) = dst.get_mut(j) {
                    *d = crate::num::sqrt(vj);
                }
            }
            if let Some(d) = out.combined.get_mut(j) {
                *d = crate::num::sqrt(sum);
            }
        }
        Ok((result, out))
    }

    /// Chord (frozen-Jacobian) Gauss–Newton: the sensitivities are taken once at the start
    /// values and reused while the steps shrink at least tenfold per iteration (refreshed
    /// otherwise). The deviations are µm and µrad on lever arms of 10²–10³ mm, so the model is
    /// linear to ~1e-5 and the chord iteration contracts by about that factor per step; its
    /// fixed point is the Gauss–Newton one when every equation is met (5 patterns, 10
    /// unknowns) and differs from it by (J − J₀)ᵀ·residual ≈ 1e-5 × the residual otherwise.
    /// One Jacobian costs a model simulation per free deviation and pattern; each iteration
    /// one per pattern — the reason for the chord method on the pod (soft f64 on the M4).
    ///
    /// `jac` is the caller's (4.8 KiB of sensitivities and SVD, kept off this frame): it ends
    /// holding the last sensitivities and the converged system's SVD ([`response`]).
    #[inline(never)] // flash: one body for identify and identify_propagated
    fn solve(
        &self,
        m: &[PatternMeasurement],
        jac: &mut Jacobian,
    ) -> Result<ModelLsqResult, ModelLsqError> {
        self.check(m)?;
        let mut x = self.fixed.to_array();
        let mut pred = Self::predict(m, &x)?;
        self.jacobian(m, &x, &pred, Differences::Forward, jac)?;
        let mut last_step = f64::INFINITY;
        let mut checked_rank = false;
        for it in 0..self.max_iterations.max(1) {
            let mut b = [[0.0f64; 2]; MAX_MEASUREMENTS];
            let mut rss = 0.0;
            for ((dst, p), pr) in b.iter_mut().zip(m.iter()).zip(pred.iter()) {
                *dst = [p.e1_um - pr[0], p.e2_um - pr[1]];
                rss += dst[0] * dst[0] + dst[1] * dst[1];
            }
            let sol = self
                .system(m, jac, &b)?
                .solve_in(DEFAULT_RANK_TOL, &mut jac.svd)
                .map_err(ModelLsqError::Lsq)?;
            if !checked_rank {
                let rank = Self::rank_of(&sol);
                if rank < 13 {
                    let v = sol
                        .right_singular_vectors
                        .last()
                        .copied()
                        .unwrap_or([0.0; 13]);
                    return Err(self.not_separable(rank, &v));
                }
                checked_rank = true;
            }
            let scale = x.iter().fold(1.0f64, |a, v| a.max(libm::fabs(*v)));
            let step = sol.x.iter().fold(0.0f64, |a, v| a.max(libm::fabs(*v)));
            if step <= 1e-10 * scale {
                // Converged: the quality figures of this last system (residual at x).
                let eqs = 2 * m.len();
                // GivensLsq divides the RSS by (rows − 13), counting the 13 fixing/damping
                // rows (zero residual at the solution); the true redundancy is eqs − free.
                let dof_lsq = (sol.rows as usize).saturating_sub(13);
                let dof = eqs.saturating_sub(self.free_count());
                let k = if dof > 0 {
                    crate::num::sqrt(dof_lsq as f64 / dof as f64)
                } else {
                    0.0
                };
                let mut std_uncertainty = sol.std_uncertainty;
                std_uncertainty
                    .iter_mut()
                    .zip(self.free.iter())
                    .for_each(|(u, f)| *u = if *f { *u * k } else { 0.0 });
                let result = ModelLsqResult {
                    deviations: Deviations::from_array(&x),
                    std_uncertainty,
                    residual_rms_um: crate::num::sqrt(rss / eqs.max(1) as f64),
                    condition: sol.condition,
                    iterations: it + 1,
                };
                jac.singular_values = sol.singular_values;
                jac.right_singular_vectors = sol.right_singular_vectors;
                return Ok(result);
            }
            x.iter_mut().zip(sol.x.iter()).for_each(|(a, d)| *a += d);
            pred = Self::predict(m, &x)?;
            if step > 0.1 * last_step {
                self.jacobian(m, &x, &pred, Differences::Forward, jac)?;
            }
            last_step = step;
        }
        Err(ModelLsqError::NoConvergence)
    }
}

/// Largest number of measurements one identification takes (2 equations each; the
/// sensitivities are kept, 2 × 16 × 13 f64 = 3.3 KiB).
pub const MAX_MEASUREMENTS: usize = 16;

/// Where an identification keeps its sensitivities and SVD (4.8 KiB): the
/// caller's, so that a job can keep it off the stack.
#[derive(Clone, Copy)]
pub struct IdentificationScratch(Jacobian);

impl IdentificationScratch {
    /// All zero.
    pub const EMPTY: Self = Self(Jacobian::EMPTY);
}

/// Sensitivity rows ∂e/∂x of the measurement equations (µm per µm / µrad, unweighted; two
/// per measurement), the largest weighted column norm, and once solved the weighted system's
/// singular values and right singular vectors ([`response`]).
#[derive(Clone, Copy)]
struct Jacobian {
    rows: [[f64; 13]; 2 * MAX_MEASUREMENTS],
    scale: f64,
    singular_values: [f64; 13],
    right_singular_vectors: [[f64; 13]; 13],
    /// The SVD's working arrays (off the worker's stack).
    svd: SvdScratch<13>,
}

impl Jacobian {
    /// All zero (a constant of zeros is a memset, any other value a 4.8 KB image in flash).
    const EMPTY: Self = Self {
        rows: [[0.0; 13]; 2 * MAX_MEASUREMENTS],
        scale: 0.0,
        singular_values: [0.0; 13],
        right_singular_vectors: [[0.0; 13]; 13],
        svd: SvdScratch::EMPTY,
    };
}

/// How [`ModelLsq::jacobian`] differentiates the model.
#[derive(Clone, Copy)]
enum Differences {
    Forward,
    Central,
}

/// `cov += dx dxᵀ` (nothing without a `cov`).
fn add_outer(cov: &mut Option<&mut [[f64; 13]; 13]>, dx: &[f64; 13]) {
    if let Some(cov) = cov.as_deref_mut() {
        for (row, di) in cov.iter_mut().zip(dx.iter()) {
            row.iter_mut()
                .zip(dx.iter())
                .for_each(|(c, dj)| *c += di * dj);
        }
    }
}

/// The deviations' response ∂x/∂e · b to eccentricity changes `b` (µm): the least-squares
/// step of the converged system (weighted design A with its fixing and damping rows,
/// `AᵀA = V·Σ²·Vᵀ` from the SVD [`ModelLsq::solve`] leaves in `jac`) for the right-hand side
/// b, `Δx = V·Σ⁻²·Vᵀ·JᵀW·b` — one product instead of a new factorisation per input.
fn response(
    m: &[PatternMeasurement],
    jac: &Jacobian,
    b: &[[f64; 2]; MAX_MEASUREMENTS],
) -> [f64; 13] {
    let mut g = [0.0f64; 13];
    for ((p, rows), rhs) in m.iter().zip(jac.rows.chunks_exact(2)).zip(b.iter()) {
        for (row, v) in rows.iter().zip(rhs.iter()) {
            let wv = p.weight() * v;
            g.iter_mut().zip(row.iter()).for_each(|(g, r)| *g += wv * r);
        }
    }
    let mut dx = [0.0f64; 13];
    for (s, v) in jac
        .singular_values
        .iter()
        .zip(jac.right_singular_vectors.iter())
    {
        if *s > 0.0 {
            let c = v.iter().zip(g.iter()).map(|(a, b)| a * b).sum::<f64>() / (s * s);
            dx.iter_mut().zip(v.iter()).for_each(|(d, a)| *d += c * a);
        }
    }
    dx
}

/// The model's eccentricity for measurement `index` at deviations `x` (µm), balls mounted
/// without offsets.
fn predict_one(
    index: usize,
    p: &PatternMeasurement,
    x: &[f64; 13],
) -> Result<[f64; 2], ModelLsqError> {
    predict_with(index, p, x, &Mounting::default())
}

/// The model's eccentricity for measurement `index` at deviations `x` with the balls'
/// mounting offsets `mounting` (µm).
fn predict_with(
    index: usize,
    p: &PatternMeasurement,
    x: &[f64; 13],
    mounting: &Mounting,
) -> Result<[f64; 2], ModelLsqError> {
    simulate_eccentricity(
        p.pattern,
        &p.geometry,
        &Deviations::from_array(x),
        mounting,
        p.samples,
    )
    .map(|e| [e.e1_um, e.e2_um])
    .map_err(|cause| ModelLsqError::BallbarPattern { index, cause })
}

impl PatternMeasurement {
    /// Weight 1/σ² of each component (1/µm²).
    fn weight(&self) -> f64 {
        1.0 / (self.sigma_um * self.sigma_um)
    }
}
