//! ballpod core: the hardware-independent measurement maths of the pod.
//!
//! `#![no_std]`, allocation-free and panic-free: every fallible operation returns a typed error,
//! buffers are fixed at compile time, and clippy denies `unwrap`/`expect`/`panic`/unchecked
//! indexing in this crate. The embassy firmware (`src/main.rs`, feature `firmware`) only moves
//! data between peripherals and these functions; `host-tests/` tests them against independent
//! oracles and drives them from the virtual machine tool.
//!
//! One folder per concern (see `design/DESIGN.md` §4):
//! - [`acquisition`]: raw sensor readings → calibrated, flagged [`acquisition::Sample`]s;
//! - [`config`]: the pod's configuration with units, defaults, ranges and a CRC'd binary encoding;
//! - [`metrology`]: samples → SSM position errors, circle fits, ISO 230-4 figures;
//! - [`identify`]: test results → machine deviations and corrections;
//! - [`app`]: the pod application — session, run monitor, the armed pattern's estimators, live
//!   values, results, procedures, recording — the same on the firmware, the simulator and
//!   replay;
//! - [`protocol`]: the CANopen and SCPI state machines: bytes and frames ↔ reads of the `app`
//!   and its commands;
//! - [`pod`]: the application with its protocol servers, log and stream: the one pod type every
//!   shell (board, emulated board, simulated pod) drives;
//! - [`settings`]: the configuration in two power-safe flash slots;
//! - [`boot`]: what a boot finds — the reset cause, the option bytes — and what is reported;
//! - [`num`]: small numeric helpers shared by all of them (hardware square root, CRC);
//! - [`units`]: the units of the configuration fields and the results (one name table).
#![no_std]
#![deny(missing_docs)]
#![deny(
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::indexing_slicing,
    clippy::unreachable,
    clippy::todo,
    clippy::unimplemented
)]
// `!(x > 0.0)` is the idiom this crate uses to reject NaN together with out-of-range values
// (a NaN fails every comparison, so the negation catches it); the lint would make each check
// longer and easier to get wrong.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

/// The firmware's version: the crate's version and the commit it was built from
/// (`0.2.0+1a2b3c4d5e6f`; `+unknown` outside a git checkout) — CANopen 0x100A (after
/// `ballpod `), `*IDN?`'s fourth field.
pub const FIRMWARE_VERSION: &str = concat!(env!("CARGO_PKG_VERSION"), "+", env!("BALLPOD_COMMIT"));

pub mod acquisition;
pub mod app;
pub mod boot;
pub mod config;
pub mod identify;
mod in_place;
pub mod metrology;
pub mod num;
pub mod pod;
pub mod protocol;
pub mod settings;
pub mod units;
