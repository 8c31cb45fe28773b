//! The direction of dependencies inside `strahl-host`, as the crate doc (`host/src/lib.rs`)
//! states it: a group names nothing of the groups above it. Paths are read as text, so a
//! `crate::` path in any file of a group counts, doc links included. (The formats are a crate of
//! their own, `strahl-formats`, which the compiler keeps below everything.)

use std::path::{Path, PathBuf};

/// Every `.rs` file below `dir`, or `dir` itself if it is a file.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    if dir.is_file() {
        return vec![dir.to_path_buf()];
    }
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                files.push(path);
            }
        }
    }
    files
}

/// The places in `group` (a folder or file under `host/src`) that name one of `forbidden`.
fn violations(group: &str, forbidden: &[&str]) -> Vec<String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("src")
        .join(group);
    assert!(root.exists(), "{} is missing", root.display());
    let mut found = Vec::new();
    for file in rust_files(&root) {
        let text = std::fs::read_to_string(&file).unwrap_or_default();
        for (i, line) in text.lines().enumerate() {
            for f in forbidden {
                if line.contains(f) {
                    found.push(format!("{}:{}: {f}", file.display(), i + 1));
                }
            }
        }
    }
    found
}

const ABOVE_FORMATS: &[&str] = &[
    "crate::cli",
    "crate::bench",
    "crate::cluster",
    "crate::executor",
    "crate::generate",
];

#[test]
fn util_uses_no_group() {
    let mut above = ABOVE_FORMATS.to_vec();
    above.push("crate::formats");
    assert_eq!(violations("util", &above), Vec::<String>::new());
}

#[test]
fn generate_uses_only_formats_and_util() {
    assert_eq!(
        violations("generate.rs", ABOVE_FORMATS),
        Vec::<String>::new()
    );
}

#[test]
fn cluster_uses_neither_the_interface_nor_the_benchmarks() {
    for group in ["cluster", "executor.rs"] {
        assert_eq!(
            violations(group, &["crate::cli", "crate::bench", "clap::"]),
            Vec::<String>::new()
        );
    }
}
