//! The simulated session: the virtual machine tool runs the seed 002 procedure and the
//! ISO 230-4 circle, the virtual pod turns each pose into a sample (sensor level, through the
//! core's acquisition). Returns the runs with their session description; [`crate::analysis`]
//! does the rest.

use ballpod::acquisition::Sample;
use ballpod::metrology::iso230_4::Direction;
use ballpod::session::seed002::{Setup, Step};

use crate::analysis::{CircleGeometry, RunDesc, Seed002Geometry, SessionDesc, direction_name};
use crate::vmt::machine::MachineFile;
use crate::vmt::pod::Pod;

/// Options of a simulated session.
#[derive(Clone, Copy, Debug)]
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
}

impl Default for SimOptions {
    fn default() -> Self {
        Self {
            seed: 1,
            repeats: 3,
            feed_mm_per_min: 1000.0,
            seed002: true,
            circle: true,
        }
    }
}

/// A simulated session: its description and one sample vector per run.
pub struct SimSession {
    /// What each run is.
    pub desc: SessionDesc,
    /// The runs' samples.
    pub runs: Vec<Vec<Sample>>,
}

/// Samples of a seed 002 step run at `rate_hz`: B arcs 0..=90° (n points), C circles
/// 2π·i/n, at the feed's tangential speed of the T-ball.
fn step_samples(setup: &Setup, step: Step, feed_mm_per_min: f64, rate_hz: f64) -> usize {
    let g = setup.geometry(step);
    let len_mm = match step {
        Step::Bx | Step::By => g.r_b_mm * std::f64::consts::FRAC_PI_2,
        Step::Cr | Step::CrSecond => 2.0 * std::f64::consts::PI * (g.r_c_mm - g.l_b_mm).abs(),
        Step::Ca => 2.0 * std::f64::consts::PI * g.r_c_mm,
    };
    ((len_mm / (feed_mm_per_min / 60.0) * rate_hz).round() as usize).max(16)
}

/// Runs the session; `progress(done, total, what)` is called before each run.
pub fn simulate(
    m: &MachineFile,
    o: &SimOptions,
    progress: &mut dyn FnMut(usize, usize, &str),
) -> SimSession {
    let setup = Setup::thesis_table_4_3();
    let mut desc = SessionDesc {
        seed002: o.seed002.then(|| Seed002Geometry::from_setup(&setup)),
        circle: o.circle.then_some(CircleGeometry {
            radius_mm: m.circle.radius_mm,
            socket_mm: [0.0, 0.0],
            feed_mm_per_min: m.circle.feed_mm_per_min,
        }),
        runs: Vec::new(),
    };
    let total = if o.seed002 { o.repeats * 10 } else { 0 } + if o.circle { 2 } else { 0 };
    let mut runs = Vec::new();
    let rate = m.instrument.sample_rate_hz;
    let mut seed = o.seed;
    let mut next_seed = || {
        seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
        seed
    };
    if o.seed002 {
        for rep in 0..o.repeats {
            for step in Step::ALL {
                for dir in [Direction::Cw, Direction::Ccw] {
                    let name = format!("r{}_{}_{}.csv", rep + 1, step.name(), direction_name(dir));
                    progress(runs.len(), total, &name);
                    let n = step_samples(&setup, step, o.feed_mm_per_min, rate);
                    let mut pod = Pod::new(setup.l_b_mm, &m.instrument, next_seed());
                    let angle = |i: usize| {
                        let k = match dir {
                            Direction::Ccw => i,
                            Direction::Cw => n - 1 - i,
                        };
                        if step.pattern().is_b() {
                            std::f64::consts::FRAC_PI_2 * k as f64 / (n - 1) as f64
                        } else {
                            // CW: 0, −Δ, −2Δ, … (the same angles as CCW, visited backwards)
                            let k = match dir {
                                Direction::Ccw => i as f64,
                                Direction::Cw => -(i as f64),
                            };
                            2.0 * std::f64::consts::PI * k / n as f64
                        }
                    };
                    let (_, start) = m.seed002.pose(&setup, step, angle(0));
                    pod.reference(&start);
                    let samples = (0..n)
                        .map(|i| {
                            let (dl, axes) = m.seed002.pose(&setup, step, angle(i));
                            pod.sample(dl, &axes)
                        })
                        .collect();
                    runs.push(samples);
                    desc.runs.push(RunDesc {
                        log: name,
                        method: step.name().to_string(),
                        direction: direction_name(dir).to_string(),
                    });
                }
            }
        }
    }
    if o.circle {
        let c = &m.circle;
        let n = c.samples_per_rev(rate);
        for dir in [Direction::Ccw, Direction::Cw] {
            let name = format!("iso230_4_{}.csv", direction_name(dir));
            progress(runs.len(), total, &name);
            let s = if dir == Direction::Ccw { 1.0 } else { -1.0 };
            let mut pod = Pod::new(c.radius_mm, &m.instrument, next_seed());
            let (_, start) = c.pose(0.0, s);
            pod.reference(&start);
            let samples = (0..n)
                .map(|i| {
                    let th = s * 2.0 * std::f64::consts::PI * i as f64 / n as f64;
                    let (dl, axes) = c.pose(th, s);
                    pod.sample(dl, &axes)
                })
                .collect();
            runs.push(samples);
            desc.runs.push(RunDesc {
                log: name,
                method: "ISO230-4".to_string(),
                direction: direction_name(dir).to_string(),
            });
        }
    }
    progress(total, total, "done");
    SimSession { desc, runs }
}
