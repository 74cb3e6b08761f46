//! Identification: test results → machine geometric deviations and NC corrections (f64,
//! nalgebra fixed-size, no allocation; DESIGN §6).
//!
//! - [`lsq`]: streaming Givens least squares with rank, conditioning and uncertainties, shared
//!   by every method.
//! - [`two_step`]: seed 000 two-step orientation errors of RRTTT / TTTRR / RTTTR machines from two
//!   SSM measurements (exact inversion and corrected paper formulas).
//! - [`mill_turn`]: seed 002 (B head + C table): ball-bar and touch-probe identification, NC fix.
//!
//! The methods that run on the host only (seeds 001, 003, 004) are in the host crate
//! (`ballpod_host::methods`): the firmware never calls them.

pub mod lsq;
pub mod mill_turn;
pub mod two_step;
