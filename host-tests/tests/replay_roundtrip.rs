//! Replaying what the simulator recorded gives the simulator's report byte for byte: the runs
//! are written as `cargo sim --write-logs` writes them (one pod CSV per run in the stream's
//! text, and a `session.toml` listing them), read back as `cargo replay` reads them, fed into a
//! fresh application, and the JSON texts (and the polar plots) are compared. The samples
//! themselves come back bit for bit, and the report holds what the session ran.

use std::path::{Path, PathBuf};

use ballpod_host::recording::{Event, RecordedRun, parse_runs};
use ballpod_host::replay::replay;
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
    };
    let s = simulate(&m, &o, &mut |_, _, _| {}).expect("simulated session");
    let sim = &s.report;
    // the session ran what was asked: ten seed 002 runs and two circles, all done, and the
    // procedures' results are there
    assert_eq!(s.runs.len(), 12);
    assert_eq!(sim.runs.len(), 12);
    assert!(
        sim.runs.iter().all(|r| r.outcome == "DONE"),
        "{:?}",
        sim.runs
    );
    for name in ["dx_CZ", "th_alpha_CZ", "e_CR2_y", "G_bidir", "squareness"] {
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
    let (runs, host) = read_inputs(&[dir.join("session.toml")]).expect("read the session");
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
    let (direct, _) = read_inputs(&files).expect("read the run files");
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
