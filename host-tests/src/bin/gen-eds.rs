//! `gen-eds`: writes the pod's CANopen EDS (CiA 306), generated from the firmware's object
//! dictionary, to stdout or to the file given as the only argument (usually `ballpod.eds` at
//! the repository root; `host-tests/tests/canopen_eds.rs` checks that the committed file is
//! current).
use std::io::Write;

fn main() {
    let mut text = String::new();
    if let Err(e) = ballpod::protocol::canopen::eds::write_eds(&mut text) {
        eprintln!("gen-eds: formatting failed: {e}");
        std::process::exit(1);
    }
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.as_slice() {
        [] => std::io::stdout().write_all(text.as_bytes()),
        [path] => std::fs::write(path, &text),
        _ => {
            eprintln!("usage: gen-eds [OUTPUT.eds]");
            std::process::exit(2);
        }
    };
    if let Err(e) = result {
        eprintln!("gen-eds: {e}");
        std::process::exit(1);
    }
}
