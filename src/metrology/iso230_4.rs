//! ISO 230-4 circular test figures and ball-bar diagnostics for a circle about the socket.
//!
//! Names (ISO 230-4:2005 → ISO 230-4:2022, which calls the measured quantities "errors"):
//! - circular deviation G → circular error G: max − min radial deviation from the
//!   least-squares circle, per direction;
//! - radial deviation F (F_max, F_min) → radial error F: deviation of the actual path from the
//!   nominal radius about the nominal centre (the socket), per direction;
//! - bi-directional circular deviation G(b) → bi-directional circular error G(b): max − min of
//!   both directions from one least-squares circle fitted to both;
//! - mean bi-directional radial deviation → mean bi-directional radial error: the radius change
//!   of that joint circle;
//! - circular hysteresis H (both editions): max radial difference CW − CCW at equal angle.
//!
//! Per sample: the running limaçon fit of the direction ([`CircleFit`]), the F extremes, and the
//! sample's angular bin (`BINS` equal bins from +u, aligned with the quadrants; per bin the
//! sums of ΔL and n). Profile figures (G, G(b), H) and diagnostics are evaluated on the
//! bin-averaged profile: intra-bin extremes narrower than 360°/`BINS` are averaged, which is a
//! low-pass filter of that width. The least-squares centre subtracted is the exact one of the
//! running fit (the bin mean of e·n is e·(mean n), exactly).
//!
//! Diagnostics (one weighted least-squares fit per direction, f64, on the bin profile) of
//! ΔL = r0 + e·n + a₂ cos 2θ + b₂ sin 2θ + B_u g_u(θ) + B_v g_v(θ), θ from +u towards +v:
//! - out-of-squareness (45° ovality) S = 2 b₂ / R, µrad; S > 0 when the angle between +u and +v
//!   is less than 90° (the error E_u = S·v makes the v axis lean towards +u);
//! - scale mismatch (0°/90° ovality) k_u − k_v = 2 a₂ / R, µm/m; > 0 when u is longer;
//! - reversal steps (backlash, lost motion) B_u, B_v, µm: the axis lags by B/2 behind its
//!   direction of travel, E_u = −sign(v_u)·B_u/2, so the trace steps by B at the crossings
//!   where u reverses (θ = 0°, 180°); g_u = d·cos θ·sign(sin θ)/2,
//!   g_v = −d·sin θ·sign(cos θ)/2, d = +1 CCW, −1 CW;
//! - cyclic error: the largest harmonic (orders 3..=`MAX_CYCLIC_ORDER`) of the residual profile.

use super::angle::quadrant_angle;
use super::circle_fit::{CircleEstimate, CircleFit, CircleFitConfig, CircleFitError, Moments};
use super::solve3::cholesky_solve;
use crate::acquisition::Sample;

/// Highest harmonic order searched for the cyclic error.
pub const MAX_CYCLIC_ORDER: u32 = 16;

pub use super::pattern::Direction;

/// Why ISO 230-4 figures are not available.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum IsoError {
    /// The least-squares circle of a direction is not available (too few samples, short arc).
    Fit(CircleFitError),
    /// A bi-directional figure needs both directions.
    MissingDirection,
    /// The diagnostics need bins all around the circle (every quadrant covered).
    NotFullCircle,
    /// The harmonic fit is singular.
    IllConditioned,
}

#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Bin {
    dl_um: f32,
    nu: f32,
    nv: f32,
    n: u32,
}

impl Bin {
    fn mean(&self) -> Option<(f64, f64, f64)> {
        if self.n == 0 {
            return None;
        }
        let k = 1.0 / f64::from(self.n);
        Some((
            f64::from(self.dl_um) * k,
            f64::from(self.nu) * k,
            f64::from(self.nv) * k,
        ))
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Run<const BINS: usize> {
    fit: CircleFit,
    bins: [Bin; BINS],
    f_max_um: f32,
    f_min_um: f32,
}

/// Figures of one direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionFigures {
    /// The least-squares (limaçon) circle: centre offset e, radius change r0, uncertainties.
    pub fit: CircleEstimate,
    /// Circular deviation G (2005) = circular error G (2022), µm.
    pub circular_deviation_g_um: f32,
    /// Radial deviation F_max (2005) = radial error F_max (2022): max ΔL about the socket, µm.
    pub radial_deviation_f_max_um: f32,
    /// Radial deviation F_min (2005) = radial error F_min (2022): min ΔL about the socket, µm.
    pub radial_deviation_f_min_um: f32,
    /// Bins that received samples.
    pub bins_used: u32,
}

/// Figures that compare or combine both directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BidirectionalFigures {
    /// Circular hysteresis H (2005 and 2022): max |CW − CCW| at equal angle (bins), µm.
    pub circular_hysteresis_h_um: f32,
    /// Bi-directional circular deviation G(b) (2005) = bi-directional circular error (2022), µm.
    pub bidirectional_circular_deviation_um: f32,
    /// Mean bi-directional radial deviation (2005) = mean bi-directional radial error (2022):
    /// radius change of the circle fitted to both directions, µm.
    pub mean_bidirectional_radial_deviation_um: f32,
    /// Centre offset of the circle fitted to both directions, (u, v) µm.
    pub joint_e_um: [f32; 2],
}

/// Ball-bar diagnostics of one direction (see the module doc for models and signs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Diagnostics {
    /// Out-of-squareness of u and v (45° ovality), µrad.
    pub squareness_urad: f32,
    /// Scale mismatch k_u − k_v (0°/90° ovality), µm/m.
    pub scale_mismatch_um_per_m: f32,
    /// Reversal step (backlash) of u at its reversals (θ = 0°, 180°), µm.
    pub reversal_step_u_um: f32,
    /// Reversal step (backlash) of v at its reversals (θ = 90°, 270°), µm.
    pub reversal_step_v_um: f32,
    /// Amplitude (half peak-to-peak) of the largest residual harmonic of order 3..=16, µm.
    pub cyclic_amplitude_um: f32,
    /// Its order (cycles per revolution).
    pub cyclic_order: u32,
    /// RMS of the bin profile after the diagnostic model, µm.
    pub residual_rms_um: f32,
}

/// An ISO 230-4 circular test about the socket (both directions), `BINS` angular bins
/// (a multiple of 4, at most 4096). State: 32·BINS + 268 bytes (11 788 B for 360 bins).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircularTest<const BINS: usize> {
    radius_mm: f32,
    runs: [Run<BINS>; 2],
}

impl<const BINS: usize> CircularTest<BINS> {
    /// Angle bins per quadrant (at least 1).
    const BINS_PER_QUADRANT: usize = if BINS >= 4 { BINS / 4 } else { 1 };

    const CHECK: () = assert!(
        BINS.is_multiple_of(4) && BINS >= 8 && BINS <= 4096,
        "BINS: multiple of 4"
    );

    /// A new test; `config.geometry` is the circle about the socket, `radius_mm` its nominal
    /// radius (the bar length, for the diagnostics' angular units).
    pub fn new(config: CircleFitConfig, radius_mm: f32) -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::CHECK;
        let run = Run {
            fit: CircleFit::new(config),
            bins: [Bin::default(); BINS],
            f_max_um: f32::NEG_INFINITY,
            f_min_um: f32::INFINITY,
        };
        Self {
            radius_mm,
            runs: [run, run],
        }
    }

    /// Forgets the samples of direction `d` (a new run of that direction replaces the old one:
    /// runs are not merged); the other direction is kept.
    pub fn reset_direction(&mut self, d: Direction) {
        let [ccw, cw] = &mut self.runs;
        let run = match d {
            Direction::Ccw => ccw,
            Direction::Cw => cw,
        };
        *run = Run {
            fit: CircleFit::new(*run.fit.config()),
            bins: [Bin::default(); BINS],
            f_max_um: f32::NEG_INFINITY,
            f_min_um: f32::INFINITY,
        };
    }

    /// The nominal radius the test was built with, mm.
    pub fn radius_mm(&self) -> f32 {
        self.radius_mm
    }

    fn run(&self, d: Direction) -> &Run<BINS> {
        let [ccw, cw] = &self.runs;
        match d {
            Direction::Ccw => ccw,
            Direction::Cw => cw,
        }
    }

    /// The running fit of one direction.
    pub fn fit(&self, d: Direction) -> &CircleFit {
        &self.run(d).fit
    }

    /// Feeds one sample of the run in direction `d` (O(1): the fit update, a polynomial atan
    /// for the bin, 3 adds).
    pub fn update(&mut self, sample: &Sample, d: Direction) -> super::circle_fit::SampleUse {
        let [ccw, cw] = &mut self.runs;
        let run = match d {
            Direction::Ccw => ccw,
            Direction::Cw => cw,
        };
        let [nu, nv] = match run.fit.update_direction(sample) {
            Ok(n) => n,
            Err(skipped) => return skipped,
        };
        let dl = sample.delta_l_um;
        // comparisons, not f32::min/max (library calls on the M4F)
        if dl > run.f_max_um {
            run.f_max_um = dl;
        }
        if dl < run.f_min_um {
            run.f_min_um = dl;
        }
        let (q, a) = quadrant_angle(nu, nv);
        // a constant divisor: no division-by-zero check (a panic path) in the bin loops
        let per_q = Self::BINS_PER_QUADRANT;
        let k = ((a * (per_q as f32 / core::f32::consts::FRAC_PI_2)) as usize).min(per_q - 1);
        if let Some(bin) = run.bins.get_mut(usize::from(q) * per_q + k) {
            bin.dl_um += dl;
            bin.nu += nu;
            bin.nv += nv;
            bin.n = bin.n.saturating_add(1);
        }
        super::circle_fit::SampleUse::Used
    }

    /// Figures of one direction.
    pub fn direction_figures(&self, d: Direction) -> Result<DirectionFigures, IsoError> {
        let run = self.run(d);
        let fit = run.fit.estimate().map_err(IsoError::Fit)?;
        let x = run.fit.moments().solve_f64().map_err(IsoError::Fit)?;
        let (mut lo, mut hi, mut used) = (f64::INFINITY, f64::NEG_INFINITY, 0u32);
        for (r, _) in residuals(&run.bins, x) {
            lo = lo.min(r);
            hi = hi.max(r);
            used += 1;
        }
        Ok(DirectionFigures {
            fit,
            circular_deviation_g_um: (hi - lo) as f32,
            radial_deviation_f_max_um: run.f_max_um,
            radial_deviation_f_min_um: run.f_min_um,
            bins_used: used,
        })
    }

    /// Figures comparing or combining both directions.
    pub fn bidirectional_figures(&self) -> Result<BidirectionalFigures, IsoError> {
        let [ccw, cw] = &self.runs;
        if ccw.fit.samples() == 0 || cw.fit.samples() == 0 {
            return Err(IsoError::MissingDirection);
        }
        ccw.fit.estimate().map_err(IsoError::Fit)?;
        cw.fit.estimate().map_err(IsoError::Fit)?;
        let joint: Moments = ccw.fit.moments().merged(&cw.fit.moments());
        let x = joint.solve_f64().map_err(IsoError::Fit)?;
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for run in [ccw, cw] {
            for (r, _) in residuals(&run.bins, x) {
                lo = lo.min(r);
                hi = hi.max(r);
            }
        }
        let mut h: f64 = 0.0;
        for (a, b) in ccw.bins.iter().zip(cw.bins.iter()) {
            if let (Some((la, ua, va)), Some((lb, ub, vb))) = (a.mean(), b.mean()) {
                let ra = la - x[1] * ua - x[2] * va;
                let rb = lb - x[1] * ub - x[2] * vb;
                h = h.max((ra - rb).abs());
            }
        }
        Ok(BidirectionalFigures {
            circular_hysteresis_h_um: h as f32,
            bidirectional_circular_deviation_um: (hi - lo) as f32,
            mean_bidirectional_radial_deviation_um: x[0] as f32,
            joint_e_um: [x[1] as f32, x[2] as f32],
        })
    }

    /// Ball-bar diagnostics of one direction (needs every quadrant covered).
    pub fn diagnostics(&self, d: Direction) -> Result<Diagnostics, IsoError> {
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
        let dir = match d {
            Direction::Ccw => 1.0,
            Direction::Cw => -1.0,
        };
        // weighted least squares on the bin means, 7 unknowns
        let mut a = [[0.0f64; 7]; 7];
        let mut rhs = [0.0f64; 7];
        let basis = |i: usize, nu: f64, nv: f64| -> [f64; 7] {
            let q = i / Self::BINS_PER_QUADRANT;
            let r = crate::num::sqrt(nu * nu + nv * nv).max(1e-12);
            let (c, s) = (nu / r, nv / r);
            // sign(sin θ), sign(cos θ) are constant within a quadrant's bins
            let ssin = if q < 2 { 1.0 } else { -1.0 };
            let scos = if q == 0 || q == 3 { 1.0 } else { -1.0 };
            [
                1.0,
                nu,
                nv,
                c * c - s * s,
                2.0 * c * s,
                0.5 * dir * nu * ssin,
                -0.5 * dir * nv * scos,
            ]
        };
        for (i, b) in run.bins.iter().enumerate() {
            if let Some((dl, nu, nv)) = b.mean() {
                let w = f64::from(b.n);
                let g = basis(i, nu, nv);
                for (row, gi) in a.iter_mut().zip(g) {
                    for (x, gj) in row.iter_mut().zip(g) {
                        *x += gi * gj * w;
                    }
                }
                for (r, gi) in rhs.iter_mut().zip(g) {
                    *r += gi * dl * w;
                }
            }
        }
        // [r0, e_u, e_v, cos 2θ, sin 2θ, reversal u, reversal v]
        let p = cholesky_solve(a, rhs).ok_or(IsoError::IllConditioned)?;
        let dot = |g: [f64; 7]| g.iter().zip(p).map(|(x, y)| x * y).sum::<f64>();
        // residual profile and its harmonics
        let (mut ss, mut wsum) = (0.0, 0.0);
        let mut best = (0.0f64, 0u32);
        let mut harm = [[0.0f64; 2]; MAX_CYCLIC_ORDER as usize + 1];
        for (i, b) in run.bins.iter().enumerate() {
            if let Some((dl, nu, nv)) = b.mean() {
                let w = f64::from(b.n);
                let g = basis(i, nu, nv);
                let r = dl - dot(g);
                ss += w * r * r;
                wsum += w;
                let rn = crate::num::sqrt(nu * nu + nv * nv).max(1e-12);
                let (c1, s1) = (nu / rn, nv / rn);
                let (mut ck, mut sk) = (1.0, 0.0);
                for h in harm.iter_mut() {
                    let [hc, hs] = h;
                    *hc += w * r * ck;
                    *hs += w * r * sk;
                    let t = ck * c1 - sk * s1;
                    sk = sk * c1 + ck * s1;
                    ck = t;
                }
            }
        }
        for (k, [hc, hs]) in harm.iter().enumerate().skip(3) {
            let amp = 2.0 * crate::num::sqrt(hc * hc + hs * hs) / wsum;
            if amp > best.0 {
                best = (amp, k as u32);
            }
        }
        let r = f64::from(self.radius_mm);
        let out = Diagnostics {
            squareness_urad: (2.0 * p[4] / r * 1e3) as f32,
            scale_mismatch_um_per_m: (2.0 * p[3] / r * 1e3) as f32,
            reversal_step_u_um: p[5] as f32,
            reversal_step_v_um: p[6] as f32,
            cyclic_amplitude_um: best.0 as f32,
            cyclic_order: best.1,
            residual_rms_um: crate::num::sqrt(ss / wsum.max(1.0)) as f32,
        };
        let finite = [
            out.squareness_urad,
            out.scale_mismatch_um_per_m,
            out.reversal_step_u_um,
            out.reversal_step_v_um,
            out.cyclic_amplitude_um,
            out.residual_rms_um,
        ]
        .iter()
        .all(|v| v.is_finite());
        if finite {
            Ok(out)
        } else {
            Err(IsoError::IllConditioned)
        }
    }
}

/// Residuals of the bin means against the circle x = (r0, e_u, e_v), with the bin index.
fn residuals(bins: &[Bin], x: [f64; 3]) -> impl Iterator<Item = (f64, usize)> + '_ {
    bins.iter().enumerate().filter_map(move |(i, b)| {
        b.mean()
            .map(|(dl, nu, nv)| (dl - x[0] - x[1] * nu - x[2] * nv, i))
    })
}

/// Mean of the CW and CCW diagnostics (squareness, scale and cyclic error are common to both
/// directions; the reversal steps are signed per direction in the model, so they average too).
pub fn mean_diagnostics(a: &Diagnostics, b: &Diagnostics) -> Diagnostics {
    let m = |x: f32, y: f32| (x + y) * 0.5;
    Diagnostics {
        squareness_urad: m(a.squareness_urad, b.squareness_urad),
        scale_mismatch_um_per_m: m(a.scale_mismatch_um_per_m, b.scale_mismatch_um_per_m),
        reversal_step_u_um: m(a.reversal_step_u_um, b.reversal_step_u_um),
        reversal_step_v_um: m(a.reversal_step_v_um, b.reversal_step_v_um),
        cyclic_amplitude_um: a.cyclic_amplitude_um.max(b.cyclic_amplitude_um),
        cyclic_order: if a.cyclic_amplitude_um >= b.cyclic_amplitude_um {
            a.cyclic_order
        } else {
            b.cyclic_order
        },
        residual_rms_um: m(a.residual_rms_um, b.residual_rms_um),
    }
}
