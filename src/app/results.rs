//! The results table: every figure the pod computes from its runs, with its unit, standard
//! uncertainty and validity (CANopen 0x4000–0x4002, SCPI `FETCh:RESult?`). The list below is the
//! one catalogue: [`ResultId`] names an entry, [`ResultInfo::all`] gives its name and unit and
//! [`RESULT_MEANINGS`] its meaning in the same order, and the EDS and the docs are generated
//! from it. The catalogue is append-only (the wire contract, [`crate::protocol::canopen::od`]):
//! a new result goes at the end, a retired one keeps its row and stays invalid.
//!
//! A result that has not been computed for the present runs is **invalid**: CANopen answers
//! "no data available" (0x0800 0024), SCPI -230 with its name. Never 0.0.
//! A standard uncertainty of NaN means "not evaluated" (the method does not state one yet).

use crate::metrology::bar_budget::{BarBudget, FigureKind};
use crate::units::Unit;

/// Name and unit of a result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ResultInfo {
    /// Name (CANopen sub-entry name, SCPI `FETCh:RESult? <name>`).
    pub name: &'static str,
    /// Unit (µm, µrad, arc-seconds, mm, degrees, µm/m, ms or a number).
    pub unit: Unit,
}

macro_rules! results {
    ($($id:ident => ($name:literal, $unit:ident, $what:literal),)*) => {
        /// A result of the table (the discriminant is its index: CANopen sub-index − 1).
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        #[repr(u8)]
        #[allow(non_camel_case_types)]
        pub enum ResultId {
            $(#[doc = $what] $id,)*
        }
        /// Every result's name, one after the other in [`ResultId`] order: one string in flash
        /// (a `&str` in each row took 8 B more a result).
        const NAMES: &str = concat!($($name,)*);
        /// Where each name ends in [`NAMES`].
        const NAME_ENDS: [u16; RESULT_COUNT] = name_ends([$($name.len(),)*]);
        /// Unit of every result, in [`ResultId`] order.
        const UNITS: [Unit; RESULT_COUNT] = [$(Unit::$unit,)*];
        /// What each result is, in [`ResultId`] order (for the EDS and the docs: kept apart from
        /// [`ResultInfo::all`] so the firmware does not carry the text).
        pub const RESULT_MEANINGS: &[&str] = &[$($what,)*];
        impl ResultId {
            /// Every result, in order.
            pub const ALL: &[ResultId] = &[$(ResultId::$id,)*];
        }
    };
}

results! {
    EccU => ("ecc_u", Um, "Last circular run (CIRCLE or seed 002 step): eccentricity along the pattern plane's first axis (limaçon fit; seed 002 §3.5)"),
    EccV => ("ecc_v", Um, "Last circular run: eccentricity along the pattern plane's second axis"),
    R0 => ("r0", Um, "Last circular run: radius change r0 (mean ΔL of the fit)"),
    ResidualRms => ("residual_rms", Um, "Last circular run: RMS of the fit residuals"),
    Arc => ("arc", Deg, "Last circular run: arc turned"),
    GCcw => ("G_ccw", Um, "ISO 230-4 circular deviation G (2022: circular error), CCW"),
    GCw => ("G_cw", Um, "ISO 230-4 circular deviation G, CW"),
    FMaxCcw => ("F_max_ccw", Um, "ISO 230-4 radial deviation F_max about the socket, CCW"),
    FMinCcw => ("F_min_ccw", Um, "ISO 230-4 radial deviation F_min about the socket, CCW"),
    FMaxCw => ("F_max_cw", Um, "ISO 230-4 radial deviation F_max about the socket, CW"),
    FMinCw => ("F_min_cw", Um, "ISO 230-4 radial deviation F_min about the socket, CW"),
    GBidir => ("G_bidir", Um, "ISO 230-4 bi-directional circular deviation G(b) (latest CCW and CW runs)"),
    H => ("H", Um, "ISO 230-4 circular hysteresis H (latest CCW and CW runs)"),
    RadialBidir => ("radial_bidir", Um, "ISO 230-4 mean bi-directional radial deviation"),
    Squareness => ("squareness", Urad, "Ball-bar diagnosis: out-of-squareness of the plane's axes (mean of CCW and CW; both arcs with samples in all four quadrants)"),
    ScaleMismatch => ("scale_mismatch", UmPerM, "Ball-bar diagnosis: scale mismatch k_u − k_v"),
    ReversalU => ("reversal_u", Um, "Ball-bar diagnosis: reversal step (backlash) of the first axis"),
    ReversalV => ("reversal_v", Um, "Ball-bar diagnosis: reversal step (backlash) of the second axis"),
    CyclicAmplitude => ("cyclic_amplitude", Um, "Ball-bar diagnosis: amplitude of the cyclic error, the harmonic of order 4–16 that, fitted jointly with the other diagnoses, explains most of the profile (full circle only; a third-order shape is the straightness)"),
    CyclicOrder => ("cyclic_order", One, "Ball-bar diagnosis: order of that harmonic (cycles per revolution) when its amplitude is at least 4 standard uncertainties; 0: no cyclic error named"),
    ServoMismatch => ("servo_mismatch", Ms, "Ball-bar diagnosis: servo mismatch τ_u − τ_v (needs circle_feed)"),
    CentreDu => ("centre_du", Um, "Last CIRCLE run: the centre of the circle the axis positions traced less circle_centre, along the plane's first axis (the first harmonic of their distance from it)"),
    CentreDv => ("centre_dv", Um, "Last CIRCLE run: the traced centre less circle_centre, along the plane's second axis"),
    EBxX => ("e_BX_x", Um, "Seed 002 step BX: eccentricity ex (mean of CW/CCW over the repeats)"),
    EBxZ => ("e_BX_z", Um, "Seed 002 step BX: eccentricity ez"),
    EByX => ("e_BY_x", Um, "Seed 002 step BY: eccentricity ex"),
    EByZ => ("e_BY_z", Um, "Seed 002 step BY: eccentricity ez"),
    ECrX => ("e_CR_x", Um, "Seed 002 step CR: eccentricity ex"),
    ECrY => ("e_CR_y", Um, "Seed 002 step CR: eccentricity ey"),
    ECaX => ("e_CA_x", Um, "Seed 002 step CA: eccentricity ex"),
    ECaY => ("e_CA_y", Um, "Seed 002 step CA: eccentricity ey"),
    ECr2X => ("e_CR2_x", Um, "Seed 002 step CR2 (CR′): eccentricity ex"),
    ECr2Y => ("e_CR2_y", Um, "Seed 002 step CR2 (CR′): eccentricity ey"),
    DxBt => ("dx_BT", Um, "Seed 002 model mode (literal HTM model): δx_BT"),
    DzBt => ("dz_BT", Um, "Seed 002 model mode: δz_BT"),
    AlphaBt => ("alpha_BT", Arcsec, "Seed 002 model mode: α_BT"),
    AlphaXb => ("alpha_XB", Arcsec, "Seed 002 model mode: α_XB"),
    BetaXb => ("beta_XB", Arcsec, "Seed 002 model mode: β_XB"),
    GammaXb => ("gamma_XB", Arcsec, "Seed 002 model mode: γ_XB"),
    DxCz => ("dx_CZ", Um, "Seed 002 model mode: δx_CZ"),
    DyCz => ("dy_CZ", Um, "Seed 002 model mode: δy_CZ"),
    AlphaCz => ("alpha_CZ", Arcsec, "Seed 002 model mode: α_CZ"),
    BetaCz => ("beta_CZ", Arcsec, "Seed 002 model mode: β_CZ"),
    ModelResidualRms => ("model_residual_rms", Um, "Seed 002 model mode: RMS of the eccentricity residuals"),
    ModelCondition => ("model_condition", One, "Seed 002 model mode: condition number of the last Gauss–Newton step"),
    ThAlphaCz => ("th_alpha_CZ", Arcsec, "Seed 002 thesis mode (eqs 4.10–4.18): α_CZ"),
    ThBetaCz => ("th_beta_CZ", Arcsec, "Seed 002 thesis mode: β_CZ"),
    ThAlphaXb => ("th_alpha_XB", Arcsec, "Seed 002 thesis mode: α_XB"),
    ThBetaXb => ("th_beta_XB", Arcsec, "Seed 002 thesis mode: β_XB"),
    ThGammaXb => ("th_gamma_XB", Arcsec, "Seed 002 thesis mode: γ_XB"),
    ThAlphaBt => ("th_alpha_BT", Arcsec, "Seed 002 thesis mode: α_BT"),
    ThDxCzMinusDxBt => ("th_dx_CZ_minus_dx_BT", Um, "Seed 002 thesis mode: δx_CZ − δx_BT"),
    ThDyCz => ("th_dy_CZ", Um, "Seed 002 thesis mode: δy_CZ"),
    ThDzBtSetting => ("th_dz_BT_setting", Um, "Seed 002 thesis mode: the δz_BT (tool-length) setting ex_BX"),
    CorrDxBt => ("corr_dx_BT", Um, "Seed 002 correction (compensation = −error) of δx_BT"),
    CorrDzBt => ("corr_dz_BT", Um, "Seed 002 correction of δz_BT"),
    CorrAlphaBt => ("corr_alpha_BT", Arcsec, "Seed 002 correction of α_BT"),
    CorrAlphaXb => ("corr_alpha_XB", Arcsec, "Seed 002 correction of α_XB"),
    CorrBetaXb => ("corr_beta_XB", Arcsec, "Seed 002 correction of β_XB"),
    CorrGammaXb => ("corr_gamma_XB", Arcsec, "Seed 002 correction of γ_XB"),
    CorrDxCz => ("corr_dx_CZ", Um, "Seed 002 correction of δx_CZ"),
    CorrDyCz => ("corr_dy_CZ", Um, "Seed 002 correction of δy_CZ"),
    CorrAlphaCz => ("corr_alpha_CZ", Arcsec, "Seed 002 correction of α_CZ"),
    CorrBetaCz => ("corr_beta_CZ", Arcsec, "Seed 002 correction of β_CZ"),
    SsmEx => ("ssm_ex", Um, "SSM run: position error E_x from the dwell stations (seed 000 eq 1, Gauss–Newton refined)"),
    SsmEy => ("ssm_ey", Um, "SSM run: position error E_y"),
    SsmEz => ("ssm_ez", Um, "SSM run: position error E_z"),
    SsmCond => ("ssm_cond", One, "SSM run: condition number of the station directions"),
    SsmResidualRms => ("ssm_residual_rms", Um, "SSM run: RMS residual of the station equations (0 for exactly three)"),
    SsmStations => ("ssm_stations", One, "SSM run: dwell stations used"),
    TsDeltaAlpha => ("ts_d_alpha", Urad, "Seed 000 two-step: Δα (RRTTT, TTTRR, RTTTR table)"),
    TsDeltaBeta => ("ts_d_beta", Urad, "Seed 000 two-step: Δβ (RRTTT, RTTTR spindle)"),
    TsDeltaGamma => ("ts_d_gamma", Urad, "Seed 000 two-step: Δγ (TTTRR)"),
    SphereX => ("sphere_x", Mm, "PROBE run: fitted sphere centre X (stylus-ball centre path)"),
    SphereY => ("sphere_y", Mm, "PROBE run: fitted sphere centre Y"),
    SphereZ => ("sphere_z", Mm, "PROBE run: fitted sphere centre Z"),
    SphereRadius => ("sphere_radius", Mm, "PROBE run: fitted radius (sphere + stylus ball − pre-travel)"),
    SphereResidualRms => ("sphere_residual_rms", Um, "PROBE run: RMS residual of the touch points"),
    ProbeAlphaCz => ("probe_alpha_CZ", Arcsec, "Seed 002 chapter 5 touch-probe C axis (spheres at C = 0/90/180/270°, B = 0): α_CZ"),
    ProbeBetaCz => ("probe_beta_CZ", Arcsec, "Touch-probe C axis: β_CZ"),
    ProbeDxCz => ("probe_dx_CZ", Um, "Touch-probe C axis: δx_CZ"),
    ProbeDyCz => ("probe_dy_CZ", Um, "Touch-probe C axis: δy_CZ"),
    ProbeDxBt => ("probe_dx_BT", Um, "Seed 002 chapter 5 touch-probe B axis (sphere on the C centreline at B = 0/90° with two tool lengths, probe_length): δx_BT"),
    ProbeDzBt => ("probe_dz_BT", Um, "Touch-probe B axis: δz_BT"),
    ProbeBetaXb => ("probe_beta_XB", Arcsec, "Touch-probe B axis: β_XB"),
    ProbeAlphaBtPlusAlphaXb => ("probe_alpha_BT_plus_alpha_XB", Arcsec, "Touch-probe B axis: α_BT + α_XB (not separable with B = 0/90° alone)"),
    ProbeAlphaBtMinusGammaXb => ("probe_alpha_BT_minus_gamma_XB", Arcsec, "Touch-probe B axis: α_BT − γ_XB"),
    ProbeBResidualRms => ("probe_B_residual_rms", Um, "Touch-probe B axis: RMS residual of the X/Z equations (8 equations, 3 unknowns)"),
    ReversalUPos => ("reversal_u_pos", Um, "Ball-bar diagnosis: reversal step (backlash) of the first axis at its + end (θ = 0°; the arcs must cross it)"),
    ReversalUNeg => ("reversal_u_neg", Um, "Ball-bar diagnosis: reversal step of the first axis at its − end (θ = 180°)"),
    ReversalVPos => ("reversal_v_pos", Um, "Ball-bar diagnosis: reversal step of the second axis at its + end (θ = 90°)"),
    ReversalVNeg => ("reversal_v_neg", Um, "Ball-bar diagnosis: reversal step of the second axis at its − end (θ = 270°)"),
    StraightnessU => ("straightness_u", Um, "Ball-bar diagnosis: straightness of the first axis over the test diameter, its path's bow across it (end-point reference; > 0: the ends lie towards +v of the middle; full circle only)"),
    StraightnessV => ("straightness_v", Um, "Ball-bar diagnosis: straightness of the second axis over the test diameter (> 0: the ends lie towards +u of the middle; full circle only)"),
    ShareSquareness => ("share_squareness", Um, "Ball-bar ranking: the out-of-squareness's share of the circular deviation, the peak-to-valley its signature alone gives (S·R)"),
    ShareScaleMismatch => ("share_scale_mismatch", Um, "Ball-bar ranking: the scale mismatch's share (Δk·R)"),
    ShareReversalU => ("share_reversal_u", Um, "Ball-bar ranking: the first axis's reversal steps' share (the larger of its two points)"),
    ShareReversalV => ("share_reversal_v", Um, "Ball-bar ranking: the second axis's reversal steps' share"),
    ShareStraightnessU => ("share_straightness_u", Um, "Ball-bar ranking: the first axis's straightness's share (half of it: the third-order shape)"),
    ShareStraightnessV => ("share_straightness_v", Um, "Ball-bar ranking: the second axis's straightness's share"),
    ShareCyclic => ("share_cyclic", Um, "Ball-bar ranking: the cyclic error's share (twice its amplitude)"),
    FaultsNamed => ("faults_named", One, "Ball-bar diagnoses named as faults (at least 3 standard uncertainties from zero, the cyclic error 4), the sum of: 1 squareness, 2 scale mismatch, 4 reversal of the first axis (either point or the mean), 8 of the second, 16 straightness of the first, 32 of the second, 64 cyclic error, 128 lateral play of the first, 256 of the second"),
    ScaleMean => ("scale_mean", UmPerM, "Ball-bar diagnosis: mean scale error (k_u + k_v)/2 of the plane's two axes relative to the bar's calibrated length, from the radius of the joint fit (every quadrant; u with the bar's length and temperature)"),
    SquarenessXy => ("squareness_xy", Urad, "Three-plane summary: out-of-squareness of X and Y, from the latest complete XY circle since the session was cleared (> 0: the angle between +X and +Y is less than 90°)"),
    SquarenessYz => ("squareness_yz", Urad, "Three-plane summary: out-of-squareness of Y and Z, from the latest YZ circle or arc (> 0: the angle between +Y and +Z is less than 90°)"),
    SquarenessZx => ("squareness_zx", Urad, "Three-plane summary: out-of-squareness of Z and X, from the latest ZX circle or arc (> 0: the angle between +Z and +X is less than 90°)"),
    ScaleX => ("scale_x", UmPerM, "Three-plane summary: scale error of X relative to the bar's calibrated length, from the three planes' radii and scale mismatches (needs a circle or arc in each of XY, YZ and ZX)"),
    ScaleY => ("scale_y", UmPerM, "Three-plane summary: scale error of Y"),
    ScaleZ => ("scale_z", UmPerM, "Three-plane summary: scale error of Z"),
    SweepFeeds => ("sweep_feeds", One, "Feed-rate sweep: the feeds at which the same circle (centre, radius, arc) in the latest complete circle's plane has run, both directions, since the session was cleared; at most 8 (the latest kept)"),
    SweepServoMismatch => ("sweep_servo_mismatch", Ms, "Feed-rate sweep: servo mismatch τ_u − τ_v over the feeds (their servo_mismatch weighted by 1/u²; needs three feeds)"),
    SweepFeedLimit => ("sweep_feed_limit", MmPerMin, "Feed-rate sweep: the feed at which G(b) first exceeds the lowest feed's by 20 %, linear between the feeds about the crossing"),
    SpikeUPos => ("spike_u_pos", Um, "Ball-bar diagnosis: reversal spike of the first axis at its + end (θ = 0°), its height h (the spike e^(−Δt/τ) after the reversal, outward > 0; the mean of the latest CCW and CW runs, each crossing the point with 12 samples before and 64 from it)"),
    SpikeUNeg => ("spike_u_neg", Um, "Ball-bar diagnosis: reversal spike of the first axis at its − end (θ = 180°), height"),
    SpikeVPos => ("spike_v_pos", Um, "Ball-bar diagnosis: reversal spike of the second axis at its + end (θ = 90°), height"),
    SpikeVNeg => ("spike_v_neg", Um, "Ball-bar diagnosis: reversal spike of the second axis at its − end (θ = 270°), height"),
    SpikeTimeUPos => ("spike_time_u_pos", Ms, "Ball-bar diagnosis: reversal spike of the first axis at its + end, its time constant τ (u not evaluated)"),
    SpikeTimeUNeg => ("spike_time_u_neg", Ms, "Ball-bar diagnosis: reversal spike of the first axis at its − end, time constant"),
    SpikeTimeVPos => ("spike_time_v_pos", Ms, "Ball-bar diagnosis: reversal spike of the second axis at its + end, time constant"),
    SpikeTimeVNeg => ("spike_time_v_neg", Ms, "Ball-bar diagnosis: reversal spike of the second axis at its − end, time constant"),
    LateralPlayU => ("lateral_play_u", Um, "Ball-bar diagnosis: lateral play of the first axis, its carriage moving across its guideway when its own direction reverses (> 0: it runs on the +v side while travelling +u), from the cusp the two directions' profiles differ by (full circle only)"),
    LateralPlayV => ("lateral_play_v", Um, "Ball-bar diagnosis: lateral play of the second axis (> 0: it runs on the +u side while travelling +v; full circle only)"),
    ShareLateralPlayU => ("share_lateral_play_u", Um, "Ball-bar ranking: the first axis's lateral play's share (half of it: its cusp)"),
    ShareLateralPlayV => ("share_lateral_play_v", Um, "Ball-bar ranking: the second axis's lateral play's share"),
    VibrationU => ("vibration_u", Um, "Ball-bar diagnosis: vibration of the first axis, amplitude A of A·sin(2πf·t + φ), from the samples about its reversal points"),
    VibrationV => ("vibration_v", Um, "Ball-bar diagnosis: vibration of the second axis, amplitude"),
    VibrationFrequency => ("vibration_frequency", Hz, "Ball-bar diagnosis: the vibration's frequency f (where it is named)"),
    StickSlipU => ("stick_slip_u", Um, "Ball-bar diagnosis: stick-slip of the first axis, amplitude a of a·sin(2πf·Δt + φ) from its reversal on"),
    StickSlipV => ("stick_slip_v", Um, "Ball-bar diagnosis: stick-slip of the second axis, amplitude"),
    StickSlipFrequency => ("stick_slip_frequency", Hz, "Ball-bar diagnosis: the stick-slip's frequency (where it is named)"),
    OscillationsNamed => ("oscillations_named", One, "Oscillations named as faults (χ² false-alarm probability under 1e-6), the sum of: 1 vibration of the first axis, 2 of the second, 4 stick-slip of the first, 8 of the second"),
}

/// Number of results.
pub const RESULT_COUNT: usize = ResultId::ALL.len();

/// The running sums of `lens` (each name's end in [`NAMES`]).
// Evaluated at compile time (`NAME_ENDS` only): an index out of bounds is a build error.
#[allow(clippy::indexing_slicing)]
const fn name_ends<const N: usize>(lens: [usize; N]) -> [u16; N] {
    let mut ends = [0u16; N];
    let (mut k, mut end) = (0, 0);
    while k < N {
        end += lens[k];
        assert!(end <= u16::MAX as usize, "result names longer than 64 KiB");
        ends[k] = end as u16;
        k += 1;
    }
    ends
}

impl ResultInfo {
    /// Name and unit of every result, in [`ResultId`] order (CANopen sub-index k + 1).
    pub fn all() -> impl Iterator<Item = ResultInfo> {
        ResultId::ALL.iter().map(|r| r.info())
    }
}

impl ResultId {
    /// Its index in [`ResultId::ALL`] (CANopen sub-index − 1).
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Its name and unit.
    pub fn info(self) -> ResultInfo {
        let k = self.index();
        let end = NAME_ENDS.get(k).map_or(0, |e| usize::from(*e));
        let start = k
            .checked_sub(1)
            .and_then(|j| NAME_ENDS.get(j))
            .map_or(0, |e| usize::from(*e));
        ResultInfo {
            name: NAMES.get(start..end).unwrap_or(""),
            unit: UNITS.get(k).copied().unwrap_or(Unit::One),
        }
    }

    /// What it is (docs and EDS).
    pub fn meaning(self) -> &'static str {
        RESULT_MEANINGS.get(self.index()).copied().unwrap_or("")
    }

    /// The result at `index`.
    pub fn from_index(index: usize) -> Option<Self> {
        Self::ALL.get(index).copied()
    }

    /// The result called `name` (any letter case).
    pub fn from_name(name: &[u8]) -> Option<Self> {
        Self::ALL
            .iter()
            .copied()
            .find(|r| r.info().name.as_bytes().eq_ignore_ascii_case(name))
    }
}

impl ResultId {
    /// The results a run of `pattern` gives by itself (its procedure's results — the other
    /// direction, the identification — are the rest of the table).
    pub fn of_run(pattern: crate::app::Pattern) -> &'static [ResultId] {
        use crate::app::Pattern as P;
        let (first, last) = match pattern {
            P::Ssm => (ResultId::SsmEx, ResultId::SsmStations),
            P::Probe => (ResultId::SphereX, ResultId::SphereResidualRms),
            P::Circle | P::Bx | P::By | P::Cr | P::Ca | P::Cr2 => (ResultId::EccU, ResultId::Arc),
        };
        Self::ALL.get(first.index()..=last.index()).unwrap_or(&[])
    }
}

/// What a result's standard uncertainty comes from: the inputs of its budget, grouped as the
/// pod states them (the discriminant indexes [`CONTRIBUTORS`] and [`ResultEntry::shares`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Contributor {
    /// Type A: the fit residuals, the repeat scatter, the noise of the readings.
    TypeA = 0,
    /// The bar's calibrated length and its temperature (a constant offset of every ΔL).
    BarOffset = 1,
    /// The LVDT's scale (calibration and linearity).
    LvdtScale = 2,
    /// The W-ball: its clamping shifts and R_C, Z_C as entered (seed 002).
    WBall = 3,
    /// The T-ball's centring and axial offsets (seed 002).
    TBall = 4,
    /// The touch probe's lobing: its pre-travel varying with the direction of approach
    /// (seed 002 chapter 5).
    ProbeLobing = 5,
    /// The socket's centre as entered: SSM's P0 against the true socket (it moves E one to
    /// one), a circle's centre against the one the part program circles about (it turns each
    /// sample's direction).
    Socket = 6,
}

/// Number of [`Contributor`]s.
pub const CONTRIBUTOR_COUNT: usize = 7;

/// The names of the [`Contributor`]s, in discriminant order (SCPI `FETCh:RESult:BUDGet?`, the
/// replay's `results.json`).
pub const CONTRIBUTORS: [&str; CONTRIBUTOR_COUNT] = [
    "type_a",
    "bar_offset",
    "lvdt_scale",
    "w_ball",
    "t_ball",
    "probe_lobing",
    "socket",
];

impl Contributor {
    /// Every contributor, in discriminant order.
    pub const ALL: [Contributor; CONTRIBUTOR_COUNT] = [
        Self::TypeA,
        Self::BarOffset,
        Self::LvdtScale,
        Self::WBall,
        Self::TBall,
        Self::ProbeLobing,
        Self::Socket,
    ];

    /// Its name in [`CONTRIBUTORS`].
    pub fn name(self) -> &'static str {
        CONTRIBUTORS.get(self as usize).copied().unwrap_or("")
    }
}

/// One result with its quality.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResultEntry {
    /// The value in the unit of [`ResultInfo::all`] (NaN while invalid).
    pub value: f32,
    /// Its standard uncertainty, same unit (NaN: not evaluated): the root sum of squares of
    /// [`Self::shares`].
    pub std_uncertainty: f32,
    /// The standard uncertainty each [`Contributor`] gives it, same unit, by discriminant
    /// (independent inputs: they add in quadrature).
    pub shares: [f32; CONTRIBUTOR_COUNT],
    /// True once computed from the present runs.
    pub valid: bool,
}

impl ResultEntry {
    /// An entry with no value.
    pub const INVALID: Self = Self {
        value: f32::NAN,
        std_uncertainty: f32::NAN,
        shares: [f32::NAN; CONTRIBUTOR_COUNT],
        valid: false,
    };

    /// The (up to) three largest contributors to the standard uncertainty, largest first, with
    /// their shares; `None` past the last one that gives a share above 0. None at all while the
    /// uncertainty is not evaluated.
    pub fn largest_contributors(&self) -> [Option<(Contributor, f32)>; 3] {
        let mut top = [None; 3];
        let mut taken = [false; CONTRIBUTOR_COUNT];
        for slot in top.iter_mut() {
            // the largest share not taken yet (ties: the first contributor)
            let mut best: Option<(usize, f32)> = None;
            for (k, (&share, &t)) in self.shares.iter().zip(taken.iter()).enumerate() {
                if share > 0.0 && !t && best.is_none_or(|(_, b)| share > b) {
                    best = Some((k, share));
                }
            }
            if let Some((k, share)) = best
                && let (Some(t), Some(c)) = (taken.get_mut(k), Contributor::ALL.get(k))
            {
                *t = true;
                *slot = Some((*c, share));
            }
        }
        top
    }
}

impl Default for ResultEntry {
    fn default() -> Self {
        Self::INVALID
    }
}

/// The results table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Results {
    entries: [ResultEntry; RESULT_COUNT],
}

impl Default for Results {
    fn default() -> Self {
        Self::new()
    }
}

impl Results {
    /// Every entry invalid.
    pub const fn new() -> Self {
        Self {
            entries: [ResultEntry::INVALID; RESULT_COUNT],
        }
    }

    /// [`Results::new`] built in place in `slot` (no stack copy of the table, 40 B a result: the
    /// application's construction runs at the bottom of the stack every job runs on).
    pub fn init(slot: &mut core::mem::MaybeUninit<Self>) -> &mut Self {
        crate::in_place::init_in_place!(slot, Self {} in place {
            entries: |s| crate::in_place::fill(s, ResultEntry::INVALID),
        })
    }

    /// The entry of `id`.
    pub fn get(&self, id: ResultId) -> ResultEntry {
        self.entries.get(id.index()).copied().unwrap_or_default()
    }

    /// Every entry, in [`ResultInfo::all`] order.
    pub fn entries(&self) -> &[ResultEntry] {
        &self.entries
    }

    /// Sets `id` to `value` with the standard uncertainty each [`Contributor`] gives it
    /// (`shares`, by discriminant, same unit; NaN: not evaluated); u is their root sum of
    /// squares. A value that is not finite leaves the entry invalid.
    // one copy, not one per result the application sets (flash: ~1.5 KiB)
    #[inline(never)]
    pub fn set_budget(&mut self, id: ResultId, value: f64, shares: [f32; CONTRIBUTOR_COUNT]) {
        if let Some(e) = self.entries.get_mut(id.index()) {
            *e = if value.is_finite() {
                let u2: f32 = shares.iter().map(|s| s * s).sum();
                ResultEntry {
                    value: value as f32,
                    std_uncertainty: crate::num::sqrtf(u2),
                    shares: shares.map(libm::fabsf),
                    valid: true,
                }
            } else {
                ResultEntry::INVALID
            };
        }
    }

    /// Invalidates the results from `first` to `last` (inclusive, in [`ResultInfo::all`] order).
    pub fn clear(&mut self, first: ResultId, last: ResultId) {
        for e in self
            .entries
            .iter_mut()
            .take(last.index() + 1)
            .skip(first.index())
        {
            *e = ResultEntry::INVALID;
        }
    }

    /// Invalidates every result, in place (no temporary of the table on the stack).
    pub fn clear_all(&mut self) {
        self.entries.fill(ResultEntry::INVALID);
    }

    /// Number of valid results.
    pub fn valid_count(&self) -> usize {
        self.entries.iter().filter(|e| e.valid).count()
    }
}

/// Where a computation writes its results: the results table itself, or a [`ResultPatch`] that
/// a job fills on its own and the application applies to the table when the job ends (the
/// same [`ResultSink::set_budget`] calls, so the table ends the same either way).
pub trait ResultSink {
    /// Sets `id` to `value` with the standard uncertainty each [`Contributor`] gives it
    /// (`shares`, by discriminant, same unit; NaN: not evaluated) ([`Results::set_budget`]).
    fn set_budget(&mut self, id: ResultId, value: f64, shares: [f32; CONTRIBUTOR_COUNT]);

    /// Sets `id` to `value` ± `u` (standard uncertainty, NaN if not evaluated), all of it
    /// [`Contributor::TypeA`]; a value that is not finite leaves the entry invalid.
    fn set(&mut self, id: ResultId, value: f64, u: f64) {
        self.set_budget(id, value, [u as f32, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    }

    /// Sets `id` to a figure computed from ΔL: `value` ± its own (Type A) standard uncertainty
    /// `u_a`, with the bar's shares of a figure of `kind` ([`BarBudget::shares`]) and the
    /// socket's `socket` as entered (0 for a figure the budget gives none).
    fn set_with_bar(
        &mut self,
        id: ResultId,
        value: f32,
        [u_a, socket]: [f32; 2],
        bar: &BarBudget,
        kind: FigureKind,
    ) {
        let [offset, scale] = bar.shares(kind, value);
        self.set_budget(
            id,
            f64::from(value),
            [u_a, offset, scale, 0.0, 0.0, 0.0, socket],
        );
    }
}

impl ResultSink for Results {
    fn set_budget(&mut self, id: ResultId, value: f64, shares: [f32; CONTRIBUTOR_COUNT]) {
        Results::set_budget(self, id, value, shares);
    }
}

/// Results a job computed, in the order it set them, for [`Results`] when the job ends
/// ([`ResultPatch::apply`]). Sized for the job that sets the most (a circle's figures with both
/// directions: 34); a set beyond it is counted, never dropped silently ([`ResultPatch::overflowed`]).
#[derive(Clone, Debug, Default)]
pub struct ResultPatch {
    sets: heapless::Vec<(ResultId, f64, [f32; CONTRIBUTOR_COUNT]), RESULT_PATCH_LEN>,
    overflowed: u32,
}

/// Results one job sets at most ([`ResultPatch`]).
pub const RESULT_PATCH_LEN: usize = 40;

impl ResultPatch {
    /// No results.
    pub const fn new() -> Self {
        Self {
            sets: heapless::Vec::new(),
            overflowed: 0,
        }
    }

    /// Forgets every set.
    pub fn clear(&mut self) {
        self.sets.clear();
        self.overflowed = 0;
    }

    /// Sets that did not fit (0 unless [`RESULT_PATCH_LEN`] is too small: a test holds it).
    pub fn overflowed(&self) -> u32 {
        self.overflowed
    }

    /// Applies every set to `results`, in order, and forgets them.
    pub fn apply(&mut self, results: &mut Results) {
        for &(id, v, shares) in self.sets.iter() {
            results.set_budget(id, v, shares);
        }
        self.sets.clear();
    }
}

impl ResultSink for ResultPatch {
    fn set_budget(&mut self, id: ResultId, value: f64, shares: [f32; CONTRIBUTOR_COUNT]) {
        if self.sets.push((id, value, shares)).is_err() {
            self.overflowed = self.overflowed.saturating_add(1);
        }
    }
}
