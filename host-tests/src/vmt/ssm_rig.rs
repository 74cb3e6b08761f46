//! Single-socket-method measurements of a tool point at sensor level (seed 000 eq 1, the
//! "SSM" of the two-step method): the ball bar on a socket below the nominal point, the
//! machine dwelling at three stations on the bar's sphere and moving between them at a feed,
//! the simulated pod ([`super::pod::Pod`]: LVDT ADC blocks, encoder counters) producing the
//! samples, and the core's `metrology::ssm::station::StationCollector` (dwell detection by
//! axis speed, averaging) and `solve_stations` turning them into the error E.
//!
//! Convention: the encoders read the nominal tool-ball centre (the CNC's tool-point
//! coordinates X, Y, Z; rotary axes still during the SSM), and the ball sits at nominal + E,
//! with E constant over the small translations between the stations (the orientation error of
//! a rotary axis moves the tool point, it does not change with X, Y, Z).

use ballpod::acquisition::MAX_AXES;
use ballpod::metrology::ssm::SsmGeometry;
use ballpod::metrology::ssm::station::{DwellConfig, StationCollector, refine, solve_stations};

use super::pod::{Instrument, Pod};

/// Bar length of the SSM, mm.
pub const BAR_LENGTH_MM: f64 = 150.0;
/// Station directions from the socket (normalised in use): three azimuths 120° apart, 16.7°
/// above the horizontal, as seed 000 §3 places the stations around the socket.
const STATION_DIRS: [[f64; 3]; 3] = [[1.0, 0.0, 0.3], [-0.5, 0.866, 0.3], [-0.5, -0.866, 0.3]];
/// Samples the machine dwells at each station (1 kHz: 0.4 s, of which 0.1 s settle).
const DWELL_SAMPLES: usize = 400;
/// Feed between stations, mm/min.
const FEED_MM_PER_MIN: f64 = 2000.0;

/// Standard uncertainty of a station's ΔL that dwelling does not average away, µm: at a fixed
/// position the 12-bit quantisation of the LVDT secondaries gives the same error in every
/// block (up to ≈ 0.12 µm, `acquisition_rtest_head.rs`), and the encoders count 0.1 µm.
const FIXED_POSITION_U_UM: f64 = 0.1;

/// An SSM measurement: E and its standard uncertainty.
#[derive(Clone, Copy, Debug)]
pub struct SsmMeasurement {
    /// E = actual − nominal tool-ball centre, µm.
    pub e_um: [f64; 3],
    /// Standard uncertainty of each component of E, µm: the stations' ΔL uncertainty (the
    /// largest standard error of the mean, combined with the fixed-position term
    /// `FIXED_POSITION_U_UM`) times the RMS gain cond/3 of the unit-direction inverse
    /// (‖U⁺‖_F = cond/√3 for three unit rows).
    pub std_um: f64,
}

/// The simulated pod doing SSM measurements, one after the other in virtual time.
pub struct SsmRig {
    pod: Pod,
    /// Where the machine is (nominal tool point, mm); `None` before the first measurement.
    at: Option<[f64; 3]>,
}

impl SsmRig {
    /// A pod with a 150 mm bar, bar noise σ `noise_um` per sample and noise seed `seed`.
    pub fn new(noise_um: f64, seed: u64) -> Self {
        let inst = Instrument {
            bar_noise_um: noise_um,
            ..Instrument::default()
        };
        Self {
            pod: Pod::new(BAR_LENGTH_MM, &inst, seed),
            at: None,
        }
    }

    /// Measures E at the nominal tool point `nominal_mm` whose ball is actually at
    /// `actual_mm`: socket at `nominal − L·ẑ`, three stations, the core's station collector
    /// and solver.
    pub fn measure(
        &mut self,
        nominal_mm: [f64; 3],
        actual_mm: [f64; 3],
    ) -> Result<SsmMeasurement, String> {
        let l = BAR_LENGTH_MM;
        let e = [0, 1, 2].map(|i| actual_mm[i] - nominal_mm[i]);
        let socket = [nominal_mm[0], nominal_mm[1], nominal_mm[2] - l];
        let stations: Vec<[f64; 3]> = STATION_DIRS
            .iter()
            .map(|u| {
                let n = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
                [0, 1, 2].map(|i| socket[i] + l * u[i] / n)
            })
            .collect();
        let axes = |p: [f64; 3]| -> [f64; MAX_AXES] { [p[0], p[1], p[2], 0.0, 0.0] };
        let dl_um = |p: [f64; 3]| {
            let q = [0, 1, 2].map(|i| p[i] + e[i] - socket[i]);
            ((q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt() - l) * 1e3
        };
        let step_mm = FEED_MM_PER_MIN / 60.0 / self.pod.config.sample_rate_hz as f64;
        match self.at {
            None => self.pod.reference(&axes(stations[0])),
            // the transfer to the new socket with the bar lifted off (the LVDT at rest, ΔL
            // reads the free length: 0 µm); the collector of this measurement is not fed yet
            Some(from) => {
                let d = [0, 1, 2].map(|i| stations[0][i] - from[i]);
                let n = ((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() / step_mm).ceil();
                for j in 1..=n as usize {
                    let p = [0, 1, 2].map(|i| from[i] + d[i] * j as f64 / n);
                    self.pod.sample(0.0, &axes(p));
                }
            }
        }
        let mut collector = StationCollector::<4>::new(DwellConfig {
            max_speed_mm_per_s: 1.0,
            max_rotary_speed_deg_per_s: 0.1,
            settle_us: 100_000,
            min_samples: 100,
        });
        let mut at = stations[0];
        // the path: dwell at each station, move to the next, then move off to close the dwell
        let mut path = stations.clone();
        path.push([at[0], at[1], at[2] + 5.0]);
        for (k, target) in path.iter().enumerate() {
            let d = [0, 1, 2].map(|i| target[i] - at[i]);
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let n = (len / step_mm).ceil() as usize;
            for j in 1..=n {
                let p = [0, 1, 2].map(|i| at[i] + d[i] * j as f64 / n as f64);
                collector.update(&self.pod.sample(dl_um(p), &axes(p)));
            }
            at = *target;
            if k < stations.len() {
                for _ in 0..DWELL_SAMPLES {
                    collector.update(&self.pod.sample(dl_um(at), &axes(at)));
                }
            }
        }
        collector.finish();
        self.at = Some(at);
        let st = collector.stations();
        if st.len() != 3 {
            return Err(format!(
                "SSM: {} stations detected (3 dwelt; {} too short, {} skipped samples)",
                st.len(),
                collector.dropped_short(),
                collector.skipped()
            ));
        }
        let geom = SsmGeometry {
            socket_mm: socket,
            bar_length_mm: l,
        };
        // eq 1 is linear in E; a rotary-axis error moves the tool point by up to a few hundred
        // µm, where the |E|²/2L linearisation error reaches 0.1 µm: refined on the exact
        // sphere equations (seed 000 B.2 item 4)
        let sol = solve_stations(st, &geom)
            .and_then(|s0| refine(st, &geom, &s0, 10))
            .map_err(|e| format!("SSM: {e:?}"))?;
        let [Some(ex), Some(ey), Some(ez)] = sol.e_um else {
            return Err("SSM: a component of E is not observable".into());
        };
        let sem = st
            .iter()
            .map(|s| f64::from(s.std_um) / f64::from(s.samples.max(1)).sqrt())
            .fold(0.0, f64::max);
        let u_station = sem.hypot(FIXED_POSITION_U_UM);
        Ok(SsmMeasurement {
            e_um: [ex, ey, ez],
            std_um: u_station * sol.cond / 3.0,
        })
    }
}
