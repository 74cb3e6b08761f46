//! Host side of ballpod: what a user runs on a PC, and what the tests check the pod against.
//!
//! Two kinds of module, kept apart below:
//!
//! - **products** — what the binaries (`sim`, `replay`, `ncgen`, `emu`, `fw-image`,
//!   `gen-docs`, `gen-eds`) are made of: the virtual machine tool and the simulated pod, replay
//!   and its inputs and report, part programs, the served ports, the host-only methods;
//! - **oracles and rigs** — independent models the tests hold the pod to (forward models of
//!   every seed and of two controls' kinematics, f64 least squares, the LVDT's and the flash's
//!   physics, GUM coverage factors), and the test rigs built on them (scenarios, the layer
//!   table, the book's checks).
//!
//! The oracles are written from the papers and the standards, not from the core's code; the
//! virtual machine tool takes its truth from the forward models.

// ---- products
pub mod cli;
#[cfg(feature = "desk")]
pub mod desk;
pub mod diagonals;
pub mod docs_ref;
pub mod emu;
pub mod fw_image;
pub mod methods;
pub mod ncgen;
pub mod recording;
pub mod replay;
pub mod report;
pub mod serve;
pub mod session_file;
pub mod simulate;
pub mod slcan;
pub mod vmt;

// ---- oracles and rigs
pub mod app_state;
pub mod docs;
pub mod flash_model;
pub mod forward_linuxcnc_trt;
pub mod forward_seed000;
pub mod forward_seed001;
pub mod forward_seed002;
pub mod forward_seed003;
pub mod forward_seed004;
pub mod forward_siemens_carr;
pub mod gum;
pub mod layers;
pub mod lvdt_model;
pub mod oracle;
pub mod rng;
pub mod scenario;

/// Runs the jobs `app` wants here and now, in a slot of this thread's ([`ballpod::app::job`]:
/// the figures a run's end left, an identification; the pod runs them at its lowest priority
/// while it goes on): what a test that drives the application directly does after a STOP
/// before it reads the results. Returns whether there was one.
pub fn run_jobs(app: &mut ballpod::app::App) -> bool {
    use std::cell::RefCell;
    thread_local! {
        static SLOT: RefCell<Box<ballpod::app::JobSlot>> =
            RefCell::new(Box::new(ballpod::app::JobSlot::new()));
    }
    SLOT.with(|s| app.run_jobs(&mut s.borrow_mut()))
}
