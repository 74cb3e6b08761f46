//! The machine file (`--machine`): the example in the book's "Machine file" section (docs/src/simulator.md) parses with
//! `deny_unknown_fields`, names every key `MachineFile` has (so every fault the virtual machine
//! tool can inject is documented and settable), and states the defaults.

use ballpod_host::vmt::machine::MachineFile;
use std::collections::BTreeSet;

/// The ```toml block after the book's "## Machine file" heading.
fn readme_example() -> String {
    ballpod_host::docs::block_after("## Machine file (`--machine`", "toml")
}

/// `section.key` of every key of a two-level TOML table.
fn keys(v: &toml::Value) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for (s, t) in v.as_table().expect("table") {
        for k in t.as_table().expect("section").keys() {
            out.insert(format!("{s}.{k}"));
        }
    }
    out
}

#[test]
fn the_readme_example_names_every_key_and_states_the_defaults() {
    let text = readme_example();
    let parsed: MachineFile = toml::from_str(&text).expect("the docs' example parses");
    let documented = keys(&toml::from_str::<toml::Value>(&text).expect("toml"));
    let all = keys(&toml::Value::try_from(MachineFile::default()).expect("serialise"));
    let missing: Vec<_> = all.difference(&documented).collect();
    assert!(
        missing.is_empty(),
        "keys not in the docs' example: {missing:?}"
    );
    assert_eq!(parsed, MachineFile::default());
}

#[test]
fn an_unknown_key_is_rejected_and_the_fault_keys_parse_from_toml_and_json() {
    let err = toml::from_str::<MachineFile>("[circle]\nstraightnes_x_along_y_um = 1.0\n");
    assert!(err.is_err());
    let mut m = MachineFile::default();
    m.circle.straightness_x_along_y_um = 3.0;
    m.circle.straightness_y_along_x_um = -2.0;
    m.circle.socket_offset_um = [5.0, -1.0];
    m.circle.thermal_growth_x_um_per_min = 0.5;
    m.instrument.bar_temp_drift_c_per_min = 1.5;
    m.instrument.thermistor_detached = true;
    m.instrument.lvdt_nonlinearity_per_um = 1e-5;
    let json = serde_json::to_string(&m).expect("json");
    assert_eq!(serde_json::from_str::<MachineFile>(&json).expect("back"), m);
    let toml = "[circle]\nstraightness_x_along_y_um = 3.0\nstraightness_y_along_x_um = -2.0\n\
                socket_offset_um = [5.0, -1.0]\nthermal_growth_x_um_per_min = 0.5\n\
                [instrument]\nbar_temp_drift_c_per_min = 1.5\nthermistor_detached = true\n\
                lvdt_nonlinearity_per_um = 1e-5\n";
    assert_eq!(toml::from_str::<MachineFile>(toml).expect("toml"), m);
}
