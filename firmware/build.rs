//! Puts `memory.x` where the linker finds it and links with cortex-m-rt's `link.x` (here rather
//! than in a `.cargo/config.toml`, which cargo ignores when run from another folder with
//! `--manifest-path`).

use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    std::fs::write(out.join("memory.x"), include_bytes!("memory.x")).expect("OUT_DIR writable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg=-Tlink.x");
    println!("cargo:rerun-if-changed=memory.x");
}
