//! The local executor: worker threads in this process, each taking the next free image line.
//!
//! This is the seed's scheduling ("one image line to whichever client is free") with threads for
//! clients: an atomic counter hands out line numbers, each worker renders its line with
//! [`render_line`] straight into that line's place in the image, and the ray counts are summed at
//! the end. Because `render_line` depends only on the scene and the line number, the image is the
//! same, bit for bit, for any number of workers.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::Mutex;
use strahl_core::error::RenderError;
use strahl_core::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::scene::Scene;
use strahl_core::shade::RayCounts;

/// Why a local render failed.
#[derive(Debug, thiserror::Error)]
pub enum LocalRenderError {
    /// `render_line` refused a line (an internal error: the executor asked for a wrong line).
    #[error("internal error: rendering line {line}: {error}")]
    Render {
        /// The line that failed.
        line: u32,
        /// What `render_line` reported.
        error: RenderError,
    },
    /// The operating system could not start a worker thread.
    #[error("cannot start a worker thread: {0}")]
    Spawn(#[from] std::io::Error),
}

/// A rendered image: pixels row-major, top row first, and the rays traced for it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LocalImage {
    /// `width × height` pixels, row-major, top row first.
    pub pixels: Vec<Pixel>,
    /// All rays traced, summed over the lines.
    pub rays: RayCounts,
}

/// What the workers share: the next line to hand out, a stop flag, and one slot per line.
struct Shared<'a, 'img> {
    scene: &'a Scene,
    next: AtomicU32,
    failed: AtomicBool,
    /// Line `y` of the image; each is locked by exactly one worker, so never contended.
    rows: Vec<Mutex<&'img mut [Pixel]>>,
    error: Mutex<Option<LocalRenderError>>,
    on_line: &'a (dyn Fn(u32, RayCounts) + Sync),
}

impl Shared<'_, '_> {
    /// One worker's loop: takes lines until none are left (or another worker failed) and returns
    /// the rays it traced.
    fn work(&self) -> RayCounts {
        let mut total = RayCounts::default();
        while !self.failed.load(Ordering::Relaxed) {
            let y = self.next.fetch_add(1, Ordering::Relaxed);
            let Some(row) = self.rows.get(y as usize) else {
                break;
            };
            // A worker that panicked while holding a row poisons only that row; its data is
            // overwritten here anyway.
            let mut row = row.lock().unwrap_or_else(|e| e.into_inner());
            match render_line(self.scene, y, &mut row) {
                Ok(counts) => {
                    total += counts;
                    (self.on_line)(y, counts);
                }
                Err(error) => {
                    self.fail(LocalRenderError::Render { line: y, error });
                    break;
                }
            }
        }
        total
    }

    /// Records the first error and stops the other workers.
    fn fail(&self, err: LocalRenderError) {
        self.failed.store(true, Ordering::Relaxed);
        let mut slot = self.error.lock().unwrap_or_else(|e| e.into_inner());
        slot.get_or_insert(err);
    }
}

/// Renders `scene` with `workers` threads (at least 1, at most one per line; the calling thread is
/// one of them) and calls `on_line(y, rays)` from a worker after each finished line.
///
/// # Errors
/// [`LocalRenderError::Spawn`] if a thread cannot be started, [`LocalRenderError::Render`] if a
/// line cannot be rendered (which the scene's own size rules out).
pub fn render_local(
    scene: &Scene,
    workers: usize,
    on_line: &(dyn Fn(u32, RayCounts) + Sync),
) -> Result<LocalImage, LocalRenderError> {
    let width = scene.settings.width as usize;
    let height = scene.settings.height as usize;
    let mut pixels = vec![Pixel::default(); width * height];
    let workers = workers.clamp(1, height.max(1));
    let mut rays = RayCounts::default();
    if width > 0 {
        let shared = Shared {
            scene,
            next: AtomicU32::new(0),
            failed: AtomicBool::new(false),
            rows: pixels.chunks_mut(width).map(Mutex::new).collect(),
            error: Mutex::new(None),
            on_line,
        };
        std::thread::scope(|s| {
            let mut handles = Vec::with_capacity(workers - 1);
            for i in 1..workers {
                let shared = &shared;
                match std::thread::Builder::new()
                    .name(format!("strahl-worker-{i}"))
                    .spawn_scoped(s, move || shared.work())
                {
                    Ok(h) => handles.push(h),
                    Err(e) => {
                        shared.fail(e.into());
                        break;
                    }
                }
            }
            rays += shared.work();
            for h in handles {
                match h.join() {
                    Ok(counts) => rays += counts,
                    Err(panic) => std::panic::resume_unwind(panic),
                }
            }
        });
        let error = shared.error.into_inner().unwrap_or_else(|e| e.into_inner());
        if let Some(err) = error {
            return Err(err);
        }
    }
    Ok(LocalImage { pixels, rays })
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use std::sync::atomic::AtomicU64;
    use strahl_core::camera::Camera;
    use strahl_core::octree::OctreeParams;
    use strahl_core::scene::{Light, RenderSettings, SceneDesc, Shader, TriangleDesc};

    fn scene(width: u32, height: u32) -> Scene {
        let points = vec![
            Vec3::new(-5.0, 5.0, -3.0),
            Vec3::new(5.0, 5.0, -3.0),
            Vec3::new(0.0, 5.0, 4.0),
            Vec3::new(-8.0, 8.0, -3.0),
            Vec3::new(8.0, 8.0, -3.0),
            Vec3::new(0.0, 8.0, 6.0),
        ];
        let triangles = vec![
            TriangleDesc {
                points: [0, 1, 2],
                shader: 0,
            },
            TriangleDesc {
                points: [3, 4, 5],
                shader: 1,
            },
        ];
        let shaders = vec![
            Shader {
                ambient: Vec3::splat(0.1),
                diffuse: Vec3::new(0.8, 0.2, 0.2),
                specular: Vec3::splat(0.5),
                shininess: 20.0,
                reflection: 0.3,
            },
            Shader {
                ambient: Vec3::splat(0.05),
                diffuse: Vec3::new(0.2, 0.7, 0.3),
                specular: Vec3::ZERO,
                shininess: 1.0,
                reflection: 0.0,
            },
        ];
        let lights = vec![Light {
            position: Vec3::new(1.0, -2.0, 6.0),
            color: Vec3::ONE,
            amount: 1.0,
            casts_shadows: true,
        }];
        let desc = SceneDesc {
            points,
            triangles,
            shaders,
            lights,
            camera: Camera {
                position: Vec3::new(0.0, -10.0, 0.0),
                ..Camera::default()
            },
            settings: RenderSettings {
                width,
                height,
                ..RenderSettings::default()
            },
        };
        Scene::build(&desc, &OctreeParams::default()).expect("the test scene is valid")
    }

    #[test]
    fn identical_for_any_worker_count() {
        let scene = scene(37, 23);
        let lines = AtomicU64::new(0);
        let count = |_y: u32, _c: RayCounts| {
            lines.fetch_add(1, Ordering::Relaxed);
        };
        let one = render_local(&scene, 1, &count).expect("renders");
        assert_eq!(lines.load(Ordering::Relaxed), 23);
        assert_eq!(one.pixels.len(), 37 * 23);
        assert_eq!(one.rays.primary, 37 * 23);
        assert!(
            one.pixels.iter().any(|p| *p != Pixel::default()),
            "something is visible"
        );
        for workers in [2, 3, 8, 100] {
            let many = render_local(&scene, workers, &|_, _| {}).expect("renders");
            assert_eq!(many, one, "{workers} workers");
        }
        // The image equals render_line's lines, in order.
        let mut line = vec![Pixel::default(); 37];
        for y in 0..23u32 {
            render_line(&scene, y, &mut line).expect("line renders");
            assert_eq!(&one.pixels[y as usize * 37..][..37], &line[..]);
        }
    }

    #[test]
    fn zero_workers_means_one() {
        let scene = scene(4, 3);
        let img = render_local(&scene, 0, &|_, _| {}).expect("renders");
        assert_eq!(img.pixels.len(), 12);
    }
}
