//! Image assembly on the master: the first result of every task becomes pixels. Without
//! adaptive multisampling a line's result is its pixels. With it, a line's first pass gives its
//! centres, the core's [`SecondPass`] says which lines' second passes are decided by them, and a
//! second pass's flagged pixels are merged over the centres. It holds the lines the job renders
//! alone (a region's, or all).

use crate::cluster::job::{AdaptiveJob, ClusterJob};
use core::ops::Range;
use strahl_core::render::adaptive::{mask_len, merge_refined, SecondPass};
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;

/// The image as results come in.
pub(crate) struct Assembly {
    width: u32,
    /// The first line rendered (the job's `lines.start`).
    first: u32,
    /// `width` pixels for each line the job renders, row-major, top row first.
    pixels: Vec<Pixel>,
    /// Rays traced for the result used of each task (first passes, then second passes), summed
    /// at the end: a task put in again (its first result was wrong) replaces its rays.
    rays: Vec<RayCounts>,
    adaptive: Option<Adaptive>,
}

/// The second pass's state, with adaptive multisampling.
struct Adaptive {
    job: AdaptiveJob,
    pass: SecondPass,
    /// The rays of each line's first pass.
    first_rays: Vec<RayCounts>,
}

/// What a line's first pass decides.
#[derive(Debug, PartialEq)]
pub(crate) enum Decided {
    /// The line is final (no adaptive multisampling).
    Final,
    /// The lines whose second passes became decided, top first, each with whether it is to be
    /// asked for (some pixel flagged, or every pixel wanted); one that is not is final as is.
    Refine([Option<(u32, bool)>; 3]),
}

impl Assembly {
    /// A black image of the lines `job` renders.
    pub(crate) fn new(job: &ClusterJob) -> Self {
        Assembly {
            width: job.width,
            first: job.lines.start,
            pixels: vec![Pixel::default(); job.width as usize * job.lines.len()],
            rays: vec![RayCounts::default(); 2 * job.height as usize],
            adaptive: job.adaptive.map(|a| Adaptive {
                job: a,
                pass: SecondPass::new(a.threshold, job.width, job.height),
                first_rays: vec![RayCounts::default(); job.height as usize],
            }),
        }
    }

    /// Line `y`'s pixels as they stand (`y` one of the job's lines).
    pub(crate) fn line(&self, y: u32) -> &[Pixel] {
        &self.pixels[self.span(y)]
    }

    fn line_mut(&mut self, y: u32) -> &mut [Pixel] {
        let span = self.span(y);
        &mut self.pixels[span]
    }

    /// Where line `y`'s pixels lie in `pixels`.
    fn span(&self, y: u32) -> Range<usize> {
        let w = self.width as usize;
        let at = (y - self.first) as usize * w;
        at..at + w
    }

    /// Puts the first result of line `y`'s (first) pass in: its pixels and the `rays` it took.
    pub(crate) fn put_line(&mut self, y: u32, rays: RayCounts, pixels: &[Pixel]) -> Decided {
        self.rays[y as usize] = rays;
        self.line_mut(y).copy_from_slice(pixels);
        let Some(a) = &mut self.adaptive else {
            return Decided::Final;
        };
        a.first_rays[y as usize] = rays;
        let decided = a.pass.add_centres(y, pixels).map(|line| {
            line.and_then(|l| {
                let (_, flagged) = a.pass.decision(l)?;
                Some((l, flagged > 0 || a.job.refine_all))
            })
        });
        Decided::Refine(decided)
    }

    /// Merges the first result of line `y`'s second pass (which took `rays`); returns the rays
    /// of both passes.
    pub(crate) fn put_refined(&mut self, y: u32, rays: RayCounts, pixels: &[Pixel]) -> RayCounts {
        let height = self.rays.len() / 2;
        self.rays[height + y as usize] = rays;
        let mut all = self.first_rays(y);
        all += rays;
        if let Some(a) = &self.adaptive {
            // A second pass is asked for only once its line is decided.
            let decision = a.pass.decision(y);
            debug_assert!(decision.is_some(), "second pass of undecided line {y}");
            if let Some((edges, _)) = decision {
                let span = self.span(y);
                merge_refined(edges, pixels, &mut self.pixels[span]);
            }
        }
        all
    }

    /// The rays of line `y`'s first pass (none without adaptive multisampling).
    pub(crate) fn first_rays(&self, y: u32) -> RayCounts {
        self.adaptive
            .as_ref()
            .map_or_else(RayCounts::default, |a| a.first_rays[y as usize])
    }

    /// The mask of a second-pass request for line `y`: its flagged pixels, or every pixel when
    /// effects are not skipped (only the flagged ones are kept).
    pub(crate) fn refine_mask(&self, y: u32) -> Vec<u8> {
        match &self.adaptive {
            Some(a) if !a.job.refine_all => match a.pass.decision(y) {
                Some((edges, _)) => edges.to_vec(),
                None => {
                    debug_assert!(false, "second pass of undecided line {y}");
                    vec![0xffu8; mask_len(self.width)]
                }
            },
            _ => vec![0xffu8; mask_len(self.width)],
        }
    }

    /// The pixels and the rays of the results used.
    pub(crate) fn into_parts(self) -> (Vec<Pixel>, RayCounts) {
        let mut rays = RayCounts::default();
        for r in self.rays {
            rays += r;
        }
        (self.pixels, rays)
    }
}
