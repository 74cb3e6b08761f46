//! The centre as entered against the one the part program circles about: its first-order
//! shares in e, r0, every figure and diagnosis ([`CircularTest::centre_shares`]), and the
//! centre the axis positions traced ([`TracedCentre`]).

use super::{Bin, CW_BIN, CircularTest, Direction, Figures};
use crate::metrology::circle_fit::{CircleFitError, Moments};
use crate::metrology::pattern::Sensitivity;

/// A least-squares circle's (r0, e_u, e_v) over some bins and their first-order response to
/// the centre as entered ([`CircularTest::centre_shares`]).
pub(super) struct CentreResponse {
    /// The fit (r0, e_u, e_v), µm.
    pub(super) x: [f32; 3],
    /// ∂(r0, e_u, e_v)/∂δ for the centre moved along u (`[0]`) and along v (`[1]`), µm/µm.
    pub(super) per_um: [[f32; 3]; 2],
    /// −s/R per µm: the turn of a direction n by a centre moved 1 µm across it.
    pub(super) k: f32,
}

impl CentreResponse {
    /// The moments `m` of the profiles `bins` (one direction's, or both for the joint circle)
    /// of a test of sensitivity `s` on radius `radius_mm`: the fit and its response,
    /// dx = (AᵀA)⁻¹ Σ [(0, dn) r − (1, n)(dn·e)] over the bins (module doc of
    /// [`CircularTest::centre_shares`]).
    pub(super) fn of(
        m: &Moments,
        bins: &[&[Bin]],
        s: Sensitivity,
        radius_mm: f32,
    ) -> Result<Self, CircleFitError> {
        let chol = m
            .normal_matrix()
            .cholesky()
            .map_err(|_| CircleFitError::IllConditioned)?;
        // the fit (r0 relative to the moments' reference, added back below)
        let [x0, x1, x2] = chol.solve([m.y, m.y_u, m.y_v]);
        let s = s.sign();
        let mut c = CentreResponse {
            x: [x0 + m.y_ref_um, x1, x2].map(|v| v as f32),
            per_um: [[0.0; 3]; 2],
            k: -s / (radius_mm * 1e3),
        };
        // Σ over the bins, per δ direction (u, v): the right-hand side of dx
        let mut g = [[0.0f32; 3]; 2];
        for b in bins.iter().flat_map(|b| b.iter()) {
            let Some((dl, nu, nv)) = b.mean() else {
                continue;
            };
            let w = b.n as f32;
            let [r0, eu, ev] = c.x;
            let r = dl - (r0 + eu * nu + ev * nv);
            for (g, delta) in g.iter_mut().zip([[1.0, 0.0], [0.0, 1.0]]) {
                let [dnu, dnv] = c.turn(delta, nu, nv);
                let de = dnu * eu + dnv * ev;
                g[0] -= w * de;
                g[1] += w * (dnu * r - nu * de);
                g[2] += w * (dnv * r - nv * de);
            }
        }
        for (p, g) in c.per_um.iter_mut().zip(g) {
            *p = chol.solve(g.map(f64::from)).map(|v| v as f32);
        }
        Ok(c)
    }

    /// The turn dn = k (δ − (δ·n) n) of the direction n = (n_u, n_v) with the centre as entered
    /// moved by δ (µm).
    pub(super) fn turn(&self, [du, dv]: [f32; 2], nu: f32, nv: f32) -> [f32; 2] {
        let along = du * nu + dv * nv;
        [self.k * (du - along * nu), self.k * (dv - along * nv)]
    }

    /// The change of bin `i` of the profile `bins` with the centre as entered moved by δ (µm):
    /// (its mean ΔL, its residual about the circle besides). Each sample's direction turns by
    /// dn = k (δ − (δ·n) n), so the bin at angle θ holds the samples from dθ = n × dn further
    /// back along the profile: it gives up that fraction f = dθ/Δ of its width (Δ the bin's)
    /// and takes as much of its neighbour's, f·(ΔL_neighbour − ΔL) (the profile closed around
    /// the circle; none beyond an arc's end) — a reversal step's edge as much as the limaçon's
    /// e·dn; never past the neighbour's value, so an extreme does not overshoot (a secant at δ;
    /// f at most 1: a centre moved more than a bin's angle, R·Δ — 2.6 mm at R 150 mm, 0.87 mm
    /// at R 50 mm — moves it by one bin only). The circle fitted to the bins moves by dx
    /// ([`CircularTest::centre_shares`]), the residual by −(dr0 + de·n) more.
    pub(super) fn bin_shift(&self, bins: &[Bin], i: usize, delta: [f32; 2]) -> (f32, f32) {
        let Some((dl, nu, nv)) = bins.get(i).and_then(Bin::mean) else {
            return (0.0, 0.0);
        };
        let [du, dv] = delta;
        let [dnu, dnv] = self.turn(delta, nu, nv);
        let turn = nu * dnv - nv * dnu;
        let f = turn * bins.len() as f32 * (1.0 / core::f32::consts::TAU);
        // the samples come from before the bin (f > 0) or after it
        let last = bins.len().saturating_sub(1);
        let j = match (f > 0.0, i) {
            (true, 0) => last,
            (true, _) => i - 1,
            (false, i) if i == last => 0,
            (false, _) => i + 1,
        };
        let from = bins.get(j).and_then(Bin::mean).map_or(dl, |m| m.0);
        let [[a0, a1, a2], [b0, b1, b2]] = self.per_um;
        let fit = (a0 * du + b0 * dv) + (a1 * du + b1 * dv) * nu + (a2 * du + b2 * dv) * nv;
        // at most the whole neighbour (comparisons: NaN goes through, and no library call)
        let share = f.abs();
        let share = if share > 1.0 { 1.0 } else { share };
        (share * (from - dl), -fit)
    }

    /// The centre's shares in the values `figures` computes of the profiles `bins` (the CW
    /// profile's, when the figures mark bins with [`CW_BIN`], second), `u_centre_um` per
    /// coordinate: each value's change with every bin moved as by the centre moved ±u along u
    /// and along v ([`Self::bin_shift`]), the root mean square of each pair, in quadrature.
    pub(super) fn figure_shares(
        &self,
        figures: Figures,
        bins: [&[Bin]; 2],
        u_centre_um: f32,
    ) -> [f32; 5] {
        if u_centre_um == 0.0 {
            return [0.0; 5];
        }
        let observed = figures(&mut |_, _| (0.0, 0.0));
        let mut s2 = [0.0f32; 5];
        for delta in MOVES.map(|d| d.map(|c| c * u_centre_um)) {
            let moved = figures(&mut |i, n| {
                let [ccw, cw] = bins;
                self.bin_shift(if n & CW_BIN != 0 { cw } else { ccw }, i, delta)
            });
            for ((s2, m), o) in s2.iter_mut().zip(moved).zip(observed) {
                *s2 += (m - o) * (m - o);
            }
        }
        s2.map(|v| crate::num::sqrtf(0.5 * v))
    }
}

/// The centre's moves a share is taken over (unit vectors, ±u and ±v): the response is a
/// secant, not symmetric where it moves a step's edge.
pub(super) const MOVES: [[f32; 2]; 4] = [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]];

/// A bin's mean traced radius less the second-order term of the offset `x` (µm; `inv_2r`
/// 1/2R per µm), its mean n and its samples ([`CircularTest::traced_centre`]); `None` if empty.
pub(super) fn traced_bin(
    b: &Bin,
    [_, x1, x2]: [f32; 3],
    inv_2r: f32,
) -> Option<(f32, f32, f32, f32)> {
    let (_, nu, nv) = b.mean()?;
    let along = x1 * nu + x2 * nv;
    let q = (x1 * x1 + x2 * x2 - along * along) * inv_2r;
    Some((b.traced_um / b.n as f32 + q, nu, nv, b.n as f32))
}

/// One pass of [`CircularTest::traced_centre`] with the second-order term of `x` taken off:
/// the fit (ρ₀, δ_u, δ_v) by the bins' normal matrix `chol`, the bins' sum of squared
/// residuals and their number.
#[inline(never)] // one copy for both passes
pub(super) fn traced_pass(
    bins: &[Bin],
    chol: &crate::metrology::solve3::Chol3,
    x: [f32; 3],
    inv_2r: f32,
) -> ([f32; 3], f32, u32) {
    let mut g = [0.0f32; 3];
    for (t, nu, nv, w) in bins.iter().filter_map(|b| traced_bin(b, x, inv_2r)) {
        let [g0, g1, g2] = &mut g;
        *g0 += w * t;
        *g1 += w * t * nu;
        *g2 += w * t * nv;
    }
    let x = chol.solve(g.map(f64::from)).map(|v| v as f32);
    let [x0, x1, x2] = x;
    let (mut ss, mut n) = (0.0f32, 0u32);
    for (t, nu, nv, _) in bins.iter().filter_map(|b| traced_bin(b, x, inv_2r)) {
        let r = t - (x0 + x1 * nu + x2 * nv);
        ss += r * r;
        n += 1;
    }
    (x, ss, n)
}

/// The centre of the circle a run's axis positions traced, against the centre as entered
/// ([`CircularTest::traced_centre`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TracedCentre {
    /// The traced centre less the centre as entered, per in-plane coordinate (u, v), µm.
    pub offset_um: [f32; 2],
    /// Its standard uncertainty per coordinate, µm (NaN with fewer than 4 bins).
    pub u_um: [f32; 2],
}

impl TracedCentre {
    /// The standard uncertainty per in-plane coordinate of the centre as entered for the
    /// figures' centre shares, µm: `u_entered_um` (`circle_u_centre`), unless the traced
    /// offset contradicts it — a coordinate beyond 3·√(u_entered² + u²) — then that offset
    /// (the larger coordinate's): the data's word over the budget. The figures stay binned
    /// about the centre as entered (a bin's samples cannot be moved back afterwards), so the
    /// offset is not corrected; it is reported for the set-up to be put right.
    pub fn centre_u_um(&self, u_entered_um: f32) -> f32 {
        let mut u = u_entered_um;
        for (o, ut) in self.offset_um.into_iter().zip(self.u_um) {
            let o = o.abs();
            let allowed = 3.0 * crate::num::sqrtf(u_entered_um * u_entered_um + ut * ut);
            // comparisons: false for NaN
            if o > allowed && o > u {
                u = o;
            }
        }
        u
    }
}

impl<const BINS: usize> CircularTest<BINS> {
    /// The centre's shares of the limaçon fit of direction `d`, (r0, e_u, e_v) in µm, for a
    /// centre entered with standard uncertainty `u_centre_um` in each in-plane coordinate
    /// against the centre the path circles about: first order (GUM §5.1.2, analytic),
    /// u_centre·|∂x/∂(δ_u, δ_v)|.
    ///
    /// The pod takes from the centre as entered only each sample's direction n about it
    /// ([`crate::metrology::pattern::ArcGeometry::direction`]). Entered δ off, n moves by
    /// dn = −s (δ − (δ·n) n) / R (s the pattern's sign, R the radius), so the rows (1, n) of
    /// the least squares move by (0, dn), and x = (r0, e) by
    /// dx = (AᵀA)⁻¹ Σ [(0, dn) r − (1, n)(dn·e)], r each sample's residual. The sums run over
    /// the 1° bins (each bin's mean ΔL, mean n and count): the profile's shape (its ovality:
    /// squareness, scale mismatch) gives e its share, e itself gives r0 one (δ·e / 2R on a full
    /// circle). The coordinate across the plane does not turn n (second order). `Err` where
    /// the fit is not available.
    ///
    /// The profile's figures and the diagnoses take their shares where they are computed
    /// ([`Self::direction_figures`], [`Self::bidirectional_figures`], [`Self::diagnostics`]):
    /// with n turned, each bin holds samples from further along the profile as well
    /// (`CentreResponse::bin_shift`).
    pub fn centre_shares(
        &self,
        d: Direction,
        u_centre_um: f32,
    ) -> Result<[f32; 3], CircleFitError> {
        let c = self.centre_response(d)?;
        let [a, b] = c.per_um;
        let mut out = [0.0; 3];
        for ((o, a), b) in out.iter_mut().zip(a).zip(b) {
            *o = u_centre_um * crate::num::sqrtf(a * a + b * b);
        }
        Ok(out)
    }

    /// Where the encoders put the centre of the circle direction `d` traced, against the centre
    /// as entered: the axis positions follow the part program's circle (the machine's
    /// geometric errors are between them and the tool, where the bar sees them), so the first
    /// harmonic of their distance from the centre as entered, ρ ≈ ρ₀ + (c − c_entered)·d̂ (d̂
    /// the unit vector from it; n = ±d̂), is the program's centre's offset. Fitted over the 1°
    /// bins (each bin's mean ρ and mean n, weighted by its samples), the second-order term
    /// taken off in a second pass; u from the bins' scatter about it (servo and reversal
    /// errors of the positions, the encoders' resolution), each bin one observation. `Err`
    /// where its bins do not determine it (no samples, an arc of a few bins).
    #[inline(never)] // called at a run's end only
    pub fn traced_centre(&self, d: Direction) -> Result<TracedCentre, CircleFitError> {
        let run = self.run(d);
        // the bins' normal matrix, not the samples': a bin's mean n is shorter than its
        // samples' (by Δ²/24 on 1°), its mean ρ holds δ·(mean n) exactly; the samples' matrix
        // with the bins' right-hand side read δ short by Δ²/12 (0.013 µm at 0.5 mm). f32 sums:
        // 360 terms.
        let mut a = [0.0f32; 6];
        for b in run.bins.iter() {
            let Some((_, nu, nv)) = b.mean() else {
                continue;
            };
            for (s, v) in a.iter_mut().zip([1.0, nu, nv, nu * nu, nu * nv, nv * nv]) {
                *s += b.n as f32 * v;
            }
        }
        let [a00, a01, a02, a11, a12, a22] = a.map(f64::from);
        let chol = crate::metrology::solve3::Sym3 {
            a00,
            a01,
            a02,
            a11,
            a12,
            a22,
        }
        .cholesky()
        .map_err(|_| CircleFitError::IllConditioned)?;
        // ρ = δ·d̂ + (R_p − R) − (|δ|² − (δ·d̂)²)/2R + O(δ³/R²) (the exact circle through
        // the positions, R_p the program's radius): the second-order term from the first pass's
        // δ taken off in the second (δ 0.5 mm off on R 150 mm: 0.8 µm; 0.006 µm left)
        let inv_2r = 0.5 / (self.radius_mm * 1e3);
        let first = traced_pass(&run.bins, &chol, [0.0; 3], inv_2r);
        let [_, x1, x2] = first.0;
        // a second pass only where the term matters (above 0.1 nm: δ beyond 5 µm on R 150 mm);
        // the first pass's residual already has it taken off
        let ([_, x1, x2], ss, bins) = if (x1 * x1 + x2 * x2) * inv_2r > 1e-4 {
            traced_pass(&run.bins, &chol, first.0, inv_2r)
        } else {
            first
        };
        let inv = chol.inverse();
        // each bin one observation of variance ss/(bins − 3): (AᵀA)⁻¹ of the bins ≈ that of
        // the samples × samples / bins
        let var = if bins > 3 {
            ss / (bins - 3) as f32 * a[0] / bins as f32
        } else {
            f32::NAN
        };
        let u = |a: f64| crate::num::sqrtf(var * a as f32);
        let s = run.fit.config().geometry.sensitivity.sign();
        Ok(TracedCentre {
            offset_um: [s * x1, s * x2],
            u_um: [u(inv.a11), u(inv.a22)],
        })
    }

    /// The centre's u for the shares of direction `d`, µm per in-plane coordinate:
    /// `u_entered_um`, or the traced offset where it contradicts that
    /// ([`TracedCentre::centre_u_um`]; as entered where the bins do not tell the offset).
    pub fn centre_u_um(&self, d: Direction, u_entered_um: f32) -> f32 {
        self.traced_centre(d)
            .map_or(u_entered_um, |t| t.centre_u_um(u_entered_um))
    }

    /// [`CentreResponse`] of direction `d`'s circle.
    pub(super) fn centre_response(&self, d: Direction) -> Result<CentreResponse, CircleFitError> {
        let run = self.run(d);
        CentreResponse::of(
            &run.fit.moments(),
            &[&run.bins],
            run.fit.config().geometry.sensitivity,
            self.radius_mm,
        )
    }
}
