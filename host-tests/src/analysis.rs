//! From runs of samples to the results the simulator and the replay both report: the session
//! description (what each run is) and [`analyse`], which feeds the samples to the core
//! (`ballpod::session`, `ballpod::metrology`) and collects the results as JSON-ready structs.
//!
//! Simulator and replay call the same function on the same samples, so a replay of the logs
//! the simulator wrote gives the same results bit for bit.

use ballpod::acquisition::Sample;
use ballpod::identify::multitasking::compensation::{CompensationMode, compensate};
use ballpod::identify::multitasking::patterns::{NcBlock, NcOffset};
use ballpod::identify::multitasking::{Parameter, urad_to_arcsec};
use ballpod::metrology::circle_fit::{CircleEstimate, CircleFitConfig};
use ballpod::metrology::iso230_4::{self, CircularTest, Diagnostics, Direction};
use ballpod::metrology::pattern::{PatternGeometry, Plane, Sensitivity};
use ballpod::session::seed002::{Procedure, Setup, Step};
use serde::{Deserialize, Serialize};

/// Angular bins of the ISO 230-4 profile (1° each).
pub const ISO_BINS: usize = 360;

/// NC check points where the seed 002 result is applied as a compensation (`results.json`
/// `seed002.compensation[]`): X, Y, Z in mm, B, C in degrees, in the working zone of the
/// Table 4.3 set-up (the first is the check point of spec seed-002 part 5).
pub const COMPENSATION_POINTS: [[f64; 5]; 4] = [
    [-390.0, 0.0, -112.2605, 10.0, 0.0],
    [-490.0, 0.0, -112.2877, 0.0, 0.0],
    [-390.0, 50.0, -62.2491, 45.0, 90.0],
    [-440.0, -50.0, -112.2605, 90.0, 225.0],
];

/// Seed 002 geometry of a session (Table 4.3 symbols, mm).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Seed002Geometry {
    /// L_B, mm.
    pub l_b_mm: f64,
    /// R_B, mm.
    pub r_b_mm: f64,
    /// R′_B (CR2 step), mm.
    pub r_b2_mm: f64,
    /// R_C, mm.
    pub r_c_mm: f64,
    /// Z_C, mm.
    pub z_c_mm: f64,
    /// Z_T, mm (thesis mode).
    pub z_t_mm: f64,
    /// Z′_T, mm (thesis mode).
    pub z_t2_mm: f64,
    /// X_T, mm (thesis mode).
    pub x_t_mm: f64,
    /// Machine coordinates of the model-frame origin O_M (x, y, z), mm.
    #[serde(default)]
    pub offset_mm: [f64; 3],
}

impl Seed002Geometry {
    /// The core's set-up.
    pub fn setup(&self) -> Setup {
        Setup {
            l_b_mm: self.l_b_mm,
            r_b_mm: self.r_b_mm,
            r_b2_mm: self.r_b2_mm,
            r_c_mm: self.r_c_mm,
            z_c_mm: self.z_c_mm,
            z_t_mm: self.z_t_mm,
            z_t2_mm: self.z_t2_mm,
            x_t_mm: self.x_t_mm,
            offset: NcOffset {
                x_mm: self.offset_mm[0],
                y_mm: self.offset_mm[1],
                z_mm: self.offset_mm[2],
            },
        }
    }

    /// From the core's set-up.
    pub fn from_setup(s: &Setup) -> Self {
        Self {
            l_b_mm: s.l_b_mm,
            r_b_mm: s.r_b_mm,
            r_b2_mm: s.r_b2_mm,
            r_c_mm: s.r_c_mm,
            z_c_mm: s.z_c_mm,
            z_t_mm: s.z_t_mm,
            z_t2_mm: s.z_t2_mm,
            x_t_mm: s.x_t_mm,
            offset_mm: [s.offset.x_mm, s.offset.y_mm, s.offset.z_mm],
        }
    }
}

/// ISO 230-4 circle geometry of a session.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CircleGeometry {
    /// Nominal radius (bar length), mm.
    pub radius_mm: f64,
    /// Socket (circle centre) position in machine X, Y, mm.
    pub socket_mm: [f64; 2],
    /// Feed, mm/min (for the servo mismatch).
    pub feed_mm_per_min: f64,
}

/// What one log is.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RunDesc {
    /// Log file name, relative to the session file.
    pub log: String,
    /// `"BX"`, `"BY"`, `"CR"`, `"CA"`, `"CR2"` (seed 002 steps) or `"ISO230-4"` (circle).
    pub method: String,
    /// `"CW"` or `"CCW"`.
    pub direction: String,
}

/// A session description: geometry and the list of runs.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SessionDesc {
    /// Seed 002 geometry (required when a run is a seed 002 step).
    #[serde(default)]
    pub seed002: Option<Seed002Geometry>,
    /// Circle geometry (required when a run is `ISO230-4`).
    #[serde(default)]
    pub circle: Option<CircleGeometry>,
    /// The runs, in order.
    pub runs: Vec<RunDesc>,
}

/// Parsed direction.
pub fn parse_direction(s: &str) -> Option<Direction> {
    match s {
        "CW" => Some(Direction::Cw),
        "CCW" => Some(Direction::Ccw),
        _ => None,
    }
}

/// Direction name.
pub fn direction_name(d: Direction) -> &'static str {
    match d {
        Direction::Cw => "CW",
        Direction::Ccw => "CCW",
    }
}

/// A fit of one run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunResult {
    /// Log name.
    pub log: String,
    /// Method (step name or `ISO230-4`).
    pub method: String,
    /// `CW` / `CCW`.
    pub direction: String,
    /// Samples in the log.
    pub samples: usize,
    /// Samples the fit used.
    pub samples_used: u32,
    /// Radius change r0, µm.
    pub r0_um: f32,
    /// Eccentricity (e_u, e_v), µm (seed 002: (ex, ez) or (ex, ey)).
    pub e_um: [f32; 2],
    /// Standard uncertainty of e, µm.
    pub u_e_um: [f32; 2],
    /// Residual RMS, µm.
    pub residual_rms_um: f32,
    /// Condition number of the fit's normal matrix.
    pub cond: f32,
}

/// One identified value.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Value {
    /// Symbol, e.g. `alpha_XB`.
    pub name: String,
    /// Value.
    pub value: f64,
    /// Standard uncertainty.
    pub u: f64,
    /// Unit: `um` or `arcsec`.
    pub unit: String,
}

/// Eccentricity of a step.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct StepResult {
    /// Step name.
    pub step: String,
    /// Mean eccentricity, µm.
    pub e_um: [f64; 2],
    /// Its standard uncertainty, µm.
    pub u_e_um: [f64; 2],
    /// CCW − CW, µm.
    pub e_ccw_minus_cw_um: [f64; 2],
    /// CW/CCW pairs.
    pub repeats: usize,
}

/// Seed 002 identification.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Seed002Result {
    /// Per-step eccentricities.
    pub steps: Vec<StepResult>,
    /// Thesis mode (eqs 4.10–4.18): 8 values.
    pub thesis: Vec<Value>,
    /// Thesis mode: the δz_BT setting ex_BX, µm.
    pub thesis_dz_bt_setting_um: f64,
    /// Model mode (literal HTM model): the 10 identified deviations.
    pub model: Vec<Value>,
    /// Model mode: residual RMS of the eccentricity equations, µm.
    pub model_residual_rms_um: f64,
    /// Model mode: condition number.
    pub model_condition: f64,
    /// Corrections: the negative of each model-mode deviation (same units).
    pub corrections: Vec<Value>,
    /// The model-mode deviations applied by the core's compensation
    /// (`identify::multitasking::compensation`, single correction) at [`COMPENSATION_POINTS`].
    pub compensation: Vec<CompensatedPoint>,
}

/// One NC point compensated with the identified deviations.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CompensatedPoint {
    /// The commanded NC block: X, Y, Z (mm), B, C (degrees).
    pub nc_mm_deg: [f64; 5],
    /// The corrected command X, Y, Z (mm); B and C stay as commanded.
    pub corrected_xyz_mm: [f64; 3],
    /// Corrected − commanded X, Y, Z, µm.
    pub correction_um: [f64; 3],
}

/// Figures of one ISO 230-4 direction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IsoDirection {
    /// Circular deviation G, µm.
    pub g_um: f32,
    /// Radial deviation F_max, µm.
    pub f_max_um: f32,
    /// Radial deviation F_min, µm.
    pub f_min_um: f32,
    /// Fitted centre (e_x, e_y), µm.
    pub centre_um: [f32; 2],
    /// Fitted radius change, µm.
    pub r0_um: f32,
    /// Diagnostics of this direction.
    pub diagnostics: Diag,
}

/// Ball-bar diagnostics.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Diag {
    /// Out-of-squareness, µrad.
    pub squareness_urad: f32,
    /// Scale mismatch k_x − k_y, µm/m.
    pub scale_mismatch_um_per_m: f32,
    /// Reversal step X, µm.
    pub reversal_x_um: f32,
    /// Reversal step Y, µm.
    pub reversal_y_um: f32,
    /// Cyclic error amplitude, µm.
    pub cyclic_amplitude_um: f32,
    /// Cyclic error order.
    pub cyclic_order: u32,
    /// Residual RMS of the diagnostic model, µm.
    pub residual_rms_um: f32,
}

impl From<&Diagnostics> for Diag {
    fn from(d: &Diagnostics) -> Self {
        Self {
            squareness_urad: d.squareness_urad,
            scale_mismatch_um_per_m: d.scale_mismatch_um_per_m,
            reversal_x_um: d.reversal_step_u_um,
            reversal_y_um: d.reversal_step_v_um,
            cyclic_amplitude_um: d.cyclic_amplitude_um,
            cyclic_order: d.cyclic_order,
            residual_rms_um: d.residual_rms_um,
        }
    }
}

/// ISO 230-4 circular test.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct IsoResult {
    /// Nominal radius, mm.
    pub radius_mm: f64,
    /// CCW figures.
    pub ccw: IsoDirection,
    /// CW figures.
    pub cw: IsoDirection,
    /// Circular hysteresis H, µm.
    pub hysteresis_h_um: f32,
    /// Bi-directional circular deviation G(b), µm.
    pub bidirectional_g_um: f32,
    /// Mean bi-directional radial deviation, µm.
    pub mean_bidirectional_radial_um: f32,
    /// Mean of the CW and CCW diagnostics.
    pub diagnostics: Diag,
    /// Servo mismatch τ_x − τ_y, ms.
    pub servo_mismatch_ms: f64,
}

/// Everything a session reports.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Results {
    /// Per-run fits.
    pub runs: Vec<RunResult>,
    /// Seed 002 procedure, when its runs are complete.
    pub seed002: Option<Seed002Result>,
    /// ISO 230-4 circle, when both directions are there.
    pub iso230_4: Option<IsoResult>,
}

fn run_result(r: &RunDesc, n: usize, e: &CircleEstimate) -> RunResult {
    RunResult {
        log: r.log.clone(),
        method: r.method.clone(),
        direction: r.direction.clone(),
        samples: n,
        samples_used: e.samples,
        r0_um: e.r0_um,
        e_um: e.e_um,
        u_e_um: e.u_e_um,
        residual_rms_um: e.residual_rms_um,
        cond: e.cond,
    }
}

fn value(name: &str, value: f64, u: f64, unit: &str) -> Value {
    Value {
        name: name.to_string(),
        value,
        u,
        unit: unit.to_string(),
    }
}

/// Analyses runs (one sample vector per [`RunDesc`], same order). Errors name the run.
pub fn analyse(desc: &SessionDesc, runs: &[Vec<Sample>]) -> Result<Results, String> {
    if runs.len() != desc.runs.len() {
        return Err(format!(
            "session lists {} runs, {} logs given",
            desc.runs.len(),
            runs.len()
        ));
    }
    let mut out = Vec::new();
    let mut proc002 = desc.seed002.map(|g| Procedure::new(g.setup()));
    let mut iso = desc.circle.map(|c| {
        CircularTest::<ISO_BINS>::new(
            CircleFitConfig {
                geometry: PatternGeometry {
                    plane: Plane::XY,
                    centre_u_mm: c.socket_mm[0] as f32,
                    centre_v_mm: c.socket_mm[1] as f32,
                    sensitivity: Sensitivity::Outward,
                },
                min_arc_deg: 300.0,
            },
            c.radius_mm as f32,
        )
    });
    let mut iso_runs = 0usize;
    for (r, samples) in desc.runs.iter().zip(runs) {
        let dir = parse_direction(&r.direction).ok_or(format!(
            "{}: direction {:?} (CW or CCW)",
            r.log, r.direction
        ))?;
        if r.method == "ISO230-4" {
            let t = iso
                .as_mut()
                .ok_or(format!("{}: ISO230-4 run without [circle] geometry", r.log))?;
            for s in samples {
                t.update(s, dir);
            }
            iso_runs += 1;
            let e = t
                .fit(dir)
                .estimate()
                .map_err(|e| format!("{}: circle fit: {e:?}", r.log))?;
            out.push(run_result(r, samples.len(), &e));
        } else {
            let step = Step::from_name(&r.method)
                .ok_or(format!("{}: unknown method {:?}", r.log, r.method))?;
            let p = proc002.as_mut().ok_or(format!(
                "{}: seed 002 run without [seed002] geometry",
                r.log
            ))?;
            let (e, _) = p
                .run(step, dir, samples.iter())
                .map_err(|e| format!("{}: {e:?}", r.log))?;
            out.push(run_result(r, samples.len(), &e));
        }
    }
    let seed002 = match proc002 {
        Some(p) if p.missing().is_none() => Some(seed002_result(&p)?),
        _ => None,
    };
    let iso230_4 = match (iso, desc.circle) {
        (Some(t), Some(c)) if iso_runs >= 2 => Some(iso_result(&t, &c)?),
        _ => None,
    };
    Ok(Results {
        runs: out,
        seed002,
        iso230_4,
    })
}

fn seed002_result(p: &Procedure) -> Result<Seed002Result, String> {
    let id = p.identify().map_err(|e| format!("seed 002: {e:?}"))?;
    let steps = Step::ALL
        .iter()
        .zip(id.steps.iter())
        .map(|(s, e)| StepResult {
            step: s.name().to_string(),
            e_um: e.e_um,
            u_e_um: e.u_e_um,
            e_ccw_minus_cw_um: e.e_ccw_minus_cw_um,
            repeats: e.repeats,
        })
        .collect();
    let (t, u) = (id.thesis.deviations, id.thesis.std_uncertainty);
    let thesis = vec![
        value("alpha_CZ", t.alpha_cz_arcsec, u.alpha_cz_arcsec, "arcsec"),
        value("beta_CZ", t.beta_cz_arcsec, u.beta_cz_arcsec, "arcsec"),
        value("alpha_XB", t.alpha_xb_arcsec, u.alpha_xb_arcsec, "arcsec"),
        value("beta_XB", t.beta_xb_arcsec, u.beta_xb_arcsec, "arcsec"),
        value("gamma_XB", t.gamma_xb_arcsec, u.gamma_xb_arcsec, "arcsec"),
        value("alpha_BT", t.alpha_bt_arcsec, u.alpha_bt_arcsec, "arcsec"),
        value(
            "dx_CZ-dx_BT",
            t.dx_cz_minus_dx_bt_um,
            u.dx_cz_minus_dx_bt_um,
            "um",
        ),
        value("dy_CZ", t.dy_cz_um, u.dy_cz_um, "um"),
    ];
    let m = &id.model;
    let x = m.result.deviations.to_array();
    let lsq = ballpod::identify::multitasking::model_lsq::ModelLsq::without_squareness();
    let mut model = Vec::new();
    for p in Parameter::ALL {
        let i = p.index();
        if !lsq.free[i] {
            continue;
        }
        let (v, uu) = (x[i], m.std_uncertainty[i]);
        model.push(if p.is_positional() {
            value(p.name(), v, uu, "um")
        } else {
            value(p.name(), urad_to_arcsec(v), urad_to_arcsec(uu), "arcsec")
        });
    }
    let corrections = model
        .iter()
        .map(|v| Value {
            value: -v.value,
            ..v.clone()
        })
        .collect();
    let mut compensation = Vec::new();
    for nc in COMPENSATION_POINTS {
        let b = NcBlock {
            x_mm: nc[0],
            y_mm: nc[1],
            z_mm: nc[2],
            b_deg: nc[3],
            c_deg: nc[4],
        };
        let c = compensate(&b, &m.result.deviations, CompensationMode::Once)
            .map_err(|e| format!("seed 002 compensation at {nc:?}: {e:?}"))?;
        compensation.push(CompensatedPoint {
            nc_mm_deg: nc,
            corrected_xyz_mm: [c.x_mm, c.y_mm, c.z_mm],
            correction_um: [
                (c.x_mm - b.x_mm) * 1e3,
                (c.y_mm - b.y_mm) * 1e3,
                (c.z_mm - b.z_mm) * 1e3,
            ],
        });
    }
    Ok(Seed002Result {
        steps,
        thesis,
        thesis_dz_bt_setting_um: id.thesis.dz_bt_setting_um,
        model,
        model_residual_rms_um: m.result.residual_rms_um,
        model_condition: m.result.condition,
        corrections,
        compensation,
    })
}

fn iso_result(t: &CircularTest<ISO_BINS>, c: &CircleGeometry) -> Result<IsoResult, String> {
    let e = |e| format!("ISO 230-4: {e:?}");
    let dir = |d: Direction| -> Result<(IsoDirection, Diagnostics), String> {
        let f = t.direction_figures(d).map_err(e)?;
        let g = t.diagnostics(d).map_err(e)?;
        Ok((
            IsoDirection {
                g_um: f.circular_deviation_g_um,
                f_max_um: f.radial_deviation_f_max_um,
                f_min_um: f.radial_deviation_f_min_um,
                centre_um: f.fit.e_um,
                r0_um: f.fit.r0_um,
                diagnostics: Diag::from(&g),
            },
            g,
        ))
    };
    let (ccw, dccw) = dir(Direction::Ccw)?;
    let (cw, dcw) = dir(Direction::Cw)?;
    let b = t.bidirectional_figures().map_err(e)?;
    let mean = iso230_4::mean_diagnostics(&dccw, &dcw);
    Ok(IsoResult {
        radius_mm: c.radius_mm,
        ccw,
        cw,
        hysteresis_h_um: b.circular_hysteresis_h_um,
        bidirectional_g_um: b.bidirectional_circular_deviation_um,
        mean_bidirectional_radial_um: b.mean_bidirectional_radial_deviation_um,
        diagnostics: Diag::from(&mean),
        servo_mismatch_ms: ballpod::session::circular::servo_mismatch_ms(
            &dccw,
            &dcw,
            c.radius_mm,
            c.feed_mm_per_min,
        ),
    })
}
