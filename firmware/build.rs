//! Puts `memory.x` where the linker finds it and links with cortex-m-rt's `link.x` (here rather
//! than in a `.cargo/config.toml`, which cargo ignores when run from another folder with
//! `--manifest-path`), and writes the shared secret the firmware is built with: the file named by
//! `STRAHL_FIRMWARE_SECRET_FILE` without its trailing line break, or nothing.

use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    std::fs::write(out.join("memory.x"), include_bytes!("memory.x")).expect("OUT_DIR writable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg=-Tlink.x");
    println!("cargo:rerun-if-changed=memory.x");
    println!("cargo:rerun-if-env-changed={SECRET_FILE}");
    let mut secret = Vec::new();
    if let Some(path) = std::env::var_os(SECRET_FILE) {
        println!("cargo:rerun-if-changed={}", PathBuf::from(&path).display());
        secret = std::fs::read(&path)
            .unwrap_or_else(|e| panic!("{SECRET_FILE}={}: {e}", PathBuf::from(&path).display()));
        while secret.last().is_some_and(|b| matches!(b, b'\n' | b'\r')) {
            secret.pop();
        }
    }
    std::fs::write(out.join("secret"), secret).expect("OUT_DIR writable");
}

/// The environment variable naming the secret's file.
const SECRET_FILE: &str = "STRAHL_FIRMWARE_SECRET_FILE";
