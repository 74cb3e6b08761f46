//! Running limaçon circle fit of a measuring pattern (seed 002 §3.5, DESIGN §7 "Eccentricity").
//!
//! Model: ΔL_i = r0 + e·n_i, with n_i the pattern's sensitive direction at sample i (see
//! [`ArcGeometry::direction`]), e = (e_u, e_v) the eccentricity (the centre of the measured
//! trajectory relative to the commanded one, in the pattern plane, µm) and r0 the mean radius
//! change (µm). This is the small-deviation limit of a least-squares circle fit; it holds for
//! full circles and for partial arcs (the 90° B arcs), where Fourier orthogonality does not,
//! because the full 3×3 normal equations are solved.
//!
//! Per sample (O(1), no solve, no trigonometry): n from the geometry, 9 Kahan-compensated f32
//! sums of n, n nᵀ, y, y n, y² with y = ΔL − ΔL_ref on deviations (ΔL_ref = the first used
//! sample), and the turned angle for the arc check. The results' solve (hand-written f64
//! Cholesky, see [`super::solve3`]) happens only when an estimate is asked for; the live value
//! of every sample is an f32 solve of the same sums ([`CircleFit::live`]). See
//! [`super::compensated`] for why Kahan sums.

use super::compensated::KahanF32;
use super::pattern::ArcGeometry;
use super::solve3::Sym3;
use crate::acquisition::Sample;

/// How far short of the minimum arc a turned arc may fall and still count, degrees. A sampled
/// arc ends at its first and last samples, up to one sample's step inside the program's ends
/// (0.04° at F6000 on R 150 mm at 1 kHz): a 220° program measured as 219.9998° meets a
/// `circle_min_arc` of 220°. 0.05° is 0.13 mm of path on R 150 — far below the arcs the
/// minimum is there to refuse.
pub const ARC_END_TOLERANCE_DEG: f32 = 0.05;

/// Why no circle-fit estimate is available (yet).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CircleFitError {
    /// Fewer valid samples than the 4 needed for r0, e and a residual variance.
    NotEnoughSamples {
        /// Valid samples so far.
        have: u32,
    },
    /// The turned arc is shorter than the configured minimum (e is not yet observable).
    ArcTooShort {
        /// Arc turned so far, degrees.
        arc_deg: f32,
        /// Configured minimum, degrees.
        min_arc_deg: f32,
    },
    /// The normal matrix is singular to working precision (e.g. all samples at one angle).
    IllConditioned,
}

/// What [`CircleFit::update`] did with a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SampleUse {
    /// Accumulated.
    Used,
    /// Skipped: flagged invalid for metrology (counted).
    SkippedFlagged,
    /// Skipped: ΔL or a position not finite, or the position at the pattern centre (counted).
    SkippedInvalid,
}

/// Configuration of a [`CircleFit`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircleFitConfig {
    /// The pattern's geometry (plane, centre, sign of n).
    pub geometry: ArcGeometry,
    /// Minimum arc, degrees, before an estimate is given (issue 3: ≥ 60°).
    pub min_arc_deg: f32,
}

/// The f64 moments of a fit, read back from the compensated f32 sums (relative to `y_ref_um`).
/// Public so that fits can be merged (CW + CCW) and evaluated by ISO 230-4.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Moments {
    /// Number of samples.
    pub n: f64,
    /// Σ n_u.
    pub s_u: f64,
    /// Σ n_v.
    pub s_v: f64,
    /// Σ n_u².
    pub s_uu: f64,
    /// Σ n_u n_v.
    pub s_uv: f64,
    /// Σ n_v².
    pub s_vv: f64,
    /// Σ y, µm (y = ΔL − y_ref).
    pub y: f64,
    /// Σ y n_u, µm.
    pub y_u: f64,
    /// Σ y n_v, µm.
    pub y_v: f64,
    /// Σ y², µm².
    pub yy: f64,
    /// Reference ΔL subtracted from every sample, µm.
    pub y_ref_um: f64,
}

/// A limaçon fit result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircleEstimate {
    /// Radius change r0 (mean ΔL of the model), µm.
    pub r0_um: f32,
    /// Eccentricity (e_u, e_v) in the pattern plane, µm (seed 002: (ex, ey) for C, (ex, ez) for B).
    pub e_um: [f32; 2],
    /// Standard uncertainty of r0, µm (residual variance × (AᵀA)⁻¹).
    pub u_r0_um: f32,
    /// Standard uncertainties of (e_u, e_v), µm.
    pub u_e_um: [f32; 2],
    /// Residual RMS, µm.
    pub residual_rms_um: f32,
    /// Samples used.
    pub samples: u32,
    /// Frobenius condition number √(tr A · tr A⁻¹) of the 3×3 normal matrix A (√10 ≈ 3.2 for a full
    /// circle; grows as the arc shortens).
    pub cond: f32,
}

/// Combination of a CW and a CCW estimate (seed 002 §3.5: the mean of the two is used).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CombinedEstimate {
    /// Mean eccentricity of CW and CCW, µm.
    pub e_um: [f32; 2],
    /// Its standard uncertainty √(u_cw² + u_ccw²)/2, µm.
    pub u_e_um: [f32; 2],
    /// Mean radius change, µm.
    pub r0_um: f32,
    /// CCW minus CW eccentricity (e.g. B-axis synchronisation error), µm.
    pub e_ccw_minus_cw_um: [f32; 2],
}

#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Sums {
    s_u: KahanF32,
    s_v: KahanF32,
    s_uu: KahanF32,
    s_uv: KahanF32,
    s_vv: KahanF32,
    y: KahanF32,
    y_u: KahanF32,
    y_v: KahanF32,
    yy: KahanF32,
}

/// The running limaçon fit of one pattern run (one direction). State: 124 bytes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CircleFit {
    config: CircleFitConfig,
    sums: Sums,
    used: u32,
    skipped_flagged: u32,
    skipped_invalid: u32,
    y_ref_um: f32,
    n_anchor: [f32; 2],
    /// Turned angle of the anchor direction since the first sample, rad (unwrapped), and the
    /// extremes of the turned angle.
    psi_anchor_rad: f32,
    psi_min_rad: f32,
    psi_max_rad: f32,
}

impl CircleFit {
    /// An empty fit.
    pub fn new(config: CircleFitConfig) -> Self {
        Self {
            config,
            sums: Sums::default(),
            used: 0,
            skipped_flagged: 0,
            skipped_invalid: 0,
            y_ref_um: 0.0,
            n_anchor: [0.0, 0.0],
            psi_anchor_rad: 0.0,
            psi_min_rad: 0.0,
            psi_max_rad: 0.0,
        }
    }

    /// Forgets all samples, keeps the configuration.
    pub fn reset(&mut self) {
        *self = Self::new(self.config);
    }

    /// The configuration.
    pub fn config(&self) -> &CircleFitConfig {
        &self.config
    }

    /// Accumulates one sample (O(1): ~60 flops, one square root, one division).
    pub fn update(&mut self, sample: &Sample) -> SampleUse {
        match self.update_direction(sample) {
            Ok(_) => SampleUse::Used,
            Err(skipped) => skipped,
        }
    }

    /// As [`update`](Self::update), returning the sensitive direction n of a used sample and
    /// its position's distance from the centre, mm (so that callers binning by angle do not
    /// compute them twice).
    #[inline]
    pub fn update_direction(&mut self, sample: &Sample) -> Result<([f32; 2], f32), SampleUse> {
        if !sample.flags.is_valid_for_metrology() {
            self.skipped_flagged = self.skipped_flagged.saturating_add(1);
            return Err(SampleUse::SkippedFlagged);
        }
        let dl = sample.delta_l_um;
        let (n, r) = match self.config.geometry.direction_and_radius(&sample.axes) {
            Some(nr) if dl.is_finite() => nr,
            _ => {
                self.skipped_invalid = self.skipped_invalid.saturating_add(1);
                return Err(SampleUse::SkippedInvalid);
            }
        };
        self.add(n, dl);
        Ok((n, r))
    }

    /// Accumulates one observation ΔL = `delta_l_um` at sensitive direction `n` (unit, in the
    /// pattern plane). [`update`](Self::update) calls this after the checks; exposed for
    /// callers that already have n.
    #[inline]
    pub fn add(&mut self, n: [f32; 2], delta_l_um: f32) {
        let [nu, nv] = n;
        if self.used == 0 {
            self.y_ref_um = delta_l_um;
            self.n_anchor = n;
        } else {
            // Turned angle relative to an anchor direction: Δψ from sin Δψ = n_a × n and
            // cos Δψ = n_a · n, using Δψ ≈ sin Δψ · (1 + (1 − cos Δψ)/3) (error O(Δψ⁵)). The
            // anchor moves on only once the turn exceeds 1/16 rad: differencing consecutive
            // samples directly would add a biased f32 rounding of ~5e-8 rad per sample
            // (0.3° over 100 000 samples).
            let [pu, pv] = self.n_anchor;
            let s = pu * nv - pv * nu;
            let c = pu * nu + pv * nv;
            let turn = s * (1.0 + (1.0 - c) * (1.0 / 3.0));
            let psi = self.psi_anchor_rad + turn;
            // comparisons, not f32::min/max: those are fminf/fmaxf library calls on the M4F
            if psi < self.psi_min_rad {
                self.psi_min_rad = psi;
            }
            if psi > self.psi_max_rad {
                self.psi_max_rad = psi;
            }
            if !(s.abs() < 0.0625) {
                self.psi_anchor_rad = psi;
                self.n_anchor = n;
            }
        }
        let y = delta_l_um - self.y_ref_um;
        let s = &mut self.sums;
        s.s_u.add(nu);
        s.s_v.add(nv);
        s.s_uu.add(nu * nu);
        s.s_uv.add(nu * nv);
        s.s_vv.add(nv * nv);
        s.y.add(y);
        s.y_u.add(y * nu);
        s.y_v.add(y * nv);
        s.yy.add(y * y);
        self.used = self.used.saturating_add(1);
    }

    /// Samples used.
    pub fn samples(&self) -> u32 {
        self.used
    }

    /// Samples skipped because they were flagged invalid for metrology.
    pub fn skipped_flagged(&self) -> u32 {
        self.skipped_flagged
    }

    /// Samples skipped because ΔL or a position was not finite, or at the pattern centre.
    pub fn skipped_invalid(&self) -> u32 {
        self.skipped_invalid
    }

    /// The arc turned so far (max − min of the unwrapped angle), degrees (a sampled arc: up to
    /// a sample's step short of the program's at each end).
    pub fn arc_deg(&self) -> f32 {
        (self.psi_max_rad - self.psi_min_rad).to_degrees()
    }

    /// The moments (f64) for merging and ISO 230-4.
    pub fn moments(&self) -> Moments {
        let s = &self.sums;
        Moments {
            n: f64::from(self.used),
            s_u: s.s_u.value(),
            s_v: s.s_v.value(),
            s_uu: s.s_uu.value(),
            s_uv: s.s_uv.value(),
            s_vv: s.s_vv.value(),
            y: s.y.value(),
            y_u: s.y_u.value(),
            y_v: s.y_v.value(),
            yy: s.yy.value(),
            y_ref_um: f64::from(self.y_ref_um),
        }
    }

    /// Whether e is observable yet: enough samples and the minimum arc turned (the rule of
    /// both [`estimate`](Self::estimate) and [`live`](Self::live)).
    fn observable(&self) -> Result<(), CircleFitError> {
        if self.used < 4 {
            return Err(CircleFitError::NotEnoughSamples { have: self.used });
        }
        let arc_deg = self.arc_deg();
        if !(arc_deg + ARC_END_TOLERANCE_DEG >= self.config.min_arc_deg) {
            return Err(CircleFitError::ArcTooShort {
                arc_deg,
                min_arc_deg: self.config.min_arc_deg,
            });
        }
        Ok(())
    }

    /// The current estimate, or why there is none yet.
    pub fn estimate(&self) -> Result<CircleEstimate, CircleFitError> {
        self.observable()?;
        self.moments().solve()
    }

    /// The live (r0, e_u, e_v), µm: the least-squares solution of the same sums in f32 on the
    /// FPU, for the value refreshed at every sample (≈ 60 instructions against ≈ 15 000 for the
    /// f64 [`estimate`](Self::estimate), which the results use). The same rule as `estimate`
    /// for when e is observable.
    ///
    /// Solved on the means (Schur complement of the constant term): with m = (Σn)/N, the
    /// centred 2×2 system C e = d, C = Σnnᵀ/N − m mᵀ, d = Σyn/N − m ȳ, then r0 = ȳ − m·e. The
    /// centring costs ≈ 9 bits on a 60° arc, so e is within a few nm of the f64 solve there and
    /// well under 1 nm on a full circle (host tests).
    pub fn live(&self) -> Result<[f32; 3], CircleFitError> {
        self.live_solve().map(|l| l.value)
    }

    /// [`live`](Self::live) and the Type A standard uncertainties of (r0, e_u, e_v), µm, from
    /// the same sums (for a refresh every few samples), with one sample's noise σ =
    /// `sample_noise_um` (the rule of `CircularTest::fit_estimate`: about 100 instructions) or,
    /// where that is NaN, from the residual as [`estimate`](Self::estimate) does (σ² =
    /// SSR/(N − 3)). Then u(e)² = σ²·(C⁻¹)_kk/N and u(r0)² = σ²·(1 + mᵀC⁻¹m)/N, the blocks of
    /// σ²(AᵀA)⁻¹ in the centred form.
    ///
    /// The residual is SSR(x) = Σy² − 2xᵀb + xᵀ(AᵀA)x in f64 from the sums' f64 values at
    /// the live solution x (a few thousand soft-float instructions): it cancels to 1e-6 of Σy²
    /// at e = 100 µm and 0.05 µm of noise, which f32 cannot hold, and an error δ of x moves it
    /// by δᵀ(AᵀA)δ only, second order.
    pub fn live_with_uncertainty(
        &self,
        sample_noise_um: f32,
    ) -> Result<([f32; 3], [f32; 3]), CircleFitError> {
        let l = self.live_solve()?;
        let [_, eu, ev] = l.value;
        let sigma2_per_n = if sample_noise_um.is_finite() {
            sample_noise_um * sample_noise_um * l.inv_n
        } else {
            let m = self.moments();
            let a = m.normal_matrix();
            // x with r0 from the first sample's ΔL, as the sums' y
            let x = [l.y - l.mu * eu - l.mv * ev, eu, ev].map(f64::from);
            let ax = [
                a.a00 * x[0] + a.a01 * x[1] + a.a02 * x[2],
                a.a01 * x[0] + a.a11 * x[1] + a.a12 * x[2],
                a.a02 * x[0] + a.a12 * x[1] + a.a22 * x[2],
            ];
            let ssr = m.yy
                + x[0] * (ax[0] - 2.0 * m.y)
                + x[1] * (ax[1] - 2.0 * m.y_u)
                + x[2] * (ax[2] - 2.0 * m.y_v);
            // rounding can leave a noiseless fit's SSR slightly negative: 0; NaN stays NaN
            if ssr.is_nan() || ssr > 0.0 {
                (ssr / (m.n * (m.n - 3.0))) as f32
            } else {
                0.0
            }
        };
        let (ciuu, ciuv, civv) = (l.cvv * l.inv_det, -l.cuv * l.inv_det, l.cuu * l.inv_det);
        let m_ci_m = l.mu * l.mu * ciuu + 2.0 * l.mu * l.mv * ciuv + l.mv * l.mv * civv;
        let u = |c: f32| crate::num::sqrtf(sigma2_per_n * c);
        Ok((l.value, [u(1.0 + m_ci_m), u(ciuu), u(civv)]))
    }

    /// The centred live solve of [`live`](Self::live), with what its uncertainty needs.
    #[inline(never)] // one copy for `live` (every sample) and the u (every few)
    fn live_solve(&self) -> Result<LiveSolve, CircleFitError> {
        self.observable()?;
        let s = &self.sums;
        let inv_n = 1.0 / self.used as f32;
        let (mu, mv) = (s.s_u.value_f32() * inv_n, s.s_v.value_f32() * inv_n);
        let y = s.y.value_f32() * inv_n;
        let cuu = s.s_uu.value_f32() * inv_n - mu * mu;
        let cuv = s.s_uv.value_f32() * inv_n - mu * mv;
        let cvv = s.s_vv.value_f32() * inv_n - mv * mv;
        let du = s.y_u.value_f32() * inv_n - mu * y;
        let dv = s.y_v.value_f32() * inv_n - mv * y;
        let det = cuu * cvv - cuv * cuv;
        let trace = cuu + cvv;
        // f32 resolves the centred matrix to ~1e-5 of its trace after the centring's loss
        if !(det > 1e-6 * trace * trace) {
            return Err(CircleFitError::IllConditioned);
        }
        let inv_det = 1.0 / det;
        let eu = (cvv * du - cuv * dv) * inv_det;
        let ev = (cuu * dv - cuv * du) * inv_det;
        // finite sums and a regular matrix give finite values (the live table also refuses
        // any non-finite value)
        Ok(LiveSolve {
            value: [y - mu * eu - mv * ev + self.y_ref_um, eu, ev],
            inv_n,
            mu,
            mv,
            y,
            cuu,
            cuv,
            cvv,
            inv_det,
        })
    }
}

/// The centred live solve (f32, means over the used samples; see [`CircleFit::live`]).
struct LiveSolve {
    /// (r0, e_u, e_v), µm.
    value: [f32; 3],
    /// 1/N.
    inv_n: f32,
    /// Mean sensitive direction m = (mu, mv).
    mu: f32,
    mv: f32,
    /// Mean y (ΔL less the first sample's), µm.
    y: f32,
    /// Centred normal matrix C.
    cuu: f32,
    cuv: f32,
    cvv: f32,
    /// 1/det C.
    inv_det: f32,
}

impl Moments {
    /// The same moments with y measured from `y_ref_um` instead (y' = y + old_ref − new_ref).
    pub fn with_reference(&self, y_ref_um: f64) -> Moments {
        let d = self.y_ref_um - y_ref_um; // y' = y + d
        Moments {
            y: self.y + d * self.n,
            y_u: self.y_u + d * self.s_u,
            y_v: self.y_v + d * self.s_v,
            yy: self.yy + 2.0 * d * self.y + d * d * self.n,
            y_ref_um,
            ..*self
        }
    }

    /// Moments of the union of two sample sets (a joint fit, e.g. CW and CCW together).
    pub fn merged(&self, other: &Moments) -> Moments {
        let o = other.with_reference(self.y_ref_um);
        Moments {
            n: self.n + o.n,
            s_u: self.s_u + o.s_u,
            s_v: self.s_v + o.s_v,
            s_uu: self.s_uu + o.s_uu,
            s_uv: self.s_uv + o.s_uv,
            s_vv: self.s_vv + o.s_vv,
            y: self.y + o.y,
            y_u: self.y_u + o.y_u,
            y_v: self.y_v + o.y_v,
            yy: self.yy + o.yy,
            y_ref_um: self.y_ref_um,
        }
    }

    /// The normal matrix AᵀA of the design rows (1, n_u, n_v).
    pub fn normal_matrix(&self) -> Sym3 {
        Sym3 {
            a00: self.n,
            a01: self.s_u,
            a02: self.s_v,
            a11: self.s_uu,
            a12: self.s_uv,
            a22: self.s_vv,
        }
    }

    /// Least-squares solution (r0, e_u, e_v) in µm, r0 absolute (y_ref added back).
    pub fn solve_f64(&self) -> Result<[f64; 3], CircleFitError> {
        let x = self
            .normal_matrix()
            .solve([self.y, self.y_u, self.y_v])
            .map_err(|_| CircleFitError::IllConditioned)?;
        Ok([x[0] + self.y_ref_um, x[1], x[2]])
    }

    /// The full estimate (requires n ≥ 4).
    pub fn solve(&self) -> Result<CircleEstimate, CircleFitError> {
        if !(self.n >= 4.0) {
            return Err(CircleFitError::NotEnoughSamples {
                have: self.n as u32,
            });
        }
        let a = self.normal_matrix();
        let chol = a.cholesky().map_err(|_| CircleFitError::IllConditioned)?;
        let b = [self.y, self.y_u, self.y_v];
        let x = chol.solve(b);
        let inv = chol.inverse();
        // SSR = Σy² − xᵀb at the solution (clamped: rounding can make it slightly negative)
        let ssr = (self.yy - (x[0] * b[0] + x[1] * b[1] + x[2] * b[2])).max(0.0);
        let var = ssr / (self.n - 3.0);
        let u = |d: f64| crate::num::sqrt((var * d).max(0.0)) as f32;
        let cond = crate::num::sqrt(a.trace() * inv.trace()) as f32;
        let est = CircleEstimate {
            r0_um: (x[0] + self.y_ref_um) as f32,
            e_um: [x[1] as f32, x[2] as f32],
            u_r0_um: u(inv.a00),
            u_e_um: [u(inv.a11), u(inv.a22)],
            residual_rms_um: crate::num::sqrt(ssr / self.n) as f32,
            samples: self.n as u32,
            cond,
        };
        let finite =
            est.r0_um.is_finite() && est.e_um.iter().all(|v| v.is_finite()) && est.cond.is_finite();
        if finite {
            Ok(est)
        } else {
            Err(CircleFitError::IllConditioned)
        }
    }
}

/// CW and CCW combined as in seed 002 §3.5 (mean of the two eccentricities).
pub fn combine(cw: &CircleEstimate, ccw: &CircleEstimate) -> CombinedEstimate {
    let [a0, a1] = cw.e_um;
    let [b0, b1] = ccw.e_um;
    let [ua0, ua1] = cw.u_e_um;
    let [ub0, ub1] = ccw.u_e_um;
    CombinedEstimate {
        e_um: [(a0 + b0) * 0.5, (a1 + b1) * 0.5],
        u_e_um: [
            crate::num::sqrtf(ua0 * ua0 + ub0 * ub0) * 0.5,
            crate::num::sqrtf(ua1 * ua1 + ub1 * ub1) * 0.5,
        ],
        r0_um: (cw.r0_um + ccw.r0_um) * 0.5,
        e_ccw_minus_cw_um: [b0 - a0, b1 - a1],
    }
}
