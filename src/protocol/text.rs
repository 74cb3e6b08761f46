//! The words of the application's refusals and procedure notes, as both protocols say them
//! (SCPI's error text, CANopen 0x3006 `last_refusal` and 0x3007 `procedure_note`): the
//! application keeps typed reasons ([`CommandError`], [`Needs`], [`ProcedureNote`]); the text
//! is made here, at the protocol edge.

use crate::app::{CommandError, Needs, ProcedureNote, field_name};
use crate::config::ConfigError;

impl Needs {
    /// What the refused command needed, in words.
    pub fn text(self) -> &'static str {
        match self {
            Needs::Idle => "ARM needs IDLE, DONE or ABORTED",
            Needs::Armed => "START needs ARMED",
            Needs::Running => "STOP needs RUNNING",
            Needs::ArmedOrRunning => "ABORT needs ARMED or RUNNING",
            Needs::Procedure => "no procedure",
            Needs::NoComputation => "not while a computation runs: ask again when it has ended",
            Needs::AxisReadable => "axis position out of range, or the axis not read yet",
        }
    }
}

impl CommandError {
    /// The refusal in words, as two static parts to print one after the other (a field name
    /// and what is wrong with it): e.g. `("circle_radius", " not set")`.
    pub fn text(&self) -> (&'static str, &'static str) {
        match *self {
            CommandError::WrongState(needs) => (needs.text(), ""),
            CommandError::Busy => ("not while a run is armed or running", ""),
            CommandError::Missing(f) => (field_name(f), " not set"),
            CommandError::Config(ConfigError::OutOfRange { field, .. }) => {
                (field_name(field), " out of range")
            }
            CommandError::Config(ConfigError::Duplicate { .. }) => ("axis name used twice", ""),
            CommandError::Config(_) => ("configuration refused", ""),
        }
    }
}

impl ProcedureNote {
    /// The note in words, as two static parts (as [`CommandError::text`]).
    pub fn text(&self) -> (&'static str, &'static str) {
        match *self {
            ProcedureNote::Missing(f) => (field_name(f), " not set"),
            ProcedureNote::WaitingForFeedIn => ("FEED_IN: waiting for the feed-in", ""),
            ProcedureNote::WaitingForDataArc => ("FEED_IN: fed in, waiting for the data arc", ""),
            ProcedureNote::CAxisFailed => ("C-axis identification failed", ""),
            ProcedureNote::BAxisFailed => ("B-axis identification failed", ""),
            ProcedureNote::Seed002Failed => ("seed 002 identification failed", ""),
            ProcedureNote::TwoStepFailed => ("two-step identification failed", ""),
        }
    }
}
