//! The measuring methods that run on the technician's PC only (replay session tables, `ncgen`
//! corrections), not on the pod: the firmware never calls them, so they live in the host crate
//! and not in the pod's flash image. They keep the pod crate's rules — no allocation, no
//! panics, typed errors — so one could move onto the pod unchanged.
//!
//! - [`volumetric`]: seed 001 rigid-body volumetric error model, body-diagonal and vector
//!   diagonal methods, grid/thermal compensation, volumetric-error definitions, table conventions.
//! - [`rtest`]: seed 003 — R-test identification of A/C table-tilting location errors
//!   (first-order chain model, 11-parameter least squares with rank check, verification).
//! - [`rtest_head`]: the R-test head's three LVDT channels → sphere-centre displacement.
//! - [`centreline`]: seed 004 — rotary-axis centreline (direction, centre) from dial-gauge
//!   readings and NC-point correction (eq 9).
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing,
    clippy::unreachable,
    clippy::todo,
    clippy::unimplemented
)]
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod centreline;
pub mod rtest;
pub mod rtest_head;
pub mod volumetric;
