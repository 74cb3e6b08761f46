//! Regression tests of panic paths found in the release firmware by `.ci/panic-paths`
//! (issue 7): each once reachable from the core with inputs a validated configuration
//! excludes, but present in flash; the core now handles them without panicking.
use ballpod::acquisition::lvdt::{LvdtCalibration, LvdtReading, LvdtStatus};

/// `LvdtCalibration::displacement_um` clamped the ratio with `f32::clamp`, which panics when
/// its bounds are NaN or reversed. With a NaN or negative limit it now returns a value
/// (the bounds of an invalid calibration are not checked here: `Config::validate` does that).
#[test]
fn lvdt_displacement_with_a_degenerate_limit_does_not_panic() {
    let reading = LvdtReading {
        ratio: 0.3,
        signal_level: 1.0,
        iq_a: [0.0; 2],
        clipped: false,
    };
    for limit in [f32::NAN, -0.5, 0.0] {
        let cal = LvdtCalibration {
            poly_um: [0.0, 1000.0, 0.0, 0.0],
            max_abs_ratio: limit,
            min_signal_level: 0.1,
        };
        let (x, status) = cal.displacement_um(&reading);
        assert!(x.is_finite(), "limit {limit}: {x}");
        if limit.is_nan() {
            // No limit: the reading as it is, 1000 µm per unit ratio.
            assert_eq!((x, status), (300.0, LvdtStatus::Ok));
        } else {
            assert_eq!(status, LvdtStatus::OverRange);
        }
    }
}
