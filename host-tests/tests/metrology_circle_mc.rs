//! Statistical efficiency of the running limaçon fit (issue 3 "Done when"): 200 Monte-Carlo runs,
//! σ = 0.5 µm white noise on ΔL, full circle. Expectations from theory, not from the core:
//! for N uniformly spaced samples the least-squares e_x has variance 2σ²/N.

use ballpod::acquisition::{Sample, SampleFlags};
use ballpod::metrology::circle_fit::{CircleFit, CircleFitConfig};
use ballpod::metrology::pattern::{ArcGeometry, Plane, Sensitivity};
use ballpod_host::oracle::Rng;

#[test]
fn monte_carlo_efficiency_and_reported_uncertainty() {
    const RUNS: usize = 200;
    const N: usize = 3600;
    const SIGMA: f64 = 0.5;
    let (cx, cy, r) = (612.0f64, -288.5f64, 150.0f64);
    let e_true = [23.0f64, -41.0f64];
    let mut rng = Rng::new(42);
    let (mut ss_ex, mut ss_ey, mut sum_u_ex, mut ss_r0) = (0.0, 0.0, 0.0, 0.0);
    let mut sum_rms = 0.0;
    for _ in 0..RUNS {
        let mut f = CircleFit::new(CircleFitConfig {
            geometry: ArcGeometry {
                plane: Plane::XY,
                centre_u_mm: cx as f32,
                centre_v_mm: cy as f32,
                sensitivity: Sensitivity::Outward,
            },
            min_arc_deg: 60.0,
        });
        let phase = rng.range(0.0, 360.0);
        for i in 0..N {
            let th = (phase + 360.0 * i as f64 / N as f64).to_radians();
            let (s, c) = th.sin_cos();
            let dl = e_true[0] * c + e_true[1] * s + 5.0 + SIGMA * rng.normal();
            f.update(&Sample {
                seq: i as u32,
                t_us: 0,
                delta_l_um: dl as f32,
                axes: [(cx + r * c) as f32, (cy + r * s) as f32, 0.0, 0.0, 0.0],
                temp_c: 20.0,
                flags: SampleFlags::NONE,
            });
        }
        let est = f.estimate().unwrap();
        ss_ex += (est.e_um[0] as f64 - e_true[0]).powi(2);
        ss_ey += (est.e_um[1] as f64 - e_true[1]).powi(2);
        ss_r0 += (est.r0_um as f64 - 5.0).powi(2);
        sum_u_ex += est.u_e_um[0] as f64;
        sum_rms += est.residual_rms_um as f64;
    }
    let theory = (2.0 * SIGMA * SIGMA / N as f64).sqrt();
    let rms_ex = (ss_ex / RUNS as f64).sqrt();
    let rms_ey = (ss_ey / RUNS as f64).sqrt();
    let rms_r0 = (ss_r0 / RUNS as f64).sqrt();
    let mean_u = sum_u_ex / RUNS as f64;
    println!(
        "theory {theory:.5} µm; RMS e_x {rms_ex:.5}, e_y {rms_ey:.5}; mean reported u(e_x) {mean_u:.5}; \
         RMS r0 {rms_r0:.5} (theory {:.5}); mean residual RMS {:.4}",
        SIGMA / (N as f64).sqrt(),
        sum_rms / RUNS as f64
    );
    assert!(
        (rms_ex / theory - 1.0).abs() < 0.10,
        "RMS e_x {rms_ex} vs {theory}"
    );
    assert!(
        (rms_ey / theory - 1.0).abs() < 0.10,
        "RMS e_y {rms_ey} vs {theory}"
    );
    assert!(
        (mean_u / rms_ex - 1.0).abs() < 0.20,
        "reported u {mean_u} vs spread {rms_ex}"
    );
    assert!(
        (mean_u / theory - 1.0).abs() < 0.05,
        "reported u {mean_u} vs theory {theory}"
    );
    assert!((sum_rms / RUNS as f64 / SIGMA - 1.0).abs() < 0.02);
}

#[test]
fn monte_carlo_reported_uncertainty_on_a_90deg_arc() {
    // On a 90° arc the normal matrix is far from diagonal (e and r0 correlate strongly): the
    // reported u must still match the empirical spread (within 20 %).
    const RUNS: usize = 200;
    const N: usize = 900;
    const SIGMA: f64 = 0.5;
    let (cx, cz, r) = (-140.0f64, 655.0f64, 356.3945f64);
    let mut rng = Rng::new(4242);
    let (mut ss, mut su) = ([0.0f64; 3], [0.0f64; 3]);
    for _ in 0..RUNS {
        let mut f = CircleFit::new(CircleFitConfig {
            geometry: ArcGeometry {
                plane: Plane::XZ,
                centre_u_mm: cx as f32,
                centre_v_mm: cz as f32,
                sensitivity: Sensitivity::Outward,
            },
            min_arc_deg: 60.0,
        });
        for i in 0..N {
            // BX-like arc: n = (sin φ, cos φ), φ 0..90°
            let phi = (90.0 * i as f64 / (N - 1) as f64).to_radians();
            let (s, c) = phi.sin_cos();
            let dl = -51.7 * s - 41.6 * c + 2.0 + SIGMA * rng.normal();
            f.update(&Sample {
                seq: i as u32,
                t_us: 0,
                delta_l_um: dl as f32,
                axes: [
                    (cx + r * s) as f32,
                    0.0,
                    (cz + r * c) as f32,
                    phi.to_degrees() as f32,
                    0.0,
                ],
                temp_c: 20.0,
                flags: SampleFlags::NONE,
            });
        }
        let e = f.estimate().unwrap();
        let err = [
            e.r0_um as f64 - 2.0,
            e.e_um[0] as f64 + 51.7,
            e.e_um[1] as f64 + 41.6,
        ];
        let u = [e.u_r0_um as f64, e.u_e_um[0] as f64, e.u_e_um[1] as f64];
        for k in 0..3 {
            ss[k] += err[k] * err[k];
            su[k] += u[k];
        }
    }
    for k in 0..3 {
        let spread = (ss[k] / RUNS as f64).sqrt();
        let rep = su[k] / RUNS as f64;
        println!("param {k}: empirical {spread:.4} µm, reported {rep:.4} µm");
        assert!(
            (rep / spread - 1.0).abs() < 0.2,
            "param {k}: reported {rep} vs spread {spread}"
        );
        // a 90° arc is much weaker than a full circle
        assert!(rep > 3.0 * (2.0 * SIGMA * SIGMA / N as f64).sqrt());
    }
}
