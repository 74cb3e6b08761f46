//! The R-test head's combination of three LVDT channels (`ballpod_host::methods::rtest_head`)
//! against an independent f64 forward projection `r_k = n_k · q`.

use ballpod::acquisition::lvdt::{LvdtCalibration, LvdtReading, LvdtStatus};
use ballpod_host::methods::rtest_head::{RtestHead, RtestHeadError};
use ballpod_host::rng::Rng;
use ballpod_host::vmt::rtest_rig::RtestRig;

fn project(n: &[[f32; 3]; 3], q: [f64; 3]) -> [f32; 3] {
    n.map(|row| (0..3).map(|i| f64::from(row[i]) * q[i]).sum::<f64>() as f32)
}

#[test]
fn default_head_is_orthonormal_and_tilted_54_7_degrees_from_its_axis() {
    let n = RtestHead::default().directions();
    for i in 0..3 {
        for j in 0..3 {
            let d: f64 = (0..3)
                .map(|k| f64::from(n[i][k]) * f64::from(n[j][k]))
                .sum();
            let want = if i == j { 1.0 } else { 0.0 };
            assert!((d - want).abs() < 1e-6, "n{i}·n{j} = {d}");
        }
        let tilt = f64::from(n[i][2]).acos().to_degrees();
        assert!((tilt - 54.735_610_317).abs() < 1e-4, "tilt {tilt}");
    }
    // the default equals what the general constructor makes of the same directions
    let general = RtestHead::new(RtestHead::DEFAULT_DIRECTIONS).unwrap();
    let q = [12.5, -40.0, 7.25];
    let r = project(&n, q);
    let (a, b) = (
        RtestHead::default().displacement_um(r),
        general.displacement_um(r),
    );
    for i in 0..3 {
        assert!((f64::from(a[i]) - q[i]).abs() < 1e-4, "{a:?} vs {q:?}");
        assert!((a[i] - b[i]).abs() < 1e-4);
    }
}

#[test]
fn any_well_conditioned_arrangement_recovers_the_displacement() {
    let mut rng = Rng::new(7);
    let mut tried = 0;
    while tried < 200 {
        let n: [[f32; 3]; 3] = std::array::from_fn(|_| {
            let v = [rng.normal(), rng.normal(), rng.normal()];
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|x| (x / l) as f32)
        });
        let Ok(head) = RtestHead::new(n) else {
            continue;
        };
        tried += 1;
        let q = [
            100.0 * rng.normal(),
            100.0 * rng.normal(),
            100.0 * rng.normal(),
        ];
        let got = head.displacement_um(project(&n, q));
        // |det| ≥ 0.05 bounds the amplification of the f32 rounding of r (≈ 1e-5 µm)
        for i in 0..3 {
            assert!((f64::from(got[i]) - q[i]).abs() < 0.01, "{got:?} vs {q:?}");
        }
    }
}

#[test]
fn bad_arrangements_are_refused() {
    let d = RtestHead::DEFAULT_DIRECTIONS;
    let mut long = d;
    long[1] = [0.0, 0.0, 1.01];
    assert_eq!(
        RtestHead::new(long),
        Err(RtestHeadError::NotUnit { sensor: 1 })
    );
    let mut nan = d;
    nan[2] = [f32::NAN, 0.0, 1.0];
    assert_eq!(
        RtestHead::new(nan),
        Err(RtestHeadError::NotUnit { sensor: 2 })
    );
    // three directions in the XY plane
    let s = 0.5f32.sqrt();
    let coplanar = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [s, s, 0.0]];
    assert_eq!(RtestHead::new(coplanar), Err(RtestHeadError::Singular));
}

#[test]
fn one_bad_channel_invalidates_the_whole_reading() {
    let cal = LvdtCalibration {
        poly_um: [0.0, 2000.0, 0.0, 0.0],
        max_abs_ratio: 0.5,
        min_signal_level: 100.0,
    };
    let ok = |ratio: f32| {
        Some(LvdtReading {
            ratio,
            signal_level: 3000.0,
            iq_a: [0.0; 2],
            clipped: false,
        })
    };
    let head = RtestHead::default();
    let good = head.read(&cal, [ok(0.01), ok(-0.02), ok(0.005)]);
    assert!(good.is_valid());
    // r = 20, −40, 10 µm through Nᵀ
    let want = head.displacement_um([20.0, -40.0, 10.0]);
    for i in 0..3 {
        assert!((good.displacement_um[i] - want[i]).abs() < 1e-3);
    }
    let open = head.read(&cal, [ok(0.01), None, ok(0.005)]);
    assert!(!open.is_valid());
    assert_eq!(open.status[1], LvdtStatus::Open);
    assert_eq!(open.displacement_um, [0.0; 3]);
    let over = head.read(&cal, [ok(0.01), ok(-0.02), ok(0.9)]);
    assert_eq!(over.status[2], LvdtStatus::OverRange);
    assert_eq!(over.displacement_um, [0.0; 3]);
}

#[test]
fn through_the_lvdt_channels_the_head_reads_the_displacement() {
    // noise-free sensors, 0.5-count ADC noise: the demodulated, calibrated and combined
    // reading equals the true displacement within the ADC's resolution — one count of the
    // 3000-count amplitude sum is 0.67 µm, which a 100-sample block averages to ≈ 0.1 µm
    // per sensor (deterministic at a fixed position, so not reduced further by the dither)
    let mut rig = RtestRig::new(0.0, 3);
    for q in [[0.0, 0.0, 0.0], [50.0, -30.0, 12.0], [-200.0, 150.0, -80.0]] {
        let r = rig.sample(q);
        assert!(r.is_valid());
        for i in 0..3 {
            assert!(
                (f64::from(r.displacement_um[i]) - q[i]).abs() < 0.25,
                "{:?} vs {q:?}",
                r.displacement_um
            );
        }
    }
    assert_eq!(rig.invalid_samples, 0);
}
