//! The uncertainty of the extremes of a noisy bin profile: ISO 230-4's G, F, G(b) and H are
//! maxima and minima over the 1° bin means of a run, and a maximum over many noisy bins is
//! biased upward (the largest of the near-top bins' noise wins), by about as much as its own
//! scatter.
//!
//! - **The noise** of one sample's ΔL, σ: from the bin means' third differences
//!   m₊₂ − 3m₊₁ + 3m₀ − m₋₁, whose variance is σ²(1/n₊₂ + 9/n₊₁ + 9/n₀ + 1/n₋₁) for white noise
//!   and which remove the path up to its cubic term; the median of the normalised squares
//!   (÷ 0.4549, the χ²₁ median) so that the few bins a reversal step crosses do not count; at
//!   least the resolution's q/√12. A bin mean carries σ/√n.
//! - **A parametric bootstrap** (GUM Supplement 1's propagation of distributions, on the
//!   measured profile): [`REPLICAS`] copies of the profile with fresh noise of that size per
//!   bin; each figure's excess Δ = mean(replicas) − observed and spread s*. Where one bin alone
//!   holds the extreme Δ ≈ 0; where k bins tie, the observed extreme already carries the bias
//!   b_k = σ_b·E[max of k normals] and the replicas add (√2 − 1)·b_k. The figure reported is
//!   the observed one less 2Δ (between those two cases), with
//!   u² = s*²(1 + 4/[`REPLICAS`]) + 1.6 ΣΔₑ² (the spread, the replicas' own sampling error of
//!   2Δ, and the correction's uncertainty from the excess Δₑ of each extreme the figure is made
//!   of: one for F and H, two for G and G(b)).
//!
//! Checked by Monte Carlo against an independent forward model (tests/metrology_iso230_4.rs:
//! random squareness, scale, reversal and cyclic faults of random phase, 0.2 µm noise): U = 2u
//! covers the noise-free figure in 95 % ± 3 % of runs and u is within 20 % of the figures'
//! scatter. Only the noise is in this u: the instrument's calibration and the set-up are not
//! (issue 14).

use super::iso230_4::{Diagnosed, RESOLUTION_UM};

/// Noisy copies of the profile the bootstrap draws.
pub const REPLICAS: u32 = 128;

/// The χ²₁ distribution's median: median(z²) = 0.4549 σ² for normal z.
const CHI2_1_MEDIAN: f32 = 0.454_936;

/// One bin of a profile: the mean of its samples' ΔL, µm, and how many there were (0: empty).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BinMean {
    /// Mean ΔL of the bin's samples, µm.
    pub mean_um: f32,
    /// Samples in the bin.
    pub n: u32,
}

/// The standard deviation of one sample's ΔL noise, µm, from the third differences of
/// consecutive non-empty bins 0..`len` (`bin(i)`; module doc; at least q/√12 of
/// [`RESOLUTION_UM`]); `None` with fewer than 8 runs of four consecutive non-empty bins.
/// `scratch` holds the normalised squares (at least `len` long).
pub fn sample_noise_um(
    len: usize,
    bin: impl Fn(usize) -> BinMean,
    scratch: &mut [f32],
) -> Option<f32> {
    if len < 4 {
        return None;
    }
    let mut k = 0;
    // the last four bins, each read once (a bin's mean costs a division)
    let [mut a, mut b, mut c] = [0, 1, 2].map(&bin);
    for i in 3..len {
        let d = bin(i);
        let window = [a, b, c, d];
        [a, b, c] = [b, c, d];
        let [a, b, c, d] = window;
        if a.n == 0 || b.n == 0 || c.n == 0 || d.n == 0 {
            continue;
        }
        let d3 = d.mean_um - 3.0 * c.mean_um + 3.0 * b.mean_um - a.mean_um;
        let inv = |n: u32| 1.0 / n as f32;
        let w = inv(d.n) + 9.0 * inv(c.n) + 9.0 * inv(b.n) + inv(a.n);
        if let Some(z) = scratch.get_mut(k) {
            *z = d3 * d3 / w;
            k += 1;
        }
    }
    if k < 8 {
        return None;
    }
    let median = crate::num::select_f32(scratch.get_mut(..k)?, k / 2)?;
    let floor = RESOLUTION_UM * RESOLUTION_UM / 12.0;
    Some(crate::num::sqrtf((median / CHI2_1_MEDIAN).max(floor)))
}

/// Standard normal numbers for the bootstrap: a fixed-seed xorshift32 (the same data give the
/// same u, which replay needs), Irwin–Hall's sum of 12 uniforms less 6 (no transcendental
/// function on the pod; tails cut at ±6, beyond any maximum of a few thousand bins).
#[derive(Debug, Clone, Copy)]
pub struct Normals(u32);

impl Default for Normals {
    fn default() -> Self {
        Self(0x9E37_79B9)
    }
}

impl Normals {
    /// The next number.
    #[inline]
    pub fn draw(&mut self) -> f32 {
        let mut sum: u32 = 0;
        for _ in 0..12 {
            let mut x = self.0;
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            self.0 = x;
            sum = sum.wrapping_add(x >> 8); // 12 × 2²⁴ < 2³²
        }
        sum as f32 * (1.0 / 16_777_216.0) - 6.0
    }
}

/// Running moments of one figure's replicas, about the observed figure (small numbers: f32).
#[derive(Debug, Clone, Copy, Default)]
pub struct Replicas {
    sum: f32,
    sum2: f32,
}

impl Replicas {
    /// Adds one replica's value less the observed figure.
    #[inline]
    pub fn add(&mut self, deviation: f32) {
        self.sum += deviation;
        self.sum2 += deviation * deviation;
    }

    /// The excess Δ the added noise gives: the replicas' mean less the observed figure.
    pub fn excess(&self) -> f32 {
        self.sum * (1.0 / REPLICAS as f32)
    }

    /// The figure observed without added noise, corrected and with its standard uncertainty
    /// (module doc), after [`REPLICAS`] replicas; `extremes` are the excesses of the maxima or
    /// minima it is made of (its own for an extreme, the maximum's and the minimum's for a
    /// range), each an uncertainty of the correction.
    pub fn figure(&self, observed: f32, extremes: &[f32]) -> Diagnosed {
        let k = REPLICAS as f32;
        let excess = self.excess();
        let var = (self.sum2 / k - excess * excess).max(0.0);
        let corrections: f32 = extremes.iter().map(|d| d * d).sum();
        let u2 = var * (1.0 + 4.0 / k) + CORRECTION_U2 * corrections;
        Diagnosed {
            value: observed - 2.0 * excess,
            std_uncertainty: crate::num::sqrtf(u2),
            centre_um: 0.0,
        }
    }
}

/// (u of a correction / its extreme's excess)²: with the correction's factor 2, the Monte
/// Carlo test's choice (coverage 95 % ± 3 % and scatter/u within 20 % for every figure over
/// random faults at 160 samples a bin; at 20 a bin u is then up to ~25 % conservative).
const CORRECTION_U2: f32 = 1.6;
