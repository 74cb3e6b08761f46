//! The three-plane summary on the virtual machine tool (issue 45): YZ and ZX arcs, then the
//! XY circle, each CCW and CW on the simulated pod; the machine's three squarenesses and three
//! axis scales come back from the pod's results table within their U. The truth is the
//! virtual machine's own axis faults (`vmt::machine::ThreePlaneMachine`, `CircleMachine`: each
//! axis's position error, then the bar's length between the balls), never the pod's fit.

use ballpod::acquisition::MAX_AXES;
use ballpod::app::{App, Command, Direction, Pattern, ResultId};
use ballpod::config::{CirclePlane, Config};
use ballpod_host::replay::Report;
use ballpod_host::rng::Rng;
use ballpod_host::simulate::{SimOptions, simulate};
use ballpod_host::vmt::machine::{CircleMachine, MachineFile, ThreePlaneMachine};
use ballpod_host::vmt::sensors::Instrument;

const SUMMARY: [&str; 6] = [
    "squareness_xy",
    "squareness_yz",
    "squareness_zx",
    "scale_x",
    "scale_y",
    "scale_z",
];

/// The summary's truth of `m`: the three squarenesses (µrad), the three scales (µm/m).
fn truth(m: &MachineFile) -> [f64; 6] {
    let (xy, p) = (&m.circle, &m.planes);
    let k = p.scales_um_per_m(xy);
    [
        xy.squareness_urad,
        p.squareness_yz_urad,
        p.squareness_zx_urad,
        k[0],
        k[1],
        k[2],
    ]
}

/// The vertical arcs and the XY circle of `m`, nothing else.
fn session(m: &MachineFile, seed: u64) -> Report {
    let o = SimOptions {
        seed,
        repeats: 1,
        seed002: false,
        circle: true,
        three_planes: true,
        ..SimOptions::default()
    };
    simulate(m, &o, &mut |_, _, _| {})
        .expect("simulated session")
        .report
}

/// A machine with random faults in every plane (squareness ±40 µrad, scales ±20 µm/m,
/// reversal steps, servo lags), random radius, vertical arcs of 220° to a full circle, and a
/// bar miscalibrated by a draw of the length u the pod is told (`bar_u_length`, 0.5 µm).
fn machine(rng: &mut Rng) -> MachineFile {
    let circle = CircleMachine {
        radius_mm: rng.range(100.0, 200.0),
        feed_mm_per_min: 2000.0,
        squareness_urad: rng.range(-40.0, 40.0),
        scale_x_um_per_m: rng.range(-20.0, 20.0),
        scale_y_um_per_m: rng.range(-20.0, 20.0),
        backlash_x_um: rng.range(0.0, 6.0),
        backlash_y_um: rng.range(0.0, 6.0),
        servo_lag_x_ms: rng.range(0.0, 1.0),
        servo_lag_y_ms: rng.range(0.0, 1.0),
        ..CircleMachine::perfect()
    };
    let planes = ThreePlaneMachine {
        squareness_yz_urad: rng.range(-40.0, 40.0),
        squareness_zx_urad: rng.range(-40.0, 40.0),
        scale_z_um_per_m: rng.range(-20.0, 20.0),
        backlash_z_um: rng.range(0.0, 6.0),
        vertical_arc_deg: if rng.range(0.0, 1.0) < 0.25 {
            360.0
        } else {
            rng.range(220.0, 300.0)
        },
    };
    let instrument = Instrument {
        sample_rate_hz: 250.0,
        bar_temp_c: 20.0,
        bar_calibration_error_um: f64::from(ballpod::config::DEFAULT_U_LENGTH_UM) * rng.normal(),
        ..Instrument::default()
    };
    MachineFile {
        circle,
        planes,
        instrument,
        ..MachineFile::default()
    }
}

/// 40 machines: every summary value within U = 2u of the truth in 90–99 % of the cases (the
/// scales share their machine's one bar error, so they count as 40 draws of it), and the
/// squarenesses' u (their noise's) not below their errors' scatter by more than 20 %. On the
/// virtual machine's sensor chain (ADC, demodulation, encoders) the squarenesses' u is 1.31 to
/// 1.35 times their scatter, servo lags or not (1.03 on the bare forward model of
/// `ballbar_diagnoses_mc.rs`): conservative, by a cause not yet found; bounded at 1.4.
#[test]
fn the_summary_recovers_injected_squarenesses_and_scales_within_u() {
    let mut rng = Rng::new(20_261_130);
    let mut errors: [Vec<(f64, f64)>; 6] = Default::default();
    for i in 0..40 {
        let m = machine(&mut rng);
        let r = session(&m, 100 + i);
        for ((name, t), e) in SUMMARY.iter().zip(truth(&m)).zip(errors.iter_mut()) {
            let v = r
                .result(name)
                .unwrap_or_else(|| panic!("{name} not valid for {m:?}"));
            e.push((f64::from(v.value) - t, f64::from(v.u.expect("u"))));
        }
    }
    let coverage = |e: &[(f64, f64)]| {
        e.iter().filter(|(e, u)| e.abs() <= 2.0 * u).count() as f64 / e.len() as f64
    };
    let (squareness, scales) = errors.split_at(3);
    let sq: Vec<(f64, f64)> = squareness.concat();
    let sc: Vec<(f64, f64)> = scales.concat();
    let rms = |e: &[(f64, f64)], f: fn(&(f64, f64)) -> f64| {
        (e.iter().map(|x| f(x) * f(x)).sum::<f64>() / e.len() as f64).sqrt()
    };
    let ratio = rms(&sq, |x| x.1) / rms(&sq, |x| x.0);
    println!(
        "squareness: coverage {:.3}, rms u / rms error {ratio:.3}; scales: coverage {:.3}, rms error {:.3} µm/m, rms u {:.3} µm/m",
        coverage(&sq),
        coverage(&sc),
        rms(&sc, |x| x.0),
        rms(&sc, |x| x.1)
    );
    assert!((0.90..=0.99).contains(&coverage(&sq)), "{sq:?}");
    assert!((0.8..=1.4).contains(&ratio), "ratio {ratio}");
    assert!((0.90..=1.0).contains(&coverage(&sc)), "{sc:?}");
}

/// The scales are relative to the bar's calibrated length: a bar 2 µm short of it (the same
/// noise draws; the ADC quantises the shifted signal differently, a few hundredths of a µrad
/// or µm/m) reads as 2 µm / R more on every axis, the squarenesses unchanged.
#[test]
fn a_bar_calibration_error_reads_as_the_same_scale_on_every_axis() {
    let m = MachineFile {
        instrument: Instrument {
            sample_rate_hz: 250.0,
            ..Default::default()
        },
        ..Default::default()
    };
    let mut off = m;
    off.instrument.bar_calibration_error_um = 2.0;
    let (a, b) = (session(&m, 3), session(&off, 3));
    let want = 2.0 / m.circle.radius_mm * 1e3;
    for name in SUMMARY {
        let (x, y) = (a.result(name).unwrap(), b.result(name).unwrap());
        let d = f64::from(y.value - x.value);
        // the scales: 13.3 µm/m to within 1 %; the squarenesses: within their noise's u
        let (expect, within) = if name.starts_with("scale") {
            (want, 0.01 * want)
        } else {
            (0.0, f64::from(x.u.unwrap()))
        };
        assert!(
            (d - expect).abs() <= within,
            "{name}: moved {d}, want {expect} ± {within}"
        );
    }
}

/// On the pod's application: a plane's squareness as soon as its circle is complete, the
/// scales only once all three planes are, the reason while they are not, and a cleared
/// session forgets them.
#[test]
fn the_summary_waits_for_every_plane_and_says_why() {
    let m = MachineFile::default();
    let (xy, p) = (&m.circle, &m.planes);
    let mut app = App::new(
        Config {
            bar_length_mm: xy.radius_mm as f32,
            ..Config::default()
        },
        [16; MAX_AXES],
    );
    app.set_pattern(Pattern::Circle).unwrap();
    let run_plane = |app: &mut App, plane: CirclePlane| {
        let (c, (start, arc)) = match plane {
            CirclePlane::XY => (*xy, (0.0, 360.0)),
            _ => (p.plane(xy, plane), p.arc()),
        };
        app.configure(|cfg| {
            let s = &mut cfg.setup;
            s.circle_plane = plane;
            s.circle_centre_mm = [0.0; 3];
            s.circle_radius_mm = c.radius_mm as f32;
            s.circle_min_arc_deg = 200.0;
        })
        .unwrap();
        let n = 2000;
        for d in [Direction::Ccw, Direction::Cw] {
            app.set_direction(d).unwrap();
            app.execute(Command::Arm).unwrap();
            app.execute(Command::Start).unwrap();
            let sgn = d.sign();
            let from = if sgn > 0.0 { start } else { start + arc };
            for i in 0..n {
                let th = (from + sgn * arc * i as f64 / n as f64).to_radians();
                let (dl, uv) = c.pose(th, sgn);
                let axes = ThreePlaneMachine::axes(plane, uv);
                let s = ballpod::acquisition::Sample {
                    seq: i,
                    t_us: u64::from(i) * 1000,
                    delta_l_um: dl as f32,
                    axes: axes.map(|a| a as f32),
                    temp_c: 20.0,
                    ..Default::default()
                };
                app.on_sample(&s, &mut ());
            }
            app.execute(Command::Stop).unwrap();
            ballpod_host::run_jobs(app);
        }
    };
    run_plane(&mut app, CirclePlane::XY);
    assert!(app.result(ResultId::SquarenessXy).valid);
    for id in [ResultId::SquarenessYz, ResultId::ScaleX, ResultId::ScaleZ] {
        assert!(!app.result(id).valid, "{id:?}");
        let why = app.why_invalid(id).expect("a reason");
        assert!(why.contains("not available yet"), "{why}");
    }
    run_plane(&mut app, CirclePlane::YZ);
    assert!(!app.result(ResultId::ScaleX).valid);
    run_plane(&mut app, CirclePlane::ZX);
    for (id, t) in [
        (ResultId::SquarenessXy, xy.squareness_urad),
        (ResultId::SquarenessYz, p.squareness_yz_urad),
        (ResultId::SquarenessZx, p.squareness_zx_urad),
        (ResultId::ScaleX, xy.scale_x_um_per_m),
        (ResultId::ScaleY, xy.scale_y_um_per_m),
        (ResultId::ScaleZ, p.scale_z_um_per_m),
    ] {
        let e = app.result(id);
        assert!(e.valid, "{id:?}");
        assert!(
            (f64::from(e.value) - t).abs() <= 2.0 * f64::from(e.std_uncertainty),
            "{id:?}: {e:?} vs {t}"
        );
        assert_eq!(app.why_invalid(id), None);
    }
    // the bar's length is the scales' largest contributor (one bar for every plane)
    let top = app.result(ResultId::ScaleZ).largest_contributors();
    assert_eq!(
        top[0].map(|(c, _)| c),
        Some(ballpod::app::Contributor::BarOffset)
    );
    app.execute(Command::Clear).unwrap();
    for id in [ResultId::SquarenessXy, ResultId::ScaleY] {
        assert!(!app.result(id).valid, "{id:?} after CLEAR");
    }
}
