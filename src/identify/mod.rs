//! Identification: test results → machine geometric deviations and NC corrections (f64,
//! nalgebra fixed-size, no allocation; DESIGN §6).
//!
//! - [`lsq`]: streaming Givens least squares with rank, conditioning and uncertainties, shared
//!   by every method.
//! - [`centreline`]: seed 004 — rotary-axis centreline (direction, centre) from dial-gauge
//!   readings and NC-point correction (eq 9).
//! - [`rtest`]: seed 003 — R-test identification of A/C table-tilting location errors
//!   (first-order chain model, 11-parameter least squares with rank check, verification).

pub mod centreline;
pub mod lsq;
pub mod rtest;
