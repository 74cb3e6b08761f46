//! Corrections a control takes (`ncgen::kins`): the trt kinematics as two axis lines against
//! LinuxCNC's published equations (`forward_linuxcnc_trt`), the R-test's frame against seed
//! 003's HTM chain, and the closed loop on the virtual machine: identify with the R-test →
//! write the pins back → the control commands its corrected kinematics → the R-test again.

use ballpod::identify::rtest::{
    LocationErrors, RtestConfig, RtestGeometry, RtestSample, identify, predict_um,
};
use ballpod_host::forward_linuxcnc_trt::{self as lcnc, Pins};
use ballpod_host::forward_seed003 as fw;
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
    fn of(id: &ballpod::identify::rtest::RtestIdentification) -> Self {
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
