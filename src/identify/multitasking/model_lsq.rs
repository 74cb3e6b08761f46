//! Model-based least-squares identification on the literal HTM model (eqs 2.1–2.21), with an
//! identifiability report (spec seed-002 §3.7, §9.1 item 7).
//!
//! Each measured pattern contributes two equations: its eccentricity (e1, e2) (µm, §3.5
//! convention, see [`super::patterns`]) equals the eccentricity the literal model predicts for
//! the deviations, simulated over the same sampling ([`super::patterns::simulate_eccentricity`]).
//! The map is solved by Gauss–Newton: Jacobian by central differences of the full model (exact
//! for its quadratic part), each step a weighted linear least squares in
//! [`crate::identify::lsq::GivensLsq`] with a rank check. The unknowns are the chosen subset
//! of the 13 deviations (µm / µrad); the others stay at given fixed values.
//!
//! What the literal model can and cannot separate (the report computes it for any set-up):
//! - BX, BY, CR, CA and CR' (second tool length) determine the 10 deviations other than the
//!   squareness errors (δx_BT, δz_BT, α_BT, α_XB, β_XB, γ_XB, δx_CZ, δy_CZ, α_CZ, β_CZ) —
//!   exactly (10 equations) unless patterns are repeated;
//! - α_YZ and β_YZ alias α_XB and β_XB, and γ_XY is seen only by CX (spec §3.4): freeing
//!   them gives [`ModelLsqError::NotSeparable`] naming the combination;
//! - T-ball mounting offsets x_T, z_T act exactly like δx_BT, δz_BT (they are not unknowns
//!   here; what is identified as δx_BT/δz_BT includes them).
use crate::identify::lsq::{DEFAULT_RANK_TOL, GivensLsq, LsqError, LsqSolution};

/// Relative damping λ of the free deviations (× the largest weighted sensitivity column).
pub const DAMPING: f64 = 1e-7;

/// A direction counts as separable when its singular value exceeds this fraction of the
/// largest (condition number up to 1e5; a damped null direction sits at ≈ [`DAMPING`]).
pub const RANK_REL_TOL: f64 = 1e-5;

use super::patterns::{Mounting, Pattern, PatternError, PatternGeometry, simulate_eccentricity};
use super::{Deviations, Parameter};

/// One measured pattern: its eccentricity in the §3.5 sign convention of
/// [`super::patterns`] (the same as [`super::ballbar::ThesisEccentricities`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatternMeasurement {
    /// The pattern (Tables 2.2/2.3).
    pub pattern: Pattern,
    /// Its set-up lengths (mm).
    pub geometry: PatternGeometry,
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
    /// A fixed (or start) deviation value is NaN or infinite.
    NonFiniteFixed,
    /// A measurement's σ is ≤ 0 or not finite, or an eccentricity is not finite (index).
    BadMeasurement {
        /// Index of the measurement.
        index: usize,
    },
    /// A pattern could not be simulated (bad geometry, sampling).
    Pattern {
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

    fn free_count(&self) -> usize {
        self.free.iter().filter(|f| **f).count()
    }

    fn check(&self, m: &[PatternMeasurement]) -> Result<(), ModelLsqError> {
        if m.is_empty() || self.free_count() == 0 {
            return Err(ModelLsqError::Empty);
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
                .map_err(|cause| ModelLsqError::Pattern { index, cause })?;
        }
        Ok(())
    }

    /// One linearised system at `x`: the accumulator, the unweighted RSS of the eccentricity
    /// residuals and the number of measurement equations.
    ///
    /// Rows: the weighted measurement equations; `Δx_j = 0` for every fixed deviation (weight
    /// scaled to the largest weighted sensitivity column, so it never limits the rank test);
    /// and a damping row `λ·Δx_j = 0` for every free deviation, λ = [`DAMPING`] × that column
    /// norm (Levenberg–Marquardt on the step: it vanishes at the Gauss–Newton fixed point, keeps
    /// the SVD well posed when the set-up is rank-deficient, and puts an inseparable direction at
    /// singular value ≈ λ, far below the rank threshold [`RANK_REL_TOL`]).
    fn linearise(
        &self,
        m: &[PatternMeasurement],
        x: &[f64; 13],
    ) -> Result<(GivensLsq<13>, f64, usize), ModelLsqError> {
        let mut lsq = GivensLsq::<13>::new();
        let mut rss = 0.0;
        let mut eqs = 0usize;
        let mut col2 = [0.0f64; 13];
        let sim = |index: usize, p: &PatternMeasurement, d: &[f64; 13]| {
            simulate_eccentricity(
                p.pattern,
                &p.geometry,
                &Deviations::from_array(d),
                &Mounting::default(),
                p.samples,
            )
            .map(|e| [e.e1_um, e.e2_um])
            .map_err(|cause| ModelLsqError::Pattern { index, cause })
        };
        for (index, p) in m.iter().enumerate() {
            let pred = sim(index, p, x)?;
            let mut jac = [[0.0f64; 13]; 2];
            for (j, free) in self.free.iter().enumerate() {
                if !free {
                    continue;
                }
                // Central difference with a 1 µm / 1 µrad step: exact for the quadratic part.
                let h = 1.0;
                let (mut xp, mut xm) = (*x, *x);
                if let (Some(a), Some(b)) = (xp.get_mut(j), xm.get_mut(j)) {
                    *a += h;
                    *b -= h;
                }
                let (ep, em) = (sim(index, p, &xp)?, sim(index, p, &xm)?);
                for ((row, a), b) in jac.iter_mut().zip(ep.iter()).zip(em.iter()) {
                    if let Some(v) = row.get_mut(j) {
                        *v = (a - b) / (2.0 * h);
                    }
                }
            }
            let w = 1.0 / (p.sigma_um * p.sigma_um);
            for ((row, meas), pr) in jac.iter().zip([p.e1_um, p.e2_um]).zip(pred) {
                lsq.add_row(row, meas - pr, w).map_err(ModelLsqError::Lsq)?;
                col2.iter_mut()
                    .zip(row.iter())
                    .for_each(|(c, v)| *c += w * v * v);
                rss += (meas - pr) * (meas - pr);
                eqs += 1;
            }
        }
        let scale = crate::num::sqrt(col2.iter().fold(0.0f64, |a, v| a.max(*v)));
        let scale = if scale > 0.0 && scale.is_finite() {
            scale
        } else {
            1.0
        };
        for (j, free) in self.free.iter().enumerate() {
            let mut row = [0.0f64; 13];
            if let Some(v) = row.get_mut(j) {
                *v = 1.0;
            }
            let lambda = if *free { DAMPING * scale } else { scale };
            lsq.add_row(&row, 0.0, lambda * lambda)
                .map_err(ModelLsqError::Lsq)?;
        }
        Ok((lsq, rss, eqs))
    }

    /// Rank of a solved linearisation among all 13 columns (fixed ones count as resolved).
    fn rank_of(sol: &LsqSolution<13>) -> usize {
        let s_max = sol.singular_values.first().copied().unwrap_or(0.0);
        sol.singular_values
            .iter()
            .filter(|s| **s > RANK_REL_TOL * s_max)
            .count()
    }

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
        let (lsq, _, equations) = self.linearise(m, &x)?;
        let sol = lsq.solve(DEFAULT_RANK_TOL).map_err(ModelLsqError::Lsq)?;
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
            equations,
            null_combinations,
            condition,
        })
    }

    /// Identifies the free deviations from the measured patterns (Gauss–Newton on the literal
    /// model). Rank deficiency is an error naming the inseparable combination.
    pub fn identify(&self, m: &[PatternMeasurement]) -> Result<ModelLsqResult, ModelLsqError> {
        self.check(m)?;
        let mut x = self.fixed.to_array();
        for it in 0..self.max_iterations.max(1) {
            let (lsq, _, _) = self.linearise(m, &x)?;
            let sol = lsq.solve(DEFAULT_RANK_TOL).map_err(ModelLsqError::Lsq)?;
            let rank = Self::rank_of(&sol);
            if rank < 13 {
                let v = sol
                    .right_singular_vectors
                    .last()
                    .copied()
                    .unwrap_or([0.0; 13]);
                return Err(self.not_separable(rank, &v));
            }
            let scale = x.iter().fold(1.0f64, |a, v| a.max(libm::fabs(*v)));
            let step = sol.x.iter().fold(0.0f64, |a, v| a.max(libm::fabs(*v)));
            x.iter_mut().zip(sol.x.iter()).for_each(|(a, d)| *a += d);
            if step <= 1e-10 * scale {
                // Converged: report the quality figures at the solution.
                let (lsq, rss, eqs) = self.linearise(m, &x)?;
                let fin = lsq.solve(DEFAULT_RANK_TOL).map_err(ModelLsqError::Lsq)?;
                // GivensLsq divides the RSS by (rows − 13), counting the 13 fixing/damping
                // rows (zero residual at the solution); the true redundancy is eqs − free.
                let dof_lsq = (fin.rows as usize).saturating_sub(13);
                let dof = eqs.saturating_sub(self.free_count());
                let k = if dof > 0 {
                    crate::num::sqrt(dof_lsq as f64 / dof as f64)
                } else {
                    0.0
                };
                let mut std_uncertainty = fin.std_uncertainty;
                std_uncertainty
                    .iter_mut()
                    .zip(self.free.iter())
                    .for_each(|(u, f)| *u = if *f { *u * k } else { 0.0 });
                return Ok(ModelLsqResult {
                    deviations: Deviations::from_array(&x),
                    std_uncertainty,
                    residual_rms_um: crate::num::sqrt(rss / eqs.max(1) as f64),
                    condition: fin.condition,
                    iterations: it + 1,
                });
            }
        }
        Err(ModelLsqError::NoConvergence)
    }
}
