//! Protocol layers: the CNC's CANopen view and the technician's SCPI view of the same pod.
//!
//! Both are transport-agnostic state machines over plain data (frames / lines and elapsed time
//! in, frames / lines out). They read and write the pod through [`pod::PodModel`] — live
//! values, configuration, session state, results — and hand session actions back to the
//! application as [`pod::SessionCommand`]s, so the same code runs in the firmware and in the
//! simulator.
//!
//! - [`pod`]: the shared model (live values, status word, session, results table).
//! - [`canopen`]: the CiA 301 slave (NMT, heartbeat, SDO, SYNC/TPDO, EMCY) and its EDS.
//! - [`scpi`]: the USB command interface (IEEE 488.2 / SCPI-99 parser, status model, error queue).
//! - [`log`]: the fixed-capacity sample log and its CSV download format.

pub mod canopen;
pub mod log;
pub mod pod;
pub mod scpi;
