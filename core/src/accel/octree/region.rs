//! The tree's cells for structures built beside the octree: which primitives the tree files near
//! a region, for those that must know every primitive a ray could meet inside a box
//! (`accel::sphere_interiors`), and its occupied cells from the root down, for those that must
//! know where a ray can meet any (`accel::camera_cover`).

use super::overlap::cell_margin;
use super::{child_box, Node, Octree, MAX_DEPTH_LIMIT};
use crate::math::aabb::Aabb;
use alloc::vec::Vec;

impl Octree {
    /// The primitives filed in a leaf whose cell meets `region` (closed boxes: touching counts),
    /// and the large ones kept out of the tree, sorted, each once. A primitive is filed in every
    /// cell that holds a point of it (see `build.rs`), so every primitive with a point in
    /// `region` and in the root cell is among them.
    pub fn filed_in(&self, region: &Aabb) -> Vec<u32> {
        let mut found = self.large.clone();
        if self.nodes.is_empty() || !self.root.meets(region) {
            found.sort_unstable();
            return found;
        }
        // Each level pushes at most eight cells and pops one.
        let mut stack = Vec::with_capacity(8 * MAX_DEPTH_LIMIT as usize + 1);
        stack.push((0u32, self.root));
        while let Some((index, cell)) = stack.pop() {
            let node = self.nodes[index as usize];
            if node.is_leaf() {
                let start = node.first as usize;
                found.extend_from_slice(&self.indices[start..start + node.count as usize]);
                continue;
            }
            let mid = cell.center();
            for c in 0..8 {
                let child = child_box(&cell, mid, c);
                if node.child_occupied(c) && child.meets(region) {
                    stack.push((node.first + c as u32, child));
                }
            }
        }
        found.sort_unstable();
        found.dedup();
        found
    }

    /// Visits the cells that hold a primitive from the root down, depth first: `visit(cell,
    /// node)` gets each one's box (the walk's, to the bit) and node, and says whether to go on
    /// into an interior node's children. Empty leaves are not visited: the walk finds nothing
    /// in them.
    pub fn descend(&self, mut visit: impl FnMut(&Aabb, &Node) -> bool) {
        let Some(&root) = self.nodes.first() else {
            return;
        };
        // Each level pushes at most eight cells and pops one.
        let mut stack = Vec::with_capacity(8 * MAX_DEPTH_LIMIT as usize + 1);
        stack.push((root, self.root));
        while let Some((node, cell)) = stack.pop() {
            let empty = node.is_leaf() && node.count == 0;
            if empty || !visit(&cell, &node) || node.is_leaf() {
                continue;
            }
            let mid = cell.center();
            for c in (0..8).filter(|&c| node.child_occupied(c)) {
                let child = self.nodes[node.first as usize + c];
                stack.push((child, child_box(&cell, mid, c)));
            }
        }
    }

    /// How far the build grows every cell before it files a primitive in it, in world units
    /// (the build's own [`cell_margin`]). A primitive's test reports hits where it lies, to
    /// within this: the walk visits only cells that hold a primitive, and so does every
    /// structure that relies on the tree's filing.
    pub fn margin(&self) -> f32 {
        cell_margin(&self.root)
    }
}

#[cfg(test)]
mod tests {
    use super::super::OctreeParams;
    use super::*;
    use crate::math::float::gamma;
    use glam::Vec3;

    /// A row of small triangles along x, one per unit.
    fn row(n: usize) -> Vec<[Vec3; 3]> {
        (0..n)
            .map(|i| {
                let x = i as f32;
                [
                    Vec3::new(x, 0.0, 0.0),
                    Vec3::new(x + 0.5, 0.0, 0.0),
                    Vec3::new(x, 0.5, 0.5),
                ]
            })
            .collect()
    }

    #[test]
    fn finds_every_primitive_in_the_region_and_few_others() {
        let triangles = row(64);
        let tree = Octree::build(&triangles, &OctreeParams::default());
        assert!(tree.stats().depth >= 3, "the test needs a split tree");
        for lo in [0usize, 10, 31, 63] {
            let region = Aabb {
                min: Vec3::new(lo as f32 + 0.1, -1.0, -1.0),
                max: Vec3::new(lo as f32 + 0.2, 1.0, 1.0),
            };
            let found = tree.filed_in(&region);
            assert!(found.contains(&(lo as u32)), "{lo}: {found:?}");
            // The leaves around one triangle hold a few of its neighbours, not the row.
            assert!(found.len() < 16, "{lo}: {found:?}");
            assert!(found.windows(2).all(|w| w[0] < w[1]), "sorted, each once");
        }
        let outside = Aabb {
            min: Vec3::splat(100.0),
            max: Vec3::splat(101.0),
        };
        assert!(tree.filed_in(&outside).is_empty());
    }

    /// The margin grows with the root's largest coordinate: a thousand times the scene, a
    /// thousand times the margin (to the rounding of the root cell).
    #[test]
    fn margin_scales_with_the_root() {
        let triangles = row(8);
        let far: Vec<[Vec3; 3]> = triangles.iter().map(|t| t.map(|p| p * 1000.0)).collect();
        let params = OctreeParams::default();
        let (near, far) = (
            Octree::build(&triangles, &params).margin(),
            Octree::build(&far, &params).margin(),
        );
        // The root of this row reaches x = 7.5.
        assert!(near > 7.5 * gamma(1) && near < 8.0 * gamma(64), "{near}");
        assert!((far / near / 1000.0 - 1.0).abs() < 1e-5, "{near} {far}");
    }
}
