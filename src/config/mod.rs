//! The pod's configuration: every field with its unit, default for the reference hardware
//! (NUCLEO-G474RE, a 150 mm steel ball bar, 0.1 µm encoders) and validated range, plus a
//! versioned binary encoding with CRC-32 (persisted by [`crate::settings`]). The test set-up
//! ([`TestSetup`]: circle centre and radius, the seed 002 Table 4.3 quantities, the SSM socket,
//! the two-step machine) is part of it, so it travels with the configuration over both
//! protocols and survives a reset.
//!
//! Changes go through [`Config::try_update`]: the closure edits a copy, the copy is validated
//! as a whole, and only a valid copy replaces the configuration — a bad value changes nothing
//! and the error names the field and its allowed range.
//!
//! The encoding is hand-written (little-endian, fixed layout) rather than serde + postcard: it is
//! ~150 lines, needs no derive machinery in the flash image, and its layout is the one the
//! settings slots and the CAN/USB configuration objects document.

use crate::units::Unit;

/// Number of encoder axes the pod reads (X, Y, Z and two rotary axes; DESIGN §1).
pub const MAX_AXES: usize = 5;

// The defaults of the uncertainty fields, and why each (the modules that use them import them
// from here: configuration stands below everything it configures).

/// Default standard uncertainty of each in-plane coordinate of the circle's centre as entered
/// (`circle_centre`) against the centre the part program circles about (`circle_u_centre`),
/// µm: the program's centre entered to the micrometre (`ncgen circle` writes both from one
/// set-up). Where the socket truly is does not enter: the path's centre relative to the
/// socket's ball is what e measures.
pub const U_CENTRE_UM: f64 = 1.0;

/// Default standard uncertainty of each coordinate of the socket's centre as entered
/// (`ssm_socket`) against its true centre (`ssm_u_socket`), µm: the socket found by docking
/// the spindle's setting cup on its ball, which seats within about 1 µm. E is read against P0
/// as entered (seed 000 B.2 item 5: an error of P0 is a common offset of every E), so this
/// moves each component of E one to one. What the machine's own error at the docking pose
/// adds is the reference E is read against (the socket side), not an uncertainty.
pub const U_SOCKET_UM: f64 = 1.0;

/// Default standard uncertainty of each lobing component, µm (`probe_u_lobing`: the third
/// harmonic's two and the axial difference d; the higher harmonics in proportion): kinematic
/// machine-tool probes state a 2D lobing of ±1 µm and a 3D lobing of ±1–2 µm at a 50 mm stylus
/// (e.g. Renishaw's OMP40-2 and RMP60 data sheets). A probe qualified per direction on a
/// reference sphere, or a strain-gauge probe, is better: enter what its qualification leaves.
pub const U_LOBING_UM: f64 = 1.0;

/// Default standard uncertainty of the bar's calibrated length, µm (`bar_u_length`): a
/// calibration certificate's U = 1 µm at k = 2 (state the bar's own).
pub const DEFAULT_U_LENGTH_UM: f32 = 0.5;
/// Default standard uncertainty of the bar's temperature as measured, K (`bar_u_temp`): the
/// thermistor's tolerance and the gradient along a hand-warmed bar.
pub const DEFAULT_U_TEMP_K: f32 = 0.2;
/// Default relative standard uncertainty of the LVDT's scale, ppm of ΔL (`lvdt_u_scale`): a
/// 0.1 % calibration and linearity.
pub const DEFAULT_U_SCALE_PPM: f32 = 1000.0;

/// Seed 002 default, µm (`s002_u_w_clamp`): the W-ball shifts 10–60 µm in a random direction
/// at every clamping (measured in the thesis, spec seed-002 §2.7); a magnitude uniform in
/// 10–60 µm gives an rms per component of √((60³ − 10³) / (3 · 50) / 3) = 21.9 µm.
pub const S002_U_W_CLAMP_UM: f64 = 22.0;
/// Seed 002 default, µm (`s002_u_t_centring`): the T-ball centred until the bar's length
/// change stays within ±1 µm as the spindle turns, an offset uniform in a disc of 1 µm radius
/// (rms per component 1/2 µm).
pub const S002_U_T_CENTRING_UM: f64 = 0.5;
/// Seed 002 default, µm (`s002_u_t_axial`): the T-ball's clamping shift along the spindle,
/// taken as the W-ball's (the dummy sphere, not the T-ball, sets R_B).
pub const S002_U_T_AXIAL_UM: f64 = 22.0;
/// Seed 002 default, µm (`s002_u_r_c_z_c`, each of R_C and Z_C): Z_C transferred with a dial
/// gauge (spec seed-002 §5.2 item 4: two readings of a 1 µm gauge, the sphere's top found by
/// hand, its diameter from its certificate), R_C the X at which the W-ball is docked to the
/// dummy sphere; a few µm each, taken as 10.
pub const S002_U_R_C_Z_C_UM: f64 = 10.0;
/// Seed 002 default, µm (`s002_u_r_b`, each of R_B and R′_B): each tool length from the
/// spindle nose and the dummy sphere's top with a lever dial gauge (§5.2 item 2), as Z_C.
pub const S002_U_R_B_UM: f64 = 10.0;

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

/// One encoder input.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisConfig {
    /// Which machine axis this input reads.
    pub name: AxisName,
    /// Counts per mm (linear) or per degree (rotary), after ×4 quadrature decoding.
    pub counts_per_unit: f64,
    /// Counting direction: true if the counter counts down in the axis' positive direction.
    pub reversed: bool,
    /// Fastest plausible axis speed, mm/s or °/s: larger count steps are quadrature glitches.
    pub max_speed_per_s: f32,
}

/// The test set-up: the geometry each measuring pattern needs (machine coordinates, mm and
/// degrees). A length or position that the pod cannot know by itself is **not set** (NaN)
/// until a client writes it; arming a pattern whose geometry is not set is refused with the
/// field named ([`crate::app`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TestSetup {
    /// Plane of the ISO 230-4 circle.
    pub circle_plane: CirclePlane,
    /// Circle centre = the socket (pivot) position, X, Y, Z in mm; not set by default.
    pub circle_centre_mm: [f32; 3],
    /// Nominal radius of the circle, mm (the bar length for a circle about the socket in its
    /// plane); not set by default.
    pub circle_radius_mm: f32,
    /// Programmed feed of the circle, mm/min (for the servo mismatch); not set by default.
    pub circle_feed_mm_per_min: f32,
    /// Shortest arc a circular run must turn to give results, degrees (a partial arc such as
    /// 220° needs this set to at most 220).
    pub circle_min_arc_deg: f32,
    /// Seed 002 (Table 4.3): L_B, ball-bar length, mm.
    pub s002_l_b_mm: f32,
    /// Seed 002: R_B, B centre → T-ball, steps BX–CA, mm.
    pub s002_r_b_mm: f32,
    /// Seed 002: R′_B, B centre → T-ball, step CR2, mm.
    pub s002_r_b2_mm: f32,
    /// Seed 002: R_C, W-ball distance from the C centreline, mm.
    pub s002_r_c_mm: f32,
    /// Seed 002: Z_C, W-ball height above the C table, mm.
    pub s002_z_c_mm: f32,
    /// Seed 002: Z_T, thesis lever arm of steps 1–4, mm (thesis mode only).
    pub s002_z_t_mm: f32,
    /// Seed 002: Z′_T, thesis lever arm of step 5, mm (thesis mode only).
    pub s002_z_t2_mm: f32,
    /// Seed 002: X_T, thesis lever arm, mm (thesis mode only).
    pub s002_x_t_mm: f32,
    /// Seed 002: machine coordinates X, Y, Z of the model-frame origin O_M (on the C axis at
    /// the table), mm.
    pub s002_origin_mm: [f32; 3],
    /// SSM: socket (pivot) centre P0, X, Y, Z in mm.
    pub ssm_socket_mm: [f32; 3],
    /// SSM streaming: neighbourhood radius, mm.
    pub ssm_window_radius_mm: f32,
    /// SSM: linear speed below which the machine dwells, mm/s: the stations are averaged there,
    /// and a still sample empties the live E's window ([`crate::app::ssm::SsmRun::update`]).
    pub ssm_dwell_speed_mm_per_s: f32,
    /// SSM stations: settling time before a dwell is averaged, ms.
    pub ssm_settle_ms: f32,
    /// SSM stations: fewest averaged samples for a dwell to count as a station.
    pub ssm_min_dwell_samples: u32,
    /// Seed 000 two-step: machine type.
    pub ts_machine: TwoStepMachine,
    /// Two-step: signed tool vector z_r along the spindle z axis (RRTTT, RTTTR spindle), mm.
    pub ts_tool_z_mm: f32,
    /// Two-step: z_αγ between the table's α and γ centres (TTTRR), mm.
    pub ts_z_alpha_gamma_mm: f32,
    /// Two-step: reference point in the table frame (TTTRR, RTTTR table), X, Y, Z in mm.
    pub ts_reference_mm: [f32; 3],
    /// Two-step: nominal pivot (spindle) or table origin after the translation, X, Y, Z in mm.
    pub ts_origin_mm: [f32; 3],
    /// Two-step: nominal angles of the rotation step, degrees: RRTTT (α, β), TTTRR (α, γ),
    /// RTTTR spindle (β, –), RTTTR table (α, –).
    pub ts_angles_deg: [f32; 2],
    /// PROBE: tool length R, B-axis centre → stylus-ball centre along the tool axis, mm. Set, a
    /// touch point is the nominal stylus-ball centre `axes − R·(sin B, 0, cos B)`; not set
    /// (default), it is the X, Y, Z positions as latched. The B-axis probe method needs it.
    pub probe_length_mm: f32,
    /// What starts and stops a run (added in encoding version 4).
    pub run_trigger: RunTrigger,
    /// CIRCLE: span of the data arc a self-triggered run measures, degrees (not set: until the
    /// feed-out; added in encoding version 4).
    pub circle_arc_deg: f32,
    /// Seed 002: standard uncertainty of each component of the W-ball's clamping shift, µm
    /// ([`S002_U_W_CLAMP_UM`] by default; added in encoding version 5).
    pub s002_u_w_clamp_um: f32,
    /// Seed 002: standard uncertainty of each radial component of the T-ball's offset left by
    /// centring, µm ([`S002_U_T_CENTRING_UM`] by default; added in encoding version 5).
    pub s002_u_t_centring_um: f32,
    /// Seed 002: standard uncertainty of the T-ball's axial offset (its tool length), µm
    /// ([`S002_U_T_AXIAL_UM`] by default; added in encoding version 5).
    pub s002_u_t_axial_um: f32,
    /// Seed 002: standard uncertainty of each of R_C and Z_C as entered, µm
    /// ([`S002_U_R_C_Z_C_UM`] by default; added in encoding
    /// version 7).
    pub s002_u_r_c_z_c_um: f32,
    /// PROBE: standard uncertainty of each component of the touch probe's lobing, µm — its
    /// three-lobe pre-travel across the stylus (each harmonic's two components, the higher
    /// harmonics in proportion) and the difference of its pre-travel along the stylus from
    /// across it ([`crate::identify::multitasking::lobing`]; added in encoding version 8).
    pub probe_u_lobing_um: f32,
    /// SSM: standard uncertainty of each coordinate of the socket's centre as entered
    /// (`ssm_socket`) against its true centre, µm: it moves E one to one
    /// ([`U_SOCKET_UM`]; added in encoding version 9).
    pub ssm_u_socket_um: f32,
    /// CIRCLE: standard uncertainty of each in-plane coordinate of the circle's centre as
    /// entered (`circle_centre`) against the centre the part program circles about, µm: it
    /// turns each sample's direction, and so e and r0 through the profile
    /// ([`U_CENTRE_UM`]; added in encoding version 9).
    pub circle_u_centre_um: f32,
    /// Seed 002: standard uncertainty of each of the tool lengths R_B and R′_B as entered
    /// against the ones the steps ran with, µm ([`S002_U_R_B_UM`] by default; added in
    /// encoding version 10).
    pub s002_u_r_b_um: f32,
}

/// The pod's configuration (see the module doc; fields listed with unit, default and range in
/// [`FIELDS`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Calibrated ball-bar length at 20 °C, mm.
    pub bar_length_mm: f32,
    /// Bar thermal expansion coefficient, µm/m/K (ppm/K).
    pub bar_cte_ppm_per_k: f32,
    /// LVDT input mode.
    pub lvdt_input: LvdtInput,
    /// LVDT calibration polynomial, µm per ratio^k (k = 0…3): `x = Σ c_k r^k`.
    pub lvdt_poly_um: [f32; 4],
    /// Largest |ratio| inside the calibrated stroke (beyond: over-range).
    pub lvdt_max_abs_ratio: f32,
    /// Smallest healthy LVDT signal level, ADC counts (AC) or volts (DC); below: open.
    pub lvdt_min_signal: f32,
    /// DC mode: conditioner output at the LVDT null, V.
    pub lvdt_dc_zero_v: f32,
    /// DC mode: conditioner output change for ratio 1, V.
    pub lvdt_dc_span_v: f32,
    /// LVDT excitation frequency, Hz.
    pub excitation_hz: f32,
    /// ADC samples per excitation period (the DAC table length).
    pub samples_per_period: u16,
    /// Pod sample rate (ΔL + axes), Hz.
    pub sample_rate_hz: f32,
    /// Encoder inputs 1…5.
    pub axes: [AxisConfig; MAX_AXES],
    /// Thermistor resistance at 25 °C, Ω.
    pub thermistor_r25_ohm: f32,
    /// Thermistor β constant, K.
    pub thermistor_beta_k: f32,
    /// Divider's fixed resistor, Ω.
    pub thermistor_r_fixed_ohm: f32,
    /// Probe debounce window, µs.
    pub probe_debounce_us: u32,
    /// Time the probe must read seated before it re-arms, µs.
    pub probe_reseat_us: u32,
    /// CANopen node-ID (1…127), or 255: none, LSS only ([`crate::protocol::canopen::lss`]).
    pub can_node_id: u8,
    /// CAN bit rate.
    pub can_bitrate: CanBitrate,
    /// The test set-up (pattern geometry).
    pub setup: TestSetup,
    /// Standard uncertainty of the bar's calibrated length, µm (its certificate; added in
    /// encoding version 6).
    pub bar_u_length_um: f32,
    /// Standard uncertainty of the bar's temperature as the pod measures it, K (added in
    /// encoding version 6).
    pub bar_u_temp_k: f32,
    /// Relative standard uncertainty of the LVDT's scale (calibration and linearity), ppm of
    /// ΔL (added in encoding version 6).
    pub lvdt_u_scale_ppm: f32,
}

/// A configuration field (named in [`ConfigError`] and in [`FIELDS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    /// [`Config::bar_length_mm`].
    BarLengthMm,
    /// [`Config::bar_cte_ppm_per_k`].
    BarCtePpmPerK,
    /// [`Config::lvdt_poly_um`] coefficient k.
    LvdtPolyUm(u8),
    /// [`Config::lvdt_max_abs_ratio`].
    LvdtMaxAbsRatio,
    /// [`Config::lvdt_min_signal`].
    LvdtMinSignal,
    /// [`Config::lvdt_dc_zero_v`].
    LvdtDcZeroV,
    /// [`Config::lvdt_dc_span_v`].
    LvdtDcSpanV,
    /// [`Config::excitation_hz`].
    ExcitationHz,
    /// [`Config::samples_per_period`].
    SamplesPerPeriod,
    /// [`Config::sample_rate_hz`].
    SampleRateHz,
    /// [`AxisConfig::counts_per_unit`] of input i.
    AxisCountsPerUnit(u8),
    /// [`AxisConfig::max_speed_per_s`] of input i.
    AxisMaxSpeed(u8),
    /// [`Config::thermistor_r25_ohm`].
    ThermistorR25Ohm,
    /// [`Config::thermistor_beta_k`].
    ThermistorBetaK,
    /// [`Config::thermistor_r_fixed_ohm`].
    ThermistorRFixedOhm,
    /// [`Config::probe_debounce_us`].
    ProbeDebounceUs,
    /// [`Config::probe_reseat_us`].
    ProbeReseatUs,
    /// [`Config::can_node_id`].
    CanNodeId,
    /// [`TestSetup::circle_plane`].
    CirclePlane,
    /// [`TestSetup::circle_centre_mm`] component k (0 X, 1 Y, 2 Z).
    CircleCentreMm(u8),
    /// [`TestSetup::circle_radius_mm`].
    CircleRadiusMm,
    /// [`TestSetup::circle_feed_mm_per_min`].
    CircleFeed,
    /// [`TestSetup::circle_min_arc_deg`].
    CircleMinArcDeg,
    /// [`TestSetup::s002_l_b_mm`].
    S002LbMm,
    /// [`TestSetup::s002_r_b_mm`].
    S002RbMm,
    /// [`TestSetup::s002_r_b2_mm`].
    S002Rb2Mm,
    /// [`TestSetup::s002_r_c_mm`].
    S002RcMm,
    /// [`TestSetup::s002_z_c_mm`].
    S002ZcMm,
    /// [`TestSetup::s002_z_t_mm`].
    S002ZtMm,
    /// [`TestSetup::s002_z_t2_mm`].
    S002Zt2Mm,
    /// [`TestSetup::s002_x_t_mm`].
    S002XtMm,
    /// [`TestSetup::s002_origin_mm`] component k.
    S002OriginMm(u8),
    /// [`TestSetup::ssm_socket_mm`] component k.
    SsmSocketMm(u8),
    /// [`TestSetup::ssm_window_radius_mm`].
    SsmWindowRadiusMm,
    /// [`TestSetup::ssm_dwell_speed_mm_per_s`].
    SsmDwellSpeed,
    /// [`TestSetup::ssm_settle_ms`].
    SsmSettleMs,
    /// [`TestSetup::ssm_min_dwell_samples`].
    SsmMinDwellSamples,
    /// [`TestSetup::ts_machine`].
    TsMachine,
    /// [`TestSetup::ts_tool_z_mm`].
    TsToolZMm,
    /// [`TestSetup::ts_z_alpha_gamma_mm`].
    TsZAlphaGammaMm,
    /// [`TestSetup::ts_reference_mm`] component k.
    TsReferenceMm(u8),
    /// [`TestSetup::ts_origin_mm`] component k.
    TsOriginMm(u8),
    /// [`TestSetup::ts_angles_deg`] component k.
    TsAngleDeg(u8),
    /// [`TestSetup::probe_length_mm`] (added in encoding version 3).
    ProbeLengthMm,
    /// [`TestSetup::run_trigger`] (added in encoding version 4).
    RunTrigger,
    /// [`TestSetup::circle_arc_deg`] (added in encoding version 4).
    CircleArcDeg,
    /// [`TestSetup::s002_u_w_clamp_um`] (added in encoding version 5).
    S002UWClampUm,
    /// [`TestSetup::s002_u_t_centring_um`] (added in encoding version 5).
    S002UTCentringUm,
    /// [`TestSetup::s002_u_t_axial_um`] (added in encoding version 5).
    S002UTAxialUm,
    /// [`Config::bar_u_length_um`] (added in encoding version 6).
    BarULengthUm,
    /// [`Config::bar_u_temp_k`] (added in encoding version 6).
    BarUTempK,
    /// [`Config::lvdt_u_scale_ppm`] (added in encoding version 6).
    LvdtUScalePpm,
    /// [`TestSetup::s002_u_r_c_z_c_um`] (added in encoding version 7; the last object below
    /// the enumerated ones at 0x2040).
    S002URcZcUm,
    /// [`TestSetup::probe_u_lobing_um`] (added in encoding version 8; the first object after
    /// the enumerated ones, 0x2044).
    ProbeULobingUm,
    /// [`TestSetup::ssm_u_socket_um`] (added in encoding version 9, 0x2045).
    SsmUSocketUm,
    /// [`TestSetup::circle_u_centre_um`] (added in encoding version 9, 0x2046).
    CircleUCentreUm,
    /// [`TestSetup::s002_u_r_b_um`] (added in encoding version 10, 0x2047).
    S002URbUm,
    /// A pod sample is not a whole number of excitation periods within the ADC ring
    /// (`excitation / sample_rate` ∉ 1…[`MAX_PERIODS_PER_SAMPLE`]).
    PeriodsPerSample,
    /// An axis name is used by two inputs.
    AxisNameDuplicate(u8),
    /// Encoder input n moves, at [`GLITCH_MARGIN`] × its maximum speed, more counts between two
    /// reads of its hardware counter than the count extension can follow
    /// ([`Config::counter_reach`]).
    AxisCounterReach(u8),
}

/// An encoder input's count step between two counter reads against what the extension follows
/// ([`Config::counter_reach`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CounterReach {
    /// Counts between two reads at [`GLITCH_MARGIN`] × the maximum speed.
    pub counts_per_read: f64,
    /// The largest step the extension follows, counts (2^(bits − 1) − 1).
    pub max_counts_per_read: f64,
}

/// How a field is stored (and sent: CANopen data type, encoding width).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FieldType {
    /// IEEE 754 single (REAL32).
    F32,
    /// IEEE 754 double (the encoder scales: sent as REAL32 over CANopen, 15 digits over SCPI).
    F64,
    /// Unsigned 8-bit integer (UNSIGNED8); with [`FieldInfo::choices`], a code.
    U8,
    /// Unsigned 16-bit integer (UNSIGNED16).
    U16,
    /// Unsigned 32-bit integer (UNSIGNED32).
    U32,
}

/// Name, unit, type, range and default of a field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FieldInfo {
    /// The field (for an indexed field, element 0; see [`FieldInfo::elements`]).
    pub field: Field,
    /// Its name as users see it (SCPI / CANopen / docs).
    pub name: &'static str,
    /// Its unit.
    pub unit: Unit,
    /// Storage type.
    pub ty: FieldType,
    /// Smallest allowed value (inclusive).
    pub min: f64,
    /// Largest allowed value (inclusive).
    pub max: f64,
    /// Number of elements of an indexed field (e.g. 4 polynomial coefficients), 0 for a scalar.
    pub elements: u8,
    /// True if the field may be **not set** (NaN; the default of set-up lengths and positions
    /// the pod cannot know). Once written it can only return to "not set" by restoring the
    /// defaults.
    pub optional: bool,
}

/// Points of the excitation table per period: the pod's DAC table and the demodulation's (the
/// firmware builds both at compile time), so `samples_per_period` can only be this.
pub const EXCITATION_POINTS: u16 = 20;
/// Width of each encoder input's hardware counter, bits, in input order: TIM1, TIM3, TIM4
/// (16 bits), TIM2 and TIM5 (32 bits) on the NUCLEO-G474RE — the rotary axes' default inputs
/// (4 and 5) are the wide ones. The configuration's rule ([`Config::counter_reach`]) holds every
/// board to these, so a configuration the pod takes is one the real counters follow.
pub const ENCODER_COUNTER_BITS: [u32; MAX_AXES] = [16, 16, 16, 32, 32];
/// Times a sample the board reads the hardware counters and extends them to 64 bits (the block
/// latch at each half block: `board::lvdt::BlockLatchIsr`).
pub const COUNTER_READS_PER_SAMPLE: u32 = 2;
/// Margin on the plausible count step between two samples: a step beyond this many times the
/// step at the axis' maximum speed is a quadrature glitch (flagged, counted).
pub const GLITCH_MARGIN: f64 = 2.0;
/// Most excitation periods in one pod sample: the ADC DMA ring holds one block of
/// [`EXCITATION_POINTS`] × this samples per channel (RAM budget).
pub const MAX_PERIODS_PER_SAMPLE: u32 = 5;
/// The fields the pod applies at its next reset (the sample clock, the excitation table and
/// the ADC rings are set up at boot): written values are kept and read back, saved with
/// `*SAV` / 0x1010, and reported pending (status word bit 14) until then.
pub const AT_RESET: [Field; 3] = [
    Field::ExcitationHz,
    Field::SamplesPerPeriod,
    Field::SampleRateHz,
];

const fn real(field: Field, name: &'static str, unit: Unit, min: f64, max: f64) -> FieldInfo {
    FieldInfo {
        field,
        name,
        unit,
        ty: FieldType::F32,
        min,
        max,
        elements: 0,
        optional: false,
    }
}

const fn unset(mut f: FieldInfo) -> FieldInfo {
    f.optional = true;
    f
}

const fn typed(mut f: FieldInfo, ty: FieldType) -> FieldInfo {
    f.ty = ty;
    f
}

const fn indexed(mut f: FieldInfo, elements: u8) -> FieldInfo {
    f.elements = elements;
    f
}

/// A code field: codes 0 … the last of [`FieldInfo::choices`].
const fn code(field: Field, name: &'static str) -> FieldInfo {
    let mut f = FieldInfo {
        field,
        name,
        unit: Unit::One,
        ty: FieldType::U8,
        min: 0.0,
        max: 0.0,
        elements: 0,
        optional: false,
    };
    f.max = f.choices().len() as f64 - 1.0;
    f
}

/// Largest |coordinate| of a set-up position or an axis reference, mm (degrees for a rotary
/// axis's reference).
pub const POS_MM: f64 = 10_000.0;

/// Every numeric configuration field with unit, type and range: the single table that
/// validation, the binary encoding, the CANopen objects
/// ([`crate::protocol::canopen::od::config_index`] of the row), SCPI `CONFigure`, the EDS and
/// the documentation share. Append new rows at the end (the row gives the CANopen index).
pub const FIELDS: &[FieldInfo] = &[
    real(Field::BarLengthMm, "bar_length", Unit::Mm, 50.0, 600.0),
    real(Field::BarCtePpmPerK, "bar_cte", Unit::PpmPerK, -5.0, 30.0),
    indexed(
        real(Field::LvdtPolyUm(0), "lvdt_poly", Unit::Um, -1.0e5, 1.0e5),
        4,
    ),
    real(
        Field::LvdtMaxAbsRatio,
        "lvdt_max_ratio",
        Unit::One,
        0.01,
        1.0,
    ),
    real(
        Field::LvdtMinSignal,
        "lvdt_min_signal",
        Unit::CountsOrV,
        1.0e-3,
        4095.0,
    ),
    real(Field::LvdtDcZeroV, "lvdt_dc_zero", Unit::V, -10.0, 10.0),
    real(Field::LvdtDcSpanV, "lvdt_dc_span", Unit::V, 0.01, 20.0),
    real(Field::ExcitationHz, "excitation", Unit::Hz, 1000.0, 20000.0),
    typed(
        real(
            Field::SamplesPerPeriod,
            "samples_per_period",
            Unit::One,
            EXCITATION_POINTS as f64,
            EXCITATION_POINTS as f64,
        ),
        FieldType::U16,
    ),
    // 200 Hz: five periods of the slowest excitation (MAX_PERIODS_PER_SAMPLE)
    real(Field::SampleRateHz, "sample_rate", Unit::Hz, 200.0, 10000.0),
    indexed(
        typed(
            real(
                Field::AxisCountsPerUnit(0),
                "axis_counts",
                Unit::CountsPerMmOrDeg,
                0.1,
                1.0e8,
            ),
            FieldType::F64,
        ),
        MAX_AXES as u8,
    ),
    indexed(
        real(
            Field::AxisMaxSpeed(0),
            "axis_max_speed",
            Unit::MmOrDegPerS,
            1.0,
            10000.0,
        ),
        MAX_AXES as u8,
    ),
    real(Field::ThermistorR25Ohm, "ntc_r25", Unit::Ohm, 100.0, 1.0e6),
    real(Field::ThermistorBetaK, "ntc_beta", Unit::K, 1000.0, 10000.0),
    real(
        Field::ThermistorRFixedOhm,
        "ntc_r_fixed",
        Unit::Ohm,
        100.0,
        1.0e6,
    ),
    typed(
        real(
            Field::ProbeDebounceUs,
            "probe_debounce",
            Unit::Us,
            0.0,
            100_000.0,
        ),
        FieldType::U32,
    ),
    typed(
        real(
            Field::ProbeReseatUs,
            "probe_reseat",
            Unit::Us,
            0.0,
            5_000_000.0,
        ),
        FieldType::U32,
    ),
    typed(
        real(Field::CanNodeId, "can_node_id", Unit::One, 1.0, 255.0),
        FieldType::U8,
    ),
    code(Field::CirclePlane, "circle_plane"),
    unset(real(
        Field::CircleCentreMm(0),
        "circle_centre_x",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::CircleCentreMm(1),
        "circle_centre_y",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::CircleCentreMm(2),
        "circle_centre_z",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::CircleRadiusMm,
        "circle_radius",
        Unit::Mm,
        1.0,
        2000.0,
    )),
    unset(real(
        Field::CircleFeed,
        "circle_feed",
        Unit::MmPerMin,
        1.0,
        100_000.0,
    )),
    real(
        Field::CircleMinArcDeg,
        "circle_min_arc",
        Unit::Deg,
        10.0,
        360.0,
    ),
    unset(real(Field::S002LbMm, "s002_l_b", Unit::Mm, 10.0, 2000.0)),
    unset(real(Field::S002RbMm, "s002_r_b", Unit::Mm, 1.0, POS_MM)),
    unset(real(Field::S002Rb2Mm, "s002_r_b2", Unit::Mm, 1.0, POS_MM)),
    unset(real(Field::S002RcMm, "s002_r_c", Unit::Mm, 1.0, POS_MM)),
    unset(real(Field::S002ZcMm, "s002_z_c", Unit::Mm, -POS_MM, POS_MM)),
    unset(real(Field::S002ZtMm, "s002_z_t", Unit::Mm, -POS_MM, POS_MM)),
    unset(real(
        Field::S002Zt2Mm,
        "s002_z_t2",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(Field::S002XtMm, "s002_x_t", Unit::Mm, -POS_MM, POS_MM)),
    unset(real(
        Field::S002OriginMm(0),
        "s002_origin_x",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::S002OriginMm(1),
        "s002_origin_y",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::S002OriginMm(2),
        "s002_origin_z",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::SsmSocketMm(0),
        "ssm_socket_x",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::SsmSocketMm(1),
        "ssm_socket_y",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::SsmSocketMm(2),
        "ssm_socket_z",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    real(
        Field::SsmWindowRadiusMm,
        "ssm_window_radius",
        Unit::Mm,
        0.1,
        1000.0,
    ),
    real(
        Field::SsmDwellSpeed,
        "ssm_dwell_speed",
        Unit::MmPerS,
        0.01,
        100.0,
    ),
    real(Field::SsmSettleMs, "ssm_settle", Unit::Ms, 0.0, 10_000.0),
    typed(
        real(
            Field::SsmMinDwellSamples,
            "ssm_min_dwell",
            Unit::Samples,
            3.0,
            1.0e6,
        ),
        FieldType::U32,
    ),
    code(Field::TsMachine, "ts_machine"),
    unset(real(
        Field::TsToolZMm,
        "ts_tool_z",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::TsZAlphaGammaMm,
        "ts_z_alpha_gamma",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::TsReferenceMm(0),
        "ts_reference_x",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::TsReferenceMm(1),
        "ts_reference_y",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::TsReferenceMm(2),
        "ts_reference_z",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::TsOriginMm(0),
        "ts_origin_x",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::TsOriginMm(1),
        "ts_origin_y",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::TsOriginMm(2),
        "ts_origin_z",
        Unit::Mm,
        -POS_MM,
        POS_MM,
    )),
    unset(real(
        Field::TsAngleDeg(0),
        "ts_angle_1",
        Unit::Deg,
        -360.0,
        360.0,
    )),
    unset(real(
        Field::TsAngleDeg(1),
        "ts_angle_2",
        Unit::Deg,
        -360.0,
        360.0,
    )),
    // new fields go last: a field's CANopen index follows from its row, and the version 2
    // encoding is this table's prefix
    unset(real(
        Field::ProbeLengthMm,
        "probe_length",
        Unit::Mm,
        1.0,
        POS_MM,
    )),
    code(Field::RunTrigger, "run_trigger"),
    unset(real(
        Field::CircleArcDeg,
        "circle_arc",
        Unit::Deg,
        10.0,
        360.0,
    )),
    real(
        Field::S002UWClampUm,
        "s002_u_w_clamp",
        Unit::Um,
        0.0,
        1000.0,
    ),
    real(
        Field::S002UTCentringUm,
        "s002_u_t_centring",
        Unit::Um,
        0.0,
        1000.0,
    ),
    real(
        Field::S002UTAxialUm,
        "s002_u_t_axial",
        Unit::Um,
        0.0,
        1000.0,
    ),
    real(Field::BarULengthUm, "bar_u_length", Unit::Um, 0.0, 100.0),
    real(Field::BarUTempK, "bar_u_temp", Unit::K, 0.0, 10.0),
    real(
        Field::LvdtUScalePpm,
        "lvdt_u_scale",
        Unit::Ppm,
        0.0,
        100_000.0,
    ),
    real(Field::S002URcZcUm, "s002_u_r_c_z_c", Unit::Um, 0.0, 1000.0),
    real(
        Field::ProbeULobingUm,
        "probe_u_lobing",
        Unit::Um,
        0.0,
        100.0,
    ),
    real(Field::SsmUSocketUm, "ssm_u_socket", Unit::Um, 0.0, 1000.0),
    real(
        Field::CircleUCentreUm,
        "circle_u_centre",
        Unit::Um,
        0.0,
        1000.0,
    ),
    real(Field::S002URbUm, "s002_u_r_b", Unit::Um, 0.0, 1000.0),
];

/// Why a configuration was rejected.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ConfigError {
    /// A value outside its allowed range (or not finite, or NaN where the field must be set).
    OutOfRange {
        /// The field.
        field: Field,
        /// The rejected value.
        value: f64,
        /// Smallest allowed value.
        min: f64,
        /// Largest allowed value.
        max: f64,
    },
    /// Two inputs name the same axis (the field names the second input).
    Duplicate {
        /// The field.
        field: Field,
    },
    /// Encoded bytes too short or too long for this version.
    BadLength {
        /// Bytes given.
        len: usize,
        /// Bytes expected.
        expected: usize,
    },
    /// The encoding does not start with the magic `BPOD`.
    BadMagic,
    /// An encoding version this firmware does not read.
    UnsupportedVersion(u16),
    /// The CRC does not match (corrupt or torn write).
    BadCrc {
        /// CRC stored in the bytes.
        stored: u32,
        /// CRC computed over them.
        computed: u32,
    },
    /// An enum byte with no meaning (axis name, input mode, bit rate); the byte offset is given.
    BadEnum {
        /// Offset of the byte in the encoding.
        offset: usize,
    },
}

impl Default for TestSetup {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl TestSetup {
    /// The defaults: every length and position not set (NaN), the SSM and circle limits.
    // A constant, so a default is a copy from flash (smaller than building it in code).
    const DEFAULT: Self = {
        const NOT_SET: f32 = f32::NAN;
        Self {
            circle_plane: CirclePlane::XY,
            circle_centre_mm: [NOT_SET; 3],
            circle_radius_mm: NOT_SET,
            circle_feed_mm_per_min: NOT_SET,
            circle_min_arc_deg: 300.0,
            s002_l_b_mm: NOT_SET,
            s002_r_b_mm: NOT_SET,
            s002_r_b2_mm: NOT_SET,
            s002_r_c_mm: NOT_SET,
            s002_z_c_mm: NOT_SET,
            s002_z_t_mm: NOT_SET,
            s002_z_t2_mm: NOT_SET,
            s002_x_t_mm: NOT_SET,
            s002_origin_mm: [NOT_SET; 3],
            ssm_socket_mm: [NOT_SET; 3],
            ssm_window_radius_mm: 5.0,
            ssm_dwell_speed_mm_per_s: 1.0,
            ssm_settle_ms: 100.0,
            ssm_min_dwell_samples: 100,
            ts_machine: TwoStepMachine::None,
            ts_tool_z_mm: NOT_SET,
            ts_z_alpha_gamma_mm: NOT_SET,
            ts_reference_mm: [NOT_SET; 3],
            ts_origin_mm: [NOT_SET; 3],
            ts_angles_deg: [NOT_SET; 2],
            probe_length_mm: NOT_SET,
            run_trigger: RunTrigger::Command,
            circle_arc_deg: NOT_SET,
            s002_u_w_clamp_um: S002_U_W_CLAMP_UM as f32,
            s002_u_t_centring_um: S002_U_T_CENTRING_UM as f32,
            s002_u_t_axial_um: S002_U_T_AXIAL_UM as f32,
            s002_u_r_c_z_c_um: S002_U_R_C_Z_C_UM as f32,
            probe_u_lobing_um: U_LOBING_UM as f32,
            ssm_u_socket_um: U_SOCKET_UM as f32,
            circle_u_centre_um: U_CENTRE_UM as f32,
            s002_u_r_b_um: S002_U_R_B_UM as f32,
        }
    };
}

impl Default for Config {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Config {
    /// The defaults (the tables of the book's configuration reference).
    // A constant, so a default is a copy from flash (smaller than building it in code).
    const DEFAULT: Self = {
        const fn lin(name: AxisName) -> AxisConfig {
            AxisConfig {
                name,
                counts_per_unit: 10_000.0,
                reversed: false,
                max_speed_per_s: 1000.0,
            }
        }
        const fn rot(name: AxisName) -> AxisConfig {
            AxisConfig {
                name,
                counts_per_unit: 10_000.0,
                reversed: false,
                max_speed_per_s: 3600.0,
            }
        }
        Self {
            bar_length_mm: 150.0,
            bar_cte_ppm_per_k: 11.5,
            lvdt_input: LvdtInput::AcRatiometric,
            // ±1 mm stroke at ratio ±0.5 (a typical half-bridge LVDT); calibrated per bar.
            lvdt_poly_um: [0.0, 2000.0, 0.0, 0.0],
            lvdt_max_abs_ratio: 0.55,
            lvdt_min_signal: 200.0,
            lvdt_dc_zero_v: 0.0,
            lvdt_dc_span_v: 10.0,
            excitation_hz: 5000.0,
            samples_per_period: 20,
            sample_rate_hz: 1000.0,
            axes: [
                lin(AxisName::X),
                lin(AxisName::Y),
                lin(AxisName::Z),
                rot(AxisName::B),
                rot(AxisName::C),
            ],
            thermistor_r25_ohm: 10_000.0,
            thermistor_beta_k: 3950.0,
            thermistor_r_fixed_ohm: 10_000.0,
            probe_debounce_us: 2_000,
            probe_reseat_us: 50_000,
            can_node_id: 16,
            can_bitrate: CanBitrate::K500,
            setup: TestSetup::DEFAULT,
            bar_u_length_um: DEFAULT_U_LENGTH_UM,
            bar_u_temp_k: DEFAULT_U_TEMP_K,
            lvdt_u_scale_ppm: DEFAULT_U_SCALE_PPM,
        }
    };
}

impl Config {
    /// All zeros: a placeholder for the header of an empty log, not a valid configuration
    /// ([`Config::validate`] refuses it).
    pub const ZERO: Self = {
        const AXIS: AxisConfig = AxisConfig {
            name: AxisName::Unused,
            counts_per_unit: 0.0,
            reversed: false,
            max_speed_per_s: 0.0,
        };
        Self {
            bar_length_mm: 0.0,
            bar_cte_ppm_per_k: 0.0,
            lvdt_input: LvdtInput::AcRatiometric,
            lvdt_poly_um: [0.0; 4],
            lvdt_max_abs_ratio: 0.0,
            lvdt_min_signal: 0.0,
            lvdt_dc_zero_v: 0.0,
            lvdt_dc_span_v: 0.0,
            excitation_hz: 0.0,
            samples_per_period: 0,
            sample_rate_hz: 0.0,
            axes: [AXIS; MAX_AXES],
            thermistor_r25_ohm: 0.0,
            thermistor_beta_k: 0.0,
            thermistor_r_fixed_ohm: 0.0,
            probe_debounce_us: 0,
            probe_reseat_us: 0,
            can_node_id: 0,
            can_bitrate: CanBitrate::K125,
            setup: TestSetup {
                circle_plane: CirclePlane::XY,
                circle_centre_mm: [0.0; 3],
                circle_radius_mm: 0.0,
                circle_feed_mm_per_min: 0.0,
                circle_min_arc_deg: 0.0,
                s002_l_b_mm: 0.0,
                s002_r_b_mm: 0.0,
                s002_r_b2_mm: 0.0,
                s002_r_c_mm: 0.0,
                s002_z_c_mm: 0.0,
                s002_z_t_mm: 0.0,
                s002_z_t2_mm: 0.0,
                s002_x_t_mm: 0.0,
                s002_origin_mm: [0.0; 3],
                ssm_socket_mm: [0.0; 3],
                ssm_window_radius_mm: 0.0,
                ssm_dwell_speed_mm_per_s: 0.0,
                ssm_settle_ms: 0.0,
                ssm_min_dwell_samples: 0,
                ts_machine: TwoStepMachine::None,
                ts_tool_z_mm: 0.0,
                ts_z_alpha_gamma_mm: 0.0,
                ts_reference_mm: [0.0; 3],
                ts_origin_mm: [0.0; 3],
                ts_angles_deg: [0.0; 2],
                probe_length_mm: 0.0,
                run_trigger: RunTrigger::Command,
                circle_arc_deg: 0.0,
                s002_u_w_clamp_um: 0.0,
                s002_u_t_centring_um: 0.0,
                s002_u_t_axial_um: 0.0,
                s002_u_r_c_z_c_um: 0.0,
                probe_u_lobing_um: 0.0,
                ssm_u_socket_um: 0.0,
                circle_u_centre_um: 0.0,
                s002_u_r_b_um: 0.0,
            },
            bar_u_length_um: 0.0,
            bar_u_temp_k: 0.0,
            lvdt_u_scale_ppm: 0.0,
        }
    };
}

/// The table row of a field (indexed fields share the row of element 0).
fn info(field: Field) -> Option<&'static FieldInfo> {
    let key = match field {
        Field::LvdtPolyUm(_) => Field::LvdtPolyUm(0),
        Field::AxisCountsPerUnit(_) => Field::AxisCountsPerUnit(0),
        Field::AxisMaxSpeed(_) => Field::AxisMaxSpeed(0),
        f => f,
    };
    FIELDS.iter().find(|i| i.field == key)
}

impl Field {
    /// What the field is, for the EDS and the book's configuration reference (an exhaustive
    /// match: a new field does not build without its text; the firmware never calls it, so the
    /// text is not in flash).
    pub const fn meaning(self) -> &'static str {
        match self {
            Field::BarLengthMm => {
                "Calibrated ball-bar length at 20 °C (the nominal the LVDT's ΔL is measured against)"
            }
            Field::BarCtePpmPerK => "Thermal expansion coefficient of the bar body (steel 11.5)",
            Field::LvdtPolyUm(_) => {
                "LVDT calibration polynomial, coefficient k of x = Σ c_k·r^k (r the demodulated ratio)"
            }
            Field::LvdtMaxAbsRatio => {
                "Largest |ratio| inside the calibrated stroke; beyond it a sample is over-range"
            }
            Field::LvdtMinSignal => {
                "Smallest healthy LVDT signal, ADC counts (AC) or volts (DC); below it the coil is open"
            }
            Field::LvdtDcZeroV => "DC input mode: the conditioner's output at the LVDT null",
            Field::LvdtDcSpanV => "DC input mode: the conditioner's output change for ratio 1",
            Field::ExcitationHz => {
                "LVDT excitation frequency; a sample must be a whole 1 … 5 excitation periods (taken at reset)"
            }
            Field::SamplesPerPeriod => {
                "ADC samples per excitation period: the 20-point excitation table (taken at reset)"
            }
            Field::SampleRateHz => "Pod sample rate (ΔL and axes); taken at reset",
            Field::AxisCountsPerUnit(_) => {
                "Encoder input n: counts per mm (linear) or per degree (rotary), after ×4 quadrature decoding"
            }
            Field::AxisMaxSpeed(_) => {
                "Encoder input n: fastest plausible axis speed; a larger count step is a quadrature glitch"
            }
            Field::ThermistorR25Ohm => "Bar thermistor: resistance at 25 °C",
            Field::ThermistorBetaK => "Bar thermistor: β constant",
            Field::ThermistorRFixedOhm => "Bar thermistor: the divider's fixed resistor",
            Field::ProbeDebounceUs => {
                "Touch probe: edges this soon after a trigger are contact bounce"
            }
            Field::ProbeReseatUs => {
                "Touch probe: time the stylus must read seated before the probe re-arms"
            }
            Field::CanNodeId => {
                "CANopen node-ID 1–127 (taken at reset communication), or 255: none, the pod answers LSS (CiA 305) only until a master configures one"
            }
            Field::CirclePlane => "CIRCLE: plane of the circle",
            Field::CircleCentreMm(_) => {
                "CIRCLE: circle centre = the socket, machine coordinate X, Y or Z (the coordinate normal to the plane may stay not set)"
            }
            Field::CircleRadiusMm => {
                "CIRCLE: nominal radius (the bar length for a circle about the socket in its plane)"
            }
            Field::CircleFeed => "CIRCLE: programmed feed (for the servo-mismatch diagnosis)",
            Field::CircleMinArcDeg => {
                "Circular runs: shortest arc that gives results (set at most 220 for a 220° partial arc)"
            }
            Field::S002LbMm => "Seed 002 (Table 4.3): L_B, ball-bar length",
            Field::S002RbMm => "Seed 002: R_B, B-axis centre to T-ball, steps BX … CA",
            Field::S002Rb2Mm => "Seed 002: R′_B, B-axis centre to T-ball, step CR2",
            Field::S002RcMm => "Seed 002: R_C, W-ball distance from the C centreline",
            Field::S002ZcMm => "Seed 002: Z_C, W-ball height above the C table",
            Field::S002ZtMm => "Seed 002 thesis mode: Z_T, lever arm of steps 1–4",
            Field::S002Zt2Mm => "Seed 002 thesis mode: Z′_T, lever arm of step 5",
            Field::S002XtMm => "Seed 002 thesis mode: X_T, lever arm",
            Field::S002OriginMm(_) => {
                "Seed 002: machine coordinate X, Y or Z of the model frame's origin O_M (on the C axis at the table)"
            }
            Field::SsmSocketMm(_) => {
                "SSM: machine coordinate X, Y or Z of the socket (pivot) centre P0"
            }
            Field::SsmWindowRadiusMm => {
                "SSM streaming: radius of the neighbourhood whose samples share one E"
            }
            Field::SsmDwellSpeed => {
                "SSM: linear speed below which the machine dwells (a station; the live E's window restarts)"
            }
            Field::SsmSettleMs => "SSM stations: settling time before a dwell is averaged",
            Field::SsmMinDwellSamples => {
                "SSM stations: fewest averaged samples for a dwell to count as a station"
            }
            Field::TsMachine => "Seed 000 two-step: machine type",
            Field::TsToolZMm => {
                "Two-step: signed tool vector z_r along the spindle axis (RRTTT, RTTTR spindle)"
            }
            Field::TsZAlphaGammaMm => "Two-step: z_αγ between the table's α and γ centres (TTTRR)",
            Field::TsReferenceMm(_) => {
                "Two-step: reference point in the table frame, X, Y or Z (TTTRR, RTTTR table)"
            }
            Field::TsOriginMm(_) => {
                "Two-step: nominal pivot (spindle) or table origin after the translation, X, Y or Z"
            }
            Field::TsAngleDeg(_) => {
                "Two-step: nominal angle 1 or 2 of the rotation: RRTTT (α, β), TTTRR (α, γ), RTTTR spindle (β), RTTTR table (α)"
            }
            Field::ProbeLengthMm => {
                "PROBE: tool length R, B-axis centre to stylus-ball centre; set, a touch point is the nominal stylus-ball centre axes − R·(sin B, 0, cos B)"
            }
            Field::RunTrigger => {
                "What starts and stops a run: COMMAND (a client) or FEED_IN (CIRCLE: the part program's feed-in and data arc)"
            }
            Field::CircleArcDeg => {
                "CIRCLE, FEED_IN: span of the data arc a self-triggered run measures (not set: until the feed-out)"
            }
            Field::S002UWClampUm => {
                "Seed 002 uncertainty budget: W-ball clamping shift, standard uncertainty per component, each clamping (default: 10–60 µm in a random direction)"
            }
            Field::S002UTCentringUm => {
                "Seed 002 uncertainty budget: T-ball radial offset left by centring, standard uncertainty per component, each tool length (default: within a 1 µm disc)"
            }
            Field::S002UTAxialUm => {
                "Seed 002 uncertainty budget: T-ball axial offset (tool-length error), standard uncertainty, each tool length (default: as the W-ball's clamping shift)"
            }
            Field::BarULengthUm => {
                "Uncertainty budget: the bar's calibrated length, standard uncertainty (default: a certificate's U = 1 µm at k = 2)"
            }
            Field::BarUTempK => {
                "Uncertainty budget: the bar's temperature as measured, standard uncertainty (default: the thermistor and the bar's gradient)"
            }
            Field::LvdtUScalePpm => {
                "Uncertainty budget: the LVDT's scale (calibration, linearity), relative standard uncertainty of ΔL (default: 0.1 %)"
            }
            Field::S002URcZcUm => {
                "Seed 002 uncertainty budget: R_C and Z_C as entered, standard uncertainty of each one's difference from the value the steps ran with (default: Z_C by dial gauge, R_C the X the W-ball was docked at)"
            }
            Field::ProbeULobingUm => {
                "Touch-probe uncertainty budget: the probe's lobing (pre-travel varying with the direction of approach), standard uncertainty of each component of its three-lobe pattern across the stylus (the higher harmonics in proportion) and of its pre-travel along the stylus less across (default: a kinematic probe's ±1–2 µm 2D/3D lobing)"
            }
            Field::SsmUSocketUm => {
                "SSM uncertainty budget: the socket's centre as entered (ssm_socket), standard uncertainty of each coordinate's difference from its true centre; it moves E one to one (default: the spindle's setting cup docked on the socket's ball)"
            }
            Field::CircleUCentreUm => {
                "Circle uncertainty budget: the circle's centre as entered (circle_centre), standard uncertainty of each in-plane coordinate's difference from the centre the part program circles about; it turns each sample's direction, moving e and r0 through the profile's shape, and moves each sample along the profile into another bin, moving G, F, G(b) and the diagnoses (default: the program's centre entered to the micrometre; the socket's own offset shows in e)"
            }
            Field::S002URbUm => {
                "Seed 002 uncertainty budget: the tool lengths R_B and R′_B as entered, standard uncertainty of each one's difference from the length the steps ran with (default: a tool length measured to a few µm)"
            }
            Field::PeriodsPerSample => {
                "Cross-field rule: excitation / sample_rate must be a whole 1 … 5 periods"
            }
            Field::AxisNameDuplicate(_) => {
                "Cross-field rule: an axis name may be used by one encoder input only"
            }
            Field::AxisCounterReach(_) => {
                "Cross-field rule: at twice axis_max_speed, axis_counts × speed / (2 × sample_rate) must stay below half the input's counter range: 32 767 counts for encoder inputs 1–3 (16-bit timers), 2³¹ − 1 for inputs 4 and 5 (32-bit)"
            }
        }
    }
}

impl FieldInfo {
    /// The field of element `k` of this row (the row's own field for a scalar).
    pub const fn element(&self, k: u8) -> Field {
        match self.field {
            Field::LvdtPolyUm(_) => Field::LvdtPolyUm(k),
            Field::AxisCountsPerUnit(_) => Field::AxisCountsPerUnit(k),
            Field::AxisMaxSpeed(_) => Field::AxisMaxSpeed(k),
            f => f,
        }
    }

    /// Every field of this row: its elements, or the row's field alone.
    pub fn fields(&'static self) -> impl Iterator<Item = Field> {
        let n = self.elements.max(1);
        (0..n).map(move |k| self.element(k))
    }

    /// True for integer storage (U8, U16, U32).
    pub const fn is_integer(&self) -> bool {
        matches!(self.ty, FieldType::U8 | FieldType::U16 | FieldType::U32)
    }

    /// For a code field ([`FieldType::U8`] with named codes): the name of each code, in code
    /// order; empty for any other field. A match on the field, not a slice in every row of
    /// [`FIELDS`] (three code fields among about 80 rows: 0.6 KB of flash).
    pub const fn choices(&self) -> &'static [&'static str] {
        match self.field {
            Field::CirclePlane => &CirclePlane::NAMES,
            Field::TsMachine => &TwoStepMachine::NAMES,
            Field::RunTrigger => &RunTrigger::NAMES,
            _ => &[],
        }
    }

    /// The code of choice `name` (case-insensitive) of a code field.
    pub fn choice(&self, name: &[u8]) -> Option<u8> {
        self.choices()
            .iter()
            .position(|c| c.as_bytes().eq_ignore_ascii_case(name))
            .map(|i| i as u8)
    }
}

/// Checks one value of `field` against its table row: in range, finite (NaN only where the
/// field may be not set). An `f32` field compares the value it would store (rounded to `f32`)
/// with its limits rounded to `f32`, so a limit such as 0.01, which has no exact binary value,
/// can itself be written whichever way it is given (0.01 as REAL32 over CANopen, or the
/// decimal 0.01 over SCPI).
fn check(field: Field, value: f64) -> Result<(), ConfigError> {
    let Some(i) = info(field) else {
        return Ok(());
    };
    let (min, max, stored) = if i.ty == FieldType::F32 {
        let r = |v: f64| f64::from(v as f32);
        (r(i.min), r(i.max), r(value))
    } else {
        (i.min, i.max, value)
    };
    if (value.is_nan() && i.optional) || (stored.is_finite() && stored >= min && stored <= max) {
        Ok(())
    } else {
        Err(ConfigError::OutOfRange {
            field,
            value,
            min: i.min,
            max: i.max,
        })
    }
}

/// True if `v` is a set value (a set-up field that is not set reads NaN).
pub fn is_set(v: f32) -> bool {
    !v.is_nan()
}

/// The value of set-up field `f` that a computation needs (`v`, as f64), or `f` when it is
/// not set.
// one copy in flash for the many set-up fields the application reads
#[inline(never)]
pub fn required(v: f32, f: Field) -> Result<f64, Field> {
    if is_set(v) { Ok(f64::from(v)) } else { Err(f) }
}

/// The X, Y, Z components of set-up field `f` (e.g. [`Field::S002OriginMm`]), all needed.
pub fn required3(v: [f32; 3], f: fn(u8) -> Field) -> Result<[f64; 3], Field> {
    let [x, y, z] = v;
    Ok([required(x, f(0))?, required(y, f(1))?, required(z, f(2))?])
}

impl Config {
    /// Unit, range and name of a field.
    pub fn field_info(field: Field) -> Option<&'static FieldInfo> {
        info(field)
    }

    /// The field called `name` (as in [`FIELDS`]; `lvdt_poly`, `axis_counts` and
    /// `axis_max_speed` take the element as a suffix: `lvdt_poly2`, `axis_counts1`…), or `None`.
    pub fn field_by_name(name: &str) -> Option<Field> {
        if let Some(i) = FIELDS.iter().find(|i| i.elements == 0 && i.name == name) {
            return Some(i.field);
        }
        FIELDS.iter().filter(|i| i.elements > 0).find_map(|i| {
            let k: u8 = name.strip_prefix(i.name)?.parse().ok()?;
            (k < i.elements).then(|| i.element(k))
        })
    }

    /// Excitation periods in one pod sample, `excitation_hz / sample_rate_hz` (a whole number
    /// 1…[`MAX_PERIODS_PER_SAMPLE`] in a valid configuration).
    pub fn periods_per_sample(&self) -> f64 {
        f64::from(self.excitation_hz) / f64::from(self.sample_rate_hz)
    }

    /// Validates every field; the first violation is returned.
    pub fn validate(&self) -> Result<(), ConfigError> {
        for row in FIELDS {
            for f in row.fields() {
                check(f, self.field_value(f).unwrap_or(f64::NAN))?;
            }
        }
        // a node-ID is 1–127, or 255 for none (CiA 305's "unconfigured")
        if (128..=254).contains(&self.can_node_id) {
            return Err(ConfigError::OutOfRange {
                field: Field::CanNodeId,
                value: f64::from(self.can_node_id),
                min: 1.0,
                max: 127.0,
            });
        }
        // a sample is a whole number of excitation periods that fits the ADC ring
        let periods = self.periods_per_sample();
        let max = f64::from(MAX_PERIODS_PER_SAMPLE);
        if !(periods >= 1.0 && periods <= max && periods == libm::trunc(periods)) {
            return Err(ConfigError::OutOfRange {
                field: Field::PeriodsPerSample,
                value: periods,
                min: 1.0,
                max,
            });
        }
        for (i, a) in (0u8..).zip(self.axes.iter()) {
            let dup = a.name != AxisName::Unused
                && self
                    .axes
                    .iter()
                    .take(usize::from(i))
                    .any(|b| b.name == a.name);
            if dup {
                return Err(ConfigError::Duplicate {
                    field: Field::AxisNameDuplicate(i),
                });
            }
        }
        self.check_counter_reach()
    }

    /// The counter-reach rule alone ([`Config::counter_reach`] of every input that reads an
    /// axis), the first input beyond it named.
    pub fn check_counter_reach(&self) -> Result<(), ConfigError> {
        for (i, a) in (0u8..).zip(self.axes.iter()) {
            let reach = self.counter_reach(usize::from(i));
            if a.name != AxisName::Unused && !(reach.counts_per_read <= reach.max_counts_per_read) {
                return Err(ConfigError::OutOfRange {
                    field: Field::AxisCounterReach(i),
                    value: reach.counts_per_read,
                    min: 0.0,
                    max: reach.max_counts_per_read,
                });
            }
        }
        Ok(())
    }

    /// Encoder input `i`'s counts between two reads of its hardware counter at
    /// [`GLITCH_MARGIN`] × its maximum speed, and the most the count extension follows: the
    /// difference of two reads is taken modulo 2^bits as signed, so a step must stay below
    /// 2^(bits − 1) ([`ENCODER_COUNTER_BITS`], [`COUNTER_READS_PER_SAMPLE`]). A step the pod
    /// flags as a glitch is then one it measured. (Unknown input: 0 of 0.)
    pub fn counter_reach(&self, i: usize) -> CounterReach {
        let (Some(a), Some(bits)) = (self.axes.get(i), ENCODER_COUNTER_BITS.get(i)) else {
            return CounterReach::default();
        };
        let reads_per_s = f64::from(self.sample_rate_hz) * f64::from(COUNTER_READS_PER_SAMPLE);
        CounterReach {
            counts_per_read: GLITCH_MARGIN * f64::from(a.max_speed_per_s) * a.counts_per_unit
                / reads_per_s,
            max_counts_per_read: (1u64 << (bits.saturating_sub(1) & 63)) as f64 - 1.0,
        }
    }

    /// A numeric field's value as `f64` in its unit (NaN for a set-up field that is not set;
    /// `None` for [`Field`]s with no storage). The one accessor the protocol layers (CANopen
    /// objects, SCPI `CONFigure`) and the encoding share.
    pub fn field_value(&self, f: Field) -> Option<f64> {
        let axis = |i: u8| self.axes.get(usize::from(i));
        let s = &self.setup;
        let at = |a: &[f32], k: u8| a.get(usize::from(k)).copied().map(f64::from);
        Some(match f {
            Field::BarLengthMm => f64::from(self.bar_length_mm),
            Field::BarCtePpmPerK => f64::from(self.bar_cte_ppm_per_k),
            Field::LvdtPolyUm(k) => at(&self.lvdt_poly_um, k)?,
            Field::LvdtMaxAbsRatio => f64::from(self.lvdt_max_abs_ratio),
            Field::LvdtMinSignal => f64::from(self.lvdt_min_signal),
            Field::LvdtDcZeroV => f64::from(self.lvdt_dc_zero_v),
            Field::LvdtDcSpanV => f64::from(self.lvdt_dc_span_v),
            Field::ExcitationHz => f64::from(self.excitation_hz),
            Field::SamplesPerPeriod => f64::from(self.samples_per_period),
            Field::SampleRateHz => f64::from(self.sample_rate_hz),
            Field::AxisCountsPerUnit(i) => axis(i)?.counts_per_unit,
            Field::AxisMaxSpeed(i) => f64::from(axis(i)?.max_speed_per_s),
            Field::ThermistorR25Ohm => f64::from(self.thermistor_r25_ohm),
            Field::ThermistorBetaK => f64::from(self.thermistor_beta_k),
            Field::ThermistorRFixedOhm => f64::from(self.thermistor_r_fixed_ohm),
            Field::ProbeDebounceUs => f64::from(self.probe_debounce_us),
            Field::ProbeReseatUs => f64::from(self.probe_reseat_us),
            Field::CanNodeId => f64::from(self.can_node_id),
            Field::CirclePlane => f64::from(s.circle_plane as u8),
            Field::CircleCentreMm(k) => at(&s.circle_centre_mm, k)?,
            Field::CircleRadiusMm => f64::from(s.circle_radius_mm),
            Field::CircleFeed => f64::from(s.circle_feed_mm_per_min),
            Field::CircleMinArcDeg => f64::from(s.circle_min_arc_deg),
            Field::S002LbMm => f64::from(s.s002_l_b_mm),
            Field::S002RbMm => f64::from(s.s002_r_b_mm),
            Field::S002Rb2Mm => f64::from(s.s002_r_b2_mm),
            Field::S002RcMm => f64::from(s.s002_r_c_mm),
            Field::S002ZcMm => f64::from(s.s002_z_c_mm),
            Field::S002ZtMm => f64::from(s.s002_z_t_mm),
            Field::S002Zt2Mm => f64::from(s.s002_z_t2_mm),
            Field::S002XtMm => f64::from(s.s002_x_t_mm),
            Field::S002OriginMm(k) => at(&s.s002_origin_mm, k)?,
            Field::SsmSocketMm(k) => at(&s.ssm_socket_mm, k)?,
            Field::SsmWindowRadiusMm => f64::from(s.ssm_window_radius_mm),
            Field::SsmDwellSpeed => f64::from(s.ssm_dwell_speed_mm_per_s),
            Field::SsmSettleMs => f64::from(s.ssm_settle_ms),
            Field::SsmMinDwellSamples => f64::from(s.ssm_min_dwell_samples),
            Field::TsMachine => f64::from(s.ts_machine as u8),
            Field::TsToolZMm => f64::from(s.ts_tool_z_mm),
            Field::TsZAlphaGammaMm => f64::from(s.ts_z_alpha_gamma_mm),
            Field::TsReferenceMm(k) => at(&s.ts_reference_mm, k)?,
            Field::TsOriginMm(k) => at(&s.ts_origin_mm, k)?,
            Field::TsAngleDeg(k) => at(&s.ts_angles_deg, k)?,
            Field::ProbeLengthMm => f64::from(s.probe_length_mm),
            Field::RunTrigger => f64::from(s.run_trigger as u8),
            Field::CircleArcDeg => f64::from(s.circle_arc_deg),
            Field::S002UWClampUm => f64::from(s.s002_u_w_clamp_um),
            Field::S002UTCentringUm => f64::from(s.s002_u_t_centring_um),
            Field::S002UTAxialUm => f64::from(s.s002_u_t_axial_um),
            Field::BarULengthUm => f64::from(self.bar_u_length_um),
            Field::BarUTempK => f64::from(self.bar_u_temp_k),
            Field::LvdtUScalePpm => f64::from(self.lvdt_u_scale_ppm),
            Field::S002URcZcUm => f64::from(s.s002_u_r_c_z_c_um),
            Field::ProbeULobingUm => f64::from(s.probe_u_lobing_um),
            Field::SsmUSocketUm => f64::from(s.ssm_u_socket_um),
            Field::CircleUCentreUm => f64::from(s.circle_u_centre_um),
            Field::S002URbUm => f64::from(s.s002_u_r_b_um),
            Field::PeriodsPerSample | Field::AxisNameDuplicate(_) | Field::AxisCounterReach(_) => {
                return None;
            }
        })
    }

    /// True for the fields stored as integers (a written value must be a whole number).
    pub fn is_integer_field(f: Field) -> bool {
        info(f).is_some_and(FieldInfo::is_integer)
    }

    /// Sets a numeric field from `v` in its unit: `f32` fields take the nearest `f32`, integer
    /// fields the nearest integer (saturating; a code field an unknown code keeps the old
    /// value and fails validation), `counts_per_unit` the `f64`
    /// as is. No range check here: use it inside [`Config::try_update`], which validates the
    /// result (the `f32` limits are compared rounded to `f32`, so every value the table allows
    /// can be set).
    pub fn set_field(&mut self, f: Field, v: f64) {
        let x = v as f32;
        let int = libm::round(v);
        let s = &mut self.setup;
        let put = |a: &mut [f32], k: u8| {
            if let Some(p) = a.get_mut(usize::from(k)) {
                *p = x;
            }
        };
        match f {
            Field::BarLengthMm => self.bar_length_mm = x,
            Field::BarCtePpmPerK => self.bar_cte_ppm_per_k = x,
            Field::LvdtPolyUm(k) => put(&mut self.lvdt_poly_um, k),
            Field::LvdtMaxAbsRatio => self.lvdt_max_abs_ratio = x,
            Field::LvdtMinSignal => self.lvdt_min_signal = x,
            Field::LvdtDcZeroV => self.lvdt_dc_zero_v = x,
            Field::LvdtDcSpanV => self.lvdt_dc_span_v = x,
            Field::ExcitationHz => self.excitation_hz = x,
            Field::SamplesPerPeriod => self.samples_per_period = int as u16,
            Field::SampleRateHz => self.sample_rate_hz = x,
            Field::AxisCountsPerUnit(i) => {
                if let Some(a) = self.axes.get_mut(usize::from(i)) {
                    a.counts_per_unit = v;
                }
            }
            Field::AxisMaxSpeed(i) => {
                if let Some(a) = self.axes.get_mut(usize::from(i)) {
                    a.max_speed_per_s = x;
                }
            }
            Field::ThermistorR25Ohm => self.thermistor_r25_ohm = x,
            Field::ThermistorBetaK => self.thermistor_beta_k = x,
            Field::ThermistorRFixedOhm => self.thermistor_r_fixed_ohm = x,
            Field::ProbeDebounceUs => self.probe_debounce_us = int as u32,
            Field::ProbeReseatUs => self.probe_reseat_us = int as u32,
            Field::CanNodeId => self.can_node_id = int as u8,
            Field::CirclePlane => {
                if let Some(p) = CirclePlane::from_u8(int as u8).filter(|_| int >= 0.0) {
                    s.circle_plane = p;
                }
            }
            Field::CircleCentreMm(k) => put(&mut s.circle_centre_mm, k),
            Field::CircleRadiusMm => s.circle_radius_mm = x,
            Field::CircleFeed => s.circle_feed_mm_per_min = x,
            Field::CircleMinArcDeg => s.circle_min_arc_deg = x,
            Field::S002LbMm => s.s002_l_b_mm = x,
            Field::S002RbMm => s.s002_r_b_mm = x,
            Field::S002Rb2Mm => s.s002_r_b2_mm = x,
            Field::S002RcMm => s.s002_r_c_mm = x,
            Field::S002ZcMm => s.s002_z_c_mm = x,
            Field::S002ZtMm => s.s002_z_t_mm = x,
            Field::S002Zt2Mm => s.s002_z_t2_mm = x,
            Field::S002XtMm => s.s002_x_t_mm = x,
            Field::S002OriginMm(k) => put(&mut s.s002_origin_mm, k),
            Field::SsmSocketMm(k) => put(&mut s.ssm_socket_mm, k),
            Field::SsmWindowRadiusMm => s.ssm_window_radius_mm = x,
            Field::SsmDwellSpeed => s.ssm_dwell_speed_mm_per_s = x,
            Field::SsmSettleMs => s.ssm_settle_ms = x,
            Field::SsmMinDwellSamples => s.ssm_min_dwell_samples = int as u32,
            Field::TsMachine => {
                if let Some(m) = TwoStepMachine::from_u8(int as u8).filter(|_| int >= 0.0) {
                    s.ts_machine = m;
                }
            }
            Field::TsToolZMm => s.ts_tool_z_mm = x,
            Field::TsZAlphaGammaMm => s.ts_z_alpha_gamma_mm = x,
            Field::TsReferenceMm(k) => put(&mut s.ts_reference_mm, k),
            Field::TsOriginMm(k) => put(&mut s.ts_origin_mm, k),
            Field::TsAngleDeg(k) => put(&mut s.ts_angles_deg, k),
            Field::ProbeLengthMm => s.probe_length_mm = x,
            Field::RunTrigger => {
                if let Some(t) = RunTrigger::from_u8(int as u8).filter(|_| int >= 0.0) {
                    s.run_trigger = t;
                }
            }
            Field::CircleArcDeg => s.circle_arc_deg = x,
            Field::S002UWClampUm => s.s002_u_w_clamp_um = x,
            Field::S002UTCentringUm => s.s002_u_t_centring_um = x,
            Field::S002UTAxialUm => s.s002_u_t_axial_um = x,
            Field::BarULengthUm => self.bar_u_length_um = x,
            Field::BarUTempK => self.bar_u_temp_k = x,
            Field::LvdtUScalePpm => self.lvdt_u_scale_ppm = x,
            Field::S002URcZcUm => s.s002_u_r_c_z_c_um = x,
            Field::ProbeULobingUm => s.probe_u_lobing_um = x,
            Field::SsmUSocketUm => s.ssm_u_socket_um = x,
            Field::CircleUCentreUm => s.circle_u_centre_um = x,
            Field::S002URbUm => s.s002_u_r_b_um = x,
            Field::PeriodsPerSample | Field::AxisNameDuplicate(_) | Field::AxisCounterReach(_) => {}
        }
    }

    /// Checks `v` for field `f` as a write would see it (range, whole number for an integer
    /// field, a known code for a code field, NaN only for a field that may be not set) without
    /// changing anything.
    pub fn check_write(f: Field, v: f64) -> Result<(), ConfigError> {
        check(f, v)?;
        if Self::is_integer_field(f) && v != libm::trunc(v) {
            let (min, max) = info(f).map_or((0.0, 0.0), |i| (i.min, i.max));
            return Err(ConfigError::OutOfRange {
                field: f,
                value: v,
                min,
                max,
            });
        }
        Ok(())
    }

    /// Applies `edit` to a copy and keeps it only if the whole copy is valid; on error the
    /// configuration is unchanged.
    pub fn try_update(&mut self, edit: impl FnOnce(&mut Config)) -> Result<(), ConfigError> {
        let mut next = *self;
        edit(&mut next);
        next.validate()?;
        *self = next;
        Ok(())
    }

    /// Sets field `f` to `v` if the value is acceptable ([`check_write`](Self::check_write))
    /// and the whole configuration stays valid; otherwise nothing changes.
    pub fn set(&mut self, f: Field, v: f64) -> Result<(), ConfigError> {
        Self::check_write(f, v)?;
        self.try_update(|c| c.set_field(f, v))
    }
}

// ---------------------------------------------------------------------------------------------
// Binary encoding
// ---------------------------------------------------------------------------------------------

/// Magic at the start of an encoded configuration.
pub const MAGIC: [u8; 4] = *b"BPOD";
/// Current encoding version (10: version 9 plus the seed 002 budget's `s002_u_r_b`; 9:
/// version 8 plus the set-up's `ssm_u_socket` and
/// `circle_u_centre`; 8: version 7
/// plus the touch probe's `probe_u_lobing`; 7: version
/// 6 plus the seed 002 budget's `s002_u_r_c_z_c`; 6:
/// version 5 plus the bar's uncertainty budget `bar_u_length`,
/// `bar_u_temp`, `lvdt_u_scale`; 5: version 4 plus the seed 002 mounting uncertainties
/// `s002_u_w_clamp`, `s002_u_t_centring`, `s002_u_t_axial`; 4: version 3 plus `run_trigger`
/// and `circle_arc`; 3: version 2 plus `probe_length`). Version 2 to 9 encodings are read
/// and migrated (the fields added since keep their defaults); version 1 records are not read:
/// the pod boots on the defaults and says so.
pub const ENCODING_VERSION: u16 = 10;
/// Oldest encoding version read.
pub const OLDEST_ENCODING_VERSION: u16 = 2;

/// The encoding version that added a field (new fields are the last [`FIELDS`] rows, so each
/// older encoding is a prefix of the table).
const fn added_in(f: Field) -> u16 {
    match f {
        Field::ProbeLengthMm => 3,
        Field::RunTrigger | Field::CircleArcDeg => 4,
        Field::S002UWClampUm | Field::S002UTCentringUm | Field::S002UTAxialUm => 5,
        Field::BarULengthUm | Field::BarUTempK | Field::LvdtUScalePpm => 6,
        Field::S002URcZcUm => 7,
        Field::ProbeULobingUm => 8,
        Field::SsmUSocketUm | Field::CircleUCentreUm => 9,
        Field::S002URbUm => 10,
        _ => 2,
    }
}

/// Bytes of one stored value of `ty`.
const fn type_bytes(ty: FieldType) -> usize {
    match ty {
        FieldType::F32 | FieldType::U32 => 4,
        FieldType::F64 => 8,
        FieldType::U8 => 1,
        FieldType::U16 => 2,
    }
}

/// Payload bytes of encoding `version`: every [`FIELDS`] element that version has, by its
/// type, then the enumerated fields (LVDT input, CAN bit rate, per axis name and reversed flag).
// Evaluated at compile time for each version: an index out of bounds is a build error.
#[allow(clippy::indexing_slicing)]
const fn payload_len(version: u16) -> usize {
    let mut n = 0;
    let mut i = 0;
    while i < FIELDS.len() {
        let r = &FIELDS[i];
        let k = if r.elements == 0 {
            1
        } else {
            r.elements as usize
        };
        if added_in(r.field) <= version {
            n += k * type_bytes(r.ty);
        }
        i += 1;
    }
    n + 2 + 2 * MAX_AXES
}
/// Payload bytes of the current encoding.
const PAYLOAD: usize = payload_len(ENCODING_VERSION);
/// Total encoded size: magic, version u16, payload length u16, payload, CRC-32.
pub const ENCODED_LEN: usize = 4 + 2 + 2 + PAYLOAD + 4;
/// Total size of each encoding read, oldest first (read and migrated; only the last written).
pub const ENCODED_LENS: [usize; 9] = [
    12 + payload_len(2),
    12 + payload_len(3),
    12 + payload_len(4),
    12 + payload_len(5),
    12 + payload_len(6),
    12 + payload_len(7),
    12 + payload_len(8),
    12 + payload_len(9),
    12 + payload_len(ENCODING_VERSION),
];

/// Little-endian writer over a fixed buffer (never writes past its end).
struct Writer<'a> {
    buf: &'a mut [u8],
    pos: usize,
}

impl Writer<'_> {
    fn put(&mut self, bytes: &[u8]) {
        if let Some(dst) = self.buf.get_mut(self.pos..self.pos + bytes.len()) {
            dst.copy_from_slice(bytes);
        }
        self.pos += bytes.len();
    }
}

/// Little-endian reader (returns zeros past the end; lengths are checked before reading).
struct Reader<'a> {
    buf: &'a [u8],
    pos: usize,
}

impl Reader<'_> {
    fn take<const K: usize>(&mut self) -> [u8; K] {
        let mut out = [0u8; K];
        if let Some(src) = self.buf.get(self.pos..self.pos + K) {
            out.copy_from_slice(src);
        }
        self.pos += K;
        out
    }
    fn u8(&mut self) -> u8 {
        self.take::<1>()[0]
    }
}

impl Config {
    /// Encodes into `out` (which must hold [`ENCODED_LEN`] bytes; returns the bytes written or
    /// `BadLength`). Layout: `"BPOD"`, version u16, payload length u16, payload, CRC-32/ISO-HDLC
    /// of everything before it. Payload: every [`FIELDS`] element in table order as its type
    /// (little-endian f32 / f64 / u8 / u16 / u32; a set-up field that is not set is the f32
    /// NaN), then `lvdt_input`, `can_bitrate`, and per encoder input its axis name and
    /// reversed flag (one byte each).
    pub fn encode(&self, out: &mut [u8]) -> Result<usize, ConfigError> {
        if out.len() < ENCODED_LEN {
            return Err(ConfigError::BadLength {
                len: out.len(),
                expected: ENCODED_LEN,
            });
        }
        let mut w = Writer { buf: out, pos: 0 };
        w.put(&MAGIC);
        w.put(&ENCODING_VERSION.to_le_bytes());
        w.put(&(PAYLOAD as u16).to_le_bytes());
        for row in FIELDS {
            for f in row.fields() {
                let v = self.field_value(f).unwrap_or(f64::NAN);
                match row.ty {
                    FieldType::F32 => w.put(&(v as f32).to_le_bytes()),
                    FieldType::F64 => w.put(&v.to_le_bytes()),
                    FieldType::U8 => w.put(&[v as u8]),
                    FieldType::U16 => w.put(&(v as u16).to_le_bytes()),
                    FieldType::U32 => w.put(&(v as u32).to_le_bytes()),
                }
            }
        }
        w.put(&[self.lvdt_input as u8, self.can_bitrate as u8]);
        for a in &self.axes {
            w.put(&[a.name as u8, u8::from(a.reversed)]);
        }
        let crc_end = w.pos;
        let crc = out.get(..crc_end).map_or(0, crate::num::crc32);
        let mut w = Writer {
            buf: out,
            pos: crc_end,
        };
        w.put(&crc.to_le_bytes());
        Ok(w.pos)
    }

    /// Decodes and validates an encoding. Every check (length, magic, version, CRC, enum
    /// bytes, ranges) must pass; otherwise the error says which failed and nothing is returned.
    /// An older encoding (versions 2 to 9, [`ENCODED_LENS`]) is read too: the fields added
    /// since keep their defaults.
    pub fn decode(bytes: &[u8]) -> Result<Config, ConfigError> {
        let mut r = Reader { buf: bytes, pos: 0 };
        if r.take::<4>() != MAGIC {
            return Err(ConfigError::BadMagic);
        }
        let version = u16::from_le_bytes(r.take());
        if !(OLDEST_ENCODING_VERSION..=ENCODING_VERSION).contains(&version) {
            return Err(ConfigError::UnsupportedVersion(version));
        }
        let payload_len = payload_len(version);
        let len = 12 + payload_len;
        if bytes.len() != len {
            return Err(ConfigError::BadLength {
                len: bytes.len(),
                expected: len,
            });
        }
        let payload = usize::from(u16::from_le_bytes(r.take()));
        if payload != payload_len {
            return Err(ConfigError::BadLength {
                len: payload,
                expected: payload_len,
            });
        }
        let crc_at = len - 4;
        let computed = bytes.get(..crc_at).map_or(0, crate::num::crc32);
        let stored = bytes
            .get(crc_at..)
            .and_then(|s| s.try_into().ok())
            .map_or(0, u32::from_le_bytes);
        if stored != computed {
            return Err(ConfigError::BadCrc { stored, computed });
        }
        let mut c = Config::default();
        for row in FIELDS {
            for f in row.fields() {
                if added_in(f) > version {
                    continue;
                }
                let at = r.pos;
                let v = match row.ty {
                    FieldType::F32 => f64::from(f32::from_le_bytes(r.take())),
                    FieldType::F64 => f64::from_le_bytes(r.take()),
                    FieldType::U8 => f64::from(r.u8()),
                    FieldType::U16 => f64::from(u16::from_le_bytes(r.take())),
                    FieldType::U32 => f64::from(u32::from_le_bytes(r.take())),
                };
                if !row.choices().is_empty() && !(v <= row.max) {
                    return Err(ConfigError::BadEnum { offset: at });
                }
                c.set_field(f, v);
                // a value set_field cannot hold (e.g. beyond an integer's width) fails here
                check(f, v)?;
            }
        }
        let at = r.pos;
        c.lvdt_input = match r.u8() {
            0 => LvdtInput::AcRatiometric,
            1 => LvdtInput::DcConditioner,
            _ => return Err(ConfigError::BadEnum { offset: at }),
        };
        let at = r.pos;
        c.can_bitrate = CanBitrate::from_u8(r.u8()).ok_or(ConfigError::BadEnum { offset: at })?;
        for a in c.axes.iter_mut() {
            let at = r.pos;
            a.name = AxisName::from_u8(r.u8()).ok_or(ConfigError::BadEnum { offset: at })?;
            a.reversed = match r.u8() {
                0 => false,
                1 => true,
                _ => return Err(ConfigError::BadEnum { offset: at + 1 }),
            };
        }
        c.validate()?;
        Ok(c)
    }
}
