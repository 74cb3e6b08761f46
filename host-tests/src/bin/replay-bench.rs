//! `cargo replay-bench`: host throughput of the per-sample metrology path on a logged run.
//!
//! Replay (issue 6 item 4): acquisition is upstream of the log, so replaying a log means running
//! the per-sample metrology path on its samples — the ISO 230-4 trackers with their running
//! circle fit ([`CircularTest::update`]) and the streaming SSM ([`StreamingSsm::update`]), as the
//! replay tool does. The log is 10^6 samples of ball-bar circles (CCW then CW, 0.01° apart, about
//! the socket, with a centre offset, ovality and noise from [`Rng`]), built in memory first so
//! only the metrology is timed. Prints samples per second (best of `--repeat` runs, default 5)
//! and the estimates as a check. A benchmark, not a test: nothing fails on speed.
//!
//! Options: `--samples N` (default 1 000 000), `--repeat N` (default 5).
use std::hint::black_box;
use std::time::Instant;

use ballpod::acquisition::{Sample, SampleFlags};
use ballpod::metrology::circle_fit::CircleFitConfig;
use ballpod::metrology::iso230_4::{CircularTest, Direction};
use ballpod::metrology::pattern::{ArcGeometry, Plane, Sensitivity};
use ballpod::metrology::ssm::SsmGeometry;
use ballpod::metrology::ssm::streaming::{StreamingConfig, StreamingSsm};
use ballpod_host::rng::Rng;

const BAR_MM: f64 = 150.0;
const SOCKET_MM: [f64; 3] = [100.0, 50.0, 0.0];
const E_UM: [f64; 2] = [3.0, -2.0];
/// Samples per revolution (0.01°).
const PER_REV: usize = 36_000;

/// Host throughput of the per-sample metrology path replaying a logged run.
#[derive(clap::Parser, Debug)]
#[command(name = "cargo replay-bench", version)]
struct Args {
    /// Samples in the log.
    #[arg(long, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(1..))]
    samples: u64,
    /// Timed repeats (the best is reported).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(1..))]
    repeat: u64,
}

/// The log: half the samples CCW, half CW.
fn log(n: usize) -> Vec<(Sample, Direction)> {
    let mut rng = Rng::new(6);
    (0..n)
        .map(|i| {
            let ccw = i < n / 2;
            let step = (i % PER_REV) as f64 / PER_REV as f64;
            let th = 2.0 * std::f64::consts::PI * if ccw { step } else { 1.0 - step };
            let dl = 0.5
                + E_UM[0] * th.cos()
                + E_UM[1] * th.sin()
                + 0.3 * (2.0 * th).cos()
                + 0.1 * rng.normal();
            let s = Sample {
                seq: i as u32,
                t_us: i as u64 * 1000,
                delta_l_um: dl as f32,
                axes: [
                    (SOCKET_MM[0] + BAR_MM * th.cos()) as f32,
                    (SOCKET_MM[1] + BAR_MM * th.sin()) as f32,
                    SOCKET_MM[2] as f32,
                    0.0,
                    0.0,
                ],
                temp_c: 20.0,
                flags: SampleFlags::NONE,
            };
            (s, if ccw { Direction::Ccw } else { Direction::Cw })
        })
        .collect()
}

fn main() {
    let args: Args = ballpod_host::cli::parse();
    let (n, repeat) = (args.samples as usize, args.repeat as usize);
    let samples = log(n);
    let fit_cfg = CircleFitConfig {
        geometry: ArcGeometry {
            plane: Plane::XY,
            centre_u_mm: SOCKET_MM[0] as f32,
            centre_v_mm: SOCKET_MM[1] as f32,
            sensitivity: Sensitivity::Outward,
        },
        min_arc_deg: 60.0,
    };
    let ssm_cfg = StreamingConfig {
        geometry: SsmGeometry {
            socket_mm: SOCKET_MM,
            bar_length_mm: BAR_MM,
        },
        radius_mm: 5.0,
        rotary_tol_deg: 0.001,
    };
    let mut best = f64::INFINITY;
    let mut last = None;
    for _ in 0..repeat {
        let mut iso = Box::new(CircularTest::<360>::new(fit_cfg, BAR_MM as f32));
        let mut ssm = Box::new(StreamingSsm::<256>::new(ssm_cfg));
        let t0 = Instant::now();
        for (s, d) in &samples {
            black_box(iso.update(black_box(s), *d));
            black_box(ssm.update(black_box(s)));
        }
        best = best.min(t0.elapsed().as_secs_f64());
        last = Some((iso, ssm));
    }
    println!(
        "replay of {n} logged samples (ISO 230-4 trackers + circle fit + streaming SSM), release, one core"
    );
    println!(
        "best of {repeat}: {:.3} ms, {:.2} million samples per second ({:.1} ns per sample); target >= 5 million: {}",
        best * 1e3,
        n as f64 / best / 1e6,
        best / n as f64 * 1e9,
        if n as f64 / best >= 5e6 {
            "met"
        } else {
            "MISSED"
        }
    );
    if let Some((iso, ssm)) = last {
        match iso.direction_figures(Direction::Ccw, 0.0) {
            Ok(f) => println!(
                "check: CCW eccentricity ({:.3}, {:.3}) um (truth {:?}), G {:.3} um",
                f.fit.e_um[0], f.fit.e_um[1], E_UM, f.circular_deviation_g_um.value
            ),
            Err(e) => println!("check: no CCW figures: {e:?}"),
        }
        println!("check: streaming SSM window {} samples", ssm.window_len());
    }
}
