//! `strahl bench`: the subcommand's entry. Its clap types ([`BenchArgs`] and those of its
//! sub-benchmarks) still live in [`crate::bench`], whose owner moves them here in a later change;
//! this module is the one place [`super::run`] reaches the benchmarks through.

pub use crate::bench::BenchArgs;

/// Runs `strahl bench` ([`crate::bench::run_command`]).
///
/// # Errors
/// Whatever the benchmark reports.
pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    crate::bench::run_command(args)
}
