//! Point fits (issue 3 item 4): seed 002 TV-13 (sphere through the Fig 5.13 probe points) and
//! forward-model circles/spheres on arcs and caps, plus degenerate input.

use ballpod::metrology::point_fit::{PointFitError, fit_circle, fit_sphere};
use ballpod_host::forward_seed002::FIG_5_13;
use ballpod_host::oracle::Rng;

#[test]
fn tv13_sphere_fit_of_fig_5_13() {
    let f = fit_sphere(&FIG_5_13).unwrap();
    println!("{f:?}");
    // seed 002 TV-13: centre (−390.2175, −0.0005, −472.4176), R = 7.9106 mm, RMS 1.46 µm
    let want = [-390.2175, -0.0005, -472.4176];
    for (g, w) in f.centre_mm.iter().zip(want) {
        assert!((g - w).abs() <= 0.00005 + 1e-9, "centre {:?}", f.centre_mm);
    }
    assert!(
        (f.radius_mm - 7.9106).abs() <= 0.00005 + 1e-9,
        "R {}",
        f.radius_mm
    );
    assert!(
        (f.residual_rms_um - 1.46).abs() <= 0.005 + 1e-9,
        "RMS {}",
        f.residual_rms_um
    );
    assert_eq!(f.points, 21);
}

#[test]
fn circle_on_short_arc_and_sphere_on_cap_recover_forward_model() {
    let mut rng = Rng::new(5);
    // exact points on a 60° arc far from the origin: recovered to 1e-9 mm
    let (cx, cy, r) = (612.345, -987.654, 25.0);
    let arc: Vec<[f64; 2]> = (0..13)
        .map(|i| {
            let t = (20.0 + 5.0 * i as f64).to_radians();
            [cx + r * t.cos(), cy + r * t.sin()]
        })
        .collect();
    let f = fit_circle(&arc).unwrap();
    assert!((f.centre_mm[0] - cx).abs() < 1e-9 && (f.centre_mm[1] - cy).abs() < 1e-9);
    assert!((f.radius_mm - r).abs() < 1e-9 && f.residual_rms_um < 1e-6);
    // noisy 90° arc, σ = 1 µm: geometric fit, residual RMS ≈ σ·√((N−3)/N)
    let noisy: Vec<[f64; 2]> = (0..400)
        .map(|i| {
            let t = (90.0 * i as f64 / 399.0).to_radians();
            let rr = r + 1e-3 * rng.normal();
            [cx + rr * t.cos(), cy + rr * t.sin()]
        })
        .collect();
    let f = fit_circle(&noisy).unwrap();
    assert!((f.residual_rms_um - 1.0).abs() < 0.1, "{f:?}");
    assert!((f.radius_mm - r).abs() < 1e-3 && (f.centre_mm[0] - cx).abs() < 1e-3);

    // exact points on a 40° cap of a sphere
    let (c, rs) = ([-390.0, 12.5, -472.0], 7.9375);
    let mut cap = Vec::new();
    for i in 0..5 {
        for j in 0..8 {
            let pol = (10.0 * i as f64).to_radians();
            let az = (45.0 * j as f64).to_radians();
            cap.push([
                c[0] + rs * pol.sin() * az.cos(),
                c[1] + rs * pol.sin() * az.sin(),
                c[2] + rs * pol.cos(),
            ]);
        }
    }
    let f = fit_sphere(&cap).unwrap();
    for (g, w) in f.centre_mm.iter().zip(c) {
        assert!((g - w).abs() < 1e-9);
    }
    assert!((f.radius_mm - rs).abs() < 1e-9);
}

#[test]
fn degenerate_point_sets() {
    assert_eq!(
        fit_circle(&[[0.0, 0.0], [1.0, 0.0]]),
        Err(PointFitError::TooFewPoints { have: 2, need: 3 })
    );
    assert_eq!(
        fit_sphere(&[[0.0; 3]; 3]),
        Err(PointFitError::TooFewPoints { have: 3, need: 4 })
    );
    let line: Vec<[f64; 2]> = (0..10).map(|i| [i as f64, 2.0 * i as f64 + 1.0]).collect();
    assert_eq!(fit_circle(&line), Err(PointFitError::Degenerate));
    assert_eq!(fit_circle(&[[1.0, 1.0]; 5]), Err(PointFitError::Degenerate));
    // coplanar points (a circle in space): infinitely many spheres
    let ring: Vec<[f64; 3]> = (0..12)
        .map(|i| {
            let t = (30.0 * i as f64).to_radians();
            [10.0 * t.cos(), 10.0 * t.sin(), 5.0]
        })
        .collect();
    assert_eq!(fit_sphere(&ring), Err(PointFitError::Degenerate));
    let mut nan = ring.clone();
    nan[3][1] = f64::NAN;
    assert_eq!(fit_sphere(&nan), Err(PointFitError::NotFinite));
}

/// The Kåsa start (biased on short arcs and caps: it shrinks the radius) only has to put
/// Gauss–Newton in the geometric fit's basin. 300 noisy caps of 15–60° (half-angle, 0.5–2 µm
/// per point, 9–30 points) and 300 arcs of 20–90°: every fit converges, and to a minimum of
/// the geometric distances — the gradient of Σ(|p − c| − R)² is zero there, checked here
/// independently of the fit.
#[test]
fn short_noisy_caps_and_arcs_converge_to_the_geometric_fit() {
    let mut rng = Rng::new(52);
    for case in 0..300 {
        let c = [
            rng.range(-500.0, 500.0),
            rng.range(-500.0, 500.0),
            rng.range(-500.0, 0.0),
        ];
        let rs = rng.range(3.0, 13.0);
        let cap_deg = rng.range(15.0, 60.0);
        let sigma = rng.range(0.5e-3, 2e-3);
        let n = 9 + (case % 22);
        let pts: Vec<[f64; 3]> = (0..n)
            .map(|_| {
                let pol = rng.range(0.0, cap_deg).to_radians();
                let az = rng.range(0.0, 360.0).to_radians();
                let r = rs + sigma * rng.normal();
                [
                    c[0] + r * pol.sin() * az.cos(),
                    c[1] + r * pol.sin() * az.sin(),
                    c[2] + r * pol.cos(),
                ]
            })
            .collect();
        let f = fit_sphere(&pts).unwrap_or_else(|e| panic!("cap {case}: {e:?}"));
        // ∂/∂c Σ r_i² = −2 Σ r_i (p_i − c)/|p_i − c|, ∂/∂R = −2 Σ r_i: both zero at the minimum
        let mut grad = [0.0f64; 4];
        for p in &pts {
            let d: [f64; 3] = std::array::from_fn(|k| p[k] - f.centre_mm[k]);
            let dn = d.iter().map(|v| v * v).sum::<f64>().sqrt();
            let r = dn - f.radius_mm;
            for k in 0..3 {
                grad[k] += r * d[k] / dn;
            }
            grad[3] += r;
        }
        let g = grad.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(g < 1e-9, "cap {case}: gradient {grad:?}");
        // and the truth is within a plausible distance (a short cap's centre is poorly known)
        let err = (0..3)
            .map(|k| (f.centre_mm[k] - c[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(err < 2.0, "cap {case}: centre {err} mm off");
    }
    for case in 0..300 {
        let (cx, cy) = (rng.range(-800.0, 800.0), rng.range(-800.0, 800.0));
        let r = rng.range(5.0, 150.0);
        let arc = rng.range(20.0, 90.0);
        let start = rng.range(0.0, 360.0);
        let sigma = rng.range(0.5e-3, 2e-3);
        let pts: Vec<[f64; 2]> = (0..40)
            .map(|i| {
                let t = (start + arc * i as f64 / 39.0).to_radians();
                let rr = r + sigma * rng.normal();
                [cx + rr * t.cos(), cy + rr * t.sin()]
            })
            .collect();
        let f = fit_circle(&pts).unwrap_or_else(|e| panic!("arc {case}: {e:?}"));
        let mut grad = [0.0f64; 3];
        for p in &pts {
            let d = [p[0] - f.centre_mm[0], p[1] - f.centre_mm[1]];
            let dn = d[0].hypot(d[1]);
            let res = dn - f.radius_mm;
            grad[0] += res * d[0] / dn;
            grad[1] += res * d[1] / dn;
            grad[2] += res;
        }
        let g = grad.iter().fold(0.0f64, |a, v| a.max(v.abs()));
        assert!(g < 1e-9, "arc {case}: gradient {grad:?}");
    }
}
