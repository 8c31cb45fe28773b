//! [`render_line`]: one image line, the unit of work that every executor hands out.
//!
//! A pixel is one ray through its centre, or with `samples = m > 1` the mean of `m × m` rays on
//! a stratified pattern fixed by the pixel's coordinates ([`crate::sampling::pixel_sample`]),
//! summed in sample order. Adaptive multisampling (`aa_threshold ≥ 0`, POV-Ray's method) first
//! traces the centre of every pixel of the line and of the lines above and below, and supersamples
//! only pixels whose centre colour differs from a neighbour's by more than the threshold. Every
//! decision depends on the scene and the pixel alone, so any executor on any machine produces the
//! same pixels.

use crate::error::RenderError;
use crate::pixel::Pixel;
use crate::ray::Ray;
use crate::sampling::{mix, pixel_sample, pixel_seed};
use crate::scene::Scene;
use crate::shade::{trace, RayCounts, TraceScratch};
use alloc::vec::Vec;
use glam::Vec3;

/// Renders image line `y` (0 is the top) of `scene` into `out`, one [`Pixel`] per column, and
/// returns the rays it traced. The result depends only on the scene and `y`.
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
    if m > 1 && s.aa_threshold >= 0.0 {
        adaptive_line(scene, y, out, &mut scratch, &mut counts);
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
fn supersample(
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

/// Adaptive multisampling of line `y` (see the module documentation).
fn adaptive_line(
    scene: &Scene,
    y: u32,
    out: &mut [Pixel],
    scratch: &mut TraceScratch,
    counts: &mut RayCounts,
) {
    let s = &scene.settings;
    let w = s.width;
    let mut line = |yy: u32, counts: &mut RayCounts| -> Vec<Vec3> {
        (0..w)
            .map(|x| centre(scene, x, yy, scratch, counts).clamp(Vec3::ZERO, Vec3::ONE))
            .collect()
    };
    let here = line(y, counts);
    let above = (y > 0).then(|| line(y - 1, counts));
    let below = (y + 1 < s.height).then(|| line(y + 1, counts));
    // The neighbour lines' centre rays are extra samples; what they spawn counts by kind.
    let neighbour_lines = u64::from(above.is_some()) + u64::from(below.is_some());
    counts.extra_samples += neighbour_lines * u64::from(w);
    let m = s.samples.max(1);
    let differs = |a: Vec3, b: Vec3| (a - b).abs().max_element() > s.aa_threshold;
    for (x, px) in out.iter_mut().enumerate() {
        let c = here[x];
        let edge = (x > 0 && differs(c, here[x - 1]))
            || (x + 1 < here.len() && differs(c, here[x + 1]))
            || above.as_ref().is_some_and(|a| differs(c, a[x]))
            || below.as_ref().is_some_and(|b| differs(c, b[x]));
        counts.primary += 1;
        let color = if edge || !s.skip_effects {
            counts.extra_samples += u64::from(m * m);
            let fine = supersample(scene, x as u32, y, scratch, counts);
            if edge {
                fine
            } else {
                c
            }
        } else {
            c
        };
        *px = Pixel::from_color(color);
    }
}
