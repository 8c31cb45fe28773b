//! The cross-crate tests, in one binary: each file of `tests/tests/` is a module here, so cargo
//! compiles and links them once rather than once per file (they link the host, its transports and
//! the core). `fuzz_entry` holds the fuzzing entry points that `fuzz_corpus` and `fuzz/` share.
//! The tests of all files run side by side, one per CPU.

mod fuzz_entry;

mod camera_cover;
mod cluster_sim;
mod fault_injection;
mod fuzz_corpus;
mod golden;
mod hard_cases;
mod layers;
mod multisample;
mod packets;
mod pgo_record;
mod pgo_wrapper;
mod protocol_frames;
mod protocol_worker;

/// Every `.rs` file of `tests/tests/` is compiled: a module of this binary (`autotests = false`,
/// so cargo would not find a new file by itself).
#[test]
fn every_test_file_is_compiled() -> Result<(), String> {
    let (main_rs, manifest) = (include_str!("main.rs"), include_str!("../Cargo.toml"));
    strahl_core_tests::test_files::check(env!("CARGO_MANIFEST_DIR"), main_rs, manifest)
}
