//! Independent forward model of seed 004's dial-gauge procedure (virtual machine tool side):
//! rotations by the literal Rodrigues matrix `I + sin θ K + (1 − cos θ) K²`, written index by
//! index here (the core uses nalgebra's `Rotation3`), plane heights seen by a dial gauge, and
//! vertices rotated about an axis line.

/// 3-vector.
pub type V3 = [f64; 3];

/// Dot product.
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product.
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// a − b.
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// a + b.
pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// s·a.
pub fn scale(s: f64, a: V3) -> V3 {
    [s * a[0], s * a[1], s * a[2]]
}

/// a / |a|.
pub fn normalize(a: V3) -> V3 {
    scale(1.0 / dot(a, a).sqrt(), a)
}

/// Right-handed rotation matrix about `d` (normalised here) by `t` rad (Rodrigues).
pub fn rodrigues(d: V3, t: f64) -> [[f64; 3]; 3] {
    let d = normalize(d);
    let k = [[0.0, -d[2], d[1]], [d[2], 0.0, -d[0]], [-d[1], d[0], 0.0]];
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let mut k2 = 0.0;
            for l in 0..3 {
                k2 += k[i][l] * k[l][j];
            }
            m[i][j] = if i == j { 1.0 } else { 0.0 } + t.sin() * k[i][j] + (1.0 - t.cos()) * k2;
        }
    }
    m
}

/// m·v.
pub fn mul(m: [[f64; 3]; 3], v: V3) -> V3 {
    [dot(m[0], v), dot(m[1], v), dot(m[2], v)]
}

/// Point `p` rotated by `t` rad about the line through `c` with direction `d`.
pub fn rotate_about_line(d: V3, c: V3, t: f64, p: V3) -> V3 {
    add(mul(rodrigues(d, t), sub(p, c)), c)
}

/// Dial reading (µm) at lateral position (u, v) mm of a face with unit normal `n` through the
/// origin, gauge frame (u_dir, v_dir, w_dir): the face height along w at that lateral position,
/// minus `zero_um` (the indicator zero).
pub fn dial_reading_um(
    n: V3,
    u_dir: V3,
    v_dir: V3,
    w_dir: V3,
    u: f64,
    v: f64,
    zero_um: f64,
) -> f64 {
    // plane n·x = 0, x = u·U + v·V + h·W  →  h = −(u n·U + v n·V)/(n·W)
    let h_mm = -(u * dot(n, u_dir) + v * dot(n, v_dir)) / dot(n, w_dir);
    h_mm * 1e3 - zero_um
}

/// Seed 004 eq 9 written out: the work point rotated about the table axis (A) by ε first, then
/// about the tilting axis (B) by φ.
pub fn eq9(p: V3, da: V3, pa: V3, db: V3, pb: V3, eps: f64, phi: f64) -> V3 {
    rotate_about_line(db, pb, phi, rotate_about_line(da, pa, eps, p))
}

/// The seeded generator of the host tests (SplitMix64), under the name the seed 003/004 tests use.
pub use crate::rng::Rng as SplitMix;
