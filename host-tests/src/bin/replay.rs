//! `cargo replay SESSION [--out DIR]`: reads a session description (JSON or TOML) and the
//! sample logs it lists (CSV, as the pod streams them over USB), runs them through the same
//! core code as the simulator and writes the same `results.json` and SVG plots.
//!
//! A malformed file is rejected with its name, line and field, and nothing is written.

use std::path::PathBuf;

use ballpod_host::analysis::analyse;
use ballpod_host::logfile::read_session;
use ballpod_host::report;

const USAGE: &str = "usage: cargo replay SESSION.json|SESSION.toml [--out DIR]";

fn main() {
    let mut session = None;
    let mut out = PathBuf::from("replay-out");
    let mut it = std::env::args().skip(1);
    while let Some(a) = it.next() {
        match a.as_str() {
            "--out" => match it.next() {
                Some(d) => out = PathBuf::from(d),
                None => fail("--out needs a value", 2),
            },
            "-h" | "--help" => fail("", 2),
            _ if session.is_none() && !a.starts_with("--") => session = Some(PathBuf::from(a)),
            _ => fail(&format!("unexpected argument {a}"), 2),
        }
    }
    let Some(session) = session else {
        fail("no session file given", 2)
    };
    let (desc, runs) = match read_session(&session) {
        Ok(v) => v,
        Err(e) => fail(&e.to_string(), 1),
    };
    let results = match analyse(&desc, &runs) {
        Ok(r) => r,
        Err(e) => fail(&e, 1),
    };
    let write = |name: &str, text: &str| {
        let p = out.join(name);
        if let Err(e) = std::fs::write(&p, text) {
            fail(&format!("{}: {e}", p.display()), 1);
        }
    };
    if let Err(e) = std::fs::create_dir_all(&out) {
        fail(&format!("{}: {e}", out.display()), 1);
    }
    match report::results_json(&results) {
        Ok(j) => write("results.json", &j),
        Err(e) => fail(&e, 1),
    }
    for (name, svg) in report::plots(&desc, &runs, &results) {
        write(&name, &svg);
    }
    println!(
        "replayed {} logs: {} run fits{}{}; results in {}",
        runs.len(),
        results.runs.len(),
        if results.seed002.is_some() {
            ", seed 002 identification"
        } else {
            ""
        },
        if results.iso230_4.is_some() {
            ", ISO 230-4 figures"
        } else {
            ""
        },
        out.display()
    );
}

fn fail(msg: &str, code: i32) -> ! {
    if !msg.is_empty() {
        eprintln!("replay: {msg}");
    }
    eprintln!("{USAGE}");
    std::process::exit(code)
}
