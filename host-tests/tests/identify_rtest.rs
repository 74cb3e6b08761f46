//! Seed 003 (Hsu): R-test identification of the A/C table-tilting location errors.
//!
//! Independent sources: the paper's printed Table 1 and Table 2 (transcribed below, OCR repaired
//! as in spec A5), the spec's test vectors C1–C9 (copied numbers), and the literal 4×4 HTM
//! chain `ballpod_host::forward_seed003` (exact rotations, all 44 errors).
use ballpod_host::forward_seed003 as fw;
use ballpod_host::forward_seed004 as fw4;
use ballpod_host::forward_seed004::SplitMix;
use ballpod_host::methods::centreline::axis_direction_half_turn;
use ballpod_host::methods::rtest::{
    ARCSEC_RAD, ChainGeometry, ChainPose, ErrorTerm, LocationErrors, RankPolicy, ReadingZero,
    RtestConfig, RtestError, RtestGeometry, RtestParam, RtestSample, axis_lines, identify,
    predict_um, reduced_gains_si, table1_gains, verify,
};

const NAMES11: [&str; 11] = [
    "XOW", "YOW", "ZOW", "YOA", "ZOA", "BOA", "COA", "XOC", "YOC", "AOC", "BOC",
];
/// Table 4 of seed 003 (µm / arc-seconds).
const TABLE4: [f64; 11] = [
    -3.2, -21.6, -33.9, 20.5, 32.5, 12.3, -7.2, 1.4, -15.9, -6.5, -4.6,
];
const ANGULAR: [bool; 11] = [
    false, false, false, false, false, true, true, false, false, true, true,
];

fn table4() -> LocationErrors {
    LocationErrors::from_array(TABLE4)
}

fn si(v: [f64; 11]) -> [f64; 11] {
    core::array::from_fn(|i| {
        if ANGULAR[i] {
            v[i] * ARCSEC_RAD
        } else {
            v[i] * 1e-3
        }
    })
}

fn g3() -> RtestGeometry {
    RtestGeometry::SEED003_TABLE3
}

/// The paper's identification: one linear pass with the gains of the ball as entered, which
/// reproduces readings made with those gains (the printed Table 2) exactly.
fn paper() -> RtestConfig {
    RtestConfig {
        refine_ball: false,
        ..RtestConfig::default()
    }
}

fn kin3() -> fw::Kin {
    ballpod_host::vmt::rtest_rig::seed003_table3_kinematics()
}

/// Geometry values used by the printed-table transcription.
#[derive(Clone, Copy)]
struct Sym {
    xa: f64,
    ya: f64,
    za: f64,
    zc: f64,
    xw: f64,
    yw: f64,
    zw: f64,
    xz: f64,
    yz: f64,
    zz: f64,
    xh: f64,
    zh: f64,
    zp: f64,
    xm: f64,
    zm: f64,
    ca: f64,
    sa: f64,
    cc: f64,
    sc: f64,
}

/// Seed 003 Table 1 **as printed** (ΔX_p, ΔY_p, ΔZ_p, ΔI, ΔJ, ΔK), OCR garbage repaired only
/// where unambiguous (spec A5): COX "S_a*Z_a"→S_a*Z_c, "C_a*S_a*X_w"→C_a*S_c*X_w, "X X.a"→X_m + X_a;
/// AOZ/BOZ rows un-garbled, NOW/TOW → XOW/YOW, missing EZA ΔZ = −1. The printed signs are kept.
fn printed_table1(n: &str, s: &Sym) -> [f64; 6] {
    let Sym {
        xa,
        ya,
        za,
        zc,
        xw,
        yw,
        zw,
        xz,
        yz,
        zz,
        xh,
        zh,
        zp,
        xm,
        zm,
        ca,
        sa,
        cc,
        sc,
    } = *s;
    match n {
        "EXX" => [-1., 0., 0., 0., 0., 0.],
        "EYX" => [0., -1., 0., 0., 0., 0.],
        "EZX" => [0., 0., -1., 0., 0., 0.],
        "EAX" => [
            0.,
            za + ca * zc + sa * sc * xw + sa * cc * yw + ca * zw,
            -ya + sa * zw + sa * zc - ca * cc * yw - ca * sc * xw,
            0.,
            ca,
            sa,
        ],
        "EBX" => [
            -za - ca * zc - sa * sc * xw - sa * cc * yw - ca * zw,
            0.,
            xa - sc * yw + cc * xw,
            -ca,
            0.,
            0.,
        ],
        "ECX" => [
            ya - sa * zc - ca * sc * xw - ca * cc * yw - sa * zw,
            -xa - cc * xw + sc * yw,
            0.,
            -sa,
            0.,
            0.,
        ],
        "EXY" => [1., 0., 0., 0., 0., 0.],
        "EYY" => [0., 1., 0., 0., 0., 0.],
        "EZY" => [0., 0., 1., 0., 0., 0.],
        "EAY" => [0., -zh - zp - zm - zz, yz, 0., -1., 0.],
        "EBY" => [zh + zp + zm + zz, 0., -xh - xz, 1., 0., 0.],
        "ECY" => [-yz, xh + xz, 0., 0., 0., 0.],
        "EXZ" => [1., 0., 0., 0., 0., 0.],
        "EYZ" => [0., 1., 0., 0., 0., 0.],
        "EZZ" => [0., 0., 1., 0., 0., 0.],
        "EAZ" => [0., -zh - zp, 0., 0., -1., 0.],
        "EBZ" => [zh + zp, 0., -xh, 1., 0., 0.],
        "ECZ" => [0., xh, 0., 0., 0., 0.],
        "COX" => [
            ya - sa * zc - ca * sc * xw - ca * cc * yw - sa * zw,
            -xm - xa - cc * xw + sc * yw,
            0.,
            -sa,
            0.,
            0.,
        ],
        "AOZ" => [0., -zh - zp - zm, 0., 0., -1., 0.],
        "BOZ" => [zh + zp + zm, 0., -xh, 1., 0., 0.],
        "XOW" => [-cc, -ca * sc, -sa * sc, 0., 0., 0.],
        "YOW" => [sc, -ca * cc, -sa * cc, 0., 0., 0.],
        "ZOW" => [0., sa, -ca, 0., 0., 0.],
        "EXA" => [-1., 0., 0., 0., 0., 0.],
        "EYA" => [0., -1., 0., 0., 0., 0.],
        "EZA" => [0., 0., -1., 0., 0., 0.],
        "EAA" => [
            0.,
            sa * sc * xw + sa * cc * yw + ca * (zw + zc),
            -ca * cc * yw + sa * (zw + zc) - ca * sc * xw,
            0.,
            ca,
            sa,
        ],
        "EBA" | "BOA" => [
            -ca * (zw + zc) - sa * sc * xw - sa * cc * yw,
            0.,
            -sc * yw + cc * xw,
            -ca,
            0.,
            0.,
        ],
        "ECA" | "COA" => [
            -sa * (zw + zc) + ca * sc * xw + ca * cc * yw,
            -cc * xw + sc * yw,
            0.,
            -sa,
            0.,
            0.,
        ],
        "YOA" => [0., -1., 0., 0., 0., 0.],
        "ZOA" => [0., 0., -1., 0., 0., 0.],
        "EXC" | "XOC" => [-1., 0., 0., 0., 0., 0.],
        "EYC" | "YOC" => [0., -ca, -sa, 0., 0., 0.],
        "EZC" => [0., sa, -ca, 0., 0., 0.],
        "EAC" | "AOC" => [
            0.,
            sc * sa * xw + cc * sa * yw + ca * zw,
            -cc * ca * yw + sa * zw - sc * ca * xw,
            0.,
            ca,
            sa,
        ],
        "EBC" | "BOC" => [
            -zw,
            -cc * sa * xw + sc * sa * yw,
            -sc * ca * yw + cc * ca * xw,
            -1.,
            0.,
            0.,
        ],
        "ECC" => [
            sc * xw + cc * yw,
            -ca * cc * xw + ca * sc * yw,
            sa * sc * yw - sa * cc * xw,
            0.,
            0.,
            0.,
        ],
        _ => panic!("unknown row {n}"),
    }
}

/// Seed 003 Table 2 as printed (gains of a1…a11; ΔX, ΔY, ΔZ rows), for generating readings
/// independently of the core.
fn printed_table2(xw: f64, yw: f64, zw: f64, zc: f64, a: f64, c: f64) -> [[f64; 11]; 3] {
    let (ca, sa, cc, sc) = (a.cos(), a.sin(), c.cos(), c.sin());
    let cols: [[f64; 3]; 11] = [
        [-cc, -ca * sc, -sa * sc],
        [sc, -ca * cc, -sa * cc],
        [0., sa, -ca],
        [0., -1., 0.],
        [0., 0., -1.],
        [
            -ca * (zw + zc) - sa * sc * xw - sa * cc * yw,
            0.,
            -sc * yw + cc * xw,
        ],
        [
            -sa * (zw + zc) + ca * sc * xw + ca * cc * yw,
            -cc * xw + sc * yw,
            0.,
        ],
        [-1., 0., 0.],
        [0., -ca, -sa],
        [
            0.,
            sc * sa * xw + cc * sa * yw + ca * zw,
            -cc * ca * yw + sa * zw - sc * ca * xw,
        ],
        [
            -zw,
            -cc * sa * xw + sc * sa * yw,
            -sc * ca * yw + cc * ca * xw,
        ],
    ];
    core::array::from_fn(|i| core::array::from_fn(|j| cols[j][i]))
}

/// Readings (µm) from the printed Table 2 and parameters in µm / arcsec.
fn table2_reading_um(a_deg: f64, c_deg: f64, p: [f64; 11]) -> [f64; 3] {
    let h = printed_table2(
        -217.504,
        -0.279,
        211.537,
        29.794,
        a_deg.to_radians(),
        c_deg.to_radians(),
    );
    let x = si(p);
    core::array::from_fn(|i| 1e3 * (0..11).map(|j| h[i][j] * x[j]).sum::<f64>())
}

fn k4a() -> Vec<(f64, f64)> {
    (0..241)
        .map(|i| (-90.0 * i as f64 / 240.0, 1.5 * i as f64))
        .collect()
}
fn k1() -> Vec<(f64, f64)> {
    (0..361).map(|i| (0.0, i as f64)).collect()
}
fn k2() -> Vec<(f64, f64)> {
    (0..121).map(|i| (-(i as f64), 0.0)).collect()
}

fn samples(path: &[(f64, f64)], f: impl Fn(f64, f64) -> [f64; 3]) -> Vec<RtestSample> {
    path.iter()
        .map(|&(a, c)| RtestSample {
            a_deg: a,
            c_deg: c,
            reading_um: f(a, c),
        })
        .collect()
}

fn random_sym(rng: &mut SplitMix) -> (Sym, ChainGeometry, ChainPose) {
    let mut u = |lo: f64, hi: f64| rng.range(lo, hi);
    let (a_deg, c_deg) = (u(-120.0, 120.0), u(0.0, 360.0));
    let g = ChainGeometry {
        x_a_mm: u(-300.0, 300.0),
        y_a_mm: u(-300.0, 300.0),
        z_a_mm: u(-300.0, 300.0),
        x_c_mm: 0.0,
        y_c_mm: 0.0,
        z_c_mm: u(-100.0, 100.0),
        x_w_mm: u(-250.0, 250.0),
        y_w_mm: u(-250.0, 250.0),
        z_w_mm: u(0.0, 300.0),
        x_z_mm: u(-300.0, 300.0),
        y_z_mm: u(-300.0, 300.0),
        z_z_mm: u(-300.0, 300.0),
        x_h_mm: u(-50.0, 50.0),
        y_h_mm: 0.0,
        z_h_mm: u(-100.0, 100.0),
        z_p_mm: u(50.0, 250.0),
    };
    let pose = ChainPose {
        a_deg,
        c_deg,
        x_m_mm: u(-500.0, 500.0),
        z_m_mm: u(-500.0, 500.0),
    };
    let (a, c) = (a_deg.to_radians(), c_deg.to_radians());
    let s = Sym {
        xa: g.x_a_mm,
        ya: g.y_a_mm,
        za: g.z_a_mm,
        zc: g.z_c_mm,
        xw: g.x_w_mm,
        yw: g.y_w_mm,
        zw: g.z_w_mm,
        xz: g.x_z_mm,
        yz: g.y_z_mm,
        zz: g.z_z_mm,
        xh: g.x_h_mm,
        zh: g.z_h_mm,
        zp: g.z_p_mm,
        xm: pose.x_m_mm,
        zm: pose.z_m_mm,
        ca: a.cos(),
        sa: a.sin(),
        cc: c.cos(),
        sc: c.sin(),
    };
    (s, g, pose)
}

// ------------------------------------------------------------------ Table 1 (C7)
#[test]
fn c7_table1_42_of_44_rows_match_print_and_ecx_cox_dx_are_typos() {
    assert_eq!(
        ErrorTerm::ALL.len(),
        44,
        "41 ISO 230 errors + 3 ball position errors (C9)"
    );
    assert_eq!(RtestParam::ALL.len(), 11, "reduced model (C9)");
    let mut rng = SplitMix(3);
    for _ in 0..200 {
        let (s, g, pose) = random_sym(&mut rng);
        for (k, err) in ErrorTerm::ALL.iter().enumerate() {
            let name = fw::NAMES[k];
            assert_eq!(format!("{err:?}"), name, "row order");
            let ours = table1_gains(*err, &g, &pose);
            let printed = printed_table1(name, &s);
            for col in 0..6 {
                let typo = (name == "ECX" || name == "COX") && col == 0;
                let scale = 1.0 + printed[col].abs();
                if typo {
                    // The printed row has −Ca·Sc·X_w − Ca·Cc·Y_w where the chain gives +.
                    let expected_diff = 2.0 * s.ca * (s.sc * s.xw + s.cc * s.yw);
                    assert!(
                        (ours[0] - printed[0] - expected_diff).abs() < 1e-9 * scale,
                        "{name} typo form"
                    );
                    assert!(
                        expected_diff.abs() < 1e-6 || (ours[0] - printed[0]).abs() > 1e-6,
                        "{name}: typo must differ"
                    );
                } else {
                    assert!(
                        (ours[col] - printed[col]).abs() < 1e-9 * scale,
                        "{name} col {col}: {} vs printed {}",
                        ours[col],
                        printed[col]
                    );
                }
            }
        }
    }
}

#[test]
fn c7_table1_all_44_rows_match_the_htm_chain_including_offset_axes() {
    // The forward model (exact 4x4 chain) is differentiated numerically; X_c, Y_c, Y_h ≠ 0 too.
    let mut rng = SplitMix(5);
    for trial in 0..40 {
        let (_, mut g, pose) = random_sym(&mut rng);
        if trial % 2 == 1 {
            g.x_c_mm = rng.range(-50.0, 50.0);
            g.y_c_mm = rng.range(-50.0, 50.0);
            g.y_h_mm = rng.range(-50.0, 50.0);
        }
        let k = fw::Kin {
            x_x: rng.range(-100.0, 100.0),
            y_x: rng.range(-100.0, 100.0),
            z_x: rng.range(-100.0, 100.0),
            x_a: g.x_a_mm,
            y_a: g.y_a_mm,
            z_a: g.z_a_mm,
            x_c: g.x_c_mm,
            y_c: g.y_c_mm,
            z_c: g.z_c_mm,
            x_w: g.x_w_mm,
            y_w: g.y_w_mm,
            z_w: g.z_w_mm,
            x_z: g.x_z_mm,
            y_z: g.y_z_mm,
            z_z: g.z_z_mm,
            x_h: g.x_h_mm,
            y_h: g.y_h_mm,
            z_h: g.z_h_mm,
            z_p: g.z_p_mm,
        };
        // Table 1 is the first-order reading with the nest on the ball: follow the ideal TCP.
        let (a, c) = (pose.a_deg.to_radians(), pose.c_deg.to_radians());
        let (xm, ym, zm) = fw::tcp_commands(&k, a, c);
        let pose = ChainPose {
            x_m_mm: xm,
            z_m_mm: zm,
            ..pose
        };
        let num = fw::numeric_gains(&k, a, c, xm, ym, zm, 1e-6);
        for (n, err) in ErrorTerm::ALL.iter().enumerate() {
            let ours = table1_gains(*err, &g, &pose);
            for col in 0..6 {
                assert!(
                    (ours[col] - num[n][col]).abs() < 1e-6 * (1.0 + num[n][col].abs()),
                    "{} col {col}: {} vs chain {} (trial {trial})",
                    fw::NAMES[n],
                    ours[col],
                    num[n][col]
                );
            }
        }
    }
}

// ------------------------------------------------------------------ Table 2, C1, C2
#[test]
#[allow(clippy::approx_constant)] // 0.707107 is the spec's printed 6-digit value, kept as printed
fn c1_c2_h_blocks_and_table2_as_printed() {
    let c1 = [
        [-1., 0., 0., 0., 0., -241.331, -0.279, -1., 0., 0., -211.537],
        [0., -1., 0., -1., 0., 0., 217.504, 0., -1., 211.537, 0.],
        [0., 0., -1., 0., -1., -217.504, 0., 0., 0., 0.279, -217.504],
    ];
    let h = reduced_gains_si(&g3(), 0.0, 0.0);
    for i in 0..3 {
        for j in 0..11 {
            assert!(
                (h[i][j] - c1[i][j]).abs() < 1e-9,
                "C1 [{i}][{j}] {} vs {}",
                h[i][j],
                c1[i][j]
            );
        }
    }
    let c2 = [
        [
            0.,
            1.,
            0.,
            0.,
            0.,
            -324.445340,
            16.848233,
            -1.,
            0.,
            0.,
            -211.537,
        ],
        [
            -0.707107, 0., -0.707107, -1., 0., 0., -0.279, 0., -0.707107, 303.377801, 0.197283,
        ],
        [
            0.707107, 0., -0.707107, 0., -1., 0.279, 0., 0., 0.707107, 4.219306, 0.197283,
        ],
    ];
    let h = reduced_gains_si(&g3(), -45.0, 90.0);
    for i in 0..3 {
        for j in 0..11 {
            assert!(
                (h[i][j] - c2[i][j]).abs() < 1e-6,
                "C2 [{i}][{j}] {} vs {}",
                h[i][j],
                c2[i][j]
            );
        }
    }
    // Table 2 as printed, at many poses.
    let mut rng = SplitMix(11);
    for _ in 0..500 {
        let (a, c) = (rng.range(-120.0, 120.0), rng.range(0.0, 360.0));
        let h = reduced_gains_si(&g3(), a, c);
        let p = printed_table2(
            -217.504,
            -0.279,
            211.537,
            29.794,
            a.to_radians(),
            c.to_radians(),
        );
        for i in 0..3 {
            for j in 0..11 {
                assert!(
                    (h[i][j] - p[i][j]).abs() < 1e-9,
                    "Table 2 {} row {i}",
                    NAMES11[j]
                );
            }
        }
    }
}

#[test]
fn c8_arcsecond_conversions() {
    for (arcsec, rad) in [
        (12.3, 5.963208e-5),
        (-7.2, -3.490659e-5),
        (-6.5, -3.151289e-5),
        (-4.6, -2.230143e-5),
    ] {
        assert!((arcsec * ARCSEC_RAD - rad).abs() < 1e-11);
    }
}

#[test]
fn c3_predicted_readings_with_table4() {
    let vectors = [
        ((0.0, 0.0), [-7.8638, 2.7415, -6.7284]),
        ((0.0, 90.0), [-25.0812, -8.0564, -5.4438]),
        ((0.0, 180.0), [-14.2832, -25.2738, 9.5284]),
        ((0.0, 270.0), [2.9342, -14.4759, 8.2438]),
        ((-30.0, 0.0), [-10.1574, 17.9815, -27.3357]),
        ((-45.0, 90.0), [-38.2179, 7.4217, -22.1555]),
        ((-90.0, 0.0), [-1.9231, 10.6495, -76.3041]),
        ((-90.0, 90.0), [-39.6767, 6.5493, -44.9172]),
        ((30.0, 45.0), [-8.6974, -18.9144, -0.1523]),
        ((90.0, 180.0), [8.5250, -41.9658, -31.8959]),
    ];
    for ((a, c), want) in vectors {
        let got = predict_um(&g3(), &table4(), a, c).unwrap();
        for i in 0..3 {
            assert!(
                (got[i] - want[i]).abs() < 1e-3,
                "({a},{c})[{i}]: {} vs {}",
                got[i],
                want[i]
            );
        }
    }
}

#[test]
fn c4_exact_chain_vs_first_order_model_within_3nm() {
    let k = kin3();
    let p = si(TABLE4);
    let mut worst: f64 = 0.0;
    for ai in 0..=12 {
        for ci in 0..12 {
            let (a, c) = (-90.0 + 15.0 * ai as f64, 30.0 * ci as f64);
            let exact = fw::exact_reduced_reading_um(&k, &p, a.to_radians(), c.to_radians());
            let lin = predict_um(&g3(), &table4(), a, c).unwrap();
            for i in 0..3 {
                worst = worst.max((exact[i] - lin[i]).abs());
            }
        }
    }
    assert!(worst < 3e-3, "max |exact − linear| = {worst} µm");
    assert!(
        worst > 1e-3,
        "the chain is nonlinear: spec C4 measures 2.64 nm, got {worst}"
    );
}

// ------------------------------------------------------------------ C5 LSQ round trip
#[test]
fn c5_k4a_round_trip_recovers_table4() {
    let s = samples(&k4a(), |a, c| table2_reading_um(a, c, TABLE4));
    let r = identify(&g3(), &s, &paper()).unwrap();
    assert_eq!(r.rank, 11);
    assert_eq!(r.fixed.count(), 0);
    let got = r.errors.to_array();
    for j in 0..11 {
        assert!(
            (got[j] - TABLE4[j]).abs() < 1e-6,
            "{}: {} vs {}",
            NAMES11[j],
            got[j],
            TABLE4[j]
        );
    }
    assert!(r.residuals.rms_total_um < 1e-9);
    // spec A7: condition ≈ 27 with columns in µm / arcsec
    assert!(
        r.condition > 20.0 && r.condition < 35.0,
        "condition {}",
        r.condition
    );
}

#[test]
fn c5_k4a_with_1um_noise_stays_within_3_sigma() {
    let sigma = [
        0.16, 0.25, 0.48, 0.43, 0.43, 0.34, 0.34, 0.15, 0.49, 0.17, 0.46,
    ];
    let mut rng = SplitMix(2024);
    let mut worst_ratio: f64 = 0.0;
    for _ in 0..20 {
        let s: Vec<RtestSample> = samples(&k4a(), |a, c| table2_reading_um(a, c, TABLE4))
            .into_iter()
            .map(|mut s| {
                s.reading_um.iter_mut().for_each(|v| *v += rng.normal());
                s
            })
            .collect();
        let r = identify(&g3(), &s, &paper()).unwrap();
        let got = r.errors.to_array();
        let u = r.u_type_a.to_array();
        for j in 0..11 {
            worst_ratio = worst_ratio.max((got[j] - TABLE4[j]).abs() / sigma[j]);
            // the Type A share is the spec's 1σ (within sampling of the residual variance)
            assert!(
                (u[j] / sigma[j] - 1.0).abs() < 0.15,
                "{}: u {} vs σ {}",
                NAMES11[j],
                u[j],
                sigma[j]
            );
        }
        assert!((r.residuals.rms_total_um - 1.0).abs() < 0.1);
    }
    assert!(worst_ratio < 4.0, "worst |error|/σ = {worst_ratio}");
}

#[test]
fn round_trip_random_deviations_linear_and_exact_chain() {
    let mut rng = SplitMix(77);
    let k = kin3();
    for _ in 0..10 {
        let truth: [f64; 11] = core::array::from_fn(|j| {
            if ANGULAR[j] {
                rng.range(-20.0, 20.0)
            } else {
                rng.range(-50.0, 50.0)
            }
        });
        // linear (printed Table 2) readings: recovered to 1e-9 relative
        let s = samples(&k4a(), |a, c| table2_reading_um(a, c, truth));
        let r = identify(&g3(), &s, &paper()).unwrap();
        let got = r.errors.to_array();
        let scale = truth.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for j in 0..11 {
            assert!(
                (got[j] - truth[j]).abs() < 1e-9 * scale,
                "{} linear",
                NAMES11[j]
            );
        }
        // exact HTM chain readings: recovered to the linearisation bound
        let p = si(truth);
        let s = samples(&k4a(), |a, c| {
            fw::exact_reduced_reading_um(&k, &p, a.to_radians(), c.to_radians())
        });
        let r = identify(&g3(), &s, &RtestConfig::default()).unwrap();
        let got = r.errors.to_array();
        for j in 0..11 {
            assert!(
                (got[j] - truth[j]).abs() < 0.05,
                "{} exact chain: {} vs {}",
                NAMES11[j],
                got[j],
                truth[j]
            );
        }
        assert!(
            r.residuals.rms_total_um < 0.01,
            "{}",
            r.residuals.rms_total_um
        );
    }
}

// ------------------------------------------------------------------ C6 rank
#[test]
fn c6_ranks_of_k1_k2_k4_absolute_and_zeroed() {
    let truth = TABLE4;
    let data = |p: &[(f64, f64)]| samples(p, |a, c| table2_reading_um(a, c, truth));
    let zeroed = RtestConfig {
        zero: ReadingZero::FirstPose,
        ..paper()
    };
    let k1k2: Vec<(f64, f64)> = k1().into_iter().chain(k2()).collect();
    for (name, path, abs_rank, zero_rank) in [
        ("K4a", k4a(), 11, 8),
        ("K1", k1(), 7, 4),
        ("K2", k2(), 7, 4),
        ("K1+K2", k1k2, 11, 8),
    ] {
        let s = data(&path);
        let r = identify(&g3(), &s, &paper()).unwrap();
        assert_eq!(r.rank, abs_rank, "{name} absolute");
        assert_eq!(r.fixed.count(), 11 - abs_rank, "{name} absolute fixed");
        let z = identify(&g3(), &s, &zeroed).unwrap();
        assert_eq!(z.rank, zero_rank, "{name} zeroed");
        assert_eq!(z.fixed.count(), 11 - zero_rank, "{name} zeroed fixed");
        // whatever is fixed, the estimate reproduces the data (the fixed columns lie in the span)
        assert!(
            r.residuals.rms_total_um < 1e-9 && z.residuals.rms_total_um < 1e-9,
            "{name}"
        );
    }
}

#[test]
fn zeroed_readings_fix_xoc_yoa_zoa_and_recover_the_rest() {
    let s = samples(&k4a(), |a, c| {
        let q = table2_reading_um(a, c, TABLE4);
        [q[0] + 3.0, q[1] - 7.0, q[2] + 11.0] // unknown sensor zero: irrelevant when zeroed
    });
    let cfg = RtestConfig {
        zero: ReadingZero::FirstPose,
        ..paper()
    };
    let r = identify(&g3(), &s, &cfg).unwrap();
    let fixed: Vec<&str> = (0..11)
        .filter(|&j| r.fixed.0[j])
        .map(|j| NAMES11[j])
        .collect();
    assert_eq!(fixed, ["YOA", "ZOA", "XOC"]);
    assert_eq!(
        r.combined.count(),
        0,
        "the offsets only hide the constant columns"
    );
    let got = r.errors.to_array();
    for j in 0..11 {
        if r.fixed.0[j] {
            assert!(
                got[j].is_nan(),
                "{}: a fixed parameter is not reported",
                NAMES11[j]
            );
            assert!(r.std_uncertainty.to_array()[j].is_nan());
            assert_eq!(r.path_model.to_array()[j], 0.0);
        } else {
            assert!((got[j] - TABLE4[j]).abs() < 1e-6, "{}", NAMES11[j]);
        }
    }
    // Fixing at supplied values instead of 0 (e.g. from another measurement).
    let mut values = [0.0; 11];
    values[RtestParam::Xoc.index()] = 1.4;
    values[RtestParam::Yoa.index()] = 20.5;
    values[RtestParam::Zoa.index()] = 32.5;
    let cfg = RtestConfig {
        fixed_values: LocationErrors::from_array(values),
        ..cfg
    };
    let r = identify(&g3(), &s, &cfg).unwrap();
    let got = r.path_model.to_array();
    for j in 0..11 {
        assert!(
            (got[j] - TABLE4[j]).abs() < 1e-6,
            "{} with fixed values",
            NAMES11[j]
        );
    }
}

#[test]
fn k1_alone_names_the_inseparable_parameters_or_refuses() {
    let s = samples(&k1(), |a, c| table2_reading_um(a, c, TABLE4));
    let r = identify(&g3(), &s, &paper()).unwrap();
    let fixed: Vec<&str> = (0..11)
        .filter(|&j| r.fixed.0[j])
        .map(|j| NAMES11[j])
        .collect();
    // spec A7 dependencies at A = 0: ZOW≡ZOA, YOA≡YOC, BOA−BOC = Z_c·XOC, COA = X_w·YOW − Y_w·XOW
    assert_eq!(fixed, ["YOW", "ZOW", "YOA", "XOC"]);
    // the free parameters in those dependencies absorb the fixed ones: not reported (issue 14:
    // BOA read 262″ for a true −9.4″); the rest equal the truth
    let combined: Vec<&str> = (0..11)
        .filter(|&j| r.combined.0[j])
        .map(|j| NAMES11[j])
        .collect();
    // exactly the free partners of those four dependencies; only AOC is determined
    assert_eq!(combined, ["XOW", "ZOA", "BOA", "COA", "YOC", "BOC"]);
    let (got, u) = (r.errors.to_array(), r.std_uncertainty.to_array());
    for j in 0..11 {
        if r.fixed.0[j] || r.combined.0[j] {
            assert!(
                got[j].is_nan() && u[j].is_nan(),
                "{} = {}",
                NAMES11[j],
                got[j]
            );
        } else {
            assert!(
                (got[j] - TABLE4[j]).abs() < 1e-6,
                "{}: {}",
                NAMES11[j],
                got[j]
            );
        }
    }
    let cfg = RtestConfig {
        policy: RankPolicy::Refuse,
        ..RtestConfig::default()
    };
    match identify(&g3(), &s, &cfg) {
        Err(RtestError::NotIdentifiable {
            rank: 7,
            inseparable,
        }) => assert_eq!(inseparable, r.fixed),
        other => panic!("expected NotIdentifiable, got {other:?}"),
    }
    // K2 alone likewise
    let s2 = samples(&k2(), |a, c| table2_reading_um(a, c, TABLE4));
    assert!(matches!(
        identify(&g3(), &s2, &cfg),
        Err(RtestError::NotIdentifiable { rank: 7, .. })
    ));
}

// ------------------------------------------------------------------ verification paths
#[test]
fn verification_on_k1_k2_after_identification_on_k4() {
    let k = kin3();
    let truth = TABLE4;
    let p = si(truth);
    let exact = |path: &[(f64, f64)]| {
        samples(path, |a, c| {
            fw::exact_reduced_reading_um(&k, &p, a.to_radians(), c.to_radians())
        })
    };
    let r = identify(&g3(), &exact(&k4a()), &RtestConfig::default()).unwrap();
    for (name, path) in [("K1", k1()), ("K2", k2())] {
        let g = r.gains_geometry;
        let v = verify(&g, &r.errors, &exact(&path), ReadingZero::Absolute).unwrap();
        assert!(
            v.max_abs_um.iter().all(|m| *m < 0.01),
            "{name}: {:?}",
            v.max_abs_um
        );
        assert_eq!(v.samples, path.len());
    }
    // A 5 µm error of the C-axis radial motion (EYC, not in the reduced model) shows up in the
    // verification residual on K1 with its known size.
    let mut e = [0.0; 44];
    for (n, v) in NAMES11.iter().zip(p) {
        e[fw::idx(n)] = v;
    }
    e[fw::idx("EYC")] = 5e-3;
    let s = samples(&k1(), |a, c| {
        let (a, c) = (a.to_radians(), c.to_radians());
        let (xm, ym, zm) = fw::tcp_commands(&k, a, c);
        let q = fw::reading(&k, &e, a, c, xm, ym, zm);
        [q[0] * 1e3, q[1] * 1e3, q[2] * 1e3]
    });
    let v = verify(&r.gains_geometry, &r.errors, &s, ReadingZero::Absolute).unwrap();
    assert!((v.max_abs_um[1] - 5.0).abs() < 0.02, "{:?}", v.max_abs_um);
}

// ------------------------------------------------------------------ offset C axis
#[test]
fn reduced_gains_with_offset_c_axis_match_the_chain() {
    let g = RtestGeometry {
        x_c_mm: 12.0,
        y_c_mm: -7.5,
        ..g3()
    };
    let k = fw::Kin {
        x_c: 12.0,
        y_c: -7.5,
        ..kin3()
    };
    let mut rng = SplitMix(8);
    for _ in 0..20 {
        let (a, c) = (rng.range(-100.0, 100.0), rng.range(0.0, 360.0));
        let (xm, ym, zm) = fw::tcp_commands(&k, a.to_radians(), c.to_radians());
        let num = fw::numeric_gains(&k, a.to_radians(), c.to_radians(), xm, ym, zm, 1e-6);
        let h = reduced_gains_si(&g, a, c);
        for (j, n) in NAMES11.iter().enumerate() {
            for i in 0..3 {
                let want = num[fw::idx(n)][i];
                assert!(
                    (h[i][j] - want).abs() < 1e-6 * (1.0 + want.abs()),
                    "{n} row {i}"
                );
            }
        }
    }
}

// ------------------------------------------------------------------ bad input
#[test]
fn bad_input_gets_typed_errors() {
    let mut s = samples(&k4a(), |a, c| table2_reading_um(a, c, TABLE4));
    let cfg = RtestConfig::default();
    assert_eq!(
        identify(&g3(), &s[..3], &cfg),
        Err(RtestError::TooFewSamples {
            given: 3,
            needed: 4
        })
    );
    let zeroed = RtestConfig {
        zero: ReadingZero::FirstPose,
        ..cfg
    };
    assert_eq!(
        identify(&g3(), &s[..4], &zeroed),
        Err(RtestError::TooFewSamples {
            given: 4,
            needed: 5
        })
    );
    let bad_geom = RtestGeometry {
        z_w_mm: f64::NAN,
        ..g3()
    };
    assert_eq!(identify(&bad_geom, &s, &cfg), Err(RtestError::BadParameter));
    let mut order = cfg.estimation_order;
    order[1] = order[0];
    assert_eq!(
        identify(
            &g3(),
            &s,
            &RtestConfig {
                estimation_order: order,
                ..cfg
            }
        ),
        Err(RtestError::BadEstimationOrder)
    );
    s[17].reading_um[2] = f64::INFINITY;
    assert_eq!(
        identify(&g3(), &s, &cfg),
        Err(RtestError::NonFiniteSample { sample: 17 })
    );
    assert_eq!(
        verify(&g3(), &table4(), &s, ReadingZero::Absolute),
        Err(RtestError::NonFiniteSample { sample: 17 })
    );
    assert_eq!(
        predict_um(&g3(), &table4(), f64::NAN, 0.0),
        Err(RtestError::BadParameter)
    );
    assert_eq!(
        axis_lines(&bad_geom, &table4()),
        Err(RtestError::BadParameter)
    );
    let neg_tol = RtestConfig {
        rank_tol: -1.0,
        ..cfg
    };
    assert_eq!(
        identify(&g3(), &s[..10], &neg_tol),
        Err(RtestError::BadParameter)
    );
    for u_reading_scale in [-1e-3, f64::NAN, f64::INFINITY] {
        let bad_budget = RtestConfig {
            u_reading_scale,
            ..cfg
        };
        assert_eq!(
            identify(&g3(), &s[..10], &bad_budget),
            Err(RtestError::BadParameter)
        );
    }
    // all samples at one pose: only the constant columns survive; refusing names the rest
    let same = vec![
        RtestSample {
            a_deg: 0.0,
            c_deg: 0.0,
            reading_um: [1.0, 2.0, 3.0]
        };
        10
    ];
    match identify(
        &g3(),
        &same,
        &RtestConfig {
            policy: RankPolicy::Refuse,
            ..cfg
        },
    ) {
        Err(RtestError::NotIdentifiable {
            rank: 3,
            inseparable,
        }) => assert_eq!(inseparable.count(), 8),
        other => panic!("{other:?}"),
    }
}

// ------------------------------------------------------------------ bridge to seed 004
#[test]
fn axis_lines_are_what_the_chain_rotates_the_ball_about() {
    let g = RtestGeometry {
        x_c_mm: 4.0,
        y_c_mm: -3.0,
        ..g3()
    };
    let k = fw::Kin {
        x_c: 4.0,
        y_c: -3.0,
        ..kin3()
    };
    let mut rng = SplitMix(31);
    for _ in 0..20 {
        let truth: [f64; 11] = core::array::from_fn(|j| {
            if ANGULAR[j] {
                rng.range(-20.0, 20.0)
            } else {
                rng.range(-50.0, 50.0)
            }
        });
        let mut e = [0.0; 44];
        for (n, v) in NAMES11.iter().zip(si(truth)) {
            e[fw::idx(n)] = v;
        }
        let ball = |a: f64, c: f64| {
            let (w, _) = fw::chains(&k, &e, a.to_radians(), c.to_radians(), 0.0, 0.0, 0.0);
            [w[0][3], w[1][3], w[2][3]]
        };
        let (a_line, c_line) = axis_lines(&g, &LocationErrors::from_array(truth)).unwrap();
        let p0 = ball(0.0, 0.0);
        for ang in [30.0f64, 90.0, 200.0] {
            // C turned at A = 0: the ball circles the C line
            let want =
                fw4::rotate_about_line(c_line.direction, c_line.point_mm, ang.to_radians(), p0);
            let got = ball(0.0, ang);
            assert!(
                (0..3).all(|i| (got[i] - want[i]).abs() < 2e-6),
                "C line: {got:?} vs {want:?}"
            );
            // A tilted at C = 0: the ball circles the A line
            let want = fw4::rotate_about_line(
                a_line.direction,
                a_line.point_mm,
                -ang.to_radians() / 2.0,
                p0,
            );
            let got = ball(-ang / 2.0, 0.0);
            assert!(
                (0..3).all(|i| (got[i] - want[i]).abs() < 2e-6),
                "A line: {got:?} vs {want:?}"
            );
        }
    }
}

#[test]
fn seed004_half_turn_on_the_c_table_measures_the_c_line_of_axis_lines() {
    // A tilted reference face on the C table, dial-gauged at C0 and C180 with A = 0 (seed 004
    // §3.1 on seed 003's machine): the centreline direction it gives is axis_lines' C line
    // (tilt BOC + BOA about Y), not (BOC, −AOC, 1) alone.
    let k = kin3();
    let mut rng = SplitMix(12);
    for _ in 0..20 {
        let truth: [f64; 11] = core::array::from_fn(|j| {
            if ANGULAR[j] {
                rng.range(-40.0, 40.0)
            } else {
                rng.range(-50.0, 50.0)
            }
        });
        let mut e = [0.0; 44];
        for (n, v) in NAMES11.iter().zip(si(truth)) {
            e[fw::idx(n)] = v;
        }
        let face_c = fw4::normalize([rng.range(-2e-3, 2e-3), rng.range(-2e-3, 2e-3), 1.0]);
        let normal = |c: f64| {
            let (w, _) = fw::chains(&k, &e, 0.0, c.to_radians(), 0.0, 0.0, 0.0);
            fw4::normalize(core::array::from_fn(|i| {
                (0..3).map(|j| w[i][j] * face_c[j]).sum()
            }))
        };
        let d = axis_direction_half_turn(normal(0.0), normal(180.0), [0.0, 0.0, 1.0], 0.0)
            .unwrap()
            .direction;
        let (_, c_line) = axis_lines(&g3(), &LocationErrors::from_array(truth)).unwrap();
        assert!(
            (0..3).all(|i| (d[i] - c_line.direction[i]).abs() < 1e-8),
            "{d:?} vs {:?}",
            c_line.direction
        );
        let boc_plus_boa = (truth[5] + truth[10]) * ARCSEC_RAD;
        assert!(
            (d[0] - boc_plus_boa).abs() < 1e-7,
            "first order: BOC + BOA (second-order COA·AOC aside)"
        );
    }
}

/// Coverage of the 11 parameters over Monte Carlo runs: how often U = 2u covers the truth and
/// the rms u against the rms error (issue 14's criteria: 95 % ± 3 %, within 20 %).
#[derive(Default)]
struct Coverage {
    runs: usize,
    covered: [usize; 11],
    e2: [f64; 11],
    u2: [f64; 11],
}

impl Coverage {
    /// Adds one run's estimates `got` with their u against `truth`, for the parameters in `which`.
    fn add(
        &mut self,
        got: [f64; 11],
        u: [f64; 11],
        truth: [f64; 11],
        which: impl Fn(usize) -> bool,
    ) {
        self.runs += 1;
        for j in (0..11).filter(|&j| which(j)) {
            let e = got[j] - truth[j];
            self.covered[j] += usize::from(e.abs() <= 2.0 * u[j]);
            self.e2[j] += e * e;
            self.u2[j] += u[j] * u[j];
        }
    }

    /// Parameter `j`'s (coverage, rms u / rms error), printed with `label`.
    fn stats(&self, j: usize, label: &str) -> (f64, f64) {
        let coverage = self.covered[j] as f64 / self.runs as f64;
        let ratio = (self.u2[j] / self.e2[j]).sqrt();
        println!(
            "{} ({label}): coverage {coverage:.3}, rms u / rms error {ratio:.2}",
            NAMES11[j]
        );
        (coverage, ratio)
    }

    /// Asserts issue 14's criteria for parameter `j`.
    fn assert_honest(&self, j: usize, label: &str) {
        let (coverage, ratio) = self.stats(j, label);
        assert!(
            (0.92..=0.98).contains(&coverage) && (0.8..=1.2).contains(&ratio),
            "{}: coverage {coverage:.3}, rms u / rms error {ratio:.3}",
            NAMES11[j]
        );
    }
}

/// Issue 14: readings zeroed at the first pose. 300 noisy K4 runs (1 µm per axis) with an
/// unknown sensor zero: U = 2u covers Table 4 in 95 % ± 3 % of the estimates of each free
/// parameter, and u matches the scatter within 20 % (differencing against the first pose made u
/// 3–10× too small).
#[test]
fn first_pose_zeroing_states_an_honest_u() {
    // the simulated head is calibrated exactly: its budget says so
    let cfg = RtestConfig {
        zero: ReadingZero::FirstPose,
        u_reading_scale: 0.0,
        ..RtestConfig::default()
    };
    let path: Vec<(f64, f64)> = k4a().into_iter().step_by(4).collect();
    let mut rng = SplitMix(14);
    const RUNS: usize = 300;
    let mut cov = Coverage::default();
    let mut fixed = None;
    for _ in 0..RUNS {
        let zero = [
            rng.range(-50.0, 50.0),
            rng.range(-50.0, 50.0),
            rng.range(-50.0, 50.0),
        ];
        let s = samples(&path, |a, c| {
            let q = table2_reading_um(a, c, TABLE4);
            core::array::from_fn(|k| q[k] - zero[k])
        })
        .into_iter()
        .map(|mut s| {
            s.reading_um.iter_mut().for_each(|v| *v += rng.normal());
            s
        })
        .collect::<Vec<_>>();
        let r = identify(&g3(), &s, &cfg).unwrap();
        fixed = Some(r.fixed);
        let (got, u) = (r.errors.to_array(), r.std_uncertainty.to_array());
        cov.add(got, u, TABLE4, |j| !r.fixed.0[j]);
    }
    let fixed = fixed.unwrap();
    assert_eq!(fixed.count(), 3);
    for j in (0..11).filter(|&j| !fixed.0[j]) {
        cov.assert_honest(j, "first-pose zero");
    }
}

/// Issue 14: the head's calibration. 1 000 K4 runs on machines with random location errors (up
/// to 3× Table 4's), readings from the printed Table 2 read by a head whose three axes' scales
/// are each off by N(0, 1 %), plus 0.2 µm of noise per axis. With `u_reading_scale` = 1 % U = 2u
/// covers every parameter in 95 % ± 3 % of the runs and u matches the scatter within 20 %;
/// with the residuals' u alone (the head taken as exact) the largest parameters are covered
/// far less often.
#[test]
fn the_heads_calibration_is_in_u() {
    let path: Vec<(f64, f64)> = k4a().into_iter().step_by(4).collect();
    let run = |u_reading_scale: f64| {
        let cfg = RtestConfig {
            u_reading_scale,
            ..RtestConfig::default()
        };
        let mut rng = SplitMix(31);
        const RUNS: usize = 1000;
        let mut cov = Coverage::default();
        for _ in 0..RUNS {
            let truth: [f64; 11] = core::array::from_fn(|j| TABLE4[j] * rng.range(-3.0, 3.0));
            let scale: [f64; 3] = core::array::from_fn(|_| 1.0 + 0.01 * rng.normal());
            let s = samples(&path, |a, c| {
                let q = table2_reading_um(a, c, truth);
                core::array::from_fn(|k| q[k] * scale[k])
            })
            .into_iter()
            .map(|mut s| {
                s.reading_um
                    .iter_mut()
                    .for_each(|v| *v += 0.2 * rng.normal());
                s
            })
            .collect::<Vec<_>>();
            let r = identify(&g3(), &s, &cfg).unwrap();
            assert_eq!(r.fixed.count(), 0);
            cov.add(
                r.errors.to_array(),
                r.std_uncertainty.to_array(),
                truth,
                |_| true,
            );
        }
        cov
    };
    let cov = run(0.01);
    for j in 0..11 {
        cov.assert_honest(j, "u_reading_scale 0.01");
    }
    let cov = run(0.0);
    let worst = (0..11)
        .map(|j| cov.stats(j, "u_reading_scale 0").0)
        .fold(1.0f64, f64::min);
    assert!(worst < 0.8, "{worst}");
}

/// Issue 14, the ball's and the C axis's positions as entered: estimated, not budgeted. 300 K4
/// runs on the literal HTM chain (`forward_seed003`), the ball up to ±0.5 mm (XOW, YOW, ZOW)
/// and the C axis up to ±0.3 mm (XOC, YOC) from where they are entered and the other errors up
/// to 3× Table 4, 0.3 µm of noise per axis, the head exact (`u_reading_scale` 0): U = 2u covers
/// every parameter in 95 % ± 3 % of the runs and u matches the scatter within 20 % when the
/// gains are taken again where the first pass puts them (the default; 0.009 at most without
/// noise); the paper's one pass with the gains as entered errs by up to 0.23 (µm or ″)
/// without noise, and covers some parameter in under 90 %.
#[test]
fn the_ball_as_entered_is_estimated_not_budgeted() {
    let k = kin3();
    let path = k4a();
    const RUNS: usize = 300;
    let run = |refine_ball: bool| {
        let cfg = RtestConfig {
            u_reading_scale: 0.0,
            refine_ball,
            ..RtestConfig::default()
        };
        let mut rng = SplitMix(503);
        let mut cov = Coverage::default();
        let mut worst_clean = 0.0f64;
        for _ in 0..RUNS {
            // the ball (XOW, YOW, ZOW) up to 0.5 mm and the C axis (XOC, YOC) up to 0.3 mm from
            // where they are entered
            let truth: [f64; 11] = core::array::from_fn(|j| match j {
                0..=2 => rng.range(-500.0, 500.0),
                7 | 8 => rng.range(-300.0, 300.0),
                _ => TABLE4[j] * rng.range(-3.0, 3.0),
            });
            let p = si(truth);
            let clean = samples(&path, |a, c| {
                fw::exact_reduced_reading_um(&k, &p, a.to_radians(), c.to_radians())
            });
            let r = identify(&g3(), &clean, &cfg).unwrap();
            for (g, t) in r.errors.to_array().iter().zip(truth) {
                worst_clean = worst_clean.max((g - t).abs());
            }
            let noisy: Vec<RtestSample> = clean
                .into_iter()
                .map(|mut s| {
                    s.reading_um
                        .iter_mut()
                        .for_each(|v| *v += 0.3 * rng.normal());
                    s
                })
                .collect();
            let r = identify(&g3(), &noisy, &cfg).unwrap();
            cov.add(
                r.errors.to_array(),
                r.std_uncertainty.to_array(),
                truth,
                |_| true,
            );
        }
        println!("refine_ball {refine_ball}: worst error without noise {worst_clean:.4}");
        (cov, worst_clean)
    };
    let (refined, worst) = run(true);
    assert!(worst < 0.02, "refined, without noise: {worst}");
    for j in 0..11 {
        refined.assert_honest(j, "refine_ball true");
    }
    let (paper, worst) = run(false);
    assert!(worst > 0.1, "the paper's pass, without noise: {worst}");
    let least = (0..11)
        .map(|j| paper.stats(j, "refine_ball false").0)
        .fold(1.0f64, f64::min);
    assert!(
        least < 0.9,
        "the paper's pass covers every parameter in {least:.3} or more"
    );
}

/// The identification's covariance: its diagonal is u², and over 300 noisy K4 runs with the
/// head's axes each off by N(0, 0.5 %) its off-diagonal terms follow the estimates' own
/// covariance (every correlation within 0.15 of the scatter's).
#[test]
fn the_covariance_follows_the_estimates_scatter() {
    let g = RtestGeometry::SEED003_TABLE3;
    let truth = [
        -3.2, -21.6, -33.9, 20.5, 32.5, 12.3, -7.2, 1.4, -15.9, -6.5, -4.6,
    ];
    let e = LocationErrors::from_array(truth);
    let path: Vec<(f64, f64)> = (0..241)
        .map(|i| (-90.0 * i as f64 / 240.0, 360.0 * i as f64 / 240.0))
        .collect();
    let mut rng = SplitMix::new(5);
    let n = 300;
    let mut est = Vec::new();
    let mut cov_sum = [[0.0f64; 11]; 11];
    for _ in 0..n {
        let scale: [f64; 3] = std::array::from_fn(|_| 1.0 + 0.005 * rng.normal());
        let samples: Vec<RtestSample> = path
            .iter()
            .map(|&(a, c)| {
                let p = predict_um(&g, &e, a, c).unwrap();
                RtestSample {
                    a_deg: a,
                    c_deg: c,
                    reading_um: std::array::from_fn(|k| p[k] * scale[k] + 0.3 * rng.normal()),
                }
            })
            .collect();
        let cfg = RtestConfig {
            refine_ball: false,
            ..RtestConfig::default()
        };
        let id = identify(&g, &samples, &cfg).unwrap();
        let u = id.std_uncertainty.to_array();
        for i in 0..11 {
            assert!((id.covariance[i][i] - u[i] * u[i]).abs() <= 1e-9 * u[i] * u[i]);
            for j in 0..11 {
                cov_sum[i][j] += id.covariance[i][j];
            }
        }
        est.push(id.errors.to_array());
    }
    let mean: [f64; 11] = std::array::from_fn(|i| est.iter().map(|x| x[i]).sum::<f64>() / n as f64);
    let scatter = |i: usize, j: usize| {
        est.iter()
            .map(|x| (x[i] - mean[i]) * (x[j] - mean[j]))
            .sum::<f64>()
            / (n - 1) as f64
    };
    for i in 0..11 {
        for j in 0..11 {
            let r_stated = cov_sum[i][j] / (cov_sum[i][i] * cov_sum[j][j]).sqrt();
            let r_seen = scatter(i, j) / (scatter(i, i) * scatter(j, j)).sqrt();
            assert!(
                (r_stated - r_seen).abs() <= 0.15,
                "({i}, {j}): stated {r_stated:.3}, seen {r_seen:.3}"
            );
        }
    }
}
