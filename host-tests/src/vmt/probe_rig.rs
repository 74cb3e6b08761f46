//! Touch-probe measurement of a precision sphere at sensor level (seed 002 chapter 5): the
//! simulated pod runs a PROBE run while the machine approaches the sphere along its normal at
//! nine points of the upper hemisphere; the probe switches after its pre-travel (plus a
//! repeatability scatter) and may bounce; the pod latches the encoder counters at the edge
//! (its application's probe latch, debounce and re-seat lock-out), the machine retracts and
//! the stylus re-seats. At the end of the run the pod fits the sphere (results `sphere_*`),
//! and once it has spheres at C = 0/90/180/270° it identifies the C axis (`probe_*_CZ`).
//!
//! A constant pre-travel shrinks the fitted radius by the pre-travel and leaves the centre
//! where it is (every point moves along its own normal by the same amount) — the reason the
//! chapter 5 method uses sphere centres, not single touches. A pre-travel that varies with the
//! direction of approach (lobing, `Instrument::probe_pretravel_at`) moves the centre too.

use ballpod::acquisition::MAX_AXES;
use ballpod::acquisition::probe::TriggerOutcome;
use ballpod::app::{Command, Pattern, ResultId};

use super::motion::probing_directions;
use super::sensors::Instrument;
use super::virtual_pod::{VirtualPod, VirtualSetup};
use crate::rng::Rng;

pub use super::motion::{SPHERE_RADIUS_MM, STYLUS_RADIUS_MM};
/// Approach: start this far from contact, mm, at this feed, mm/min.
const APPROACH_MM: f64 = 0.3;
const PROBING_FEED_MM_PER_MIN: f64 = 100.0;
/// Retract after a touch, mm, at this feed, mm/min.
const RETRACT_MM: f64 = 0.5;
const RETRACT_FEED_MM_PER_MIN: f64 = 1000.0;

/// A sphere measurement as the pod reports it.
#[derive(Clone, Copy, Debug)]
pub struct SphereMeasurement {
    /// Fitted centre, mm (results `sphere_x/y/z`).
    pub centre_mm: [f64; 3],
    /// Fitted radius, mm (`sphere_radius`).
    pub radius_mm: f64,
    /// Touch points accepted.
    pub accepted: u32,
    /// Edges rejected as bounce.
    pub bounces: u32,
}

/// The simulated pod probing spheres.
pub struct ProbeRig {
    /// The pod (set its configuration, read its results).
    pub pod: VirtualPod,
    inst: Instrument,
    rng: Rng,
    at: Option<[f64; MAX_AXES]>,
}

impl ProbeRig {
    /// A pod with the probe faults and noise of `inst` (pre-travel, repeatability, bounces).
    pub fn new(inst: &Instrument, seed: u64) -> Self {
        Self {
            pod: VirtualPod::new(VirtualSetup {
                seed,
                instrument: *inst,
                ..VirtualSetup::default()
            }),
            inst: *inst,
            rng: Rng::new(seed ^ 0x0005_eed0_f9e0_be00),
            at: None,
        }
    }

    fn move_to(&mut self, to: [f64; MAX_AXES], feed_mm_per_min: f64) {
        let from = self.at.unwrap_or(to);
        let d: [f64; 3] = std::array::from_fn(|i| to[i] - from[i]);
        let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        let step = feed_mm_per_min / 60.0 / self.inst.sample_rate_hz;
        let n = (len / step).ceil().max(1.0) as usize;
        for j in 1..=n {
            let f = j as f64 / n as f64;
            let p: [f64; MAX_AXES] = std::array::from_fn(|i| from[i] + (to[i] - from[i]) * f);
            self.pod.sample_at(0.0, &p);
        }
        self.at = Some(to);
    }

    /// A PROBE run on the sphere whose true centre is `centre_mm` (machine X, Y, Z) with the
    /// rotary axes at `rotary_deg` (B, C): nine touches, and the pod's sphere.
    pub fn measure_sphere(
        &mut self,
        centre_mm: [f64; 3],
        rotary_deg: [f64; 2],
    ) -> Result<SphereMeasurement, String> {
        let (a0, b0, _) = self.pod.app.probe_counts();
        let contact = SPHERE_RADIUS_MM + STYLUS_RADIUS_MM;
        let axes = |p: [f64; 3]| [p[0], p[1], p[2], rotary_deg[0], rotary_deg[1]];
        let on =
            |n: [f64; 3], r: f64| -> [f64; 3] { std::array::from_fn(|i| centre_mm[i] + n[i] * r) };
        let start = axes(on(probing_directions()[0], contact + RETRACT_MM));
        if self.at.is_none() {
            self.pod.home(&start);
        }
        self.move_to(start, RETRACT_FEED_MM_PER_MIN);
        let app = &mut self.pod.app;
        let cmd = |e: ballpod::app::CommandError| format!("{:?}", e.text());
        app.set_pattern(Pattern::Probe).map_err(cmd)?;
        self.pod.execute(Command::Arm).map_err(cmd)?;
        self.pod.execute(Command::Start).map_err(cmd)?;
        for n in probing_directions() {
            // clear of the sphere, then the approach along −n
            self.move_to(axes(on(n, contact + RETRACT_MM)), RETRACT_FEED_MM_PER_MIN);
            self.move_to(axes(on(n, contact + APPROACH_MM)), RETRACT_FEED_MM_PER_MIN);
            let trigger_r = contact - self.inst.probe_pretravel_at(n, rotary_deg[0]) * 1e-3
                + self.inst.probe_repeatability_um * 1e-3 * self.rng.normal();
            self.move_to(axes(on(n, trigger_r)), PROBING_FEED_MM_PER_MIN);
            match self.pod.probe_edge_at(&axes(on(n, trigger_r))) {
                TriggerOutcome::Accepted(_) => {}
                other => return Err(format!("probe: touch not accepted ({other:?})")),
            }
            for _ in 0..self.inst.probe_bounces {
                if self.pod.probe_edge_at(&axes(on(n, trigger_r))) != TriggerOutcome::Bounce {
                    return Err("probe: a bounce edge was not rejected as bounce".into());
                }
            }
            // deflected until the retract has lifted the stylus off, then seated
            self.pod.set_probe_seated(false);
            self.move_to(axes(on(n, contact + 0.05)), RETRACT_FEED_MM_PER_MIN);
            self.pod.set_probe_seated(true);
            self.move_to(axes(on(n, contact + RETRACT_MM)), RETRACT_FEED_MM_PER_MIN);
            // the re-seat time before the next touch counts
            let here = axes(on(n, contact + RETRACT_MM));
            for _ in 0..(0.06 * self.inst.sample_rate_hz) as usize {
                self.pod.sample_at(0.0, &here);
            }
        }
        self.pod.execute(Command::Stop).map_err(cmd)?;
        let app = &mut self.pod.app;
        let r = |id| {
            let e = app.result(id);
            e.valid.then_some(f64::from(e.value)).ok_or(format!(
                "probe: no {} ({:?})",
                id.info().name,
                app.abort_reason()
            ))
        };
        let (a1, b1, _) = app.probe_counts();
        Ok(SphereMeasurement {
            centre_mm: [
                r(ResultId::SphereX)?,
                r(ResultId::SphereY)?,
                r(ResultId::SphereZ)?,
            ],
            radius_mm: r(ResultId::SphereRadius)?,
            accepted: a1 - a0,
            bounces: b1 - b0,
        })
    }
}
