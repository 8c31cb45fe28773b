//! [`line_ray_limit`]: the most rays of each kind one image line can trace, so that a master can
//! refuse a result whose counts no renderer of this scene could have reported.
//!
//! The bound follows the tracer's shape ([`crate::render::shade::trace`]): every camera ray starts
//! a tree of rays in which each hit pushes at most one mirror and one refracted ray while its depth
//! is below the bounce cap, so a camera ray makes at most `2^(d+1) − 1` hits for a cap `d` (one hit
//! when reflections and refractions are both off). Each hit sends at most one shadow ray per light
//! (a ray whose answer cannot matter included, with `--skip-effects off`), `a²` occlusion rays, and
//! at most one mirror and one refracted ray (traced or dropped). Sums saturate, so a huge cap gives
//! `u64::MAX` rather than a wrapped figure. The octree work of [`RayCounts::work`] has no such bound
//! and is not limited.

use crate::render::stats::RayCounts;
use crate::scene::effects::is_adaptive;
use crate::scene::settings::RenderSettings;

/// The limits of both passes of a scene's lines, as a master keeps them for checking results.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineRayLimits {
    first: RayCounts,
    refined: RayCounts,
}

impl LineRayLimits {
    /// The limits for a scene with these settings and `lights` lights.
    pub fn new(settings: &RenderSettings, lights: usize) -> Self {
        LineRayLimits {
            first: line_ray_limit(settings, lights, LinePass::First),
            refined: line_ray_limit(settings, lights, LinePass::Refined),
        }
    }

    /// The first kind of ray whose count a result of `pass` could not have; `None` if a line
    /// can have every count.
    pub fn check(&self, counts: &RayCounts, pass: LinePass) -> Option<Impossible> {
        let limit = match pass {
            LinePass::First => &self.first,
            LinePass::Refined => &self.refined,
        };
        counts.beyond(limit, pass)
    }
}

/// A ray count that a line cannot have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Impossible {
    /// The kind of ray, as a word: `primary`, `extra sample`, `shadow`, ...
    pub kind: &'static str,
    /// The count reported.
    pub count: u64,
    /// The limit: the exact figure if `exact`, else the most a line can have.
    pub limit: u64,
    /// Whether a line has exactly `limit` rays of this kind.
    pub exact: bool,
}

impl core::fmt::Display for Impossible {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let bound = if self.exact { "exactly" } else { "at most" };
        write!(
            f,
            "{} {} rays where a line has {bound} {}",
            self.count, self.kind, self.limit
        )
    }
}

/// Which pass of a line a result belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinePass {
    /// [`crate::render::line::render_line`]: every pixel (its centre alone with adaptive sampling).
    First,
    /// [`crate::render::adaptive::refine_line`]: the supersampled pixels of adaptive sampling.
    Refined,
}

/// The most rays of each kind that one line of a scene with these settings and `lights` lights
/// can trace in `pass`. `primary` and, outside the refined pass, `extra_samples` are exact: a
/// first pass traces one primary ray per pixel and `m² − 1` more without adaptive sampling, none
/// with it. [`RayCounts::work`] is left at its maximum (not bounded).
pub fn line_ray_limit(settings: &RenderSettings, lights: usize, pass: LinePass) -> RayCounts {
    let width = u64::from(settings.width);
    let m = u64::from(settings.samples.max(1));
    let per_pixel = m * m;
    let adaptive = is_adaptive(settings);
    let (primary, extra_samples, camera_rays) = match pass {
        LinePass::First if adaptive => (width, 0, width),
        LinePass::First => (width, width * (per_pixel - 1), width * per_pixel),
        LinePass::Refined => (0, width * per_pixel, width * per_pixel),
    };
    let hits = camera_rays.saturating_mul(hits_per_camera_ray(settings));
    let ao = u64::from(settings.ambient_occlusion);
    RayCounts {
        primary,
        extra_samples,
        shadow: hits.saturating_mul(lights as u64),
        reflection: hits,
        refraction: hits,
        occlusion: hits.saturating_mul(ao * ao),
        work: crate::accel::work::QueryWork {
            intersection_tests: u64::MAX,
            octree_cells: u64::MAX,
        },
    }
}

/// The most surfaces one camera ray's tree of rays can hit: `2^(d+1) − 1` for a bounce cap `d`.
fn hits_per_camera_ray(settings: &RenderSettings) -> u64 {
    if !settings.reflections && !settings.refractions {
        return 1;
    }
    match settings.max_depth {
        d @ 0..=62 => (1u64 << (d + 1)) - 1,
        _ => u64::MAX,
    }
}

impl RayCounts {
    /// The first kind of ray where `self` exceeds `limit`, or differs from an exact figure of
    /// [`line_ray_limit`]; `None` if every count is one a line can have.
    fn beyond(&self, limit: &RayCounts, pass: LinePass) -> Option<Impossible> {
        let exact_extra = pass == LinePass::First;
        let checks = [
            ("primary", self.primary, limit.primary, true),
            (
                "extra sample",
                self.extra_samples,
                limit.extra_samples,
                exact_extra,
            ),
            ("shadow", self.shadow, limit.shadow, false),
            ("reflection", self.reflection, limit.reflection, false),
            ("refraction", self.refraction, limit.refraction, false),
            ("occlusion", self.occlusion, limit.occlusion, false),
        ];
        checks
            .into_iter()
            .find(|&(_, n, max, exact)| if exact { n != max } else { n > max })
            .map(|(kind, count, limit, exact)| Impossible {
                kind,
                count,
                limit,
                exact,
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::string::ToString;

    fn settings(depth: u32, samples: u32) -> RenderSettings {
        RenderSettings {
            width: 10,
            max_depth: depth,
            samples,
            ambient_occlusion: 2,
            ..RenderSettings::default()
        }
    }

    #[test]
    fn a_tree_of_depth_d_has_at_most_two_to_the_d_plus_one_minus_one_hits() {
        let limit = line_ray_limit(&settings(2, 1), 3, LinePass::First);
        assert_eq!((limit.primary, limit.extra_samples), (10, 0));
        assert_eq!(
            (limit.reflection, limit.shadow, limit.occlusion),
            (70, 210, 280)
        );
        let limit = line_ray_limit(&settings(2, 2), 3, LinePass::First);
        assert_eq!(
            (limit.primary, limit.extra_samples, limit.reflection),
            (10, 30, 280)
        );
    }

    #[test]
    fn a_huge_bounce_cap_saturates_instead_of_wrapping() {
        for depth in [62, 63, 64, 100, u32::MAX] {
            let limit = line_ray_limit(&settings(depth, 16), 5, LinePass::First);
            assert_eq!(limit.shadow, u64::MAX, "depth {depth}");
        }
    }

    #[test]
    fn without_mirrors_or_refraction_a_camera_ray_hits_once() {
        let s = RenderSettings {
            reflections: false,
            refractions: false,
            ..settings(5, 1)
        };
        assert_eq!(line_ray_limit(&s, 1, LinePass::First).reflection, 10);
    }

    #[test]
    fn counts_beyond_the_limit_or_off_an_exact_figure_are_named() {
        let limit = line_ray_limit(&settings(1, 1), 1, LinePass::First);
        let fine = RayCounts {
            primary: 10,
            shadow: 30,
            ..RayCounts::default()
        };
        assert_eq!(fine.beyond(&limit, LinePass::First), None);
        let both = LineRayLimits::new(&settings(1, 1), 1);
        assert_eq!(both.check(&fine, LinePass::First), None);
        let refined = both.check(&fine, LinePass::Refined);
        assert_eq!(
            refined.map(|i| (i.kind, i.count, i.exact)),
            Some(("primary", 10, true))
        );
        let shadows = RayCounts { shadow: 31, ..fine };
        let too_many = shadows
            .beyond(&limit, LinePass::First)
            .map(|i| i.to_string());
        assert_eq!(
            too_many.as_deref(),
            Some("31 shadow rays where a line has at most 30")
        );
        let extra = RayCounts {
            extra_samples: 1,
            ..fine
        };
        let off = extra.beyond(&limit, LinePass::First).map(|i| i.to_string());
        assert_eq!(
            off.as_deref(),
            Some("1 extra sample rays where a line has exactly 0")
        );
    }
}
