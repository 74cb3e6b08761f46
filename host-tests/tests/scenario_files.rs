//! Scenario tests: every file in `host-tests/scenarios/` is one test here (a test checks that
//! none is left out). Each runs its method on the virtual machine and compares the pod's
//! result with the scenario's truth under the scenario's expectation.

use std::path::PathBuf;

use ballpod_host::scenario;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenarios")
}

fn check(file: &str) {
    let s = scenario::read(&dir().join(file)).expect("scenario file");
    let checks = scenario::run(&s).unwrap_or_else(|e| panic!("{file}: {e}"));
    assert!(!checks.is_empty(), "{file}: nothing checked");
    for c in &checks {
        eprintln!(
            "{file}: {:<24} truth {:>12.4} got {:>12.4} u {:>8.4} {}",
            c.name, c.truth, c.got, c.u, c.unit
        );
    }
    let failures: Vec<String> = checks.iter().filter_map(|c| c.failure(&s.expect)).collect();
    assert!(
        failures.is_empty(),
        "{file} ({}):\n{}",
        s.description,
        failures.join("\n")
    );
}

macro_rules! scenarios {
    ($($name:ident => $file:literal),* $(,)?) => {
        $(#[test] fn $name() { check($file); })*
        const FILES: &[&str] = &[$($file),*];
    };
}

scenarios! {
    seed000_two_step_rrttt => "seed000_two_step_rrttt.toml",
    seed000_two_step_tttrr => "seed000_two_step_tttrr.toml",
    seed000_two_step_rtttr_spindle => "seed000_two_step_rtttr_spindle.toml",
    seed000_two_step_rtttr_table => "seed000_two_step_rtttr_table.toml",
    seed002_ballbar_thesis => "seed002_ballbar_thesis.toml",
    seed002_ballbar_offsets => "seed002_ballbar_offsets.toml",
    seed002_probe => "seed002_probe.toml",
    seed002_probe_b_axis => "seed002_probe_b_axis.toml",
    seed003_rtest_table4 => "seed003_rtest_table4.toml",
    seed004_dial_gauge => "seed004_dial_gauge.toml",
    seed004_dial_gauge_right_handed => "seed004_dial_gauge_right_handed.toml",
    iso230_4_typical => "iso230_4_typical.toml",
    iso230_4_backlash_only => "iso230_4_backlash_only.toml",
}

#[test]
fn every_scenario_file_is_a_test_and_every_method_is_covered() {
    let mut on_disk: Vec<String> = std::fs::read_dir(dir())
        .expect("scenarios dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".toml"))
        .collect();
    on_disk.sort();
    let mut listed: Vec<String> = FILES.iter().map(|s| s.to_string()).collect();
    listed.sort();
    assert_eq!(on_disk, listed);
    let methods: std::collections::BTreeSet<String> = FILES
        .iter()
        .map(|f| scenario::read(&dir().join(f)).expect("file").method)
        .collect();
    for m in [
        "seed000_two_step",
        "seed002_ballbar",
        "seed002_probe",
        "seed002_probe_b_axis",
        "seed003_rtest",
        "seed004_dial_gauge",
        "iso230_4",
    ] {
        assert!(methods.contains(m), "no scenario for {m}");
    }
}
