//! `cargo replay FILE… [--out DIR]`: recorded runs — the pod's stream or log files, or a
//! session file (TOML / JSON) listing logs and the host-only methods' readings — fed back into
//! the pod's own application; writes `results.json` and the SVG plots (the same as `cargo sim`
//! for the runs it recorded, byte for byte).
//!
//! A malformed file is rejected with its name, line and field, and nothing is written.

use std::path::PathBuf;

use clap::Parser;

use ballpod_host::replay::{Report, replay};
use ballpod_host::report;
use ballpod_host::session_file::read_inputs;

/// Recorded runs (the pod's stream or log, or a session file) through the pod's own
/// application: results.json and polar plots.
#[derive(Parser, Debug)]
#[command(name = "cargo replay", version)]
struct Args {
    /// Pod files (a recorded stream or a `DATA:LOG?` download) or a session file (.toml, .json).
    #[arg(required = true)]
    files: Vec<PathBuf>,
    /// Output directory.
    #[arg(long, default_value = "replay-out")]
    out: PathBuf,
}

fn main() {
    let args: Args = ballpod_host::cli::parse();
    if let Err(e) = run(&args) {
        eprintln!("replay: {e}");
        std::process::exit(1);
    }
}

fn run(args: &Args) -> Result<(), String> {
    let inputs = read_inputs(&args.files).map_err(|e| e.to_string())?;
    let (runs, host, rtest_covariance) = (inputs.runs, inputs.host, inputs.rtest_covariance);
    let mut report = if runs.is_empty() {
        Report::default()
    } else {
        replay(&runs)?
    };
    report.host = host;
    report.rtest_covariance = rtest_covariance;
    std::fs::create_dir_all(&args.out).map_err(|e| format!("{}: {e}", args.out.display()))?;
    let write = |name: &str, text: &str| -> Result<(), String> {
        let p = args.out.join(name);
        std::fs::write(&p, text).map_err(|e| format!("{}: {e}", p.display()))
    };
    write("results.json", &report.to_json()?)?;
    for (name, svg) in report::plots(&runs, &report) {
        write(&name, &svg)?;
    }
    for (name, text) in &inputs.files {
        write(name, text)?;
    }
    println!(
        "replayed {} runs ({} done), {} results{}{}; written to {}",
        report.runs.len(),
        report.runs.iter().filter(|r| r.outcome == "DONE").count(),
        report.results.len(),
        if report.host.is_empty() {
            String::new()
        } else {
            format!(", {} host-method figures", report.host.len())
        },
        if inputs.files.is_empty() {
            String::new()
        } else {
            let names: Vec<&str> = inputs.files.iter().map(|f| f.0.as_str()).collect();
            format!(" ({})", names.join(", "))
        },
        args.out.display()
    );
    Ok(())
}
