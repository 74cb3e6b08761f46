//! The pod as the protocol layers see it: live process values, the status word, the session
//! state, the configuration and the results table. The application (firmware or simulator)
//! keeps it up to date and executes the [`SessionCommand`]s the protocols emit.

use crate::acquisition::SampleFlags;
use crate::config::Config;
use crate::session::run::RunCounters;

/// Status word bits (CANopen live value, SCPI `STATus:POD?`): sample validity, faults and the
/// session state in one `u16`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StatusWord(pub u16);

impl StatusWord {
    /// Bits 0–5: the latest sample's [`SampleFlags`] (same bit positions).
    pub const SAMPLE_FLAGS_MASK: u16 = 0x003F;
    /// Bit 8: a session is armed.
    pub const ARMED: u16 = 1 << 8;
    /// Bit 9: a session is running (samples go into the fits).
    pub const RUNNING: u16 = 1 << 9;
    /// Bit 10: results of the last run are available.
    pub const RESULTS_READY: u16 = 1 << 10;
    /// Bit 11: the last run was aborted (reason in [`PodModel::abort_reason`]).
    pub const ABORTED: u16 = 1 << 11;
    /// Bit 15: an error is pending (EMCY sent / SCPI error queue not empty).
    pub const ERROR: u16 = 1 << 15;

    /// The status word of a sample's flags and a session state.
    pub const fn new(flags: SampleFlags, session: SessionState, error: bool) -> Self {
        let mut w = flags.0 & Self::SAMPLE_FLAGS_MASK;
        w |= match session {
            SessionState::Idle => 0,
            SessionState::Armed => Self::ARMED,
            SessionState::Running => Self::RUNNING,
            SessionState::Done => Self::RESULTS_READY,
            SessionState::Aborted => Self::ABORTED,
        };
        if error {
            w |= Self::ERROR;
        }
        Self(w)
    }
}

/// The live process values, refreshed every sample (CANopen TPDOs, SCPI `MEASure?`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LiveValues {
    /// Sample counter of the latest sample.
    pub sample_counter: u32,
    /// ΔL of the latest sample, µm.
    pub delta_l_um: f32,
    /// Per-sample SSM total position error E = (Ex, Ey, Ez), µm (0 where not observable).
    pub ssm_e_um: [f32; 3],
    /// Running circle-fit eccentricity e_x, µm.
    pub ecc_x_um: f32,
    /// Running circle-fit eccentricity e_y, µm.
    pub ecc_y_um: f32,
    /// Running circle-fit radius deviation r0, µm.
    pub r0_um: f32,
    /// Bar temperature, °C.
    pub temp_c: f32,
    /// Status word.
    pub status: StatusWord,
}

/// Session state (DESIGN §7a: configure → arm → run → results).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum SessionState {
    /// Nothing armed.
    #[default]
    Idle = 0,
    /// Armed: waiting for start (by command, or the CNC's first motion).
    Armed = 1,
    /// Running: samples go into the fits.
    Running = 2,
    /// Stopped normally: results available.
    Done = 3,
    /// Aborted (by command or a fault): see [`PodModel::abort_reason`].
    Aborted = 4,
}

/// The measuring pattern of the next run (ISO 230-4 circle, seed 002 patterns, SSM, probe).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum Pattern {
    /// ISO 230-4 circular test about the socket.
    #[default]
    Circle = 0,
    /// Seed 002 pattern BX (B arc, bar along X).
    Bx = 1,
    /// Seed 002 pattern BY (B arc, bar along Y).
    By = 2,
    /// Seed 002 pattern CR (C rotation, bar radial).
    Cr = 3,
    /// Seed 002 pattern CA (C rotation, bar axial).
    Ca = 4,
    /// Seed 002 pattern CR′ (CR with the second tool length).
    CrPrime = 5,
    /// Single-socket-method stations / streaming (seed 000).
    Ssm = 6,
    /// Touch-probe points (seed 002 chapter 5, seed 004).
    Probe = 7,
}

impl Pattern {
    /// From its encoded byte.
    pub const fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            0 => Self::Circle,
            1 => Self::Bx,
            2 => Self::By,
            3 => Self::Cr,
            4 => Self::Ca,
            5 => Self::CrPrime,
            6 => Self::Ssm,
            7 => Self::Probe,
            _ => return None,
        })
    }
}

/// Direction of a run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum Direction {
    /// Counter-clockwise (positive about the axis).
    #[default]
    Ccw = 0,
    /// Clockwise.
    Cw = 1,
}

/// Why a run was aborted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum AbortReason {
    /// Aborted by the CNC or the technician.
    ByCommand = 1,
    /// The LVDT went open or over-range (bar dropped from the socket).
    LvdtFault = 2,
    /// Samples were lost (overrun).
    Overrun = 3,
    /// Too few valid samples or too short an arc for the pattern.
    NotObservable = 4,
}

/// An action a protocol asks of the application.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SessionCommand {
    /// Arm a run of `pattern` in `direction`.
    Arm {
        /// Pattern of the run.
        pattern: Pattern,
        /// Direction of the run.
        direction: Direction,
    },
    /// Start the armed run now.
    Start,
    /// Stop the run normally and compute results.
    Stop,
    /// Abort the run (no results).
    Abort,
    /// The configuration in [`PodModel::config`] changed (already validated): apply it.
    ConfigChanged,
    /// Store the configuration to non-volatile memory (CANopen 0x1010 "save", SCPI `*SAV`).
    StoreSettings,
    /// Restore default parameters (CANopen 0x1011 "load", effective at the next reset).
    RestoreDefaults,
    /// Reset the pod's application state (`*RST`, NMT reset node).
    Reset,
}

/// Number of entries in the results table.
pub const RESULT_COUNT: usize = 16;

/// One result with its quality.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ResultEntry {
    /// The value in the unit of [`RESULTS`].
    pub value: f32,
    /// Its standard uncertainty (same unit); 0 where the method has no redundancy.
    pub std_uncertainty: f32,
    /// True once computed for the current run / procedure.
    pub valid: bool,
}

/// Name and unit of each results-table entry, in order (CANopen 0x4000 sub-index k+1, SCPI
/// `FETCh:RESult? k`). ISO 230-4 figures carry their 2022 names with the 2005 name in the doc.
pub const RESULTS: [(&str, &str); RESULT_COUNT] = [
    ("ecc_x", "um"),      // eccentricity e_x of the last run (limaçon fit)
    ("ecc_y", "um"),      // eccentricity e_y
    ("r0", "um"),         // radius deviation
    ("G_ccw", "um"),      // circular deviation, CCW (ISO 230-4 G)
    ("G_cw", "um"),       // circular deviation, CW
    ("G_bidir", "um"),    // bi-directional circular deviation
    ("F_max", "um"),      // radial deviation max
    ("F_min", "um"),      // radial deviation min
    ("H", "um"),          // circular hysteresis
    ("alpha_CZ", "urad"), // seed 002 identified deviations (eqs 4.10–4.18) …
    ("beta_CZ", "urad"),
    ("alpha_XB", "urad"),
    ("beta_XB", "urad"),
    ("gamma_XB", "urad"),
    ("alpha_BT", "urad"),
    ("dx_CZ_minus_dx_BT", "um"),
];

/// The pod as the protocol layers see it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PodModel {
    /// The active configuration (changes only through `Config::try_update`).
    pub config: Config,
    /// Live values of the latest sample.
    pub live: LiveValues,
    /// Session state.
    pub session: SessionState,
    /// Pattern of the current / next run.
    pub pattern: Pattern,
    /// Direction of the current / next run.
    pub direction: Direction,
    /// Why the last run was aborted, if it was.
    pub abort_reason: Option<AbortReason>,
    /// Results table.
    pub results: [ResultEntry; RESULT_COUNT],
    /// Accounting of the current / last run (CANopen 0x3005, SCPI `SESSion:COUNt?`).
    pub run: RunCounters,
}

impl PodModel {
    /// Applies the session-state part of a command the protocols accepted (they have already
    /// checked it against the current state): Arm → Armed with its pattern and direction,
    /// Start → Running, Stop → Done, Abort → Aborted (by command), Reset → Idle. The other
    /// commands leave the session state alone; the application does the rest of each command
    /// (resetting estimators, starting the log, storing settings).
    pub fn apply(&mut self, cmd: SessionCommand) {
        match cmd {
            SessionCommand::Arm { pattern, direction } => {
                self.pattern = pattern;
                self.direction = direction;
                self.abort_reason = None;
                self.run = RunCounters::default();
                self.session = SessionState::Armed;
            }
            SessionCommand::Start => self.session = SessionState::Running,
            SessionCommand::Stop => self.session = SessionState::Done,
            SessionCommand::Abort => {
                self.abort_reason = Some(AbortReason::ByCommand);
                self.session = SessionState::Aborted;
            }
            SessionCommand::Reset => {
                self.session = SessionState::Idle;
                self.abort_reason = None;
            }
            SessionCommand::ConfigChanged
            | SessionCommand::StoreSettings
            | SessionCommand::RestoreDefaults => {}
        }
    }

    /// Ends the running (or just stopped) run as aborted by the application for `reason` (a
    /// fault the run monitor found): state Aborted, the reason for CANopen 0x3004 and SCPI
    /// `SESSion:REASon?`, every result invalid.
    pub fn abort_run(&mut self, reason: AbortReason) {
        self.session = SessionState::Aborted;
        self.abort_reason = Some(reason);
        for r in &mut self.results {
            r.valid = false;
        }
    }
}
