//! The simulated session of `cargo sim`: the virtual machine tool runs the seed 002 procedure
//! and the ISO 230-4 circle through the simulated pod ([`crate::vmt::virtual_pod`]), run by
//! run, as a client drives the pod: the set-up written to its configuration, each run armed,
//! started and stopped through its application, its results read from the pod's results table
//! ([`crate::replay::Report`]). The runs are recorded as the pod's stream would carry them,
//! so a replay of them reports the same, byte for byte.

use ballpod::acquisition::MAX_AXES;
use ballpod::app::bc_ballbar::Setup;
use ballpod::app::{Command, Direction, Pattern, ResultId};
use ballpod::config::CirclePlane;

use crate::recording::RecordedRun;
use crate::replay::Report;
use crate::vmt::machine::{CircleMachine, MachineFile, ThreePlaneMachine};
use crate::vmt::motion::ServeTruth;
use crate::vmt::nc_motion::{self, NcRun};
use crate::vmt::virtual_pod::{VirtualPod, VirtualSetup};

/// Options of a simulated session.
#[derive(Clone, Debug)]
pub struct SimOptions {
    /// Noise seed.
    pub seed: u64,
    /// Repeats of the seed 002 procedure (each step CW and CCW every time).
    pub repeats: usize,
    /// Seed 002 feed, mm/min (thesis §5.5: 1000).
    pub feed_mm_per_min: f64,
    /// Run the seed 002 procedure.
    pub seed002: bool,
    /// Run the ISO 230-4 circle.
    pub circle: bool,
    /// Run the three-plane test: arcs in YZ and ZX (the machine file's `[planes]`,
    /// `vertical_arc_deg`) before the ISO 230-4 circle, which is its XY plane.
    pub three_planes: bool,
    /// Before the three-plane test and the ISO 230-4 circle, the same circle at each of these
    /// feeds (mm/min; empty: no feed-rate sweep).
    pub feed_sweep: Vec<f64>,
    /// The seed 002 steps from part programs: `BX.ngc`, `BY.ngc`, `CR.ngc`, `CA.ngc`,
    /// `CR2.ngc` in this directory (`cargo ncgen -- pattern`), and the ISO 230-4 circle from
    /// `CIRCLE.ngc` if it is there (`cargo ncgen -- circle`), through LinuxCNC's interpreter
    /// ([`crate::vmt::nc_motion`]), instead of the built-in motion.
    pub nc_dir: Option<std::path::PathBuf>,
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            repeats: 3,
            feed_mm_per_min: 1000.0,
            seed002: true,
            circle: true,
            three_planes: true,
            feed_sweep: Vec::new(),
            nc_dir: None,
        }
    }
}

/// A simulated session: what the pod reported and what it recorded, run by run.
pub struct SimSession {
    /// The report (each run's results, the final results table).
    pub report: Report,
    /// The recorded runs with their file names (for `--write-logs`, the plots and replay).
    pub runs: Vec<(String, RecordedRun)>,
    /// The feed-rate sweep: each feed's G(b) and servo mismatch as the pod published them
    /// after that feed's circle (value, u; NaN if invalid).
    pub sweep: Vec<SweepRow>,
}

/// One feed of a simulated feed-rate sweep, as the pod published it.
#[derive(Clone, Copy, Debug)]
pub struct SweepRow {
    /// Feed, mm/min.
    pub feed_mm_per_min: f64,
    /// G(b) and its u, µm.
    pub g_bidir_um: [f64; 2],
    /// Servo mismatch and its u, ms.
    pub servo_mismatch_ms: [f64; 2],
}

/// Samples of a seed 002 step run at `rate_hz`: B arcs 0..=90° (n points), C circles
/// 2π·i/n, at the feed's tangential speed of the T-ball.
fn step_samples(setup: &Setup, step: Pattern, feed_mm_per_min: f64, rate_hz: f64) -> usize {
    let g = setup.geometry(step);
    let len_mm = match step {
        Pattern::Bx | Pattern::By => g.r_b_mm * std::f64::consts::FRAC_PI_2,
        Pattern::Ca => 2.0 * std::f64::consts::PI * g.r_c_mm,
        _ => 2.0 * std::f64::consts::PI * (g.r_c_mm - g.l_b_mm).abs(),
    };
    ((len_mm / (feed_mm_per_min / 60.0) * rate_hz).round() as usize).max(16)
}

/// A client's run on the pod: pattern and direction selected, armed, the encoders homed at
/// the first pose, started, one sample per pose, stopped; the run reported as `name`.
pub fn run_poses(
    vp: &mut VirtualPod,
    report: &mut Report,
    name: &str,
    pattern: Pattern,
    direction: Direction,
    poses: impl Iterator<Item = (f64, [f64; MAX_AXES])>,
) -> Result<(), String> {
    let refused = |what: &str, e: ballpod::app::CommandError| {
        let (a, b) = e.text();
        format!("{name}: {what} refused: {a}{b}")
    };
    vp.app
        .set_pattern(pattern)
        .map_err(|e| refused("pattern", e))?;
    vp.app
        .set_direction(direction)
        .map_err(|e| refused("direction", e))?;
    vp.execute(Command::Arm).map_err(|e| refused("arm", e))?;
    let mut poses = poses.peekable();
    if let Some((_, start)) = poses.peek() {
        vp.home(start);
    }
    vp.execute(Command::Start)
        .map_err(|e| refused("start", e))?;
    for (dl, axes) in poses {
        vp.sample_at(dl, &axes);
    }
    // stopped; a run without results is reported as aborted with its reason
    // (the pod's jobs run at the end of the turn: the run's figures are there)
    let _ = vp.execute(Command::Stop);
    let run = vp
        .recording
        .runs
        .last()
        .ok_or(format!("{name}: nothing recorded"))?;
    let touches = run
        .events
        .iter()
        .filter(|e| matches!(e, crate::recording::Event::Touch(_)))
        .count();
    report.capture_run(&vp.app, name, run.events.len() - touches, touches);
    Ok(())
}

/// The data runs of the program `file` through LinuxCNC's interpreter: one CCW and one CW run,
/// or why not (`generator`: the `cargo ncgen` command that writes such a program).
fn nc_runs(file: &std::path::Path, generator: &str) -> Result<Vec<NcRun>, String> {
    let runs = nc_motion::runs(&nc_motion::interpret(file)?)
        .map_err(|e| format!("{}: {e}", file.display()))?;
    let has = |d| runs.iter().filter(|r| r.direction == d).count() == 1;
    if runs.len() != 2 || !has(Direction::Cw) || !has(Direction::Ccw) {
        return Err(format!(
            "{}: {} data runs; it needs one CCW and one CW run (cargo ncgen -- {generator})",
            file.display(),
            runs.len()
        ));
    }
    Ok(runs)
}

/// The data runs of each seed 002 step's program in `dir` (`<STEP>.ngc`, in
/// [`Pattern::SEED002`] order).
fn nc_programs(dir: &std::path::Path) -> Result<Vec<Vec<NcRun>>, String> {
    Pattern::SEED002
        .into_iter()
        .map(|step| nc_runs(&dir.join(format!("{}.ngc", step.name())), "pattern"))
        .collect()
}

/// Runs the session; `progress(done, total, what)` is called before each run.
pub fn simulate(
    m: &MachineFile,
    o: &SimOptions,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> Result<SimSession, String> {
    simulate_commanded(m, o, progress, None)
}

/// How a control commands a seed 002 step's pose: the axes its kinematics sends for the
/// nominal pattern's axes (X, Y, Z mm, B, C degrees) — a control holding a corrected model.
pub type Commanded<'a> = &'a dyn Fn(Pattern, [f64; MAX_AXES]) -> [f64; MAX_AXES];

/// [`simulate`] with the seed 002 steps' built-in motion commanded through `command` (the
/// machine's bar read where those axes put it; part programs, `nc_dir`, run as written).
pub fn simulate_commanded(
    m: &MachineFile,
    o: &SimOptions,
    progress: &mut dyn FnMut(usize, usize, &str),
    command: Option<Commanded<'_>>,
) -> Result<SimSession, String> {
    let mut vp: VirtualPod = VirtualPod::new(VirtualSetup {
        seed: o.seed,
        instrument: m.instrument,
        truth: ServeTruth {
            machine: *m,
            ..ServeTruth::default()
        },
    });
    let mut report = Report::default();
    let mut names = Vec::new();
    let total = if o.seed002 { o.repeats * 10 } else { 0 }
        + if o.circle { 2 } else { 0 }
        + if o.three_planes { 4 } else { 0 }
        + 2 * o.feed_sweep.len();
    let mut sweep = Vec::new();
    let rate = m.instrument.sample_rate_hz;
    let bad = |e: ballpod::app::CommandError| {
        let (a, b) = e.text();
        format!("set-up refused: {a}{b}")
    };
    if o.seed002 {
        let setup = Setup::thesis_table_4_3();
        vp.sensors.set_bar_length(setup.l_b_mm);
        vp.app
            .configure(|c| {
                c.bar_length_mm = setup.l_b_mm as f32;
                setup.to_config(&mut c.setup);
            })
            .map_err(bad)?;
        // the pod's own set-up (f32, as stored): the machine is commanded from what the pod
        // was told
        let pod_setup = Setup::from_config(&vp.app.config().setup)
            .map_err(|f| format!("set-up: {} not set", ballpod::app::field_name(f)))?;
        // the programs' runs, interpreted once (each repeat runs them again)
        let programs = match &o.nc_dir {
            Some(dir) => Some(nc_programs(dir)?),
            None => None,
        };
        for rep in 0..o.repeats {
            for (k, step) in Pattern::SEED002.into_iter().enumerate() {
                if let Some(runs) = programs.as_ref().and_then(|p| p.get(k)) {
                    for run in runs {
                        let dir = run.direction;
                        let name = format!("r{}_{}_{}.csv", rep + 1, step.name(), dir.name());
                        progress(names.len(), total, &name);
                        let poses = run
                            .samples(rate)
                            .into_iter()
                            .map(|axes| (m.seed002.delta_l_um(&pod_setup, step, &axes), axes));
                        run_poses(&mut vp, &mut report, &name, step, dir, poses)?;
                        names.push(name);
                    }
                    continue;
                }
                for dir in [Direction::Cw, Direction::Ccw] {
                    let name = format!("r{}_{}_{}.csv", rep + 1, step.name(), dir.name());
                    progress(names.len(), total, &name);
                    let n = step_samples(&pod_setup, step, o.feed_mm_per_min, rate);
                    let angle = |i: usize| {
                        if matches!(step, Pattern::Bx | Pattern::By) {
                            // CCW: θ increasing in XZ, φ (B) 90° → 0° (`Direction`)
                            let k = match dir {
                                Direction::Ccw => n - 1 - i,
                                Direction::Cw => i,
                            };
                            std::f64::consts::FRAC_PI_2 * k as f64 / (n - 1) as f64
                        } else {
                            // CW: 0, −Δ, −2Δ, … (the same angles as CCW, visited backwards)
                            dir.sign() * 2.0 * std::f64::consts::PI * i as f64 / n as f64
                        }
                    };
                    let poses = (0..n).map(|i| {
                        let (dl, axes) = m.seed002.pose(&pod_setup, step, angle(i));
                        match command {
                            None => (dl, axes),
                            Some(f) => {
                                let axes = f(step, axes);
                                (m.seed002.delta_l_um(&pod_setup, step, &axes), axes)
                            }
                        }
                    });
                    run_poses(&mut vp, &mut report, &name, step, dir, poses)?;
                    names.push(name);
                }
            }
        }
    }
    // the feed-rate sweep before the three-plane test and the ISO 230-4 circle (whose
    // figures the final table then holds); the sweep is kept per plane
    for &feed in &o.feed_sweep {
        let c = CircleMachine {
            feed_mm_per_min: feed,
            ..m.circle
        };
        configure_circle(&mut vp, CirclePlane::XY, c.radius_mm, feed, 300.0)?;
        let n = c.samples_per_rev(rate);
        for dir in [Direction::Ccw, Direction::Cw] {
            let name = format!("sweep_f{feed}_{}.csv", dir.name());
            progress(names.len(), total, &name);
            let s = dir.sign();
            let poses = (0..n).map(|i| c.pose(s * std::f64::consts::TAU * i as f64 / n as f64, s));
            run_poses(&mut vp, &mut report, &name, Pattern::Circle, dir, poses)?;
            names.push(name);
        }
        let r = |id| {
            let e = vp.app.result(id);
            if e.valid {
                [f64::from(e.value), f64::from(e.std_uncertainty)]
            } else {
                [f64::NAN; 2]
            }
        };
        sweep.push(SweepRow {
            feed_mm_per_min: feed,
            g_bidir_um: r(ResultId::GBidir),
            servo_mismatch_ms: r(ResultId::ServoMismatch),
        });
    }
    if o.three_planes {
        // the vertical planes first: the XY plane is the ISO 230-4 circle's (run last, so the
        // final table holds its figures and the summary it completes)
        let (xy, m) = (&m.circle, &m.planes);
        let (start_deg, arc_deg) = m.arc();
        for plane in [CirclePlane::YZ, CirclePlane::ZX] {
            // the samples span the arc less one step: the minimum a little below it
            let min_arc = (arc_deg - 5.0).min(300.0);
            configure_circle(&mut vp, plane, xy.radius_mm, xy.feed_mm_per_min, min_arc)?;
            let c = m.plane(xy, plane);
            let n = (c.samples_per_rev(rate) as f64 * arc_deg / 360.0).round() as usize;
            for dir in [Direction::Ccw, Direction::Cw] {
                let name = format!(
                    "planes_{}_{}.csv",
                    CirclePlane::NAMES[plane as usize].to_lowercase(),
                    dir.name()
                );
                progress(names.len(), total, &name);
                // CCW from the arc's start, CW back from its end
                let s = dir.sign();
                let from = if s > 0.0 {
                    start_deg
                } else {
                    start_deg + arc_deg
                };
                let poses = (0..n).map(|i| {
                    let theta = (from + s * arc_deg * i as f64 / n as f64).to_radians();
                    let (dl, uv) = c.pose(theta, s);
                    (dl, ThreePlaneMachine::axes(plane, uv))
                });
                run_poses(&mut vp, &mut report, &name, Pattern::Circle, dir, poses)?;
                names.push(name);
            }
        }
    }
    if o.circle {
        let c = &m.circle;
        configure_circle(
            &mut vp,
            CirclePlane::XY,
            c.radius_mm,
            c.feed_mm_per_min,
            300.0,
        )?;
        let n = c.samples_per_rev(rate);
        // the data arcs of the circle's program, if the directory has one (`CIRCLE.ngc`,
        // `ncgen circle` of this circle: XY about the origin)
        let program = match &o.nc_dir {
            Some(dir) if dir.join("CIRCLE.ngc").exists() => {
                Some(nc_runs(&dir.join("CIRCLE.ngc"), "circle")?)
            }
            _ => None,
        };
        for dir in [Direction::Ccw, Direction::Cw] {
            let name = format!("iso230_4_{}.csv", dir.name());
            progress(names.len(), total, &name);
            let s = dir.sign();
            let arc = program
                .as_ref()
                .and_then(|p| p.iter().find(|r| r.direction == dir));
            let angles: Vec<f64> = match arc {
                // the commanded angle of each interpreted sample about the centre, unwrapped
                // from the data arc's start (the machine's faults are a function of it)
                Some(run) => {
                    let mut last = 0.0f64;
                    run.samples(rate)
                        .iter()
                        .map(|p| {
                            let a = p[1].atan2(p[0]);
                            let tau = std::f64::consts::TAU;
                            last += (a - last + std::f64::consts::PI).rem_euclid(tau)
                                - std::f64::consts::PI;
                            last
                        })
                        .collect()
                }
                None => (0..n)
                    .map(|i| s * 2.0 * std::f64::consts::PI * i as f64 / n as f64)
                    .collect(),
            };
            let poses = angles.into_iter().map(|theta| c.pose(theta, s));
            run_poses(&mut vp, &mut report, &name, Pattern::Circle, dir, poses)?;
            names.push(name);
        }
    }
    report.finish(&vp.app);
    progress(total, total, "done");
    let runs = names.into_iter().zip(vp.recording.runs).collect();
    Ok(SimSession {
        report,
        runs,
        sweep,
    })
}

/// Writes the set-up of a circle about the origin in `plane` (radius = bar length, `feed`,
/// `min_arc_deg`) to the simulated pod and its bar.
fn configure_circle(
    vp: &mut VirtualPod,
    plane: CirclePlane,
    radius_mm: f64,
    feed_mm_per_min: f64,
    min_arc_deg: f64,
) -> Result<(), String> {
    vp.sensors.set_bar_length(radius_mm);
    vp.app
        .configure(|cfg| {
            cfg.bar_length_mm = radius_mm as f32;
            let s = &mut cfg.setup;
            s.circle_plane = plane;
            s.circle_centre_mm = [0.0; 3];
            s.circle_radius_mm = radius_mm as f32;
            s.circle_feed_mm_per_min = feed_mm_per_min as f32;
            s.circle_min_arc_deg = min_arc_deg as f32;
        })
        .map_err(|e| {
            let (a, b) = e.text();
            format!("set-up refused: {a}{b}")
        })
}
