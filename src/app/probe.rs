//! PROBE: touch points on a reference sphere (seed 002 chapter 5). Each accepted probe edge
//! of a run adds the encoder positions latched at the edge — with `probe_length` R set, as the
//! nominal stylus-ball centre `axes − R·(sin B, 0, cos B)` (B = 0 when the machine has no B
//! input); at the end of the run the sphere is fitted. Finished spheres are filed by where
//! they were probed (B, C: the mean over the run's touches, within [`SLOT_TOL_DEG`]):
//!
//! - **C axis**: B = 0, C at 0°, 90°, 180° or 270°, the sphere off the C centreline (at R_C).
//!   Once all four are in, the C-axis location and orientation errors are identified (eqs
//!   5.1–5.7, literal-model signs; nominal C centreline = the seed 002 origin X, Y; lever Z_C).
//! - **B axis**: the sphere on the C centreline (within [`CENTRELINE_TOL_MM`] in X, Y) at
//!   B = 0°, or any sphere at B = 90°, each with the run's tool length. Once B = 0° and 90° are
//!   in for two tool lengths (the thesis's R_B and R′_B styli), δx_BT, δz_BT, β_XB and the
//!   observable combinations α_BT + α_XB, α_BT − γ_XB are identified by least squares (eqs
//!   5.8–5.19, corrected mode) with their standard uncertainties. The nominal sphere centre is
//!   the seed 002 origin raised by Z_C (the sphere on the C centreline at the C-axis sphere's
//!   height; the thesis's "standard position", which it does not state: spec seed-002 §6.6).
//!   A third tool length replaces the length probed less recently.
//!
//! Each result's u has two shares: Type A from the sphere fits (and the method's own
//! redundancy), and the probe's lobing (`probe_u_lobing`), moved through the method by
//! [`lobing_share`] from each filed sphere's response to it ([`SphereFit::lobing_um_per_um`]).

use super::results::{ResultId, ResultSink, Results};
use crate::config::{Field, TestSetup, required, required3};
use crate::identify::mill_turn::lobing::{LOBING_COMPONENTS, lobing_share};
use crate::identify::mill_turn::probe::{
    BAxisProbe, CAxisProbe, ProbeError, ProbeMode, SphereFit, SphereFitError, fit_sphere,
    identify_b_axis, identify_c_axis,
};

/// Touch points one PROBE run keeps (a touch beyond is dropped and counted).
pub const MAX_TOUCHES: usize = 32;
/// How close a rotary position must be to its slot (B = 0° or 90°, C = k·90°), degrees.
pub const SLOT_TOL_DEG: f64 = 0.5;
/// A sphere probed at B = 0 this close to the C centreline (X and Y distance, mm) is a B-axis
/// sphere; farther out, a C-axis sphere (the C method needs the sphere at a radius R_C).
pub const CENTRELINE_TOL_MM: f64 = 5.0;

/// A PROBE run in progress.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProbeRun {
    points_mm: [[f64; 3]; MAX_TOUCHES],
    len: usize,
    dropped: u32,
    /// Sums of the B and C positions of the touches (degrees; NaN sums when the axis is not
    /// configured).
    b_sum_deg: f64,
    c_sum_deg: f64,
    /// Tool length R of the run, mm (NaN: the points are the axes as latched).
    length_mm: f64,
}

impl Default for ProbeRun {
    fn default() -> Self {
        Self::new(f64::NAN)
    }
}

impl ProbeRun {
    /// No touch yet; `length_mm` is the tool length R of the run (NaN if not set).
    pub const fn new(length_mm: f64) -> Self {
        Self {
            points_mm: [[0.0; 3]; MAX_TOUCHES],
            len: 0,
            dropped: 0,
            b_sum_deg: 0.0,
            c_sum_deg: 0.0,
            length_mm,
        }
    }

    /// Adds a touch at axis positions X, Y, Z (mm) with the B and C positions (degrees, NaN
    /// if that axis is not configured): the nominal stylus-ball centre if the run has a tool
    /// length.
    pub fn touch(&mut self, xyz_mm: [f64; 3], b_deg: f64, c_deg: f64) {
        let [x, y, z] = xyz_mm;
        let point = if self.length_mm.is_nan() {
            xyz_mm
        } else {
            // the tool points along −Z at B = 0, turned about Y by B (seed 002 eq 2.4)
            let b = if b_deg.is_nan() {
                0.0
            } else {
                b_deg.to_radians()
            };
            let r = self.length_mm;
            let (sin_b, cos_b) = crate::num::sin_cos(b);
            [x - r * sin_b, y, z - r * cos_b]
        };
        match self.points_mm.get_mut(self.len) {
            Some(p) => {
                *p = point;
                self.len += 1;
                self.b_sum_deg += b_deg;
                self.c_sum_deg += c_deg;
            }
            None => self.dropped = self.dropped.saturating_add(1),
        }
    }

    /// The touches so far, mm.
    pub fn points(&self) -> &[[f64; 3]] {
        self.points_mm.get(..self.len).unwrap_or(&[])
    }

    /// Touches dropped because [`MAX_TOUCHES`] were already kept.
    pub const fn dropped(&self) -> u32 {
        self.dropped
    }

    /// Mean (B, C) of the touches, degrees.
    fn rotary_deg(&self) -> (f64, f64) {
        let n = self.len.max(1) as f64;
        (self.b_sum_deg / n, self.c_sum_deg / n)
    }

    /// The fitted sphere.
    #[inline(never)] // flash: 0.2 KB smaller than inlined into the application task
    pub fn finish(&self) -> Result<SphereFit, SphereFitError> {
        fit_sphere(self.points(), self.rotary_deg().0)
    }
}

/// True if `v` is within [`SLOT_TOL_DEG`] of `slot_deg`.
fn at_deg(v: f64, slot_deg: f64) -> bool {
    libm::fabs(v - slot_deg) <= SLOT_TOL_DEG
}

/// The C slot (0…3 for C = 0, 90, 180, 270°) of a sphere probed at (B, C), if B = 0.
fn c_slot(b_deg: f64, c_deg: f64) -> Option<usize> {
    // nearest multiple of 90° (any number of turns), then its quarter
    let k = libm::round(c_deg / 90.0);
    if !(at_deg(b_deg, 0.0) && at_deg(c_deg, k * 90.0) && libm::fabs(k) < 1e6) {
        return None;
    }
    Some((k as i64).rem_euclid(4) as usize)
}

/// Why a touch-probe identification gave no result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ProbeFailure {
    /// The set-up lacks this field.
    Missing(Field),
    /// The C-axis identification failed.
    CAxis(ProbeError),
    /// The B-axis identification failed.
    BAxis(ProbeError),
}

/// A touch-probe method: which axis it identifies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProbeAxis {
    /// The B axis (B = 0°/90°, two tool lengths).
    B,
    /// The C axis (four spheres at C = 0/90/180/270°).
    C,
}

impl ProbeAxis {
    /// The results the method publishes (first and last, in [`ResultId`] order).
    pub const fn results(self) -> (ResultId, ResultId) {
        match self {
            ProbeAxis::B => (ResultId::ProbeDxBt, ResultId::ProbeBResidualRms),
            ProbeAxis::C => (ResultId::ProbeAlphaCz, ResultId::ProbeDyCz),
        }
    }
}

/// A sphere filed for a method.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Filed {
    /// Fitted centre, mm.
    centre_mm: [f64; 3],
    /// Its standard uncertainties (X, Y, Z), µm.
    u_um: [f64; 3],
    /// Its centre's shift per µm of each lobing component ([`SphereFit::lobing_um_per_um`]).
    lobing: [[f32; 3]; LOBING_COMPONENTS],
    /// The fit's residuals |p − c| − R at its touches, in touch order, µm.
    residual_um: [f32; MAX_TOUCHES],
    /// Its touches.
    touches: usize,
}

/// Rescales the Type A u of the spheres in `groups` to the touch scatter their residuals do not
/// share. The spheres of a group are touched along the same directions of the probe (the C
/// spheres; a B position's two styli), so a pre-travel that varies with direction (lobing)
/// leaves the same residuals in each: a fit's own residual counts it as scatter, though it does
/// not vary from sphere to sphere — the lobing's share, which moves the centres alike, is
/// budgeted apart ([`lobing_share`]). The pooled variance of the residuals about their
/// per-touch mean over the group, Σ(r − r̄)² / ((K − 1)(m − 4)), is the touches' scatter alone.
/// The touches are matched by their order (the same part program for every sphere: the
/// directions themselves are not compared). If the spheres of any group differ in their number
/// of touches, or have no more than four, no sphere is rescaled: all are left as fitted.
/// Returns the pooled degrees of freedom (0: left as fitted).
fn pool_type_a(groups: &mut [&mut [Filed]]) -> usize {
    let (mut ss, mut dof) = (0.0f32, 0usize);
    for g in groups.iter() {
        let m = g.first().map_or(0, |f| f.touches);
        if m <= 4 || g.iter().any(|f| f.touches != m) {
            return 0;
        }
        for i in 0..m {
            let r = |f: &Filed| f.residual_um.get(i).copied().unwrap_or(0.0);
            let mean = g.iter().map(r).sum::<f32>() / g.len() as f32;
            ss += g.iter().map(|f| (r(f) - mean) * (r(f) - mean)).sum::<f32>();
        }
        dof += (g.len() - 1) * (m - 4);
    }
    if dof == 0 {
        return 0;
    }
    let pooled = ss / dof as f32;
    for f in groups.iter_mut().flat_map(|g| g.iter_mut()) {
        let own = f.residual_um.iter().map(|r| r * r).sum::<f32>() / (f.touches - 4) as f32;
        if own > 0.0 {
            let k = f64::from(crate::num::sqrtf(pooled / own));
            f.u_um = f.u_um.map(|u| u * k);
        }
    }
    dof
}

/// B = 0° and 90° sphere centres probed with one tool length.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct BSet {
    /// Tool length R, mm (0: the set is empty; a configured length is ≥ 1 mm).
    length_mm: f64,
    /// The spheres at B = 0° and B = 90°.
    centres_mm: [Option<Filed>; 2],
}

/// The spheres of the chapter 5 probe methods.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spheres {
    /// C-axis spheres at C = 0, 90, 180, 270°.
    c_mm: [Option<Filed>; 4],
    /// B-axis centres for two tool lengths.
    b: [BSet; 2],
    /// The B set filed last.
    b_latest: usize,
}

impl From<Field> for ProbeFailure {
    fn from(f: Field) -> Self {
        Self::Missing(f)
    }
}

impl Spheres {
    /// Forgets every sphere.
    pub fn clear(&mut self) {
        *self = Self::default();
    }

    /// Files a finished PROBE run; returns the method that has all its spheres now (its
    /// identification is a job: [`Spheres::identify`]), if one does.
    #[inline(never)] // flash: 0.2 KB smaller than inlined into the application task
    pub fn on_sphere(
        &mut self,
        run: &ProbeRun,
        fit: &SphereFit,
        t: &TestSetup,
    ) -> Result<Option<ProbeAxis>, ProbeFailure> {
        let (b, c) = run.rotary_deg();
        let [x, y, _] = fit.centre_mm;
        let [ox, oy, _] = t.s002_origin_mm.map(f64::from);
        let on_centreline =
            libm::fabs(x - ox) <= CENTRELINE_TOL_MM && libm::fabs(y - oy) <= CENTRELINE_TOL_MM;
        let b_slot = if at_deg(b, 90.0) {
            Some(1)
        } else if at_deg(b, 0.0) && on_centreline {
            Some(0)
        } else {
            None
        };
        let [ux, uy, uz, _] = fit.std_uncertainty_um;
        let mut residual_um = [0.0f32; MAX_TOUCHES];
        let [cx, cy, cz] = fit.centre_mm;
        for (r, [px, py, pz]) in residual_um.iter_mut().zip(run.points()) {
            let (dx, dy, dz) = (px - cx, py - cy, pz - cz);
            *r = ((crate::num::sqrt(dx * dx + dy * dy + dz * dz) - fit.radius_mm) * 1e3) as f32;
        }
        let centre = Filed {
            centre_mm: fit.centre_mm,
            u_um: [ux, uy, uz],
            lobing: fit.lobing_um_per_um,
            residual_um,
            touches: run.points().len(),
        };
        if let Some(slot) = b_slot {
            if run.length_mm.is_nan() {
                return Err(ProbeFailure::Missing(Field::ProbeLengthMm));
            }
            self.file_b(run.length_mm, slot, centre);
            let complete = self
                .b
                .iter()
                .all(|s| s.centres_mm.iter().all(Option::is_some));
            return Ok(complete.then_some(ProbeAxis::B));
        }
        let Some(slot) = c_slot(b, c) else {
            return Ok(None);
        };
        if let Some(s) = self.c_mm.get_mut(slot) {
            *s = Some(centre);
        }
        Ok(self
            .c_mm
            .iter()
            .all(Option::is_some)
            .then_some(ProbeAxis::C))
    }

    /// Identifies `axis` from the spheres filed (a job: the lobing shares refit the method
    /// four ways) into `results`; `Ok(false)` if the method lacks a sphere.
    pub fn identify(
        &self,
        axis: ProbeAxis,
        t: &TestSetup,
        results: &mut impl ResultSink,
    ) -> Result<bool, ProbeFailure> {
        match axis {
            ProbeAxis::B => self.identify_b(t, results),
            ProbeAxis::C => self.identify_c(t, results),
        }
    }

    fn file_b(&mut self, length_mm: f64, slot: usize, centre: Filed) {
        let i = self
            .b
            .iter()
            .position(|s| s.length_mm == length_mm)
            .or_else(|| self.b.iter().position(|s| s.length_mm == 0.0))
            .unwrap_or(1 - self.b_latest.min(1));
        if let Some(set) = self.b.get_mut(i) {
            if set.length_mm != length_mm {
                *set = BSet {
                    length_mm,
                    ..BSet::default()
                };
            }
            if let Some(c) = set.centres_mm.get_mut(slot) {
                *c = Some(centre);
            }
            self.b_latest = i;
        }
    }

    fn identify_c(
        &self,
        t: &TestSetup,
        results: &mut impl ResultSink,
    ) -> Result<bool, ProbeFailure> {
        let [Some(p1), Some(p2), Some(p3), Some(p4)] = self.c_mm else {
            return Ok(false);
        };
        let mut spheres = [p1, p2, p3, p4];
        let dof = pool_type_a(&mut [&mut spheres]);
        // by reference from here: a sphere is 0.3 KB
        let spheres = spheres.each_ref();
        // a fit of exactly four touches states no uncertainty (0): the C method then takes
        // its uncertainties from the diagonals' mismatch alone
        let input = CAxisProbe {
            centres_mm: spheres.map(|p| p.centre_mm),
            centres_std_uncertainty_um: spheres.map(|p| p.u_um),
            nominal_axis_xy_mm: [
                required(t.s002_origin_mm[0], Field::S002OriginMm(0))?,
                required(t.s002_origin_mm[1], Field::S002OriginMm(1))?,
            ],
            z_c_mm: required(t.s002_z_c_mm, Field::S002ZcMm)?,
            std_uncertainty_dof: dof as f64,
        };
        let r = identify_c_axis(&input, ProbeMode::Corrected).map_err(ProbeFailure::CAxis)?;
        let value = [r.alpha_cz_arcsec, r.beta_cz_arcsec, r.dx_cz_um, r.dy_cz_um];
        let lobing = lobing_share(
            &input.centres_mm,
            &spheres.map(|p| p.lobing),
            f64::from(t.probe_u_lobing_um),
            &|c: &[[f64; 3]; 4]| {
                let mut moved = input;
                moved.centres_mm = *c;
                let r = identify_c_axis(&moved, ProbeMode::Corrected).ok()?;
                Some([
                    r.alpha_cz_arcsec,
                    r.beta_cz_arcsec,
                    r.dx_cz_um,
                    r.dy_cz_um,
                    0.0,
                ])
            },
        );
        let ids = [
            ResultId::ProbeAlphaCz,
            ResultId::ProbeBetaCz,
            ResultId::ProbeDxCz,
            ResultId::ProbeDyCz,
        ];
        publish_probe(results, &ids, &value, &r.std_uncertainty, &lobing);
        Ok(true)
    }

    fn identify_b(
        &self,
        t: &TestSetup,
        results: &mut impl ResultSink,
    ) -> Result<bool, ProbeFailure> {
        let [
            BSet {
                length_mm: r1,
                centres_mm: [Some(a0), Some(a90)],
            },
            BSet {
                length_mm: r2,
                centres_mm: [Some(b0), Some(b90)],
            },
        ] = self.b
        else {
            return Ok(false);
        };
        let u_lobing = f64::from(t.probe_u_lobing_um);
        // each B position's two styli touch along the same directions of the probe
        let (mut at_0, mut at_90) = ([a0, b0], [a90, b90]);
        let dof = pool_type_a(&mut [&mut at_0, &mut at_90]);
        let ([a0, b0], [a90, b90]) = (at_0.each_ref(), at_90.each_ref());
        let spheres = [a0, a90, b0, b90];
        let [ox, oy, oz] = required3(t.s002_origin_mm, Field::S002OriginMm)?;
        let nominal = [ox, oy, oz + required(t.s002_z_c_mm, Field::S002ZcMm)?];
        // a fit of exactly four touches states no uncertainty (0): the B method then takes
        // its uncertainties from its own residual alone
        let input = BAxisProbe {
            measured_mm: spheres.map(|p| p.centre_mm),
            nominal_mm: [nominal; 4],
            measured_std_uncertainty_um: spheres.map(|p| p.u_um),
            // NaN where the response is not known (also × 0): the B residual's weighing
            // skips it, as it skips a shift of 0
            lobing_shift_um: spheres.map(|p| p.lobing.map(|c| c.map(|v| f64::from(v) * u_lobing))),
            std_uncertainty_dof: dof as f64,
            r_b_mm: r1,
            r_b2_mm: r2,
            // X_T (paper mode's lever only): the sphere's nominal X
            x_t_mm: nominal[0],
        };
        let r = identify_b_axis(&input, ProbeMode::Corrected).map_err(ProbeFailure::BAxis)?;
        // (β_XB, δx_BT, δz_BT, α_BT + α_XB, α_BT − γ_XB), in the order of the uncertainties
        let outputs = |r: &crate::identify::mill_turn::probe::BAxisResult| {
            let or_nan = |v: Option<f64>| v.unwrap_or(f64::NAN);
            [
                r.beta_xb_arcsec,
                r.dx_bt_um,
                r.dz_bt_um,
                or_nan(r.alpha_bt_plus_alpha_xb_arcsec),
                or_nan(r.alpha_bt_minus_gamma_xb_arcsec),
            ]
        };
        let lobing = lobing_share(
            &input.measured_mm,
            &spheres.map(|p| p.lobing),
            u_lobing,
            &|c: &[[f64; 3]; 4]| {
                let mut moved = input;
                moved.measured_mm = *c;
                Some(outputs(
                    &identify_b_axis(&moved, ProbeMode::Corrected).ok()?,
                ))
            },
        );
        let [u_beta, u_dx, u_dz] = r.std_uncertainty;
        let [u_sum, u_diff] = r.std_uncertainty_y;
        let ids = [
            ResultId::ProbeBetaXb,
            ResultId::ProbeDxBt,
            ResultId::ProbeDzBt,
            ResultId::ProbeAlphaBtPlusAlphaXb,
            ResultId::ProbeAlphaBtMinusGammaXb,
        ];
        let u = [u_beta, u_dx, u_dz, u_sum, u_diff];
        publish_probe(results, &ids, &outputs(&r), &u, &lobing);
        results.set(ResultId::ProbeBResidualRms, r.residual_rms_um, f64::NAN);
        Ok(true)
    }
}

/// Writes a method's results: each value with its Type A u and its lobing share.
fn publish_probe(
    results: &mut impl ResultSink,
    ids: &[ResultId],
    value: &[f64],
    u_a: &[f64],
    lobing: &[f64],
) {
    for (((id, v), a), l) in ids.iter().zip(value).zip(u_a).zip(lobing) {
        results.set_budget(*id, *v, [*a as f32, 0.0, 0.0, 0.0, 0.0, *l as f32, 0.0]);
    }
}

/// Writes a fitted sphere into the results.
pub fn publish(fit: &SphereFit, results: &mut Results) {
    let [ux, uy, uz, ur] = fit.std_uncertainty_um;
    let [x, y, z] = fit.centre_mm;
    results.set(ResultId::SphereX, x, ux * 1e-3);
    results.set(ResultId::SphereY, y, uy * 1e-3);
    results.set(ResultId::SphereZ, z, uz * 1e-3);
    results.set(ResultId::SphereRadius, fit.radius_mm, ur * 1e-3);
    results.set(ResultId::SphereResidualRms, fit.residual_rms_um, f64::NAN);
}
