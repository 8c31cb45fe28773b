//! Helpers shared by the parser tests.

use std::path::{Path, PathBuf};
use strahl_host::formats::error::LoadError;

/// Writes a fixture file into `dir` and returns its path.
pub fn write(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).expect("write fixture");
    path
}

/// Asserts that `err` is a line error at `path:line: ` and returns its message.
pub fn assert_at(err: LoadError, path: &Path, line: usize) -> String {
    let msg = err.to_string();
    assert!(
        matches!(err, LoadError::At { line: l, .. } if l == line),
        "{msg}"
    );
    assert!(
        msg.starts_with(&format!("{}:{line}: ", path.display())),
        "{msg}"
    );
    msg
}
