//! Lone spheres moved into place by a translation alone, tested without their node.
//!
//! Most spheres of NFF and FART scenes are objects of one sphere shape, translated. Their node
//! ([`PreparedNode::Leaf`](super::prepared::PreparedNode)) carries the shape and a placement of
//! four matrices, about 170 bytes, and a test reads both and applies the inverse matrix. A
//! [`LoneSphere`] keeps the 24 bytes the test needs and runs the node's test operation for
//! operation (the identity as inverse included), so every hit is the node's to the bit. On
//! SPD's shells, where a ray tests hundreds of overlapping spheres, the nodes no longer fit the
//! cache; these records do.

use super::prepared::SolidHit;
use super::shape;
use super::Shape;
use crate::math::ray::Ray;
use crate::math::transform::Placement;
use glam::{Mat3, Vec3};

/// A sphere object whose placement is a translation: its world centre, radius and node.
#[derive(Clone, Copy, Debug)]
pub struct LoneSphere {
    centre: Vec3,
    radius: f32,
    /// The sphere's node in the arena (the object's root), named in its hits.
    leaf: u32,
}

impl LoneSphere {
    /// The record of the object whose root `leaf` is `shape` placed by `placement`, if that is a
    /// sphere whose inverse placement is exactly the identity matrix.
    pub fn of(shape: &Shape, placement: &Placement, leaf: u32) -> Option<LoneSphere> {
        match *shape {
            Shape::Sphere { radius } if placement.inverse == Mat3::IDENTITY => Some(LoneSphere {
                centre: placement.to_world.translation,
                radius,
                leaf,
            }),
            _ => None,
        }
    }

    /// The first crossing of `ray` in front of its origin before `t_max`: the node's
    /// [`Solids::first_hit`](super::prepared::Solids::first_hit), to the bit.
    #[inline]
    pub fn first_hit(&self, ray: &Ray, t_max: f32) -> Option<SolidHit> {
        // `Placement::point_to_object` and `vector_to_object` with the identity as inverse: the
        // products by 1 and 0 and their sums are kept, so signed zeros come out as there.
        let o = Mat3::IDENTITY * (ray.origin - self.centre);
        let d = Mat3::IDENTITY * ray.dir;
        let (t, t_error, face) = shape::sphere_first_crossing(self.radius, o, d, t_max)?;
        Some(SolidHit {
            t,
            t_error,
            leaf: self.leaf,
            face,
            flip: false,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::transform::Transform;
    use crate::scene::mesh::Rng;

    /// The node's test: the placement's maps, then the shape's first crossing.
    fn node_hit(shape: &Shape, pl: &Placement, ray: &Ray, t_max: f32) -> Option<(u32, u32, u32)> {
        let o = pl.point_to_object(ray.origin);
        let d = pl.vector_to_object(ray.dir);
        shape::first_crossing(shape, o, d, t_max).map(|(t, e, f)| (t.to_bits(), e.to_bits(), f))
    }

    #[test]
    fn hits_are_the_nodes_to_the_bit() {
        let mut rng = Rng::new(7);
        let mut hits = 0;
        for i in 0..20_000 {
            let centre = Vec3::new(
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
                rng.range(-5.0, 5.0),
            );
            let shape = Shape::Sphere {
                radius: rng.range(0.01, 3.0),
            };
            let pl = Placement::new(&Transform::translate(centre));
            let sphere = LoneSphere::of(&shape, &pl, 3).expect("a translated sphere is lone");
            // From anywhere, the centre's surroundings included (rays from inside); aimed near
            // the centre so about half hit; some components zero of either sign.
            let origin = centre + rng.direction() * rng.range(0.0, 8.0);
            let mut dir = centre + rng.direction() * rng.range(0.0, 4.0) - origin;
            if i % 5 == 0 {
                dir[i % 3] = if i % 2 == 0 { 0.0 } else { -0.0 };
            }
            if dir == Vec3::ZERO {
                continue;
            }
            let ray = Ray::new(origin, dir);
            let t_max = if i % 3 == 0 {
                f32::INFINITY
            } else {
                rng.range(0.0, 2.0)
            };
            let got = sphere.first_hit(&ray, t_max);
            assert_eq!(
                got.map(|h| (h.t.to_bits(), h.t_error.to_bits(), h.face)),
                node_hit(&shape, &pl, &ray, t_max),
                "ray {i}: {ray:?}"
            );
            assert!(got.is_none_or(|h| h.leaf == 3 && !h.flip));
            hits += usize::from(got.is_some());
        }
        assert!(hits > 5_000, "{hits} hits");
    }

    #[test]
    fn only_translated_spheres_are_lone() {
        let sphere = Shape::Sphere { radius: 1.0 };
        let moved = Placement::new(&Transform::translate(Vec3::ONE));
        let scaled = Placement::new(&Transform::scale(Vec3::splat(2.0)));
        assert!(LoneSphere::of(&sphere, &moved, 0).is_some());
        assert!(LoneSphere::of(&sphere, &scaled, 0).is_none());
        let cube = Shape::Cuboid { size: Vec3::ONE };
        assert!(LoneSphere::of(&cube, &moved, 0).is_none());
    }
}
