//! `--region`: render part of the image (POV-Ray's `+SR/+ER` and `+SC/+EC` idea).
//!
//! Lines outside the region are not rendered: the job is limited to the region's lines
//! ([`crate::cluster::job::ClusterJob::limited_to`]), so the master neither asks for the others
//! nor holds their pixels. Inside, whole lines are rendered (a request is a line), and the
//! columns outside are cut off after ([`Region::crop`]), or set to the background with
//! `--keep-size` ([`Region::place`]).
//! Every pixel of the region is the full render's, because a pixel depends on no other pixel;
//! with adaptive multisampling it does (its neighbours decide whether it is supersampled), so
//! then every line is rendered.

use std::fmt;
use std::ops::Range;
use strahl_core::render::pixel::Pixel;
use strahl_core::scene::effects::is_adaptive;
use strahl_core::scene::settings::RenderSettings;

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
                "--region {self} reaches beyond the {width}x{height} image (X1 at most {width}, \
                 Y1 at most {height})"
            ));
        }
        Ok(())
    }

    /// The whole of a `width × height` image.
    pub fn whole(width: u32, height: u32) -> Region {
        Region {
            x0: 0,
            y0: 0,
            x1: width,
            y1: height,
        }
    }

    /// Its size in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.x1 - self.x0, self.y1 - self.y0)
    }

    /// The lines the master renders for `region` of an image rendered with `settings`: the
    /// region's, or every line without one or with adaptive multisampling (a line's
    /// neighbours decide which of its pixels are supersampled).
    pub fn rendered_lines(region: Option<Region>, settings: &RenderSettings) -> Range<u32> {
        match region {
            Some(r) if !is_adaptive(settings) => r.y0..r.y1,
            _ => 0..settings.height,
        }
    }

    /// The region's pixels of line `y` out of `rendered`: the `width`-wide lines from `first`
    /// on (the region's own, or with adaptive multisampling the whole image's).
    fn row<'p>(&self, (width, first): (u32, u32), rendered: &'p [Pixel], y: u32) -> &'p [Pixel] {
        let at = (y - first) as usize * width as usize;
        &rendered[at + self.x0 as usize..at + self.x1 as usize]
    }

    /// The region's pixels, row by row, out of `rendered` (as for [`Region::row`]).
    pub fn crop(&self, width: u32, first: u32, rendered: &[Pixel]) -> Vec<Pixel> {
        (self.y0..self.y1)
            .flat_map(|y| self.row((width, first), rendered, y).iter().copied())
            .collect()
    }

    /// The whole `width × height` image (`--keep-size`): the region's pixels out of `rendered`
    /// (as for [`Region::crop`]), `background` everywhere else.
    pub fn place(
        &self,
        (width, height): (u32, u32),
        first: u32,
        rendered: &[Pixel],
        background: Pixel,
    ) -> Vec<Pixel> {
        let mut image = vec![background; width as usize * height as usize];
        for y in self.y0..self.y1 {
            let at = y as usize * width as usize;
            image[at + self.x0 as usize..at + self.x1 as usize].copy_from_slice(self.row(
                (width, first),
                rendered,
                y,
            ));
        }
        image
    }
}

/// `X0,Y0,X1,Y1`, as [`Region::parse`] reads it.
impl fmt::Display for Region {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{},{},{},{}", self.x0, self.y0, self.x1, self.y1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_checks_crops_and_places() {
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
        let values = |p: &[Pixel]| p.iter().map(|p| p.0[0]).collect::<Vec<_>>();
        // The whole image rendered (adaptive multisampling), and the region's lines alone.
        assert_eq!(values(&r.crop(4, 0, &pixels)), [1, 2, 5, 6]);
        let lower = Region::parse("1,1,3,3").expect("a region");
        assert_eq!(values(&lower.crop(4, 1, &pixels[4..])), [5, 6, 9, 10]);
        let placed = lower.place((4, 3), 1, &pixels[4..], Pixel([99, 0, 0]));
        assert_eq!(
            values(&placed),
            [99, 99, 99, 99, 99, 5, 6, 99, 99, 9, 10, 99]
        );
    }
}
