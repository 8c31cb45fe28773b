//! `pgo/rustc-wrapper`, through which Cargo runs rustc (`.cargo/config.toml`), adds the committed
//! profile to optimised builds for x86_64 Linux by a compiler that reads it, and to nothing else.
//!
//! Each test runs the wrapper with a stand-in compiler, a script that prints the arguments it was
//! given (and, asked `-vV`, an LLVM version), and reads back what the wrapper passed on.
//! `pgo/check.sh` (run by `.ci/run`) checks the other half: that the release binary built with
//! the profile renders the same bytes as the test build without it.

use std::fs;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::Command;

fn pgo_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../pgo")
        .canonicalize()
        .expect("the pgo folder of the checkout")
}

/// The arguments the wrapper hands to a compiler whose LLVM is `llvm`, given `args`, with the
/// environment variable STRAHL_PGO set to `pgo` (or unset).
fn passed_on(llvm: u32, args: &[&str], pgo: Option<&str>) -> Vec<String> {
    let dir = tempfile::tempdir().expect("temporary folder");
    let fake = dir.path().join("rustc");
    fs::write(
        &fake,
        format!(
            "#!/bin/sh\nif [ \"$1\" = -vV ]; then echo 'release: 9.9.9'; \
             echo 'LLVM version: {llvm}.1.0'; exit 0; fi\n\
             for a in \"$@\"; do echo \"$a\"; done\n"
        ),
    )
    .expect("write the stand-in compiler");
    fs::set_permissions(&fake, fs::Permissions::from_mode(0o755)).expect("make it executable");
    let mut command = Command::new(pgo_dir().join("rustc-wrapper"));
    command.arg(&fake).args(args).env_remove("STRAHL_PGO");
    if let Some(value) = pgo {
        command.env("STRAHL_PGO", value);
    }
    let out = command.output().expect("run pgo/rustc-wrapper");
    assert!(out.status.success(), "the wrapper failed: {out:?}");
    String::from_utf8(out.stdout)
        .expect("UTF-8 arguments")
        .lines()
        .map(str::to_owned)
        .collect()
}

/// The LLVM major version that wrote the committed profile (`pgo/recorded-with`).
fn recorded_llvm() -> u32 {
    let text = fs::read_to_string(pgo_dir().join("recorded-with")).expect("pgo/recorded-with");
    text.lines()
        .find_map(|l| l.strip_prefix("llvm "))
        .and_then(|v| v.parse().ok())
        .expect("an `llvm N` line in pgo/recorded-with")
}

const RELEASE: &[&str] = &["--crate-name", "strahl_core", "-C", "opt-level=3"];

fn with_profile(args: &[&str]) -> Vec<String> {
    let profile = pgo_dir().join("x86_64-unknown-linux-gnu.profdata");
    assert!(profile.is_file(), "the committed profile is missing");
    let mut v: Vec<String> = args.iter().map(|a| a.to_string()).collect();
    v.push(format!("-Cprofile-use={}", profile.display()));
    v
}

fn unchanged(args: &[&str]) -> Vec<String> {
    args.iter().map(|a| a.to_string()).collect()
}

#[test]
fn an_optimised_build_for_this_machine_gets_the_profile() {
    let llvm = recorded_llvm();
    let expected = if cfg!(all(target_os = "linux", target_arch = "x86_64")) {
        with_profile(RELEASE)
    } else {
        unchanged(RELEASE)
    };
    assert_eq!(passed_on(llvm, RELEASE, None), expected);
    assert_eq!(passed_on(llvm + 1, RELEASE, Some("on")), expected);
}

#[test]
fn other_builds_are_passed_through_unchanged() {
    let llvm = recorded_llvm();
    let test_profile = ["--crate-name", "strahl_core", "-C", "opt-level=2"];
    assert_eq!(
        passed_on(llvm, &test_profile, None),
        unchanged(&test_profile)
    );
    let debug = ["--crate-name", "strahl_core", "-C", "debuginfo=2"];
    assert_eq!(passed_on(llvm, &debug, None), unchanged(&debug));
    let cross = [
        "--crate-name",
        "strahl_core",
        "--target",
        "thumbv7em-none-eabihf",
        "-C",
        "opt-level=3",
    ];
    assert_eq!(passed_on(llvm, &cross, None), unchanged(&cross));
    let recording = [
        "--crate-name",
        "x",
        "-C",
        "opt-level=3",
        "-Cprofile-generate=/tmp/r",
    ];
    assert_eq!(passed_on(llvm, &recording, None), unchanged(&recording));
}

#[test]
fn the_profile_is_left_out_when_asked_or_unreadable() {
    let llvm = recorded_llvm();
    assert_eq!(passed_on(llvm, RELEASE, Some("off")), unchanged(RELEASE));
    // An older LLVM cannot read a newer profile's format: the build goes on without it.
    assert_eq!(passed_on(llvm - 1, RELEASE, None), unchanged(RELEASE));
}
