//! Adaptive multisampling (POV-Ray's method), the second pass over an image.
//!
//! With `samples = m > 1` and `aa_threshold ≥ 0`, [`crate::render::render_line`] first traces only
//! each pixel's centre. Once the centres of a line and of the lines above and below are known
//! (on the master, or in [`crate::render::render_image`]), [`edge_mask`] flags the pixels whose
//! centre differs from one of its four neighbours by more than the threshold in some channel,
//! [`refine_line`] traces the `m × m` samples of just those pixels, and [`merge_refined`] puts
//! them into the line. Flat regions cost one ray per pixel and nothing more. Everything is decided
//! on the 16-bit pixels, so every executor flags the same pixels.

use crate::render::error::RenderError;
use crate::render::line::supersample;
use crate::render::pixel::Pixel;
use crate::render::shade::TraceScratch;
use crate::render::stats::RayCounts;
use crate::scene::effects::is_adaptive;
use crate::scene::Scene;
use alloc::vec;
use alloc::vec::Vec;

/// Bytes of a mask for a line `width` pixels wide: one bit per pixel, pixel `x` in bit `x % 8` of
/// byte `x / 8`.
#[inline]
pub const fn mask_len(width: u32) -> usize {
    width.div_ceil(8) as usize
}

/// Whether pixel `x` is flagged in `mask`.
#[inline]
pub fn is_flagged(mask: &[u8], x: usize) -> bool {
    mask.get(x / 8).is_some_and(|b| b & (1 << (x % 8)) != 0)
}

/// Whether two pixels differ by more than `threshold` (a fraction of full scale) in some channel.
#[inline]
fn differs(threshold: f32, a: Pixel, b: Pixel) -> bool {
    let d =
        a.0.iter()
            .zip(b.0)
            .map(|(&p, q)| p.abs_diff(q))
            .max()
            .unwrap_or(0);
    f32::from(d) / 65535.0 > threshold
}

/// Flags in `mask` the pixels of line `y` of `centres` (every line's first-pass pixels,
/// row-major, `width` per line) whose centre differs from its left or right neighbour, or from
/// the pixel above or below, by more than `threshold`. Returns how many are flagged. Only lines
/// `y − 1` to `y + 1` are read. `mask` must be [`mask_len`] of `width` long; bits past the width
/// stay clear.
pub fn edge_mask(threshold: f32, centres: &[Pixel], width: u32, y: u32, mask: &mut [u8]) -> u32 {
    let w = width as usize;
    let row = |l: usize| centres.get(l * w..(l + 1) * w);
    let y = y as usize;
    let here = row(y).unwrap_or(&[]);
    let above = y.checked_sub(1).and_then(row);
    let below = row(y + 1);
    mask.fill(0);
    let mut flagged = 0;
    for (x, &c) in here.iter().enumerate() {
        let near = |line: Option<&[Pixel]>| line.and_then(|l| l.get(x)).copied();
        let edge = [
            x.checked_sub(1).and_then(|l| here.get(l)).copied(),
            here.get(x + 1).copied(),
            near(above),
            near(below),
        ]
        .into_iter()
        .flatten()
        .any(|n| differs(threshold, c, n));
        if edge {
            if let Some(b) = mask.get_mut(x / 8) {
                *b |= 1 << (x % 8);
                flagged += 1;
            }
        }
    }
    flagged
}

/// The second pass of line `y`: the `m × m`-sample colour of every pixel flagged in `mask`, into
/// `out`; unflagged pixels are left black. Returns the rays traced (`m²` extra samples per
/// flagged pixel, and what they spawn).
///
/// # Errors
/// [`RenderError::LineOutOfRange`] if `y` is not below the image height,
/// [`RenderError::WrongBufferLength`] if `out` is not the image's width or `mask` is not
/// [`mask_len`] of it, [`RenderError::NotAdaptive`] if the scene does not use adaptive
/// multisampling.
pub fn refine_line(
    scene: &Scene,
    y: u32,
    mask: &[u8],
    out: &mut [Pixel],
) -> Result<RayCounts, RenderError> {
    let s = &scene.settings;
    if !is_adaptive(s) {
        return Err(RenderError::NotAdaptive);
    }
    if y >= s.height {
        return Err(RenderError::LineOutOfRange);
    }
    if out.len() != s.width as usize || mask.len() != mask_len(s.width) {
        return Err(RenderError::WrongBufferLength);
    }
    let m = s.samples;
    let mut counts = RayCounts::default();
    let mut scratch = TraceScratch::default();
    for (x, px) in out.iter_mut().enumerate() {
        *px = if is_flagged(mask, x) {
            counts.extra_samples += u64::from(m * m);
            Pixel::from_color(supersample(scene, x as u32, y, &mut scratch, &mut counts))
        } else {
            Pixel::default()
        };
    }
    Ok(counts)
}

/// Replaces the pixels of `line` flagged in `mask` by those of `refined`.
pub fn merge_refined(mask: &[u8], refined: &[Pixel], line: &mut [Pixel]) {
    for (x, (px, r)) in line.iter_mut().zip(refined).enumerate() {
        if is_flagged(mask, x) {
            *px = *r;
        }
    }
}

/// The bookkeeping of the second pass over one image, with no I/O: which lines have their
/// centres in, and each line's flagged pixels once they can be known (its centres and its
/// neighbours' are in). [`crate::render::render_image`] and the cluster's master both use it,
/// so they decide the same lines the same way.
#[derive(Clone, Debug)]
pub struct SecondPass {
    threshold: f32,
    width: u32,
    /// Every line's first-pass pixels, row-major (black until the line is in).
    centres: Vec<Pixel>,
    /// Whether each line's centres are in.
    have: Vec<bool>,
    /// Each line's mask ([`mask_len`] bytes per line), valid where `flagged` is known.
    masks: Vec<u8>,
    /// How many pixels each line has flagged, once known.
    flagged: Vec<Option<u32>>,
}

impl SecondPass {
    /// The second pass of a `width × height` image supersampling where centres differ by more
    /// than `threshold`; no line is in.
    pub fn new(threshold: f32, width: u32, height: u32) -> Self {
        let h = height as usize;
        SecondPass {
            threshold,
            width,
            centres: vec![Pixel::default(); width as usize * h],
            have: vec![false; h],
            masks: vec![0; mask_len(width) * h],
            flagged: vec![None; h],
        }
    }

    /// Records the centres of line `y` (`width` pixels) and returns the lines whose flagged
    /// pixels became known with them, top first: of `y − 1`, `y` and `y + 1`, those not yet
    /// known whose centres and whose neighbours' centres are all in. A line out of the image
    /// or of the wrong width is ignored.
    pub fn add_centres(&mut self, y: u32, centres: &[Pixel]) -> [Option<u32>; 3] {
        let (w, h) = (self.width as usize, self.have.len() as u32);
        let mut known = [None; 3];
        if y >= h || centres.len() != w {
            return known;
        }
        let at = y as usize * w;
        self.centres[at..at + w].copy_from_slice(centres);
        self.have[y as usize] = true;
        let is_in = |l: u32| self.have[l as usize];
        for (slot, line) in known.iter_mut().zip(y.saturating_sub(1)..(y + 2).min(h)) {
            let ready = self.flagged[line as usize].is_none()
                && is_in(line)
                && (line == 0 || is_in(line - 1))
                && (line + 1 == h || is_in(line + 1));
            if ready {
                *slot = Some(line);
            }
        }
        for line in known.iter().flatten() {
            let n = mask_len(self.width);
            let mask = &mut self.masks[*line as usize * n..(*line as usize + 1) * n];
            let flagged = edge_mask(self.threshold, &self.centres, self.width, *line, mask);
            self.flagged[*line as usize] = Some(flagged);
        }
        known
    }

    /// Line `y`'s mask and how many pixels it flags, once known.
    pub fn decision(&self, y: u32) -> Option<(&[u8], u32)> {
        let flagged = (*self.flagged.get(y as usize)?)?;
        let n = mask_len(self.width);
        Some((&self.masks[y as usize * n..(y as usize + 1) * n], flagged))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GREY: Pixel = Pixel([30000, 30000, 30000]);

    #[test]
    fn flags_pixels_next_to_a_difference_in_any_direction() {
        // Three lines of 10: line 1 has a bright pixel at 4, line 2 a black one at 8.
        let mut image = [GREY; 30];
        image[14] = Pixel([30000, 40000, 30000]);
        image[28] = Pixel([0, 0, 0]);
        let mut mask = [0u8; 2];
        let n = edge_mask(0.1, &image, 10, 1, &mut mask);
        // 3, 4, 5 around the bright pixel; 8 above the black one.
        assert_eq!(n, 4);
        let flagged: alloc::vec::Vec<usize> = (0..10).filter(|&x| is_flagged(&mask, x)).collect();
        assert_eq!(flagged, [3, 4, 5, 8]);
        // A threshold above the bright difference flags only the black one's neighbour.
        assert_eq!(edge_mask(0.2, &image, 10, 1, &mut mask), 1);
        assert_eq!(edge_mask(1.0, &image, 10, 1, &mut mask), 0);
        assert_eq!(mask, [0, 0]);
        // The top line has no line above: only the pixel over the bright one is flagged.
        assert_eq!(edge_mask(0.1, &image, 10, 0, &mut mask), 1);
        assert!(is_flagged(&mask, 4));
    }

    #[test]
    fn a_line_is_decided_once_it_and_its_neighbours_are_in() {
        // Three lines of 10, as above, arriving bottom, top, middle.
        let mut image = [GREY; 30];
        image[14] = Pixel([30000, 40000, 30000]);
        image[28] = Pixel([0, 0, 0]);
        let mut pass = SecondPass::new(0.1, 10, 3);
        assert_eq!(pass.add_centres(2, &image[20..]), [None, None, None]);
        assert_eq!(pass.add_centres(0, &image[..10]), [None, None, None]);
        assert!(pass.decision(1).is_none());
        assert_eq!(
            pass.add_centres(1, &image[10..20]),
            [Some(0), Some(1), Some(2)]
        );
        let mut mask = [0u8; 2];
        for y in 0..3 {
            let n = edge_mask(0.1, &image, 10, y, &mut mask);
            assert_eq!(pass.decision(y), Some((&mask[..], n)));
        }
        // A line is decided once.
        assert_eq!(pass.add_centres(1, &image[10..20]), [None, None, None]);
    }

    #[test]
    fn merge_takes_only_flagged_pixels() {
        let mut line = [GREY; 3];
        let refined = [Pixel([1, 1, 1]); 3];
        merge_refined(&[0b010], &refined, &mut line);
        assert_eq!(line, [GREY, Pixel([1, 1, 1]), GREY]);
    }
}
