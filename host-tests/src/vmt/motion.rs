//! The virtual CNC of the simulated pod (`sim --serve`): when a client starts a run, the
//! machine moves through the armed pattern with the pod's own set-up (its configuration) and,
//! like the last block of a part program, ends the run at the end of the motion (a client may
//! stop or abort it earlier). Each sample period gives the true bar-length deviation, the axis
//! positions the encoders read, and for a PROBE run the probe's edges and level.
//!
//! - CIRCLE: one revolution about the configured centre in the configured plane at the
//!   configured feed (else the machine's), with the circular-test machine's faults
//!   ([`super::machine::CircleMachine`]);
//! - BX … CR2: the step's B arc or C circle on the seed 002 machine ([`super::machine::Machine002`])
//!   with the configured Table 4.3 set-up, at the machine's feed;
//! - SSM: three dwells (0.4 s) on the bar's sphere around the configured socket, 2000 mm/min
//!   between them, the tool point off by the truth's E;
//! - PROBE: nine touches on a sphere (radius 12.7 mm, stylus 1.5 mm), the runs going through
//!   the seed 002 chapter 5 sequence of eight ([`probe_target`]): C = 0/90/180/270° then
//!   B = 0/90° twice (change `probe_length` between the two B pairs, as the thesis changes to
//!   the long stylus).

use ballpod::acquisition::MAX_AXES;
use ballpod::app::Pattern;
use ballpod::app::bc_ballbar::Setup;
use ballpod::config::{CirclePlane, Config};
use serde::{Deserialize, Serialize};

use super::machine::MachineFile;
use crate::forward_seed002 as fwd;

/// What the serving simulator's machine is (the truth the clients compare against).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ServeTruth {
    /// The machines (circle faults, seed 002 deviations, instrument).
    pub machine: MachineFile,
    /// E of an SSM run, µm: the tool point is this far from where it is commanded.
    pub ssm_error_um: [f64; 3],
    /// The probed sphere's distance from the C axis, mm, and its centre height above the
    /// seed 002 origin, mm.
    pub sphere_rc_zc_mm: [f64; 2],
}

impl Default for ServeTruth {
    fn default() -> Self {
        let mut machine = MachineFile::default();
        // a socket 5 µm / 3 µm off where the pod believes it: the circle's eccentricity
        machine.circle.socket_offset_um = [-5.0, 3.0];
        Self {
            machine,
            ssm_error_um: [3.0, -2.0, 1.5],
            sphere_rc_zc_mm: [100.0, 64.838],
        }
    }
}

/// One sample period of the machine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MachineStep {
    /// True bar-length deviation, µm.
    pub dl_um: f64,
    /// Axis positions the encoders read (X, Y, Z mm; B, C degrees).
    pub axes: [f64; MAX_AXES],
    /// A probe edge before this sample, the counters latched at these positions.
    pub edge: Option<[f64; MAX_AXES]>,
    /// The probe stylus is seated.
    pub seated: bool,
}

impl MachineStep {
    fn at(dl_um: f64, axes: [f64; MAX_AXES]) -> Self {
        Self {
            dl_um,
            axes,
            edge: None,
            seated: true,
        }
    }
}

/// The planned motion of one run.
#[derive(Clone, Debug, Default)]
pub struct Motion {
    steps: Vec<MachineStep>,
    next: usize,
}

/// Radius of the probed sphere, mm.
pub const SPHERE_RADIUS_MM: f64 = 12.7;
/// Radius of the stylus ball, mm.
pub const STYLUS_RADIUS_MM: f64 = 1.5;

impl Motion {
    /// No motion.
    pub fn none() -> Self {
        Self::default()
    }

    /// The motion of a run of `pattern` in `direction` with the pod's configuration `cfg`
    /// (set-up, bar length, sample rate); `probe_runs` PROBE runs came before this one. `Err`
    /// names what the set-up lacks for the machine to move.
    pub fn plan(
        truth: &ServeTruth,
        cfg: &Config,
        pattern: Pattern,
        direction: ballpod::app::Direction,
        probe_runs: u32,
    ) -> Result<Self, String> {
        let rate = f64::from(cfg.sample_rate_hz);
        let t = &cfg.setup;
        let sign = direction.sign();
        let steps = match pattern {
            Pattern::Circle => {
                let c = CircleProgram::new(truth, cfg)?;
                let n = c.machine.samples_per_rev(rate);
                (0..n)
                    .map(|i| {
                        c.step(
                            sign * 2.0 * std::f64::consts::PI * i as f64 / n as f64,
                            sign,
                            0.0,
                        )
                    })
                    .collect()
            }
            Pattern::Ssm => ssm_path(truth.ssm_error_um, cfg, SSM_ACCEL_MM_PER_S2)?,
            Pattern::Probe => probe_path(truth, cfg, probe_runs)?,
            step @ (Pattern::Bx | Pattern::By | Pattern::Cr | Pattern::Ca | Pattern::Cr2) => {
                let setup = Setup::from_config(t).map_err(|f| {
                    format!("seed 002 set-up: {} not set", ballpod::app::field_name(f))
                })?;
                let g = setup.geometry(step);
                let feed = truth.machine.circle.feed_mm_per_min;
                let b = matches!(step, Pattern::Bx | Pattern::By);
                let len_mm = if b {
                    g.r_b_mm * std::f64::consts::FRAC_PI_2
                } else if step == Pattern::Ca {
                    2.0 * std::f64::consts::PI * g.r_c_mm
                } else {
                    2.0 * std::f64::consts::PI * (g.r_c_mm - g.l_b_mm).abs()
                };
                let n = ((len_mm / (feed / 60.0) * rate).round() as usize).max(16);
                (0..n)
                    .map(|i| {
                        let angle = if b {
                            // CCW: θ increasing in XZ, φ (B) 90° → 0° (`Direction`)
                            let k = if sign > 0.0 { n - 1 - i } else { i };
                            std::f64::consts::FRAC_PI_2 * k as f64 / (n - 1) as f64
                        } else {
                            sign * 2.0 * std::f64::consts::PI * i as f64 / n as f64
                        };
                        let (dl, axes) = truth.machine.seed002.pose(&setup, step, angle);
                        MachineStep::at(dl, axes)
                    })
                    .collect()
            }
        };
        Ok(Self { steps, next: 0 })
    }

    /// The program the served CNC runs for a run armed or started: a self-triggered circle's
    /// whole part program ([`Self::plan_feed_in`]), else the pattern's motion ([`Self::plan`]).
    /// Both virtual CNCs (the simulated pod's, the emulated board's) choose through this.
    pub fn plan_run(
        truth: &ServeTruth,
        cfg: &Config,
        pattern: Pattern,
        direction: ballpod::app::Direction,
        self_triggered: bool,
        probe_runs: u32,
    ) -> Result<Self, String> {
        if self_triggered {
            Self::plan_feed_in(truth, cfg, direction)
        } else {
            Self::plan(truth, cfg, pattern, direction, probe_runs)
        }
    }

    /// The served CNC's part program of a self-triggered circle run (`run_trigger = FEED_IN`),
    /// started when the pod is armed for it: at rest on the feed-in point (the machine file's
    /// `feed_in_mm` outside the circle at 0°), the radial feed-in, the data arc (`circle_arc`,
    /// else a full turn), 45° of overshoot, the radial feed-out, at rest. The pod starts and
    /// ends the run itself; with `feed_in_mm = 0` the program starts on the circle and the run
    /// never starts.
    pub fn plan_feed_in(
        truth: &ServeTruth,
        cfg: &Config,
        direction: ballpod::app::Direction,
    ) -> Result<Self, String> {
        let c = CircleProgram::new(truth, cfg)?;
        let rate = f64::from(cfg.sample_rate_hz);
        let sign = direction.sign();
        let arc = f64::from(cfg.setup.circle_arc_deg);
        let span = if arc.is_finite() { arc } else { 360.0 } + 45.0;
        let step_mm = c.machine.feed_mm_per_min / 60.0 / rate;
        let feed_in = c.machine.feed_in_mm.max(0.0);
        let radial = ((feed_in / step_mm).round() as usize).max(1);
        let end = sign * span.to_radians();
        let mut steps = Vec::new();
        let rest = |steps: &mut Vec<MachineStep>, th: f64| {
            for _ in 0..50 {
                steps.push(c.step(th, sign, feed_in));
            }
        };
        rest(&mut steps, 0.0);
        if feed_in > 0.0 {
            for k in 1..radial {
                steps.push(c.step(0.0, sign, feed_in * (1.0 - k as f64 / radial as f64)));
            }
        }
        let n = (c.machine.samples_per_rev(rate) as f64 * span / 360.0).round() as usize;
        for i in 0..=n {
            steps.push(c.step(end * i as f64 / n as f64, sign, 0.0));
        }
        if feed_in > 0.0 {
            for k in 1..=radial {
                steps.push(c.step(end, sign, feed_in * k as f64 / radial as f64));
            }
        }
        rest(&mut steps, end);
        Ok(Self { steps, next: 0 })
    }

    /// Where the motion starts (the encoders are homed there), if it moves at all.
    pub fn start(&self) -> Option<[f64; MAX_AXES]> {
        self.steps.first().map(|s| s.axes)
    }

    /// The first sample period's axis positions (mm / degrees) and true bar-length deviation
    /// (µm).
    pub fn start_step(&self) -> Option<([f64; MAX_AXES], f64)> {
        self.steps.first().map(|s| (s.axes, s.dl_um))
    }

    /// The next sample period, `None` once the motion is over.
    pub fn next_step(&mut self) -> Option<MachineStep> {
        let s = self.steps.get(self.next).copied();
        self.next += 1;
        s
    }

    /// Sample periods left.
    pub fn remaining(&self) -> usize {
        self.steps.len().saturating_sub(self.next)
    }
}

/// The served machine with the bar of the pod's `pattern` mounted and the axes commanded to
/// `axes` (X, Y, Z mm; B, C degrees): a CIRCLE on the circle machine
/// ([`circle_machine_at`]), a seed 002 step on the seed 002 machine with the configured
/// Table 4.3 set-up (the bar of that step between the W and T balls); the true bar-length
/// deviation and the positions the encoders read, for a part program's path.
pub fn machine_at(
    truth: &ServeTruth,
    cfg: &Config,
    pattern: Pattern,
    axes: &[f64; MAX_AXES],
    sense: f64,
) -> Result<MachineStep, String> {
    if pattern.seed002_step().is_some() {
        let setup = Setup::from_config(&cfg.setup)
            .map_err(|f| format!("seed 002 set-up: {f:?} not set"))?;
        let dl = truth.machine.seed002.delta_l_um(&setup, pattern, axes);
        return Ok(MachineStep::at(dl, *axes));
    }
    circle_machine_at(truth, cfg, axes, sense)
}

/// The served circle machine with the bar mounted, the axes commanded to `axes` (X, Y, Z mm)
/// moving in `sense` (+1 CCW, −1 CW about the plane's normal): the true bar-length deviation
/// and the positions the encoders read, for a part program's path (`sim --serve --program`).
/// The circle is the pod's set-up's (centre, radius, plane, feed): the program is written from
/// it; a position off the circle extends the bar by as much (feed-in, feed-out).
pub fn circle_machine_at(
    truth: &ServeTruth,
    cfg: &Config,
    axes: &[f64; MAX_AXES],
    sense: f64,
) -> Result<MachineStep, String> {
    let c = CircleProgram::new(truth, cfg)?;
    let (u, v, _) = crate::ncgen::plane_axes(c.plane);
    let (du, dv) = (axes[u] - c.centre_mm[u], axes[v] - c.centre_mm[v]);
    let theta = dv.atan2(du);
    let out_mm = du.hypot(dv) - c.machine.radius_mm;
    let sign = if sense < 0.0 { -1.0 } else { 1.0 };
    let mut step = c.step(theta, sign, out_mm);
    // the axes outside the plane and the rotary ones stay where the program has them
    for (k, a) in axes.iter().enumerate() {
        if k != u && k != v {
            step.axes[k] = *a;
        }
    }
    Ok(step)
}

/// The circle the served CNC runs: the pod's set-up (centre, radius, plane, feed) on the
/// circular-test machine's faults (XY) or its vertical planes' ([`super::machine::ThreePlaneMachine`]).
struct CircleProgram {
    machine: super::machine::CircleMachine,
    centre_mm: [f64; 3],
    plane: CirclePlane,
    /// (radius − bar length), µm: the bar's reading on the nominal circle.
    radius_less_bar_um: f64,
}

impl CircleProgram {
    fn new(truth: &ServeTruth, cfg: &Config) -> Result<Self, String> {
        let t = &cfg.setup;
        let c = |k: usize| f64::from(t.circle_centre_mm[k]);
        let r = f64::from(t.circle_radius_mm);
        if r.is_nan()
            || r <= 0.0
            || (0..3).any(|k| c(k).is_nan() && !in_plane_unused(t.circle_plane, k))
        {
            return Err("circle set-up not complete".into());
        }
        // XY: the circular-test machine; YZ, ZX: its vertical planes (the three-plane test)
        let mut machine = match t.circle_plane {
            CirclePlane::XY => truth.machine.circle,
            p => truth.machine.planes.plane(&truth.machine.circle, p),
        };
        machine.radius_mm = r;
        if t.circle_feed_mm_per_min > 0.0 {
            machine.feed_mm_per_min = f64::from(t.circle_feed_mm_per_min);
        }
        Ok(Self {
            machine,
            centre_mm: [0, 1, 2].map(|k| if c(k).is_nan() { 0.0 } else { c(k) }),
            plane: t.circle_plane,
            radius_less_bar_um: (r - f64::from(cfg.bar_length_mm)) * 1e3,
        })
    }

    /// The machine at commanded angle `theta` (rad) moving in `sign`, `out_mm` radially
    /// outside the circle (the bar extends by as much).
    fn step(&self, theta: f64, sign: f64, out_mm: f64) -> MachineStep {
        let (dl, a) = self.machine.pose(theta, sign);
        let scale = 1.0 + out_mm / self.machine.radius_mm;
        let (u, v) = (a[0] * scale, a[1] * scale);
        let c = self.centre_mm;
        let xyz = match self.plane {
            CirclePlane::XY => [c[0] + u, c[1] + v, c[2]],
            CirclePlane::YZ => [c[0], c[1] + u, c[2] + v],
            CirclePlane::ZX => [c[0] + v, c[1], c[2] + u],
        };
        MachineStep::at(
            dl + self.radius_less_bar_um + out_mm * 1e3,
            [xyz[0], xyz[1], xyz[2], 0.0, 0.0],
        )
    }
}

/// True if axis `k` (0 X, 1 Y, 2 Z) is the plane's normal (its coordinate may be not set: the
/// machine keeps it at 0).
fn in_plane_unused(p: CirclePlane, k: usize) -> bool {
    matches!(
        (p, k),
        (CirclePlane::XY, 2) | (CirclePlane::YZ, 0) | (CirclePlane::ZX, 1)
    )
}

/// Station directions from the socket (normalised in use): three azimuths 120° apart, 16.7°
/// above the horizontal, as seed 000 §3 places the stations around the socket.
pub const STATION_DIRS: [[f64; 3]; 3] = [[1.0, 0.0, 0.3], [-0.5, 0.866, 0.3], [-0.5, -0.866, 0.3]];

/// Acceleration of the served machine's SSM moves, mm/s² (a machining centre's axes take
/// 1–10 m/s²; the slow end leaves the most samples bunched in front of a dwell).
pub const SSM_ACCEL_MM_PER_S2: f64 = 1000.0;

/// Three dwells on the bar's sphere around the configured socket, the tool point E = `e_um`
/// off its nominal (µm). Between the stations, and to leave the last dwell (5 mm on towards
/// the first station), the machine moves on the sphere (arcs about the socket at 2000
/// mm/min, accelerating from and decelerating into each dwell at `accel_mm_per_s2`;
/// `f64::INFINITY`: at speed from the first sample to the last), so the bar stays within the
/// LVDT's range as on a real SSM.
pub fn ssm_path(
    e_um: [f64; 3],
    cfg: &Config,
    accel_mm_per_s2: f64,
) -> Result<Vec<MachineStep>, String> {
    let s = cfg.setup.ssm_socket_mm;
    if s.iter().any(|v| v.is_nan()) {
        return Err("SSM socket not set".into());
    }
    let socket = s.map(f64::from);
    let l = f64::from(cfg.bar_length_mm);
    let rate = f64::from(cfg.sample_rate_hz);
    let unit = |u: [f64; 3]| {
        let n = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
        u.map(|v| v / n)
    };
    let on_sphere = |u: [f64; 3]| [0, 1, 2].map(|i| socket[i] + l * u[i]);
    let dl = |p: [f64; 3]| {
        let q = [0, 1, 2].map(|i| p[i] + e_um[i] * 1e-3 - socket[i]);
        ((q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt() - l) * 1e3
    };
    let step = |p: [f64; 3]| MachineStep::at(dl(p), [p[0], p[1], p[2], 0.0, 0.0]);
    let dwell = (0.4 * rate) as usize;
    let dirs: Vec<[f64; 3]> = STATION_DIRS.iter().map(|u| unit(*u)).collect();
    // the arc from direction a to b (normalised chord points: no antipodal stations here)
    let arc = |a: [f64; 3], b: [f64; 3], to_mm: f64, out: &mut Vec<MachineStep>| {
        let cos = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0);
        let theta = cos.acos();
        let len_mm = to_mm.min(l * theta);
        for s_mm in move_profile(len_mm, 2000.0 / 60.0, accel_mm_per_s2, rate) {
            // the direction at arc fraction t (spherical interpolation)
            let t = s_mm / (l * theta);
            let (wa, wb) = (((1.0 - t) * theta).sin(), (t * theta).sin());
            let u = unit([0, 1, 2].map(|i| wa * a[i] + wb * b[i]));
            out.push(step(on_sphere(u)));
        }
    };
    let mut out = Vec::new();
    for (k, u) in dirs.iter().enumerate() {
        if k > 0 {
            arc(dirs[k - 1], *u, f64::INFINITY, &mut out);
        }
        for _ in 0..dwell {
            out.push(step(on_sphere(*u)));
        }
    }
    if let (Some(last), Some(first)) = (dirs.last(), dirs.first()) {
        arc(*last, *first, 5.0, &mut out);
    }
    Ok(out)
}

/// Where along a move of `len_mm` from rest to rest its samples (`rate_hz`) fall, mm, the last
/// at its end: a trapezoidal speed profile, up to `speed_mm_per_s` at `accel_mm_per_s2`
/// (`f64::INFINITY`: at speed throughout, the samples evenly spaced).
fn move_profile(len_mm: f64, speed_mm_per_s: f64, accel_mm_per_s2: f64, rate_hz: f64) -> Vec<f64> {
    let a = accel_mm_per_s2;
    // a move too short to reach the speed peaks at √(len·a)
    let v = speed_mm_per_s.min((len_mm * a).sqrt());
    let t_acc = v / a;
    let d_acc = 0.5 * v * t_acc;
    let total = 2.0 * t_acc + (len_mm - 2.0 * d_acc) / v;
    let n = (total * rate_hz).ceil().max(1.0) as usize;
    (1..=n)
        .map(|j| {
            let t = total * j as f64 / n as f64;
            let s = if j == n {
                len_mm
            } else if t < t_acc {
                0.5 * a * t * t
            } else if t <= total - t_acc {
                d_acc + v * (t - t_acc)
            } else {
                len_mm - 0.5 * a * (total - t) * (total - t)
            };
            s.clamp(0.0, len_mm)
        })
        .collect()
}

/// PROBE runs in the seed 002 chapter 5 sequence (then it starts over).
pub const PROBE_SEQUENCE: u32 = 8;

/// Where PROBE run `run` of the seed 002 chapter 5 sequence finds the sphere on the seed 002
/// machine with deviations `d` (µm, µrad; the literal HTM model): the sphere centre in the
/// axis positions the encoders read when the stylus ball's nominal centre (`axes −
/// R·(sin B, 0, cos B)`, R = `length_mm`, 0 if not set) is on it, mm, and the rotary axes
/// (B, C), degrees. `origin_mm` is the seed 002 origin O_M, `rc_zc_mm` the C-axis sphere's
/// radius R_C and height Z_C.
///
/// - runs 0–3: the sphere at R_C on the C table at C = run·90°, B = 0, carried by the C axis
///   (its location and orientation errors; the spindle side is taken as known, as the C-axis
///   method does);
/// - runs 4–7: the sphere on the C centreline at height Z_C, B = 0° (4, 6) or 90° (5, 7); the
///   stylus ball displaced by the B-axis and spindle deviations (δx_BT, δz_BT, α_BT, α_XB,
///   β_XB, γ_XB; the sphere itself at its nominal place, the "standard position" the B-axis
///   method assumes).
pub fn probe_target(
    d: &[f64; 13],
    origin_mm: [f64; 3],
    rc_zc_mm: [f64; 2],
    length_mm: f64,
    run: u32,
) -> ([f64; 3], [f64; 2]) {
    let r = if length_mm.is_nan() { 0.0 } else { length_mm };
    let [rc, zc] = rc_zc_mm;
    let k = run % PROBE_SEQUENCE;
    if k < 4 {
        let c_deg = 90.0 * f64::from(k);
        let (_, _, _, _, mcz, _) = fwd::mats(d);
        let p = fwd::apply(&fwd::mul(&mcz, &fwd::ec(c_deg.to_radians())), [rc, 0.0, zc]);
        let centre = std::array::from_fn(|i| origin_mm[i] + p[i] + if i == 2 { r } else { 0.0 });
        return (centre, [0.0, c_deg]);
    }
    let b_deg = if k.is_multiple_of(2) { 0.0 } else { 90.0 };
    let b = f64::to_radians(b_deg);
    let sphere = [origin_mm[0], origin_mm[1], origin_mm[2] + zc];
    // the spindle and B deviations only (the B-axis method's model)
    let mut spindle = [0.0; 13];
    spindle[..6].copy_from_slice(&d[..6]);
    let cmd = [sphere[0] + r * b.sin(), sphere[1], sphere[2] + r * b.cos()];
    let actual = fwd::t_ball(&spindle, cmd[0], cmd[1], cmd[2], b, r, [0.0; 3]);
    let nominal = fwd::t_ball(&[0.0; 13], cmd[0], cmd[1], cmd[2], b, r, [0.0; 3]);
    // the actual ball touches the sphere where the nominal one is displaced by −(actual − nominal)
    (
        std::array::from_fn(|i| cmd[i] - (actual[i] - nominal[i])),
        [b_deg, 0.0],
    )
}

/// Nine touches on the sphere of PROBE run `probe_runs` of the sequence ([`probe_target`]).
fn probe_path(
    truth: &ServeTruth,
    cfg: &Config,
    probe_runs: u32,
) -> Result<Vec<MachineStep>, String> {
    let t = &cfg.setup;
    let origin = t
        .s002_origin_mm
        .map(|v| if v.is_nan() { 0.0 } else { f64::from(v) });
    let d = truth.machine.seed002.deviations().to_array();
    let (centre, [b_deg, c_deg]) = probe_target(
        &d,
        origin,
        truth.sphere_rc_zc_mm,
        f64::from(t.probe_length_mm),
        probe_runs,
    );
    let rate = f64::from(cfg.sample_rate_hz);
    let contact = SPHERE_RADIUS_MM + STYLUS_RADIUS_MM;
    let axes = |p: [f64; 3]| [p[0], p[1], p[2], b_deg, c_deg];
    let on = |n: [f64; 3], r: f64| -> [f64; 3] { std::array::from_fn(|i| centre[i] + n[i] * r) };
    let dirs = probing_directions();
    let mut out: Vec<MachineStep> = Vec::new();
    let mut at = on(dirs[0], contact + 0.5);
    let go =
        |out: &mut Vec<MachineStep>, at: &mut [f64; 3], to: [f64; 3], feed: f64, seated: bool| {
            let d: [f64; 3] = std::array::from_fn(|i| to[i] - at[i]);
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let n = (len / (feed / 60.0 / rate)).ceil().max(1.0) as usize;
            for j in 1..=n {
                let p: [f64; 3] = std::array::from_fn(|i| at[i] + d[i] * j as f64 / n as f64);
                out.push(MachineStep {
                    seated,
                    ..MachineStep::at(0.0, axes(p))
                });
            }
            *at = to;
        };
    for n in dirs {
        go(&mut out, &mut at, on(n, contact + 0.5), 1000.0, true);
        go(&mut out, &mut at, on(n, contact + 0.3), 1000.0, true);
        go(&mut out, &mut at, on(n, contact), 100.0, true);
        if let Some(last) = out.last_mut() {
            last.edge = Some(axes(on(n, contact)));
        }
        go(&mut out, &mut at, on(n, contact + 0.05), 1000.0, false);
        go(&mut out, &mut at, on(n, contact + 0.5), 1000.0, true);
        // the re-seat time before the next touch
        for _ in 0..(0.06 * rate) as usize {
            out.push(MachineStep::at(0.0, axes(at)));
        }
    }
    Ok(out)
}

/// The nine probing directions (unit normals, upper hemisphere: the stem blocks the lower
/// one): the pole, four at 45° latitude, four on the equator between them. The served
/// pod's PROBE motion and the probe rig ([`super::probe_rig`]) touch along them.
pub fn probing_directions() -> [[f64; 3]; 9] {
    let s = std::f64::consts::FRAC_1_SQRT_2;
    [
        [0.0, 0.0, 1.0],
        [s, 0.0, s],
        [0.0, s, s],
        [-s, 0.0, s],
        [0.0, -s, s],
        [s, s, 0.0],
        [-s, s, 0.0],
        [-s, -s, 0.0],
        [s, -s, 0.0],
    ]
}
