//! Seed 002 model-based least squares on the literal HTM model
//! (`identify::mill_turn::model_lsq`): random deviations → the independent forward model of
//! `ballpod_host::forward_seed002` (literal 4×4 products + §3.5 fit) → identification recovers
//! them; rank-deficient set-ups are reported with the combination they cannot separate.
use ballpod::identify::mill_turn::model_lsq::{
    ModelLsq, ModelLsqError, MountingUncertainty, PatternMeasurement,
};
use ballpod::identify::mill_turn::patterns::{BallbarLengths, BallbarPattern, PatternError};
use ballpod::identify::mill_turn::{Deviations, Parameter};
use ballpod::metrology::bar_budget::BarBudget;
use ballpod_host::forward_seed002 as fwd;

const N: usize = 37;
const LB: f64 = 100.0;
const ZC: f64 = 65.5;
const RB: f64 = 356.4;
const RB2: f64 = 406.5;
const RC: f64 = 50.0;

fn geo(rb: f64) -> BallbarLengths {
    BallbarLengths {
        l_b_mm: LB,
        r_b_mm: rb,
        r_c_mm: RC,
        z_c_mm: ZC,
    }
}

/// The five steps of §5.3 measured on the independent forward model for deviations `d`.
fn procedure(d: &[f64; 13]) -> Vec<PatternMeasurement> {
    let steps = [
        (BallbarPattern::Bx, fwd::Pat::Bx, RB),
        (BallbarPattern::By, fwd::Pat::By, RB),
        (BallbarPattern::Cr, fwd::Pat::Cr, RB),
        (BallbarPattern::Ca, fwd::Pat::Ca, RB),
        (BallbarPattern::Cr, fwd::Pat::Cr, RB2),
    ];
    steps
        .iter()
        .map(|&(p, pf, rb)| {
            let g = fwd::Geo {
                lb: LB,
                zc: ZC,
                rb,
                rc: RC,
            };
            let (e1, e2) = fwd::ecc(pf, d, &g, N, [0.0; 3], [0.0; 3]);
            PatternMeasurement {
                pattern: p,
                geometry: geo(rb),
                samples: N,
                e1_um: e1,
                e2_um: e2,
                sigma_um: 0.3,
            }
        })
        .collect()
}

fn without_squareness(d: &mut [f64; 13]) {
    for p in [Parameter::GammaXy, Parameter::AlphaYz, Parameter::BetaYz] {
        d[p.index()] = 0.0;
    }
}

/// Noise-free round trip of the 10 non-squareness deviations (Gauss–Newton on the full model:
/// recovery to numerical precision, far below the 1e-3 µm linearisation residue).
#[test]
fn round_trip_recovers_ten_deviations() {
    let mut r = fwd::Rng(0x1a5e_0002);
    for _ in 0..4 {
        let mut d = r.deviations();
        without_squareness(&mut d);
        let m = procedure(&d);
        let res = ModelLsq::without_squareness().identify(&m).unwrap();
        let got = res.deviations.to_array();
        for (i, p) in Parameter::ALL.iter().enumerate() {
            assert!(
                (got[i] - d[i]).abs() <= 1e-7 * d[i].abs().max(1.0),
                "{p:?}: {} vs {}",
                got[i],
                d[i]
            );
        }
        assert!(res.residual_rms_um < 1e-8);
        assert!(res.iterations >= 2 && res.condition.is_finite());
    }
}

/// The pod predicts each pattern from `MODEL_SAMPLES_MAX` (37) points while its runs have
/// thousands of samples: against a 3601-point forward-model measurement the identified
/// deviations stay within 1e-3 µm / µrad (1 nm, 0.0002″) of the truth.
#[test]
fn coarse_model_sampling_is_exact_enough() {
    use ballpod::app::bc_ballbar::MODEL_SAMPLES_MAX;
    let mut r = fwd::Rng(0x5a3b_1e02);
    for _ in 0..3 {
        let mut d = r.deviations();
        without_squareness(&mut d);
        let mut m = procedure(&d);
        let steps = [
            fwd::Pat::Bx,
            fwd::Pat::By,
            fwd::Pat::Cr,
            fwd::Pat::Ca,
            fwd::Pat::Cr,
        ];
        for (p, pf) in m.iter_mut().zip(steps) {
            let g = fwd::Geo {
                lb: LB,
                zc: ZC,
                rb: p.geometry.r_b_mm,
                rc: RC,
            };
            (p.e1_um, p.e2_um) = fwd::ecc(pf, &d, &g, 3601, [0.0; 3], [0.0; 3]);
            p.samples = MODEL_SAMPLES_MAX;
        }
        let got = ModelLsq::without_squareness()
            .identify(&m)
            .unwrap()
            .deviations
            .to_array();
        for (i, p) in Parameter::ALL.iter().enumerate() {
            assert!(
                (got[i] - d[i]).abs() < 1e-3,
                "{p:?}: {} vs {}",
                got[i],
                d[i]
            );
        }
    }
}

/// Repeated runs with noise give redundancy: a residual and finite, positive uncertainties
/// that cover the error.
#[test]
fn redundancy_gives_residual_and_uncertainty() {
    let mut r = fwd::Rng(0x0dd_5eed);
    let mut d = r.deviations();
    without_squareness(&mut d);
    let mut m = Vec::new();
    for _ in 0..3 {
        for mut p in procedure(&d) {
            p.e1_um += 0.3 * r.uniform();
            p.e2_um += 0.3 * r.uniform();
            m.push(p);
        }
    }
    let res = ModelLsq::without_squareness().identify(&m).unwrap();
    assert!(res.residual_rms_um > 0.01 && res.residual_rms_um < 0.3);
    let got = res.deviations.to_array();
    for (i, p) in Parameter::ALL.iter().enumerate() {
        let u = res.std_uncertainty[i];
        if matches!(
            p,
            Parameter::GammaXy | Parameter::AlphaYz | Parameter::BetaYz
        ) {
            assert_eq!(u, 0.0);
            assert_eq!(got[i], 0.0);
        } else {
            assert!(u > 0.0 && u.is_finite(), "{p:?}");
            assert!(
                (got[i] - d[i]).abs() < 6.0 * u + 1e-6,
                "{p:?}: {} vs {} ± {u}",
                got[i],
                d[i]
            );
        }
    }
}

/// All 13 free: squareness aliases B-head angles and γ_XY is invisible: rank 10 of 13.
#[test]
fn squareness_is_not_separable() {
    let m = procedure(&[0.0; 13]);
    let all = ModelLsq::with_free(&Parameter::ALL);
    let rep = all.identifiability(&m).unwrap();
    assert_eq!((rep.free, rep.rank, rep.equations), (13, 10, 10));
    assert!(rep.null_combination(3).is_none());
    // γ_XY alone is one null direction; the null space contains it.
    let gxy = Parameter::GammaXy.index();
    let share: f64 = (0..3)
        .map(|k| rep.null_combination(k).unwrap()[gxy].powi(2))
        .sum();
    assert!((share - 1.0).abs() < 1e-9, "{share}");
    // Every null combination is orthogonal to every pattern: changing the deviations along it
    // does not change the forward model's eccentricities (to first order).
    for k in 0..3 {
        let v = rep.null_combination(k).unwrap();
        let d: [f64; 13] = std::array::from_fn(|i| v[i] * 10.0);
        for p in procedure(&d) {
            assert!(p.e1_um.abs() < 1e-3 && p.e2_um.abs() < 1e-3, "{p:?}");
        }
    }
    match all.identify(&m) {
        Err(ModelLsqError::NotSeparable {
            rank,
            free,
            dominant,
            ..
        }) => {
            assert_eq!((rank, free), (10, 13));
            assert!(matches!(
                dominant,
                Parameter::GammaXy
                    | Parameter::AlphaYz
                    | Parameter::BetaYz
                    | Parameter::AlphaXb
                    | Parameter::BetaXb
                    | Parameter::AlphaCz
                    | Parameter::BetaCz
            ));
        }
        other => panic!("{other:?}"),
    }
}

/// Without the second tool length (CR'), β_XB cannot be told from δx_BT (BX ez and CR ex see
/// δx_BT − R_B β_XB) nor α_BT from δy_CZ.
#[test]
fn without_second_tool_length_is_rank_deficient() {
    let m = procedure(&[0.0; 13]);
    let setup = ModelLsq::without_squareness();
    let rep = setup.identifiability(&m[..4]).unwrap();
    assert_eq!((rep.free, rep.rank), (10, 8));
    for k in 0..2 {
        let v = rep.null_combination(k).unwrap();
        // Only δx_BT, β_XB, α_BT, δy_CZ (and nothing else) take part.
        for (i, p) in Parameter::ALL.iter().enumerate() {
            if !matches!(
                p,
                Parameter::DxBt | Parameter::BetaXb | Parameter::AlphaBt | Parameter::DyCz
            ) {
                assert!(v[i].abs() < 1e-6, "{p:?} {}", v[i]);
            }
        }
    }
    // identify names a combination of the same two-dimensional null space (which one within
    // it is arbitrary: both directions are equally unobservable).
    let four = [
        Parameter::DxBt,
        Parameter::BetaXb,
        Parameter::AlphaBt,
        Parameter::DyCz,
    ];
    match setup.identify(&m[..4]) {
        Err(ModelLsqError::NotSeparable {
            rank: 8,
            free: 10,
            combination,
            dominant,
            second,
        }) => {
            assert!(
                four.contains(&dominant) && four.contains(&second),
                "{dominant:?} {second:?}"
            );
            for (i, p) in Parameter::ALL.iter().enumerate() {
                if !four.contains(p) {
                    assert!(combination[i].abs() < 1e-5, "{p:?} {}", combination[i]);
                }
            }
        }
        other => panic!("{other:?}"),
    }
    // The thesis-style 8-parameter set without δx_BT, δz_BT... with δx_BT fixed, CR' is still
    // needed for α_BT vs δy_CZ.
    let mut free = ModelLsq::without_squareness();
    free.free[Parameter::DxBt.index()] = false;
    assert_eq!(free.identifiability(&m[..4]).unwrap().rank, 8);
    assert_eq!(free.identifiability(&m).unwrap().rank, 9);
}

#[test]
fn bad_input_is_typed() {
    let mut m = procedure(&[0.0; 13]);
    let s = ModelLsq::without_squareness();
    assert_eq!(s.identify(&[]), Err(ModelLsqError::Empty));
    assert_eq!(
        ModelLsq::with_free(&[]).identify(&m),
        Err(ModelLsqError::Empty)
    );
    m[2].sigma_um = 0.0;
    assert_eq!(
        s.identify(&m),
        Err(ModelLsqError::BadMeasurement { index: 2 })
    );
    m[2].sigma_um = 0.3;
    m[3].e2_um = f64::NAN;
    assert_eq!(
        s.identify(&m),
        Err(ModelLsqError::BadMeasurement { index: 3 })
    );
    m[3].e2_um = 0.0;
    m[1].geometry.r_b_mm = -1.0;
    assert_eq!(
        s.identify(&m),
        Err(ModelLsqError::BallbarPattern {
            index: 1,
            cause: PatternError::NonPositiveLength { what: "R_B" }
        })
    );
    m[1].geometry.r_b_mm = RB;
    m[0].samples = 1;
    assert_eq!(
        s.identify(&m),
        Err(ModelLsqError::BallbarPattern {
            index: 0,
            cause: PatternError::TooFewSamples { samples: 1 }
        })
    );
    let _ = Deviations::default();
}

#[test]
fn non_finite_fixed_value_is_typed() {
    let m = procedure(&[0.0; 13]);
    let mut s = ModelLsq::without_squareness();
    s.fixed.gamma_xy_urad = f64::NAN;
    assert_eq!(s.identify(&m), Err(ModelLsqError::NonFiniteFixed));
}

/// The propagated uncertainty of `identify_propagated` (linear, one solve per eccentricity
/// component) equals the one obtained by re-identifying with each component moved by its
/// uncertainty (the full non-linear model) to 1e-3 relative.
#[test]
fn propagated_uncertainty_matches_re_identification() {
    let mut r = fwd::Rng(0x7e57_0013);
    let mut d = r.deviations();
    without_squareness(&mut d);
    let m = procedure(&d);
    let u: Vec<[f64; 2]> = (0..m.len())
        .map(|i| [0.1 + 0.02 * i as f64, 0.15])
        .collect();
    let lsq = ModelLsq::without_squareness();
    let (res, got) = lsq
        .identify_propagated(&m, &u, &MountingUncertainty::NONE, &BarBudget::NONE)
        .unwrap();
    let got = got.combined;
    let x0 = res.deviations.to_array();
    let mut var = [0.0f64; 13];
    for i in 0..m.len() {
        for k in 0..2 {
            let mut mp = m.clone();
            if k == 0 {
                mp[i].e1_um += u[i][0];
            } else {
                mp[i].e2_um += u[i][1];
            }
            let xp = lsq.identify(&mp).unwrap().deviations.to_array();
            for j in 0..13 {
                var[j] += (xp[j] - x0[j]).powi(2);
            }
        }
    }
    for (j, p) in Parameter::ALL.iter().enumerate() {
        let want = var[j].sqrt();
        assert!(
            (got[j] - want).abs() <= 1e-3 * want + 1e-9,
            "{p:?}: {} vs {want}",
            got[j]
        );
    }
    assert_eq!(
        lsq.identify_propagated(&m, &u[..2], &MountingUncertainty::NONE, &BarBudget::NONE)
            .map(|_| ()),
        Err(ModelLsqError::BadMeasurement { index: 2 })
    );
}
