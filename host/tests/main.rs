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

/// Every `.rs` file of `host/tests/` is a module of this binary or a test target of its own in
/// `host/Cargo.toml` (the package sets `autotests = false`, so cargo would not find a new file
/// by itself).
#[test]
fn every_test_file_is_compiled() -> support::TestResult {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let declared = |name: &str| include_str!("main.rs").contains(&format!("\nmod {name};\n"));
    let own_binary =
        |name: &str| include_str!("../Cargo.toml").contains(&format!("\"tests/{name}.rs\""));
    let mut left_out = Vec::new();
    for entry in std::fs::read_dir(&dir)? {
        let path = entry?.path();
        let Some(name) = path.file_stem().and_then(|s| s.to_str()) else {
            continue;
        };
        let is_rs = path.extension().is_some_and(|e| e == "rs");
        if is_rs && name != "main" && !declared(name) && !own_binary(name) {
            left_out.push(name.to_owned());
        }
    }
    assert!(
        left_out.is_empty(),
        "not compiled into any test: {left_out:?}"
    );
    Ok(())
}
