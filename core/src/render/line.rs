//! [`render_line`]: one image line, the unit of work that every executor hands out.
//!
//! A pixel is one ray through its centre, or with `samples = m > 1` the mean of `m × m` rays on
//! a stratified pattern fixed by the pixel's coordinates ([`crate::render::sampling::pixel_sample`]),
//! summed in sample order. Rays are traced four at a time, to the hits each finds alone: four
//! neighbouring pixels' with one sample per pixel, four samples of a pixel with more. Their first
//! hits are found together ([`Scene::closest_hits4`]), without a walk of the octree where the
//! camera's cover says the pixels' rays meet none of its cells ([`Scene::cover`]), and so are
//! their next rays while each of the four has one (`trace4`).
//! Adaptive multisampling ([`crate::render::adaptive`]) takes two passes: with it,
//! `render_line` traces only the pixel centres, and [`crate::render::adaptive::refine_line`]
//! later supersamples the pixels that differ from a neighbour. Every decision depends on the
//! scene and the pixel alone, so any executor on any machine produces the same pixels.

use crate::accel::octree::{per_lane, LANES};
use crate::math::ray::Ray;
use crate::render::error::RenderError;
use crate::render::pixel::Pixel;
use crate::render::sampling::{mix, pixel_sample, pixel_seed};
use crate::render::shade::{trace, trace4, TraceScratch};
use crate::render::stats::RayCounts;
use crate::scene::effects::is_adaptive;
use crate::scene::Scene;
use glam::Vec3;

/// Renders image line `y` (0 is the top) of `scene` into `out`, one [`Pixel`] per column, and
/// returns the rays it traced. The result depends only on the scene and `y`. With adaptive
/// multisampling on ([`crate::scene::effects::is_adaptive`]) this is the first pass: the clamped colour
/// of each pixel's centre ray.
///
/// # Errors
/// [`RenderError::LineOutOfRange`] if `y` is not below the image height,
/// [`RenderError::WrongBufferLength`] if `out` is not as long as the image is wide.
pub fn render_line(scene: &Scene, y: u32, out: &mut [Pixel]) -> Result<RayCounts, RenderError> {
    let s = &scene.settings;
    if y >= s.height {
        return Err(RenderError::LineOutOfRange);
    }
    if out.len() != s.width as usize {
        return Err(RenderError::WrongBufferLength);
    }
    let mut counts = RayCounts::default();
    let mut scratch = TraceScratch::default();
    let m = s.samples.max(1);
    if is_adaptive(s) {
        for (x, px) in out.iter_mut().enumerate() {
            let color = centre(scene, x as u32, y, &mut scratch, &mut counts);
            counts.primary += 1;
            *px = Pixel::from_color(color);
        }
        return Ok(counts);
    }
    if m == 1 {
        for (k, pixels) in out.chunks_mut(LANES).enumerate() {
            let x = (k * LANES) as u32;
            single_samples(scene, (x, y), pixels, &mut scratch, &mut counts);
        }
        counts.primary += out.len() as u64;
        return Ok(counts);
    }
    for (x, px) in out.iter_mut().enumerate() {
        let color = supersample(scene, x as u32, y, &mut scratch, &mut counts);
        counts.primary += 1;
        counts.extra_samples += u64::from(m * m - 1);
        *px = Pixel::from_color(color);
    }
    Ok(counts)
}

/// The pixels from `(x, y)` rightwards, one sample each: [`supersample`]'s colours. Four
/// neighbours' rays are traced together ([`trace4`]); a line's last pixels, fewer than four, go
/// one at a time.
fn single_samples(
    scene: &Scene,
    (x, y): (u32, u32),
    pixels: &mut [Pixel],
    scratch: &mut TraceScratch,
    counts: &mut RayCounts,
) {
    let Ok(four) = <&mut [Pixel; LANES]>::try_from(&mut *pixels) else {
        for (px, x) in pixels.iter_mut().zip(x..) {
            *px = Pixel::from_color(supersample(scene, x, y, scratch, counts));
        }
        return;
    };
    let samples = per_lane(|l| sample(scene, x + l as u32, y, 0));
    let beside_tree = scene.cover().is_some_and(|cover| cover.clear(x, y));
    let colors = trace4(scene, samples, beside_tree, scratch, counts);
    for (px, color) in four.iter_mut().zip(colors) {
        *px = Pixel::from_color(color);
    }
}

/// Sample `k` of pixel `(x, y)` on the scene's `m × m` pattern: its ray, and the seed of its
/// occlusion pattern. With one sample and no occlusion nothing is drawn from the seed (the
/// offset is the pixel's centre, and only occlusion reads the pattern), so none is made.
fn sample(scene: &Scene, x: u32, y: u32, k: u32) -> (Ray, u32) {
    let m = scene.settings.samples.max(1);
    if m == 1 && scene.settings.ambient_occlusion == 0 {
        return (scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5), 0);
    }
    let seed = pixel_seed(x, y);
    let (dx, dy) = pixel_sample(seed, k, m);
    let ray = scene.camera.ray(x as f32 + dx, y as f32 + dy);
    (ray, mix(seed, k))
}

/// The mean of the `m × m` samples of pixel `(x, y)` (just the centre sample for `m = 1`), summed
/// in sample order; four at a time, their rays walk together ([`trace4`]). Counts nothing but
/// the rays the samples spawn.
pub(crate) fn supersample(
    scene: &Scene,
    x: u32,
    y: u32,
    scratch: &mut TraceScratch,
    counts: &mut RayCounts,
) -> Vec3 {
    let m = scene.settings.samples.max(1);
    let n = m * m;
    let mut sum = Vec3::ZERO;
    // Four samples at a time where four are left: their rays walk together (not at all where
    // the camera's cover clears the pixel's packet: every sample lies in the pixel), and their
    // colours are added in sample order, as one at a time.
    let beside_tree = scene
        .cover()
        .is_some_and(|cover| cover.clear(x - x % LANES as u32, y));
    let mut k = 0;
    while k + LANES as u32 <= n {
        let samples = per_lane(|l| sample(scene, x, y, k + l as u32));
        for color in trace4(scene, samples, beside_tree, scratch, counts) {
            sum += color;
        }
        k += LANES as u32;
    }
    for k in k..n {
        let (ray, seed) = sample(scene, x, y, k);
        sum += trace(scene, ray, seed, scratch, counts);
    }
    if n == 1 {
        sum
    } else {
        sum / n as f32
    }
}

/// The colour of the ray through the centre of pixel `(x, y)`: adaptive multisampling's first
/// pass (its occlusion pattern is sample `m²`, after the grid's). It repeats the setup of
/// [`supersample`] (pattern count, pixel seed) on purpose: a shared helper would need the
/// sample's offset and pattern index passed in, and would hide that the two passes use
/// different patterns.
fn centre(
    scene: &Scene,
    x: u32,
    y: u32,
    scratch: &mut TraceScratch,
    counts: &mut RayCounts,
) -> Vec3 {
    let m = scene.settings.samples.max(1);
    let seed = pixel_seed(x, y);
    let ray: Ray = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5);
    trace(scene, ray, mix(seed, m * m), scratch, counts)
}
