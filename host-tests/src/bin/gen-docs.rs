//! `gen-docs`: writes the book's reference pages (`docs/src/reference/*.md`), generated from the
//! code's own tables (`ballpod_host::docs_ref`), into the repository given as the only argument
//! (default: the current directory). `host-tests/tests/docs.rs` checks the committed pages.
use std::path::PathBuf;

use clap::Parser;

/// Writes the book's reference pages, generated from the code.
#[derive(Parser, Debug)]
#[command(name = "gen-docs", version)]
struct Args {
    /// Repository root (default: the current directory).
    root: Option<PathBuf>,
}

fn main() {
    let args = Args::parse();
    let dir = args
        .root
        .unwrap_or_else(|| PathBuf::from("."))
        .join(ballpod_host::docs_ref::DIR);
    if let Err(e) = std::fs::create_dir_all(&dir) {
        eprintln!("gen-docs: {}: {e}", dir.display());
        std::process::exit(1);
    }
    for page in ballpod_host::docs_ref::pages() {
        let path = dir.join(page.file);
        if let Err(e) = std::fs::write(&path, page.text) {
            eprintln!("gen-docs: {}: {e}", path.display());
            std::process::exit(1);
        }
        println!("{}", path.display());
    }
}
