//! Octree construction: split at the centre, file each primitive in every child it touches.
//!
//! Primitives are the scene's triangles (indices `0..T`) followed by its bounded solids (indices
//! `T..`): a triangle is filed by the exact triangle/box test, a solid by its world bounding box.

use super::overlap::triangle_box_overlap;
use super::{Node, Octree, OctreeParams, OctreeStats, INTERIOR, MAX_DEPTH_LIMIT};
use crate::geom::triangle::unit_normal;
use crate::math::aabb::Aabb;
use crate::math::float::gamma;
use alloc::vec::Vec;
use glam::Vec3;

/// Children whose references add up to more than this many times their parent's are not made:
/// the triangles overlap each other too much for splitting to separate them.
const MAX_DUPLICATION: usize = 2;

struct Builder<'a> {
    triangles: &'a [[Vec3; 3]],
    /// World boxes of primitives `T..` (solids); only the bounded ones are filed.
    boxes: Vec<Aabb>,
    params: OctreeParams,
    /// How far every cell is grown before the overlap test: the rounding error bound of the test
    /// at the scene's magnitude, so a triangle on a cell boundary is filed on both sides.
    margin: f32,
    nodes: Vec<Node>,
    indices: Vec<u32>,
    /// Scratch: the triangle lists of the cells being built, parents before children.
    refs: Vec<u32>,
    /// Scratch: per triangle of the cell being split, the children it touches (bit per child).
    masks: Vec<u8>,
    stats: OctreeStats,
}

impl Octree {
    /// Builds the octree over `triangles` (vertex positions by triangle index).
    ///
    /// Degenerate (zero-area) triangles are left out: the watertight test never hits them.
    pub fn build(triangles: &[[Vec3; 3]], params: &OctreeParams) -> Octree {
        Self::build_mixed(triangles, &[], params)
    }

    /// Builds the octree over `triangles` (primitives `0..T`) and solids with the world boxes
    /// `solids` (primitives `T..`). A solid whose box is `None` (unbounded) is not filed.
    pub fn build_mixed(
        triangles: &[[Vec3; 3]],
        solids: &[Option<Aabb>],
        params: &OctreeParams,
    ) -> Octree {
        let params = OctreeParams {
            max_depth: params.max_depth.min(MAX_DEPTH_LIMIT),
            max_leaf_triangles: params.max_leaf_triangles.max(1),
        };
        let mut bounds = Aabb::EMPTY;
        let mut filed = Vec::with_capacity(triangles.len());
        let mut boxes = Vec::with_capacity(triangles.len());
        for (i, p) in triangles.iter().enumerate() {
            let b = Aabb::of_triangle(p);
            boxes.push(b);
            if unit_normal(p).is_some() {
                filed.push(i as u32);
                bounds.min = bounds.min.min(b.min);
                bounds.max = bounds.max.max(b.max);
            }
        }
        for (j, b) in solids.iter().enumerate() {
            match b {
                Some(b) => {
                    boxes.push(*b);
                    filed.push((triangles.len() + j) as u32);
                    bounds.min = bounds.min.min(b.min);
                    bounds.max = bounds.max.max(b.max);
                }
                None => boxes.push(Aabb::EMPTY),
            }
        }
        if bounds.is_empty() {
            bounds = Aabb {
                min: Vec3::ZERO,
                max: Vec3::ZERO,
            };
        }
        let magnitude = bounds.min.abs().max(bounds.max.abs()).max_element();
        let mut b = Builder {
            triangles,
            boxes,
            params,
            margin: magnitude * gamma(16),
            nodes: alloc::vec![Node { first: 0, count: 0 }],
            indices: Vec::with_capacity(2 * filed.len()),
            refs: Vec::with_capacity(4 * filed.len()),
            masks: Vec::with_capacity(filed.len()),
            stats: OctreeStats {
                triangles: (triangles.len() + solids.len()) as u32,
                filed_triangles: filed.len() as u32,
                ..OctreeStats::default()
            },
        };
        let n = filed.len();
        b.refs.extend_from_slice(&filed);
        drop(filed);
        b.build_node(0, bounds, (0, n), 0);
        b.stats.nodes = b.nodes.len() as u32;
        b.stats.references = b.indices.len() as u32;
        b.stats.bytes = b.nodes.len() * core::mem::size_of::<Node>()
            + b.indices.len() * core::mem::size_of::<u32>();
        Octree {
            nodes: b.nodes,
            indices: b.indices,
            bounds,
            stats: b.stats,
        }
    }
}

impl Builder<'_> {
    fn make_leaf(&mut self, node: usize, range: (usize, usize), depth: u32) {
        let first = self.indices.len() as u32;
        let count = (range.1 - range.0) as u32;
        self.indices.extend_from_slice(&self.refs[range.0..range.1]);
        self.nodes[node] = Node { first, count };
        self.stats.leaves += 1;
        if count == 0 {
            self.stats.empty_leaves += 1;
        }
        self.stats.depth = self.stats.depth.max(depth);
        self.stats.max_leaf_triangles = self.stats.max_leaf_triangles.max(count);
    }

    /// Builds `node` over the triangles `refs[range.0..range.1]`. Children's lists are appended
    /// to `refs` (one scratch buffer for the whole build) and dropped once they are built.
    fn build_node(&mut self, node: usize, cell: Aabb, range: (usize, usize), depth: u32) {
        let n = range.1 - range.0;
        if n <= self.params.max_leaf_triangles as usize || depth >= self.params.max_depth {
            self.make_leaf(node, range, depth);
            return;
        }
        let mid = cell.center();
        let counts = self.split(&cell, mid, range);
        let total: usize = counts.iter().sum();
        let non_empty = counts.iter().filter(|&&c| c != 0).count();
        let separated = non_empty == 1 || counts.iter().any(|&c| c != 0 && c < n);
        if !separated || total > MAX_DUPLICATION * n {
            self.make_leaf(node, range, depth);
            return;
        }
        // Lay the children's lists out after everything in use, in child order.
        let base = self.refs.len();
        let mut offsets = [0usize; 8];
        let mut at = base;
        for (o, &c) in offsets.iter_mut().zip(&counts) {
            *o = at;
            at += c;
        }
        self.refs.resize(at, 0);
        let mut fill = offsets;
        for k in 0..n {
            let t = self.refs[range.0 + k];
            let mask = self.masks[k];
            for (c, f) in fill.iter_mut().enumerate() {
                if mask & (1 << c) != 0 {
                    self.refs[*f] = t;
                    *f += 1;
                }
            }
        }
        let first = self.nodes.len();
        self.nodes.resize(first + 8, Node { first: 0, count: 0 });
        self.nodes[node] = Node {
            first: first as u32,
            count: INTERIOR,
        };
        for c in 0..8 {
            let child_cell = child_box(&cell, mid, c);
            let child_range = (offsets[c], offsets[c] + counts[c]);
            self.build_node(first + c, child_cell, child_range, depth + 1);
        }
        self.refs.truncate(base);
    }

    /// Decides which children of `cell` each triangle of `refs[range.0..range.1]` touches: bit `c`
    /// of `masks[k]` for the `k`-th triangle. Returns how many triangles each child gets.
    fn split(&mut self, cell: &Aabb, mid: Vec3, range: (usize, usize)) -> [usize; 8] {
        let mut counts = [0usize; 8];
        let m = self.margin;
        self.masks.clear();
        let child_boxes: [Aabb; 8] = core::array::from_fn(|c| child_box(cell, mid, c));
        for k in range.0..range.1 {
            let t = self.refs[k] as usize;
            let b = &self.boxes[t];
            // Which halves of each axis the triangle's box reaches (boundaries count on both).
            let mut lo = [false; 3];
            let mut hi = [false; 3];
            for a in 0..3 {
                lo[a] = b.min[a] <= mid[a] + m;
                hi[a] = b.max[a] >= mid[a] - m;
            }
            let single = (0..3).all(|a| !(lo[a] && hi[a]));
            let mut mask = 0u8;
            for (c, cb) in child_boxes.iter().enumerate() {
                let candidate = (0..3).all(|a| if (c >> a) & 1 == 1 { hi[a] } else { lo[a] });
                if !candidate {
                    continue;
                }
                // A box on one side of every centre plane lies in one child: it is the triangle's
                // only candidate and the parent's test already said the triangle touches it.
                if single || self.touches(cb, t) {
                    mask |= 1 << c;
                    counts[c] += 1;
                }
            }
            self.masks.push(mask);
        }
        counts
    }

    /// True if primitive `t` touches the child box `cb` grown by the margin.
    #[inline]
    fn touches(&self, cb: &Aabb, t: usize) -> bool {
        let m = Vec3::splat(self.margin);
        let (lo, hi) = (cb.min - m, cb.max + m);
        let Some(p) = self.triangles.get(t) else {
            // A solid: its world box against the grown cell.
            let b = &self.boxes[t];
            return b.min.cmple(hi).all() && b.max.cmpge(lo).all();
        };
        // A vertex inside the grown box is a touch (accepting it can only file more, never
        // fewer); otherwise the exact separating-axis test decides.
        if p.iter().any(|v| v.cmpge(lo).all() && v.cmple(hi).all()) {
            return true;
        }
        let half = (cb.max - cb.min) * 0.5 + m;
        triangle_box_overlap(cb.center(), half, p)
    }
}

/// The box of child `c` of `cell` split at `mid`: bit `a` of `c` selects the upper half on axis `a`.
#[inline]
pub(super) fn child_box(cell: &Aabb, mid: Vec3, c: usize) -> Aabb {
    let mut b = *cell;
    for a in 0..3 {
        if (c >> a) & 1 == 1 {
            b.min[a] = mid[a];
        } else {
            b.max[a] = mid[a];
        }
    }
    b
}
