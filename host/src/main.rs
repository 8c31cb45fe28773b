//! The `strahl` command line: parses the arguments and runs the subcommand (`strahl_host::cli`).

use clap::Parser as _;
use std::process::ExitCode;
use strahl_host::cli::{run, Cli};
use strahl_host::util::cpu;
use strahl_host::util::text::printable;
use strahl_host::util::usage::UsageError;

/// The error and its causes, joined by `: `, leaving out a cause whose text the message already
/// ends with (some errors repeat their source in their own message).
fn error_chain(err: &anyhow::Error) -> String {
    let mut msg = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if msg.is_empty() {
            msg = text;
        } else if !msg.ends_with(&text) {
            msg.push_str(": ");
            msg.push_str(&text);
        }
    }
    msg
}

/// How `error:` looks, as clap writes it: bold red where stderr is a terminal that takes colour;
/// `anstream` writes it plain where it is not, or where `NO_COLOR` is set.
fn error_style() -> anstyle::Style {
    anstyle::Style::new()
        .bold()
        .fg_color(Some(anstyle::AnsiColor::Red.into()))
}

/// Whether the error is a write to a closed pipe.
fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|c| {
        c.downcast_ref::<std::io::Error>()
            .is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// Whether `args` run `render` with `-h` and no number after it: FART's height, mistaken for
/// help.
fn height_without_value(args: &[String]) -> bool {
    args.get(1).is_some_and(|c| c == "render")
        && args
            .iter()
            .enumerate()
            .any(|(i, a)| a == "-h" && args.get(i + 1).is_none_or(|v| v.parse::<u32>().is_err()))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    if height_without_value(&args) {
        let style = error_style();
        anstream::eprintln!(
            "{style}error:{style:#} -h is the image height (as in FART), and it needs a number, \
             for example -h 480; for help use --help"
        );
        return ExitCode::from(2);
    }
    // clap prints usage errors itself and exits with code 2 (0 for --help and --version).
    let cli = Cli::parse();
    // Before any of the core's code runs, which may use instructions this processor lacks.
    match cpu::check().and_then(|()| run(cli)) {
        Ok(()) => ExitCode::SUCCESS,
        // The reader of our output went away (`strahl bench | head`): nothing left to say.
        Err(err) if is_broken_pipe(&err) => ExitCode::SUCCESS,
        Err(err) => {
            let style = error_style();
            anstream::eprintln!("{style}error:{style:#} {}", printable(&error_chain(&err)));
            // 2 for what the command line asks wrongly, as clap's own errors; 1 for failures.
            if err.chain().any(|c| c.is::<UsageError>()) {
                ExitCode::from(2)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}
