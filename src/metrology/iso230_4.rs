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
//! Per sample: the running limaçon fit of the direction ([`CircleFit`]) and the sample's
//! angular bin (`BINS` equal bins from +u, aligned with the quadrants; per bin the sums of ΔL
//! and n). Profile figures (G, F, G(b), H) and diagnostics are evaluated on the bin-averaged
//! profile: intra-bin extremes narrower than 360°/`BINS` are averaged, which is a
//! low-pass filter of that width. The least-squares centre subtracted is the exact one of the
//! running fit (the bin mean of e·n is e·(mean n), exactly).
//!
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
use super::angle::quadrant_angle;
use super::circle_fit::{CircleEstimate, CircleFit, CircleFitConfig, CircleFitError, Moments};
use super::extremes;
use super::pattern::Sensitivity;
use super::solve3::cholesky_solve;
use crate::acquisition::Sample;
use crate::in_place::{self, init_in_place};
use core::mem::MaybeUninit;

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
    /// Σ of the positions' distance from the centre as entered less the nominal radius, µm.
    traced_um: f32,
    n: u32,
}

impl Bin {
    /// Means of ΔL (µm) and of n's components, f32 (the figures' small numbers).
    fn mean(&self) -> Option<(f32, f32, f32)> {
        if self.n == 0 {
            return None;
        }
        let k = 1.0 / self.n as f32;
        Some((self.dl_um * k, self.nu * k, self.nv * k))
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Run<const BINS: usize> {
    fit: CircleFit,
    bins: [Bin; BINS],
}

impl<const BINS: usize> Run<BINS> {
    /// An empty run of the fit `config`, built in `slot`.
    fn init(slot: &mut MaybeUninit<Self>, config: CircleFitConfig) -> &mut Self {
        init_in_place!(slot, Self {
            fit: CircleFit::new(config),
        } in place {
            bins: |s| in_place::fill(s, Bin::default()),
        })
    }

    /// One sample's ΔL noise, µm, from the bin profile ([`extremes::sample_noise_um`]); NaN
    /// if the profile is too short to tell.
    fn noise_um(&self) -> f32 {
        let mut scratch = [0.0f32; BINS];
        let bin = |i: usize| {
            self.bins
                .get(i)
                .and_then(|b| {
                    b.mean().map(|(dl, _, _)| extremes::BinMean {
                        mean_um: dl,
                        n: b.n,
                    })
                })
                .unwrap_or_default()
        };
        extremes::sample_noise_um(BINS, bin, &mut scratch).unwrap_or(f32::NAN)
    }
}

/// Marks a CW bin's sample count for the bidirectional bootstrap's noise (a bin never holds
/// 2³¹ samples).
const CW_BIN: u32 = 1 << 31;

/// Five profile figures of a test, computed with `shift(i, n)` added to each bin: bin `i` of
/// `n` samples (the CW profile's n marked with [`CW_BIN`]) moves its mean ΔL by the first
/// value and its residual about the circle by both.
type Figures<'a> = &'a dyn Fn(&mut dyn FnMut(usize, u32) -> (f32, f32)) -> [f32; 5];

/// The values `figures` computes, observed (no noise added), and their moments over
/// [`extremes::REPLICAS`] replicas with normal noise of standard deviation `sigma(n)` added to
/// each bin of n samples ([`super::extremes`]); `Err(observed)` if the noise is not told (σ
/// NaN).
// one copy in flash for both callers (`dyn`), five values each (the bidirectional use four)
fn bootstrap(
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

/// A least-squares circle's (r0, e_u, e_v) over some bins and their first-order response to
/// the centre as entered ([`CircularTest::centre_shares`]).
struct CentreResponse {
    /// The fit (r0, e_u, e_v), µm.
    x: [f32; 3],
    /// ∂(r0, e_u, e_v)/∂δ for the centre moved along u (`[0]`) and along v (`[1]`), µm/µm.
    per_um: [[f32; 3]; 2],
    /// −s/R per µm: the turn of a direction n by a centre moved 1 µm across it.
    k: f32,
}

impl CentreResponse {
    /// The moments `m` of the profiles `bins` (one direction's, or both for the joint circle)
    /// of a test of sensitivity `s` on radius `radius_mm`: the fit and its response,
    /// dx = (AᵀA)⁻¹ Σ [(0, dn) r − (1, n)(dn·e)] over the bins (module doc of
    /// [`CircularTest::centre_shares`]).
    fn of(
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
    fn turn(&self, [du, dv]: [f32; 2], nu: f32, nv: f32) -> [f32; 2] {
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
    fn bin_shift(&self, bins: &[Bin], i: usize, delta: [f32; 2]) -> (f32, f32) {
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
    fn figure_shares(&self, figures: Figures, bins: [&[Bin]; 2], u_centre_um: f32) -> [f32; 5] {
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
const MOVES: [[f32; 2]; 4] = [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]];

/// A figure whose u is not evaluated (NaN).
fn not_evaluated(value: f32) -> Diagnosed {
    Diagnosed {
        value,
        std_uncertainty: f32::NAN,
        centre_um: 0.0,
    }
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

/// A bin's mean traced radius less the second-order term of the offset `x` (µm; `inv_2r`
/// 1/2R per µm), its mean n and its samples ([`CircularTest::traced_centre`]); `None` if empty.
fn traced_bin(b: &Bin, [_, x1, x2]: [f32; 3], inv_2r: f32) -> Option<(f32, f32, f32, f32)> {
    let (_, nu, nv) = b.mean()?;
    let along = x1 * nu + x2 * nv;
    let q = (x1 * x1 + x2 * x2 - along * along) * inv_2r;
    Some((b.traced_um / b.n as f32 + q, nu, nv, b.n as f32))
}

/// One pass of [`CircularTest::traced_centre`] with the second-order term of `x` taken off:
/// the fit (ρ₀, δ_u, δ_v) by the bins' normal matrix `chol`, the bins' sum of squared
/// residuals and their number.
#[inline(never)] // one copy for both passes
fn traced_pass(
    bins: &[Bin],
    chol: &super::solve3::Chol3,
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
    fn set_centre_moves(&mut self, moves: [[f32; 5]; 4]) {
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

/// An ISO 230-4 circular test about the socket (both directions), `BINS` angular bins
/// (a multiple of 4, at most 4096). State: 32·BINS + 252 bytes (11 772 B for 360 bins).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircularTest<const BINS: usize> {
    radius_mm: f32,
    ccw: Run<BINS>,
    cw: Run<BINS>,
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
        in_place::build(|s| Self::init(s, config, radius_mm))
    }

    /// [`CircularTest::new`] built in place in `slot` (no stack copy of the 14.3 KiB state).
    pub fn init(
        slot: &mut MaybeUninit<Self>,
        config: CircleFitConfig,
        radius_mm: f32,
    ) -> &mut Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::CHECK;
        init_in_place!(slot, Self {
            radius_mm: radius_mm,
        } in place {
            ccw: |s| Run::init(s, config),
            cw: |s| Run::init(s, config),
        })
    }

    /// Starts a new test in place (as [`CircularTest::new`]).
    pub fn restart(&mut self, config: CircleFitConfig, radius_mm: f32) {
        in_place::reinit(self, |s| Self::init(s, config, radius_mm));
    }

    /// Forgets the samples of direction `d` (a new run of that direction replaces the old one:
    /// runs are not merged); the other direction is kept.
    pub fn reset_direction(&mut self, d: Direction) {
        let run = self.run_mut(d);
        let config = *run.fit.config();
        in_place::reinit(run, |s| Run::init(s, config));
    }

    /// The nominal radius the test was built with, mm.
    pub fn radius_mm(&self) -> f32 {
        self.radius_mm
    }

    fn run(&self, d: Direction) -> &Run<BINS> {
        match d {
            Direction::Ccw => &self.ccw,
            Direction::Cw => &self.cw,
        }
    }

    fn run_mut(&mut self, d: Direction) -> &mut Run<BINS> {
        match d {
            Direction::Ccw => &mut self.ccw,
            Direction::Cw => &mut self.cw,
        }
    }

    /// The running fit of one direction.
    pub fn fit(&self, d: Direction) -> &CircleFit {
        &self.run(d).fit
    }

    /// The limaçon fit of direction `d` (r0, e) with its u from the samples' noise (the
    /// profile's third differences, as G's), σ·√((AᵀA)⁻¹ᵢᵢ), rather than from the fit's
    /// residual: the profile's shape is what is measured, not noise (on a circle with the
    /// faults above the residual's u(e) was 6–7 times the scatter). The residual's u where the
    /// profile is too short to tell its noise.
    pub fn fit_estimate(&self, d: Direction) -> Result<CircleEstimate, CircleFitError> {
        let run = self.run(d);
        let mut est = run.fit.estimate()?;
        let s = run.noise_um();
        if let (true, Ok(c)) = (s.is_finite(), run.fit.moments().normal_matrix().cholesky()) {
            let inv = c.inverse();
            let u = |a: f64| crate::num::sqrtf(s * s * a as f32);
            est.u_r0_um = u(inv.a00);
            est.u_e_um = [u(inv.a11), u(inv.a22)];
        }
        Ok(est)
    }

    /// The centre's shares of the limaçon fit of direction `d`, (r0, e_u, e_v) in µm, for a
    /// centre entered with standard uncertainty `u_centre_um` in each in-plane coordinate
    /// against the centre the path circles about: first order (GUM §5.1.2, analytic),
    /// u_centre·|∂x/∂(δ_u, δ_v)|.
    ///
    /// The pod takes from the centre as entered only each sample's direction n about it
    /// ([`super::pattern::PatternGeometry::direction`]). Entered δ off, n moves by
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
        let chol = super::solve3::Sym3 {
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
    fn centre_response(&self, d: Direction) -> Result<CentreResponse, CircleFitError> {
        let run = self.run(d);
        CentreResponse::of(
            &run.fit.moments(),
            &[&run.bins],
            run.fit.config().geometry.sensitivity,
            self.radius_mm,
        )
    }

    /// One sample's ΔL noise of the run in direction `d`, µm, from its profile's third
    /// differences ([`extremes::sample_noise_um`]); NaN while the profile is too short to tell.
    pub fn noise_um(&self, d: Direction) -> f32 {
        self.run(d).noise_um()
    }

    /// Feeds one sample of the run in direction `d` (O(1): the fit update, a polynomial atan
    /// for the bin, 4 adds).
    pub fn update(&mut self, sample: &Sample, d: Direction) -> super::circle_fit::SampleUse {
        let radius_mm = self.radius_mm;
        let run = self.run_mut(d);
        let ([nu, nv], r_mm) = match run.fit.update_direction(sample) {
            Ok(nr) => nr,
            Err(skipped) => return skipped,
        };
        let dl = sample.delta_l_um;
        let (q, a) = quadrant_angle(nu, nv);
        // a constant divisor: no division-by-zero check (a panic path) in the bin loops
        let per_q = Self::BINS_PER_QUADRANT;
        let k = ((a * (per_q as f32 / core::f32::consts::FRAC_PI_2)) as usize).min(per_q - 1);
        if let Some(bin) = run.bins.get_mut(usize::from(q) * per_q + k) {
            bin.dl_um += dl;
            bin.nu += nu;
            bin.nv += nv;
            bin.traced_um += (r_mm - radius_mm) * 1e3;
            bin.n = bin.n.saturating_add(1);
        }
        super::circle_fit::SampleUse::Used
    }

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
struct NormalEquations {
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
struct DiagnosticFit {
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
fn normal_equations(
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
    fn fit(&self) -> Result<DiagnosticFit, IsoError> {
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

fn dot(a: &[f32], b: &[f32]) -> f32 {
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
