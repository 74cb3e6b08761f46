//! Seed 002 chapter 5 touch-probe method (`identify::mill_turn::probe`): TV-12 (eqs 5.1–5.19
//! on the Table 5.2 averages, spec §6.6/§8.2) in paper mode, and round trips through the
//! independent literal HTM chain of `ballpod_host::forward_seed002` in corrected mode.
use ballpod::identify::mill_turn::lobing::LOBING_COMPONENTS;
use ballpod::identify::mill_turn::probe::{
    BAxisProbe, CAxisProbe, ProbeError, ProbeMode, SphereFitError, fit_sphere, identify_b_axis,
    identify_c_axis,
};
use ballpod_host::forward_seed002 as fwd;

const AS: f64 = 206_264.806_247_096_36;

/// Table 5.2 C-axis averages (mm), C = 0, 90, 180, 270°.
const C_AVG: [[f64; 3]; 4] = [
    [-390.00025, 0.00075, -471.9975],
    [-489.7417, 99.7009, -472.00875],
    [-589.4389, -0.039, -472.02695],
    [-489.7001, -99.738, -472.013],
];

/// TV-12: N = (−5.87331, −0.84884, 39775.83); paper β_CZ = −30.46", α_CZ = −4.40"; the
/// corrected α has the opposite sign.
#[test]
fn tv12_c_axis_formula_outputs() {
    let input = CAxisProbe {
        centres_mm: C_AVG,
        nominal_axis_xy_mm: [-490.0, 0.0],
        z_c_mm: 64.838,
        std_uncertainty_dof: 0.0,
        centres_std_uncertainty_um: [[0.0; 3]; 4],
    };
    let p = identify_c_axis(&input, ProbeMode::Paper).unwrap();
    let n = p.normal_mm2;
    assert!(
        (n[0] + 5.87331).abs() < 5e-6
            && (n[1] + 0.84884).abs() < 5e-6
            && (n[2] - 39775.8266).abs() < 5e-4,
        "{n:?}"
    );
    assert!(
        (p.beta_cz_arcsec + 30.46).abs() < 0.005,
        "{}",
        p.beta_cz_arcsec
    );
    assert!(
        (p.alpha_cz_arcsec + 4.40).abs() < 0.005,
        "{}",
        p.alpha_cz_arcsec
    );
    let c = identify_c_axis(&input, ProbeMode::Corrected).unwrap();
    assert!((c.alpha_cz_arcsec - 4.40).abs() < 0.005);
    assert_eq!(c.beta_cz_arcsec, p.beta_cz_arcsec);
    // Centre vs nominal (−490, 0): ΔX_c ≈ +280 µm, ΔY_c ≈ −18.6 µm (spec §6.6, there from a circle
    // fit; the mean of the four points used here differs by < 1 µm).
    assert!(
        (c.centre_error_um[0] - 280.4).abs() < 1.0 && (c.centre_error_um[1] + 18.6).abs() < 1.0,
        "{:?}",
        c.centre_error_um
    );
    // (5.7) to first order: δx = ΔX_c − Z_C β, δy = ΔY_c + Z_C α.
    let b = c.beta_cz_arcsec / AS;
    let a = c.alpha_cz_arcsec / AS;
    assert!((c.dx_cz_um - (c.centre_error_um[0] - 64.838e3 * b)).abs() < 0.01);
    assert!((c.dy_cz_um - (c.centre_error_um[1] + 64.838e3 * a)).abs() < 0.01);
}

/// TV-12, B axis with nominal (−490, 0, −472) at both angles (spec §6.6): β_XB −5.35",
/// δx_BT −1566 µm, δz_BT −1608 µm, α_XB −18.72" (5.19 with R_B).
#[test]
fn tv12_b_axis_formula_outputs() {
    let input = BAxisProbe {
        measured_mm: [
            [-490.0053, -0.0004, -471.9939],
            [-493.2217, 0.03435, -468.8529],
            [-489.9992, 0.00085, -471.993],
            [-493.2231, 0.04745, -468.8442],
        ],
        nominal_mm: [[-490.0, 0.0, -472.0]; 4],
        measured_std_uncertainty_um: [[0.0; 3]; 4],
        lobing_shift_um: [[[0.0; 3]; LOBING_COMPONENTS]; 4],
        std_uncertainty_dof: 0.0,
        r_b_mm: 382.950,
        r_b2_mm: 433.062,
        x_t_mm: 490.0,
    };
    let p = identify_b_axis(&input, ProbeMode::Paper).unwrap();
    assert!(
        (p.beta_xb_arcsec + 5.35).abs() < 0.005,
        "{}",
        p.beta_xb_arcsec
    );
    assert!((p.dx_bt_um + 1566.0).abs() < 0.5, "{}", p.dx_bt_um);
    assert!((p.dz_bt_um + 1608.0).abs() < 0.5, "{}", p.dz_bt_um);
    assert!((p.alpha_xb_arcsec.unwrap() + 18.72).abs() < 0.005);
    // γ_XB ≈ −1354" with X_T = 490 (spec §6.6: the nominal B = 90° position is clearly not this).
    assert!(
        (p.gamma_xb_arcsec.unwrap() + 1354.0).abs() < 1.0,
        "{:?}",
        p.gamma_xb_arcsec
    );
}

/// Sphere centres the probe reports: the sphere (fixed, at `sphere`) seen through the actual
/// tool tip, i.e. sphere − (T_actual − T_nominal), with T from the literal chain (2.10).
fn b_probe(d: &[f64; 13], rb: f64, sphere: [f64; 3]) -> [[f64; 3]; 2] {
    let mut out = [[0.0; 3]; 2];
    for (k, phi) in [0.0f64, std::f64::consts::FRAC_PI_2].iter().enumerate() {
        // Command that puts the nominal tip on the sphere centre: X − R_B sin φ, Z − R_B cos φ.
        let (x, z) = (sphere[0] + rb * phi.sin(), sphere[2] + rb * phi.cos());
        let t = fwd::t_ball(d, x, sphere[1], z, *phi, rb, [0.0; 3]);
        let t0 = fwd::t_ball(&[0.0; 13], x, sphere[1], z, *phi, rb, [0.0; 3]);
        for i in 0..3 {
            out[k][i] = sphere[i] - (t[i] - t0[i]);
        }
    }
    out
}

#[test]
fn b_axis_corrected_round_trip() {
    let mut r = fwd::Rng(0xb0_be);
    let sphere = [-490.0, 0.0, -472.0];
    for _ in 0..20 {
        let mut d = [0.0; 13];
        d[0] = 40.0 * r.uniform(); // δx_BT
        d[1] = 40.0 * r.uniform(); // δz_BT
        d[2] = 100.0 * r.uniform(); // α_BT
        d[3] = 100.0 * r.uniform(); // α_XB
        d[4] = 100.0 * r.uniform(); // β_XB
        d[5] = 100.0 * r.uniform(); // γ_XB
        let (rb, rb2) = (382.95, 433.062);
        let [m0, m90] = b_probe(&d, rb, sphere);
        let [n0, n90] = b_probe(&d, rb2, sphere);
        let input = BAxisProbe {
            measured_mm: [m0, m90, n0, n90],
            nominal_mm: [sphere; 4],
            measured_std_uncertainty_um: [[0.0; 3]; 4],
            lobing_shift_um: [[[0.0; 3]; LOBING_COMPONENTS]; 4],
            std_uncertainty_dof: 0.0,
            r_b_mm: rb,
            r_b2_mm: rb2,
            x_t_mm: 490.0,
        };
        let c = identify_b_axis(&input, ProbeMode::Corrected).unwrap();
        let asec = |urad: f64| urad * 1e-6 * AS;
        assert!(
            (c.dx_bt_um - d[0]).abs() < 0.01,
            "{} vs {}",
            c.dx_bt_um,
            d[0]
        );
        assert!((c.dz_bt_um - d[1]).abs() < 0.01);
        assert!((c.beta_xb_arcsec - asec(d[4])).abs() < 0.01);
        assert!((c.alpha_bt_plus_alpha_xb_arcsec.unwrap() - asec(d[2] + d[3])).abs() < 0.01);
        assert!((c.alpha_bt_minus_gamma_xb_arcsec.unwrap() - asec(d[2] - d[5])).abs() < 0.01);
        assert!(c.alpha_xb_arcsec.is_none() && c.gamma_xb_arcsec.is_none());
        assert!(c.residual_rms_um < 0.01);
        // Paper (5.13) returns δx_BT with the wrong sign under the literal model (spec §9.1.1).
        let p = identify_b_axis(&input, ProbeMode::Paper).unwrap();
        assert!((p.dx_bt_um + d[0]).abs() < 0.01);
        assert!((p.beta_xb_arcsec - asec(d[4])).abs() < 0.01);
    }
}

#[test]
fn b_axis_redundancy_shows_in_residual() {
    let sphere = [-490.0, 0.0, -472.0];
    let d = [
        10.0, -5.0, 0.0, 0.0, 30.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    ];
    let [m0, mut m90] = b_probe(&d, 380.0, sphere);
    let [n0, n90] = b_probe(&d, 430.0, sphere);
    m90[0] += 0.002; // 2 µm inconsistency in one X reading
    let input = BAxisProbe {
        measured_mm: [m0, m90, n0, n90],
        nominal_mm: [sphere; 4],
        measured_std_uncertainty_um: [[0.0; 3]; 4],
        lobing_shift_um: [[[0.0; 3]; LOBING_COMPONENTS]; 4],
        std_uncertainty_dof: 0.0,
        r_b_mm: 380.0,
        r_b2_mm: 430.0,
        x_t_mm: 490.0,
    };
    let c = identify_b_axis(&input, ProbeMode::Corrected).unwrap();
    assert!(c.residual_rms_um > 0.1 && c.std_uncertainty.iter().all(|u| *u > 0.0));
}

/// Monte-Carlo of the B-axis identification over noisy centres (σ per component, µm; with
/// `known` the σ are given to it): per result the RMS of the stated standard uncertainty and
/// the scatter of the value, in the result's unit.
fn b_axis_monte_carlo(sigma_um: [f64; 3], known: bool) -> [(f64, f64); 5] {
    let sphere = [-490.0, 0.0, -472.0];
    let d = [
        10.0, -5.0, 20.0, 30.0, 40.0, -25.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
    ];
    let (rb, rb2) = (382.95, 433.062);
    let clean = [b_probe(&d, rb, sphere), b_probe(&d, rb2, sphere)];
    let mut r = fwd::Rng(0x005e_edb0);
    let mut normal = || {
        let (u1, u2) = ((r.uniform() + 1.0) / 2.0, (r.uniform() + 1.0) / 2.0);
        (-2.0 * (u1.max(1e-300)).ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    };
    let trials = 4000;
    // per result: Σ value, Σ value², Σ u²
    let mut acc = [[0.0f64; 3]; 5];
    for _ in 0..trials {
        let mut m = [[0.0; 3]; 4];
        for (k, c) in m.iter_mut().enumerate() {
            for (i, v) in c.iter_mut().enumerate() {
                *v = clean[k / 2][k % 2][i] + sigma_um[i] * 1e-3 * normal();
            }
        }
        let input = BAxisProbe {
            measured_mm: m,
            nominal_mm: [sphere; 4],
            measured_std_uncertainty_um: [if known { sigma_um } else { [0.0; 3] }; 4],
            lobing_shift_um: [[[0.0; 3]; LOBING_COMPONENTS]; 4],
            std_uncertainty_dof: 0.0,
            r_b_mm: rb,
            r_b2_mm: rb2,
            x_t_mm: 490.0,
        };
        let c = identify_b_axis(&input, ProbeMode::Corrected).unwrap();
        let vals = [
            (c.beta_xb_arcsec, c.std_uncertainty[0]),
            (c.dx_bt_um, c.std_uncertainty[1]),
            (c.dz_bt_um, c.std_uncertainty[2]),
            (
                c.alpha_bt_plus_alpha_xb_arcsec.unwrap(),
                c.std_uncertainty_y[0],
            ),
            (
                c.alpha_bt_minus_gamma_xb_arcsec.unwrap(),
                c.std_uncertainty_y[1],
            ),
        ];
        for (a, (v, u)) in acc.iter_mut().zip(vals) {
            a[0] += v;
            a[1] += v * v;
            a[2] += u * u;
        }
    }
    let n = trials as f64;
    acc.map(|a| ((a[2] / n).sqrt(), (a[1] / n - (a[0] / n).powi(2)).sqrt()))
}

/// The stated standard uncertainties of the B-axis results against the scatter of the results
/// over many noisy probings (Y: the analytic σ/√(l₁² + l₂²) of the two-lever least squares).
#[test]
fn b_axis_uncertainties_match_the_scatter() {
    let (rb, rb2) = (382.95f64, 433.062f64);
    // σ not known: from the residual (unbiased variance: the RMS u is the scatter)
    let sigma_um = 0.5;
    let analytic_y_arcsec =
        sigma_um / ((rb * 1e-3).powi(2) + (rb2 * 1e-3).powi(2)).sqrt() * 1e-6 * AS;
    for (k, (stated, scatter)) in b_axis_monte_carlo([sigma_um; 3], false)
        .into_iter()
        .enumerate()
    {
        assert!(
            (stated / scatter - 1.0).abs() < 0.1,
            "result {k}: stated u {stated} vs scatter {scatter}"
        );
        if k >= 3 {
            assert!(
                (scatter / analytic_y_arcsec - 1.0).abs() < 0.1,
                "result {k}: scatter {scatter} vs analytic {analytic_y_arcsec}"
            );
        }
    }
    // σ known and unequal: propagated, never below the scatter; the Birge ratio raises it
    // only by what the 5 and 2 degrees of freedom of the residual ask
    let sigma_xyz = [0.3, 0.5, 0.8];
    let analytic_y_arcsec =
        sigma_xyz[1] / ((rb * 1e-3).powi(2) + (rb2 * 1e-3).powi(2)).sqrt() * 1e-6 * AS;
    for (k, (stated, scatter)) in b_axis_monte_carlo(sigma_xyz, true).into_iter().enumerate() {
        let ratio = stated / scatter;
        assert!(
            (0.97..1.35).contains(&ratio),
            "result {k}: stated u {stated} vs scatter {scatter}"
        );
        if k >= 3 {
            assert!(
                (scatter / analytic_y_arcsec - 1.0).abs() < 0.1,
                "result {k}: scatter {scatter} vs analytic {analytic_y_arcsec}"
            );
        }
    }
}

#[test]
fn c_axis_corrected_round_trip() {
    let mut r = fwd::Rng(0xc_a515);
    for _ in 0..20 {
        let (centres, truth) = c_axis_machine(&mut r);
        let input = CAxisProbe {
            centres_mm: centres,
            nominal_axis_xy_mm: [-490.0, 0.0],
            z_c_mm: 64.838,
            std_uncertainty_dof: 0.0,
            centres_std_uncertainty_um: [[0.0; 3]; 4],
        };
        let c = identify_c_axis(&input, ProbeMode::Corrected).unwrap();
        let got = [c.alpha_cz_arcsec, c.beta_cz_arcsec, c.dx_cz_um, c.dy_cz_um];
        for (g, t) in got.iter().zip(truth) {
            assert!((g - t).abs() < 0.01, "{got:?} vs {truth:?}");
        }
        assert!(c.diagonal_mismatch_um < 1e-3);
        let p = identify_c_axis(&input, ProbeMode::Paper).unwrap();
        assert!((p.alpha_cz_arcsec + truth[0]).abs() < 0.01);
        // Points listed in the clockwise order (0, 270, 180, 90°): same angles.
        let cw = CAxisProbe {
            centres_mm: [centres[0], centres[3], centres[2], centres[1]],
            ..input
        };
        let w = identify_c_axis(&cw, ProbeMode::Corrected).unwrap();
        assert!(
            (w.alpha_cz_arcsec - c.alpha_cz_arcsec).abs() < 1e-9
                && (w.beta_cz_arcsec - c.beta_cz_arcsec).abs() < 1e-9
        );
    }
}

/// The four C-axis centres (C = 0, 90, 180, 270°; nominal centreline (−490, 0) mm, Z_C
/// 64.838 mm) of a random machine through the literal HTM chain, without noise, and its truth
/// (α_CZ ", β_CZ ", δx_CZ µm, δy_CZ µm).
fn c_axis_machine(r: &mut fwd::Rng) -> ([[f64; 3]; 4], [f64; 4]) {
    c_axis_machine_positioned(r, [0.0; 4])
}

/// [`c_axis_machine`] with the C axis stopping `c_error_rad` off each of its four positions.
fn c_axis_machine_positioned(r: &mut fwd::Rng, c_error_rad: [f64; 4]) -> ([[f64; 3]; 4], [f64; 4]) {
    let mut d = [0.0; 13];
    d[9] = 50.0 * r.uniform(); // δx_CZ
    d[10] = 50.0 * r.uniform(); // δy_CZ
    d[11] = 150.0 * r.uniform(); // α_CZ
    d[12] = 150.0 * r.uniform(); // β_CZ
    let (_, _, _, _, mcz, _) = fwd::mats(&d);
    let (rc, zc) = (100.0, 64.838);
    let origin = [-490.0, 0.0, -536.838]; // machine coordinates of O_M
    let mut centres = [[0.0; 3]; 4];
    for (k, c) in centres.iter_mut().enumerate() {
        let th = k as f64 * std::f64::consts::FRAC_PI_2 + c_error_rad[k];
        let p = fwd::apply(&fwd::mul(&mcz, &fwd::ec(th)), [rc, 0.0, zc]);
        for i in 0..3 {
            c[i] = origin[i] + p[i];
        }
    }
    let asec = |urad: f64| urad * 1e-6 * AS;
    (centres, [asec(d[11]), asec(d[12]), d[9], d[10]])
}

/// The corrected C-axis outputs (α_CZ ″, β_CZ ″, δx_CZ µm, δy_CZ µm) of `centres` on the test
/// machine's set-up ([`c_axis_machine`]) and their u, the fits' `sigma_um` stated.
fn c_axis_outputs(centres: [[f64; 3]; 4], sigma_um: [[f64; 3]; 4]) -> ([f64; 4], [f64; 4]) {
    let input = CAxisProbe {
        centres_mm: centres,
        nominal_axis_xy_mm: [-490.0, 0.0],
        z_c_mm: 64.838,
        std_uncertainty_dof: 0.0,
        centres_std_uncertainty_um: sigma_um,
    };
    let c = identify_c_axis(&input, ProbeMode::Corrected).unwrap();
    let got = [c.alpha_cz_arcsec, c.beta_cz_arcsec, c.dx_cz_um, c.dy_cz_um];
    (got, c.std_uncertainty)
}

/// Per C-axis output over the trials: how often U = 2u covered the error, Σ error², Σ u².
#[derive(Default)]
struct Tally {
    covered: [usize; 4],
    err2: [f64; 4],
    u2: [f64; 4],
}

impl Tally {
    /// Adds one trial's outputs `got` against `truth` with their u.
    fn add(&mut self, got: [f64; 4], truth: [f64; 4], u: [f64; 4]) {
        for k in 0..4 {
            let e = got[k] - truth[k];
            self.covered[k] += usize::from(e.abs() <= 2.0 * u[k]);
            self.err2[k] += e * e;
            self.u2[k] += u[k] * u[k];
        }
    }

    /// Output `k`'s coverage, rms u / rms error and rms error over `trials`.
    fn of(&self, k: usize, trials: usize) -> (f64, f64, f64) {
        (
            self.covered[k] as f64 / trials as f64,
            (self.u2[k] / self.err2[k]).sqrt(),
            (self.err2[k] / trials as f64).sqrt(),
        )
    }
}

/// Monte Carlo of the C-axis uncertainty: centres from the literal HTM chain plus Gaussian
/// noise of a different σ per centre and coordinate (0.2–1.5 µm). With the σ stated, U = 2u
/// covers the truth in 95–99 % (u is the propagated σ, raised by the Birge ratio of the
/// diagonals' mismatch when that is larger); with nothing stated, u comes from the mismatch
/// alone (3 degrees of freedom: 2u covers as Student's t₃, 86 %) and its mean square matches
/// the scatter's within 10 %.
#[test]
fn c_axis_uncertainty_covers_the_truth() {
    let mut r = fwd::Rng(0xc0_5e7);
    let mut noise = ballpod_host::rng::Rng::new(0xc_0a_u64);
    const TRIALS: usize = 4000;
    for stated in [true, false] {
        let mut tally = Tally::default();
        for _ in 0..TRIALS {
            let (mut centres, truth) = c_axis_machine(&mut r);
            let mut sigma = [[0.0; 3]; 4];
            for (c, s) in centres.iter_mut().zip(sigma.iter_mut()) {
                for (x, si) in c.iter_mut().zip(s.iter_mut()) {
                    *si = noise.range(0.2, 1.5);
                    *x += *si * 1e-3 * noise.normal();
                }
            }
            let (got, us) = c_axis_outputs(centres, if stated { sigma } else { [[0.0; 3]; 4] });
            assert!(us.iter().all(|u| u.is_finite() && *u > 0.0), "{us:?}");
            tally.add(got, truth, us);
        }
        for k in 0..4 {
            let (coverage, ratio, _) = tally.of(k, TRIALS);
            if stated {
                // the Birge factor only ever raises u (by E[max(1, χ²₃/3)] ≈ 1.3 in u²)
                assert!(
                    (0.95..0.99).contains(&coverage) && (1.0..1.25).contains(&ratio),
                    "stated, output {k}: coverage {coverage}, rms u / rms error {ratio}"
                );
            } else {
                // u² from 3 degrees of freedom: unbiased; 2u covers as Student's t₃ (0.861)
                assert!(
                    (coverage - 0.861).abs() < 0.03 && (ratio - 1.0).abs() < 0.1,
                    "from the mismatch, output {k}: coverage {coverage}, rms u / rms error {ratio}"
                );
            }
        }
    }
}

/// C positioning errors (the axis stopping N(0, u_C) off each of its four positions: a
/// tangential shift of R_C·δC per sphere, 2.4 µm at 5″ and R_C 100 mm) with 0.5 µm of stated
/// fit noise, 4000 machines per u_C. The shifts do not cancel in the mean centre, so δx_CZ and
/// δy_CZ scatter more (0.34 µm without, 1.8 µm at 10″); they show in the diagonals' mismatch
/// in the plane, whose Birge ratio raises their u: U = 2u covers them in 94–99 %, u within
/// 25 % of the scatter. The tilts do not move (a tangential shift leaves the diagonals' Z), and
/// their u, raised by Z's mismatch alone, stays as without (a single Birge ratio over all
/// three components made it 6 times their scatter at 10″).
#[test]
fn c_axis_positioning_errors_are_covered() {
    let mut r = fwd::Rng(0xc_905);
    let mut noise = ballpod_host::rng::Rng::new(0xc_906);
    const TRIALS: usize = 4000;
    for u_c_arcsec in [0.0, 2.0, 5.0, 10.0] {
        let mut tally = Tally::default();
        for _ in 0..TRIALS {
            let dc = [0; 4].map(|_| u_c_arcsec / AS * noise.normal());
            let (mut centres, truth) = c_axis_machine_positioned(&mut r, dc);
            for c in centres.iter_mut() {
                for x in c.iter_mut() {
                    *x += 0.5e-3 * noise.normal();
                }
            }
            let (got, us) = c_axis_outputs(centres, [[0.5; 3]; 4]);
            tally.add(got, truth, us);
        }
        for k in 0..4 {
            let (coverage, ratio, rms) = tally.of(k, TRIALS);
            println!(
                "u_C {u_c_arcsec}\", output {k}: coverage {coverage:.3}, rms u / rms error {ratio:.2}, rms error {rms:.3}"
            );
            assert!(
                (0.92..=1.0).contains(&coverage),
                "{u_c_arcsec}, {k}: {coverage}"
            );
            if k >= 2 {
                assert!((0.95..=1.25).contains(&ratio), "{u_c_arcsec}, {k}: {ratio}");
            } else {
                // the tilts: their scatter is the fit noise's whatever u_C
                assert!((0.7..0.76).contains(&rms), "{u_c_arcsec}, {k}: {rms}");
                assert!((1.0..1.3).contains(&ratio), "{u_c_arcsec}, {k}: {ratio}");
            }
        }
    }
}

#[test]
fn bad_input_is_typed() {
    let same = CAxisProbe {
        centres_mm: [[1.0, 2.0, 3.0]; 4],
        nominal_axis_xy_mm: [0.0, 0.0],
        z_c_mm: 60.0,
        std_uncertainty_dof: 0.0,
        centres_std_uncertainty_um: [[0.0; 3]; 4],
    };
    assert_eq!(
        identify_c_axis(&same, ProbeMode::Corrected),
        Err(ProbeError::DegenerateCircle)
    );
    // Points on a vertical line: N has no Z component.
    let line = CAxisProbe {
        centres_mm: [
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, 0.0, 2.0],
            [0.0, 0.0, 3.0],
        ],
        ..same
    };
    assert_eq!(
        identify_c_axis(&line, ProbeMode::Paper),
        Err(ProbeError::DegenerateCircle)
    );
    // a non-finite centre or centre uncertainty
    let poisons: [fn(&mut CAxisProbe); 2] = [
        |p| p.centres_mm[2][1] = f64::NAN,
        |p| p.centres_std_uncertainty_um[1][2] = f64::INFINITY,
    ];
    for poison in poisons {
        let mut bad = CAxisProbe {
            centres_mm: C_AVG,
            ..same
        };
        poison(&mut bad);
        assert_eq!(
            identify_c_axis(&bad, ProbeMode::Corrected),
            Err(ProbeError::NonFinite)
        );
    }
    let b = BAxisProbe {
        measured_mm: [[0.0; 3]; 4],
        nominal_mm: [[0.0; 3]; 4],
        measured_std_uncertainty_um: [[0.0; 3]; 4],
        lobing_shift_um: [[[0.0; 3]; LOBING_COMPONENTS]; 4],
        std_uncertainty_dof: 0.0,
        r_b_mm: 380.0,
        r_b2_mm: 380.0,
        x_t_mm: 490.0,
    };
    assert_eq!(
        identify_b_axis(&b, ProbeMode::Corrected),
        Err(ProbeError::SameToolLength)
    );
    assert_eq!(
        identify_b_axis(&BAxisProbe { r_b_mm: 0.0, ..b }, ProbeMode::Paper),
        Err(ProbeError::NonPositiveLength { what: "R_B" })
    );
    assert_eq!(
        identify_b_axis(&BAxisProbe { r_b2_mm: -1.0, ..b }, ProbeMode::Paper),
        Err(ProbeError::NonPositiveLength { what: "R'_B" })
    );
    assert_eq!(
        identify_b_axis(
            &BAxisProbe {
                r_b2_mm: 430.0,
                x_t_mm: 0.0,
                ..b
            },
            ProbeMode::Paper
        ),
        Err(ProbeError::NonPositiveLength { what: "X_T" })
    );
    assert_eq!(
        identify_b_axis(
            &BAxisProbe {
                x_t_mm: f64::NAN,
                ..b
            },
            ProbeMode::Paper
        ),
        Err(ProbeError::NonFinite)
    );
}

/// TV-13: least-squares sphere through the 21 Fig 5.13 points: centre (−390.2175, −0.0005,
/// −472.4176), R 7.9106 mm, RMS 1.46 µm.
#[test]
fn tv13_sphere_fit_of_fig_5_13() {
    let pts = ballpod_host::forward_seed002::FIG_5_13;
    let f = fit_sphere(&pts, 0.0).unwrap();
    let exp = [-390.2175, -0.0005, -472.4176];
    for (a, b) in f.centre_mm.iter().zip(exp) {
        assert!((a - b).abs() < 5e-5 + 1e-9, "{:?}", f.centre_mm);
    }
    assert!((f.radius_mm - 7.9106).abs() < 5e-5);
    assert!((f.residual_rms_um - 1.46).abs() < 0.005);
    assert!(f.std_uncertainty_um.iter().all(|u| *u > 0.0 && *u < 5.0));
}

#[test]
fn sphere_fit_round_trip_and_bad_input() {
    let mut r = fwd::Rng(0x5f_e7e);
    for _ in 0..20 {
        let c = [
            -400.0 + 50.0 * r.uniform(),
            30.0 * r.uniform(),
            -470.0 + 20.0 * r.uniform(),
        ];
        let rad = 5.0 + 3.0 * r.uniform().abs();
        let pts: Vec<[f64; 3]> = (0..15)
            .map(|_| {
                let (u, v) = (r.uniform() * std::f64::consts::PI, r.uniform() * 1.3);
                [
                    c[0] + rad * v.cos() * u.cos(),
                    c[1] + rad * v.cos() * u.sin(),
                    c[2] + rad * v.sin(),
                ]
            })
            .collect();
        let f = fit_sphere(&pts, 0.0).unwrap();
        for i in 0..3 {
            assert!((f.centre_mm[i] - c[i]).abs() < 1e-9);
        }
        assert!((f.radius_mm - rad).abs() < 1e-9 && f.residual_rms_um < 1e-6);
    }
    assert_eq!(
        fit_sphere(&[[0.0; 3]; 3], 0.0),
        Err(SphereFitError::TooFewPoints { points: 3 })
    );
    let plane = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
        [2.0, 0.5, 0.0],
    ];
    assert_eq!(fit_sphere(&plane, 0.0), Err(SphereFitError::Degenerate));
    assert_eq!(
        fit_sphere(&[[0.0, 0.0, f64::NAN]; 5], 0.0),
        Err(SphereFitError::NonFinite)
    );
}

/// The sphere fit's response to the probe's lobing (`SphereFit::lobing_um_per_um`, row j per µm
/// of component j: `identify::mill_turn::lobing`) against a refit: nine touches on a sphere,
/// each moved inward by 1 µm of one component computed here from θ and φ (acos, atan2, cos,
/// sin in the probe's frame: stylus up (sin B, 0, cos B), x (cos B, 0, −sin B)) and refitted.
#[test]
fn the_fits_lobing_response_is_a_refit_of_the_moved_touches() {
    use ballpod_host::vmt::motion::probing_directions;
    // harmonics 3k, k = 1…6, relative to the third's (the kinematic 1/cos law), then d
    const RATIO: [f64; 6] = [1.0, 0.379, 0.195, 0.118, 0.078, 0.056];
    let (centre, r) = ([12.0, -3.0, 40.0], 15.0);
    let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    for b_deg in [0.0, 90.0, 35.0] {
        let b = f64::to_radians(b_deg);
        let (x_axis, z_axis) = ([b.cos(), 0.0, -b.sin()], [b.sin(), 0.0, b.cos()]);
        let on =
            |n: [f64; 3], rr: f64| -> [f64; 3] { std::array::from_fn(|i| centre[i] + rr * n[i]) };
        let pts: Vec<[f64; 3]> = probing_directions().iter().map(|n| on(*n, r)).collect();
        let fit = fit_sphere(&pts, b_deg).unwrap();
        for j in 0..LOBING_COMPONENTS {
            let g = |n: [f64; 3]| {
                let (x, y, z) = (dot(n, x_axis), n[1], dot(n, z_axis));
                let (theta, phi) = (z.clamp(-1.0, 1.0).acos(), y.atan2(x));
                if j == LOBING_COMPONENTS - 1 {
                    return z * z;
                }
                let k = 3.0 * (j / 2 + 1) as f64;
                let wave = if j % 2 == 0 {
                    (k * phi).cos()
                } else {
                    (k * phi).sin()
                };
                RATIO[j / 2] * theta.sin().powi(2) * wave
            };
            let moved: Vec<[f64; 3]> = probing_directions()
                .iter()
                .map(|n| on(*n, r - 1e-3 * g(*n)))
                .collect();
            let refit = fit_sphere(&moved, b_deg).unwrap();
            for axis in 0..3 {
                let want = (refit.centre_mm[axis] - fit.centre_mm[axis]) * 1e3;
                let got = f64::from(fit.lobing_um_per_um[j][axis]);
                assert!(
                    (got - want).abs() < 1e-3,
                    "B {b_deg}°, component {j}, axis {axis}: {got} vs refit {want}"
                );
            }
        }
    }
}
