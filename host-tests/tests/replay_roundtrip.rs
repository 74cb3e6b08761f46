//! Replaying what the simulator recorded gives the simulator's report byte for byte: the runs
//! are written as `cargo sim --write-logs` writes them (one pod CSV per run in the stream's
//! text, and a `session.toml` listing them), read back as `cargo replay` reads them, fed into a
//! fresh application, and the JSON texts (and the polar plots) are compared. The samples
//! themselves come back bit for bit, and the report holds what the session ran. Partial arcs
//! (90°, 220°, CW and CCW, two planes) are measured by the pod, checked against an independent
//! f64 fit and replayed the same way. (The probe and SSM runs are replayed by every scenario of
//! `scenario_files.rs`; the R-test and dial-gauge readings go through the session file there.)

use std::path::{Path, PathBuf};

use ballpod::acquisition::{MAX_AXES, Sample, SampleFlags};
use ballpod::app::{App, Command, Direction, Pattern, ResultId, SessionState};
use ballpod::config::{CirclePlane, Config};
use ballpod_host::oracle::{Rng, lstsq};
use ballpod_host::recording::{Event, RecordedRun, Recording, parse_runs};
use ballpod_host::replay::{figures, replay};
use ballpod_host::report;
use ballpod_host::session_file::read_inputs;
use ballpod_host::simulate::{SimOptions, simulate};
use ballpod_host::vmt::machine::MachineFile;

/// Every field of two recorded runs, exactly (f32 by bits: a NaN set-up field equals itself).
fn assert_same_run(a: &RecordedRun, b: &RecordedRun, name: &str) {
    assert_eq!(
        (a.meta.run, a.meta.pattern, a.meta.direction),
        (b.meta.run, b.meta.pattern, b.meta.direction),
        "{name}"
    );
    for info in ballpod::config::FIELDS {
        for k in 0..info.elements.max(1) {
            let f = info.element(k);
            let (x, y) = (
                a.meta.config.field_value(f).map(f64::to_bits),
                b.meta.config.field_value(f).map(f64::to_bits),
            );
            assert_eq!(x, y, "{name}: {}[{k}]", info.name);
        }
    }
    assert_eq!(a.meta.config.axes, b.meta.config.axes, "{name}");
    assert_eq!(
        (a.meta.config.lvdt_input, a.meta.config.can_bitrate),
        (b.meta.config.lvdt_input, b.meta.config.can_bitrate),
        "{name}"
    );
    assert_eq!(a.events.len(), b.events.len(), "{name}");
    for (x, y) in a.events.iter().zip(&b.events) {
        match (x, y) {
            (Event::Sample(x), Event::Sample(y)) => {
                assert_eq!((x.seq, x.t_us, x.flags), (y.seq, y.t_us, y.flags), "{name}");
                assert_eq!(x.delta_l_um.to_bits(), y.delta_l_um.to_bits(), "{name}");
                assert_eq!(x.axes.map(f32::to_bits), y.axes.map(f32::to_bits), "{name}");
                // the stream prints the temperature to 0.01 °C
                assert!((x.temp_c - y.temp_c).abs() <= 0.005 + 1e-4, "{name}");
            }
            (Event::Touch(x), Event::Touch(y)) => {
                assert_eq!(x.t_us, y.t_us, "{name}");
                assert_eq!(x.axes.map(f32::to_bits), y.axes.map(f32::to_bits), "{name}");
            }
            _ => panic!("{name}: a sample against a touch"),
        }
    }
    assert_eq!(a.end, b.end, "{name}");
    assert_eq!(a.decimation, b.decimation, "{name}");
}

#[test]
fn replay_of_the_simulators_recorded_runs_reproduces_its_report_byte_for_byte() {
    let m = MachineFile::default();
    let o = SimOptions {
        seed: 5,
        repeats: 1,
        feed_mm_per_min: 8000.0,
        seed002: true,
        circle: true,
        three_planes: true,
        feed_sweep: Vec::new(),
        nc_dir: None,
    };
    let s = simulate(&m, &o, &mut |_, _, _| {}).expect("simulated session");
    let sim = &s.report;
    // the session ran what was asked: ten seed 002 runs, the three-plane test's four vertical
    // arcs and two circles, all done, and the procedures' results are there
    assert_eq!(s.runs.len(), 16);
    assert_eq!(sim.runs.len(), 16);
    assert!(
        sim.runs.iter().all(|r| r.outcome == "DONE"),
        "{:?}",
        sim.runs
    );
    for name in [
        "dx_CZ",
        "th_alpha_CZ",
        "e_CR2_y",
        "G_bidir",
        "squareness",
        "scale_z",
    ] {
        assert!(sim.result(name).is_some(), "{name} missing");
    }

    // `cargo sim --write-logs DIR`: one file per run, and a session file listing them
    let dir: PathBuf = std::env::temp_dir().join(format!("ballpod-replay-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("dir");
    let mut session_toml = String::from("# the runs of a simulated session\n");
    for (name, run) in &s.runs {
        std::fs::write(dir.join(name), run.to_csv()).expect("write run");
        session_toml.push_str(&format!("\n[[runs]]\nlog = \"{name}\"\n"));
    }
    std::fs::write(dir.join("session.toml"), &session_toml).expect("write session");

    // `cargo replay DIR/session.toml`
    let inputs = read_inputs(&[dir.join("session.toml")]).expect("read the session");
    let (runs, host) = (inputs.runs, inputs.host);
    assert!(host.is_empty());
    assert_eq!(runs.len(), s.runs.len());
    for ((na, a), (nb, b)) in runs.iter().zip(&s.runs) {
        assert_eq!(na, nb);
        assert_same_run(a, b, na);
    }
    let replayed = replay(&runs).expect("replay");
    let (json_sim, json_replay) = (
        sim.to_json().expect("json"),
        replayed.to_json().expect("json"),
    );
    assert!(json_sim.len() > 1000, "{json_sim}");
    assert_eq!(json_replay, json_sim, "results.json differs");
    // and the plots of `cargo replay` are those of `cargo sim`
    assert_eq!(
        report::plots(&runs, &replayed),
        report::plots(&s.runs, sim),
        "plots differ"
    );

    // the run files given directly (`cargo replay DIR/*.csv`) replay the same
    let files: Vec<PathBuf> = s.runs.iter().map(|(n, _)| dir.join(n)).collect();
    let direct = read_inputs(&files).expect("read the run files").runs;
    assert_eq!(
        replay(&direct).expect("replay").to_json().expect("json"),
        json_sim
    );

    // one stream holding every run one after the other (a reader recording the whole
    // session): the same runs, the same report
    let stream: String = s.runs.iter().map(|(_, r)| r.to_csv()).collect();
    let parsed = parse_runs(Path::new("stream.csv"), &stream).expect("the whole stream");
    assert_eq!(parsed.len(), s.runs.len());
    let named: Vec<(String, RecordedRun)> =
        s.runs.iter().map(|(n, _)| n.clone()).zip(parsed).collect();
    assert_eq!(
        replay(&named).expect("replay").to_json().expect("json"),
        json_sim
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The independent fit of a circular run: the bar's reading against the direction of the
/// commanded point from the configured centre, rows (1, n_u, n_v), f64 Householder QR on the
/// samples as they were recorded → (r0, e_u, e_v), µm.
fn oracle_fit(plane: CirclePlane, centre_mm: [f32; 3], samples: &[Sample]) -> [f64; 3] {
    let (iu, iv) = match plane {
        CirclePlane::XY => (0, 1),
        CirclePlane::YZ => (1, 2),
        // ISO 230-4's ZX plane: u = Z, v = X
        CirclePlane::ZX => (2, 0),
    };
    let mut rows = Vec::new();
    let mut y = Vec::new();
    for s in samples {
        let du = f64::from(s.axes[iu]) - f64::from(centre_mm[iu]);
        let dv = f64::from(s.axes[iv]) - f64::from(centre_mm[iv]);
        let r = du.hypot(dv);
        rows.push(vec![1.0, du / r, dv / r]);
        y.push(f64::from(s.delta_l_um));
    }
    let (x, _) = lstsq(&rows, &y);
    [x[0], x[1], x[2]]
}

#[test]
fn partial_arcs_on_the_pod_and_in_replay_match_an_f64_fit_within_1_nm() {
    let (radius, feed_mm_per_s, rate_hz) = (150.0f64, 1000.0 / 60.0, 1000.0);
    let mut rng = Rng::new(0xA2C5);
    let mut cases = 0;
    for plane in [CirclePlane::XY, CirclePlane::ZX] {
        for arc_deg in [90.0f64, 220.0] {
            for dir in [Direction::Ccw, Direction::Cw] {
                cases += 1;
                let centre = [120.5f32, -40.25, -310.0];
                let e_um = [rng.range(-8.0, 8.0), rng.range(-8.0, 8.0)];
                let r0_um = rng.range(-3.0, 3.0);
                let mut cfg = Config {
                    bar_length_mm: radius as f32,
                    ..Config::default()
                };
                cfg.setup.circle_plane = plane;
                cfg.setup.circle_centre_mm = centre;
                cfg.setup.circle_radius_mm = radius as f32;
                cfg.setup.circle_min_arc_deg = 80.0;
                let mut app = App::new(cfg, [16; MAX_AXES]);
                let mut rec = Recording::default();
                app.set_pattern(Pattern::Circle).expect("pattern");
                app.set_direction(dir).expect("direction");
                app.execute(Command::Arm).expect("arm");
                app.execute(Command::Start).expect("start");
                // the commanded arc at F1000 from a random start; the socket sits −e off the
                // configured centre (the traced circle is e off the socket: the pod's
                // eccentricity), so the bar reads ΔL = |R n + e| − R + r0, plus 0.2 µm noise
                let start = rng.range(0.0, 360.0);
                let n = (radius * arc_deg.to_radians() / feed_mm_per_s * rate_hz) as usize;
                let sign = dir.sign();
                for i in 0..=n {
                    let th = (start + sign * arc_deg * i as f64 / n as f64).to_radians();
                    let (s, c) = th.sin_cos();
                    let len = (radius * c + e_um[0] * 1e-3).hypot(radius * s + e_um[1] * 1e-3);
                    let dl = (len - radius) * 1e3 + r0_um + 0.2 * rng.normal();
                    let (u, v) = (radius * c, radius * s);
                    let mut axes = [0.0f32; MAX_AXES];
                    axes[..3].copy_from_slice(&centre);
                    let (iu, iv) = match plane {
                        CirclePlane::XY => (0, 1),
                        CirclePlane::YZ => (1, 2),
                        CirclePlane::ZX => (2, 0),
                    };
                    axes[iu] = (f64::from(centre[iu]) + u) as f32;
                    axes[iv] = (f64::from(centre[iv]) + v) as f32;
                    let sample = Sample {
                        seq: i as u32,
                        t_us: 5_000_000 + i as u64 * 1000,
                        delta_l_um: dl as f32,
                        axes,
                        temp_c: 20.0,
                        flags: SampleFlags::NONE,
                    };
                    app.on_sample(&sample, &mut rec);
                }
                app.execute(Command::Stop).expect("stop");
                ballpod_host::run_jobs(&mut app);
                app.flush(&mut rec);
                let what = format!("{plane:?} {arc_deg}° {}", dir.name());
                assert_eq!(app.session(), SessionState::Done, "{what}");
                // the pod's fit against the independent one on the samples it recorded
                let run = &rec.runs[0];
                let samples: Vec<Sample> = run.samples().copied().collect();
                assert_eq!(samples.len(), n + 1, "{what}");
                let [r0, eu, ev] = oracle_fit(plane, centre, &samples);
                let got = |id: ResultId| {
                    let e = app.result(id);
                    assert!(e.valid, "{what}: {} invalid", id.info().name);
                    f64::from(e.value)
                };
                for (name, pod, oracle) in [
                    ("r0", got(ResultId::R0), r0),
                    ("e_u", got(ResultId::EccU), eu),
                    ("e_v", got(ResultId::EccV), ev),
                ] {
                    assert!(
                        (pod - oracle).abs() <= 1e-3,
                        "{what}: {name} pod {pod} oracle {oracle} µm"
                    );
                }
                // and the truth it was made from, within the noise (σ ≈ 0.2/√n µm, larger on
                // a short arc where e and r0 correlate)
                assert!(
                    (eu - e_um[0]).abs() < 0.1 && (ev - e_um[1]).abs() < 0.1,
                    "{what}"
                );
                assert!((got(ResultId::Arc).abs() - arc_deg).abs() < 0.1, "{what}");
                // the stream's text replays to the same results table, figure for figure
                let parsed = parse_runs(Path::new("arc.csv"), &run.to_csv()).expect("parse");
                let replayed =
                    replay(&[("arc.csv".to_string(), parsed[0].clone())]).expect("replay");
                assert_eq!(
                    replayed.results,
                    figures(&app, ResultId::ALL),
                    "{what}: replay differs"
                );
            }
        }
    }
    assert_eq!(cases, 8);
}

#[test]
fn the_readme_session_file_replays_a_pod_file_and_a_plain_log() {
    // The docs' example (docs/src/replay.md) verbatim, with its two logs made here from the forward model: a
    // CCW circle recorded by the pod's application (a pod file), the CW circle as a plain log of
    // another recorder. R 150 mm about (0, 0), traced e = (4, −2.5) µm off the socket, r0 1 µm.
    const R_MM: f64 = 150.0;
    const E_UM: [f64; 2] = [4.0, -2.5];
    const R0_UM: f64 = 1.0;
    const PER_REV: usize = 3600;
    let dir = std::env::temp_dir().join(format!("ballpod-readme-session-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch");
    let sample = |k: usize, sign: f64| {
        let th = sign * 2.0 * std::f64::consts::PI * k as f64 / PER_REV as f64;
        Sample {
            seq: k as u32,
            t_us: 1_000_000 + k as u64 * 1000,
            ..ballpod_host::vmt::machine::linear_circle_sample(th, R_MM, E_UM, R0_UM)
        }
    };

    // the pod's set-up is the docs' [setup] (circle_centre_z stays unset: an XY circle does
    // not need it), so both runs belong to one circular test
    let mut cfg = Config::default();
    cfg.setup.circle_centre_mm[0] = 0.0;
    cfg.setup.circle_centre_mm[1] = 0.0;
    cfg.setup.circle_radius_mm = R_MM as f32;
    let mut app = App::new(cfg, [16; MAX_AXES]);
    let mut rec = Recording::default();
    app.set_pattern(Pattern::Circle).expect("pattern");
    app.set_direction(Direction::Ccw).expect("direction");
    app.execute(Command::Arm).expect("arm");
    app.execute(Command::Start).expect("start");
    for k in 0..=PER_REV {
        app.on_sample(&sample(k, 1.0), &mut rec);
    }
    app.execute(Command::Stop).expect("stop");
    ballpod_host::run_jobs(&mut app);
    app.flush(&mut rec);
    std::fs::write(dir.join("ccw.csv"), rec.runs[0].to_csv()).expect("ccw.csv");

    let mut plain = String::from("# exported from another recorder\nt_s,dl_um,x_mm,y_mm\n");
    for k in 0..=PER_REV {
        let s = sample(k, -1.0);
        plain += &format!(
            "{:.6},{},{},{}\n",
            s.t_us as f64 * 1e-6,
            s.delta_l_um,
            s.axes[0],
            s.axes[1]
        );
    }
    std::fs::write(dir.join("cw_plain.csv"), plain).expect("cw_plain.csv");
    let session = dir.join("session.toml");
    std::fs::write(
        &session,
        ballpod_host::docs::block_after("## Session file", "toml"),
    )
    .expect("session");

    let read = read_inputs(&[session]);
    let _ = std::fs::remove_dir_all(&dir);
    let inputs = read.expect("the docs' session file reads");
    let (runs, host) = (inputs.runs, inputs.host);
    assert!(host.is_empty());
    let names: Vec<_> = runs
        .iter()
        .map(|(n, r)| (n.as_str(), r.meta.pattern, r.meta.direction))
        .collect();
    assert_eq!(
        names,
        [
            ("ccw.csv", Pattern::Circle, Direction::Ccw),
            ("cw_plain.csv", Pattern::Circle, Direction::Cw)
        ]
    );
    let report = replay(&runs).expect("replay");
    // each run's eccentricity is the traced one (first-order model: exact to 1e-7 µm)
    for run in &report.runs {
        let fig = |name: &str| {
            run.results
                .iter()
                .find(|f| f.name == name)
                .unwrap_or_else(|| panic!("{} has {name}", run.source))
                .value
        };
        assert_eq!(run.outcome, "DONE", "{}", run.source);
        for (name, truth) in [("ecc_u", E_UM[0]), ("ecc_v", E_UM[1]), ("r0", R0_UM)] {
            let got = f64::from(fig(name));
            assert!(
                (got - truth).abs() < 1e-3,
                "{}: {name} {got} µm",
                run.source
            );
        }
    }
    // both directions measured: the bidirectional figures exist
    for name in ["G_ccw", "G_cw", "G_bidir", "H"] {
        assert!(report.result(name).is_some(), "{name}");
    }
}

/// The pod's own log of a run longer than it holds (`DATA:LOG?`: 1 sample in 32 here) replays
/// as the run ended, DONE (the samples it thinned out are not lost ones), and the replayed fit
/// is the f64 fit of the logged samples; the same log with a sample off its 1-in-d grid is
/// refused with the sample named.
#[test]
fn the_pods_decimated_log_replays_as_done_with_the_fit_of_its_samples() {
    use ballpod::app::log::{LOG_CAPACITY, SampleLog};
    use ballpod::protocol::download::write_csv;
    let (radius, feed_mm_per_s, rate_hz) = (150.0f64, 6000.0 / 60.0, 1000.0);
    let centre = [120.5f32, -40.25, -310.0];
    let mut cfg = Config {
        bar_length_mm: radius as f32,
        ..Config::default()
    };
    cfg.setup.circle_centre_mm = centre;
    cfg.setup.circle_radius_mm = radius as f32;
    let mut app = App::new(cfg, [16; MAX_AXES]);
    let mut log = Box::new(SampleLog::<LOG_CAPACITY>::new());
    app.set_pattern(Pattern::Circle).expect("pattern");
    app.execute(Command::Arm).expect("arm");
    app.execute(Command::Start).expect("start");
    let mut rng = Rng::new(0xDEC1);
    let e_um = [3.0, -2.0];
    let n = (radius * std::f64::consts::TAU / feed_mm_per_s * rate_hz) as usize;
    for i in 0..=n {
        let th = std::f64::consts::TAU * i as f64 / n as f64;
        let (s, c) = th.sin_cos();
        let len = (radius * c + e_um[0] * 1e-3).hypot(radius * s + e_um[1] * 1e-3);
        let mut axes = [0.0f32; MAX_AXES];
        axes[..3].copy_from_slice(&centre);
        axes[0] = (f64::from(centre[0]) + radius * c) as f32;
        axes[1] = (f64::from(centre[1]) + radius * s) as f32;
        let sample = Sample {
            seq: 7 + i as u32,
            t_us: 5_000_000 + i as u64 * 1000,
            delta_l_um: ((len - radius) * 1e3 + 0.2 * rng.normal()) as f32,
            axes,
            temp_c: 20.0,
            flags: SampleFlags::NONE,
        };
        app.on_sample(&sample, &mut *log);
    }
    app.execute(Command::Stop).expect("stop");
    app.flush(&mut *log);
    assert_eq!(app.session(), SessionState::Done);
    assert_eq!(
        log.decimation(),
        32,
        "{n} samples in {LOG_CAPACITY} records"
    );
    let mut text = Vec::new();
    write_csv(&log, app.run_meta(), &mut |c: &[u8]| {
        text.extend_from_slice(c)
    });
    let text = String::from_utf8(text).expect("utf-8");
    let runs = parse_runs(Path::new("log.csv"), &text).expect("parse");
    let logged: Vec<Sample> = runs[0].samples().copied().collect();
    let report =
        replay(&[("log.csv".to_string(), runs[0].clone())]).expect("a decimated log replays");
    assert_eq!(report.runs[0].outcome, "DONE");
    assert_eq!(report.runs[0].samples, logged.len());
    let [r0, eu, ev] = oracle_fit(CirclePlane::XY, centre, &logged);
    for (name, oracle) in [("r0", r0), ("ecc_u", eu), ("ecc_v", ev)] {
        let got = report.runs[0]
            .results
            .iter()
            .find(|f| f.name == name)
            .unwrap_or_else(|| panic!("{name} not in the run's results"));
        assert!(
            (f64::from(got.value) - oracle).abs() <= 1e-3,
            "{name}: replay {} oracle {oracle} µm",
            got.value
        );
    }
    // a row off the grid: refused, the sample named
    let mut off = runs[0].clone();
    if let Some(Event::Sample(s)) = off.events.get_mut(3) {
        s.seq += 1;
    }
    let e = replay(&[("log.csv".to_string(), off)]).expect_err("a sample off the grid");
    assert!(e.contains("is not one the log keeps (1 in 32"), "{e}");
}
