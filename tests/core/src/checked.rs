//! Helpers shared by the integration tests that render scenes or query solids: a checked
//! render (every pixel's centre ray traced again, its colour finite and equal to the pixel) and
//! the closest solid hit of a ray with its surface. Each test file uses only some of them.

use glam::Vec3;
use strahl_core::geom::solid::prepared::{SolidHit, SolidSurface};
use strahl_core::math::ray::{offset_ray_origin, Ray};
use strahl_core::render::intersect::PrimitiveHit;
use strahl_core::render::intersect::QueryScratch;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::render::sampling::{mix, pixel_seed};
use strahl_core::render::shade::{trace, TraceScratch};
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::Scene;

/// A rendered image: the pixels of `render_line`, the centre rays' colours before quantisation,
/// and the rays traced.
pub struct Rendered {
    /// Image width.
    pub width: usize,
    /// The pixels of `render_line`.
    pub pixels: Vec<Pixel>,
    /// The centre rays' colours.
    pub colors: Vec<Vec3>,
    /// The rays `render_line` traced.
    pub counts: RayCounts,
}

impl Rendered {
    /// The pixel at `(x, y)`.
    pub fn at(&self, x: usize, y: usize) -> Pixel {
        self.pixels[y * self.width + x]
    }
}

/// Renders every line of `scene` (one sample per pixel) and traces every pixel's centre ray
/// again to check its colour is finite and is what the pixel holds.
pub fn render(scene: &Scene) -> Rendered {
    let s = &scene.settings;
    assert_eq!(s.samples, 1, "the colour check traces one ray per pixel");
    let (w, h) = (s.width, s.height);
    let mut pixels = vec![Pixel::default(); (w * h) as usize];
    let mut counts = RayCounts::default();
    for (y, line) in pixels.chunks_mut(w as usize).enumerate() {
        counts += render_line(scene, y as u32, line).expect("line renders");
    }
    let mut colors = Vec::with_capacity(pixels.len());
    let mut scratch = TraceScratch::default();
    let mut again = RayCounts::default();
    for y in 0..h {
        for x in 0..w {
            let ray = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5);
            let c = trace(
                scene,
                ray,
                mix(pixel_seed(x, y), 0),
                &mut scratch,
                &mut again,
            );
            assert!(
                c.is_finite(),
                "pixel ({x}, {y}): colour {c:?} is not finite"
            );
            assert_eq!(
                Pixel::from_color(c),
                pixels[(y * w + x) as usize],
                "pixel ({x}, {y}): the centre ray's colour is not the rendered pixel"
            );
            colors.push(c);
        }
    }
    assert_eq!(again.total(), counts.total() - counts.primary);
    Rendered {
        width: w as usize,
        pixels,
        colors,
        counts,
    }
}

/// The centre ray of pixel `(x, y)`.
pub fn pixel_ray(scene: &Scene, x: usize, y: usize) -> Ray {
    scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5)
}

/// The closest solid hit of a ray and its surface.
#[derive(Clone, Copy, Debug)]
pub struct Found {
    /// The scene object hit.
    pub object: u32,
    /// The hit.
    pub hit: SolidHit,
    /// Its surface.
    pub surface: SolidSurface,
}

/// The closest solid hit of `ray` in `scene` (which must hold only solids), with its surface.
pub fn closest(scene: &Scene, ray: &Ray) -> Option<Found> {
    let mut scratch = QueryScratch::default();
    match scene.closest_hit(ray, f32::INFINITY, &mut scratch)? {
        PrimitiveHit::Solid(object, hit) => Some(Found {
            object,
            hit,
            surface: scene.solids.surface(ray, &hit),
        }),
        PrimitiveHit::Triangle(..) => panic!("these scenes have no triangles"),
    }
}

/// The ray continued past a hit: origin offset off the surface to the side the ray goes on.
pub fn continue_past(ray: &Ray, f: &Found) -> Ray {
    let o = offset_ray_origin(
        f.surface.point,
        f.surface.point_error,
        f.surface.normal,
        ray.dir,
    );
    Ray::new(o, ray.dir)
}
