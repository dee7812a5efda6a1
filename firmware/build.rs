//! Build script: hands `memory.x` (workspace root) to the linker, for the
//! bare-metal target only. A host build of the firmware is a plain program
//! and needs no linker script.

use std::{env, fs, path::PathBuf};

fn main() {
    let memory_x = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"))
        .join("..")
        .join("memory.x");
    println!("cargo:rerun-if-changed={}", memory_x.display());
    println!("cargo:rerun-if-changed=build.rs");

    // `cfg!(target_os)` in a build script describes the host; the target is in
    // CARGO_CFG_TARGET_OS.
    if env::var("CARGO_CFG_TARGET_OS").as_deref() != Ok("none") {
        return;
    }

    // cortex-m-rt's `link.x` does `INCLUDE memory.x`: put it on the search path.
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("set by cargo"));
    fs::copy(&memory_x, out.join("memory.x")).expect("copy memory.x into OUT_DIR");
    println!("cargo:rustc-link-search={}", out.display());
}
