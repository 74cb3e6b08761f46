//! Every configuration field, declared once: one row each, in wire order (a row's position is
//! its CANopen object, and each older encoding is a prefix of the rows). A new field is one
//! row **at the end** with the next encoding version; everything else — the storage member and
//! its default, the [`Field`] variant, the [`FIELDS`] row, get and set, validation, the
//! encoding, the EDS and the book's reference — follows from it. The columns are explained in
//! [`super::declare`].

use super::kinds::{AxisName, CanBitrate, CirclePlane, LvdtInput, RunTrigger, TwoStepMachine};
use super::{
    DEFAULT_U_LENGTH_UM, DEFAULT_U_SCALE_PPM, DEFAULT_U_TEMP_K, EXCITATION_POINTS, FieldInfo,
    FieldType, MAX_AXES, POS_MM, S002_U_R_B_UM, S002_U_R_C_Z_C_UM, S002_U_T_AXIAL_UM,
    S002_U_T_CENTRING_UM, S002_U_W_CLAMP_UM, TakesEffect, U_CENTRE_UM, U_LOBING_UM, U_SOCKET_UM,
    family,
};
use crate::units::Unit;

/// A set-up length or position the pod cannot know by itself: not set until a client writes it.
const NOT_SET: f32 = f32::NAN;

config_fields! {
    // members of `Config` that are not numeric fields (CANopen objects of their own)
    config {
        /// LVDT input mode.
        lvdt_input: LvdtInput = LvdtInput::AcRatiometric,
        /// CAN bit rate.
        can_bitrate: CanBitrate = CanBitrate::K500,
    }
    // members of each encoder input that are not numeric fields, one default per input
    axes {
        /// Which machine axis this input reads.
        name: AxisName = [AxisName::X, AxisName::Y, AxisName::Z, AxisName::B, AxisName::C],
        /// Counting direction: true if the counter counts down in the axis' positive direction.
        reversed: bool = [false; MAX_AXES],
    }
    // rules across fields (named in a refusal; nothing stored)
    rules {
        /// A pod sample is not a whole number of excitation periods within the ADC ring
        /// (`excitation / sample_rate` ∉ 1…[`super::MAX_PERIODS_PER_SAMPLE`]).
        PeriodsPerSample => "Cross-field rule: excitation / sample_rate must be a whole 1 … 5 periods",
        /// An axis name is used by two inputs (the second is named).
        AxisNameDuplicate(n) => "Cross-field rule: an axis name may be used by one encoder input only",
        /// Encoder input n moves, at [`super::GLITCH_MARGIN`] × its maximum speed, more counts
        /// between two reads of its hardware counter than the count extension can follow
        /// ([`Config::counter_reach`](super::Config::counter_reach)).
        AxisCounterReach(n) => "Cross-field rule: at twice axis_max_speed, axis_counts × speed / (2 × sample_rate) must stay below half the input's counter range: 32 767 counts for encoder inputs 1–3 (16-bit timers), 2³¹ − 1 for inputs 4 and 5 (32-bit)",
    }
    rows {
        BarLengthMm = config.bar_length_mm (f32) "bar_length" = 150.0;
            Mm [50.0, 600.0] needed since 2 at NextSample
            "Calibrated ball-bar length at 20 °C (the nominal the LVDT's ΔL is measured against)",
        BarCtePpmPerK = config.bar_cte_ppm_per_k (f32) "bar_cte" = 11.5;
            PpmPerK [-5.0, 30.0] needed since 2 at NextSample
            "Thermal expansion coefficient of the bar body (steel 11.5)",
        // ±1 mm stroke at ratio ±0.5 (a typical half-bridge LVDT); calibrated per bar
        LvdtPolyUm(k) = config.lvdt_poly_um (f32) {"lvdt_poly"; 4} = [0.0, 2000.0, 0.0, 0.0];
            Um [-1.0e5, 1.0e5] needed since 2 at NextSample
            "LVDT calibration polynomial, coefficient k of x = Σ c_k·r^k (r the demodulated ratio)",
        LvdtMaxAbsRatio = config.lvdt_max_abs_ratio (f32) "lvdt_max_ratio" = 0.55;
            One [0.01, 1.0] needed since 2 at NextSample
            "Largest |ratio| inside the calibrated stroke; beyond it a sample is over-range",
        LvdtMinSignal = config.lvdt_min_signal (f32) "lvdt_min_signal" = 200.0;
            CountsOrV [1.0e-3, 4095.0] needed since 2 at NextSample
            "Smallest healthy LVDT signal, ADC counts (AC) or volts (DC); below it the coil is open",
        LvdtDcZeroV = config.lvdt_dc_zero_v (f32) "lvdt_dc_zero" = 0.0;
            V [-10.0, 10.0] needed since 2 at NextSample
            "DC input mode: the conditioner's output at the LVDT null",
        LvdtDcSpanV = config.lvdt_dc_span_v (f32) "lvdt_dc_span" = 10.0;
            V [0.01, 20.0] needed since 2 at NextSample
            "DC input mode: the conditioner's output change for ratio 1",
        ExcitationHz = config.excitation_hz (f32) "excitation" = 5000.0;
            Hz [1000.0, 20000.0] needed since 2 at Reset
            "LVDT excitation frequency; a sample must be a whole 1 … 5 excitation periods (taken at reset)",
        SamplesPerPeriod = config.samples_per_period (u16) "samples_per_period" = EXCITATION_POINTS;
            One [EXCITATION_POINTS as f64, EXCITATION_POINTS as f64] needed since 2 at Reset
            "ADC samples per excitation period: the 20-point excitation table (taken at reset)",
        // 200 Hz: five periods of the slowest excitation (MAX_PERIODS_PER_SAMPLE)
        SampleRateHz = config.sample_rate_hz (f32) "sample_rate" = 1000.0;
            Hz [200.0, 10000.0] needed since 2 at Reset
            "Pod sample rate (ΔL and axes); taken at reset",
        AxisCountsPerUnit(k) = axes.counts_per_unit (f64) {"axis_counts"; MAX_AXES} = [10_000.0; MAX_AXES];
            CountsPerMmOrDeg [0.1, 1.0e8] needed since 2 at NextSample
            "Encoder input n: counts per mm (linear) or per degree (rotary), after ×4 quadrature decoding",
        AxisMaxSpeed(k) = axes.max_speed_per_s (f32) {"axis_max_speed"; MAX_AXES} = [1000.0, 1000.0, 1000.0, 3600.0, 3600.0];
            MmOrDegPerS [1.0, 10000.0] needed since 2 at NextSample
            "Encoder input n: fastest plausible axis speed; a larger count step is a quadrature glitch",
        ThermistorR25Ohm = config.thermistor_r25_ohm (f32) "ntc_r25" = 10_000.0;
            Ohm [100.0, 1.0e6] needed since 2 at NextSample
            "Bar thermistor: resistance at 25 °C",
        ThermistorBetaK = config.thermistor_beta_k (f32) "ntc_beta" = 3950.0;
            K [1000.0, 10000.0] needed since 2 at NextSample
            "Bar thermistor: β constant",
        ThermistorRFixedOhm = config.thermistor_r_fixed_ohm (f32) "ntc_r_fixed" = 10_000.0;
            Ohm [100.0, 1.0e6] needed since 2 at NextSample
            "Bar thermistor: the divider's fixed resistor",
        ProbeDebounceUs = config.probe_debounce_us (u32) "probe_debounce" = 2_000;
            Us [0.0, 100_000.0] needed since 2 at NextSample
            "Touch probe: edges this soon after a trigger are contact bounce",
        ProbeReseatUs = config.probe_reseat_us (u32) "probe_reseat" = 50_000;
            Us [0.0, 5_000_000.0] needed since 2 at NextSample
            "Touch probe: time the stylus must read seated before the probe re-arms",
        // 1–127, or 255: none (CiA 305's "unconfigured"; `Config::validate` refuses 128–254)
        CanNodeId = config.can_node_id (u8) "can_node_id" = 16;
            One [1.0, 255.0] needed since 2 at ResetCommunication
            "CANopen node-ID 1–127 (taken at reset communication), or 255: none, the pod answers LSS (CiA 305) only until a master configures one",
        CirclePlane = setup.circle_plane (code CirclePlane) "circle_plane" = CirclePlane::XY;
            One codes needed since 2 at NextRun
            "CIRCLE: plane of the circle",
        CircleCentreMm(k) = setup.circle_centre_mm (f32) ["circle_centre_x", "circle_centre_y", "circle_centre_z"] = [NOT_SET; 3];
            Mm [-POS_MM, POS_MM] optional since 2 at NextRun
            "CIRCLE: circle centre = the socket, machine coordinate X, Y or Z (the coordinate normal to the plane may stay not set)",
        CircleRadiusMm = setup.circle_radius_mm (f32) "circle_radius" = NOT_SET;
            Mm [1.0, 2000.0] optional since 2 at NextRun
            "CIRCLE: nominal radius (the bar length for a circle about the socket in its plane)",
        CircleFeed = setup.circle_feed_mm_per_min (f32) "circle_feed" = NOT_SET;
            MmPerMin [1.0, 100_000.0] optional since 2 at NextRun
            "CIRCLE: programmed feed (for the servo-mismatch diagnosis)",
        CircleMinArcDeg = setup.circle_min_arc_deg (f32) "circle_min_arc" = 300.0;
            Deg [10.0, 360.0] needed since 2 at NextRun
            "Circular runs: shortest arc that gives results (set at most 220 for a 220° partial arc)",
        S002LbMm = setup.s002_l_b_mm (f32) "s002_l_b" = NOT_SET;
            Mm [10.0, 2000.0] optional since 2 at NextRun
            "Seed 002 (Table 4.3): L_B, ball-bar length",
        S002RbMm = setup.s002_r_b_mm (f32) "s002_r_b" = NOT_SET;
            Mm [1.0, POS_MM] optional since 2 at NextRun
            "Seed 002: R_B, B-axis centre to T-ball, steps BX … CA",
        S002Rb2Mm = setup.s002_r_b2_mm (f32) "s002_r_b2" = NOT_SET;
            Mm [1.0, POS_MM] optional since 2 at NextRun
            "Seed 002: R′_B, B-axis centre to T-ball, step CR2",
        S002RcMm = setup.s002_r_c_mm (f32) "s002_r_c" = NOT_SET;
            Mm [1.0, POS_MM] optional since 2 at NextRun
            "Seed 002: R_C, W-ball distance from the C centreline",
        S002ZcMm = setup.s002_z_c_mm (f32) "s002_z_c" = NOT_SET;
            Mm [-POS_MM, POS_MM] optional since 2 at NextRun
            "Seed 002: Z_C, W-ball height above the C table",
        S002ZtMm = setup.s002_z_t_mm (f32) "s002_z_t" = NOT_SET;
            Mm [-POS_MM, POS_MM] optional since 2 at NextRun
            "Seed 002 thesis mode: Z_T, lever arm of steps 1–4",
        S002Zt2Mm = setup.s002_z_t2_mm (f32) "s002_z_t2" = NOT_SET;
            Mm [-POS_MM, POS_MM] optional since 2 at NextRun
            "Seed 002 thesis mode: Z′_T, lever arm of step 5",
        S002XtMm = setup.s002_x_t_mm (f32) "s002_x_t" = NOT_SET;
            Mm [-POS_MM, POS_MM] optional since 2 at NextRun
            "Seed 002 thesis mode: X_T, lever arm",
        S002OriginMm(k) = setup.s002_origin_mm (f32) ["s002_origin_x", "s002_origin_y", "s002_origin_z"] = [NOT_SET; 3];
            Mm [-POS_MM, POS_MM] optional since 2 at NextRun
            "Seed 002: machine coordinate X, Y or Z of the model frame's origin O_M (on the C axis at the table)",
        SsmSocketMm(k) = setup.ssm_socket_mm (f32) ["ssm_socket_x", "ssm_socket_y", "ssm_socket_z"] = [NOT_SET; 3];
            Mm [-POS_MM, POS_MM] optional since 2 at NextRun
            "SSM: machine coordinate X, Y or Z of the socket (pivot) centre P0",
        SsmWindowRadiusMm = setup.ssm_window_radius_mm (f32) "ssm_window_radius" = 5.0;
            Mm [0.1, 1000.0] needed since 2 at NextRun
            "SSM streaming: radius of the neighbourhood whose samples share one E",
        SsmDwellSpeed = setup.ssm_dwell_speed_mm_per_s (f32) "ssm_dwell_speed" = 1.0;
            MmPerS [0.01, 100.0] needed since 2 at NextRun
            "SSM: linear speed below which the machine dwells (a station; the live E's window restarts)",
        SsmSettleMs = setup.ssm_settle_ms (f32) "ssm_settle" = 100.0;
            Ms [0.0, 10_000.0] needed since 2 at NextRun
            "SSM stations: settling time before a dwell is averaged",
        SsmMinDwellSamples = setup.ssm_min_dwell_samples (u32) "ssm_min_dwell" = 100;
            Samples [3.0, 1.0e6] needed since 2 at NextRun
            "SSM stations: fewest averaged samples for a dwell to count as a station",
        TsMachine = setup.ts_machine (code TwoStepMachine) "ts_machine" = TwoStepMachine::None;
            One codes needed since 2 at NextRun
            "Seed 000 two-step: machine type",
        TsToolZMm = setup.ts_tool_z_mm (f32) "ts_tool_z" = NOT_SET;
            Mm [-POS_MM, POS_MM] optional since 2 at NextRun
            "Two-step: signed tool vector z_r along the spindle axis (RRTTT, RTTTR spindle)",
        TsZAlphaGammaMm = setup.ts_z_alpha_gamma_mm (f32) "ts_z_alpha_gamma" = NOT_SET;
            Mm [-POS_MM, POS_MM] optional since 2 at NextRun
            "Two-step: z_αγ between the table's α and γ centres (TTTRR)",
        TsReferenceMm(k) = setup.ts_reference_mm (f32) ["ts_reference_x", "ts_reference_y", "ts_reference_z"] = [NOT_SET; 3];
            Mm [-POS_MM, POS_MM] optional since 2 at NextRun
            "Two-step: reference point in the table frame, X, Y or Z (TTTRR, RTTTR table)",
        TsOriginMm(k) = setup.ts_origin_mm (f32) ["ts_origin_x", "ts_origin_y", "ts_origin_z"] = [NOT_SET; 3];
            Mm [-POS_MM, POS_MM] optional since 2 at NextRun
            "Two-step: nominal pivot (spindle) or table origin after the translation, X, Y or Z",
        TsAngleDeg(k) = setup.ts_angles_deg (f32) ["ts_angle_1", "ts_angle_2"] = [NOT_SET; 2];
            Deg [-360.0, 360.0] optional since 2 at NextRun
            "Two-step: nominal angle 1 or 2 of the rotation: RRTTT (α, β), TTTRR (α, γ), RTTTR spindle (β), RTTTR table (α)",
        // new fields go last: a field's CANopen index follows from its row, and each older
        // encoding is a prefix of the rows
        ProbeLengthMm = setup.probe_length_mm (f32) "probe_length" = NOT_SET;
            Mm [1.0, POS_MM] optional since 3 at NextRun
            "PROBE: tool length R, B-axis centre to stylus-ball centre; set, a touch point is the nominal stylus-ball centre axes − R·(sin B, 0, cos B)",
        RunTrigger = setup.run_trigger (code RunTrigger) "run_trigger" = RunTrigger::Command;
            One codes needed since 4 at NextRun
            "What starts and stops a run: COMMAND (a client) or FEED_IN (CIRCLE: the part program's feed-in and data arc)",
        CircleArcDeg = setup.circle_arc_deg (f32) "circle_arc" = NOT_SET;
            Deg [10.0, 360.0] optional since 4 at NextRun
            "CIRCLE, FEED_IN: span of the data arc a self-triggered run measures (not set: until the feed-out)",
        S002UWClampUm = setup.s002_u_w_clamp_um (f32) "s002_u_w_clamp" = S002_U_W_CLAMP_UM as f32;
            Um [0.0, 1000.0] needed since 5 at NextRun
            "Seed 002 uncertainty budget: W-ball clamping shift, standard uncertainty per component, each clamping (default: 10–60 µm in a random direction)",
        S002UTCentringUm = setup.s002_u_t_centring_um (f32) "s002_u_t_centring" = S002_U_T_CENTRING_UM as f32;
            Um [0.0, 1000.0] needed since 5 at NextRun
            "Seed 002 uncertainty budget: T-ball radial offset left by centring, standard uncertainty per component, each tool length (default: within a 1 µm disc)",
        S002UTAxialUm = setup.s002_u_t_axial_um (f32) "s002_u_t_axial" = S002_U_T_AXIAL_UM as f32;
            Um [0.0, 1000.0] needed since 5 at NextRun
            "Seed 002 uncertainty budget: T-ball axial offset (tool-length error), standard uncertainty, each tool length (default: as the W-ball's clamping shift)",
        BarULengthUm = config.bar_u_length_um (f32) "bar_u_length" = DEFAULT_U_LENGTH_UM;
            Um [0.0, 100.0] needed since 6 at NextRun
            "Uncertainty budget: the bar's calibrated length, standard uncertainty (default: a certificate's U = 1 µm at k = 2)",
        BarUTempK = config.bar_u_temp_k (f32) "bar_u_temp" = DEFAULT_U_TEMP_K;
            K [0.0, 10.0] needed since 6 at NextRun
            "Uncertainty budget: the bar's temperature as measured, standard uncertainty (default: the thermistor and the bar's gradient)",
        LvdtUScalePpm = config.lvdt_u_scale_ppm (f32) "lvdt_u_scale" = DEFAULT_U_SCALE_PPM;
            Ppm [0.0, 100_000.0] needed since 6 at NextRun
            "Uncertainty budget: the LVDT's scale (calibration, linearity), relative standard uncertainty of ΔL (default: 0.1 %)",
        S002URcZcUm = setup.s002_u_r_c_z_c_um (f32) "s002_u_r_c_z_c" = S002_U_R_C_Z_C_UM as f32;
            Um [0.0, 1000.0] needed since 7 at NextRun
            "Seed 002 uncertainty budget: R_C and Z_C as entered, standard uncertainty of each one's difference from the value the steps ran with (default: Z_C by dial gauge, R_C the X the W-ball was docked at)",
        ProbeULobingUm = setup.probe_u_lobing_um (f32) "probe_u_lobing" = U_LOBING_UM as f32;
            Um [0.0, 100.0] needed since 8 at NextRun
            "Touch-probe uncertainty budget: the probe's lobing (pre-travel varying with the direction of approach), standard uncertainty of each component of its three-lobe pattern across the stylus (the higher harmonics in proportion) and of its pre-travel along the stylus less across (default: a kinematic probe's ±1–2 µm 2D/3D lobing)",
        SsmUSocketUm = setup.ssm_u_socket_um (f32) "ssm_u_socket" = U_SOCKET_UM as f32;
            Um [0.0, 1000.0] needed since 9 at NextRun
            "SSM uncertainty budget: the socket's centre as entered (ssm_socket), standard uncertainty of each coordinate's difference from its true centre; it moves E one to one (default: the spindle's setting cup docked on the socket's ball)",
        CircleUCentreUm = setup.circle_u_centre_um (f32) "circle_u_centre" = U_CENTRE_UM as f32;
            Um [0.0, 1000.0] needed since 9 at NextRun
            "Circle uncertainty budget: the circle's centre as entered (circle_centre), standard uncertainty of each in-plane coordinate's difference from the centre the part program circles about; it turns each sample's direction, moving e and r0 through the profile's shape, and moves each sample along the profile into another bin, moving G, F, G(b) and the diagnoses (default: the program's centre entered to the micrometre; the socket's own offset shows in e)",
        S002URbUm = setup.s002_u_r_b_um (f32) "s002_u_r_b" = S002_U_R_B_UM as f32;
            Um [0.0, 1000.0] needed since 10 at NextRun
            "Seed 002 uncertainty budget: the tool lengths R_B and R′_B as entered, standard uncertainty of each one's difference from the length the steps ran with (default: a tool length measured to a few µm)",
        // traceability: what a run's header, results.json and the desk's report name; numbers,
        // not text (the configuration holds numbers), 0 until entered. The LVDT is calibrated
        // in its bar (lvdt_poly is the bar's calibration): the bar's certificate covers it, and
        // the LVDT is named by its serial number
        BarSerial = config.bar_serial (u32) "bar_serial" = 0;
            One [0.0, 4_294_967_295.0] needed since 11 at NextRun
            "Traceability: the ball bar's serial number (0: not entered)",
        BarCertificate = config.bar_certificate (u32) "bar_certificate" = 0;
            One [0.0, 4_294_967_295.0] needed since 11 at NextRun
            "Traceability: the number of the bar's calibration certificate (its length, bar_length, and its LVDT's, lvdt_poly), its digits (0: not entered)",
        BarCalibrated = config.bar_calibrated (u32) "bar_calibrated" = 0;
            One [0.0, 99_991_231.0] needed since 11 at NextRun
            "Traceability: the date of the bar's calibration, YYYYMMDD (0: not entered)",
        LvdtSerial = config.lvdt_serial (u32) "lvdt_serial" = 0;
            One [0.0, 4_294_967_295.0] needed since 11 at NextRun
            "Traceability: the serial number of the bar's LVDT (0: not entered)",
        // a field that exists only in the test build of the `one-more-field` feature: the host
        // test `config_one_row` checks that this one row is all a new field needs
        #[cfg(feature = "one-more-field")]
        TestExtraUm = setup.test_extra_um (f32) "test_extra" = 2.5;
            Um [0.0, 10.0] needed since 12 at NextRun
            "Test build only: a field added by one row",
    }
}
