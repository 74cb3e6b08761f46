//! `cargo ncgen -- correct` (seed 002 chapter 3 compensation out as a part program): the five
//! pattern programs corrected with the deviations the simulated pod identified, each block's
//! point checked with the independent forward model (`forward_seed002::actual_and_ideal`, the
//! literal HTM chain): on a machine with the identified deviations the corrected commands land
//! on the ideal workpiece points (to the program's 0.1 µm resolution); on the true machine
//! within the identification's accuracy, where the uncorrected program misses by tens of µm.
//! Bad programs are refused with the line named.
use ballpod::app::Pattern;
use ballpod::identify::multitasking::Deviations;
use ballpod_host::forward_seed002 as fwd;
use ballpod_host::forward_seed004 as fw4;
use ballpod_host::ncgen::{
    Dialect, PatternTest, centrelines_from_toml, correct_program, correct_program_centrelines,
    deviations_from_results,
};
use ballpod_host::simulate::{SimOptions, simulate};
use ballpod_host::vmt::machine::MachineFile;

/// The X Y Z B C of every G0/G1 block (the programs write all five words).
fn points(program: &str) -> Vec<[f64; 5]> {
    points_of(program, "XYZBC")
}

/// The five `axes` words of every G0/G1 block, in that order.
fn points_of(program: &str, axes: &str) -> Vec<[f64; 5]> {
    program
        .lines()
        .filter(|l| l.starts_with("G0 ") || l.starts_with("G1 "))
        .map(|l| {
            let code = l.split('(').next().unwrap_or("");
            let mut p = [f64::NAN; 5];
            for w in code.split_whitespace() {
                if let Some(k) = axes.find(&w[..1]) {
                    p[k] = w[1..].parse().unwrap();
                }
            }
            assert!(p.iter().all(|v| v.is_finite()), "{l}");
            p
        })
        .collect()
}

/// |actual − ideal| of commanding `cmd` for the ideal point of `nominal`, µm.
fn miss_um(d: &Deviations, nominal: &[f64; 5], cmd: &[f64; 5]) -> f64 {
    let (b, c) = (nominal[3].to_radians(), nominal[4].to_radians());
    let (_, ideal) =
        fwd::actual_and_ideal(&d.to_array(), [nominal[0], nominal[1], nominal[2]], b, c);
    let (act, _) = fwd::actual_and_ideal(&d.to_array(), [cmd[0], cmd[1], cmd[2]], b, c);
    (0..3)
        .map(|k| (act[k] - ideal[k]).powi(2))
        .sum::<f64>()
        .sqrt()
        * 1e3
}

#[test]
fn corrected_programs_reach_the_ideal_points() {
    let m = MachineFile::default();
    let o = SimOptions {
        repeats: 1,
        circle: false,
        ..SimOptions::default()
    };
    let sim = simulate(&m, &o, &mut |_, _, _| {}).expect("simulated session");
    let identified = deviations_from_results(&sim.report.to_json().unwrap()).unwrap();
    let truth = m.seed002.deviations();
    let cfg = {
        let mut c = ballpod::config::Config::default();
        ballpod::app::seed002::Setup::thesis_table_4_3().to_config(&mut c.setup);
        c
    };
    for step in Pattern::SEED002 {
        let steps = PatternTest::default_steps(&cfg, step, 1000.0).unwrap();
        let test = PatternTest::from_config(
            &cfg,
            step,
            steps,
            1000.0,
            vec![ballpod::app::Direction::Ccw],
        )
        .unwrap();
        let program = test.program(Dialect::LinuxCnc);
        let corrected = correct_program(&program, [0.0; 3], &identified, "results.json").unwrap();
        let (nominal, cmd) = (points(&program), points(&corrected));
        assert_eq!(nominal.len(), cmd.len());
        let (mut on_model, mut on_truth, mut uncorrected) = (0.0f64, 0.0f64, f64::INFINITY);
        for (n, c) in nominal.iter().zip(&cmd) {
            assert_eq!((n[3], n[4]), (c[3], c[4]), "B and C as programmed");
            on_model = on_model.max(miss_um(&identified, n, c));
            on_truth = on_truth.max(miss_um(&truth, n, c));
            uncorrected = uncorrected.min(miss_um(&truth, n, n));
        }
        let name = step.name();
        // 4 decimals per word: ≤ 0.05 µm per axis
        assert!(
            on_model < 0.09,
            "{name}: {on_model} µm on the identified machine"
        );
        assert!(on_truth < 0.5, "{name}: {on_truth} µm on the true machine");
        assert!(
            uncorrected > 50.0 * on_truth,
            "{name}: uncorrected {uncorrected} µm"
        );
        println!(
            "{name}: corrected miss {on_truth:.3} µm (identified machine {on_model:.3}), uncorrected ≥ {uncorrected:.1} µm"
        );
    }
}

#[test]
fn bad_programs_and_results_are_refused_naming_what() {
    let dev = Deviations::default();
    // a dwell's X (its time on an ISO/Fanuc control) is not a point: passed unchanged
    let dwell = "G21 G90\nG1 X1 Y0 Z0 B0 C0 F100\nG4 X0.3\nG1 X2\n";
    let c = correct_program(dwell, [0.0; 3], &dev, "r").unwrap();
    assert!(
        c.contains("\nG4 X0.3\n") && c.contains("G1 X2.0000 Y0.0000 Z0.0000"),
        "{c}"
    );
    for (program, says) in [
        (
            "G21 G90\nG1 X1 Y0 Z0 B0 C0 F100\nG2 X0 Y1 I-1 J0\n",
            "line 3",
        ),
        ("G1 X1 F100\n", "Y not programmed yet"),
        ("G1 X1 Y0 Z0 B0 C0 F100\nG92 X0\n", "G92"),
        ("X1 Y2 Z3\n", "before any G0/G1"),
    ] {
        let e = correct_program(program, [0.0; 3], &dev, "r").unwrap_err();
        assert!(e.what.contains(says), "{program:?}: {e}");
    }
    let missing = r#"{"results": [{"name": "dx_BT", "value": 0.1}]}"#;
    assert!(
        deviations_from_results(missing)
            .unwrap_err()
            .what
            .contains("dz_BT not identified")
    );
    assert!(deviations_from_results("not json").is_err());
}

/// Seed 004's groove test (§4.2): the work block at (−63.72, −70.71, 258.75) mm, one groove
/// per posture A0B0 … A180B75 (table axes primed), its points `moves` (word, X offset in mm)
/// along the block as a post-processor writes them with the NC-set centrelines (A ∥ Z, B ∥ Y
/// through the origin: eq 9's V2, the independent forward model). Returns the program and per
/// point (work point, physical ε, physical φ, V2).
#[allow(clippy::type_complexity)]
fn groove(moves: &[(&str, f64)]) -> (String, Vec<([f64; 3], f64, f64, [f64; 3])>) {
    let block = [-63.72, -70.71, 258.75];
    let mut program = String::from("G21 G90 G94\n");
    let mut work = Vec::new();
    for (k, (a_cmd, b_cmd)) in [(0.0f64, 0.0f64), (60.0, 25.0), (120.0, 50.0), (180.0, 75.0)]
        .into_iter()
        .enumerate()
    {
        let (eps, phi) = ((-a_cmd).to_radians(), (-b_cmd).to_radians());
        for (g, dx) in moves {
            let p = [block[0] + dx, block[1] + 10.0 + 8.0 * k as f64, block[2]];
            let v2 = fw4::eq9(
                p,
                [0.0, 0.0, 1.0],
                [0.0; 3],
                [0.0, 1.0, 0.0],
                [0.0; 3],
                eps,
                phi,
            );
            program += &format!(
                "{g} X{:.4} Y{:.4} Z{:.4} A{a_cmd} B{b_cmd} F500\n",
                v2[0], v2[1], v2[2]
            );
            work.push((p, eps, phi, v2));
        }
    }
    program += "M2\n";
    (program, work)
}

/// Seed 004 §4.3 on its groove test (work block at (−63.72, −70.71, 258.75) mm, grooves at the
/// postures A0B0 … A180B75): the program a post-processor writes with the NC-set centrelines
/// (eq 9's V2, from the independent forward model `forward_seed004::eq9`, table axes primed),
/// corrected with the docs' example centrelines (docs/src/part-programs.md), commands each point where the machine
/// with those centrelines actually carries the work point (V1) — within the words' 0.1 µm —
/// where the uncorrected program misses by up to hundreds of µm. A and B stay as programmed.
#[test]
fn a_program_corrected_for_the_centrelines_reaches_the_work_points() {
    let toml = ballpod_host::docs::block_after("**Centrelines file**", "toml");
    let lines = centrelines_from_toml(&toml).expect("the docs' centrelines file");
    let a = &lines.actual;
    let (program, work) = groove(&[("G0", 5.0), ("G1", 45.0)]);
    let corrected = correct_program_centrelines(&program, &lines, "centrelines.toml").unwrap();
    let pts = points_of(&corrected, "XYZAB");
    assert_eq!(pts.len(), work.len());
    let mut worst_uncorrected = 0.0f64;
    for (c, (p, eps, phi, v2)) in pts.iter().zip(&work) {
        let v1 = fw4::eq9(
            *p,
            a.a_direction,
            a.a_point_mm,
            a.b_direction,
            a.b_point_mm,
            *eps,
            *phi,
        );
        let miss = (0..3).map(|i| (c[i] - v1[i]).powi(2)).sum::<f64>().sqrt() * 1e3;
        // V2 written to 0.1 µm, V1 written to 0.1 µm: ≤ √3·0.1 µm
        assert!(miss <= 0.18, "{c:?} vs {v1:?}: {miss} um");
        let before = (0..3).map(|i| (v2[i] - v1[i]).powi(2)).sum::<f64>().sqrt() * 1e3;
        worst_uncorrected = worst_uncorrected.max(before);
        assert_eq!(
            (c[3], c[4]),
            (-eps.to_degrees().round(), -phi.to_degrees().round())
        );
    }
    assert!(worst_uncorrected > 100.0, "{worst_uncorrected}");
    assert!(
        corrected.contains("(corrected by ballpod ncgen for the centrelines of centrelines.toml")
    );
    // a C word is not an axis of this machine; a zero direction is refused
    let e = correct_program_centrelines("G1 X1 Y2 Z3 A0 B0 C5\n", &lines, "c").unwrap_err();
    assert!(e.what.contains("C5") && e.what.contains("XYZAB"), "{e}");
    let zero = toml.replacen("a_direction = [", "a_direction = [0.0, 0.0, 0.0] #", 1);
    assert!(centrelines_from_toml(&zero).is_err());
    let sense = toml.replacen("a = \"primed\"", "a = \"left\"", 1);
    let e = correct_program_centrelines(&program, &centrelines_from_toml(&sense).unwrap(), "c")
        .unwrap_err();
    assert_eq!(e.field, "sense.a");
}

/// Seed 004 end to end: a table-swivel machine with tilted, offset centrelines; the dial-gauge
/// procedure simulated with the independent forward model (face heights read by a gauge with
/// 0.2 µm noise: the top face at A 0/90/180/270, a side face at B 0/30/60/90, a vertex at each
/// angle with 0.2 µm noise per coordinate); the core identifies both lines
/// (`axis_direction_lsq`, `axis_centre`); `ncgen correct-centrelines` with those lines rewrites
/// the groove program; on the **true** machine (eq 9) the corrected points miss the work points
/// by no more than the identification's stated uncertainty carries (3u: the tilt u times the
/// lever arm and the centre u), where the uncorrected ones miss by more than 100 µm.
#[test]
fn a_program_corrected_with_identified_centrelines_reaches_the_work_points_within_u() {
    use ballpod::identify::centreline::{
        DialPoint, GaugeFrame, NominalAxis, NormalAtAngle, PointAtAngle, RotationSense,
        axis_centre, axis_direction_lsq, plane_normal,
    };
    use ballpod_host::ncgen::{CentrelinePair, CentrelinesFile};
    const Z: [f64; 3] = [0.0, 0.0, 1.0];
    const Y: [f64; 3] = [0.0, 1.0, 0.0];
    let mut rng = fw4::SplitMix(11);
    let sigma_um = 0.2;
    // the true lines (A the table on B, both primed)
    let (da, pa) = (fw4::normalize([1.6e-3, 0.4e-3, 1.0]), [0.012, -0.008, 0.0]);
    let (db, pb) = (fw4::normalize([0.2e-3, 1.0, 0.05e-3]), [0.006, 0.0, 0.015]);
    let phys = |cmd_deg: f64| -cmd_deg.to_radians(); // primed
    let frame = |w: [f64; 3], hint: [f64; 3]| {
        let w = fw4::normalize(w);
        let u = fw4::normalize(fw4::sub(hint, fw4::scale(fw4::dot(hint, w), w)));
        GaugeFrame {
            lateral_u: u,
            lateral_v: fw4::cross(w, u),
            reading_dir: w,
        }
    };
    let grid = [
        (0.0, 0.0),
        (80.0, 0.0),
        (0.0, 80.0),
        (80.0, 80.0),
        (40.0, 40.0),
    ];
    let mut face = |n: [f64; 3], g: &GaugeFrame| -> [f64; 3] {
        let pts: Vec<DialPoint> = grid
            .iter()
            .map(|&(u, v)| DialPoint {
                u_mm: u,
                v_mm: v,
                reading_um: fw4::dial_reading_um(
                    n,
                    g.lateral_u,
                    g.lateral_v,
                    g.reading_dir,
                    u,
                    v,
                    0.0,
                ) + sigma_um * rng.normal(),
            })
            .collect();
        plane_normal(&pts, g).unwrap().normal
    };
    // the face normal near +Z at 0°, turned about the true line `d`, read by a gauge along the
    // nominal normal (the nominal axis turned) at each commanded angle
    let n_top = fw4::normalize([0.3e-3, -0.2e-3, 1.0]);
    let mut normals = |d: [f64; 3], nominal: [f64; 3], cmds: &[f64], hint: [f64; 3]| {
        cmds.iter()
            .map(|&c| NormalAtAngle {
                commanded_deg: c,
                normal: face(
                    fw4::mul(fw4::rodrigues(d, phys(c)), n_top),
                    &frame(fw4::mul(fw4::rodrigues(nominal, phys(c)), Z), hint),
                ),
            })
            .collect::<Vec<_>>()
    };
    // A: the top face at A 0/90/180/270; B: at B 0/30/60/90
    let (a_cmds, b_cmds) = ([0.0, 90.0, 180.0, 270.0], [0.0, 30.0, 60.0, 90.0]);
    let a_normals = normals(da, Z, &a_cmds, [1.0, 0.0, 0.0]);
    let b_normals = normals(db, Y, &b_cmds, Y);
    let a_dir = axis_direction_lsq(&a_normals, RotationSense::Primed, Z).unwrap();
    let b_dir = axis_direction_lsq(&b_normals, RotationSense::Primed, Y).unwrap();
    // the centres from a vertex at each angle (A: its X Y; B: its X Z), 0.2 µm per coordinate
    let mut vertex = |d: [f64; 3], p: [f64; 3], cmds: &[f64], v: [f64; 3], k: [usize; 2]| {
        cmds.iter()
            .map(|&c| {
                let q = fw4::rotate_about_line(d, p, phys(c), v);
                PointAtAngle {
                    commanded_deg: c,
                    point_mm: k.map(|i| q[i] + sigma_um * 1e-3 * rng.normal()),
                }
            })
            .collect::<Vec<_>>()
    };
    let va = [70.0, -40.0, 0.0];
    let a_centre = axis_centre(
        &vertex(da, pa, &a_cmds, va, [0, 1]),
        NominalAxis::Z,
        RotationSense::Primed,
    )
    .unwrap();
    let vb = [60.0, 0.0, 50.0];
    let b_centre = axis_centre(
        &vertex(db, pb, &b_cmds, vb, [0, 2]),
        NominalAxis::Y,
        RotationSense::Primed,
    )
    .unwrap();
    let identified = CentrelinesFile {
        actual: CentrelinePair {
            a_direction: a_dir.direction,
            // on the axis at the vertex's height (the fitted centre's plane)
            a_point_mm: [a_centre.centre_mm[0], a_centre.centre_mm[1], va[2]],
            b_direction: b_dir.direction,
            b_point_mm: [b_centre.centre_mm[0], vb[1], b_centre.centre_mm[1]],
        },
        nominal: None,
        sense: None,
    };
    // the groove program, corrected with the identified lines
    let (program, work) = groove(&[("G1", 25.0)]);
    let corrected = correct_program_centrelines(&program, &identified, "identified").unwrap();
    // the identification's u at the work point: tilt u × lever arm (the point's distance from
    // the axis point) and the centre u, for both axes, root-sum-square
    let lever = |p: [f64; 3], q: [f64; 3]| fw4::dot(fw4::sub(p, q), fw4::sub(p, q)).sqrt();
    let mut worst_uncorrected = 0.0f64;
    for (c, (p, eps, phi, v2)) in points_of(&corrected, "XYZAB").iter().zip(&work) {
        let truth = fw4::eq9(*p, da, pa, db, pb, *eps, *phi);
        let miss = lever(truth, [c[0], c[1], c[2]]) * 1e3;
        let u = |t: [f64; 2], cu: [f64; 2], arm: f64| {
            (t[0] * t[0] + t[1] * t[1]) * (arm * 1e-3).powi(2) + cu[0] * cu[0] + cu[1] * cu[1]
        };
        let u_um = (u(
            a_dir.tilt_uncertainty_urad,
            a_centre.centre_uncertainty_um,
            lever(*p, pa),
        ) + u(
            b_dir.tilt_uncertainty_urad,
            b_centre.centre_uncertainty_um,
            lever(*p, pb),
        ))
        .sqrt();
        assert!(u_um > 0.01 && u_um < 5.0, "{u_um}");
        assert!(miss <= 3.0 * u_um + 0.2, "{miss} um vs u {u_um} um");
        worst_uncorrected = worst_uncorrected.max(lever(truth, *v2) * 1e3);
    }
    assert!(worst_uncorrected > 100.0, "{worst_uncorrected}");
}
