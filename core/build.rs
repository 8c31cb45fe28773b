//! Rebuilds the crate when `STRAHL_CPU` changes: `pgo/rustc-wrapper` compiles it for that
//! processor level in optimised x86_64 builds, and Cargo does not see the wrapper's environment.

fn main() {
    println!("cargo:rerun-if-env-changed=STRAHL_CPU");
}
