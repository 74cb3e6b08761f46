//! Corrections a control takes (`ncgen::kins`): the trt kinematics as two axis lines against
//! LinuxCNC's published equations (`forward_linuxcnc_trt`), the R-test's frame against seed
//! 003's HTM chain, and the closed loop on the virtual machine: identify with the R-test →
//! write the pins back → the control commands its corrected kinematics → the R-test again.
//! The same for SINUMERIK records: type P (a swivel table) against Siemens' chain with the
//! R-test and seed 004's centrelines, and type M (seed 002's B head and C table) against seed
//! 002's HTM chain and in a closed loop through the pod's seed 002 procedure.

use ballpod_host::forward_linuxcnc_trt::{self as lcnc, Pins};
use ballpod_host::forward_seed003 as fw;
use ballpod_host::methods::rtest::{
    LocationErrors, RtestConfig, RtestGeometry, RtestSample, identify, predict_um,
};
use ballpod_host::ncgen::kins::{
    Dispersion, DispersionGrid, KinsCorrection, Pin, TrtKins, TrtPins, correct, rtest_deviations,
    rtest_nominal_pins, rtest_work_point, turned,
};
use ballpod_host::rng::Rng;
use ballpod_host::vmt::rtest_rig::{RtestRig, path_k4, seed003_table3_kinematics};

fn pins_of(p: &TrtPins) -> Pins {
    Pins {
        x_rot_point: p.get(Pin::XRotPoint),
        y_rot_point: p.get(Pin::YRotPoint),
        z_rot_point: p.get(Pin::ZRotPoint),
        x_offset: p.get(Pin::XOffset),
        y_offset: p.get(Pin::YOffset),
        z_offset: p.get(Pin::ZOffset),
        tool_offset: p.get(Pin::ToolOffset),
    }
}

fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}

/// One of LinuxCNC's kinematics functions: pins, X Y Z (mm), tilt and table angles (deg).
type Kinematics = fn(&Pins, [f64; 3], f64, f64) -> [f64; 3];

#[test]
fn linuxcnc_trt_kinematics_turn_the_work_about_the_two_lines_of_its_pins() {
    let mut rng = Rng::new(7);
    for kins in [TrtKins::Xyzac, TrtKins::Xyzbc] {
        for _ in 0..200 {
            let p = TrtPins(std::array::from_fn(|_| 200.0 * rng.normal()));
            let q = [
                300.0 * rng.normal(),
                300.0 * rng.normal(),
                300.0 * rng.normal(),
            ];
            let (tilt, table) = (120.0 * rng.normal(), 400.0 * rng.normal());
            let (inverse, forward): (Kinematics, Kinematics) = match kins {
                TrtKins::Xyzac => (lcnc::xyzac_inverse, lcnc::xyzac_forward),
                TrtKins::Xyzbc => (lcnc::xyzbc_inverse, lcnc::xyzbc_forward),
            };
            let j = inverse(&pins_of(&p), q, tilt, table);
            let ours = turned(&kins.lines(&p), q, tilt, table);
            assert!(close(j, ours, 1e-9), "{kins:?} {p:?}: {j:?} vs {ours:?}");
            // (and LinuxCNC's forward undoes its inverse)
            assert!(close(forward(&pins_of(&p), j, tilt, table), q, 1e-9));
        }
    }
}

/// Table 3's machine: LinuxCNC joints (the tool over the table at A = C = 0, from the A
/// axis's nominal point) → seed 003's servo positions (X moves the table, Y and Z the probe).
fn servo(k: &fw::Kin, j: [f64; 3]) -> [f64; 3] {
    [
        k.x_z + k.x_h - k.x_x - k.x_a - j[0],
        j[1] + k.y_x + k.y_a - k.y_z - k.y_h,
        j[2] + k.z_x + k.z_a - k.z_z - k.z_h - k.z_p,
    ]
}

#[test]
fn linuxcnc_xyzac_with_the_drawings_pins_commands_seed003s_ideal_tcp() {
    let k = seed003_table3_kinematics();
    let g = RtestGeometry::SEED003_TABLE3;
    let pins = rtest_nominal_pins(&g);
    let w = rtest_work_point(&g, &pins);
    for (a, c) in path_k4(37) {
        let j = lcnc::xyzac_inverse(&pins_of(&pins), w, a, c);
        let (xm, ym, zm) = fw::tcp_commands(&k, a.to_radians(), c.to_radians());
        assert!(close(servo(&k, j), [xm, ym, zm], 1e-9), "A {a} C {c}");
    }
}

/// Seed 003's hidden location errors, as a machine might have them (µm / arc-seconds): the
/// ball where it was meant to be.
const TRUTH: [f64; 11] = [
    0.0, 0.0, 0.0, 40.0, -30.0, 6.0, -4.0, 35.0, -25.0, 5.0, -8.0,
];

/// An R-test on path K4 of Table 3's machine whose control runs xyzac with `pins`: the
/// readings, identified.
fn rtest(rig: &mut RtestRig, pins: &TrtPins) -> (Vec<RtestSample>, Identified) {
    let k = seed003_table3_kinematics();
    let g = RtestGeometry::SEED003_TABLE3;
    let w = rtest_work_point(&g, pins);
    let poses: Vec<_> = path_k4(241)
        .into_iter()
        .map(|(a, c)| {
            (
                a,
                c,
                servo(&k, lcnc::xyzac_inverse(&pins_of(pins), w, a, c)),
            )
        })
        .collect();
    let samples = rig.measure_commanded(&k, &TRUTH, &poses);
    assert_eq!(rig.invalid_samples, 0);
    let id = identify(&g, &samples, &RtestConfig::default()).expect("identified");
    (samples, Identified::of(&id))
}

/// What an R-test identified: the errors, their u and correlations (as `ncgen kins` reads
/// them from `results.json`).
struct Identified {
    e: LocationErrors,
    u: LocationErrors,
    r: [[f64; 11]; 11],
}

impl Identified {
    fn of(id: &ballpod_host::methods::rtest::RtestIdentification) -> Self {
        let c = &id.covariance;
        Self {
            e: id.errors,
            u: id.std_uncertainty,
            r: std::array::from_fn(|i| {
                std::array::from_fn(|j| c[i][j] / (c[i][i] * c[j][j]).sqrt())
            }),
        }
    }

    /// The hidden errors themselves (u 0).
    fn truth() -> Self {
        Self {
            e: LocationErrors::from_array(TRUTH),
            u: LocationErrors::default(),
            r: std::array::from_fn(|i| std::array::from_fn(|j| f64::from(u8::from(i == j)))),
        }
    }
}

fn rms_um(samples: &[RtestSample]) -> f64 {
    let s: f64 = samples
        .iter()
        .map(|r| r.reading_um.iter().map(|v| v * v).sum::<f64>())
        .sum();
    (s / samples.len() as f64).sqrt()
}

fn corrected(pins: &TrtPins, id: &Identified) -> KinsCorrection {
    let g = RtestGeometry::SEED003_TABLE3;
    let measured = rtest_deviations(&g, &id.e, &id.u, Some(&id.r)).expect("lines");
    let grid = DispersionGrid {
        tilt_range_deg: (-90.0, 0.0),
        half_side_mm: 0.0,
    };
    correct(
        TrtKins::Xyzac,
        pins,
        &measured,
        rtest_work_point(&g, pins),
        &grid,
        500.0,
    )
    .expect("within the guard")
}

#[test]
fn the_rtests_correction_written_back_leaves_what_xyzac_cannot_express() {
    let g = RtestGeometry::SEED003_TABLE3;
    let mut rig = RtestRig::new(0.3, 11);
    let drawing = rtest_nominal_pins(&g);
    // 1. identify on the machine whose control holds the drawing's pins
    let (before, id) = rtest(&mut rig, &drawing);
    let c = corrected(&drawing, &id);
    // the pins moved where the true lines cross the work (the true errors through the same
    // mapping, noise-free), within 2 u
    let truth = corrected(&drawing, &Identified::truth());
    for pin in TrtKins::Xyzac.pins() {
        let (got, want, u) = (
            c.corrected.get(pin),
            truth.corrected.get(pin),
            c.u_mm[pin as usize],
        );
        assert!(
            (got - want).abs() <= 2.0 * u + 1e-6,
            "{pin:?}: {got} vs {want} (u {u})"
        );
    }
    // the four tilts are what the kinematics cannot take: the true ones, within 2 u
    for (x, t) in c.unexpressed.iter().zip(truth.unexpressed.iter()) {
        assert!(
            (x.value_arcsec - t.value_arcsec).abs() <= 2.0 * x.u_arcsec + 0.05,
            "{x:?} vs {t:?}"
        );
    }
    // 2. write back, run the R-test again: the control commands its corrected kinematics
    let (after, id2) = rtest(&mut rig, &c.corrected);
    // the readings (the tool-centre error at the ball along K4) shrink to what the tilts leave
    let (rms_before, rms_after) = (rms_um(&before), rms_um(&after));
    assert!(rms_after < rms_before / 4.0, "{rms_before} → {rms_after}");
    // what the second run reads is what the identified lines predict: the tool where the
    // corrected kinematics puts it less where the ball is — at home, where the first run's
    // reading at A = C = 0 put it (the reduced model's prediction there), turned about the
    // identified lines — within the readings' noise
    let predicted = {
        let control = TrtKins::Xyzac.lines(&c.corrected);
        let actual = rtest_deviations(&g, &id.e, &id.u, Some(&id.r))
            .expect("lines")
            .deviations
            .actual(&TrtKins::Xyzac.lines(&drawing));
        let w_control = rtest_work_point(&g, &c.corrected);
        let home = predict_um(&g, &id.e, 0.0, 0.0).expect("prediction");
        let w_drawing = rtest_work_point(&g, &drawing);
        let ball: [f64; 3] = std::array::from_fn(|i| w_drawing[i] - home[i] * 1e-3);
        let s: f64 = path_k4(241)
            .iter()
            .map(|&(a, cc)| {
                let (p, q) = (
                    turned(&control, w_control, a, cc),
                    turned(&actual, ball, a, cc),
                );
                (0..3).map(|i| ((p[i] - q[i]) * 1e3).powi(2)).sum::<f64>()
            })
            .sum();
        (s / 241.0).sqrt()
    };
    assert!(
        (rms_after - predicted).abs() < 0.2,
        "read {rms_after} µm, predicted {predicted} µm"
    );
    // 3. the correction the second run asks for is the first one's error plus the second
    // run's own: within 2·√(u₁² + u₂²) of none
    let c2 = corrected(&c.corrected, &id2);
    for pin in TrtKins::Xyzac.pins() {
        let d = (c2.corrected.get(pin) - c.corrected.get(pin)) * 1e3;
        let u = c.u_mm[pin as usize].hypot(c2.u_mm[pin as usize]) * 1e3;
        assert!(
            d.abs() <= 2.0 * u + 1e-3,
            "{pin:?}: asks for {d} µm again (u {u})"
        );
    }
    assert!(c2.before.max_um < c.before.max_um / 4.0);
}

#[test]
fn a_correction_beyond_the_guard_is_refused_with_both_numbers() {
    let g = RtestGeometry::SEED003_TABLE3;
    let drawing = rtest_nominal_pins(&g);
    let measured = rtest_deviations(
        &g,
        &LocationErrors::from_array(TRUTH),
        &LocationErrors::default(),
        None,
    )
    .expect("lines");
    let grid = DispersionGrid {
        tilt_range_deg: (-90.0, 0.0),
        half_side_mm: 0.0,
    };
    let e = correct(
        TrtKins::Xyzac,
        &drawing,
        &measured,
        rtest_work_point(&g, &drawing),
        &grid,
        20.0,
    )
    .expect_err("beyond 20 µm");
    assert_eq!(e.field, "--max-change-um");
    assert!(e.what.contains("beyond the guard of 20 µm"), "{}", e.what);
}

/// The book's examples (Part programs, "Corrections the control takes"): its results file
/// through `cargo ncgen -- kins xyzac-trt` and `sinumerik-p` prints their blocks.
#[test]
fn the_books_kins_example_is_what_ncgen_prints() {
    let json = ballpod_host::docs::block_after("**R-test results**", "json");
    let dir = std::env::temp_dir().join(format!("ballpod-kins-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("results.json");
    std::fs::write(&file, json).unwrap();
    let printed = run_ok(
        &dir,
        env!("CARGO_BIN_EXE_ncgen"),
        &["kins", "xyzac-trt", "results.json"],
    );
    let example = ballpod_host::docs::block_after("xyzac-trt results.json` prints:", "text");
    assert_eq!(printed, example);
    // and into a SINUMERIK record
    let printed = run_ok(
        &dir,
        env!("CARGO_BIN_EXE_ncgen"),
        &["kins", "sinumerik-p", "results.json"],
    );
    let example = ballpod_host::docs::block_after(
        "sinumerik-p results.json` (the R-test results above) prints:",
        "text",
    );
    assert_eq!(printed, example);
    // the same file, asked for xyzbc: refused with the reason
    let out = run(
        &dir,
        env!("CARGO_BIN_EXE_ncgen"),
        &["kins", "xyzbc-trt", "results.json"],
    );
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("A/C table-tilting machine"));
    // seed 002's results (a B head and a C table): refused by both targets, with the reason
    std::fs::write(
        dir.join("seed002.json"),
        r#"{"results": [{"name": "dx_BT", "value": 1.0, "u": 0.1}]}"#,
    )
    .unwrap();
    for target in ["xyzac-trt", "sinumerik-p"] {
        let out = run(
            &dir,
            env!("CARGO_BIN_EXE_ncgen"),
            &["kins", target, "seed002.json"],
        );
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("turns the tool about B") && err.contains("type P"),
            "{err}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The dispersion a correction states is the oracle's `(max, rms)` (µm), to 1e-6 µm.
fn assert_states(stated: Dispersion, oracle: (f64, f64)) {
    assert!(
        (stated.max_um - oracle.0).abs() < 1e-6 && (stated.rms_um - oracle.1).abs() < 1e-6,
        "{stated:?} vs {oracle:?}"
    );
}

/// The tool-centre error (max, rms µm) of a control that sends the tool to `control(w, B, C)`
/// for the work point w at B, C (degrees) against seed 004's eq 9 about `file`'s actual lines,
/// over B 0 … 90° and C a turn every 15°, at `work` and the corners of a 100 mm cube about it.
fn seed004_dispersion(
    file: &ballpod_host::ncgen::CentrelinesFile,
    work: [f64; 3],
    control: impl Fn([f64; 3], f64, f64) -> [f64; 3],
) -> (f64, f64) {
    use ballpod_host::forward_seed004 as fw4;
    let a = &file.actual;
    let (mut max, mut sum, mut n) = (0.0f64, 0.0, 0);
    for i in 0..=6 {
        let b = 15.0 * i as f64;
        for j in 0..24 {
            let cc = 15.0 * j as f64;
            for k in 0..9 {
                let s = |bit: usize| {
                    if k == 0 {
                        0.0
                    } else if (k - 1) & bit == 0 {
                        -50.0
                    } else {
                        50.0
                    }
                };
                let w = [work[0] + s(1), work[1] + s(2), work[2] + s(4)];
                let j = control(w, b, cc);
                let p = fw4::eq9(
                    w,
                    a.a_direction,
                    a.a_point_mm,
                    a.b_direction,
                    a.b_point_mm,
                    cc.to_radians(),
                    b.to_radians(),
                );
                let e = (0..3).map(|i| (j[i] - p[i]).powi(2)).sum::<f64>().sqrt() * 1e3;
                max = max.max(e);
                sum += e * e;
                n += 1;
            }
        }
    }
    (max, (sum / n as f64).sqrt())
}

/// Seed 004's machine (the rotary table A ∥ Z on the tilting B ∥ Y: xyzbc-trt's C and B) with
/// the book's centrelines file: the dispersion `ncgen kins` states before and after is the
/// error of LinuxCNC's xyzbc equations (with the present and the corrected pins) against seed
/// 004's eq 9 about the file's actual lines (`forward_seed004`), over the same grid.
#[test]
fn seed004s_centrelines_into_xyzbc_leave_the_dispersion_it_states() {
    use ballpod_host::ncgen::centrelines_from_toml;
    use ballpod_host::ncgen::kins::centreline_deviations;
    let toml = ballpod_host::docs::block_after("**Centrelines file**", "toml");
    let file = centrelines_from_toml(&toml).expect("the book's centrelines file");
    let (measured, nominal) = centreline_deviations(&file).expect("lines");
    let work = [-63.72, -70.71, 258.75];
    let grid = DispersionGrid {
        tilt_range_deg: (0.0, 90.0),
        half_side_mm: 50.0,
    };
    let c = correct(TrtKins::Xyzbc, &nominal, &measured, work, &grid, 1000.0).expect("corrected");
    let a = &file.actual;
    let oracle = |pins: &TrtPins| {
        seed004_dispersion(&file, work, |w, b, cc| {
            lcnc::xyzbc_inverse(&pins_of(pins), w, b, cc)
        })
    };
    let (before, after) = (oracle(&nominal), oracle(&c.corrected));
    assert_states(c.before, before);
    assert_states(c.after, after);
    // (the file's table axis is tilted 1.6 mrad, which xyzbc cannot take: rms 632 → 213 µm)
    assert!(after.1 < before.1 / 2.5, "{before:?} → {after:?}");
    // the lines' tilts are what xyzbc cannot take: the file's, in arc-seconds
    let t = &c.unexpressed;
    assert!((t[1].value_arcsec - (-a.b_direction[0] / a.b_direction[1]) / ARCSEC).abs() < 1e-6);
    assert!((t[3].value_arcsec - (a.a_direction[0] / a.a_direction[2]) / ARCSEC).abs() < 1e-6);
    // every pin the correction changes has a u > 0
    for pin in [Pin::XRotPoint, Pin::YRotPoint, Pin::XOffset, Pin::ZOffset] {
        assert!(c.u_mm[pin as usize] > 0.0, "{pin:?}");
    }
}

/// One arc-second, rad.
const ARCSEC: f64 = std::f64::consts::PI / 648_000.0;

/// The pins' u are honest: over 200 R-tests of the same machine (0.3 µm noise, a head whose
/// axes' scales are each off by N(0, 0.5 %) — the default u_reading_scale), each pin's stated u
/// is within 25 % of its scatter, and U = 2u covers the true mapping in 95 % ± 4 % of the runs.
#[test]
fn the_pins_u_follows_their_scatter() {
    let g = RtestGeometry::SEED003_TABLE3;
    let drawing = rtest_nominal_pins(&g);
    let truth = corrected(&drawing, &Identified::truth());
    let pins = [Pin::XRotPoint, Pin::YRotPoint, Pin::YOffset, Pin::ZOffset];
    let mut rng = Rng::new(23);
    let (mut sq, mut u2, mut covered) = ([0.0f64; 4], [0.0f64; 4], [0usize; 4]);
    let n = 200;
    for run in 0..n {
        let mut rig = RtestRig::new(0.3, 1000 + run);
        let (mut samples, _) = rtest(&mut rig, &drawing);
        let scale: [f64; 3] = std::array::from_fn(|_| 1.0 + 0.005 * rng.normal());
        for s in &mut samples {
            for (r, k) in s.reading_um.iter_mut().zip(scale) {
                *r *= k;
            }
        }
        let id = identify(&g, &samples, &RtestConfig::default()).expect("identified");
        let c = corrected(&drawing, &Identified::of(&id));
        for (k, pin) in pins.iter().enumerate() {
            let d = c.corrected.get(*pin) - truth.corrected.get(*pin);
            let u = c.u_mm[*pin as usize];
            sq[k] += d * d;
            u2[k] += u * u;
            covered[k] += usize::from(d.abs() <= 2.0 * u);
        }
    }
    for (k, pin) in pins.iter().enumerate() {
        let (rms, u) = ((sq[k] / n as f64).sqrt(), (u2[k] / n as f64).sqrt());
        let cover = covered[k] as f64 / n as f64;
        eprintln!(
            "{pin:?}: rms {:.3} µm, u {:.3} µm, U covers {:.1} %",
            rms * 1e3,
            u * 1e3,
            cover * 100.0
        );
        assert!(
            (u / rms - 1.0).abs() <= 0.25,
            "{pin:?}: u {u} vs scatter {rms}"
        );
        assert!((cover - 0.95).abs() <= 0.04, "{pin:?}: U covers {cover}");
    }
}

/// End to end as a user runs it: the R-test's readings → `cargo replay` (its `results.json`
/// carries `rtest_covariance`) → `cargo ncgen -- kins xyzac-trt results.json`: the pins and
/// their u are the ones the identification's own covariance gives (to the figures' f32), and
/// nothing says the u leave the correlations out.
#[test]
fn replay_then_kins_uses_the_rtests_covariance() {
    let dir = std::env::temp_dir().join(format!("ballpod-kins-e2e-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let g = RtestGeometry::SEED003_TABLE3;
    let drawing = rtest_nominal_pins(&g);
    let mut rig = RtestRig::new(0.3, 77);
    let (samples, id) = rtest(&mut rig, &drawing);
    let mut csv = String::from("a_deg,c_deg,dx_um,dy_um,dz_um\n");
    for s in &samples {
        let [x, y, z] = s.reading_um;
        csv.push_str(&format!("{:?},{:?},{x:?},{y:?},{z:?}\n", s.a_deg, s.c_deg));
    }
    std::fs::write(dir.join("rtest.csv"), csv).unwrap();
    std::fs::write(
        dir.join("session.toml"),
        "[rtest]\nreadings = \"rtest.csv\"\n",
    )
    .unwrap();
    let run = |exe: &str, args: &[&str]| run_ok(&dir, exe, args);
    run(
        env!("CARGO_BIN_EXE_replay"),
        &["session.toml", "--out", "out"],
    );
    let results = std::fs::read_to_string(dir.join("out/results.json")).unwrap();
    assert!(results.contains("\"rtest_covariance\""));
    let csv = run(
        env!("CARGO_BIN_EXE_ncgen"),
        &["kins", "xyzac-trt", "out/results.json", "--format", "csv"],
    );
    let hal = run(
        env!("CARGO_BIN_EXE_ncgen"),
        &["kins", "xyzac-trt", "out/results.json"],
    );
    assert!(!hal.contains("# u:"), "{hal}");
    let want = corrected(&drawing, &id);
    for pin in TrtKins::Xyzac.pins() {
        let row = csv
            .lines()
            .find(|l| l.starts_with(&format!("pin:{},", pin.name())))
            .expect("the pin's row");
        let cols: Vec<&str> = row.split(',').collect();
        let (value, u): (f64, f64) = (cols[2].parse().unwrap(), cols[3].parse().unwrap());
        assert!((value - want.corrected.get(pin)).abs() < 1e-6, "{row}");
        assert!(
            (u - want.u_mm[pin as usize]).abs() < 1e-6,
            "{row} vs {}",
            want.u_mm[pin as usize]
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// One of the crate's binaries run in `dir`.
fn run(dir: &std::path::Path, exe: &str, args: &[&str]) -> std::process::Output {
    std::process::Command::new(exe)
        .current_dir(dir)
        .args(args)
        .output()
        .expect("runs")
}

/// [`run`], which must succeed: its standard output.
fn run_ok(dir: &std::path::Path, exe: &str, args: &[&str]) -> String {
    let out = run(dir, exe, args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).unwrap()
}

// ---------------------------------------------------------------------------------------------
// SINUMERIK: a swivel data record of kinematic type P
// ---------------------------------------------------------------------------------------------

use ballpod_host::forward_siemens_carr as sie;
use ballpod_host::ncgen::carr::{self, CarrCorrection, SwivelTable};
use ballpod_host::ncgen::kins::rtest_ball;

fn chain_of(t: &SwivelTable) -> sie::SwivelTable {
    sie::SwivelTable {
        l2: t.l2(),
        l3: t.l3(),
        l4: t.l4(),
        v1: t.v1(),
        v2: t.v2(),
    }
}

#[test]
fn a_sinumerik_swivel_tables_chain_turns_the_part_about_the_two_lines_of_its_record() {
    let mut rng = Rng::new(8);
    for _ in 0..200 {
        let v = |rng: &mut Rng| [rng.normal(), rng.normal(), rng.normal()];
        let l = |rng: &mut Rng| {
            [
                300.0 * rng.normal(),
                300.0 * rng.normal(),
                300.0 * rng.normal(),
            ]
        };
        let t = SwivelTable::closed(l(&mut rng), l(&mut rng), v(&mut rng), v(&mut rng));
        let w = l(&mut rng);
        let (a1, a2) = (120.0 * rng.normal(), 400.0 * rng.normal());
        let siemens = sie::part_point(&chain_of(&t), w, a1, a2);
        let ours = turned(&t.lines(), w, a1, a2);
        assert!(close(siemens, ours, 1e-9), "{t:?}: {siemens:?} vs {ours:?}");
        // and the same lines given at their reference points turn it alike
        assert!(close(
            turned(&t.lines().at_reference(), w, a1, a2),
            ours,
            1e-9
        ));
    }
    // the R-test frame's drawing record is the drawing's xyzac pins: the same tool positions
    let g = RtestGeometry::SEED003_TABLE3;
    let (rec, pins) = (SwivelTable::rtest_nominal(&g), rtest_nominal_pins(&g));
    let w = rtest_work_point(&g, &pins);
    assert!(close(rtest_ball(&g, &rec.lines().at_reference()), w, 1e-12));
    for (a, c) in path_k4(37) {
        let j = lcnc::xyzac_inverse(&pins_of(&pins), w, a, c);
        assert!(
            close(sie::part_point(&chain_of(&rec), w, a, c), j, 1e-9),
            "A {a} C {c}"
        );
    }
}

/// An R-test on path K4 of Table 3's machine whose SINUMERIK holds the record `rec`, the
/// ball where the control takes it to be (`w`, mm): the readings, identified.
fn rtest_sinumerik(
    rig: &mut RtestRig,
    rec: &SwivelTable,
    w: [f64; 3],
) -> (Vec<RtestSample>, Identified) {
    let k = seed003_table3_kinematics();
    let g = RtestGeometry::SEED003_TABLE3;
    let chain = chain_of(rec);
    let poses: Vec<_> = path_k4(241)
        .into_iter()
        .map(|(a, c)| (a, c, servo(&k, sie::part_point(&chain, w, a, c))))
        .collect();
    let samples = rig.measure_commanded(&k, &TRUTH, &poses);
    assert_eq!(rig.invalid_samples, 0);
    let id = identify(&g, &samples, &RtestConfig::default()).expect("identified");
    (samples, Identified::of(&id))
}

fn corrected_record(
    rec: &SwivelTable,
    id: &Identified,
    max_turn_urad: f64,
) -> Result<CarrCorrection, ballpod_host::ncgen::NcError> {
    let g = RtestGeometry::SEED003_TABLE3;
    let measured = rtest_deviations(&g, &id.e, &id.u, Some(&id.r)).expect("lines");
    let grid = DispersionGrid {
        tilt_range_deg: (-90.0, 0.0),
        half_side_mm: 50.0,
    };
    let w = rtest_ball(&g, &rec.lines().at_reference());
    carr::correct(1, rec, &measured, w, &grid, 500.0, max_turn_urad)
}

#[test]
fn the_rtests_correction_into_a_sinumerik_record_leaves_only_the_measurements_u() {
    let g = RtestGeometry::SEED003_TABLE3;
    let mut rig = RtestRig::new(0.3, 12);
    let drawing = SwivelTable::rtest_nominal(&g);
    // 1. identify on the machine whose control holds the drawing's record, the ball where the
    // drawing puts it
    let w = rtest_ball(&g, &drawing.lines().at_reference());
    let (before, id) = rtest_sinumerik(&mut rig, &drawing, w);
    let c = corrected_record(&drawing, &id, 2000.0).expect("within the guard");
    // every value where the true lines put it (the true errors, noise-free), within 2 u
    let truth = corrected_record(&drawing, &Identified::truth(), 2000.0).expect("truth");
    for (k, (n, what)) in carr::PARAMETERS.iter().enumerate() {
        let (got, want, u) = (c.corrected.0[k], truth.corrected.0[k], c.u[k]);
        assert!(
            (got - want).abs() <= 2.0 * u + 1e-9,
            "$TC_CARR{n} ({what}): {got} vs {want} (u {u})"
        );
    }
    // a type-P record takes directions too: nothing is left over
    assert!(truth.before.max_um > 20.0, "{:?}", truth.before);
    assert!(truth.after.max_um < 1e-6, "{:?}", truth.after);
    // 2. write back, run the R-test again: the control commands its corrected record, the
    // ball set up where it is (the first run's reading at A = C = 0 says where: the ball's
    // place is the set-up's, not the machine's — XOW … ZOW)
    let home = predict_um(&g, &id.e, 0.0, 0.0).expect("prediction");
    let ball: [f64; 3] = std::array::from_fn(|i| w[i] - home[i] * 1e-3);
    let (after, id2) = rtest_sinumerik(&mut rig, &c.corrected, ball);
    let (rms_before, rms_after) = (rms_um(&before), rms_um(&after));
    // the readings fall to the head's noise (three sensors at 0.3 µm: 0.52 µm) and what the
    // first run's u leave
    assert!(rms_after < 1.0, "{rms_before} → {rms_after}");
    // 3. what the second run asks for is the first one's error plus its own: within
    // 2·√(u₁² + u₂²) of none, lengths and vectors alike
    let c2 = corrected_record(&c.corrected, &id2, 2000.0).expect("within the guard");
    for (k, (n, what)) in carr::PARAMETERS.iter().enumerate() {
        let d = c2.corrected.0[k] - c.corrected.0[k];
        let u = c.u[k].hypot(c2.u[k]);
        assert!(
            d.abs() <= 2.0 * u + 1e-9,
            "$TC_CARR{n} ({what}): asks for {d:e} again (u {u:e})"
        );
    }
    assert!(
        c2.before.max_um < c.before.max_um / 20.0,
        "{:?} then {:?}",
        c.before,
        c2.before
    );
    eprintln!(
        "sinumerik loop: readings {rms_before:.2} → {rms_after:.2} µm rms; dispersion {:?} → {:?}",
        c.before, c2.before
    );
}

#[test]
fn a_sinumerik_record_is_refused_a_turn_beyond_the_guard_or_an_open_chain() {
    let g = RtestGeometry::SEED003_TABLE3;
    let drawing = SwivelTable::rtest_nominal(&g);
    // the truth's tilts (A: 7.2″ = 35 µrad, C: 9.4″ = 46 µrad) against a guard of 10 µrad
    let e = corrected_record(&drawing, &Identified::truth(), 10.0).expect_err("beyond 10 µrad");
    assert_eq!(e.field, "--max-turn-urad");
    assert!(e.what.contains("beyond the guard of 10 µrad"), "{}", e.what);
    // l4 that does not close the chain
    let mut open = drawing;
    open.0[14] += 0.5;
    let e = corrected_record(&open, &Identified::truth(), 2000.0).expect_err("open chain");
    assert_eq!(e.field, "--carr");
    assert!(e.what.contains("0.5000 mm"), "{}", e.what);
}

/// The same centrelines file into a SINUMERIK record (axis 1 the tilting B, axis 2 the table):
/// the dispersion it states before and after is Siemens' chain with the present and the
/// corrected record against seed 004's eq 9 — and after, with the table's 1.6 mrad tilt taken
/// by v2, none is left.
#[test]
fn seed004s_centrelines_into_a_sinumerik_record_leave_no_dispersion() {
    use ballpod_host::ncgen::centrelines_from_toml;
    use ballpod_host::ncgen::kins::centreline_deviations;
    let toml = ballpod_host::docs::block_after("**Centrelines file**", "toml");
    let file = centrelines_from_toml(&toml).expect("the book's centrelines file");
    let (measured, nominal) = centreline_deviations(&file).expect("lines");
    let record = SwivelTable::through(&TrtKins::Xyzbc.lines(&nominal));
    let work = [-63.72, -70.71, 258.75];
    let grid = DispersionGrid {
        tilt_range_deg: (0.0, 90.0),
        half_side_mm: 50.0,
    };
    let c = carr::correct(1, &record, &measured, work, &grid, 1000.0, 5000.0).expect("corrected");
    let oracle = |rec: &SwivelTable| {
        seed004_dispersion(&file, work, |w, b, cc| {
            sie::part_point(&chain_of(rec), w, b, cc)
        })
    };
    let (before, after) = (oracle(&record), oracle(&c.corrected));
    assert_states(c.before, before);
    assert_states(c.after, after);
    assert!(before.1 > 600.0 && after.0 < 1e-6, "{before:?} → {after:?}");
    // the vectors are the file's actual directions; every value the correction changes has a u
    let a = &file.actual;
    let unit = |d: [f64; 3]| {
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        d.map(|v| v / n)
    };
    assert!(close(c.corrected.v1(), unit(a.b_direction), 1e-12));
    assert!(close(c.corrected.v2(), unit(a.a_direction), 1e-12));
    for (k, (n, what)) in carr::PARAMETERS.iter().enumerate() {
        if (c.corrected.0[k] - c.current.0[k]).abs() > 1e-9 {
            assert!(c.u[k] > 0.0, "$TC_CARR{n} ({what})");
        }
    }
}

// ---------------------------------------------------------------------------------------------
// SINUMERIK: a swivel data record of kinematic type M (seed 002's B head and C table)
// ---------------------------------------------------------------------------------------------

use ballpod::app::Pattern;
use ballpod::app::bc_ballbar::Setup;
use ballpod::identify::mill_turn::{Deviations, Parameter, arcsec_to_urad};
use ballpod_host::forward_seed002 as f2;
use ballpod_host::ncgen::carr_mixed::{self, MixedGrid, MixedRecord, Seed002Deviations};
use ballpod_host::simulate::{SimOptions, simulate_commanded};
use ballpod_host::vmt::machine::MachineFile;

fn mixed_chain_of(r: &MixedRecord) -> sie::MixedRecord {
    sie::MixedRecord {
        l1: r.l1(),
        l2: r.l2(),
        v1: r.v1(),
        v2: r.v2(),
        l3: r.l3(),
        l4: r.l4(),
        offset1_deg: r.offset1_deg(),
    }
}

/// Where seed 002's machine (the literal HTM chain, `forward_seed002`, deviations `d` in µm /
/// µrad) has the tool tip less the part point `w` (mm) when a control holding the record
/// `rec` commands them together at B, C (degrees). The record's frame: the model frame's
/// origin (C at the table face) at `origin`; the tool's tip at rest at `tip` from the carrier
/// reference (on the spindle); B, C counted about v1's and v2's senses.
fn seed002_error_um(
    rec: &MixedRecord,
    nominal: &MixedRecord,
    d: &[f64; 13],
    origin: [f64; 3],
    tip: [f64; 3],
    w: [f64; 3],
    (b, c): (f64, f64),
) -> [f64; 3] {
    let t = tip.map(|v| -v);
    let p = sie::mixed_command(&mixed_chain_of(rec), t, w, b, c);
    // the machine: its B pivot on the spindle, at the nominal record's place
    let b0 = nominal.b_pivot();
    let (s1, s2) = (nominal.v1()[1].signum(), nominal.v2()[2].signum());
    let (mbt, mxb, _, _, mcz, mczi) = f2::mats(d);
    let mut m = f2::mul(&mxb, &f2::eb((s1 * b).to_radians()));
    m = f2::mul(&m, &mbt);
    let arm = f2::apply(&m, std::array::from_fn(|k| tip[k] - b0[k]));
    let tool: [f64; 3] = std::array::from_fn(|k| p[k] + b0[k] - origin[k] + arm[k]);
    let wm: [f64; 3] = std::array::from_fn(|k| w[k] - origin[k]);
    let mut mc = f2::mul(&mcz, &f2::ec((s2 * c).to_radians()));
    mc = f2::mul(&mc, &mczi);
    let part = f2::apply(&mc, wm);
    std::array::from_fn(|k| (tool[k] - part[k]) * 1e3)
}

/// Seed 002's deviations as a results file states them: `d` with a diagonal covariance of
/// `u` (µm, µrad).
fn seed002_measured(d: [f64; 13], u: f64) -> Seed002Deviations {
    let mut covariance = [[0.0; 13]; 13];
    for (i, row) in covariance.iter_mut().enumerate() {
        row[i] = u * u;
    }
    Seed002Deviations {
        deviations: Deviations::from_array(&d),
        covariance,
        u_note: None,
        source: carr_mixed::Source::Model,
    }
}

/// A type-M record in a machine's frame (the adapter 150 mm under the B pivot, l2 slid 35 mm
/// along B; C through (420, −180) with its l3 point 40 mm under the table face at Z −260),
/// with B and C counted either way round.
fn mixed_present(s1: f64, s2: f64) -> (MixedRecord, f64) {
    (
        MixedRecord::closed(
            [0.0, 35.0, 150.0],
            [0.0, s1, 0.0],
            [420.0, -180.0, -300.0],
            [0.0, 0.0, s2],
            0.0,
        ),
        -260.0,
    )
}

/// Random deviations (µm, µrad) of the size seed 002 finds; the squareness ones 0;
/// `tilt`: whether the spindle may be tilted at B = 0 (α_BT + α_XB ≠ 0).
fn seed002_random(rng: &mut Rng, tilt: bool) -> [f64; 13] {
    let mut d = [0.0; 13];
    for p in Parameter::ALL {
        d[p.index()] = if p.is_positional() {
            40.0 * rng.normal()
        } else {
            arcsec_to_urad(25.0 * rng.normal())
        };
    }
    for p in [Parameter::GammaXy, Parameter::AlphaYz, Parameter::BetaYz] {
        d[p.index()] = 0.0;
    }
    if !tilt {
        d[Parameter::AlphaBt.index()] = -d[Parameter::AlphaXb.index()];
    }
    d
}

/// The type-M record corrected for seed 002's deviations puts the tool on the part as seed
/// 002's HTM chain moves the machine (Siemens' chain, `forward_siemens_carr`, against
/// `forward_seed002`): with the spindle untilted at B = 0 (α_BT = −α_XB) to 0.15 µm over
/// B 0 … 90° and any C, for 50 random machines, both senses of v1 and v2, in a machine frame;
/// and the dispersion a correction states — before and after, the spindle's tilt left — is
/// that chain's over the same grid, to 0.15 µm. (The bound is the linearised HTMs' second
/// order, which the first-order mapping does not carry: (75″)² over 400 mm is 0.05 µm.)
#[test]
fn a_type_m_record_corrected_for_seed002s_deviations_moves_as_its_htm_chain() {
    let mut rng = Rng::new(42);
    let tool = 356.3945;
    for case in 0..50 {
        let (s1, s2) = match case % 4 {
            0 => (1.0, 1.0),
            1 => (-1.0, 1.0),
            2 => (1.0, -1.0),
            _ => (-1.0, -1.0),
        };
        let (present, face_z) = mixed_present(s1, s2);
        let origin = [420.0, -180.0, face_z];
        let b0 = present.b_pivot();
        assert!(close(b0, [0.0, 0.0, 150.0], 1e-12), "{b0:?}");
        let tip = [0.0, 0.0, b0[2] - tool];
        // untilted: the corrected record is the machine
        let d = seed002_random(&mut rng, false);
        let rec = present.corrected(&Deviations::from_array(&d), face_z);
        let mut before = 0.0f64;
        for _ in 0..40 {
            let w = std::array::from_fn(|k| origin[k] + 100.0 * rng.normal());
            let (b, c) = (90.0 * rng.uniform(), 360.0 * rng.uniform());
            let e = seed002_error_um(&rec, &present, &d, origin, tip, w, (b, c));
            assert!(e.iter().all(|v| v.abs() < 0.15), "case {case}: {e:?}");
            let e0 = seed002_error_um(&present, &present, &d, origin, tip, w, (b, c));
            before = before.max(e0.iter().map(|v| v * v).sum::<f64>().sqrt());
        }
        assert!(
            before > 20.0,
            "case {case}: the present record was off by {before} µm only"
        );
        // tilted: the stated dispersion is the chain's
        let d = seed002_random(&mut rng, true);
        let grid = MixedGrid {
            b_range_deg: (0.0, 90.0),
            tool_below_pivot_mm: tool,
            work_mm: [origin[0], origin[1], origin[2] + 65.5],
            half_side_mm: 50.0,
        };
        let c = carr_mixed::correct(
            1,
            &present,
            &seed002_measured(d, 1.0),
            face_z,
            &grid,
            1e3,
            1e3,
        )
        .expect("corrected");
        for (stated, rec) in [(c.before, &present), (c.after, &c.corrected)] {
            let (mut max, mut sum, mut n) = (0.0f64, 0.0, 0usize);
            for i in 0..=6 {
                let b = 15.0 * i as f64;
                for j in 0..24 {
                    let cc = 15.0 * j as f64;
                    for k in 0..9 {
                        let s = |bit: usize| match (k, k & bit) {
                            (0, _) => 0.0,
                            (_, 0) => -50.0,
                            _ => 50.0,
                        };
                        let w0 = grid.work_mm;
                        let w = [w0[0] + s(1), w0[1] + s(2), w0[2] + s(4)];
                        let e = seed002_error_um(rec, &present, &d, origin, tip, w, (b, cc));
                        let e = e.iter().map(|v| v * v).sum::<f64>().sqrt();
                        max = max.max(e);
                        sum += e * e;
                        n += 1;
                    }
                }
            }
            let rms = (sum / n as f64).sqrt();
            assert!(
                (stated.max_um - max).abs() < 0.15 && (stated.rms_um - rms).abs() < 0.15,
                "case {case}: stated {stated:?}, the chain's max {max} rms {rms}"
            );
        }
        // the tilt left: α_BT + α_XB times the tool's reach, the same at every pose
        let tilt = d[Parameter::AlphaBt.index()] + d[Parameter::AlphaXb.index()];
        assert!((c.spindle_tilt_urad.0 - tilt).abs() < 1e-9);
        assert!(
            (c.after.max_um - tilt.abs() * 1e-6 * tool * 1e3).abs()
                < 0.05 * c.after.max_um.max(1.0)
        );
    }
}

/// The axes a control holding `rec` (in seed 002's model frame) sends for a seed 002 pose:
/// the pattern's T-ball point on the part (where the nominal record puts it), commanded
/// through Siemens' chain — the tool the T-ball R_B under the B pivot.
fn commanded_through(rec: &MixedRecord, step: Pattern, axes: [f64; 5]) -> [f64; 5] {
    let r_b = Setup::thesis_table_4_3().geometry(step).r_b_mm;
    let [x, y, z, b, c] = axes;
    let t = [0.0, 0.0, r_b];
    let nominal = mixed_chain_of(&MixedRecord::model_frame());
    let tip = sie::mixed_tool_tip(&nominal, t, b);
    // the part point there, the table at C = 0
    let w = sie::mixed_part_point(&nominal, [x + tip[0], y + tip[1], z + tip[2]], -c);
    let p = sie::mixed_command(&mixed_chain_of(rec), t, w, b, c);
    [p[0], p[1], p[2], b, c]
}

/// The seed 002 procedure on `m` with the control commanding through `rec`: the results file
/// and the rms of the bar's true readings over the procedure's poses (µm).
fn seed002_through(m: &MachineFile, rec: &MixedRecord) -> (String, f64) {
    let o = SimOptions {
        seed: 11,
        repeats: 1,
        feed_mm_per_min: 4000.0,
        seed002: true,
        circle: false,
        three_planes: false,
        feed_sweep: Vec::new(),
        nc_dir: None,
    };
    let setup = Setup::thesis_table_4_3();
    let sum = std::cell::Cell::new((0.0f64, 0usize));
    let command = |step: Pattern, axes: [f64; 5]| {
        let a = commanded_through(rec, step, axes);
        let dl = m.seed002.delta_l_um(&setup, step, &a);
        let (s, n) = sum.get();
        sum.set((s + dl * dl, n + 1));
        a
    };
    let s = simulate_commanded(m, &o, &mut |_, _, _| {}, Some(&command)).expect("session");
    assert!(
        s.report.runs.iter().all(|r| r.outcome == "DONE"),
        "{:?}",
        s.report.runs
    );
    let (sq, n) = sum.get();
    (s.report.to_json().expect("json"), (sq / n as f64).sqrt())
}

/// The closed loop on the virtual machine: seed 002's procedure (the pod's acquisition and
/// model-mode identification on the machine's literal HTM chain, 0.2 µm bar noise) on a
/// machine off by the thesis's Table 4.5 and a spindle 30 µm / −20 µm from its B axis, its
/// SINUMERIK commanding through a type-M record of the model frame; the record corrected by
/// `ncgen kins sinumerik-m` and written back, the W ball set again where the corrected control
/// puts the T-ball, the procedure run again. Every corrected value is within 2u of where the
/// true deviations put it; the second run identifies every deviation the record takes within
/// 2·√(u₁² + u₂²) of none, and the spindle's tilt it cannot take, α_BT + α_XB, where the first
/// run stated it; the bar's readings fall to what that tilt alone reads.
#[test]
fn seed002s_correction_into_a_type_m_record_leaves_only_the_spindles_tilt() {
    let mut m = MachineFile::default();
    m.seed002.dx_bt_um = 30.0;
    m.seed002.dz_bt_um = -20.0;
    let nominal = MixedRecord::model_frame();
    let (json1, rms1) = seed002_through(&m, &nominal);
    let first = carr_mixed::seed002_from_results(&json1, false).expect("results");
    assert!(first.u_note.is_none(), "the covariance is in the results");
    let grid = MixedGrid {
        b_range_deg: (0.0, 90.0),
        tool_below_pivot_mm: 356.3945,
        work_mm: [0.0, 0.0, 65.5],
        half_side_mm: 50.0,
    };
    let c = carr_mixed::correct(1, &nominal, &first, 0.0, &grid, 200.0, 500.0).expect("corrected");
    // the values within 2u of the truth's record
    let truth = m.seed002.deviations();
    let want = nominal.corrected(&truth, 0.0);
    for (k, &(n, what)) in carr_mixed::PARAMETERS.iter().enumerate() {
        let (got, w, u) = (c.corrected.0[k], want.0[k], c.u[k]);
        assert!(
            (got - w).abs() <= 2.0 * u + 1e-12,
            "$TC_CARR{n} ({what}): {got} vs the truth's {w} (u {u})"
        );
    }
    // written back, the W ball set again with the corrected control, run again
    let setup = Setup::thesis_table_4_3();
    let at_setup = [setup.r_c_mm, 0.0, setup.z_c_mm + setup.r_b_mm, 0.0, 0.0];
    let moved = commanded_through(&c.corrected, Pattern::Cr, at_setup);
    let mut m2 = m;
    m2.seed002.w_offset_um = std::array::from_fn(|k| (moved[k] - at_setup[k]) * 1e3);
    let (json2, rms2) = seed002_through(&m2, &c.corrected);
    let second = carr_mixed::seed002_from_results(&json2, false).expect("results");
    let u = |s: &Seed002Deviations, p: Parameter| s.covariance[p.index()][p.index()].sqrt();
    let (d1, d2) = (&first.deviations, &second.deviations);
    for p in [
        Parameter::DxBt,
        Parameter::DzBt,
        Parameter::AlphaXb,
        Parameter::BetaXb,
        Parameter::GammaXb,
        Parameter::DxCz,
        Parameter::DyCz,
        Parameter::AlphaCz,
        Parameter::BetaCz,
    ] {
        let bound = 2.0 * u(&first, p).hypot(u(&second, p));
        eprintln!(
            "{}: first {:+.3} second {:+.3} (bound {:.3})",
            p.name(),
            d1.get(p),
            d2.get(p),
            bound
        );
        assert!(
            d2.get(p).abs() <= bound,
            "{}: {} left, bound {bound}",
            p.name(),
            d2.get(p)
        );
    }
    // the tilt: the second run sees it all in α_BT (the record's B axis is the machine's)
    let (tilt1, u_tilt1) = c.spindle_tilt_urad;
    let tilt_true = truth.alpha_bt_urad + truth.alpha_xb_urad;
    assert!(
        (tilt1 - tilt_true).abs() <= 2.0 * u_tilt1,
        "{tilt1} vs {tilt_true} (u {u_tilt1})"
    );
    let bound = 2.0 * u_tilt1.hypot(u(&second, Parameter::AlphaBt));
    assert!(
        (d2.alpha_bt_urad - tilt1).abs() <= bound,
        "α_BT {} vs {tilt1}",
        d2.alpha_bt_urad
    );
    // the readings: what the tilt alone reads on a nominal control
    let mut tilted = MachineFile {
        seed002: ballpod_host::vmt::machine::Machine002::perfect(),
        ..MachineFile::default()
    };
    tilted.seed002.alpha_bt_arcsec = ballpod::identify::mill_turn::urad_to_arcsec(tilt_true);
    let (_, rms_tilt) = seed002_through(&tilted, &nominal);
    eprintln!(
        "readings rms: {rms1:.3} → {rms2:.3} µm; the tilt alone {rms_tilt:.3} µm; dispersion {:?} → {:?}",
        c.before, c.after
    );
    assert!(rms2 < rms1 / 3.0);
    assert!(
        (rms2 - rms_tilt).abs() < 0.5,
        "{rms2} vs the tilt's {rms_tilt}"
    );
}

/// The book's type-M example (Part programs, "seed 002 into a mixed record"): its command on
/// its results file prints its block; the guards refuse that correction with both numbers; and
/// what does not fit is refused with the reason: a record without the table face's height, an
/// open part chain, a v1 not along Y, an R-test's results or a centrelines file.
#[test]
fn the_books_type_m_example_is_what_ncgen_prints_and_what_does_not_fit_is_refused() {
    let json = ballpod_host::docs::block_after("**Seed 002 results**", "json");
    let dir = std::env::temp_dir().join(format!("ballpod-kins-m-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("results.json"), json).unwrap();
    let marker = "C's vector entered as (0, 0, −1):";
    let command = ballpod_host::docs::block_after(marker, "sh");
    let words: Vec<&str> = command.split_whitespace().collect();
    assert_eq!(words[..3], ["cargo", "ncgen", "--"], "{command}");
    let args = &words[3..];
    let ncgen = env!("CARGO_BIN_EXE_ncgen");
    let printed = run_ok(&dir, ncgen, args);
    assert_eq!(printed, ballpod_host::docs::block_after(marker, "text"));
    let refused = |extra: &[&str], expect: &[&str]| {
        let all: Vec<&str> = args.iter().chain(extra).copied().collect();
        let out = run(&dir, ncgen, &all);
        assert!(!out.status.success(), "{extra:?} accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        for e in expect {
            assert!(err.contains(e), "{extra:?}: {err}");
        }
    };
    // the guards, with both numbers (v1 turns 104.9 µrad; l3 x moves 53.1 µm)
    refused(
        &["--max-turn-urad", "100"],
        &[
            "v1 ($TC_CARR7…9) would turn by 104.9 µrad",
            "guard of 100 µrad",
        ],
    );
    refused(
        &["--max-change-um", "40"],
        &[
            "$TC_CARR15[2] (l3 x) would change by +53.1 µm",
            "guard of 40 µm",
        ],
    );
    // an open part chain; a v1 along X
    refused(&["--carr", "18=1"], &["l4 ($TC_CARR18…20)", "from −l3"]);
    refused(
        &["--carr", "7=1", "--carr", "8=0"],
        &["v1 ($TC_CARR7…9) must run along Y"],
    );
    // a record without the table face's height
    let short: Vec<&str> = args
        .iter()
        .copied()
        .take_while(|a| *a != "--table-face-z-mm")
        .collect();
    let out = run(&dir, ncgen, &short);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--table-face-z-mm"));
    // an R-test's results; a centrelines file
    std::fs::write(
        dir.join("rtest.json"),
        ballpod_host::docs::block_after("**R-test results**", "json"),
    )
    .unwrap();
    for (file, expect) in [
        ("rtest.json", "R-test's results"),
        ("lines.toml", "seed 004"),
    ] {
        let out = run(&dir, ncgen, &["kins", "sinumerik-m", file]);
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expect) && err.contains("sinumerik-p"), "{err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The touch probe's figures (seed 002 chapter 5) into a type-M record: a machine off in
/// everything the probe identifies (the spindle 30/−20 µm from B, B's zero, C's place and tilt;
/// B untilted), its spheres through seed 002's HTM chain, identified by the core's probe
/// method, its `probe_*` figures as `results.json` lists them: the record corrected from them
/// is the one the true deviations give (to 0.01 µm and 0.01 µrad), and says that v1 stays.
/// A file with only the C axis's figures changes only the part's chain; one with the model
/// mode's as well takes those unless asked for the probe's.
#[test]
fn the_touch_probes_figures_correct_a_type_m_record_as_its_truth() {
    use ballpod::identify::mill_turn::lobing::LOBING_COMPONENTS;
    use ballpod::identify::mill_turn::probe::{
        BAxisProbe, CAxisProbe, ProbeMode, identify_b_axis, identify_c_axis,
    };
    let mut d = [0.0; 13];
    d[Parameter::DxBt.index()] = 30.0;
    d[Parameter::DzBt.index()] = -20.0;
    d[Parameter::BetaXb.index()] = arcsec_to_urad(-24.1);
    d[Parameter::DxCz.index()] = 53.1;
    d[Parameter::DyCz.index()] = -45.7;
    d[Parameter::AlphaCz.index()] = arcsec_to_urad(1.1);
    d[Parameter::BetaCz.index()] = arcsec_to_urad(-25.2);
    // B: the sphere on the C centreline seen through the actual tip at B = 0 and 90°, two
    // tool lengths (the probe reports the sphere less the tip's displacement)
    let sphere = [-490.0, 0.0, -472.0];
    let (rb, rb2) = (382.95, 433.062);
    let seen = |rb: f64| -> [[f64; 3]; 2] {
        [0.0f64, 90.0].map(|deg| {
            let phi = deg.to_radians();
            let (x, z) = (sphere[0] + rb * phi.sin(), sphere[2] + rb * phi.cos());
            let t = f2::t_ball(&d, x, sphere[1], z, phi, rb, [0.0; 3]);
            let t0 = f2::t_ball(&[0.0; 13], x, sphere[1], z, phi, rb, [0.0; 3]);
            std::array::from_fn(|i| sphere[i] - (t[i] - t0[i]))
        })
    };
    let ([m0, m90], [n0, n90]) = (seen(rb), seen(rb2));
    let b = identify_b_axis(
        &BAxisProbe {
            measured_mm: [m0, m90, n0, n90],
            nominal_mm: [sphere; 4],
            measured_std_uncertainty_um: [[0.1; 3]; 4],
            lobing_shift_um: [[[0.0; 3]; LOBING_COMPONENTS]; 4],
            std_uncertainty_dof: 0.0,
            r_b_mm: rb,
            r_b2_mm: rb2,
            x_t_mm: 490.0,
        },
        ProbeMode::Corrected,
    )
    .expect("B axis");
    // C: the sphere at R_C on the table at C = 0, 90, 180, 270°
    let (_, _, _, _, mcz, _) = f2::mats(&d);
    let (rc, zc, origin) = (100.0, 64.838, [-490.0, 0.0, -536.838]);
    let centres: [[f64; 3]; 4] = std::array::from_fn(|k| {
        let th = k as f64 * std::f64::consts::FRAC_PI_2;
        let p = f2::apply(&f2::mul(&mcz, &f2::ec(th)), [rc, 0.0, zc]);
        std::array::from_fn(|i| origin[i] + p[i])
    });
    let c = identify_c_axis(
        &CAxisProbe {
            centres_mm: centres,
            nominal_axis_xy_mm: [-490.0, 0.0],
            z_c_mm: zc,
            std_uncertainty_dof: 0.0,
            centres_std_uncertainty_um: [[0.1; 3]; 4],
        },
        ProbeMode::Corrected,
    )
    .expect("C axis");
    let figure = |name: &str, value: f64, unit: &str| {
        format!(r#"{{"name": "{name}", "value": {value}, "u": 0.1, "unit": "{unit}"}}"#)
    };
    let b_figures = [
        figure("probe_dx_BT", b.dx_bt_um, "um"),
        figure("probe_dz_BT", b.dz_bt_um, "um"),
        figure("probe_beta_XB", b.beta_xb_arcsec, "arcsec"),
        figure(
            "probe_alpha_BT_plus_alpha_XB",
            b.alpha_bt_plus_alpha_xb_arcsec.expect("α_BT + α_XB"),
            "arcsec",
        ),
    ];
    let c_figures = [
        figure("probe_alpha_CZ", c.alpha_cz_arcsec, "arcsec"),
        figure("probe_beta_CZ", c.beta_cz_arcsec, "arcsec"),
        figure("probe_dx_CZ", c.dx_cz_um, "um"),
        figure("probe_dy_CZ", c.dy_cz_um, "um"),
    ];
    let file = |figures: &[String]| format!(r#"{{"results": [{}]}}"#, figures.join(", "));
    let nominal = MixedRecord::model_frame();
    let grid = MixedGrid {
        b_range_deg: (0.0, 90.0),
        tool_below_pivot_mm: 356.3945,
        work_mm: [0.0, 0.0, 65.5],
        half_side_mm: 50.0,
    };
    let corrected = |json: &str, probe: bool| {
        let m = carr_mixed::seed002_from_results(json, probe).expect("figures");
        carr_mixed::correct(1, &nominal, &m, 0.0, &grid, 200.0, 500.0).expect("corrected")
    };
    let both: Vec<String> = b_figures.iter().chain(&c_figures).cloned().collect();
    let got = corrected(&file(&both), false);
    let want = nominal.corrected(&Deviations::from_array(&d), 0.0);
    for (k, &(n, what)) in carr_mixed::PARAMETERS.iter().enumerate() {
        let tol = match carr_mixed::kind(k) {
            carr::Kind::Length => 1e-5,
            carr::Kind::Direction => 1e-8,
            carr::Kind::Angle => 1e-8_f64.to_degrees(),
        };
        assert!(
            (got.corrected.0[k] - want.0[k]).abs() < tol,
            "$TC_CARR{n} ({what}): {} vs {}",
            got.corrected.0[k],
            want.0[k]
        );
    }
    assert!(
        got.spindle_tilt_urad.0.abs() < 0.05,
        "{:?}",
        got.spindle_tilt_urad
    );
    let printed = carr_mixed::mixed_lines(&got, "results.json");
    assert!(
        printed.contains("v1 stays") && printed.contains("; probe_dx_BT |"),
        "{printed}"
    );
    // only the C axis: the tool's chain stays
    let c_only = corrected(&file(&c_figures), false);
    for k in carr_mixed::L1..carr_mixed::V2 {
        assert_eq!(
            c_only.corrected.0[k],
            nominal.0[k],
            "{}",
            carr_mixed::PARAMETERS[k].1
        );
    }
    assert_eq!(c_only.corrected.offset1_deg(), 0.0);
    for k in carr_mixed::V2..carr_mixed::OFFSET1 {
        assert!((c_only.corrected.0[k] - want.0[k]).abs() < 1e-5);
    }
    assert!(carr_mixed::mixed_lines(&c_only, "r").contains("B axis not probed"));
    // with the model mode's figures too: those, unless the probe's are asked for
    let mut with_model = both.clone();
    with_model.push(figure("dx_BT", 1.0, "um"));
    // (the model mode's path: this file's model figures are one of ten, so it names the next)
    let e = carr_mixed::seed002_from_results(&file(&with_model), false).expect_err("model mode");
    assert!(e.what.contains("dz_BT not identified"), "{}", e.what);
    let probe = carr_mixed::seed002_from_results(&file(&with_model), true).expect("probe");
    assert_eq!(
        probe.source,
        carr_mixed::Source::Probe {
            b_axis: true,
            c_axis: true
        }
    );
    // an axis with some of its figures is refused with the missing one's name
    let e = carr_mixed::seed002_from_results(&file(&b_figures[..3]), false).expect_err("partial");
    assert!(
        e.what.contains("probe_alpha_BT_plus_alpha_XB"),
        "{}",
        e.what
    );
}
