//! Vibration and stick-slip: oscillations in time, not in angle, read from the samples a run
//! keeps about its reversal points ([`SpikeCapture`], 76 each, 12 before the crossing and 64
//! from it). At an axis's reversal point the bar lies along that axis, so the window reads the
//! axis's own motion (the other axis's enters with the sine of the window's angle, under 0.01
//! at F1000 on R 150 mm, 0.13 at F5000 on R 50 mm).
//!
//! Models (each axis in its own coordinates, t the time, Δt from the axis's reversal):
//! - **vibration**: the axis oscillates steadily, E = A·sin(2πf·t + φ) (a structural mode
//!   excited by the drives, a pump, an unbalance) — in every window, before and after the
//!   crossing alike;
//! - **stick-slip**: after the axis reverses, static friction holds it, then it slips, sticks
//!   and slips again while it moves slowly: E = a·sin(2πf_s·Δt + φ) from the crossing on (and
//!   not before). Within a window the axis's speed stays under 1 % of the feed (64 samples at
//!   1 kHz are 0.4° at F1000 on R 150 mm), so the oscillation's amplitude is taken as
//!   constant over it.
//!
//! Each window is fitted with the spike's local model (`super::spikes`: 1, t, t², the step,
//! the spike at the τ its own fit kept), the vibration's sin/cos over the whole window (and the
//! same times t: the other axis's vibration, read through the sine of the bar's angle from the
//! point, grows through the window) and the stick-slip's from the crossing — jointly, so
//! neither is read as the other or as a spike. The frequencies (one for each, the strongest,
//! common to a run's windows; each window has its own phases) are found by a scan of the
//! pooled residual over [`NU_SPAN`] in steps of half the window's resolution, refined by golden
//! section: each kind's scan alone keeps its two deepest minima, every pair of those four
//! (either kind at any) is tried, and the best pair refined, each kind in turn; a kind named
//! nowhere beside one that is named is then left out of the named one's fit. Two oscillations
//! closer than twice the resolution (1/32 of the sample rate: 31 Hz at 1 kHz) are one to the
//! fit. The spikes are then fitted again on the windows less the oscillations named (their u
//! grown by the oscillations' share of the spike's variance and of the residual's degrees of
//! freedom), and the oscillations with the spikes' new time constants (their frequencies
//! refined, not searched again). Why our own fit: it is the spike window's, a few hundred
//! 11 × 11 normal equations a run (≈ 0.7 s on the pod at worst, in the figures job).
//!
//! Reported per axis: the amplitude A (µm), from A² = the mean over the axis's windows of
//! a² + b² less the noise's share of it (unbiased), u from the coefficients' covariance; and the
//! frequency (Hz), u from the residual's curvature in it. An oscillation is **named** on an axis
//! when its coefficients' χ² (pooled noise) has a false-alarm probability below
//! [`OSCILLATION_FALSE_ALARM`] (which allows for the scan's maximum over the frequencies).

use super::spikes::{SPIKE_POST, SPIKE_PRE, SPIKE_WINDOW, Spike, SpikeCapture, Window, spike_of};
use crate::metrology::solve3::cholesky_solve;

/// The frequencies scanned, cycles per sample: from 2 cycles in the samples from the crossing
/// to 0.45 (at the Nyquist frequency, 0.5, a sine is zero at every sample).
pub const NU_SPAN: [f32; 2] = [2.0 / SPIKE_POST as f32, 0.45];

/// The scan's step, cycles per sample (half a window's resolution).
const NU_STEP: f32 = 0.5 / SPIKE_WINDOW as f32;

/// A χ² of an axis's oscillation coefficients is named a fault when its probability under
/// noise alone is below this: the scan's maximum over ≈ 30 independent frequencies and the
/// pairs of both kinds raise it; 1e-5 named one in 50 circles without an oscillation, 1e-6
/// none to one in 100 (`ballbar_spikes_mc.rs`).
pub const OSCILLATION_FALSE_ALARM: f32 = 1e-6;

/// The window model's columns: 1, t, t², the step, the spike, the vibration's sin and cos,
/// the same times t (the other axis's vibration, read with the sine of the bar's angle from
/// the point, which grows through the window), the stick-slip's sin and cos (t in units of
/// half a window from the crossing).
const COLS: usize = 11;
/// The spike's column.
const SPIKE: usize = 4;
/// The first column of the vibration.
const VIB: usize = 5;
/// The first column of the stick-slip.
const SLIP: usize = 9;

/// The two kinds of oscillation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OscillationKind {
    /// Steady, before and after the crossing.
    Vibration = 0,
    /// From the crossing on.
    StickSlip = 1,
}

/// One axis's oscillation in one run (or, [`Oscillation::both`], both).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AxisOscillation {
    /// A², µm²: the mean over the axis's windows of a² + b² less its noise share (may be
    /// negative where there is none).
    pub power_um2: f32,
    /// Its standard uncertainty, µm².
    pub u_power_um2: f32,
    /// χ² of the coefficients against the noise (2 degrees of freedom a window).
    pub chi2: f32,
    /// Windows (reversal points, runs) read.
    pub windows: u8,
}

impl AxisOscillation {
    /// The amplitude A, µm, and its standard uncertainty: √A² (0 for a negative A²), u(A²)/2A
    /// where A stands well above its u, √(u(A²)/2) at A = 0 (one smooth expression).
    pub fn amplitude_um(&self) -> (f32, f32) {
        let p = self.power_um2.max(0.0);
        let u = self.u_power_um2;
        let a = crate::num::sqrtf(p);
        (a, u / crate::num::sqrtf(4.0 * p + 2.0 * u))
    }

    /// The probability of a χ² this large from noise alone (2·windows degrees of freedom).
    pub fn false_alarm(&self) -> f32 {
        chi2_even_survival(self.chi2, usize::from(self.windows))
    }

    /// Significant: [`Self::false_alarm`] below [`OSCILLATION_FALSE_ALARM`].
    pub fn named(&self) -> bool {
        self.windows > 0 && self.false_alarm() < OSCILLATION_FALSE_ALARM
    }
}

/// One kind of oscillation in a run (or both runs): each axis's (`None`: none of its reversal
/// points crossed with a whole window) and the frequency.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Oscillation {
    /// Along u, along v.
    pub axes: [Option<AxisOscillation>; 2],
    /// The frequency, Hz, and its standard uncertainty (NaN: not told).
    pub frequency_hz: (f32, f32),
}

impl Oscillation {
    /// The test's oscillation from its CCW and CW runs: each axis's A² and χ² pooled (an axis
    /// needs windows in both runs), the frequency the runs' weighted by 1/u².
    pub fn both(a: &Self, b: &Self) -> Self {
        let axes = [0, 1].map(|i| match (a.axes.get(i), b.axes.get(i)) {
            (Some(Some(x)), Some(Some(y))) => Some(AxisOscillation {
                power_um2: 0.5 * (x.power_um2 + y.power_um2),
                u_power_um2: 0.5
                    * crate::num::sqrtf(
                        x.u_power_um2 * x.u_power_um2 + y.u_power_um2 * y.u_power_um2,
                    ),
                chi2: x.chi2 + y.chi2,
                windows: x.windows.saturating_add(y.windows),
            }),
            _ => None,
        });
        // each run's f·w and w = 1/u² (none where either is not finite); NaN where neither has
        let weigh = |(f, u): (f32, f32)| {
            let w = 1.0 / (u * u);
            if (f * w).is_finite() {
                (f * w, w)
            } else {
                (0.0, 0.0)
            }
        };
        let ((fa, wa), (fb, wb)) = (weigh(a.frequency_hz), weigh(b.frequency_hz));
        let w = wa + wb;
        Self {
            axes,
            frequency_hz: ((fa + fb) / w, crate::num::sqrtf(1.0 / w)),
        }
    }

    /// Named on either axis.
    pub fn named(&self) -> bool {
        self.axes.iter().flatten().any(AxisOscillation::named)
    }
}

/// A run's oscillations, by [`OscillationKind`].
pub type RunOscillations = [Oscillation; 2];

/// The probability that χ² with 2m degrees of freedom exceeds `x`: e^(−x/2)·Σ_{i<m} (x/2)^i/i!.
fn chi2_even_survival(x: f32, m: usize) -> f32 {
    let h = 0.5 * x.max(0.0);
    let (mut term, mut sum) = (1.0f32, 0.0f32);
    for i in 0..m {
        sum += term;
        term *= h / (i + 1) as f32;
    }
    libm::expf(-h) * sum
}

/// sin and cos of `x` (rad), by the pod's own f64 ones (`libm`'s sincosf costs 3.7 KiB of
/// flash for its large-argument reduction).
fn sin_cos(x: f32) -> (f32, f32) {
    let (s, c) = crate::num::sin_cos(f64::from(x));
    (s as f32, c as f32)
}

/// A window, the spike's time constant its own fit kept (samples; `None`: no spike column),
/// and whether the vibration's columns times t are in the model (they are not where the
/// frequencies are found: a frequency offset is a phase ramp, much like them).
#[derive(Clone, Copy)]
struct Read<'a> {
    w: &'a Window,
    tau: Option<f32>,
    modulated: bool,
}

/// The frequencies of the model (cycles per sample; `None`: the kind's columns left out).
type Nus = [Option<f32>; 2];

/// One window's normal equations for frequencies `nu`: Σ g gᵀ (lower triangle), Σ g·y, Σ y².
fn normal(r: Read, nu: Nus) -> ([[f32; COLS]; COLS], [f32; COLS], f32) {
    let mut a = [[0.0f32; COLS]; COLS];
    let mut b = [0.0f32; COLS];
    let mut yy = 0.0;
    let phase = r.w.phase;
    let half = 0.5 * SPIKE_WINDOW as f32;
    // each kind's sine and cosine, by rotation a sample at a time: the vibration's from the
    // window's first sample, the stick-slip's from the crossing
    let turn = |nu: Option<f32>| {
        let (s, c) = sin_cos(core::f32::consts::TAU * nu.unwrap_or(0.0));
        [c, s]
    };
    let (rot_v, rot_s) = (turn(nu[0]), turn(nu[1]));
    let mut vib = [1.0f32, 0.0];
    let (s0, c0) = sin_cos(core::f32::consts::TAU * nu[1].unwrap_or(0.0) * phase);
    let mut slip = [c0, s0];
    let rotate = |[c, s]: [f32; 2], [rc, rs]: [f32; 2]| [c * rc - s * rs, s * rc + c * rs];
    let (decay, mut spike) = match r.tau {
        Some(t) => (libm::expf(-1.0 / t), libm::expf(-phase / t)),
        None => (0.0, 0.0),
    };
    // the columns summed: up to the last present one (the spike's fits need 5 of 11)
    let used = if nu[1].is_some() {
        COLS
    } else if nu[0].is_some() {
        if r.modulated { SLIP } else { VIB + 2 }
    } else {
        SPIKE + 1
    };
    for k in 0..SPIKE_WINDOW {
        let after = k >= SPIKE_PRE;
        let x = (k as f32 - SPIKE_PRE as f32) / half;
        let on = |b: bool, v: f32| if b { v } else { 0.0 };
        let g: [f32; COLS] = [
            1.0,
            x,
            x * x,
            on(after, 1.0),
            on(after && r.tau.is_some(), spike),
            on(nu[0].is_some(), vib[1]),
            on(nu[0].is_some(), vib[0]),
            on(r.modulated && nu[0].is_some(), x * vib[1]),
            on(r.modulated && nu[0].is_some(), x * vib[0]),
            on(after && nu[1].is_some(), slip[1]),
            on(after && nu[1].is_some(), slip[0]),
        ];
        let y = r.w.reading(k);
        for (i, ((row, bi), gi)) in a
            .iter_mut()
            .zip(b.iter_mut())
            .zip(&g)
            .enumerate()
            .take(used)
        {
            // take, then zip: written as the diagnostics' normal equations write it, the
            // machine outliner (opt-level "z") made one call of both loops' bodies and doubled
            // the diagnoses' time (`cargo bench-m4`)
            for (x, gj) in row.iter_mut().take(i + 1).zip(&g) {
                *x += gi * gj;
            }
            *bi += gi * y;
        }
        yy += y * y;
        vib = rotate(vib, rot_v);
        if after {
            slip = rotate(slip, rot_s);
            spike *= decay;
        }
    }
    // a column left out: an identity row, its coefficient 0
    let absent = [
        false,
        false,
        false,
        false,
        r.tau.is_none(),
        nu[0].is_none(),
        nu[0].is_none(),
        !r.modulated || nu[0].is_none(),
        !r.modulated || nu[0].is_none(),
        nu[1].is_none(),
        nu[1].is_none(),
    ];
    for (i, (row, out)) in a.iter_mut().zip(absent).enumerate() {
        if out && let Some(d) = row.get_mut(i) {
            *d = 1.0;
        }
    }
    (a, b, yy)
}

/// The spike column's element of the inverse normal matrix of window `r` with frequencies `nu`.
fn spike_variance(r: Read, nu: Nus) -> Option<f32> {
    let (a, _, _) = normal(r, nu);
    let mut e = [0.0f32; COLS];
    if let Some(x) = e.get_mut(SPIKE) {
        *x = 1.0;
    }
    cholesky_solve(a, e)?.get(SPIKE).copied()
}

/// One window's fit: coefficients and residual sum of squares (µm²).
fn fit(r: Read, nu: Nus) -> Option<([f32; COLS], f32)> {
    let (a, b, yy) = normal(r, nu);
    let p = cholesky_solve(a, b)?;
    let rss = (yy - p.iter().zip(b).map(|(p, b)| p * b).sum::<f32>()).max(0.0);
    Some((p, rss))
}

/// The residual pooled over the windows (infinite where a fit fails).
fn pooled(reads: &[Option<Read>; 4], nu: Nus) -> f32 {
    reads
        .iter()
        .flatten()
        .map(|r| fit(*r, nu).map_or(f32::INFINITY, |(_, rss)| rss))
        .sum()
}

/// Candidate frequencies a scan keeps (its strongest peaks).
const CANDIDATES: usize = 2;

/// `nu` without kind `kind`'s columns.
fn with_none(nu: Nus, kind: usize) -> Nus {
    let mut n = nu;
    if let Some(x) = n.get_mut(kind) {
        *x = None;
    }
    n
}

/// `nu` with kind `kind`'s frequency set to `f`.
fn with(nu: Nus, kind: usize, f: f32) -> Nus {
    let mut n = nu;
    if let Some(x) = n.get_mut(kind) {
        *x = Some(f);
    }
    n
}

/// The [`CANDIDATES`] deepest local minima of the pooled residual over [`NU_SPAN`] with kind
/// `kind`'s frequency scanned and the other kind's columns left out (cycles per sample, NaN:
/// none).
fn scan(reads: &[Option<Read>; 4], kind: usize) -> [f32; CANDIDATES] {
    let [lo, hi] = NU_SPAN;
    let steps = ((hi - lo) / NU_STEP) as usize;
    let at = |j: usize| lo + NU_STEP * j as f32;
    let rss = |nu: f32| pooled(reads, with([None, None], kind, nu));
    let mut best = [(f32::INFINITY, f32::NAN); CANDIDATES];
    let (mut before, mut here) = (f32::INFINITY, rss(at(0)));
    for j in 0..=steps {
        let next = if j < steps {
            rss(at(j + 1))
        } else {
            f32::INFINITY
        };
        if here.is_finite() && here <= before && here <= next {
            // keep it in place of the shallowest kept, if deeper
            if let Some(slot) = best.iter_mut().max_by(|a, b| a.0.total_cmp(&b.0))
                && here < slot.0
            {
                *slot = (here, at(j));
            }
        }
        (before, here) = (here, next);
    }
    best.map(|(_, f)| f)
}

/// Kind `kind`'s frequency refined by golden section within a scan step of `nu`'s, the other
/// kind's held.
fn refine(reads: &[Option<Read>; 4], nu: Nus, kind: usize) -> Nus {
    let Some(Some(f)) = nu.get(kind).copied() else {
        return nu;
    };
    // 12 steps: 0.3 % of two scan steps, 0.04 Hz at 1 kHz (8 leave 0.26 Hz: more than a
    // strong vibration's u)
    let x = golden_min(f - NU_STEP, f + NU_STEP, 12, &|x| {
        pooled(reads, with(nu, kind, x))
    });
    with(nu, kind, x)
}

/// The minimum of `f` between `lo` and `hi` by golden section (`steps` steps: 12 leave 0.3 %
/// of the span, 8 leave 2 %).
pub(super) fn golden_min(mut lo: f32, mut hi: f32, steps: u32, f: &dyn Fn(f32) -> f32) -> f32 {
    const GOLD: f32 = 0.618_034;
    let (mut x1, mut x2) = (hi - GOLD * (hi - lo), lo + GOLD * (hi - lo));
    let (mut f1, mut f2) = (f(x1), f(x2));
    for _ in 0..steps {
        if f1 <= f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - GOLD * (hi - lo);
            f1 = f(x1);
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + GOLD * (hi - lo);
            f2 = f(x2);
        }
    }
    if f1 <= f2 { x1 } else { x2 }
}

/// One time constant's fit of a window's spike model (1, t, t², the step, the spike of time
/// constant `tau`, samples): `super::spikes`' τ scan.
pub(super) fn spike_fit(w: &Window, tau: f32) -> Option<TauFit> {
    let r = Read {
        w,
        tau: Some(tau),
        modulated: false,
    };
    let (a, b, yy) = normal(r, [None, None]);
    let p = cholesky_solve(a, b)?;
    let rss = (yy - p.iter().zip(b).map(|(p, b)| p * b).sum::<f32>()).max(0.0);
    let mut e = [0.0f32; COLS];
    if let Some(x) = e.get_mut(SPIKE) {
        *x = 1.0;
    }
    Some(TauFit {
        rss,
        h: p.get(SPIKE).copied()?,
        c_hh: cholesky_solve(a, e)?.get(SPIKE).copied()?,
    })
}

/// One time constant's fit of the spike model.
#[derive(Clone, Copy)]
pub(super) struct TauFit {
    /// Residual sum of squares, µm².
    pub(super) rss: f32,
    /// The spike's height, µm.
    pub(super) h: f32,
    /// (A⁻¹)_hh of the normal matrix.
    pub(super) c_hh: f32,
}

/// The two kinds' frequencies: each kind's scan alone gives candidates, every pair of them
/// (either kind at any candidate: a strong stick-slip is the vibration scan's deepest minimum
/// too) is tried, and the best pair refined, each kind in turn. Scanning one kind with the
/// other held instead can lock in the swapped pair.
fn frequencies(reads: &[Option<Read>; 4]) -> Option<Nus> {
    let v = scan(reads, 0);
    let s = scan(reads, 1);
    let mut best: Option<(f32, Nus)> = None;
    for a in v.iter().chain(&s).filter(|f| f.is_finite()) {
        for b in v.iter().chain(&s).filter(|f| f.is_finite()) {
            let nu = [Some(*a), Some(*b)];
            let r = pooled(reads, nu);
            if r.is_finite() && best.is_none_or(|(x, _)| r < x) {
                best = Some((r, nu));
            }
        }
    }
    let (_, nu) = best?;
    Some(refine(reads, refine(reads, refine(reads, nu, 0), 1), 0))
}

/// A run's reversal spikes and oscillations, fitted jointly.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RunReversals {
    /// The spike at each reversal point (0°, 90°, 180°, 270°; `None`: not crossed with a whole
    /// window, or no fit).
    pub spikes: [Option<Spike>; 4],
    /// The vibration and stick-slip (`None`: no window, or no fit).
    pub oscillations: Option<RunOscillations>,
}

/// Each window's fitted oscillations: the vibration's sin, cos and the stick-slip's sin, cos
/// coefficients (µm), and the frequencies.
type Fitted = ([Option<[f32; COLS]>; 4], Nus);

impl SpikeCapture {
    /// The run's spikes and oscillations, jointly: the spikes alone (their time constants), the
    /// oscillations with those, the spikes again on the windows less the oscillations fitted,
    /// and the oscillations with the spikes' new time constants.
    #[inline(never)] // at a run's end, once: its own frame, not in the caller's
    pub fn reversals(&self) -> RunReversals {
        let windows = self.windows();
        let first = windows.map(|w| w.and_then(spike_of));
        let Some((run, (coef, [Some(v), Some(s)]))) = oscillations(windows, &first, None) else {
            return RunReversals {
                spikes: first,
                oscillations: None,
            };
        };
        // a kind named on an axis comes off that axis's windows; noise fitted as an
        // oscillation would only shrink the spikes' residual
        let named = |kind: OscillationKind, p: usize| {
            run.get(kind as usize)
                .and_then(|o| o.axes.get(p % 2).copied().flatten())
                .is_some_and(|a| a.named())
        };
        let mut spikes = first;
        for (p, ((spike, w), c)) in spikes.iter_mut().zip(windows).zip(coef).enumerate() {
            if let (Some(w), Some(c)) = (w, c) {
                let (vib, slip) = (
                    named(OscillationKind::Vibration, p),
                    named(OscillationKind::StickSlip, p),
                );
                let c = |i: usize| c.get(i).copied().unwrap_or(0.0);
                let tau = core::f32::consts::TAU;
                let half = 0.5 * SPIKE_WINDOW as f32;
                // the named oscillations at their fitted coefficients (the window model's
                // columns VIB.., as `normal` builds them)
                let e = |k: usize| {
                    let t = (k as f32 - SPIKE_PRE as f32) / half;
                    let (sv, cv) = sin_cos(tau * v * k as f32);
                    let (ss, cs) = sin_cos(tau * s * (k as f32 - SPIKE_PRE as f32 + w.phase));
                    let vib = if vib {
                        (c(VIB) + c(VIB + 2) * t) * sv + (c(VIB + 1) + c(VIB + 3) * t) * cv
                    } else {
                        0.0
                    };
                    let slip = if slip && k >= SPIKE_PRE {
                        c(SLIP) * ss + c(SLIP + 1) * cs
                    } else {
                        0.0
                    };
                    vib + slip
                };
                let nu = [vib.then_some(v), slip.then_some(s)];
                *spike = spike_of(&w.less(e)).map(|mut h| {
                    // the spike's variance in the model with the oscillations taken off beside
                    // it, over that without them: its u grows by the columns' correlation
                    let read = Read {
                        modulated: true,
                        w,
                        tau: Some(h.tau_ms * 1e3 / w.period_us()),
                    };
                    let inflation = spike_variance(read, nu)
                        .zip(spike_variance(read, [None, None]))
                        .map_or(1.0, |(with, without)| with / without);
                    // and the residual's degrees of freedom the oscillations took (their
                    // columns and frequencies): the spike's fit counts only its own six
                    let own = (SPIKE_WINDOW - 6) as f32;
                    let taken = (5 * usize::from(vib) + 3 * usize::from(slip)) as f32;
                    let dof = own / (own - taken);
                    let inflation = inflation.max(1.0) * dof;
                    if inflation.is_finite() {
                        h.u_height_um *= crate::num::sqrtf(inflation);
                    }
                    h
                });
            }
        }
        RunReversals {
            spikes,
            oscillations: oscillations(windows, &spikes, Some([Some(v), Some(s)])).map(|(o, _)| o),
        }
    }
}

/// The vibration and stick-slip (by [`OscillationKind`]) in the complete `windows` with the
/// `spikes` found in them (their time constants), and each window's fitted oscillations;
/// `None` where no window is complete or no fit is possible.
fn oscillations(
    windows: [Option<&Window>; 4],
    spikes: &[Option<Spike>; 4],
    prior: Option<Nus>,
) -> Option<(RunOscillations, Fitted)> {
    let mut reads: [Option<Read>; 4] = [None; 4];
    let mut period_us = 0.0f32;
    let mut count = 0usize;
    for ((read, w), s) in reads.iter_mut().zip(windows).zip(spikes) {
        if let Some(w) = w {
            let p = w.period_us();
            let tau = s
                .map(|s| s.tau_ms * 1e3 / p)
                .filter(|t| t.is_finite() && *t > 0.0);
            *read = Some(Read {
                w,
                tau,
                modulated: false,
            });
            period_us += p;
            count += 1;
        }
    }
    if count == 0 || !(period_us > 0.0) {
        return None;
    }
    let period_s = period_us / count as f32 * 1e-6;
    // the frequencies found before (the spikes have only moved): refined, not searched again
    let nu = match prior {
        Some(nu) => refine(&reads, refine(&reads, nu, 0), 1),
        None => frequencies(&reads)?,
    };
    let run = [
        kind(&reads, nu, OscillationKind::Vibration, period_s)?,
        kind(&reads, nu, OscillationKind::StickSlip, period_s)?,
    ];
    // a kind named nowhere beside one that is: the named one again without the other's
    // columns (fitted to noise at a frequency near the named one's, they take part of it)
    let mut run = run;
    if let [a, b] = run.map(|o| o.named())
        && a != b
    {
        let (k, which) = if a {
            (0, OscillationKind::Vibration)
        } else {
            (1, OscillationKind::StickSlip)
        };
        let alone = refine(&reads, with_none(nu, 1 - k), k);
        if let Some(slot) = run.get_mut(k) {
            *slot = kind(&reads, alone, which, period_s)?;
        }
    }
    let mut coef = [None; 4];
    for (c, r) in coef.iter_mut().zip(&reads) {
        if let Some(r) = r {
            let (p, _) = fit(
                Read {
                    modulated: true,
                    ..*r
                },
                nu,
            )?;
            *c = Some(p);
        }
    }
    Some((run, (coef, nu)))
}

/// Kind `which`'s oscillation in the windows `reads` with frequencies `nu` (cycles per
/// sample; `period_s` the sample period, s).
fn kind(
    reads: &[Option<Read>; 4],
    nu: Nus,
    which: OscillationKind,
    period_s: f32,
) -> Option<Oscillation> {
    let (k, col) = match which {
        OscillationKind::Vibration => (0, VIB),
        OscillationKind::StickSlip => (1, SLIP),
    };
    // pooled noise: the residual over the samples less the coefficients and the frequencies
    let noise = |reads: &[Option<Read>; 4]| {
        let (mut rss, mut dof) = (0.0f32, 0.0f32);
        let present = nu.iter().filter(|f| f.is_some()).count();
        for r in reads.iter().flatten() {
            let (_, x) = fit(*r, nu)?;
            rss += x;
            let vib = if r.modulated { 4 } else { 2 };
            let columns =
                VIB + vib * usize::from(nu[0].is_some()) + 2 * usize::from(nu[1].is_some())
                    - usize::from(r.tau.is_none());
            dof += SPIKE_WINDOW.saturating_sub(columns) as f32;
        }
        Some((rss, rss / (dof - present as f32).max(1.0)))
    };
    let (rss, s2) = noise(reads)?;
    let reads = *reads;
    // the frequency's u from the residual's curvature about it, u² = 2s²/RSS'', in the
    // model without the other axis's share (with it, a frequency offset — a phase ramp —
    // is nearly a share, and the curvature is lost)
    let f = nu.get(k).copied().flatten()?;
    let h = 0.1 / SPIKE_WINDOW as f32;
    let curvature = (pooled(&reads, with(nu, k, f + h)) - 2.0 * rss
        + pooled(&reads, with(nu, k, f - h)))
        / (h * h);
    let u_nu = crate::num::sqrtf(2.0 * s2 / curvature);
    let u_nu = if u_nu.is_finite() { u_nu } else { f32::NAN };
    // the amplitudes with the other axis's share in the model
    let reads = reads.map(|r| {
        r.map(|r| Read {
            modulated: true,
            ..r
        })
    });
    let (_, s2) = noise(&reads)?;
    // each axis: the windows' A² and its variance (the coefficients'), summed (the
    // frequency's u moves A² by under a hundredth of its own u: the Monte Carlo with and
    // without it is the same)
    let mut axes: [Option<AxisOscillation>; 2] = [None; 2];
    for (p, r) in reads.iter().enumerate() {
        let Some(r) = r else { continue };
        let (a, b, _) = normal(*r, nu);
        let coef = cholesky_solve(a, b)?;
        let e = |i: usize| {
            let mut e = [0.0f32; COLS];
            if let Some(x) = e.get_mut(i) {
                *x = 1.0;
            }
            cholesky_solve(a, e)
        };
        let (ca, cb) = (e(col)?, e(col + 1)?);
        let pair = |p: &[f32; COLS]| {
            (
                p.get(col).copied().unwrap_or(0.0),
                p.get(col + 1).copied().unwrap_or(0.0),
            )
        };
        let (x, y) = pair(&coef);
        // the coefficients' covariance s²·C, C the 2 × 2 block of the inverse
        let c = [
            ca.get(col).copied().unwrap_or(0.0),
            ca.get(col + 1).copied().unwrap_or(0.0),
            cb.get(col + 1).copied().unwrap_or(0.0),
        ];
        let det = c[0] * c[2] - c[1] * c[1];
        if !(det > 0.0) {
            return None;
        }
        let chi2 = (x * x * c[2] - 2.0 * x * y * c[1] + y * y * c[0]) / det / s2;
        let power = x * x + y * y - s2 * (c[0] + c[2]);
        // var(a² + b²) for Gaussian (a, b): 4·βᵀΣβ + 2·tr(Σ²)
        let var = 4.0 * s2 * (x * x * c[0] + 2.0 * x * y * c[1] + y * y * c[2])
            + 2.0 * s2 * s2 * (c[0] * c[0] + 2.0 * c[1] * c[1] + c[2] * c[2]);
        if let Some(slot) = axes.get_mut(p % 2) {
            let o = slot.get_or_insert_default();
            // sums here, means below
            o.power_um2 += power;
            o.u_power_um2 += var;
            o.chi2 += chi2;
            o.windows = o.windows.saturating_add(1);
        }
    }
    for o in axes.iter_mut().flatten() {
        {
            let n = f32::from(o.windows.max(1));
            o.power_um2 /= n;
            o.u_power_um2 = crate::num::sqrtf(o.u_power_um2) / n;
        }
    }
    Some(Oscillation {
        axes,
        frequency_hz: (f / period_s, u_nu / period_s),
    })
}
