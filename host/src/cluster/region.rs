//! `--region`: render part of the image (POV-Ray's `+SR/+ER` and `+SC/+EC` idea).
//!
//! Lines outside the region are not rendered: the master takes them as already done, with the
//! background's pixels and no rays (as a checkpoint's lines are taken). Inside, whole lines are
//! rendered (a request is a line), and the columns outside are set to the background after.
//! Every pixel of the region is the full render's, because a pixel depends on no other pixel;
//! with adaptive multisampling it does (its neighbours decide whether it is supersampled), so
//! then every line is rendered.

use crate::cluster::checkpoint::Record;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;

/// A rectangle of pixels: columns `x0..x1`, lines `y0..y1` (ends exclusive).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    /// First column.
    pub x0: u32,
    /// First line.
    pub y0: u32,
    /// Column after the last.
    pub x1: u32,
    /// Line after the last.
    pub y1: u32,
}

impl Region {
    /// Parses `X0,Y0,X1,Y1` (pixels; the ends exclusive, so `0,0,W,H` is the whole image).
    ///
    /// # Errors
    /// Text that is not four numbers with `X0 < X1` and `Y0 < Y1`, with an example.
    pub fn parse(text: &str) -> Result<Region, String> {
        let example = "expected X0,Y0,X1,Y1 in pixels with X0 < X1 and Y0 < Y1 (the ends \
                       exclusive), for example 100,50,300,200";
        let numbers: Result<Vec<u32>, _> = text.split(',').map(|n| n.trim().parse()).collect();
        match numbers.as_deref() {
            Ok(&[x0, y0, x1, y1]) if x0 < x1 && y0 < y1 => Ok(Region { x0, y0, x1, y1 }),
            _ => Err(format!("`{text}`: {example}")),
        }
    }

    /// Checks that the region lies inside a `width × height` image.
    ///
    /// # Errors
    /// Which end lies outside.
    pub fn check(&self, width: u32, height: u32) -> Result<(), String> {
        if self.x1 > width || self.y1 > height {
            return Err(format!(
                "--region {},{},{},{} reaches beyond the {width}x{height} image (X1 at most \
                 {width}, Y1 at most {height})",
                self.x0, self.y0, self.x1, self.y1
            ));
        }
        Ok(())
    }

    /// Its size in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.x1 - self.x0, self.y1 - self.y0)
    }

    /// The lines outside the region, as results the master takes first: `background` pixels,
    /// no rays.
    pub fn outside(&self, width: u32, height: u32, background: Pixel) -> Vec<Record> {
        (0..height)
            .filter(|y| !(self.y0..self.y1).contains(y))
            .map(|task| Record {
                task,
                rays: RayCounts::default(),
                pixels: vec![background; width as usize],
            })
            .collect()
    }

    /// Sets every pixel of the `width`-wide image outside the region to `background`.
    pub fn mask(&self, width: u32, pixels: &mut [Pixel], background: Pixel) {
        for (i, p) in pixels.iter_mut().enumerate() {
            let (x, y) = ((i % width as usize) as u32, (i / width as usize) as u32);
            if !(self.x0..self.x1).contains(&x) || !(self.y0..self.y1).contains(&y) {
                *p = background;
            }
        }
    }

    /// The region's pixels out of the `width`-wide image, row by row.
    pub fn crop(&self, width: u32, pixels: &[Pixel]) -> Vec<Pixel> {
        let w = width as usize;
        (self.y0..self.y1)
            .flat_map(|y| {
                let row = y as usize * w;
                pixels[row + self.x0 as usize..row + self.x1 as usize]
                    .iter()
                    .copied()
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_checks_crops_and_masks() {
        let r = Region::parse("1,0,3,2").expect("a region");
        assert_eq!(
            r,
            Region {
                x0: 1,
                y0: 0,
                x1: 3,
                y1: 2
            }
        );
        for bad in [
            "1,2,3",
            "3,0,1,2",
            "1,1,2,1",
            "a,b,c,d",
            "1,2,3,4,5",
            "-1,0,2,2",
        ] {
            let e = Region::parse(bad).expect_err(bad);
            assert!(e.contains("for example"), "{e}");
        }
        assert!(r.check(3, 2).is_ok());
        assert!(r
            .check(2, 2)
            .expect_err("too narrow")
            .contains("beyond the 2x2 image"));
        let pixels: Vec<Pixel> = (0..12u16).map(|i| Pixel([i, 0, 0])).collect();
        let cropped = r.crop(4, &pixels);
        assert_eq!(
            cropped.iter().map(|p| p.0[0]).collect::<Vec<_>>(),
            [1, 2, 5, 6]
        );
        let mut masked = pixels.clone();
        r.mask(4, &mut masked, Pixel([99, 0, 0]));
        let kept: Vec<u16> = masked.iter().map(|p| p.0[0]).collect();
        assert_eq!(kept, [99, 1, 2, 99, 99, 5, 6, 99, 99, 99, 99, 99]);
        let outside = r.outside(4, 3, Pixel([7, 0, 0]));
        assert_eq!(outside.len(), 1);
        assert_eq!(outside[0].task, 2);
    }
}
