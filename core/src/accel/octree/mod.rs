//! The octree: an arena of nodes with `u32` handles over the scene's triangles.
//!
//! The octree files primitives by index: triangles first, then bounded solids (see `build.rs`);
//! the generic queries take a closure that tests one primitive.
//! - [`Node`]s live in one flat `Vec`; the eight children of an interior node are stored together
//!   and addressed by the index of the first. A leaf is a range of [`Octree::indices`], the
//!   triangle indices reordered so each leaf's are contiguous. A node is 8 bytes; child boxes are
//!   not stored but derived from the parent's by halving.
//! - A few large primitives (a floor under a small object) are kept out of the tree and tested
//!   by every query before its walk. The root cell is the box around the rest, grown along its
//!   short sides where it is flatter than 4 : 1 (every cell has the root's shape; see
//!   `build.rs`).
//! - [`build`](Octree::build) (in `build.rs`) splits cells at their centre, best split first by
//!   the surface area heuristic (its queue of leaves in `queue.rs`), within
//!   [`BYTES_PER_PRIMITIVE`]. Which children a primitive goes in is decided in `filing.rs`: a
//!   triangle every child cell it touches (exact separating-axis test, in `overlap.rs`, on a
//!   box grown by its error bound), a sphere standing alone every cell its surface passes
//!   through, and other solids every cell their reject box touches; a primitive that only
//!   touches a centre plane from one side is filed on that side alone.
//! - [`closest_hit`](Octree::closest_hit) and [`any_hit`](Octree::any_hit) (in `traverse.rs`)
//!   walk the cells a ray crosses or touches (on both sides of a centre plane where the ray
//!   meets it), nearest child first, with a fixed-size stack; `closest_hit_grouped` and
//!   `any_hit_grouped` hand a large leaf to their tests whole (where they keep its primitives
//!   ready, [`GroupTests::test_leaf`]) or [`GROUP`] primitives at a time.
//! - [`closest_hits4`](Octree::closest_hits4) (in `packet.rs`) walks four neighbouring camera
//!   rays together, one per vector lane, to the one-ray walk's answers: a [`Packet`], which
//!   lays the rays out in lanes once for every four-ray test of a query, where they go the
//!   same way along every axis.
//! - [`filed_in`](Octree::filed_in) (in `region.rs`) lists the primitives filed near a box, for
//!   structures beside the tree that rely on its filing.
//! - [`brute_force_closest_hit`] is the reference the octree is tested against.
//!
//! The closest hit is the smallest `t`, ties going to the smallest triangle index; the octree
//! returns exactly the triangle and `t` that testing every triangle would, wherever the triangle
//! test's `f32` inside decision holds. Its known exception: a ray that grazes a face from far
//! away can be judged inside the face at a point well outside it (a ray from 1,000 units at
//! 1.2° to a face of SPD's tetra, judged inside two faces 0.02 and 0.03 units past them), in no
//! cell that holds the face, so only brute force reports that hit (2 of 1.6 million rays aimed
//! at face edges at grazing angles, with this filing and with the margin-grown one before it).

mod build;
mod filing;
pub use build::BYTES_PER_PRIMITIVE;
mod overlap;
mod packet;
mod queue;
mod region;
pub use packet::{lanes_of, per_lane, Packet, PacketStack, LANES};
mod traverse;
pub use crate::geom::hit::GROUP;
pub use traverse::{GroupBlocks, GroupTests};

use crate::geom::hit::closer;
use crate::geom::triangle::{intersect, RayFrame, TriangleHit};
use crate::math::aabb::Aabb;
use crate::math::ray::Ray;
use alloc::vec::Vec;
use glam::{Vec3, Vec3A};

/// The deepest octree [`OctreeParams::max_depth`] may ask for (bounds the traversal stack).
pub const MAX_DEPTH_LIMIT: u32 = 20;

/// Octree build limits.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct OctreeParams {
    /// Cells at this depth are never split (clamped to [`MAX_DEPTH_LIMIT`]).
    pub max_depth: u32,
    /// Cells with at most this many primitives are not split (others only where the surface area
    /// heuristic says it pays and the memory budget allows).
    pub max_leaf_triangles: u32,
}

impl Default for OctreeParams {
    fn default() -> Self {
        OctreeParams {
            max_depth: 16,
            max_leaf_triangles: 4,
        }
    }
}

/// Marks an interior node in [`Node::count`]; its low 8 bits say which children are not empty
/// leaves.
const INTERIOR: u32 = 1 << 31;

/// One octree cell: an interior node (children at `first .. first + 8`, `count` is `INTERIOR`
/// with bit `c` set if child `c` holds anything) or a leaf (primitive indices at
/// `first .. first + count` of [`Octree::indices`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Node {
    first: u32,
    count: u32,
}

impl Node {
    /// True for a leaf.
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.count & INTERIOR == 0
    }

    /// For an interior node: true if child `c` is not an empty leaf (read without loading it).
    #[inline]
    pub fn child_occupied(&self, c: usize) -> bool {
        self.occupied() >> c & 1 == 1
    }

    /// For an interior node: bit `c` set where child `c` is not an empty leaf.
    #[inline]
    pub fn occupied(&self) -> usize {
        (self.count & 0xFF) as usize
    }
}

/// Figures about a built octree, for the end-of-render summary and benchmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct OctreeStats {
    /// Triangles given to the build.
    pub triangles: u32,
    /// Triangles filed in the tree (degenerate ones are left out: they are never hit).
    pub filed_triangles: u32,
    /// All nodes, interior and leaf.
    pub nodes: u32,
    /// Leaf nodes.
    pub leaves: u32,
    /// Leaves with no triangle.
    pub empty_leaves: u32,
    /// Depth of the deepest leaf (the root is depth 0).
    pub depth: u32,
    /// Entries in the leaf index list (a triangle spanning cells counts once per cell).
    pub references: u32,
    /// The most triangles in one leaf.
    pub max_leaf_triangles: u32,
    /// Bytes of the node array and the index list.
    pub bytes: usize,
}

impl OctreeStats {
    /// Octree bytes per triangle given to the build.
    pub fn bytes_per_triangle(&self) -> f32 {
        if self.triangles == 0 {
            0.0
        } else {
            self.bytes as f32 / self.triangles as f32
        }
    }

    /// Mean triangles per non-empty leaf.
    pub fn mean_leaf_triangles(&self) -> f32 {
        let full = self.leaves - self.empty_leaves;
        if full == 0 {
            0.0
        } else {
            self.references as f32 / full as f32
        }
    }
}

/// The octree over a triangle list. It stores indices only; queries take the triangle positions.
#[derive(Clone, Debug)]
pub struct Octree {
    nodes: Vec<Node>,
    indices: Vec<u32>,
    /// The box around every filed primitive.
    bounds: Aabb,
    /// The root cell: the box around the primitives in the tree, grown where it is much flatter
    /// than a cube (see `build.rs`).
    root: Aabb,
    /// Large primitives kept out of the tree (a floor under a small object), tested by every
    /// query before its walk.
    large: Vec<u32>,
    stats: OctreeStats,
}

/// A ray's closest hit: which triangle, where, and how exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Index of the triangle hit.
    pub triangle: u32,
    /// The hit's `t`, barycentrics and `t` error bound.
    pub tri: TriangleHit,
}

/// Tests the ray against every triangle: the reference for the octree's closest hit.
pub fn brute_force_closest_hit(triangles: &[[Vec3; 3]], ray: &Ray, t_max: f32) -> Option<Hit> {
    let frame = RayFrame::new(ray);
    let mut best: Option<(u32, TriangleHit)> = None;
    for (i, p) in triangles.iter().enumerate() {
        // Degenerate triangles are not filed in the octree either.
        if crate::geom::triangle::unit_normal(p).is_none() {
            continue;
        }
        if let Some(h) = intersect(&frame, p, t_max) {
            if closer(h.t, i as u32, &best) {
                best = Some((i as u32, h));
            }
        }
    }
    best.map(|(triangle, tri)| Hit { triangle, tri })
}

impl Octree {
    /// Build statistics.
    pub fn stats(&self) -> &OctreeStats {
        &self.stats
    }

    /// The box around every filed triangle.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The root cell, which the cells of the tree divide: the box around the primitives in the
    /// tree, grown along its short sides where it is much flatter than a cube.
    pub fn root(&self) -> Aabb {
        self.root
    }

    /// The large primitives kept out of the tree, tested by every query before its walk.
    pub fn large(&self) -> &[u32] {
        &self.large
    }

    /// The node array (root at index 0).
    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// The reordered triangle index list that leaves point into.
    pub fn indices(&self) -> &[u32] {
        &self.indices
    }

    /// Every leaf that holds a primitive, as its start in [`Octree::indices`] and its primitive
    /// indices, in node order.
    pub fn leaves(&self) -> impl Iterator<Item = (u32, &[u32])> + '_ {
        self.nodes
            .iter()
            .filter(|n| n.is_leaf() && n.count > 0)
            .map(|n| {
                let start = n.first as usize;
                (n.first, &self.indices[start..start + n.count as usize])
            })
    }
}

/// The box of child `c` of `cell` split at `mid`: bit `a` of `c` selects the upper half on axis
/// `a`. The build, the filing tests and the walk all cut cells with it, so theirs agree to the bit.
#[inline]
fn child_box(cell: &Aabb, mid: Vec3, c: usize) -> Aabb {
    // As vector selects: `Vec3::select` is a branch per component, which the walk's children
    // made unpredictable.
    let upper = glam::BVec3A::new(c & 1 != 0, c & 2 != 0, c & 4 != 0);
    let (mid, min, max) = (
        Vec3A::from(mid),
        Vec3A::from(cell.min),
        Vec3A::from(cell.max),
    );
    Aabb {
        min: Vec3A::select(upper, mid, min).into(),
        max: Vec3A::select(upper, max, mid).into(),
    }
}

/// The octree tests' fixed sequence of numbers (xorshift32 from `seed`): each call gives the
/// next.
#[cfg(test)]
fn xorshift(seed: u32) -> impl FnMut() -> u32 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        state
    }
}
