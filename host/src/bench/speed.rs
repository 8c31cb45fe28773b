//! `strahl bench`: the performance figures of issue 2, measured in one run on this machine.
//!
//! On the generated large scene (at least 100,000 triangles), or on a scene file given with
//! `--scene` (an SPD scene, say), it reports the octree build time, octree bytes per primitive,
//! primary rays per second on one core with shading off (closest hit only, four neighbouring
//! pixels' rays together as `render_line` traces them), and a full render
//! (the scene's shading) on one core for comparison. Each figure is the median of several runs;
//! ratios are against figures from the same run.

use super::stats::median;
use crate::generate;
use anyhow::Context as _;
use std::path::PathBuf;
use std::time::{Duration, Instant};
use strahl_core::accel::octree::{Octree, OctreeParams, LANES};
use strahl_core::render::intersect::QueryScratch;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::scene::{RenderSettings, Scene, SceneDesc};
use strahl_formats::load::{load_scene, Overrides};

/// What `strahl bench` measures and how often.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// A scene file to measure instead of the generated scene.
    pub scene: Option<PathBuf>,
    /// Triangles in the generated scene (at least).
    pub triangles: u32,
    /// Image size of the ray-throughput runs (square).
    pub size: u32,
    /// Runs per figure; the median is reported.
    pub runs: usize,
    /// Octree limits.
    pub octree: OctreeParams,
}

impl Default for BenchOptions {
    fn default() -> Self {
        BenchOptions {
            scene: None,
            triangles: 100_000,
            size: 512,
            runs: 5,
            octree: OctreeParams::default(),
        }
    }
}

/// The measured figures.
#[derive(Clone, Debug)]
pub struct BenchReport {
    /// What was measured: the scene file, or the generated scene.
    pub scene: String,
    /// Primitives in the scene (triangles and solids).
    pub triangles: usize,
    /// Median octree build time.
    pub build: Duration,
    /// Octree statistics of the last build.
    pub stats: strahl_core::accel::octree::OctreeStats,
    /// Median primary rays per second, one core, closest hit only.
    pub primary_rays_per_s: f64,
    /// Median rays (all kinds) per second of a full render on one core.
    pub shaded_rays_per_s: f64,
    /// Median wall time of the full render on one core.
    pub shaded_time: Duration,
}

/// The scene to measure at `opts.size` squared, and its name for the report.
fn scene_desc(opts: &BenchOptions) -> anyhow::Result<(SceneDesc, String)> {
    let Some(path) = &opts.scene else {
        let mut desc = generate::large(opts.triangles);
        desc.settings = RenderSettings {
            width: opts.size,
            height: opts.size,
            ..RenderSettings::default()
        };
        return Ok((desc, "generated: strahl generate large".to_string()));
    };
    let overrides = Overrides {
        width: Some(opts.size),
        height: Some(opts.size),
        ..Overrides::default()
    };
    let loaded = load_scene(path, &overrides)?;
    Ok((loaded.desc, path.display().to_string()))
}

/// Runs the benchmark.
///
/// # Errors
/// How many of line `y`'s `w` pixel-centre rays hit something: four neighbours at a time, as
/// `render_line` finds the first hits of one sample per pixel, the last few one at a time.
fn primary_hits(scene: &Scene, y: u32, w: u32, scratch: &mut QueryScratch) -> u64 {
    let ray = |x: u32| scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5);
    let mut hits = 0;
    let mut x = 0;
    while x + LANES as u32 <= w {
        let rays = std::array::from_fn(|l| ray(x + l as u32));
        let four = scene.closest_hits4(&rays, f32::INFINITY, [None; LANES], scratch);
        hits += four.iter().filter(|h| h.is_some()).count() as u64;
        x += LANES as u32;
    }
    for x in x..w {
        hits += u64::from(scene.closest_hit(&ray(x), f32::INFINITY, scratch).is_some());
    }
    hits
}

/// The scene file's load error, or the scene's [`SceneError`](strahl_core::scene::error::SceneError)
/// (the generated scene is valid for any options the command line accepts).
pub fn run(opts: &BenchOptions) -> anyhow::Result<BenchReport> {
    let (desc, name) = scene_desc(opts)?;
    let scene = Scene::build(&desc, &opts.octree).with_context(|| name.clone())?;
    let runs = opts.runs.max(1);

    let mut builds = Vec::with_capacity(runs);
    let extents = scene.solids.extents();
    let mut build = || {
        let start = Instant::now();
        let tree = Octree::build_mixed(&scene.triangle_points, &extents, &opts.octree);
        builds.push(start.elapsed());
        tree
    };
    // At least one build, so there are always statistics.
    let mut octree = build();
    for _ in 1..runs {
        octree = build();
    }
    let stats = *octree.stats();

    let (w, h) = (opts.size, opts.size);
    let mut primary = Vec::with_capacity(runs);
    let mut hits = 0u64;
    let mut scratch = QueryScratch::default();
    for _ in 0..runs {
        hits = 0;
        let start = Instant::now();
        for y in 0..h {
            hits += primary_hits(&scene, y, w, &mut scratch);
        }
        primary.push(start.elapsed());
    }
    std::hint::black_box(hits);

    let mut shaded = Vec::with_capacity(runs);
    let mut rays = 0u64;
    let mut line = vec![Pixel::default(); w as usize];
    for _ in 0..runs {
        rays = 0;
        let start = Instant::now();
        for y in 0..h {
            if let Ok(c) = render_line(&scene, y, &mut line) {
                rays += c.total();
            }
        }
        shaded.push(start.elapsed());
    }
    let shaded_time = median(shaded);
    Ok(BenchReport {
        scene: name,
        triangles: scene.triangle_points.len() + scene.solids.len(),
        build: median(builds),
        stats,
        primary_rays_per_s: (w * h) as f64 / median(primary).as_secs_f64(),
        shaded_rays_per_s: rays as f64 / shaded_time.as_secs_f64(),
        shaded_time,
    })
}

impl std::fmt::Display for BenchReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = &self.stats;
        let per_million = self.build.as_secs_f64() * 1e6 / self.triangles as f64;
        writeln!(f, "scene: {} primitives ({})", self.triangles, self.scene)?;
        writeln!(
            f,
            "octree build: {:.3} s median ({:.3} s per million primitives)",
            self.build.as_secs_f64(),
            per_million
        )?;
        writeln!(
            f,
            "octree: {} nodes, {} leaves ({} empty), depth {}, {:.1} primitives per leaf (max {}), {} bytes = {:.1} bytes per primitive",
            s.nodes,
            s.leaves,
            s.empty_leaves,
            s.depth,
            s.mean_leaf_triangles(),
            s.max_leaf_triangles,
            s.bytes,
            s.bytes_per_triangle()
        )?;
        writeln!(
            f,
            "primary rays, shading off, 1 core: {:.2} M rays/s median",
            self.primary_rays_per_s / 1e6
        )?;
        write!(
            f,
            "full render (the scene's shading), 1 core: {:.3} s, {:.2} M rays/s median",
            self.shaded_time.as_secs_f64(),
            self.shaded_rays_per_s / 1e6
        )
    }
}
