//! Diagnostics (one weighted least-squares fit per direction on the bin profile about the
//! least-squares circle, f32) of
//! ΔL = r0 + e·n + a₂ cos 2θ + b₂ sin 2θ + Σ_p B_p g_p(θ) + s_u sin 3θ/4 − s_v cos 3θ/4
//!      + a_k cos kθ + b_k sin kθ,
//! θ from +u towards +v (the socket's offset e also bends the profile by its second-order
//! term (|e|² − (e·n)²)/2R, a 2θ term of |e|²/4R that is the set-up's, not the machine's: taken
//! off before the fit, with e from the circle), fitted jointly for each cyclic order
//! k = 4..=`MAX_CYCLIC_ORDER` and the order with the least residual kept (the step shapes carry
//! even harmonics, so a cyclic error fitted after them, from what they leave, leaks into them
//! and into the squareness: an order-6 error of 1.45 µm read as 19 µrad):
//! - out-of-squareness (45° ovality) S = 2 b₂ / R, µrad; S > 0 when the angle between +u and +v
//!   is less than 90° (the error E_u = S·v makes the v axis lean towards +u);
//! - scale mismatch (0°/90° ovality) k_u − k_v = 2 a₂ / R, µm/m; > 0 when u is longer;
//! - reversal steps (backlash, lost motion) B_p at the four reversal points p (u at θ = 0° and
//!   180°, v at 90° and 270°), µm: the axis lags by B/2 behind its direction of travel, B
//!   depending on the end of its travel, E_u = −sign(v_u)·B_{u±}/2 for u ≷ 0, so the trace steps
//!   by B_p at p; g_p is d·cos θ·sign(sin θ)/2 (u) or −d·sin θ·sign(cos θ)/2 (v) on the half of
//!   the circle about p and 0 on the other, d = +1 CCW, −1 CW; an axis's reversal step is the
//!   mean of its two points;
//! - straightness over the test diameter s_u, s_v, µm: the axis's path bows across it
//!   quadratically, E_v = s_u·(u/R)² (s_u > 0: the ends of u's path lie towards +v of its
//!   middle; the end-point reference line of ISO 230-1), E_u = s_v·(v/R)²; radially
//!   s_u cos²θ sin θ = s_u (sin θ + sin 3θ)/4 and s_v sin²θ cos θ = s_v (cos θ − cos 3θ)/4, whose
//!   first-order part moves the circle: straightness is the third-order shape, so the cyclic
//!   search starts at order 4 (a third-order cyclic error and a bow are one shape on a circle);
//! - the radius change r0 (the circle's plus the joint fit's correction), µm: the mean of the
//!   two axes' scale errors times R, with the bar's length error (a partial arc's plain circle
//!   fit takes part of the 2θ and step shapes into its r0; the joint fit does not);
//! - cyclic error: amplitude √(a_k² + b_k²) of the kept order, divided by the bins' averaging
//!   gain sinc(kπ/BINS), **named** only when it is at least `CYCLIC_SIGNIFICANCE` (4)
//!   standard uncertainties.
//!
//! Which of these an arc determines is [`super::support`]'s: a reversal point's column is
//! dropped when the arc barely touches its half of the circle (fewer than
//! [`super::support::REVERSAL_SIDE_DEG`] of bins), the rest stay in the fit on any arc so none
//! leaks into another.
//!
//! Uncertainty (GUM Type A): u_j = s·√((GᵀWG)⁻¹)_jj with the bins' sample counts as weights and
//! s² = RSS / (bins − unknowns) the per-sample variance the residual shows — which also holds
//! what the model leaves out (another cyclic order, a fault of another shape), so u grows with
//! it — and at least the resolution's q²/12 (Type B, `RESOLUTION_UM`). The bar's own
//! uncertainty (length, temperature, LVDT scale) is added where the results are published
//! ([`crate::metrology::bar_budget`]); the centre as entered (Type B) is each figure's and diagnosis's
//! `Diagnosed::centre_um` ([`CircularTest::centre_shares`] says how the centre enters).

use super::centre::MOVES;
use super::support::{ArcSupport, DIAGNOSES, Diagnosis};
use super::{Bin, CircularTest, Direction, IsoError};
use crate::metrology::solve3::cholesky_solve;

/// Highest harmonic order searched for the cyclic error.
pub const MAX_CYCLIC_ORDER: u32 = 16;

/// A figure whose u is not evaluated (NaN).
pub(super) fn not_evaluated(value: f32) -> Diagnosed {
    Diagnosed {
        value,
        std_uncertainty: f32::NAN,
        centre_um: 0.0,
    }
}

/// An ISO 230-4 figure or diagnosis: its value and standard uncertainties, same unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Diagnosed {
    /// The estimate.
    pub value: f32,
    /// Its standard uncertainty from the samples' noise (diagnoses: Type A from the residual
    /// of the joint fit, the resolution's as a floor, the module doc; figures:
    /// [`super::extremes`]).
    pub std_uncertainty: f32,
    /// The standard uncertainty the circle's centre as entered gives it (Type B, for the
    /// `u_centre_um` of the call per in-plane coordinate: the change with the profile moved as
    /// by the centre moved ±u along each axis; [`CircularTest::centre_shares`] says how the
    /// centre enters), beside [`Self::std_uncertainty`], not in it; 0 where none is taken (H).
    pub centre_um: f32,
}

impl Diagnosed {
    /// The mean of two independent estimates (CCW and CW): u = √(u₁² + u₂²)/2; the centre's
    /// share at most (c₁ + c₂)/2 ([`mean_diagnostics`] takes it from the signed changes).
    pub fn mean(&self, other: &Self) -> Self {
        let (a, b) = (self.std_uncertainty, other.std_uncertainty);
        Self {
            value: (self.value + other.value) * 0.5,
            std_uncertainty: crate::num::sqrtf(a * a + b * b) * 0.5,
            centre_um: (self.centre_um + other.centre_um) * 0.5,
        }
    }

    /// |value| / u: how many standard uncertainties the estimate is from zero.
    pub fn significance(&self) -> f32 {
        if self.std_uncertainty > 0.0 {
            self.value.abs() / self.std_uncertainty
        } else {
            f32::INFINITY
        }
    }
}

/// Ball-bar diagnostics of one direction, or the mean of both (see the module doc for models
/// and signs; [`Diagnostics::determined`] for what the arcs support).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Diagnostics {
    /// Each [`Diagnosis`], its discriminant the index ([`Diagnostics::get`]): out-of-squareness
    /// (45° ovality, µrad), scale mismatch k_u − k_v (0°/90° ovality, µm/m), each axis's
    /// reversal step (the mean of its two points, µm), the cyclic amplitude (half
    /// peak-to-peak of the harmonic of order [`Self::cyclic_order`], µm), the step at each
    /// reversal point (µm), each axis's straightness over the test diameter (µm), the joint
    /// fit's radius change r0 (µm).
    pub values: [Diagnosed; DIAGNOSES],
    /// The order (cycles per revolution, 4..=16) whose joint fit explains most of the profile.
    pub cyclic_order: u32,
    /// What the run's coverage (the mean's: both runs') determines.
    pub support: ArcSupport,
    /// Standard uncertainty of one sample's ΔL the uncertainties rest on, µm.
    pub sample_std_um: f32,
    /// RMS of the bin profile after the diagnostic model, µm.
    pub residual_rms_um: f32,
    /// The change of each [`Diagnosis`] (its discriminant the column), in its unit, with the
    /// centre as entered moved by +u, −u along u, then +u, −u along v (u the `u_centre_um` of
    /// [`CircularTest::diagnostics`]): what each `centre_um` is made of, kept signed so that
    /// [`mean_diagnostics`] averages the two directions' changes (a reversal step's edge moves
    /// the two directions' squareness apart).
    pub centre_moves: [[f32; DIAGNOSES]; 4],
}

impl Diagnostics {
    /// Sets [`Self::centre_moves`] and each diagnosis's `centre_um` from them: the root mean
    /// square of the ± moves along each axis, in quadrature.
    pub(super) fn set_centre_moves(&mut self, moves: [[f32; DIAGNOSES]; 4]) {
        self.centre_moves = moves;
        for (k, d) in self.values.iter_mut().enumerate() {
            let s2: f32 = moves.iter().map(|m| m.get(k).map_or(0.0, |v| v * v)).sum();
            d.centre_um = crate::num::sqrtf(0.5 * s2);
        }
    }

    /// The estimate of `which` (determinable or not: [`Self::determined`]).
    pub fn get(&self, which: Diagnosis) -> Diagnosed {
        self.values
            .get(which as usize)
            .copied()
            .unwrap_or(not_evaluated(f32::NAN))
    }

    /// The cyclic error's order if it is named ([`Self::is_named`]: a full circle, amplitude
    /// ≥ [`CYCLIC_SIGNIFICANCE`]·u), else `None`: no cyclic error is named.
    pub fn named_cyclic_order(&self) -> Option<u32> {
        self.is_named(Diagnosis::Cyclic)
            .then_some(self.cyclic_order)
    }
}

/// Columns of the joint diagnostic model (the module doc), in [`NormalEquations`] order.
mod col {
    /// r0, e_u, e_v: the least-squares circle.
    pub const R0: usize = 0;
    /// cos 2θ (scale mismatch), sin 2θ (squareness).
    pub const COS2: usize = 3;
    pub const SIN2: usize = 4;
    /// The reversal points' steps, in angle order (0°, 90°, 180°, 270°).
    pub const STEP: usize = 5;
    /// sin 3θ/4 (straightness of u), −cos 3θ/4 (straightness of v).
    pub const STRAIGHT_U: usize = 9;
    pub const STRAIGHT_V: usize = 10;
    /// cos kθ, sin kθ of the cyclic order.
    pub const CYC_COS: usize = 11;
    pub const CYC_SIN: usize = 12;
}

/// Unknowns of the joint diagnostic model: r0, e_u, e_v, cos 2θ, sin 2θ, the four reversal
/// points' steps, the two straightnesses, and the cyclic order's cos kθ, sin kθ.
pub const DIAGNOSTIC_PARAMETERS: usize = 13;

impl<const BINS: usize> CircularTest<BINS> {
    /// Ball-bar diagnostics of one direction (needs every quadrant covered and more than
    /// [`DIAGNOSTIC_PARAMETERS`] bins): the joint fit of the module doc for each cyclic order
    /// 4..=[`MAX_CYCLIC_ORDER`], the order that explains most of the profile kept; what the
    /// arc determines in [`Diagnostics::support`].
    ///
    /// Each diagnosis with the centre's share for a centre entered with standard uncertainty
    /// `u_centre_um` per in-plane coordinate (`Diagnosed::centre_um`): the fit's response to
    /// every bin moved as by the centre moved ±u along each axis (its samples come from
    /// further along the profile: a reversal step's edge moves against the step shapes, the
    /// limaçon's e·dn is a 2θ term in squareness and scale mismatch; first order).
    pub fn diagnostics(&self, d: Direction, u_centre_um: f32) -> Result<Diagnostics, IsoError> {
        self.diagnostics_about(d, u_centre_um, [0.0; 2])
    }

    /// [`Self::diagnostics`] of the profile less the lateral play `play` = (p_u, p_v), µm,
    /// the two directions found ([`CircularTest::lateral_play`](super::CircularTest::lateral_play)): a shape one direction's model does not
    /// hold (its 4θ, 6θ, … terms would read as a cyclic error and bend the steps).
    fn diagnostics_about(
        &self,
        d: Direction,
        u_centre_um: f32,
        play: [f32; 2],
    ) -> Result<Diagnostics, IsoError> {
        let run = self.run(d);
        run.fit.estimate().map_err(IsoError::Fit)?;
        let support = ArcSupport::of(&run.bins);
        if !support.quadrants {
            return Err(IsoError::NotFullCircle);
        }
        // the profile about the least-squares circle: small numbers, so f32 (the M4F's FPU)
        // keeps ~7 digits of what the model explains
        let x = run.fit.moments().solve_f64().map_err(IsoError::Fit)?;
        // the circle's own response to the centre as entered (its k: the geometry's sign and
        // scale, for the socket's second-order term and the centre's shares below)
        let centre = self.centre_response(d).map_err(IsoError::Fit)?;
        let mut model = Model {
            bins: &run.bins,
            // a constant divisor: no division-by-zero check (a panic path) in the bin loops
            per_q: Self::BINS_PER_QUADRANT,
            x: x.map(|v| v as f32),
            curvature: -0.5 * centre.k,
            dir: match d {
                Direction::Ccw => 1.0,
                Direction::Cw => -1.0,
            },
            order: None,
            steps: [true; 4],
            play,
        };
        model.steps = model.step_support();
        // the order whose joint fit explains most (least residual sum of squares)
        let mut best: Option<(f32, NormalEquations)> = None;
        for k in 4..=MAX_CYCLIC_ORDER {
            let nk = model.with_order(Some(k)).normal_equations(&|_| 0.0);
            if nk.bins <= DIAGNOSTIC_PARAMETERS as u32 {
                return Err(IsoError::IllConditioned);
            }
            if let Some(p) = cholesky_solve(nk.a, nk.b) {
                let explained = dot(&p, &nk.b);
                if best.as_ref().is_none_or(|(e, _)| explained > *e) {
                    best = Some((explained, nk));
                }
            }
        }
        let (_, nk) = best.ok_or(IsoError::IllConditioned)?;
        let joint = nk.fit()?;
        let (c_k, s_k) = (joint.p[col::CYC_COS], joint.p[col::CYC_SIN]);
        let (v_c, v_s) = (joint.var[col::CYC_COS], joint.var[col::CYC_SIN]);
        let amp = crate::num::sqrtf(c_k * c_k + s_k * s_k);
        let v_amp = if amp > 0.0 {
            (c_k * c_k * v_c + 2.0 * c_k * s_k * joint.cov_cs + s_k * s_k * v_s) / (amp * amp)
        } else {
            0.5 * (v_c + v_s)
        };
        // a bin averages cos kθ over its width Δ = 2π/BINS: the profile holds the harmonic
        // times sinc(kΔ/2) (0.9968 for order 16 in 1° bins), undone here
        let half_width = core::f64::consts::PI * f64::from(nk.order) / BINS as f64;
        let gain = (crate::num::sin(half_width) / half_width) as f32;
        let cyclic = estimate(amp, v_amp, 1.0 / gain);
        // Without a significant cyclic error the other diagnoses come from the model without
        // one: the order picked from noise alone is, for an even one, correlated with the step
        // shapes, and the fit conditioned on it understated the reversal steps' u by 15 %.
        // The centre's shares: each fit's change with every bin moved as by the centre moved
        // ±u along each axis (none for u 0; the profile's own r0 and e columns take the circle's move).
        let moved = |order: Option<u32>, p: &[f32; DIAGNOSTIC_PARAMETERS]| {
            let mut dp = [[0.0f32; DIAGNOSTIC_PARAMETERS]; 4];
            if u_centre_um == 0.0 {
                return Ok(dp);
            }
            let m = model.with_order(order);
            for (dp, delta) in dp.iter_mut().zip(MOVES.map(|d| d.map(|c| c * u_centre_um))) {
                let shift = |i| centre.bin_shift(&run.bins, i, delta).0;
                let ne = m.normal_equations(&shift);
                let q = cholesky_solve(ne.a, ne.b).ok_or(IsoError::IllConditioned)?;
                for ((d, q), p) in dp.iter_mut().zip(q).zip(p) {
                    *d = q - p;
                }
            }
            Ok::<_, IsoError>(dp)
        };
        let joint_moved = moved(Some(nk.order), &joint.p)?;
        let (fit, fit_order) = if cyclic.significance() >= CYCLIC_SIGNIFICANCE {
            (joint, Some(nk.order))
        } else {
            (model.normal_equations(&|_| 0.0).fit()?, None)
        };
        let fit_moved = if fit_order.is_some() {
            joint_moved
        } else {
            moved(None, &fit.p)?
        };
        // each parameter's change in each diagnosis's unit, and the cyclic amplitude's (its
        // change along the harmonic)
        let [c_cyc, s_cyc] = if amp > 0.0 {
            [c_k / amp, s_k / amp]
        } else {
            [0.0; 2]
        };
        let to_urad = 2e3 / self.radius_mm;
        let mut centre_moves = [[0.0f32; DIAGNOSES]; 4];
        for ((m, f), j) in centre_moves.iter_mut().zip(fit_moved).zip(joint_moved) {
            let values = diagnoses(
                &f,
                &[0.0; DIAGNOSTIC_PARAMETERS],
                [0.0; 2],
                to_urad,
                &not_evaluated(0.0),
            );
            for (m, v) in m.iter_mut().zip(values) {
                *m = v.value;
            }
            if let Some(c) = m.get_mut(Diagnosis::Cyclic as usize) {
                *c = (c_cyc * j[col::CYC_COS] + s_cyc * j[col::CYC_SIN]) / gain;
            }
        }
        let mut out = Diagnostics {
            values: diagnoses(&fit.p, &fit.var, fit.cov_steps, to_urad, &cyclic),
            cyclic_order: nk.order,
            support,
            sample_std_um: crate::num::sqrtf(fit.s2),
            residual_rms_um: crate::num::sqrtf(fit.rss / nk.weight),
            centre_moves,
        };
        out.set_centre_moves(centre_moves);
        // the joint fit's radius: the circle's r0 plus the fit's correction to it
        if let Some(r) = out.values.get_mut(Diagnosis::Radius as usize) {
            r.value += model.x[0];
        }
        // a point whose column is dropped is not determinable (and reads NaN)
        let finite = Diagnosis::ALL
            .iter()
            .filter(|w| !BOTH_DIRECTIONS_ONLY.contains(w) && support.determinable(**w).is_ok())
            .all(|w| {
                let v = out.get(*w);
                v.value.is_finite() && v.std_uncertainty.is_finite()
            })
            && out.residual_rms_um.is_finite();
        if finite {
            Ok(out)
        } else {
            Err(IsoError::IllConditioned)
        }
    }
}

/// A diagnosis of `value`·`scale` with u √`var`·`scale`, no centre's share yet.
fn estimate(value: f32, var: f32, scale: f32) -> Diagnosed {
    Diagnosed {
        value: value * scale,
        std_uncertainty: crate::num::sqrtf(var) * scale,
        centre_um: 0.0,
    }
}

/// A fit's parameters `p` and variances `var` read as every [`Diagnosis`], in discriminant
/// order (squareness and scale mismatch × `to_urad`), `cyclic` as given; an axis's reversal
/// step the mean of its two points', var = (v₁ + v₂ + 2 cov)/4 with `cov_steps` (the two points
/// correlate through the circle and the other shapes).
fn diagnoses(
    p: &[f32; DIAGNOSTIC_PARAMETERS],
    var: &[f32; DIAGNOSTIC_PARAMETERS],
    cov_steps: [f32; 2],
    to_urad: f32,
    cyclic: &Diagnosed,
) -> [Diagnosed; DIAGNOSES] {
    let at = |c: usize, scale: f32| {
        let (p, v) = (
            p.get(c).copied().unwrap_or(f32::NAN),
            var.get(c).copied().unwrap_or(f32::NAN),
        );
        estimate(p, v, scale)
    };
    let [p0, p1, p2, p3] = [0, 1, 2, 3].map(|k| at(col::STEP + k, 1.0));
    let mean = |a: Diagnosed, b: Diagnosed, cov: f32| {
        let (ua, ub) = (a.std_uncertainty, b.std_uncertainty);
        estimate(
            a.value + b.value,
            (ua * ua + ub * ub + 2.0 * cov).max(0.0),
            0.5,
        )
    };
    let [cov_u, cov_v] = cov_steps;
    [
        at(col::SIN2, to_urad),
        at(col::COS2, to_urad),
        mean(p0, p2, cov_u),
        mean(p1, p3, cov_v),
        *cyclic,
        p0,
        p1,
        p2,
        p3,
        at(col::STRAIGHT_U, 1.0),
        at(col::STRAIGHT_V, 1.0),
        at(col::R0, 1.0),
        // lateral play: only both directions tell it ([`CircularTest::lateral_play`](super::CircularTest::lateral_play),
        // `CircularTest::both_directions`): one direction's is 0 ± ∞
        ONE_DIRECTION_PLAY,
        ONE_DIRECTION_PLAY,
    ]
}

/// What one direction's diagnostics hold for a diagnosis only the two directions together give
/// (lateral play): nothing known, 0 ± ∞.
const ONE_DIRECTION_PLAY: Diagnosed = Diagnosed {
    value: 0.0,
    std_uncertainty: f32::INFINITY,
    centre_um: 0.0,
};

/// The diagnoses only the two directions together give ([`CircularTest::both_directions`]):
/// [`ONE_DIRECTION_PLAY`] in one direction's.
const BOTH_DIRECTIONS_ONLY: [Diagnosis; 2] = [Diagnosis::LateralPlayU, Diagnosis::LateralPlayV];

impl<const BINS: usize> CircularTest<BINS> {
    /// Each direction's diagnostics and their mean ([`mean_diagnostics`]) with what only the
    /// two directions together give: the lateral play of each axis ([`CircularTest::lateral_play`](super::CircularTest::lateral_play)) where
    /// both runs are full circles.
    ///
    /// The play is found first, from the difference of the two runs (on any arc: the
    /// direction-even faults cancel in it), and taken off each direction's profile before its
    /// joint fit; it is reported from a full circle only, where its cusps are orthogonal to
    /// every other direction-odd shape. Its u (a few hundredths of a µm at 0.2 µm of noise) is
    /// not carried into the other diagnoses: what an error of it moves them by is a fraction of
    /// their own u.
    pub fn both_directions(&self, u_centre_um: f32) -> Result<[Diagnostics; 3], IsoError> {
        let play = self.lateral_play();
        let values = play.map_or([0.0; 2], |p| p.map(|d| d.value));
        let ccw = self.diagnostics_about(Direction::Ccw, u_centre_um, values)?;
        let cw = self.diagnostics_about(Direction::Cw, u_centre_um, values)?;
        let mut mean = mean_diagnostics(&ccw, &cw);
        // reported from a full circle only; elsewhere (or no fit) NaN, never the 0 ± ∞ of
        // one direction
        let reported = play.filter(|_| mean.support.full_circle);
        for (k, which) in BOTH_DIRECTIONS_ONLY.iter().enumerate() {
            if let Some(v) = mean.values.get_mut(*which as usize) {
                *v = reported
                    .and_then(|p| p.get(k).copied())
                    .unwrap_or(not_evaluated(f32::NAN));
            }
        }
        Ok([ccw, cw, mean])
    }
}

/// Resolution of the bar's length reading, µm (DESIGN §1, the QC20-W class): its uniform
/// quantisation, u = q/√12 per sample, is the least per-sample uncertainty the diagnostics
/// assume (Type B), so a noise-free profile does not make every harmonic "significant".
pub const RESOLUTION_UM: f32 = 0.1;

/// A cyclic error is named only when its amplitude is at least this many standard
/// uncertainties. On white noise the largest of the 13 orders' amplitudes (Rayleigh-distributed)
/// passes with probability ≈ 13·exp(−4²/2) ≈ 0.4 %.
pub const CYCLIC_SIGNIFICANCE: f32 = 4.0;

/// Whether bin `i` (`per_q` bins a quadrant) lies on the half of the circle about reversal
/// point `p` (0°, 90°, 180°, 270°): quadrants 3, 0 for p 0; 0, 1 for 1; 1, 2 for 2; 2, 3 for 3.
pub(super) fn point_of(i: usize, per_q: usize, p: usize) -> bool {
    let q = i / per_q.max(1);
    q == p || (q + 1) % 4 == p
}

/// The diagnostic model on one direction's bin profile: what [`Model::normal_equations`] sums.
#[derive(Clone, Copy)]
struct Model<'a> {
    bins: &'a [Bin],
    /// Bins per quadrant.
    per_q: usize,
    /// The least-squares circle (r0, e_u, e_v), µm.
    x: [f32; 3],
    /// The socket's offset's second-order term's factor (module doc).
    curvature: f32,
    /// +1 CCW, −1 CW.
    dir: f32,
    /// The cyclic order k (None: no cyclic pair).
    order: Option<u32>,
    /// The reversal points whose step column is fitted (the arc reaches their half of the
    /// circle, [`Model::step_support`]); the others' columns are dropped.
    steps: [bool; 4],
    /// The lateral play (p_u, p_v) taken off the profile, µm.
    play: [f32; 2],
}

impl Model<'_> {
    fn with_order(&self, order: Option<u32>) -> Self {
        Self { order, ..*self }
    }

    /// The reversal points whose half of the circle holds at least
    /// [`super::support::REVERSAL_SIDE_DEG`] of bins (fewer make a column the fit cannot tell
    /// from the circle's).
    fn step_support(&self) -> [bool; 4] {
        let n = self.bins.len().max(1);
        let least = ((super::support::REVERSAL_SIDE_DEG * n as f32 / 360.0) as usize).max(1);
        [0usize, 1, 2, 3].map(|p| {
            self.bins
                .iter()
                .enumerate()
                .filter(|(i, b)| b.n > 0 && point_of(*i, self.per_q, p))
                .count()
                >= least
        })
    }

    /// The weighted normal equations with bin `i` moved by `shift(i)`. f32 throughout (the
    /// profile about the least-squares circle is small numbers; the M4F's FPU; a quarter of
    /// the f64 soft-float code): one pass per order (13 × BINS × 91 multiply-adds) rather
    /// than every order's cross terms kept.
    fn normal_equations(&self, shift: &dyn Fn(usize) -> f32) -> NormalEquations {
        let mut ne = NormalEquations {
            a: [[0.0; DIAGNOSTIC_PARAMETERS]; DIAGNOSTIC_PARAMETERS],
            b: [0.0; DIAGNOSTIC_PARAMETERS],
            yy: 0.0,
            weight: 0.0,
            bins: 0,
            order: self.order.unwrap_or(0),
            unknowns: 0,
            dropped: [false; DIAGNOSTIC_PARAMETERS],
        };
        let x = self.x;
        let dir = self.dir;
        for (i, bin) in self.bins.iter().enumerate() {
            if bin.n == 0 {
                continue;
            }
            let w = bin.n as f32;
            let (dl, nu, nv) = (bin.dl_um / w, bin.nu / w, bin.nv / w);
            let en = x[1] * nu + x[2] * nv;
            let y =
                dl - x[0] - en - (x[1] * x[1] + x[2] * x[2] - en * en) * self.curvature + shift(i);
            let rn = crate::num::sqrtf(nu * nu + nv * nv).max(1e-12);
            let (c1, s1) = (nu / rn, nv / rn);
            // the lateral play's cusps ([`CircularTest::lateral_play`](super::CircularTest::lateral_play)), taken off
            let [p_u, p_v] = self.play;
            let y = y - dir * 0.5 * (p_v * libm::fabsf(c1) - p_u * libm::fabsf(s1));
            // cos kθ, sin kθ by the angle-addition recurrence
            let (mut ck, mut sk) = (1.0f32, 0.0f32);
            for _ in 0..self.order.unwrap_or(0) {
                let t = ck * c1 - sk * s1;
                sk = sk * c1 + ck * s1;
                ck = t;
            }
            let cyc = if self.order.is_some() { 1.0 } else { 0.0 };
            // sign(sin θ), sign(cos θ) are constant within a quadrant's bins
            let q = i / self.per_q.max(1);
            let ssin = if q < 2 { 1.0 } else { -1.0 };
            let scos = if q == 0 || q == 3 { 1.0 } else { -1.0 };
            let g_u = 0.5 * dir * nu * ssin;
            let g_v = -0.5 * dir * nv * scos;
            let step = |p: usize, g: f32| {
                let on = self.steps.get(p).copied().unwrap_or(false);
                if on && point_of(i, self.per_q, p) {
                    g
                } else {
                    0.0
                }
            };
            let (c2, s2) = (c1 * c1 - s1 * s1, 2.0 * c1 * s1);
            let g = [
                1.0,
                nu,
                nv,
                c2,
                s2,
                step(0, g_u),
                step(1, g_v),
                step(2, g_u),
                step(3, g_v),
                // sin 3θ/4, −cos 3θ/4
                0.25 * (s1 * c2 + c1 * s2),
                -0.25 * (c1 * c2 - s1 * s2),
                cyc * ck,
                cyc * sk,
            ];
            // the lower triangle only (all the Cholesky solve reads); by reference: an array's
            // by-value iterator is a call per element at opt-level "z"
            for (r, ((row, bj), gi)) in
                ne.a.iter_mut()
                    .zip(ne.b.iter_mut())
                    .zip(g.iter())
                    .enumerate()
            {
                let wg = w * gi;
                for (x, gj) in row.iter_mut().zip(g.iter()).take(r + 1) {
                    *x += wg * gj;
                }
                *bj += wg * y;
            }
            ne.yy += w * y * y;
            ne.weight += w;
            ne.bins += 1;
        }
        // a dropped column (a reversal point the arc does not reach, the cyclic pair without
        // an order): identity, so its parameter solves to 0 and the rest are untouched
        let mut dropped = [false; DIAGNOSTIC_PARAMETERS];
        for (p, on) in self.steps.iter().enumerate() {
            if let Some(d) = dropped.get_mut(col::STEP + p) {
                *d = !on;
            }
        }
        if self.order.is_none() {
            dropped[col::CYC_COS] = true;
            dropped[col::CYC_SIN] = true;
        }
        for (r, (row, bj)) in ne.a.iter_mut().zip(ne.b.iter_mut()).enumerate() {
            let row_dropped = dropped.get(r).copied().unwrap_or(false);
            for (k, (x, col_dropped)) in row.iter_mut().zip(dropped).enumerate().take(r + 1) {
                if row_dropped || col_dropped {
                    *x = if k == r { 1.0 } else { 0.0 };
                }
            }
            if row_dropped {
                *bj = 0.0;
            }
        }
        ne.unknowns = dropped.iter().filter(|d| !**d).count() as u32;
        ne.dropped = dropped;
        ne
    }
}

/// The weighted normal equations of the diagnostic model with one cyclic order on a bin
/// profile ([`Model::normal_equations`]).
pub(super) struct NormalEquations {
    /// Σ w g gᵀ of the columns, lower triangle (a dropped column: identity).
    a: [[f32; DIAGNOSTIC_PARAMETERS]; DIAGNOSTIC_PARAMETERS],
    /// Σ w g y.
    b: [f32; DIAGNOSTIC_PARAMETERS],
    /// Σ w y².
    yy: f32,
    /// Σ w (samples).
    weight: f32,
    /// Bins with samples.
    bins: u32,
    /// The cyclic order k (0: none).
    order: u32,
    /// Columns fitted (not dropped).
    unknowns: u32,
    /// The dropped columns.
    dropped: [bool; DIAGNOSTIC_PARAMETERS],
}

/// One weighted least-squares fit of the diagnostic model with its uncertainties.
pub(super) struct DiagnosticFit {
    /// The parameters (module doc order; a dropped column's 0).
    p: [f32; DIAGNOSTIC_PARAMETERS],
    /// Their variances (e_u, e_v, not evaluated: 0; a dropped column's NaN).
    var: [f32; DIAGNOSTIC_PARAMETERS],
    /// Covariance of the cyclic pair (cos kθ, sin kθ).
    cov_cs: f32,
    /// Covariance of each axis's two reversal points (u: 0° and 180°, v: 90° and 270°).
    cov_steps: [f32; 2],
    /// Residual sum of squares (weights: sample counts), µm².
    rss: f32,
    /// Per-sample variance the uncertainties rest on, µm².
    s2: f32,
}

impl NormalEquations {
    /// The fit and its uncertainties: u_j = s·√(A⁻¹)_jj, s² = RSS / (bins − unknowns) per
    /// sample (the weights are sample counts; Type A), at least the resolution's q²/12
    /// (Type B).
    pub(super) fn fit(&self) -> Result<DiagnosticFit, IsoError> {
        let p = cholesky_solve(self.a, self.b).ok_or(IsoError::IllConditioned)?;
        let dof = self.bins.saturating_sub(self.unknowns).max(1) as f32;
        let rss = (self.yy - dot(&p, &self.b)).max(0.0);
        let q = RESOLUTION_UM;
        let s2 = (rss / dof).max(q * q / 12.0);
        let mut var = [0.0f32; DIAGNOSTIC_PARAMETERS];
        let mut cov_cs = 0.0;
        let mut cov_steps = [0.0f32; 2];
        for (j, v) in var.iter_mut().enumerate() {
            // e_u, e_v: the circle's, not a diagnosis
            if j == col::R0 + 1 || j == col::R0 + 2 {
                continue;
            }
            if self.dropped.get(j).copied().unwrap_or(true) {
                *v = f32::NAN;
                continue;
            }
            let mut e = [0.0; DIAGNOSTIC_PARAMETERS];
            if let Some(ej) = e.get_mut(j) {
                *ej = 1.0;
            }
            let c = cholesky_solve(self.a, e).ok_or(IsoError::IllConditioned)?;
            *v = s2 * c.get(j).copied().unwrap_or(f32::NAN);
            if j == col::CYC_COS {
                cov_cs = s2 * c.get(col::CYC_SIN).copied().unwrap_or(f32::NAN);
            }
            if let Some(cov) = j.checked_sub(col::STEP).and_then(|k| cov_steps.get_mut(k)) {
                *cov = s2 * c.get(j + 2).copied().unwrap_or(f32::NAN);
            }
        }
        Ok(DiagnosticFit {
            p,
            var,
            cov_cs,
            cov_steps,
            rss,
            s2,
        })
    }
}

pub(super) fn dot(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Mean of the CW and CCW diagnostics (squareness, scale, straightness and cyclic error are
/// common to both directions; the reversal steps are signed per direction in the model, so
/// they average too), each with u = √(u₁² + u₂²)/2 and the centre's share from the mean of the
/// two directions' changes (one centre for both); what both runs support
/// ([`ArcSupport::both`]). The cyclic error is the more significant direction's.
pub fn mean_diagnostics(a: &Diagnostics, b: &Diagnostics) -> Diagnostics {
    let significance = |d: &Diagnostics| d.get(Diagnosis::Cyclic).significance();
    let cyclic = if significance(a) >= significance(b) {
        a
    } else {
        b
    };
    let (sa, sb) = (a.sample_std_um, b.sample_std_um);
    let mut moves = cyclic.centre_moves;
    for ((m, ma), mb) in moves.iter_mut().zip(a.centre_moves).zip(b.centre_moves) {
        for (k, ((v, x), y)) in m.iter_mut().zip(ma).zip(mb).enumerate() {
            if k != Diagnosis::Cyclic as usize {
                *v = (x + y) * 0.5;
            }
        }
    }
    let mut mean = *cyclic;
    for (k, ((m, x), y)) in mean
        .values
        .iter_mut()
        .zip(a.values)
        .zip(b.values)
        .enumerate()
    {
        if k != Diagnosis::Cyclic as usize {
            *m = x.mean(&y);
        }
    }
    mean.support = a.support.both(&b.support);
    mean.sample_std_um = crate::num::sqrtf((sa * sa + sb * sb) * 0.5);
    mean.residual_rms_um = (a.residual_rms_um + b.residual_rms_um) * 0.5;
    mean.set_centre_moves(moves);
    mean
}
