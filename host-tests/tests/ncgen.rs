//! The part-program generator: the ISO/Fanuc circle programs against reviewed golden files
//! (`tests/data/nc/`), the LinuxCNC programs differing from them only where the dialect does,
//! and a set-up the machine cannot run refused with the field named. (LinuxCNC's interpreter
//! checks the programs' geometry: `host-tests/nc/test_rs274.py`.)
use std::path::Path;

use ballpod::app::Direction;
use ballpod::config::{CirclePlane, Config};
use ballpod_host::ncgen::{CircleOptions, CircleTest, Dialect, SphereTest};

fn setup(plane: CirclePlane, centre: [f32; 3], radius: f32, feed: f32) -> Config {
    let mut c = Config::default();
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
    for (stem, cfg, options) in cases() {
        let program = CircleTest::from_config(&cfg, options)
            .unwrap()
            .program(Dialect::Fanuc);
        let path = dir.join(format!("{stem}.{}", Dialect::Fanuc.extension()));
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
        let t = CircleTest::from_config(&cfg, options).unwrap();
        let (l, f) = (t.program(Dialect::LinuxCnc), t.program(Dialect::Fanuc));
        assert_eq!(body(&l), body(&f), "{stem}");
        assert!(l.ends_with("M2\n") && f.ends_with("M30\n%\n"), "{stem}");
        assert!(f.starts_with("%\nO1000\n"), "{stem}");
    }
}

#[test]
fn a_set_up_the_machine_cannot_run_is_refused_with_the_field() {
    let ok = setup(CirclePlane::XY, [0.0, 0.0, 0.0], 150.0, 1000.0);
    let field = |cfg: &Config, o: CircleOptions| CircleTest::from_config(cfg, o).unwrap_err().field;
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
    c = ok;
    c.setup.circle_centre_mm[1] = f32::NAN;
    let e = CircleTest::from_config(&c, d()).unwrap_err();
    assert_eq!(
        (e.field, e.what.as_str()),
        ("circle_centre", "circle_centre_y not set")
    );
    // the out-of-plane coordinate may be unknown: that axis is not moved
    c = ok;
    c.setup.circle_centre_mm[2] = f32::NAN;
    let p = CircleTest::from_config(&c, d())
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

/// README's example: its set-up file and command, as a user runs them.
#[test]
fn the_readme_example_writes_its_program() {
    let section = ballpod_host::readme::from("## Part programs");
    let toml = ballpod_host::readme::block_after("## Part programs", "toml");
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
    // the framing, the comments' case and the dwell word (G4 P seconds / G4 X seconds)
    let body = |p: &str| -> Vec<String> {
        p.lines()
            .filter(|l| !matches!(*l, "%" | "O1000" | "M2" | "M30"))
            .map(|l| l.replace("G4 P", "G4 X").to_ascii_uppercase())
            .collect()
    };
    assert_eq!(body(&l), body(&f));
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
    ballpod::app::seed002::Setup::thesis_table_4_3().to_config(&mut cfg.setup);
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
    for (step, stem) in [(Pattern::Bx, "pattern_bx_8"), (Pattern::Cr2, "pattern_cr2_8")] {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("tests/data/nc/{stem}.nc"));
        let golden = std::fs::read_to_string(&path).unwrap_or_default();
        let (l, f) = (
            pattern(step).program(Dialect::LinuxCnc),
            pattern(step).program(Dialect::Fanuc),
        );
        assert_eq!(f, golden, "{}", path.display());
        let body = |p: &str| -> Vec<String> {
            p.lines()
                .filter(|l| !matches!(*l, "%" | "O1000" | "M2" | "M30"))
                .map(|l| l.to_ascii_uppercase())
                .collect()
        };
        assert_eq!(body(&l), body(&f), "{stem}");
    }
}
