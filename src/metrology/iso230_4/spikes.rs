//! Reversal spikes: the short, decaying error right after an axis reverses (static friction
//! holds the axis at the end of its travel while its command turns back, then the servo
//! catches up): E = h·e^(−Δt/τ) along the axis's previous direction of travel, Δt from the
//! reversal. At a reversal point the axis's direction is the bar's, so the bar reads it as an
//! outward spike of height h. It is narrower than the profile's 1° bins at most feeds
//! (τ = 10 ms at F1000 on R 150 mm is 0.06°), so the run keeps the samples themselves about
//! each reversal point it crosses — [`SPIKE_PRE`] before the crossing and [`SPIKE_POST`] from it,
//! 0.8 KiB a run — and fits the local model
//!
//! ΔL(k) = a + b·k + c·k² + d·[k ≥ 0] + h·[k ≥ 0]·e^(−(k + φ)/τ), k the sample from the crossing,
//!
//! (a, b, c: the circle and the slow shapes about the point, c its curvature over a window at
//! high feeds; d: the reversal step, the axis's lost motion; φ the part of a sample period
//! between the crossing and sample 0, from the two samples' directions): linear for a given τ,
//! so τ is scanned over [`TAU_SPAN`] (10 % steps) and refined about the least residual
//! (`super::oscillation`'s window model without its oscillations: one normal-equation build
//! for both). h's u: the larger of its u at the τ kept and, where τ is poorly told (a long
//! spike is much like a step over the window, and h is not linear in τ), the profile
//! likelihood's: half of the two-standard-deviation interval's half-width, the h whose
//! residual, τ free, is within 4s² of the least (a skewed likelihood's 2u is its 95 % interval,
//! not twice its 1σ). Where the run vibrates or sticks and slips
//! ([`SpikeCapture::reversals`]), the spike is fitted again on the window less the oscillations
//! named. Why our own fit: the spike and the step share the crossing, a spike shorter than a
//! sample is the one sample after it, and the fit is bounded in time (in the circle figures'
//! job, `app::job`).

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

/// `q` to the nearest i16 (half away from zero; `as` saturates beyond the range).
fn round_i16(q: f32) -> i16 {
    (q + if q >= 0.0 { 0.5 } else { -0.5 }) as i16
}

/// The samples about one reversal point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Window {
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
    pub(super) phase: f32,
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
        let q = (dl_um - self.ref_um) / STORE_UM;
        if let Some(x) = self.dl.get_mut(k) {
            // rounded: truncation would pull every reading 0.005 µm towards the first, an
            // oscillation's amplitude with it
            *x = round_i16(q);
        }
        self.t_us[1] = t_us;
        self.filled = self.filled.saturating_add(1);
    }

    pub(super) fn complete(&self) -> bool {
        usize::from(self.filled) == SPIKE_WINDOW
    }

    /// The window's sample period, µs (its span over its samples).
    pub(super) fn period_us(&self) -> f32 {
        self.t_us[1].wrapping_sub(self.t_us[0]) as f32 / (SPIKE_WINDOW - 1) as f32
    }

    /// The window with `e(k)` (µm) taken off each sample `k`'s reading.
    pub(super) fn less(&self, e: impl Fn(usize) -> f32) -> Self {
        let mut w = *self;
        for (k, x) in w.dl.iter_mut().enumerate() {
            let q = f32::from(*x) - e(k) / STORE_UM;
            *x = round_i16(q);
        }
        w
    }

    /// Sample `k`'s reading less the first's, µm.
    pub(super) fn reading(&self, k: usize) -> f32 {
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
        self.windows
            .get(p)
            .filter(|w| w.complete())
            .and_then(spike_of)
    }

    /// The complete window about each reversal point (0°, 90°, 180°, 270°).
    pub(super) fn windows(&self) -> [Option<&Window>; 4] {
        [0, 1, 2, 3].map(|p| self.windows.get(p).filter(|w| w.complete()))
    }
}

/// The spike in a complete window.
pub(super) fn spike_of(w: &Window) -> Option<Spike> {
    let period_us = w.period_us();
    let fit = |tau: f32| super::oscillation::spike_fit(w, tau);
    let [lo_tau, hi_tau] = TAU_SPAN.map(libm::logf);
    let at = |j: usize| lo_tau + (hi_tau - lo_tau) * j as f32 / (SCAN - 1) as f32;
    // the scan's least residual, then refined between its neighbours (golden section on
    // ln τ): a τ between two steps biases h
    // (kept for the profile likelihood below: each is an 11 × 11 build and two solves)
    let mut scanned: [Option<super::oscillation::TauFit>; SCAN] = [None; SCAN];
    for (j, f) in scanned.iter_mut().enumerate() {
        *f = fit(libm::expf(at(j)));
    }
    let mut best: Option<(f32, usize)> = None;
    for (j, f) in scanned.iter().enumerate() {
        if let Some(f) = f
            && best.is_none_or(|(r, _)| f.rss < r)
        {
            best = Some((f.rss, j));
        }
    }
    let (_, i) = best?;
    let ln_tau = super::oscillation::golden_min(
        at(i.saturating_sub(1)),
        at((i + 1).min(SCAN - 1)),
        12,
        &|ln_tau| fit(libm::expf(ln_tau)).map_or(f32::INFINITY, |f| f.rss),
    );
    let tau = libm::expf(ln_tau);
    let f = fit(tau)?;
    let (rss, h) = (f.rss, f.h);
    // 1, t, t², the step, the spike and τ
    let s2 = rss / (SPIKE_WINDOW - 6) as f32;
    let var_fixed = s2 * f.c_hh;
    // where τ is poorly told (a long spike is much like a step over the window) h is not
    // linear in it: the profile likelihood's two-standard-deviation interval of h, the h
    // whose residual, τ free, is within 4s² of the least — at each τ scanned, h(τ) ± its u
    // at that τ times the share of 4s² its residual leaves; u is half its half-width
    let (mut h_lo, mut h_hi) = (h, h);
    for g in scanned.iter().flatten() {
        if g.rss <= rss + 4.0 * s2 {
            let reach = crate::num::sqrtf((rss + 4.0 * s2 - g.rss).max(0.0) * g.c_hh);
            h_lo = h_lo.min(g.h - reach);
            h_hi = h_hi.max(g.h + reach);
        }
    }
    let half = 0.25 * (h_hi - h_lo);
    Some(Spike {
        height_um: h,
        u_height_um: crate::num::sqrtf(var_fixed.max(half * half)),
        tau_ms: tau * period_us * 1e-3,
    })
}
