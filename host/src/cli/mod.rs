//! The `strahl` command line: its arguments ([`Cli`]), one module per subcommand, and what a
//! render shows the user while and after it runs.
//!
//! Each subcommand is one variant of [`Command`] holding its own argument struct (a clap type);
//! its module ([`render`], [`view`], [`worker`], [`shell`] (completions and the manual page), [`convert`], [`generate`], [`bench`](mod@bench)) holds that struct
//! and a `run` function that turns the arguments into plain values and calls the group that does
//! the work: [`crate::formats`] and [`crate::cluster`] for `render`, [`crate::formats`] for
//! `convert`, [`crate::generate`] for `generate`, the benchmark modules for `bench`, and the
//! transports for `worker`. [`run`] dispatches. [`progress`] and [`summary`] are what a render
//! prints on stderr. Nothing outside `cli` uses it, except `main.rs`.
//!
//! To add a subcommand: add a module `name.rs` with `NameArgs` and `run`, a variant
//! `Name(name::NameArgs)` with a doc comment (its help line) and a match arm calling
//! `name::run(&args)`.

pub mod bench;
pub mod convert;
pub mod generate;
pub mod progress;
pub mod render;
pub mod shell;
pub mod summary;
pub mod view;
pub mod worker;

use clap::{Parser, Subcommand};

/// Strahl, a distributed ray tracer: renders the seed's, FART's and NFF scenes to images on
/// this machine, a cluster over TCP and boards on serial links.
#[derive(Debug, Parser)]
#[command(name = "strahl", version, propagate_version = true)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Render a scene (.fart, .nff, or the seed's configuration file) to an image.
    Render(Box<render::RenderArgs>),
    /// Convert a Wavefront OBJ mesh to the seed's data format, with a raytracer.cfg beside it.
    Convert(convert::ConvertArgs),
    /// Write a generated scene: the demo room's ROOM.txt or the large benchmark scene.
    Generate(generate::GenerateArgs),
    /// Measure octree build time and size, and rays per second, on the large generated scene.
    Bench(bench::BenchArgs),
    /// Serve masters as a render worker, over TCP (listening or dialling) or a serial port.
    Worker(worker::WorkerArgs),
    /// Open a scene in the browser: set up its render in a form, start, stop and resume it, and
    /// watch it fill in.
    View(view::ViewArgs),
    /// Print a shell completion script (bash, zsh, fish, elvish or powershell).
    Completions(shell::CompletionsArgs),
    /// Print the manual page (roff), e.g. `strahl man > ~/.local/share/man/man1/strahl.1`.
    Man,
}

/// Runs the subcommand `cli` names.
///
/// # Errors
/// Whatever the subcommand reports; the messages are meant for the user.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(args) => render::run(&args),
        Command::Convert(args) => convert::run(&args),
        Command::Generate(args) => generate::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Worker(args) => worker::run(&args),
        Command::View(args) => view::run(&args),
        Command::Completions(args) => shell::completions(&args),
        Command::Man => shell::man(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory as _;
    use std::path::PathBuf;

    #[test]
    fn cli_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn dash_h_is_height_and_help_stays_long() {
        let help = Cli::try_parse_from(["strahl", "render", "--help"]);
        assert!(matches!(help, Err(e) if e.kind() == clap::error::ErrorKind::DisplayHelp));
        let short = Cli::try_parse_from(["strahl", "render", "a.fart", "-h"]);
        assert!(short.is_err(), "-h needs a height");
    }

    #[test]
    fn parses_render() -> anyhow::Result<()> {
        let cli = Cli::try_parse_from([
            "strahl",
            "render",
            "a.cfg",
            "-o",
            "x.png",
            "--width",
            "7",
            "--shadows",
            "off",
            "--reflections",
            "1",
            "--workers",
            "3",
            "--index-base",
            "1",
            "-h",
            "9",
            "-m",
            "3",
            "-f",
            "60",
            "-d",
            "4",
            "-a",
            "2",
            "-p",
            "--quiet",
        ])?;
        let a = match cli.command {
            Command::Render(a) => a,
            #[allow(unreachable_patterns)]
            _ => anyhow::bail!("parsed as another subcommand"),
        };
        let o = a.overrides();
        assert_eq!(a.config, PathBuf::from("a.cfg"));
        assert_eq!(o.output, Some(PathBuf::from("x.png")));
        assert_eq!((o.width, o.height), (Some(7), Some(9)));
        assert_eq!(
            (
                o.samples,
                o.field_of_view,
                o.max_depth,
                o.ambient_occlusion,
                o.preview
            ),
            (Some(3), Some(60.0), Some(4), Some(2), true)
        );
        assert_eq!(
            (o.shadows, o.reflections, o.index_base),
            (Some(false), Some(true), Some(1))
        );
        assert_eq!(a.worker_count(), 3);
        assert!(a.quiet);
        for bad in [
            &["--workers", "1025"][..],
            &["--window", "0"],
            &["--worker-timeout", "0"],
            &["--launch", "x"],
            &["--index-base", "2"],
            &["--width", "0"],
            &["--shadows", "maybe"],
            &["-m", "0"],
            &["-m", "17"],
            &["-a", "10"],
            &["-f", "180"],
            &["-f", "0"],
        ] {
            let mut argv = vec!["strahl", "render", "a.cfg"];
            argv.extend_from_slice(bad);
            assert!(Cli::try_parse_from(argv).is_err(), "{bad:?}");
        }
        Ok(())
    }
}
