//! The touch probe's lobing in the chapter 5 budget (issue 14): how a pre-travel that varies
//! with the direction of approach moves the fitted sphere centres, and what that does to the
//! identified C and B deviations.
//!
//! **Model.** A kinematic touch-trigger probe (three seats at 120°) switches after a pre-travel
//! that depends on the direction n of the contact force in the probe's own frame (z up the
//! stylus; the machine frame turned by B about Y, seed 002 eq 2.4). With θ the angle of n from
//! z and φ its azimuth about z, the part that does not shrink every touch alike is
//!
//! `p(n) − p̄ = sin²θ · Σₖ ρₖ (cₖ cos 3kφ + sₖ sin 3kφ) + d·cos²θ`, k = 1…6,
//!
//! the lobes across the stylus and the difference d of the pre-travel along the stylus from
//! across it. Across the stylus the trigger force, and so the pre-travel, grows as 1/cos of the
//! direction's angle from the middle of its lobe (the stylus tips about the line through two
//! seats): harmonics 3, 6, … 18 with amplitudes ρₖ = 1, 0.379, 0.195, 0.118, 0.078, 0.056 of
//! the third (ratios of ∫cos 3kψ / cos ψ over ±60°; the 21st and above, under 0.05 each, are
//! left out).
//! A constant pre-travel p̄ only shrinks the fitted radius. Each latched point lies p(n) inside
//! the surface along n, so the fitted centre moves by the least squares of
//! `n·δc + δR = −(p(n) − p̄)` over the touches: the sphere fit's
//! [`SphereFit::lobing_um_per_um`], from [`lobing_basis`] at each touch. Which harmonics move a
//! centre depends on the touch pattern: with the nine touches of `ncgen sphere` at B = 0 the
//! 3rd, 9th and 15th move it across, the 12th and d along the stylus.
//!
//! **Budget.** The [`LOBING_COMPONENTS`] components (c₁, s₁ … c₆, s₆, d) are unknown,
//! independent, each with standard uncertainty `probe_u_lobing`
//! ([`crate::config::U_LOBING_UM`] by default), and the same at every sphere of a procedure
//! (one probe and stylus set, the spindle oriented alike): a sphere's shift is not random
//! from sphere to sphere. [`lobing_share`] moves all four spheres of a method at once by
//! each component's u and takes the identification's
//! secant, so a shift common to the spheres goes into what it moves (δx_CZ, δy_CZ take the C
//! spheres' common shift whole; the C tilts see only its differences) and the aliasing of the
//! lobes by the touch pattern actually probed is counted.

#[cfg(doc)]
use super::probe::SphereFit;

/// Lobing components of the budget: six harmonics' cosine and sine, and d.
pub const LOBING_COMPONENTS: usize = 13;

/// Amplitudes of the harmonics 3, 6, … 18 of the kinematic 1/cos law relative to the third's.
const HARMONIC_RATIO: [f32; 6] = [1.0, 0.379, 0.195, 0.118, 0.078, 0.056];

/// The lobing's basis functions (module doc: c₁, s₁ … c₆, s₆ scaled by ρₖ, then d) for a touch
/// whose outward surface normal is `n` (machine frame, unit), probed at B with `sin_b`, `cos_b`.
/// In f32: three significant digits are all a budget needs (f64 is soft-float on the pod).
#[inline(never)]
pub fn lobing_basis(n: [f64; 3], sin_b: f64, cos_b: f64) -> [f32; LOBING_COMPONENTS] {
    let [n0, n1, n2] = n.map(|v| v as f32);
    let (sin_b, cos_b) = (sin_b as f32, cos_b as f32);
    // n in the probe's frame: R_y(−B)·n (the tool along −z at B = 0, turned about Y)
    let (x, y, z) = (cos_b * n0 - sin_b * n2, n1, sin_b * n0 + cos_b * n2);
    let rho2 = x * x + y * y;
    let mut out = [0.0f32; LOBING_COMPONENTS];
    if rho2 > 1e-12 {
        // w = e^{iφ}; w³ = e^{3iφ}; the harmonics by repeated products
        let r = crate::num::sqrtf(rho2);
        let (c, s) = (x / r, y / r);
        let w3 = (c * c * c - 3.0 * c * s * s, 3.0 * c * c * s - s * s * s);
        let mut wk = w3;
        for (pair, ratio) in out.chunks_exact_mut(2).zip(HARMONIC_RATIO) {
            if let [a, b] = pair {
                *a = rho2 * ratio * wk.0;
                *b = rho2 * ratio * wk.1;
            }
            wk = (wk.0 * w3.0 - wk.1 * w3.1, wk.0 * w3.1 + wk.1 * w3.0);
        }
    }
    if let Some(d) = out.last_mut() {
        *d = z * z;
    }
    out
}

/// Outputs [`lobing_share`] moves: the B method's five (the C method's four and a 0).
pub const LOBING_OUTPUTS: usize = 5;

/// A method's identification from four sphere centres (mm) to its outputs (`None`: failed).
pub type Identify<'a> = dyn Fn(&[[f64; 3]; 4]) -> Option<[f64; LOBING_OUTPUTS]> + 'a;

/// The standard uncertainty each output of `identify` takes from the probe's lobing: the four
/// sphere centres `centres_mm` (mm) moved together by `u_um` of one lobing component at a
/// time, through each sphere's [`SphereFit::lobing_um_per_um`] in `sensitivity`; the
/// components' secants add in quadrature. 0 when `u_um` is 0 (whatever the sensitivities);
/// NaN where a sensitivity is not known or `identify` fails on the moved centres. Up to
/// [`LOBING_OUTPUTS`] outputs (one copy of this for every method: flash).
pub fn lobing_share(
    centres_mm: &[[f64; 3]; 4],
    sensitivity: &[[[f32; 3]; LOBING_COMPONENTS]; 4],
    u_um: f64,
    identify: &Identify<'_>,
) -> [f64; LOBING_OUTPUTS] {
    if u_um == 0.0 {
        return [0.0; LOBING_OUTPUTS];
    }
    let Some(at) = identify(centres_mm) else {
        return [f64::NAN; LOBING_OUTPUTS];
    };
    let mut var = [0.0f64; LOBING_OUTPUTS];
    for j in 0..LOBING_COMPONENTS {
        let mut moved = *centres_mm;
        for (c, s) in moved.iter_mut().zip(sensitivity) {
            let shift = s.get(j).copied().unwrap_or([f32::NAN; 3]);
            for (v, d) in c.iter_mut().zip(shift) {
                *v += f64::from(d) * u_um * 1e-3;
            }
        }
        let Some(out) = identify(&moved) else {
            return [f64::NAN; LOBING_OUTPUTS];
        };
        for ((v, o), a) in var.iter_mut().zip(out).zip(at) {
            *v += (o - a) * (o - a);
        }
    }
    var.map(crate::num::sqrt)
}
