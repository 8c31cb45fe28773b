//! [`render_line`]: one image line, the unit of work that every executor hands out.

use crate::error::RenderError;
use crate::pixel::Pixel;
use crate::sampling::{mix, pixel_sample, pixel_seed};
use crate::scene::Scene;
use crate::shade::{trace, RayCounts, TraceScratch};
use glam::Vec3;

/// Renders image line `y` (0 is the top) of `scene` into `out`, one [`Pixel`] per column, and
/// returns the rays it traced. The result depends only on the scene and `y`, so any executor, on
/// any machine, produces the same pixels.
///
/// With `samples = m > 1` each pixel averages `m × m` rays on a stratified pattern fixed by the
/// pixel's coordinates ([`crate::sampling::pixel_sample`]), summed in sample order.
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
    let n = m * m;
    for (x, px) in out.iter_mut().enumerate() {
        let seed = pixel_seed(x as u32, y);
        let mut sum = Vec3::ZERO;
        for k in 0..n {
            let (dx, dy) = pixel_sample(seed, k, m);
            let ray = scene.camera.ray(x as f32 + dx, y as f32 + dy);
            sum += trace(scene, ray, mix(seed, k), &mut scratch, &mut counts);
        }
        counts.primary += 1;
        counts.extra_samples += u64::from(n - 1);
        let color = if n == 1 { sum } else { sum / n as f32 };
        *px = Pixel::from_color(color);
    }
    Ok(counts)
}
