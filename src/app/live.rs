//! The live process values, refreshed every sample (CANopen 0x2100–0x2103 and TPDOs, SCPI
//! `MEASure:ALL?`), and the status word. A live value that is not observable yet (the circle
//! has not turned its minimum arc, an SSM component the path cannot see, the LVDT open) is
//! **invalid**: its bit in [`LiveValues::valid`] is clear and the value is NaN, never 0.0.

use super::SessionState;
use crate::acquisition::SampleFlags;

/// Samples between two refreshes of a live u: the live E's at every sample whose counter is
/// a multiple of this, the live circle fit's at every this many used samples of the run
/// (computed every sample it would take the SSM pipeline past its 2 500 instructions); held
/// between while its value is valid, invalid where the value is not. The live E's is refreshed
/// more often while its window grows ([`super::ssm::LIVE_U_EVERY_GROWING`]).
pub const LIVE_U_EVERY: u32 = 32;

/// Names and units of the live REAL32 values, in CANopen sub-index order (0x2100:k+1) and bit
/// order of [`LiveValues::valid`].
pub const LIVE: [(&str, &str); LIVE_COUNT] = [
    ("delta_l", "um"),
    ("ssm_ex", "um"),
    ("ssm_ey", "um"),
    ("ssm_ez", "um"),
    ("ecc_u", "um"),
    ("ecc_v", "um"),
    ("r0", "um"),
    ("temp", "degC"),
    ("u_ssm_ex", "um"),
    ("u_ssm_ey", "um"),
    ("u_ssm_ez", "um"),
    ("u_ecc_u", "um"),
    ("u_ecc_v", "um"),
    ("u_r0", "um"),
];

/// Number of live REAL32 values.
pub const LIVE_COUNT: usize = 14;

/// Index of each live value in [`LIVE`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Live {
    /// ΔL of the latest sample, µm.
    DeltaL = 0,
    /// SSM E_x at the latest sample (streaming neighbourhood), µm.
    SsmEx = 1,
    /// SSM E_y, µm.
    SsmEy = 2,
    /// SSM E_z, µm.
    SsmEz = 3,
    /// Running circle-fit eccentricity e_u, µm.
    EccU = 4,
    /// Running circle-fit eccentricity e_v, µm.
    EccV = 5,
    /// Running circle-fit radius change r0, µm.
    R0 = 6,
    /// Bar temperature, °C.
    Temp = 7,
    /// Standard uncertainty of the live E_x (Type A from the neighbourhood's residual, the
    /// bar's length, temperature and scale; refreshed every [`LIVE_U_EVERY`] samples), µm;
    /// U = 2u.
    USsmEx = 8,
    /// Standard uncertainty of the live E_y, µm.
    USsmEy = 9,
    /// Standard uncertainty of the live E_z, µm.
    USsmEz = 10,
    /// Standard uncertainty of the live e_u (Type A: a CIRCLE run's from its profile's noise,
    /// a seed 002 step's from the fit's residual; the LVDT's scale: the run's result's u if
    /// the run ended at the refresh; refreshed every [`LIVE_U_EVERY`] samples), µm; U = 2u.
    UEccU = 11,
    /// Standard uncertainty of the live e_v, µm.
    UEccV = 12,
    /// Standard uncertainty of the live r0 (as e's, with the bar's length and temperature),
    /// µm.
    UR0 = 13,
}

/// The live values of the latest sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LiveValues {
    /// Sample counter of the latest sample (counts lost samples too).
    pub sample_counter: u32,
    /// The values in [`LIVE`] order (NaN where invalid).
    pub values: [f32; LIVE_COUNT],
    /// Bit k set: `values[k]` is valid.
    pub valid: u16,
    /// Status word.
    pub status: StatusWord,
}

impl Default for LiveValues {
    fn default() -> Self {
        Self {
            sample_counter: 0,
            values: [f32::NAN; LIVE_COUNT],
            valid: 0,
            status: StatusWord::default(),
        }
    }
}

impl LiveValues {
    /// The validity bits of the values `ks` (for [`Self::all_valid`]).
    pub const fn mask(ks: &[Live]) -> u16 {
        let mut m = 0;
        let mut rest = ks;
        while let [k, tail @ ..] = rest {
            m |= 1 << (*k as u16);
            rest = tail;
        }
        m
    }

    /// Whether every value of `mask` ([`Self::mask`]) is valid.
    pub const fn all_valid(&self, mask: u16) -> bool {
        self.valid & mask == mask
    }

    /// The value `k`, or `None` while it is invalid.
    pub fn get(&self, k: Live) -> Option<f32> {
        let i = k as usize;
        if self.valid & (1 << i) != 0 {
            self.values.get(i).copied()
        } else {
            None
        }
    }

    /// Marks the values of `mask` ([`Self::mask`]) invalid (NaN).
    pub fn invalidate(&mut self, mask: u16) {
        if self.valid & mask != 0 {
            for (k, v) in self.values.iter_mut().enumerate() {
                if mask & (1 << k) != 0 {
                    *v = f32::NAN;
                }
            }
            self.valid &= !mask;
        }
    }

    /// Sets value `k` (`None` or a non-finite value marks it invalid).
    pub fn set(&mut self, k: Live, v: Option<f32>) {
        let i = k as usize;
        let x = v.unwrap_or(f32::NAN);
        let ok = x.is_finite();
        if let Some(slot) = self.values.get_mut(i) {
            *slot = if ok { x } else { f32::NAN };
        }
        let bit = 1 << i;
        self.valid = if ok {
            self.valid | bit
        } else {
            self.valid & !bit
        };
    }
}

/// Status word bits (CANopen 0x2102, SCPI `STATus:POD?`): sample validity, faults and the
/// session state in one `u16`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StatusWord(pub u16);

impl StatusWord {
    /// Bits 0–5: the latest sample's [`SampleFlags`] (same bit positions).
    pub const SAMPLE_FLAGS_MASK: u16 = 0x003F;
    /// Bit 6: a job is wanted or running ([`crate::app::job`]: the ISO 230-4 figures of a
    /// CIRCLE run that ended, the seed 002 identification); the results it publishes are
    /// invalid, and [`Self::RESULTS_READY`] is clear, until it has.
    pub const COMPUTING: u16 = 1 << 6;
    /// Bit 8: a run is armed.
    pub const ARMED: u16 = 1 << 8;
    /// Bit 9: a run is running (samples go into its estimators).
    pub const RUNNING: u16 = 1 << 9;
    /// Bit 10: the last run ended normally and has valid results (every job it left has
    /// published them: [`Self::COMPUTING`] is clear).
    pub const RESULTS_READY: u16 = 1 << 10;
    /// Bit 11: the last run was aborted (reason: CANopen 0x3004, SCPI `SESSion:REASon?`).
    pub const ABORTED: u16 = 1 << 11;
    /// Bit 12: every live value of the armed pattern is valid (CIRCLE / seed 002: e and r0;
    /// SSM: all three components of E).
    pub const LIVE_VALID: u16 = 1 << 12;
    /// Bit 13: the seed 002 identification is wanted or running (procedure complete,
    /// computing; [`Self::COMPUTING`] is set too).
    pub const IDENTIFYING: u16 = 1 << 13;
    /// Bit 14: a field that takes effect at reset ([`crate::config::AT_RESET`]) differs from
    /// the value the pod runs with.
    pub const RESET_PENDING: u16 = 1 << 14;
    /// Bit 15: a fault is present: the latest sample is flagged invalid for metrology or its
    /// temperature is faulty, or the last settings save failed.
    pub const ERROR: u16 = 1 << 15;

    /// The status word of a sample's flags, a session state and the other bits.
    pub const fn new(flags: SampleFlags, session: SessionState, extra: u16) -> Self {
        let mut w = flags.0 & Self::SAMPLE_FLAGS_MASK;
        w |= match session {
            SessionState::Idle => 0,
            SessionState::Armed => Self::ARMED,
            SessionState::Running => Self::RUNNING,
            SessionState::Done => Self::RESULTS_READY,
            SessionState::Aborted => Self::ABORTED,
        };
        Self(w | extra)
    }
}
