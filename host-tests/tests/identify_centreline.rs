//! Seed 004 (Yamamoto): rotary-axis centreline from dial-gauge data, and eq 9 NC correction.
//! Exact test vectors C12–C18 of `design/spec/seed-003-004.md` (numbers copied from the
//! spec, i.e. from the paper and the spec's check script), the paper's printed formulas
//! transcribed here to show they are NOT what the pod computes, and round trips through the
//! independent forward model `ballpod_host::forward_seed004`.
use ballpod_host::forward_seed004 as fw;
use ballpod_host::methods::centreline::{
    AxisCentre, AxisLine, CentrelineError, DialPoint, GaugeFrame, NominalAxis, NormalAtAngle,
    PointAtAngle, RotationSense, TableAxes, axis_centre, axis_centre_budget,
    axis_direction_half_turn, axis_direction_lsq, axis_direction_two_positions,
    nc_command_correction, nc_correction, paper, plane_normal,
};

fn assert_close(got: &[f64], want: &[f64], tol: f64, what: &str) {
    assert_eq!(got.len(), want.len(), "{what}: length");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= tol,
            "{what}[{i}]: got {g:.12e}, want {w:.12e} (tol {tol:e})"
        );
    }
}

fn max_diff(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]).abs()).fold(0.0, f64::max)
}

/// The three C12 dial points, readings in mm as in the spec → µm.
fn dial3(readings_mm: [f64; 3]) -> [DialPoint; 3] {
    let xy = [(0.0, 0.0), (100.0, 0.0), (0.0, 100.0)];
    core::array::from_fn(|i| DialPoint {
        u_mm: xy[i].0,
        v_mm: xy[i].1,
        reading_um: readings_mm[i] * 1e3,
    })
}

/// Seed 004 eqs (1)–(3) exactly as printed (B3).
fn printed_eq1_3(n1: [f64; 3], n2: [f64; 3]) -> [f64; 3] {
    let (a, b, c) = (n1[0] + n2[0], n1[1] + n2[1], n1[2] + n2[2]);
    let aa = 1.0 / (1.0 + (b / a).powi(2) + (c / a).powi(2)).sqrt();
    [aa, (a / b) * aa, (a / c) * aa]
}

/// Seed 004 eqs (5)–(7) exactly as printed (B3).
fn printed_eq5_7(n3: [f64; 3], n4: [f64; 3]) -> [f64; 3] {
    let ([a3, b3, c3], [a4, b4, c4]) = (n3, n4);
    let s2 = (a3 + a4).powi(2) + (b3 + b4).powi(2) + (c3 + c4).powi(2);
    let ba = -2.0 * (b3 * c3 - b4 * c4) / s2;
    [
        ba,
        (ba * (b3 + b4) - c3 + c4) / (c3 + c4),
        (ba * (c3 + c4) + b3 - b4) / (a3 + a4),
    ]
}

const Z: [f64; 3] = [0.0, 0.0, 1.0];
const Y: [f64; 3] = [0.0, 1.0, 0.0];

// ------------------------------------------------------------------------------ C12
#[test]
fn c12_table_axis_direction_from_a0_a180_dial_points() {
    let n1 = plane_normal(&dial3([0.0, -0.04, 0.03]), &GaugeFrame::FROM_PLUS_Z).unwrap();
    assert_close(
        &n1.normal,
        &[3.9999995e-4, -2.999999625e-4, 0.999999875],
        1e-9,
        "n1",
    );
    assert_eq!(n1.residual_rms_um, 0.0);
    let n2 = plane_normal(
        &dial3([0.0, 0.3697218412, -0.02222016494]),
        &GaugeFrame::FROM_PLUS_Z,
    )
    .unwrap();
    assert_close(
        &n2.normal,
        &[-3.697193052e-3, 2.222001253e-4, 0.9999931407],
        1e-9,
        "n2",
    );
    let d = axis_direction_half_turn(n1.normal, n2.normal, Z, 0.0).unwrap();
    // Table 1's A vector (seed 004) as the spec reproduces it.
    assert_close(
        &d.direction,
        &[-0.001648600066, -3.890000157e-05, 0.9999986403],
        1e-9,
        "d_A",
    );
    // The printed eqs (1)-(3) give (0.0016486, 0.069868, −2.718e−6): not the axis.
    let printed = printed_eq1_3(n1.normal, n2.normal);
    assert_close(
        &printed,
        &[0.0016486, 0.069868, -2.718e-6],
        1e-6,
        "printed eqs 1-3",
    );
    assert!(
        max_diff(printed, d.direction) > 0.5,
        "pod must not implement the printed eqs 1-3"
    );
}

#[test]
fn c11_published_vectors_are_unit_to_rounding_and_tilt_matches_paper() {
    // Table 1 of seed 004 fed as if it were n1 = n2 (a normal along the axis): the half-turn
    // method returns it normalised; its XZ tilt reproduces the paper's 0.094458°.
    let a = [-0.0016486, -0.0000389, 0.9999986];
    let d = axis_direction_half_turn(a, a, Z, 0.0).unwrap();
    let norm_a = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    assert!((norm_a - 0.99999996).abs() < 1e-7);
    let tilt_deg = (-d.direction[0] / d.direction[2]).atan().to_degrees();
    assert!((tilt_deg - 0.0944579).abs() < 1e-6, "{tilt_deg}");
}

// ------------------------------------------------------------------------------ C13
#[test]
fn c13_tilt_axis_perpendicular_face_quarter_turn() {
    let n3 = [9.724999865e-9, -1.249999983e-4, 0.9999999922];
    let n4 = [-0.999999997, -7.779999976e-5, 0.0];
    let want = [-7.779999916e-5, 0.9999999892, 1.249999986e-4];
    // Commanded B+90 on a primed table axis = physical −90° about +Y.
    let two = axis_direction_two_positions(n3, n4, 90.0, RotationSense::Primed, Y, 0.0).unwrap();
    assert_close(&two.perpendicular_assumption, &want, 1e-9, "k = 0 member");
    assert!(
        two.axial_cos_abs < 1e-6,
        "face ⟂ axis: k = {}",
        two.axial_cos_abs
    );
    // Paper mode (corrected eqs 5–7) reproduces the same vector.
    let p = paper::eq5_7_corrected(n3, n4).unwrap();
    assert_close(&p, &want, 1e-9, "eq 5-7 corrected");
    // The printed eqs give (1.25e−4, −1, −7.78e−5): wrong sign, x/z swapped.
    let printed = printed_eq5_7(n3, n4);
    assert_close(
        &printed,
        &[1.25e-4, -1.0, -7.78e-5],
        1e-7,
        "printed eqs 5-7",
    );
    assert!(max_diff(printed, want) > 1.0);
}

// ------------------------------------------------------------------------------ C14
#[test]
fn c14_two_positions_are_ambiguous_three_positions_are_not() {
    let n3 = [0.0, 0.0, 1.0];
    let n4 = [-0.99999999889, 4.7199998134e-5, 1.5624999627e-8];
    let d = [-7.78e-5, 0.99999998916, 1.25e-4];
    let d_alt = [1.722e-4, 0.99999997736, -1.25e-4];
    let two = axis_direction_two_positions(n3, n4, 90.0, RotationSense::Primed, Y, 0.0).unwrap();
    let [c0, c1] = two.candidates;
    let (hit_d, hit_alt) = if max_diff(c0, d) < max_diff(c1, d) {
        (c0, c1)
    } else {
        (c1, c0)
    };
    assert_close(&hit_d, &d, 1e-9, "candidate d");
    assert_close(&hit_alt, &d_alt, 1e-9, "candidate d'");
    // Both satisfy R(d, −90°)·n3 = n4 (the forward model's Rodrigues).
    for c in [c0, c1] {
        let r = fw::mul(fw::rodrigues(c, -std::f64::consts::FRAC_PI_2), n3);
        assert!(max_diff(r, n4) < 1e-9);
    }
    // The (corrected) paper formula returns the midpoint.
    assert_close(
        &two.perpendicular_assumption,
        &[4.72e-5, 0.9999999989, 0.0],
        1e-9,
        "k=0 midpoint",
    );
    let p = paper::eq5_7_corrected(n3, n4).unwrap();
    assert_close(
        &fw::normalize(p),
        &[4.72e-5, 0.9999999989, 0.0],
        1e-9,
        "paper mode",
    );
    // Ambiguity ≈ angle between d and d'.
    let ang = fw::dot(fw::normalize(d), fw::normalize(d_alt)).acos() * 1e6;
    assert!(
        (two.ambiguity_urad - ang).abs() < 1e-2,
        "{} vs {ang}",
        two.ambiguity_urad
    );
    // Three positions B0/B45/B90 (physical 0, −45°, −90°) give d exactly.
    let d_true = fw::normalize(d);
    let pos: Vec<NormalAtAngle> = [0.0, 45.0, 90.0]
        .iter()
        .map(|&b: &f64| NormalAtAngle {
            commanded_deg: b,
            normal: fw::mul(fw::rodrigues(d_true, -b.to_radians()), n3),
        })
        .collect();
    let est = axis_direction_lsq(&pos, RotationSense::Primed, Y).unwrap();
    assert_close(&est.direction, &d_true, 1e-12, "3-position LSQ");
    assert!(est.angle_rms_deg < 1e-9);
    // The wrong sense is caught by the angle check, not silently accepted.
    let wrong = axis_direction_lsq(&pos, RotationSense::RightHanded, Y).unwrap();
    assert!(wrong.angle_rms_deg > 40.0, "{}", wrong.angle_rms_deg);
}

// ------------------------------------------------------------------------------ C15, C16
#[test]
fn c15_eq4_half_turn_centre() {
    let pos = [
        PointAtAngle {
            commanded_deg: 0.0,
            point_mm: [40.0, 30.0],
        },
        PointAtAngle {
            commanded_deg: 180.0,
            point_mm: [-39.838, -29.988],
        },
    ];
    for sense in [RotationSense::RightHanded, RotationSense::Primed] {
        let c = axis_centre(&pos, NominalAxis::Z, sense).unwrap();
        assert_close(&c.centre_mm, &[0.081, 0.006], 1e-12, "eq 4 via LSQ");
        assert!((c.radius_mm - (39.919f64.hypot(29.994))).abs() < 1e-9);
    }
    assert_close(
        &paper::eq4_centre([40.0, 30.0], [-39.838, -29.988]),
        &[0.081, 0.006],
        1e-12,
        "eq4",
    );
}

#[test]
fn c16_eq8_quarter_turn_centre_primed_b() {
    let pos = [
        PointAtAngle {
            commanded_deg: 0.0,
            point_mm: [50.0, 80.0],
        },
        PointAtAngle {
            commanded_deg: 90.0,
            point_mm: [-79.958, 49.982],
        },
    ];
    let c = axis_centre(&pos, NominalAxis::Y, RotationSense::Primed).unwrap();
    assert_close(&c.centre_mm, &[0.03, 0.012], 1e-12, "eq 8 via LSQ");
    assert_close(
        &paper::eq8_centre([50.0, 80.0], [-79.958, 49.982]),
        &[0.03, 0.012],
        1e-12,
        "eq8",
    );
    // With the other sense the same data give a different (wrong) centre: the sense matters.
    let wrong = axis_centre(&pos, NominalAxis::Y, RotationSense::RightHanded).unwrap();
    assert!((wrong.centre_mm[0] - 0.03).abs() > 1.0);
}

/// A vertex turned about a tilted line (the independent forward model's Rodrigues rotation) at
/// A 0/90/180/270: the in-plane fit finds the projection of the vertex circle's centre, and
/// `point_on_axis` places it on the line — the circle's centre p + ((v − p)·d)d, out of the
/// vertex's plane by τ·radius — where the vertex's height would misplace it by τ²·radius.
#[test]
fn the_centre_of_a_tilted_axis_is_placed_on_the_line() {
    let d = fw::normalize([1.6e-3, 0.4e-3, 1.0]);
    let p = [0.012, -0.008, 0.0];
    let v = [70.0, -40.0, 0.0];
    let pos: Vec<PointAtAngle> = [0.0, 90.0, 180.0, 270.0]
        .iter()
        .map(|&c: &f64| {
            let q = fw::rotate_about_line(d, p, c.to_radians(), v);
            PointAtAngle {
                commanded_deg: c,
                point_mm: [q[0], q[1]],
            }
        })
        .collect();
    let c = axis_centre(&pos, NominalAxis::Z, RotationSense::RightHanded).unwrap();
    let s = fw::dot(fw::sub(v, p), d);
    let truth = fw::add(p, fw::scale(s, d));
    let on_line = c.point_on_axis(NominalAxis::Z, d, v).unwrap();
    assert!(max_diff(on_line, truth) < 1e-9, "{on_line:?} vs {truth:?}");
    // at the vertex's height, the line is 0.2 µm away from the centre taken there
    let at_height = fw::add(p, fw::scale(-p[2] / d[2], d));
    let off =
        ((c.centre_mm[0] - at_height[0]).powi(2) + (c.centre_mm[1] - at_height[1]).powi(2)).sqrt();
    assert!(off > 1.5e-4, "{off}");
    // the same with Y and Z swapped: nominal Y, in-plane (X, Z), the point's Y from the plane
    let swap = |a: [f64; 3]| [a[0], a[2], a[1]];
    let (dy, vy, py) = (swap(d), swap(v), swap(p));
    let ty = swap(truth);
    let c_y = AxisCentre {
        centre_mm: [ty[0], ty[2]],
        ..c
    };
    let q = c_y.point_on_axis(NominalAxis::Y, dy, vy).unwrap();
    assert!(max_diff(fw::add(py, fw::scale(fw::dot(fw::sub(vy, py), dy), dy)), ty) < 1e-12);
    assert!(max_diff(q, ty) < 1e-9, "{q:?} vs {ty:?}");
    assert_eq!(
        c.point_on_axis(NominalAxis::Z, [1.0, 0.0, 0.1], v),
        Err(CentrelineError::FarFromNominal)
    );
    assert_eq!(
        c.point_on_axis(NominalAxis::Z, d, [f64::NAN, 0.0, 0.0]),
        Err(CentrelineError::NonFinite)
    );
}

// ------------------------------------------------------------------------------ C17, C18
#[test]
fn c17_eq9_table_axis_tilt_only() {
    let actual = TableAxes {
        table: AxisLine {
            direction: fw::normalize([0.001, 0.0, 1.0]),
            point_mm: [0.01, 0.02, 0.0],
        },
        tilt: AxisLine {
            direction: Y,
            point_mm: [0.0; 3],
        },
    };
    let nominal = TableAxes {
        table: AxisLine {
            direction: Z,
            point_mm: [0.0; 3],
        },
        tilt: AxisLine {
            direction: Y,
            point_mm: [0.0; 3],
        },
    };
    let r = nc_correction(&actual, &nominal, [100.0, 0.0, 50.0], 90.0, 0.0).unwrap();
    assert_close(
        &r.actual_mm,
        &[0.0800999299, 99.95995003, 50.0999199],
        1e-8,
        "V1",
    );
    assert_close(&r.nominal_mm, &[0.0, 100.0, 50.0], 1e-12, "V2");
    assert_close(
        &r.error_machine_um,
        &[-80.0999, 40.0500, -99.9199],
        1e-4,
        "V2 - V1",
    );
    assert_close(
        &r.correction_um,
        &[80.0999, -40.0500, 99.9199],
        1e-4,
        "correction",
    );
    assert_close(
        &r.corrected_command_mm,
        &r.actual_mm,
        0.0,
        "corrected command = V1",
    );
    // Work frame: R_r = R_z(90°)ᵀ maps (ex, ey, ez) to (ey, −ex, ez).
    assert_close(
        &r.error_work_um,
        &[40.0500, 80.0999, -99.9199],
        1e-4,
        "V_E1",
    );
}

#[test]
fn c18_eq9_tilt_axis_only() {
    let nominal = TableAxes {
        table: AxisLine {
            direction: Z,
            point_mm: [0.0; 3],
        },
        tilt: AxisLine {
            direction: Y,
            point_mm: [0.0; 3],
        },
    };
    let actual = TableAxes {
        table: nominal.table,
        tilt: AxisLine {
            direction: fw::normalize([0.0, 1.0, 0.001]),
            point_mm: [0.0, 0.0, 0.05],
        },
    };
    let r = nc_correction(&actual, &nominal, [100.0, 0.0, 50.0], 0.0, 90.0).unwrap();
    assert_close(
        &r.actual_mm,
        &[49.94997503, 0.1499499001, -99.94990005],
        1e-8,
        "V1",
    );
    assert_close(&r.nominal_mm, &[50.0, 0.0, -100.0], 1e-12, "V2");
    assert_close(
        &r.error_machine_um,
        &[50.0250, -149.9499, -50.0999],
        1e-4,
        "V2 - V1",
    );
}

// ------------------------------------------------------------------------------ round trips
/// Where the gauge touches a face (u, v), mm.
const FACE_GRID: [(f64, f64); 5] = [
    (0.0, 0.0),
    (60.0, 0.0),
    (0.0, 40.0),
    (60.0, 40.0),
    (30.0, 20.0),
];

/// Gauge frame whose reading direction is `w` (u chosen ⟂ w, v = w × u).
fn gauge_towards(w: [f64; 3], u_hint: [f64; 3]) -> GaugeFrame {
    let w = fw::normalize(w);
    let u = fw::normalize(fw::sub(u_hint, fw::scale(fw::dot(u_hint, w), w)));
    GaugeFrame {
        lateral_u: u,
        lateral_v: fw::cross(w, u),
        reading_dir: w,
    }
}

/// Dial points on a face with normal `n`, seen by a gauge along the nominal face normal `w`.
fn dial_on_face(
    n: [f64; 3],
    g: &GaugeFrame,
    grid: &[(f64, f64)],
    noise: &mut dyn FnMut() -> f64,
) -> Vec<DialPoint> {
    let zero = fw::dial_reading_um(
        n,
        g.lateral_u,
        g.lateral_v,
        g.reading_dir,
        grid[0].0,
        grid[0].1,
        0.0,
    );
    grid.iter()
        .map(|&(u, v)| DialPoint {
            u_mm: u,
            v_mm: v,
            reading_um: fw::dial_reading_um(n, g.lateral_u, g.lateral_v, g.reading_dir, u, v, zero)
                + noise(),
        })
        .collect()
}

#[test]
fn round_trip_tilt_axis_from_dial_points_at_several_angles() {
    let mut rng = fw::SplitMix(4);
    let grid = FACE_GRID;
    for _ in 0..50 {
        let d = fw::normalize([rng.range(-2e-3, 2e-3), 1.0, rng.range(-2e-3, 2e-3)]);
        // top face of the block, tilted by up to 2 mrad (k = d·n up to ~4e-3)
        let n0 = fw::normalize([rng.range(-2e-3, 2e-3), rng.range(-2e-3, 2e-3), 1.0]);
        let cmds: [f64; 4] = [0.0, 30.0, 60.0, 90.0];
        let mut pos = Vec::new();
        for &b in &cmds {
            let n = fw::mul(fw::rodrigues(d, -b.to_radians()), n0); // primed axis
            // gauge along the nominal face normal at this angle (nominal axis +Y)
            let w = fw::mul(fw::rodrigues(Y, -b.to_radians()), Z);
            let g = gauge_towards(w, Y);
            let pts = dial_on_face(n, &g, &grid, &mut || 0.0);
            let pn = plane_normal(&pts, &g).unwrap();
            assert!(max_diff(pn.normal, n) < 1e-12, "normal");
            pos.push(NormalAtAngle {
                commanded_deg: b,
                normal: pn.normal,
            });
        }
        let est = axis_direction_lsq(&pos, RotationSense::Primed, Y).unwrap();
        assert!(
            max_diff(est.direction, d) < 1e-11,
            "{:?} vs {d:?}",
            est.direction
        );
        assert!(est.residual_rms_urad < 1e-5 && est.angle_rms_deg < 1e-7);
        // Two positions alone: the truth is one of the candidates, the k=0 member is off.
        let two = axis_direction_two_positions(
            pos[0].normal,
            pos[3].normal,
            90.0,
            RotationSense::Primed,
            Y,
            0.0,
        )
        .unwrap();
        let best = two
            .candidates
            .iter()
            .map(|c| max_diff(*c, d))
            .fold(f64::INFINITY, f64::min);
        assert!(best < 1e-9, "{best}");
    }
}

#[test]
fn round_trip_table_axis_half_turn_and_centre_with_noise() {
    let mut rng = fw::SplitMix(7);
    let grid = [(0.0, 0.0), (100.0, 0.0), (0.0, 100.0)];
    for _ in 0..50 {
        let d = fw::normalize([rng.range(-2e-3, 2e-3), rng.range(-2e-3, 2e-3), 1.0]);
        let n0 = fw::normalize([rng.range(-1e-3, 1e-3), rng.range(-1e-3, 1e-3), 1.0]);
        let n180 = fw::mul(fw::rodrigues(d, std::f64::consts::PI), n0);
        let g = GaugeFrame::FROM_PLUS_Z;
        let p1 = plane_normal(&dial_on_face(n0, &g, &grid, &mut || 0.0), &g).unwrap();
        let p2 = plane_normal(&dial_on_face(n180, &g, &grid, &mut || 0.0), &g).unwrap();
        let est = axis_direction_half_turn(p1.normal, p2.normal, Z, 0.0).unwrap();
        assert!(max_diff(est.direction, d) < 1e-12);
        // centre: vertex rotated about the (tilted) axis through c, at 4 table angles
        let c = [rng.range(-0.1, 0.1), rng.range(-0.1, 0.1), 0.0];
        let v = [rng.range(-80.0, 80.0), rng.range(-80.0, 80.0), 0.0];
        let exact: Vec<PointAtAngle> = [0.0, 180.0]
            .iter()
            .map(|&a: &f64| {
                let p = fw::rotate_about_line(d, c, a.to_radians(), v);
                PointAtAngle {
                    commanded_deg: a,
                    point_mm: [p[0], p[1]],
                }
            })
            .collect();
        let ce = axis_centre(&exact, NominalAxis::Z, RotationSense::RightHanded).unwrap();
        // the mid-point lies on the tilted axis, at the mean height of the two vertex positions
        let z_mid = 0.5
            * (fw::rotate_about_line(d, c, 0.0, v)[2]
                + fw::rotate_about_line(d, c, std::f64::consts::PI, v)[2]);
        let on_axis = fw::add(c, fw::scale((z_mid - c[2]) / d[2], d));
        assert_close(
            &ce.centre_mm,
            &[on_axis[0], on_axis[1]],
            1e-11,
            "half-turn centre (exact for a tilted axis)",
        );
        // 8 positions with 1 µm noise: error within 5 σ of the reported uncertainty
        let noisy: Vec<PointAtAngle> = (0..8)
            .map(|i| {
                let a = 45.0 * i as f64;
                let p = fw::rotate_about_line(Z, c, a.to_radians(), v);
                PointAtAngle {
                    commanded_deg: a,
                    point_mm: [p[0] + 1e-3 * rng.normal(), p[1] + 1e-3 * rng.normal()],
                }
            })
            .collect();
        let cn = axis_centre(&noisy, NominalAxis::Z, RotationSense::RightHanded).unwrap();
        for k in 0..2 {
            let e_um = (cn.centre_mm[k] - c[k]) * 1e3;
            assert!(
                e_um.abs() < 5.0 * cn.centre_uncertainty_um[k] + 1e-9,
                "{e_um} vs {}",
                cn.centre_uncertainty_um[k]
            );
        }
        assert!(
            cn.residual_rms_um > 0.3 && cn.residual_rms_um < 2.0,
            "{}",
            cn.residual_rms_um
        );
    }
}

#[test]
fn round_trip_eq9_matches_forward_model() {
    let mut rng = fw::SplitMix(9);
    for _ in 0..100 {
        let da = fw::normalize([rng.range(-2e-3, 2e-3), rng.range(-2e-3, 2e-3), 1.0]);
        let db = fw::normalize([rng.range(-2e-3, 2e-3), 1.0, rng.range(-2e-3, 2e-3)]);
        let pa = [
            rng.range(-0.1, 0.1),
            rng.range(-0.1, 0.1),
            rng.range(-0.1, 0.1),
        ];
        let pb = [
            rng.range(-0.1, 0.1),
            rng.range(-0.1, 0.1),
            rng.range(-0.1, 0.1),
        ];
        let p = [
            rng.range(-100.0, 100.0),
            rng.range(-100.0, 100.0),
            rng.range(0.0, 200.0),
        ];
        let (eps, phi) = (rng.range(-180.0, 180.0), rng.range(-90.0, 90.0));
        let actual = TableAxes {
            table: AxisLine {
                direction: da,
                point_mm: pa,
            },
            tilt: AxisLine {
                direction: db,
                point_mm: pb,
            },
        };
        let nominal = TableAxes {
            table: AxisLine {
                direction: Z,
                point_mm: [0.0; 3],
            },
            tilt: AxisLine {
                direction: Y,
                point_mm: [0.0; 3],
            },
        };
        let r = nc_correction(&actual, &nominal, p, eps, phi).unwrap();
        let v1 = fw::eq9(p, da, pa, db, pb, eps.to_radians(), phi.to_radians());
        let v2 = fw::eq9(
            p,
            Z,
            [0.0; 3],
            Y,
            [0.0; 3],
            eps.to_radians(),
            phi.to_radians(),
        );
        assert!(max_diff(r.actual_mm, v1) < 1e-11 && max_diff(r.nominal_mm, v2) < 1e-11);
        // error in the work frame, rotated back to the machine frame, is the machine error
        let rr_t = fw::mul(
            fw::rodrigues(Y, phi.to_radians()),
            fw::mul(fw::rodrigues(Z, eps.to_radians()), r.error_work_um),
        );
        assert!(max_diff(rr_t, r.error_machine_um) < 1e-9);
        // corrected command puts the tool on the actual work point; compensation = −error
        assert!(max_diff(fw::add(r.error_machine_um, r.correction_um), [0.0; 3]) < 1e-12);
        // from the program's side: the NC point V2 (nominal centrelines) gives back the same
        // correction, also for NC-set centres off the origin
        let nominal_off = TableAxes {
            table: AxisLine {
                direction: Z,
                point_mm: [1.5, -2.0, 0.0],
            },
            tilt: AxisLine {
                direction: Y,
                point_mm: [0.0, 0.0, 40.0],
            },
        };
        let (e, f) = (eps.to_radians(), phi.to_radians());
        let v2_off = fw::eq9(p, Z, [1.5, -2.0, 0.0], Y, [0.0, 0.0, 40.0], e, f);
        let c = nc_command_correction(&actual, &nominal_off, v2_off, eps, phi).unwrap();
        assert!(max_diff(c.corrected_command_mm, v1) < 1e-10, "{c:?}");
        assert!(max_diff(c.nominal_mm, v2_off) < 1e-10);
    }
}

// ------------------------------------------------------------------------------ bad input
#[test]
fn bad_input_gets_typed_errors() {
    let g = GaugeFrame::FROM_PLUS_Z;
    let collinear = [
        DialPoint {
            u_mm: 0.0,
            v_mm: 0.0,
            reading_um: 0.0,
        },
        DialPoint {
            u_mm: 10.0,
            v_mm: 10.0,
            reading_um: 1.0,
        },
        DialPoint {
            u_mm: 20.0,
            v_mm: 20.0,
            reading_um: 2.0,
        },
    ];
    assert_eq!(
        plane_normal(&collinear, &g),
        Err(CentrelineError::DegeneratePointLayout)
    );
    assert_eq!(
        plane_normal(&collinear[..2], &g),
        Err(CentrelineError::TooFewInputs {
            given: 2,
            needed: 3
        })
    );
    let mut nan = dial3([0.0, 0.01, 0.02]);
    nan[1].reading_um = f64::NAN;
    assert_eq!(plane_normal(&nan, &g), Err(CentrelineError::NonFinite));
    let skew = GaugeFrame {
        lateral_u: [1.0, 0.0, 0.0],
        lateral_v: [0.0, 1.0, 0.0],
        reading_dir: [0.0, 0.0, -1.0],
    };
    assert_eq!(
        plane_normal(&dial3([0.0, 0.01, 0.02]), &skew),
        Err(CentrelineError::BadGaugeFrame)
    );
    // half turn with the face normal ⟂ axis: n1 + n2 = 0
    assert_eq!(
        axis_direction_half_turn([1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], Z, 0.0),
        Err(CentrelineError::NormalPerpendicularToAxis)
    );
    assert_eq!(
        axis_direction_half_turn([0.0; 3], Z, Z, 0.0),
        Err(CentrelineError::ZeroVector)
    );
    assert_eq!(
        axis_direction_half_turn(Z, Z, [1.0, 0.0, 0.0], 0.0),
        Err(CentrelineError::FarFromNominal)
    );
    // LSQ direction: the same normal three times does not fix an axis
    let same = [NormalAtAngle {
        commanded_deg: 0.0,
        normal: Z,
    }; 3];
    assert_eq!(
        axis_direction_lsq(&same, RotationSense::Primed, Y),
        Err(CentrelineError::NoRotation)
    );
    assert_eq!(
        axis_direction_lsq(&same[..2], RotationSense::Primed, Y),
        Err(CentrelineError::TooFewInputs {
            given: 2,
            needed: 3
        })
    );
    // two positions: zero angle, and an angle too small for the change of the normal
    assert_eq!(
        axis_direction_two_positions(Z, [1.0, 0.0, 0.0], 0.0, RotationSense::Primed, Y, 0.0),
        Err(CentrelineError::NoRotation)
    );
    assert!(matches!(
        axis_direction_two_positions(Z, [1.0, 0.0, 0.0], 10.0, RotationSense::Primed, Y, 0.0),
        Err(CentrelineError::InconsistentAngle { .. })
    ));
    // a stated noise that is negative or not finite is refused by name
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let field = CentrelineError::BadUncertainty {
            field: "normal_std_urad",
        };
        assert_eq!(axis_direction_half_turn(Z, Z, Z, bad), Err(field));
        let two =
            axis_direction_two_positions(Z, [1.0, 0.0, 0.0], 90.0, RotationSense::Primed, Y, bad);
        assert_eq!(two, Err(field));
    }
    // centre: both positions at the same angle
    let pts = [
        PointAtAngle {
            commanded_deg: 30.0,
            point_mm: [1.0, 2.0],
        },
        PointAtAngle {
            commanded_deg: 30.0,
            point_mm: [1.0, 2.0],
        },
    ];
    assert_eq!(
        axis_centre(&pts, NominalAxis::Z, RotationSense::RightHanded),
        Err(CentrelineError::NoRotation)
    );
    assert_eq!(
        axis_centre(&pts[..1], NominalAxis::Z, RotationSense::RightHanded),
        Err(CentrelineError::TooFewInputs {
            given: 1,
            needed: 2
        })
    );
    let nominal = TableAxes {
        table: AxisLine {
            direction: Z,
            point_mm: [0.0; 3],
        },
        tilt: AxisLine {
            direction: Y,
            point_mm: [0.0; 3],
        },
    };
    let broken = TableAxes {
        table: AxisLine {
            direction: [0.0; 3],
            point_mm: [0.0; 3],
        },
        tilt: nominal.tilt,
    };
    assert_eq!(
        nc_correction(&broken, &nominal, [1.0; 3], 10.0, 0.0),
        Err(CentrelineError::ZeroVector)
    );
    assert_eq!(
        nc_correction(&nominal, &nominal, [f64::NAN; 3], 10.0, 0.0),
        Err(CentrelineError::NonFinite)
    );
}

/// The tilt of `d` along the pair the centreline module reports for nominal +Y: (X, −Z).
fn tilt_y(d: [f64; 3]) -> [f64; 2] {
    [d[0], -d[2]]
}

/// Issue 14: seed 004's two-position method on noisy gauges (0.2–0.5 µm, 4 points ±50 mm, so
/// each normal's tilt components have σ = noise·√2/100 mm). With a hard-coded k² limit it
/// refused 4 of 9 machines and called a result 726 µrad off "ambiguity 0". Now, over 300
/// machines (faces up to 2 mrad off perpendicular to the axis, the nearly perpendicular ones
/// included): it refuses rarely and then states k² and its noise; when it answers, the truth
/// is within 2u of a candidate in both tilt components in ≥ 95 % of the cases, and within the
/// stated ambiguity of the k = 0 member.
#[test]
fn two_positions_with_gauge_noise_answer_within_u_or_refuse_with_the_noise() {
    let mut rng = fw::SplitMix(404);
    let grid = [(-50.0, 0.0), (50.0, 0.0), (0.0, -50.0), (0.0, 50.0)];
    let (mut answered, mut covered, mut within_ambiguity, mut refused) = (0, 0, 0, 0);
    for _ in 0..300 {
        let noise_um = rng.range(0.2, 0.5);
        let sigma_urad = noise_um * 2f64.sqrt() / 100.0 * 1e3;
        let d = fw::normalize([rng.range(-2e-3, 2e-3), 1.0, rng.range(-2e-3, 2e-3)]);
        let n0 = fw::normalize([rng.range(-2e-3, 2e-3), rng.range(-2e-3, 2e-3), 1.0]);
        let mut normal_at = |b: f64| {
            let n = fw::mul(fw::rodrigues(d, -b.to_radians()), n0);
            let w = fw::mul(fw::rodrigues(Y, -b.to_radians()), Z);
            let g = gauge_towards(w, Y);
            let pts = dial_on_face(n, &g, &grid, &mut || noise_um * rng.normal());
            plane_normal(&pts, &g).unwrap().normal
        };
        let (n3, n4) = (normal_at(0.0), normal_at(90.0));
        match axis_direction_two_positions(n3, n4, 90.0, RotationSense::Primed, Y, sigma_urad) {
            Ok(two) => {
                answered += 1;
                let t = tilt_y(d);
                let hit = (0..2).any(|i| {
                    let (c, u) = (tilt_y(two.candidates[i]), two.tilt_uncertainty_urad[i]);
                    (0..2).all(|k| ((c[k] - t[k]) * 1e6).abs() <= 2.0 * u[k])
                });
                covered += usize::from(hit);
                let m = two.perpendicular_assumption;
                let off_urad = (m[0] - d[0]).hypot(m[2] - d[2]) * 1e6;
                let u_mid = two.tilt_uncertainty_urad[0][0].hypot(two.tilt_uncertainty_urad[0][1]);
                within_ambiguity += usize::from(off_urad <= two.ambiguity_urad / 2.0 + 2.0 * u_mid);
            }
            Err(CentrelineError::InconsistentAngle { k2, u_k2 }) => {
                assert!(k2 < -3.0 * u_k2 && u_k2 > 0.0, "{k2} ± {u_k2}");
                refused += 1;
            }
            Err(e) => panic!("{e:?}"),
        }
    }
    println!(
        "answered {answered}, covered {covered}, within ambiguity {within_ambiguity}, refused {refused}"
    );
    assert!(refused <= 3, "refused {refused} of 300");
    assert!(
        covered as f64 >= 0.95 * answered as f64,
        "{covered} of {answered} within 2u"
    );
    assert!(
        within_ambiguity as f64 >= 0.95 * answered as f64,
        "{within_ambiguity} of {answered}"
    );
}

/// The half turn's propagated u against the scatter of 2000 noisy measurements (within 20 %),
/// U = 2u covering the truth in 95 % ± 3 %, and the stated correlation of the two tilt
/// components against their errors'.
#[test]
fn half_turn_with_gauge_noise_states_an_honest_u() {
    let mut rng = fw::SplitMix(180);
    let grid = [(-50.0, 0.0), (50.0, 0.0), (0.0, -50.0), (0.0, 50.0)];
    let noise_um = 0.3;
    let sigma_urad = noise_um * 2f64.sqrt() / 100.0 * 1e3;
    let (mut covered, mut e2, mut u2) = (0, 0.0, 0.0);
    let (mut e01, mut e00, mut e11, mut rho_sum) = (0.0, 0.0, 0.0, 0.0);
    const RUNS: usize = 2000;
    for _ in 0..RUNS {
        let d = fw::normalize([rng.range(-2e-3, 2e-3), rng.range(-2e-3, 2e-3), 1.0]);
        let n0 = fw::normalize([rng.range(-1e-3, 1e-3), rng.range(-1e-3, 1e-3), 1.0]);
        let n180 = fw::mul(fw::rodrigues(d, std::f64::consts::PI), n0);
        let g = GaugeFrame::FROM_PLUS_Z;
        let mut normal = |n| {
            plane_normal(
                &dial_on_face(n, &g, &grid, &mut || noise_um * rng.normal()),
                &g,
            )
            .unwrap()
            .normal
        };
        let (a, b) = (normal(n0), normal(n180));
        let est = axis_direction_half_turn(a, b, Z, sigma_urad).unwrap();
        // nominal Z: tilt components along (X, Y)
        let e = [0, 1].map(|k| (est.direction[k] - d[k]) * 1e6);
        for k in 0..2 {
            let u = est.tilt_uncertainty_urad[k];
            covered += usize::from(e[k].abs() <= 2.0 * u);
            e2 += e[k] * e[k];
            u2 += u * u;
        }
        e01 += e[0] * e[1];
        e00 += e[0] * e[0];
        e11 += e[1] * e[1];
        rho_sum += est.tilt_correlation;
        assert_eq!(est.tilt_degrees_of_freedom, None);
    }
    let coverage = covered as f64 / (2 * RUNS) as f64;
    let ratio = (u2 / e2).sqrt();
    assert!(
        (0.92..=0.98).contains(&coverage) && (0.8..=1.2).contains(&ratio),
        "coverage {coverage:.3}, rms u / rms error {ratio:.3}"
    );
    // the stated correlation of the two components against the errors' (its standard error
    // with 2000 runs ≈ 0.02)
    let (empirical, stated) = (e01 / (e00 * e11).sqrt(), rho_sum / RUNS as f64);
    assert!((empirical - stated).abs() < 0.08, "{empirical} vs {stated}");
}

/// Issue 14: the gauge's calibration. 1 000 tilted axes (tilts up to ±2 mrad, the face up to
/// ±2 mrad) measured at eight positions on the independent forward model, read by a gauge whose
/// scale is off by N(0, 1 %) with 0.05 µm of noise: with the gauge's share
/// (`AxisDirection::gauge_scale_share_urad`, u = 1 %) U = 2u covers each tilt in 95 % ± 3 % of
/// the runs and u matches the scatter within 20 %; with the residuals' u alone far fewer.
#[test]
fn the_gauges_calibration_is_in_u() {
    let grid = FACE_GRID;
    const RUNS: usize = 1000;
    let mut rng = fw::SplitMix(1414);
    let (mut covered, mut covered_a) = ([0usize; 2], [0usize; 2]);
    let (mut e2, mut u2) = ([0.0f64; 2], [0.0f64; 2]);
    for _ in 0..RUNS {
        let d = fw::normalize([rng.range(-2e-3, 2e-3), 1.0, rng.range(-2e-3, 2e-3)]);
        let n0 = fw::normalize([rng.range(-2e-3, 2e-3), rng.range(-2e-3, 2e-3), 1.0]);
        let scale = 1.0 + 0.01 * rng.normal();
        let mut pos = Vec::new();
        for b in (0..8).map(|i| 15.0 * f64::from(i)) {
            let n = fw::mul(fw::rodrigues(d, -f64::to_radians(b)), n0); // primed axis
            let w = fw::mul(fw::rodrigues(Y, -f64::to_radians(b)), Z);
            let g = gauge_towards(w, Y);
            let pts: Vec<DialPoint> = dial_on_face(n, &g, &grid, &mut || 0.0)
                .into_iter()
                .map(|p| DialPoint {
                    reading_um: p.reading_um * scale + 0.05 * rng.normal(),
                    ..p
                })
                .collect();
            pos.push(NormalAtAngle {
                commanded_deg: b,
                normal: plane_normal(&pts, &g).unwrap().normal,
            });
        }
        let est = axis_direction_lsq(&pos, RotationSense::Primed, Y).unwrap();
        let gauge = est.gauge_scale_share_urad(Y, 0.01).unwrap();
        // the tilt components about nominal +Y: X and −Z
        let err = [
            (est.direction[0] - d[0]) * 1e6,
            -(est.direction[2] - d[2]) * 1e6,
        ];
        for k in 0..2 {
            let type_a = est.tilt_uncertainty_urad[k];
            let u = type_a.hypot(gauge[k]);
            covered[k] += usize::from(err[k].abs() <= 2.0 * u);
            covered_a[k] += usize::from(err[k].abs() <= 2.0 * type_a);
            e2[k] += err[k] * err[k];
            u2[k] += u * u;
        }
    }
    for k in 0..2 {
        let coverage = covered[k] as f64 / RUNS as f64;
        let ratio = (u2[k] / e2[k]).sqrt();
        let alone = covered_a[k] as f64 / RUNS as f64;
        println!(
            "tilt {k}: coverage {coverage:.3} (Type A alone {alone:.3}), rms u / rms error {ratio:.2}"
        );
        assert!((0.92..=0.98).contains(&coverage), "tilt {k}: {coverage}");
        assert!((0.8..=1.2).contains(&ratio), "tilt {k}: {ratio}");
        assert!(alone < 0.5, "tilt {k}: {alone}");
    }
    // a negative or non-finite scale u is refused by name
    let est = axis_direction_lsq(&pos_of_any_axis(), RotationSense::Primed, Y).unwrap();
    for bad in [-0.01, f64::NAN] {
        assert_eq!(
            est.gauge_scale_share_urad(Y, bad),
            Err(CentrelineError::BadUncertainty { field: "u_scale" })
        );
    }
}

/// Exact normals of a slightly tilted axis at four positions.
fn pos_of_any_axis() -> Vec<NormalAtAngle> {
    let d = fw::normalize([1e-3, 1.0, -0.5e-3]);
    let n0 = fw::normalize([0.3e-3, -0.2e-3, 1.0]);
    [0.0f64, 30.0, 60.0, 90.0]
        .iter()
        .map(|&b| NormalAtAngle {
            commanded_deg: b,
            normal: fw::mul(fw::rodrigues(d, -b.to_radians()), n0),
        })
        .collect()
}

/// One procedure of seed 004 §3.2/§3.4 on an independent forward model: a block whose corner
/// (`corner_signs` from the block's middle, half-sizes `half_mm`, the middle `middle_mm` near
/// the axis) is touched off at each commanded angle, the block turned about the actual axis
/// line (`direction`, through `point_mm`, `sense`). Each in-plane machine axis is touched on
/// the face whose turned outward normal points most along it; the touch stops `offset_um` (0:
/// across the spindle, X and Y; 1: along it, Z) further out along that normal, plus `noise`.
/// Returns the touched points in the plane of `axis` and the true centre there: the foot of
/// the corner on the line.
#[allow(clippy::too_many_arguments)]
fn touch_off_corner(
    axis: NominalAxis,
    sense: RotationSense,
    direction: [f64; 3],
    point_mm: [f64; 3],
    middle_mm: [f64; 3],
    half_mm: [f64; 3],
    corner_signs: [f64; 3],
    angles_deg: &[f64],
    offset_um: [f64; 2],
    noise: &mut dyn FnMut() -> f64,
) -> (Vec<PointAtAngle>, [f64; 2]) {
    let plane = match axis {
        NominalAxis::X => [1, 2],
        NominalAxis::Y => [0, 2],
        NominalAxis::Z => [0, 1],
    };
    let corner: [f64; 3] = std::array::from_fn(|i| middle_mm[i] + corner_signs[i] * half_mm[i]);
    let normals: [[f64; 3]; 3] = std::array::from_fn(|i| {
        let mut n = [0.0; 3];
        n[i] = corner_signs[i];
        n
    });
    let d = fw::normalize(direction);
    let mut points = Vec::new();
    for &commanded in angles_deg {
        let t = sense.physical_deg(commanded).to_radians();
        let v = fw::rotate_about_line(d, point_mm, t, corner);
        let turned = normals.map(|n| fw::mul(fw::rodrigues(d, t), n));
        let mut p = [0.0; 2];
        for (slot, &m) in p.iter_mut().zip(&plane) {
            let face = turned
                .iter()
                .max_by(|a, b| a[m].abs().total_cmp(&b[m].abs()))
                .unwrap();
            let eps = offset_um[usize::from(m == 2)];
            *slot = v[m] + (eps * face[m].signum() + noise()) * 1e-3;
        }
        points.push(PointAtAngle {
            commanded_deg: commanded,
            point_mm: p,
        });
    }
    let foot = fw::add(
        point_mm,
        fw::scale(fw::dot(fw::sub(corner, point_mm), d), d),
    );
    (points, plane.map(|m| foot[m]))
}

/// Issue 14: the centre's touch-offs. Seed 004's own procedures on the forward model above,
/// 1 000 times each: a table axis (Z) by half turn (eq 4) and at four quarter turns, a tilting
/// axis (Y, primed) at B0 and B90 (eq 8). Each run draws the axis (tilt ±0.5 mrad, centre
/// ±0.1 mm), the block (its middle ±10 mm off the axis, 30–50 mm half-sizes, any corner), the
/// touch-off's two offsets N(0, 2 µm) and each touch's noise N(0, 2 µm). `axis_centre_budget`
/// with the defaults: U (k from Student's t at the stated degrees of freedom) covers each
/// centre component in 95 % ± 3 % of the runs and u matches the scatter within 20 %. Without
/// the offset's share the quarter turn of B covers far fewer; the table axis has none (its
/// touches are all across the spindle, and the offset turns with the faces).
#[test]
fn the_touch_offs_are_in_the_centres_u() {
    use ballpod_host::gum::coverage_factor;
    use ballpod_host::methods::centreline::{TouchUncertainty, U_TOUCH_UM};
    let cases: [(&str, NominalAxis, RotationSense, &[f64]); 3] = [
        (
            "A half turn",
            NominalAxis::Z,
            RotationSense::RightHanded,
            &[0.0, 180.0],
        ),
        (
            "A quarter turns",
            NominalAxis::Z,
            RotationSense::RightHanded,
            &[0.0, 90.0, 180.0, 270.0],
        ),
        (
            "B0/B90",
            NominalAxis::Y,
            RotationSense::Primed,
            &[0.0, 90.0],
        ),
    ];
    const RUNS: usize = 1000;
    let mut rng = fw::SplitMix(3004);
    for (name, axis, sense, angles) in cases {
        let (mut covered, mut covered_random) = ([0usize; 2], [0usize; 2]);
        let (mut e2, mut u2, mut offset_max) = ([0.0f64; 2], [0.0f64; 2], 0.0f64);
        let (mut e01, mut rho_sum) = (0.0, 0.0);
        for _ in 0..RUNS {
            let tilt = [rng.range(-5e-4, 5e-4), rng.range(-5e-4, 5e-4)];
            let (direction, point_mm) = match axis {
                NominalAxis::Z => (
                    [tilt[0], tilt[1], 1.0],
                    [rng.range(-0.1, 0.1), rng.range(-0.1, 0.1), 0.0],
                ),
                _ => (
                    [tilt[0], 1.0, tilt[1]],
                    [rng.range(-0.1, 0.1), 0.0, rng.range(-0.1, 0.1)],
                ),
            };
            let middle = [0, 1, 2].map(|_| rng.range(-10.0, 10.0));
            let half = [0, 1, 2].map(|_| rng.range(30.0, 50.0));
            let signs = [0, 1, 2].map(|_| {
                if rng.range(-1.0, 1.0) < 0.0 {
                    -1.0
                } else {
                    1.0
                }
            });
            let offset = [rng.normal() * 2.0, rng.normal() * 2.0];
            let (points, truth) = touch_off_corner(
                axis,
                sense,
                direction,
                point_mm,
                middle,
                half,
                signs,
                angles,
                offset,
                &mut || 2.0 * rng.normal(),
            );
            let b = axis_centre_budget(&points, axis, sense, TouchUncertainty::default()).unwrap();
            let errs = [0, 1].map(|k| (b.centre.centre_mm[k] - truth[k]) * 1e3);
            e01 += errs[0] * errs[1];
            rho_sum += b.correlation;
            for k in 0..2 {
                let err = errs[k];
                let dof = b.degrees_of_freedom[k].map(f64::from);
                let kf = coverage_factor(dof).unwrap();
                covered[k] += usize::from(err.abs() <= kf * b.u_um[k]);
                covered_random[k] += usize::from(err.abs() <= kf * b.random_um[k]);
                e2[k] += err * err;
                u2[k] += b.u_um[k] * b.u_um[k];
                offset_max = offset_max.max(b.offset_um[k]);
            }
            assert_eq!(b.random_is_type_a, angles.len() > 2);
        }
        // the stated correlation of the two components against their errors' (standard
        // error ≈ 0.03 with 1 000 runs)
        let (empirical, stated) = (e01 / (e2[0] * e2[1]).sqrt(), rho_sum / RUNS as f64);
        println!("{name}: correlation of the errors {empirical:.3}, stated {stated:.3}");
        assert!(
            (empirical - stated).abs() < 0.1,
            "{name}: {empirical} vs {stated}"
        );
        for k in 0..2 {
            let coverage = covered[k] as f64 / RUNS as f64;
            let alone = covered_random[k] as f64 / RUNS as f64;
            let ratio = (u2[k] / e2[k]).sqrt();
            println!(
                "{name} component {k}: coverage {coverage:.3} (random share alone {alone:.3}), \
                 rms u / rms error {ratio:.2}, largest offset share {offset_max:.3} µm"
            );
            assert!((0.92..=0.98).contains(&coverage), "{name} {k}: {coverage}");
            assert!((0.8..=1.2).contains(&ratio), "{name} {k}: {ratio}");
            if axis == NominalAxis::Z {
                assert!(offset_max < 1e-6, "{name}: {offset_max}");
            } else {
                assert!(alone < 0.88, "{name} {k}: {alone}");
            }
        }
    }
    // the half turn's stated u is the repeatability over √2 (c = (p1 + p2)/2), not 0
    let half_turn = [(0.0, [40.0, 30.0]), (180.0, [-39.838, -29.988])].map(|(a, p)| PointAtAngle {
        commanded_deg: a,
        point_mm: p,
    });
    let b = axis_centre_budget(
        &half_turn,
        NominalAxis::Z,
        RotationSense::RightHanded,
        TouchUncertainty::default(),
    )
    .unwrap();
    assert_close(&b.u_um, &[U_TOUCH_UM / 2f64.sqrt(); 2], 1e-9, "half-turn u");
    assert_eq!(b.degrees_of_freedom, [None, None]);
    // positions not quarter turns apart: the faces are not square to the machine axes, the
    // offset's model does not hold, and u is not evaluated (NaN), never a number
    let skew = [
        (0.0, [40.0, 30.0]),
        (30.0, [19.64, 45.98]),
        (60.0, [-5.98, 49.64]),
    ]
    .map(|(a, p)| PointAtAngle {
        commanded_deg: a,
        point_mm: p,
    });
    let b = axis_centre_budget(
        &skew,
        NominalAxis::Z,
        RotationSense::RightHanded,
        TouchUncertainty::default(),
    )
    .unwrap();
    assert!(
        b.u_um.iter().chain(&b.offset_um).all(|u| u.is_nan()),
        "{b:?}"
    );
    // a negative or non-finite input u is refused by name
    for (touch, field) in [
        (
            TouchUncertainty {
                repeatability_um: -1.0,
                ..TouchUncertainty::default()
            },
            "repeatability_um",
        ),
        (
            TouchUncertainty {
                offset_um: f64::NAN,
                ..TouchUncertainty::default()
            },
            "offset_um",
        ),
    ] {
        assert_eq!(
            axis_centre_budget(
                &half_turn,
                NominalAxis::Z,
                RotationSense::RightHanded,
                touch
            ),
            Err(CentrelineError::BadUncertainty { field })
        );
    }
}

/// The book's `[vertex]` example (docs/src/methods/centreline.md, C16) verbatim through
/// `replay`'s session reader: the centre is eq 8's closed form of the readings, X =
/// ½(X1 + X2 + Z1 − Z2), Z = ½(−X1 + X2 + Z1 + Z2); its u is the quarter turn's in closed form,
/// c = (I − R)⁻¹(p2 − R·p1): the touch's 2 µm once per component (each row of (I − R)⁻¹ and of
/// (I − R)⁻¹R has norm² ½), and along Z the difference of the two 2 µm offsets (the corner's
/// faces +X, +Z at B0 are touched along Z and −X at B90). The page prints what replay reports.
#[test]
fn the_books_vertex_example_replays_eq8_with_its_u() {
    use ballpod_host::docs::{block_after, from};
    let marker = "C16 as a session";
    let dir = std::env::temp_dir().join(format!("ballpod-vertex-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let csv = block_after(marker, "csv");
    std::fs::write(dir.join("vertex.csv"), &csv).unwrap();
    std::fs::write(dir.join("session.toml"), block_after(marker, "toml")).unwrap();
    let read = ballpod_host::session_file::read_inputs(&[dir.join("session.toml")]);
    let _ = std::fs::remove_dir_all(&dir);
    let host = read.unwrap().host;
    let rows: Vec<Vec<f64>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    let ([x1, z1], [x2, z2]) = ([rows[0][1], rows[0][2]], [rows[1][1], rows[1][2]]);
    let want = [
        ("vertex_centre_x", 0.5 * (x1 + x2 + z1 - z2), 2.0f64, 0.0f64),
        (
            "vertex_centre_z",
            0.5 * (-x1 + x2 + z1 + z2),
            2.0,
            2.0 * 2f64.sqrt(),
        ),
    ];
    let page = from(marker);
    for (name, centre_mm, touch, offset) in want {
        let f = host.iter().find(|f| f.name == name).unwrap();
        let u = touch.hypot(offset);
        assert!(
            (f64::from(f.value) - centre_mm * 1e3).abs() < 1e-3,
            "{name}: {f:?}"
        );
        assert!((f64::from(f.u.unwrap()) - u).abs() < 1e-5, "{name}: {f:?}");
        assert_eq!(f.dof, None);
        let share = |n: &str| f.contributors.iter().find(|s| s.name == n).unwrap().u;
        assert!((f64::from(share("touch")) - touch).abs() < 1e-5, "{name}");
        assert!(
            (f64::from(share("touch_offset")) - offset).abs() < 1e-5,
            "{name}"
        );
        let printed = format!(
            "| `{name}` (µm) | {:.0} | {:.1} ± {:.2} (",
            centre_mm * 1e3,
            f.value,
            u
        );
        assert!(page.contains(&printed), "the page should print {printed}");
    }
}

/// `[vertex]` refuses a bad key by name: an unknown axis, a negative or non-finite u.
#[test]
fn the_vertex_table_refuses_bad_input_by_name() {
    let dir = std::env::temp_dir().join(format!("ballpod-vertex-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("v.csv"),
        "angle_deg,u_mm,v_mm\n0,40,30\n180,-39.838,-29.988\n",
    )
    .unwrap();
    let cases = [
        ("axis = [0.0, 0.6, 0.8]", "vertex.axis"),
        ("u_touch_um = -1.0", "vertex.u_touch_um"),
        ("u_touch_offset_um = nan", "vertex.u_touch_offset_um"),
    ];
    for (line, field) in cases {
        let session = dir.join("s.toml");
        std::fs::write(
            &session,
            format!("[vertex]\nreadings = \"v.csv\"\n{line}\n"),
        )
        .unwrap();
        let err = ballpod_host::session_file::read_inputs(&[session]).unwrap_err();
        assert_eq!(err.field.as_deref(), Some(field), "{line}: {err:?}");
    }
    // the same readings about Z by half turn: C15's centre (81, 6) µm, u = 2 µm / √2
    let session = dir.join("s.toml");
    std::fs::write(
        &session,
        "[vertex]\nreadings = \"v.csv\"\naxis = [0.0, 0.0, 1.0]\nsense = \"right_handed\"\n",
    )
    .unwrap();
    let host = ballpod_host::session_file::read_inputs(&[session])
        .unwrap()
        .host;
    let _ = std::fs::remove_dir_all(&dir);
    for (name, want) in [("vertex_centre_x", 81.0), ("vertex_centre_y", 6.0)] {
        let f = host.iter().find(|f| f.name == name).unwrap();
        assert!((f64::from(f.value) - want).abs() < 1e-3, "{f:?}");
        assert!(
            (f64::from(f.u.unwrap()) - 2f64.sqrt()).abs() < 1e-5,
            "{f:?}"
        );
    }
}
