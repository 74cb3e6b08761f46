//! Identification: test results → machine geometric deviations and NC corrections (f64,
//! nalgebra fixed-size, no allocation; DESIGN §6).
//!
//! - [`lsq`]: streaming Givens least squares with rank, conditioning and uncertainties, shared
//!   by every method.
//! - [`multitasking`]: seed 002 (B head + C table): ball-bar and touch-probe identification, NC fix.

pub mod lsq;
pub mod multitasking;
