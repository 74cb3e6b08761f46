//! The part-program generator: the ISO/Fanuc circle programs against reviewed golden files
//! (`tests/data/nc/`), the LinuxCNC programs differing from them only where the dialect does,
//! and a set-up the machine cannot run refused with the field named. (LinuxCNC's interpreter
//! checks the programs' geometry: `host-tests/nc/test_rs274.py`.)
use std::path::Path;

use ballpod::app::Direction;
use ballpod::config::{CirclePlane, Config, RunTrigger};
use ballpod_host::ncgen::{CircleOptions, CircleRun, DEFAULT_M_BASE, Dialect, Session, SphereTest};

fn setup(plane: CirclePlane, centre: [f32; 3], radius: f32, feed: f32) -> Config {
    let mut c = Config {
        bar_length_mm: radius,
        ..Config::default()
    };
    c.setup.circle_plane = plane;
    c.setup.circle_centre_mm = centre;
    c.setup.circle_radius_mm = radius;
    c.setup.circle_feed_mm_per_min = feed;
    c
}

/// The golden cases: (file stem, set-up, options).
fn cases() -> Vec<(&'static str, Config, CircleOptions)> {
    vec![
        (
            "circle_xy_full",
            setup(CirclePlane::XY, [0.0, 0.0, f32::NAN], 150.0, 1000.0),
            CircleOptions::default(),
        ),
        (
            "circle_zx_220",
            setup(CirclePlane::ZX, [-30.0, 7.0, 180.0], 300.0, 1500.0),
            CircleOptions {
                start_deg: 90.0,
                arc_deg: 220.0,
                directions: vec![Direction::Cw],
                ..CircleOptions::default()
            },
        ),
    ]
}

#[test]
fn fanuc_programs_match_their_reviewed_golden_files() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/nc");
    // the 220° ZX circle once more with its session: the PLC's M-codes (book: "Running a test
    // from the CNC", the hand-shake table)
    let session = Session::new(DEFAULT_M_BASE, 1000, RunTrigger::Command).unwrap();
    let mut all: Vec<_> = cases().into_iter().map(|c| (c, None)).collect();
    let zx = cases()[1].clone();
    all.push((("circle_zx_220_session", zx.1, zx.2), Some(session)));
    for ((stem, cfg, options), session) in all {
        let program = CircleRun::from_config(&cfg, options)
            .unwrap()
            .program_with(Dialect::Fanuc, session.as_ref());
        let path = dir.join(format!("{stem}.{}", Dialect::Fanuc.extension()));
        if std::env::var_os("BALLPOD_BLESS").is_some() {
            std::fs::write(&path, &program).unwrap();
        }
        let golden = std::fs::read_to_string(&path).unwrap_or_default();
        assert_eq!(program, golden, "{} differs", path.display());
    }
}

/// The sphere measurement's golden case.
fn sphere() -> SphereTest {
    SphereTest::new([10.0, -20.0, 35.0], 14.2, [90.0, 0.0]).unwrap()
}

#[test]
fn the_fanuc_sphere_program_matches_its_reviewed_golden_file() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/nc/sphere_b90.nc");
    let golden = std::fs::read_to_string(&path).unwrap_or_default();
    assert_eq!(
        sphere().program(Dialect::Fanuc),
        golden,
        "{}",
        path.display()
    );
}

#[test]
fn linuxcnc_programs_differ_only_in_the_dialect() {
    // the framing (%, the O number, M2 / M30) and the comments' letter case
    let body = |p: &str| -> Vec<String> {
        p.lines()
            .filter(|l| !matches!(*l, "%" | "O1000" | "M2" | "M30"))
            .map(str::to_ascii_uppercase)
            .collect()
    };
    // and the probing word (G38.2 / G31)
    let sphere_body = |p: &str| -> Vec<String> { body(&p.replace("G38.2 ", "G31 ")) };
    let (l, f) = (
        sphere().program(Dialect::LinuxCnc),
        sphere().program(Dialect::Fanuc),
    );
    assert_eq!(sphere_body(&l), sphere_body(&f));
    assert_eq!(
        (l.matches("G38.2 ").count(), f.matches("G31 ").count()),
        (9, 9)
    );
    for (stem, cfg, options) in cases() {
        let t = CircleRun::from_config(&cfg, options).unwrap();
        let (l, f) = (t.program(Dialect::LinuxCnc), t.program(Dialect::Fanuc));
        assert_eq!(body(&l), body(&f), "{stem}");
        assert!(l.ends_with("M2\n") && f.ends_with("M30\n%\n"), "{stem}");
        assert!(f.starts_with("%\nO1000\n"), "{stem}");
    }
}

#[test]
fn a_set_up_the_machine_cannot_run_is_refused_with_the_field() {
    let ok = setup(CirclePlane::XY, [0.0, 0.0, 0.0], 150.0, 1000.0);
    let field = |cfg: &Config, o: CircleOptions| CircleRun::from_config(cfg, o).unwrap_err().field;
    let d = CircleOptions::default;
    let mut c = ok;
    c.setup.circle_radius_mm = 0.0;
    assert_eq!(field(&c, d()), "circle_radius");
    c = ok;
    c.setup.circle_radius_mm = f32::NAN;
    assert_eq!(field(&c, d()), "circle_radius");
    c = ok;
    c.setup.circle_feed_mm_per_min = -5.0;
    assert_eq!(field(&c, d()), "circle_feed");
    // a radius the bar cannot reach: beyond the LVDT's ±1.1 mm stroke about bar_length
    c = ok;
    c.setup.circle_radius_mm = 151.2;
    assert_eq!(field(&c, d()), "circle_radius");
    c.setup.circle_radius_mm = 151.0;
    assert!(CircleRun::from_config(&c, d()).is_ok());
    c = ok;
    c.setup.circle_centre_mm[1] = f32::NAN;
    let e = CircleRun::from_config(&c, d()).unwrap_err();
    assert_eq!(
        (e.field, e.what.as_str()),
        ("circle_centre", "circle_centre_y not set")
    );
    // the out-of-plane coordinate may be unknown: that axis is not moved
    c = ok;
    c.setup.circle_centre_mm[2] = f32::NAN;
    let p = CircleRun::from_config(&c, d())
        .unwrap()
        .program(Dialect::LinuxCnc);
    assert!(!p.lines().any(|l| l.starts_with("G0 Z")), "{p}");
    for (o, name) in [
        (
            CircleOptions {
                arc_deg: 0.0,
                ..d()
            },
            "--arc-deg",
        ),
        (
            CircleOptions {
                arc_deg: 400.0,
                ..d()
            },
            "--arc-deg",
        ),
        (
            CircleOptions {
                overshoot_deg: 181.0,
                ..d()
            },
            "--overshoot-deg",
        ),
        (
            CircleOptions {
                feed_in_mm: f64::NAN,
                ..d()
            },
            "--feed-in-mm",
        ),
        (
            CircleOptions {
                directions: vec![],
                ..d()
            },
            "--direction",
        ),
    ] {
        assert_eq!(field(&ok, o), name);
    }
}

/// The docs' example (docs/src/part-programs.md): its set-up file and command, as a user runs them.
#[test]
fn the_readme_example_writes_its_program() {
    let section = ballpod_host::docs::from("# Part programs (`cargo ncgen`)");
    let toml = ballpod_host::docs::block_after("# Part programs (`cargo ncgen`)", "toml");
    // the example command (the first `cargo ncgen -- …` of the section is its synopsis)
    let command = section
        .split_once("`cargo ncgen -- circle circle.toml")
        .expect("the command")
        .1
        .split_once('`')
        .expect("its end")
        .0;
    let command = format!("circle circle.toml{command}");
    let dir = std::env::temp_dir().join(format!("ballpod-ncgen-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("circle.toml"), &toml).unwrap();
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_ncgen"))
        .args(command.split_whitespace())
        .current_dir(&dir)
        .status()
        .unwrap();
    assert!(status.success());
    let program = std::fs::read_to_string(dir.join("circle.ngc")).unwrap();
    // the set-up read from the file: the centre's Z moved to, the radius and the arc in the
    // header, one data arc of 220° per direction
    assert!(program.contains("\nG0 Z-20.0000\n"), "{program}");
    assert!(program.contains("radius 150.0000 mm"), "{program}");
    assert!(
        program.contains("data arc 220.0000 deg from 30.0000 deg"),
        "{program}"
    );
    assert_eq!(program.matches("data arc start").count(), 2);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_set_up_files_arc_and_trigger_make_the_program_unless_an_option_overrides_them() {
    let dir = std::env::temp_dir().join(format!("ballpod-ncgen-file-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("c.toml"),
        "[setup]\ncircle_plane = \"XY\"\ncircle_centre_x = 0.0\ncircle_centre_y = 0.0\n\
         circle_radius = 150.0\nbar_length = 150.0\ncircle_feed = 1000.0\n\
         circle_arc = 300.0\nrun_trigger = \"FEED_IN\"\n",
    )
    .unwrap();
    let ncgen = |extra: &[&str]| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_ncgen"))
            .args(["circle", "c.toml"])
            .args(extra)
            .current_dir(&dir)
            .output()
            .unwrap();
        assert!(out.status.success(), "{out:?}");
        String::from_utf8(out.stdout).unwrap()
    };
    let from_file = ncgen(&[]);
    assert!(from_file.contains("data arc 300.0000 deg"), "{from_file}");
    assert!(from_file.contains("circle_arc 300.0000"), "{from_file}");
    assert!(from_file.contains("run_trigger FEED_IN"), "{from_file}");
    let overridden = ncgen(&["--arc-deg", "360", "--trigger", "command"]);
    assert!(overridden.contains("data arc 360.0000 deg"), "{overridden}");
    assert!(overridden.contains("run_trigger COMMAND"), "{overridden}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A program without what the dialects do differently: the framing (`%`, `O1000`, `M2` /
/// `M30`), the comments' case and the dwell word (`G4 P` seconds / `G4 X` seconds).
fn dialect_free(p: &str) -> Vec<String> {
    p.lines()
        .filter(|l| !matches!(*l, "%" | "O1000" | "M2" | "M30"))
        .map(|l| l.replace("G4 P", "G4 X").to_ascii_uppercase())
        .collect()
}

/// The SSM station set's golden case: socket 150 mm below the target, bar 150 mm, four
/// stations 10° apart.
fn ssm(stations: usize) -> ballpod_host::ncgen::SsmTest {
    let mut cfg = Config {
        bar_length_mm: 150.0,
        ..Config::default()
    };
    cfg.setup.ssm_socket_mm = [20.0, -10.0, -150.0];
    ballpod_host::ncgen::SsmTest::from_config(&cfg, [20.0, -10.0, 0.0], 10.0, stations, 1000.0)
        .unwrap()
}

#[test]
fn the_ssm_station_set_matches_its_golden_file_and_differs_from_linuxcnc_only_in_the_dialect() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/nc/ssm_4.nc");
    let golden = std::fs::read_to_string(&path).unwrap_or_default();
    let (l, f) = (
        ssm(4).program(Dialect::LinuxCnc),
        ssm(4).program(Dialect::Fanuc),
    );
    assert_eq!(f, golden, "{}", path.display());
    assert_eq!(dialect_free(&l), dialect_free(&f));
    assert_eq!(
        (l.matches("G4 P0.3").count(), f.matches("G4 X0.3").count()),
        (4, 4)
    );
}

#[test]
fn ssm_stations_lie_on_the_bar_sphere_with_the_conditioning_the_spec_tabulates() {
    // spec seed-000 TV-SSM-cond: three stations, θ = 10°, L = 150: Frobenius cond(U) = 19.9
    let t = ssm(3);
    let u: Vec<[f64; 3]> = t
        .stations_mm()
        .iter()
        .map(|p| std::array::from_fn(|k| (p[k] - t.socket_mm[k]) / 150.0))
        .collect();
    for d in &u {
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
        assert!((n - 1.0).abs() < 1e-12, "on the sphere");
    }
    let m = nalgebra::Matrix3::from_fn(|i, j| u[i][j]);
    let inv = m.try_inverse().expect("not coplanar with the socket");
    let cond = m.norm() * inv.norm();
    assert!((cond - 19.9).abs() < 0.05, "cond {cond}");
    // first station towards the target, the others 10° from it
    assert!((u[0][2] - 1.0).abs() < 1e-12);
    for d in &u[1..] {
        assert!((d[2] - 10f64.to_radians().cos()).abs() < 1e-12);
    }
}

#[test]
fn an_ssm_set_up_the_machine_cannot_run_is_refused_with_the_field() {
    use ballpod_host::ncgen::SsmTest;
    let mut cfg = Config::default();
    let e = SsmTest::from_config(&cfg, [0.0; 3], 10.0, 4, 1000.0).unwrap_err();
    assert_eq!(e.field, "ssm_socket_x");
    cfg.setup.ssm_socket_mm = [0.0; 3];
    assert_eq!(
        SsmTest::from_config(&cfg, [0.0; 3], 10.0, 4, 1000.0)
            .unwrap_err()
            .field,
        "--target"
    );
    let at = [0.0, 0.0, 150.0];
    for (sep, n, feed, field) in [
        (0.0, 4, 1000.0, "--separation-deg"),
        (50.0, 4, 1000.0, "--separation-deg"),
        (10.0, 2, 1000.0, "--stations"),
        (10.0, 9, 1000.0, "--stations"),
        (10.0, 4, 0.0, "--feed"),
    ] {
        assert_eq!(
            SsmTest::from_config(&cfg, at, sep, n, feed)
                .unwrap_err()
                .field,
            field
        );
    }
}

/// The seed 002 pattern programs' golden cases: BX (a B quarter turn) and CR2 (a C revolution
/// with the simultaneous X Y Z path) of the thesis's Table 4.3 set-up, 8 blocks a run, CCW then
/// CW, F1000 — small enough to review line by line.
fn pattern(step: ballpod::app::Pattern) -> ballpod_host::ncgen::PatternTest {
    let mut cfg = Config::default();
    ballpod::app::bc_ballbar::Setup::thesis_table_4_3().to_config(&mut cfg.setup);
    ballpod_host::ncgen::PatternTest::from_config(
        &cfg,
        step,
        8,
        1000.0,
        vec![ballpod::app::Direction::Ccw, ballpod::app::Direction::Cw],
    )
    .unwrap()
}

#[test]
fn the_pattern_programs_match_their_golden_files_and_differ_from_linuxcnc_only_in_the_dialect() {
    use ballpod::app::Pattern;
    for (step, stem) in [
        (Pattern::Bx, "pattern_bx_8"),
        (Pattern::Cr2, "pattern_cr2_8"),
    ] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/data/nc/{stem}.nc"));
        let (l, f) = (
            pattern(step).program(Dialect::LinuxCnc),
            pattern(step).program(Dialect::Fanuc),
        );
        if std::env::var_os("BALLPOD_BLESS").is_some() {
            std::fs::write(&path, &f).unwrap();
        }
        let golden = std::fs::read_to_string(&path).unwrap_or_default();
        assert_eq!(f, golden, "{}", path.display());
        assert_eq!(dialect_free(&l), dialect_free(&f), "{stem}");
    }
}

/// The two-step set-ups of the docs' examples: RRTTT / RTTTR spindle (pivot after the
/// translation, tool z_r −250 mm, rotation A20 B30 / B20) and TTTRR / RTTTR table (table
/// origin, z_αγ 80 mm, reference ball (60, −20, 30) mm, A15 C40 / A15); bar 150 mm.
fn two_step_cfg(machine: ballpod::config::TwoStepMachine) -> Config {
    use ballpod::config::TwoStepMachine as M;
    let mut cfg = Config {
        bar_length_mm: 150.0,
        ..Config::default()
    };
    let s = &mut cfg.setup;
    s.ts_machine = machine;
    match machine {
        M::Rrttt | M::RtttrSpindle => {
            s.ts_origin_mm = [-50.0, -15.0, 500.0];
            s.ts_tool_z_mm = -250.0;
            s.ts_angles_deg = if machine == M::Rrttt {
                [20.0, 30.0]
            } else {
                [20.0, f32::NAN]
            };
        }
        _ => {
            s.ts_origin_mm = [-30.0, 15.0, 120.0];
            s.ts_z_alpha_gamma_mm = 80.0;
            s.ts_reference_mm = [60.0, -20.0, 30.0];
            s.ts_angles_deg = if machine == M::Tttrr {
                [15.0, 40.0]
            } else {
                [15.0, f32::NAN]
            };
        }
    }
    cfg
}

/// The numbers after `key` in a header line (`socket X… Y… Z…`).
fn xyz_after(line: &str, key: &str) -> [f64; 3] {
    let rest = &line[line.find(key).unwrap() + key.len()..];
    let w: Vec<&str> = rest.split_whitespace().take(3).collect();
    std::array::from_fn(|i| w[i][1..].trim_end_matches([',', ')']).parse().unwrap())
}

/// Seed 000's two-step program for each machine type, checked with the independent forward
/// model of eqs 2/4, 8, 13/15 and 14/16 (`forward_seed000`: the ball of the chain at the
/// rotary words, the programmed point being the ball at zero angles): the first station of
/// each run is the ball at the origin after the translation, at zero angles and at the angles;
/// every station and every move of both runs keeps the ball on the bar's sphere about the one
/// socket within 1 µm; the pod's ssm_socket of each run (the header) sees the programmed points
/// at the bar's length; the rotation happens only with the bar off (M0); refusals name their
/// field.
#[test]
fn the_two_step_program_keeps_the_ball_on_the_bar_sphere_at_both_locations() {
    use ballpod::config::TwoStepMachine as M;
    use ballpod_host::forward_seed000 as fwd;
    for machine in [M::Rrttt, M::RtttrSpindle, M::Tttrr, M::RtttrTable] {
        let cfg = two_step_cfg(machine);
        let test = ballpod_host::ncgen::TwoStepTest::from_config(&cfg, 10.0, 4, 1000.0).unwrap();
        let program = test.program(Dialect::LinuxCnc);
        let header: Vec<&str> = program.lines().take(4).collect();
        let socket = xyz_after(header[2], "socket ");
        let pod_sockets = [
            xyz_after(header[3], "run 1 ssm_socket "),
            xyz_after(header[3], "run 2 ssm_socket "),
        ];
        let t = &cfg.setup;
        let origin = t.ts_origin_mm.map(f64::from);
        let (z_r, z_ag) = (f64::from(t.ts_tool_z_mm), f64::from(t.ts_z_alpha_gamma_mm));
        let r = t.ts_reference_mm.map(f64::from);
        // the ball of the chain from the origin p at the words (A, B, C) in radians
        let ball = |p: [f64; 3], w: [f64; 3]| match machine {
            M::Rrttt => fwd::rrttt_tip(p, [0.0; 3], w[0], w[1], z_r),
            M::RtttrSpindle => fwd::rtttr_tip(p, [0.0; 3], w[1], z_r),
            M::Tttrr => fwd::tttrr_point(p, [0.0; 3], w[0], w[2], z_ag, r),
            _ => fwd::rtttr_table_point(p, [0.0; 3], w[0], r),
        };
        // the programmed point is the ball at zero angles: the origin is that less c(0)
        let c0 = ball([0.0; 3], [0.0; 3]);
        let at = |xyz: [f64; 3], w: [f64; 3]| ball(std::array::from_fn(|i| xyz[i] - c0[i]), w);
        let dist = |p: [f64; 3], q: [f64; 3]| {
            ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
        };
        let (mut pos, mut rot) = ([f64::NAN; 3], [0.0f64; 3]);
        let (mut run, mut stops, mut dwells) = (0usize, 0, vec![Vec::new(), Vec::new()]);
        for line in program.lines() {
            let code = line.split('(').next().unwrap().trim();
            if code == "M0" {
                stops += 1;
                continue;
            }
            if code.starts_with("G4") {
                dwells[run].push((pos, rot));
                continue;
            }
            if !(code.starts_with("G0") || code.starts_with("G1")) {
                continue;
            }
            let before = rot;
            for w in code.split_whitespace() {
                let v = || w[1..].parse::<f64>().unwrap();
                match &w[..1] {
                    "X" => pos[0] = v(),
                    "Y" => pos[1] = v(),
                    "Z" => pos[2] = v(),
                    "A" => rot[0] = v().to_radians(),
                    "B" => rot[1] = v().to_radians(),
                    "C" => rot[2] = v().to_radians(),
                    _ => {}
                }
            }
            if rot != before {
                // the rotation: only after the first run, the bar off
                assert_eq!((run, stops), (0, 2), "{machine:?}: {line}");
                run = 1;
            }
            // every point of a run: the ball on the bar's sphere (the G0 to run 2's first
            // station is the rotation itself, with the bar off)
            assert!(
                (dist(at(pos, rot), socket) - 150.0).abs() < 1e-3,
                "{machine:?}: {line}"
            );
            // the pod's view: the programmed point from the run's ssm_socket
            assert!(
                (dist(pos, pod_sockets[run]) - 150.0).abs() < 1e-3,
                "{machine:?}: {line}"
            );
        }
        assert_eq!(stops, 3, "mount, off, mount again");
        assert_eq!((dwells[0].len(), dwells[1].len()), (4, 4));
        let words = |a: [f32; 2]| -> [f64; 3] {
            let d = |k: usize| f64::from(a[k]).to_radians();
            match machine {
                M::Rrttt => [d(0), d(1), 0.0],
                M::RtttrSpindle => [0.0, d(0), 0.0],
                M::Tttrr => [d(0), 0.0, d(1)],
                _ => [d(0), 0.0, 0.0],
            }
        };
        let want = [ball(origin, [0.0; 3]), ball(origin, words(t.ts_angles_deg))];
        for ((p, w), b) in [dwells[0][0], dwells[1][0]].iter().zip(want) {
            assert!(dist(at(*p, *w), b) < 1e-4, "{machine:?}: {p:?} {b:?}");
        }
        // both runs' first stations are the same programmed point: the linear axes stand
        // still through the rotation
        assert!(dist(dwells[0][0].0, dwells[1][0].0) < 1e-4, "{machine:?}");
    }
    // refusals name their field
    let mut cfg = two_step_cfg(M::Tttrr);
    cfg.setup.ts_reference_mm[1] = f32::NAN;
    let e = ballpod_host::ncgen::TwoStepTest::from_config(&cfg, 10.0, 4, 1000.0).unwrap_err();
    assert_eq!(e.field, "ts_reference_y");
    let mut cfg = two_step_cfg(M::Rrttt);
    cfg.setup.ts_tool_z_mm = f32::NAN;
    let e = ballpod_host::ncgen::TwoStepTest::from_config(&cfg, 10.0, 4, 1000.0).unwrap_err();
    assert_eq!(e.field, "ts_tool_z");
    cfg.setup.ts_tool_z_mm = -450.0;
    cfg.setup.ts_angles_deg = [60.0, 40.0];
    let e = ballpod_host::ncgen::TwoStepTest::from_config(&cfg, 10.0, 4, 1000.0).unwrap_err();
    assert_eq!(e.field, "bar_length", "{e}");
    cfg.setup.ts_machine = M::None;
    let e = ballpod_host::ncgen::TwoStepTest::from_config(&cfg, 10.0, 4, 1000.0).unwrap_err();
    assert_eq!(e.field, "ts_machine");
}

#[test]
fn the_two_step_program_matches_its_golden_file_and_differs_from_linuxcnc_only_in_the_dialect() {
    let cfg = two_step_cfg(ballpod::config::TwoStepMachine::Rrttt);
    let test = ballpod_host::ncgen::TwoStepTest::from_config(&cfg, 10.0, 3, 1000.0).unwrap();
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/nc/two_step_rrttt.nc");
    let golden = std::fs::read_to_string(&path).unwrap_or_default();
    let (l, f) = (
        test.program(Dialect::LinuxCnc),
        test.program(Dialect::Fanuc),
    );
    assert_eq!(f, golden, "{}", path.display());
    assert_eq!(dialect_free(&l), dialect_free(&f));
}

/// The extents the travel check reads from a program, against hand-computed arcs: a CCW half
/// turn passes 90° (not 270°), the same CW passes 270°, a G18 arc works in Z, X, a full turn
/// (start = end) reaches all four extremes, a G4's X is a time, not a position.
#[test]
fn program_extents_follow_the_arcs() {
    use ballpod_host::ncgen::extents;
    let near = |got: Option<(f64, f64)>, want: (f64, f64)| {
        let (a, b) = got.unwrap();
        assert!(
            (a - want.0).abs() < 1e-9 && (b - want.1).abs() < 1e-9,
            "{got:?} {want:?}"
        );
    };
    let e = extents("G17 G90\nG0 X10 Y0 Z5\nG3 X-10 Y0 I-10 J0\nG4 X99\n").unwrap();
    near(e[0], (-10.0, 10.0));
    near(e[1], (0.0, 10.0));
    near(e[2], (5.0, 5.0));
    assert_eq!(e[3], None);
    let e = extents("G17\nG0 X10 Y0\nG2 X-10 Y0 I-10 J0\n").unwrap();
    near(e[1], (-10.0, 0.0));
    // G18: the plane (Z, X) with offsets K, I; (Z 10, X 0) is at 0°, (Z 0, X 10) at 90°: a CCW
    // quarter turn passes no other extreme
    let e = extents("G18\nG0 X0 Z10\nG3 X10 Z0 I0 K-10\n").unwrap();
    near(e[0], (0.0, 10.0));
    near(e[2], (0.0, 10.0));
    let e = extents("G17\nG0 X5 Y0\nG3 X5 Y0 I-5 J0\n").unwrap();
    near(e[0], (-5.0, 5.0));
    near(e[1], (-5.0, 5.0));
}

/// A program beyond the set-up file's travel is refused naming the axis; within it passes.
#[test]
fn programs_beyond_the_travel_are_refused_naming_the_axis() {
    use ballpod_host::ncgen::{Travel, check_travel};
    let (_, cfg, options) = cases().into_iter().next().unwrap(); // the XY circle, R 150 about 0
    let circle = CircleRun::from_config(&cfg, options)
        .unwrap()
        .program(Dialect::LinuxCnc);
    let tight = Travel {
        x_mm: Some([-100.0, 100.0]),
        ..Travel::default()
    };
    let e = check_travel(&circle, &tight).unwrap_err();
    assert_eq!(e.field, "travel.x_mm", "{e}");
    let roomy = Travel {
        x_mm: Some([-200.0, 200.0]),
        y_mm: Some([-200.0, 200.0]),
        ..Travel::default()
    };
    check_travel(&circle, &roomy).unwrap();
    let bx = pattern(ballpod::app::Pattern::Bx).program(Dialect::Fanuc);
    let b60 = Travel {
        b_deg: Some([0.0, 60.0]),
        ..Travel::default()
    };
    assert_eq!(check_travel(&bx, &b60).unwrap_err().field, "travel.b_deg");
    let upside_down = Travel {
        z_mm: Some([10.0, -10.0]),
        ..Travel::default()
    };
    assert_eq!(
        check_travel(&bx, &upside_down).unwrap_err().field,
        "travel.z_mm"
    );
}

/// One direction convention (`Direction`: θ increasing in the pattern's plane, so for the B arcs
/// in XZ B 90° → 0° is CCW): a B pattern program's run and the served pod's built-in motion of
/// the same direction turn B the same way, so a run's label in the pod's log and results is the
/// program's.
#[test]
fn a_b_pattern_program_and_the_served_pods_motion_turn_b_alike_for_each_direction() {
    use ballpod::app::Pattern;
    use ballpod_host::vmt::motion::{Motion, ServeTruth};
    let mut cfg = Config::default();
    ballpod::app::bc_ballbar::Setup::thesis_table_4_3().to_config(&mut cfg.setup);
    for d in Direction::ALL {
        let program =
            ballpod_host::ncgen::PatternTest::from_config(&cfg, Pattern::Bx, 8, 1000.0, vec![d])
                .unwrap()
                .program(Dialect::Fanuc);
        let b: Vec<f64> = program
            .lines()
            .filter(|l| l.starts_with("G1 "))
            .map(|l| {
                let w = l.split_whitespace().find(|w| w.starts_with('B')).unwrap();
                w[1..].parse().unwrap()
            })
            .collect();
        let mut motion = Motion::plan(&ServeTruth::default(), &cfg, Pattern::Bx, d, 0).unwrap();
        let first = motion.start().unwrap()[3];
        let mut last = first;
        while let Some(s) = motion.next_step() {
            last = s.axes[3];
        }
        let want = if d == Direction::Ccw { -1.0 } else { 1.0 };
        assert_eq!(
            (b[b.len() - 1] - b[0]).signum(),
            want,
            "program {d:?}: {b:?}"
        );
        assert_eq!(
            (last - first).signum(),
            want,
            "motion {d:?}: {first} → {last}"
        );
    }
}
