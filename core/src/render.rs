//! [`render_line`]: one image line, the unit of work that every executor hands out.

use crate::error::RenderError;
use crate::pixel::Pixel;
use crate::scene::Scene;
use crate::shade::{trace, RayCounts};

/// Renders image line `y` (0 is the top) of `scene` into `out`, one [`Pixel`] per column, and
/// returns the rays it traced. The result depends only on the scene and `y`, so any executor, on
/// any machine, produces the same pixels.
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
    for (x, px) in out.iter_mut().enumerate() {
        let ray = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5);
        counts.primary += 1;
        *px = Pixel::from_color(trace(scene, ray, &mut counts));
    }
    Ok(counts)
}
