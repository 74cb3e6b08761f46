//! Protocol layers: the CNC's CANopen view and the technician's SCPI view of the same pod, and
//! the text the pod records runs in.
//!
//! Both are transport-agnostic state machines over plain data (frames / lines and elapsed time
//! in, frames / lines out). They read the pod's state from the application
//! ([`crate::app::App`]: live values, configuration, session, results) and hand it the clients'
//! commands; every decision (is this command allowed now, is that result valid) is the
//! application's, so both protocols answer the same way.
//!
//! - [`canopen`]: the CiA 301 slave (NMT, heartbeat, SDO, SYNC/TPDO, EMCY) and its EDS.
//! - [`scpi`]: the USB command interface (IEEE 488.2 / SCPI-99 parser, status model, error queue).
//! - [`csv`]: the text of a recorded run (header, samples, touch points, end);
//! - [`download`]: the log download (`DATA:LOG?`) in that text;
//! - [`stream`]: the USB sample stream in that text;
//! - [`slcan`]: CAN frames as SLCAN text lines (the simulated and the emulated pod's CAN port);
//! - [`text`]: the words of the application's refusals and procedure notes.

pub mod canopen;
pub mod csv;
pub mod download;
pub mod scpi;
pub mod slcan;
pub mod stream;
pub mod text;

use crate::app::CommandError;
use crate::config::ConfigError;

/// Reports settings slots found unreadable at boot (`unreadable`, from
/// [`Loaded::unreadable`](crate::settings::Loaded::unreadable): a double ECC error, a save cut
/// by a power loss; the other slot's settings or the defaults are in use) on both protocols:
/// CANopen EMCY 0x6300 byte 3 = 7 after the boot-up; SCPI -315 `"Configuration memory
/// lost;settings slot unreadable …"`. Called once at boot (`Pod::boot`).
pub fn report_unreadable_settings(
    unreadable: u32,
    node: &mut canopen::CanOpenNode,
    scpi: &mut scpi::ScpiServer,
) {
    if unreadable > 0 {
        node.report_boot_error(
            canopen::emcy::DATA_SET,
            canopen::emcy::REASON_SETTINGS_UNREADABLE,
        );
        scpi.push_settings_rejected(
            "settings slot unreadable (flash ECC error: a save cut by a power loss)",
            "",
        );
    }
}

/// Reports a stored configuration rejected at boot (`rejected`, from
/// [`Loaded::rejected`](crate::settings::Loaded::rejected); the other slot's settings or the
/// defaults are in use) on both protocols: CANopen EMCY 0x6300 (data set),
/// byte 3 = 3, after the boot-up; SCPI -315 `"Configuration memory lost;<what> <why>"`.
/// The firmware and the simulated pod call it once at boot.
pub fn report_rejected_settings(
    rejected: Option<ConfigError>,
    node: &mut canopen::CanOpenNode,
    scpi: &mut scpi::ScpiServer,
) {
    if let Some(e) = rejected {
        node.report_boot_error(
            canopen::emcy::DATA_SET,
            canopen::emcy::REASON_SETTINGS_REJECTED,
        );
        let (what, why) = CommandError::Config(e).text();
        scpi.push_settings_rejected(what, why);
    }
}
