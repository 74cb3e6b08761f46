//! Identification: test results → machine geometric deviations and NC corrections (f64,
//! nalgebra fixed-size, no allocation; DESIGN §6).
//!
//! - [`lsq`]: streaming Givens least squares with rank, conditioning and uncertainties, shared
//!   by every method.

pub mod lsq;
