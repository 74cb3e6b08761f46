//! The B/C ball-bar procedure of a mill-turn machine, seed 002's (spec seed-002 §5.3, Table 4.3): steps BX, BY, CR, CA and CR′
//! (`CR2`: CR with the second tool length R′_B), each run CW and CCW, the whole procedure
//! repeated. The steps are the seed 002 [`Pattern`]s ([`Pattern::SEED002`]).
//!
//! Per run: a [`CircleFit`] with the step's sensitive directions ([`Procedure::run_fit`]), fed
//! with the run's samples; its estimate is [`Procedure::record`]ed. Per step: each repeat's CW
//! and CCW estimates are averaged ([`circle_fit::combine`], §3.5), then the repeats are
//! averaged. Once every step has a CW and a CCW run, [`Procedure::identify`] gives
//! - thesis mode: eqs 4.10–4.18 verbatim ([`identify_thesis`]), and
//! - model mode: the literal HTM model ([`ModelLsq::without_squareness`], 10 deviations),
//!
//! both with standard uncertainties propagated from the eccentricity uncertainties (thesis
//! mode: one perturbation per eccentricity component; model mode: linear propagation through
//! the solution's sensitivities, [`ModelLsq::identify_propagated`]); the model mode's adds the
//! balls' mounting offsets of the set-up's budget ([`Setup::mounting`]).
//!
//! Eccentricity uncertainty of a step: u = max(u_fit, s/√m) per component, u_fit from the runs'
//! residuals (combined CW/CCW, averaged over the m repeats), s the repeat scatter (m ≥ 2).
//!
//! Machine coordinates of the samples: the Table 2.2/2.3 model frame plus the procedure's
//! [`NcOffset`] (linear axes in mm; B and C in degrees, unused by the fits).

use super::pattern::{Direction, Pattern};
use super::results::{ResultId, ResultSink};
use crate::acquisition::Sample;
use crate::config::{Field, TestSetup};
use crate::identify::mill_turn::ballbar::{
    BallBarError, ThesisEccentricities, ThesisGeometry, ThesisResult, identify_thesis,
};
use crate::identify::mill_turn::model_lsq::{
    DeviationUncertainty, IdentificationScratch, ModelLsq, ModelLsqError, ModelLsqResult,
    MountingUncertainty, PatternMeasurement,
};
use crate::identify::mill_turn::patterns::{BallbarLengths, BallbarPattern, NcOffset};
use crate::identify::mill_turn::{Parameter, urad_to_arcsec};
use crate::metrology::bar_budget::{BarBudget, FigureKind};
use crate::metrology::circle_fit::{
    self, CircleEstimate, CircleFit, CircleFitConfig, CircleFitError, SampleUse,
};
use crate::metrology::pattern::{self, Plane, Sensitivity};

/// Most repeats of each step and direction a session keeps (the thesis ran 3).
pub const MAX_REPEATS: usize = 8;

/// Minimum turned arc for a run's estimate, degrees (the B arcs turn 90°).
pub const MIN_ARC_DEG: f32 = 80.0;

/// Most sampling points the model-mode prediction uses per pattern (B arcs every 2.5°, C
/// circles every 10°). The measured runs have thousands of samples; the model's eccentricity
/// depends on the sampling only through its second-order (non-limaçon) part, so predicting it
/// from 37 equally spaced points moves the identified deviations by ≤ 3e-4 µm / µrad against
/// a 3601-point measurement of ~100 µm deviations (test `coarse_model_sampling_is_exact_enough`
/// in host-tests/tests/identify_mill_turn_lsq.rs), while each model simulation — the cost
/// of the identification on the pod, soft f64 on the M4 — is 20× cheaper than at 721 points.
pub const MODEL_SAMPLES_MAX: usize = 37;

/// The model pattern (Tables 2.2/2.3) a step runs: CR′ is CR with R′_B (a pattern that is no
/// seed 002 step is taken as CR).
pub const fn model_pattern(step: Pattern) -> BallbarPattern {
    match step {
        Pattern::Bx => BallbarPattern::Bx,
        Pattern::By => BallbarPattern::By,
        Pattern::Ca => BallbarPattern::Ca,
        _ => BallbarPattern::Cr,
    }
}

/// Set-up of the procedure (Table 4.3 symbols, mm).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Setup {
    /// L_B: ball-bar length (mm).
    pub l_b_mm: f64,
    /// R_B: B centre → T-ball, steps 1–4 (mm).
    pub r_b_mm: f64,
    /// R′_B: B centre → T-ball, step 5 (mm).
    pub r_b2_mm: f64,
    /// R_C: W-ball distance from the C centreline (mm).
    pub r_c_mm: f64,
    /// Z_C: W-ball height above the C table (mm).
    pub z_c_mm: f64,
    /// Z_T: thesis lever arm of steps 1–4 (mm; thesis mode only).
    pub z_t_mm: f64,
    /// Z′_T: thesis lever arm of step 5 (mm; thesis mode only).
    pub z_t2_mm: f64,
    /// X_T: thesis lever arm (mm; thesis mode only).
    pub x_t_mm: f64,
    /// Offset of the machine coordinates from the model frame (mm).
    pub offset: NcOffset,
    /// The Type B inputs of the model mode's budget: the balls' mounting, R_C and Z_C as
    /// entered (µm).
    pub mounting: MountingUncertainty,
}

impl Setup {
    /// Table 4.3 of the thesis (L_B = 100 mm, R_C = 50 mm), model frame = machine frame.
    pub const fn thesis_table_4_3() -> Self {
        Self {
            l_b_mm: 100.0,
            r_b_mm: 356.3945,
            r_b2_mm: 406.4608,
            r_c_mm: 50.0,
            z_c_mm: 65.5348,
            z_t_mm: 112.2877,
            z_t2_mm: 62.2491,
            x_t_mm: 490.0,
            offset: NcOffset {
                x_mm: 0.0,
                y_mm: 0.0,
                z_mm: 0.0,
            },
            mounting: MountingUncertainty::SEED002,
        }
    }

    /// The set-up of the configuration, or the first field it lacks (the thesis lever arms
    /// Z_T, Z′_T, X_T may be not set: thesis mode then gives no result).
    pub fn from_config(t: &TestSetup) -> Result<Self, Field> {
        use crate::config::{required as need, required3};
        // fields in table order: the first missing one is named
        Ok(Self {
            l_b_mm: need(t.s002_l_b_mm, Field::S002LbMm)?,
            r_b_mm: need(t.s002_r_b_mm, Field::S002RbMm)?,
            r_b2_mm: need(t.s002_r_b2_mm, Field::S002Rb2Mm)?,
            r_c_mm: need(t.s002_r_c_mm, Field::S002RcMm)?,
            z_c_mm: need(t.s002_z_c_mm, Field::S002ZcMm)?,
            z_t_mm: f64::from(t.s002_z_t_mm),
            z_t2_mm: f64::from(t.s002_z_t2_mm),
            x_t_mm: f64::from(t.s002_x_t_mm),
            offset: {
                let [x_mm, y_mm, z_mm] = required3(t.s002_origin_mm, Field::S002OriginMm)?;
                NcOffset { x_mm, y_mm, z_mm }
            },
            mounting: MountingUncertainty {
                w_clamp_um: f64::from(t.s002_u_w_clamp_um),
                t_centring_um: f64::from(t.s002_u_t_centring_um),
                t_axial_um: f64::from(t.s002_u_t_axial_um),
                r_c_um: f64::from(t.s002_u_r_c_z_c_um),
                z_c_um: f64::from(t.s002_u_r_c_z_c_um),
                r_b_um: f64::from(t.s002_u_r_b_um),
            },
        })
    }

    /// The configuration's set-up fields holding this set-up (f32, as stored).
    pub fn to_config(&self, t: &mut TestSetup) {
        t.s002_l_b_mm = self.l_b_mm as f32;
        t.s002_r_b_mm = self.r_b_mm as f32;
        t.s002_r_b2_mm = self.r_b2_mm as f32;
        t.s002_r_c_mm = self.r_c_mm as f32;
        t.s002_z_c_mm = self.z_c_mm as f32;
        t.s002_z_t_mm = self.z_t_mm as f32;
        t.s002_z_t2_mm = self.z_t2_mm as f32;
        t.s002_x_t_mm = self.x_t_mm as f32;
        t.s002_origin_mm = [
            self.offset.x_mm as f32,
            self.offset.y_mm as f32,
            self.offset.z_mm as f32,
        ];
        t.s002_u_w_clamp_um = self.mounting.w_clamp_um as f32;
        t.s002_u_t_centring_um = self.mounting.t_centring_um as f32;
        t.s002_u_t_axial_um = self.mounting.t_axial_um as f32;
        // R_C and Z_C share one field: the larger of their u
        t.s002_u_r_c_z_c_um = self.mounting.r_c_um.max(self.mounting.z_c_um) as f32;
        t.s002_u_r_b_um = self.mounting.r_b_um as f32;
    }

    /// Whether `other` describes the same measurement: every length and the origin. The
    /// budget's inputs ([`Setup::mounting`]) do not count: runs measured under one budget stay
    /// valid under another.
    pub fn same_measurement(&self, other: &Setup) -> bool {
        Setup {
            mounting: other.mounting,
            ..*self
        } == *other
    }

    /// The pattern geometry of a step (R′_B for CR2).
    pub fn geometry(&self, step: Pattern) -> BallbarLengths {
        BallbarLengths {
            l_b_mm: self.l_b_mm,
            r_b_mm: if step == Pattern::Cr2 {
                self.r_b2_mm
            } else {
                self.r_b_mm
            },
            r_c_mm: self.r_c_mm,
            z_c_mm: self.z_c_mm,
        }
    }

    /// The metrology geometry of a step in machine coordinates: the commanded T-ball path's
    /// centre and plane, n outward (which is sign(R_C − L_B)(cos θ, sin θ) for CR, §3.5).
    pub fn fit_geometry(&self, step: Pattern) -> pattern::ArcGeometry {
        let o = &self.offset;
        let (plane, cu, cv) = match step {
            Pattern::Bx => (Plane::XZ, self.l_b_mm + o.x_mm, self.z_c_mm + o.z_mm),
            Pattern::By => (Plane::XZ, o.x_mm, self.z_c_mm + o.z_mm),
            _ => (Plane::XY, o.x_mm, o.y_mm),
        };
        pattern::ArcGeometry {
            plane,
            centre_u_mm: cu as f32,
            centre_v_mm: cv as f32,
            sensitivity: Sensitivity::Outward,
        }
    }

    fn thesis_geometry(&self) -> ThesisGeometry {
        ThesisGeometry {
            r_b_mm: self.r_b_mm,
            r_c_mm: self.r_c_mm,
            z_c_mm: self.z_c_mm,
            z_t_mm: self.z_t_mm,
            z_t2_mm: self.z_t2_mm,
            x_t_mm: self.x_t_mm,
        }
    }
}

/// Why a session operation failed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SessionError {
    /// A run's fit gave no estimate.
    Fit(CircleFitError),
    /// The pattern is not a seed 002 step.
    NotAStep(Pattern),
    /// The step already holds [`MAX_REPEATS`] runs in this direction (the run is not kept).
    TooManyRuns {
        /// The step.
        step: Pattern,
    },
    /// The procedure lacks a run (the first missing one is named).
    Incomplete {
        /// Step without a run.
        step: Pattern,
        /// Direction without a run.
        direction: Direction,
    },
    /// Model-based identification failed.
    Model(ModelLsqError),
}

/// Eccentricity of one step (µm, §3.5 convention: (ex, ez) for B steps, (ex, ey) for C).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct StepEccentricity {
    /// Mean over the repeats of the CW/CCW means (µm).
    pub e_um: [f64; 2],
    /// Standard uncertainty of `e_um` (µm), see the module doc.
    pub u_e_um: [f64; 2],
    /// Mean CCW − CW eccentricity (µm).
    pub e_ccw_minus_cw_um: [f64; 2],
    /// Repeats (CW/CCW pairs) used.
    pub repeats: usize,
    /// Samples of the first CW run (the sampling the model predicts with).
    pub samples: usize,
    /// Largest residual RMS of the step's runs (µm).
    pub residual_rms_um: f64,
}

/// Model-mode result with the propagated uncertainty.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModelIdentification {
    /// The Gauss–Newton solution on the measured eccentricities.
    pub result: ModelLsqResult,
    /// Standard uncertainty of each deviation by source, the eccentricities' and the balls'
    /// mounting offsets ([`Setup::mounting`]) (µm / µrad, 0 for the fixed squareness errors).
    pub uncertainty: DeviationUncertainty,
}

/// Everything the procedure identifies.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Identification {
    /// Eccentricity of each step, in [`Pattern::SEED002`] order.
    pub steps: [StepEccentricity; 5],
    /// Thesis mode (eqs 4.10–4.18; its relations differ from the literal model, spec §9.1), or
    /// why it has no result (e.g. the lever arms Z_T, Z′_T, X_T are not set).
    pub thesis: Result<ThesisResult, BallBarError>,
    /// Model mode (literal HTM model).
    pub model: ModelIdentification,
}

/// The runs of one procedure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Procedure {
    setup: Setup,
    runs: [[[Option<CircleEstimate>; MAX_REPEATS]; 2]; 5],
}

const fn dir_index(d: Direction) -> usize {
    match d {
        Direction::Cw => 0,
        Direction::Ccw => 1,
    }
}

impl Procedure {
    /// Starts again, empty, with `setup` (in place).
    pub fn restart(&mut self, setup: Setup) {
        self.setup = setup;
        self.runs
            .iter_mut()
            .flatten()
            .flatten()
            .for_each(|r| *r = None);
    }

    /// An empty procedure.
    pub const fn new(setup: Setup) -> Self {
        Self {
            setup,
            runs: [[[None; MAX_REPEATS]; 2]; 5],
        }
    }

    /// The set-up.
    pub const fn setup(&self) -> &Setup {
        &self.setup
    }

    /// Takes a new budget for the identification; the runs stay.
    pub fn set_mounting(&mut self, mounting: MountingUncertainty) {
        self.setup.mounting = mounting;
    }

    /// A fresh running fit for a run of `step`.
    pub fn run_fit(&self, step: Pattern) -> CircleFit {
        CircleFit::new(CircleFitConfig {
            geometry: self.setup.fit_geometry(step),
            min_arc_deg: MIN_ARC_DEG,
        })
    }

    /// Forgets every run (a new procedure with the same set-up).
    pub fn clear(&mut self) {
        *self = Self::new(self.setup);
    }

    /// Feeds a whole run's samples to a fresh fit and records the estimate (host convenience;
    /// the firmware calls [`CircleFit::update`] per sample and [`Procedure::record`] at the end).
    /// Returns the estimate and how many samples were skipped.
    pub fn run<'a, I: IntoIterator<Item = &'a Sample>>(
        &mut self,
        step: Pattern,
        direction: Direction,
        samples: I,
    ) -> Result<(CircleEstimate, u32), SessionError> {
        let mut fit = self.run_fit(step);
        let mut skipped = 0u32;
        for s in samples {
            if fit.update(s) != SampleUse::Used {
                skipped = skipped.saturating_add(1);
            }
        }
        let est = fit.estimate().map_err(SessionError::Fit)?;
        self.record(step, direction, est)?;
        Ok((est, skipped))
    }

    /// Keeps a finished run's estimate.
    pub fn record(
        &mut self,
        step: Pattern,
        direction: Direction,
        estimate: CircleEstimate,
    ) -> Result<(), SessionError> {
        let index = step.seed002_step().ok_or(SessionError::NotAStep(step))?;
        let slot = self
            .runs
            .get_mut(index)
            .and_then(|s| s.get_mut(dir_index(direction)))
            .and_then(|r| r.iter_mut().find(|e| e.is_none()))
            .ok_or(SessionError::TooManyRuns { step })?;
        *slot = Some(estimate);
        Ok(())
    }

    fn runs_of(&self, step: Pattern, d: Direction) -> impl Iterator<Item = &CircleEstimate> {
        self.runs
            .get(step.seed002_step().unwrap_or(usize::MAX))
            .and_then(|s| s.get(dir_index(d)))
            .into_iter()
            .flat_map(|r| r.iter().flatten())
    }

    /// The first step and direction without a run, or `None` when the procedure is complete.
    pub fn missing(&self) -> Option<(Pattern, Direction)> {
        Pattern::SEED002.iter().find_map(|&s| {
            [Direction::Cw, Direction::Ccw]
                .into_iter()
                .find(|&d| self.runs_of(s, d).next().is_none())
                .map(|d| (s, d))
        })
    }

    /// Eccentricity of one step over its CW/CCW pairs (a run without a partner is ignored).
    pub fn step_eccentricity(&self, step: Pattern) -> Result<StepEccentricity, SessionError> {
        let mut m = 0usize;
        let (mut sum, mut sum2, mut u2, mut diff) = ([0.0f64; 2], [0.0f64; 2], [0.0; 2], [0.0; 2]);
        let mut samples = 0usize;
        let mut rms = 0.0f64;
        for (cw, ccw) in self
            .runs_of(step, Direction::Cw)
            .zip(self.runs_of(step, Direction::Ccw))
        {
            let c = circle_fit::combine(cw, ccw);
            if m == 0 {
                samples = cw.samples as usize;
            }
            m += 1;
            rms = rms
                .max(f64::from(cw.residual_rms_um))
                .max(f64::from(ccw.residual_rms_um));
            for k in 0..2 {
                let (e, u, d) = (
                    c.e_um.get(k).copied().map(f64::from).unwrap_or(0.0),
                    c.u_e_um.get(k).copied().map(f64::from).unwrap_or(0.0),
                    c.e_ccw_minus_cw_um
                        .get(k)
                        .copied()
                        .map(f64::from)
                        .unwrap_or(0.0),
                );
                if let (Some(s), Some(s2), Some(uu), Some(dd)) = (
                    sum.get_mut(k),
                    sum2.get_mut(k),
                    u2.get_mut(k),
                    diff.get_mut(k),
                ) {
                    *s += e;
                    *s2 += e * e;
                    *uu += u * u;
                    *dd += d;
                }
            }
        }
        if m == 0 {
            let direction = if self.runs_of(step, Direction::Cw).next().is_none() {
                Direction::Cw
            } else {
                Direction::Ccw
            };
            return Err(SessionError::Incomplete { step, direction });
        }
        let mf = m as f64;
        let mut out = StepEccentricity {
            repeats: m,
            samples,
            residual_rms_um: rms,
            ..StepEccentricity::default()
        };
        for k in 0..2 {
            let (s, s2, uu, dd) = (
                sum.get(k).copied().unwrap_or(0.0),
                sum2.get(k).copied().unwrap_or(0.0),
                u2.get(k).copied().unwrap_or(0.0),
                diff.get(k).copied().unwrap_or(0.0),
            );
            let mean = s / mf;
            let u_fit = crate::num::sqrt(uu) / mf;
            let u_rep = if m >= 2 {
                let var = ((s2 - s * mean) / (mf - 1.0)).max(0.0);
                crate::num::sqrt(var / mf)
            } else {
                0.0
            };
            if let (Some(e), Some(u), Some(d)) = (
                out.e_um.get_mut(k),
                out.u_e_um.get_mut(k),
                out.e_ccw_minus_cw_um.get_mut(k),
            ) {
                *e = mean;
                *u = u_fit.max(u_rep);
                *d = dd / mf;
            }
        }
        Ok(out)
    }

    /// Identification from a complete procedure, in both modes; `bar` the configured bar's
    /// budget (its LVDT scale enters the model mode's u).
    pub fn identify(&self, bar: &BarBudget) -> Result<Identification, SessionError> {
        self.identification_input()?.identify(bar)
    }

    /// What the identification reads of a complete procedure: the set-up and each step's
    /// eccentricity (cheap: means over the runs), or the first step and direction it lacks.
    pub fn identification_input(&self) -> Result<IdentificationInput, SessionError> {
        if let Some((step, direction)) = self.missing() {
            return Err(SessionError::Incomplete { step, direction });
        }
        let mut steps = [StepEccentricity::default(); 5];
        for (dst, &s) in steps.iter_mut().zip(Pattern::SEED002.iter()) {
            *dst = self.step_eccentricity(s)?;
        }
        Ok(IdentificationInput {
            setup: self.setup,
            steps,
        })
    }

    /// The full covariance of the model mode's deviations (µm², µm·µrad, µrad²; rows and
    /// columns in [`crate::identify::mill_turn::Parameter::ALL`] order) from the same inputs
    /// as [`Self::identify`]'s u: what a compensation of several deviations needs (the host's
    /// part programs; the pod reports each deviation's u).
    pub fn model_covariance(&self, bar: &BarBudget) -> Result<[[f64; 13]; 13], SessionError> {
        let input = self.identification_input()?;
        let (_, _, cov) = ModelLsq::without_squareness()
            .identify_covariance(
                &input.measurements(),
                &input.steps.map(|s| s.u_e_um),
                &self.setup.mounting,
                bar,
            )
            .map_err(SessionError::Model)?;
        Ok(cov)
    }
}

/// What the seed 002 identification reads of a complete procedure
/// ([`Procedure::identification_input`]): the set-up and the five steps' eccentricities, 0.6
/// KiB where the runs are 3.3 KiB — the copy a job takes ([`super::job`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentificationInput {
    /// The procedure's set-up.
    pub setup: Setup,
    /// Eccentricity of each step, in [`Pattern::SEED002`] order.
    pub steps: [StepEccentricity; 5],
}

impl IdentificationInput {
    /// Identification in both modes (seconds of f64 on the pod: a job); `bar` the configured
    /// bar's budget (its LVDT scale enters the model mode's u).
    pub fn identify(&self, bar: &BarBudget) -> Result<Identification, SessionError> {
        let mut scratch = IdentificationScratch::EMPTY;
        self.identify_in(bar, &mut scratch)
    }

    /// [`Self::identify`] with the model fit's sensitivities in the caller's `scratch` (the
    /// pod's job slot: 4.8 KiB off the worker's stack).
    pub fn identify_in(
        &self,
        bar: &BarBudget,
        scratch: &mut IdentificationScratch,
    ) -> Result<Identification, SessionError> {
        let steps = self.steps;
        let [bx, by, cr, ca, cr2] = steps;
        let ecc = |f: fn(&StepEccentricity) -> [f64; 2]| ThesisEccentricities {
            ex_bx_um: f(&bx)[0],
            ez_bx_um: f(&bx)[1],
            ex_by_um: f(&by)[0],
            ez_by_um: f(&by)[1],
            ex_cr_um: f(&cr)[0],
            ey_cr_um: f(&cr)[1],
            ex_ca_um: f(&ca)[0],
            ey_ca_um: f(&ca)[1],
            ex_cr2_um: f(&cr2)[0],
            ey_cr2_um: f(&cr2)[1],
        };
        let thesis = identify_thesis(
            &ecc(|s| s.e_um),
            &self.setup.thesis_geometry(),
            Some(&ecc(|s| s.u_e_um)),
        );
        let model = self.identify_model(bar, scratch)?;
        Ok(Identification {
            steps,
            thesis,
            model,
        })
    }

    fn measurements(&self) -> [PatternMeasurement; 5] {
        let steps = &self.steps;
        let mut m = [PatternMeasurement {
            pattern: BallbarPattern::Bx,
            geometry: self.setup.geometry(Pattern::Bx),
            samples: 0,
            e1_um: 0.0,
            e2_um: 0.0,
            sigma_um: 1.0,
        }; 5];
        for ((dst, s), &step) in m.iter_mut().zip(steps.iter()).zip(Pattern::SEED002.iter()) {
            let [e1_um, e2_um] = s.e_um;
            let [u1, u2] = s.u_e_um;
            // a zero uncertainty (noise-free simulation) would make the weights infinite
            let sigma_um = u1.max(u2).max(1e-6);
            *dst = PatternMeasurement {
                pattern: model_pattern(step),
                geometry: self.setup.geometry(step),
                samples: s.samples.min(MODEL_SAMPLES_MAX),
                e1_um,
                e2_um,
                sigma_um,
            };
        }
        m
    }

    fn identify_model(
        &self,
        bar: &BarBudget,
        scratch: &mut IdentificationScratch,
    ) -> Result<ModelIdentification, SessionError> {
        let steps = &self.steps;
        let lsq = ModelLsq::without_squareness();
        let m = self.measurements();
        let mut u = [[0.0f64; 2]; 5];
        u.iter_mut()
            .zip(steps.iter())
            .for_each(|(u, s)| *u = s.u_e_um);
        let (result, uncertainty) = lsq
            .identify_propagated_in(&m, &u, &self.setup.mounting, bar, scratch)
            .map_err(SessionError::Model)?;
        Ok(ModelIdentification {
            result,
            uncertainty,
        })
    }
}

/// Publishes a seed 002 identification into `r`: the ten model-mode deviations with their
/// budgets (by source: the eccentricities, the W-ball, the T-ball, the LVDT's scale) and their
/// corrections, the model's residual and condition, and the thesis mode's deviations with the
/// LVDT scale's share of `bar`.
pub fn publish_identification(id: &Identification, bar: &BarBudget, r: &mut impl ResultSink) {
    let m = &id.model;
    let x = m.result.deviations.to_array();
    const MODEL: [(Parameter, ResultId, ResultId); 10] = [
        (Parameter::DxBt, ResultId::DxBt, ResultId::CorrDxBt),
        (Parameter::DzBt, ResultId::DzBt, ResultId::CorrDzBt),
        (Parameter::AlphaBt, ResultId::AlphaBt, ResultId::CorrAlphaBt),
        (Parameter::AlphaXb, ResultId::AlphaXb, ResultId::CorrAlphaXb),
        (Parameter::BetaXb, ResultId::BetaXb, ResultId::CorrBetaXb),
        (Parameter::GammaXb, ResultId::GammaXb, ResultId::CorrGammaXb),
        (Parameter::DxCz, ResultId::DxCz, ResultId::CorrDxCz),
        (Parameter::DyCz, ResultId::DyCz, ResultId::CorrDyCz),
        (Parameter::AlphaCz, ResultId::AlphaCz, ResultId::CorrAlphaCz),
        (Parameter::BetaCz, ResultId::BetaCz, ResultId::CorrBetaCz),
    ];
    for (p, id, corr) in MODEL {
        let i = p.index();
        let unit = if p.is_positional() {
            1.0
        } else {
            urad_to_arcsec(1.0)
        };
        let v = x.get(i).copied().unwrap_or(f64::NAN) * unit;
        // by_source: the eccentricities, the W-ball, the T-ball, the LVDT's scale
        let [ecc, w, t, scale] = m
            .uncertainty
            .by_source
            .map(|s| (s.get(i).copied().unwrap_or(f64::NAN) * unit) as f32);
        let shares = [ecc, 0.0, scale, w, t, 0.0, 0.0];
        r.set_budget(id, v, shares);
        r.set_budget(corr, -v, shares);
    }
    r.set(
        ResultId::ModelResidualRms,
        m.result.residual_rms_um,
        f64::NAN,
    );
    r.set(ResultId::ModelCondition, m.result.condition, f64::NAN);
    if let Ok(t) = &id.thesis {
        let (d, u) = (&t.deviations, &t.std_uncertainty);
        for (id, v, uu) in [
            (ResultId::ThAlphaCz, d.alpha_cz_arcsec, u.alpha_cz_arcsec),
            (ResultId::ThBetaCz, d.beta_cz_arcsec, u.beta_cz_arcsec),
            (ResultId::ThAlphaXb, d.alpha_xb_arcsec, u.alpha_xb_arcsec),
            (ResultId::ThBetaXb, d.beta_xb_arcsec, u.beta_xb_arcsec),
            (ResultId::ThGammaXb, d.gamma_xb_arcsec, u.gamma_xb_arcsec),
            (ResultId::ThAlphaBt, d.alpha_bt_arcsec, u.alpha_bt_arcsec),
            (
                ResultId::ThDxCzMinusDxBt,
                d.dx_cz_minus_dx_bt_um,
                u.dx_cz_minus_dx_bt_um,
            ),
            (ResultId::ThDyCz, d.dy_cz_um, u.dy_cz_um),
            // ex_BX itself, with the step's u
            (
                ResultId::ThDzBtSetting,
                t.dz_bt_setting_um,
                id.steps.first().map_or(f64::NAN, |bx| bx.u_e_um[0]),
            ),
        ] {
            // eqs 4.10–4.18 are linear in the eccentricities without a constant term: the
            // LVDT's scale error k moves every result by k times itself, as a shape figure
            r.set_with_bar(id, v as f32, [uu as f32, 0.0], bar, FigureKind::Shape);
        }
    }
}
