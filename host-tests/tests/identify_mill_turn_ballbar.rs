//! Seed 002 ball-bar procedure, thesis mode (`identify::mill_turn::ballbar`): TV-1 to TV-4
//! (Tables 4.4, 4.5, 4.7 of the thesis, spec seed-002 §8.1), a round trip through the thesis
//! relations 4.1–4.9 written independently in `ballpod_host::forward_seed002`, uncertainty
//! propagation and bad input.
use ballpod::identify::mill_turn::ballbar::{
    BallBarError, ThesisEccentricities, ThesisGeometry, identify_thesis, run_statistics,
};
use ballpod_host::forward_seed002 as fwd;

/// Table 4.3 set-up.
const T43: ThesisGeometry = ThesisGeometry {
    r_b_mm: 356.3945,
    r_c_mm: 50.0,
    z_c_mm: 65.5348,
    z_t_mm: 112.2877,
    z_t2_mm: 62.2491,
    x_t_mm: 490.0,
};

/// Table 4.4 runs (µm) with the printed average and population σ.
const T44: [([f64; 3], f64, f64); 10] = [
    ([-51.4, -52.1, -51.6], -51.70, 0.29),
    ([-41.3, -42.0, -41.7], -41.67, 0.29),
    ([-9.4, -10.0, -9.8], -9.73, 0.25),
    ([-35.4, -36.7, -36.2], -36.10, 0.54),
    ([-47.9, -48.0, -48.1], -48.00, 0.08),
    ([25.4, 25.9, 26.0], 25.77, 0.26),
    ([-6.1, -6.1, -6.1], -6.10, 0.00),
    ([-0.3, -0.3, -0.2], -0.27, 0.05),
    ([-57.6, -57.8, -57.8], -57.73, 0.09),
    ([28.5, 28.4, 28.6], 28.50, 0.08),
];

fn ecc(v: [f64; 10]) -> ThesisEccentricities {
    ThesisEccentricities {
        ex_bx_um: v[0],
        ez_bx_um: v[1],
        ex_by_um: v[2],
        ez_by_um: v[3],
        ex_cr_um: v[4],
        ey_cr_um: v[5],
        ex_ca_um: v[6],
        ey_ca_um: v[7],
        ex_cr2_um: v[8],
        ey_cr2_um: v[9],
    }
}

/// Unrounded means of Table 4.4 (TV-2 note: only these reproduce α_CZ and α_BT).
fn t44_means() -> ThesisEccentricities {
    let mut m = [0.0; 10];
    for (i, (runs, _, _)) in T44.iter().enumerate() {
        m[i] = run_statistics(runs).unwrap().mean;
    }
    ecc(m)
}

#[test]
fn tv1_means_and_population_sigma() {
    for (runs, mean, sigma) in T44 {
        let s = run_statistics(&runs).unwrap();
        assert!((s.mean - mean).abs() <= 0.005 + 1e-12, "{runs:?}");
        assert!(
            (s.population_sigma - sigma).abs() <= 0.005 + 1e-12,
            "{runs:?}: {}",
            s.population_sigma
        );
        assert_eq!(s.runs, 3);
    }
    assert_eq!(run_statistics(&[]), Err(BallBarError::NoRuns));
    assert_eq!(
        run_statistics(&[1.0, f64::NAN]),
        Err(BallBarError::NonFinite)
    );
}

fn check(got: f64, printed: f64, derived: f64, what: &str) {
    assert!(
        (got - printed).abs() <= 0.005 + 1e-9,
        "{what}: {got} vs printed {printed}"
    );
    assert!(
        (got - derived).abs() <= 5e-5 + 1e-9,
        "{what}: {got} vs derived {derived}"
    );
}

/// TV-2: Table 4.5 (printed to 2 decimals; spec §5.7 gives the 4-decimal values).
#[test]
fn tv2_table_4_5() {
    let r = identify_thesis(&t44_means(), &T43, None).unwrap();
    let d = r.deviations;
    check(d.alpha_cz_arcsec, 1.10, 1.1001, "alpha_CZ");
    check(d.beta_cz_arcsec, -25.16, -25.1643, "beta_CZ");
    check(d.alpha_xb_arcsec, -20.89, -20.8930, "alpha_XB");
    check(d.beta_xb_arcsec, -24.11, -24.1148, "beta_XB");
    check(d.gamma_xb_arcsec, 5.63, 5.6332, "gamma_XB");
    check(d.alpha_bt_arcsec, 9.63, 9.6259, "alpha_BT");
    check(d.dx_cz_minus_dx_bt_um, 53.13, 53.1325, "dx_CZ - dx_BT");
    check(d.dy_cz_um, -45.63, -45.6320, "dy_CZ");
    assert!((r.dz_bt_setting_um + 51.70).abs() < 1e-9);
    // The 2-decimal averages do not reproduce α_CZ (spec: 1.1138").
    let mut rounded = [0.0; 10];
    for (i, (_, m, _)) in T44.iter().enumerate() {
        rounded[i] = *m;
    }
    let r2 = identify_thesis(&ecc(rounded), &T43, None).unwrap();
    assert!((r2.deviations.alpha_cz_arcsec - 1.1138).abs() < 5e-5);
    assert!((r2.deviations.alpha_bt_arcsec - 9.6397).abs() < 5e-5);
}

/// TV-3: Table 4.6 eccentricities after compensation → Table 4.7.
#[test]
fn tv3_table_4_7() {
    let e = ecc([-27.8, -3.8, -0.7, 0.4, -0.8, 2.7, 0.3, -0.2, -5.8, 0.5]);
    let d = identify_thesis(&e, &T43, None).unwrap().deviations;
    check(d.alpha_cz_arcsec, 0.83, 0.8251, "alpha_CZ");
    check(d.beta_cz_arcsec, 1.24, 1.2376, "beta_CZ");
    check(d.alpha_xb_arcsec, 0.23, 0.2315, "alpha_XB");
    check(d.beta_xb_arcsec, -2.20, -2.1993, "beta_XB");
    check(d.gamma_xb_arcsec, 0.41, 0.4051, "gamma_XB");
    check(d.alpha_bt_arcsec, 8.84, 8.8371, "alpha_BT");
    check(d.dx_cz_minus_dx_bt_um, 2.39, 2.3905, "dx_CZ - dx_BT");
    check(d.dy_cz_um, 1.01, 1.0123, "dy_CZ");
}

/// TV-4: ez_BY = −36.10 µm, R_B = 356.3945 mm → −1.01292e-4 rad = −20.893".
#[test]
fn tv4_unit_conversion() {
    let e = ThesisEccentricities {
        ez_by_um: -36.10,
        ..Default::default()
    };
    let d = identify_thesis(&e, &T43, None).unwrap().deviations;
    assert!((d.alpha_xb_arcsec / 206_264.806 - (-1.01292e-4)).abs() < 5e-10);
    assert!((d.alpha_xb_arcsec - (-20.893)).abs() < 5e-4);
    assert!((ballpod::identify::mill_turn::ARCSEC_PER_RAD - 206_264.806).abs() < 5e-4);
}

/// Round trip: random deviations → thesis relations 4.1–4.9 → eqs 4.10–4.18 recover them (linear:
/// 1e-9 relative).
#[test]
fn thesis_mode_round_trip() {
    let mut r = fwd::Rng(0xba11_ba12);
    let as2rad = 1.0 / 206_264.806_247_096_36;
    for _ in 0..200 {
        let t: [f64; 6] = std::array::from_fn(|_| 40.0 * r.uniform() * as2rad);
        let (dx, dy, dz) = (60.0 * r.uniform(), 60.0 * r.uniform(), 60.0 * r.uniform());
        let g = ThesisGeometry {
            r_b_mm: 200.0 + 200.0 * r.uniform().abs(),
            r_c_mm: 30.0 + 70.0 * r.uniform().abs(),
            z_c_mm: 50.0 + 30.0 * r.uniform(),
            z_t_mm: 110.0 + 20.0 * r.uniform(),
            z_t2_mm: 60.0 + 20.0 * r.uniform(),
            x_t_mm: 490.0 + 50.0 * r.uniform(),
        };
        let e = fwd::thesis_forward(
            t, dx, dy, dz, g.r_b_mm, g.r_c_mm, g.z_c_mm, g.z_t_mm, g.z_t2_mm, g.x_t_mm,
        );
        let d = identify_thesis(&ecc(e), &g, None).unwrap().deviations;
        let got = [
            d.alpha_cz_arcsec,
            d.beta_cz_arcsec,
            d.alpha_xb_arcsec,
            d.beta_xb_arcsec,
            d.gamma_xb_arcsec,
            d.alpha_bt_arcsec,
        ];
        for (a, b) in got.iter().zip(t.iter()) {
            assert!(
                (a * as2rad - b).abs() <= 1e-9 * b.abs().max(1e-6),
                "{a} vs {b}"
            );
        }
        assert!((d.dx_cz_minus_dx_bt_um - dx).abs() < 1e-9 * 60.0);
        assert!((d.dy_cz_um - dy).abs() < 1e-9 * 60.0);
    }
}

/// Uncertainty propagation: σ(ey_CA) alone gives u(α_CZ) = σ/R_C (rad) and u(δy_CZ) = Z_C σ/R_C.
#[test]
fn uncertainty_propagation() {
    let s = ThesisEccentricities {
        ey_ca_um: 0.05,
        ..Default::default()
    };
    let r = identify_thesis(&t44_means(), &T43, Some(&s)).unwrap();
    let u = r.std_uncertainty;
    assert!((u.alpha_cz_arcsec - 0.05e-3 / 50.0 * 206_264.806_247).abs() < 1e-9);
    assert!((u.dy_cz_um - 65.5348 * 0.05 / 50.0).abs() < 1e-9);
    assert!((u.alpha_xb_arcsec).abs() < 1e-15 && u.beta_cz_arcsec.abs() < 1e-15);
    // With Table 4.4's σ/√3 everywhere every output gets a positive uncertainty.
    let mut sig = [0.0; 10];
    for (i, (runs, _, _)) in T44.iter().enumerate() {
        sig[i] = run_statistics(runs).unwrap().population_sigma / 3f64.sqrt();
    }
    let r = identify_thesis(&t44_means(), &T43, Some(&ecc(sig))).unwrap();
    assert!(r.std_uncertainty.alpha_bt_arcsec > 0.0 && r.std_uncertainty.dy_cz_um > 0.0);
    let neg = ThesisEccentricities {
        ex_ca_um: -1.0,
        ..Default::default()
    };
    assert_eq!(
        identify_thesis(&t44_means(), &T43, Some(&neg)),
        Err(BallBarError::NegativeUncertainty)
    );
}

#[test]
fn bad_input_is_typed() {
    let e = t44_means();
    let mut g = T43;
    g.z_t2_mm = g.z_t_mm;
    assert_eq!(
        identify_thesis(&e, &g, None),
        Err(BallBarError::SameToolLength)
    );
    let mut g = T43;
    g.r_b_mm = 0.0;
    assert_eq!(
        identify_thesis(&e, &g, None),
        Err(BallBarError::NonPositiveLength { what: "R_B" })
    );
    let mut g = T43;
    g.r_c_mm = -50.0;
    assert_eq!(
        identify_thesis(&e, &g, None),
        Err(BallBarError::NonPositiveLength { what: "R_C" })
    );
    let mut bad = e;
    bad.ey_cr2_um = f64::INFINITY;
    assert_eq!(
        identify_thesis(&bad, &T43, None),
        Err(BallBarError::NonFinite)
    );
}

/// Spec §9.1: the thesis relations contradict the literal HTM model. On literal-model data
/// (independent forward model, chapter-2 set-up) thesis mode gets δx_CZ right but turns a pure
/// β_CZ into a spurious δx_CZ − δx_BT of 2·Z_C·β_CZ (the Z_C sign conflict of item 3).
#[test]
fn thesis_mode_on_literal_model_data_shows_the_documented_conflict() {
    let g = fwd::Geo {
        lb: 100.0,
        zc: 100.0,
        rb: 200.0,
        rc: 50.0,
    };
    let tg = ThesisGeometry {
        r_b_mm: 200.0,
        r_c_mm: 50.0,
        z_c_mm: 100.0,
        z_t_mm: 200.0,
        z_t2_mm: 250.0,
        x_t_mm: 0.0,
    };
    let measure = |d: &[f64; 13]| {
        let e = |p| fwd::ecc(p, d, &g, 361, [0.0; 3], [0.0; 3]);
        let (bx, by, cr, ca) = (
            e(fwd::Pat::Bx),
            e(fwd::Pat::By),
            e(fwd::Pat::Cr),
            e(fwd::Pat::Ca),
        );
        let cr2 = fwd::ecc(
            fwd::Pat::Cr,
            d,
            &fwd::Geo { rb: 250.0, ..g },
            361,
            [0.0; 3],
            [0.0; 3],
        );
        ecc([bx.0, bx.1, by.0, by.1, cr.0, cr.1, ca.0, ca.1, cr2.0, cr2.1])
    };
    let mut d = [0.0; 13];
    d[9] = 20.0; // δx_CZ
    let r = identify_thesis(&measure(&d), &tg, None).unwrap().deviations;
    assert!((r.dx_cz_minus_dx_bt_um - 20.0).abs() < 0.01);
    let mut d = [0.0; 13];
    d[12] = 100.0; // β_CZ, µrad
    let r = identify_thesis(&measure(&d), &tg, None).unwrap().deviations;
    assert!((r.beta_cz_arcsec - 100e-6 * 206_264.806).abs() < 0.01);
    assert!(
        (r.dx_cz_minus_dx_bt_um - 2.0 * 100.0 * 100e-6 * 1e3).abs() < 0.01,
        "{}",
        r.dx_cz_minus_dx_bt_um
    );
}
