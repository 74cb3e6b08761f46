//! Streaming SSM: E at every sample from the samples of its neighbourhood (DESIGN §7).
//!
//! The neighbourhood is a trailing window of at most `W` samples whose nominal points lie
//! within `radius_mm` of the current one and whose rotary axes did not move (a rotary move
//! empties the window). The normal equations are kept as **exact integer sums**: u quantised
//! to Q24 (6e-8, the f32 resolution), y to Q16 µm (1.5e-5 µm), products accumulated in i64
//! (one SMLAL each on the M4). Entering *and leaving* samples are then added and subtracted
//! without any drift, which a sliding window of compensated float sums cannot guarantee. The
//! sums are taken of v = u − u_ref, u_ref a reference direction moved to the window's mean
//! direction (an exact O(1) shift of the sums) only when the mean has drifted so far that Σv
//! would leave the i32 range (1/4 rad for the pod's 256-sample window: a shift every quarter
//! radian of turn). G = Σ u uᵀ and b = Σ u y follow exactly (wrapping i64 arithmetic; their
//! true values are in range, so the modular results are exact), and so do the window's
//! *centred* sums n Σvvᵀ − Σv Σvᵀ = n² C and n Σvy − Σv Σy = n² c, the scatter of the
//! directions — which decides what E the path can see — and their covariance with y.
//!
//! Two solves of the same sums:
//! - [`StreamingSsm::live`], every sample (≈ 515 instructions, f32 on the FPU): the live E,
//!   solved on the window's mean and scatter (below), with the observability rule of
//!   [`super::solve_normal`]; [`StreamingSsm::live_with_uncertainty`] adds each component's
//!   standard uncertainty (the window's residual and the bar), from the same solve and one
//!   more exact sum, Σ y/16;
//! - [`StreamingSsm::estimate`] (f64, soft-float on the M4, with the full observability
//!   analysis of G) and [`StreamingSsm::estimate_refined`] on the exact sphere equation.
//!
//! The live solve: with m the mean direction, C the covariance of the directions and c their
//! covariance with y (both from the exact centred sums, one f32 rounding), G/n = C + m mᵀ and
//! b/n = c + m ȳ. In an orthonormal basis (t₁, t₂, m̂) the m̂ row gives
//! E_m = (|m| ȳ + c_m − C_mt E_t)/(|m|² + C_mm), and the tangent rows the 2×2 Schur complement
//! S E_t = c_t − C_tm α: only C and c, of the size of the window's spread (≈ 10⁻⁴ for a 5 mm window at 150 mm), enter the small
//! eigenvalues, so f32 resolves them far below the 10⁻⁹ observability threshold; forming G
//! in f32 would lose them.
//!
//! Precision: positions arrive as f32 mm (61 nm ulp at 1000 mm) and y uses |P − P0| in f32
//! (~15 nm at 150 mm); E is therefore good to a few tens of nm times the condition number,
//! which is what a 0.1 µm streaming target needs. Use stations for nm work.
//!
//! One file of about 900 lines on purpose: the window's add, remove, re-reference and solve
//! keep one invariant together (the sums stay exact integers), and each is read with the others.

use super::{
    OBSERVABLE_AXIS_TOL, SsmError, SsmGeometry, SsmSolution, UNOBSERVABLE_EIG_RATIO, solve_normal,
};
use crate::acquisition::Sample;
use crate::in_place::{self, init_in_place};
use crate::metrology::bar_budget::BarBudget;
use crate::metrology::solve3::Sym3;
use core::mem::MaybeUninit;

const U_SCALE: f32 = 16_777_216.0; // 2^24
const Y_SCALE: f32 = 65_536.0; // 2^16 per µm
const P_SCALE: f32 = 65_536.0; // 2^16 per mm (positions relative to the socket)
/// |y| accepted by the streaming estimator, µm (keeps every i64 sum exact for W ≤ 2048).
pub const MAX_ABS_Y_UM: f32 = 4000.0;

/// Configuration of a [`StreamingSsm`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamingConfig {
    /// Socket position and bar length.
    pub geometry: SsmGeometry,
    /// Neighbourhood radius: samples farther than this from the current nominal point leave
    /// the window, mm.
    pub radius_mm: f32,
    /// A rotary axis moving more than this from the window's reference empties the window, deg.
    pub rotary_tol_deg: f32,
}

/// What [`StreamingSsm::update`] did with a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StreamUse {
    /// Added to the window.
    Used,
    /// Added; the rotary axes had moved, so the window was emptied first.
    UsedAfterRotaryMove,
    /// Flagged invalid for metrology: skipped and counted.
    SkippedFlagged,
    /// Not finite, within 1 mm of the socket or farther than 3162 mm, or |y| > [`MAX_ABS_Y_UM`]:
    /// skipped and counted.
    SkippedInvalid,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct Entry {
    u: [i32; 3],
    y: i32,
    d: [i32; 3],
}

/// The window's exact sums, mod 2⁶⁴ (see the module doc): of v = u − u_ref (Q24), y (Q16 µm)
/// and the positions d (Q16 mm).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct Sums {
    /// Σ v.
    v: [i64; 3],
    /// Σ v vᵀ (00, 01, 02, 11, 12, 22).
    vv: [i64; 6],
    /// Σ v y.
    vy: [i64; 3],
    /// Σ y.
    y: i64,
    /// Σ (y/16)².
    yy: i64,
    /// Σ y/16 (Q12 µm): the same truncated y as `yy`, so that n Σ(y/16)² − (Σ y/16)² is
    /// n² times the variance of y exactly (the live E's residual,
    /// [`StreamingSsm::live_with_uncertainty`]).
    y16: i64,
    /// Σ d.
    d: [i64; 3],
}

impl Sums {
    /// Adds (`ADD`) or removes an entry, relative to `r` = u_ref: i32×i32→i64 products and
    /// 64-bit adds, exact. Written on the i32 values directly so that each product compiles to
    /// one SMLAL on the M4, not a 64×64 multiply; a removal multiplies by the negated first
    /// factor (exact: every factor is below 2³⁰ in magnitude), so it is SMLALs too.
    #[inline(always)]
    fn apply<const ADD: bool>(&mut self, e: &Entry, r: &[i32; 3]) {
        #[inline(always)]
        fn mac(s: &mut i64, a: i32, b: i32) {
            *s = s.wrapping_add(i64::from(a) * i64::from(b));
        }
        #[inline(always)]
        fn add(s: &mut i64, a: i32) {
            *s = s.wrapping_add(i64::from(a));
        }
        // |u − u_ref| ≤ 2²⁵: an i32
        let [v0, v1, v2] = [
            e.u[0].wrapping_sub(r[0]),
            e.u[1].wrapping_sub(r[1]),
            e.u[2].wrapping_sub(r[2]),
        ];
        let y = e.y;
        let y8 = y >> 4; // Q12: y² < 2^48 per term
        let [d0, d1, d2] = e.d;
        // the signed first factors
        let sg = |x: i32| if ADD { x } else { x.wrapping_neg() };
        let [s0, s1, s2, sy, sy8] = [sg(v0), sg(v1), sg(v2), sg(y), sg(y8)];
        let [g0, g1, g2, g3, g4, g5] = &mut self.vv;
        mac(g0, s0, v0);
        mac(g1, s0, v1);
        mac(g2, s0, v2);
        mac(g3, s1, v1);
        mac(g4, s1, v2);
        mac(g5, s2, v2);
        let [b0, b1, b2] = &mut self.vy;
        mac(b0, s0, y);
        mac(b1, s1, y);
        mac(b2, s2, y);
        mac(&mut self.yy, sy8, y8);
        add(&mut self.y16, sy8);
        add(&mut self.y, sy);
        // written out: an array loop here is an out-of-line iterator call at opt-level "z"
        let [t0, t1, t2] = &mut self.v;
        add(t0, s0);
        add(t1, s1);
        add(t2, s2);
        let [p0, p1, p2] = &mut self.d;
        add(p0, sg(d0));
        add(p1, sg(d1));
        add(p2, sg(d2));
    }

    /// The sums of a window of one entry, relative to its own direction (v = 0).
    fn first(e: &Entry) -> Self {
        let [d0, d1, d2] = e.d;
        let y8 = e.y >> 4;
        Self {
            y: i64::from(e.y),
            yy: i64::from(y8) * i64::from(y8),
            y16: i64::from(y8),
            d: [i64::from(d0), i64::from(d1), i64::from(d2)],
            ..Self::default()
        }
    }

    /// The same sums relative to u_ref + `delta` (v' = v − Δ), exactly (mod 2⁶⁴): with
    /// w = Σv' = Σv − nΔ, Σv'v'ᵀ = Σvvᵀ − Δ wᵀ − Σv Δᵀ (on the diagonal Δᵢ(wᵢ + Σvᵢ)) and
    /// Σv'y = Σvy − Δ Σy. Straight-line: it runs whenever the window has turned.
    #[inline(always)]
    fn shift(&mut self, delta: [i32; 3], n: i32) {
        // an i32 times a 64-bit sum, mod 2⁶⁴
        let m = |d: i32, x: i64| i64::from(d).wrapping_mul(x);
        let [v0, v1, v2] = self.v;
        let [d0, d1, d2] = delta;
        let w0 = v0.wrapping_sub(i64::from(n) * i64::from(d0));
        let w1 = v1.wrapping_sub(i64::from(n) * i64::from(d1));
        let w2 = v2.wrapping_sub(i64::from(n) * i64::from(d2));
        let [g0, g1, g2, g3, g4, g5] = &mut self.vv;
        *g0 = g0.wrapping_sub(m(d0, w0.wrapping_add(v0)));
        *g1 = g1.wrapping_sub(m(d0, w1).wrapping_add(m(d1, v0)));
        *g2 = g2.wrapping_sub(m(d0, w2).wrapping_add(m(d2, v0)));
        *g3 = g3.wrapping_sub(m(d1, w1.wrapping_add(v1)));
        *g4 = g4.wrapping_sub(m(d1, w2).wrapping_add(m(d2, v1)));
        *g5 = g5.wrapping_sub(m(d2, w2.wrapping_add(v2)));
        let y = self.y;
        let [b0, b1, b2] = &mut self.vy;
        *b0 = b0.wrapping_sub(m(d0, y));
        *b1 = b1.wrapping_sub(m(d1, y));
        *b2 = b2.wrapping_sub(m(d2, y));
        self.v = [w0, w1, w2];
    }
}

/// Index pairs of the six sums of a symmetric 3×3, in [`Sums::vv`] order.
const PAIRS: [(usize, usize); 6] = [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)];

/// p · q.
#[inline(always)]
fn dot(p: [f32; 3], q: [f32; 3]) -> f32 {
    let ([p0, p1, p2], [q0, q1, q2]) = (p, q);
    p0 * q0 + p1 * q1 + p2 * q2
}

/// m v.
#[inline(always)]
fn times(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    let [r0, r1, r2] = *m;
    [dot(r0, v), dot(r1, v), dot(r2, v)]
}

/// An i64 as f32 from its two words (two roundings, ≤ 1 ulp: the live solve's inputs).
#[inline(always)]
fn f32_of(x: i64) -> f32 {
    ((x >> 32) as i32 as f32) * 4_294_967_296.0 + (x as u32) as f32
}

/// A streaming SSM estimate: E for the current neighbourhood.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamingEstimate {
    /// The solution (E µm, condition number, observability).
    pub solution: SsmSolution,
    /// Mean nominal point of the window (where E applies), mm.
    pub centroid_mm: [f64; 3],
}

/// Smallest eigenvalue of the live solve's tangent-plane matrix, relative to its largest,
/// that f32 resolves (128 ε: the matrix is a few f32 products of the directions' covariance,
/// each rounded); a direction below it is not observable in the live E.
pub const LIVE_EIG_RESOLUTION: f32 = 128.0 * f32::EPSILON;

/// Fewest residual degrees of freedom (samples less the components the path sees) for which
/// the live E states a Type A u: below, the scatter's own estimate is too loose for U = 2u to
/// cover 95 % (Student's t at 30 dof is 2.04).
pub const LIVE_MIN_DOF: u32 = 30;
/// Smallest per-sample scatter the live E's Type A u assumes, µm: the 0.1 µm resolution of the
/// readings (q/√12). A window that fits better than that is not believed to.
pub const LIVE_SIGMA_FLOOR_UM: f32 = 0.028_867_513;

/// The parts of a live solve that the live E's u needs (f32, as the solve has them).
#[derive(Debug, Clone, Copy, Default)]
struct LiveParts {
    /// Covariance of the window's directions.
    cov: [[f32; 3]; 3],
    /// Covariance of the directions with y, µm.
    cy: [f32; 3],
    /// Mean y, µm.
    ybar: f32,
    /// The basis (t₁, t₂, m̂).
    basis: [[f32; 3]; 3],
    /// |m|, the mean direction's length.
    mm: f32,
    /// |m|² + C_mm.
    den: f32,
    /// The coupling (C_t₁m, C_t₂m)/den.
    b: [f32; 2],
    /// The tangent plane's Schur complement (00, 01, 11).
    schur: [f32; 3],
    /// Its larger eigenvalue.
    l_max: f32,
    /// E in the axes (every component, seen or not), µm.
    e: [f32; 3],
    /// Which components the path sees.
    seen: [bool; 3],
    /// The unseen tangent direction (−q, p), if any.
    null: Option<[f32; 2]>,
}

/// Streaming SSM over a fixed window of `W` samples (4 ≤ W ≤ 2048).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamingSsm<const W: usize> {
    config: StreamingConfig,
    socket_f32: [f32; 3],
    bar_length_f32: f32,
    /// (radius in Q16 mm)², for the neighbourhood test.
    radius2_q: f32,
    ring: [Entry; W],
    /// Index of the oldest entry and number of entries.
    tail: usize,
    len: usize,
    /// Index of the current window's first entry.
    start: usize,
    sums: Sums,
    /// The reference direction of the sums, Q24.
    u_ref: [i32; 3],
    rotary_ref_deg: [f32; 2],
    skipped_flagged: u32,
    skipped_invalid: u32,
    evicted_full: u32,
}

impl<const W: usize> StreamingSsm<W> {
    const CHECK: () = assert!(W >= 4 && W <= 2048, "window must be 4..=2048 samples");

    /// An empty estimator.
    pub fn new(config: StreamingConfig) -> Self {
        in_place::build(|s| Self::init(s, config))
    }

    /// [`StreamingSsm::new`] built in place in `slot` (no stack copy of the window).
    pub fn init(slot: &mut MaybeUninit<Self>, config: StreamingConfig) -> &mut Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::CHECK;
        let [x, y, z] = config.geometry.socket_mm;
        init_in_place!(slot, Self {
            config: config,
            socket_f32: [x as f32, y as f32, z as f32],
            bar_length_f32: config.geometry.bar_length_mm as f32,
            radius2_q: (config.radius_mm * P_SCALE) * (config.radius_mm * P_SCALE),
            tail: 0,
            len: 0,
            start: 0,
            sums: Sums::default(),
            u_ref: [0; 3],
            rotary_ref_deg: [0.0; 2],
            skipped_flagged: 0,
            skipped_invalid: 0,
            evicted_full: 0,
        } in place {
            ring: |s| in_place::fill(s, Entry::default()),
        })
    }

    /// Samples in the current neighbourhood.
    pub fn window_len(&self) -> usize {
        self.len
    }

    /// True while the window only grows: no sample has left it since it started (the first
    /// sample after [`Self::clear`], a rotary move, the estimator's start, or every sample
    /// having left). Read off the ring's oldest index, which stays at the window's first
    /// until a sample leaves (and passes it again for one sample in `W`, where this is true by
    /// mistake: nothing more on the per-sample path).
    pub fn is_growing(&self) -> bool {
        self.tail == self.start
    }

    /// Samples skipped as flagged invalid.
    pub fn skipped_flagged(&self) -> u32 {
        self.skipped_flagged
    }

    /// Samples skipped as not finite, at the socket or out of range.
    pub fn skipped_invalid(&self) -> u32 {
        self.skipped_invalid
    }

    /// Samples that left the window only because it was full (W too small for the radius at
    /// this feed rate; counted, not hidden).
    pub fn evicted_full(&self) -> u32 {
        self.evicted_full
    }

    /// Empties the window.
    pub fn clear(&mut self) {
        self.tail = 0;
        self.len = 0;
        self.sums = Sums::default();
    }

    fn pop_oldest(&mut self) {
        if self.len == 0 {
            return;
        }
        if let Some(e) = self.ring.get(self.tail).copied() {
            self.sums.apply::<false>(&e, &self.u_ref);
        }
        self.tail = (self.tail + 1) % W;
        self.len -= 1;
    }

    /// Feeds one sample (O(1) amortised: each sample enters and leaves once).
    pub fn update(&mut self, s: &Sample) -> StreamUse {
        if !s.flags.is_valid_for_metrology() {
            self.skipped_flagged = self.skipped_flagged.saturating_add(1);
            return StreamUse::SkippedFlagged;
        }
        let [x, y, z, a, b] = s.axes;
        let [sx, sy, sz] = self.socket_f32;
        let d = [x - sx, y - sy, z - sz];
        let r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
        // 1 mm < |P − P0| < 3162 mm keeps the Q16 positions and their differences in i32
        let ok = r2 > 1.0 && r2 < 1.0e7 && a.is_finite() && b.is_finite();
        let r = crate::num::sqrtf(r2);
        let yv = s.delta_l_um + (self.bar_length_f32 - r) * 1e3;
        if !ok || !(yv.abs() <= MAX_ABS_Y_UM) {
            self.skipped_invalid = self.skipped_invalid.saturating_add(1);
            return StreamUse::SkippedInvalid;
        }
        let inv = U_SCALE / r;
        let entry = Entry {
            u: [
                (d[0] * inv) as i32,
                (d[1] * inv) as i32,
                (d[2] * inv) as i32,
            ],
            y: (yv * Y_SCALE) as i32,
            d: [
                (d[0] * P_SCALE) as i32,
                (d[1] * P_SCALE) as i32,
                (d[2] * P_SCALE) as i32,
            ],
        };
        let [ra, rb] = self.rotary_ref_deg;
        let tol = self.config.rotary_tol_deg;
        let mut used = StreamUse::Used;
        if self.len > 0 && !((a - ra).abs() <= tol && (b - rb).abs() <= tol) {
            self.clear();
            used = StreamUse::UsedAfterRotaryMove;
        }
        if self.len == 0 {
            self.rotary_ref_deg = [a, b];
        }
        // leave: samples outside the radius (oldest first), then the oldest if full
        while self.len > 0 {
            let Some(old) = self.ring.get(self.tail) else {
                break;
            };
            // Q16 differences fit in i32 (|d| < 3162 mm); f32 squares, no soft double
            let [o0, o1, o2] = old.d;
            let [n0, n1, n2] = entry.d;
            let q = |n: i32, o: i32| n.wrapping_sub(o) as f32;
            let (q0, q1, q2) = (q(n0, o0), q(n1, o1), q(n2, o2));
            let dist2 = q0 * q0 + q1 * q1 + q2 * q2;
            if dist2 > self.radius2_q {
                self.pop_oldest();
            } else {
                break;
            }
        }
        if self.len == W {
            self.pop_oldest();
            self.evicted_full = self.evicted_full.saturating_add(1);
        }
        let head = (self.tail + self.len) % W;
        if let Some(slot) = self.ring.get_mut(head) {
            *slot = entry;
            if self.len == 0 {
                // a new window: its first direction is the reference, so its sums are those of
                // one entry with v = 0 (stored, not a reset followed by `apply`: merged, the
                // two paths made every sum a select and spilled them all, ~65 instructions)
                self.u_ref = entry.u;
                self.start = head;
                self.sums = Sums::first(&entry);
            } else {
                self.sums.apply::<true>(&entry, &self.u_ref);
            }
            self.len += 1;
        }
        self.recentre();
        used
    }

    /// How far (Q24 bits) the window's mean direction may drift from u_ref: as far as keeps
    /// |Σv| ≤ W·2^bits ≤ 2³⁰, an i32 for the live solve's products (2²², 1/4 rad, for 256
    /// samples; 2¹⁹ for 2048). The live solve centres the sums exactly, so the drift costs no
    /// precision; the f64 solve rebuilds G exactly whatever u_ref is.
    const SHIFT_BITS: u32 = 30 - (usize::BITS - (W - 1).leading_zeros());

    /// Moves u_ref to (about) the window's mean direction once the mean is 2^[`SHIFT_BITS`]
    /// (Q24) or more from it. Any integer shift keeps the sums exact, so the mean is taken in
    /// f32 (no i64 division).
    ///
    /// [`SHIFT_BITS`]: Self::SHIFT_BITS
    #[inline(always)] // the test is a few instructions; the shift is rare
    fn recentre(&mut self) {
        let limit = ((self.len as i64) << Self::SHIFT_BITS).unsigned_abs();
        let [v0, v1, v2] = self.sums.v;
        if v0.unsigned_abs() > limit || v1.unsigned_abs() > limit || v2.unsigned_abs() > limit {
            self.shift_to_mean();
        }
    }

    /// Moves u_ref to the window's mean direction (rounded to Q24), shifting the sums.
    #[inline(never)] // out of line: inlined, its register pressure costs `update` every sample
    fn shift_to_mean(&mut self) {
        // |mean| ≤ 2^SHIFT_BITS + one sample's 2²⁵: well inside i32
        let [v0, v1, v2] = self.sums.v;
        let inv_n = 1.0 / self.len as f32;
        let mean = |s: i64| (f32_of(s) * inv_n) as i32;
        let delta = [mean(v0), mean(v1), mean(v2)];
        self.sums.shift(delta, self.len as i32);
        let [r0, r1, r2] = &mut self.u_ref;
        let [d0, d1, d2] = delta;
        *r0 = r0.wrapping_add(d0);
        *r1 = r1.wrapping_add(d1);
        *r2 = r2.wrapping_add(d2);
    }

    /// E for the current neighbourhood refined on the exact sphere equation
    /// |P − P0 + E| = L + ΔL (seed 000 B.2 item 4): with ρ = |P − P0| and y as above the exact
    /// form is u·E = y + (y² − |E|²)/(2ρ), solved by `iterations` fixed-point steps (each a
    /// pass over the window, f64, O(W); the correction is second order, so 2 suffice). Removes
    /// the |E|²/2L linearisation error (0.5 µm for |E| = 0.4 mm, L = 150 mm).
    pub fn estimate_refined(&self, iterations: u32) -> Result<StreamingEstimate, SsmError> {
        let mut est = self.estimate()?;
        let (g, _, _) = self.normal_equations();
        let n = self.len as u32;
        let us = 1.0 / f64::from(U_SCALE);
        let ys = 1.0 / f64::from(Y_SCALE);
        let ps = 1.0 / f64::from(P_SCALE);
        for _ in 0..iterations {
            let e = est.solution.e_um.map(|c| c.unwrap_or(0.0));
            let e2 = e[0] * e[0] + e[1] * e[1] + e[2] * e[2];
            let mut b = [0.0f64; 3];
            let mut yy = 0.0;
            for k in 0..self.len {
                let Some(en) = self.ring.get((self.tail + k) % W) else {
                    continue;
                };
                let d = en.d.map(|v| f64::from(v) * ps);
                let rho_um = crate::num::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) * 1e3;
                let y = f64::from(en.y) * ys;
                let y_exact = y + (y * y - e2) / (2.0 * rho_um);
                for (bk, u) in b.iter_mut().zip(en.u) {
                    *bk += f64::from(u) * us * y_exact;
                }
                yy += y_exact * y_exact;
            }
            let solution = solve_normal(&g, b, yy, n)?;
            est.solution = SsmSolution {
                iterations: est.solution.iterations + 1,
                ..solution
            };
        }
        Ok(est)
    }

    fn normal_equations(&self) -> (Sym3, [f64; 3], f64) {
        let gs = 1.0 / (f64::from(U_SCALE) * f64::from(U_SCALE));
        let bs = 1.0 / (f64::from(U_SCALE) * f64::from(Y_SCALE));
        let ys = 16.0 / f64::from(Y_SCALE);
        // G = Σvvᵀ + r Σvᵀ + Σv rᵀ + n r rᵀ, b = Σvy + r Σy (exact mod 2⁶⁴, true values in range)
        let s = &self.sums;
        let n = self.len as i64;
        let r = self.u_ref.map(i64::from);
        let at = |a: &[i64; 3], i: usize| a.get(i).copied().unwrap_or(0);
        let mut g = [0f64; 6];
        for ((gk, &vv), (i, j)) in g.iter_mut().zip(s.vv.iter()).zip(PAIRS) {
            let exact = vv
                .wrapping_add(at(&r, i).wrapping_mul(at(&s.v, j)))
                .wrapping_add(at(&s.v, i).wrapping_mul(at(&r, j)))
                .wrapping_add(n.wrapping_mul(at(&r, i)).wrapping_mul(at(&r, j)));
            *gk = exact as f64 * gs;
        }
        let [g0, g1, g2, g3, g4, g5] = g;
        let g = Sym3 {
            a00: g0,
            a01: g1,
            a02: g2,
            a11: g3,
            a12: g4,
            a22: g5,
        };
        let mut b = [0f64; 3];
        for ((bk, &vy), rk) in b.iter_mut().zip(s.vy.iter()).zip(r) {
            *bk = vy.wrapping_add(rk.wrapping_mul(s.y)) as f64 * bs;
        }
        let yy = s.yy as f64 * ys * ys;
        (g, b, yy)
    }

    /// The live E of the current neighbourhood, µm: each component, or `None` where the path
    /// cannot see it; f32 on the FPU (see the module doc). The same errors and observability
    /// rule ([`UNOBSERVABLE_EIG_RATIO`], [`OBSERVABLE_AXIS_TOL`]) as [`estimate`](Self::estimate),
    /// whose f64 values it matches to a few nm on the host tests' paths, except that a
    /// direction f32 cannot resolve (below [`LIVE_EIG_RESOLUTION`] of the largest eigenvalue
    /// across the mean direction: a ratio beyond ≈ 7·10⁴) is not observable here.
    pub fn live(&self) -> Result<[Option<f32>; 3], SsmError> {
        self.solve_live(None)
    }

    /// [`live`](Self::live), and into `u` the standard uncertainty of each component, µm,
    /// with the bar's shares `bar` and the socket's `u_socket_um` (`None` where E_k is not
    /// observable or the window has fewer than [`LIVE_MIN_DOF`] degrees of freedom). Type A:
    /// σ̂ √((G⁻¹)_kk), σ̂² the window's residual sum of squares over its degrees of freedom, at
    /// least [`LIVE_SIGMA_FLOOR_UM`]²; the bar (GUM first order): a constant offset of every y
    /// moves E_k by the least squares of the window with y ≡ 1 (times `bar.offset_um`), the
    /// scale by E_k·`bar.scale`; the socket as entered, off by δ, changes every y by u·δ, which
    /// the least squares reproduces: E_k by δ_k whole (each coordinate's `u_socket_um`). About
    /// 300 instructions more than [`live`](Self::live): the pod refreshes it every
    /// [`crate::app::live::LIVE_U_EVERY`] samples.
    pub fn live_with_uncertainty(
        &self,
        bar: &BarBudget,
        u_socket_um: f32,
        u: &mut [Option<f32>; 3],
    ) -> Result<[Option<f32>; 3], SsmError> {
        let mut parts = LiveParts::default();
        *u = [None; 3];
        let e = self.solve_live(Some(&mut parts))?;
        *u = self.live_u(&parts, bar, u_socket_um);
        Ok(e)
    }

    /// The live solve; with `parts`, what [`Self::live_u`] needs of it, stored where each is
    /// computed (kept live to the end, they would make the per-sample path spill).
    #[inline(never)] // one copy in flash (the application task's poll would inline it)
    fn solve_live(&self, mut parts: Option<&mut LiveParts>) -> Result<[Option<f32>; 3], SsmError> {
        let n = self.len as u32;
        if n < 3 {
            return Err(SsmError::TooFewObservations { have: n, need: 3 });
        }
        const U: f32 = 1.0 / U_SCALE;
        const Y: f32 = 1.0 / Y_SCALE;
        let s = &self.sums;
        let nf = n as f32;
        let inv_n = 1.0 / nf;
        // (no array `map`s in this function: at opt-level "z" each is an out-of-line loop;
        // comparisons, not `max`: that is a call here)
        // |Σv| ≤ n·2^SHIFT_BITS ≤ 2³⁰ after `recentre`: i32, and Σv Σvᵀ single SMULLs
        let [v0, v1, v2] = s.v;
        let [w0, w1, w2] = [v0 as i32, v1 as i32, v2 as i32];
        let ku = inv_n * U;
        let [a, b, c] = [w0 as f32 * ku, w1 as f32 * ku, w2 as f32 * ku];
        let sy = f32_of(s.y);
        let ybar = sy * inv_n * Y;
        let [vv0, vv1, vv2, vv3, vv4, vv5] = s.vv;
        // The centred sums P = n Σvvᵀ − Σv Σvᵀ = n² C and Q = n Σvy − Σv Σy = n² c, computed
        // mod 2⁶⁴, are exact when their true values are in range: P when its diagonals are
        // below 2⁶² (|P_ij| ≤ √(P_ii P_jj)), certainly so when n Σvv_kk is (each vv ≤ W·2⁵⁰
        // does not wrap) — the pod's windows, whose directions stay within 1/4 rad of u_ref.
        let big = if vv3 > vv0 { vv3 } else { vv0 };
        let big = if vv5 > big { vv5 } else { big };
        let (cov, cy) = if f32_of(big) * nf < 4.6e18 {
            let nn = i64::from(n);
            let p = |vv: i64, a: i32, b: i32| {
                f32_of(
                    vv.wrapping_mul(nn)
                        .wrapping_sub(i64::from(a) * i64::from(b)),
                )
            };
            let k = inv_n * inv_n * U * U;
            let p0 = p(vv0, w0, w0) * k;
            let p1 = p(vv1, w0, w1) * k;
            let p2 = p(vv2, w0, w2) * k;
            let p3 = p(vv3, w1, w1) * k;
            let p4 = p(vv4, w1, w2) * k;
            let p5 = p(vv5, w2, w2) * k;
            // Q is in range when P_kk · n²var(y) < 2¹²⁴ (Cauchy–Schwarz), with n²var(y) ≤
            // n Σy² − (Σy)² and Σy² ≤ 257 Σ(y/16)² + 65 792 n (y/16 truncated: y² ≤
            // 256 (y>>4)² + 512 |y>>4| + 256), in f32 with a 2⁻²⁰ margin (Σvy may wrap)
            let syy = nf * (257.0 * f32_of(s.yy) + 65_792.0 * nf);
            let var_y = syy * (1.0 + 1.0 / 1_048_576.0) - sy * sy;
            let pk = if p3 > p0 { p3 } else { p0 };
            let pk = if p5 > pk { p5 } else { pk };
            if !(pk * var_y < 2.126_765e37 * k) {
                return Err(SsmError::InvalidInput);
            }
            let q = |vy: i64, a: i32| {
                f32_of(
                    vy.wrapping_mul(nn)
                        .wrapping_sub(i64::from(a).wrapping_mul(s.y)),
                )
            };
            let kc = inv_n * inv_n * U * Y;
            let [vy0, vy1, vy2] = s.vy;
            (
                [[p0, p1, p2], [p1, p3, p4], [p2, p4, p5]],
                [q(vy0, w0) * kc, q(vy1, w1) * kc, q(vy2, w2) * kc],
            )
        } else {
            // A window of widely spread directions (radius comparable with the bar): the
            // covariances as means less products in f32, whose cancellation is small beside a
            // spread this wide; Σvy is read only while certainly in range (Σv_k²·Σy² < 2¹²⁴).
            let [vv0, vv1, vv2, vv3, vv4, vv5] = [
                f32_of(vv0),
                f32_of(vv1),
                f32_of(vv2),
                f32_of(vv3),
                f32_of(vv4),
                f32_of(vv5),
            ];
            let big = if vv3 > vv0 { vv3 } else { vv0 };
            let big = if vv5 > big { vv5 } else { big };
            if !(big * f32_of(s.yy) * 256.0 < 2.126_765e37) {
                return Err(SsmError::InvalidInput);
            }
            let q = inv_n * U * U;
            let [w0, w1, w2] = s.vy;
            let [w0, w1, w2] = [f32_of(w0), f32_of(w1), f32_of(w2)];
            let k = inv_n * U * Y;
            (
                [
                    [vv0 * q - a * a, vv1 * q - a * b, vv2 * q - a * c],
                    [vv1 * q - a * b, vv3 * q - b * b, vv4 * q - b * c],
                    [vv2 * q - a * c, vv4 * q - b * c, vv5 * q - c * c],
                ],
                [w0 * k - a * ybar, w1 * k - b * ybar, w2 * k - c * ybar],
            )
        };
        if let Some(p) = parts.as_deref_mut() {
            p.cov = cov;
            p.cy = cy;
            p.ybar = ybar;
        }
        let [u0, u1, u2] = self.u_ref;
        let m = [u0 as f32 * U + a, u1 as f32 * U + b, u2 as f32 * U + c];
        let mm = crate::num::sqrtf(dot(m, m));
        let [m0, m1, m2] = m;
        let mh = [m0 / mm, m1 / mm, m2 / mm];
        // an orthonormal basis (t1, t2, m̂) (Duff et al. 2017, branch on the sign only)
        let [x, y, z] = mh;
        let sg = if z >= 0.0 { 1.0 } else { -1.0 };
        let ka = -1.0 / (sg + z);
        let kb = x * y * ka;
        let t1 = [1.0 + sg * x * x * ka, sg * kb, -sg * x];
        let t2 = [kb, sg + y * y * ka, -y];
        let (w1, w2, w3) = (times(&cov, t1), times(&cov, t2), times(&cov, mh));
        let (s00, s01, s11) = (dot(t1, w1), dot(t1, w2), dot(t2, w2));
        let (c1m, c2m, cmm) = (dot(t1, w3), dot(t2, w3), dot(mh, w3));
        let den = mm * mm + cmm;
        let alpha = (mm * ybar + dot(mh, cy)) / den;
        let (b1, b2) = (c1m / den, c2m / den);
        // the tangent plane's Schur complement and right-hand side
        let (s00, s01, s11) = (s00 - c1m * b1, s01 - c1m * b2, s11 - c2m * b2);
        let r1 = dot(t1, cy) - c1m * alpha;
        let r2 = dot(t2, cy) - c2m * alpha;
        let h = 0.5 * (s00 - s11);
        let l_max = 0.5 * (s00 + s11) + crate::num::sqrtf(h * h + s01 * s01);
        let l_min = (s00 * s11 - s01 * s01) / l_max;
        if let Some(p) = parts.as_deref_mut() {
            p.basis = [t1, t2, mh];
            p.mm = mm;
            p.den = den;
            p.b = [b1, b2];
            p.schur = [s00, s01, s11];
            p.l_max = l_max;
        }
        let ratio = UNOBSERVABLE_EIG_RATIO as f32 * den;
        if !(l_max > ratio) {
            return Err(SsmError::Degenerate);
        }
        // S comes from f32 products of C with a few roundings each: an eigenvalue below
        // LIVE_EIG_RESOLUTION × λ_max is rounding, not the path (a wide planar arc read its
        // zero across-plane eigenvalue as 10⁻⁸ and solved E_z from it)
        let resolved = l_max * LIVE_EIG_RESOLUTION;
        let (e1, e2, null) = if l_min > ratio && l_min > resolved {
            let det = s00 * s11 - s01 * s01;
            (
                (s11 * r1 - s01 * r2) / det,
                (s00 * r2 - s01 * r1) / det,
                None,
            )
        } else {
            // the eigenvector of l_max (the better conditioned of its two forms); E has no
            // component along the other, which the path cannot see
            let (p, q) = if s00 >= s11 {
                (l_max - s11, s01)
            } else {
                (s01, l_max - s00)
            };
            let norm = crate::num::sqrtf(p * p + q * q);
            let (p, q) = (p / norm, q / norm);
            let k = (p * r1 + q * r2) / l_max;
            (k * p, k * q, Some([-q, p]))
        };
        let em = alpha - b1 * e1 - b2 * e2;
        // E in the axes; a component with a share of the unseen direction is not observable
        let [t10, t11, t12] = t1;
        let [t20, t21, t22] = t2;
        let [m0, m1, m2] = mh;
        let [c0, c1, c2] = [
            e1 * t10 + e2 * t20 + em * m0,
            e1 * t11 + e2 * t21 + em * m1,
            e1 * t12 + e2 * t22 + em * m2,
        ];
        let seen = |t1k: f32, t2k: f32| match null {
            Some([n1, n2]) => libm::fabsf(n1 * t1k + n2 * t2k) < OBSERVABLE_AXIS_TOL as f32,
            None => true,
        };
        let [s0, s1, s2] = [seen(t10, t20), seen(t11, t21), seen(t12, t22)];
        if let Some(p) = parts {
            p.e = [c0, c1, c2];
            p.seen = [s0, s1, s2];
            p.null = null;
        }
        Ok([
            (s0 && c0.is_finite()).then_some(c0),
            (s1 && c1.is_finite()).then_some(c1),
            (s2 && c2.is_finite()).then_some(c2),
        ])
    }

    /// The live E's u from the parts of its solve (see [`Self::live_with_uncertainty`]).
    #[inline(never)] // off the per-sample path
    fn live_u(&self, p: &LiveParts, bar: &BarBudget, u_socket_um: f32) -> [Option<f32>; 3] {
        let mut out = [None; 3];
        let n = self.len as u32;
        let s = &self.sums;
        let dof = n.saturating_sub(if p.null.is_some() { 2 } else { 3 });
        let nf = n as f32;
        // var(y) from the exact n² var(y) in Q24 µm² (mod 2⁶⁴: in range while n Σ(y/16)² is)
        if !(dof >= LIVE_MIN_DOF && f32_of(s.yy) * nf < 9.2e18) {
            return out;
        }
        let nn = i64::from(n);
        let vq =
            s.yy.wrapping_mul(nn)
                .wrapping_sub(s.y16.wrapping_mul(s.y16));
        let inv_n = 1.0 / nf;
        let var_y = f32_of(vq) * (inv_n * inv_n * (1.0 / 16_777_216.0));
        let [t1, t2, mh] = p.basis;
        let e = p.e;
        // RSS/n = var(y) − 2 cᵀE + Eᵀ C E + (ȳ − mᵀE)², m = |m| m̂
        let d = p.ybar - p.mm * dot(mh, e);
        let rss = var_y - 2.0 * dot(p.cy, e) + dot(e, times(&p.cov, e)) + d * d;
        let floor = LIVE_SIGMA_FLOOR_UM * LIVE_SIGMA_FLOOR_UM;
        let sigma2 = rss * nf / dof as f32;
        let kv = if sigma2 > floor { sigma2 } else { floor } * inv_n;
        // cov(E) = σ²/n (G/n)⁺ and E's response to ȳ = 1, c = 0 (a constant offset of every
        // y), in the basis (t₁, t₂, m̂) where the solve is the block inverse
        // M = [[P, −P b], [−bᵀP, 1/den + bᵀ P b]] of G/n, P the tangent plane's S⁻¹, or
        // v vᵀ/λ_max along the eigenvector v = (p, q) of λ_max where the path does not see the
        // other direction: var(E_k) = σ²/n wᵀ M w and ∂E_k/∂δ = |m| (M w)₃, w = (t₁ₖ, t₂ₖ, m̂ₖ).
        let [s00, s01, s11] = p.schur;
        let [p00, p01, p11] = match p.null {
            None => {
                let k = 1.0 / (s00 * s11 - s01 * s01);
                [s11 * k, -s01 * k, s00 * k]
            }
            Some([nq, pv]) => {
                let k = 1.0 / p.l_max;
                [pv * pv * k, -pv * nq * k, nq * nq * k]
            }
        };
        let [b1, b2] = p.b;
        let (pb0, pb1) = (p00 * b1 + p01 * b2, p01 * b1 + p11 * b2);
        let m22 = 1.0 / p.den + b1 * pb0 + b2 * pb1;
        for (k, o) in out.iter_mut().enumerate() {
            let at = |v: [f32; 3]| v.get(k).copied().unwrap_or(f32::NAN);
            let (w0, w1, w2, ek) = (at(t1), at(t2), at(mh), at(e));
            let mw2 = m22 * w2 - pb0 * w0 - pb1 * w1;
            let g = w0 * (p00 * w0 + p01 * w1 - pb0 * w2)
                + w1 * (p01 * w0 + p11 * w1 - pb1 * w2)
                + w2 * mw2;
            let (off, scale) = (p.mm * mw2 * bar.offset_um, ek * bar.scale);
            let socket = u_socket_um * u_socket_um;
            let u = crate::num::sqrtf(kv * g + off * off + scale * scale + socket);
            let seen = p.seen.get(k).copied().unwrap_or(false);
            *o = (seen && u.is_finite()).then_some(u);
        }
        out
    }

    /// E for the current neighbourhood, with condition number and observability.
    pub fn estimate(&self) -> Result<StreamingEstimate, SsmError> {
        let n = self.len as u32;
        if n < 3 {
            return Err(SsmError::TooFewObservations { have: n, need: 3 });
        }
        let (g, b, yy) = self.normal_equations();
        let solution = solve_normal(&g, b, yy, n)?;
        let [px, py, pz] = self.config.geometry.socket_mm;
        let [dx, dy, dz] = self
            .sums
            .d
            .map(|v| v as f64 / (f64::from(P_SCALE) * f64::from(n)));
        Ok(StreamingEstimate {
            solution,
            centroid_mm: [px + dx, py + dy, pz + dz],
        })
    }
}
