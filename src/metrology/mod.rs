//! Metrology: samples → SSM position errors, running circle fits, ISO 230-4 figures, point fits.
//!
//! - [`pattern`]: a measuring pattern's plane, centre and sensitive direction n;
//! - [`circle_fit`]: the running limaçon fit ΔL = r0 + e·n (seed 002 §3.5), f32 per sample;
//! - [`iso230_4`]: ISO 230-4 figures (G, F, H, G(b)) and ball-bar diagnostics;
//! - [`extremes`]: the noise of a bin profile and the uncertainty of its extremes (G, F, …);
//! - [`angle`]: quadrant + polynomial angle for binning (no atan2);
//! - [`bar_budget`]: the ball bar's own Type B uncertainty (length, temperature, LVDT scale);
//! - [`compensated`]: the Kahan-compensated f32 sum the running fits accumulate with;
//! - [`point_fit`]: circle and sphere from touch points (Kåsa start, Gauss–Newton);
//! - [`ssm`]: SSM position errors (seed 000 eq 1), station and streaming modes;
//! - [`solve3`]: hand-written 3×3 symmetric Cholesky solve, inverse, condition number.
//!
//! Units: ΔL and eccentricities in µm, positions in mm, angles in degrees at the interface.
//! Error = actual − nominal.

pub mod angle;
pub mod bar_budget;
pub mod circle_fit;
pub mod compensated;
pub mod extremes;
pub mod iso230_4;
pub mod pattern;
pub mod point_fit;
pub mod solve3;
pub mod ssm;
