//! PROBE: touch points on a reference sphere (seed 002 chapter 5). Each accepted probe edge
//! of a run adds the encoder positions latched at the edge; at the end of the run the sphere
//! is fitted. A run whose touches were made with B = 0 and C at 0°, 90°, 180° or 270° fills
//! that C slot, and once all four are in, the C axis location and orientation errors are
//! identified (eqs 5.1–5.7, literal-model signs; nominal C centreline = the seed 002 origin
//! X, Y; lever = Z_C).

use super::results::{ResultId, Results};
use crate::config::{Field, TestSetup, is_set};
use crate::identify::multitasking::probe::{
    CAxisProbe, ProbeError, ProbeMode, SphereFit, SphereFitError, fit_sphere, identify_c_axis,
};

/// Touch points one PROBE run keeps (a touch beyond is dropped and counted).
pub const MAX_TOUCHES: usize = 32;
/// How close a rotary position must be to its slot (B = 0°, C = k·90°), degrees.
pub const SLOT_TOL_DEG: f64 = 0.5;

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
}

impl Default for ProbeRun {
    fn default() -> Self {
        Self::new()
    }
}

impl ProbeRun {
    /// No touch yet.
    pub const fn new() -> Self {
        Self {
            points_mm: [[0.0; 3]; MAX_TOUCHES],
            len: 0,
            dropped: 0,
            b_sum_deg: 0.0,
            c_sum_deg: 0.0,
        }
    }

    /// Adds a touch at X, Y, Z (mm) with the B and C positions (degrees, NaN if that axis is
    /// not configured).
    pub fn touch(&mut self, xyz_mm: [f64; 3], b_deg: f64, c_deg: f64) {
        match self.points_mm.get_mut(self.len) {
            Some(p) => {
                *p = xyz_mm;
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
    pub fn finish(&self) -> Result<SphereFit, SphereFitError> {
        fit_sphere(self.points())
    }
}

/// The C slot (0…3 for C = 0, 90, 180, 270°) of a sphere probed at (B, C), if B = 0.
fn c_slot(b_deg: f64, c_deg: f64) -> Option<usize> {
    if !(libm::fabs(b_deg) <= SLOT_TOL_DEG) {
        return None;
    }
    // nearest multiple of 90° (any number of turns), then its quarter
    let k = libm::round(c_deg / 90.0);
    if !(libm::fabs(c_deg - k * 90.0) <= SLOT_TOL_DEG && libm::fabs(k) < 1e6) {
        return None;
    }
    Some((k as i64).rem_euclid(4) as usize)
}

/// Why the touch-probe C-axis identification gave no result.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CAxisFailure {
    /// The set-up lacks this field.
    Missing(Field),
    /// The identification failed.
    Identify(ProbeError),
}

/// The spheres of the C-axis probe method.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CAxisSpheres {
    centres_mm: [Option<[f64; 3]>; 4],
}

impl CAxisSpheres {
    /// Forgets every sphere.
    pub fn clear(&mut self) {
        *self = Self::default();
    }

    /// Number of C slots filled.
    pub fn filled(&self) -> usize {
        self.centres_mm.iter().flatten().count()
    }

    /// Files a finished PROBE run; once all four slots are filled, identifies the C axis into
    /// `results`. Returns whether it did.
    pub fn on_sphere(
        &mut self,
        run: &ProbeRun,
        fit: &SphereFit,
        t: &TestSetup,
        results: &mut Results,
    ) -> Result<bool, CAxisFailure> {
        let (b, c) = run.rotary_deg();
        let Some(slot) = c_slot(b, c) else {
            return Ok(false);
        };
        if let Some(s) = self.centres_mm.get_mut(slot) {
            *s = Some(fit.centre_mm);
        }
        let [Some(p1), Some(p2), Some(p3), Some(p4)] = self.centres_mm else {
            return Ok(false);
        };
        let need = |v: f32, f| {
            if is_set(v) {
                Ok(f64::from(v))
            } else {
                Err(CAxisFailure::Missing(f))
            }
        };
        let input = CAxisProbe {
            centres_mm: [p1, p2, p3, p4],
            nominal_axis_xy_mm: [
                need(t.s002_origin_mm[0], Field::S002OriginMm(0))?,
                need(t.s002_origin_mm[1], Field::S002OriginMm(1))?,
            ],
            z_c_mm: need(t.s002_z_c_mm, Field::S002ZcMm)?,
        };
        let r = identify_c_axis(&input, ProbeMode::Corrected).map_err(CAxisFailure::Identify)?;
        // the probe method states no uncertainty yet: NaN = not evaluated
        results.set(ResultId::ProbeAlphaCz, r.alpha_cz_arcsec, f64::NAN);
        results.set(ResultId::ProbeBetaCz, r.beta_cz_arcsec, f64::NAN);
        results.set(ResultId::ProbeDxCz, r.dx_cz_um, f64::NAN);
        results.set(ResultId::ProbeDyCz, r.dy_cz_um, f64::NAN);
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
