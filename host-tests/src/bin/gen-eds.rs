//! `gen-eds`: writes the pod's CANopen EDS (CiA 306), generated from the firmware's object
//! dictionary, to stdout or to the file given as the only argument (usually `ballpod.eds` at
//! the repository root; `host-tests/tests/canopen_eds.rs` checks that the committed file is
//! current).
use std::io::Write;
use std::path::PathBuf;

use clap::Parser;

/// Writes the pod's CANopen EDS (CiA 306), generated from its object dictionary.
#[derive(Parser, Debug)]
#[command(name = "gen-eds", version)]
struct Args {
    /// Output file (default: stdout).
    output: Option<PathBuf>,
}

fn main() {
    let args = Args::parse();
    let mut text = String::new();
    if let Err(e) = ballpod::protocol::canopen::eds::write_eds(&mut text) {
        eprintln!("gen-eds: formatting failed: {e}");
        std::process::exit(1);
    }
    let result = match &args.output {
        None => std::io::stdout().write_all(text.as_bytes()),
        Some(path) => std::fs::write(path, &text),
    };
    if let Err(e) = result {
        eprintln!("gen-eds: {e}");
        std::process::exit(1);
    }
}
