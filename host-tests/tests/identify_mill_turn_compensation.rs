//! Seed 002 chapter 3 compensation (`identify::mill_turn::compensation`), checked with the
//! independent 4×4 products of `ballpod_host::forward_seed002` and the spec's check-script
//! vector for the literal eq 3.13.
use ballpod::identify::mill_turn::ballbar::ThesisDeviations;
use ballpod::identify::mill_turn::compensation::{
    CompensationError, CompensationMode, DxSplit, compensate, deviations_for_compensation,
};
use ballpod::identify::mill_turn::patterns::NcBlock;
use ballpod::identify::mill_turn::{Deviations, Parameter};
use ballpod_host::forward_seed002 as fwd;

const AS: f64 = 206_264.806_247_096_36;

/// Table 4.5 (printed values), δx difference all in δx_CZ, α_BT included: the deviation set of
/// seed002_checks.py part 5.
fn table_4_5() -> ThesisDeviations {
    ThesisDeviations {
        alpha_cz_arcsec: 1.10,
        beta_cz_arcsec: -25.16,
        alpha_xb_arcsec: -20.89,
        beta_xb_arcsec: -24.11,
        gamma_xb_arcsec: 5.63,
        alpha_bt_arcsec: 9.63,
        dx_cz_minus_dx_bt_um: 53.13,
        dy_cz_um: -45.63,
    }
}

fn block(x: f64, y: f64, z: f64, b: f64, c: f64) -> NcBlock {
    NcBlock {
        x_mm: x,
        y_mm: y,
        z_mm: z,
        b_deg: b,
        c_deg: c,
    }
}

/// Inverse of a rotation-only HTM (transpose) or general 4×4 via the host: E_C⁻¹ = E_C(−θ).
fn actual_and_ideal(d: &[f64; 13], b: &NcBlock) -> ([f64; 3], [f64; 3]) {
    fwd::actual_and_ideal(
        d,
        [b.x_mm, b.y_mm, b.z_mm],
        b.b_deg.to_radians(),
        b.c_deg.to_radians(),
    )
}

/// Spec seed002_checks.py part 5: literal eq 3.13 at X −390, Z −112.2605, B 10°, C 0 gives a
/// correction of (105.79, −70.58, 14.47) µm (≈ −2·G⁻¹e: the double correction).
#[test]
fn paper_mode_reproduces_check_script() {
    let d = deviations_for_compensation(&table_4_5(), DxSplit::AllInCz, true);
    let b = block(-390.0, 0.0, -112.2605, 10.0, 0.0);
    let c = compensate(&b, &d, CompensationMode::PaperDouble).unwrap();
    let corr = [
        (c.x_mm - b.x_mm) * 1e3,
        (c.y_mm - b.y_mm) * 1e3,
        (c.z_mm - b.z_mm) * 1e3,
    ];
    for (got, exp) in corr.iter().zip([105.79, -70.58, 14.47]) {
        assert!((got - exp).abs() < 0.006, "{corr:?}");
    }
    assert_eq!((c.b_deg, c.c_deg), (10.0, 0.0));
    // Once mode: about half of it (single correction), to second order.
    let o = compensate(&b, &d, CompensationMode::Once).unwrap();
    let once = [
        (o.x_mm - b.x_mm) * 1e3,
        (o.y_mm - b.y_mm) * 1e3,
        (o.z_mm - b.z_mm) * 1e3,
    ];
    for (a, p) in once.iter().zip(corr.iter()) {
        assert!((a - p / 2.0).abs() < 0.05, "{once:?} vs {corr:?}");
    }
}

/// Once mode: the actual chain (eq 3.7) at the corrected command lands exactly on the ideal
/// point (eq 3.4) of the original command; the correction is −(error) to first order.
#[test]
fn once_mode_round_trip() {
    let mut r = fwd::Rng(0xc0_3e4);
    for _ in 0..50 {
        let mut d = r.deviations();
        for p in [Parameter::GammaXy, Parameter::AlphaYz, Parameter::BetaYz] {
            d[p.index()] = 0.0;
        }
        let b = block(
            -490.0 + 200.0 * r.uniform(),
            50.0 * r.uniform(),
            -300.0 + 200.0 * r.uniform(),
            90.0 * r.uniform().abs(),
            180.0 * r.uniform(),
        );
        let c = compensate(&b, &Deviations::from_array(&d), CompensationMode::Once).unwrap();
        let (act_c, _) = actual_and_ideal(&d, &c);
        let (act, ideal) = actual_and_ideal(&d, &b);
        for k in 0..3 {
            assert!(
                (act_c[k] - ideal[k]).abs() < 1e-10,
                "{k}: {} vs {}",
                act_c[k],
                ideal[k]
            );
        }
        // First order: correction = −G⁻¹(P' − P), G = E_C⁻¹E_B (a rotation): check the norm.
        let err: f64 = (0..3)
            .map(|k| (act[k] - ideal[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        let corr =
            ((c.x_mm - b.x_mm).powi(2) + (c.y_mm - b.y_mm).powi(2) + (c.z_mm - b.z_mm).powi(2))
                .sqrt();
        assert!(
            (err - corr).abs() < 1e-3 * err.max(1e-6) + 1e-7,
            "{err} vs {corr}"
        );
    }
}

#[test]
fn no_deviation_no_correction_and_bad_input() {
    let b = block(-390.0, 1.0, -112.0, 33.0, 45.0);
    for mode in [CompensationMode::Once, CompensationMode::PaperDouble] {
        let c = compensate(&b, &Deviations::default(), mode).unwrap();
        assert!(
            (c.x_mm - b.x_mm).abs() < 1e-12
                && (c.y_mm - b.y_mm).abs() < 1e-12
                && (c.z_mm - b.z_mm).abs() < 1e-12
        );
    }
    let nan = block(f64::NAN, 0.0, 0.0, 0.0, 0.0);
    assert_eq!(
        compensate(&nan, &Deviations::default(), CompensationMode::Once),
        Err(CompensationError::NonFinite)
    );
    let bad = Deviations {
        beta_cz_urad: f64::INFINITY,
        ..Deviations::default()
    };
    assert_eq!(
        compensate(&b, &bad, CompensationMode::PaperDouble),
        Err(CompensationError::NonFinite)
    );
}

#[test]
fn thesis_result_mapping() {
    let t = table_4_5();
    let d = deviations_for_compensation(&t, DxSplit::AllInBt, false);
    assert_eq!(d.dx_cz_um, 0.0);
    assert_eq!(d.dx_bt_um, -53.13);
    assert_eq!(d.alpha_bt_urad, 0.0);
    assert!((d.beta_xb_urad - (-24.11 / AS * 1e6)).abs() < 1e-9);
    assert_eq!(d.dz_bt_um, 0.0);
    let d = deviations_for_compensation(&t, DxSplit::AllInCz, true);
    assert_eq!(d.dx_cz_um, 53.13);
    assert!((d.alpha_bt_urad - 9.63 / AS * 1e6).abs() < 1e-9);
}
