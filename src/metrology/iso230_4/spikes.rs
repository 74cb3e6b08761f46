//! Reversal spikes: the short, decaying error right after an axis reverses (static friction
//! holds the axis at the end of its travel while its command turns back, then the servo
//! catches up): E = h·e^(−Δt/τ) along the axis's previous direction of travel, Δt from the
//! reversal. At a reversal point the axis's direction is the bar's, so the bar reads it as an
//! outward spike of height h. It is narrower than the profile's 1° bins at most feeds
//! (τ = 10 ms at F1000 on R 150 mm is 0.06°), so the run keeps the samples themselves about
//! each reversal point it crosses — [`SPIKE_PRE`] before the crossing and [`SPIKE_POST`] from it,
//! 0.8 KiB a run — and fits the local model
//!
//! ΔL(k) = a + b·k + c·[k ≥ 0] + h·[k ≥ 0]·e^(−(k + φ)/τ), k the sample from the crossing,
//!
//! (a, b: the circle and the slow shapes about the point; c: the reversal step, the axis's
//! lost motion; φ the part of a sample period between the crossing and sample 0, from the two
//! samples' directions): linear for a given τ, so τ is scanned over [`TAU_SPAN`] (10 % steps)
//! and refined about the least residual. h's u: the larger of the first-order one with τ free
//! (τ's derivative as a fifth column) and, where τ is poorly told (a long spike is much like a
//! step over the window, and h is not linear in τ), h's u at fixed τ with the half-spread of h
//! over the τ whose residual is within s² of the least (the profile likelihood). Why our own
//! fit: the spike and the step share the crossing, a spike shorter than a sample is the one
//! sample after it, and the fit is bounded in time (≈ 95 small solves a point, 17.5 ms for a
//! run's four points on the pod: in the circle figures' job, `app::job`).

/// Samples kept before a reversal point's crossing.
pub const SPIKE_PRE: usize = 12;
/// Samples kept from the crossing on.
pub const SPIKE_POST: usize = 64;
/// Samples of a window.
pub const SPIKE_WINDOW: usize = SPIKE_PRE + SPIKE_POST;

/// The span of the spike's time constants tried, samples (a spike of 0.5 sample is the
/// crossing's sample alone; one of 24 samples is still told from a step in the window).
pub const TAU_SPAN: [f32; 2] = [0.5, 24.0];

/// Time constants scanned over [`TAU_SPAN`] before the refinement (10 % apart).
const SCAN: usize = 40;

/// A window's readings are stored as ΔL less its first sample's, in this unit (µm): ±327 µm
/// in an i16 (a window spans a fraction of a degree).
const STORE_UM: f32 = 0.01;

/// The samples about one reversal point.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Window {
    /// ΔL less `ref_um`, in [`STORE_UM`].
    dl: [i16; SPIKE_WINDOW],
    /// ΔL of the window's first sample, µm.
    ref_um: f32,
    /// Samples stored.
    filled: u8,
    /// Time of the first and the last sample stored, µs (the low 32 bits: a window spans
    /// milliseconds, the difference wraps correctly).
    t_us: [u32; 2],
    /// How long before the first sample from the crossing the run crossed the point, in
    /// sample periods (0 … 1, from the two samples' directions).
    phase: f32,
}

impl Window {
    const EMPTY: Self = Self {
        dl: [0; SPIKE_WINDOW],
        ref_um: 0.0,
        filled: 0,
        t_us: [0; 2],
        phase: 0.0,
    };

    fn push(&mut self, dl_um: f32, t_us: u32) {
        let k = usize::from(self.filled);
        if k >= SPIKE_WINDOW {
            return;
        }
        if k == 0 {
            self.ref_um = dl_um;
            self.t_us[0] = t_us;
        }
        let q = ((dl_um - self.ref_um) / STORE_UM).clamp(f32::from(i16::MIN), f32::from(i16::MAX));
        if let Some(x) = self.dl.get_mut(k) {
            *x = q as i16;
        }
        self.t_us[1] = t_us;
        self.filled = self.filled.saturating_add(1);
    }

    fn complete(&self) -> bool {
        usize::from(self.filled) == SPIKE_WINDOW
    }

    /// Sample `k`'s reading less the first's, µm.
    fn reading(&self, k: usize) -> f32 {
        f32::from(self.dl.get(k).copied().unwrap_or(0)) * STORE_UM
    }
}

/// One reversal point's spike in one run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spike {
    /// Height h, µm (> 0: outward, the axis held at the end of its travel).
    pub height_um: f32,
    /// Its standard uncertainty, µm (the fit's, for the time constant kept).
    pub u_height_um: f32,
    /// The time constant τ kept, ms.
    pub tau_ms: f32,
}

/// The samples about each reversal point one run crosses (the run's direction's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpikeCapture {
    /// The last [`SPIKE_PRE`] samples (ΔL µm, time µs: its low 32 bits), a ring.
    ring: [(f32, u32); SPIKE_PRE],
    /// Samples in the ring (at most [`SPIKE_PRE`]) and where the next goes.
    ring_len: u8,
    ring_at: u8,
    /// The quadrant of the last sample (0: 0°–90°, …), `None` before the run's first.
    quadrant: Option<u8>,
    /// The last sample's direction n.
    last_n: [f32; 2],
    /// The window being filled, by reversal point (0°, 90°, 180°, 270°).
    filling: Option<u8>,
    windows: [Window; 4],
}

impl Default for SpikeCapture {
    fn default() -> Self {
        Self::new()
    }
}

impl SpikeCapture {
    /// Nothing captured.
    pub const fn new() -> Self {
        Self {
            ring: [(0.0, 0); SPIKE_PRE],
            ring_len: 0,
            ring_at: 0,
            quadrant: None,
            last_n: [0.0; 2],
            filling: None,
            windows: [Window::EMPTY; 4],
        }
    }

    /// One sample of the run: ΔL (µm), its direction n from the centre (u, v), its time (µs).
    pub fn update(&mut self, dl_um: f32, [nu, nv]: [f32; 2], t_us: u64) {
        // the low 32 bits: a window's span is all that is read
        let t_us = t_us as u32;
        let q = match (nu >= 0.0, nv >= 0.0) {
            (true, true) => 0u8,
            (false, true) => 1,
            (false, false) => 2,
            (true, false) => 3,
        };
        if let Some(p) = self.filling {
            if let Some(w) = self.windows.get_mut(usize::from(p)) {
                w.push(dl_um, t_us);
                if w.complete() {
                    self.filling = None;
                }
            }
        } else if let Some(last) = self.quadrant
            && last != q
            && usize::from(self.ring_len) == SPIKE_PRE
        {
            // the point between two neighbouring quadrants: 0/1 → 90° (1), 1/2 → 180° (2),
            // 2/3 → 270° (3), 3/0 → 0° (0); a jump across two quadrants is no crossing
            let point = match (last, q) {
                (0, 1) | (1, 0) => Some(1u8),
                (1, 2) | (2, 1) => Some(2),
                (2, 3) | (3, 2) => Some(3),
                (3, 0) | (0, 3) => Some(0),
                _ => None,
            };
            if let Some(p) = point
                && let Some(w) = self.windows.get_mut(usize::from(p))
            {
                *w = Window::EMPTY;
                // the ring, oldest first, then this sample (the first from the crossing)
                for k in 0..SPIKE_PRE {
                    let i = (usize::from(self.ring_at) + k) % SPIKE_PRE;
                    if let Some(&(dl, t)) = self.ring.get(i) {
                        w.push(dl, t);
                    }
                }
                w.push(dl_um, t_us);
                // the sine of each sample's angle from the point (CCW positive): they straddle
                // zero, and the crossing lies between them in proportion
                let from_point = |[u, v]: [f32; 2]| match p {
                    0 => v,
                    1 => -u,
                    2 => -v,
                    _ => u,
                };
                let (before, after) = (from_point(self.last_n), from_point([nu, nv]));
                let phase = after / (after - before);
                w.phase = if phase.is_finite() {
                    phase.clamp(0.0, 1.0)
                } else {
                    0.0
                };
                self.filling = Some(p);
            }
        }
        self.quadrant = Some(q);
        self.last_n = [nu, nv];
        if let Some(slot) = self.ring.get_mut(usize::from(self.ring_at)) {
            *slot = (dl_um, t_us);
        }
        self.ring_at = ((usize::from(self.ring_at) + 1) % SPIKE_PRE) as u8;
        self.ring_len = self.ring_len.saturating_add(1).min(SPIKE_PRE as u8);
    }

    /// The spike at reversal point `p` (0: 0°, 1: 90°, 2: 180°, 3: 270°), if the run crossed it
    /// with a whole window on each side (`None` otherwise, or if no fit is possible).
    #[inline(never)] // at a run's end, four times: one small frame, not in the caller's
    pub fn spike(&self, p: usize) -> Option<Spike> {
        let w = self.windows.get(p).filter(|w| w.complete())?;
        let period_us = w.t_us[1].wrapping_sub(w.t_us[0]) as f32 / (SPIKE_WINDOW - 1) as f32;
        let base = Base::of(w);
        let [lo_tau, hi_tau] = TAU_SPAN.map(libm::logf);
        let at = |j: usize| lo_tau + (hi_tau - lo_tau) * j as f32 / (SCAN - 1) as f32;
        // the scan's least residual, then refined between its neighbours (golden section on
        // ln τ): a τ between two steps biases h
        let mut best: Option<(f32, usize)> = None;
        for j in 0..SCAN {
            if let Some(f) = base.fit(w, libm::expf(at(j)))
                && best.is_none_or(|(r, _)| f.rss < r)
            {
                best = Some((f.rss, j));
            }
        }
        let (_, i) = best?;
        let (mut lo, mut hi) = (at(i.saturating_sub(1)), at((i + 1).min(SCAN - 1)));
        let rss_at = |ln_tau: f32| {
            base.fit(w, libm::expf(ln_tau))
                .map_or(f32::INFINITY, |f| f.rss)
        };
        const GOLD: f32 = 0.618_034;
        let (mut x1, mut x2) = (hi - GOLD * (hi - lo), lo + GOLD * (hi - lo));
        let (mut f1, mut f2) = (rss_at(x1), rss_at(x2));
        for _ in 0..12 {
            if f1 <= f2 {
                hi = x2;
                (x2, f2) = (x1, f1);
                x1 = hi - GOLD * (hi - lo);
                f1 = rss_at(x1);
            } else {
                lo = x1;
                (x1, f1) = (x2, f2);
                x2 = lo + GOLD * (hi - lo);
                f2 = rss_at(x2);
            }
        }
        let tau = libm::expf(if f1 <= f2 { x1 } else { x2 });
        let f = base.fit(w, tau)?;
        let (rss, h) = (f.rss, f.h);
        let s2 = rss / (SPIKE_WINDOW - 5) as f32;
        let var_fixed = s2 * f.c_hh;
        let var_linear = base.var_h_tau_free(w, tau, h).map_or(var_fixed, |c| s2 * c);
        // where τ is poorly told (a long spike is much like a step over the window) h is not
        // linear in it: the profile likelihood's one-standard-deviation interval of h, the h
        // whose residual, τ free, is within s² of the least — at each τ scanned, h(τ) ± its u
        // at that τ times the share of s² its residual leaves
        let (mut h_lo, mut h_hi) = (h, h);
        for j in 0..SCAN {
            if let Some(g) = base.fit(w, libm::expf(at(j)))
                && g.rss <= rss + s2
            {
                let reach = crate::num::sqrtf((rss + s2 - g.rss).max(0.0) * g.c_hh);
                h_lo = h_lo.min(g.h - reach);
                h_hi = h_hi.max(g.h + reach);
            }
        }
        let half = 0.5 * (h_hi - h_lo);
        let var_h = var_linear.max(var_fixed).max(half * half);
        Some(Spike {
            height_um: h,
            u_height_um: crate::num::sqrtf(var_h),
            tau_ms: tau * period_us * 1e-3,
        })
    }
}

/// One τ's fit of the local model.
struct TauFit {
    /// Residual sum of squares, µm².
    rss: f32,
    /// The spike's height, µm.
    h: f32,
    /// (A⁻¹)_hh of the normal matrix.
    c_hh: f32,
}

/// The sums of the window that do not depend on τ: the columns 1, k, the step over all
/// samples, and the readings (the spike's column is summed per τ over the samples from the
/// crossing, by a recurrence: e^(−(k+1+φ)/τ) = e^(−(k+φ)/τ)·e^(−1/τ)).
struct Base {
    /// Σ g gᵀ of (1, k, step), Σ g·y, Σ y².
    a: [[f32; 3]; 3],
    b: [f32; 3],
    yy: f32,
}

impl Base {
    fn of(w: &Window) -> Self {
        let mut a = [[0.0f32; 3]; 3];
        let mut b = [0.0f32; 3];
        let mut yy = 0.0;
        for k in 0..SPIKE_WINDOW {
            let [g0, g1, g2, _] = columns(k, 0.0, 1.0);
            let g = [g0, g1, g2];
            let y = w.reading(k);
            for (row, (br, gr)) in a.iter_mut().zip(b.iter_mut().zip(g)) {
                for (x, gc) in row.iter_mut().zip(g) {
                    *x += gr * gc;
                }
                *br += gr * y;
            }
            yy += y * y;
        }
        Self { a, b, yy }
    }

    /// The fit for time constant `tau` (samples).
    fn fit(&self, w: &Window, tau: f32) -> Option<TauFit> {
        let ratio = libm::expf(-1.0 / tau);
        let mut e = libm::expf(-w.phase / tau);
        // Σ e, Σ e·k, Σ e², Σ e·y over the samples from the crossing (the step is 1 there)
        let (mut se, mut sxe, mut see, mut sye) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        for k in SPIKE_PRE..SPIKE_WINDOW {
            let x = (k - SPIKE_PRE) as f32;
            se += e;
            sxe += x * e;
            see += e * e;
            sye += w.reading(k) * e;
            e *= ratio;
        }
        let [[a00, a01, a02], [_, a11, a12], [_, _, a22]] = self.a;
        let a = [
            [a00, a01, a02, se],
            [a01, a11, a12, sxe],
            [a02, a12, a22, se],
            [se, sxe, se, see],
        ];
        let [b0, b1, b2] = self.b;
        let b = [b0, b1, b2, sye];
        let p = crate::metrology::solve3::cholesky_solve(a, b)?;
        let [.., c_hh] = crate::metrology::solve3::cholesky_solve(a, [0.0, 0.0, 0.0, 1.0])?;
        let rss = (self.yy - p.iter().zip(b).map(|(p, b)| p * b).sum::<f32>()).max(0.0);
        Some(TauFit { rss, h: p[3], c_hh })
    }

    /// (A⁻¹)_hh with τ free too, to first order: the model's derivative in τ,
    /// h·e^(−(k+φ)/τ)·(k+φ)/τ², as a fifth column; `None` where it is singular (a spike too
    /// small to tell its τ).
    fn var_h_tau_free(&self, w: &Window, tau: f32, h: f32) -> Option<f32> {
        let mut a = [[0.0f32; 5]; 5];
        for k in 0..SPIKE_WINDOW {
            let g4 = columns(k, w.phase, tau);
            let x = (k as f32 - SPIKE_PRE as f32).max(0.0) + w.phase;
            let g = [g4[0], g4[1], g4[2], g4[3], h * g4[3] * x / (tau * tau)];
            for (row, gr) in a.iter_mut().zip(g) {
                for (x, gc) in row.iter_mut().zip(g) {
                    *x += gr * gc;
                }
            }
        }
        match crate::metrology::solve3::cholesky_solve(a, [0.0, 0.0, 0.0, 1.0, 0.0]) {
            Some([.., c, _]) if c.is_finite() && c > 0.0 => Some(c),
            _ => None,
        }
    }
}

/// The local model's columns at window sample `k` for a spike of time constant `tau` (samples)
/// that began `phase` of a sample before the first sample from the crossing: 1, k, the step,
/// the spike.
fn columns(k: usize, phase: f32, tau: f32) -> [f32; 4] {
    let x = k as f32 - SPIKE_PRE as f32;
    let after = if k >= SPIKE_PRE { 1.0 } else { 0.0 };
    let decay = libm::expf(-(x.max(0.0) + phase) / tau);
    [1.0, x, after, after * decay]
}
