//! `strahl render`: its arguments ([`RenderArgs`], with the workers' options in
//! [`ClusterArgs`]) and its run: load the scene ([`crate::formats::load`]), check the outputs,
//! prepare the scene and start the workers ([`crate::cluster`], [`crate::cluster::executor`]), render
//! through the master while [`super::progress`] draws, write the image
//! ([`crate::output`]) and the statistics, and print [`super::summary`].
//!
//! The clap types stay here: the executor takes a plain [`WorkerSources`] and the master plain
//! [`MasterOptions`], both made from the arguments by [`ClusterArgs::sources`] and
//! [`RenderArgs::master_options`].

use super::progress::Progress;
use super::summary::{RenderStats, RenderSummary};
use crate::cluster::checkpoint::{checkpoint_path, Checkpoint, Record};
use crate::cluster::executor::{start_workers, WorkerSources};
use crate::cluster::job::{ClusterError, ClusterJob};
use crate::cluster::job::{PROBE_INTERVAL, WINDOW, WORKER_TIMEOUT};
use crate::cluster::master::{run_master_with, ClusterImage, FinalLine, Hooks, MasterOptions};
use crate::cluster::prepared::{PrepareError, PreparedScene};
use crate::cluster::region::Region;
use crate::cluster::report::WorkerTable;
use crate::cluster::report::{Activity, WorkerState};
use crate::formats::fs::{refuse_to_replace_input, same_destination, write_atomically};
use crate::formats::load::{load_scene, LoadedScene, Overrides, SceneFormat};
use crate::output::{check_destination, check_scene_output, image_memory, is_stdout};
use crate::output::{write_image, ImageKind};
use crate::util::secret::{load_secret, Secret};
use crate::util::usage::usage;
use crate::view::events::Status;
use crate::view::hub::{Hub, Shown};
use crate::view::server::{ViewServer, DEFAULT_VIEW};
use anyhow::anyhow;
use clap::Args;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::error::SceneError;
use strahl_core::scene::settings::MAX_BOUNCES;
use strahl_core::scene::{MAX_AMBIENT_OCCLUSION, MAX_IMAGE_SIDE, MAX_SAMPLES};
use strahl_core::wire::MAX_LINES_PER_REQUEST;

pub use crate::cluster::local::MAX_WORKERS;

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

    /// Also write the render's statistics (times, rays by kind, workers) as JSON to FILE (`-`:
    /// standard output, unless the image goes there).
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

    /// In-process workers (threads of this process), 0 to 1024 [default: the number of CPUs, or
    /// 0 when other workers are named].
    #[arg(long, visible_alias = "threads", value_name = "N", value_parser = worker_count())]
    pub workers: Option<u32>,

    /// Whether the data file's _TR point and shader indices count from 0 or 1, instead of
    /// $INDEX_BASE [default: 0].
    #[arg(long, value_name = "0|1", value_parser = clap::value_parser!(u32).range(0..=1))]
    pub index_base: Option<u32>,

    /// Print nothing on stderr unless there is an error (no progress bar, no summary).
    #[arg(short, long)]
    pub quiet: bool,

    /// Go on with an interrupted render of the same scene, settings and output: the lines in
    /// OUTPUT.checkpoint are kept, only the others are rendered, and the image is the one an
    /// uninterrupted render gives.
    #[arg(long)]
    pub resume: bool,

    /// Watch the render in a browser: serve a page at ADDR (PORT, HOST:PORT; port 0 picks one)
    /// and print its URL; after the render the page keeps serving until Ctrl-C. Beyond this
    /// machine only with a secret (the URL then carries a key) or --insecure.
    #[arg(long, value_name = "ADDR", num_args = 0..=1, default_missing_value = DEFAULT_VIEW,
          value_parser = view_address_arg)]
    pub view: Option<String>,

    /// Render only columns X0..X1 of lines Y0..Y1 (pixels, ends exclusive; POV-Ray's +SR/+ER)
    /// and write that rectangle; its pixels are those of a full render.
    #[arg(long, value_name = "X0,Y0,X1,Y1", value_parser = Region::parse)]
    pub region: Option<Region>,

    /// With --region, write the whole image, everything outside the region in the background
    /// colour.
    #[arg(long, requires = "region")]
    pub keep_size: bool,

    /// The image format instead of the output name's extension: bmp, png, png16 (16 bits per
    /// channel), ppm or exr; with `-o -` the image goes to standard output [default: bmp].
    #[arg(long, value_name = "FORMAT", value_parser = ImageKind::from_name)]
    pub format: Option<ImageKind>,

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

/// Checks that `--stats-json FILE` can be written: its folder exists and takes a new file,
/// `FILE` is not a folder or a device, nor the image or a file the scene was loaded from; or
/// `FILE` is `-` (standard output) and the image goes elsewhere.
///
/// # Errors
/// A message naming the path; a usage error for both on standard output.
fn check_stats_path(path: &std::path::Path, loaded: &LoadedScene) -> anyhow::Result<()> {
    if is_stdout(path) {
        if is_stdout(&loaded.output) {
            return Err(usage(
                "--stats-json - and -o - both write to standard output; name a file for one",
            ));
        }
        return Ok(());
    }
    check_destination(path, "the statistics")?;
    if same_destination(path, &loaded.output) {
        anyhow::bail!(
            "{}: the statistics would replace the image; choose another name",
            path.display()
        );
    }
    refuse_to_replace_input(path, &loaded.inputs, "the statistics")
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

/// The CPUs of this machine (1 if it does not say): the default number of in-process workers.
pub fn cpu_count() -> u32 {
    std::thread::available_parallelism().map_or(1, |n| u32::try_from(n.get()).unwrap_or(u32::MAX))
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

/// The command-line options that choose a render's workers and tune the master.
#[derive(Clone, Debug, Default, Args)]
pub struct ClusterArgs {
    /// A TCP worker listening at HOST[:PORT] (default port 7415); repeatable.
    #[arg(long = "worker", value_name = "HOST[:PORT]", value_parser = endpoint_arg)]
    pub worker: Vec<String>,

    /// A hosts file (one HOST[:PORT] per line, `#` comments): the workers to dial, or with
    /// --launch the hosts to start workers on.
    #[arg(long, value_name = "FILE")]
    pub hosts: Option<PathBuf>,

    /// Accept workers that dial in (`strahl worker --connect`) at HOST[:PORT]; port 0 picks a
    /// free one.
    #[arg(long, value_name = "HOST[:PORT]", value_parser = listen_arg)]
    pub listen: Option<String>,

    /// Start one worker per hosts-file line with this command; `{host}` is replaced by the
    /// host, `{master}` by the address workers dial (e.g. `ssh {host} strahl worker --connect
    /// {master}`). Listens on --listen, or on a free port (of this machine only without a
    /// secret). The template is split into words (quotes keep spaces) and run without a shell.
    #[arg(long, value_name = "TEMPLATE", requires = "hosts")]
    pub launch: Option<String>,

    /// Inside a Slurm allocation (sbatch, salloc): start one worker per allocated node through
    /// srun, using the node's CPUs; they dial back to this master. Several nodes need a secret
    /// (--secret-file on a file system they share, or STRAHL_SECRET).
    #[arg(long, conflicts_with = "launch")]
    pub slurm: bool,

    /// A serial worker at PATH[:BAUD] (default 115200 baud); repeatable.
    #[arg(long = "serial", value_name = "PATH[:BAUD]")]
    pub serial: Vec<String>,

    /// Prove to workers, and require of them, the shared secret in FILE (at least 16 bytes)
    /// [default: the secret in the environment variable STRAHL_SECRET, if set]. Without a
    /// secret, --listen and --launch listen on this machine only.
    #[arg(long, value_name = "FILE")]
    pub secret_file: Option<PathBuf>,

    /// Have FRACTION (0 to 1) of the lines rendered by a second worker and compared byte for
    /// byte before use; a worker whose pixels differ from the master's own render of that line
    /// is dropped and its unchecked lines rendered again [default: 0]. With adaptive
    /// multisampling every first pass is checked once FRACTION is above 0.
    #[arg(long, value_name = "FRACTION", default_value_t = 0.0, value_parser = fraction)]
    pub verify: f64,

    /// Listen for workers, and serve --view, on an address other machines can reach without a
    /// secret.
    #[arg(long)]
    pub insecure: bool,

    /// Line requests each worker thread has outstanding; 1 is the seed's one line at a time.
    #[arg(long, value_name = "N", default_value_t = WINDOW,
          value_parser = clap::value_parser!(u32).range(1..=64))]
    pub window: u32,

    /// Lines per request [default: chosen from the measured cost of a line, so that a request
    /// carries about 2 ms of one thread's work]; 1 is the seed's one line at a time.
    #[arg(long, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_LINES_PER_REQUEST)))]
    pub lines_per_request: Option<u32>,

    /// Seconds a worker with work may stay silent before it counts as hung and its lines go to
    /// others; also how long a listening master waits with no worker.
    #[arg(long, value_name = "SECS", default_value_t = WORKER_TIMEOUT.as_secs_f64(), value_parser = positive_seconds)]
    pub worker_timeout: f64,
}

/// Parses an address to dial (`PORT`, `:PORT`, `HOST`, `HOST:PORT`): a usage error otherwise.
///
/// # Errors
/// What is wrong, with the forms an address takes.
pub fn endpoint_arg(s: &str) -> Result<String, String> {
    strahl_tcp::parse_endpoint(s)
}

/// Parses an address to listen on (port 0 allowed): a usage error otherwise.
///
/// # Errors
/// What is wrong, with the forms an address takes.
pub fn listen_arg(s: &str) -> Result<String, String> {
    strahl_tcp::parse_listen_address(s)
}

/// Parses `--view`'s address: a usage error otherwise.
///
/// # Errors
/// What is wrong, with examples.
pub fn view_address_arg(s: &str) -> Result<String, String> {
    crate::view::server::view_address(s)
        .map(|a| a.to_string())
        .map_err(|e| {
            e.to_string()
                .trim_start_matches(&format!("--view {s}: "))
                .to_string()
        })
}

/// Parses a number from 0 to 1.
///
/// # Errors
/// A message if the text is not such a number.
pub fn fraction(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..=1.0).contains(&v) => Ok(v),
        _ => Err("expected a fraction from 0 to 1 (for example 0.05)".to_string()),
    }
}

/// Parses a positive number of seconds, at most a million (11.6 days).
///
/// # Errors
/// A message if the text is not such a number.
pub fn positive_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 1e6 => Ok(v),
        _ => Err("expected a number of seconds above 0 and at most 1000000".to_string()),
    }
}

impl ClusterArgs {
    /// Whether any worker outside this process is named.
    pub fn has_remote(&self) -> bool {
        self.sources(false).has_remote()
    }

    /// The workers named, for [`start_workers`]; `secret`: whether the master has one.
    pub fn sources(&self, secret: bool) -> WorkerSources {
        WorkerSources {
            worker: self.worker.clone(),
            hosts: self.hosts.clone(),
            listen: self.listen.clone(),
            launch: self.launch.clone(),
            serial: self.serial.clone(),
            secret,
            insecure: self.insecure,
            slurm: self.slurm,
            secret_file: self
                .secret_file
                .as_ref()
                .map(|f| std::path::absolute(f).unwrap_or_else(|_| f.clone())),
        }
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
            None => cpu_count() as usize,
        }
    }

    /// The master's options from the command line, with its shared secret.
    pub fn master_options(&self, secret: Option<Secret>) -> MasterOptions {
        let timeout = Duration::from_secs_f64(self.cluster.worker_timeout);
        MasterOptions {
            secret,
            verify: self.cluster.verify,
            window: self.cluster.window,
            lines_per_request: self.cluster.lines_per_request,
            probe_interval: (timeout / 4).min(PROBE_INTERVAL),
            worker_timeout: timeout,
            wait_for_workers: timeout,
            name: crate::util::sys::host_name(),
        }
    }
}

/// Runs `strahl render`: load, check the output path, build the octree, start or reach the workers,
/// render through the master, write the image, print the summary.
///
/// # Errors
/// A message naming the file (and line) at fault, the output path that cannot be written, a
/// worker option that cannot be used, or the workers lost before the image was complete (then
/// no image is written).
pub fn run(args: &RenderArgs) -> anyhow::Result<()> {
    let start = Instant::now();
    let Checked {
        loaded,
        kind,
        secret,
    } = check_before_render(args)?;
    let load = start.elapsed();
    let view = match &args.view {
        Some(address) => Some(start_view(
            address,
            secret.is_some(),
            args.cluster.insecure,
        )?),
        None => None,
    };
    let hub = view.as_ref().map(|(_, hub)| hub.as_ref());

    let build_start = Instant::now();
    let prepared = prepare(&loaded)?;
    let preparing = build_start.elapsed();
    let lines = Region::rendered_lines(args.region, &prepared.scene.settings);
    let job = prepared.job().limited_to(lines);
    let progress = Progress::new(job.lines.len() as u32, args.quiet);
    let warn = |msg: &str| {
        if !args.quiet {
            progress.println(&format!("warning: {msg}"));
        }
    };
    warn_about_scene(args, &loaded, &prepared, &warn);
    let render_start = Instant::now();
    let output = Output {
        path: &loaded.output,
        kind,
    };
    let image = render_and_write(
        args,
        &output,
        (&prepared, &job),
        secret,
        &progress,
        &warn,
        hub,
    );
    if let Some(hub) = hub {
        hub.end(match &image {
            Ok(_) => Status::Done {
                output: loaded.output.display().to_string(),
            },
            Err(e) => Status::Failed {
                message: format!("{e:#}"),
            },
        });
    }
    let Traced { image, complete } = image?;
    let written = Instant::now();
    let traced_from = image
        .first_request
        .map_or(render_start, |t| t.max(render_start));
    let times = Times {
        total: written.duration_since(start),
        load,
        preparing,
        // Waiting for workers and the scene's transfer are not tracing, nor is writing the
        // file (POV-Ray's `Trace Time` ends before its file is written, too).
        render: complete.saturating_duration_since(traced_from),
        writing: written.saturating_duration_since(complete),
    };
    report(args, &loaded, &prepared, &image, times)?;
    if let Some((server, _)) = view {
        serve_until_ctrl_c(&server);
    }
    Ok(())
}

/// What [`check_before_render`] found usable.
struct Checked {
    loaded: LoadedScene,
    kind: ImageKind,
    secret: Option<Secret>,
}

/// Everything that can fail before the long part: the scene's type, a worker to render with,
/// the scene itself, the image's name and format, the region, the secret, the memory for the
/// pixels, the statistics' path.
///
/// # Errors
/// The first of these that fails, usage errors as such.
fn check_before_render(args: &RenderArgs) -> anyhow::Result<Checked> {
    scene_format(&args.config)?;
    if args.workers == Some(0) && !args.cluster.has_remote() {
        return Err(usage(
            "--workers 0 leaves no worker: name workers with --worker HOST[:PORT], --hosts FILE, \
             --listen ADDR (workers dial in), --serial PATH, or give --workers N for threads here",
        ));
    }
    let loaded = load_scene(&args.config, &args.overrides())?;
    let kind = check_scene_output(&loaded, args.format)?;
    if let Some(r) = args.region {
        let s = &loaded.desc.settings;
        r.check(s.width, s.height).map_err(usage)?;
    }
    let secret = load_secret(args.cluster.secret_file.as_deref())?;
    let have = crate::util::sys::available_memory();
    check_image_memory(&loaded, (args.region, args.keep_size), kind, have)?;
    if let Some(stats) = &args.stats_json {
        check_stats_path(stats, &loaded)?;
    }
    Ok(Checked {
        loaded,
        kind,
        secret,
    })
}

/// Wall times of a render's parts.
struct Times {
    total: Duration,
    load: Duration,
    preparing: Duration,
    render: Duration,
    writing: Duration,
}

/// A render the master finished: its image, and when it had every line (the tracing's end;
/// the file is written after).
struct Traced {
    image: ClusterImage,
    complete: Instant,
}

/// Writes the statistics (`--stats-json`) and, unless `-q`, prints the summary, the effects
/// and the worker table.
///
/// # Errors
/// The statistics cannot be written (the image is then removed too).
fn report(
    args: &RenderArgs,
    loaded: &LoadedScene,
    prepared: &PreparedScene,
    image: &ClusterImage,
    times: Times,
) -> anyhow::Result<()> {
    let scene = &prepared.scene;
    let summary = RenderSummary {
        width: scene.settings.width,
        height: scene.settings.height,
        total: times.total,
        load: times.load,
        preparing: times.preparing,
        octree_build: prepared.octree_build,
        render: times.render,
        writing: times.writing,
        triangles: scene.triangle_points.len(),
        solids: scene.solids.len(),
        octree: *scene.octree.stats(),
        sphere_groups: scene.leaf_spheres.bytes(),
        rays: image.rays,
        workers: image.workers.len(),
        workers_lost: image.workers.iter().filter(|w| w.lost.is_some()).count(),
        peak_memory: crate::util::sys::peak_memory_bytes(),
        output: loaded.output.clone(),
    };
    if let Some(path) = &args.stats_json {
        let stats = RenderStats::new(
            &summary,
            scene.settings.samples,
            scene.effects,
            &image.workers,
        );
        write_stats(path, &stats, &loaded.output)?;
    }
    if !args.quiet {
        eprintln!("{summary}");
        eprintln!("effects: {}", scene.effects.describe());
        eprint!("{}", WorkerTable(&image.workers));
    }
    Ok(())
}

/// After a render with `--view`: the page keeps serving until Ctrl-C, and says so.
fn serve_until_ctrl_c(server: &ViewServer) {
    eprintln!(
        "view: the render is done; still serving {} until Ctrl-C",
        server.url
    );
    let stop = stop_on_ctrl_c();
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Starts the view's server at `address` and prints its URL (also with `-q`: it is what the
/// user asked for).
fn start_view(
    address: &str,
    secret: bool,
    insecure: bool,
) -> anyhow::Result<(ViewServer, std::sync::Arc<Hub>)> {
    let hub = Hub::new();
    let server = ViewServer::start(address, std::sync::Arc::clone(&hub), None, secret, insecure)?;
    eprintln!("view: {}", server.url);
    Ok((server, hub))
}

/// Checks that Strahl reads scenes from `path`'s extension: a usage error that lists what it
/// reads otherwise.
///
/// # Errors
/// The usage error.
pub fn scene_format(path: &Path) -> anyhow::Result<SceneFormat> {
    SceneFormat::of(path).map_err(|e| usage(format!("{}: {e}", path.display())))
}

/// Refuses, before anything is built, an image whose pixels cannot fit in the memory the system
/// reports available (`have`; `None`: it does not say). With `region` the master holds the
/// region's lines alone (all lines with adaptive multisampling, as its job does), and writes the
/// rectangle, or with `keep_size` the whole image.
fn check_image_memory(
    loaded: &LoadedScene,
    (region, keep_size): (Option<Region>, bool),
    kind: ImageKind,
    have: Option<u64>,
) -> anyhow::Result<()> {
    let s = &loaded.desc.settings;
    let (need, what) = match region {
        None => (
            image_memory(kind, s.width, s.height),
            format!("a {}x{} image", s.width, s.height),
        ),
        Some(r) => {
            let lines = Region::rendered_lines(region, s).len() as u32;
            let (w, h) = if keep_size {
                (s.width, s.height)
            } else {
                r.size()
            };
            (
                6 * u64::from(s.width) * u64::from(lines) + image_memory(kind, w, h),
                format!("the region {r} of a {}x{} image", s.width, s.height),
            )
        }
    };
    match have {
        Some(have) if need > have => Err(anyhow!(
            "{}: {what} needs {} for its pixels (6 bytes each while rendering, and what \
             writing it as {} copies), and the system has {} available; render a smaller \
             image",
            loaded.config_path.display(),
            crate::util::units::format_bytes(usize::try_from(need).unwrap_or(usize::MAX)),
            kind.name(),
            crate::util::units::format_bytes(usize::try_from(have).unwrap_or(usize::MAX))
        )),
        _ => Ok(()),
    }
}

/// Renders `prepared` with the workers the command line names, keeping every result in the
/// checkpoint (going on from it with `--resume`), and writes the image; the checkpoint is
/// removed once the image is written. Returns the image and when the master had every line.
///
/// # Errors
/// A checkpoint that cannot be opened, no worker, the render failing or stopped (the error
/// then says how to resume), the image that cannot be written.
fn render_and_write(
    args: &RenderArgs,
    output: &Output<'_>,
    (prepared, job): (&PreparedScene, &ClusterJob),
    secret: Option<Secret>,
    progress: &Progress,
    warn: &(dyn Fn(&str) + Sync),
    hub: Option<&Hub>,
) -> anyhow::Result<Traced> {
    let (checkpoint, kept) = open_checkpoint(args.resume, output.path, job)?;
    if !kept.is_empty() && !args.quiet {
        progress.println(&format!(
            "resuming: {} results kept in {}",
            kept.len(),
            checkpoint.path().display()
        ));
    }
    let checkpoint = Mutex::new(Some(checkpoint));
    let record = |task: u32, rays: RayCounts, pixels: &[Pixel]| {
        record_result(&checkpoint, task, rays, pixels, warn);
    };
    let workers = start_workers(
        &args.cluster.sources(secret.is_some()),
        args.worker_count(),
        prepared,
        warn,
    );
    let mut workers = match workers {
        Ok(w) => w,
        Err(e) => return Err(with_resume_hint(e, take(checkpoint))),
    };
    if let Some(hub) = hub {
        let rect = args.region.unwrap_or(Region::whole(job.width, job.height));
        hub.begin(Shown::part(job.width, rect, job.lines.clone()));
    }
    let on_final = |line: FinalLine<'_>| {
        if let Some(h) = hub {
            h.line(&line);
        }
    };
    if let Some(acceptor) = &workers.acceptor {
        progress.println(&format!("listening for workers on {}", acceptor.address));
        progress.waiting_on(&acceptor.address.to_string());
    }
    let on_tick = |w: &[WorkerState]| {
        progress.tick(w.iter().filter(|w| w.activity != Activity::Lost).count());
        if let Some(h) = hub {
            h.workers(w);
        }
    };
    let hooks = Hooks {
        on_line: &|_, rays| progress.line_done(rays),
        log: warn,
        on_result: Some(&record),
        on_final: hub.map(|_| &on_final as _),
        on_tick: Some(&on_tick),
        resume: &kept,
        stop: Some(stop_on_ctrl_c()),
    };
    let image = run_master_with(
        job,
        std::mem::take(&mut workers.links),
        workers.joins.as_ref(),
        &args.master_options(secret),
        &hooks,
    );
    let complete = Instant::now();
    progress.finish();
    let listened = workers.acceptor.as_ref().map(|a| a.address);
    drop(workers);
    let checkpoint = take(checkpoint);
    let image = match image {
        Ok(image) => image,
        Err(e) => {
            let e = why_no_image(e, listened, args.cluster.worker_timeout);
            return Err(with_resume_hint(e, checkpoint));
        }
    };
    write_output(args, output, (prepared, job), &image.pixels)?;
    // (None: writing it failed, as was warned.)
    if let Some(c) = checkpoint {
        c.remove()?;
    }
    Ok(Traced { image, complete })
}

/// Why the master gave no image, in words: when no worker ever joined a listening master,
/// where it waited and how workers join.
fn why_no_image(
    e: ClusterError,
    listened: Option<std::net::SocketAddr>,
    timeout_secs: f64,
) -> anyhow::Error {
    match (e, listened) {
        (ClusterError::AllWorkersLost { workers, .. }, Some(address)) if workers.is_empty() => {
            anyhow!(
                "no worker joined at {address} within {timeout_secs} s (--worker-timeout); \
                 start workers with `strahl worker --connect {address}`"
            )
        }
        (ClusterError::AllWorkersLost { workers, .. }, None) if workers.is_empty() => {
            anyhow!("no worker to render with")
        }
        (e, _) => e.into(),
    }
}

/// Where the image goes and in which format.
struct Output<'a> {
    path: &'a Path,
    kind: ImageKind,
}

/// Writes the image of the `rendered` lines of `job`, or with `--region` its rectangle
/// (`--keep-size`: the whole image with the rest in the background colour).
fn write_output(
    args: &RenderArgs,
    output: &Output<'_>,
    (prepared, job): (&PreparedScene, &ClusterJob),
    rendered: &[Pixel],
) -> anyhow::Result<()> {
    let s = prepared.scene.settings;
    let (kind, path) = (output.kind, output.path);
    let first = job.lines.start;
    match args.region {
        None => write_image(path, kind, s.width, s.height, rendered),
        Some(r) if args.keep_size => {
            let background = Pixel::from_color(s.background);
            let full = r.place((s.width, s.height), first, rendered, background);
            write_image(path, kind, s.width, s.height, &full)
        }
        Some(r) => {
            let (w, h) = r.size();
            write_image(path, kind, w, h, &r.crop(s.width, first, rendered))
        }
    }
}

/// The checkpoint out of its lock.
fn take(checkpoint: Mutex<Option<Checkpoint>>) -> Option<Checkpoint> {
    checkpoint.into_inner().unwrap_or_else(|e| e.into_inner())
}

/// The checkpoint of this render beside `output`: a new one, or with `resume` the one there
/// and the results it kept.
fn open_checkpoint(
    resume: bool,
    output: &Path,
    job: &ClusterJob,
) -> anyhow::Result<(Checkpoint, Vec<Record>)> {
    let path = checkpoint_path(output);
    if resume {
        Checkpoint::resume(&path, job)
    } else {
        Ok((Checkpoint::create(&path, job)?, Vec::new()))
    }
}

/// Appends a result to the checkpoint; if that fails, warns once and goes on without one.
fn record_result(
    checkpoint: &Mutex<Option<Checkpoint>>,
    task: u32,
    rays: RayCounts,
    pixels: &[Pixel],
    warn: &dyn Fn(&str),
) {
    let mut c = checkpoint.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(open) = c.as_mut() {
        if let Err(e) = open.append(task, rays, pixels) {
            warn(&format!("{e:#}; going on without a checkpoint"));
            if let Some(broken) = c.take() {
                // The file is incomplete: a resume from it would render the rest again anyway.
                let _ = broken.remove();
            }
        }
    }
}

/// The flag Ctrl-C, SIGTERM and SIGHUP set (`ctrlc`'s `termination` feature), with its
/// handler installed on first use. Without a handler they end the process at once: the
/// checkpoint is kept all the same, but an image being written leaves its temporary file.
fn stop_on_ctrl_c() -> &'static AtomicBool {
    static STOP: AtomicBool = AtomicBool::new(false);
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        // Another handler already installed (a library user's): theirs decides.
        let _ = ctrlc::set_handler(|| STOP.store(true, Ordering::Relaxed));
    });
    &STOP
}

/// A failed render's error, with how to go on where it stopped when a checkpoint kept results
/// (one that kept none is removed).
fn with_resume_hint(e: anyhow::Error, checkpoint: Option<Checkpoint>) -> anyhow::Error {
    let Some(c) = checkpoint else {
        return e;
    };
    if c.records() == 0 {
        return match c.remove() {
            Ok(()) => e,
            Err(r) => e.context(format!("{r:#}")),
        };
    }
    let mut command: Vec<String> = std::env::args().map(|a| shell_quote(&a)).collect();
    if !command.iter().any(|a| a == "--resume") {
        command.push("--resume".to_string());
    }
    e.context(format!(
        "the lines finished are kept in {}; go on with: {}",
        c.path().display(),
        command.join(" ")
    ))
}

/// `arg` quoted for a POSIX shell where it needs it.
fn shell_quote(arg: &str) -> String {
    let plain = !arg.is_empty()
        && arg
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./:=,+@%".contains(c));
    if plain {
        arg.to_string()
    } else {
        format!("'{}'", arg.replace('\'', "'\\''"))
    }
}

/// The scene prepared for rendering (checked, octree built); an error names the configuration
/// file for a bad image size and the data file for anything else.
fn prepare(loaded: &LoadedScene) -> anyhow::Result<PreparedScene> {
    PreparedScene::new(&loaded.desc, &OctreeParams::default()).map_err(|e| {
        let file = match e {
            PrepareError::Scene(SceneError::BadImageSize) => &loaded.config_path,
            _ => &loaded.data_path,
        };
        anyhow!("{}: {e}", file.display())
    })
}

/// Warns about what renders but is likely not meant: triangles that can never be hit, and an
/// `--aa-threshold` with nothing to supersample.
fn warn_about_scene(
    args: &RenderArgs,
    loaded: &LoadedScene,
    prepared: &PreparedScene,
    warn: &dyn Fn(&str),
) {
    for warning in &loaded.warnings {
        warn(warning);
    }
    let scene = &prepared.scene;
    if scene.degenerate_triangles > 0 {
        warn(&format!(
            "{}: {} of {} triangles have zero area (collinear or repeated points) and are never hit",
            loaded.data_path.display(),
            scene.degenerate_triangles,
            scene.triangle_points.len() + scene.solids.mesh_triangle_count()
        ));
    }
    if args.aa_threshold.is_some() && scene.settings.samples < 2 {
        warn("--aa-threshold has no effect at multisample 1: give -m 2 or more to supersample the pixels it flags");
    }
}

/// Writes the statistics as JSON to `path` (`-`: standard output); if that fails, removes the
/// image at `image` too (all or nothing: no image without its statistics).
fn write_stats(path: &Path, stats: &RenderStats, image: &Path) -> anyhow::Result<()> {
    let json = serde_json::to_string_pretty(stats)? + "\n";
    let written = if is_stdout(path) {
        let mut out = std::io::stdout().lock();
        out.write_all(json.as_bytes())
            .and_then(|()| out.flush())
            .map_err(|e| anyhow!("cannot write the statistics to standard output: {e}"))
    } else {
        write_atomically(path, |w| {
            w.write_all(json.as_bytes())
                .map_err(|e| anyhow!("{}: cannot write the statistics: {e}", path.display()))
        })
    };
    if let Err(e) = written {
        let _ = std::fs::remove_file(image);
        return Err(e);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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
    fn an_image_larger_than_the_memory_is_refused_with_both_figures() {
        let mut desc = crate::generate::room();
        desc.settings.width = 32768;
        desc.settings.height = 32768;
        let loaded = LoadedScene {
            desc,
            output: "out.bmp".into(),
            config_path: "raytracer.cfg".into(),
            data_path: "ROOM.txt".into(),
            inputs: vec!["raytracer.cfg".into(), "ROOM.txt".into()],
            warnings: Vec::new(),
        };
        let need = image_memory(ImageKind::Bmp, 32768, 32768);
        assert_eq!(need, 6_442_450_944, "BMP is written row by row: no copy");
        assert_eq!(image_memory(ImageKind::Png, 32768, 32768), 9_663_676_416);
        let whole = (None, false);
        let err = check_image_memory(&loaded, whole, ImageKind::Bmp, Some(need - 1))
            .expect_err("too large");
        let text = err.to_string();
        assert!(
            text.starts_with("raytracer.cfg: a 32768x32768 image needs"),
            "{text}"
        );
        assert!(check_image_memory(&loaded, whole, ImageKind::Bmp, Some(need)).is_ok());
        assert!(check_image_memory(&loaded, whole, ImageKind::Bmp, None).is_ok());
        // A region's lines alone: 16 of 32768 pixels while rendering, the 16x16 rectangle
        // written; with --keep-size the whole image written.
        let region = Region::parse("0,0,16,16").ok();
        let part = 6 * 32768 * 16 + 6 * 16 * 16;
        let err = check_image_memory(&loaded, (region, false), ImageKind::Bmp, Some(part - 1))
            .expect_err("too large");
        assert!(
            err.to_string()
                .starts_with("raytracer.cfg: the region 0,0,16,16 of a 32768x32768 image needs"),
            "{err}"
        );
        assert!(check_image_memory(&loaded, (region, false), ImageKind::Bmp, Some(part)).is_ok());
        let kept = (region, true);
        assert!(check_image_memory(&loaded, kept, ImageKind::Bmp, Some(need)).is_err());
    }
}
