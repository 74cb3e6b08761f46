//! SSM (issue 3 item 1) against seed 000 C.1 (TV-SSM-1, TV-SSM-2, TV-SSM-cond) and forward
//! models of the ball bar: station mode, dwell detection, streaming mode, bad input.

use ballpod::acquisition::{Sample, SampleFlags};
use ballpod::app::ssm::{FIXED_POSITION_U_UM, SsmMeasurement, TwoStep};
use ballpod::app::{Contributor, ResultId, Results};
use ballpod::config::U_SOCKET_UM;
use ballpod::config::{TestSetup, TwoStepMachine};
use ballpod::metrology::bar_budget::BarBudget;
use ballpod::metrology::ssm::station::{
    DwellConfig, DwellEvent, Station, StationCollector, refine, solve_stations, station_covariance,
};
use ballpod::metrology::ssm::streaming::{StreamUse, StreamingConfig, StreamingSsm};
use ballpod::metrology::ssm::{SsmError, SsmGeometry};
use ballpod_host::forward_seed000 as fwd;
use ballpod_host::oracle::Rng;

fn norm(v: [f64; 3]) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// Stations whose ΔL is the exact bar reading |P − P0 + E| − L (forward model), µm.
fn exact_stations(p0: [f64; 3], l: f64, pts: &[[f64; 3]], e_mm: [f64; 3]) -> Vec<Station> {
    pts.iter()
        .map(|p| {
            let a = [
                p[0] - p0[0] + e_mm[0],
                p[1] - p0[1] + e_mm[1],
                p[2] - p0[2] + e_mm[2],
            ];
            Station {
                p_mm: *p,
                delta_l_um: (norm(a) - l) * 1e3,
                samples: 1,
                ..Default::default()
            }
        })
        .collect()
}

fn assert_e(got: [Option<f64>; 3], want: [f64; 3], tol: f64, what: &str) {
    for k in 0..3 {
        let g = got[k].expect("observable");
        assert!(
            (g - want[k]).abs() <= tol,
            "{what}: E[{k}] = {g}, want {} ± {tol}",
            want[k]
        );
    }
}

#[test]
fn tv_ssm_1_symmetric_layout() {
    let p0 = [0.0; 3];
    let l = 150.0;
    let pts = [
        [0.0, 0.0, 150.0],
        [26.047227, 0.0, 147.721163],
        [0.0, 26.047227, 147.721163],
    ];
    let e = [0.010, -0.020, 0.015];
    let geom = SsmGeometry {
        socket_mm: p0,
        bar_length_mm: l,
    };
    // linear-model Δl (u·E, seed 000: (0.015, 0.016508598, 0.011299153) mm): eq (1) returns E to 1e-12 mm
    let lin: Vec<Station> = pts
        .iter()
        .map(|p| {
            let ln = norm(*p);
            let dl = (p[0] * e[0] + p[1] * e[1] + p[2] * e[2]) / ln;
            Station {
                p_mm: *p,
                delta_l_um: (dl + ln - l) * 1e3,
                samples: 1,
                ..Default::default()
            }
        })
        .collect();
    let want_lin = [0.015, 0.016508598, 0.011299153];
    for (st, w) in lin.iter().zip(want_lin) {
        let ln = norm(st.p_mm);
        assert!((st.delta_l_um * 1e-3 + l - ln - w).abs() < 1e-9);
    }
    let s = solve_stations(&lin, &geom).unwrap();
    assert_e(s.e_um, [10.0, -20.0, 15.0], 1e-9, "TV-SSM-1 linear");
    // exact Δl: (0.015001666, 0.016510106, 0.011301144) mm; eq (1) gives (9.9992, −19.9980, 15.0017) µm
    let ex = exact_stations(p0, l, &pts, e);
    for (st, w) in ex.iter().zip([0.015001666, 0.016510106, 0.011301144]) {
        assert!((st.delta_l_um * 1e-3 + l - norm(st.p_mm) - w).abs() < 6e-10);
    }
    let s = solve_stations(&ex, &geom).unwrap();
    assert_e(
        s.e_um,
        [9.9992, -19.9980, 15.0017],
        6e-5,
        "TV-SSM-1 eq 1 on exact Δl",
    );
    assert!((s.cond - 19.9).abs() < 0.05, "cond {}", s.cond);
    let g = refine(&ex, &geom, &s, 10).unwrap();
    assert_e(g.e_um, [10.0, -20.0, 15.0], 1e-6, "TV-SSM-1 Gauss–Newton");
    assert!(g.iterations <= 4);
}

#[test]
fn tv_ssm_2_non_symmetric() {
    let p0 = [100.0, -50.0, 20.0];
    let pts = [
        [180.0, -50.0, 147.0],
        [190.0, -30.0, 140.0],
        [170.0, -25.0, 150.0],
    ];
    let e = [-0.004, 0.007, 0.012];
    for &l in &[150.0, 149.5] {
        // any calibrated L: ΔL is relative to it, y = ΔL + (L − l_n)
        let geom = SsmGeometry {
            socket_mm: p0,
            bar_length_mm: l,
        };
        let st = exact_stations(p0, l, &pts, e);
        for ((s, ln), dl) in st
            .iter()
            .zip([150.096636, 151.327460, 149.749791])
            .zip([8.021981, 8.062463, 9.716590])
        {
            let d = [s.p_mm[0] - p0[0], s.p_mm[1] - p0[1], s.p_mm[2] - p0[2]];
            assert!((norm(d) - ln).abs() < 6e-7);
            assert!((s.delta_l_um + (l - norm(d)) * 1e3 - dl).abs() < 6e-7);
        }
        let lin = solve_stations(&st, &geom).unwrap();
        assert_e(
            lin.e_um,
            [-3.999287, 6.999669, 12.000120],
            1e-6,
            "TV-SSM-2 eq 1",
        );
        let g = refine(&st, &geom, &lin, 10).unwrap();
        assert_e(g.e_um, [-4.0, 7.0, 12.0], 1e-6, "TV-SSM-2 Gauss–Newton");
        assert!(g.residual_rms_um < 1e-6);
    }
}

#[test]
fn tv_ssm_cond_frobenius() {
    let l = 150.0;
    let geom = SsmGeometry {
        socket_mm: [0.0; 3],
        bar_length_mm: l,
    };
    for (th, want) in [(30.0f64, 6.7), (10.0, 19.9), (5.0, 39.7), (2.0, 99.2)] {
        let t = th.to_radians();
        let pts = [
            [0.0, 0.0, l],
            [l * t.sin(), 0.0, l * t.cos()],
            [0.0, l * t.sin(), l * t.cos()],
        ];
        let st = exact_stations(geom.socket_mm, l, &pts, [0.01, -0.02, 0.015]);
        let s = solve_stations(&st, &geom).unwrap();
        assert!(
            (s.cond - want).abs() < 0.05,
            "θ={th}: cond {} want {want}",
            s.cond
        );
    }
}

#[test]
fn least_squares_from_more_stations_and_bad_layouts() {
    let p0 = [-250.0, 400.0, -300.0];
    let l = 150.0;
    let geom = SsmGeometry {
        socket_mm: p0,
        bar_length_mm: l,
    };
    let e = [0.0031, -0.0022, 0.0047];
    let dirs: [[f64; 3]; 6] = [
        [0.3, 0.1, 1.0],
        [-0.2, 0.3, 1.0],
        [0.1, -0.35, 1.0],
        [0.4, 0.4, 0.9],
        [-0.3, -0.2, 1.0],
        [0.0, 0.0, 1.0],
    ];
    let pts: Vec<[f64; 3]> = dirs
        .iter()
        .map(|d| {
            let n = norm(*d);
            [
                p0[0] + l * d[0] / n,
                p0[1] + l * d[1] / n,
                p0[2] + l * d[2] / n,
            ]
        })
        .collect();
    let st = exact_stations(p0, l, &pts, e);
    let s = refine(&st, &geom, &solve_stations(&st, &geom).unwrap(), 10).unwrap();
    assert_e(s.e_um, [3.1, -2.2, 4.7], 1e-6, "6 stations LSQ + GN");

    // coplanar stations (all in a plane through the socket): the normal component is unobservable
    let planar: Vec<[f64; 3]> = (0..5)
        .map(|i| {
            let a = (i as f64 * 20.0).to_radians();
            [p0[0] + l * a.cos(), p0[1] + l * a.sin(), p0[2]]
        })
        .collect();
    let st = exact_stations(p0, l, &planar, e);
    let s = solve_stations(&st, &geom).unwrap();
    assert_eq!(s.observable(), [true, true, false]);
    assert!(s.e_um[2].is_none());
    let v = s.unobservable_direction.unwrap();
    assert!(v[2].abs() > 1.0 - 1e-9);
    // in-plane components: linear error only |E|²/2L ≈ 0.1 nm here
    assert!((s.e_um[0].unwrap() - 3.1).abs() < 1e-3 && (s.e_um[1].unwrap() + 2.2).abs() < 1e-3);
    let g = refine(&st, &geom, &s, 10).unwrap();
    assert_eq!(g.observable(), [true, true, false]);
    // exact sphere equations with E_z unknown: GN with E_z = 0 fits x, y to the z-free model
    assert!((g.e_um[0].unwrap() - 3.1).abs() < 1e-3);

    // coincident stations, too few, at the socket, NaN
    let same = exact_stations(p0, l, &[pts[0], pts[0], pts[0], pts[0]], e);
    assert_eq!(solve_stations(&same, &geom), Err(SsmError::Degenerate));
    assert_eq!(
        solve_stations(&st[..2], &geom),
        Err(SsmError::TooFewObservations { have: 2, need: 3 })
    );
    let mut bad = st.clone();
    bad[1].p_mm = p0;
    assert_eq!(solve_stations(&bad, &geom), Err(SsmError::InvalidInput));
    let mut nan = st.clone();
    nan[0].delta_l_um = f64::NAN;
    assert_eq!(solve_stations(&nan, &geom), Err(SsmError::InvalidInput));
}

#[test]
fn dwell_detection_builds_stations() {
    // forward model: move between 4 points on the sphere (1 kHz samples), dwell 400 ms at each;
    // ΔL with 0.3 µm noise and a servo overshoot during the first 50 ms of each dwell
    let p0 = [100.0, 200.0, -400.0];
    let l = 150.0;
    let geom = SsmGeometry {
        socket_mm: p0,
        bar_length_mm: l,
    };
    let e = [0.004, 0.0065, -0.003];
    let dirs: [[f64; 3]; 4] = [
        [0.0, 0.0, 1.0],
        [0.5, 0.0, 0.866],
        [0.0, 0.5, 0.866],
        [-0.4, -0.4, 0.825],
    ];
    let mut rng = Rng::new(7);
    let mut samples = Vec::new();
    let mut t = 0u64;
    let mut pos = [p0[0], p0[1], p0[2] + l];
    let mut push = |p: [f64; 3], dl: f64, t: u64, flags| {
        samples.push(Sample {
            seq: samples.len() as u32,
            t_us: t,
            delta_l_um: dl as f32,
            axes: [p[0] as f32, p[1] as f32, p[2] as f32, 0.0, 0.0],
            temp_c: 20.0,
            flags,
        })
    };
    for (k, d) in dirs.iter().enumerate() {
        let n = norm(*d);
        let target = [
            p0[0] + l * d[0] / n,
            p0[1] + l * d[1] / n,
            p0[2] + l * d[2] / n,
        ];
        // move (straight line, 100 mm/s), then dwell
        let dist = norm([target[0] - pos[0], target[1] - pos[1], target[2] - pos[2]]);
        let steps = (dist / 0.1).ceil() as usize;
        for i in 1..=steps {
            let f = i as f64 / steps as f64;
            let p = [
                pos[0] + f * (target[0] - pos[0]),
                pos[1] + f * (target[1] - pos[1]),
                pos[2] + f * (target[2] - pos[2]),
            ];
            t += 1000;
            push(p, 50.0 * (k as f64 + 1.0), t, SampleFlags::NONE);
        }
        pos = target;
        let a = [
            pos[0] - p0[0] + e[0],
            pos[1] - p0[1] + e[1],
            pos[2] - p0[2] + e[2],
        ];
        let dl = (norm(a) - l) * 1e3;
        for i in 0..400 {
            t += 1000;
            let settle = if i < 50 {
                5.0 * (1.0 - i as f64 / 50.0)
            } else {
                0.0
            };
            let flags = if i == 200 {
                SampleFlags::LVDT_OVER_RANGE
            } else {
                SampleFlags::NONE
            };
            push(pos, dl + settle + 0.3 * rng.normal(), t, flags);
        }
    }
    t += 1000;
    push([pos[0] + 1.0, pos[1], pos[2]], 0.0, t, SampleFlags::NONE);
    let mut c = StationCollector::<8>::new(DwellConfig {
        max_speed_mm_per_s: 1.0,
        max_rotary_speed_deg_per_s: 0.1,
        settle_us: 100_000,
        min_samples: 100,
    });
    let mut closed = 0;
    for s in &samples {
        if c.update(s) == DwellEvent::DwellClosed {
            closed += 1;
        }
    }
    c.finish();
    assert_eq!(closed, 4);
    assert_eq!(c.stations().len(), 4);
    assert_eq!(c.skipped(), 4);
    for st in c.stations() {
        assert!(st.samples >= 295 && st.samples <= 300, "{}", st.samples);
        assert!((st.std_um - 0.3).abs() < 0.05);
    }
    let s = solve_stations(c.stations(), &geom).unwrap();
    let g = refine(c.stations(), &geom, &s, 10).unwrap();
    // noise: 0.3 µm/√300 per station, amplified by cond (~6)
    assert_e(g.e_um, [4.0, 6.5, -3.0], 0.15, "stations from dwells");

    // a full buffer counts its overruns
    let mut small = StationCollector::<2>::new(DwellConfig {
        max_speed_mm_per_s: 1.0,
        max_rotary_speed_deg_per_s: 0.1,
        settle_us: 100_000,
        min_samples: 100,
    });
    for s in &samples {
        small.update(s);
    }
    assert_eq!(small.stations().len(), 2);
    assert_eq!(small.dropped_full(), 2);
}

struct Path {
    samples: Vec<Sample>,
    truth: Vec<[f64; 3]>,
}

/// Smooth error field, µm (a few tenths of a µm per metre: what one neighbourhood can resolve).
fn field(p: [f64; 3], p0: [f64; 3], s: f64) -> [f64; 3] {
    let q = [
        (p[0] - p0[0]) / 1000.0,
        (p[1] - p0[1]) / 1000.0,
        (p[2] - p0[2]) / 1000.0,
    ];
    [
        5.0 + s * (2.0 * (2.0 * q[0]).sin() + 3.0 * q[1]),
        -8.0 + s * (4.0 * q[2] - 2.0 * q[0] * q[0]),
        12.0 + s * (3.0 * (3.0 * q[1]).cos() + 1.5 * q[0]),
    ]
}

/// Sample `i` (1 kHz) of a bar from the socket `p0` of length `l` to the nominal point `p`, the
/// machine `e_um` off it: ΔL = |p − p0 + e| − l (the exact sphere equation).
fn bar_sample(i: usize, p: [f64; 3], p0: [f64; 3], l: f64, e_um: [f64; 3]) -> Sample {
    let d: [f64; 3] = std::array::from_fn(|k| p[k] - p0[k] + e_um[k] * 1e-3);
    Sample {
        seq: i as u32,
        t_us: i as u64 * 1000,
        delta_l_um: ((norm(d) - l) * 1e3) as f32,
        axes: [p[0] as f32, p[1] as f32, p[2] as f32, 0.0, 0.0],
        temp_c: 20.0,
        flags: SampleFlags::NONE,
    }
}

fn cone_path(p0: [f64; 3], l: f64, half_angle_deg: f64, n: usize, s: f64) -> Path {
    let a = half_angle_deg.to_radians();
    let mut samples = Vec::new();
    let mut truth = Vec::new();
    for i in 0..n {
        let ph = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
        let p = [
            p0[0] + l * a.sin() * ph.cos(),
            p0[1] + l * a.sin() * ph.sin(),
            p0[2] + l * a.cos(),
        ];
        let e = field(p, p0, s);
        samples.push(bar_sample(i, p, p0, l, e));
        truth.push(e);
    }
    Path { samples, truth }
}

#[test]
fn streaming_on_cone_recovers_smooth_field() {
    let p0 = [320.0, -140.0, -480.0];
    let l = 150.0;
    let path = cone_path(p0, l, 30.0, 3600, 0.1);
    let mut ssm = StreamingSsm::<2048>::new(StreamingConfig {
        geometry: SsmGeometry {
            socket_mm: p0,
            bar_length_mm: l,
        },
        radius_mm: 140.0,
        rotary_tol_deg: 0.001,
    });
    let mut worst: f64 = 0.0;
    let mut live_worst: f64 = 0.0;
    let mut checked = 0;
    for (i, s) in path.samples.iter().enumerate() {
        assert_eq!(ssm.update(s), StreamUse::Used);
        if i >= 1800 && i % 7 == 0 {
            let est = ssm.estimate().unwrap();
            assert_eq!(est.solution.observable(), [true, true, true]);
            live_worst = live_worst.max(live_minus_estimate(&ssm));
            let want = field(est.centroid_mm, p0, 0.1);
            // and E at the sample itself (the window trails it by ~half its length)
            let at = path.truth[i];
            for ((got, w), a) in est.solution.e_um.iter().zip(want).zip(at) {
                worst = worst.max((got.unwrap() - w).abs());
                assert!((got.unwrap() - a).abs() < 0.1);
            }
            checked += 1;
        }
    }
    println!(
        "cone: {checked} estimates, worst |E − E(centroid)| = {worst:.4} µm, window {}",
        ssm.window_len()
    );
    assert!(worst < 0.1, "worst {worst}");
    assert!(live_worst < 0.005, "live vs f64: {live_worst} µm");
    assert_eq!(ssm.evicted_full(), 0);

    // a constant field is recovered to the f32 input resolution
    let path = cone_path(p0, l, 30.0, 3600, 0.0);
    let mut ssm = StreamingSsm::<2048>::new(StreamingConfig {
        geometry: SsmGeometry {
            socket_mm: p0,
            bar_length_mm: l,
        },
        radius_mm: 140.0,
        rotary_tol_deg: 0.001,
    });
    for s in &path.samples {
        ssm.update(s);
    }
    let est = ssm.estimate().unwrap();
    assert_e(est.solution.e_um, [5.0, -8.0, 12.0], 0.02, "constant field");
}

#[test]
fn streaming_planar_path_marks_out_of_plane_unobservable() {
    let p0 = [-100.0, 250.0, 50.0];
    let l = 150.0;
    let path = cone_path(p0, l, 90.0, 1440, 0.0); // circle in the XY plane of the socket
    let mut ssm = StreamingSsm::<512>::new(StreamingConfig {
        geometry: SsmGeometry {
            socket_mm: p0,
            bar_length_mm: l,
        },
        radius_mm: 120.0,
        rotary_tol_deg: 0.001,
    });
    assert_eq!(
        ssm.estimate().unwrap_err(),
        SsmError::TooFewObservations { have: 0, need: 3 }
    );
    for s in &path.samples {
        ssm.update(s);
    }
    let est = ssm.estimate().unwrap();
    assert_eq!(est.solution.observable(), [true, true, false]);
    assert!(est.solution.e_um[2].is_none());
    let live = ssm.live().unwrap();
    assert_eq!(
        live.map(|c| c.is_some()),
        [true, true, false],
        "live {live:?}"
    );
    assert!(live_minus_estimate(&ssm) < 0.005);
    assert!((est.solution.e_um[0].unwrap() - 5.0).abs() < 0.02);
    assert!((est.solution.e_um[1].unwrap() + 8.0).abs() < 0.02);

    // a rotary move empties the window; flagged / NaN samples are skipped and counted
    let mut s = path.samples[10];
    s.axes[3] = 15.0;
    assert_eq!(ssm.update(&s), StreamUse::UsedAfterRotaryMove);
    assert_eq!(ssm.window_len(), 1);
    assert!(matches!(
        ssm.estimate(),
        Err(SsmError::TooFewObservations { .. })
    ));
    assert!(matches!(
        ssm.live(),
        Err(SsmError::TooFewObservations { .. })
    ));
    let mut f = s;
    f.flags = SampleFlags::QUADRATURE_ERROR;
    assert_eq!(ssm.update(&f), StreamUse::SkippedFlagged);
    f.flags = SampleFlags::NONE;
    f.delta_l_um = f32::NAN;
    assert_eq!(ssm.update(&f), StreamUse::SkippedInvalid);
    f.delta_l_um = 0.0;
    f.axes = [p0[0] as f32, p0[1] as f32, p0[2] as f32, 15.0, 0.0];
    assert_eq!(ssm.update(&f), StreamUse::SkippedInvalid);
    assert_eq!((ssm.skipped_flagged(), ssm.skipped_invalid()), (1, 2));
    // a window that only ever sees one point: degenerate, not NaN
    for _ in 0..100 {
        ssm.update(&s);
    }
    assert_eq!(ssm.estimate().unwrap_err(), SsmError::Degenerate);
    assert_eq!(ssm.live().unwrap_err(), SsmError::Degenerate);
}

/// Issue 17: the largest difference between the live (f32, mean and scatter) and the f64
/// estimate of the same window, µm, over the components both call observable (and they must
/// agree on which those are).
fn live_minus_estimate<const W: usize>(ssm: &StreamingSsm<W>) -> f64 {
    let est = ssm.estimate().unwrap().solution.e_um;
    let live = ssm.live().unwrap();
    let mut worst: f64 = 0.0;
    for (e, l) in est.iter().zip(live) {
        match (e, l) {
            (Some(e), Some(l)) => worst = worst.max((f64::from(l) - e).abs()),
            (None, None) => {}
            _ => panic!("observability differs: f64 {est:?}, live {live:?}"),
        }
    }
    worst
}

#[test]
fn streaming_refinement_removes_linearisation_error() {
    // constant E of ~0.4 mm: eq (1) is off by ~|E|²/2L ≈ 0.5 µm; the exact sphere equation is not
    let p0 = [40.0, 60.0, -300.0];
    let l = 150.0;
    let e = [150.0, -220.0, 310.0];
    let a = 30.0f64.to_radians();
    let mut ssm = StreamingSsm::<1024>::new(StreamingConfig {
        geometry: SsmGeometry {
            socket_mm: p0,
            bar_length_mm: l,
        },
        radius_mm: 140.0,
        rotary_tol_deg: 0.001,
    });
    for i in 0..1800 {
        let ph = 2.0 * std::f64::consts::PI * i as f64 / 3600.0;
        let p = [
            p0[0] + l * a.sin() * ph.cos(),
            p0[1] + l * a.sin() * ph.sin(),
            p0[2] + l * a.cos(),
        ];
        let d = [
            p[0] - p0[0] + e[0] * 1e-3,
            p[1] - p0[1] + e[1] * 1e-3,
            p[2] - p0[2] + e[2] * 1e-3,
        ];
        ssm.update(&Sample {
            seq: i,
            t_us: 0,
            delta_l_um: ((norm(d) - l) * 1e3) as f32,
            axes: [p[0] as f32, p[1] as f32, p[2] as f32, 0.0, 0.0],
            temp_c: 20.0,
            flags: SampleFlags::NONE,
        });
    }
    let lin = ssm.estimate().unwrap().solution;
    // the live solve carries the same linearisation (|E| = 0.41 mm: a few nm of f32)
    assert!(live_minus_estimate(&ssm) < 0.01);
    let lin_err = (0..3)
        .map(|k| (lin.e_um[k].unwrap() - e[k]).abs())
        .fold(0.0, f64::max);
    assert!(lin_err > 0.2, "linear error {lin_err}");
    let refined = ssm.estimate_refined(3).unwrap().solution;
    assert_eq!(refined.iterations, 3);
    assert_e(refined.e_um, e, 0.02, "refined streaming");
    println!(
        "streaming |E| = 0.41 mm: linear error {lin_err:.3} µm, refined {:?}",
        refined.e_um
    );
}

#[test]
fn streaming_on_a_tilted_planar_arc_keeps_the_in_plane_component_observable_every_sample() {
    // A great-circle arc of the bar's sphere in the plane with normal n = (sin a, 0, cos a)
    // (the served pod's SSM arc between stations 2 and 3), axes read at the encoders' 0.1 µm
    // resolution, a 5 mm neighbourhood: E_y lies in the plane, so it is observable at every
    // sample (its validity must not flicker with the quantisation), E_x and E_z are not.
    let p0 = [10.0, -20.0, -150.0];
    let l = 150.0;
    let a = 31.0f64.to_radians();
    let (u, w) = ([a.cos(), 0.0, -a.sin()], [0.0, 1.0, 0.0]);
    let e_um = [3.0, -4.0, 2.0];
    let quantise = |x: f64| (x * 1e4).round() / 1e4;
    let mut ssm = StreamingSsm::<512>::new(StreamingConfig {
        geometry: SsmGeometry {
            socket_mm: p0,
            bar_length_mm: l,
        },
        radius_mm: 5.0,
        rotary_tol_deg: 0.001,
    });
    let n = 4000;
    let (mut checked, mut flicker) = (0, 0);
    for i in 0..n {
        let ph = std::f64::consts::FRAC_PI_2 * i as f64 / n as f64;
        let p: [f64; 3] =
            std::array::from_fn(|k| quantise(p0[k] + l * (ph.cos() * u[k] + ph.sin() * w[k])));
        assert_eq!(ssm.update(&bar_sample(i, p, p0, l, e_um)), StreamUse::Used);
        if i < 200 {
            continue;
        }
        let est = ssm.estimate().expect("estimate");
        let live = ssm.live().expect("live");
        assert!(
            live[0].is_none() && live[2].is_none(),
            "sample {i}: live out-of-plane {live:?}"
        );
        match live[1] {
            Some(ey) => assert!(
                (f64::from(ey) - e_um[1]).abs() < 0.2,
                "sample {i}: live E_y {ey}"
            ),
            None => flicker += 1,
        }
        let obs = est.solution.observable();
        assert!(
            !obs[0] && !obs[2],
            "sample {i}: out-of-plane mix observable {obs:?}"
        );
        match est.solution.e_um[1] {
            // within two encoder steps: the 0.1 µm quantisation over a 5 mm window
            Some(ey) => assert!((ey - e_um[1]).abs() < 0.2, "sample {i}: E_y {ey}"),
            None => flicker += 1,
        }
        checked += 1;
    }
    assert_eq!(
        flicker, 0,
        "E_y unobservable at {flicker} of {checked} samples"
    );
}

/// Where an SSM run's stations are: `count` dwells on a cone of `half_angle_deg` about +Z
/// through the socket `p0`, each up to `off_sphere_mm` off the sphere of the bar's length `l`.
struct Cone {
    p0: [f64; 3],
    l: f64,
    count: usize,
    half_angle_deg: f64,
    off_sphere_mm: f64,
}

/// An SSM run's stations as a bar reads them: on `cone` (random start); the exact ΔL
/// (forward model) passes through `bar` (the bar's own errors), then each dwell averages 50
/// samples of 0.4 µm noise and adds a fixed 0.1 µm error that dwelling does not average away.
fn dwell_stations(
    rng: &mut Rng,
    cone: &Cone,
    e_mm: [f64; 3],
    bar: impl Fn(f64) -> f64,
) -> Vec<Station> {
    let Cone {
        p0,
        l,
        count,
        half_angle_deg,
        off_sphere_mm,
    } = *cone;
    let phi0 = rng.range(0.0, std::f64::consts::TAU);
    let (s, c) = (
        half_angle_deg.to_radians().sin(),
        half_angle_deg.to_radians().cos(),
    );
    let pts: Vec<[f64; 3]> = (0..count)
        .map(|i| {
            let phi = phi0 + std::f64::consts::TAU * i as f64 / count as f64;
            let nominal = l + rng.range(-off_sphere_mm, off_sphere_mm);
            [
                p0[0] + nominal * s * phi.cos(),
                p0[1] + nominal * s * phi.sin(),
                p0[2] + nominal * c,
            ]
        })
        .collect();
    let mut st = exact_stations(p0, l, &pts, e_mm);
    for s in st.iter_mut() {
        let n = 50;
        let noise: Vec<f64> = (0..n).map(|_| 0.4 * rng.normal()).collect();
        let mean = noise.iter().sum::<f64>() / n as f64;
        let var = noise.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        s.delta_l_um = bar(s.delta_l_um) + mean + 0.1 * rng.normal();
        s.std_um = var.sqrt() as f32;
        s.samples = n as u32;
    }
    st
}

/// Issue 14: the stations' E states its covariance. 400 simulated SSM tests (6 stations on a
/// cone about the socket, true E of up to ±30 µm, each dwell 50 samples of 0.4 µm noise plus a
/// fixed 0.1 µm error that dwelling does not average away): U = 2u of each component covers the
/// truth in 95 % ± 3 %, and u matches the scatter within 20 %. With exactly three stations (no
/// redundancy) u comes from the stated σ_i alone.
#[test]
fn station_covariance_covers_the_truth() {
    let p0 = [100.0, 50.0, -20.0];
    let l = 150.0;
    let geom = SsmGeometry {
        socket_mm: p0,
        bar_length_mm: l,
    };
    for count in [6usize, 3] {
        let mut rng = Rng::new(14 + count as u64);
        let (mut covered, mut e2, mut u2) = ([0usize; 3], [0.0f64; 3], [0.0f64; 3]);
        const RUNS: usize = 400;
        for _ in 0..RUNS {
            let e_mm = [0; 3].map(|_| rng.range(-0.03, 0.03));
            let st = dwell_stations(
                &mut rng,
                &Cone {
                    p0,
                    l,
                    count,
                    half_angle_deg: 50.0,
                    off_sphere_mm: 0.2,
                },
                e_mm,
                |dl| dl,
            );
            let sol = solve_stations(&st, &geom).unwrap();
            let sol = refine(&st, &geom, &sol, 10).unwrap();
            let (cov, _) = station_covariance(&st, &geom, &sol, 0.1).unwrap();
            let u = [cov.a00, cov.a11, cov.a22].map(f64::sqrt);
            for k in 0..3 {
                let err = sol.e_um[k].unwrap() - e_mm[k] * 1e3;
                covered[k] += usize::from(err.abs() <= 2.0 * u[k]);
                e2[k] += err * err;
                u2[k] += u[k] * u[k];
            }
        }
        for k in 0..3 {
            let coverage = covered[k] as f64 / RUNS as f64;
            let ratio = (u2[k] / e2[k]).sqrt();
            println!(
                "{count} stations, E[{k}]: coverage {coverage:.3}, rms u / rms error {ratio:.3}"
            );
            assert!(
                (0.92..=0.98).contains(&coverage) && (0.8..=1.2).contains(&ratio),
                "{count} stations, E[{k}]: coverage {coverage:.3}, rms u / rms error {ratio:.3}"
            );
        }
    }
    // a stated floor that is negative or not finite is refused
    let st = exact_stations(
        p0,
        l,
        &[
            [250.0, 50.0, -20.0],
            [100.0, 200.0, -20.0],
            [100.0, 50.0, 130.0],
        ],
        [0.0; 3],
    );
    let sol = solve_stations(&st, &geom).unwrap();
    for bad in [-0.1, f64::NAN] {
        assert_eq!(
            station_covariance(&st, &geom, &sol, bad),
            Err(SsmError::InvalidInput)
        );
    }
}

/// An SSM run's measurement as the pod makes it at a run's end (solve, refine, covariance,
/// the bar's sensitivities).
fn measure(st: &[Station], geom: &SsmGeometry) -> SsmMeasurement {
    let sol = solve_stations(st, geom).unwrap();
    let solution = refine(st, geom, &sol, 10).unwrap();
    let (covariance_um2, bar) =
        station_covariance(st, geom, &solution, FIXED_POSITION_U_UM).unwrap();
    SsmMeasurement {
        solution,
        covariance_um2,
        bar,
    }
}

/// The bar of the Monte Carlo runs below: its length (calibration and temperature) known to
/// 0.6 µm, its LVDT's scale to 0.5 % (larger than the defaults, so that the bar dominates).
const BAR: BarBudget = BarBudget {
    offset_um: 0.6,
    scale: 0.005,
};

/// Draws one bar error from [`BAR`]: (offset µm, relative scale), normal.
fn draw_bar(rng: &mut Rng) -> (f64, f64) {
    (
        f64::from(BAR.offset_um) * rng.normal(),
        f64::from(BAR.scale) * rng.normal(),
    )
}

/// Draws where the socket is entered: the true socket `p0` off by N(0, `U_SOCKET_UM`) in each
/// coordinate, mm.
fn entered_socket(rng: &mut Rng, p0: [f64; 3]) -> [f64; 3] {
    p0.map(|x| x + U_SOCKET_UM * 1e-3 * rng.normal())
}

/// Issue 14: E carries the bar's own errors and the socket's as entered. 400 simulated SSM
/// runs (as above), each read by a bar whose length is off by δ ~ N(0, 0.6 µm) and whose LVDT
/// scale is off by k ~ N(0, 0.5 %) — the forward model reads ΔL·(1 + k) + δ at every station
/// — and told a socket off by N(0, 1 µm) per coordinate (the pod's default `ssm_u_socket`):
/// U = 2u of each component of E (stations, bar and socket) covers the truth in 95 % ± 3 %,
/// and u matches the scatter within 20 %. With the stations' share alone the bar's offset and
/// the socket, common to every station, are missed.
/// The stations sit within 20 µm of the bar's sphere, as the pod's station set puts them
/// (`ncgen` SSM). Far off the sphere the LVDT's scale error also shows in the stations'
/// scatter, which the Birge ratio then counts a second time: at ±0.2 mm and 0.5 % u came out
/// 1.4 times the scatter.
#[test]
fn the_bar_errors_move_e_and_its_u_covers_them() {
    let p0 = [-40.0, 120.0, 10.0];
    let l = 150.0;
    let geom = SsmGeometry {
        socket_mm: p0,
        bar_length_mm: l,
    };
    for (count, half_angle) in [(6usize, 50.0), (4, 35.0)] {
        let mut rng = Rng::new(1400 + count as u64);
        let (mut covered, mut covered_a) = ([0usize; 3], [0usize; 3]);
        let (mut e2, mut u2) = ([0.0f64; 3], [0.0f64; 3]);
        const RUNS: usize = 400;
        for _ in 0..RUNS {
            let e_mm = [0; 3].map(|_| rng.range(-0.03, 0.03));
            let (offset, k) = draw_bar(&mut rng);
            let bar = |dl: f64| dl * (1.0 + k) + offset;
            let st = dwell_stations(
                &mut rng,
                &Cone {
                    p0,
                    l,
                    count,
                    half_angle_deg: half_angle,
                    off_sphere_mm: 0.02,
                },
                e_mm,
                bar,
            );
            let entered = SsmGeometry {
                socket_mm: entered_socket(&mut rng, p0),
                ..geom
            };
            let m = measure(&st, &entered);
            let u = m.u_e_um(&BAR, U_SOCKET_UM as f32);
            let u_a = m.u_e_um(&BarBudget::NONE, 0.0);
            // the results the pod publishes: the socket's share in each component's budget
            let mut results = Results::new();
            ballpod::app::ssm::publish(&m, &BAR, U_SOCKET_UM as f32, &mut results);
            for (k, id) in [ResultId::SsmEx, ResultId::SsmEy, ResultId::SsmEz]
                .into_iter()
                .enumerate()
            {
                let r = results.get(id);
                assert_eq!(r.shares[Contributor::Socket as usize], U_SOCKET_UM as f32);
                assert!((f64::from(r.std_uncertainty) - u[k]).abs() < 1e-6 * u[k]);
            }
            for k in 0..3 {
                let err = m.solution.e_um[k].unwrap() - e_mm[k] * 1e3;
                covered[k] += usize::from(err.abs() <= 2.0 * u[k]);
                covered_a[k] += usize::from(err.abs() <= 2.0 * u_a[k]);
                e2[k] += err * err;
                u2[k] += u[k] * u[k];
            }
        }
        for k in 0..3 {
            let coverage = covered[k] as f64 / RUNS as f64;
            let coverage_a = covered_a[k] as f64 / RUNS as f64;
            let ratio = (u2[k] / e2[k]).sqrt();
            let what = format!(
                "{count} stations at {half_angle}°, E[{k}]: coverage {coverage:.3} \
                 (stations' u alone {coverage_a:.3}), rms u / rms error {ratio:.3}"
            );
            println!("{what}");
            assert!(
                (0.92..=0.98).contains(&coverage) && (0.8..=1.2).contains(&ratio),
                "{what}"
            );
        }
        // along the cone's axis the offset moves E by δ / cos(half angle); the socket moves
        // every component more than the stations' noise does
        for k in 0..3 {
            let coverage_a = covered_a[k] as f64 / RUNS as f64;
            assert!(
                coverage_a < 0.5,
                "the stations' u alone covers E[{k}] in {coverage_a:.3}"
            );
        }
    }
}

/// A two-step machine of the tests below: the pod's set-up and the seed's HTM forward model
/// (`forward_seed000`): from E after the translation and the true angle errors (rad), ΔV2 (mm).
struct TwoStepMachineCase {
    setup: TestSetup,
    /// The angles' results, in the order of the drawn angle errors.
    angles: &'static [ResultId],
    dv2_mm: fn(e1_mm: [f64; 3], d_rad: [f64; 2]) -> [f64; 3],
}

const D2R: f64 = std::f64::consts::PI / 180.0;

/// RTTTR table (Δα): Trans(p + e)·Rx(α)·r_t at α = 40°, r_t = (25, 70, 45) mm.
fn rtttr_table() -> TwoStepMachineCase {
    TwoStepMachineCase {
        setup: TestSetup {
            ts_machine: TwoStepMachine::RtttrTable,
            ts_reference_mm: [25.0, 70.0, 45.0],
            ts_origin_mm: [0.0; 3],
            ts_angles_deg: [40.0, f32::NAN],
            ..TestSetup::default()
        },
        angles: &[ResultId::TsDeltaAlpha],
        dv2_mm: |e1, [d, _]| {
            let r_t = [25.0, 70.0, 45.0];
            let nominal = fwd::rtttr_table_point([0.0; 3], [0.0; 3], 40.0 * D2R, r_t);
            let actual = fwd::rtttr_table_point([0.0; 3], e1, 40.0 * D2R + d, r_t);
            fwd::diff_um(actual, nominal).map(|x| x * 1e-3)
        },
    }
}

/// RRTTT head (Δα, Δβ): the tip z_r = −250 mm below the pivot (10, 20, 400) mm, at α = 30°,
/// β = 50°.
fn rrttt_head() -> TwoStepMachineCase {
    TwoStepMachineCase {
        setup: TestSetup {
            ts_machine: TwoStepMachine::Rrttt,
            ts_tool_z_mm: -250.0,
            ts_origin_mm: [10.0, 20.0, 400.0],
            ts_angles_deg: [30.0, 50.0],
            ..TestSetup::default()
        },
        angles: &[ResultId::TsDeltaAlpha, ResultId::TsDeltaBeta],
        dv2_mm: |e1, [d1, d2]| {
            let (p, a, b) = ([10.0, 20.0, 400.0], 30.0 * D2R, 50.0 * D2R);
            let nominal = fwd::rrttt_tip(p, [0.0; 3], a, b, -250.0);
            let actual = fwd::rrttt_tip(p, e1, a + d1, b + d2, -250.0);
            fwd::diff_um(actual, nominal).map(|x| x * 1e-3)
        },
    }
}

/// Issue 14: the seed 000 two-step from two SSM runs through the pod's pairing ([`TwoStep`]),
/// on an RTTTR table (Δα) and an RRTTT head (Δα, Δβ). One bar measures both runs, so its
/// errors move ΔV1 and ΔV2 together. 1 000 pairs per machine with random angle errors (±200
/// µrad), random E after the translation (±20 µm), each run's stations on a cone of random
/// half-angle (30–60°: the bar's offset moves the two runs differently, so it does not cancel),
/// one bar error per pair and one socket entered off by N(0, 1 µm) per coordinate for both
/// runs (one socket: its error moves ΔV1 and ΔV2 alike and cancels in the exact mode, so the
/// angles are those of the same stations read about the true socket within 1 % of u): U = 2u
/// of each angle covers the truth in 95 % ± 3 %, and u matches the scatter within 20 % (the
/// runs' full covariances are propagated, not each run's largest component).
#[test]
fn two_step_u_covers_one_bar_measuring_both_runs() {
    let p0 = [0.0, 0.0, 0.0];
    let l = 150.0;
    let geom = SsmGeometry {
        socket_mm: p0,
        bar_length_mm: l,
    };
    for (name, machine) in [("RTTTR table", rtttr_table()), ("RRTTT", rrttt_head())] {
        let mut rng = Rng::new(0x2057e9);
        const PAIRS: usize = 1000;
        let n = machine.angles.len();
        let (mut covered, mut e2, mut u2) = (vec![0usize; n], vec![0.0; n], vec![0.0; n]);
        let mut u_bar_share = vec![0.0; n];
        for _ in 0..PAIRS {
            let d_rad = [0; 2].map(|_| rng.range(-200e-6, 200e-6));
            let e1_mm = [0; 3].map(|_| rng.range(-0.02, 0.02));
            let dv2_mm = (machine.dv2_mm)(e1_mm, d_rad);
            let (offset, k) = draw_bar(&mut rng);
            let bar = |dl: f64| dl * (1.0 + k) + offset;
            let entered = SsmGeometry {
                socket_mm: entered_socket(&mut rng, p0),
                ..geom
            };
            let mut pair = TwoStep::default();
            let mut results = Results::new();
            let mut stations_only = Results::new();
            // the same stations read about the true socket: the angles must not move
            let (mut true_socket, mut about_true) = (TwoStep::default(), Results::new());
            for (i, e_mm) in [e1_mm, dv2_mm].into_iter().enumerate() {
                let cone = Cone {
                    p0,
                    l,
                    count: 6,
                    half_angle_deg: rng.range(30.0, 60.0),
                    off_sphere_mm: 0.02,
                };
                let stations = dwell_stations(&mut rng, &cone, e_mm, bar);
                let m = measure(&stations, &entered);
                true_socket
                    .on_measurement(
                        &machine.setup,
                        &measure(&stations, &geom),
                        &BAR,
                        &mut about_true,
                    )
                    .unwrap();
                let mut alone = pair;
                let done = pair
                    .on_measurement(&machine.setup, &m, &BAR, &mut results)
                    .unwrap();
                alone
                    .on_measurement(&machine.setup, &m, &BarBudget::NONE, &mut stations_only)
                    .unwrap();
                assert_eq!(done, i == 1);
            }
            for (j, &id) in machine.angles.iter().enumerate() {
                let r = results.get(id);
                assert!(r.valid);
                let (err, u) = (
                    f64::from(r.value) - d_rad[j] * 1e6,
                    f64::from(r.std_uncertainty),
                );
                covered[j] += usize::from(err.abs() <= 2.0 * u);
                e2[j] += err * err;
                u2[j] += u * u;
                let u_a = f64::from(stations_only.get(id).std_uncertainty);
                u_bar_share[j] += (u * u - u_a * u_a).max(0.0) / (u * u);
                let moved = f64::from(r.value - about_true.get(id).value);
                assert!(
                    moved.abs() < 0.01 * u,
                    "the socket moved {id:?} by {moved} µrad"
                );
            }
        }
        for (j, id) in machine.angles.iter().enumerate() {
            let coverage = covered[j] as f64 / PAIRS as f64;
            let ratio = (u2[j] / e2[j]).sqrt();
            let share = u_bar_share[j] / PAIRS as f64;
            let what = format!(
                "{name} {id:?}: coverage {coverage:.3}, rms u / rms error {ratio:.3}, \
                 the bar's share of u² {share:.2}"
            );
            println!("{what}");
            assert!(
                (0.92..=0.98).contains(&coverage) && (0.8..=1.2).contains(&ratio),
                "{what}"
            );
            // the bar is a real part of the budget here, not a rounding
            assert!(share > 0.1, "{what}");
        }
    }
}

/// Issue 17, bad input: the fast (live, f32) and the slow (f64) solve keep the validity rules —
/// flagged samples and NaN, ±inf or out-of-range values fed between the good ones change
/// neither, every sample (bit for bit against a stream that never saw them).
#[test]
fn bad_samples_between_good_ones_change_neither_the_live_nor_the_f64_solve() {
    let p0 = [-100.0, 250.0, 50.0];
    let l = 150.0;
    let path = cone_path(p0, l, 60.0, 720, 0.1);
    let config = StreamingConfig {
        geometry: SsmGeometry {
            socket_mm: p0,
            bar_length_mm: l,
        },
        radius_mm: 5.0,
        rotary_tol_deg: 0.001,
    };
    let mut clean = StreamingSsm::<256>::new(config);
    let mut fed = StreamingSsm::<256>::new(config);
    let (mut flagged, mut invalid) = (0, 0);
    for (i, s) in path.samples.iter().enumerate() {
        clean.update(s);
        fed.update(s);
        let mut bad = *s;
        match i % 6 {
            0 => bad.flags = SampleFlags::LVDT_OVER_RANGE,
            1 => bad.delta_l_um = f32::NAN,
            2 => bad.axes[0] = f32::INFINITY,
            3 => bad.axes[2] = f32::NEG_INFINITY,
            4 => bad.delta_l_um = 5_000.0, // |y| beyond MAX_ABS_Y_UM
            _ => bad.axes[4] = f32::NAN,
        }
        match fed.update(&bad) {
            StreamUse::SkippedFlagged => flagged += 1,
            StreamUse::SkippedInvalid => invalid += 1,
            other => panic!("sample {i}: {other:?}"),
        }
        assert_eq!(fed.live(), clean.live(), "live, sample {i}");
        assert_eq!(fed.estimate(), clean.estimate(), "f64, sample {i}");
    }
    assert_eq!((flagged, invalid), (120, 600));
    assert_eq!((fed.skipped_flagged(), fed.skipped_invalid()), (120, 600));
    assert!(clean.live().is_ok(), "{:?}", clean.live());
}

/// The oracle of one window of the live E, f64 (nalgebra's symmetric eigen-decomposition,
/// independent of the pod's sums and basis): the least squares u·E = y with
/// y = ΔL + l − |p − p0| over `samples`, on the eigen-directions of UᵀU above 10⁻⁹ of the
/// largest eigenvalue (the pod's observability rule), σ̂² = RSS/(n − rank) from the samples'
/// residuals (at least (0.1 µm)²/12), and E's response to y ≡ 1.
struct LiveOracle {
    e_um: [f64; 3],
    type_a_um: [f64; 3],
    offset_sensitivity: [f64; 3],
}

fn live_oracle(samples: &[Sample], p0: [f64; 3], l: f64) -> LiveOracle {
    use nalgebra::{Matrix3, Vector3};
    let rows: Vec<(Vector3<f64>, f64)> = samples
        .iter()
        .map(|s| {
            let d = Vector3::from(std::array::from_fn(|k| f64::from(s.axes[k]) - p0[k]));
            let r = d.norm();
            (d / r, f64::from(s.delta_l_um) + (l - r) * 1e3)
        })
        .collect();
    let g: Matrix3<f64> = rows.iter().map(|(u, _)| u * u.transpose()).sum();
    let eig = g.symmetric_eigen();
    let top = eig.eigenvalues.max();
    let mut pinv = Matrix3::zeros();
    let mut rank = 0;
    for (k, lam) in eig.eigenvalues.iter().enumerate() {
        if *lam > 1e-9 * top {
            let v = eig.eigenvectors.column(k);
            pinv += v * v.transpose() / *lam;
            rank += 1;
        }
    }
    let b: Vector3<f64> = rows.iter().map(|(u, y)| u * *y).sum();
    let ones: Vector3<f64> = rows.iter().map(|(u, _)| *u).sum();
    let e = pinv * b;
    let rss: f64 = rows.iter().map(|(u, y)| (y - u.dot(&e)).powi(2)).sum();
    let sigma2 = (rss / (rows.len() - rank) as f64).max(0.1f64.powi(2) / 12.0);
    let s = pinv * ones;
    LiveOracle {
        e_um: std::array::from_fn(|k| e[k]),
        type_a_um: std::array::from_fn(|k| (sigma2 * pinv[(k, k)]).sqrt()),
        offset_sensitivity: std::array::from_fn(|k| s[k]),
    }
}

/// Issue 14, the live E per sample: 400 windows of the pod's size (256 samples) on two paths —
/// a zigzag on the bar's sphere that sees all three components, and an arc in the socket's
/// plane that does not see the one across it — each with a constant E, i.i.d. noise of
/// 0.1–0.5 µm, a bar off by δ ~ N(0, 0.6 µm) in length and k ~ N(0, 0.5 %) in scale, and the
/// socket entered off by N(0, 1 µm) per coordinate. The live E's Type A u (within 1 %) and
/// its response to a constant offset (within 0.01 µm/µm) agree with an f64 eigen-solve of the
/// same samples about the entered socket; U = 2u of each seen component (with the bar's and
/// the socket's shares) covers the truth in 95 % ± 3 %, and u matches the scatter within
/// 20 %. A window of fewer than 30 degrees of freedom states E but no u.
#[test]
fn the_live_e_states_a_u_that_covers_the_truth() {
    use ballpod::metrology::ssm::streaming::LIVE_MIN_DOF;
    let p0 = [60.0, -30.0, -200.0];
    let l = 150.0;
    let config = StreamingConfig {
        geometry: SsmGeometry {
            socket_mm: p0,
            bar_length_mm: l,
        },
        radius_mm: 200.0,
        rotary_tol_deg: 0.01,
    };
    const RUNS: usize = 400;
    for zigzag in [true, false] {
        let mut rng = Rng::new(1414 + u64::from(zigzag));
        // the socket's entry errors from a stream of their own: the other draws stay as they were
        let mut socket = Rng::new(1416 + u64::from(zigzag));
        let (mut covered, mut e2, mut u2) = ([0usize; 3], [0.0f64; 3], [0.0f64; 3]);
        let (mut worst_a, mut worst_s): (f64, f64) = (0.0, 0.0);
        for _ in 0..RUNS {
            let e_um: [f64; 3] = std::array::from_fn(|_| rng.range(-30.0, 30.0));
            let noise = rng.range(0.1, 0.5);
            let (offset, k) = draw_bar(&mut rng);
            let start = rng.range(0.0, 360.0);
            let entered = entered_socket(&mut socket, p0);
            let mut ssm = StreamingSsm::<256>::new(StreamingConfig {
                geometry: SsmGeometry {
                    socket_mm: entered,
                    ..config.geometry
                },
                ..config
            });
            let mut fed = Vec::new();
            for i in 0..256 {
                let t = i as f64 / 256.0;
                // azimuth over 40°; polar angle 45° ± 12° three times over, or 90° (the plane)
                let (az, polar) = if zigzag {
                    let w = 12.0 * (6.0 * std::f64::consts::PI * t).sin();
                    (start + 40.0 * t, 45.0 + w)
                } else {
                    (start + 60.0 * t, 90.0)
                };
                let (az, polar) = (az.to_radians(), polar.to_radians());
                let p = [
                    p0[0] + l * polar.sin() * az.cos(),
                    p0[1] + l * polar.sin() * az.sin(),
                    p0[2] + l * polar.cos(),
                ];
                let mut s = bar_sample(i, p, p0, l, e_um);
                let dl = f64::from(s.delta_l_um);
                s.delta_l_um = (dl * (1.0 + k) + offset + noise * rng.normal()) as f32;
                assert_eq!(ssm.update(&s), StreamUse::Used);
                fed.push(s);
                let n = fed.len() as u32;
                let seen = if zigzag { 3 } else { 2 };
                if n == seen + LIVE_MIN_DOF - 1 {
                    // E, but one degree of freedom too few for its u
                    let mut u = [Some(1.0); 3];
                    let e = ssm.live_with_uncertainty(&BAR, 0.0, &mut u).unwrap();
                    assert!(e[0].is_some() && u == [None; 3]);
                }
                if n == seen + LIVE_MIN_DOF {
                    let mut u = [None; 3];
                    let e = ssm.live_with_uncertainty(&BAR, 0.0, &mut u).unwrap();
                    assert_eq!(u.map(|c| c.is_some()), e.map(|c| c.is_some()));
                }
            }
            // Type A alone (no bar), with a 1 µm offset alone (its share is the sensitivity),
            // and with the bar of the runs
            let with = |bar: &BarBudget, u_socket_um: f64| {
                let mut u = [None; 3];
                let e = ssm
                    .live_with_uncertainty(bar, u_socket_um as f32, &mut u)
                    .unwrap();
                (e, u)
            };
            let (e, u_a) = with(&BarBudget::NONE, 0.0);
            let unit_offset = BarBudget {
                offset_um: 1.0,
                scale: 0.0,
            };
            let (_, u_1) = with(&unit_offset, 0.0);
            let (_, combined) = with(&BAR, U_SOCKET_UM);
            assert_eq!(e, ssm.live().unwrap());
            assert_eq!(
                e.map(|c| c.is_some()),
                [true, true, zigzag],
                "{e:?} {:?} {:?}",
                ssm.estimate(),
                fed.last()
            );
            let oracle = live_oracle(&fed, entered, l);
            for c in 0..3 {
                let Some(v) = e[c] else {
                    assert!(u_a[c].is_none() && combined[c].is_none());
                    continue;
                };
                let (a, a_o) = (f64::from(u_a[c].unwrap()), oracle.type_a_um[c]);
                worst_a = worst_a.max((a / a_o - 1.0).abs());
                let s = (f64::from(u_1[c].unwrap()).powi(2) - a * a).max(0.0).sqrt();
                worst_s = worst_s.max((s - oracle.offset_sensitivity[c].abs()).abs());
                assert!((f64::from(v) - oracle.e_um[c]).abs() < 0.02 + 0.02 * a_o);
                let u = f64::from(combined[c].unwrap());
                let err = f64::from(v) - e_um[c];
                covered[c] += usize::from(err.abs() <= 2.0 * u);
                e2[c] += err * err;
                u2[c] += u * u;
            }
        }
        println!(
            "zigzag {zigzag}: Type A u vs f64 worst {worst_a:.4} (relative), offset \
             sensitivity worst {worst_s:.4}"
        );
        assert!(worst_a < 0.01 && worst_s < 0.01, "{worst_a} {worst_s}");
        for c in 0..if zigzag { 3 } else { 2 } {
            let coverage = covered[c] as f64 / RUNS as f64;
            let ratio = (u2[c] / e2[c]).sqrt();
            let what = format!(
                "zigzag {zigzag}, live E[{c}]: coverage {coverage:.3}, rms u / rms error \
                 {ratio:.3}"
            );
            println!("{what}");
            assert!(
                (0.92..=0.98).contains(&coverage) && (0.8..=1.2).contains(&ratio),
                "{what}"
            );
        }
    }
}

/// A wide window in the socket's plane (256 samples on arcs of 3–100°, every 5° of start
/// angle): the live f32 solve agrees with the f64 one in value (0.01 µm) and in what it sees —
/// E across the plane is not observable. Before the live solve's eigenvalue floor
/// (`LIVE_EIG_RESOLUTION`), 14 of 72 starts on the 60° arc read the rounding of its zero
/// across-plane eigenvalue as an observable direction and stated E off by up to 11 µm.
#[test]
fn a_wide_planar_arc_is_not_read_as_seeing_across_the_plane() {
    let p0 = [60.0f64, -30.0, -200.0];
    let l = 150.0;
    let e_um = [5.0, -3.0, 2.0];
    let mut checked = 0;
    for start in (0..72).map(|k| f64::from(k) * 5.0) {
        for arc in [3.0, 10.0, 30.0, 60.0, 100.0] {
            let mut ssm = StreamingSsm::<256>::new(StreamingConfig {
                geometry: SsmGeometry {
                    socket_mm: p0,
                    bar_length_mm: l,
                },
                radius_mm: 300.0,
                rotary_tol_deg: 0.01,
            });
            for i in 0..256 {
                let az = (start + arc * i as f64 / 256.0).to_radians();
                let p = [p0[0] + l * az.cos(), p0[1] + l * az.sin(), p0[2]];
                ssm.update(&bar_sample(i, p, p0, l, e_um));
            }
            let live = ssm.live().unwrap();
            let f64_e = ssm.estimate().unwrap().solution.e_um;
            assert_eq!(live[2], None, "start {start}°, arc {arc}°: live {live:?}");
            assert!(
                live_minus_estimate(&ssm) < 0.01,
                "start {start}°, arc {arc}°: live {live:?}, f64 {f64_e:?}"
            );
            checked += 1;
        }
    }
    assert_eq!(checked, 360);
}

/// Issue 14, the live E on the pod: SSM runs of the served machine's path (three dwells of 0.4
/// s on the bar's sphere, great-circle arcs between them at 2000 mm/min) through the virtual
/// pod's sensors (the LVDT's 12-bit ADC blocks, 0.2 µm of bar noise) and the application, E
/// drawn up to ±5 µm per component, the socket where it is entered (`ssm_u_socket` 0); the
/// machine stopping dead and accelerating at 1 m/s² (the samples bunched in front of a dwell,
/// above `ssm_dwell_speed`, enter the window). Where the pod states a component of the live E
/// with its u, U = 2u covers the truth in 95 % ± 3 % and rms(error / u) is 1 within 20 %: at
/// every sample, and while the window grows back after a dwell (its first 170 samples) at a
/// refreshed u and at the u held between refreshes. A still sample empties the live window
/// (`SsmRun::update`). When still samples entered it, the refreshed u covered 91.3 % there
/// (rms(error / u) 1.16); kept out but with the window held across the dwell, the held u
/// covered 93.1 % (rms 2.0): the window turned from the approach's arc to the departure's
/// faster than the u was refreshed. Restarted but refreshed every 32 samples while it grew, the
/// held u was a third high (coverage 98.5 %, rms 0.75): now every 4 while it grows
/// (`LIVE_U_EVERY_GROWING`).
#[test]
fn the_live_e_on_the_pod_covers_the_truth_around_dwells() {
    use ballpod_host::vmt::motion::SSM_ACCEL_MM_PER_S2;
    const RUNS: u64 = 100;
    // samples after a still one while the window grows back: the 5 mm radius at 2000 mm/min
    // (33 µm a sample) holds 150, and accelerating at 1 m/s² takes 17 more
    const REGROWING: usize = 170;
    for accel in [f64::INFINITY, SSM_ACCEL_MM_PER_S2] {
        live_e_around_dwells(RUNS, accel, REGROWING);
    }
}

/// [`the_live_e_on_the_pod_covers_the_truth_around_dwells`] for the machine accelerating at
/// `accel` mm/s², `runs` runs: the window counts as regrowing for `regrowing` samples after a
/// still one.
fn live_e_around_dwells(runs: u64, accel: f64, regrowing: usize) {
    use ballpod::app::{Command, Live, LiveValues, Pattern};
    use ballpod_host::vmt::motion::ssm_path;
    use ballpod_host::vmt::ssm_rig::SsmRig;
    // [covered, stated, Σ(error / u)²]: every sample, the window regrowing after a dwell at a
    // refreshed u, and there between refreshes
    let mut tally = [[0.0f64; 3]; 3];
    let mut rng = Rng::new(1414);
    for seed in 0..runs {
        let mut rig = SsmRig::new(0.2, seed);
        let e_um: [f64; 3] = core::array::from_fn(|_| rng.range(-5.0, 5.0));
        let socket = [100.0, 50.0, -200.0];
        let pod = &mut rig.pod;
        pod.app
            .configure(|c| {
                c.setup.ssm_socket_mm = socket.map(|v| v as f32);
                c.setup.ssm_u_socket_um = 0.0;
            })
            .unwrap();
        let path = ssm_path(e_um, pod.app.config(), accel).unwrap();
        pod.home(&path[0].axes);
        pod.app.set_pattern(Pattern::Ssm).unwrap();
        pod.execute(Command::Arm).unwrap();
        pod.execute(Command::Start).unwrap();
        let mut since_still = usize::MAX;
        let mut prev_u = [f32::NAN; 3];
        for (i, s) in path.iter().enumerate() {
            let still = i > 0 && s.axes == path[i - 1].axes;
            since_still = if still {
                0
            } else {
                since_still.saturating_add(1)
            };
            pod.sample_at(s.dl_um, &s.axes);
            let live: &LiveValues = pod.app.live();
            for (k, (ek, uk)) in [
                (Live::SsmEx, Live::USsmEx),
                (Live::SsmEy, Live::USsmEy),
                (Live::SsmEz, Live::USsmEz),
            ]
            .into_iter()
            .enumerate()
            {
                let (Some(e), Some(u)) = (live.get(ek), live.get(uk)) else {
                    continue;
                };
                // a u just refreshed (the pod holds it for LIVE_U_EVERY samples)
                let fresh = u != prev_u[k];
                prev_u[k] = u;
                let (d, u) = (f64::from(e) - e_um[k], f64::from(u));
                let near = since_still <= regrowing;
                for (t, counts) in tally.iter_mut().zip([true, near && fresh, near && !fresh]) {
                    if counts {
                        t[0] += f64::from(u8::from(d.abs() <= 2.0 * u));
                        t[1] += 1.0;
                        t[2] += (d / u) * (d / u);
                    }
                }
            }
        }
    }
    let [all, near, held] = tally.map(|[c, n, z2]| (c / n, (z2 / n).sqrt(), n));
    // u against the error in each window: rms(error / u) is 1 for an honest u; within 20 % of
    // it is u within 20 % of the scatter
    for (what, (coverage, rms, n)) in [
        ("every sample", all),
        ("regrowing after a dwell, refreshed", near),
        ("regrowing after a dwell, held", held),
    ] {
        println!(
            "accel {accel} mm/s², {what}: {n} stated, coverage {coverage:.3}, rms(error / u) {rms:.2}"
        );
        assert!(n > 300.0, "{what}: {n}");
        assert!(
            (0.92..=0.98).contains(&coverage) && (1.0 / 1.2..=1.0 / 0.8).contains(&rms),
            "accel {accel} mm/s², {what}: coverage {coverage:.3}, rms(error / u) {rms:.3}"
        );
    }
}

/// `StreamingSsm::is_growing` (the live E's u is refreshed more often while it holds): true
/// from the window's first sample until one leaves it — by the radius, or the ring full —
/// counted here from the positions; again after every sample has left (a jump farther than the
/// radius), after `clear`; and in steady state only where the ring's oldest index passes the
/// window's first again (one sample in W).
#[test]
fn the_window_grows_until_a_sample_leaves_it() {
    const W: usize = 64;
    let p0 = [40.0, -20.0, 10.0];
    let (l, radius) = (150.0, 5.0);
    // 0.1° a sample on a 30° cone: 0.13 mm apart, so the 5 mm radius holds 38 samples
    let path = cone_path(p0, l, 30.0, 3600, 0.0);
    let mut ssm = StreamingSsm::<W>::new(StreamingConfig {
        geometry: SsmGeometry {
            socket_mm: p0,
            bar_length_mm: l,
        },
        radius_mm: radius,
        rotary_tol_deg: 0.001,
    });
    let pos = |s: &Sample| s.axes.map(f64::from);
    let dist = |a: [f64; 5], b: [f64; 5]| {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    };
    let first = pos(&path.samples[0]);
    // the first sample farther than the radius from the window's first makes it leave
    let leaves_at = path
        .samples
        .iter()
        .position(|s| dist(pos(s), first) > f64::from(radius))
        .unwrap();
    assert!(leaves_at < W, "{leaves_at}");
    let mut steady_growing = 0;
    for (i, s) in path.samples.iter().take(1000).enumerate() {
        ssm.update(s);
        if i < leaves_at {
            assert!(ssm.is_growing(), "sample {i}");
        } else if i == leaves_at {
            assert!(!ssm.is_growing(), "sample {i}");
        } else if ssm.is_growing() {
            steady_growing += 1;
        }
    }
    // about 1000 − 38 samples have left: the oldest index passed the window's first once
    // every W of them
    let passes = (1000 - leaves_at) / W;
    assert!(
        (passes - 1..=passes + 1).contains(&steady_growing),
        "{steady_growing} vs {passes}"
    );
    // a jump farther than the radius: every sample leaves, the window starts anew
    ssm.update(&path.samples[1800]);
    assert_eq!(ssm.window_len(), 1);
    assert!(ssm.is_growing());
    ssm.update(&path.samples[1801]);
    assert!(ssm.is_growing());
    ssm.clear();
    ssm.update(&path.samples[2000]);
    assert!(ssm.is_growing());
}
