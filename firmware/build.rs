//! Puts the chosen board's `memory.x` where cortex-m-rt's `link.x` finds it
//! and links with `link.x` (no `.cargo/config.toml` needed).

use std::path::PathBuf;

fn main() {
    let board = if std::env::var_os("CARGO_FEATURE_STM32F401").is_some() {
        "stm32f401"
    } else {
        "qemu-mps2-an386"
    };
    let out = PathBuf::from(std::env::var_os("OUT_DIR").unwrap_or_default());
    let memory = std::fs::read(format!("memory/{board}.x"))
        .unwrap_or_else(|e| panic!("memory/{board}.x: {e}"));
    std::fs::write(out.join("memory.x"), memory)
        .unwrap_or_else(|e| panic!("{}: {e}", out.display()));
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory");
    println!("cargo:rerun-if-changed=build.rs");
    if std::env::var("TARGET").is_ok_and(|t| t.starts_with("thumb")) {
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
    }
}
