//! `strahl bench`: its command line and the dispatch to the benchmarks.
//!
//! The clap types of `strahl bench` ([`BenchArgs`]), `bench scaling` ([`ScalingArgs`]),
//! `bench accuracy` ([`AccuracyArgs`]) and `bench peers` ([`PeersArgs`]) live here, like every
//! other clap type; each becomes the plain options struct its benchmark in [`crate::bench`]
//! takes, so the benchmarks name no clap.

use crate::bench::accuracy::{self, parse_size, AccuracyOptions, ImageSize};
use crate::bench::peers::{self, PeersOptions, DEFAULT_SCENES};
use crate::bench::scaling::{self, ScalingOptions};
use crate::bench::speed::{self, BenchOptions};
use crate::cluster::job::WINDOW;
use std::io::Write as _;
use std::path::PathBuf;
use strahl_core::accel::octree::{OctreeParams, MAX_DEPTH_LIMIT};
use strahl_core::scene::settings::MAX_BOUNCES;
use strahl_core::scene::MAX_IMAGE_SIDE;
use strahl_core::wire::MAX_LINES_PER_REQUEST;

/// Arguments of `strahl bench`.
#[derive(Debug, clap::Args)]
#[command(args_conflicts_with_subcommands = true)]
pub struct BenchArgs {
    /// Another benchmark instead of the core figures.
    #[command(subcommand)]
    pub command: Option<BenchCommand>,
    /// Measure this scene file (any format `strahl render` reads) instead of the generated one.
    #[arg(long, value_name = "PATH")]
    pub scene: Option<PathBuf>,
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
          value_parser = clap::value_parser!(u32).range(0..=i64::from(MAX_DEPTH_LIMIT)))]
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
    Scaling(ScalingArgs),
    /// What accuracy costs in time: each quality knob swept alone against a converged
    /// reference (RMSE, PSNR, SSIM, median time), written to docs/accuracy.md with a plot.
    Accuracy(AccuracyArgs),
    /// Strahl against POV-Ray 3.7 (`povray`, Debian's package) on the SPD scenes: tracing time
    /// on one thread, the whole process on two, rays, image difference, side-by-side pictures.
    Peers(PeersArgs),
}

/// Arguments of `strahl bench scaling`.
#[derive(Debug, clap::Args)]
pub struct ScalingArgs {
    /// The scene to render (any format `strahl render` reads) [default: the demo room with
    /// reflections].
    #[arg(long, value_name = "PATH")]
    pub scene: Option<PathBuf>,
    /// Image width.
    #[arg(long, value_name = "PIXELS", default_value_t = 640,
          value_parser = clap::value_parser!(u32).range(16..=4096))]
    pub width: u32,
    /// Image height.
    #[arg(long, value_name = "PIXELS", default_value_t = 480,
          value_parser = clap::value_parser!(u32).range(16..=4096))]
    pub height: u32,
    /// Runs per figure (the median is reported).
    #[arg(long, value_name = "N", default_value_t = 5,
          value_parser = clap::value_parser!(u32).range(1..=100))]
    pub runs: u32,
    /// Most workers measured for real [default: the number of CPUs].
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=256))]
    pub max_real: Option<u32>,
    /// Most workers in the model (the seed compared 1 to 12 machines).
    #[arg(long, value_name = "N", default_value_t = 12,
          value_parser = clap::value_parser!(u32).range(1..=4096))]
    pub up_to: u32,
    /// Requests each worker has outstanding.
    #[arg(long, value_name = "N", default_value_t = WINDOW,
          value_parser = clap::value_parser!(u32).range(1..=64))]
    pub window: u32,
    /// Skip the TCP worker processes (in-process and model only).
    #[arg(long)]
    pub no_tcp: bool,
    /// Lines per request [default: chosen by the master from the measured cost of a line].
    #[arg(long, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_LINES_PER_REQUEST)))]
    pub lines_per_request: Option<u32>,
    /// One-way link latency in the model, in microseconds (100: a switched LAN).
    #[arg(long, value_name = "MICROSECONDS", default_value_t = 100,
          value_parser = clap::value_parser!(u32).range(0..=1_000_000))]
    pub latency_us: u32,
}

/// Arguments of `strahl bench accuracy`.
#[derive(Debug, clap::Args)]
pub struct AccuracyArgs {
    /// A scene to measure (repeatable) [default: scenes/room/raytracer.cfg and the first two
    /// scenes/fart/*.fart that load, mirrors.fart and glass.fart first; from the current folder].
    #[arg(long = "scene", value_name = "PATH")]
    pub scenes: Vec<PathBuf>,
    /// Image size of every render.
    #[arg(long, value_name = "WxH", default_value = "320x240", value_parser = parse_size)]
    pub size: ImageSize,
    /// Timed runs per setting (the median is reported).
    #[arg(long, value_name = "N", default_value_t = 3,
          value_parser = clap::value_parser!(u32).range(1..=100))]
    pub runs: u32,
    /// The Markdown report; the SVG plot goes next to it (same name, `.svg`). Neither replaces
    /// a file that is there without --force (docs/accuracy.md is refreshed with `--out
    /// docs/accuracy.md --force`).
    #[arg(long, value_name = "FILE", default_value = "accuracy.md")]
    pub out: PathBuf,
    /// Replace the report and its plot if they are there.
    #[arg(long)]
    pub force: bool,
    /// Sweep fewer values of each knob (for tests and a first look).
    #[arg(long)]
    pub quick: bool,
}

/// Arguments of `strahl bench peers`.
#[derive(Debug, clap::Args)]
pub struct PeersArgs {
    /// Folder of scene pairs: X.nff for Strahl beside X.pov for POV-Ray.
    #[arg(long, value_name = "DIR", default_value = DEFAULT_SCENES)]
    pub scenes: PathBuf,
    /// Only these scenes (names without extension, comma-separated) [default: every pair].
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub only: Vec<String>,
    /// Side of the square images.
    #[arg(long, value_name = "PIXELS", default_value_t = 512,
          value_parser = clap::value_parser!(u32).range(8..=i64::from(MAX_IMAGE_SIDE)))]
    pub size: u32,
    /// Rounds per scene, each running both tracers (the medians are reported).
    #[arg(long, value_name = "N", default_value_t = 3,
          value_parser = clap::value_parser!(u32).range(1..=100))]
    pub runs: u32,
    /// Strahl's cap on reflection and refraction bounces (POV-Ray keeps its scene's
    /// max_trace_level, 5 unless the scene sets one).
    #[arg(long, value_name = "N", default_value_t = 5,
          value_parser = clap::value_parser!(u32).range(0..=i64::from(MAX_BOUNCES)))]
    pub depth: u32,
    /// Put the report between the `bench peers` markers of this Markdown file (adding a section
    /// with them if absent); the side-by-side pictures go to peers/ beside it [default: only
    /// print the tables, pictures to --pictures or docs/peers/].
    #[arg(long, value_name = "FILE")]
    pub write_docs: Option<PathBuf>,
    /// Put the side-by-side pictures in this folder (created if missing) instead of
    /// docs/peers/; not with --write-docs, whose report links the pictures beside it.
    #[arg(long, value_name = "DIR", conflicts_with = "write_docs")]
    pub pictures: Option<PathBuf>,
}

impl BenchArgs {
    /// The options of the core figures.
    pub fn options(&self) -> BenchOptions {
        BenchOptions {
            scene: self.scene.clone(),
            triangles: self.triangles,
            size: self.size,
            runs: self.runs as usize,
            octree: OctreeParams {
                max_depth: self.octree_depth,
                max_leaf_triangles: self.octree_leaf,
            },
        }
    }
}

impl ScalingArgs {
    /// The options of the scaling benchmark.
    pub fn options(&self) -> ScalingOptions {
        ScalingOptions {
            scene: self.scene.clone(),
            width: self.width,
            height: self.height,
            runs: self.runs,
            max_real: self.max_real,
            up_to: self.up_to,
            window: self.window,
            no_tcp: self.no_tcp,
            latency: f64::from(self.latency_us) * 1e-6,
            lines_per_request: self.lines_per_request,
        }
    }
}

impl AccuracyArgs {
    /// The options of the accuracy study.
    pub fn options(&self) -> AccuracyOptions {
        AccuracyOptions {
            scenes: self.scenes.clone(),
            size: self.size,
            runs: self.runs,
            out: self.out.clone(),
            quick: self.quick,
            force: self.force,
        }
    }
}

impl PeersArgs {
    /// The options of the comparison with POV-Ray.
    pub fn options(&self) -> PeersOptions {
        PeersOptions {
            scenes: self.scenes.clone(),
            only: self.only.clone(),
            size: self.size,
            runs: self.runs,
            depth: self.depth,
            write_docs: self.write_docs.clone(),
            pictures: self.pictures.clone(),
        }
    }
}

/// Runs `strahl bench` (the core figures, printed on stdout) or the benchmark it names.
///
/// # Errors
/// If the generated scene cannot be built, or the chosen benchmark fails.
pub fn run(args: &BenchArgs) -> anyhow::Result<()> {
    match &args.command {
        Some(BenchCommand::Scaling(a)) => scaling::run(&a.options()),
        Some(BenchCommand::Accuracy(a)) => accuracy::run(&a.options()),
        Some(BenchCommand::Peers(a)) => peers::run(&a.options()),
        None => {
            let report = speed::run(&args.options())?;
            writeln!(std::io::stdout().lock(), "{report}")?;
            Ok(())
        }
    }
}
