//! Streaming SSM: E at every sample from the samples of its neighbourhood (DESIGN §7).
//!
//! The neighbourhood is a trailing window of at most `W` samples whose nominal points lie
//! within `radius_mm` of the current one and whose rotary axes did not move (a rotary move
//! empties the window). The normal equations G = Σ u uᵀ, b = Σ u y are kept as **exact integer
//! sums**: u quantised to Q24 (6e-8, the f32 resolution), y to Q16 µm (1.5e-5 µm), products
//! accumulated in i64 (one SMLAL each on the M4). Entering *and leaving* samples are then added
//! and subtracted without any drift, which a sliding window of compensated float sums cannot
//! guarantee. Per sample: one square root, one division, three float→int conversions, ~20
//! integer multiply-accumulates (plus the same for each sample leaving), no solve. The solve
//! (f64, with observability analysis) happens in [`StreamingSsm::estimate`].
//!
//! Precision: positions arrive as f32 mm (61 nm ulp at 1000 mm) and y uses |P − P0| in f32
//! (~15 nm at 150 mm); E is therefore good to a few tens of nm times the condition number,
//! which is what a 0.1 µm streaming target needs. Use stations for nm work.

use super::{SsmError, SsmGeometry, SsmSolution, solve_normal};
use crate::acquisition::Sample;
use crate::metrology::solve3::Sym3;

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

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
struct Sums {
    g: [i64; 6],
    b: [i64; 3],
    yy: i64,
    d: [i64; 3],
}

impl Sums {
    /// Adds (`ADD`) or removes an entry: i32×i32→i64 products and 64-bit adds, exact. Written
    /// on the i32 values directly so that each product compiles to one SMLAL (add) or SMULL +
    /// SUBS/SBC (remove) on the M4, not a 64×64 multiply.
    #[inline(always)]
    fn apply<const ADD: bool>(&mut self, e: &Entry) {
        #[inline(always)]
        fn mac<const ADD: bool>(s: &mut i64, a: i32, b: i32) {
            let p = i64::from(a) * i64::from(b);
            *s = if ADD {
                s.wrapping_add(p)
            } else {
                s.wrapping_sub(p)
            };
        }
        let [u0, u1, u2] = e.u;
        let y = e.y;
        let [g0, g1, g2, g3, g4, g5] = &mut self.g;
        mac::<ADD>(g0, u0, u0);
        mac::<ADD>(g1, u0, u1);
        mac::<ADD>(g2, u0, u2);
        mac::<ADD>(g3, u1, u1);
        mac::<ADD>(g4, u1, u2);
        mac::<ADD>(g5, u2, u2);
        let [b0, b1, b2] = &mut self.b;
        mac::<ADD>(b0, u0, y);
        mac::<ADD>(b1, u1, y);
        mac::<ADD>(b2, u2, y);
        let y8 = y >> 4; // Q12: y² < 2^48 per term
        mac::<ADD>(&mut self.yy, y8, y8);
        let [d0, d1, d2] = e.d;
        let [s0, s1, s2] = &mut self.d;
        for (s, d) in [(s0, d0), (s1, d1), (s2, d2)] {
            *s = if ADD {
                s.wrapping_add(i64::from(d))
            } else {
                s.wrapping_sub(i64::from(d))
            };
        }
    }
}

/// A streaming SSM estimate: E for the current neighbourhood.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreamingEstimate {
    /// The solution (E µm, condition number, observability).
    pub solution: SsmSolution,
    /// Mean nominal point of the window (where E applies), mm.
    pub centroid_mm: [f64; 3],
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
    sums: Sums,
    rotary_ref_deg: [f32; 2],
    skipped_flagged: u32,
    skipped_invalid: u32,
    evicted_full: u32,
}

impl<const W: usize> StreamingSsm<W> {
    const CHECK: () = assert!(W >= 4 && W <= 2048, "window must be 4..=2048 samples");

    /// An empty estimator.
    pub fn new(config: StreamingConfig) -> Self {
        #[allow(clippy::let_unit_value)]
        let () = Self::CHECK;
        let [x, y, z] = config.geometry.socket_mm;
        Self {
            config,
            socket_f32: [x as f32, y as f32, z as f32],
            bar_length_f32: config.geometry.bar_length_mm as f32,
            radius2_q: (config.radius_mm * P_SCALE) * (config.radius_mm * P_SCALE),
            ring: [Entry::default(); W],
            tail: 0,
            len: 0,
            sums: Sums::default(),
            rotary_ref_deg: [0.0; 2],
            skipped_flagged: 0,
            skipped_invalid: 0,
            evicted_full: 0,
        }
    }

    /// Samples in the current neighbourhood.
    pub fn window_len(&self) -> usize {
        self.len
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
            self.sums.apply::<false>(&e);
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
            let dist2: f32 = old
                .d
                .iter()
                .zip(entry.d)
                .map(|(o, n)| {
                    let q = n.wrapping_sub(*o) as f32;
                    q * q
                })
                .sum();
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
            self.sums.apply::<true>(&entry);
            self.len += 1;
        }
        used
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
        let [g0, g1, g2, g3, g4, g5] = self.sums.g.map(|v| v as f64 * gs);
        let g = Sym3 {
            a00: g0,
            a01: g1,
            a02: g2,
            a11: g3,
            a12: g4,
            a22: g5,
        };
        let b = self.sums.b.map(|v| v as f64 * bs);
        let yy = self.sums.yy as f64 * ys * ys;
        (g, b, yy)
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
