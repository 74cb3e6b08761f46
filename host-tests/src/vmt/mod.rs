//! The virtual machine tool: machines with deviations (forward models written on the host,
//! independent of the core) and the pod's peripherals (LVDT secondaries as ADC blocks, encoder
//! counters, bar thermistor) in virtual time. The pod's own code — its application
//! `ballpod::app` on `acquisition`, `metrology`, `identify` — does everything else.
//!
//! - [`machine`]: the seed 002 multi-tasking machine (literal HTM model of
//!   [`crate::forward_seed002`]) and an XY machine with linear-axis faults for circular tests;
//! - [`rtest_rig`]: the seed 003 A/C table-tilting machine under an R-test head (three LVDT
//!   channels → `methods::rtest_head`);
//! - [`ssm_rig`]: single-socket-method stations around a tool point (seed 000), through the
//!   pod and the core's station collector;
//! - [`probe_rig`]: touch-probe measurement of a sphere (pre-travel, repeatability, bounce)
//!   through the pod's probe latch and the core's sphere fit;
//! - [`lvdt_channel`]: one LVDT's ADC blocks through the core's demodulator;
//! - [`sensors`]: the pod's peripherals in virtual time (LVDT ADC blocks, encoder counters,
//!   thermistor, probe edges), with fault injection;
//! - [`motion`]: the virtual CNC of `sim --serve` (each pattern's motion, the chapter 5 probe
//!   sequence);
//! - [`nc_motion`]: a part program's path through LinuxCNC's interpreter (`rs274 -g`), run by
//!   run, sampled at the pod's rate (`sim --nc`);
//! - [`nc_program`]: a part program as LinuxCNC's task runs it, user M-codes in step with the
//!   motion (`sim --serve --program`);
//! - [`virtual_pod`]: the pod's application with its log, stream, CANopen slave and SCPI
//!   server on those sensors, behind `sim --serve`, the simulator and the fault-scenario tests.

pub mod lvdt_channel;
pub mod machine;
pub mod motion;
pub mod mounting;
pub mod nc_motion;
pub mod nc_program;
pub mod probe_rig;
pub mod rtest_rig;
pub mod sensors;
pub mod ssm_rig;
pub mod virtual_pod;
