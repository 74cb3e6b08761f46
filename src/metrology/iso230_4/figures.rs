//! The ISO 230-4 figures: G and F of each direction, G(b), H and the mean bi-directional
//! radial deviation, on the bin-averaged profile, each with its bootstrap uncertainty.

use super::centre::CentreResponse;
use super::diagnostics::{Diagnosed, not_evaluated};
use super::{Bin, CW_BIN, CircularTest, Direction, Figures, IsoError};
use crate::metrology::circle_fit::{CircleEstimate, Moments};
use crate::metrology::extremes;

/// The values `figures` computes, observed (no noise added), and their moments over
/// [`extremes::REPLICAS`] replicas with normal noise of standard deviation `sigma(n)` added to
/// each bin of n samples ([`crate::metrology::extremes`]); `Err(observed)` if the noise is not told (σ
/// NaN).
// one copy in flash for both callers (`dyn`), five values each (the bidirectional use four)
pub(super) fn bootstrap(
    figures: Figures,
    sigma: &dyn Fn(u32) -> f32,
) -> Result<([f32; 5], [extremes::Replicas; 5]), [f32; 5]> {
    let observed = figures(&mut |_, _| (0.0, 0.0));
    if sigma(1).is_nan() || sigma(1 | CW_BIN).is_nan() {
        return Err(observed);
    }
    let mut normals = extremes::Normals::default();
    let mut moments = [extremes::Replicas::default(); 5];
    for _ in 0..extremes::REPLICAS {
        let replica = figures(&mut |_, n| (sigma(n) * normals.draw(), 0.0));
        for ((m, v), o) in moments.iter_mut().zip(replica).zip(observed) {
            m.add(v - o);
        }
    }
    Ok((observed, moments))
}

/// Figures of one direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionFigures {
    /// The least-squares (limaçon) circle: centre offset e, radius change r0, uncertainties.
    pub fit: CircleEstimate,
    /// Circular deviation G (2005) = circular error G (2022), µm, with its u (noise only,
    /// [`super::extremes`]; NaN if the profile is too short to tell its noise).
    pub circular_deviation_g_um: Diagnosed,
    /// Radial deviation F_max (2005) = radial error F_max (2022): max of the bin-averaged ΔL
    /// about the socket, µm, with its u as G's.
    pub radial_deviation_f_max_um: Diagnosed,
    /// Radial deviation F_min (2005) = radial error F_min (2022): min of the bin-averaged ΔL
    /// about the socket, µm, with its u as G's.
    pub radial_deviation_f_min_um: Diagnosed,
    /// Standard deviation of one sample's ΔL noise the u rest on, µm (NaN: not told).
    pub sample_std_um: f32,
    /// Bins that received samples.
    pub bins_used: u32,
}

/// Figures that compare or combine both directions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BidirectionalFigures {
    /// Circular hysteresis H (2005 and 2022): max |CW − CCW| at equal angle (bins), µm, with
    /// its u as G's.
    pub circular_hysteresis_h_um: Diagnosed,
    /// Bi-directional circular deviation G(b) (2005) = bi-directional circular error (2022), µm,
    /// with its u as G's.
    pub bidirectional_circular_deviation_um: Diagnosed,
    /// Mean bi-directional radial deviation (2005) = mean bi-directional radial error (2022):
    /// radius change of the circle fitted to both directions, µm, with its u from the
    /// samples' noise (the profiles' third differences, as G's): σ·√((AᵀA)⁻¹₀₀) of the joint
    /// least squares, σ² the directions' noise pooled by their sample counts. The profile's
    /// shape is not noise (it is what is measured), so the fit residual is not its u.
    pub mean_bidirectional_radial_deviation_um: Diagnosed,
    /// Centre offset of the circle fitted to both directions, (u, v) µm.
    pub joint_e_um: [f32; 2],
}

impl<const BINS: usize> CircularTest<BINS> {
    /// Figures of one direction, G and F with the centre's share (`Diagnosed::centre_um`) for a
    /// centre entered with standard uncertainty `u_centre_um` per in-plane coordinate: the
    /// figures again on the profile moved as by the centre moved ±u along each axis (each bin
    /// by `CentreResponse::bin_shift`: its samples from further along the profile, and the
    /// circle G is taken about moved as [`Self::centre_shares`] moves it).
    pub fn direction_figures(
        &self,
        d: Direction,
        u_centre_um: f32,
    ) -> Result<DirectionFigures, IsoError> {
        let run = self.run(d);
        let fit = run.fit.estimate().map_err(IsoError::Fit)?;
        let x = run.fit.moments().solve_f64().map_err(IsoError::Fit)?;
        let used = run.bins.iter().filter(|b| b.n > 0).count() as u32;
        let [x0, x1, x2] = [x[0] as f32, x[1] as f32, x[2] as f32];
        let s = run.noise_um();
        // G and F of the profile with `noise(n)` added to each bin of n samples: F on the same
        // bin-averaged profile as G (single samples' extremes would be the noise's: +4σ at
        // 0.2 µm and 57 000 samples, +0.8 µm), G about the least-squares circle
        let figures = |noise: &mut dyn FnMut(usize, u32) -> (f32, f32)| {
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            let (mut f_lo, mut f_hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for (i, b) in run.bins.iter().enumerate() {
                if let Some((dl, nu, nv)) = b.mean() {
                    let (p, q) = noise(i, b.n);
                    let r = dl - x0 - x1 * nu - x2 * nv + p + q;
                    let dl = dl + p;
                    // comparisons, not f32::min/max (library calls on the M4F)
                    lo = if r < lo { r } else { lo };
                    hi = if r > hi { r } else { hi };
                    f_lo = if dl < f_lo { dl } else { f_lo };
                    f_hi = if dl > f_hi { dl } else { f_hi };
                }
            }
            [hi - lo, hi, lo, f_hi, f_lo]
        };
        let [mut g, mut f_max, mut f_min] =
            match bootstrap(&figures, &|n| s / crate::num::sqrtf(n as f32)) {
                Ok(([g, _, _, f_hi, f_lo], [rg, rhi, rlo, rf_hi, rf_lo])) => [
                    rg.figure(g, &[rhi.excess(), rlo.excess()]),
                    rf_hi.figure(f_hi, &[rf_hi.excess()]),
                    rf_lo.figure(f_lo, &[rf_lo.excess()]),
                ],
                Err([g, _, _, f_hi, f_lo]) => [g, f_hi, f_lo].map(not_evaluated),
            };
        let centre = self.centre_response(d).map_err(IsoError::Fit)?;
        let [g_c, _, _, f_max_c, f_min_c] =
            centre.figure_shares(&figures, [&run.bins, &run.bins], u_centre_um);
        g.centre_um = g_c;
        f_max.centre_um = f_max_c;
        f_min.centre_um = f_min_c;
        Ok(DirectionFigures {
            fit,
            circular_deviation_g_um: g,
            radial_deviation_f_max_um: f_max,
            radial_deviation_f_min_um: f_min,
            sample_std_um: s,
            bins_used: used,
        })
    }

    /// Figures comparing or combining both directions; G(b) and the mean radial deviation with
    /// the centre's shares for a centre entered with standard uncertainty `u_centre_um` per
    /// in-plane coordinate: G(b) as [`Self::direction_figures`] (about the joint circle), the
    /// mean radial deviation by the joint circle's first-order r0 response
    /// ([`Self::centre_shares`]). H takes none: both profiles move alike, and the extremes of
    /// their difference lie on its plateaus.
    pub fn bidirectional_figures(
        &self,
        u_centre_um: f32,
    ) -> Result<BidirectionalFigures, IsoError> {
        let (ccw, cw) = (&self.ccw, &self.cw);
        if ccw.fit.samples() == 0 || cw.fit.samples() == 0 {
            return Err(IsoError::MissingDirection);
        }
        ccw.fit.estimate().map_err(IsoError::Fit)?;
        cw.fit.estimate().map_err(IsoError::Fit)?;
        let joint: Moments = ccw.fit.moments().merged(&cw.fit.moments());
        let x = joint.solve_f64().map_err(IsoError::Fit)?;
        let (sa, sb) = (ccw.noise_um(), cw.noise_um());
        let [x0, x1, x2] = [x[0] as f32, x[1] as f32, x[2] as f32];
        // G(b): both profiles about the joint circle; H: bin by bin |CW − CCW| about it
        let figures = |noise: &mut dyn FnMut(usize, u32) -> (f32, f32)| {
            let (mut lo, mut hi, mut h) = (f32::INFINITY, f32::NEG_INFINITY, 0.0f32);
            // the noise of a bin of the CCW profile: n > 0; of the CW: the high bit marks it
            let mut residual = |i: usize, b: &Bin, cw: u32| {
                b.mean().map(|(dl, nu, nv)| {
                    let (p, q) = noise(i, b.n | cw);
                    dl - x0 - x1 * nu - x2 * nv + p + q
                })
            };
            for (i, (a, b)) in ccw.bins.iter().zip(cw.bins.iter()).enumerate() {
                let ra = residual(i, a, 0);
                let rb = residual(i, b, CW_BIN);
                for r in [ra, rb].into_iter().flatten() {
                    lo = if r < lo { r } else { lo };
                    hi = if r > hi { r } else { hi };
                }
                if let (Some(ra), Some(rb)) = (ra, rb) {
                    let d = (ra - rb).abs();
                    h = if d > h { d } else { h };
                }
            }
            [hi - lo, hi, lo, h, 0.0]
        };
        let sigma = |n: u32| {
            let s = if n & CW_BIN != 0 { sb } else { sa };
            s / crate::num::sqrtf((n & !CW_BIN) as f32)
        };
        let [mut g_b, h] = match bootstrap(&figures, &sigma) {
            Ok(([g, _, _, h, _], [rg, rhi, rlo, rh, _])) => [
                rg.figure(g, &[rhi.excess(), rlo.excess()]),
                rh.figure(h, &[rh.excess()]),
            ],
            Err([g, _, _, h, _]) => [g, h].map(not_evaluated),
        };
        let centre = CentreResponse::of(
            &joint,
            &[&ccw.bins, &cw.bins],
            ccw.fit.config().geometry.sensitivity,
            self.radius_mm,
        )
        .map_err(IsoError::Fit)?;
        // H takes none: both profiles move alike, and the extremes of their difference lie on
        // its plateaus (the bins' exchange there is noise the bootstrap's u holds already)
        [g_b.centre_um, ..] = centre.figure_shares(&figures, [&ccw.bins, &cw.bins], u_centre_um);
        let [[r0_u, ..], [r0_v, ..]] = centre.per_um;
        let (na, nb) = (ccw.fit.samples() as f32, cw.fit.samples() as f32);
        let pooled = (na * sa * sa + nb * sb * sb) / (na + nb);
        let a00 = joint
            .normal_matrix()
            .cholesky()
            .map_or(f64::NAN, |c| c.inverse().a00) as f32;
        Ok(BidirectionalFigures {
            circular_hysteresis_h_um: h,
            bidirectional_circular_deviation_um: g_b,
            mean_bidirectional_radial_deviation_um: Diagnosed {
                value: x0,
                std_uncertainty: crate::num::sqrtf(pooled * a00),
                centre_um: u_centre_um * crate::num::sqrtf(r0_u * r0_u + r0_v * r0_v),
            },
            joint_e_um: [x[1] as f32, x[2] as f32],
        })
    }
}
