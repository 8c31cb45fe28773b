//! A usage error: the command line asks for something that cannot be done (a bad output name
//! or format, a bad address, no worker named). `main` exits with code 2 for it, as clap does
//! for the errors it finds, and 1 for every failure while running.

/// A usage error, in words that say what to give instead.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// A usage error as an `anyhow` error.
pub fn usage(message: impl Into<String>) -> anyhow::Error {
    UsageError(message.into()).into()
}
