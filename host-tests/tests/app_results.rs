//! The results table's uncertainty budget (`ballpod::app::Results`): each result keeps the
//! share of every contributor, u is their root sum of squares, and the three largest are
//! reported largest first — against values computed here by hand.
use ballpod::app::{Contributor, ResultId, ResultSink, Results};
use ballpod::metrology::bar_budget::{BarBudget, FigureKind};

#[test]
fn u_is_the_shares_in_quadrature_and_the_largest_three_come_first() {
    let mut r = Results::new();
    // 0.3² + 0.4² + 1.2² = 1.69
    r.set_budget(ResultId::DxBt, 12.0, [0.3, 0.0, 0.4, 1.2, 0.0, 0.0, 0.0]);
    let e = r.get(ResultId::DxBt);
    assert!((e.std_uncertainty - 1.3).abs() < 1e-6, "{e:?}");
    assert_eq!(
        e.largest_contributors(),
        [
            Some((Contributor::WBall, 1.2)),
            Some((Contributor::LvdtScale, 0.4)),
            Some((Contributor::TypeA, 0.3)),
        ]
    );
    // seven contributors: the smallest four are not among the three; equal shares keep their
    // order; the last contributor counts as the others
    r.set_budget(ResultId::DzBt, 1.0, [0.1, 0.5, 0.5, 0.05, 0.2, 0.15, 0.3]);
    assert_eq!(
        r.get(ResultId::DzBt).largest_contributors(),
        [
            Some((Contributor::BarOffset, 0.5)),
            Some((Contributor::LvdtScale, 0.5)),
            Some((Contributor::Socket, 0.3)),
        ]
    );
    // one contributor; a negative share counts by its size
    r.set_budget(ResultId::R0, -3.0, [-0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let e = r.get(ResultId::R0);
    assert_eq!(e.std_uncertainty, 0.2);
    assert_eq!(
        e.largest_contributors(),
        [Some((Contributor::TypeA, 0.2)), None, None]
    );
    // set: all of u is Type A; not evaluated: no contributor
    r.set(ResultId::EccU, 1.5, 0.25);
    assert_eq!(
        r.get(ResultId::EccU).largest_contributors(),
        [Some((Contributor::TypeA, 0.25)), None, None]
    );
    r.set(ResultId::EccV, 1.5, f64::NAN);
    let e = r.get(ResultId::EccV);
    assert!(e.valid && e.std_uncertainty.is_nan());
    assert_eq!(e.largest_contributors(), [None; 3]);
    // a value that is not finite: invalid, whatever its budget
    r.set_budget(ResultId::EccV, f64::NAN, [1.0; 7]);
    assert!(!r.get(ResultId::EccV).valid);
}

/// A figure from ΔL: its own u, the LVDT's scale |value|·u_k, for a radial figure the bar's
/// offset (a shape figure has none), and the socket's share where it has one.
#[test]
fn a_figure_from_delta_l_carries_the_bars_shares() {
    let bar = BarBudget {
        offset_um: 0.6,
        scale: 2e-3,
    };
    let mut r = Results::new();
    r.set_with_bar(ResultId::R0, -50.0, [0.05, 0.08], &bar, FigureKind::Radial);
    let e = r.get(ResultId::R0);
    // |−50| · 0.002 = 0.1; √(0.05² + 0.6² + 0.1² + 0.08²), the socket's 0.08 its own
    let u = (0.05f32 * 0.05 + 0.36 + 0.01 + 0.0064).sqrt();
    assert!((e.std_uncertainty - u).abs() < 1e-6, "{e:?}");
    assert_eq!(
        e.largest_contributors(),
        [
            Some((Contributor::BarOffset, 0.6)),
            Some((Contributor::LvdtScale, 0.1)),
            Some((Contributor::Socket, 0.08)),
        ]
    );
    r.set_with_bar(ResultId::GCcw, 10.0, [0.05, 0.0], &bar, FigureKind::Shape);
    let e = r.get(ResultId::GCcw);
    assert!((e.std_uncertainty - (0.05f32 * 0.05 + 0.02 * 0.02).sqrt()).abs() < 1e-6);
    let [a, k, none] = e.largest_contributors();
    assert_eq!((a, none), (Some((Contributor::TypeA, 0.05)), None));
    let (c, share) = k.unwrap();
    assert_eq!(c, Contributor::LvdtScale);
    assert!((share - 0.02).abs() < 1e-7, "{share}");
}
