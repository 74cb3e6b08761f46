//! Puts memory.x on the linker path and adds the cortex-m-rt / defmt linker scripts, for the
//! firmware binary on the bare-metal target only (host builds of the core link nothing).
use std::{env, fs, path::PathBuf};

fn main() {
    let Some(out) = env::var_os("OUT_DIR").map(PathBuf::from) else {
        println!("cargo:warning=OUT_DIR not set");
        return;
    };
    if let Err(e) = fs::copy("memory.x", out.join("memory.x")) {
        println!("cargo:warning=cannot copy memory.x: {e}");
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-changed=build.rs");
    let target = env::var("TARGET").unwrap_or_default();
    if target.starts_with("thumb") {
        println!("cargo:rustc-link-arg-bins=--nmagic");
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
        // Identical code folding: monomorphised copies that compile to the same machine code
        // (e.g. embassy's per-peripheral generics) share one body; 0.6 KB of flash.
        println!("cargo:rustc-link-arg-bins=--icf=all");
    }
}
