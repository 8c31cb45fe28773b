//! [`SolidExtent`]: where in the world a scene object can be hit, as the octree build files it:
//! nowhere bounded (a plane), within a box, or on a sphere's surface.

use crate::math::aabb::Aabb;
use glam::Vec3;

/// Where a solid can be hit: what the octree's build files it by (`Octree::build_mixed`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SolidExtent {
    /// No bound (a plane, say): it stays out of the tree.
    Unbounded,
    /// Filed in every cell its world box touches.
    Box(Aabb),
    /// A sphere standing alone: filed in every cell its surface comes within `margin` of, which
    /// leaves out the cells inside it; `bounds` is its world box.
    Sphere {
        /// World box.
        bounds: Aabb,
        /// Centre, world space.
        center: Vec3,
        /// Radius, world space.
        radius: f32,
        /// How far from the surface a cell still holds it, on top of the growth every cell gets
        /// for every primitive (the scene's magnitude times `gamma(16)`): the reject boxes'
        /// margin, 1e-4 of the object's size and distance from the origin, so the centre and
        /// radius read off a placement that is a rotation and scale only to a millionth still
        /// bound the surface its test sees.
        margin: f32,
    },
}

impl SolidExtent {
    /// The world box, `None` for an unbounded solid.
    pub fn bounds(&self) -> Option<Aabb> {
        match *self {
            SolidExtent::Unbounded => None,
            SolidExtent::Box(b) | SolidExtent::Sphere { bounds: b, .. } => Some(b),
        }
    }
}
