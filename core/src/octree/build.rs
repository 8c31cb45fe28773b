//! Octree construction: split at the centre, file each triangle in every child it touches.

use super::overlap::triangle_box_overlap;
use super::{Node, Octree, OctreeParams, OctreeStats, INTERIOR, MAX_DEPTH_LIMIT};
use crate::aabb::Aabb;
use crate::float::gamma;
use crate::triangle::area_normal;
use alloc::vec::Vec;
use glam::Vec3;

/// Children whose references add up to more than this many times their parent's are not made:
/// the triangles overlap each other too much for splitting to separate them.
const MAX_DUPLICATION: usize = 2;

struct Builder<'a> {
    triangles: &'a [[Vec3; 3]],
    boxes: Vec<Aabb>,
    params: OctreeParams,
    /// How far every cell is grown before the overlap test: the rounding error bound of the test
    /// at the scene's magnitude, so a triangle on a cell boundary is filed on both sides.
    margin: f32,
    nodes: Vec<Node>,
    indices: Vec<u32>,
    stats: OctreeStats,
}

impl Octree {
    /// Builds the octree over `triangles` (vertex positions by triangle index).
    ///
    /// Degenerate (zero-area) triangles are left out: the watertight test never hits them.
    pub fn build(triangles: &[[Vec3; 3]], params: &OctreeParams) -> Octree {
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
            if area_normal(p) != Vec3::ZERO {
                filed.push(i as u32);
                bounds.min = bounds.min.min(b.min);
                bounds.max = bounds.max.max(b.max);
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
            indices: Vec::new(),
            stats: OctreeStats {
                triangles: triangles.len() as u32,
                filed_triangles: filed.len() as u32,
                ..OctreeStats::default()
            },
        };
        b.build_node(0, bounds, filed, 0);
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
    fn make_leaf(&mut self, node: usize, tris: &[u32], depth: u32) {
        let first = self.indices.len() as u32;
        self.indices.extend_from_slice(tris);
        self.nodes[node] = Node {
            first,
            count: tris.len() as u32,
        };
        self.stats.leaves += 1;
        if tris.is_empty() {
            self.stats.empty_leaves += 1;
        }
        self.stats.depth = self.stats.depth.max(depth);
        self.stats.max_leaf_triangles = self.stats.max_leaf_triangles.max(tris.len() as u32);
    }

    fn build_node(&mut self, node: usize, cell: Aabb, tris: Vec<u32>, depth: u32) {
        if tris.len() <= self.params.max_leaf_triangles as usize || depth >= self.params.max_depth {
            self.make_leaf(node, &tris, depth);
            return;
        }
        let mid = cell.center();
        let children = self.split(&cell, mid, &tris);
        let total: usize = children.iter().map(Vec::len).sum();
        let non_empty = children.iter().filter(|c| !c.is_empty()).count();
        let separated = non_empty == 1
            || children
                .iter()
                .any(|c| !c.is_empty() && c.len() < tris.len());
        if !separated || total > MAX_DUPLICATION * tris.len() {
            self.make_leaf(node, &tris, depth);
            return;
        }
        drop(tris);
        let first = self.nodes.len();
        self.nodes.resize(first + 8, Node { first: 0, count: 0 });
        self.nodes[node] = Node {
            first: first as u32,
            count: INTERIOR,
        };
        for (c, list) in children.into_iter().enumerate() {
            let child_cell = child_box(&cell, mid, c);
            self.build_node(first + c, child_cell, list, depth + 1);
        }
    }

    /// Files each triangle of `tris` into the children of `cell` it touches.
    fn split(&self, cell: &Aabb, mid: Vec3, tris: &[u32]) -> [Vec<u32>; 8] {
        let mut children: [Vec<u32>; 8] = Default::default();
        let m = self.margin;
        for &t in tris {
            let b = &self.boxes[t as usize];
            // Which halves of each axis the triangle's box reaches (boundaries count on both).
            let mut sides = [[false; 2]; 3];
            for a in 0..3 {
                sides[a] = [b.min[a] <= mid[a] + m, b.max[a] >= mid[a] - m];
            }
            let candidates = (0..8usize).filter(|&c| (0..3).all(|a| sides[a][(c >> a) & 1]));
            let single = (0..3).all(|a| !(sides[a][0] && sides[a][1]));
            for c in candidates {
                if single {
                    children[c].push(t);
                    continue;
                }
                let cb = child_box(cell, mid, c);
                let half = (cb.max - cb.min) * 0.5 + Vec3::splat(m);
                if triangle_box_overlap(cb.center(), half, &self.triangles[t as usize]) {
                    children[c].push(t);
                }
            }
        }
        children
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
