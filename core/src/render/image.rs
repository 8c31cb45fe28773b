//! [`render_image`]: every line of the image on this machine, both passes of adaptive
//! multisampling included, exactly as the master assembles it from workers.

use crate::render::adaptive::{mask_len, merge_refined, refine_line, SecondPass};
use crate::render::error::RenderError;
use crate::render::pixel::Pixel;
use crate::render::render_line;
use crate::render::stats::RayCounts;
use crate::scene::effects::is_adaptive;
use crate::scene::Scene;
use alloc::vec;

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
    let Some(threshold) = s.aa_threshold.filter(|_| is_adaptive(s)) else {
        return Ok(counts);
    };
    let mut pass = SecondPass::new(threshold, s.width, s.height);
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
