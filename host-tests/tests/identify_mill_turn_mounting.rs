//! Seed 002 model mode with the balls' real mounting errors (issue 14): Monte Carlo against the
//! independent forward model of `ballpod_host::forward_seed002` (literal 4×4 products, its own
//! §3.5 fit). Each simulated procedure clamps the W-ball twice (B steps, C steps) with a shift of
//! 10–60 µm in a random direction (the thesis's measured fact, spec seed-002 §2.7), mounts the
//! T-ball once per tool length with an axial shift from the same distribution and a radial
//! offset left by centring (uniform in a 1 µm disc, §5.2 step 3), and adds the bar noise's
//! eccentricity scatter; an LVDT whose scale is off by k reads every eccentricity (1 + k) times;
//! a set-up length entered off is run true on the machine and told wrong to the pod.
//! The stated U = 2u must cover the truth — the machine's deviations plus what the
//! identification absorbs of the first tool length's T-ball offset — in ≥ 95 % of the runs,
//! and u must match the scatter.
use ballpod::identify::mill_turn::Parameter;
use ballpod::identify::mill_turn::model_lsq::{
    ModelLsq, ModelLsqError, MountingInput, MountingUncertainty, PatternMeasurement,
};
use ballpod::identify::mill_turn::patterns::{BallbarLengths, BallbarPattern};
use ballpod::metrology::bar_budget::BarBudget;
use ballpod_host::forward_seed002 as fwd;
use ballpod_host::rng::Rng;
use ballpod_host::vmt::mounting::{clamping_shift, t_ball_offset};

/// Samples of the simulated measurement (the forward model) and of the pod's model.
const N_MEASURED: usize = 181;
const N_MODEL: usize = 37;
/// Thesis Table 4.3 set-up (mm).
const LB: f64 = 100.0;
const ZC: f64 = 65.5;
const RB: f64 = 356.4;
const RB2: f64 = 406.5;
const RC: f64 = 50.0;
/// Standard uncertainty of each step's eccentricity component from the bar noise (µm; the
/// size the worked example's 0.2 µm bar noise gives).
const U_ECC_UM: f64 = 0.005;

struct Truth {
    deviations: [f64; 13],
    w: [[f64; 3]; 2],
    t: [[f64; 3]; 2],
    /// The LVDT's relative scale error.
    scale: f64,
    /// The errors of the set-up as entered: R_B, R′_B, R_C, Z_C (mm).
    entered_mm: [f64; 4],
}

/// The five steps of §5.3 measured on the forward model with the mounting errors and noise.
fn procedure(truth: &Truth, rng: &mut Rng) -> Vec<PatternMeasurement> {
    let steps = [
        (BallbarPattern::Bx, fwd::Pat::Bx, RB, 0, 0),
        (BallbarPattern::By, fwd::Pat::By, RB, 0, 0),
        (BallbarPattern::Cr, fwd::Pat::Cr, RB, 1, 0),
        (BallbarPattern::Ca, fwd::Pat::Ca, RB, 1, 0),
        (BallbarPattern::Cr, fwd::Pat::Cr, RB2, 1, 1),
    ];
    steps
        .iter()
        .map(|&(p, pf, rb, w, t)| {
            let [d_rb, d_rb2, d_rc, d_zc] = truth.entered_mm;
            let g = fwd::Geo {
                lb: LB,
                zc: ZC,
                rb,
                rc: RC,
            };
            let (e1, e2) = fwd::ecc(
                pf,
                &truth.deviations,
                &g,
                N_MEASURED,
                truth.t[t],
                truth.w[w],
            );
            PatternMeasurement {
                pattern: p,
                geometry: BallbarLengths {
                    l_b_mm: LB,
                    r_b_mm: rb + if t == 0 { d_rb } else { d_rb2 },
                    r_c_mm: RC + d_rc,
                    z_c_mm: ZC + d_zc,
                },
                samples: N_MODEL,
                e1_um: e1 * (1.0 + truth.scale) + U_ECC_UM * rng.normal(),
                e2_um: e2 * (1.0 + truth.scale) + U_ECC_UM * rng.normal(),
                sigma_um: U_ECC_UM,
            }
        })
        .collect()
}

/// The errors a Monte Carlo run draws: the balls' mounting (10–60 µm clamping shifts, the
/// T-ball's centring) or none, the LVDT's scale error, N(0, `scale`), and the set-up's lengths
/// as entered (R_B, R′_B, R_C, Z_C), each off by N(0, its `entered_mm`).
struct Errors {
    mounting: bool,
    scale: f64,
    entered_mm: [f64; 4],
}

/// Per free deviation: the share of runs whose |error| ≤ 2u, and rms(u) / rms(error). Each run
/// draws its `errors`; the pod states `budget` and `bar`.
fn monte_carlo(
    errors: &Errors,
    budget: &MountingUncertainty,
    bar: &BarBudget,
    seed: u64,
    runs: usize,
) -> Vec<(Parameter, f64, f64)> {
    // the machines' deviations from the forward model's generator, the rest from the tests' one
    let (mut machines, mut rng) = (fwd::Rng(seed), Rng::new(seed));
    // the entries' errors from a stream of their own: the other draws stay as they were
    let mut entries = Rng::new(seed ^ 0x05e7);
    let mut covered = [0usize; 13];
    let (mut err2, mut u2) = ([0.0f64; 13], [0.0f64; 13]);
    for _ in 0..runs {
        let mut deviations = machines.deviations();
        for p in [Parameter::GammaXy, Parameter::AlphaYz, Parameter::BetaYz] {
            deviations[p.index()] = 0.0;
        }
        let mounted = |v: [f64; 3]| if errors.mounting { v } else { [0.0; 3] };
        let truth = Truth {
            deviations,
            w: [clamping_shift(&mut rng), clamping_shift(&mut rng)].map(mounted),
            t: [t_ball_offset(&mut rng), t_ball_offset(&mut rng)].map(mounted),
            scale: errors.scale * rng.normal(),
            entered_mm: errors.entered_mm.map(|u| u * entries.normal()),
        };
        let m = procedure(&truth, &mut rng);
        let u_ecc = vec![[U_ECC_UM; 2]; m.len()];
        let (res, u) = ModelLsq::without_squareness()
            .identify_propagated(&m, &u_ecc, budget, bar)
            .unwrap();
        // What is identified includes the first tool length's T-ball offset (first order).
        let mut want = truth.deviations;
        want[Parameter::DxBt.index()] += truth.t[0][0];
        want[Parameter::DyCz.index()] -= truth.t[0][1];
        want[Parameter::DzBt.index()] += truth.t[0][2];
        let got = res.deviations.to_array();
        for p in ModelLsq::without_squareness().free_parameters() {
            let j = p.index();
            let e = got[j] - want[j];
            covered[j] += usize::from(e.abs() <= 2.0 * u.combined[j]);
            err2[j] += e * e;
            u2[j] += u.combined[j] * u.combined[j];
        }
    }
    ModelLsq::without_squareness()
        .free_parameters()
        .map(|p| {
            let j = p.index();
            (p, covered[j] as f64 / runs as f64, (u2[j] / err2[j]).sqrt())
        })
        .collect()
}

/// Each deviation's U covers the truth in 95 % ± 3 % of the runs, and u is within 20 % of the
/// scatter.
fn assert_calibrated(r: &[(Parameter, f64, f64)]) {
    for (p, coverage, ratio) in r {
        println!("{p:?}: coverage {coverage:.3}, rms u / rms error {ratio:.2}");
        assert!((0.92..=0.98).contains(coverage), "{p:?}: {coverage}");
        assert!((0.8..=1.2).contains(ratio), "{p:?}: {ratio}");
    }
}

/// The pod's default bar: its LVDT's scale known to 0.1 % (`lvdt_u_scale`).
const DEFAULT_BAR: BarBudget = BarBudget {
    offset_um: 0.6,
    scale: 1e-3,
};

/// Issue 14's criteria: with 10–60 µm clamping shifts (and the LVDT's scale off by 0.1 %
/// rms) U covers the ten deviations in ≥ 95 % of the runs on average and each in 95 % ± 3 %
/// (1 000 runs: a coverage's sampling standard deviation is 0.7 %, so a calibrated U's 95.4 %
/// reads 94–97 %), and u is within 20 % of the scatter.
#[test]
fn u_covers_the_deviations_with_the_balls_clamping_shifts() {
    let errors = Errors {
        mounting: true,
        scale: 1e-3,
        entered_mm: [0.0; 4],
    };
    let r = monte_carlo(
        &errors,
        &MountingUncertainty::SEED002,
        &DEFAULT_BAR,
        0x0c1a_3902,
        1000,
    );
    assert_calibrated(&r);
    let mean = r.iter().map(|(_, c, _)| c).sum::<f64>() / r.len() as f64;
    assert!(mean >= 0.95, "mean coverage {mean}");
}

/// Without the mounting budget the stated u (the eccentricities' alone) is far too small: the
/// Monte Carlo above detects it (the α_CZ of issue 14, 45u off).
#[test]
fn eccentricity_u_alone_does_not_cover_the_clamping_shifts() {
    let errors = Errors {
        mounting: true,
        scale: 0.0,
        entered_mm: [0.0; 4],
    };
    let r = monte_carlo(
        &errors,
        &MountingUncertainty::NONE,
        &BarBudget::NONE,
        0x0c1a_3903,
        100,
    );
    for (p, c, _) in &r {
        println!("{p:?}: coverage {c:.3} with the eccentricities' u alone");
    }
    let worst = r.iter().map(|(_, c, _)| *c).fold(1.0f64, f64::min);
    assert!(worst < 0.5, "{r:?}");
}

/// The LVDT's scale moves every eccentricity by k times itself — one input for all five steps.
/// With the scale off by 2 % rms (the balls mounted perfectly) U covers each deviation in
/// 95 % ± 3 % of 400 runs and u matches the scatter within 20 %; the eccentricities' u alone
/// covers the largest deviations in far fewer.
#[test]
fn u_covers_the_lvdt_scale() {
    let bar = BarBudget {
        offset_um: 0.0,
        scale: 0.02,
    };
    let errors = Errors {
        mounting: false,
        scale: 0.02,
        entered_mm: [0.0; 4],
    };
    let none = MountingUncertainty::NONE;
    let r = monte_carlo(&errors, &none, &bar, 0x0c1a_3904, 400);
    assert_calibrated(&r);
    let without = monte_carlo(&errors, &none, &BarBudget::NONE, 0x0c1a_3904, 400);
    for (p, c, _) in &without {
        println!("{p:?}: coverage {c:.3} without the scale's share");
    }
    let worst = without.iter().map(|(_, c, _)| *c).fold(1.0f64, f64::min);
    assert!(worst < 0.5, "{without:?}");
}

/// R_C and Z_C as entered are budgeted (`r_c_um`, `z_c_um`: every step's model moved by its u).
/// With R_C and Z_C entered off by N(0, 0.2 mm) and the budget saying so, on top of the
/// mounting errors and the default LVDT scale, U covers each deviation in 95 % ± 3 % of 1 000
/// runs and u matches the scatter within 20 %; with the default budget (10 µm) the C axis's
/// deviations are covered in about 80 % only.
#[test]
fn u_covers_r_c_and_z_c_as_entered() {
    let errors = Errors {
        mounting: true,
        scale: 1e-3,
        entered_mm: [0.0, 0.0, 0.2, 0.2],
    };
    let budget = MountingUncertainty {
        r_c_um: 200.0,
        z_c_um: 200.0,
        ..MountingUncertainty::SEED002
    };
    let r = monte_carlo(&errors, &budget, &DEFAULT_BAR, 0x0c1a_3905, 1000);
    assert_calibrated(&r);
    default_budget_falls_short(&errors, 0x0c1a_3905, "R_C and Z_C");
}

/// With the default budget (10 µm for each length as entered), 400 runs of `errors`: some
/// deviation is covered in under 90 % (`what`, the lengths, for the printout).
fn default_budget_falls_short(errors: &Errors, seed: u64, what: &str) {
    let r = monte_carlo(
        errors,
        &MountingUncertainty::SEED002,
        &DEFAULT_BAR,
        seed,
        400,
    );
    for (p, c, _) in &r {
        println!("{p:?}: coverage {c:.3} with {what} budgeted at 10 µm");
    }
    let worst = r.iter().map(|(_, c, _)| *c).fold(1.0f64, f64::min);
    assert!(worst < 0.9, "{r:?}");
}

/// The tool lengths as entered (R_B, R′_B) are budgeted (`r_b_um`: the model of every step run
/// with a length moved by its u, each length on its own). With R_B and R′_B entered off by
/// N(0, 0.5 mm) and the budget saying so, on top of the mounting errors, the default LVDT scale
/// and R_C, Z_C off by their default 10 µm, U covers each deviation in 95 % ± 3 % of 1 000 runs
/// and u matches the scatter within 20 %; with the default budget (10 µm) some deviation is
/// covered in under 90 % (the input matters at that size); and off by N(0, 0.1 mm), a tool
/// length known to a tenth, the default budget still covers them.
#[test]
fn u_covers_the_tool_lengths_as_entered() {
    let entered = |rb: f64| Errors {
        mounting: true,
        scale: 1e-3,
        entered_mm: [rb, rb, 0.01, 0.01],
    };
    let budget = MountingUncertainty {
        r_b_um: 500.0,
        ..MountingUncertainty::SEED002
    };
    let r = monte_carlo(&entered(0.5), &budget, &DEFAULT_BAR, 0x0c1a_3907, 1000);
    assert_calibrated(&r);
    default_budget_falls_short(&entered(0.5), 0x0c1a_3907, "R_B and R′_B");
    let r = monte_carlo(
        &entered(0.1),
        &MountingUncertainty::SEED002,
        &DEFAULT_BAR,
        0x0c1a_3906,
        1000,
    );
    assert_calibrated(&r);
}

/// A negative or non-finite input uncertainty is refused with the input named.
#[test]
fn bad_mounting_uncertainty_is_refused_with_the_input_named() {
    let mut rng = Rng::new(7);
    let truth = Truth {
        deviations: [0.0; 13],
        w: [[0.0; 3]; 2],
        t: [[0.0; 3]; 2],
        scale: 0.0,
        entered_mm: [0.0; 4],
    };
    let m = procedure(&truth, &mut rng);
    let u = vec![[U_ECC_UM; 2]; m.len()];
    for (budget, input) in [
        (
            MountingUncertainty {
                w_clamp_um: -1.0,
                ..MountingUncertainty::SEED002
            },
            MountingInput::WClamp,
        ),
        (
            MountingUncertainty {
                t_centring_um: f64::NAN,
                ..MountingUncertainty::SEED002
            },
            MountingInput::TCentring,
        ),
        (
            MountingUncertainty {
                t_axial_um: f64::INFINITY,
                ..MountingUncertainty::SEED002
            },
            MountingInput::TAxial,
        ),
        (
            MountingUncertainty {
                r_c_um: -0.5,
                ..MountingUncertainty::SEED002
            },
            MountingInput::RC,
        ),
        (
            MountingUncertainty {
                z_c_um: f64::NAN,
                ..MountingUncertainty::SEED002
            },
            MountingInput::ZC,
        ),
        (
            MountingUncertainty {
                r_b_um: -2.0,
                ..MountingUncertainty::SEED002
            },
            MountingInput::RB,
        ),
    ] {
        assert_eq!(
            ModelLsq::without_squareness()
                .identify_propagated(&m, &u, &budget, &DEFAULT_BAR)
                .map(|_| ()),
            Err(ModelLsqError::BadMountingUncertainty { input })
        );
    }
    for scale in [-1e-3, f32::NAN] {
        let bar = BarBudget {
            scale,
            ..DEFAULT_BAR
        };
        assert_eq!(
            ModelLsq::without_squareness()
                .identify_propagated(&m, &u, &MountingUncertainty::SEED002, &bar)
                .map(|_| ()),
            Err(ModelLsqError::BadScaleUncertainty)
        );
    }
}
