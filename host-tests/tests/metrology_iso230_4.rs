//! ISO 230-4 figures and ball-bar diagnostics (issue 3 item 3) against a forward model of the
//! ball bar on a machine with injected squareness, scale mismatch, backlash and cyclic error.
//! Expected sizes come from the injected parameters and closed-form consequences, never from
//! the code under test.

use ballpod::acquisition::{Sample, SampleFlags};
use ballpod::app::circle::servo_mismatch_ms;
use ballpod::metrology::circle_fit::{CircleFitConfig, CircleFitError};
use ballpod::metrology::iso230_4::{
    CircularTest, Diagnosed, Diagnosis, Direction, IsoError, mean_diagnostics,
};
use ballpod::metrology::pattern::{ArcGeometry, Plane, Sensitivity};
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
    /// its phase φ: cyc_amp_um·cos(kθ + φ)
    cyc_phase: f64,
    noise_um: f64,
    /// circle radius, mm (0: [`R`])
    radius: f64,
    /// the socket's ball off the centre the machine circles about (P0), mm: the bar reads
    /// its length from there (e = −socket)
    socket_mm: [f64; 2],
}

impl Machine {
    fn r(&self) -> f64 {
        if self.radius > 0.0 { self.radius } else { R }
    }
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
            let r = m.r();
            let (rx, ry) = (r * c, r * s);
            let ex = m.squareness * ry + m.kx * rx + d * s.signum() * m.bx / 2.0;
            let ey = m.ky * ry - d * c.signum() * m.by / 2.0;
            let [sx, sy] = m.socket_mm;
            let len = ((rx + ex - sx).powi(2) + (ry + ey - sy).powi(2)).sqrt();
            let dl = (len - r) * 1e3
                + m.cyc_amp_um * (m.cyc_order as f64 * th + m.cyc_phase).cos()
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
    test_seeded(m, 99)
}

/// An ISO 230-4 test of a circle of radius `r` mm about P0 in XY (1° bins).
fn empty_test(r: f64) -> CircularTest<360> {
    test_about(P0, r, 300.0)
}

/// An ISO 230-4 test of a circle of radius `r` mm about `centre` in XY (1° bins), e observable
/// from `min_arc_deg` of arc.
fn test_about(centre: [f64; 2], r: f64, min_arc_deg: f32) -> CircularTest<360> {
    test_sensing(centre, r, min_arc_deg, Sensitivity::Outward)
}

/// [`test_about`] with the pattern's `sensitivity`.
fn test_sensing(
    centre: [f64; 2],
    r: f64,
    min_arc_deg: f32,
    sensitivity: Sensitivity,
) -> CircularTest<360> {
    CircularTest::<360>::new(
        CircleFitConfig {
            geometry: ArcGeometry {
                plane: Plane::XY,
                centre_u_mm: centre[0] as f32,
                centre_v_mm: centre[1] as f32,
                sensitivity,
            },
            min_arc_deg,
        },
        r as f32,
    )
}

fn test_seeded(m: &Machine, seed: u64) -> CircularTest<360> {
    let mut t = empty_test(m.r());
    let mut rng = Rng::new(seed);
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
        let dg = t.diagnostics(dir, 0.0).unwrap();
        close(
            dg.get(Diagnosis::Squareness).value,
            20.0,
            0.05,
            "squareness",
        );
        assert!(dg.get(Diagnosis::ScaleMismatch).value.abs() < 1.0, "{dg:?}"); // 5 % of the 20 µrad ovality
        assert!(
            dg.get(Diagnosis::ReversalU).value.abs() < 0.05
                && dg.get(Diagnosis::ReversalV).value.abs() < 0.05
        );
        let f = t.direction_figures(dir, 0.0).unwrap();
        // ΔL = (R S / 2) sin 2θ: G = R·S = 3 µm, F = ±1.5 µm
        close(f.circular_deviation_g_um.value, R * 20e-6 * 1e3, 0.02, "G");
        close(f.radial_deviation_f_max_um.value, 1.5, 0.02, "F_max");
        close(f.radial_deviation_f_min_um.value, -1.5, 0.02, "F_min");
    }
    let b = t.bidirectional_figures(0.0).unwrap();
    assert!(
        b.circular_hysteresis_h_um.value < 0.01,
        "H {}",
        b.circular_hysteresis_h_um.value
    );
    close(
        b.bidirectional_circular_deviation_um.value,
        3.0,
        0.02,
        "G(b)",
    );
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
        &t.diagnostics(Direction::Ccw, 0.0).unwrap(),
        &t.diagnostics(Direction::Cw, 0.0).unwrap(),
    );
    close(
        dg.get(Diagnosis::ScaleMismatch).value,
        10.0,
        0.05,
        "scale mismatch",
    );
    assert!(dg.get(Diagnosis::Squareness).value.abs() < 0.5);
    assert!(
        dg.get(Diagnosis::ReversalU).value.abs() < 0.05
            && dg.get(Diagnosis::ReversalV).value.abs() < 0.05
    );
    // mean radius change R(kx + ky)/2 = 1.5 µm
    close(
        t.bidirectional_figures(0.0)
            .unwrap()
            .mean_bidirectional_radial_deviation_um
            .value,
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
        let dg = t.diagnostics(dir, 0.0).unwrap();
        close(dg.get(Diagnosis::ReversalU).value, 4.0, 0.05, "B_x");
        close(dg.get(Diagnosis::ReversalV).value, 2.0, 0.05, "B_y");
        assert!(
            dg.get(Diagnosis::Squareness).value.abs() < 0.5
                && dg.get(Diagnosis::ScaleMismatch).value.abs() < 0.5,
            "{dg:?}"
        );
    }
    // CW − CCW = ±(B_x cos θ sgn sin θ − B_y sin θ sgn cos θ): H = max(B_x, B_y); G(b) likewise
    let b = t.bidirectional_figures(0.0).unwrap();
    close(b.circular_hysteresis_h_um.value, 4.0, 0.02, "H");
    close(
        b.bidirectional_circular_deviation_um.value,
        4.0,
        0.02,
        "G(b)",
    );
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
        cyc_phase: 0.3,
        noise_um: 0.2,
        radius: 0.0,
        socket_mm: [0.0; 2],
    };
    let t = test_of(&m);
    let dg = mean_diagnostics(
        &t.diagnostics(Direction::Ccw, 0.0).unwrap(),
        &t.diagnostics(Direction::Cw, 0.0).unwrap(),
    );
    println!("{dg:?}");
    close(
        dg.get(Diagnosis::Squareness).value,
        -35.0,
        0.05,
        "squareness",
    );
    close(
        dg.get(Diagnosis::ScaleMismatch).value,
        -12.0,
        0.05,
        "scale mismatch",
    );
    close(dg.get(Diagnosis::ReversalU).value, 3.0, 0.05, "B_x");
    close(dg.get(Diagnosis::ReversalV).value, 5.0, 0.05, "B_y");
    close(
        dg.get(Diagnosis::Cyclic).value,
        0.6,
        0.05,
        "cyclic amplitude",
    );
    assert_eq!(dg.named_cyclic_order(), Some(7));
}

#[test]
fn not_available_states() {
    let m = Machine::default();
    let mut t = test_about(P0, R, 60.0);
    assert_eq!(
        t.direction_figures(Direction::Ccw, 0.0),
        Err(IsoError::Fit(CircleFitError::NotEnoughSamples { have: 0 }))
    );
    assert_eq!(
        t.bidirectional_figures(0.0),
        Err(IsoError::MissingDirection)
    );
    let mut rng = Rng::new(1);
    let s = run(&m, Direction::Ccw, 720, &mut rng);
    for x in &s[..200] {
        t.update(x, Direction::Ccw); // 100°: a fit, but not every quadrant
    }
    assert!(t.direction_figures(Direction::Ccw, 0.0).is_ok());
    assert_eq!(
        t.diagnostics(Direction::Ccw, 0.0),
        Err(IsoError::NotFullCircle)
    );
    assert_eq!(
        t.bidirectional_figures(0.0),
        Err(IsoError::MissingDirection)
    );
    let mut bad = s[300];
    bad.flags = SampleFlags::LVDT_OVER_RANGE;
    t.update(&bad, Direction::Cw);
    assert_eq!(t.fit(Direction::Cw).skipped_flagged(), 1);
    assert_eq!(
        t.bidirectional_figures(0.0),
        Err(IsoError::MissingDirection)
    );
}

/// The injected faults of `m` as the diagnoses report them: squareness µrad, scale mismatch
/// µm/m, reversal steps µm (first-order consequences of the forward model's parameters).
fn truth(m: &Machine) -> [f64; 4] {
    [
        m.squareness * 1e6,
        (m.kx - m.ky) * 1e6,
        m.bx * 1e3,
        m.by * 1e3,
    ]
}

fn reported(dg: &ballpod::metrology::iso230_4::Diagnostics) -> [(f32, f32); 4] {
    [
        dg.get(Diagnosis::Squareness),
        dg.get(Diagnosis::ScaleMismatch),
        dg.get(Diagnosis::ReversalU),
        dg.get(Diagnosis::ReversalV),
    ]
    .map(|d| (d.value, d.std_uncertainty))
}

/// Issue 14: a lone even-order cyclic error of a phase that the step shapes see (sin 6θ) read
/// as 19 µrad of squareness and ±1.1 µm of phantom reversal when the harmonic was looked for
/// after the other diagnoses. Fitted jointly, each reads zero within its U.
#[test]
fn even_order_cyclic_error_does_not_leak_into_squareness_or_reversal() {
    for phase in [0.0, std::f64::consts::FRAC_PI_2, 1.1] {
        let m = Machine {
            cyc_amp_um: 1.45,
            cyc_order: 6,
            cyc_phase: phase,
            noise_um: 0.2,
            radius: 100.0,
            ..Default::default()
        };
        let t = test_of(&m);
        for dir in [Direction::Ccw, Direction::Cw] {
            let dg = t.diagnostics(dir, 0.0).unwrap();
            for (i, (v, u)) in reported(&dg).into_iter().enumerate() {
                assert!(
                    v.abs() <= 2.0 * u,
                    "φ {phase}, {dir:?}, diagnosis {i}: {v} ± {u}"
                );
            }
            assert_eq!(dg.named_cyclic_order(), Some(6), "{dg:?}");
            let (a, u) = (
                dg.get(Diagnosis::Cyclic).value,
                dg.get(Diagnosis::Cyclic).std_uncertainty,
            );
            assert!(
                (f64::from(a) - 1.45).abs() <= 2.0 * f64::from(u),
                "{a} ± {u}"
            );
        }
    }
}

/// A fault-free circle names no cyclic error: noise-free (the resolution floor), and on 100
/// noisy circles at most as often as the 4u threshold lets white noise pass (≈ 1 % for the
/// two directions).
#[test]
fn fault_free_circle_names_no_cyclic_error() {
    let t = test_of(&Machine::default());
    let dg = mean_diagnostics(
        &t.diagnostics(Direction::Ccw, 0.0).unwrap(),
        &t.diagnostics(Direction::Cw, 0.0).unwrap(),
    );
    assert_eq!(dg.named_cyclic_order(), None, "{dg:?}");
    let m = Machine {
        noise_um: 0.3,
        ..Default::default()
    };
    let named = (0..100)
        .filter(|seed| {
            let t = test_seeded(&m, 1000 + seed);
            let dg = mean_diagnostics(
                &t.diagnostics(Direction::Ccw, 0.0).unwrap(),
                &t.diagnostics(Direction::Cw, 0.0).unwrap(),
            );
            dg.named_cyclic_order().is_some()
        })
        .count();
    assert!(
        named <= 3,
        "{named} of 100 fault-free circles named a cyclic error"
    );
}

/// Monte Carlo (issue 14): 800 circles with faults of random size and sign, alone and all
/// together, cyclic errors of every order 4–16 (even ones included; a third order is a straightness,
/// `ballbar_diagnoses_mc.rs`) at random phase, 0.2 µm of
/// bar noise. For each diagnosis, U = 2u covers the injected value in 95 % ± 3 % of the runs,
/// and u agrees with the empirical scatter of the errors within 20 %.
#[test]
fn monte_carlo_diagnoses_cover_the_truth_within_their_u() {
    const RUNS: usize = 800;
    let mut rng = Rng::new(20_261_125);
    // per quantity: covered count, Σ error², Σ u²
    let mut stats = [(0usize, 0.0f64, 0.0f64); 5];
    let mut order_named_right = 0;
    for run in 0..RUNS {
        let together = run % 4 == 0;
        let alone = run % 4; // 1: squareness + scale, 2: reversal, 3: cyclic
        let pick = |on: bool, x: f64| if together || on { x } else { 0.0 };
        let m = Machine {
            squareness: pick(alone == 1, rng.range(-40e-6, 40e-6)),
            kx: pick(alone == 1, rng.range(-15e-6, 15e-6)),
            ky: pick(alone == 1, rng.range(-15e-6, 15e-6)),
            bx: pick(alone == 2, rng.range(-6e-3, 6e-3)),
            by: pick(alone == 2, rng.range(-6e-3, 6e-3)),
            cyc_amp_um: pick(alone == 3, rng.range(0.5, 2.0)),
            cyc_order: 4 + (rng.next_u64() % 13) as u32,
            cyc_phase: rng.range(0.0, std::f64::consts::TAU),
            noise_um: 0.2,
            radius: rng.range(80.0, 160.0),
            socket_mm: [0.0; 2],
        };
        let t = test_seeded(&m, run as u64);
        let dg = mean_diagnostics(
            &t.diagnostics(Direction::Ccw, 0.0).unwrap(),
            &t.diagnostics(Direction::Cw, 0.0).unwrap(),
        );
        let mut got = reported(&dg).to_vec();
        let mut want = truth(&m).to_vec();
        if m.cyc_amp_um > 0.0 {
            got.push((
                dg.get(Diagnosis::Cyclic).value,
                dg.get(Diagnosis::Cyclic).std_uncertainty,
            ));
            want.push(m.cyc_amp_um);
            if dg.named_cyclic_order() == Some(m.cyc_order) {
                order_named_right += 1;
            }
        }
        for ((s, (v, u)), w) in stats.iter_mut().zip(got).zip(want) {
            let e = f64::from(v) - w;
            let u = f64::from(u);
            s.0 += usize::from(e.abs() <= 2.0 * u);
            s.1 += e * e;
            s.2 += u * u;
        }
    }
    let names = [
        "squareness",
        "scale mismatch",
        "reversal u",
        "reversal v",
        "cyclic",
    ];
    let cyclic_runs = RUNS / 2; // together + cyclic alone
    for (i, (name, (covered, e2, u2))) in names.iter().zip(stats).enumerate() {
        let n = if i == 4 { cyclic_runs } else { RUNS };
        let coverage = covered as f64 / n as f64;
        let ratio = (u2 / e2).sqrt();
        println!("{name}: coverage {coverage:.3}, rms u / rms error {ratio:.3}");
        assert!(
            (0.92..=0.98).contains(&coverage),
            "{name}: U covers the truth in {:.1} % of {n} runs",
            coverage * 100.0
        );
        assert!(
            (0.8..=1.2).contains(&ratio),
            "{name}: rms u is {ratio:.2} × the rms error"
        );
    }
    assert_eq!(order_named_right, cyclic_runs, "cyclic order named right");
}

/// F is the path's, not the noise's: on a circle of squareness 20 µrad (ΔL = ±1.5 µm) read
/// with 0.2 µm of noise per sample, 72 000 samples a run (200 a bin, as the pod's F1000 circle
/// of R 150 mm at 1 kHz has about 160), F_max and F_min lie within 0.06 µm (≈ 4 standard
/// deviations of a bin's mean) of ±1.5 µm, while the single samples' own extremes are beyond
/// by more than 0.6 µm (the forward model's samples show it).
#[test]
fn radial_deviation_f_is_the_bin_averaged_paths_not_the_noises() {
    let m = Machine {
        squareness: 20e-6,
        noise_um: 0.2,
        ..Default::default()
    };
    let mut t = empty_test(R);
    let mut rng = Rng::new(5);
    for dir in [Direction::Ccw, Direction::Cw] {
        let samples = run(&m, dir, 72_000, &mut rng);
        let raw_max = samples
            .iter()
            .map(|s| s.delta_l_um)
            .fold(f32::MIN, f32::max);
        let raw_min = samples
            .iter()
            .map(|s| s.delta_l_um)
            .fold(f32::MAX, f32::min);
        assert!(
            raw_max > 2.1 && raw_min < -2.1,
            "samples {raw_min} … {raw_max}"
        );
        for s in &samples {
            t.update(s, dir);
        }
        let f = t.direction_figures(dir, 0.0).unwrap();
        let (hi, lo) = (
            f.radial_deviation_f_max_um.value,
            f.radial_deviation_f_min_um.value,
        );
        assert!((hi - 1.5).abs() < 0.06, "{dir:?} F_max {hi}");
        assert!((lo + 1.5).abs() < 0.06, "{dir:?} F_min {lo}");
    }
}

/// The truth of one run's figures from its noise-free samples, f64, independently of the pod:
/// 1° bins from +u, the least-squares limaçon ΔL = r0 + e·n over the samples (normal
/// equations), the bins' residual and ΔL means.
struct Truth {
    /// Per bin: (residual mean about the circle, ΔL mean) of each direction, or None.
    bins: Vec<[Option<(f64, f64)>; 2]>,
}

fn limacon_lsq(samples: &[(f64, f64, f64)]) -> [f64; 3] {
    // samples (θ, ΔL, _): n = (cos θ, sin θ)
    let mut a = [[0.0f64; 3]; 3];
    let mut b = [0.0f64; 3];
    for &(th, dl, _) in samples {
        let row = [1.0, th.cos(), th.sin()];
        for i in 0..3 {
            b[i] += row[i] * dl;
            for j in 0..3 {
                a[i][j] += row[i] * row[j];
            }
        }
    }
    // Cramer's rule on the 3×3 normal equations
    let det = |m: [[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let d = det(a);
    std::array::from_fn(|k| {
        let mut m = a;
        for i in 0..3 {
            m[i][k] = b[i];
        }
        det(m) / d
    })
}

fn truth_of(runs: [&[(f64, f64, f64)]; 2], joint: bool) -> Truth {
    let fits = if joint {
        let all: Vec<_> = runs[0].iter().chain(runs[1]).copied().collect();
        let x = limacon_lsq(&all);
        [x, x]
    } else {
        [limacon_lsq(runs[0]), limacon_lsq(runs[1])]
    };
    let mut bins = vec![[None; 2]; 360];
    for (d, (run, x)) in runs.iter().zip(fits).enumerate() {
        let mut acc = vec![(0.0, 0.0, 0usize); 360];
        for &(th, dl, _) in run.iter() {
            let deg = th.to_degrees().rem_euclid(360.0);
            let k = (deg as usize).min(359);
            let r = dl - x[0] - x[1] * th.cos() - x[2] * th.sin();
            acc[k].0 += r;
            acc[k].1 += dl;
            acc[k].2 += 1;
        }
        for (k, (r, dl, n)) in acc.into_iter().enumerate() {
            if n > 0 {
                bins[k][d] = Some((r / n as f64, dl / n as f64));
            }
        }
    }
    Truth { bins }
}

/// Issue 14, ISO 230-4 figures report u: over 200 simulated circles (the forward model above,
/// random squareness, scale, reversal steps and a cyclic error of random order 3–16 and
/// random phase, a quarter of them the cyclic error alone; 0.2 µm of noise per sample, 160
/// samples a bin as an F1000 circle of R 150 mm at 1 kHz), U = 2u of G, F_max, F_min (each direction), G(b) and H covers the
/// noise-free figure of the same bins (computed here in f64) in 95 % ± 3 % of the runs, and u
/// is within 20 % of the figures' scatter about it; so does the mean bi-directional radial
/// deviation, against the noise-free joint limaçon fit.
/// The noise-free figures of machine `m` (its noise set to 0) over `n` samples a direction,
/// in f64, independently of the pod: [G ccw, F_max ccw, F_min ccw, G cw, F_max cw, F_min cw,
/// G(b), H, mean bi-directional radial deviation (the joint limaçon's r0)] and each direction's
/// limaçon fit (r0, e_u, e_v), µm.
fn noise_free_figures(m: &Machine, n: usize) -> ([f64; 9], [[f64; 3]; 2]) {
    let clean = Machine {
        noise_um: 0.0,
        ..*m
    };
    let mut runs: Vec<Vec<(f64, f64, f64)>> = Vec::new();
    for dir in [Direction::Ccw, Direction::Cw] {
        // the positions of `run`, which draws only its noise from the generator
        let mut quiet = Rng::new(0);
        runs.push(
            run(&clean, dir, n, &mut quiet)
                .iter()
                .map(|s| {
                    let (x, y) = (f64::from(s.axes[0]) - P0[0], f64::from(s.axes[1]) - P0[1]);
                    (y.atan2(x), f64::from(s.delta_l_um), 0.0)
                })
                .collect(),
        );
    }
    let per_dir = truth_of([&runs[0], &runs[1]], false);
    let joint = truth_of([&runs[0], &runs[1]], true);
    let extreme = |tr: &Truth, d: usize, f: fn(&(f64, f64)) -> f64| {
        let v: Vec<f64> = tr
            .bins
            .iter()
            .filter_map(|b| b[d].as_ref().map(f))
            .collect();
        (
            v.iter().copied().fold(f64::MIN, f64::max),
            v.iter().copied().fold(f64::MAX, f64::min),
        )
    };
    let mut t = [0.0; 9];
    for d in 0..2 {
        let (rhi, rlo) = extreme(&per_dir, d, |b| b.0);
        let (fhi, flo) = extreme(&per_dir, d, |b| b.1);
        t[3 * d..3 * d + 3].copy_from_slice(&[rhi - rlo, fhi, flo]);
    }
    let (hi0, lo0) = extreme(&joint, 0, |b| b.0);
    let (hi1, lo1) = extreme(&joint, 1, |b| b.0);
    t[6] = hi0.max(hi1) - lo0.min(lo1);
    t[7] = joint
        .bins
        .iter()
        .filter_map(|b| Some((b[0]?.0 - b[1]?.0).abs()))
        .fold(0.0, f64::max);
    let all: Vec<_> = runs[0].iter().chain(&runs[1]).copied().collect();
    t[8] = limacon_lsq(&all)[0];
    (t, [limacon_lsq(&runs[0]), limacon_lsq(&runs[1])])
}

/// The pod's figures of test `t` in [`FIGURES`] order, with the centre's shares for
/// `u_centre_um`.
fn published(t: &CircularTest<360>, u_centre_um: f32) -> Vec<Diagnosed> {
    let mut got = Vec::new();
    for dir in [Direction::Ccw, Direction::Cw] {
        let f = t.direction_figures(dir, u_centre_um).unwrap();
        got.extend([
            f.circular_deviation_g_um,
            f.radial_deviation_f_max_um,
            f.radial_deviation_f_min_um,
        ]);
    }
    let b = t.bidirectional_figures(u_centre_um).unwrap();
    got.extend([
        b.bidirectional_circular_deviation_um,
        b.circular_hysteresis_h_um,
        b.mean_bidirectional_radial_deviation_um,
    ]);
    got
}

/// The names of [`noise_free_figures`]'s figures.
const FIGURES: [&str; 9] = [
    "G ccw",
    "F_max ccw",
    "F_min ccw",
    "G cw",
    "F_max cw",
    "F_min cw",
    "G(b)",
    "H",
    "radial_bidir",
];

/// A machine of random faults: squareness, scale, reversal steps and a cyclic error of random
/// order 4–16 and phase, every fourth (`i % 4 == 0`) the cyclic error alone; 0.2 µm of noise.
fn random_machine(i: usize, rng: &mut Rng) -> Machine {
    let between = |r: &mut Rng, lo: f64, hi: f64| lo + (hi - lo) * r.uniform();
    let mut m = Machine {
        squareness: between(rng, -30e-6, 30e-6),
        kx: between(rng, -20e-6, 20e-6),
        ky: between(rng, -20e-6, 20e-6),
        bx: between(rng, 0.0, 5e-3),
        by: between(rng, 0.0, 5e-3),
        // a third order is a straightness (`ballbar_diagnoses_mc.rs`): order 3 draws read 4
        cyc_amp_um: between(rng, 0.0, 1.5),
        cyc_order: (3 + (between(rng, 0.0, 14.0) as u32).min(13)).max(4),
        cyc_phase: between(rng, 0.0, std::f64::consts::TAU),
        noise_um: 0.2,
        radius: 0.0,
        socket_mm: [0.0; 2],
    };
    if i.is_multiple_of(4) {
        (m.squareness, m.kx, m.ky, m.bx, m.by) = (0.0, 0.0, 0.0, 0.0, 0.0);
    }
    m
}

/// Coverage of U = 2u (`err`, `u`: one row per run, one column per figure `names`): each within
/// 95 % ± 3 %, and u within 20 % of the errors' scatter; the names that are not.
fn out_of_bounds<'a>(names: &[&'a str], err: &[Vec<f64>], u: &[Vec<f64>]) -> Vec<&'a str> {
    let runs = err.len() as f64;
    let mut failed = Vec::new();
    for (k, name) in names.iter().enumerate() {
        let covered = err
            .iter()
            .zip(u)
            .filter(|(e, u)| e[k].abs() <= 2.0 * u[k])
            .count();
        let coverage = covered as f64 / runs;
        let mean = err.iter().map(|e| e[k]).sum::<f64>() / runs;
        let sd = (err.iter().map(|e| (e[k] - mean).powi(2)).sum::<f64>() / (runs - 1.0)).sqrt();
        let mean_u = u.iter().map(|u| u[k]).sum::<f64>() / runs;
        println!(
            "{name:12} coverage {coverage:.3}  scatter {sd:.4}  mean u {mean_u:.4}  bias {mean:+.4}"
        );
        if !(0.92..=0.98).contains(&coverage) || !(0.8..=1.2).contains(&(sd / mean_u)) {
            failed.push(*name);
        }
    }
    failed
}

#[test]
fn iso_figures_u_covers_the_noise_free_figures_in_95_percent_of_runs() {
    const RUNS: usize = 200;
    const N: usize = 57_600;
    let mut rng = Rng::new(2026);
    let mut err = Vec::new();
    let mut u = Vec::new();
    for i in 0..RUNS {
        let m = random_machine(i, &mut rng);
        let mut t = empty_test(R);
        for dir in [Direction::Ccw, Direction::Cw] {
            for s in run(&m, dir, N, &mut rng) {
                t.update(&s, dir);
            }
        }
        let (truth, _) = noise_free_figures(&m, N);
        let got = published(&t, 0.0);
        err.push(
            got.iter()
                .zip(truth)
                .map(|(g, t)| f64::from(g.value) - t)
                .collect(),
        );
        u.push(got.iter().map(|g| f64::from(g.std_uncertainty)).collect());
    }
    let failed = out_of_bounds(&FIGURES, &err, &u);
    assert!(
        failed.is_empty(),
        "coverage or scatter/u out of bounds: {failed:?}"
    );
}

/// Issue 14, the bar's own budget (`metrology::bar_budget`): through the pod's application
/// (CIRCLE runs armed, fed and stopped on the `App`), circles of random faults as above
/// measured with a bar whose calibrated length is off by δL ~ N(0, 1 µm), whose temperature
/// reads δT ~ N(0, 0.5 K) off (L·α·δT of ΔL) and whose LVDT scale is off by k ~ N(0, 2 %), each
/// drawn per circle and applied here to the forward model's ΔL (400 circles: with 200 the
/// coverage's own scatter, 1.5 %, is half the tolerance). U = 2u of every published
/// figure (r0 and e of the CW run, G and F of each direction, G(b), H, the mean radial
/// deviation) covers the noise-free figure in 95 % ± 3 % of the runs and u is within 20 % of
/// the scatter: the radial figures by their length and temperature shares, the shape figures by
/// the scale's. Without the bar's inputs the radial figures are covered far less. The circle's
/// centre (the socket) is entered off by N(0, 0.1 mm) per coordinate from the one the machine
/// circles about in every circle, and the pod told so (`circle_u_centre` 100 µm): e takes its
/// share through the profile (the pod takes only each sample's angle about the centre, off by
/// up to 0.1/150 rad); the other figures change only to second order.
#[test]
fn bar_budget_u_covers_a_miscalibrated_bar_and_a_socket_entered_off_in_95_percent_of_runs() {
    use ballpod::acquisition::MAX_AXES;
    use ballpod::app::{App, Command, Pattern, ResultId, SessionState};
    use ballpod::config::Config;

    const RUNS: usize = 400;
    const N: usize = 57_600;
    let (u_len_um, u_temp_k, u_scale) = (1.0, 0.5, 0.02);
    let mut cfg = Config {
        bar_length_mm: R as f32,
        bar_u_length_um: u_len_um as f32,
        bar_u_temp_k: u_temp_k as f32,
        lvdt_u_scale_ppm: (u_scale * 1e6) as f32,
        ..Config::default()
    };
    cfg.setup.circle_centre_mm = [P0[0] as f32, P0[1] as f32, 88.0];
    cfg.setup.circle_radius_mm = R as f32;
    cfg.setup.circle_u_centre_um = 100.0;
    let alpha_um_per_k = R * 1e3 * f64::from(cfg.bar_cte_ppm_per_k) * 1e-6;
    let mut type_a = Config {
        bar_u_length_um: 0.0,
        bar_u_temp_k: 0.0,
        lvdt_u_scale_ppm: 0.0,
        ..cfg
    };
    type_a.setup.circle_u_centre_um = 0.0;
    let ids = [
        ResultId::GCcw,
        ResultId::FMaxCcw,
        ResultId::FMinCcw,
        ResultId::GCw,
        ResultId::FMaxCw,
        ResultId::FMinCw,
        ResultId::GBidir,
        ResultId::H,
        ResultId::RadialBidir,
        ResultId::R0,
        ResultId::EccU,
        ResultId::EccV,
    ];
    let mut names = FIGURES.to_vec();
    names.extend(["r0 cw", "e_u cw", "e_v cw"]);
    let mut rng = Rng::new(2309);
    // the socket's entry errors from a stream of their own: the other draws stay as they were
    let mut socket = Rng::new(2310);
    let (mut err, mut u, mut u_type_a) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..RUNS {
        let m = random_machine(i, &mut rng);
        let offset_um = u_len_um * rng.normal() + alpha_um_per_k * u_temp_k * rng.normal();
        let k = u_scale * rng.normal();
        // the socket entered off by N(0, 0.1 mm) per coordinate: the pod takes each sample's
        // angle about it, and that is all it takes from it
        let mut cfg = cfg;
        for (c, p) in cfg.setup.circle_centre_mm.iter_mut().zip(P0) {
            *c = (p + 0.1 * socket.normal()) as f32;
        }
        let mut app = App::new(cfg, [16; MAX_AXES]);
        // every fourth circle again without the bar's inputs (the Type A u alone)
        let mut no_bar = if i.is_multiple_of(4) {
            Some(App::new(type_a, [16; MAX_AXES]))
        } else {
            None
        };
        let mut seq = 0;
        for dir in [Direction::Ccw, Direction::Cw] {
            let samples = run(&m, dir, N, &mut rng);
            for a in std::iter::once(&mut app).chain(no_bar.as_mut()) {
                a.set_pattern(Pattern::Circle).unwrap();
                a.set_direction(dir).unwrap();
                a.execute(Command::Arm).unwrap();
                a.execute(Command::Start).unwrap();
                for (j, s) in samples.iter().enumerate() {
                    let s = Sample {
                        seq: seq + j as u32,
                        t_us: u64::from(seq + j as u32) * 500,
                        delta_l_um: ((1.0 + k) * f64::from(s.delta_l_um) + offset_um) as f32,
                        ..*s
                    };
                    a.on_sample(&s, &mut ());
                }
                a.execute(Command::Stop).unwrap();
                ballpod_host::run_jobs(a);
                assert_eq!(a.session(), SessionState::Done, "{dir:?}");
            }
            seq += N as u32;
        }
        let (truth, fits) = noise_free_figures(&m, N);
        let truth: Vec<f64> = truth.into_iter().chain(fits[1]).collect();
        let got: Vec<_> = ids.iter().map(|id| app.result(*id)).collect();
        assert!(got.iter().all(|r| r.valid), "{got:?}");
        err.push(
            got.iter()
                .zip(&truth)
                .map(|(g, t)| f64::from(g.value) - t)
                .collect::<Vec<f64>>(),
        );
        u.push(got.iter().map(|g| f64::from(g.std_uncertainty)).collect());
        if let Some(a) = &no_bar {
            let u_a: Vec<f64> = ids
                .iter()
                .map(|id| f64::from(a.result(*id).std_uncertainty))
                .collect();
            u_type_a.push((err.len() - 1, u_a));
        }
    }
    let failed = out_of_bounds(&names, &err, &u);
    assert!(
        failed.is_empty(),
        "coverage or scatter/u out of bounds: {failed:?}"
    );
    // the inputs matter: with the Type A u alone r0, F and the radial deviation are covered
    // in well under half of the runs
    for (k, name) in names.iter().enumerate() {
        let radial = name.starts_with('F') || name.starts_with('r');
        let covered = u_type_a
            .iter()
            .filter(|(run, u)| err[*run][k].abs() <= 2.0 * u[k])
            .count();
        let of = u_type_a.len();
        println!("{name:12} covered without the bar in {covered} of {of}");
        if radial {
            assert!(
                covered < of / 2,
                "{name}: {covered} of {of} covered without the bar"
            );
        }
    }
}

/// A test restarted in place (the pod restarts its one 14.3 KiB test instead of building a new
/// one on the stack) and a direction reset keep nothing of what they replace: fed the same
/// samples, they reach the state of tests built fresh, bit for bit, and the same figures.
#[test]
fn restart_and_direction_reset_forget_the_previous_samples() {
    let old = Machine {
        squareness: 40e-6,
        bx: 0.004,
        noise_um: 0.3,
        radius: 100.0,
        ..Machine::default()
    };
    let new = Machine {
        kx: 25e-6,
        by: 0.003,
        noise_um: 0.2,
        ..Machine::default()
    };
    let mut t = test_seeded(&old, 5);
    let fresh = test_seeded(&new, 6);
    let config = *fresh.fit(Direction::Ccw).config();
    t.restart(config, new.r() as f32);
    assert_eq!(t.fit(Direction::Cw).samples(), 0);
    let mut rng = Rng::new(6);
    for dir in [Direction::Ccw, Direction::Cw] {
        for s in run(&new, dir, 7200, &mut rng) {
            t.update(&s, dir);
        }
    }
    assert!(t == fresh, "a restarted test differs from a new one");
    let (got, want) = (
        t.diagnostics(Direction::Cw, 0.0),
        fresh.diagnostics(Direction::Cw, 0.0),
    );
    assert_eq!(got, want);
    assert!(
        (got.unwrap().get(Diagnosis::Squareness).value).abs() < 5.0,
        "the old squareness is gone"
    );

    // a new CW run of the same test: the CCW run stays, the old CW samples go
    let mut rng = Rng::new(7);
    let cw = run(&new, Direction::Cw, 7200, &mut rng);
    let mut reference = empty_test(new.r());
    let mut rng = Rng::new(6);
    for s in run(&new, Direction::Ccw, 7200, &mut rng) {
        reference.update(&s, Direction::Ccw);
    }
    t.reset_direction(Direction::Cw);
    for s in &cw {
        t.update(s, Direction::Cw);
        reference.update(s, Direction::Cw);
    }
    assert!(
        t == reference,
        "a reset direction kept samples of its previous run"
    );
}

/// Issue 14, the circle's centre as entered (`circle_u_centre`): the pod's share of r0 and e
/// (`CircularTest::centre_shares`, first order over the 1° bins) is u_centre × the response
/// of an independent f64 least squares of the same samples (the rows (1, n) with n about the
/// centre, nalgebra's LU of the normal equations) to the centre moved by ±0.1 mm along u and
/// along v (central differences): within 3 % on 24 random faulty circles, CCW and CW, and on
/// one with a large eccentricity (lost motion) for r0's δ·e / 2R term.
#[test]
fn the_centre_share_is_the_f64_fits_response_to_the_centre_moved() {
    use nalgebra::{Matrix3, Vector3};
    // (r0, e_u, e_v) of the samples fitted about centre `c` (mm), f64 normal equations solved
    // by nalgebra's LU
    let fit = |samples: &[Sample], c: [f64; 2]| -> [f64; 3] {
        let (mut ata, mut aty) = (Matrix3::<f64>::zeros(), Vector3::<f64>::zeros());
        for s in samples {
            let (du, dv) = (f64::from(s.axes[0]) - c[0], f64::from(s.axes[1]) - c[1]);
            let rho = du.hypot(dv);
            let row = Vector3::new(1.0, du / rho, dv / rho);
            ata += row * row.transpose();
            aty += row * f64::from(s.delta_l_um);
        }
        let x = ata.lu().solve(&aty).unwrap();
        [x[0], x[1], x[2]]
    };
    let mut rng = Rng::new(0x50c);
    let mut machines: Vec<Machine> = (0..24).map(|i| random_machine(i, &mut rng)).collect();
    machines.push(Machine {
        bx: 0.04,
        by: 0.03,
        squareness: 20e-6,
        noise_um: 0.2,
        ..Machine::default()
    });
    let h_mm = 0.1;
    let u_centre_um = 1.0;
    let mut worst = 0.0f64;
    for (i, m) in machines.iter().enumerate() {
        for dir in [Direction::Ccw, Direction::Cw] {
            let samples = run(m, dir, 7200, &mut rng);
            let mut t = empty_test(m.r());
            for s in &samples {
                t.update(s, dir);
            }
            let got = t.centre_shares(dir, u_centre_um as f32).unwrap();
            let per_um = |k: usize| -> [f64; 3] {
                let (mut plus, mut minus) = (P0, P0);
                plus[k] += h_mm;
                minus[k] -= h_mm;
                let (p, q) = (fit(&samples, plus), fit(&samples, minus));
                [0, 1, 2].map(|j| (p[j] - q[j]) / (2.0 * h_mm * 1e3))
            };
            let (su, sv) = (per_um(0), per_um(1));
            for (j, name) in ["r0", "e_u", "e_v"].iter().enumerate() {
                let want = u_centre_um * su[j].hypot(sv[j]);
                let what = format!(
                    "circle {i} {dir:?} {name}: pod {} µm, f64 fit {want:.3e} µm",
                    got[j]
                );
                assert!(
                    (f64::from(got[j]) - want).abs() <= 0.03 * want + 1e-7,
                    "{what}"
                );
                worst = worst.max((f64::from(got[j]) - want).abs() / want);
            }
        }
    }
    println!("largest relative difference {worst:.4}");
}

/// Issue 14, the circle's centre as entered: 300 random faulty circles (CCW, 14 400 samples)
/// about P0, fitted about a centre entered off by N(0, 1 mm) per coordinate, the pod told so
/// (`circle_u_centre` 1 000 µm): U = 2u of e and r0 — the fit's Type A and the centre's share
/// (`CircularTest::centre_shares`) — covers the noise-free fit about P0 in
/// 95 % ± 3 % of the circles, u within 20 % of the scatter; with the Type A u alone e is
/// covered in under 70 %.
#[test]
fn the_centre_share_covers_a_centre_entered_a_millimetre_off() {
    const RUNS: usize = 300;
    const N: usize = 14_400;
    let u_centre_um = 1000.0;
    let mut rng = Rng::new(0x50c7);
    let mut socket = Rng::new(0x50c8);
    let (mut err, mut u, mut covered_a) = (Vec::new(), Vec::new(), [0usize; 3]);
    for i in 0..RUNS {
        let m = random_machine(i, &mut rng);
        let entered = P0.map(|p| p + u_centre_um * 1e-3 * socket.normal());
        let mut t = test_about(entered, R, 300.0);
        for s in run(&m, Direction::Ccw, N, &mut rng) {
            t.update(&s, Direction::Ccw);
        }
        let (_, fits) = noise_free_figures(&m, N);
        let est = t.fit_estimate(Direction::Ccw).unwrap();
        let shares = t.centre_shares(Direction::Ccw, u_centre_um as f32).unwrap();
        let got = [est.r0_um, est.e_um[0], est.e_um[1]].map(f64::from);
        let u_a = [est.u_r0_um, est.u_e_um[0], est.u_e_um[1]].map(f64::from);
        let e: Vec<f64> = (0..3).map(|k| got[k] - fits[0][k]).collect();
        for k in 0..3 {
            covered_a[k] += usize::from(e[k].abs() <= 2.0 * u_a[k]);
        }
        u.push((0..3).map(|k| u_a[k].hypot(f64::from(shares[k]))).collect());
        err.push(e);
    }
    let failed = out_of_bounds(&["r0", "e_u", "e_v"], &err, &u);
    assert!(failed.is_empty(), "out of bounds: {failed:?}");
    for (k, name) in ["r0", "e_u", "e_v"].iter().enumerate() {
        println!(
            "{name}: covered with the Type A u alone in {} of {RUNS}",
            covered_a[k]
        );
        if k > 0 {
            assert!(covered_a[k] < RUNS * 7 / 10, "{name}: {}", covered_a[k]);
        }
    }
}

/// The pod's wiring of `circle_u_centre`: a CIRCLE run through the `App` (centre entered
/// 0.5 mm and −0.3 mm off, `circle_u_centre` 500 µm, a circle of 40 µrad squareness and
/// 30 µm/m scale mismatch) publishes e_u's, e_v's and r0's `socket` share as
/// `CircularTest::centre_shares` of the same samples states them, each in its place, and the
/// live u at the run's last sample (a refresh of the live noise and share) is the result's; G's
/// and F's as `CircularTest::direction_figures` states them; the traced centre (`centre_du`,
/// `centre_dv`) covers the offset entered. Run again with the budget at its default 1 µm, the
/// traced offset contradicts it and every share is taken for it, the live u's too.
#[test]
fn a_circle_runs_centre_share_reaches_its_results() {
    use ballpod::acquisition::MAX_AXES;
    use ballpod::app::{App, Command, Contributor, Live, Pattern, ResultId, SessionState};
    use ballpod::config::Config;
    let m = Machine {
        squareness: 40e-6,
        kx: 30e-6,
        bx: 0.01,
        noise_um: 0.2,
        ..Machine::default()
    };
    let entered = [P0[0] + 0.5, P0[1] - 0.3];
    let mut cfg = Config {
        bar_length_mm: R as f32,
        ..Config::default()
    };
    cfg.setup.circle_centre_mm = [entered[0] as f32, entered[1] as f32, 88.0];
    cfg.setup.circle_radius_mm = R as f32;
    cfg.setup.circle_u_centre_um = 500.0;
    // the live noise is taken at 256 used samples, then every 1 024, the centre's share over the
    // next two samples, and the live u at once: the run ends with one of those refreshes, so the
    // last live u is what the results state
    let samples = run(&m, Direction::Ccw, 256 + 7 * 1024 + 2, &mut Rng::new(77));
    let mut t = test_about(entered, R, cfg.setup.circle_min_arc_deg);
    for s in &samples {
        t.update(s, Direction::Ccw);
    }
    // a CCW CIRCLE run of `samples` on a pod configured `cfg`, and its live u at the last sample
    let run_pod = |cfg: Config| {
        let mut app = App::new(cfg, [16; MAX_AXES]);
        app.set_pattern(Pattern::Circle).unwrap();
        app.set_direction(Direction::Ccw).unwrap();
        app.execute(Command::Arm).unwrap();
        app.execute(Command::Start).unwrap();
        for s in &samples {
            app.on_sample(s, &mut ());
        }
        let live_u = [Live::UR0, Live::UEccU, Live::UEccV].map(|v| app.live().get(v));
        app.execute(Command::Stop).unwrap();
        ballpod_host::run_jobs(&mut app);
        assert_eq!(app.session(), SessionState::Done);
        (app, live_u)
    };
    // G's and F's centre shares are `CircularTest::direction_figures`' (`Diagnosed::centre_um`)
    // for the centre's u `u_centre`
    let figure_shares_are = |app: &App, u_centre: f32| {
        let f = t.direction_figures(Direction::Ccw, u_centre).unwrap();
        for (id, want) in [
            (ResultId::GCcw, f.circular_deviation_g_um.centre_um),
            (ResultId::FMaxCcw, f.radial_deviation_f_max_um.centre_um),
            (ResultId::FMinCcw, f.radial_deviation_f_min_um.centre_um),
        ] {
            let got = app.result(id).shares[Contributor::Socket as usize];
            assert!(
                want > 0.0 && (got - want).abs() <= 1e-5 * want,
                "{id:?}: {got} vs {want}"
            );
        }
    };
    // e's and r0's centre shares are `CircularTest::centre_shares`' for `u_centre`, and the
    // live u at the last sample is the result's (the live solve's f32 within 1 %)
    let fit_shares_are = |app: &App, live_u: [Option<f32>; 3], u_centre: f32| {
        let want = t.centre_shares(Direction::Ccw, u_centre).unwrap();
        // e's share is the profile's ovality × δ/R: well above the fit's Type A here
        assert!(want[1] > 0.01 && want[2] > 0.01, "{want:?}");
        for (k, id) in [ResultId::R0, ResultId::EccU, ResultId::EccV]
            .into_iter()
            .enumerate()
        {
            let r = app.result(id);
            let got = r.shares[Contributor::Socket as usize];
            assert!(
                (got - want[k]).abs() <= 1e-5 * want[k],
                "{id:?}: {got} vs {}",
                want[k]
            );
            let live = live_u[k].unwrap();
            assert!(
                (live - r.std_uncertainty).abs() <= 0.01 * r.std_uncertainty,
                "{id:?} live {live}, result u {}",
                r.std_uncertainty
            );
        }
    };
    let (app, live_u) = run_pod(cfg);
    fit_shares_are(&app, live_u, 500.0);
    // G and F take theirs too
    figure_shares_are(&app, 500.0);
    // the traced centre: P0 less the centre as entered (the pod's f32), within its U; within
    // the budget of 500 µm, which stays
    let traced = t.traced_centre(Direction::Ccw).unwrap();
    for (k, id) in [ResultId::CentreDu, ResultId::CentreDv]
        .into_iter()
        .enumerate()
    {
        let r = app.result(id);
        let truth = (P0[k] - f64::from(entered[k] as f32)) * 1e3;
        assert!(
            (f64::from(r.value) - truth).abs() <= 2.0 * f64::from(r.std_uncertainty),
            "{id:?}: {} ± {} vs {truth}",
            r.value,
            r.std_uncertainty
        );
        assert_eq!(
            (r.value, r.std_uncertainty),
            (traced.offset_um[k], traced.u_um[k])
        );
    }
    assert_eq!(traced.centre_u_um(500.0), 500.0);
    // the same run with the budget left at its default (1 µm): the traced offset contradicts
    // it, and the shares are taken for the larger traced coordinate (0.5 mm), the live u's too
    cfg.setup.circle_u_centre_um = 1.0;
    let u_run = traced.centre_u_um(1.0);
    assert!((u_run - 500.0).abs() < 0.1, "{u_run}");
    let (app, live_u) = run_pod(cfg);
    fit_shares_are(&app, live_u, u_run);
    figure_shares_are(&app, u_run);
}

/// The socket's offset bends the bar's profile by its second-order term (|e|² − (e·n)²)/2R, a
/// 2θ term of |e|²/4R that is the set-up's, not the machine's: on a fault-free circle traced
/// about P0 with the socket 50 µm and −40 µm off (noise-free), squareness and scale mismatch
/// read 0 within 0.005 (the term read as a fault: 0.09 µrad and 0.02 µm/m).
#[test]
fn the_socket_offsets_second_order_term_is_not_read_as_squareness_or_scale() {
    let m = Machine {
        socket_mm: [0.05, -0.04],
        ..Machine::default()
    };
    let t = test_of(&m);
    for dir in [Direction::Ccw, Direction::Cw] {
        let dg = t.diagnostics(dir, 0.0).unwrap();
        for (what, v) in [
            ("squareness", dg.get(Diagnosis::Squareness).value),
            ("scale mismatch", dg.get(Diagnosis::ScaleMismatch).value),
        ] {
            assert!(v.abs() < 0.005, "{dir:?} {what}: {v}");
        }
    }
}

/// Issue 14, the circle's centre as entered for every figure: 400 random faulty circles
/// (both directions, 57 600 samples each) traced about P0 with the socket's ball N(0, 30 µm)
/// per coordinate off it, fitted about a centre entered off by N(0, 0.5 mm) per coordinate, the
/// pod told so (`u_centre_um` 500). U = 2u of each figure and diagnosis — its Type A and the
/// centre's share (`Diagnosed::centre_um`) — covers the noise-free figure (or the injected
/// fault; the servo mismatch of an F1000 circle, 0 here) in 95 % ± 3 % of the circles and u is
/// within 20 % of the scatter; F's scatter is up to 1.6 u (its change is one bin's, its
/// extreme's, exchange with a neighbour, which the share follows in size over many circles,
/// not circle by circle); the cyclic amplitude's errors are not normal (a few circles make its
/// scatter): covered in more than 92 %, rms u within 20 % of the rms error. Without the
/// centre's share G, G(b), the mean radial deviation, squareness, scale mismatch, the reversal
/// steps and the servo mismatch are covered in under 80 %.
#[test]
fn every_circle_figure_covers_a_centre_entered_half_a_millimetre_off() {
    const RUNS: usize = 400;
    const N: usize = 57_600;
    let u_centre_um = 500.0f32;
    let mut rng = Rng::new(4242);
    let mut entry = Rng::new(4243);
    let names: Vec<&str> = FIGURES
        .into_iter()
        .chain([
            "squareness",
            "scale mismatch",
            "reversal u",
            "reversal v",
            "cyclic amplitude",
            "servo mismatch",
        ])
        .collect();
    let (mut err, mut u, mut u_a) = (Vec::new(), Vec::new(), Vec::new());
    for i in 0..RUNS {
        let mut m = random_machine(i, &mut rng);
        m.socket_mm = [0.03 * entry.normal(), 0.03 * entry.normal()];
        let entered = P0.map(|p| p + f64::from(u_centre_um) * 1e-3 * entry.normal());
        let mut t = test_about(entered, R, 300.0);
        for dir in [Direction::Ccw, Direction::Cw] {
            for s in run(&m, dir, N, &mut rng) {
                t.update(&s, dir);
            }
        }
        let (figures, _) = noise_free_figures(&m, N);
        let mut got = published(&t, u_centre_um);
        let (ccw, cw) = (
            t.diagnostics(Direction::Ccw, u_centre_um).unwrap(),
            t.diagnostics(Direction::Cw, u_centre_um).unwrap(),
        );
        let dg = mean_diagnostics(&ccw, &cw);
        // the servo mismatch of an F1000 circle (the forward model has no lag: truth 0)
        let (tau, u_tau, centre_tau) = servo_mismatch_ms(&ccw, &cw, R, 1000.0).unwrap();
        let servo = Diagnosed {
            value: tau as f32,
            std_uncertainty: u_tau as f32,
            centre_um: centre_tau as f32,
        };
        got.extend([
            dg.get(Diagnosis::Squareness),
            dg.get(Diagnosis::ScaleMismatch),
            dg.get(Diagnosis::ReversalU),
            dg.get(Diagnosis::ReversalV),
            dg.get(Diagnosis::Cyclic),
            servo,
        ]);
        let faults = truth(&m);
        let want = figures.iter().chain(&faults).chain([&m.cyc_amp_um, &0.0]);
        err.push(
            got.iter()
                .zip(want)
                .map(|(g, w)| f64::from(g.value) - w)
                .collect::<Vec<_>>(),
        );
        u.push(
            got.iter()
                .map(|g| f64::from(g.std_uncertainty).hypot(f64::from(g.centre_um)))
                .collect::<Vec<_>>(),
        );
        u_a.push(
            got.iter()
                .map(|g| f64::from(g.std_uncertainty))
                .collect::<Vec<_>>(),
        );
    }
    // F, the cyclic amplitude and the reversal steps are bounded below, each as it allows
    let failed: Vec<_> = out_of_bounds(&names, &err, &u)
        .into_iter()
        .filter(|n| !n.starts_with('F') && !n.starts_with("cyclic") && !n.starts_with("reversal"))
        .collect();
    assert!(failed.is_empty(), "out of bounds: {failed:?}");
    for (k, name) in names.iter().enumerate() {
        let covered = |u: &[Vec<f64>]| {
            err.iter()
                .zip(u)
                .filter(|(e, u)| e[k].abs() <= 2.0 * u[k])
                .count()
        };
        let (with, without) = (covered(&u), covered(&u_a));
        println!("{name:14} covered in {with} of {RUNS}, by the Type A u alone in {without}");
        let rms =
            |v: &[Vec<f64>]| (v.iter().map(|r| r[k] * r[k]).sum::<f64>() / RUNS as f64).sqrt();
        if name.starts_with('F') {
            // F's scatter is up to 1.6 u (doc above)
            assert!(
                (0.92..=0.98).contains(&(with as f64 / RUNS as f64)),
                "{name}: {with}"
            );
            assert!(
                rms(&err) <= 1.6 * rms(&u),
                "{name}: scatter {} u {}",
                rms(&err),
                rms(&u)
            );
        }
        if name.starts_with("reversal") {
            // A centre 0.5 mm off smears each step's edge over ~0.2° of bins, which lowers the
            // step by ~0.02 µm whatever the sign of the error: second order, which the
            // centre's first-order share does not hold. Measured: coverage 93.5–94.5 %, scatter
            // 1.20 (the two-point fit of 1c3aeac) and 1.26 (each point fitted, issue 45) × u.
            // Bounded so it cannot grow unseen; the share's second-order term is open.
            assert!(with * 100 >= RUNS * 92, "{name}: {with}");
            let ratio = rms(&err) / rms(&u);
            assert!(ratio <= 1.35, "{name}: scatter / u {ratio}");
        }
        if name.starts_with("cyclic") {
            // its errors are not normal (a few circles dominate the scatter): covered in more
            // than 98 %, its rms u still within 20 % of the rms error
            assert!(with * 100 >= RUNS * 92, "{name}: {with}");
            let ratio = rms(&u) / rms(&err);
            assert!((0.8..=1.2).contains(&ratio), "{name}: u / scatter {ratio}");
        }
        if !["F", "H", "cyclic"].iter().any(|p| name.starts_with(p)) {
            assert!(
                without < RUNS * 8 / 10,
                "{name}: {without} without the share"
            );
        }
    }
}

/// `run`'s samples with each axis position read with normal noise of `sd_um` (the encoders'
/// and the servo's jitter about the programmed circle).
fn jittered(samples: Vec<Sample>, sd_um: f64, rng: &mut Rng) -> Vec<Sample> {
    samples
        .into_iter()
        .map(|mut s| {
            for a in &mut s.axes[..2] {
                *a += (sd_um * 1e-3 * rng.normal()) as f32;
            }
            s
        })
        .collect()
}

/// Issue 14, the centre as entered estimated from the data: 200 random faulty circles (both
/// directions, 14 400 samples each) programmed about P0, the pod told a centre N(0, 0.5 mm)
/// per coordinate off it, the axis positions read with 0.5 µm of jitter. The circle the
/// positions trace puts the program's centre at `traced_centre`: U = 2u covers the offset
/// P0 − entered in 95 % ± 3 % of the circles per coordinate and direction, u within 20 % of
/// the scatter (94.5–96.5 %, within 7 %); with the positions exact (their f32 rounding only),
/// within 0.005 µm (0.001 µm), and so with the pattern's sensitivity inward (n flipped).
#[test]
fn the_traced_centre_is_the_programs_against_the_one_entered() {
    const RUNS: usize = 200;
    const N: usize = 14_400;
    let mut rng = Rng::new(5151);
    let mut entry = Rng::new(5152);
    let (mut err, mut u) = (Vec::new(), Vec::new());
    let mut exact_worst = 0.0f64;
    for i in 0..RUNS {
        let m = random_machine(i, &mut rng);
        let entered = P0.map(|p| p + 0.5 * entry.normal());
        // against the centre the pod holds (f32: 0.03 µm steps at 377 mm)
        let truth = [0, 1].map(|k| (P0[k] - f64::from(entered[k] as f32)) * 1e3);
        let mut t = test_about(entered, R, 300.0);
        let mut exact = test_about(entered, R, 300.0);
        let mut inward = test_sensing(entered, R, 300.0, Sensitivity::Inward);
        for dir in [Direction::Ccw, Direction::Cw] {
            let samples = run(&m, dir, N, &mut rng);
            for s in &samples {
                exact.update(s, dir);
                inward.update(s, dir);
            }
            for s in jittered(samples, 0.5, &mut rng) {
                t.update(&s, dir);
            }
        }
        let (mut e_row, mut u_row) = (Vec::new(), Vec::new());
        for dir in [Direction::Ccw, Direction::Cw] {
            let c = t.traced_centre(dir).unwrap();
            let c0 = exact.traced_centre(dir).unwrap();
            let c1 = inward.traced_centre(dir).unwrap();
            for k in 0..2 {
                e_row.push(f64::from(c.offset_um[k]) - truth[k]);
                u_row.push(f64::from(c.u_um[k]));
                for c in [c0, c1] {
                    exact_worst = exact_worst.max((f64::from(c.offset_um[k]) - truth[k]).abs());
                }
            }
        }
        err.push(e_row);
        u.push(u_row);
    }
    let names = ["ccw u", "ccw v", "cw u", "cw v"];
    let failed = out_of_bounds(&names, &err, &u);
    assert!(failed.is_empty(), "out of bounds: {failed:?}");
    println!("positions exact: worst error {exact_worst:.4} µm");
    assert!(exact_worst < 0.005, "{exact_worst}");
}

/// Issue 14, a centre entered off its budget: 200 random faulty circles as in
/// [`every_circle_figure_covers_a_centre_entered_half_a_millimetre_off`] (14 400 samples a
/// direction, the socket's ball N(0, 30 µm) per coordinate off P0, the positions read with 0.5
/// µm of jitter), the centre entered N(0, 0.5 mm) per coordinate off but its budget left at
/// the default 1 µm; every figure takes the larger direction's u (the pod takes each
/// direction's for its own figures). The traced offset contradicts the budget and the centre's shares take it
/// (`TracedCentre::centre_u_um`): U covers every figure and diagnosis in at least 92 % of the
/// circles (95 % − 3 %; a known offset budgeted, not corrected: the diagnoses up to all of
/// them, F 92.5–95 %, H, which takes no share, 94 %), where the budget as entered covered G in
/// under 60 %. With the centre entered right the budget stays as entered in every circle.
#[test]
fn a_centre_entered_off_its_budget_takes_the_traced_offset() {
    const RUNS: usize = 200;
    const N: usize = 14_400;
    let mut rng = Rng::new(6161);
    let mut entry = Rng::new(6162);
    let names: Vec<&str> = FIGURES
        .into_iter()
        .chain(["squareness", "scale mismatch", "reversal u", "reversal v"])
        .collect();
    let (mut covered, mut covered_entered) = (vec![0usize; names.len()], 0usize);
    for i in 0..RUNS {
        let mut m = random_machine(i, &mut rng);
        m.socket_mm = [0.03 * entry.normal(), 0.03 * entry.normal()];
        let entered = P0.map(|p| p + 0.5 * entry.normal());
        let mut t = test_about(entered, R, 300.0);
        let mut right = test_about(P0, R, 300.0);
        for dir in [Direction::Ccw, Direction::Cw] {
            for s in jittered(run(&m, dir, N, &mut rng), 0.5, &mut rng) {
                t.update(&s, dir);
                right.update(&s, dir);
            }
        }
        let budget = |t: &CircularTest<360>, d| t.traced_centre(d).unwrap().centre_u_um(1.0);
        for d in [Direction::Ccw, Direction::Cw] {
            assert_eq!(
                budget(&right, d),
                1.0,
                "circle {i}: the centre entered right"
            );
        }
        let u_c = budget(&t, Direction::Ccw).max(budget(&t, Direction::Cw));
        let (figures, _) = noise_free_figures(&m, N);
        let mut got = published(&t, u_c);
        let dg = mean_diagnostics(
            &t.diagnostics(Direction::Ccw, u_c).unwrap(),
            &t.diagnostics(Direction::Cw, u_c).unwrap(),
        );
        got.extend([
            dg.get(Diagnosis::Squareness),
            dg.get(Diagnosis::ScaleMismatch),
            dg.get(Diagnosis::ReversalU),
            dg.get(Diagnosis::ReversalV),
        ]);
        let faults = truth(&m);
        let want = figures.iter().chain(&faults);
        for ((c, g), w) in covered.iter_mut().zip(&got).zip(want) {
            let u = f64::from(g.std_uncertainty).hypot(f64::from(g.centre_um));
            *c += usize::from((f64::from(g.value) - w).abs() <= 2.0 * u);
        }
        let g = published(&t, 1.0)[0];
        let u = f64::from(g.std_uncertainty).hypot(f64::from(g.centre_um));
        covered_entered += usize::from((f64::from(g.value) - figures[0]).abs() <= 2.0 * u);
    }
    for (name, c) in names.iter().zip(&covered) {
        println!("{name:14} covered in {c} of {RUNS}");
    }
    for (name, c) in names.iter().zip(&covered) {
        assert!(c * 100 >= RUNS * 92, "{name}: {c}");
    }
    println!("G ccw with the budget as entered: covered in {covered_entered} of {RUNS}");
    assert!(covered_entered * 100 < RUNS * 60, "{covered_entered}");
}

/// A CIRCLE pod about [`P0`] on radius [`R`].
fn circle_pod() -> ballpod::app::App {
    use ballpod::acquisition::MAX_AXES;
    use ballpod::config::Config;
    let mut cfg = Config {
        bar_length_mm: R as f32,
        ..Config::default()
    };
    cfg.setup.circle_centre_mm = [P0[0] as f32, P0[1] as f32, 88.0];
    cfg.setup.circle_radius_mm = R as f32;
    let mut app = ballpod::app::App::new(cfg, [16; MAX_AXES]);
    app.set_pattern(ballpod::app::Pattern::Circle).unwrap();
    app
}

/// One run of `samples` in direction `d` up to its STOP (the job it wants not run).
fn circle_run(app: &mut ballpod::app::App, d: Direction, samples: &[Sample]) {
    use ballpod::app::Command;
    app.set_direction(d).unwrap();
    app.execute(Command::Arm).unwrap();
    app.execute(Command::Start).unwrap();
    for s in samples {
        app.on_sample(s, &mut ());
    }
    app.execute(Command::Stop).unwrap();
}

/// A run's results are a job (app::job): STOP is answered with them invalid (the run's fit,
/// the traced centre, the figures), the status word says COMPUTING and not RESULTS_READY;
/// the application goes on with a run of the other direction while the job waits and runs; the results it publishes are those of the
/// runs as they ended, the same as where the job runs at once, bit for bit.
#[test]
fn a_circle_stop_leaves_its_figures_to_a_job_while_the_pod_goes_on() {
    use ballpod::app::{JobSlot, ResultId, SessionState, StatusWord};
    let m = Machine {
        squareness: 40e-6,
        bx: 0.01,
        noise_um: 0.2,
        ..Machine::default()
    };
    let mut rng = Rng::new(41);
    let (ccw, cw) = (
        run(&m, Direction::Ccw, 4000, &mut rng),
        run(&m, Direction::Cw, 4000, &mut rng),
    );
    let ids = [
        ResultId::EccU,
        ResultId::R0,
        ResultId::CentreDu,
        ResultId::GCcw,
        ResultId::FMaxCcw,
        ResultId::GCw,
        ResultId::GBidir,
        ResultId::H,
        ResultId::Squareness,
        ResultId::ReversalU,
        ResultId::CyclicOrder,
    ];
    // where the jobs run at once (the simulated pod, replay)
    let mut at_once = circle_pod();
    circle_run(&mut at_once, Direction::Ccw, &ccw);
    ballpod_host::run_jobs(&mut at_once);
    circle_run(&mut at_once, Direction::Cw, &cw);
    ballpod_host::run_jobs(&mut at_once);

    let mut app = circle_pod();
    let mut slot = Box::new(JobSlot::new());
    circle_run(&mut app, Direction::Ccw, &ccw);
    let status = app.live().status.0;
    assert_eq!(app.session(), SessionState::Done);
    assert!(status & StatusWord::COMPUTING != 0, "{status:#06x}");
    assert!(status & StatusWord::RESULTS_READY == 0, "{status:#06x}");
    assert!(!app.result(ResultId::GCcw).valid, "G before its job");
    assert!(
        !app.result(ResultId::EccU).valid,
        "the run's fit is the job's too"
    );
    assert!(app.start_job(&mut slot));
    // the application goes on while the job waits for the worker: the CW run, to its end
    circle_run(&mut app, Direction::Cw, &cw);
    assert!(!app.start_job(&mut slot), "one job at a time");
    slot.run();
    app.finish_job(&mut slot);
    assert!(
        app.result(ResultId::GCcw).valid,
        "the CCW figures, published"
    );
    assert!(
        !app.result(ResultId::GBidir).valid,
        "the CW run's job is still to run"
    );
    assert!(app.job_pending());
    assert!(app.start_job(&mut slot));
    slot.run();
    app.finish_job(&mut slot);
    assert_eq!(slot.patch_overflowed(), 0);
    let status = app.live().status.0;
    assert!(status & StatusWord::COMPUTING == 0, "{status:#06x}");
    assert!(status & StatusWord::RESULTS_READY != 0, "{status:#06x}");
    for id in ids {
        let (a, b) = (app.result(id), at_once.result(id));
        assert!(a.valid, "{id:?}");
        assert_eq!(a.value.to_bits(), b.value.to_bits(), "{id:?}");
        assert_eq!(
            a.std_uncertainty.to_bits(),
            b.std_uncertainty.to_bits(),
            "{id:?}"
        );
    }
}

/// A job's figures are of the runs it read: a run of the same direction begun again before
/// the job ends makes them stale, and they are dropped (the new run's end computes its own);
/// a run of the other direction does not.
#[test]
fn a_figures_job_of_a_replaced_run_publishes_nothing() {
    use ballpod::app::{Command, JobSlot, ResultId};
    let m = Machine {
        noise_um: 0.2,
        ..Machine::default()
    };
    let ccw = run(&m, Direction::Ccw, 2000, &mut Rng::new(5));
    let mut app = circle_pod();
    let mut slot = Box::new(JobSlot::new());
    circle_run(&mut app, Direction::Ccw, &ccw);
    assert!(app.start_job(&mut slot));
    // the CW run armed meanwhile: CCW's figures stand
    app.set_direction(Direction::Cw).unwrap();
    app.execute(Command::Arm).unwrap();
    slot.run();
    app.finish_job(&mut slot);
    assert!(app.result(ResultId::GCcw).valid);
    app.execute(Command::Abort).unwrap();
    // CCW again: the job of the first CCW run is stale when it ends
    circle_run(&mut app, Direction::Ccw, &ccw);
    assert!(app.start_job(&mut slot));
    app.set_direction(Direction::Ccw).unwrap();
    app.execute(Command::Arm).unwrap();
    slot.run();
    app.finish_job(&mut slot);
    assert!(!app.result(ResultId::GCcw).valid, "a replaced run's G");
    assert!(!app.job_pending());
}
