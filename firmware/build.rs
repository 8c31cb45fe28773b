//! Puts `memory.x` where the linker finds it and links with cortex-m-rt's `link.x` (here rather
//! than in a `.cargo/config.toml`, which cargo ignores when run from another folder with
//! `--manifest-path`), and writes the shared secret the firmware is built with (the file named by
//! `STRAHL_FIRMWARE_SECRET_FILE` without its trailing line break, or nothing) and the heap's size
//! (`STRAHL_FIRMWARE_HEAP_KIB`).

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
    println!("cargo:rerun-if-env-changed={HEAP_KIB}");
    let kib: usize = match std::env::var(HEAP_KIB) {
        Ok(v) => v
            .trim()
            .parse()
            .ok()
            .filter(|&k| (64..=3840).contains(&k))
            .unwrap_or_else(|| panic!("{HEAP_KIB}={v}: give KiB from 64 to 3840")),
        Err(_) => 3840,
    };
    std::fs::write(out.join("heap_size.rs"), format!("{kib} * 1024")).expect("OUT_DIR writable");
}

/// The environment variable giving the heap's size in KiB (default 3840, what the MPS2 AN386's
/// 4 MiB leave after the stack and statics; a board with less RAM needs less).
const HEAP_KIB: &str = "STRAHL_FIRMWARE_HEAP_KIB";

/// The environment variable naming the secret's file.
const SECRET_FILE: &str = "STRAHL_FIRMWARE_SECRET_FILE";
