//! Puts this crate's memory.x (the emulated board's map) on the linker path.
use std::{env, fs, path::PathBuf};

fn main() {
    let Some(out) = env::var_os("OUT_DIR").map(PathBuf::from) else {
        return;
    };
    if let Err(e) = fs::copy("memory.x", out.join("memory.x")) {
        println!("cargo:warning=cannot copy memory.x: {e}");
    }
    // cortex-m-rt's `device` feature includes device.x (a device crate's interrupt names):
    // src/board/hw.rs writes the vector table itself, so it is empty
    if let Err(e) = fs::write(out.join("device.x"), "") {
        println!("cargo:warning=cannot write device.x: {e}");
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rustc-link-arg-bins=-Tlink.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
