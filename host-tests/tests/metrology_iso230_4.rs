//! ISO 230-4 figures and ball-bar diagnostics (issue 3 item 3) against a forward model of the
//! ball bar on a machine with injected squareness, scale mismatch, backlash and cyclic error.
//! Expected sizes come from the injected parameters and closed-form consequences, never from
//! the code under test.

use ballpod::acquisition::{Sample, SampleFlags};
use ballpod::metrology::circle_fit::{CircleFitConfig, CircleFitError};
use ballpod::metrology::iso230_4::{CircularTest, Direction, IsoError, mean_diagnostics};
use ballpod::metrology::pattern::{PatternGeometry, Plane, Sensitivity};
use ballpod_host::oracle::Rng;

#[derive(Clone, Copy, Default)]
struct Machine {
    /// E_x = S·(y − y0), rad
    squareness: f64,
    /// E_x = kx·(x − x0), E_y = ky·(y − y0)
    kx: f64,
    ky: f64,
    /// lost motion, mm: E = −sign(v)·B/2
    bx: f64,
    by: f64,
    /// radial cyclic term, µm, order
    cyc_amp_um: f64,
    cyc_order: u32,
    noise_um: f64,
}

const P0: [f64; 2] = [-215.0, 377.5];
const R: f64 = 150.0;

fn run(m: &Machine, dir: Direction, n: usize, rng: &mut Rng) -> Vec<Sample> {
    let d = match dir {
        Direction::Ccw => 1.0,
        Direction::Cw => -1.0,
    };
    (0..n)
        .map(|i| {
            // start at 7° so no sample sits exactly on an axis crossing
            let th = (7.0 + d * 360.0 * (i as f64 + 0.5) / n as f64).to_radians();
            let (s, c) = th.sin_cos();
            let (rx, ry) = (R * c, R * s);
            let ex = m.squareness * ry + m.kx * rx + d * s.signum() * m.bx / 2.0;
            let ey = m.ky * ry - d * c.signum() * m.by / 2.0;
            let len = ((rx + ex).powi(2) + (ry + ey).powi(2)).sqrt();
            let dl = (len - R) * 1e3
                + m.cyc_amp_um * (m.cyc_order as f64 * th + 0.3).cos()
                + m.noise_um * rng.normal();
            Sample {
                seq: i as u32,
                t_us: i as u64 * 500,
                delta_l_um: dl as f32,
                axes: [(P0[0] + rx) as f32, (P0[1] + ry) as f32, 88.0, 0.0, 0.0],
                temp_c: 20.0,
                flags: SampleFlags::NONE,
            }
        })
        .collect()
}

fn test_of(m: &Machine) -> CircularTest<360> {
    let mut t = CircularTest::<360>::new(
        CircleFitConfig {
            geometry: PatternGeometry {
                plane: Plane::XY,
                centre_u_mm: P0[0] as f32,
                centre_v_mm: P0[1] as f32,
                sensitivity: Sensitivity::Outward,
            },
            min_arc_deg: 300.0,
        },
        R as f32,
    );
    let mut rng = Rng::new(99);
    for dir in [Direction::Ccw, Direction::Cw] {
        for s in run(m, dir, 7200, &mut rng) {
            t.update(&s, dir);
        }
    }
    t
}

fn close(got: f32, want: f64, rel: f64, what: &str) {
    assert!(
        (got as f64 - want).abs() <= rel * want.abs(),
        "{what}: got {got}, want {want} ± {}%",
        rel * 100.0
    );
}

#[test]
fn squareness_shows_as_45deg_ovality() {
    let m = Machine {
        squareness: 20e-6,
        ..Default::default()
    };
    let t = test_of(&m);
    for dir in [Direction::Ccw, Direction::Cw] {
        let dg = t.diagnostics(dir).unwrap();
        close(dg.squareness_urad, 20.0, 0.05, "squareness");
        assert!(dg.scale_mismatch_um_per_m.abs() < 1.0, "{dg:?}"); // 5 % of the 20 µrad ovality
        assert!(dg.reversal_step_u_um.abs() < 0.05 && dg.reversal_step_v_um.abs() < 0.05);
        let f = t.direction_figures(dir).unwrap();
        // ΔL = (R S / 2) sin 2θ: G = R·S = 3 µm, F = ±1.5 µm
        close(f.circular_deviation_g_um, R * 20e-6 * 1e3, 0.02, "G");
        close(f.radial_deviation_f_max_um, 1.5, 0.02, "F_max");
        close(f.radial_deviation_f_min_um, -1.5, 0.02, "F_min");
    }
    let b = t.bidirectional_figures().unwrap();
    assert!(
        b.circular_hysteresis_h_um < 0.01,
        "H {}",
        b.circular_hysteresis_h_um
    );
    close(b.bidirectional_circular_deviation_um, 3.0, 0.02, "G(b)");
}

#[test]
fn scale_mismatch_shows_as_0_90deg_ovality() {
    let m = Machine {
        kx: 15e-6,
        ky: 5e-6,
        ..Default::default()
    };
    let t = test_of(&m);
    let dg = mean_diagnostics(
        &t.diagnostics(Direction::Ccw).unwrap(),
        &t.diagnostics(Direction::Cw).unwrap(),
    );
    close(dg.scale_mismatch_um_per_m, 10.0, 0.05, "scale mismatch");
    assert!(dg.squareness_urad.abs() < 0.5);
    assert!(dg.reversal_step_u_um.abs() < 0.05 && dg.reversal_step_v_um.abs() < 0.05);
    // mean radius change R(kx + ky)/2 = 1.5 µm
    close(
        t.bidirectional_figures()
            .unwrap()
            .mean_bidirectional_radial_deviation_um,
        1.5,
        0.02,
        "mean radial",
    );
}

#[test]
fn backlash_shows_as_reversal_steps_and_hysteresis() {
    let m = Machine {
        bx: 4e-3,
        by: 2e-3,
        ..Default::default()
    };
    let t = test_of(&m);
    for dir in [Direction::Ccw, Direction::Cw] {
        let dg = t.diagnostics(dir).unwrap();
        close(dg.reversal_step_u_um, 4.0, 0.05, "B_x");
        close(dg.reversal_step_v_um, 2.0, 0.05, "B_y");
        assert!(
            dg.squareness_urad.abs() < 0.5 && dg.scale_mismatch_um_per_m.abs() < 0.5,
            "{dg:?}"
        );
    }
    // CW − CCW = ±(B_x cos θ sgn sin θ − B_y sin θ sgn cos θ): H = max(B_x, B_y); G(b) likewise
    let b = t.bidirectional_figures().unwrap();
    close(b.circular_hysteresis_h_um, 4.0, 0.02, "H");
    close(b.bidirectional_circular_deviation_um, 4.0, 0.02, "G(b)");
}

#[test]
fn all_together_with_noise_each_in_its_diagnostic() {
    let m = Machine {
        squareness: -35e-6,
        kx: -8e-6,
        ky: 4e-6,
        bx: 3e-3,
        by: 5e-3,
        cyc_amp_um: 0.6,
        cyc_order: 7,
        noise_um: 0.2,
    };
    let t = test_of(&m);
    let dg = mean_diagnostics(
        &t.diagnostics(Direction::Ccw).unwrap(),
        &t.diagnostics(Direction::Cw).unwrap(),
    );
    println!("{dg:?}");
    close(dg.squareness_urad, -35.0, 0.05, "squareness");
    close(dg.scale_mismatch_um_per_m, -12.0, 0.05, "scale mismatch");
    close(dg.reversal_step_u_um, 3.0, 0.05, "B_x");
    close(dg.reversal_step_v_um, 5.0, 0.05, "B_y");
    close(dg.cyclic_amplitude_um, 0.6, 0.05, "cyclic amplitude");
    assert_eq!(dg.cyclic_order, 7);
}

#[test]
fn not_available_states() {
    let m = Machine::default();
    let mut t = CircularTest::<360>::new(
        CircleFitConfig {
            geometry: PatternGeometry {
                plane: Plane::XY,
                centre_u_mm: P0[0] as f32,
                centre_v_mm: P0[1] as f32,
                sensitivity: Sensitivity::Outward,
            },
            min_arc_deg: 60.0,
        },
        R as f32,
    );
    assert_eq!(
        t.direction_figures(Direction::Ccw),
        Err(IsoError::Fit(CircleFitError::NotEnoughSamples { have: 0 }))
    );
    assert_eq!(t.bidirectional_figures(), Err(IsoError::MissingDirection));
    let mut rng = Rng::new(1);
    let s = run(&m, Direction::Ccw, 720, &mut rng);
    for x in &s[..200] {
        t.update(x, Direction::Ccw); // 100°: a fit, but not every quadrant
    }
    assert!(t.direction_figures(Direction::Ccw).is_ok());
    assert_eq!(t.diagnostics(Direction::Ccw), Err(IsoError::NotFullCircle));
    assert_eq!(t.bidirectional_figures(), Err(IsoError::MissingDirection));
    let mut bad = s[300];
    bad.flags = SampleFlags::LVDT_OVER_RANGE;
    t.update(&bad, Direction::Cw);
    assert_eq!(t.fit(Direction::Cw).skipped_flagged(), 1);
    assert_eq!(t.bidirectional_figures(), Err(IsoError::MissingDirection));
}
