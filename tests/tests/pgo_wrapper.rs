//! `pgo/rustc-wrapper`, through which Cargo runs rustc (`.cargo/config.toml`), adds to optimised
//! builds for x86_64 Linux the processor level of the core (`STRAHL_CPU`, x86-64-v3 unless set)
//! and the committed profile, where the compiler reads it and the level is the profile's; and
//! adds nothing to other builds.
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
/// environment variable STRAHL_PGO set to `pgo` (or unset) and STRAHL_CPU unset.
fn passed_on(llvm: u32, args: &[&str], pgo: Option<&str>) -> Vec<String> {
    passed_on_for(llvm, args, pgo, None)
}

/// [`passed_on`] with STRAHL_CPU set to `cpu` (or unset).
fn passed_on_for(llvm: u32, args: &[&str], pgo: Option<&str>, cpu: Option<&str>) -> Vec<String> {
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
    command
        .arg(&fake)
        .args(args)
        .env_remove("STRAHL_PGO")
        .env_remove("STRAHL_CPU");
    if let Some(value) = pgo {
        command.env("STRAHL_PGO", value);
    }
    if let Some(value) = cpu {
        command.env("STRAHL_CPU", value);
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
const HOST_RELEASE: &[&str] = &["--crate-name", "strahl_host", "-C", "opt-level=3"];

/// True where the wrapper changes optimised builds at all.
const THIS_MACHINE: bool = cfg!(all(target_os = "linux", target_arch = "x86_64"));

fn unchanged(args: &[&str]) -> Vec<String> {
    args.iter().map(|a| a.to_string()).collect()
}

/// `args` with the core's processor level, on this machine.
fn for_cpu(args: &[&str], cpu: &str) -> Vec<String> {
    let mut v = unchanged(args);
    if THIS_MACHINE {
        v.push(format!("-Ctarget-cpu={cpu}"));
    }
    v
}

/// `args` with the flags an optimised build gets on this machine: the core's processor level
/// where `core`, then the profile.
fn optimised(args: &[&str], core: bool) -> Vec<String> {
    let mut v = if core {
        for_cpu(args, "x86-64-v3")
    } else {
        unchanged(args)
    };
    let profile = pgo_dir().join("x86_64-unknown-linux-gnu.profdata");
    assert!(profile.is_file(), "the committed profile is missing");
    if THIS_MACHINE {
        v.push(format!("-Cprofile-use={}", profile.display()));
    }
    v
}

#[test]
fn an_optimised_build_for_this_machine_gets_the_profile_and_the_core_its_processor_level() {
    let llvm = recorded_llvm();
    assert_eq!(passed_on(llvm, RELEASE, None), optimised(RELEASE, true));
    assert_eq!(
        passed_on(llvm + 1, RELEASE, Some("on")),
        optimised(RELEASE, true)
    );
    assert_eq!(
        passed_on(llvm, HOST_RELEASE, None),
        optimised(HOST_RELEASE, false)
    );
}

#[test]
fn the_profile_was_recorded_for_the_default_processor_level() {
    let text = fs::read_to_string(pgo_dir().join("recorded-with")).expect("pgo/recorded-with");
    assert!(text.lines().any(|l| l == "cpu x86-64-v3"), "{text}");
    let out = Command::new(pgo_dir().join("rustc-wrapper"))
        .arg("--cpu")
        .env_remove("STRAHL_CPU")
        .output()
        .expect("run pgo/rustc-wrapper --cpu");
    assert_eq!(String::from_utf8_lossy(&out.stdout), "x86-64-v3\n");
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
fn the_recording_builds_the_core_for_the_profiles_processor_level() {
    let recording = [
        "--crate-name",
        "strahl_core",
        "-C",
        "opt-level=3",
        "-Cprofile-generate=/tmp/r",
    ];
    let llvm = recorded_llvm();
    assert_eq!(
        passed_on(llvm, &recording, Some("off")),
        for_cpu(&recording, "x86-64-v3")
    );
}

#[test]
fn the_profile_is_left_out_when_asked_unreadable_or_for_another_processor() {
    let llvm = recorded_llvm();
    let core_only = for_cpu(RELEASE, "x86-64-v3");
    assert_eq!(passed_on(llvm, RELEASE, Some("off")), core_only);
    // An older LLVM cannot read a newer profile's format: the build goes on without it.
    assert_eq!(passed_on(llvm - 1, RELEASE, None), core_only);
    // A core built for another processor level than the profile's gets neither, nor do the
    // crates built with it.
    let plain = passed_on_for(llvm, RELEASE, None, Some("x86-64"));
    assert_eq!(plain, for_cpu(RELEASE, "x86-64"));
    let host = passed_on_for(llvm, HOST_RELEASE, None, Some("x86-64"));
    assert_eq!(host, unchanged(HOST_RELEASE));
}
