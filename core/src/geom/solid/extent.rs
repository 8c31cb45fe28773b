//! [`SolidExtent`]: where in the world a scene object can be hit, as the octree build files it:
//! nowhere bounded (a plane), within a box, on a sphere's surface, or near a cylinder's axis; and
//! the reject box, how far
//! beyond its world box an object's test can report a hit.

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
    /// A cylinder or cone standing alone: filed in every cell that comes within `radius` plus
    /// `margin` of its axis, the segment `a`–`b` (every point of the solid lies within its
    /// larger radius, `radius`, of the axis). A cell beside a slanted cylinder, which its world
    /// box reaches, holds no point of it.
    Cone {
        /// World box.
        bounds: Aabb,
        /// The centre of its bottom cap, world space.
        a: Vec3,
        /// The centre of its top cap, world space.
        b: Vec3,
        /// Its larger radius, world space.
        radius: f32,
        /// How far beyond that a cell still holds it: as [`SolidExtent::Sphere`]'s.
        margin: f32,
    },
}

impl SolidExtent {
    /// The world box, `None` for an unbounded solid.
    pub fn bounds(&self) -> Option<Aabb> {
        match *self {
            SolidExtent::Unbounded => None,
            SolidExtent::Box(b)
            | SolidExtent::Sphere { bounds: b, .. }
            | SolidExtent::Cone { bounds: b, .. } => Some(b),
        }
    }

    /// Where the solid's test can report a hit: its world box grown by [`reject_margin`] (the
    /// test's rounding reaches a little beyond the world box). The octree compares this box
    /// with its cells' centre planes exactly.
    pub fn reach(&self) -> Option<Aabb> {
        self.bounds().map(|b| reject_box(&b))
    }
}

/// How far an object's reject box reaches beyond its world box, relative to the box's size and
/// distance from the origin: orders of magnitude above the rounding of any crossing the object's
/// test can report, so the box test never drops a hit the test would find.
pub const REJECT_MARGIN: f32 = 1e-4;

/// [`REJECT_MARGIN`] for the object with world box `b`, in world units.
pub fn reject_margin(b: &Aabb) -> f32 {
    let scale = (b.max - b.min).max_element() + b.min.abs().max(b.max.abs()).max_element();
    scale * REJECT_MARGIN
}

/// `b` grown by [`REJECT_MARGIN`]: the object's reject box.
pub fn reject_box(b: &Aabb) -> Aabb {
    b.grown(reject_margin(b))
}
