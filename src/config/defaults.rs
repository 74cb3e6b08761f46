//! The defaults of the uncertainty fields, and why each. The modules that use them import them
//! from here: the configuration stands below everything it configures.

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
