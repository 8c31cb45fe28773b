//! The host's integration tests, in one binary: each file of `host/tests/` is a module here
//! (`cli_worker_cores.rs` excepted, which has a binary of its own), so cargo compiles and links
//! the tests once rather than once per file. `support` is shared by the end-to-end tests of
//! `strahl render` and `strahl worker`, `common` by the parsers' tests, `browser` by the live
//! view's.
//!
//! The tests of all files run side by side (cargo's test threads, one per CPU); a test that
//! measures the CPUs it is given must not share them, and lives in a binary of its own.
//!
//! On a 2-core AMD EPYC, with `.ci/run`'s settings: as 27 binaries, the host's integration
//! tests took 62 s to build after their files changed (121 CPU-seconds) and `cargo test -p
//! strahl-host` 127 to 134 s to run; as this one and `cli_worker_cores`, 31 to 32 s (51 to 59
//! CPU-seconds) and 97 to 106 s, as the slow tests of one file (the board's, Slurm's) no longer
//! leave a CPU idle while they wait.

mod browser;
mod common;
mod support;

mod bench_accuracy;
mod cli;
mod cli_addresses;
mod cli_auth;
mod cli_bench_peers;
mod cli_chaos;
mod cli_destinations;
mod cli_firmware;
mod cli_flood;
mod cli_formats;
mod cli_generate_bench;
mod cli_output;
mod cli_resume;
mod cli_serial;
mod cli_shell;
mod cli_slurm;
mod cli_stats;
mod cli_tcp;
mod cli_view;
mod load;
mod parse_config;
mod parse_data;
mod parse_fart;
mod parse_nff;
mod parse_obj;
mod view_server;

/// Every `.rs` file of `host/tests/` is compiled: a module of this binary or a test target of its
/// own in `host/Cargo.toml` (`autotests = false`, so cargo would not find a new file by itself).
#[test]
fn every_test_file_is_compiled() -> Result<(), String> {
    let (main_rs, manifest) = (include_str!("main.rs"), include_str!("../Cargo.toml"));
    strahl_core_tests::test_files::check(env!("CARGO_MANIFEST_DIR"), main_rs, manifest)
}
