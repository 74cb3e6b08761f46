//! The run vocabulary: the measuring pattern of a run and its direction, with the one name
//! table that SCPI, the CANopen codes, the log and stream metadata, replay and the docs use.

pub use crate::metrology::pattern::Direction;

/// The measuring pattern of a run (CANopen 0x3000 code = the discriminant).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum Pattern {
    /// ISO 230-4 circular test about the socket, full circle or partial arc, in the configured
    /// plane.
    #[default]
    Circle = 0,
    /// Seed 002 step BX: B arc 0 → 90°, bar along X (Table 4.3).
    Bx = 1,
    /// Seed 002 step BY: B arc 0 → 90°, bar along Y.
    By = 2,
    /// Seed 002 step CR: C circle, bar radial, tool length R_B.
    Cr = 3,
    /// Seed 002 step CA: C circle, bar axial.
    Ca = 4,
    /// Seed 002 step CR′ (written `CR2`): CR with the second tool length R′_B.
    Cr2 = 5,
    /// Single socket method (seed 000): per-sample E and dwell stations.
    Ssm = 6,
    /// Touch-probe points on a sphere (seed 002 chapter 5).
    Probe = 7,
}

impl Pattern {
    /// Every pattern, in code order.
    pub const ALL: [Pattern; 8] = [
        Pattern::Circle,
        Pattern::Bx,
        Pattern::By,
        Pattern::Cr,
        Pattern::Ca,
        Pattern::Cr2,
        Pattern::Ssm,
        Pattern::Probe,
    ];

    /// The five steps of the seed 002 procedure, in procedure order.
    pub const SEED002: [Pattern; 5] = [
        Pattern::Bx,
        Pattern::By,
        Pattern::Cr,
        Pattern::Ca,
        Pattern::Cr2,
    ];

    /// The name: `CIRCLE`, `BX`, `BY`, `CR`, `CA`, `CR2`, `SSM`, `PROBE`.
    pub const fn name(self) -> &'static str {
        match self {
            Pattern::Circle => "CIRCLE",
            Pattern::Bx => "BX",
            Pattern::By => "BY",
            Pattern::Cr => "CR",
            Pattern::Ca => "CA",
            Pattern::Cr2 => "CR2",
            Pattern::Ssm => "SSM",
            Pattern::Probe => "PROBE",
        }
    }

    /// The pattern of a name, in any letter case.
    pub fn from_name(name: &[u8]) -> Option<Self> {
        Self::ALL
            .into_iter()
            .find(|p| p.name().as_bytes().eq_ignore_ascii_case(name))
    }

    /// The pattern of a code (0…7).
    pub const fn from_u8(v: u8) -> Option<Self> {
        Some(match v {
            0 => Pattern::Circle,
            1 => Pattern::Bx,
            2 => Pattern::By,
            3 => Pattern::Cr,
            4 => Pattern::Ca,
            5 => Pattern::Cr2,
            6 => Pattern::Ssm,
            7 => Pattern::Probe,
            _ => return None,
        })
    }

    /// Index of a seed 002 step in [`Pattern::SEED002`].
    pub const fn seed002_step(self) -> Option<usize> {
        match self {
            Pattern::Bx => Some(0),
            Pattern::By => Some(1),
            Pattern::Cr => Some(2),
            Pattern::Ca => Some(3),
            Pattern::Cr2 => Some(4),
            _ => None,
        }
    }

    /// True for the patterns fitted as a circle or arc (ISO 230-4 and the seed 002 steps): the
    /// live eccentricity and r0, the run results.
    pub const fn is_circular(self) -> bool {
        match self {
            Pattern::Circle
            | Pattern::Bx
            | Pattern::By
            | Pattern::Cr
            | Pattern::Ca
            | Pattern::Cr2 => true,
            Pattern::Ssm | Pattern::Probe => false,
        }
    }

    /// True where the direction of the run matters (circular patterns; SSM and PROBE have none).
    pub const fn has_direction(self) -> bool {
        self.is_circular()
    }
}
