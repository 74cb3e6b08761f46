//! Host side of ballpod: independent f64 oracles, the virtual machine tool and the simulator.

pub mod app_state;
pub mod cli;
pub mod diagonals;
pub mod docs;
pub mod docs_ref;
pub mod flash_model;
pub mod forward_seed000;
pub mod forward_seed001;
pub mod forward_seed002;
pub mod forward_seed003;
pub mod forward_seed004;
pub mod gum;
pub mod lvdt_model;
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
