//! Declarative scenarios (RMK style): a TOML file names a method, a machine (its deviations or
//! faults), the noise and the expected outcome; [`run`] simulates the measurement, feeds it to
//! the pod's code and returns every check with its numbers.
//!
//! Methods and what is simulated:
//! - `seed002_ballbar`: the full sensor-level seed 002 procedure ([`crate::simulate`]);
//!   expectation: every model-mode deviation within `max_error_over_u`·u and within
//!   `max_abs_error_um` / `max_abs_error_arcsec` of the truth;
//! - `iso230_4`: the sensor-level circular test; each injected fault diagnosed within
//!   `max_relative_error`;
//! - `seed002_probe` / `seed002_probe_b_axis`: the chapter 5 spheres at C = 0/90/180/270° /
//!   at B = 0/90° with two tool lengths, placed by the literal HTM model
//!   ([`crate::vmt::motion::probe_target`]), each touched nine times at sensor level
//!   ([`crate::vmt::probe_rig`]: pre-travel, repeatability σ = `noise_um`, bounce edges, the
//!   pod's probe latch and debouncer, the core's sphere fit) → `identify::mill_turn::probe`;
//! - `seed003_rtest`: the R-test head on path K4 of the A/C table-tilting machine
//!   ([`crate::vmt::rtest_rig`]: the exact chain of [`crate::forward_seed003`], three noisy
//!   sensors through LVDT channels, `methods::rtest_head`) → the readings file
//!   → `methods::rtest`;
//! - `seed004_dial_gauge`: dial-gauge readings on a face turned by a tilted axis
//!   ([`crate::forward_seed004`]) plus noise, read by a contact LVDT on one of the pod's
//!   channels ([`crate::vmt::lvdt_channel::LvdtProbe`]) → the readings file →
//!   `methods::centreline`;
//! - `seed000_two_step`: the SSM after the translation and after the rotation of an RRTTT
//!   head, a TTTRR table, or an RTTTR spindle head or table ([`crate::forward_seed000`]), at
//!   sensor level ([`crate::vmt::ssm_rig`]: three dwells on the bar's sphere through the pod
//!   and the core's station collector) → `identify::two_step` (exact mode: the paper's
//!   truncated formulas are checked against their own tables in `identify_two_step.rs`).
//!
//! Every scenario also goes through replay, as a user would repeat it from files: the pod's
//! recorded stream of the probe and SSM runs is replayed through a fresh application and must
//! give the live pod's results table exactly ([`replay_reproduces`]; the simulator's own runs
//! are checked the same way in `replay_roundtrip.rs`), and the R-test and dial-gauge readings
//! are written as the session file's readings tables and identified by `cargo replay`'s reader
//! ([`crate::session_file::read_inputs`]).

use std::path::{Path, PathBuf};

use serde::Deserialize;

use ballpod::app::ResultId;

use crate::recording::parse_runs;
use crate::replay::{Figure, figures, replay};
use crate::session_file::read_inputs;
use crate::simulate::{SimOptions, simulate};
use crate::vmt::machine::MachineFile;
use crate::vmt::virtual_pod::VirtualPod;

/// A scenario file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// What the scenario shows.
    pub description: String,
    /// Method (see the module doc).
    pub method: String,
    /// Noise seed.
    #[serde(default = "one")]
    pub seed: u64,
    /// Sensor noise σ (µm: bar, probe centre, R-test or dial reading).
    pub noise_um: f64,
    /// Machine (seed 002 deviations, circle faults, instrument), for the sensor-level methods.
    #[serde(default)]
    pub machine: MachineFile,
    /// Seed 002 feed, mm/min (default 1000).
    #[serde(default)]
    pub feed_mm_per_min: Option<f64>,
    /// Seed 002 procedure repeats (default 1).
    #[serde(default)]
    pub repeats: Option<usize>,
    /// R-test: the 11 location/ball errors XOW YOW ZOW YOA ZOA BOA COA XOC YOC AOC BOC
    /// (µm / arc-seconds).
    #[serde(default)]
    pub rtest_errors: Option<[f64; 11]>,
    /// Dial gauge: tilt of the B (tilting) axis direction about X and Z, µrad.
    #[serde(default)]
    pub axis_tilt_urad: Option<[f64; 2]>,
    /// `seed004_dial_gauge`: how a commanded angle turns the table, `"primed"` (default) or
    /// `"right_handed"` (the session file's `[dial] sense`).
    #[serde(default)]
    pub dial_sense: Option<String>,
    /// Two-step RRTTT: (Δα, Δβ) µrad, the second step's (α, β) degrees, tool z_r mm and the
    /// translation error ΔV1 µm.
    #[serde(default)]
    pub rrttt: Option<Rrttt>,
    /// Two-step TTTRR table: see [`Tttrr`].
    #[serde(default)]
    pub tttrr: Option<Tttrr>,
    /// Two-step RTTTR spindle head (β): see [`RtttrSpindle`].
    #[serde(default)]
    pub rtttr_spindle: Option<RtttrSpindle>,
    /// Two-step RTTTR table (α): see [`RtttrTable`].
    #[serde(default)]
    pub rtttr_table: Option<RtttrTable>,
    /// Touch probe: the lobing's standard uncertainty the pod is told (configuration field
    /// `probe_u_lobing`, µm; default: the pod's default).
    #[serde(default)]
    pub probe_u_lobing_um: Option<f64>,
    /// Expected outcome.
    pub expect: Expect,
}

fn one() -> u64 {
    1
}

/// RRTTT two-step set-up.
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rrttt {
    /// Δα, µrad.
    pub delta_alpha_urad: f64,
    /// Δβ, µrad.
    pub delta_beta_urad: f64,
    /// α of the second step, degrees.
    pub alpha_deg: f64,
    /// β of the second step, degrees.
    pub beta_deg: f64,
    /// Tool vector z_r, mm.
    pub tool_z_mm: f64,
    /// Translation error ΔV1, µm.
    pub dv1_um: [f64; 3],
}

/// TTTRR two-step set-up (seed 000 §2.1.2, eq 8).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tttrr {
    /// Δα, µrad.
    pub delta_alpha_urad: f64,
    /// Δγ, µrad.
    pub delta_gamma_urad: f64,
    /// α of the second step, degrees.
    pub alpha_deg: f64,
    /// γ of the second step, degrees.
    pub gamma_deg: f64,
    /// z_αγ, mm.
    pub z_alpha_gamma_mm: f64,
    /// Reference point in the γ-centre frame, mm.
    pub reference_point_mm: [f64; 3],
    /// Translation error ΔV1, µm.
    pub dv1_um: [f64; 3],
}

/// RTTTR spindle-head two-step set-up (seed 000 §2.1.3, eqs 13/15).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RtttrSpindle {
    /// Δβ, µrad.
    pub delta_beta_urad: f64,
    /// β of the second step, degrees.
    pub beta_deg: f64,
    /// Tool vector z_r, mm.
    pub tool_z_mm: f64,
    /// Translation error ΔV1, µm.
    pub dv1_um: [f64; 3],
}

/// RTTTR table two-step set-up (seed 000 §2.1.3, eqs 14/16).
#[derive(Clone, Copy, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RtttrTable {
    /// Δα, µrad.
    pub delta_alpha_urad: f64,
    /// α of the second step, degrees.
    pub alpha_deg: f64,
    /// Reference point r_t in the table frame, mm.
    pub reference_point_mm: [f64; 3],
    /// Translation error ΔtV1, µm.
    pub dv1_um: [f64; 3],
}

/// Expected outcome (every given bound is checked).
#[derive(Clone, Copy, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Expect {
    /// |identified − truth| ≤ this × the reported standard uncertainty.
    pub max_error_over_u: Option<f64>,
    /// |identified − truth| ≤ this for values in µm.
    pub max_abs_error_um: Option<f64>,
    /// |identified − truth| ≤ this for values in arc-seconds.
    pub max_abs_error_arcsec: Option<f64>,
    /// |identified − truth| ≤ this for values in µrad.
    pub max_abs_error_urad: Option<f64>,
    /// |diagnosed / injected − 1| ≤ this (ISO 230-4 faults).
    pub max_relative_error: Option<f64>,
}

/// One checked value.
#[derive(Clone, Debug)]
pub struct Check {
    /// What.
    pub name: String,
    /// Truth (µm, arc-seconds, µrad, or the injected fault size).
    pub truth: f64,
    /// Identified or diagnosed.
    pub got: f64,
    /// Reported standard uncertainty (0 if none).
    pub u: f64,
    /// Unit: `um`, `arcsec`, `urad` or `relative`.
    pub unit: &'static str,
    /// The pod's share of `u` from each contributor (`ballpod::app::CONTRIBUTORS` order), for a
    /// figure the pod's results table holds with its budget.
    pub shares: Option<[f32; ballpod::app::CONTRIBUTOR_COUNT]>,
}

impl Check {
    /// Why this check fails the expectation, or `None` when it passes.
    pub fn failure(&self, e: &Expect) -> Option<String> {
        let d = (self.got - self.truth).abs();
        let mut why = Vec::new();
        if let Some(k) = e.max_error_over_u
            && self.u > 0.0
            && d > k * self.u
        {
            why.push(format!("|d| = {d:.4} > {k}·u = {:.4}", k * self.u));
        }
        let abs = match self.unit {
            "um" => e.max_abs_error_um,
            "arcsec" => e.max_abs_error_arcsec,
            "urad" => e.max_abs_error_urad,
            _ => None,
        };
        if let Some(m) = abs
            && d > m
        {
            why.push(format!("|d| = {d:.4} > {m} {}", self.unit));
        }
        if self.unit == "relative"
            && let Some(m) = e.max_relative_error
            && (self.got / self.truth - 1.0).abs() > m
        {
            why.push(format!(
                "ratio {:.4} outside 1 ± {m}",
                self.got / self.truth
            ));
        }
        (!why.is_empty()).then(|| {
            format!(
                "{}: truth {} got {} (u {}): {}",
                self.name,
                self.truth,
                self.got,
                self.u,
                why.join("; ")
            )
        })
    }
}

/// Reads a scenario file.
pub fn read(path: &std::path::Path) -> Result<Scenario, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    toml::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
}

/// Runs a scenario: the checks it produced (the caller compares them with `expect`).
pub fn run(s: &Scenario) -> Result<Vec<Check>, String> {
    match s.method.as_str() {
        "seed002_ballbar" => seed002_ballbar(s),
        "iso230_4" => iso230_4(s),
        "seed002_probe" => seed002_probe(s, 0..4),
        "seed002_probe_b_axis" => seed002_probe(s, 4..8),
        "seed003_rtest" => seed003_rtest(s),
        "seed004_dial_gauge" => seed004_dial_gauge(s),
        "seed000_two_step" => seed000_two_step(s),
        m => Err(format!("unknown method {m:?}")),
    }
}

fn seed002_ballbar(s: &Scenario) -> Result<Vec<Check>, String> {
    use ballpod::identify::mill_turn::{Parameter, urad_to_arcsec};
    let mut m = s.machine;
    m.instrument.bar_noise_um = s.noise_um;
    let o = SimOptions {
        seed: s.seed,
        repeats: s.repeats.unwrap_or(1),
        feed_mm_per_min: s.feed_mm_per_min.unwrap_or(1000.0),
        seed002: true,
        circle: false,
        three_planes: false,
        feed_sweep: Vec::new(),
        nc_dir: None,
    };
    let sim = simulate(&m, &o, &mut |_, _, _| {})?;
    let truth = m.seed002.deviations();
    let mut out = Vec::new();
    // the model-mode deviations as the pod's results table reports them
    for p in Parameter::ALL {
        let Some(v) = sim.report.result(p.name()) else {
            continue;
        };
        let (t, unit) = if p.is_positional() {
            (truth.get(p), "um")
        } else {
            (urad_to_arcsec(truth.get(p)), "arcsec")
        };
        out.push(Check {
            name: v.name.clone(),
            truth: t,
            got: f64::from(v.value),
            u: v.u.map_or(0.0, f64::from),
            unit,
            shares: None,
        });
    }
    if out.len() != 10 {
        return Err(format!("{} of 10 deviations identified", out.len()));
    }
    Ok(out)
}

fn iso230_4(s: &Scenario) -> Result<Vec<Check>, String> {
    let mut m = s.machine;
    m.instrument.bar_noise_um = s.noise_um;
    let o = SimOptions {
        seed: s.seed,
        repeats: 1,
        feed_mm_per_min: 1000.0,
        seed002: false,
        circle: true,
        three_planes: false,
        feed_sweep: Vec::new(),
        nc_dir: None,
    };
    let sim = simulate(&m, &o, &mut |_, _, _| {})?;
    let r = &sim.report;
    let c = &m.circle;
    let mut out = Vec::new();
    // only injected faults are checked (a ratio to 0 means nothing)
    for (name, truth, result) in [
        ("squareness_urad", c.squareness_urad, "squareness"),
        (
            "scale_mismatch_um_per_m",
            c.scale_x_um_per_m - c.scale_y_um_per_m,
            "scale_mismatch",
        ),
        ("reversal_x_um", c.backlash_x_um, "reversal_u"),
        ("reversal_y_um", c.backlash_y_um, "reversal_v"),
        (
            "cyclic_amplitude_um",
            c.cyclic_amplitude_um,
            "cyclic_amplitude",
        ),
        ("servo_mismatch_ms", c.servo_mismatch_ms(), "servo_mismatch"),
    ] {
        if truth != 0.0 {
            let got = r
                .result(result)
                .ok_or(format!("the pod reports no {result}"))?;
            out.push(Check {
                name: name.to_string(),
                truth,
                got: f64::from(got.value),
                u: 0.0,
                unit: "relative",
                shares: None,
            });
        }
    }
    Ok(out)
}

/// The chapter 5 probe runs `runs` of the sequence ([`crate::vmt::motion::probe_target`]) on
/// one simulated pod: C = 0/90/180/270° (runs 0–3) → the C axis; B = 0/90° with R_B and R′_B
/// (runs 4–7) → the B axis.
fn seed002_probe(s: &Scenario, runs: std::ops::Range<u32>) -> Result<Vec<Check>, String> {
    use crate::vmt::motion::probe_target;
    use ballpod::identify::mill_turn::urad_to_arcsec;
    let d = s.machine.seed002.deviations();
    let da = d.to_array();
    let (rc, zc) = (100.0, 64.838);
    let origin = [-490.0, 0.0, -536.838];
    // the thesis's styli (Table 5.2 conditions): R_B, then R′_B for the second B pair
    let (r_b, r_b2) = (382.95, 433.062);
    // sensor level: nine touches per sphere through the pod's probe latch (pre-travel,
    // repeatability σ = noise_um, bounce edges from the instrument); the pod fits each sphere,
    // identifies the C axis once the four C positions are in and the B axis once B = 0/90°
    // are in with both styli
    let inst = crate::vmt::sensors::Instrument {
        probe_repeatability_um: s.noise_um,
        ..s.machine.instrument
    };
    let mut rig = crate::vmt::probe_rig::ProbeRig::new(&inst, s.seed);
    let mut radius_dev_um = Vec::new();
    for run in runs.clone() {
        // the C-axis runs with no tool length (touch points = axis positions), the B pairs
        // with R_B then R′_B
        let length = match run {
            0..4 => f64::NAN,
            4 | 5 => r_b,
            _ => r_b2,
        };
        rig.pod
            .app
            .configure(|c| {
                c.setup.s002_origin_mm = origin.map(|v| v as f32);
                c.setup.s002_z_c_mm = zc as f32;
                c.setup.probe_length_mm = length as f32;
                if let Some(u) = s.probe_u_lobing_um {
                    c.setup.probe_u_lobing_um = u as f32;
                }
            })
            .map_err(|e| format!("set-up: {:?}", e.text()))?;
        let (centre, rotary) = probe_target(&da, origin, [rc, zc], length, run);
        let m = rig.measure_sphere(centre, rotary)?;
        if m.accepted != 9 || m.bounces != 9 * inst.probe_bounces {
            return Err(format!(
                "probe: {} touches accepted (9 made), {} bounces rejected ({} made)",
                m.accepted,
                m.bounces,
                9 * inst.probe_bounces
            ));
        }
        radius_dev_um.push(
            (m.radius_mm
                - crate::vmt::probe_rig::SPHERE_RADIUS_MM
                - crate::vmt::probe_rig::STYLUS_RADIUS_MM)
                * 1e3,
        );
    }
    replay_reproduces(&rig.pod)?;
    let app = &rig.pod.app;
    let c = |name: &str, truth: f64, id: ResultId, unit| -> Result<Check, String> {
        let e = app.result(id);
        if !e.valid {
            return Err(format!("the pod reports no {}", id.info().name));
        }
        let u = f64::from(e.std_uncertainty);
        Ok(Check {
            name: name.to_string(),
            truth,
            got: f64::from(e.value),
            u: if u.is_nan() { 0.0 } else { u },
            unit,
            shares: Some(e.shares),
        })
    };
    let asec = urad_to_arcsec;
    let mut out = Vec::new();
    if runs.contains(&3) {
        out.extend([
            c(
                "alpha_CZ",
                asec(d.alpha_cz_urad),
                ResultId::ProbeAlphaCz,
                "arcsec",
            )?,
            c(
                "beta_CZ",
                asec(d.beta_cz_urad),
                ResultId::ProbeBetaCz,
                "arcsec",
            )?,
            c("dx_CZ", d.dx_cz_um, ResultId::ProbeDxCz, "um")?,
            c("dy_CZ", d.dy_cz_um, ResultId::ProbeDyCz, "um")?,
        ]);
    }
    if runs.contains(&7) {
        out.extend([
            c("dx_BT", d.dx_bt_um, ResultId::ProbeDxBt, "um")?,
            c("dz_BT", d.dz_bt_um, ResultId::ProbeDzBt, "um")?,
            c(
                "beta_XB",
                asec(d.beta_xb_urad),
                ResultId::ProbeBetaXb,
                "arcsec",
            )?,
            c(
                "alpha_BT_plus_alpha_XB",
                asec(d.alpha_bt_urad + d.alpha_xb_urad),
                ResultId::ProbeAlphaBtPlusAlphaXb,
                "arcsec",
            )?,
            c(
                "alpha_BT_minus_gamma_XB",
                asec(d.alpha_bt_urad - d.gamma_xb_urad),
                ResultId::ProbeAlphaBtMinusGammaXb,
                "arcsec",
            )?,
        ]);
    }
    // the pre-travel shows in the fitted radius (mean of the spheres), not the centres
    out.push(Check {
        name: "sphere_radius_deviation".into(),
        truth: -inst.probe_pretravel_um,
        got: radius_dev_um.iter().sum::<f64>() / radius_dev_um.len() as f64,
        u: 0.0,
        unit: "um",
        shares: None,
    });
    Ok(out)
}

fn seed003_rtest(s: &Scenario) -> Result<Vec<Check>, String> {
    use crate::methods::rtest::RtestParam;
    use crate::vmt::rtest_rig::{RtestRig, path_k4, seed003_table3_kinematics};
    let truth = s.rtest_errors.ok_or("seed003_rtest needs rtest_errors")?;
    // sensor level: the exact chain → three LVDT channels → the core's head combination
    let mut rig = RtestRig::new(s.noise_um, s.seed);
    let samples = rig.measure(&seed003_table3_kinematics(), &truth, &path_k4(241));
    if rig.invalid_samples != 0 {
        return Err(format!(
            "R-test head: {} invalid samples",
            rig.invalid_samples
        ));
    }
    // the readings as the technician's file, identified by `cargo replay` (`{:?}` prints the
    // shortest text that reads back to the same f64)
    let mut table = String::from("a_deg,c_deg,dx_um,dy_um,dz_um\n");
    for r in &samples {
        let [x, y, z] = r.reading_um;
        table.push_str(&format!("{:?},{:?},{x:?},{y:?},{z:?}\n", r.a_deg, r.c_deg));
    }
    let figs = replay_session(
        &format!("rtest-{}", s.seed),
        "[rtest]\nreadings = \"readings.csv\"\n",
        &table,
    )?;
    RtestParam::ALL
        .iter()
        .map(|p| p.name())
        .zip(truth)
        .map(|(n, t)| {
            let f = figure(&figs, &format!("rtest_{n}"))?;
            Ok(Check {
                name: n.to_string(),
                truth: t,
                got: f64::from(f.value),
                u: f.u.map_or(0.0, f64::from),
                unit: if f.unit == "arcsec" { "arcsec" } else { "um" },
                shares: None,
            })
        })
        .collect()
}

fn seed004_dial_gauge(s: &Scenario) -> Result<Vec<Check>, String> {
    use crate::forward_seed004 as fw;
    let [tx, tz] = s
        .axis_tilt_urad
        .ok_or("seed004_dial_gauge needs axis_tilt_urad")?;
    const Y: [f64; 3] = [0.0, 1.0, 0.0];
    const Z: [f64; 3] = [0.0, 0.0, 1.0];
    // the tilting axis, nominally +Y, tilted by tx about… (x component) and tz (z component)
    let d = fw::normalize([tx * 1e-6, 1.0, tz * 1e-6]);
    let n0 = fw::normalize([0.3e-3, -0.2e-3, 1.0]); // the block's top face
    let grid = [
        (0.0, 0.0),
        (60.0, 0.0),
        (0.0, 40.0),
        (60.0, 40.0),
        (30.0, 20.0),
    ];
    // the dial gauge is a contact LVDT on one of the pod's channels (sensor level), reading
    // along the nominal axis' frame turned to each angle (the session file's defaults: axis +Y,
    // reading direction +Z at 0°)
    // A primed table axis turns the work by −b for a commanded +b (seed 004), a right-handed
    // one by +b.
    let (turn, sense_line) = match s.dial_sense.as_deref() {
        None | Some("primed") => (-1.0, ""),
        Some("right_handed") => (1.0, "sense = \"right_handed\"\n"),
        Some(x) => return Err(format!("dial_sense {x:?}: primed or right_handed")),
    };
    let mut probe = crate::vmt::lvdt_channel::LvdtProbe::new(s.noise_um, s.seed);
    let mut table = String::from("b_deg,u_mm,v_mm,reading_um\n");
    for b in [0.0f64, 30.0, 60.0, 90.0] {
        let n = fw::mul(fw::rodrigues(d, turn * b.to_radians()), n0);
        let w = fw::normalize(fw::mul(fw::rodrigues(Y, turn * b.to_radians()), Z));
        let u = fw::normalize(fw::sub(Y, fw::scale(fw::dot(Y, w), w)));
        let v = fw::cross(w, u);
        let zero = fw::dial_reading_um(n, u, v, w, 0.0, 0.0, 0.0);
        for &(pu, pv) in &grid {
            let x = probe.read_um(fw::dial_reading_um(n, u, v, w, pu, pv, zero))?;
            table.push_str(&format!("{b:?},{pu:?},{pv:?},{x:?}\n"));
        }
    }
    let figs = replay_session(
        &format!("dial-{}", s.seed),
        &format!("[dial]\nreadings = \"readings.csv\"\n{sense_line}"),
        &table,
    )?;
    let check = |name: &str, fig: &str, truth: f64| -> Result<Check, String> {
        let f = figure(&figs, fig)?;
        Ok(Check {
            name: name.into(),
            truth,
            got: f64::from(f.value),
            u: f.u.map_or(0.0, f64::from),
            unit: "urad",
            shares: None,
        })
    };
    Ok(vec![
        check("tilt_x_urad", "dial_tilt_x", d[0] * 1e6)?,
        check("tilt_z_urad", "dial_tilt_z", d[2] * 1e6)?,
    ])
}

fn seed000_two_step(s: &Scenario) -> Result<Vec<Check>, String> {
    match (s.rrttt, s.tttrr, s.rtttr_spindle, s.rtttr_table) {
        (Some(t), None, None, None) => seed000_rrttt(s, &t),
        (None, Some(t), None, None) => seed000_tttrr(s, &t),
        (None, None, Some(t), None) => seed000_rtttr_spindle(s, &t),
        (None, None, None, Some(t)) => seed000_rtttr_table(s, &t),
        _ => Err(
            "seed000_two_step needs exactly one of [rrttt], [tttrr], [rtttr_spindle], [rtttr_table]"
                .into(),
        ),
    }
}

/// A µrad check.
fn urad_check(name: &str, truth: f64, got: f64, u: f64) -> Check {
    Check {
        name: name.into(),
        truth,
        got,
        u,
        unit: "urad",
        shares: None,
    }
}

/// The two-step set-up the pod is given (its `ts_*` configuration fields).
struct TwoStepSetup {
    machine: ballpod::config::TwoStepMachine,
    tool_z_mm: f64,
    z_alpha_gamma_mm: f64,
    reference_mm: [f64; 3],
    origin_mm: [f64; 3],
    angles_deg: [f64; 2],
}

/// Both SSM runs of a two-step procedure on the simulated pod at sensor level — after the
/// translation `first` and after the rotation `second` (nominal, actual tool point, mm) — with
/// the pod's two-step set-up; returns the pod's results table after the second run.
fn two_step_on_pod(
    s: &Scenario,
    t: &TwoStepSetup,
    first: ([f64; 3], [f64; 3]),
    second: ([f64; 3], [f64; 3]),
) -> Result<ballpod::app::Results, String> {
    let mut rig = crate::vmt::ssm_rig::SsmRig::new(s.noise_um, s.seed);
    rig.pod
        .app
        .configure(|c| {
            let st = &mut c.setup;
            st.ts_machine = t.machine;
            st.ts_tool_z_mm = t.tool_z_mm as f32;
            st.ts_z_alpha_gamma_mm = t.z_alpha_gamma_mm as f32;
            st.ts_reference_mm = t.reference_mm.map(|v| v as f32);
            st.ts_origin_mm = t.origin_mm.map(|v| v as f32);
            st.ts_angles_deg = t.angles_deg.map(|v| v as f32);
        })
        .map_err(|e| format!("two-step set-up: {:?}", e.text()))?;
    rig.measure(first.0, first.1)?;
    rig.measure(second.0, second.1)?;
    if let Some(note) = rig.pod.app.procedure_note() {
        return Err(format!("two-step: {:?}", note.text()));
    }
    replay_reproduces(&rig.pod)?;
    Ok(*rig.pod.app.results())
}

/// The pod's two-step result `id` as a check against `truth` (µrad).
fn ts_check(
    r: &ballpod::app::Results,
    id: ballpod::app::ResultId,
    truth: f64,
) -> Result<Check, String> {
    let e = r.get(id);
    if !e.valid {
        return Err(format!("the pod reports no {}", id.info().name));
    }
    Ok(urad_check(
        id.info().name,
        truth,
        f64::from(e.value),
        f64::from(e.std_uncertainty),
    ))
}

/// RRTTT head: tool tip of the forward model (eqs 2/4) → two SSM runs on the pod → the pod's
/// two-step identification.
fn seed000_rrttt(s: &Scenario, t: &Rrttt) -> Result<Vec<Check>, String> {
    use crate::forward_seed000 as fwd;
    let pivot = [-50.0, -15.0, 500.0];
    let (a, b) = (t.alpha_deg.to_radians(), t.beta_deg.to_radians());
    let (d1, d2) = (t.delta_alpha_urad * 1e-6, t.delta_beta_urad * 1e-6);
    let e1 = t.dv1_um.map(|v| v * 1e-3);
    let setup = TwoStepSetup {
        machine: ballpod::config::TwoStepMachine::Rrttt,
        tool_z_mm: t.tool_z_mm,
        z_alpha_gamma_mm: f64::NAN,
        reference_mm: [f64::NAN; 3],
        origin_mm: pivot,
        angles_deg: [t.alpha_deg, t.beta_deg],
    };
    let r = two_step_on_pod(
        s,
        &setup,
        (
            fwd::rrttt_tip(pivot, [0.0; 3], 0.0, 0.0, t.tool_z_mm),
            fwd::rrttt_tip(pivot, e1, 0.0, 0.0, t.tool_z_mm),
        ),
        (
            fwd::rrttt_tip(pivot, [0.0; 3], a, b, t.tool_z_mm),
            fwd::rrttt_tip(pivot, e1, a + d1, b + d2, t.tool_z_mm),
        ),
    )?;
    Ok(vec![
        ts_check(&r, ResultId::TsDeltaAlpha, t.delta_alpha_urad)?,
        ts_check(&r, ResultId::TsDeltaBeta, t.delta_beta_urad)?,
    ])
}

/// TTTRR table: reference point of the forward model (eq 8) → the pod's two-step.
fn seed000_tttrr(s: &Scenario, t: &Tttrr) -> Result<Vec<Check>, String> {
    use crate::forward_seed000 as fwd;
    let origin = [-30.0, 15.0, 120.0];
    let (a, g) = (t.alpha_deg.to_radians(), t.gamma_deg.to_radians());
    let (da, dg) = (t.delta_alpha_urad * 1e-6, t.delta_gamma_urad * 1e-6);
    let e1 = t.dv1_um.map(|v| v * 1e-3);
    let (z, rp) = (t.z_alpha_gamma_mm, t.reference_point_mm);
    let setup = TwoStepSetup {
        machine: ballpod::config::TwoStepMachine::Tttrr,
        tool_z_mm: f64::NAN,
        z_alpha_gamma_mm: z,
        reference_mm: rp,
        origin_mm: origin,
        angles_deg: [t.alpha_deg, t.gamma_deg],
    };
    let r = two_step_on_pod(
        s,
        &setup,
        (
            fwd::tttrr_point(origin, [0.0; 3], 0.0, 0.0, z, rp),
            fwd::tttrr_point(origin, e1, 0.0, 0.0, z, rp),
        ),
        (
            fwd::tttrr_point(origin, [0.0; 3], a, g, z, rp),
            fwd::tttrr_point(origin, e1, a + da, g + dg, z, rp),
        ),
    )?;
    Ok(vec![
        ts_check(&r, ResultId::TsDeltaAlpha, t.delta_alpha_urad)?,
        ts_check(&r, ResultId::TsDeltaGamma, t.delta_gamma_urad)?,
    ])
}

/// RTTTR spindle head: tool tip of the forward model (eqs 13/15) → the pod's two-step.
fn seed000_rtttr_spindle(s: &Scenario, t: &RtttrSpindle) -> Result<Vec<Check>, String> {
    use crate::forward_seed000 as fwd;
    let pivot = [20.0, 10.0, 350.0];
    let b = t.beta_deg.to_radians();
    let db = t.delta_beta_urad * 1e-6;
    let e1 = t.dv1_um.map(|v| v * 1e-3);
    let setup = TwoStepSetup {
        machine: ballpod::config::TwoStepMachine::RtttrSpindle,
        tool_z_mm: t.tool_z_mm,
        z_alpha_gamma_mm: f64::NAN,
        reference_mm: [f64::NAN; 3],
        origin_mm: pivot,
        angles_deg: [t.beta_deg, f64::NAN],
    };
    let r = two_step_on_pod(
        s,
        &setup,
        (
            fwd::rtttr_tip(pivot, [0.0; 3], 0.0, t.tool_z_mm),
            fwd::rtttr_tip(pivot, e1, 0.0, t.tool_z_mm),
        ),
        (
            fwd::rtttr_tip(pivot, [0.0; 3], b, t.tool_z_mm),
            fwd::rtttr_tip(pivot, e1, b + db, t.tool_z_mm),
        ),
    )?;
    Ok(vec![ts_check(
        &r,
        ResultId::TsDeltaBeta,
        t.delta_beta_urad,
    )?])
}

/// RTTTR table: reference point of the forward model (eqs 14/16) → the pod's two-step.
fn seed000_rtttr_table(s: &Scenario, t: &RtttrTable) -> Result<Vec<Check>, String> {
    use crate::forward_seed000 as fwd;
    let origin = [-30.0, 15.0, 120.0];
    let a = t.alpha_deg.to_radians();
    let da = t.delta_alpha_urad * 1e-6;
    let e1 = t.dv1_um.map(|v| v * 1e-3);
    let rp = t.reference_point_mm;
    let setup = TwoStepSetup {
        machine: ballpod::config::TwoStepMachine::RtttrTable,
        tool_z_mm: f64::NAN,
        z_alpha_gamma_mm: f64::NAN,
        reference_mm: rp,
        origin_mm: origin,
        angles_deg: [t.alpha_deg, f64::NAN],
    };
    let r = two_step_on_pod(
        s,
        &setup,
        (
            fwd::rtttr_table_point(origin, [0.0; 3], 0.0, rp),
            fwd::rtttr_table_point(origin, e1, 0.0, rp),
        ),
        (
            fwd::rtttr_table_point(origin, [0.0; 3], a, rp),
            fwd::rtttr_table_point(origin, e1, a + da, rp),
        ),
    )?;
    Ok(vec![ts_check(
        &r,
        ResultId::TsDeltaAlpha,
        t.delta_alpha_urad,
    )?])
}

/// The pod's recorded runs, as its USB stream sent them (one text), parsed and replayed
/// through a fresh application: the results table must be the live pod's, value for value.
pub fn replay_reproduces(pod: &VirtualPod) -> Result<(), String> {
    let text: String = pod.recording.runs.iter().map(|r| r.to_csv()).collect();
    let runs = parse_runs(Path::new("stream.csv"), &text).map_err(|e| e.to_string())?;
    let named: Vec<_> = runs
        .into_iter()
        .enumerate()
        .map(|(k, r)| (format!("run {}", k + 1), r))
        .collect();
    let replayed = replay(&named)?;
    let live = figures(&pod.app, ResultId::ALL);
    if replayed.results != live {
        return Err(format!(
            "replay of the recorded stream differs from the live pod:\n  live   {live:?}\n  replay {:?}",
            replayed.results
        ));
    }
    Ok(())
}

/// A scratch directory for the files of one scenario (removed by [`replay_session`]).
fn scratch(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("ballpod-scenario-{}-{name}", std::process::id()))
}

/// `cargo replay` of a session file whose readings table is `table` (header line first), with
/// `section` the session file's table (`[rtest]` or `[dial]` lines, the readings file named
/// `readings.csv`): the host-only figures.
fn replay_session(name: &str, section: &str, table: &str) -> Result<Vec<Figure>, String> {
    let dir = scratch(name);
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let session = dir.join("session.toml");
    let written = std::fs::write(dir.join("readings.csv"), table)
        .and_then(|_| std::fs::write(&session, section));
    let out = written
        .map_err(|e| e.to_string())
        .and_then(|_| read_inputs(&[session]).map_err(|e| e.to_string()));
    let _ = std::fs::remove_dir_all(&dir);
    let inputs = out?;
    if !inputs.runs.is_empty() {
        return Err("the session file replayed pod runs it does not list".into());
    }
    Ok(inputs.host)
}

/// The figure `name` of a replay.
fn figure<'a>(figs: &'a [Figure], name: &str) -> Result<&'a Figure, String> {
    figs.iter()
        .find(|f| f.name == name)
        .ok_or(format!("replay reports no {name}"))
}
