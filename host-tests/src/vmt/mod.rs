//! The virtual machine tool: machines with deviations (forward models written on the host,
//! independent of the core) and the pod's peripherals (LVDT secondaries as ADC blocks, encoder
//! counters, bar thermistor) in virtual time. The pod's own code — `ballpod::acquisition`,
//! `metrology`, `session`, `identify` — does everything else.
//!
//! - [`machine`]: the seed 002 multi-tasking machine (literal HTM model of
//!   [`crate::forward_seed002`]) and an XY machine with linear-axis faults for circular tests;
//! - [`pod`]: sensor-level streams through `ballpod::acquisition` → [`ballpod::acquisition::Sample`],
//!   with fault injection;
//! - [`virtual_pod`]: the pod's application on a circle (run monitor, fit, log, CANopen, SCPI),
//!   behind `sim --serve` and the fault-scenario tests.

pub mod machine;
pub mod pod;
pub mod virtual_pod;
