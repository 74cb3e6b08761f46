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

use super::results::{ResultId, Results};
use crate::config::{Field, TestSetup, required, required3};
use crate::identify::multitasking::probe::{
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
        fit_sphere(self.points())
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

/// B = 0° and 90° sphere centres probed with one tool length.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct BSet {
    /// Tool length R, mm (0: the set is empty; a configured length is ≥ 1 mm).
    length_mm: f64,
    /// Centres at B = 0° and B = 90° (mm) with their standard uncertainties (X, Y, Z, µm).
    centres_mm: [Option<([f64; 3], [f64; 3])>; 2],
}

/// The spheres of the chapter 5 probe methods.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Spheres {
    /// C-axis centres at C = 0, 90, 180, 270° (mm) with their standard uncertainties (µm).
    c_mm: [Option<([f64; 3], [f64; 3])>; 4],
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

    /// Files a finished PROBE run; once a method has all its spheres, identifies its axis
    /// into `results`. Returns whether it did.
    #[inline(never)] // flash: 0.2 KB smaller than inlined into the application task
    pub fn on_sphere(
        &mut self,
        run: &ProbeRun,
        fit: &SphereFit,
        t: &TestSetup,
        results: &mut Results,
    ) -> Result<bool, ProbeFailure> {
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
        let centre = (fit.centre_mm, [ux, uy, uz]);
        if let Some(slot) = b_slot {
            if run.length_mm.is_nan() {
                return Err(ProbeFailure::Missing(Field::ProbeLengthMm));
            }
            self.file_b(run.length_mm, slot, centre);
            return self.identify_b(t, results);
        }
        let Some(slot) = c_slot(b, c) else {
            return Ok(false);
        };
        if let Some(s) = self.c_mm.get_mut(slot) {
            *s = Some(centre);
        }
        self.identify_c(t, results)
    }

    fn file_b(&mut self, length_mm: f64, slot: usize, centre: ([f64; 3], [f64; 3])) {
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

    fn identify_c(&self, t: &TestSetup, results: &mut Results) -> Result<bool, ProbeFailure> {
        let [Some(p1), Some(p2), Some(p3), Some(p4)] = self.c_mm else {
            return Ok(false);
        };
        // a fit of exactly four touches states no uncertainty (0): the C method then takes
        // its uncertainties from the diagonals' mismatch alone
        let input = CAxisProbe {
            centres_mm: [p1.0, p2.0, p3.0, p4.0],
            centres_std_uncertainty_um: [p1.1, p2.1, p3.1, p4.1],
            nominal_axis_xy_mm: [
                required(t.s002_origin_mm[0], Field::S002OriginMm(0))?,
                required(t.s002_origin_mm[1], Field::S002OriginMm(1))?,
            ],
            z_c_mm: required(t.s002_z_c_mm, Field::S002ZcMm)?,
        };
        let r = identify_c_axis(&input, ProbeMode::Corrected).map_err(ProbeFailure::CAxis)?;
        let [u_alpha, u_beta, u_dx, u_dy] = r.std_uncertainty;
        results.set(ResultId::ProbeAlphaCz, r.alpha_cz_arcsec, u_alpha);
        results.set(ResultId::ProbeBetaCz, r.beta_cz_arcsec, u_beta);
        results.set(ResultId::ProbeDxCz, r.dx_cz_um, u_dx);
        results.set(ResultId::ProbeDyCz, r.dy_cz_um, u_dy);
        Ok(true)
    }

    fn identify_b(&self, t: &TestSetup, results: &mut Results) -> Result<bool, ProbeFailure> {
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
        let [ox, oy, oz] = required3(t.s002_origin_mm, Field::S002OriginMm)?;
        let nominal = [ox, oy, oz + required(t.s002_z_c_mm, Field::S002ZcMm)?];
        // a fit of exactly four touches states no uncertainty (0): the B method then takes
        // its uncertainties from its own residual alone
        let input = BAxisProbe {
            measured_mm: [a0.0, a90.0, b0.0, b90.0],
            nominal_mm: [nominal; 4],
            measured_std_uncertainty_um: [a0.1, a90.1, b0.1, b90.1],
            r_b_mm: r1,
            r_b2_mm: r2,
            // X_T (paper mode's lever only): the sphere's nominal X
            x_t_mm: nominal[0],
        };
        let r = identify_b_axis(&input, ProbeMode::Corrected).map_err(ProbeFailure::BAxis)?;
        let [u_beta, u_dx, u_dz] = r.std_uncertainty;
        let [u_sum, u_diff] = r.std_uncertainty_y;
        let or_nan = |v: Option<f64>| v.unwrap_or(f64::NAN);
        results.set(ResultId::ProbeDxBt, r.dx_bt_um, u_dx);
        results.set(ResultId::ProbeDzBt, r.dz_bt_um, u_dz);
        results.set(ResultId::ProbeBetaXb, r.beta_xb_arcsec, u_beta);
        results.set(
            ResultId::ProbeAlphaBtPlusAlphaXb,
            or_nan(r.alpha_bt_plus_alpha_xb_arcsec),
            u_sum,
        );
        results.set(
            ResultId::ProbeAlphaBtMinusGammaXb,
            or_nan(r.alpha_bt_minus_gamma_xb_arcsec),
            u_diff,
        );
        results.set(ResultId::ProbeBResidualRms, r.residual_rms_um, f64::NAN);
        Ok(true)
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
