//! Seed 002 literal HTM model and patterns (`identify::mill_turn::{model, patterns}`):
//! TV-5 to TV-9 of spec seed-002 §8.1, Fig 4.30's original BX program, and the core model
//! against the independent forward model of `ballpod_host::forward_seed002`.
use ballpod::identify::mill_turn::model::{AxisCommand, r_bt_mm, r_ct_mm, t_ball_mm, w_ball_mm};
use ballpod::identify::mill_turn::patterns::{
    BallbarLengths, BallbarPattern, Mounting, NcOffset, PatternError, PatternProgram, command,
    simulate_eccentricity,
};
use ballpod::identify::mill_turn::{Deviations, Parameter};
use ballpod_host::forward_seed002 as fwd;

/// Chapter-2 simulation set-up (spec §3.7): L_B 100, Z_C 100, R_B 200, R_C 50 mm.
const SIM: BallbarLengths = BallbarLengths {
    l_b_mm: 100.0,
    r_b_mm: 200.0,
    r_c_mm: 50.0,
    z_c_mm: 100.0,
};
const N: usize = 361;
/// 0.005° in µrad.
const ANG: f64 = 0.005 * std::f64::consts::PI / 180.0 * 1e6;

fn one(p: Parameter, v: f64) -> Deviations {
    let mut a = [0.0; 13];
    a[p.index()] = v;
    Deviations::from_array(&a)
}

fn ecc(p: BallbarPattern, d: &Deviations, m: &Mounting) -> (f64, f64) {
    let e = simulate_eccentricity(p, &SIM, d, m, N).unwrap();
    (e.e1_um, e.e2_um)
}

#[test]
fn tv5_tangential_radii() {
    assert!((r_bt_mm(200.0, 100.0) - 223.6068).abs() < 5e-5);
    assert!((r_ct_mm(50.0, 100.0) - 111.8034).abs() < 5e-5);
}

/// TV-6 and Fig 4.30: X = −390 + R_B sin φ, Z = −112.2605 − R_B(1 − cos φ), R_B = 356.3945,
/// 324 steps over 90°; the ten printed original blocks within 0.3 µm.
#[test]
fn tv6_bx_program_matches_fig_4_30() {
    let g = BallbarLengths {
        l_b_mm: 100.0,
        r_b_mm: 356.3945,
        r_c_mm: 50.0,
        z_c_mm: 65.5348,
    };
    // NC = model command + offset: C centre at NC X −490; BX start at NC Z −112.2605.
    let off = NcOffset {
        x_mm: -490.0,
        y_mm: 0.0,
        z_mm: -112.2605 - (g.z_c_mm + g.r_b_mm),
    };
    let fig = [
        (-390.0000, -112.2605, 0.0000),
        (-388.2722, -112.2647, 0.2778),
        (-386.5444, -112.2773, 0.5556),
        (-384.8166, -112.2982, 0.8333),
        (-383.0890, -112.3275, 1.1111),
        (-381.3616, -112.3652, 1.3889),
        (-379.6344, -112.4113, 1.6667),
        (-377.9074, -112.4657, 1.9444),
        (-376.1807, -112.5285, 2.2222),
        (-374.4543, -112.5997, 2.5000),
    ];
    let prog = PatternProgram::new(BallbarPattern::Bx, g, off, 0.0, 90.0, 324).unwrap();
    assert_eq!(prog.count(), 325);
    let prog = PatternProgram::new(BallbarPattern::Bx, g, off, 0.0, 90.0, 324).unwrap();
    for (blk, (x, z, b)) in prog.zip(fig.iter()) {
        assert!((blk.x_mm - x).abs() < 3e-4, "{blk:?} vs {x}");
        assert!((blk.z_mm - z).abs() < 3e-4, "{blk:?} vs {z}");
        assert!((blk.b_deg - b).abs() < 5e-5);
        assert_eq!(blk.y_mm, 0.0);
        assert_eq!(blk.c_deg, 0.0);
    }
    let last = PatternProgram::new(BallbarPattern::Bx, g, off, 0.0, 90.0, 324)
        .unwrap()
        .last()
        .unwrap();
    assert!((last.b_deg - 90.0).abs() < 1e-12);
    assert!((last.x_mm - (-390.0 + 356.3945)).abs() < 1e-9);
}

/// Table 2.2/2.3 geometry: in BX/BY/BZ the T-ball is nominally stationary; in CR/CA the bar
/// keeps its length L_B to the W-ball.
#[test]
fn nominal_patterns_keep_bar_length() {
    let z = Deviations::default();
    for p in [
        BallbarPattern::Br,
        BallbarPattern::Bt,
        BallbarPattern::Ba,
        BallbarPattern::Bx,
        BallbarPattern::By,
        BallbarPattern::Bz,
        BallbarPattern::Cr,
        BallbarPattern::Ct,
        BallbarPattern::Ca,
        BallbarPattern::Cx,
        BallbarPattern::Cy,
    ] {
        let e = simulate_eccentricity(p, &SIM, &z, &Mounting::default(), 73).unwrap();
        assert!(
            e.e1_um.abs() < 1e-9 && e.e2_um.abs() < 1e-9 && e.r0_um.abs() < 1e-9,
            "{p:?} {e:?}"
        );
    }
    let c = command(BallbarPattern::Bx, &SIM, 0.7);
    let t = t_ball_mm(&z, &c, SIM.r_b_mm, [0.0; 3]);
    assert!((t.x - 100.0).abs() < 1e-12 && t.y.abs() < 1e-12 && (t.z - 100.0).abs() < 1e-12);
}

/// TV-7: δx_CZ = ±20 µm gives ex_CR = ∓20 µm.
#[test]
fn tv7_sign_anchor() {
    let m = Mounting::default();
    let (ex, ey) = ecc(BallbarPattern::Cr, &one(Parameter::DxCz, 20.0), &m);
    assert!((ex + 20.0).abs() < 0.01 && ey.abs() < 0.01);
    let (ex, _) = ecc(BallbarPattern::Cr, &one(Parameter::DxCz, -20.0), &m);
    assert!((ex - 20.0).abs() < 0.01);
}

/// TV-8: single-deviation eccentricities of the literal model (spec table, 3 decimals; the
/// second-order crosstalk is < 0.005 µm).
/// (deviation, value µm or µrad, expected (e1, e2) in BX, BY, CR, CA).
type Row = (Parameter, f64, [(f64, f64); 4]);

#[test]
fn tv8_single_deviation_table() {
    use Parameter::*;
    let z = (0.0, 0.0);
    #[rustfmt::skip]
    let table: [Row; 10] = [
        (DxBt, 20.0, [(0.0, 20.0), (0.0, 0.0), (20.0, 0.0), z]),
        (DzBt, 20.0, [(20.0, 0.0), z, z, z]),
        (AlphaXb, ANG, [z, (0.0, 17.453), (0.0, 17.453), z]),
        (BetaXb, ANG, [(0.0, -17.453), z, (-17.453, 0.0), z]),
        (GammaXb, ANG, [z, (-17.453, 0.0), z, z]),
        (AlphaBt, ANG, [z, z, (0.0, 17.453), z]),
        (DxCz, 20.0, [z, z, (-20.0, 0.0), z]),
        (DyCz, 20.0, [z, z, (0.0, -20.0), z]),
        (AlphaCz, ANG, [z, z, (0.0, 8.727), (0.0, -4.363)]),
        (BetaCz, ANG, [z, z, (-8.727, 0.0), (4.363, 0.0)]),
    ];
    let pats = [
        BallbarPattern::Bx,
        BallbarPattern::By,
        BallbarPattern::Cr,
        BallbarPattern::Ca,
    ];
    for (p, v, exp) in table {
        for (pat, (e1, e2)) in pats.iter().zip(exp) {
            let (a, b) = ecc(*pat, &one(p, v), &Mounting::default());
            assert!(
                (a - e1).abs() < 0.006 && (b - e2).abs() < 0.006,
                "{p:?} {pat:?}: ({a}, {b}) vs ({e1}, {e2})"
            );
        }
    }
}

/// TV-9: a (20, 20, 20) µm W-ball offset leaves BX, BY, CR, CA unchanged (< 0.01 µm) and moves
/// BR and CX by 20 µm.
#[test]
fn tv9_w_ball_mounting_invariance() {
    let z = Deviations::default();
    let m = Mounting {
        t_offset_um: [0.0; 3],
        w_offset_um: [20.0; 3],
    };
    for p in [
        BallbarPattern::Bx,
        BallbarPattern::By,
        BallbarPattern::Cr,
        BallbarPattern::Ca,
    ] {
        let (a, b) = ecc(p, &z, &m);
        assert!(a.abs() < 0.01 && b.abs() < 0.01, "{p:?}");
    }
    let (a, b) = ecc(BallbarPattern::Br, &z, &m);
    assert!(
        (a + 20.0).abs() < 0.01 && (b + 20.0).abs() < 0.01,
        "BR ({a}, {b})"
    );
    let (a, b) = ecc(BallbarPattern::Cx, &z, &m);
    assert!(
        (a + 20.0).abs() < 0.01 && (b - 20.0).abs() < 0.01,
        "CX ({a}, {b})"
    );
}

/// T-ball offsets x_T, y_T, z_T act like δx_BT, −δy_CZ, δz_BT to first order on every pattern
/// of the procedure (spec §3.7 for x_T, z_T; 2nd order ~2 nm): what the model mode identifies
/// as those deviations includes them (`model_lsq::MountingUncertainty`).
#[test]
fn t_ball_offsets_alias_spindle_offsets() {
    for p in [
        BallbarPattern::Bx,
        BallbarPattern::By,
        BallbarPattern::Cr,
        BallbarPattern::Ca,
    ] {
        let by_offset = ecc(
            p,
            &Deviations::default(),
            &Mounting {
                t_offset_um: [15.0, 9.0, -12.0],
                w_offset_um: [0.0; 3],
            },
        );
        let d = Deviations {
            dx_bt_um: 15.0,
            dy_cz_um: -9.0,
            dz_bt_um: -12.0,
            ..Deviations::default()
        };
        let by_dev = ecc(p, &d, &Mounting::default());
        assert!(
            (by_offset.0 - by_dev.0).abs() < 5e-3 && (by_offset.1 - by_dev.1).abs() < 5e-3,
            "{p:?} {by_offset:?} {by_dev:?}"
        );
    }
}

/// The core chain equals the independent forward model (same equations, separate code).
#[test]
fn core_model_equals_independent_forward_model() {
    let mut r = fwd::Rng(0x5eed_0002);
    for _ in 0..20 {
        let d = r.deviations();
        let dev = Deviations::from_array(&d);
        let (x, y, z, phi, th) = (
            r.uniform() * 300.0,
            r.uniform() * 100.0,
            200.0 + r.uniform() * 100.0,
            r.uniform(),
            r.uniform() * 3.0,
        );
        let tofs = [r.uniform() * 20.0, r.uniform() * 20.0, r.uniform() * 20.0];
        let cmd = AxisCommand {
            x_mm: x,
            y_mm: y,
            z_mm: z,
            b_rad: phi,
            c_rad: th,
        };
        let t = t_ball_mm(&dev, &cmd, 250.0, tofs);
        let tf = fwd::t_ball(&d, x, y, z, phi, 250.0, tofs);
        assert!(
            (t.x - tf[0]).abs() < 1e-11
                && (t.y - tf[1]).abs() < 1e-11
                && (t.z - tf[2]).abs() < 1e-11
        );
        let w = w_ball_mm(&dev, th, 80.0, 250.0, 50.0, tofs);
        let wf = fwd::w_ball(&d, th, 80.0, 250.0, 50.0, tofs);
        assert!(
            (w.x - wf[0]).abs() < 1e-11
                && (w.y - wf[1]).abs() < 1e-11
                && (w.z - wf[2]).abs() < 1e-11
        );
        let g = fwd::Geo {
            lb: 100.0,
            zc: 100.0,
            rb: 200.0,
            rc: 50.0,
        };
        for (p, pf) in [
            (BallbarPattern::Bx, fwd::Pat::Bx),
            (BallbarPattern::By, fwd::Pat::By),
            (BallbarPattern::Cr, fwd::Pat::Cr),
            (BallbarPattern::Ca, fwd::Pat::Ca),
        ] {
            let a = ecc(p, &dev, &Mounting::default());
            let b = fwd::ecc(pf, &d, &g, N, [0.0; 3], [0.0; 3]);
            assert!(
                (a.0 - b.0).abs() < 1e-8 && (a.1 - b.1).abs() < 1e-8,
                "{p:?}"
            );
        }
    }
}

#[test]
fn bad_pattern_input_is_typed() {
    let z = Deviations::default();
    let m = Mounting::default();
    let mut g = SIM;
    g.r_b_mm = 0.0;
    assert_eq!(
        simulate_eccentricity(BallbarPattern::Bx, &g, &z, &m, 10),
        Err(PatternError::NonPositiveLength { what: "R_B" })
    );
    let mut g = SIM;
    g.l_b_mm = -1.0;
    assert_eq!(
        simulate_eccentricity(BallbarPattern::Ca, &g, &z, &m, 10),
        Err(PatternError::NonPositiveLength { what: "L_B" })
    );
    let mut g = SIM;
    g.r_c_mm = 100.0;
    assert_eq!(
        simulate_eccentricity(BallbarPattern::Cr, &g, &z, &m, 10),
        Err(PatternError::DegenerateRadialPattern)
    );
    assert_eq!(
        simulate_eccentricity(BallbarPattern::Cr, &SIM, &z, &m, 2),
        Err(PatternError::TooFewSamples { samples: 2 })
    );
    let nan = Deviations {
        dx_bt_um: f64::NAN,
        ..z
    };
    assert_eq!(
        simulate_eccentricity(BallbarPattern::Cr, &SIM, &nan, &m, 10),
        Err(PatternError::NonFinite)
    );
    assert!(
        PatternProgram::new(BallbarPattern::Bx, SIM, NcOffset::default(), 0.0, 90.0, 0).is_err()
    );
    assert!(
        PatternProgram::new(
            BallbarPattern::Bx,
            SIM,
            NcOffset::default(),
            f64::NAN,
            90.0,
            3
        )
        .is_err()
    );
}

#[test]
fn nc_block_validates() {
    use ballpod::identify::mill_turn::patterns::nc_block;
    let off = NcOffset {
        x_mm: -490.0,
        y_mm: 0.0,
        z_mm: 0.0,
    };
    let b = nc_block(BallbarPattern::Ca, &SIM, &off, 90.0).unwrap();
    // CA at θ = 90°: (R_C cos θ, R_C sin θ, Z_C + L_B + R_B) + offset.
    assert!(
        (b.x_mm + 490.0).abs() < 1e-12
            && (b.y_mm - 50.0).abs() < 1e-12
            && (b.z_mm - 400.0).abs() < 1e-12
    );
    assert_eq!((b.b_deg, b.c_deg), (0.0, 90.0));
    assert_eq!(
        nc_block(BallbarPattern::Ca, &SIM, &off, f64::NAN),
        Err(PatternError::NonFinite)
    );
    let mut g = SIM;
    g.r_c_mm = 0.0;
    assert_eq!(
        nc_block(BallbarPattern::Ca, &g, &off, 0.0),
        Err(PatternError::NonPositiveLength { what: "R_C" })
    );
}
