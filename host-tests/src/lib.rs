//! Host side of ballpod: independent f64 oracles, the virtual machine tool and the simulator.

pub mod app_state;
pub mod cli;
pub mod diagonals;
pub mod docs;
pub mod docs_ref;
pub mod emu;
pub mod flash_model;
pub mod forward_linuxcnc_trt;
pub mod forward_seed000;
pub mod forward_seed001;
pub mod forward_seed002;
pub mod forward_seed003;
pub mod forward_seed004;
pub mod forward_siemens_carr;
pub mod fw_image;
pub mod gum;
pub mod layers;
pub mod lvdt_model;
pub mod methods;
pub mod ncgen;
pub mod oracle;
pub mod recording;
pub mod replay;
pub mod report;
pub mod rng;
pub mod scenario;
pub mod serve;
pub mod session_file;
pub mod simulate;
pub mod slcan;
pub mod vmt;

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
