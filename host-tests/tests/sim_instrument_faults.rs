//! Instrument and machine faults of the virtual machine tool that the ISO 230-4 diagnostics do
//! not name: straightness, a socket that is not where the pod believes, thermal drift of the
//! machine and of the bar, LVDT non-linearity, probe pre-travel and bounce. Each is injected
//! alone on an otherwise perfect machine (`CircleMachine` faults at 0) and its effect on what
//! the simulated pod reports (its results table, its recorded samples) is checked against the
//! size computed by hand from the injected fault through the forward model.
//!
//! Tolerances: the circle runs have 14 137 samples (R 150 mm at F4000, 1 kHz) with the default
//! 0.2 µm bar noise and 0.5 count ADC noise, so a fitted centre has σ ≈ 0.2·√(2/14 137) ≈
//! 0.003 µm and a ΔL-vs-time slope σ ≈ 0.2 µm / (√14 137 · 4.1 s) ≈ 0.03 µm/min; the bounds below
//! are 0.05 µm / 1 % (≥ 15 σ) so that only a wrong effect fails, not noise, and f32 sample
//! rounding (≈ 0.01 µm on ΔL at 150 mm) stays inside them.

use ballpod::acquisition::{MAX_AXES, Sample};
use ballpod::config::Config;
use ballpod_host::replay::{Report, RunReport};
use ballpod_host::simulate::{SimOptions, SimSession, simulate};
use ballpod_host::vmt::machine::{CircleMachine, MachineFile};
use ballpod_host::vmt::sensors::Instrument;
use ballpod_host::vmt::virtual_pod::{VirtualPod, VirtualSetup};

/// A perfect circle machine (R 150 mm, F4000) and the default instrument.
fn perfect() -> MachineFile {
    MachineFile {
        circle: CircleMachine {
            feed_mm_per_min: 4000.0,
            ..CircleMachine::perfect()
        },
        ..MachineFile::default()
    }
}

/// The ISO 230-4 circle, CCW then CW, on the simulated pod.
fn run(m: &MachineFile) -> SimSession {
    let o = SimOptions {
        seed: 5,
        repeats: 1,
        feed_mm_per_min: 4000.0,
        seed002: false,
        circle: true,
        three_planes: false,
        feed_sweep: Vec::new(),
        nc_dir: None,
    };
    let s = simulate(m, &o, &mut |_, _, _| {}).expect("simulated session");
    let dirs: Vec<_> = s
        .report
        .runs
        .iter()
        .map(|r| (r.direction.as_str(), r.outcome.as_str()))
        .collect();
    assert_eq!(dirs, [("CCW", "DONE"), ("CW", "DONE")]);
    s
}

/// A result of a run's own (its fit).
fn run_value(r: &RunReport, name: &str) -> f64 {
    r.results
        .iter()
        .find(|f| f.name == name)
        .map(|f| f64::from(f.value))
        .unwrap_or_else(|| panic!("run {}: {name} not valid", r.run))
}

/// A result of the pod's table at the end.
fn value(r: &Report, name: &str) -> f64 {
    f64::from(
        r.result(name)
            .unwrap_or_else(|| panic!("{name} not valid"))
            .value,
    )
}

/// Fitted centres (µm: the limaçon eccentricity, u = X, v = Y) of the CCW and CW runs.
fn centres(s: &SimSession) -> [[f64; 2]; 2] {
    let c = |r: &RunReport| [run_value(r, "ecc_u"), run_value(r, "ecc_v")];
    [c(&s.report.runs[0]), c(&s.report.runs[1])]
}

/// The samples of each recorded run.
fn samples(s: &SimSession) -> Vec<Vec<Sample>> {
    s.runs
        .iter()
        .map(|(_, r)| r.samples().copied().collect())
        .collect()
}

/// Least-squares slope of ΔL over time, µm per minute.
fn slope_um_per_min(samples: &[Sample]) -> f64 {
    let n = samples.len() as f64;
    let t: Vec<f64> = samples.iter().map(|s| s.t_us as f64 / 60e6).collect();
    let y: Vec<f64> = samples.iter().map(|s| f64::from(s.delta_l_um)).collect();
    let (mt, my) = (t.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let mut sxy = 0.0;
    let mut sxx = 0.0;
    for i in 0..samples.len() {
        sxy += (t[i] - mt) * (y[i] - my);
        sxx += (t[i] - mt) * (t[i] - mt);
    }
    sxy / sxx
}

#[test]
fn a_perfect_machine_shows_no_eccentricity_and_no_drift() {
    let s = run(&perfect());
    for c in centres(&s) {
        assert!(c[0].abs() < 0.05 && c[1].abs() < 0.05, "{c:?}");
    }
    for run in samples(&s) {
        assert!(slope_um_per_min(&run).abs() < 0.15);
    }
}

/// E_x = A·(y/R)² gives ΔL = A·sin²θ·cosθ = (A/4)(cos θ − cos 3θ): the fitted centre moves by
/// A/4 in X, not at all in Y.
#[test]
fn straightness_of_x_along_y_shifts_the_centre_by_a_quarter_of_it() {
    let mut m = perfect();
    m.circle.straightness_x_along_y_um = 8.0;
    let s = run(&m);
    for c in centres(&s) {
        assert!((c[0] - 8.0 / 4.0).abs() < 0.05, "{c:?}");
        assert!(c[1].abs() < 0.05, "{c:?}");
    }
}

/// The bar measures from the true socket; the pod fits about the believed one: the tool path's
/// centre is at −offset from the true socket, so the fitted centre is −offset.
#[test]
fn a_socket_mounting_offset_appears_as_the_same_eccentricity() {
    let mut m = perfect();
    m.circle.socket_offset_um = [3.0, -2.0];
    let s = run(&m);
    for c in centres(&s) {
        assert!((c[0] + 3.0).abs() < 0.05, "{c:?}");
        assert!((c[1] - 2.0).abs() < 0.05, "{c:?}");
    }
}

/// Both axes growing by g at x, y = R per minute: the radius, so ΔL, grows by g per minute.
#[test]
fn thermal_growth_of_the_machine_drifts_dl_by_the_injected_rate() {
    let mut m = perfect();
    m.circle.thermal_growth_x_um_per_min = 20.0;
    m.circle.thermal_growth_y_um_per_min = 20.0;
    let s = run(&m);
    for run in samples(&s) {
        let k = slope_um_per_min(&run);
        assert!((k / 20.0 - 1.0).abs() < 0.01, "slope {k} µm/min");
    }
}

/// The bar warms by 10 °C/min during the run and the thermistor follows: ΔL stays unbiased
/// (slope ≪ the uncorrected expansion rate L·α·10 K/min, mean ≈ 0) and the samples carry the
/// bar's temperature.
#[test]
fn bar_temperature_drift_is_corrected_from_the_thermistor() {
    let mut m = perfect();
    m.instrument.bar_temp_drift_c_per_min = 10.0;
    let s = run(&m);
    let cfg = Config::default();
    let uncorrected = 150.0e3 * f64::from(cfg.bar_cte_ppm_per_k) * 1e-6 * 10.0; // µm/min
    assert!(uncorrected > 10.0, "{uncorrected}");
    for run in samples(&s) {
        let k = slope_um_per_min(&run);
        assert!(
            k.abs() < 0.02 * uncorrected,
            "slope {k} vs {uncorrected} µm/min"
        );
        let mean = run.iter().map(|s| f64::from(s.delta_l_um)).sum::<f64>() / run.len() as f64;
        assert!(mean.abs() < 0.05, "mean ΔL {mean} µm");
        let last = run.last().expect("samples");
        let truth = m.instrument.bar_temp_c + 10.0 * last.t_us as f64 / 60e6;
        // the thermistor is read every 100 ms (≤ 0.017 °C behind) through a 12-bit ADC
        assert!(
            (f64::from(last.temp_c) - truth).abs() < 0.05,
            "{} vs {truth}",
            last.temp_c
        );
    }
}

/// The LVDT reads x + k·x²: at a constant true ΔL of 400 µm (bar at 20 °C: no expansion), the
/// pod reports 400 + k·400² — in its samples and in its live ΔL.
#[test]
fn lvdt_nonlinearity_adds_k_x_squared() {
    use ballpod::app::Live;
    for k in [0.0, 2e-5, -1e-5] {
        let inst = Instrument {
            bar_temp_c: 20.0,
            lvdt_nonlinearity_per_um: k,
            ..Instrument::default()
        };
        let mut vp: VirtualPod<16> = VirtualPod::new(VirtualSetup {
            seed: 9,
            instrument: inst,
            ..VirtualSetup::default()
        });
        let axes: [f64; MAX_AXES] = [150.0, 0.0, 0.0, 0.0, 0.0];
        vp.home(&axes);
        let n = 2000;
        let mut sum = 0.0;
        for _ in 0..n {
            let s = vp.sample_at(400.0, &axes).0.expect("a sample");
            assert!(s.flags.is_valid_for_metrology(), "{s:?}");
            assert_eq!(vp.app.live().get(Live::DeltaL), Some(s.delta_l_um));
            sum += f64::from(s.delta_l_um);
        }
        let mean = sum / f64::from(n);
        // σ of the mean 0.2/√2000 ≈ 0.005 µm
        let expected = 400.0 + k * 400.0 * 400.0;
        assert!(
            (mean - expected).abs() < 0.05,
            "k {k}: {mean} vs {expected}"
        );
    }
}

/// Probe pre-travel and bounce: a sphere touched nine times with a 20 µm pre-travel and three
/// bounce edges per touch, against the same sphere without them (no repeatability scatter):
/// the fitted centre does not move (every point moves 20 µm along its own normal), the radius
/// shrinks by the pre-travel, and every bounce is rejected and counted, never a point. Bounds:
/// the latched points are encoder counts (0.1 µm) in f32 at ~500 mm (0.03 µm).
#[test]
fn probe_pretravel_moves_the_radius_not_the_centre_and_bounces_are_rejected() {
    use ballpod_host::vmt::probe_rig::{ProbeRig, SPHERE_RADIUS_MM, STYLUS_RADIUS_MM};
    let centre = [-390.0, 12.5, -472.0];
    let measure = |pretravel_um: f64, bounces: u32| {
        let inst = Instrument {
            probe_pretravel_um: pretravel_um,
            probe_bounces: bounces,
            ..Instrument::default()
        };
        let mut rig = ProbeRig::new(&inst, 5);
        let m = rig.measure_sphere(centre, [0.0, 90.0]).expect("sphere");
        // the nine touches were the run's touch points, none came outside it
        assert_eq!(rig.pod.app.touch_points().len(), 9);
        assert_eq!(rig.pod.app.touches_outside_run(), 0);
        (m, rig.pod.app.probe_counts())
    };
    let (ideal, _) = measure(0.0, 0);
    let (faulty, counts) = measure(20.0, 3);
    for i in 0..3 {
        assert!(
            (ideal.centre_mm[i] - centre[i]).abs() * 1e3 < 0.1,
            "ideal centre {:?}",
            ideal.centre_mm
        );
        assert!(
            (faulty.centre_mm[i] - ideal.centre_mm[i]).abs() * 1e3 < 0.1,
            "pre-travel moved the centre: {:?} vs {:?}",
            faulty.centre_mm,
            ideal.centre_mm
        );
    }
    let contact = SPHERE_RADIUS_MM + STYLUS_RADIUS_MM;
    assert!(((ideal.radius_mm - contact) * 1e3).abs() < 0.1);
    assert!(((faulty.radius_mm - contact) * 1e3 + 20.0).abs() < 0.1);
    assert_eq!((faulty.accepted, faulty.bounces), (9, 27));
    assert_eq!(counts, (9, 27, 0));
}

/// Quadratic straightness in the ISO 230-4 figures. E_x = A·(y/R)² gives
/// ΔL = A·sin²θ·cosθ = (A/4)(cos θ − cos 3θ); E_y = B·(x/R)² gives
/// ΔL = B·cos²θ·sinθ = (B/4)(sin θ + sin 3θ). The least-squares circle takes the first
/// harmonic (centre A/4 in X, B/4 in Y); what is left is a 3rd harmonic of amplitude A/4: the
/// core's diagnostics name it a cyclic error of order 3 (no squareness, scale or reversal term
/// can take it: those are 2nd-order and even harmonics), G = 2·A/4 = A/2, and about the socket
/// F = ±max|A·sin²θ·cosθ| = ±2A/(3√3). Bounds: the default noise stays on (it dithers the
/// 12-bit ADC; without it the LVDT rounding is systematic, ≈ 0.2 µm). Fitted centre and
/// harmonic amplitudes: σ ≈ 0.003 µm, bound 0.05 µm; squareness and scale 1 µrad / 1 µm/m
/// (0.08 µm of a 2nd harmonic); G is a range over 360 bin means (σ ≈ 0.04 µm each), which noise
/// can only widen, by ≈ 3–4 σ: −0.05..+0.3 µm; F is an extreme of single samples
/// (σ ≈ 0.25 µm), widened by 3–5 σ near the peak: −0.05..+1.5 µm.
#[test]
fn straightness_is_diagnosed_per_axis_with_g_of_half_its_size() {
    let a = 8.0;
    for x_along_y in [true, false] {
        let mut m = perfect();
        if x_along_y {
            m.circle.straightness_x_along_y_um = a;
        } else {
            m.circle.straightness_y_along_x_um = a;
        }
        let s = run(&m);
        let r = &s.report;
        let centre = if x_along_y {
            [a / 4.0, 0.0]
        } else {
            [0.0, a / 4.0]
        };
        let f = 2.0 * a / (3.0 * 3f64.sqrt());
        let widen = |got: f64, want: f64, up: f64| {
            let d = got.abs() - want;
            d > -0.05 && d < up
        };
        for (c, dir) in centres(&s).into_iter().zip(["ccw", "cw"]) {
            assert!(
                (c[0] - centre[0]).abs() < 0.05 && (c[1] - centre[1]).abs() < 0.05,
                "x_along_y {x_along_y} {dir}: centre {c:?} vs {centre:?}"
            );
            let g = value(r, &format!("G_{dir}"));
            assert!(widen(g, a / 2.0, 0.3), "G_{dir} {g} vs {}", a / 2.0);
            let (f_max, f_min) = (
                value(r, &format!("F_max_{dir}")),
                value(r, &format!("F_min_{dir}")),
            );
            assert!(f_max > 0.0 && widen(f_max, f, 1.5), "F_max_{dir} {f_max}");
            assert!(f_min < 0.0 && widen(f_min, f, 1.5), "F_min_{dir} {f_min}");
        }
        // the pod's diagnoses (mean of CCW and CW): the bowing axis's straightness, A (its
        // third harmonic A/4 read with the 0.05 µm bound, ×4), the other's none
        assert_eq!(value(r, "cyclic_order"), 0.0, "{:?}", r.results);
        let (bowed, straight) = if x_along_y {
            ("straightness_v", "straightness_u")
        } else {
            ("straightness_u", "straightness_v")
        };
        let s_bowed = value(r, bowed);
        assert!((s_bowed - a).abs() < 0.2, "{bowed} {s_bowed} vs {a}");
        assert!(value(r, straight).abs() < 0.2, "{straight}");
        assert!(
            value(r, "share_straightness_u").max(value(r, "share_straightness_v")) > a / 2.0 - 0.1
        );
        assert!(value(r, "squareness").abs() < 1.0);
        assert!(value(r, "scale_mismatch").abs() < 1.0);
        assert!(value(r, "reversal_u").abs() < 0.05 && value(r, "reversal_v").abs() < 0.05);
    }
}

/// The bar warms by 10 °C/min but the thermistor is not on it (it keeps reading the start
/// temperature): the pod cannot correct, and ΔL drifts by the bar's expansion rate,
/// −L·α·10 K/min (the bar body grows, the LVDT core moves in). Bound: 1 % of ≈ 17 µm/min is
/// 0.17 µm/min, ≥ 5 σ of the slope (0.03 µm/min, module comment).
#[test]
fn bar_temperature_drift_without_the_thermistor_drifts_dl_by_the_expansion_rate() {
    let mut m = perfect();
    m.instrument.bar_temp_drift_c_per_min = 10.0;
    m.instrument.thermistor_detached = true;
    let s = run(&m);
    let cfg = Config::default();
    let expansion = 150.0e3 * f64::from(cfg.bar_cte_ppm_per_k) * 1e-6 * 10.0; // µm/min
    for run in samples(&s) {
        let k = slope_um_per_min(&run);
        assert!(
            (k / -expansion - 1.0).abs() < 0.01,
            "slope {k} vs −{expansion} µm/min"
        );
        let last = run.last().expect("samples");
        assert!(
            (f64::from(last.temp_c) - m.instrument.bar_temp_c).abs() < 0.05,
            "the pod saw {} °C",
            last.temp_c
        );
    }
}

/// LVDT non-linearity in the circle figures. With the socket e = 200 µm off in X the bar
/// swings through ΔL ≈ −e·cos θ, and the LVDT reads ΔL + k·ΔL² = ΔL + (k e²/2)(1 + cos 2θ):
/// against the same run with k = 0, the radius r0 grows by k e²/2, the centre does not move,
/// and the cos 2θ term is what the core's diagnostics call a scale mismatch,
/// 2·(k e²/2)/R = k e²/R (an eccentric set-up turns LVDT non-linearity into apparent ovality).
/// G of the faulty run is the peak-to-valley of the whole cos 2θ term, which includes the
/// geometric one of an eccentric circle, ΔL ≈ −e cos θ + (e²/2R) sin²θ:
/// G = 2·|k e²/2 − e²/(4R)|. Bounds: both runs have the same seed, so the same noise, which
/// cancels in the differences but for k·(2·ΔL·noise) (≈ 0.01 µm σ per sample): 0.05 µm on r0
/// and centre, 0.5 µm/m (0.04 µm of a₂ at R 150 mm) on the scale mismatch; G as in the
/// straightness test, −0.05..+0.3 µm.
#[test]
fn lvdt_nonlinearity_with_an_eccentric_setup_shows_as_scale_mismatch_and_radius() {
    let (k, e, r_um) = (1e-4, 200.0, 150.0e3);
    let circle = |k: f64| {
        let mut m = perfect();
        m.circle.socket_offset_um = [e, 0.0];
        m.instrument.bar_temp_c = 20.0;
        m.instrument.lvdt_nonlinearity_per_um = k;
        run(&m)
    };
    let (ideal, faulty) = (circle(0.0), circle(k));
    let ke2 = k * e * e; // 4 µm
    for (d, (i, f)) in ["ccw", "cw"]
        .into_iter()
        .zip(ideal.report.runs.iter().zip(&faulty.report.runs))
    {
        let dr0 = run_value(f, "r0") - run_value(i, "r0");
        assert!((dr0 - ke2 / 2.0).abs() < 0.05, "{d}: Δr0 {dr0}");
        for n in ["ecc_u", "ecc_v"] {
            let dc = run_value(f, n) - run_value(i, n);
            assert!(dc.abs() < 0.05, "{d}: centre moved {dc} µm");
        }
        let g = 2.0 * (ke2 / 2.0 - e * e / (4.0 * r_um)).abs();
        let got = value(&faulty.report, &format!("G_{d}"));
        let dg = got - g;
        assert!(dg > -0.05 && dg < 0.3, "{d}: G {got} vs {g}");
    }
    let ds = value(&faulty.report, "scale_mismatch") - value(&ideal.report, "scale_mismatch");
    assert!((ds - ke2 / (r_um * 1e-6)).abs() < 0.5, "Δscale {ds} µm/m");
}
