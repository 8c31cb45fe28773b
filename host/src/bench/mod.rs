//! `strahl bench`: the benchmarks a user runs, one submodule each.
//!
//! - [`speed`]: `strahl bench` itself, the performance figures of issue 2 (octree build,
//!   octree size, primary and shaded rays per second) on the generated large scene.
//! - [`scaling`]: `strahl bench scaling`, speedup over 1 to N workers, measured in-process and
//!   over TCP and extended by the discrete-event model.
//! - [`accuracy`]: `strahl bench accuracy`, what each quality knob buys against a converged
//!   reference and what it costs in time; writes `docs/accuracy.md` and its plot.
//! - `stats`: the median that every figure above is taken from.
//!
//! This file holds the command line of `strahl bench` ([`BenchArgs`]) and sends each
//! subcommand to its module ([`run_command`]).

use std::io::Write as _;
use strahl_core::accel::octree::OctreeParams;

pub mod accuracy;
pub mod scaling;
pub mod speed;
mod stats;

pub use speed::{BenchOptions, BenchReport};

/// Arguments of `strahl bench`.
#[derive(Debug, clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct BenchArgs {
    /// Another benchmark instead of the core figures.
    #[command(subcommand)]
    pub command: Option<BenchCommand>,
    /// Least number of triangles of the generated scene.
    #[arg(long, value_name = "N", default_value_t = 100_000,
          value_parser = clap::value_parser!(u32).range(1_000..=50_000_000))]
    pub triangles: u32,
    /// Side of the square image rendered for the ray figures.
    #[arg(long, value_name = "PIXELS", default_value_t = 512,
          value_parser = clap::value_parser!(u32).range(16..=8192))]
    pub size: u32,
    /// Runs per figure (the median is reported).
    #[arg(long, value_name = "N", default_value_t = 5,
          value_parser = clap::value_parser!(u32).range(1..=100))]
    pub runs: u32,
    /// Octree depth limit.
    #[arg(long, value_name = "N", default_value_t = OctreeParams::default().max_depth,
          value_parser = clap::value_parser!(u32).range(0..=20))]
    pub octree_depth: u32,
    /// Octree leaf size: cells with at most this many triangles are not split.
    #[arg(long, value_name = "N", default_value_t = OctreeParams::default().max_leaf_triangles,
          value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub octree_leaf: u32,
}

/// The benchmarks besides the core figures.
#[derive(Debug, clap::Subcommand)]
pub enum BenchCommand {
    /// Speedup over 1..N workers: in-process and TCP worker processes measured on this
    /// machine, a discrete-event model beyond it (the seed's 1-to-12-machines comparison).
    Scaling(scaling::ScalingArgs),
    /// What accuracy costs in time: each quality knob swept alone against a converged
    /// reference (RMSE, PSNR, SSIM, median time), written to docs/accuracy.md with a plot.
    Accuracy(accuracy::AccuracyArgs),
}

/// Runs `strahl bench` and prints its report on stdout.
///
/// # Errors
/// If the generated scene cannot be built, or the chosen benchmark fails.
pub fn run_command(args: &BenchArgs) -> anyhow::Result<()> {
    match &args.command {
        Some(BenchCommand::Scaling(a)) => return scaling::run(a),
        Some(BenchCommand::Accuracy(a)) => return accuracy::run(a),
        None => {}
    }
    let opts = speed::BenchOptions {
        triangles: args.triangles,
        size: args.size,
        runs: args.runs as usize,
        octree: OctreeParams {
            max_depth: args.octree_depth,
            max_leaf_triangles: args.octree_leaf,
        },
    };
    let report =
        speed::run(&opts).map_err(|e| anyhow::anyhow!("generated benchmark scene: {e}"))?;
    writeln!(std::io::stdout().lock(), "{report}")?;
    Ok(())
}
