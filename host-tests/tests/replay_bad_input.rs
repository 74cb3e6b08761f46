//! Malformed logs and session files are rejected with the file, line and field named, and no
//! samples are returned.

use std::path::Path;

use ballpod_host::logfile::{LogError, read_log, read_session};

const GOOD: &str = "# ballpod sample log\n# method: CA\n\
t_s,dl_um,x_mm,y_mm,z_mm,b_deg,c_deg,temp_c,flags\n\
0.000000,1.5,50,0,165.53,0,0,20.5,0\n\
0.001000,1.25,49.99,0.31,165.53,0,0.36,20.5,0\n\
0.002000,1.0,49.98,0.62,165.53,0,0.72,20.5,32\n";

fn read(text: &str) -> Result<usize, LogError> {
    read_log(Path::new("run.csv"), text, "CA").map(|s| s.len())
}

fn rejected(text: &str, line: usize, field: Option<&str>, what: &str) {
    let e = read(text).expect_err("must be rejected");
    assert_eq!(e.file, Path::new("run.csv"));
    assert_eq!(e.line, line, "{e}");
    assert_eq!(e.field.as_deref(), field, "{e}");
    assert!(e.what.contains(what), "{e}");
    let shown = e.to_string();
    assert!(shown.starts_with(&format!("run.csv:{line}")), "{shown}");
}

#[test]
fn a_good_log_reads() {
    let s = read_log(Path::new("run.csv"), GOOD, "CA").expect("good");
    assert_eq!(s.len(), 3);
    assert_eq!(s[1].t_us, 1000);
    assert_eq!(s[1].delta_l_um, 1.25);
    assert_eq!(s[1].axes, [49.99, 0.31, 165.53, 0.0, 0.36]);
    assert_eq!(s[2].flags.0, 32);
}

#[test]
fn missing_column() {
    let t = GOOD.replace("t_s,dl_um,x_mm,y_mm,", "t_s,dl_um,x_mm,");
    let t = t
        .lines()
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            if l.starts_with('#') || l.starts_with("t_s") {
                l.to_string()
            } else {
                [&f[..3], &f[4..]].concat().join(",")
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    rejected(&t, 3, Some("y_mm"), "missing column");
    rejected(
        &GOOD.replace("t_s,dl_um", "t_s,x_um2"),
        3,
        Some("x_um2"),
        "unknown unit",
    );
}

#[test]
fn bad_number() {
    rejected(
        &GOOD.replace("1.25", "1.2.5"),
        5,
        Some("dl_um"),
        "bad number",
    );
    rejected(&GOOD.replace("49.98", "NaN"), 6, Some("x_mm"), "bad number");
    rejected(&GOOD.replace(",32", ",-1"), 6, Some("flags"), "bad number");
}

#[test]
fn non_monotonic_time() {
    rejected(
        &GOOD.replace("0.002000", "0.001000"),
        6,
        Some("t_s"),
        "not increasing",
    );
}

#[test]
fn unknown_unit() {
    rejected(
        &GOOD.replace("x_mm", "x_in"),
        3,
        Some("x_in"),
        "unknown unit",
    );
    rejected(
        &GOOD.replace("dl_um", "dl_mm"),
        3,
        Some("dl_mm"),
        "unknown unit",
    );
    rejected(
        &GOOD.replace("temp_c", "temp_k"),
        3,
        Some("temp_k"),
        "unknown unit",
    );
}

#[test]
fn wrong_field_count() {
    rejected(
        &GOOD.replace("20.5,0\n0.001", "20.5\n0.001"),
        4,
        None,
        "fields",
    );
}

#[test]
fn bad_session_file() {
    let dir = std::env::temp_dir().join(format!("ballpod-bad-session-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("dir");
    let p = dir.join("session.json");
    std::fs::write(
        &p,
        "{\n  \"runs\": [\n    {\"log\": \"a.csv\", \"method\": \"BX\", \"direction\": \"UP\"}\n  ]\n}\n",
    )
    .expect("write");
    let e = read_session(&p).expect_err("bad direction");
    assert_eq!(e.field.as_deref(), Some("runs[0]"), "{e}");
    std::fs::write(&p, "{\n  \"runs\": [\n    {\"log\": 5}\n  ]\n}\n").expect("write");
    let e = read_session(&p).expect_err("bad type");
    assert_eq!(e.line, 3, "{e}");
    let p = dir.join("session.toml");
    std::fs::write(
        &p,
        "[[runs]]\nlog = \"a.csv\"\nmethod = \"CA\"\ndirection = \"CW\"\nbogus = 1\n",
    )
    .expect("write");
    let e = read_session(&p).expect_err("unknown key");
    assert!(e.line >= 1, "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
