//! What a render prints at the end: size and output, times, scene and octree, rays, workers.
//!
//! [`RenderSummary`] is those lines (its `Display`); [`RenderStats`] is the same render, with the
//! per-worker reports of [`crate::cluster::report`], as the JSON `--stats-json` writes.

pub use crate::util::units::format_bytes;
use crate::util::units::{format_ray_rate, group_digits};
use std::fmt;
use std::path::PathBuf;
use std::time::Duration;
use strahl_core::accel::octree::OctreeStats;
use strahl_core::render::stats::RayCounts;

/// Everything the closing line of a render reports.
#[derive(Clone, Debug)]
pub struct RenderSummary {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Wall time from start to the written file.
    pub total: Duration,
    /// Time spent reading the configuration and data files (part of `total`).
    pub load: Duration,
    /// Time spent preparing the scene (part of `total`): the octree, the lights' buffers and
    /// the other structures beside it, the scene's encoding for the workers.
    pub preparing: Duration,
    /// Time spent building the octree (part of `preparing`).
    pub octree_build: Duration,
    /// Time spent tracing rays (part of `total`): from the first line asked of a worker to the
    /// last line in.
    pub render: Duration,
    /// Time spent writing the image file after the tracing (part of `total`).
    pub writing: Duration,
    /// Triangles in the scene.
    pub triangles: usize,
    /// Solid objects (analytic shapes and CSG) in the scene.
    pub solids: usize,
    /// The octree's statistics.
    pub octree: OctreeStats,
    /// Bytes of the sphere groups kept for the octree's large leaves (0 where there are none).
    pub sphere_groups: usize,
    /// Rays traced.
    pub rays: RayCounts,
    /// Workers that joined.
    pub workers: usize,
    /// Of those, workers lost before the end.
    pub workers_lost: usize,
    /// The process's peak resident memory, if the system says.
    pub peak_memory: Option<u64>,
    /// The image file written.
    pub output: PathBuf,
}

impl fmt::Display for RenderSummary {
    /// Short lines (under 100 columns for any image name up to 40 characters): what was
    /// written, the times, the scene (the octree only where one was built), the rays by kind
    /// (the kinds traced), the workers.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let secs = |d: Duration| d.as_secs_f64();
        let r = &self.rays;
        writeln!(
            f,
            "rendered {}x{} in {:.2} s -> {}",
            self.width,
            self.height,
            secs(self.total),
            self.output.display()
        )?;
        writeln!(
            f,
            "  times:   load {:.2} s, preparing {:.2} s (octree {:.2} s), tracing {:.2} s ({})",
            secs(self.load),
            secs(self.preparing),
            secs(self.octree_build),
            secs(self.render),
            format_ray_rate(r.total(), secs(self.render)),
        )?;
        write!(
            f,
            "  scene:   {} triangles, {} solids",
            group_digits(self.triangles as u64),
            group_digits(self.solids as u64)
        )?;
        let o = &self.octree;
        if o.nodes > 0 {
            write!(
                f,
                "; octree {} nodes, {}, depth {}",
                group_digits(o.nodes as u64),
                format_bytes(o.bytes),
                o.depth
            )?;
        }
        writeln!(f)?;
        writeln!(f, "{}", wrap("  rays:    ", &rays_in_words(r), 100))?;
        let finished = self.workers - self.workers_lost;
        write!(
            f,
            "  workers: {} worker{} ({finished} finished, {} lost)",
            self.workers,
            if self.workers == 1 { "" } else { "s" },
            self.workers_lost
        )?;
        if let Some(b) = self.peak_memory {
            write!(f, "; peak memory {}", format_bytes(b as usize))?;
        }
        Ok(())
    }
}

/// The rays traced, by kind, with their digits grouped; kinds not traced are named together.
fn rays_in_words(r: &RayCounts) -> String {
    let kinds = [
        (r.primary, "primary"),
        (r.extra_samples, "extra samples"),
        (r.shadow, "shadow"),
        (r.reflection, "reflection"),
        (r.refraction, "refraction"),
        (r.occlusion, "occlusion"),
    ];
    let traced: Vec<String> = kinds
        .iter()
        .filter(|(n, _)| *n > 0)
        .map(|(n, kind)| format!("{} {kind}", group_digits(*n)))
        .collect();
    let none: Vec<&str> = kinds
        .iter()
        .filter(|(n, _)| *n == 0)
        .map(|(_, k)| *k)
        .collect();
    let mut text = traced.join(", ");
    if let Some((last, rest)) = none.split_last() {
        if !text.is_empty() {
            text.push_str("; ");
        }
        match rest {
            [] => text.push_str(&format!("no {last} rays")),
            _ => text.push_str(&format!("no {} or {last} rays", rest.join(", "))),
        }
    }
    text
}

/// `text` after `label`, broken after commas into lines of at most `width` characters, the
/// later ones indented as far as the label.
fn wrap(label: &str, text: &str, width: usize) -> String {
    let indent = " ".repeat(label.chars().count());
    let mut out = label.to_string();
    let mut line_len = out.chars().count();
    for (i, piece) in text.split_inclusive(", ").enumerate() {
        let n = piece.trim_end().chars().count();
        if i > 0 && line_len + n > width {
            out.truncate(out.trim_end().len());
            out.push('\n');
            out.push_str(&indent);
            line_len = indent.len();
        }
        out.push_str(piece);
        line_len += piece.chars().count();
    }
    out
}

/// The machine-readable statistics of a render (`--stats-json FILE`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct RenderStats {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel side.
    pub samples: u32,
    /// Seconds: total, load, octree build and tracing.
    pub seconds: StatsSeconds,
    /// Triangles in the scene.
    pub triangles: usize,
    /// Solid objects in the scene.
    pub solids: usize,
    /// The effects the scene calls for (derived before rendering).
    pub effects: strahl_core::scene::effects::Effects,
    /// Rays by kind, and their sum.
    pub rays: StatsRays,
    /// The work behind the rays: tests and cells, in all and per ray.
    pub work: StatsWork,
    /// The octree's build figures.
    pub octree: StatsOctree,
    /// The process's peak resident memory in bytes (`null` where the system does not say).
    pub peak_memory_bytes: Option<u64>,
    /// One entry per worker.
    pub workers: Vec<StatsWorker>,
    /// The image file written.
    pub output: String,
}

/// Wall times of a render in seconds.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct StatsSeconds {
    /// From start to the written file.
    pub total: f64,
    /// Reading the scene files.
    pub load: f64,
    /// Preparing the scene: the octree, the structures beside it, the encoding for workers.
    pub preparing: f64,
    /// Building the octree (part of `preparing`).
    pub octree: f64,
    /// Tracing: from the first line asked of a worker to the last line in.
    pub tracing: f64,
    /// Writing the image file, after the tracing.
    pub writing: f64,
}

/// Rays by kind and their sum.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct StatsRays {
    /// Counts by kind.
    #[serde(flatten)]
    pub kinds: RayCounts,
    /// All rays.
    pub total: u64,
}

/// The octree cells entered and intersection tests made, in all and per ray traced.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct StatsWork {
    /// Ray–primitive intersection tests.
    pub intersection_tests: u64,
    /// Octree cells entered.
    pub octree_cells: u64,
    /// Intersection tests per ray traced (0 without rays).
    pub tests_per_ray: f64,
    /// Octree cells entered per ray traced (0 without rays).
    pub cells_per_ray: f64,
}

impl StatsWork {
    fn new(rays: &RayCounts) -> StatsWork {
        let per_ray = |n: u64| match rays.total() {
            0 => 0.0,
            total => n as f64 / total as f64,
        };
        StatsWork {
            intersection_tests: rays.work.intersection_tests,
            octree_cells: rays.work.octree_cells,
            tests_per_ray: per_ray(rays.work.intersection_tests),
            cells_per_ray: per_ray(rays.work.octree_cells),
        }
    }
}

/// The octree's build figures in [`RenderStats`].
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub struct StatsOctree {
    /// Nodes, interior and leaf.
    pub nodes: u32,
    /// Leaves.
    pub leaves: u32,
    /// Leaves without a primitive.
    pub empty_leaves: u32,
    /// Depth of the deepest leaf.
    pub depth: u32,
    /// Leaf entries (a primitive in several cells counts once per cell).
    pub references: u32,
    /// Bytes of nodes and leaf entries.
    pub bytes: usize,
    /// Those bytes per primitive given to the build.
    pub bytes_per_primitive: f32,
    /// Bytes of the sphere groups kept beside the tree for its large leaves (scenes of many
    /// overlapping spheres; 0 elsewhere), not in `bytes`.
    pub sphere_group_bytes: usize,
}

impl StatsOctree {
    /// The figures of an octree with `sphere_group_bytes` of sphere groups beside it.
    fn new(o: &OctreeStats, sphere_group_bytes: usize) -> StatsOctree {
        StatsOctree {
            nodes: o.nodes,
            leaves: o.leaves,
            empty_leaves: o.empty_leaves,
            depth: o.depth,
            references: o.references,
            bytes: o.bytes,
            bytes_per_primitive: o.bytes_per_triangle(),
            sphere_group_bytes,
        }
    }
}

/// One worker's share in [`RenderStats`].
#[derive(Clone, Debug, serde::Serialize)]
pub struct StatsWorker {
    /// Its name.
    pub name: String,
    /// Lines it delivered first (their pixels are in the image).
    pub lines: u32,
    /// Lines it delivered after another worker had (copies that lost the race).
    pub duplicates: u32,
    /// Rays in every line it delivered, by kind, duplicates included: the sum over workers can
    /// exceed the render's total by the duplicates' rays.
    pub rays: RayCounts,
    /// Seconds it spent on lines.
    pub busy_seconds: f64,
    /// Why it was lost, if it was.
    pub lost: Option<String>,
}

impl RenderStats {
    /// The statistics of `summary`, with the workers' reports and the samples setting.
    pub fn new(
        summary: &RenderSummary,
        samples: u32,
        effects: strahl_core::scene::effects::Effects,
        workers: &[crate::cluster::report::WorkerReport],
    ) -> RenderStats {
        RenderStats {
            width: summary.width,
            height: summary.height,
            samples,
            seconds: StatsSeconds {
                total: summary.total.as_secs_f64(),
                load: summary.load.as_secs_f64(),
                preparing: summary.preparing.as_secs_f64(),
                octree: summary.octree_build.as_secs_f64(),
                tracing: summary.render.as_secs_f64(),
                writing: summary.writing.as_secs_f64(),
            },
            triangles: summary.triangles,
            solids: summary.solids,
            effects,
            rays: StatsRays {
                kinds: summary.rays,
                total: summary.rays.total(),
            },
            work: StatsWork::new(&summary.rays),
            octree: StatsOctree::new(&summary.octree, summary.sphere_groups),
            peak_memory_bytes: summary.peak_memory,
            workers: workers
                .iter()
                .map(|w| StatsWorker {
                    name: w.name.clone(),
                    lines: w.lines,
                    duplicates: w.duplicates,
                    rays: w.rays,
                    busy_seconds: w.busy.as_secs_f64(),
                    lost: w.lost.clone(),
                })
                .collect(),
            output: summary.output.display().to_string(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line() {
        let s = RenderSummary {
            width: 640,
            height: 480,
            total: Duration::from_millis(1230),
            load: Duration::from_millis(170),
            preparing: Duration::from_millis(80),
            octree_build: Duration::from_millis(50),
            render: Duration::from_millis(1000),
            writing: Duration::from_millis(10),
            triangles: 12345,
            solids: 3,
            octree: OctreeStats {
                nodes: 4567,
                bytes: 1_258_291,
                depth: 9,
                ..OctreeStats::default()
            },
            sphere_groups: 0,
            rays: RayCounts {
                primary: 307_200,
                shadow: 123,
                reflection: 45,
                refraction: 6,
                occlusion: 7,
                extra_samples: 8,
                ..RayCounts::default()
            },
            workers: 3,
            workers_lost: 1,
            peak_memory: Some(3 << 20),
            output: PathBuf::from("output.bmp"),
        };
        let text = s.to_string();
        assert_eq!(
            text,
            "rendered 640x480 in 1.23 s -> output.bmp\n\
             \x20 times:   load 0.17 s, preparing 0.08 s (octree 0.05 s), tracing 1.00 s (307.4 k rays/s)\n\
             \x20 scene:   12,345 triangles, 3 solids; octree 4,567 nodes, 1.2 MiB, depth 9\n\
             \x20 rays:    307,200 primary, 8 extra samples, 123 shadow, 45 reflection, 6 refraction, 7 occlusion\n\
             \x20 workers: 3 workers (2 finished, 1 lost); peak memory 3.0 MiB"
        );
        assert!(text.lines().all(|l| l.chars().count() <= 100), "{text}");
        // No octree, kinds not traced named together.
        let plain = RenderSummary {
            octree: OctreeStats::default(),
            rays: RayCounts {
                primary: 1000,
                shadow: 5,
                ..RayCounts::default()
            },
            workers: 1,
            workers_lost: 0,
            ..s
        };
        let text = plain.to_string();
        assert!(
            text.contains("  scene:   12,345 triangles, 3 solids\n"),
            "{text}"
        );
        assert!(
            text.contains("rays:    1,000 primary, 5 shadow; no extra samples, reflection, refraction or occlusion rays"),
            "{text}"
        );
        assert!(text.contains("1 worker (1 finished, 0 lost)"), "{text}");
        // Long counts wrap after a comma, under the label.
        let big = RenderSummary {
            rays: RayCounts {
                primary: 1_228_800,
                extra_samples: 9_830_400,
                shadow: 10_795_678,
                reflection: 1_714_824,
                refraction: 5_000_000,
                occlusion: 10_000_000,
                ..RayCounts::default()
            },
            ..plain
        };
        let text = big.to_string();
        assert!(text.lines().all(|l| l.chars().count() <= 100), "{text}");
        assert!(text.contains(",\n           "), "{text}");
        assert_eq!(format_bytes(100), "100 B");
        assert_eq!(format_bytes(2048), "2.0 KiB");
    }
}
