//! The `strahl` command line: its arguments ([`Cli`]) and the `render` subcommand.
//!
//! Each subcommand is one variant of [`Command`] holding its own argument struct; its run function
//! lives with it (here for `render`, in its own module for the others), and [`run`] dispatches.
//! To add a subcommand: add a variant `Name(crate::name::NameArgs)` with a doc comment (its help
//! line) and a match arm calling `crate::name::run(args)`.

use crate::cluster::master::{run_master, MasterOptions};
use crate::cluster::prepared::{PrepareError, PreparedScene};
use crate::cluster::report::WorkerTable;
use crate::executor::{start_workers, ClusterArgs};
use crate::load::{load_scene, Overrides};
use crate::output::{check_output_path, write_atomically, write_image};
use crate::progress::{format_ray_rate, Progress};
use crate::summary::{RenderStats, RenderSummary};
use anyhow::anyhow;
use clap::{Args, Parser, Subcommand};
use std::io::Write as _;
use std::num::NonZeroUsize;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::scene::error::SceneError;
use strahl_core::scene::settings::MAX_BOUNCES;
use strahl_core::scene::{MAX_AMBIENT_OCCLUSION, MAX_IMAGE_SIDE, MAX_SAMPLES};

/// Strahl, a ray tracer: renders the seed's scene files to BMP or PNG images.
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
    Render(RenderArgs),
    /// Convert a Wavefront OBJ mesh to the seed's data format, with a raytracer.cfg beside it.
    Convert(ConvertArgs),
    /// Write a generated scene: the demo room's ROOM.txt or the large benchmark scene.
    Generate(crate::generate::GenerateArgs),
    /// Measure octree build time and size, and rays per second, on the large generated scene.
    Bench(crate::bench::BenchArgs),
    /// Serve masters as a render worker, over TCP (listening or dialling) or a serial port.
    Worker(crate::worker::WorkerArgs),
}

/// Arguments of `strahl convert`.
#[derive(Debug, Args)]
pub struct ConvertArgs {
    /// The OBJ file (its .mtl materials are used when present).
    #[arg(value_name = "MODEL.obj")]
    pub input: PathBuf,

    /// The data file to write; a raytracer.cfg that frames the model is written beside it.
    #[arg(short, long, value_name = "DATA.txt")]
    pub output: PathBuf,

    /// Keep the OBJ's coordinates instead of turning its Y-up into the seed's Z-up.
    #[arg(long)]
    pub z_up: bool,
}

/// `strahl convert`: the OBJ as the seed's data file and a configuration file for it.
///
/// # Errors
/// A bad or unreadable OBJ or .mtl (naming the file and line) or a file that cannot be written.
pub fn run_convert(args: &ConvertArgs) -> anyhow::Result<()> {
    let options = crate::convert::ConvertOptions { y_up: !args.z_up };
    let summary = crate::convert::convert_obj_with(&args.input, &args.output, &options)?;
    eprint!("{summary}");
    Ok(())
}

/// The most worker threads `--workers` accepts.
pub const MAX_WORKERS: u32 = 1024;

/// Arguments of `strahl render`. As in FART, every option given beats the scene file; `-h` is
/// the height, help is `--help`.
#[derive(Debug, Args)]
#[command(disable_help_flag = true, allow_negative_numbers = true)]
pub struct RenderArgs {
    /// The scene: a .fart file, an .nff file, or the seed's configuration file (raytracer.cfg),
    /// whose file names are relative to its folder.
    #[arg(value_name = "SCENE")]
    pub config: PathBuf,

    /// Write the image here (relative to the current folder) instead of $IMAGE_NAME or the
    /// scene's name with .bmp; the extension chooses the format: .bmp or .png.
    #[arg(
        short,
        long = "output-file",
        visible_alias = "output",
        value_name = "FILE"
    )]
    pub output: Option<PathBuf>,

    /// Image width in pixels.
    #[arg(short, long, value_name = "N", value_parser = image_side())]
    pub width: Option<u32>,

    /// Image height in pixels.
    #[arg(short = 'h', long, value_name = "N", value_parser = image_side())]
    pub height: Option<u32>,

    /// Samples per pixel side: N×N stratified samples per pixel (1 to 16).
    #[arg(short, long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_SAMPLES)))]
    pub multisample: Option<u32>,

    /// Vertical field of view in degrees (above 0, below 180).
    #[arg(short = 'f', long, value_name = "DEG", value_parser = parse_fov)]
    pub field_of_view: Option<f32>,

    /// Cap on reflection and refraction bounces (0 to 100).
    #[arg(short = 'd', long, value_name = "N", value_parser = clap::value_parser!(u32).range(0..=i64::from(MAX_BOUNCES)))]
    pub max_depth: Option<u32>,

    /// Ambient-occlusion level, 0 (off) to 9: level N traces N×N occlusion rays per shaded point.
    #[arg(short = 'a', long, value_name = "0-9", value_parser = clap::value_parser!(u32).range(0..=i64::from(MAX_AMBIENT_OCCLUSION)))]
    pub ambient_occlusion: Option<u32>,

    /// FART's preview: -w 400 -h 300 -m 1 -d 8 -a 0, each unless given explicitly.
    #[arg(short, long)]
    pub preview: bool,

    /// Adaptive multisampling: supersample only pixels whose colour differs from a neighbour's
    /// by more than T (0 to 1, per channel), as POV-Ray does [default: every pixel].
    #[arg(long, value_name = "T", value_parser = parse_threshold)]
    pub aa_threshold: Option<f32>,

    /// Leave out rays that cannot change a pixel (on, the default). Off sends them anyway and
    /// drops their answers: the image must stay the same, only the ray counts and time grow.
    #[arg(long, value_name = "on|off", value_parser = parse_switch)]
    pub skip_effects: Option<bool>,

    /// Also write the render's statistics (times, rays by kind, workers) as JSON to FILE.
    #[arg(long, value_name = "FILE")]
    pub stats_json: Option<PathBuf>,

    /// Print help.
    #[arg(long, action = clap::ArgAction::Help)]
    pub help: Option<bool>,

    /// Shadows on or off (1 or 0 also accepted), instead of $SHADOWS.
    #[arg(long, value_name = "on|off", value_parser = parse_switch)]
    pub shadows: Option<bool>,

    /// Reflections on or off (1 or 0 also accepted), instead of $REFLECTIONS.
    #[arg(long, value_name = "on|off", value_parser = parse_switch)]
    pub reflections: Option<bool>,

    /// In-process workers, 0 to 1024 [default: the number of CPUs, or 0 when other workers are
    /// named].
    #[arg(long, value_name = "N", value_parser = worker_count())]
    pub workers: Option<u32>,

    /// Whether the data file's _TR point and shader indices count from 0 or 1, instead of
    /// $INDEX_BASE [default: 0].
    #[arg(long, value_name = "0|1", value_parser = clap::value_parser!(u32).range(0..=1))]
    pub index_base: Option<u32>,

    /// Print nothing on stderr unless there is an error (no progress bar, no summary).
    #[arg(short, long)]
    pub quiet: bool,

    /// Workers outside this process and how the master treats them.
    #[command(flatten)]
    pub cluster: ClusterArgs,
}

/// The parser of `--width` and `--height`: 1 to [`MAX_IMAGE_SIDE`].
fn image_side() -> clap::builder::RangedI64ValueParser<u32> {
    clap::value_parser!(u32).range(1..=i64::from(MAX_IMAGE_SIDE))
}

/// Parses a field of view in degrees: a number above 0 and below 180.
///
/// # Errors
/// A message naming the range.
pub fn parse_fov(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(f) if f > 0.0 && f < 180.0 => Ok(f),
        _ => Err("expected degrees above 0 and below 180".to_string()),
    }
}

/// Checks that `--stats-json FILE` can be written: its folder exists and takes a new file, and
/// `FILE` is not a folder or a device.
///
/// # Errors
/// A message naming the path.
fn check_stats_path(path: &std::path::Path) -> anyhow::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        anyhow::bail!(
            "{}: cannot write the statistics: folder {} does not exist",
            path.display(),
            dir.display()
        );
    }
    if path.is_dir() {
        anyhow::bail!(
            "{}: cannot write the statistics: it is a folder",
            path.display()
        );
    }
    if path.exists() && !path.is_file() {
        anyhow::bail!(
            "{}: cannot write the statistics: it is not a regular file",
            path.display()
        );
    }
    // The file is written through a temporary file in the folder: try one now.
    tempfile::Builder::new()
        .prefix(".strahl-")
        .suffix(".tmp")
        .tempfile_in(&dir)
        .map_err(|e| anyhow!("{}: cannot write the statistics: {e}", path.display()))?;
    Ok(())
}

/// Parses an adaptive-multisampling threshold: a number from 0 to 1.
///
/// # Errors
/// A message naming the range.
pub fn parse_threshold(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(t) if (0.0..=1.0).contains(&t) => Ok(t),
        _ => Err("expected a number from 0 to 1".to_string()),
    }
}

/// The parser of `--workers`: 0 to [`MAX_WORKERS`].
fn worker_count() -> clap::builder::RangedI64ValueParser<u32> {
    clap::value_parser!(u32).range(0..=i64::from(MAX_WORKERS))
}

/// Parses an on/off switch: `on` or `1` is true, `off` or `0` is false (exactly these words).
///
/// # Errors
/// A message listing the accepted words.
pub fn parse_switch(s: &str) -> Result<bool, String> {
    match s {
        "on" | "1" => Ok(true),
        "off" | "0" => Ok(false),
        _ => Err("expected `on` or `off` (or `1` or `0`)".to_string()),
    }
}

/// Runs the subcommand `cli` names.
///
/// # Errors
/// Whatever the subcommand reports; the messages are meant for the user.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Render(args) => run_render(&args),
        Command::Convert(args) => run_convert(&args),
        Command::Generate(args) => crate::generate::run(&args),
        Command::Bench(args) => crate::bench::run_command(&args),
        Command::Worker(args) => crate::worker::run(&args),
    }
}

impl RenderArgs {
    /// The settings that replace the configuration file's.
    pub fn overrides(&self) -> Overrides {
        Overrides {
            output: self.output.clone(),
            width: self.width,
            height: self.height,
            shadows: self.shadows,
            reflections: self.reflections,
            index_base: self.index_base,
            samples: self.multisample,
            field_of_view: self.field_of_view,
            max_depth: self.max_depth,
            ambient_occlusion: self.ambient_occlusion,
            preview: self.preview,
            aa_threshold: self.aa_threshold,
            skip_effects: self.skip_effects,
        }
    }

    /// The number of in-process workers: `--workers`, or the number of CPUs when no other
    /// worker is named, else 0.
    pub fn worker_count(&self) -> usize {
        match self.workers {
            Some(n) => n as usize,
            None if self.cluster.has_remote() => 0,
            None => std::thread::available_parallelism().map_or(1, NonZeroUsize::get),
        }
    }

    /// The master's options from the command line.
    pub fn master_options(&self) -> MasterOptions {
        let timeout = Duration::from_secs_f64(self.cluster.worker_timeout);
        MasterOptions {
            window: self.cluster.window,
            probe_interval: (timeout / 4).min(Duration::from_secs(2)),
            worker_timeout: timeout,
            wait_for_workers: timeout,
            name: crate::worker::host_name(),
        }
    }
}

/// `strahl render`: load, check the output path, build the octree, start or reach the workers,
/// render through the master, write the image, print the summary.
///
/// # Errors
/// A message naming the file (and line) at fault, the output path that cannot be written, a
/// worker option that cannot be used, or the workers lost before the image was complete (then
/// no image is written).
pub fn run_render(args: &RenderArgs) -> anyhow::Result<()> {
    let start = Instant::now();
    let loaded = load_scene(&args.config, &args.overrides())?;
    let load = start.elapsed();
    // Fail before the long part if the image or the statistics cannot be written.
    check_output_path(&loaded.output)?;
    if let Some(stats) = &args.stats_json {
        check_stats_path(stats)?;
    }

    let build_start = Instant::now();
    let prepared = PreparedScene::new(&loaded.desc, &OctreeParams::default()).map_err(|e| {
        let file = match e {
            PrepareError::Scene(SceneError::BadImageSize) => &loaded.config_path,
            _ => &loaded.data_path,
        };
        anyhow!("{}: {e}", file.display())
    })?;
    let octree_build = build_start.elapsed();
    let scene = &prepared.scene;
    let settings = scene.settings;

    let progress = Progress::new(settings.height, args.quiet);
    let warn = |msg: &str| {
        if !args.quiet {
            progress.println(&format!("warning: {msg}"));
        }
    };
    if scene.degenerate_triangles > 0 {
        warn(&format!(
            "{}: {} of {} triangles have zero area (collinear or repeated points) and are never hit",
            loaded.data_path.display(),
            scene.degenerate_triangles,
            scene.triangle_points.len() + scene.solids.mesh_triangle_count()
        ));
    }
    if args.aa_threshold.is_some() && settings.samples < 2 {
        warn("--aa-threshold has no effect at multisample 1: give -m 2 or more to supersample the pixels it flags");
    }
    let mut workers = start_workers(&args.cluster, args.worker_count(), &prepared, &warn)?;
    let render_start = Instant::now();
    let image = run_master(
        &prepared.job(),
        std::mem::take(&mut workers.links),
        workers.joins.as_ref(),
        &args.master_options(),
        &|_, rays| progress.line_done(rays),
        &warn,
    );
    let render = render_start.elapsed();
    progress.finish();
    drop(workers);
    let image = image?;

    write_image(
        &loaded.output,
        settings.width,
        settings.height,
        &image.pixels,
    )?;

    let summary = RenderSummary {
        width: settings.width,
        height: settings.height,
        total: start.elapsed(),
        load,
        octree_build,
        render,
        triangles: scene.triangle_points.len(),
        solids: scene.solids.len(),
        octree: *scene.octree.stats(),
        rays: image.rays,
        workers: image.workers.len(),
        output: loaded.output.clone(),
    };
    if let Some(path) = &args.stats_json {
        let stats = RenderStats::new(&summary, settings.samples, scene.effects, &image.workers);
        let json = serde_json::to_string_pretty(&stats)? + "\n";
        let written = write_atomically(path, |w| {
            w.write_all(json.as_bytes())
                .map_err(|e| anyhow!("{}: cannot write the statistics: {e}", path.display()))
        });
        if let Err(e) = written {
            // All or nothing: no image without its statistics.
            let _ = std::fs::remove_file(&loaded.output);
            return Err(e);
        }
    }
    if !args.quiet {
        eprintln!("{summary}");
        eprintln!("effects: {}", scene.effects.describe());
        eprint!("{}", WorkerTable(&image.workers, format_ray_rate));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory as _;

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
    fn switches() {
        assert_eq!(parse_switch("on"), Ok(true));
        assert_eq!(parse_switch("1"), Ok(true));
        assert_eq!(parse_switch("off"), Ok(false));
        assert_eq!(parse_switch("0"), Ok(false));
        assert!(parse_switch("yes").is_err());
        assert!(parse_switch("ON").is_err());
        assert!(parse_switch("").is_err());
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
