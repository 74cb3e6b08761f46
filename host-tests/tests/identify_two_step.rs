//! Seed 000 two-step orientation-error identification (`identify::two_step`) against the
//! paper's Table 1 (all 40 numbers), the spec's synthetic vectors TV-RRTTT-6, TV-TTTRR-1,
//! TV-T2-nominal, TV-RTTTR-A/B, the singularities of spec part D 9, and round trips through
//! the independent HTM forward model in `ballpod_host::forward_seed000`.
use ballpod::identify::two_step::{
    self, DEFAULT_MIN_LEVER_ARM_MM, Mode, ReferenceEnd, RotationOrder, RrtttConfig,
    RrtttMeasurement, RtttrSpindleConfig, RtttrTableConfig, SingleAxisMeasurement, Singularity,
    TttrrConfig, TttrrMeasurement, TwoStepError, URAD_PER_DEG,
};
use ballpod_host::forward_seed000 as fwd;

const D2R: f64 = std::f64::consts::PI / 180.0;

fn close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b} (tol {tol})");
}

/// Rounds to `dp` decimals (to compare with a printed table).
fn round(v: f64, dp: i32) -> f64 {
    let k = 10f64.powi(dp);
    (v * k).round() / k
}

fn rrttt_cfg(z: f64) -> RrtttConfig {
    RrtttConfig {
        tool_z_mm: z,
        rotation_order: RotationOrder::AlphaThenBeta,
        reference_end: ReferenceEnd::OtherMember,
        min_lever_arm_mm: DEFAULT_MIN_LEVER_ARM_MM,
    }
}

/// Seed 000 Table 1 as printed: (α, β, Δα, Δβ) in degrees, (x2, y2, z2) mm, ΔV2 mm,
/// Δα′, Δβ′ degrees.
/// One Table 1 case: (α, β, Δα, Δβ), (x2, y2, z2), ΔV2, (Δα′, Δβ′).
type Case = ([f64; 4], [f64; 3], [f64; 3], [f64; 2]);

const TABLE1: [Case; 5] = [
    (
        [30.0, 0.0, 0.1, 0.0],
        [-50.0, 110.0, 283.494],
        [0.0, 0.378, 0.218],
        [0.1, 0.0],
    ),
    (
        [0.0, 40.0, 0.0, 0.08],
        [-210.697, -15.0, 308.489],
        [-0.267, 0.0, 0.225],
        [0.0, 0.07995],
    ),
    (
        [45.0, 60.0, 0.12, 0.1],
        [-266.506, 73.388, 411.612],
        [-0.218, -0.083, 0.452],
        [0.12, 0.09985],
    ),
    (
        [60.0, 50.0, 0.15, 0.09],
        [-241.511, 124.168, 419.652],
        [-0.252, -0.051, 0.514],
        [0.15, 0.08992],
    ),
    (
        [30.0, 60.0, 0.1, 0.1],
        [-266.506, 47.5, 391.747],
        [-0.218, -0.001, 0.436],
        [0.1, 0.09985],
    ),
];
const T1_PIVOT: [f64; 3] = [-50.0, -15.0, 500.0];

/// Table 1: the 3 nominal coordinates, 3 errors and 2 identified angles of each of the 5
/// cases, at the printed decimals. ΔV2 comes from the independent HTM model (tool along −z,
/// spec B.7), the nominal tip and the angles from the core (paper mode).
#[test]
fn table1_all_40_numbers_paper_mode() {
    let cfg = rrttt_cfg(-250.0);
    let mut checked = 0;
    for (ang, xyz2, dv2_mm, out) in TABLE1 {
        let [a, b, da, db] = ang;
        let nom = two_step::rrttt_nominal_tip_mm(&cfg, T1_PIVOT, a, b);
        for k in 0..3 {
            close(round(nom[k], 3), xyz2[k], 1e-9, "Table 1 nominal x2/y2/z2");
            checked += 1;
        }
        let act = fwd::rrttt_tip(T1_PIVOT, [0.0; 3], (a + da) * D2R, (b + db) * D2R, -250.0);
        let nom_f = fwd::rrttt_tip(T1_PIVOT, [0.0; 3], a * D2R, b * D2R, -250.0);
        let dv2 = fwd::diff_um(act, nom_f);
        for k in 0..3 {
            close(nom_f[k], nom[k], 1e-12, "core nominal vs HTM nominal");
            close(round(dv2[k] / 1e3, 3), dv2_mm[k], 1e-9, "Table 1 ΔV2");
            checked += 1;
        }
        let m = RrtttMeasurement {
            pivot_mm: T1_PIVOT,
            alpha_deg: a,
            beta_deg: b,
            dv1_um: [0.0; 3],
            dv2_um: dv2,
            dv_std_um: [0.0, 0.0],
        };
        let r = two_step::identify_rrttt(&cfg, &m, Mode::Paper).unwrap();
        close(
            round(r.delta_alpha_urad / URAD_PER_DEG, 5),
            out[0],
            1e-12,
            "Table 1 Δα′",
        );
        close(
            round(r.delta_beta_urad / URAD_PER_DEG, 5),
            out[1],
            1e-12,
            "Table 1 Δβ′",
        );
        checked += 2;
        // exact mode recovers the injected angles, not the truncated ones
        let e = two_step::identify_rrttt(&cfg, &m, Mode::Exact).unwrap();
        close(e.delta_alpha_urad / URAD_PER_DEG, da, 1e-9, "exact Δα");
        close(e.delta_beta_urad / URAD_PER_DEG, db, 1e-9, "exact Δβ");
        assert!(
            e.residual_um.iter().all(|v| v.abs() < 1e-6),
            "{:?}",
            e.residual_um
        );
    }
    assert_eq!(checked, 40);
}

/// Spec C.2 full-precision values (paper mode Δβ′ by eq 6 with signed z_r = −250; eq 7 Δα′).
#[test]
fn table1_full_precision_vectors() {
    let cfg = rrttt_cfg(-250.0);
    let cases: [Case; 5] = [
        (
            [30.0, 0.0, 0.1, 0.0],
            [-50.0, 110.0, 283.493649],
            [0.0, 0.3776843, 0.2184958],
            [0.1, 0.0],
        ),
        (
            [0.0, 40.0, 0.0, 0.08],
            [-210.696902, -15.0, 308.488889],
            [-0.2672432, 0.0, 0.2245618],
            [0.0, 0.0799531],
        ),
        (
            [45.0, 60.0, 0.12, 0.1],
            [-266.506351, 73.388348, 411.611652],
            [-0.2178363, -0.0829656, 0.4520857],
            [0.12, 0.0998488],
        ),
        (
            [60.0, 50.0, 0.15, 0.09],
            [-241.511111, 124.1676, 419.651549],
            [-0.2521857, -0.0512122, 0.5144434],
            [0.15, 0.0899157],
        ),
        (
            [30.0, 60.0, 0.1, 0.1],
            [-266.506351, 47.5, 391.746825],
            [-0.2178363, -0.0007615, 0.4363314],
            [0.1, 0.0998488],
        ),
    ];
    for (ang, nom_p, dv2_mm, out) in cases {
        let [a, b, _, _] = ang;
        let nom = two_step::rrttt_nominal_tip_mm(&cfg, T1_PIVOT, a, b);
        for k in 0..3 {
            close(nom[k], nom_p[k], 6e-7, "C.2 nominal");
        }
        let dv2 = [dv2_mm[0] * 1e3, dv2_mm[1] * 1e3, dv2_mm[2] * 1e3];
        let m = RrtttMeasurement {
            pivot_mm: T1_PIVOT,
            alpha_deg: a,
            beta_deg: b,
            dv1_um: [0.0; 3],
            dv2_um: dv2,
            dv_std_um: [0.0, 0.0],
        };
        let r = two_step::identify_rrttt(&cfg, &m, Mode::Paper).unwrap();
        let e = two_step::identify_rrttt(&cfg, &m, Mode::Exact).unwrap();
        // inputs printed to 0.1 nm: 1e-7 mm / 250 mm = 2.3e-8 deg. The C.2 "eq 7" column is
        // atan(eq 7) (= exact Δα): eq 7 as printed is tan Δα, 1.0e-7° higher at 0.1° (Δα³/3),
        // which is what TV-RRTTT-6 quotes (0.050000013°).
        close(
            e.delta_alpha_urad / URAD_PER_DEG,
            out[0],
            1e-7,
            "C.2 Δα′ atan(eq 7)",
        );
        let tan_da = (out[0] * D2R).tan() / D2R;
        close(
            r.delta_alpha_urad / URAD_PER_DEG,
            tan_da,
            1e-7,
            "C.2 Δα′ eq 7 = tan Δα",
        );
        close(
            r.delta_beta_urad / URAD_PER_DEG,
            out[1],
            1e-7,
            "C.2 Δβ′ eq 6",
        );
    }
}

/// Spec B.7 item 6: the printed (rounded) Table 1 values fed back into eqs 6/7 as the paper's
/// raw formulas (p2 taken from the table too).
#[test]
fn table1_rounded_input_regression() {
    let exp_db = [0.00000, 0.07991, 0.09976, 0.08981, 0.09976];
    let exp_da = [0.10005, 0.00000, 0.11996, 0.15011, 0.09987];
    for (i, (ang, xyz2, dv2_mm, _)) in TABLE1.iter().enumerate() {
        let dv2 = [dv2_mm[0] * 1e3, dv2_mm[1] * 1e3, dv2_mm[2] * 1e3];
        let db = two_step::paper::eq6_delta_beta_rad(
            T1_PIVOT[0],
            xyz2[0],
            0.0,
            dv2[0],
            -250.0,
            ang[1] * D2R,
            1.0,
        )
        .unwrap();
        let da =
            two_step::paper::eq7_delta_alpha_rad(T1_PIVOT, *xyz2, [0.0; 3], dv2, ang[0] * D2R, 1.0)
                .unwrap();
        close(db / D2R, exp_db[i], 1e-5, "rounded-input Δβ′");
        close(da / D2R, exp_da[i], 1e-5, "rounded-input Δα′");
    }
}

/// Spec C.2: the same five cases with the paper's literal +z_r = +250 (eq 4): nominal tips,
/// ΔV2 = −(table's), and the same Δα′/Δβ′ from eqs 6/7.
#[test]
fn table1_plus_zr_convention() {
    let cfg = rrttt_cfg(250.0);
    let tips = [
        [-50.0, -140.0, 716.506],
        [110.697, -15.0, 691.511],
        [166.506, -103.388, 588.388],
        [141.511, -154.168, 580.348],
        [166.506, -77.5, 608.253],
    ];
    for ((ang, _, _, out), tip) in TABLE1.iter().zip(tips) {
        let [a, b, da, db] = *ang;
        let nom = two_step::rrttt_nominal_tip_mm(&cfg, T1_PIVOT, a, b);
        for k in 0..3 {
            close(nom[k], tip[k], 5e-4, "+z_r nominal tip");
        }
        let dv2 = fwd::diff_um(
            fwd::rrttt_tip(T1_PIVOT, [0.0; 3], (a + da) * D2R, (b + db) * D2R, 250.0),
            fwd::rrttt_tip(T1_PIVOT, [0.0; 3], a * D2R, b * D2R, 250.0),
        );
        let m = RrtttMeasurement {
            pivot_mm: T1_PIVOT,
            alpha_deg: a,
            beta_deg: b,
            dv1_um: [0.0; 3],
            dv2_um: dv2,
            dv_std_um: [0.0, 0.0],
        };
        let r = two_step::identify_rrttt(&cfg, &m, Mode::Paper).unwrap();
        close(
            round(r.delta_alpha_urad / URAD_PER_DEG, 5),
            out[0],
            1e-12,
            "+z_r Δα′",
        );
        close(
            round(r.delta_beta_urad / URAD_PER_DEG, 5),
            out[1],
            1e-12,
            "+z_r Δβ′",
        );
    }
}

/// TV-RRTTT-6 (+z_r convention, non-zero ΔV1).
#[test]
fn tv_rrttt_6() {
    let cfg = rrttt_cfg(200.0);
    let p1 = [100.0, -40.0, 300.0];
    let nom = two_step::rrttt_nominal_tip_mm(&cfg, p1, 25.0, -35.0);
    let exp = [-14.715287270, -109.237722612, 448.480775301];
    for k in 0..3 {
        close(nom[k], exp[k], 1e-9, "TV-RRTTT-6 nominal");
    }
    let dv1 = [12.0, -8.0, 20.0];
    let dv2_exp = [-0.073765673, -0.112106062, -0.094913192];
    let act = fwd::rrttt_tip(p1, [0.012, -0.008, 0.020], 25.05 * D2R, -35.03 * D2R, 200.0);
    let dv2 = fwd::diff_um(act, nom);
    for k in 0..3 {
        close(dv2[k] / 1e3, dv2_exp[k], 1e-9, "TV-RRTTT-6 ΔV2");
    }
    let m = RrtttMeasurement {
        pivot_mm: p1,
        alpha_deg: 25.0,
        beta_deg: -35.0,
        dv1_um: dv1,
        dv2_um: dv2,
        dv_std_um: [0.0, 0.0],
    };
    let p = two_step::identify_rrttt(&cfg, &m, Mode::Paper).unwrap();
    close(p.delta_alpha_urad / URAD_PER_DEG, 0.050000013, 1e-9, "eq 7");
    close(p.delta_beta_urad / URAD_PER_DEG, -0.029994499, 1e-9, "eq 6");
    let e = two_step::identify_rrttt(&cfg, &m, Mode::Exact).unwrap();
    close(e.delta_alpha_urad / URAD_PER_DEG, 0.05, 1e-7, "exact Δα");
    close(e.delta_beta_urad / URAD_PER_DEG, -0.03, 1e-7, "exact Δβ");
    // the paper-mode residual shows the truncation, the exact one does not
    let norm = |r: [f64; 3]| r.iter().map(|v| v * v).sum::<f64>().sqrt();
    assert!(norm(e.residual_um) < 1e-6);
    assert!(norm(p.residual_um) > norm(e.residual_um));
}

fn tttrr_cfg() -> TttrrConfig {
    TttrrConfig {
        z_alpha_gamma_mm: 40.0,
        reference_point_mm: [60.0, 80.0, 30.0],
        reference_end: ReferenceEnd::OtherMember,
        min_lever_arm_mm: DEFAULT_MIN_LEVER_ARM_MM,
    }
}

/// TV-TTTRR-1: corrected eqs 11/12, the printed (wrong) forms evaluated here literally, and the
/// exact inversion.
#[test]
fn tv_tttrr_1() {
    let cfg = tttrr_cfg();
    let p1 = [100.0, 50.0, 200.0];
    let (a, g) = (20.0, 35.0);
    let nom = two_step::tttrr_nominal_point_mm(&cfg, p1, a, g);
    let exp = [103.263007749, 119.977813155, 299.962285121];
    for k in 0..3 {
        close(nom[k], exp[k], 1e-9, "TV-TTTRR-1 nominal");
    }
    let dv1_mm = [0.010, -0.005, 0.008];
    let act = fwd::tttrr_point(
        p1,
        dv1_mm,
        20.05 * D2R,
        35.08 * D2R,
        40.0,
        [60.0, 80.0, 30.0],
    );
    let dv2 = fwd::diff_um(act, nom);
    let dv2_exp = [-0.129555124, -0.088071812, 0.070557675];
    for k in 0..3 {
        close(dv2[k] / 1e3, dv2_exp[k], 1e-9, "TV-TTTRR-1 ΔV2");
    }
    let m = TttrrMeasurement {
        origin_mm: p1,
        alpha_deg: a,
        gamma_deg: g,
        dv1_um: [10.0, -5.0, 8.0],
        dv2_um: dv2,
        dv_std_um: [0.0, 0.0],
    };
    let p = two_step::identify_tttrr(&cfg, &m, Mode::Paper).unwrap();
    close(
        p.delta_gamma_urad / URAD_PER_DEG,
        0.080001797,
        1e-9,
        "corrected eq 11",
    );
    close(
        p.delta_alpha_urad / URAD_PER_DEG,
        0.050067779,
        1e-9,
        "corrected eq 12",
    );
    let e = two_step::identify_tttrr(&cfg, &m, Mode::Exact).unwrap();
    close(e.delta_gamma_urad / URAD_PER_DEG, 0.08, 1e-9, "exact Δγ");
    close(e.delta_alpha_urad / URAD_PER_DEG, 0.05, 1e-9, "exact Δα");

    // The printed formulas, literally, give the spec's wrong numbers (why they are corrected).
    let (xr, yr, zr, zag) = (60.0, 80.0, 30.0, 40.0);
    let (ar, gr) = (a * D2R, g * D2R);
    let (x1, y1) = (p1[0], p1[1]);
    let (x2, y2) = (nom[0], nom[1]);
    let (dx1, dy1, dx2, dy2) = (0.010, -0.005, dv2[0] / 1e3, dv2[1] / 1e3);
    let printed11 =
        (x1 + x2 + dx1 - dx2 + xr * gr.cos() - yr * gr.sin()) / (yr * gr.cos() + xr * gr.sin());
    close(printed11 / D2R, 118.474, 5e-4, "printed eq 11");
    let k = xr * xr + yr * yr + (x1 - x2 + dx2) * (xr * gr.cos() - yr * gr.sin());
    let q = yr * gr.cos() + xr * gr.sin();
    let printed12 = ((y1 - y2 + dy1 - dy2 - (zr + zag) * ar.sin()) * q + ar.cos() * k)
        / ((zr + zag) * ar.cos() * q + ar.sin() * k);
    close(printed12 / D2R, 0.045337138, 1e-9, "printed eq 12");
}

/// TV-T2-nominal: Table 2 nominal coordinates as Rx(α)·Rz(γ)·p (z_αγ = 0, origin 0).
#[test]
fn tv_t2_nominal() {
    let p = [-49.275, -14.312, -177.777];
    let cfg = TttrrConfig {
        z_alpha_gamma_mm: 0.0,
        reference_point_mm: p,
        ..tttrr_cfg()
    };
    let cases = [
        ((0.0, 30.0), [-35.517, -37.032, -177.777]),
        ((15.0, 0.0), [-49.275, 32.188, -175.424]),
        ((10.0, 30.0), [-35.517, -5.599, -181.507]),
        ((10.0, 45.0), [-24.723, -13.409, -182.884]),
    ];
    for ((a, g), exp) in cases {
        let n = two_step::tttrr_nominal_point_mm(&cfg, [0.0; 3], a, g);
        for k in 0..3 {
            close(n[k], exp[k], 5e-4, "TV-T2-nominal");
        }
    }
}

/// TV-RTTTR-B (spindle β, eq 17) and TV-RTTTR-A (table α, eq 18).
#[test]
fn tv_rtttr_a_b() {
    let scfg = RtttrSpindleConfig {
        tool_z_mm: 180.0,
        reference_end: ReferenceEnd::OtherMember,
        min_lever_arm_mm: 1.0,
    };
    let p1 = [20.0, 10.0, 350.0];
    let nom = two_step::rtttr_spindle_nominal_tip_mm(&scfg, p1, 30.0);
    let exp = [110.0, 10.0, 505.884572681];
    for k in 0..3 {
        close(nom[k], exp[k], 1e-9, "TV-RTTTR-B nominal");
    }
    let dv2 = fwd::diff_um(
        fwd::rtttr_tip(p1, [0.004, 0.002, -0.006], 30.06 * D2R, 180.0),
        nom,
    );
    let exp = [0.167192565, 0.002, -0.100333236];
    for k in 0..3 {
        close(dv2[k] / 1e3, exp[k], 1e-9, "TV-RTTTR-B ΔV2");
    }
    let m = SingleAxisMeasurement {
        origin_mm: p1,
        angle_deg: 30.0,
        dv1_um: [4.0, 2.0, -6.0],
        dv2_um: dv2,
        dv_std_um: [0.0, 0.0],
    };
    let p = two_step::identify_rtttr_spindle(&scfg, &m, Mode::Paper).unwrap();
    close(p.delta_urad / URAD_PER_DEG, 0.059981851, 1e-9, "eq 17");
    let e = two_step::identify_rtttr_spindle(&scfg, &m, Mode::Exact).unwrap();
    close(e.delta_urad / URAD_PER_DEG, 0.06, 1e-9, "exact Δβ");

    let tcfg = RtttrTableConfig {
        reference_point_mm: [25.0, 70.0, 45.0],
        reference_end: ReferenceEnd::OtherMember,
        min_lever_arm_mm: 1.0,
    };
    let pt1 = [-30.0, 15.0, 120.0];
    let nom = two_step::rtttr_table_nominal_point_mm(&tcfg, pt1, 40.0);
    let exp = [-5.0, 39.697668582, 199.467132618];
    for k in 0..3 {
        close(nom[k], exp[k], 1e-9, "TV-RTTTR-A nominal");
    }
    let dv2 = fwd::diff_um(
        fwd::rtttr_table_point(pt1, [0.003, -0.009, 0.005], 39.93 * D2R, [25.0, 70.0, 45.0]),
        nom,
    );
    let exp = [0.003, 0.088068961, -0.025233194];
    for k in 0..3 {
        close(dv2[k] / 1e3, exp[k], 1e-9, "TV-RTTTR-A ΔtV2");
    }
    let m = SingleAxisMeasurement {
        origin_mm: pt1,
        angle_deg: 40.0,
        dv1_um: [3.0, -9.0, 5.0],
        dv2_um: dv2,
        dv_std_um: [0.0, 0.0],
    };
    let p = two_step::identify_rtttr_table(&tcfg, &m, Mode::Paper).unwrap();
    close(p.delta_urad / URAD_PER_DEG, -0.069986693, 1e-9, "eq 18");
    let e = two_step::identify_rtttr_table(&tcfg, &m, Mode::Exact).unwrap();
    close(e.delta_urad / URAD_PER_DEG, -0.07, 1e-9, "exact Δα");
}

/// The socket on the rotated member flips the SSM vectors' sign.
#[test]
fn reference_end_flips_sign() {
    let mut cfg = rrttt_cfg(200.0);
    let p1 = [100.0, -40.0, 300.0];
    let nom = two_step::rrttt_nominal_tip_mm(&cfg, p1, 25.0, -35.0);
    let dv2 = fwd::diff_um(
        fwd::rrttt_tip(p1, [0.0; 3], 25.05 * D2R, -35.03 * D2R, 200.0),
        nom,
    );
    cfg.reference_end = ReferenceEnd::RotatedMember;
    let m = RrtttMeasurement {
        pivot_mm: p1,
        alpha_deg: 25.0,
        beta_deg: -35.0,
        dv1_um: [0.0; 3],
        dv2_um: dv2.map(|v| -v),
        dv_std_um: [0.0, 0.0],
    };
    let e = two_step::identify_rrttt(&cfg, &m, Mode::Exact).unwrap();
    close(e.delta_alpha_urad / URAD_PER_DEG, 0.05, 1e-9, "flipped Δα");
    close(e.delta_beta_urad / URAD_PER_DEG, -0.03, 1e-9, "flipped Δβ");
}

/// Singularities (spec part D 9) and bad input return typed errors.
#[test]
fn singularities_and_bad_input() {
    let cfg = rrttt_cfg(-250.0);
    let m = RrtttMeasurement {
        pivot_mm: T1_PIVOT,
        alpha_deg: 10.0,
        beta_deg: 90.0,
        dv1_um: [0.0; 3],
        dv2_um: [1.0, 2.0, 3.0],
        dv_std_um: [0.0, 0.0],
    };
    for mode in [Mode::Exact, Mode::Paper] {
        assert_eq!(
            two_step::identify_rrttt(&cfg, &m, mode),
            Err(TwoStepError::Singular(Singularity::ToolAlongFirstAxis))
        );
    }
    let bad = RrtttMeasurement {
        beta_deg: f64::NAN,
        ..m
    };
    assert_eq!(
        two_step::identify_rrttt(&cfg, &bad, Mode::Exact),
        Err(TwoStepError::NonFinite)
    );
    assert_eq!(
        two_step::identify_rrttt(
            &rrttt_cfg(0.0),
            &RrtttMeasurement { beta_deg: 0.0, ..m },
            Mode::Exact
        ),
        Err(TwoStepError::ZeroLength)
    );
    let neg = RrtttConfig {
        min_lever_arm_mm: -1.0,
        ..cfg
    };
    assert_eq!(
        two_step::identify_rrttt(&neg, &m, Mode::Exact),
        Err(TwoStepError::BadMinLeverArm)
    );
    let ba = RrtttConfig {
        rotation_order: RotationOrder::BetaThenAlpha,
        ..cfg
    };
    assert_eq!(
        two_step::identify_rrttt(
            &ba,
            &RrtttMeasurement {
                beta_deg: 10.0,
                ..m
            },
            Mode::Paper
        ),
        Err(TwoStepError::PaperModeUnsupported)
    );
    // β-then-α head: singular when α = 90°
    assert_eq!(
        two_step::identify_rrttt(
            &ba,
            &RrtttMeasurement {
                alpha_deg: 90.0,
                beta_deg: 10.0,
                ..m
            },
            Mode::Exact
        ),
        Err(TwoStepError::Singular(Singularity::ToolAlongFirstAxis))
    );

    // TTTRR: x_r sin γ + y_r cos γ = 0 at γ = atan2(−y_r, x_r)
    let tc = tttrr_cfg();
    let g0 = (-80.0f64).atan2(60.0) / D2R;
    let tm = TttrrMeasurement {
        origin_mm: [0.0; 3],
        alpha_deg: 20.0,
        gamma_deg: g0,
        dv1_um: [0.0; 3],
        dv2_um: [0.0; 3],
        dv_std_um: [0.0, 0.0],
    };
    for mode in [Mode::Exact, Mode::Paper] {
        assert_eq!(
            two_step::identify_tttrr(&tc, &tm, mode),
            Err(TwoStepError::Singular(Singularity::GammaLever))
        );
    }
    // TTTRR paper eq 12: H cos α + Q sin α = 0 (point level with the A axis); exact still works
    let (h, q) = (
        70.0f64,
        60.0 * 35f64.to_radians().sin() + 80.0 * 35f64.to_radians().cos(),
    );
    let a0 = (-h).atan2(q) / D2R;
    let tm = TttrrMeasurement {
        alpha_deg: a0,
        gamma_deg: 35.0,
        ..tm
    };
    assert_eq!(
        two_step::identify_tttrr(&tc, &tm, Mode::Paper),
        Err(TwoStepError::Singular(Singularity::AlphaLever))
    );
    assert!(two_step::identify_tttrr(&tc, &tm, Mode::Exact).is_ok());
    // inconsistent x row
    let tm2 = TttrrMeasurement {
        gamma_deg: 35.0,
        alpha_deg: 20.0,
        dv2_um: [1e6, 0.0, 0.0],
        ..tm
    };
    assert!(matches!(
        two_step::identify_tttrr(&tc, &tm2, Mode::Exact),
        Err(TwoStepError::Inconsistent { .. })
    ));
    // data that rotate the point onto the γ lever singularity (v_x = ρ): refused, not a huge σ
    let nom = two_step::tttrr_nominal_point_mm(&tc, [0.0; 3], 20.0, 35.0);
    let to_singular = TttrrMeasurement {
        dv2_um: [(100.0 - nom[0]) * 1e3, 0.0, 0.0],
        ..tm2
    };
    assert_eq!(
        two_step::identify_tttrr(&tc, &to_singular, Mode::Exact),
        Err(TwoStepError::Singular(Singularity::GammaLever))
    );
    let zero = TttrrConfig {
        reference_point_mm: [0.0, 0.0, 30.0],
        ..tc
    };
    assert_eq!(
        two_step::identify_tttrr(&zero, &tm2, Mode::Exact),
        Err(TwoStepError::ZeroLength)
    );

    // RTTTR spindle: eq 17 singular at β = 90°, exact not
    let sc = RtttrSpindleConfig {
        tool_z_mm: 180.0,
        reference_end: ReferenceEnd::OtherMember,
        min_lever_arm_mm: 1.0,
    };
    let sm = SingleAxisMeasurement {
        origin_mm: [0.0; 3],
        angle_deg: 90.0,
        dv1_um: [0.0; 3],
        dv2_um: [0.0, 0.0, -10.0],
        dv_std_um: [0.0, 0.0],
    };
    assert_eq!(
        two_step::identify_rtttr_spindle(&sc, &sm, Mode::Paper),
        Err(TwoStepError::Singular(Singularity::SpindleBetaLever))
    );
    let e = two_step::identify_rtttr_spindle(&sc, &sm, Mode::Exact).unwrap();
    close(e.delta_urad, 0.01 / 180.0 * 1e6, 1e-3, "β = 90° exact");
    // RTTTR table: z_tr cos α + y_tr sin α = 0
    let tcfg = RtttrTableConfig {
        reference_point_mm: [25.0, 70.0, 45.0],
        reference_end: ReferenceEnd::OtherMember,
        min_lever_arm_mm: 1.0,
    };
    let a0 = (-45.0f64).atan2(70.0) / D2R;
    let tm = SingleAxisMeasurement {
        angle_deg: a0,
        dv2_um: [0.0; 3],
        ..sm
    };
    assert_eq!(
        two_step::identify_rtttr_table(&tcfg, &tm, Mode::Paper),
        Err(TwoStepError::Singular(Singularity::TableAlphaLever))
    );
    let on_axis = RtttrTableConfig {
        reference_point_mm: [25.0, 0.0, 0.0],
        ..tcfg
    };
    assert_eq!(
        two_step::identify_rtttr_table(&on_axis, &tm, Mode::Exact),
        Err(TwoStepError::Singular(Singularity::TableAlphaLever))
    );
}

/// Round trip: random geometry, angles and errors → HTM forward model → exact inversion
/// recovers the injected angles (to 1e-12 rad); paper mode within its second-order bound.
#[test]
fn round_trip_random() {
    let mut rng = fwd::Rng(0x5eed_0000_0000_0001);
    for _ in 0..500 {
        let e1 = [
            rng.uniform(-0.05, 0.05),
            rng.uniform(-0.05, 0.05),
            rng.uniform(-0.05, 0.05),
        ];
        let p1 = [
            rng.uniform(-300.0, 300.0),
            rng.uniform(-300.0, 300.0),
            rng.uniform(0.0, 600.0),
        ];
        let (d1, d2) = (rng.uniform(-2e-3, 2e-3), rng.uniform(-2e-3, 2e-3));
        let dmax = d1.abs().max(d2.abs());
        let e1_um = e1.map(|v| v * 1e3);

        // RRTTT
        let z = if rng.uniform(0.0, 1.0) < 0.5 {
            -rng.uniform(50.0, 400.0)
        } else {
            rng.uniform(50.0, 400.0)
        };
        let (a, b) = (rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2));
        let cfg = rrttt_cfg(z);
        let nom = fwd::rrttt_tip(p1, [0.0; 3], a, b, z);
        let act = fwd::rrttt_tip(p1, e1, a + d1, b + d2, z);
        let m = RrtttMeasurement {
            pivot_mm: p1,
            alpha_deg: a / D2R,
            beta_deg: b / D2R,
            dv1_um: e1_um,
            dv2_um: fwd::diff_um(act, nom),
            dv_std_um: [0.0, 0.0],
        };
        let r = two_step::identify_rrttt(&cfg, &m, Mode::Exact).unwrap();
        close(r.delta_alpha_urad * 1e-6, d1, 1e-12, "RRTTT exact Δα");
        close(r.delta_beta_urad * 1e-6, d2, 1e-12, "RRTTT exact Δβ");
        let p = two_step::identify_rrttt(&cfg, &m, Mode::Paper).unwrap();
        // eq 6: Δβ − tan β Δβ²/2 + O(Δβ³); eq 7: tan Δα
        let bound = (0.5 * b.tan().abs() + 1.0) * dmax * dmax + 1e-12;
        close(p.delta_beta_urad * 1e-6, d2, bound, "RRTTT eq 6");
        close(p.delta_alpha_urad * 1e-6, d1, bound, "RRTTT eq 7");

        // TTTRR
        let r_pt = [
            rng.uniform(-150.0, 150.0),
            rng.uniform(-150.0, 150.0),
            rng.uniform(-50.0, 150.0),
        ];
        let zag = rng.uniform(0.0, 100.0);
        let (a, g) = (rng.uniform(-1.5, 1.5), rng.uniform(-3.1, 3.1));
        let q0 = r_pt[0] * g.sin() + r_pt[1] * g.cos();
        let c0 = r_pt[0] * g.cos() - r_pt[1] * g.sin();
        let h = r_pt[2] + zag;
        let den = h * a.cos() + q0 * a.sin();
        if q0.abs() < 20.0 || den.abs() < 20.0 {
            continue;
        }
        let tc = TttrrConfig {
            z_alpha_gamma_mm: zag,
            reference_point_mm: r_pt,
            ..tttrr_cfg()
        };
        let nom = fwd::tttrr_point(p1, [0.0; 3], a, g, zag, r_pt);
        let act = fwd::tttrr_point(p1, e1, a + d1, g + d2, zag, r_pt);
        let m = TttrrMeasurement {
            origin_mm: p1,
            alpha_deg: a / D2R,
            gamma_deg: g / D2R,
            dv1_um: e1_um,
            dv2_um: fwd::diff_um(act, nom),
            dv_std_um: [0.0, 0.0],
        };
        let r = two_step::identify_tttrr(&tc, &m, Mode::Exact).unwrap();
        close(r.delta_alpha_urad * 1e-6, d1, 1e-11, "TTTRR exact Δα");
        close(r.delta_gamma_urad * 1e-6, d2, 1e-11, "TTTRR exact Δγ");
        let p = two_step::identify_tttrr(&tc, &m, Mode::Paper).unwrap();
        // eq 11: sin Δγ + (C/Q0) Δγ²/2; eq 12: second order in (Δα, Δγ) with levers / den
        let k11 = 0.5 * (c0 / q0).abs() + 1.0;
        close(
            p.delta_gamma_urad * 1e-6,
            d2,
            k11 * dmax * dmax,
            "TTTRR eq 11",
        );
        let lever = h.hypot(q0) + c0.abs();
        let k12 = 2.0 * (1.0 + lever / den.abs()) * (1.0 + k11);
        close(
            p.delta_alpha_urad * 1e-6,
            d1,
            k12 * dmax * dmax,
            "TTTRR eq 12",
        );

        // RTTTR spindle and table
        let b = rng.uniform(-1.2, 1.2);
        let sc = RtttrSpindleConfig {
            tool_z_mm: z,
            reference_end: ReferenceEnd::OtherMember,
            min_lever_arm_mm: 1.0,
        };
        let nom = fwd::rtttr_tip(p1, [0.0; 3], b, z);
        let act = fwd::rtttr_tip(p1, e1, b + d2, z);
        let m = SingleAxisMeasurement {
            origin_mm: p1,
            angle_deg: b / D2R,
            dv1_um: e1_um,
            dv2_um: fwd::diff_um(act, nom),
            dv_std_um: [0.0, 0.0],
        };
        close(
            two_step::identify_rtttr_spindle(&sc, &m, Mode::Exact)
                .unwrap()
                .delta_urad
                * 1e-6,
            d2,
            1e-12,
            "RTTTR exact Δβ",
        );
        let bound = (0.5 * b.tan().abs() + 1.0) * d2 * d2 + 1e-12;
        close(
            two_step::identify_rtttr_spindle(&sc, &m, Mode::Paper)
                .unwrap()
                .delta_urad
                * 1e-6,
            d2,
            bound,
            "RTTTR eq 17",
        );
        let tr = [
            rng.uniform(-100.0, 100.0),
            rng.uniform(-100.0, 100.0),
            rng.uniform(-100.0, 100.0),
        ];
        let den = tr[2] * a.cos() + tr[1] * a.sin();
        if den.abs() < 20.0 {
            continue;
        }
        let tcfg = RtttrTableConfig {
            reference_point_mm: tr,
            reference_end: ReferenceEnd::OtherMember,
            min_lever_arm_mm: 1.0,
        };
        let nom = fwd::rtttr_table_point(p1, [0.0; 3], a, tr);
        let act = fwd::rtttr_table_point(p1, e1, a + d1, tr);
        let m = SingleAxisMeasurement {
            origin_mm: p1,
            angle_deg: a / D2R,
            dv1_um: e1_um,
            dv2_um: fwd::diff_um(act, nom),
            dv_std_um: [0.0, 0.0],
        };
        close(
            two_step::identify_rtttr_table(&tcfg, &m, Mode::Exact)
                .unwrap()
                .delta_urad
                * 1e-6,
            d1,
            1e-12,
            "RTTTR exact Δα",
        );
        let bound = (0.5 * tr[1].hypot(tr[2]) / den.abs() + 1.0) * d1 * d1 + 1e-12;
        close(
            two_step::identify_rtttr_table(&tcfg, &m, Mode::Paper)
                .unwrap()
                .delta_urad
                * 1e-6,
            d1,
            bound,
            "RTTTR eq 18",
        );
    }
}

/// Gaussian-like noise of standard deviation `sd` (sum of 12 uniforms).
fn noise(rng: &mut fwd::Rng, sd: f64) -> f64 {
    (0..12).map(|_| rng.uniform(0.0, 1.0)).sum::<f64>() * sd - 6.0 * sd
}

/// The propagated standard uncertainties agree with a Monte-Carlo spread of the identified
/// angles under independent SSM noise of σ = 1 µm per component (within 10 %).
#[test]
fn propagated_uncertainty_matches_monte_carlo() {
    let mut rng = fwd::Rng(0xabcdef);
    let sigma = 1.0;
    let trials = 4000;
    let spread = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
    };
    let noisy = |rng: &mut fwd::Rng, v: [f64; 3]| v.map(|x| x + noise(rng, sigma));

    // RRTTT
    let cfg = rrttt_cfg(-250.0);
    let p1 = [10.0, 20.0, 400.0];
    let nom = two_step::rrttt_nominal_tip_mm(&cfg, p1, 30.0, 50.0);
    let dv2 = fwd::diff_um(
        fwd::rrttt_tip(p1, [0.0; 3], 30.1 * D2R, 50.05 * D2R, -250.0),
        nom,
    );
    let (mut da, mut db, mut reported) = (vec![], vec![], [0.0; 2]);
    for _ in 0..trials {
        let m = RrtttMeasurement {
            pivot_mm: p1,
            alpha_deg: 30.0,
            beta_deg: 50.0,
            dv1_um: noisy(&mut rng, [0.0; 3]),
            dv2_um: noisy(&mut rng, dv2),
            dv_std_um: [sigma, sigma],
        };
        let r = two_step::identify_rrttt(&cfg, &m, Mode::Exact).unwrap();
        da.push(r.delta_alpha_urad);
        db.push(r.delta_beta_urad);
        reported = r.std_uncertainty_urad;
    }
    close(spread(&da) / reported[0], 1.0, 0.1, "RRTTT σ(Δα)");
    close(spread(&db) / reported[1], 1.0, 0.1, "RRTTT σ(Δβ)");

    // TTTRR
    let tc = tttrr_cfg();
    let p1 = [100.0, 50.0, 200.0];
    let nom = two_step::tttrr_nominal_point_mm(&tc, p1, 20.0, 35.0);
    let dv2 = fwd::diff_um(
        fwd::tttrr_point(
            p1,
            [0.0; 3],
            20.05 * D2R,
            35.08 * D2R,
            40.0,
            [60.0, 80.0, 30.0],
        ),
        nom,
    );
    let (mut da, mut dg) = (vec![], vec![]);
    for _ in 0..trials {
        let m = TttrrMeasurement {
            origin_mm: p1,
            alpha_deg: 20.0,
            gamma_deg: 35.0,
            dv1_um: noisy(&mut rng, [0.0; 3]),
            dv2_um: noisy(&mut rng, dv2),
            dv_std_um: [sigma, sigma],
        };
        let r = two_step::identify_tttrr(&tc, &m, Mode::Exact).unwrap();
        da.push(r.delta_alpha_urad);
        dg.push(r.delta_gamma_urad);
        reported = r.std_uncertainty_urad;
    }
    close(spread(&da) / reported[0], 1.0, 0.1, "TTTRR σ(Δα)");
    close(spread(&dg) / reported[1], 1.0, 0.1, "TTTRR σ(Δγ)");

    // RTTTR table
    let tcfg = RtttrTableConfig {
        reference_point_mm: [25.0, 70.0, 45.0],
        reference_end: ReferenceEnd::OtherMember,
        min_lever_arm_mm: 1.0,
    };
    let (mut d, mut rep) = (vec![], 0.0);
    for _ in 0..trials {
        let m = SingleAxisMeasurement {
            origin_mm: [0.0; 3],
            angle_deg: 40.0,
            dv1_um: noisy(&mut rng, [0.0; 3]),
            dv2_um: noisy(&mut rng, [0.0; 3]),
            dv_std_um: [sigma, sigma],
        };
        let r = two_step::identify_rtttr_table(&tcfg, &m, Mode::Exact).unwrap();
        d.push(r.delta_urad);
        rep = r.std_uncertainty_urad;
    }
    close(spread(&d) / rep, 1.0, 0.1, "RTTTR σ(Δα)");
    // ΔV1 and ΔV2 with their own u (issue 14: one scalar for both before)
    let (mut d, mut rep) = (vec![], 0.0);
    for _ in 0..trials {
        let m = SingleAxisMeasurement {
            origin_mm: [0.0; 3],
            angle_deg: 40.0,
            dv1_um: [0.0; 3].map(|x: f64| x + noise(&mut rng, sigma)),
            dv2_um: [0.0; 3].map(|x: f64| x + noise(&mut rng, 3.0 * sigma)),
            dv_std_um: [sigma, 3.0 * sigma],
        };
        let r = two_step::identify_rtttr_table(&tcfg, &m, Mode::Exact).unwrap();
        d.push(r.delta_urad);
        rep = r.std_uncertainty_urad;
    }
    close(
        spread(&d) / rep,
        1.0,
        0.1,
        "RTTTR σ(Δα), ΔV2 three times as noisy",
    );
    let bad = SingleAxisMeasurement {
        origin_mm: [0.0; 3],
        angle_deg: 40.0,
        dv1_um: [0.0; 3],
        dv2_um: [0.0; 3],
        dv_std_um: [0.1, -1.0],
    };
    assert_eq!(
        two_step::identify_rtttr_table(&tcfg, &bad, Mode::Exact),
        Err(TwoStepError::NegativeUncertainty)
    );
}

/// β-then-α head (Ry·Rx, exact mode only): round trip through literal HTMs, and its
/// propagated uncertainties against a Monte-Carlo spread.
#[test]
fn beta_then_alpha_round_trip() {
    let tip = |p: [f64; 3], e: [f64; 3], a: f64, b: f64, z: f64| {
        let t = fwd::mul(
            &fwd::mul(
                &fwd::trans(p[0] + e[0], p[1] + e[1], p[2] + e[2]),
                &fwd::ry(b),
            ),
            &fwd::rx(a),
        );
        fwd::apply(&t, [0.0, 0.0, z])
    };
    let mut rng = fwd::Rng(99);
    for _ in 0..200 {
        let z = rng.uniform(100.0, 300.0)
            * if rng.uniform(0.0, 1.0) < 0.5 {
                -1.0
            } else {
                1.0
            };
        let cfg = RrtttConfig {
            rotation_order: RotationOrder::BetaThenAlpha,
            ..rrttt_cfg(z)
        };
        let p1 = [
            rng.uniform(-200.0, 200.0),
            rng.uniform(-200.0, 200.0),
            rng.uniform(0.0, 500.0),
        ];
        let (a, b) = (rng.uniform(-1.2, 1.2), rng.uniform(-3.0, 3.0));
        let (d1, d2) = (rng.uniform(-2e-3, 2e-3), rng.uniform(-2e-3, 2e-3));
        let e1 = [
            rng.uniform(-0.05, 0.05),
            rng.uniform(-0.05, 0.05),
            rng.uniform(-0.05, 0.05),
        ];
        let nom = two_step::rrttt_nominal_tip_mm(&cfg, p1, a / D2R, b / D2R);
        let n2 = tip(p1, [0.0; 3], a, b, z);
        for k in 0..3 {
            close(nom[k], n2[k], 1e-12, "Ry·Rx nominal");
        }
        let m = RrtttMeasurement {
            pivot_mm: p1,
            alpha_deg: a / D2R,
            beta_deg: b / D2R,
            dv1_um: e1.map(|v| v * 1e3),
            dv2_um: fwd::diff_um(tip(p1, e1, a + d1, b + d2, z), nom),
            dv_std_um: [0.0, 0.0],
        };
        let r = two_step::identify_rrttt(&cfg, &m, Mode::Exact).unwrap();
        close(r.delta_alpha_urad * 1e-6, d1, 1e-12, "Ry·Rx Δα");
        close(r.delta_beta_urad * 1e-6, d2, 1e-12, "Ry·Rx Δβ");
    }
    let cfg = RrtttConfig {
        rotation_order: RotationOrder::BetaThenAlpha,
        ..rrttt_cfg(-200.0)
    };
    let (mut da, mut db, mut rep) = (vec![], vec![], [0.0; 2]);
    for _ in 0..4000 {
        let m = RrtttMeasurement {
            pivot_mm: [0.0; 3],
            alpha_deg: 50.0,
            beta_deg: 20.0,
            dv1_um: [0.0; 3].map(|_| noise(&mut rng, 1.0)),
            dv2_um: [0.0; 3].map(|_| noise(&mut rng, 1.0)),
            dv_std_um: [1.0, 1.0],
        };
        let r = two_step::identify_rrttt(&cfg, &m, Mode::Exact).unwrap();
        da.push(r.delta_alpha_urad);
        db.push(r.delta_beta_urad);
        rep = r.std_uncertainty_urad;
    }
    let sd = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
    close(sd(&da) / rep[0], 1.0, 0.1, "Ry·Rx σ(Δα)");
    close(sd(&db) / rep[1], 1.0, 0.1, "Ry·Rx σ(Δβ)");
}
