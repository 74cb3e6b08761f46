//! The session: its states, the commands that move it, the one table of which state each
//! command needs (and its refusal otherwise), the typed refusals and procedure notes (their
//! words are the protocols': `protocol::text`).

use super::probe;
use crate::acquisition::MAX_AXES;
use crate::config::{Config, ConfigError, Field};

/// Session state (DESIGN §7a: configure → arm → run → results).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum SessionState {
    /// Nothing armed.
    #[default]
    Idle = 0,
    /// Armed: waiting for start.
    Armed = 1,
    /// Running: samples go into the estimators.
    Running = 2,
    /// Stopped normally: the run's results are valid.
    Done = 3,
    /// Aborted (by command or a fault): see [`App::abort_reason`](super::App::abort_reason).
    Aborted = 4,
}

impl SessionState {
    /// The name (SCPI `SESSion:STATe?`): `IDLE`, `ARMED`, `RUNNING`, `DONE`, `ABORTED`.
    pub const fn name(self) -> &'static str {
        match self {
            SessionState::Idle => "IDLE",
            SessionState::Armed => "ARMED",
            SessionState::Running => "RUNNING",
            SessionState::Done => "DONE",
            SessionState::Aborted => "ABORTED",
        }
    }
}

impl SessionState {
    /// True between runs: no run armed or running (a run's configuration, pattern, direction
    /// and procedures cannot change otherwise).
    pub const fn between_runs(self) -> bool {
        !matches!(self, SessionState::Armed | SessionState::Running)
    }
}

/// The sessions a command is carried out in, and its refusal in the others.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transition {
    /// The command.
    pub command: Command,
    /// The sessions it is carried out in.
    pub from: &'static [SessionState],
    /// Its refusal in any other session.
    pub refusal: CommandError,
}

/// Between runs: IDLE, DONE, ABORTED.
const BETWEEN_RUNS: &[SessionState] = &[
    SessionState::Idle,
    SessionState::Done,
    SessionState::Aborted,
];
/// Every session.
const ANY: &[SessionState] = &[
    SessionState::Idle,
    SessionState::Armed,
    SessionState::Running,
    SessionState::Done,
    SessionState::Aborted,
];

/// The session's state machine, one row per command: the sessions it is carried out in and its
/// refusal elsewhere (where it leads: the comment over each row, and [`Command`]'s doc).
pub const TRANSITIONS: [Transition; 8] = [
    // → ARMED (refused with the missing set-up field named)
    Transition {
        command: Command::Arm,
        from: BETWEEN_RUNS,
        refusal: CommandError::WrongState(Needs::Idle),
    },
    // → RUNNING
    Transition {
        command: Command::Start,
        from: &[SessionState::Armed],
        refusal: CommandError::WrongState(Needs::Armed),
    },
    // → DONE with results, or ABORTED (the reason) when the run has none
    Transition {
        command: Command::Stop,
        from: &[SessionState::Running],
        refusal: CommandError::WrongState(Needs::Running),
    },
    // → ABORTED
    Transition {
        command: Command::Abort,
        from: &[SessionState::Armed, SessionState::Running],
        refusal: CommandError::WrongState(Needs::ArmedOrRunning),
    },
    // → unchanged; procedures and results forgotten
    Transition {
        command: Command::Clear,
        from: BETWEEN_RUNS,
        refusal: CommandError::Busy,
    },
    // → IDLE (a run in progress aborted first)
    Transition {
        command: Command::Reset,
        from: ANY,
        refusal: CommandError::Busy,
    },
    // a save erases and programs a flash page (~26 ms with the bus stalled): between runs
    // only, whichever port asks (SCPI -221, SDO abort 0x0800 0022, LSS error)
    // → unchanged; the shell stores the configuration
    Transition {
        command: Command::StoreSettings,
        from: BETWEEN_RUNS,
        refusal: CommandError::Busy,
    },
    // → unchanged; the shell stores the defaults for the next reset
    Transition {
        command: Command::RestoreDefaults,
        from: BETWEEN_RUNS,
        refusal: CommandError::Busy,
    },
];

/// Whether `command` is carried out in `state` ([`TRANSITIONS`]), or its refusal.
pub fn admit(command: Command, state: SessionState) -> Result<(), CommandError> {
    match TRANSITIONS.iter().find(|t| t.command == command) {
        Some(t) if !t.from.contains(&state) => Err(t.refusal),
        _ => Ok(()),
    }
}

/// A session command (CANopen 0x3002 code = the discriminant; SCPI `SESSion:…`, `*RST`,
/// `*SAV`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Command {
    /// Arm a run of the selected pattern and direction (needs Idle, Done or Aborted and the
    /// pattern's geometry).
    Arm = 1,
    /// Start the armed run.
    Start = 2,
    /// Stop the running run: results, or an abort if it has none.
    Stop = 3,
    /// Abort the armed or running run (no results).
    Abort = 4,
    /// Forget the procedures' runs (circle directions, seed 002 steps, two-step, probe
    /// spheres) and every result (not while a run is armed or running).
    Clear = 5,
    /// Reset the application state: a run in progress is aborted, procedures and results are
    /// forgotten, the state is Idle; the configuration stays (`*RST`, NMT reset node).
    Reset = 6,
    /// Store the configuration in non-volatile memory (the shell does it: [`App::take_settings_request`](super::App::take_settings_request);
    /// not while a run is armed or running: the flash work would stall the sampling).
    StoreSettings = 7,
    /// Restore the default configuration at the next reset (CiA 301 0x1011; not while a run
    /// is armed or running).
    RestoreDefaults = 8,
}

impl Command {
    /// The command of a code.
    pub const fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            1 => Command::Arm,
            2 => Command::Start,
            3 => Command::Stop,
            4 => Command::Abort,
            5 => Command::Clear,
            6 => Command::Reset,
            7 => Command::StoreSettings,
            8 => Command::RestoreDefaults,
            _ => return None,
        })
    }
}

/// Why a command was refused (nothing changed). Its words are the protocols'
/// (`protocol::text`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CommandError {
    /// The command does not fit the state of the session or the pod.
    WrongState(Needs),
    /// Pattern, direction, configuration and procedures do not change while a run is armed
    /// or running.
    Busy,
    /// The armed pattern needs this set-up field, which is not set.
    Missing(Field),
    /// The configuration refused the value.
    Config(ConfigError),
}

/// What a refused command needed that the pod did not offer ([`CommandError::WrongState`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Needs {
    /// ARM: the session IDLE, DONE or ABORTED.
    Idle,
    /// START: a run armed.
    Armed,
    /// STOP: a run running.
    Running,
    /// ABORT: a run armed or running.
    ArmedOrRunning,
    /// A seed 002 step: its procedure (the set-up armed first).
    Procedure,
    /// The worker free (no computation running).
    NoComputation,
    /// An axis position: within the axis' range, the axis read at least once.
    AxisReadable,
}

/// What the last procedure step could not do although its run had results, or what an armed
/// self-triggered run waits for (`procedure_note`). Its words are the protocols'
/// (`protocol::text`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ProcedureNote {
    /// The step needs this set-up field, which is not set.
    Missing(Field),
    /// An armed FEED_IN run waits for the feed-in.
    WaitingForFeedIn,
    /// A FEED_IN run fed in waits for its data arc.
    WaitingForDataArc,
    /// The touch-probe C-axis identification gave no result.
    CAxisFailed,
    /// The touch-probe B-axis identification gave no result.
    BAxisFailed,
    /// The seed 002 identification gave no result.
    Seed002Failed,
    /// The SSM two-step identification gave no result.
    TwoStepFailed,
}

/// The procedure note of a touch-probe method that gave no result.
pub(super) fn probe_note(e: probe::ProbeFailure) -> ProcedureNote {
    match e {
        probe::ProbeFailure::Missing(f) => ProcedureNote::Missing(f),
        probe::ProbeFailure::CAxis(_) => ProcedureNote::CAxisFailed,
        probe::ProbeFailure::BAxis(_) => ProcedureNote::BAxisFailed,
    }
}

/// The user-facing name of a field.
pub fn field_name(f: Field) -> &'static str {
    match f {
        Field::PeriodsPerSample => "excitation / sample_rate (whole periods, 1 to 5)",
        Field::AxisNameDuplicate(_) => "axis name",
        Field::AxisCounterReach(i) => COUNTER_REACH
            .get(usize::from(i))
            .copied()
            .unwrap_or("axis_counts * axis_max_speed / sample_rate"),
        f => Config::field_info(f).map_or("field", |i| i.name),
    }
}

/// The refusal of each input's counter-reach rule ([`Config::counter_reach`]), naming its fields.
const COUNTER_REACH: [&str; MAX_AXES] = [
    "encoder input 1: axis_counts * axis_max_speed / sample_rate (counts per counter read)",
    "encoder input 2: axis_counts * axis_max_speed / sample_rate (counts per counter read)",
    "encoder input 3: axis_counts * axis_max_speed / sample_rate (counts per counter read)",
    "encoder input 4: axis_counts * axis_max_speed / sample_rate (counts per counter read)",
    "encoder input 5: axis_counts * axis_max_speed / sample_rate (counts per counter read)",
];

/// Settings the shell is asked to store.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SettingsRequest {
    /// Store the running configuration ([`App::config`](super::App::config)).
    Store,
    /// Store the defaults, to take effect at the next reset.
    RestoreDefaults,
}
