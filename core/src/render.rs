//! [`render_line`]: one image line, the unit of work that every executor hands out, and
//! [`render_image`], every line of the image on this machine.
//!
//! A pixel is one ray through its centre, or with `samples = m > 1` the mean of `m × m` rays on
//! a stratified pattern fixed by the pixel's coordinates ([`crate::sampling::pixel_sample`]),
//! summed in sample order. Adaptive multisampling ([`crate::adaptive`]) takes two passes: with it,
//! `render_line` traces only the pixel centres, and [`crate::adaptive::refine_line`] later
//! supersamples the pixels that differ from a neighbour. Every decision depends on the scene and
//! the pixel alone, so any executor on any machine produces the same pixels.

use crate::adaptive::{is_adaptive, mask_len, merge_refined, refine_line, SecondPass};
use crate::error::RenderError;
use crate::pixel::Pixel;
use crate::ray::Ray;
use crate::sampling::{mix, pixel_sample, pixel_seed};
use crate::scene::Scene;
use crate::shade::{trace, RayCounts, TraceScratch};
use alloc::vec;
use glam::Vec3;

/// Renders image line `y` (0 is the top) of `scene` into `out`, one [`Pixel`] per column, and
/// returns the rays it traced. The result depends only on the scene and `y`. With adaptive
/// multisampling on ([`crate::adaptive::is_adaptive`]) this is the first pass: the clamped colour
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
    for (x, px) in out.iter_mut().enumerate() {
        let color = supersample(scene, x as u32, y, &mut scratch, &mut counts);
        counts.primary += 1;
        counts.extra_samples += u64::from(m * m - 1);
        *px = Pixel::from_color(color);
    }
    Ok(counts)
}

/// The mean of the `m × m` samples of pixel `(x, y)` (just the centre sample for `m = 1`). Counts
/// nothing but the rays the samples spawn.
pub(crate) fn supersample(
    scene: &Scene,
    x: u32,
    y: u32,
    scratch: &mut TraceScratch,
    counts: &mut RayCounts,
) -> Vec3 {
    let m = scene.settings.samples.max(1);
    let n = m * m;
    let seed = pixel_seed(x, y);
    let mut sum = Vec3::ZERO;
    for k in 0..n {
        let (dx, dy) = pixel_sample(seed, k, m);
        let ray = scene.camera.ray(x as f32 + dx, y as f32 + dy);
        sum += trace(scene, ray, mix(seed, k), scratch, counts);
    }
    if n == 1 {
        sum
    } else {
        sum / n as f32
    }
}

/// The colour of the ray through the centre of pixel `(x, y)`: adaptive multisampling's first
/// pass (its occlusion pattern is sample `m²`, after the grid's).
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

/// Renders the whole image on this machine into `pixels` (row-major, top line first), both
/// passes of adaptive multisampling included, exactly as the master assembles it from workers;
/// returns the rays traced.
///
/// # Errors
/// [`RenderError::WrongBufferLength`] if `pixels` is not `width × height` long.
pub fn render_image(scene: &Scene, pixels: &mut [Pixel]) -> Result<RayCounts, RenderError> {
    let s = &scene.settings;
    let w = s.width as usize;
    if pixels.len() != w * s.height as usize {
        return Err(RenderError::WrongBufferLength);
    }
    let mut counts = RayCounts::default();
    for (y, line) in pixels.chunks_mut(w).enumerate() {
        counts += render_line(scene, y as u32, line)?;
    }
    if !is_adaptive(s) {
        return Ok(counts);
    }
    let mut pass = SecondPass::new(s.aa_threshold, s.width, s.height);
    for (y, line) in pixels.chunks(w).enumerate() {
        pass.add_centres(y as u32, line);
    }
    let all = vec![0xffu8; mask_len(s.width)];
    let mut refined = vec![Pixel::default(); w];
    for (y, line) in pixels.chunks_mut(w).enumerate() {
        // Every line's centres are in, so every line is decided.
        let Some((edges, flagged)) = pass.decision(y as u32) else {
            debug_assert!(false, "line {y} undecided with every line's centres in");
            continue;
        };
        // Without skipping, every pixel is supersampled and only the flagged ones are kept.
        let request = if s.skip_effects { edges } else { &all };
        if flagged > 0 || !s.skip_effects {
            counts += refine_line(scene, y as u32, request, &mut refined)?;
            merge_refined(edges, &refined, line);
        }
    }
    Ok(counts)
}
