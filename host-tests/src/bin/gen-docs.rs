//! `gen-docs`: writes the book's reference pages (`docs/src/reference/*.md`), generated from the
//! code's own tables (`ballpod_host::docs_ref`), and the ball-bar signature plots
//! (`docs/src/images/signatures/*.svg`, from the virtual machine's forward model,
//! `ballpod_host::report::svg::signature_plots`) into the repository given as the only argument
//! (default: the current directory). `host-tests/tests/docs.rs` checks the committed files.
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
    let root = args.root.unwrap_or_else(|| PathBuf::from("."));
    let pages = ballpod_host::docs_ref::pages()
        .into_iter()
        .map(|p| (ballpod_host::docs_ref::DIR, p.file.to_string(), p.text));
    let plots = ballpod_host::report::svg::signature_plots()
        .into_iter()
        .map(|(file, svg)| (ballpod_host::report::svg::SIGNATURE_DIR, file, svg));
    for (dir, file, text) in pages.chain(plots) {
        let dir = root.join(dir);
        let path = dir.join(file);
        if let Err(e) = std::fs::create_dir_all(&dir).and_then(|()| std::fs::write(&path, text)) {
            eprintln!("gen-docs: {}: {e}", path.display());
            std::process::exit(1);
        }
        println!("{}", path.display());
    }
}
