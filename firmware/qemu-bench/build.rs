//! Puts the memory map of the chosen machine on the linker's search path as
//! `memory.x` (cortex-m-rt's `link.x` INCLUDEs it): QEMU's mps2-an386
//! (`memory-mps2-an386.x`) by default, the STM32F446RE
//! (`memory-stm32f446.x`) with `--features stm32f446`. Neither file is named
//! `memory.x`: the linker runs in this directory and would find that one
//! first, whatever the feature.
//!
//! Linker scripts: cortex-m-rt's `link.x` must be passed exactly once. When
//! the bench is built from inside the main workspace, Cargo merges the
//! workspace's .cargo/config.toml, which already passes `-Tlink.x -Tdefmt.x
//! --nmagic` for the firmware; this script adds `-Tlink.x` only when the
//! rustflags lack it, and writes an empty `defmt.x` (the bench has no defmt).

use std::{env, fs, path::PathBuf};

fn main() {
    let dir = PathBuf::from(env::var_os("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let source = if env::var_os("CARGO_FEATURE_STM32F446").is_some() {
        "memory-stm32f446.x"
    } else {
        "memory-mps2-an386.x"
    };
    let out = PathBuf::from(env::var_os("OUT_DIR").expect("set by cargo"));
    fs::copy(dir.join(source), out.join("memory.x")).expect("copy the memory map into OUT_DIR");
    fs::write(
        out.join("defmt.x"),
        "/* empty: this bench does not use defmt */\n",
    )
    .expect("write an empty defmt.x");
    println!("cargo:rustc-link-search={}", out.display());
    let flags = env::var("CARGO_ENCODED_RUSTFLAGS").unwrap_or_default();
    if !flags.split('\x1f').any(|f| f.ends_with("-Tlink.x")) {
        println!("cargo:rustc-link-arg=-Tlink.x");
    }
    println!("cargo:rerun-if-changed=memory-mps2-an386.x");
    println!("cargo:rerun-if-changed=memory-stm32f446.x");
    println!("cargo:rerun-if-changed=build.rs");
}
