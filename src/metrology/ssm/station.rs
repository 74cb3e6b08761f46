//! Station-mode SSM (seed 000 eq 1): dwells detected by axis velocity, averaged into stations;
//! E solved exactly from three stations, by least squares from more, optionally refined by
//! Gauss–Newton on the exact sphere equation |P − P0 + E| = L + ΔL. f64 (once per test).

use super::{SsmError, SsmGeometry, SsmSolution, solve_normal};
use crate::acquisition::{MAX_AXES, Sample};
use crate::metrology::bar_budget::BarBudget;
use crate::metrology::compensated::KahanF32;
use crate::metrology::solve3::Sym3;

/// An averaged dwell: one point of eq (1).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Station {
    /// Nominal tool-ball centre P (mean of the dwell's axis positions X, Y, Z), mm.
    pub p_mm: [f64; 3],
    /// Mean rotary-axis positions during the dwell, degrees.
    pub rotary_deg: [f32; 2],
    /// Mean ΔL over the dwell (bar length minus calibrated length L), µm.
    pub delta_l_um: f64,
    /// Standard deviation of ΔL within the dwell, µm.
    pub std_um: f32,
    /// Samples averaged.
    pub samples: u32,
}

/// One observation u·E = y of a station: (u, y in µm).
pub fn observation(st: &Station, geom: &SsmGeometry) -> Result<([f64; 3], f64), SsmError> {
    let d = sub(st.p_mm, geom.socket_mm);
    let ln = crate::num::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if !(ln > 1e-6) || !ln.is_finite() || !st.delta_l_um.is_finite() {
        return Err(SsmError::InvalidInput);
    }
    let u = [d[0] / ln, d[1] / ln, d[2] / ln];
    // y = measured length − nominal distance = ΔL + (L − l_n), µm
    let y = st.delta_l_um + (geom.bar_length_mm - ln) * 1e3;
    Ok((u, y))
}

/// E from stations by eq (1): exact for three, least squares for more (normal equations of
/// the unit directions, f64), with condition number and observability.
pub fn solve_stations(stations: &[Station], geom: &SsmGeometry) -> Result<SsmSolution, SsmError> {
    let mut g = Sym3::default();
    let mut b = [0.0; 3];
    let mut yy = 0.0;
    let mut n = 0u32;
    for st in stations {
        let (u, y) = observation(st, geom)?;
        accumulate(&mut g, &mut b, &mut yy, u, y);
        n = n.saturating_add(1);
    }
    if n < 3 {
        return Err(SsmError::TooFewObservations { have: n, need: 3 });
    }
    solve_normal(&g, b, yy, n)
}

/// Gauss–Newton refinement of `start` on the exact sphere equations
/// |P_i − P0 + E| = L + ΔL_i (seed 000 B.2 item 4). Iterates until the step is below
/// 1e-9 µm (at most `max_iterations`). Unobservable components stay unobservable.
pub fn refine(
    stations: &[Station],
    geom: &SsmGeometry,
    start: &SsmSolution,
    max_iterations: u32,
) -> Result<SsmSolution, SsmError> {
    let mut e_um = start.e_um.map(|c| c.unwrap_or(0.0));
    let mut sol = *start;
    for it in 1..=max_iterations {
        let mut g = Sym3::default();
        let mut b = [0.0; 3];
        let mut yy = 0.0;
        let mut n = 0u32;
        for st in stations {
            let (j, r) = exact_row(st, geom, e_um)?;
            accumulate(&mut g, &mut b, &mut yy, j, r);
            n = n.saturating_add(1);
        }
        let step = solve_normal(&g, b, yy, n)?;
        let d = step.e_um.map(|c| c.unwrap_or(0.0));
        for (e, s) in e_um.iter_mut().zip(d) {
            *e += s;
        }
        let mask = start.e_um;
        sol = SsmSolution {
            e_um: [
                mask[0].map(|_| e_um[0]),
                mask[1].map(|_| e_um[1]),
                mask[2].map(|_| e_um[2]),
            ],
            iterations: it,
            // residual RMS of the exact equations at the previous iterate (≈ at the solution)
            residual_rms_um: step.residual_rms_um,
            ..step
        };
        if d.iter().all(|s| s.abs() < 1e-9) {
            return Ok(sol);
        }
    }
    if max_iterations == 0 {
        Ok(sol)
    } else {
        Err(SsmError::NotConverged)
    }
}

/// Covariance of E, µm² (GUM propagation through the least squares, at the solution `sol`):
/// E = G⁺ Σ j_i y_i ([`SsmSolution::g_pinv`]; j_i the unit direction of the exact sphere
/// equation at E), each station's y_i with variance σ_i² = std_um²/samples (Type A of the
/// dwell mean) + `fixed_u_um`² (what dwelling does not average away), so
/// cov = G⁺ (Σ σ_i² j_i j_iᵀ) G⁺ — times the Birge ratio χ²/(n − observable components) when
/// the stations scatter about the solution significantly more than their σ_i say (χ² above
/// its 95 % point). An unobservable direction has no variance. With it, how E moves with the
/// bar's own errors ([`BarSensitivity`], from the same rows).
#[inline(never)]
pub fn station_covariance(
    stations: &[Station],
    geom: &SsmGeometry,
    sol: &SsmSolution,
    fixed_u_um: f64,
) -> Result<(Sym3, BarSensitivity), SsmError> {
    if !(fixed_u_um.is_finite() && fixed_u_um >= 0.0) {
        return Err(SsmError::InvalidInput);
    }
    let e = sol.e_um.map(|c| c.unwrap_or(0.0));
    let mut w = Sym3::default();
    let (mut chi2, mut n) = (0.0f64, 0u32);
    let (mut sum_j, mut sum_jl) = ([0.0; 3], [0.0; 3]);
    for st in stations {
        let (j, r) = exact_row(st, geom, e)?;
        for ((s, sl), j) in sum_j.iter_mut().zip(sum_jl.iter_mut()).zip(j) {
            *s += j;
            *sl += j * st.delta_l_um;
        }
        let sd = f64::from(st.std_um);
        let var = sd * sd / f64::from(st.samples.max(1)) + fixed_u_um * fixed_u_um;
        w.add_outer(j, var);
        if var > 0.0 {
            chi2 += r * r / var;
        }
        n = n.saturating_add(1);
    }
    // inflate only when the scatter is significant (χ² above its 95 % point, Wilson–Hilferty):
    // χ²/dof of a few stations scatters widely, and max(1, χ²/dof) overstated u by 25 %
    let observable = 3 - u32::from(sol.unobservable_direction.is_some());
    let dof = n.saturating_sub(observable);
    let birge = if dof > 0 {
        let k = f64::from(dof);
        let h = 2.0 / (9.0 * k);
        let c = 1.0 - h + 1.645 * crate::num::sqrt(h);
        if chi2 > k * c * c * c { chi2 / k } else { 1.0 }
    } else {
        1.0
    };
    // columns of G⁺ W G⁺ (symmetric): G⁺ (W (G⁺ e_j))
    let gp = &sol.g_pinv;
    let col = |j: [f64; 3]| gp.mul(w.mul(gp.mul(j))).map(|x| x * birge);
    let [c00, c01, c02] = col([1.0, 0.0, 0.0]);
    let [_, c11, c12] = col([0.0, 1.0, 0.0]);
    let [.., c22] = col([0.0, 0.0, 1.0]);
    let cov = Sym3 {
        a00: c00,
        a01: c01,
        a02: c02,
        a11: c11,
        a12: c12,
        a22: c22,
    };
    let f32s = |v: [f64; 3]| v.map(|x| x as f32);
    let bar = BarSensitivity {
        per_offset: f32s(gp.mul(sum_j)),
        per_scale_um: f32s(gp.mul(sum_jl)),
    };
    if cov.is_finite() {
        Ok((cov, bar))
    } else {
        Err(SsmError::Degenerate)
    }
}

/// How E moves with the bar's own errors ([`crate::metrology::bar_budget`]), first order at
/// the solution (GUM §5.1.2, analytic): a constant offset δ of every station's ΔL (the bar's
/// calibrated length, its temperature) and a relative scale error k of ΔL (the LVDT) change
/// the stations' y_i by δ + k·ΔL_i, so E by G⁺ Σ j_i (δ + k·ΔL_i). Both are common to every
/// station of a run — and to every run made with the same bar — so they never average away.
/// f32 on the FPU, like [`BarBudget`]: these are uncertainties' shares.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BarSensitivity {
    /// δE per µm of ΔL offset, G⁺ Σ j_i (x, y, z; µm/µm).
    pub per_offset: [f32; 3],
    /// δE per unit relative scale error of ΔL, G⁺ Σ j_i ΔL_i (x, y, z; µm).
    pub per_scale_um: [f32; 3],
}

impl BarSensitivity {
    /// The bar's shares of the standard uncertainty of each component of E, µm: [the
    /// offset's, the scale's] (they add in quadrature).
    pub fn shares_um(&self, bar: &BarBudget) -> [[f32; 2]; 3] {
        let mut u = [[0.0; 2]; 3];
        for ((u, o), s) in u.iter_mut().zip(self.per_offset).zip(self.per_scale_um) {
            *u = [libm::fabsf(o * bar.offset_um), libm::fabsf(s * bar.scale)];
        }
        u
    }
}

/// One station's row of the exact sphere equation |P − P0 + E| = L + ΔL at `e_um`: the unit
/// direction j of P − P0 + E and the residual L + ΔL − |P − P0 + E|, µm.
#[inline(never)] // flash: one body for the refinement and the covariance
fn exact_row(
    st: &Station,
    geom: &SsmGeometry,
    e_um: [f64; 3],
) -> Result<([f64; 3], f64), SsmError> {
    let d = sub(st.p_mm, geom.socket_mm);
    let a = [
        d[0] + e_um[0] * 1e-3,
        d[1] + e_um[1] * 1e-3,
        d[2] + e_um[2] * 1e-3,
    ];
    let rho = crate::num::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
    if !(rho > 1e-6) || !rho.is_finite() {
        return Err(SsmError::InvalidInput);
    }
    Ok((
        [a[0] / rho, a[1] / rho, a[2] / rho],
        (geom.bar_length_mm - rho) * 1e3 + st.delta_l_um,
    ))
}

fn accumulate(g: &mut Sym3, b: &mut [f64; 3], yy: &mut f64, u: [f64; 3], y: f64) {
    g.add_outer(u, 1.0);
    let [u0, u1, u2] = u;
    b[0] += u0 * y;
    b[1] += u1 * y;
    b[2] += u2 * y;
    *yy += y * y;
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// Dwell detection thresholds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DwellConfig {
    /// Linear speed |v| (X, Y, Z) below which the machine counts as still, mm/s.
    pub max_speed_mm_per_s: f32,
    /// Rotary speed (each rotary axis) below which it counts as still, deg/s.
    pub max_rotary_speed_deg_per_s: f32,
    /// Time still before averaging starts (servo settling), µs.
    pub settle_us: u64,
    /// Minimum averaged samples for a dwell to become a station.
    pub min_samples: u32,
}

/// What [`StationCollector::update`] did with a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DwellEvent {
    /// The machine is moving.
    Moving,
    /// Still, within the settle time.
    Settling,
    /// Still and settled: the sample was averaged.
    Averaging,
    /// Motion resumed and the dwell became a station (or was dropped, see the counters).
    DwellClosed,
    /// Flagged invalid (or not finite): skipped and counted.
    Skipped,
}

#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct DwellAcc {
    n: u32,
    ref_axes: [f32; MAX_AXES],
    ref_dl: f32,
    dp: [KahanF32; MAX_AXES],
    dl: KahanF32,
    dl2: KahanF32,
}

/// Collects up to `S` stations from the sample stream (state size fixed by `S`).
/// Per sample: a velocity test and, while averaging, compensated sums of deviations from the
/// dwell's first sample (positions and ΔL), so the averages keep f32 resolution of deviations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StationCollector<const S: usize> {
    config: DwellConfig,
    stations: [Station; S],
    len: usize,
    dropped_full: u32,
    dropped_short: u32,
    skipped: u32,
    prev_axes: [f32; MAX_AXES],
    prev_t_us: u64,
    have_prev: bool,
    still_since_us: Option<u64>,
    acc: DwellAcc,
}

impl<const S: usize> StationCollector<S> {
    /// An empty collector.
    pub fn new(config: DwellConfig) -> Self {
        Self {
            config,
            stations: [Station::default(); S],
            len: 0,
            dropped_full: 0,
            dropped_short: 0,
            skipped: 0,
            prev_axes: [0.0; MAX_AXES],
            prev_t_us: 0,
            have_prev: false,
            still_since_us: None,
            acc: DwellAcc::default(),
        }
    }

    /// The stations collected so far.
    pub fn stations(&self) -> &[Station] {
        self.stations.get(..self.len).unwrap_or(&[])
    }

    /// Dwells dropped because the station buffer was full (an overrun, counted).
    pub fn dropped_full(&self) -> u32 {
        self.dropped_full
    }

    /// Dwells dropped because they averaged fewer than `min_samples` samples.
    pub fn dropped_short(&self) -> u32 {
        self.dropped_short
    }

    /// Samples skipped as flagged invalid or not finite.
    pub fn skipped(&self) -> u32 {
        self.skipped
    }

    /// Feeds one sample.
    pub fn update(&mut self, s: &Sample) -> DwellEvent {
        let [x, y, z, a, b] = s.axes;
        let finite = s.delta_l_um.is_finite()
            & x.is_finite()
            & y.is_finite()
            & z.is_finite()
            & a.is_finite()
            & b.is_finite();
        if !s.flags.is_valid_for_metrology() || !finite {
            self.skipped = self.skipped.saturating_add(1);
            return DwellEvent::Skipped;
        }
        let still = if self.have_prev && s.t_us > self.prev_t_us {
            // via u32 (71 min): a hardware conversion, not the soft u64 → f32 one
            let dt_us = u32::try_from(s.t_us - self.prev_t_us).unwrap_or(u32::MAX);
            let dt_s = dt_us as f32 * 1e-6;
            let [x, y, z, a, b] = s.axes;
            let [px, py, pz, pa, pb] = self.prev_axes;
            let (dx, dy, dz) = (x - px, y - py, z - pz);
            let vmax = self.config.max_speed_mm_per_s * dt_s;
            let rmax = self.config.max_rotary_speed_deg_per_s * dt_s;
            dx * dx + dy * dy + dz * dz <= vmax * vmax
                && (a - pa).abs() <= rmax
                && (b - pb).abs() <= rmax
        } else {
            false
        };
        let first = !self.have_prev;
        self.have_prev = true;
        self.prev_axes = s.axes;
        self.prev_t_us = s.t_us;
        if first {
            return DwellEvent::Moving;
        }
        if !still {
            let closed = self.still_since_us.is_some();
            // a moving sample closes nothing unless a dwell was open (the call alone is a
            // dozen instructions of the per-sample path)
            if closed || self.acc.n != 0 {
                self.close();
            }
            return if closed {
                DwellEvent::DwellClosed
            } else {
                DwellEvent::Moving
            };
        }
        let since = *self.still_since_us.get_or_insert(s.t_us);
        if s.t_us.saturating_sub(since) < self.config.settle_us {
            return DwellEvent::Settling;
        }
        let acc = &mut self.acc;
        if acc.n == 0 {
            acc.ref_axes = s.axes;
            acc.ref_dl = s.delta_l_um;
        }
        for ((sum, v), r) in acc.dp.iter_mut().zip(s.axes).zip(acc.ref_axes) {
            sum.add(v - r);
        }
        let d = s.delta_l_um - acc.ref_dl;
        acc.dl.add(d);
        acc.dl2.add(d * d);
        acc.n = acc.n.saturating_add(1);
        DwellEvent::Averaging
    }

    /// Closes an open dwell (call at the end of the program).
    pub fn finish(&mut self) {
        self.close();
    }

    fn close(&mut self) {
        self.still_since_us = None;
        if self.acc.n == 0 {
            return; // nothing to take (every moving sample comes here)
        }
        let acc = core::mem::take(&mut self.acc);
        if acc.n < self.config.min_samples {
            self.dropped_short = self.dropped_short.saturating_add(1);
            return;
        }
        let n = f64::from(acc.n);
        let mean = |k: usize| -> f64 {
            let r = acc.ref_axes.get(k).copied().unwrap_or(0.0);
            let s = acc.dp.get(k).map(|s| s.value()).unwrap_or(0.0);
            f64::from(r) + s / n
        };
        let m_dl = acc.dl.value() / n;
        let var = (acc.dl2.value() / n - m_dl * m_dl).max(0.0);
        let st = Station {
            p_mm: [mean(0), mean(1), mean(2)],
            rotary_deg: [mean(3) as f32, mean(4) as f32],
            delta_l_um: f64::from(acc.ref_dl) + m_dl,
            std_um: crate::num::sqrt(var) as f32,
            samples: acc.n,
        };
        match self.stations.get_mut(self.len) {
            Some(slot) => {
                *slot = st;
                self.len += 1;
            }
            None => self.dropped_full = self.dropped_full.saturating_add(1),
        }
    }
}
