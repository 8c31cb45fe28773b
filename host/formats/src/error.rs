//! Errors of the file loaders: every message names the file and, where there is one, the line.

use std::path::PathBuf;

/// Why a configuration or data file cannot be loaded.
///
/// The `Display` form is the message a user sees: `path:line: what is wrong`, `path:line:column: what is wrong`, `path: cannot read:
/// why`, or `path: what is wrong` for problems of the whole file.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// `path:line: message`
    #[error("{}:{line}: {message}", path.display())]
    At {
        /// The file.
        path: PathBuf,
        /// The 1-based line number.
        line: usize,
        /// What is wrong on that line.
        message: String,
    },
    /// `path:line:column: message` (scene languages where the column matters)
    #[error("{}:{line}:{column}: {message}", path.display())]
    AtColumn {
        /// The file.
        path: PathBuf,
        /// The 1-based line number.
        line: usize,
        /// The 1-based column, in characters.
        column: usize,
        /// What is wrong there, and what was expected.
        message: String,
    },
    /// `path: cannot read: io error`
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// whole-file problems without a line, e.g. `path: the scene has no light ...`
    #[error("{}: {message}", path.display())]
    File {
        /// The file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
}
