//! The kinds of the configuration's coded fields and enumerated objects: axis names, the LVDT
//! input mode, CAN bit rates, the circle's plane, the two-step machine type and the run
//! trigger, each with its code (the byte that is stored and sent).

/// Names of the axes the encoder inputs can be assigned to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum AxisName {
    /// Input not used.
    Unused = 0,
    /// Linear X, mm.
    X = 1,
    /// Linear Y, mm.
    Y = 2,
    /// Linear Z, mm.
    Z = 3,
    /// Rotary A (about X), degrees.
    A = 4,
    /// Rotary B (about Y), degrees.
    B = 5,
    /// Rotary C (about Z), degrees.
    C = 6,
}

impl AxisName {
    /// From its encoded byte.
    pub const fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            0 => Self::Unused,
            1 => Self::X,
            2 => Self::Y,
            3 => Self::Z,
            4 => Self::A,
            5 => Self::B,
            6 => Self::C,
            _ => return None,
        })
    }
    /// True for the rotary axes (positions in degrees); linear axes are in mm.
    pub const fn is_rotary(self) -> bool {
        matches!(self, Self::A | Self::B | Self::C)
    }
    /// The axis letter (`-` when unused).
    pub const fn letter(self) -> char {
        match self {
            Self::Unused => '-',
            Self::X => 'X',
            Self::Y => 'Y',
            Self::Z => 'Z',
            Self::A => 'A',
            Self::B => 'B',
            Self::C => 'C',
        }
    }
}

/// How the LVDT is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum LvdtInput {
    /// The pod excites the primary and demodulates both secondaries (ratiometric).
    AcRatiometric = 0,
    /// An external conditioner delivers a DC voltage proportional to position.
    DcConditioner = 1,
}

/// CAN bit rates the pod supports, bit/s.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum CanBitrate {
    /// 125 kbit/s.
    K125 = 0,
    /// 250 kbit/s.
    K250 = 1,
    /// 500 kbit/s (default).
    K500 = 2,
    /// 1 Mbit/s.
    M1 = 3,
}

impl CanBitrate {
    /// Bit rate in bit/s.
    pub const fn bits_per_s(self) -> u32 {
        match self {
            Self::K125 => 125_000,
            Self::K250 => 250_000,
            Self::K500 => 500_000,
            Self::M1 => 1_000_000,
        }
    }
    /// From its encoded byte.
    pub const fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            0 => Self::K125,
            1 => Self::K250,
            2 => Self::K500,
            3 => Self::M1,
            _ => return None,
        })
    }
}

/// Plane of an ISO 230-4 circular test: its first (u) and second (v) axis, right-handed about
/// the third, so that counter-clockwise (θ increasing from +u towards +v) is positive about
/// the plane's normal (ISO 230-4: XY viewed from +Z, YZ from +X, ZX from +Y).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum CirclePlane {
    /// u = X, v = Y.
    XY = 0,
    /// u = Y, v = Z.
    YZ = 1,
    /// u = Z, v = X.
    ZX = 2,
}

impl CirclePlane {
    /// Names in code order (the choices of the `circle_plane` field).
    pub const NAMES: [&'static str; 3] = ["XY", "YZ", "ZX"];
    /// From its code.
    pub const fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            0 => Self::XY,
            1 => Self::YZ,
            2 => Self::ZX,
            _ => return None,
        })
    }
}

/// The machine type of the seed 000 two-step identification (seed 000 Fig. 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum TwoStepMachine {
    /// No two-step identification: SSM runs report E only.
    None = 0,
    /// Both rotary axes in the spindle head (α about X, β about Y).
    Rrttt = 1,
    /// Both rotary axes in the table (α about X, γ about Z).
    Tttrr = 2,
    /// The β spindle-head axis of an RTTTR machine.
    RtttrSpindle = 3,
    /// The α table axis of an RTTTR machine.
    RtttrTable = 4,
}

/// What starts and stops a run (the `run_trigger` field).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum RunTrigger {
    /// The client's START and STOP (CANopen 0x3002, `SESS:STAR` / `SESS:STOP`) only.
    Command = 0,
    /// A CIRCLE run also starts at the end of the part program's feed-in and stops at the end
    /// of the data arc (`circle_arc`) or at the feed-out (`app::trigger`).
    FeedIn = 1,
}

impl RunTrigger {
    /// Names in code order (the choices of the `run_trigger` field).
    pub const NAMES: [&'static str; 2] = ["COMMAND", "FEED_IN"];
    /// From its code.
    pub const fn from_u8(v: u8) -> Option<Self> {
        match v {
            0 => Some(Self::Command),
            1 => Some(Self::FeedIn),
            _ => None,
        }
    }
}

impl TwoStepMachine {
    /// Names in code order (the choices of the `ts_machine` field).
    pub const NAMES: [&'static str; 5] = ["NONE", "RRTTT", "TTTRR", "RTTTR_SPINDLE", "RTTTR_TABLE"];
    /// From its code.
    pub const fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            0 => Self::None,
            1 => Self::Rrttt,
            2 => Self::Tttrr,
            3 => Self::RtttrSpindle,
            4 => Self::RtttrTable,
            _ => return None,
        })
    }
}
