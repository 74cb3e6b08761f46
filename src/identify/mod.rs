//! Identification: test results → machine geometric deviations and NC corrections (f64,
//! nalgebra fixed-size, no allocation; DESIGN §6).
//!
//! - [`lsq`]: streaming Givens least squares with rank, conditioning and uncertainties, shared
//!   by every method.
//! - [`centreline`]: seed 004 — rotary-axis centreline (direction, centre) from dial-gauge
//!   readings and NC-point correction (eq 9).

pub mod centreline;
pub mod lsq;
