//! Identification: test results → machine geometric deviations and NC corrections (f64,
//! nalgebra fixed-size, no allocation; DESIGN §6).
//!
//! - [`lsq`]: streaming Givens least squares with rank, conditioning and uncertainties, shared
//!   by every method.
//! - [`two_step`]: seed 000 two-step orientation errors of RRTTT / TTTRR / RTTTR machines from two
//!   SSM measurements (exact inversion and corrected paper formulas).
//! - [`volumetric`]: seed 001 rigid-body volumetric error model, body-diagonal and vector
//!   diagonal methods, grid/thermal compensation, volumetric-error definitions, table conventions.
//! - [`multitasking`]: seed 002 (B head + C table): ball-bar and touch-probe identification, NC fix.
//! - [`rtest`]: seed 003 — R-test identification of A/C table-tilting location errors
//!   (first-order chain model, 11-parameter least squares with rank check, verification).
//! - [`centreline`]: seed 004 — rotary-axis centreline (direction, centre) from dial-gauge
//!   readings and NC-point correction (eq 9).

pub mod centreline;
pub mod lsq;
pub mod multitasking;
pub mod rtest;
pub mod two_step;
pub mod volumetric;
