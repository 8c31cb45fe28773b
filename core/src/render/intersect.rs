//! The scene's ray queries over every primitive: triangles and bounded solids through the octree,
//! unbounded solids (half-spaces) beside it.
//!
//! Both queries follow the octree's rule for the closest hit: the smallest `t`, ties to the
//! smallest primitive index (triangles first, then solids), so every machine picks the same one.

use crate::geom::hit::{closer, RayHit};
use crate::geom::solid::prepared::{SolidHit, SpanScratch};
use crate::geom::triangle::{intersect, RayFrame, TriangleHit};
use crate::math::ray::Ray;
use crate::scene::Scene;

/// A hit of one primitive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PrimitiveHit {
    /// A triangle (index into the scene's triangles).
    Triangle(u32, TriangleHit),
    /// A solid object (index into the scene's objects).
    Solid(u32, SolidHit),
}

impl RayHit for PrimitiveHit {
    #[inline]
    fn t(&self) -> f32 {
        match self {
            PrimitiveHit::Triangle(_, h) => h.t,
            PrimitiveHit::Solid(_, h) => h.t,
        }
    }
    #[inline]
    fn t_error(&self) -> f32 {
        match self {
            PrimitiveHit::Triangle(_, h) => h.t_error,
            PrimitiveHit::Solid(_, h) => h.t_error,
        }
    }
}

impl Scene {
    /// Primitive index of solid object `j`.
    #[inline]
    fn solid_index(&self, j: u32) -> u32 {
        self.triangle_points.len() as u32 + j
    }

    /// Tests primitive `i` against the ray.
    #[inline]
    fn test_primitive(
        &self,
        frame: &RayFrame,
        ray: &Ray,
        i: u32,
        t_max: f32,
        scratch: &mut SpanScratch,
    ) -> Option<PrimitiveHit> {
        let n = self.triangle_points.len() as u32;
        if i < n {
            intersect(frame, &self.triangle_points[i as usize], t_max)
                .map(|h| PrimitiveHit::Triangle(i, h))
        } else {
            self.solids
                .first_hit(i - n, ray, t_max, scratch)
                .map(|h| PrimitiveHit::Solid(i - n, h))
        }
    }

    /// The closest hit of `ray` with `0 < t < t_max` over all primitives.
    pub fn closest_hit(
        &self,
        ray: &Ray,
        t_max: f32,
        scratch: &mut SpanScratch,
    ) -> Option<PrimitiveHit> {
        if self.solids.is_empty() {
            // Triangles only (the seed's scenes): the octree's own triangle query.
            return self
                .octree
                .closest_hit(&self.triangle_points, ray, t_max)
                .map(|h| PrimitiveHit::Triangle(h.triangle, h.tri));
        }
        let frame = RayFrame::new(ray);
        let mut best = self.octree.closest_hit_with(ray, t_max, |i, bound| {
            self.test_primitive(&frame, ray, i, bound, scratch)
        });
        for &j in &self.unbounded {
            let bound = best.map_or(t_max, |(_, h)| {
                h.t().min(t_max) * (1.0 + 4.0 * crate::math::float::MACHINE_EPSILON)
            });
            let i = self.solid_index(j);
            if let Some(h) = self.solids.first_hit(j, ray, bound.min(t_max), scratch) {
                if closer(h.t, i, &best) {
                    best = Some((i, PrimitiveHit::Solid(j, h)));
                }
            }
        }
        best.map(|(_, h)| h)
    }

    /// True if primitive `i` blocks `ray` provably before `t_max`: `0 < t` and
    /// `t + t_error < t_max`.
    #[inline]
    fn blocks(
        &self,
        frame: &RayFrame,
        ray: &Ray,
        i: u32,
        t_max: f32,
        scratch: &mut SpanScratch,
    ) -> bool {
        self.test_primitive(frame, ray, i, t_max, scratch)
            .is_some_and(|h| h.t() + h.t_error() < t_max)
    }

    /// [`Scene::any_hit`] for a shadow ray, trying `last` first: the primitive that blocked the
    /// previous shadow ray towards the same light (POV-Ray's light buffer). Neighbouring pixels
    /// are mostly shadowed by the same object, so one test often settles the query. The answer
    /// is `any_hit`'s whatever `last` holds: a primitive that blocks the ray is found by the
    /// walk too, and `last` only decides which is tried first. `last` becomes the blocker the
    /// walk found, and keeps its old value when nothing blocks.
    pub fn shadowed(
        &self,
        ray: &Ray,
        t_max: f32,
        scratch: &mut SpanScratch,
        last: &mut Option<u32>,
    ) -> bool {
        let frame = RayFrame::new(ray);
        // A scratch carried over from another scene may remember an index this one lacks.
        let primitives = self.solid_index(self.solids.len() as u32);
        if let Some(i) = last.filter(|&i| i < primitives) {
            if self.blocks(&frame, ray, i, t_max, scratch) {
                return true;
            }
        }
        let mut blocker = None;
        let mut test = |i: u32| {
            let hit = self.blocks(&frame, ray, i, t_max, scratch);
            if hit {
                blocker = Some(i);
            }
            hit
        };
        let found = self.octree.any_hit_with(ray, t_max, &mut test)
            || self.unbounded.iter().any(|&j| test(self.solid_index(j)));
        if blocker.is_some() {
            *last = blocker;
        }
        found
    }

    /// True if `ray` hits any primitive provably before `t_max`: `0 < t` and
    /// `t + t_error < t_max` (shadow and occlusion rays).
    pub fn any_hit(&self, ray: &Ray, t_max: f32, scratch: &mut SpanScratch) -> bool {
        if self.solids.is_empty() {
            return self.octree.any_hit(&self.triangle_points, ray, t_max);
        }
        let frame = RayFrame::new(ray);
        let mut test = |i: u32| self.blocks(&frame, ray, i, t_max, scratch);
        self.octree.any_hit_with(ray, t_max, &mut test)
            || self.unbounded.iter().any(|&j| test(self.solid_index(j)))
    }
}
