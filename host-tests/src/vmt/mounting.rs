//! How the seed 002 procedure's balls are mounted on a real machine, drawn at random as the
//! default uncertainty budget assumes (seed 002 §5.2–5.3; the book's seed 002 "Uncertainty"
//! table): the W-ball's magnetic clamping shifts 10–60 µm in a random direction at every
//! clamping (the thesis measured it: `s002_u_w_clamp` 22 µm is that shift's rms per
//! component), the T-ball is centred on the spindle to within a 1 µm disc (`s002_u_t_centring`
//! 0.5 µm) and shifts along it as the W-ball does (`s002_u_t_axial` 22 µm). The Monte Carlo
//! coverage tests and the simulator's default machine draw from here.

use crate::rng::Rng;

/// A direction uniform on the sphere (unit vector).
pub fn direction(rng: &mut Rng) -> [f64; 3] {
    let z = rng.range(-1.0, 1.0);
    let a = rng.range(0.0, std::f64::consts::TAU);
    let r = (1.0 - z * z).sqrt();
    [r * a.cos(), r * a.sin(), z]
}

/// A clamping shift: magnitude uniform in 10–60 µm, direction uniform (µm).
pub fn clamping_shift(rng: &mut Rng) -> [f64; 3] {
    let m = rng.range(10.0, 60.0);
    direction(rng).map(|c| m * c)
}

/// A T-ball offset (spindle frame, µm): radial uniform in a 1 µm disc (the centring), axial
/// a clamping shift's component.
pub fn t_ball_offset(rng: &mut Rng) -> [f64; 3] {
    let (r, a) = (rng.uniform().sqrt(), rng.range(0.0, std::f64::consts::TAU));
    [r * a.cos(), r * a.sin(), clamping_shift(rng)[2]]
}
