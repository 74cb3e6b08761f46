//! Puts memory.x on the linker path and adds the cortex-m-rt / defmt linker scripts, for the
//! firmware binary on the bare-metal target only (host builds of the core link nothing); and
//! names the commit the build comes from (`BALLPOD_COMMIT`, every target).
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
    commit();
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

/// The commit the firmware is built from, for its version (`ballpod::FIRMWARE_VERSION`: CANopen
/// 0x100A, `*IDN?`): `git rev-parse --short=12 HEAD`, or `unknown` outside a git checkout. A
/// build with uncommitted changes carries the commit they are on.
fn commit() {
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".to_string());
    println!("cargo:rustc-env=BALLPOD_COMMIT={commit}");
    // a new commit moves HEAD's branch (a loose ref, or the packed ones)
    for p in [".git/HEAD", ".git/refs/heads", ".git/packed-refs"] {
        if std::path::Path::new(p).exists() {
            println!("cargo:rerun-if-changed={p}");
        }
    }
}
