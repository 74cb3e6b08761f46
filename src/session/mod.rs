//! Session logic shared by the firmware and the simulator (DESIGN §7a): runs of a measuring
//! pattern fed sample by sample into the metrology estimators, per-run results, the
//! completeness of a procedure, and the identification once a procedure is complete.
//!
//! - [`seed002`]: the seed 002 ball-bar procedure (BX, BY, CR, CA, CR′, each CW and CCW, any
//!   number of repeats up to [`seed002::MAX_REPEATS`]) → eccentricities → deviations in thesis
//!   mode (eqs 4.10–4.18) and model-based mode (literal HTM model), with uncertainties
//!   propagated from the fits' residuals and the repeat scatter.
//! - [`circular`]: ISO 230-4 circular-test figures that combine both directions (servo
//!   mismatch).
//! - [`run`]: the run monitor every sample of a running session passes through: used or
//!   skipped, the run's counters, and the faults that abort it (bar dropped from the socket,
//!   lost samples, too few valid samples).
//!
//! The session owns no peripheral and allocates nothing: the caller (firmware task or host
//! simulator) hands over [`crate::acquisition::Sample`]s and says which run they belong to.

pub mod circular;
pub mod run;
pub mod seed002;
