//! The rays inside a transparent lone sphere: their closest hits without a walk.
//!
//! A ray refracted into a glass sphere, or reflected back inside it, mostly ends on the sphere's
//! own far side, and the octree walk crosses every cell along the chord to find that. Where
//! few primitives come near the sphere, testing the sphere and those few gives the walk's
//! answer. [`SphereInteriors`] keeps, per such sphere, its world box `B` and the primitives near
//! it; `Scene::closest_hit_inside` (in `render/intersect.rs`) asks them and answers only where
//! the ray starts in `B` and the best of those tests lies within `B` grown by `δ/2`.
//!
//! Why that is the walk's answer. The octree rests on one premise (`accel::octree`): a
//! primitive's test reports a hit only within the build's margin `μ` ([`Octree::margin`]) of
//! where the primitive is filed from (a triangle, a sphere's surface band, a cylinder's axis, a
//! reject box), and the primitive is filed in every cell that comes within `μ` of that. Let the
//! ray start at `o` in `B`, and let the best hit among the sphere and its neighbours be at `t`,
//! its computed point in `B + δ/2`. The exact point lies within the sum's rounding (below `δ/2`,
//! see [`SphereInteriors::build`]) of it, so the segment from `o` to it lies in `B + δ` (boxes
//! are convex). Another primitive that beat that hit would report a hit on the segment, so its
//! filing region comes within `μ` of `B + δ`, inside `R = B + 2δ` (`δ ≥ μ`): it is filed in a
//! leaf that meets `R` ([`Octree::filed_in`]), and its hit box (the triangle's box, the solid's
//! reject box) meets `R`. Those are the neighbours, so it was tested. The walk's known
//! exception (a grazing hit judged far outside its face) is this query's too.
//!
//! The query tests the sphere first; a neighbouring lone sphere it then tests only where the
//! ray's segment up to the hit so far comes within the neighbour's [`Clearance`] (radius,
//! filing band and `μ`): by the same premise, a sphere that could report a winning hit has a
//! point of that segment there. Touching spheres (SPD's mount stacks four in a pyramid) are
//! mostly left clear.
//!
//! Spheres with more than [`MAX_NEIGHBOURS`] neighbours (one sunk into a mesh, or holding
//! others) get no entry, and their rays walk.

use crate::accel::octree::Octree;
use crate::geom::solid::extent::SolidExtent;
use crate::geom::solid::lone_sphere::LoneSphere;
use crate::math::aabb::Aabb;
use crate::math::float::gamma;
use crate::math::ray::Ray;
use alloc::vec::Vec;
use glam::Vec3;

/// The most primitives besides the sphere that a query inside it tests: more, and the walk is
/// left to find the hit.
pub const MAX_NEIGHBOURS: usize = 8;

/// Per transparent lone sphere, its box and the primitives near it (see the module doc). The
/// sphere and the lone spheres among its neighbours are kept as their records, so a query tests
/// them without looking them up.
#[derive(Clone, Debug, Default)]
pub struct SphereInteriors {
    /// Per solid object: one more than its index in `entries`, 0 for none (empty where no
    /// sphere has an entry).
    slots: Vec<u32>,
    entries: Vec<Entry>,
    /// The neighbours that are lone spheres, with their primitive indices and clearances,
    /// entry by entry.
    spheres: Vec<(u32, LoneSphere, Clearance)>,
    /// The other neighbours' primitive indices, entry by entry.
    others: Vec<u32>,
}

#[derive(Clone, Copy, Debug)]
struct Entry {
    bounds: Aabb,
    ends: Aabb,
    sphere: (u32, LoneSphere),
    spheres: (u32, u32),
    others: (u32, u32),
}

/// What a query inside one sphere needs.
#[derive(Clone, Copy, Debug)]
pub struct Interior<'a> {
    /// The sphere's world box `B`: the ray must start in it.
    pub bounds: Aabb,
    /// `B + δ/2`: the best hit's computed point must lie in it.
    pub ends: Aabb,
    /// The sphere, with its primitive index.
    pub sphere: (u32, LoneSphere),
    /// The neighbours that are lone spheres, with their primitive indices and clearances.
    pub spheres: &'a [(u32, LoneSphere, Clearance)],
    /// The other neighbours' primitive indices.
    pub others: &'a [u32],
}

impl SphereInteriors {
    /// The entries of `spheres` (solid object indices, each a lone sphere, with `bounds` its
    /// world box) in the scene of `triangles` (primitives `0..T`) and solids of `extents`
    /// (primitives `T..`) filed in `octree`; `sphere_of` gives the lone sphere of a primitive
    /// index, if it is one.
    ///
    /// `δ` is `μ` plus `γ(32)` of `B`'s magnitude. The end check's point `o + d·t` is rounded
    /// twice, by at most `γ(2)·(|o| + |d·t|)`, and both terms are within `B + δ/2`, so that
    /// rounding is below `γ(2)·3·(|B| + δ) < δ/2`.
    pub fn build(
        octree: &Octree,
        triangles: &[[Vec3; 3]],
        extents: &[SolidExtent],
        spheres: impl Iterator<Item = (u32, Aabb)>,
        sphere_of: impl Fn(u32) -> Option<LoneSphere>,
    ) -> SphereInteriors {
        let mut interiors = SphereInteriors::default();
        let n = triangles.len() as u32;
        let hit_box = |i: u32| match i.checked_sub(n) {
            None => Some(Aabb::of_triangle(&triangles[i as usize])),
            Some(j) => extents.get(j as usize).and_then(SolidExtent::reach),
        };
        for (object, bounds) in spheres {
            let magnitude = bounds.min.abs().max(bounds.max.abs()).max_element();
            let delta = octree.margin() + gamma(32) * magnitude;
            let region = bounds.grown(2.0 * delta);
            let own = n + object;
            let Some(sphere) = sphere_of(own) else {
                continue;
            };
            let near: Vec<u32> = octree
                .filed_in(&region)
                .into_iter()
                .filter(|&i| i != own && hit_box(i).is_some_and(|b| b.meets(&region)))
                .collect();
            if near.len() > MAX_NEIGHBOURS {
                continue;
            }
            let (spheres, others) = (interiors.spheres.len(), interiors.others.len());
            for i in near {
                let clearance = i
                    .checked_sub(n)
                    .and_then(|j| extents.get(j as usize))
                    .and_then(|e| Clearance::of(e, octree.margin()));
                match sphere_of(i).zip(clearance) {
                    Some((s, c)) => interiors.spheres.push((i, s, c)),
                    None => interiors.others.push(i),
                }
            }
            interiors.entries.push(Entry {
                bounds,
                ends: bounds.grown(0.5 * delta),
                sphere: (own, sphere),
                spheres: (spheres as u32, interiors.spheres.len() as u32),
                others: (others as u32, interiors.others.len() as u32),
            });
            // Slots only once a sphere has an entry: most scenes have no glass spheres.
            interiors.slots.resize(extents.len(), 0);
            if let Some(slot) = interiors.slots.get_mut(object as usize) {
                *slot = interiors.entries.len() as u32;
            }
        }
        interiors
    }

    /// The entry of solid object `object`, if it has one.
    #[inline]
    pub fn of(&self, object: u32) -> Option<Interior<'_>> {
        let slot = *self.slots.get(object as usize)?;
        let e = self.entries.get(slot.checked_sub(1)? as usize)?;
        let range = |(start, end): (u32, u32)| start as usize..end as usize;
        Some(Interior {
            bounds: e.bounds,
            ends: e.ends,
            sphere: e.sphere,
            spheres: &self.spheres[range(e.spheres)],
            others: &self.others[range(e.others)],
        })
    }

    /// True if solid object `object` has an entry.
    #[inline]
    pub fn holds(&self, object: u32) -> bool {
        self.slots.get(object as usize).is_some_and(|&s| s != 0)
    }
}

/// How far from a neighbouring lone sphere's centre a ray's points must stay for its test to
/// report no hit among them: its radius, the band around its surface that the octree files it
/// by (`SolidExtent::Sphere`'s margin), and the build's margin `μ` (the premise in the module
/// doc: a test reports hits only within `μ` of where its primitive is filed from).
#[derive(Clone, Copy, Debug)]
pub struct Clearance {
    centre: Vec3,
    reach: f32,
}

impl Clearance {
    /// The clearance of a lone sphere filed as `extent`, `None` for another kind of extent.
    fn of(extent: &SolidExtent, mu: f32) -> Option<Clearance> {
        match *extent {
            SolidExtent::Sphere {
                center,
                radius,
                margin,
                ..
            } => Some(Clearance {
                centre: center,
                reach: radius + margin + mu,
            }),
            _ => None,
        }
    }

    /// True if the points of `ray` with `0 ≤ t ≤ t_end` all lie farther than the reach from the
    /// centre, so the sphere's test reports no hit with `t ≤ t_end`. In `f64`, from the `f32`
    /// inputs (exact in `f64`): the nearest point's parameter, clamped to the segment, and its
    /// squared distance. Their rounding, a few units of 2⁻⁵³ of the squared distances, is far
    /// below what the margins add to the squared reach (twice the radius times the surface
    /// band, 10⁻⁴ of the sphere's size and distance from the origin).
    #[inline]
    pub fn clears(&self, ray: &Ray, t_end: f32) -> bool {
        let f = |v: Vec3| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
        let (o, d, c) = (f(ray.origin), f(ray.dir), f(self.centre));
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let w = [c[0] - o[0], c[1] - o[1], c[2] - o[2]];
        // NaN for a zero or non-finite direction, and then nothing below is true.
        let s = dot(w, d) / dot(d, d);
        let end = f64::from(t_end);
        let s = if s < 0.0 {
            0.0
        } else if s > end {
            end
        } else {
            s
        };
        let gap = [w[0] - d[0] * s, w[1] - d[1] * s, w[2] - d[2] * s];
        let reach = f64::from(self.reach);
        dot(gap, gap) > reach * reach
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::solid::Shape;
    use crate::math::transform::{Placement, Transform};
    use crate::scene::mesh::Rng;

    /// A ray that stays clear of a sphere's reach up to `t_end` gets no hit from its test up to
    /// there; one through the centre is never clear; and the clearance is not empty talk: many
    /// segments that pass near the sphere are cleared.
    #[test]
    fn a_cleared_segment_gets_no_hit() {
        let mut rng = Rng::new(5);
        let mut cleared = 0;
        for k in 0..20_000 {
            let centre = Vec3::new(rng.range(-50.0, 50.0), rng.range(-5.0, 5.0), 3.0);
            let radius = rng.range(0.01, 2.0);
            let placement = Placement::new(&Transform::translate(centre));
            let Some(sphere) = LoneSphere::of(&Shape::Sphere { radius }, &placement, 0) else {
                panic!("a translated sphere is a lone sphere");
            };
            let extent = SolidExtent::Sphere {
                bounds: Aabb {
                    min: centre - Vec3::splat(radius),
                    max: centre + Vec3::splat(radius),
                },
                center: centre,
                radius,
                margin: 1e-4 * (2.0 * radius + centre.abs().max_element()),
            };
            let Some(clearance) = Clearance::of(&extent, 1e-6) else {
                panic!("a sphere's extent has a clearance");
            };
            // Rays aimed near the sphere, from outside and inside it.
            let target = centre + rng.direction() * radius * rng.range(0.5, 1.5);
            let origin = centre + rng.direction() * radius * rng.range(0.0, 4.0);
            let ray = Ray::new(origin, (target - origin) * rng.range(0.1, 3.0));
            let t_end = if k % 3 == 0 {
                f32::INFINITY
            } else {
                rng.range(0.0, 2.0)
            };
            if clearance.clears(&ray, t_end) {
                cleared += 1;
                assert!(
                    sphere.first_hit(&ray, t_end).is_none(),
                    "{ray:?} to {t_end}"
                );
            }
            let through = Ray::new(origin, centre - origin);
            assert!(!clearance.clears(&through, 1.0) || origin == centre);
        }
        assert!(cleared > 2_000, "{cleared}");
    }
}
