//! Analytic solids: spheres, half-spaces, boxes, cylinders and cones, and their CSG combinations.
//!
//! A scene's solids live in one flat arena, [`SceneDesc::solids`](crate::scene::SceneDesc): a
//! [`SolidNode`] is either a [`Shape`] placed by a [`Transform`] with its own shader, or a boolean
//! operation on two earlier nodes (children always have smaller indices, so the arena has no
//! cycles). Each root listed in `SceneDesc::objects` is one primitive of the octree, beside the
//! triangles.
//!
//! - [`shape`] intersects a ray with one shape in object space and returns the span of `t` inside it.
//! - [`mesh`] does the same for closed triangle meshes, whose spans may be several.
//! - [`spans`] combines span lists by union, intersection and difference (FART's rules: a hit
//!   reports the sub-shape actually hit, and on `A − B` the surface from `B` has its normal turned).
//! - [`prepared`] is the render-time form: placements inverted once, world bounds, and the queries
//!   the octree and the shader use.
//! - [`hit`] is what every solid query returns: where the ray first meets the object.
//! - [`sphere_miss`] tells a sure miss of a sphere without a division, under an error bound
//!   that makes it agree with [`shape`]'s test.
//! - [`cylinder_miss`] does the same for a cylinder's side. Both answer for four rays at once
//!   too; `miss_checks` (tests only) holds the checks both must pass.
//! - [`lone_sphere`] tests a sphere object that is only translated without reading its node.
//! - [`extent`] says where an object can be hit (nowhere bounded, a box, or a sphere's surface),
//!   which is what the octree files it by.

pub mod cylinder_miss;
pub mod extent;
pub mod hit;
pub mod lone_sphere;
pub mod mesh;
mod miss_checks;
pub mod prepared;
pub mod shape;
pub mod spans;
pub mod sphere_miss;

use crate::math::transform::Transform;
use glam::Vec3;

/// A shape in its own object space.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Shape {
    /// A ball of this radius around the origin.
    Sphere {
        /// Radius, positive.
        radius: f32,
    },
    /// The half-space `n̂ · p ≤ d` with `n̂` the unit vector along `normal`; its surface is the
    /// plane `n̂ · p = d` and the normal points out of the solid side. Unbounded: it sits beside the octree, not in it.
    Plane {
        /// Outward normal, not zero (need not be unit length).
        normal: Vec3,
        /// Offset along the unit normal.
        d: f32,
    },
    /// An axis-aligned box centred on the origin.
    Cuboid {
        /// Edge lengths, all positive.
        size: Vec3,
    },
    /// A capped cone frustum around the Y axis, from `y = −height/2` (radius `bottom_radius`) to
    /// `y = height/2` (radius `top_radius`); equal radii make a cylinder.
    Cylinder {
        /// Radius at the bottom cap, at least 0.
        bottom_radius: f32,
        /// Radius at the top cap, at least 0 (not both 0).
        top_radius: f32,
        /// Distance between the caps, positive.
        height: f32,
    },
}

impl Shape {
    /// True if every parameter is finite and in its range.
    pub fn is_valid(&self) -> bool {
        match *self {
            Shape::Sphere { radius } => radius.is_finite() && radius > 0.0,
            Shape::Plane { normal, d } => {
                normal.is_finite() && normal != Vec3::ZERO && d.is_finite()
            }
            Shape::Cuboid { size } => size.is_finite() && size.min_element() > 0.0,
            Shape::Cylinder {
                bottom_radius,
                top_radius,
                height,
            } => {
                bottom_radius.is_finite()
                    && top_radius.is_finite()
                    && height.is_finite()
                    && bottom_radius >= 0.0
                    && top_radius >= 0.0
                    && bottom_radius.max(top_radius) > 0.0
                    && height > 0.0
            }
        }
    }
}

/// A boolean operation of CSG.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum CsgOp {
    /// Inside either operand.
    Union,
    /// Inside both operands.
    Intersect,
    /// Inside the first operand and outside the second.
    Subtract,
}

/// One node of the solid arena.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum SolidNode {
    /// A shape placed in the world, with its shader.
    Leaf {
        /// The shape in object space.
        shape: Shape,
        /// Object to world.
        transform: Transform,
        /// Index into `SceneDesc::shaders`.
        shader: u32,
    },
    /// A closed triangle mesh placed in the world: triangles `first .. first + count` of
    /// [`SceneDesc::solid_triangles`](crate::scene::SceneDesc), in object space, wound
    /// counter-clockwise seen from outside (see [`mesh`]).
    Mesh {
        /// Index of the first triangle.
        first: u32,
        /// Number of triangles, at least 1.
        count: u32,
        /// Object to world.
        transform: Transform,
        /// Index into `SceneDesc::shaders`.
        shader: u32,
    },
    /// A boolean combination of two earlier nodes.
    Csg {
        /// Which operation.
        op: CsgOp,
        /// Index of the first operand (smaller than this node's index).
        a: u32,
        /// Index of the second operand (smaller than this node's index).
        b: u32,
    },
}

/// The deepest CSG nesting a scene may use (bounds the recursion of span evaluation).
pub const MAX_CSG_DEPTH: u32 = 64;
