//! Single-socket-method measurements of a tool point at sensor level (seed 000 eq 1, the "SSM"
//! of the two-step method): the ball bar on a socket below the nominal point, and an SSM run
//! on the simulated pod while the machine dwells at three stations on the bar's sphere and
//! moves between them at a feed. The pod's application detects the dwells, solves eq (1),
//! refines it and states u(E) (results `ssm_e*`); with its two-step set-up (`ts_*` fields) it
//! identifies the orientation errors from two SSM runs (results `ts_d_*`).
//!
//! Convention: the encoders read the nominal tool-ball centre (the CNC's tool-point
//! coordinates X, Y, Z; rotary axes still during the SSM), and the ball sits at nominal + E,
//! with E constant over the small translations between the stations (the orientation error of
//! a rotary axis moves the tool point, it does not change with X, Y, Z).

use ballpod::app::{Command, Pattern, ResultId};

use super::motion::{SSM_ACCEL_MM_PER_S2, ssm_path};
use super::sensors::Instrument;
use super::virtual_pod::{VirtualPod, VirtualSetup};

/// Bar length of the SSM, mm.
pub const BAR_LENGTH_MM: f64 = 150.0;
/// Feed of the transfer to the next socket (bar lifted off), mm/min.
const FEED_MM_PER_MIN: f64 = 2000.0;

/// An SSM measurement as the pod reports it: E and its standard uncertainty.
#[derive(Clone, Copy, Debug)]
pub struct SsmMeasurement {
    /// E = actual − nominal tool-ball centre, µm.
    pub e_um: [f64; 3],
    /// Standard uncertainty of each component of E, µm.
    pub std_um: f64,
}

/// The simulated pod doing SSM runs, one after the other in virtual time.
pub struct SsmRig {
    /// The pod (set its two-step configuration, read its results).
    pub pod: VirtualPod,
    /// Where the machine is (nominal tool point, mm); `None` before the first measurement.
    at: Option<[f64; 3]>,
}

impl SsmRig {
    /// A pod with a 150 mm bar, bar noise σ `noise_um` per sample and noise seed `seed`.
    pub fn new(noise_um: f64, seed: u64) -> Self {
        let mut pod = VirtualPod::new(VirtualSetup {
            seed,
            instrument: Instrument {
                bar_noise_um: noise_um,
                ..Instrument::default()
            },
            ..VirtualSetup::default()
        });
        pod.sensors.set_bar_length(BAR_LENGTH_MM);
        let _ = pod
            .app
            .configure(|c| c.bar_length_mm = BAR_LENGTH_MM as f32);
        Self { pod, at: None }
    }

    /// An SSM run at the nominal tool point `nominal_mm` whose ball is actually at `actual_mm`:
    /// socket at `nominal − L·ẑ` (written to the pod's set-up), three stations.
    pub fn measure(
        &mut self,
        nominal_mm: [f64; 3],
        actual_mm: [f64; 3],
    ) -> Result<SsmMeasurement, String> {
        let l = BAR_LENGTH_MM;
        let e_um = [0, 1, 2].map(|i| (actual_mm[i] - nominal_mm[i]) * 1e3);
        let socket = [nominal_mm[0], nominal_mm[1], nominal_mm[2] - l];
        let cmd = |e: ballpod::app::CommandError| format!("SSM: {:?}", e.text());
        self.pod
            .app
            .configure(|c| c.setup.ssm_socket_mm = socket.map(|v| v as f32))
            .map_err(cmd)?;
        // the path of the served pod's SSM (dwells on the sphere about the pod's socket)
        let path = ssm_path(e_um, self.pod.app.config(), SSM_ACCEL_MM_PER_S2)?;
        let (Some(first), Some(last)) = (path.first(), path.last()) else {
            return Err("SSM: empty path".into());
        };
        let (start, end) = (first.axes, last.axes);
        let step_mm =
            FEED_MM_PER_MIN / 60.0 / f64::from(self.pod.app.running_config().sample_rate_hz);
        match self.at {
            None => self.pod.home(&start),
            // the transfer to the new socket with the bar lifted off (the LVDT at rest, ΔL
            // reads the free length: 0 µm), before the run
            Some(from) => {
                let d = [0, 1, 2].map(|i| start[i] - from[i]);
                let n = ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() / step_mm).ceil();
                for j in 1..=n as usize {
                    let mut p = start;
                    p.iter_mut()
                        .zip(from.iter().zip(d.iter()))
                        .for_each(|(p, (f, d))| *p = f + d * j as f64 / n);
                    self.pod.sample_at(0.0, &p);
                }
            }
        }
        self.pod.app.set_pattern(Pattern::Ssm).map_err(cmd)?;
        self.pod.execute(Command::Arm).map_err(cmd)?;
        self.pod.execute(Command::Start).map_err(cmd)?;
        for s in &path {
            self.pod.sample_at(s.dl_um, &s.axes);
        }
        let at = [end[0], end[1], end[2]];
        self.at = Some(at);
        if self.pod.app.session() != ballpod::app::SessionState::Running {
            return Err(format!(
                "SSM: the run ended before the path did ({}, {})",
                self.pod.app.session().name(),
                self.pod
                    .app
                    .abort_reason()
                    .map_or("no reason", |a| a.name())
            ));
        }
        self.pod.execute(Command::Stop).map_err(cmd)?;
        let app = &mut self.pod.app;
        let r = |id: ResultId| {
            let e = app.result(id);
            e.valid.then_some(e).ok_or(format!(
                "SSM: no {} ({:?}, {} stations)",
                id.info().name,
                app.abort_reason(),
                app.result(ResultId::SsmStations).value
            ))
        };
        let (x, y, z) = (
            r(ResultId::SsmEx)?,
            r(ResultId::SsmEy)?,
            r(ResultId::SsmEz)?,
        );
        Ok(SsmMeasurement {
            e_um: [x.value, y.value, z.value].map(f64::from),
            std_um: f64::from(x.std_uncertainty),
        })
    }
}
