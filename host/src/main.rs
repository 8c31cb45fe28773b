//! The `strahl` command line.
fn main() {}
