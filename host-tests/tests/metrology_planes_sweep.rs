//! The three-plane summary's axis scales and the feed sweep's servo mismatch and feed limit
//! (`ballpod::metrology::iso230_4::{axis_scales, sweep_servo_mismatch, feed_limit}`) against
//! their closed forms, worked by hand.

use ballpod::metrology::iso230_4::{
    AxisScalesError, FeedLimitError, FeedPoint, PlaneScales, SUMMARY_PLANES, ScaleReading,
    axis_scales, feed_limit, sweep_servo_mismatch,
};

fn reading(value: f32) -> ScaleReading {
    ScaleReading { value, u: 1.0 }
}

#[test]
fn the_three_means_alone_give_each_axis_by_the_closed_form() {
    let k = [12.0f32, -4.0, 7.0];
    let planes = SUMMARY_PLANES.map(|(u, v)| PlaneScales {
        mean: reading((k[u] + k[v]) / 2.0),
        mismatch: None,
    });
    let s = axis_scales(&planes).unwrap();
    for (got, want) in s.scale_um_per_m.iter().zip(k) {
        assert!((got - want).abs() < 1e-4, "{got} vs {want}");
    }
    // k_x = m_XY + m_ZX − m_YZ, k_y = m_XY + m_YZ − m_ZX, k_z = m_YZ + m_ZX − m_XY
    let want = [
        [1.0, -1.0, 1.0, 0.0, 0.0, 0.0],
        [1.0, 1.0, -1.0, 0.0, 0.0, 0.0],
        [-1.0, 1.0, 1.0, 0.0, 0.0, 0.0],
    ];
    for (row, w) in s.sensitivity.iter().zip(want) {
        for (got, want) in row.iter().zip(w) {
            assert!((got - want).abs() < 1e-5, "{row:?}");
        }
    }
}

#[test]
fn a_mismatch_read_is_weighed_with_the_means() {
    // means all 0 (u 1), XY's mismatch 3 (u 1): by symmetry k = (a, −a, 0), and the squares
    // (a/2)² + (a/2)² + (2a − 3)² are least at a = 4/3: k_x − k_y = 8/3, between the means' 0
    // and the mismatch's 3
    let mut planes = SUMMARY_PLANES.map(|_| PlaneScales {
        mean: reading(0.0),
        mismatch: None,
    });
    planes[0].mismatch = Some(reading(3.0));
    let s = axis_scales(&planes).unwrap();
    let [kx, ky, kz] = s.scale_um_per_m;
    assert!((kx - ky - 8.0 / 3.0).abs() < 1e-4, "{kx} {ky}");
    assert!(kz.abs() < 1e-4 && (kx + ky).abs() < 1e-4, "{kx} {ky} {kz}");
    planes[1].mean.u = f32::NAN;
    assert_eq!(axis_scales(&planes), Err(AxisScalesError::BadReading));
}

fn point(feed: f32, g: f32, tau: f32) -> FeedPoint {
    FeedPoint {
        feed_mm_per_min: feed,
        g_bidir_um: [g, 0.1],
        servo_mismatch_ms: [tau, 0.01],
    }
}

#[test]
fn the_feed_limit_is_the_linear_crossing_of_the_stated_growth() {
    // G(b) 10, 11, 14 µm at 500, 1000, 2000 (any order): 20 % over 10 is 12, crossed a third
    // of the way from 1000 to 2000
    let p = [
        point(2000.0, 14.0, 1.0),
        point(500.0, 10.0, 1.0),
        point(1000.0, 11.0, 1.0),
    ];
    let [f, u] = feed_limit(&p, 0.2).unwrap();
    assert!((f - 4000.0 / 3.0).abs() < 0.1, "{f}");
    // u by hand, F = 1000 + 1000·(1.2·G_500 − G_1000)/(G_2000 − G_1000), each G(b) moved by
    // its 0.1 µm: G_500 → 1000·0.12/3 = 40; G_1000 → 1000·(0.9/2.9 − 1/3); G_2000 →
    // 1000·(1/3.1 − 1/3)
    let d0: f32 = 40.0;
    let d1: f32 = 1000.0 * (0.9 / 2.9 - 1.0 / 3.0);
    let d2: f32 = 1000.0 * (1.0 / 3.1 - 1.0 / 3.0);
    let want = (d0 * d0 + d1 * d1 + d2 * d2).sqrt();
    assert!((u - want).abs() < 0.01 * want, "{u} vs {want}");
    assert_eq!(feed_limit(&p, 0.5), Err(FeedLimitError::NotReached));
    // two feeds are no sweep (SWEEP_MIN_FEEDS)
    assert_eq!(feed_limit(&p[..2], 0.2), Err(FeedLimitError::TooFewFeeds));
}

#[test]
fn the_sweeps_servo_mismatch_is_the_weighted_mean() {
    let mut p = [
        point(500.0, 1.0, 1.0),
        point(1000.0, 1.0, 2.0),
        point(2000.0, 1.0, 1.5),
    ];
    p[1].servo_mismatch_ms[1] = 0.02;
    p[2].servo_mismatch_ms[1] = 0.02;
    let [tau, u] = sweep_servo_mismatch(&p).unwrap();
    // weights 1/0.01², 1/0.02², 1/0.02²: 4 : 1 : 1, (4·1 + 2 + 1.5)/6
    assert!((tau - 7.5 / 6.0).abs() < 1e-5, "{tau}");
    assert!(
        (u - (1.0f32 / (1e4 + 2.5e3 + 2.5e3)).sqrt()).abs() < 1e-6,
        "{u}"
    );
    // two feeds are no sweep (SWEEP_MIN_FEEDS)
    assert_eq!(sweep_servo_mismatch(&p[..2]), None);
}

/// Planes run with different bars are no one set-up: the scales, which rest on one bar's
/// length, are refused with the reason; each plane's squareness stays.
#[test]
fn planes_run_with_different_bars_give_no_scales() {
    use ballpod::app::planes::PlaneRecords;
    use ballpod::app::results::{ResultId, ResultSink, Results};
    use ballpod::metrology::pattern::Plane;
    let file = |records: &mut PlaneRecords, results: &mut Results, plane, bar_mm| {
        results.set(ResultId::Squareness, 10.0, 1.0);
        results.set(ResultId::ScaleMean, 5.0, 0.5);
        results.set(ResultId::ScaleMismatch, 2.0, 0.5);
        records.file(plane, bar_mm, results);
    };
    let mut results = Results::new();
    let mut one_bar = PlaneRecords::default();
    for plane in [Plane::XY, Plane::YZ, Plane::ZX] {
        file(&mut one_bar, &mut results, plane, 150.0);
    }
    assert!(results.get(ResultId::ScaleZ).valid);
    let mut results = Results::new();
    let mut two_bars = PlaneRecords::default();
    file(&mut two_bars, &mut results, Plane::XY, 150.0);
    file(&mut two_bars, &mut results, Plane::YZ, 150.0);
    file(&mut two_bars, &mut results, Plane::ZX, 100.0);
    for id in [ResultId::ScaleX, ResultId::ScaleY, ResultId::ScaleZ] {
        assert!(!results.get(id).valid, "{id:?}");
        assert!(
            two_bars
                .why_invalid(id)
                .is_some_and(|w| w.contains("different bar lengths")),
            "{id:?}"
        );
    }
    assert!(results.get(ResultId::SquarenessZx).valid);
    // the ZX arc run again with the first bar: one set-up again
    file(&mut two_bars, &mut results, Plane::ZX, 150.0);
    assert!(results.get(ResultId::ScaleZ).valid);
}
