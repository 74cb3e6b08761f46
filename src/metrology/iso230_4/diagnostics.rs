//! Diagnostics (one weighted least-squares fit per direction on the bin profile about the
//! least-squares circle, f32) of
//! ΔL = r0 + e·n + a₂ cos 2θ + b₂ sin 2θ + B_u g_u(θ) + B_v g_v(θ) + a_k cos kθ + b_k sin kθ,
//! θ from +u towards +v (the socket's offset e also bends the profile by its second-order
//! term (|e|² − (e·n)²)/2R, a 2θ term of |e|²/4R that is the set-up's, not the machine's: taken
//! off before the fit, with e from the circle), fitted jointly for each cyclic order
//! k = 3..=`MAX_CYCLIC_ORDER` and the order with the least residual kept (the step shapes g_u, g_v carry even harmonics, so a
//! cyclic error fitted after them, from what they leave, leaks into them and into the
//! squareness: an order-6 error of 1.45 µm read as 19 µrad):
//! - out-of-squareness (45° ovality) S = 2 b₂ / R, µrad; S > 0 when the angle between +u and +v
//!   is less than 90° (the error E_u = S·v makes the v axis lean towards +u);
//! - scale mismatch (0°/90° ovality) k_u − k_v = 2 a₂ / R, µm/m; > 0 when u is longer;
//! - reversal steps (backlash, lost motion) B_u, B_v, µm: the axis lags by B/2 behind its
//!   direction of travel, E_u = −sign(v_u)·B_u/2, so the trace steps by B at the crossings
//!   where u reverses (θ = 0°, 180°); g_u = d·cos θ·sign(sin θ)/2,
//!   g_v = −d·sin θ·sign(cos θ)/2, d = +1 CCW, −1 CW;
//! - cyclic error: amplitude √(a_k² + b_k²) of the kept order, divided by the bins' averaging
//!   gain sinc(kπ/BINS), **named** only when it is at least `CYCLIC_SIGNIFICANCE` (4)
//!   standard uncertainties.
//!
//! Uncertainty (GUM Type A): u_j = s·√((GᵀWG)⁻¹)_jj with the bins' sample counts as weights and
//! s² = RSS / (bins − 9) the per-sample variance the residual shows — which also holds what the
//! model leaves out (another cyclic order, a fault of another shape), so u grows with it — and at
//! least the resolution's q²/12 (Type B, `RESOLUTION_UM`). The bar's own uncertainty (length,
//! temperature, LVDT scale) is added where the results are published ([`super::bar_budget`]);
//! the centre as entered (Type B) is each figure's and diagnosis's `Diagnosed::centre_um`
//! ([`CircularTest::centre_shares`] says how the centre enters).

use super::centre::MOVES;
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

/// Ball-bar diagnostics of one direction (see the module doc for models and signs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Diagnostics {
    /// Out-of-squareness of u and v (45° ovality), µrad.
    pub squareness_urad: Diagnosed,
    /// Scale mismatch k_u − k_v (0°/90° ovality), µm/m.
    pub scale_mismatch_um_per_m: Diagnosed,
    /// Reversal step (backlash) of u at its reversals (θ = 0°, 180°), µm.
    pub reversal_step_u_um: Diagnosed,
    /// Reversal step (backlash) of v at its reversals (θ = 90°, 270°), µm.
    pub reversal_step_v_um: Diagnosed,
    /// Amplitude (half peak-to-peak) of the harmonic of order [`Self::cyclic_order`] fitted
    /// jointly with the rest, µm.
    pub cyclic_amplitude_um: Diagnosed,
    /// The order (cycles per revolution, 3..=16) whose joint fit explains most of the profile.
    pub cyclic_order: u32,
    /// Standard uncertainty of one sample's ΔL the uncertainties rest on, µm.
    pub sample_std_um: f32,
    /// RMS of the bin profile after the diagnostic model, µm.
    pub residual_rms_um: f32,
    /// The change of (squareness, scale mismatch, reversal u, reversal v, cyclic amplitude),
    /// in their units, with the centre as entered moved by +u, −u along u, then +u, −u along v
    /// (u the `u_centre_um` of [`CircularTest::diagnostics`]): what each `centre_um` is made
    /// of, kept signed so that [`mean_diagnostics`] averages the two directions' changes
    /// (a reversal step's edge moves the two directions' squareness apart).
    pub centre_moves: [[f32; 5]; 4],
}

impl Diagnostics {
    /// Sets [`Self::centre_moves`] and each diagnosis's `centre_um` from them: the root mean
    /// square of the ± moves along each axis, in quadrature.
    pub(super) fn set_centre_moves(&mut self, moves: [[f32; 5]; 4]) {
        self.centre_moves = moves;
        for (k, d) in [
            &mut self.squareness_urad,
            &mut self.scale_mismatch_um_per_m,
            &mut self.reversal_step_u_um,
            &mut self.reversal_step_v_um,
            &mut self.cyclic_amplitude_um,
        ]
        .into_iter()
        .enumerate()
        {
            let s2: f32 = moves.iter().map(|m| m.get(k).map_or(0.0, |v| v * v)).sum();
            d.centre_um = crate::num::sqrtf(0.5 * s2);
        }
    }

    /// The cyclic error's order if it is significant (amplitude ≥ [`CYCLIC_SIGNIFICANCE`]·u),
    /// else `None`: no cyclic error is named.
    pub fn named_cyclic_order(&self) -> Option<u32> {
        (self.cyclic_amplitude_um.significance() >= CYCLIC_SIGNIFICANCE)
            .then_some(self.cyclic_order)
    }
}

impl<const BINS: usize> CircularTest<BINS> {
    /// Ball-bar diagnostics of one direction (needs every quadrant covered and more than
    /// [`DIAGNOSTIC_PARAMETERS`] bins): the joint fit of the module doc for each cyclic order
    /// 3..=[`MAX_CYCLIC_ORDER`], the order that explains most of the profile kept.
    ///
    /// Each diagnosis with the centre's share for a centre entered with standard uncertainty
    /// `u_centre_um` per in-plane coordinate (`Diagnosed::centre_um`): the fit's response to
    /// every bin moved as by the centre moved ±u along each axis (its samples come from
    /// further along the profile: a reversal step's edge moves against the step shapes, the
    /// limaçon's e·dn is a 2θ term in squareness and scale mismatch; first order).
    pub fn diagnostics(&self, d: Direction, u_centre_um: f32) -> Result<Diagnostics, IsoError> {
        let run = self.run(d);
        run.fit.estimate().map_err(IsoError::Fit)?;
        // a constant divisor: no division-by-zero check (a panic path) in the bin loops
        let per_q = Self::BINS_PER_QUADRANT;
        let mut covered = [false; 4];
        for (i, b) in run.bins.iter().enumerate() {
            if b.n > 0
                && let Some(c) = covered.get_mut(i / per_q)
            {
                *c = true;
            }
        }
        if !covered.iter().all(|c| *c) {
            return Err(IsoError::NotFullCircle);
        }
        // the profile about the least-squares circle: small numbers, so f32 (the M4F's FPU)
        // keeps ~7 digits of what the model explains
        let x = run.fit.moments().solve_f64().map_err(IsoError::Fit)?;
        let x = x.map(|v| v as f32);
        let dir = match d {
            Direction::Ccw => 1.0,
            Direction::Cw => -1.0,
        };
        // the circle's own response to the centre as entered (its k: the geometry's sign and
        // scale, for the socket's second-order term and the centre's shares below)
        let centre = self.centre_response(d).map_err(IsoError::Fit)?;
        let curvature = -0.5 * centre.k;
        let ne = |k| normal_equations(&run.bins, per_q, x, curvature, dir, k, &|_| 0.0);
        // the order whose joint fit explains most (least residual sum of squares)
        let mut best: Option<(f32, NormalEquations)> = None;
        for k in 3..=MAX_CYCLIC_ORDER {
            let nk = ne(Some(k));
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
        let [.., c_k, s_k] = joint.p;
        let [.., v_c, v_s] = joint.var;
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
        let est = |v: f32, var: f32, scale: f32| Diagnosed {
            value: v * scale,
            std_uncertainty: crate::num::sqrtf(var) * scale,
            centre_um: 0.0,
        };
        let cyclic = est(amp, v_amp, 1.0 / gain);
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
            for (dp, delta) in dp.iter_mut().zip(MOVES.map(|d| d.map(|c| c * u_centre_um))) {
                let shift = |i| centre.bin_shift(&run.bins, i, delta).0;
                let m = normal_equations(&run.bins, per_q, x, curvature, dir, order, &shift);
                let q = cholesky_solve(m.a, m.b).ok_or(IsoError::IllConditioned)?;
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
            (ne(None).fit()?, None)
        };
        let fit_moved = if fit_order.is_some() {
            joint_moved
        } else {
            moved(None, &fit.p)?
        };
        // each parameter's share, and the cyclic amplitude's (its change along the harmonic)
        let [c_cyc, s_cyc] = if amp > 0.0 {
            [c_k / amp, s_k / amp]
        } else {
            [0.0; 2]
        };
        let to_urad = 2e3 / self.radius_mm;
        let mut centre_moves = [[0.0f32; 5]; 4];
        for ((m, f), j) in centre_moves.iter_mut().zip(fit_moved).zip(joint_moved) {
            let [_, _, _, d_cos2, d_sin2, d_bu, d_bv, ..] = f;
            let [.., d_c, d_s] = j;
            *m = [
                d_sin2 * to_urad,
                d_cos2 * to_urad,
                d_bu,
                d_bv,
                (c_cyc * d_c + s_cyc * d_s) / gain,
            ];
        }
        let [_, _, _, p_cos2, p_sin2, b_u, b_v, ..] = fit.p;
        let [_, _, _, v_cos2, v_sin2, v_bu, v_bv, ..] = fit.var;
        let mut out = Diagnostics {
            squareness_urad: est(p_sin2, v_sin2, to_urad),
            scale_mismatch_um_per_m: est(p_cos2, v_cos2, to_urad),
            reversal_step_u_um: est(b_u, v_bu, 1.0),
            reversal_step_v_um: est(b_v, v_bv, 1.0),
            cyclic_amplitude_um: cyclic,
            cyclic_order: nk.order,
            sample_std_um: crate::num::sqrtf(fit.s2),
            residual_rms_um: crate::num::sqrtf(fit.rss / nk.weight),
            centre_moves,
        };
        out.set_centre_moves(centre_moves);
        let finite = [
            out.squareness_urad,
            out.scale_mismatch_um_per_m,
            out.reversal_step_u_um,
            out.reversal_step_v_um,
            out.cyclic_amplitude_um,
        ]
        .iter()
        .all(|v| v.value.is_finite() && v.std_uncertainty.is_finite())
            && out.residual_rms_um.is_finite();
        if finite {
            Ok(out)
        } else {
            Err(IsoError::IllConditioned)
        }
    }
}

/// Unknowns of the joint diagnostic model: r0, e_u, e_v, cos 2θ, sin 2θ, B_u, B_v, and the
/// cyclic order's cos kθ, sin kθ.
pub const DIAGNOSTIC_PARAMETERS: usize = 9;

/// Resolution of the bar's length reading, µm (DESIGN §1, the QC20-W class): its uniform
/// quantisation, u = q/√12 per sample, is the least per-sample uncertainty the diagnostics
/// assume (Type B), so a noise-free profile does not make every harmonic "significant".
pub const RESOLUTION_UM: f32 = 0.1;

/// A cyclic error is named only when its amplitude is at least this many standard
/// uncertainties. On white noise the largest of the 14 orders' amplitudes (Rayleigh-distributed)
/// passes with probability ≈ 14·exp(−4²/2) ≈ 0.5 %.
pub const CYCLIC_SIGNIFICANCE: f32 = 4.0;

/// The weighted normal equations of the diagnostic model with one cyclic order on a bin
/// profile. f32 throughout (the profile about the least-squares circle is small numbers; the
/// M4F's FPU; a quarter of the f64 soft-float code): one pass per order
/// (15 × BINS × 81 multiply-adds) rather than every order's cross terms kept.
pub(super) struct NormalEquations {
    /// Σ w g gᵀ of the nine columns, lower triangle (without an order: the cyclic pair
    /// decoupled, identity).
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
}

/// One weighted least-squares fit of the diagnostic model with its uncertainties.
pub(super) struct DiagnosticFit {
    /// The parameters (module doc order; the cyclic pair 0 without a cyclic order).
    p: [f32; DIAGNOSTIC_PARAMETERS],
    /// Their variances (the first three, the circle's, not evaluated: 0).
    var: [f32; DIAGNOSTIC_PARAMETERS],
    /// Covariance of the cyclic pair (cos kθ, sin kθ).
    cov_cs: f32,
    /// Residual sum of squares (weights: sample counts), µm².
    rss: f32,
    /// Per-sample variance the uncertainties rest on, µm².
    s2: f32,
}

/// The normal equations of `bins` (y: the bin mean about the circle `x` = (r0, e) less the
/// socket's offset's second-order term `curvature`·(|e|² − (e·n)²), plus `shift(i)` for bin i)
/// with cyclic order `k`, `dir` +1 CCW, −1 CW. The step shapes g_u, g_v are those of the module doc (their signs
/// constant per quadrant).
pub(super) fn normal_equations(
    bins: &[Bin],
    per_q: usize,
    x: [f32; 3],
    curvature: f32,
    dir: f32,
    k: Option<u32>,
    shift: &dyn Fn(usize) -> f32,
) -> NormalEquations {
    let mut ne = NormalEquations {
        a: [[0.0; DIAGNOSTIC_PARAMETERS]; DIAGNOSTIC_PARAMETERS],
        b: [0.0; DIAGNOSTIC_PARAMETERS],
        yy: 0.0,
        weight: 0.0,
        bins: 0,
        order: k.unwrap_or(0),
    };
    for (i, bin) in bins.iter().enumerate() {
        if bin.n == 0 {
            continue;
        }
        let w = bin.n as f32;
        let (dl, nu, nv) = (bin.dl_um / w, bin.nu / w, bin.nv / w);
        let en = x[1] * nu + x[2] * nv;
        let y = dl - x[0] - en - (x[1] * x[1] + x[2] * x[2] - en * en) * curvature + shift(i);
        let rn = crate::num::sqrtf(nu * nu + nv * nv).max(1e-12);
        let (c1, s1) = (nu / rn, nv / rn);
        // cos kθ, sin kθ by the angle-addition recurrence
        let (mut ck, mut sk) = (1.0f32, 0.0f32);
        for _ in 0..k.unwrap_or(0) {
            let t = ck * c1 - sk * s1;
            sk = sk * c1 + ck * s1;
            ck = t;
        }
        let cyc = if k.is_some() { 1.0 } else { 0.0 };
        // sign(sin θ), sign(cos θ) are constant within a quadrant's bins
        let q = i / per_q.max(1);
        let ssin = if q < 2 { 1.0 } else { -1.0 };
        let scos = if q == 0 || q == 3 { 1.0 } else { -1.0 };
        let g = [
            1.0,
            nu,
            nv,
            c1 * c1 - s1 * s1,
            2.0 * c1 * s1,
            0.5 * dir * nu * ssin,
            -0.5 * dir * nv * scos,
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
    if k.is_none() {
        let [.., r7, r8] = &mut ne.a;
        r7[7] = 1.0;
        r8[8] = 1.0;
    }
    ne
}

impl NormalEquations {
    /// The fit and its uncertainties: u_j = s·√(A⁻¹)_jj, s² = RSS / (bins − unknowns) per
    /// sample (the weights are sample counts; Type A), at least the resolution's q²/12
    /// (Type B).
    pub(super) fn fit(&self) -> Result<DiagnosticFit, IsoError> {
        let p = cholesky_solve(self.a, self.b).ok_or(IsoError::IllConditioned)?;
        let unknowns = if self.order > 0 { 9 } else { 7 };
        let dof = self.bins.saturating_sub(unknowns).max(1) as f32;
        let rss = (self.yy - dot(&p, &self.b)).max(0.0);
        let q = RESOLUTION_UM;
        let s2 = (rss / dof).max(q * q / 12.0);
        let mut var = [0.0f32; DIAGNOSTIC_PARAMETERS];
        let mut cov_cs = 0.0;
        for (j, v) in var.iter_mut().enumerate().skip(3) {
            let mut e = [0.0; DIAGNOSTIC_PARAMETERS];
            if let Some(ej) = e.get_mut(j) {
                *ej = 1.0;
            }
            let c = cholesky_solve(self.a, e).ok_or(IsoError::IllConditioned)?;
            *v = s2 * c.get(j).copied().unwrap_or(f32::NAN);
            if j == 7 {
                cov_cs = s2 * c.get(8).copied().unwrap_or(f32::NAN);
            }
        }
        Ok(DiagnosticFit {
            p,
            var,
            cov_cs,
            rss,
            s2,
        })
    }
}

pub(super) fn dot(a: &[f32], b: &[f32]) -> f32 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Mean of the CW and CCW diagnostics (squareness, scale and cyclic error are common to both
/// directions; the reversal steps are signed per direction in the model, so they average too),
/// each with u = √(u₁² + u₂²)/2 and the centre's share from the mean of the two directions'
/// changes (one centre for both). The cyclic error is the more significant direction's.
pub fn mean_diagnostics(a: &Diagnostics, b: &Diagnostics) -> Diagnostics {
    let cyclic = if a.cyclic_amplitude_um.significance() >= b.cyclic_amplitude_um.significance() {
        a
    } else {
        b
    };
    let (sa, sb) = (a.sample_std_um, b.sample_std_um);
    let mut moves = cyclic.centre_moves;
    for ((m, ma), mb) in moves.iter_mut().zip(a.centre_moves).zip(b.centre_moves) {
        for ((v, x), y) in m.iter_mut().zip(ma).zip(mb).take(4) {
            *v = (x + y) * 0.5;
        }
    }
    let mut mean = Diagnostics {
        squareness_urad: a.squareness_urad.mean(&b.squareness_urad),
        scale_mismatch_um_per_m: a.scale_mismatch_um_per_m.mean(&b.scale_mismatch_um_per_m),
        reversal_step_u_um: a.reversal_step_u_um.mean(&b.reversal_step_u_um),
        reversal_step_v_um: a.reversal_step_v_um.mean(&b.reversal_step_v_um),
        cyclic_amplitude_um: cyclic.cyclic_amplitude_um,
        cyclic_order: cyclic.cyclic_order,
        sample_std_um: crate::num::sqrtf((sa * sa + sb * sb) * 0.5),
        residual_rms_um: (a.residual_rms_um + b.residual_rms_um) * 0.5,
        centre_moves: moves,
    };
    mean.set_centre_moves(moves);
    mean
}
