//! `ballpod::num::sin_cos` (the pod's own f64 sine/cosine, written to keep libm's general
//! argument reduction out of flash) against the host's libm (`f64::sin_cos` of std, an
//! independent implementation) over the angles the pod meets and beyond; and the pod's own
//! selection `ballpod::num::select_f32` against std's sort.

use ballpod::num::{SIN_COS_MAX_RAD, cos, sin, sin_cos};

/// Distance in units in the last place, measured at the larger of |a|, 2^-60 (so values near
/// zero compare absolutely, as an angle error does).
fn ulps(a: f64, b: f64) -> f64 {
    let scale = a.abs().max(b.abs()).max(2f64.powi(-60));
    (a - b).abs() / (scale * f64::EPSILON)
}

#[test]
fn matches_std_within_two_ulp() {
    // Dense near the quadrant boundaries and zero, then a sweep up to the limit.
    let mut xs: Vec<f64> = Vec::new();
    for k in -40..=40 {
        let b = k as f64 * std::f64::consts::FRAC_PI_2;
        for d in [0.0, 1e-12, -1e-12, 1e-6, -1e-6, 0.3, -0.3, 0.785, -0.785] {
            xs.push(b + d);
        }
    }
    let mut x = 1e-300f64;
    while x < SIN_COS_MAX_RAD {
        xs.push(x);
        xs.push(-x * 1.000_37);
        x *= 1.013;
    }
    for i in 0..200_000 {
        xs.push(-7.0 + 14.0 * i as f64 / 200_000.0);
    }
    for &x in &xs {
        let (s, c) = sin_cos(x);
        let (rs, rc) = x.sin_cos();
        // Relative to 2 ulp, except within ~1e-18 of a root of sin/cos, where the neglected
        // fourth part of π/2 (8.5e-32 per quarter turn) is the error: absolute ≤ 1e-28·|x|.
        let ok = |a: f64, b: f64| ulps(a, b) <= 2.0 || (a - b).abs() <= 1e-28 * x.abs().max(1.0);
        assert!(
            ok(s, rs) && ok(c, rc),
            "x = {x:e}: ({s:e}, {c:e}) vs ({rs:e}, {rc:e})"
        );
        assert_eq!((sin(x), cos(x)), (s, c));
    }
}

#[test]
fn out_of_range_is_nan() {
    for x in [
        SIN_COS_MAX_RAD * 1.001,
        -1e9,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::NAN,
    ] {
        let (s, c) = sin_cos(x);
        assert!(s.is_nan() && c.is_nan(), "{x}");
    }
    let (s, c) = sin_cos(SIN_COS_MAX_RAD);
    assert!(s.is_finite() && c.is_finite());
}

/// `num::acos` against std's `f64::acos` over [−1, 1] (denser next to ±1, where the factored
/// form matters): within 2 ulp of the result or 1e-16 rad absolute; NaN outside.
#[test]
fn acos_matches_std() {
    let mut xs: Vec<f64> = (0..=20_000).map(|k| -1.0 + f64::from(k) * 1e-4).collect();
    for k in 1..60 {
        let d = 2f64.powi(-k);
        xs.extend([1.0 - d, -1.0 + d]);
    }
    xs.extend([-1.0, -0.0, 0.0, 1.0]);
    for x in xs {
        let (got, want) = (ballpod::num::acos(x), x.acos());
        assert!(
            ulps(got, want) <= 2.0 || (got - want).abs() <= 1e-16,
            "acos({x}) = {got}, std {want}"
        );
    }
    for x in [1.0 + 1e-15, -1.5, f64::NAN, f64::INFINITY] {
        assert!(ballpod::num::acos(x).is_nan(), "{x}");
    }
}

/// `ballpod::num::sqrt` (two Newton steps from the f32 root, written to keep libm's bit-loop
/// square root out of flash) against std's correctly rounded `f64::sqrt`: within 1 ulp over
/// every binade (subnormals to the largest finite), exact on perfect squares, and IEEE's
/// special cases.
#[test]
fn sqrt_matches_std_within_one_ulp() {
    use ballpod::num::sqrt;
    let mut worst = 0.0f64;
    let mut x = f64::from_bits(1); // the smallest subnormal
    let mut k = 0u64;
    while x < f64::MAX / 1.01 {
        for m in [1.0, 1.000_000_7, 1.37, 1.999_999, 2.5, 3.999_99] {
            let v = x * m;
            if v.is_finite() {
                let (got, want) = (sqrt(v), v.sqrt());
                let ulp = f64::from_bits(want.to_bits() + 1) - want;
                worst = worst.max((got - want).abs() / ulp);
            }
        }
        // pseudo-random mantissas too
        k = k
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        let v = f64::from_bits((x.to_bits() & 0xfff0_0000_0000_0000) | (k >> 12));
        let (got, want) = (sqrt(v), v.sqrt());
        let ulp = f64::from_bits(want.to_bits() + 1) - want;
        worst = worst.max((got - want).abs() / ulp);
        x *= 1.7;
    }
    assert!(worst <= 1.0, "worst {worst} ulp");
    for n in [1u64, 2, 3, 4, 9, 144, 1 << 20, 12345, (1 << 26) - 1] {
        let f = n as f64;
        assert_eq!(sqrt(f * f), f, "{n}");
    }
    assert_eq!(sqrt(0.0).to_bits(), 0.0f64.to_bits());
    assert_eq!(sqrt(-0.0).to_bits(), (-0.0f64).to_bits());
    assert_eq!(sqrt(f64::INFINITY), f64::INFINITY);
    assert!(sqrt(-1e-300).is_nan() && sqrt(f64::NAN).is_nan() && sqrt(f64::NEG_INFINITY).is_nan());
}

/// `select_f32` against a full sort (std's): every rank of random, duplicated, sorted,
/// reversed and constant slices, NaNs included (ordered last by `total_cmp`), and `None` out
/// of range.
#[test]
fn select_f32_is_the_sorted_slices_kth_value() {
    use ballpod::num::select_f32;
    let mut rng = ballpod_host::rng::Rng(77);
    let mut cases: Vec<Vec<f32>> = vec![
        vec![],
        vec![1.0],
        vec![0.0; 360],
        (0..300).map(|i| i as f32).collect(),
        (0..300).rev().map(|i| i as f32).collect(),
        vec![2.0, f32::NAN, -1.0, f32::NAN, 0.5],
    ];
    for n in [2, 3, 7, 64, 359] {
        cases.push((0..n).map(|_| rng.normal() as f32).collect());
        cases.push(
            (0..n)
                .map(|_| (rng.range(0.0, 4.0) as i32) as f32)
                .collect(),
        );
    }
    for case in cases {
        let mut sorted = case.clone();
        sorted.sort_by(f32::total_cmp);
        for k in 0..case.len() {
            let mut v = case.clone();
            let got = select_f32(&mut v, k).unwrap();
            assert_eq!(got.to_bits(), sorted[k].to_bits(), "rank {k} of {case:?}");
        }
        assert_eq!(select_f32(&mut case.clone(), case.len()), None);
    }
}
