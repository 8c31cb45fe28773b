//! `strahl completions SHELL` and `strahl man`: shell completions (`clap_complete`) and the
//! manual page (`clap_mangen`), both generated from the clap definitions, so they cannot drift
//! from the options.

use super::Cli;
use clap::{Args, CommandFactory as _};
use std::io::Write as _;

/// Arguments of `strahl completions`.
#[derive(Debug, Args)]
pub struct CompletionsArgs {
    /// The shell: bash, zsh, fish, elvish or powershell.
    #[arg(value_name = "SHELL")]
    pub shell: clap_complete::Shell,
}

/// Writes the completion script for `args.shell` to standard output.
///
/// # Errors
/// Standard output cannot be written.
pub fn completions(args: &CompletionsArgs) -> anyhow::Result<()> {
    let mut out = Vec::new();
    clap_complete::generate(args.shell, &mut Cli::command(), "strahl", &mut out);
    std::io::stdout().lock().write_all(&out)?;
    Ok(())
}

/// Writes the manual page (roff, section 1) to standard output.
///
/// # Errors
/// Standard output cannot be written.
pub fn man() -> anyhow::Result<()> {
    let mut out = Vec::new();
    clap_mangen::Man::new(Cli::command()).render(&mut out)?;
    std::io::stdout().lock().write_all(&out)?;
    Ok(())
}
