//! `strahl bench accuracy`: what each accuracy knob buys, and what it costs in time.
//!
//! For each scene (the demo room of `scenes/room/raytracer.cfg` and up to two `scenes/fart/*.fart`
//! by default, or the `--scene` files given) at a modest size, the command
//!
//! 1. renders a converged **reference**: multisample 16 (256 stratified samples per pixel, the
//!    renderer's most), reflection cut-off 0, depth cap 32, ambient occlusion at the scene's
//!    level. Pixels are the renderer's 16-bit fixed point, the reference's too. Two knobs get their
//!    own reference: ambient occlusion is compared with the same render at level 9, and the
//!    reflection knobs of a scene with reflections off are swept with reflections on and compared
//!    with the reference with reflections on. Every reference is also rendered at half its samples
//!    per side; the RMSE between the two is the reference's **residual**, an upper estimate of its
//!    own error, and differences between settings that the residual could explain are reported
//!    as not resolved;
//! 2. sweeps each knob alone from the **baseline** (the scene's own settings at multisample 1):
//!    multisample, adaptive threshold, reflection cut-off, depth cap, ambient-occlusion level,
//!    octree depth and leaf size, and 8- against 16-bit pixels (the protocol carries 16-bit pixels
//!    only: the 8-bit row is simulated on the rendered pixels, and the bytes its line results
//!    would take on the wire are computed with the protocol's own encoder);
//! 3. times every setting (median of `--runs` renders with one in-process worker per CPU, scene
//!    preparation not timed) and measures its error against the reference: RMSE and PSNR over
//!    the colour channels in `[0, 1]`, and SSIM (11×11 Gaussian window, σ = 1.5) on luminance;
//! 4. writes a Markdown report (`--out`, default `accuracy.md`, never over a file that is there
//!    without `--force`) with the table, an SVG plot
//!    of error against time with the Pareto front (written next to it), and a paragraph per knob
//!    generated from the measured numbers, each ending with a conclusion drawn from them.
//!
//! Octree settings must not change a pixel: the command fails, naming the setting and the first
//! pixel that differs, if one does.
//!
//! This file holds the command line, the data of a sweep (knobs, configurations, rows,
//! references, a scene's run) and the run over the scenes; the parts: `plan` (each knob's values
//! from the baseline), `measure` (one scene: references, rounds of renders, errors), `metrics`
//! (RMSE, PSNR, SSIM, the Pareto front), `wire` (line-result bytes at 16 and 8 bits),
//! `conclusions` (what the reference resolves, and the conclusion of each paragraph), `report`
//! (the Markdown text), `plot` (the SVG) and `format` (numbers in text).

use crate::formats::load::{load_scene, Overrides};
use anyhow::{anyhow, bail, Context as _};
use std::io::Write as _;
use std::num::NonZeroUsize;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::{RenderSettings, SceneDesc, MAX_IMAGE_SIDE, MAX_SAMPLES};

mod conclusions;
mod format;
mod measure;
mod metrics;
mod plan;
mod plot;
mod report;
mod wire;

pub use metrics::{pareto_front, psnr, rmse, ssim, through_8_bits, to_colors, Colors};
pub use plot::{svg, PlotPanel, PlotPoint};
pub use wire::{
    line_result_frame, serial_seconds, wire_bytes, WireBytes, PIXEL_WIRE_BYTES_8,
    SERIAL_BITS_PER_BYTE,
};

use measure::run_scene;
use plan::Setting;
use report::{load_average, report};

/// The demo room's configuration file, relative to the checkout's root.
pub const DEFAULT_ROOM: &str = "scenes/room/raytracer.cfg";
/// The folder whose `.fart` scenes are added by default: the first two that load of
/// [`PREFERRED_FART_SCENES`] and then the others by name.
pub const DEFAULT_FART_DIR: &str = "scenes/fart";
/// The `.fart` scenes tried first: facing mirrors (the reflection knobs matter) and glass
/// spheres (refraction, so the depth cap matters).
pub const PREFERRED_FART_SCENES: [&str; 2] = ["mirrors.fart", "glass.fart"];
/// The least wall time of one timed run: shorter renders repeat within the run, and the run's
/// time is the mean per render.
pub const MIN_RUN: Duration = Duration::from_millis(100);
/// Samples per pixel side of the main reference: the renderer's most ([`MAX_SAMPLES`]).
///
/// Chosen by measured cost. Multisample 8 was not converged: against multisample 16 its RMSE was
/// about 0.0009, as large as the differences between multisample 5, 6 and 7. There is no render
/// at twice the samples per side of multisample 16 to measure its residual against (the renderer
/// stops at 16), so the reference is multisample 16 and its residual is measured against
/// multisample 8 ([`residual_probe_samples`]), which bounds it from above. Multisample 16 costs
/// about four times multisample 8 (glass.fart at 240×180 on 2 CPUs: 2.8 s against 14.8 s): in the
/// run that wrote `docs/accuracy.md` (282 s) the three scenes' main references took 20 s at
/// multisample 8, so multisample 16 adds about a minute, and the residual renders (a quarter of
/// each reference, the ambient-occlusion ones included) about 45 s more: acceptable.
pub const REFERENCE_SAMPLES: u32 = MAX_SAMPLES;
/// Depth cap of the reference.
pub const REFERENCE_DEPTH: u32 = 32;
/// Samples per pixel side of the ambient-occlusion reference (level 9): 16 × 81 = 1,296
/// occlusion rays per pixel; multisample 8 would take four times as long. Its residual is
/// measured like the main reference's, against half the samples per side.
pub const OCCLUSION_REFERENCE_SAMPLES: u32 = 4;

/// Samples per pixel side of the render a reference's residual is measured against: half the
/// reference's (at least 1).
pub const fn residual_probe_samples(samples: u32) -> u32 {
    if samples > 1 {
        samples / 2
    } else {
        1
    }
}

/// An image size given as `WxH`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageSize {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// Parses `WxH` (for example `320x240`), each side 8 to [`MAX_IMAGE_SIDE`].
///
/// # Errors
/// A message naming what is wrong.
pub fn parse_size(s: &str) -> Result<ImageSize, String> {
    let (w, h) = s
        .split_once(['x', 'X', '×'])
        .ok_or_else(|| format!("expected WIDTHxHEIGHT, e.g. 320x240, found `{s}`"))?;
    let side = |v: &str, what: &str| -> Result<u32, String> {
        let n: u32 = v
            .trim()
            .parse()
            .map_err(|_| format!("the {what} `{v}` is not a whole number"))?;
        if !(8..=MAX_IMAGE_SIDE).contains(&n) {
            return Err(format!(
                "the {what} must be 8 to {MAX_IMAGE_SIDE} pixels, found {n}"
            ));
        }
        Ok(n)
    };
    Ok(ImageSize {
        width: side(w, "width")?,
        height: side(h, "height")?,
    })
}

/// What `strahl bench accuracy` measures (its command line is `cli::bench::AccuracyOptions`).
#[derive(Clone, Debug)]
pub struct AccuracyOptions {
    /// The scenes to measure; empty: the room and the first two FART scenes that load.
    pub scenes: Vec<PathBuf>,
    /// Image size of every render.
    pub size: ImageSize,
    /// Timed runs per setting (the median is reported).
    pub runs: u32,
    /// The Markdown report; the SVG plot goes next to it (same name, `.svg`).
    pub out: PathBuf,
    /// Sweep fewer values of each knob.
    pub quick: bool,
    /// Replace a report or plot that is there.
    pub force: bool,
}

// ---------------------------------------------------------------------------------------------
// The sweep
// ---------------------------------------------------------------------------------------------

/// The knobs swept.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Knob {
    /// Samples per pixel side (`-m`).
    Multisample,
    /// Adaptive multisampling threshold at multisample 4.
    Adaptive,
    /// Reflection (and refraction) weight cut-off.
    Cutoff,
    /// Bounce depth cap.
    Depth,
    /// Ambient-occlusion level.
    Occlusion,
    /// Octree depth limit.
    OctreeDepth,
    /// Octree leaf size.
    OctreeLeaf,
    /// Bits per channel of the pixels on the wire.
    Precision,
}

impl Knob {
    /// Every knob, in report order.
    pub const ALL: [Knob; 8] = [
        Knob::Multisample,
        Knob::Adaptive,
        Knob::Cutoff,
        Knob::Depth,
        Knob::Occlusion,
        Knob::OctreeDepth,
        Knob::OctreeLeaf,
        Knob::Precision,
    ];

    /// The knob's name in the table.
    pub fn name(self) -> &'static str {
        match self {
            Knob::Multisample => "multisample",
            Knob::Adaptive => "adaptive threshold (m 4)",
            Knob::Cutoff => "reflection cut-off",
            Knob::Depth => "depth cap",
            Knob::Occlusion => "ambient occlusion",
            Knob::OctreeDepth => "octree depth",
            Knob::OctreeLeaf => "octree leaf size",
            Knob::Precision => "pixel precision",
        }
    }

    /// Its colour in the plot.
    fn color(self) -> &'static str {
        match self {
            Knob::Multisample => "#1f77b4",
            Knob::Adaptive => "#ff7f0e",
            Knob::Cutoff => "#2ca02c",
            Knob::Depth => "#d62728",
            Knob::Occlusion => "#9467bd",
            Knob::OctreeDepth => "#8c564b",
            Knob::OctreeLeaf => "#e377c2",
            Knob::Precision => "#7f7f7f",
        }
    }
}

/// What a row's error is measured against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum RefKind {
    /// The converged reference at the scene's settings.
    Main,
    /// The reference with reflections turned on (scenes that have them off).
    Reflections,
    /// The reference at ambient-occlusion level 9.
    Occlusion9,
    /// The baseline render with the default octree (octree rows: must be identical).
    Baseline,
}

impl RefKind {
    fn name(self) -> &'static str {
        match self {
            RefKind::Main => "reference",
            RefKind::Reflections => "reference, reflections on",
            RefKind::Occlusion9 => "reference, AO 9 (m 4)",
            RefKind::Baseline => "baseline (default octree)",
        }
    }
}

/// One render configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Config {
    settings: RenderSettings,
    octree: OctreeParams,
}

/// A configuration rendered and timed.
struct Measured {
    config: Config,
    /// Wall time of each render, one per round.
    times: Vec<Duration>,
    /// Median of `times`.
    time: Duration,
    pixels: Vec<Pixel>,
    colors: Colors,
    rays: RayCounts,
    /// Index of the first measured configuration of this scene with exactly these pixels.
    image: usize,
}

/// The three error figures.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Errors {
    rmse: f64,
    psnr: f64,
    ssim: f64,
}

/// One row of the report.
struct Row {
    scene: usize,
    knob: Knob,
    /// The knob's value.
    setting: Setting,
    /// The value in the table.
    value: String,
    /// Short label in the plot.
    short: String,
    /// Index into the scene's measured configurations.
    measured: usize,
    /// 8-bit pixels (precision row).
    eight_bit: bool,
    reference: RefKind,
    time: Duration,
    ratio: f64,
    errors: Errors,
}

/// A reference as rendered, with its residual.
struct Reference {
    /// The comparisons it serves (several when they share its settings).
    kinds: Vec<RefKind>,
    settings: RenderSettings,
    /// Render time (one run).
    time: Duration,
    rays: RayCounts,
    /// Samples per pixel side of the residual render ([`residual_probe_samples`]).
    probe_samples: u32,
    /// Its render time (one run).
    probe_time: Duration,
    /// The residual render's error against the reference: its RMSE is the reference's residual.
    residual: Errors,
}

/// A scene as measured.
struct SceneRun {
    name: String,
    triangles: usize,
    solids: usize,
    baseline: RenderSettings,
    baseline_time: Duration,
    /// The distinct references.
    references: Vec<Reference>,
    reflections_forced: bool,
    measured: Vec<Measured>,
    /// Error of 8-bit against 16-bit pixels of the baseline render.
    quantization: Errors,
    /// The baseline image's line results on the wire.
    wire: WireBytes,
}

impl SceneRun {
    /// The residual (RMSE) of the reference that `kind` compares with; 0 for the baseline.
    fn residual(&self, kind: RefKind) -> f64 {
        self.residual_errors(kind).map_or(0.0, |e| e.rmse)
    }

    /// The residual render's errors against the reference that `kind` compares with; `None`
    /// for the baseline (compared exactly).
    fn residual_errors(&self, kind: RefKind) -> Option<Errors> {
        self.references
            .iter()
            .find(|r| r.kinds.contains(&kind))
            .map(|r| r.residual)
    }

    /// The largest relative spread of median times among settings that do the same work (default
    /// octree, identical image, identical ray counts): `(max / min − 1, how many settings)`.
    fn noise(&self) -> Option<(f64, usize)> {
        let same_octree: Vec<&Measured> = self
            .measured
            .iter()
            .filter(|m| m.config.octree == OctreeParams::default())
            .collect();
        let mut worst: Option<(f64, usize)> = None;
        for (i, a) in same_octree.iter().enumerate() {
            let group: Vec<&&Measured> = same_octree[i..]
                .iter()
                .filter(|b| b.image == a.image && b.rays == a.rays)
                .collect();
            if group.len() < 2 {
                continue;
            }
            let (lo, hi) = group.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), m| {
                let t = m.time.as_secs_f64();
                (lo.min(t), hi.max(t))
            });
            if lo > 0.0 {
                let spread = hi / lo - 1.0;
                if worst.is_none_or(|(w, _)| spread > w) {
                    worst = Some((spread, group.len()));
                }
            }
        }
        worst
    }
}

// ---------------------------------------------------------------------------------------------
// Running it
// ---------------------------------------------------------------------------------------------

/// The scenes to measure, each with whether it must load: the ones given, or the demo room and
/// every `scenes/fart/*.fart`, preferred ones first (the first two that load are used).
fn scene_list(args: &AccuracyOptions) -> anyhow::Result<Vec<(PathBuf, bool)>> {
    if !args.scenes.is_empty() {
        return Ok(args.scenes.iter().map(|p| (p.clone(), true)).collect());
    }
    let room = PathBuf::from(DEFAULT_ROOM);
    if !room.is_file() {
        bail!(
            "{DEFAULT_ROOM}: not found; run from the checkout's root folder or name scenes with \
             --scene PATH"
        );
    }
    let mut list = vec![(room, true)];
    let mut farts: Vec<PathBuf> = std::fs::read_dir(DEFAULT_FART_DIR)
        .map(|d| {
            d.filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| p.extension().is_some_and(|e| e == "fart"))
                .collect()
        })
        .unwrap_or_default();
    farts.sort_by_key(|p| {
        let name = p.file_name().map(|n| n.to_string_lossy().into_owned());
        let rank = PREFERRED_FART_SCENES
            .iter()
            .position(|&f| name.as_deref() == Some(f))
            .unwrap_or(PREFERRED_FART_SCENES.len());
        (rank, p.clone())
    });
    list.extend(farts.into_iter().map(|p| (p, false)));
    Ok(list)
}

fn load(path: &Path, size: ImageSize) -> anyhow::Result<SceneDesc> {
    let loaded = load_scene(path, &Overrides::default()).map_err(|e| anyhow!("{e}"))?;
    let mut desc = loaded.desc;
    desc.settings.width = size.width;
    desc.settings.height = size.height;
    desc.validate()
        .map_err(|e| anyhow!("{}: {e}", path.display()))?;
    Ok(desc)
}

/// Runs `strahl bench accuracy`: prints the table on stdout as it goes and writes the report and
/// its plot.
///
/// # Errors
/// A scene that cannot be loaded (naming the file; default `.fart` scenes that fail are skipped
/// with a note), a render failure, an octree setting that changes a pixel, or a report that
/// cannot be written (naming the file).
pub fn run(args: &AccuracyOptions) -> anyhow::Result<()> {
    let start = Instant::now();
    let load_start = load_average();
    let cores = std::thread::available_parallelism().map_or(1, NonZeroUsize::get);
    let svg_path = args.out.with_extension("svg");
    let svg_name = svg_path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .ok_or_else(|| anyhow!("{}: not a file name", args.out.display()))?;
    check_report_folder(&args.out)?;
    crate::formats::fs::refuse_to_replace(&[&args.out, &svg_path], args.force)?;

    let list = scene_list(args)?;
    println!(
        "strahl bench accuracy: {}x{}, {} runs per setting, {cores} workers{}",
        args.size.width,
        args.size.height,
        args.runs.max(1),
        if args.quick { ", quick sweep" } else { "" }
    );
    let Sweeps {
        scenes,
        rows,
        skipped,
    } = run_scenes(list, args, cores)?;
    let total = start.elapsed();

    let md = report(
        args,
        &scenes,
        &skipped,
        &rows,
        cores,
        total,
        &svg_name,
        &load_start,
    );
    let picture = svg(&plot_panels(&scenes, &rows));
    for (path, text) in [(&args.out, &md), (&svg_path, &picture)] {
        crate::formats::fs::write_atomically(path, |w| {
            w.write_all(text.as_bytes())
                .with_context(|| format!("{}: cannot write", path.display()))
        })?;
    }
    println!(
        "\nwrote {} and {} ({:.1} s)",
        args.out.display(),
        svg_path.display(),
        total.as_secs_f64()
    );
    Ok(())
}

/// Fails before the long part if the report `out` cannot be written: its folder must exist.
fn check_report_folder(out: &Path) -> anyhow::Result<()> {
    let folder = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !folder.is_dir() {
        bail!(
            "{}: cannot write the report: no such folder {}",
            out.display(),
            folder.display()
        );
    }
    Ok(())
}

/// Every scene measured, with the rows of all of them.
struct Sweeps {
    scenes: Vec<SceneRun>,
    rows: Vec<Row>,
    /// The default scenes that did not load, with why.
    skipped: Vec<String>,
}

/// Loads and measures the scenes of `list` ([`scene_list`]): all the required ones and the first
/// two optional ones that load.
fn run_scenes(
    list: Vec<(PathBuf, bool)>,
    args: &AccuracyOptions,
    cores: usize,
) -> anyhow::Result<Sweeps> {
    let mut skipped = Vec::new();
    let mut scenes = Vec::new();
    let mut rows = Vec::new();
    let mut optional = 0;
    for (path, required) in list {
        if !required && optional == 2 {
            break;
        }
        let desc = match load(&path, args.size) {
            Ok(d) => d,
            Err(e) if !required => {
                eprintln!("skipping {}: {e}", path.display());
                skipped.push(format!("`{}`: {e}", path.display()));
                continue;
            }
            Err(e) => return Err(e),
        };
        optional += usize::from(!required);
        let name = path.display().to_string();
        let index = scenes.len();
        scenes.push(run_scene(&name, &desc, args, cores, index, &mut rows)?);
    }
    Ok(Sweeps {
        scenes,
        rows,
        skipped,
    })
}

/// The plot's panels: one per scene, one point per render and reference (the baseline appears
/// under several knobs), octree rows left out.
fn plot_panels(scenes: &[SceneRun], rows: &[Row]) -> Vec<PlotPanel> {
    scenes
        .iter()
        .enumerate()
        .map(|(si, sc)| {
            let mut seen: Vec<(usize, bool, RefKind)> = Vec::new();
            let mut points = Vec::new();
            for r in rows.iter().filter(|r| {
                r.scene == si && !matches!(r.knob, Knob::OctreeDepth | Knob::OctreeLeaf)
            }) {
                let key = (r.measured, r.eight_bit, r.reference);
                if seen.contains(&key) {
                    continue;
                }
                seen.push(key);
                points.push(PlotPoint {
                    time: r.time.as_secs_f64(),
                    rmse: r.errors.rmse,
                    knob: r.knob,
                    label: r.short.clone(),
                    main: r.reference == RefKind::Main,
                });
            }
            PlotPanel {
                title: sc.name.clone(),
                points,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(
            parse_size("320x240"),
            Ok(ImageSize {
                width: 320,
                height: 240
            })
        );
        assert!(parse_size("320").is_err());
        assert!(parse_size("4x4").is_err());
        assert!(parse_size("ax3").is_err());
    }
}
