//! Which children of a cell a primitive is filed in when the cell is split.
//!
//! [`ChildCells`] holds a cell's eight children as the tests need them (their boxes grown by the
//! build's margin, and per axis the two grown halves); [`Filing`] holds the primitives and
//! answers [`Filing::children_touched`]. The answer for one primitive comes in three steps, each
//! exact, from cheap to dear:
//! 1. Its box against the centre planes (exact comparisons, no margin) gives the candidate
//!    children. A box on one side of every plane has one candidate, and the parent's test
//!    already said the primitive touches the parent, so that is the answer.
//! 2. For a triangle, every child whose grown box holds one of its vertices is touched: each
//!    vertex is placed in the grown halves of each axis (four comparisons of three lanes per
//!    vertex, however many candidates there are).
//!
//!    Steps 1 and 2 compare all three axes in the lanes of one [`Vec3A`] and look the children
//!    up in [`REACHED`] by which sides of the planes were reached.
//! 3. The remaining candidates get the separating-axis test (triangles, `overlap.rs`), the
//!    sphere-surface test (lone spheres), the axis test (lone cylinders and cones) or the box
//!    test (other solids).
//!
//! A triangle touches a child exactly when the child's grown box (its sides included) holds a
//! vertex or the separating-axis test finds no separating axis: the same answer as testing each
//! candidate child on its own, which the tests below check.

use super::child_box;
use super::overlap::{segment_box_overlap, sphere_surface_box_overlap, triangle_box_overlap};
use crate::geom::solid::extent::SolidExtent;
use crate::math::aabb::Aabb;
use alloc::vec::Vec;
use glam::{BVec3A, Vec3, Vec3A};

/// Per axis, the children on its upper side (bit `a` of the child's index set).
const UPPER: [u8; 3] = [0xAA, 0xCC, 0xF0];

/// The children a point or a box may be in, by which sides of the centre planes it reaches:
/// entry `lower | upper << 3`, where bit `a` of `lower` (of `upper`) says it reaches the lower
/// (upper) side of axis `a`'s plane, is the children on a reached side of every axis.
const REACHED: [u8; 64] = {
    let mut table = [0u8; 64];
    let mut k = 0;
    while k < 64 {
        let mut mask = 0xFFu8;
        let mut a = 0;
        while a < 3 {
            let lower = if k >> a & 1 == 1 { !UPPER[a] } else { 0 };
            let upper = if k >> (a + 3) & 1 == 1 { UPPER[a] } else { 0 };
            mask &= lower | upper;
            a += 1;
        }
        table[k] = mask;
        k += 1;
    }
    table
};

/// [`REACHED`] for the sides given as lane masks (lane `a` for axis `a`).
#[inline]
fn reached(lower: BVec3A, upper: BVec3A) -> u8 {
    REACHED[(lower.bitmask() | upper.bitmask() << 3) as usize]
}

/// The eight children of a cell split at its centre, as the filing tests need them.
pub(super) struct ChildCells {
    mid: Vec3A,
    /// Each child's centre, and its half size grown by the margin, for the separating-axis
    /// test.
    centers: [Vec3; 8],
    halves: [Vec3; 8],
    /// Each child's box grown by the margin: (lower corner, upper corner).
    grown: [(Vec3, Vec3); 8],
    /// The lower and the upper half of the cell grown by the margin, each as (low, high) per
    /// axis: the same numbers as the grown boxes' sides.
    lower: (Vec3A, Vec3A),
    upper: (Vec3A, Vec3A),
}

impl ChildCells {
    /// The children of `cell`, each grown by `margin`.
    pub(super) fn new(cell: &Aabb, margin: f32) -> ChildCells {
        let mid = cell.center();
        let m = Vec3::splat(margin);
        let boxes: [Aabb; 8] = core::array::from_fn(|c| child_box(cell, mid, c));
        let grown = boxes.map(|b| (b.min - m, b.max + m));
        let (lower, upper) = (grown[0], grown[7]);
        ChildCells {
            mid: mid.into(),
            centers: boxes.map(|b| b.center()),
            halves: boxes.map(|b| (b.max - b.min) * 0.5 + m),
            grown,
            lower: (lower.0.into(), lower.1.into()),
            upper: (upper.0.into(), upper.1.into()),
        }
    }

    /// The children whose grown box holds the point `v` (bit `c` for child `c`): per axis the
    /// halves that hold its coordinate, intersected over the axes.
    #[inline]
    fn holding(&self, v: Vec3A) -> u8 {
        let inside = |(lo, hi): (Vec3A, Vec3A)| v.cmpge(lo) & v.cmple(hi);
        reached(inside(self.lower), inside(self.upper))
    }

    /// The children the box `min..max` may reach, by exact comparisons with the centre planes,
    /// and whether it straddles one of them. A box on one side of a plane, touching it or lying
    /// in it, goes to that side only: its points on the plane are in that side's closed cells
    /// too, and the walk visits the cells on both sides of every point of a ray's path that lies
    /// on a centre plane (see `traverse.rs`).
    #[inline]
    fn candidates(&self, min: Vec3A, max: Vec3A) -> (u8, bool) {
        let lower = min.cmplt(self.mid);
        let upper = max.cmpgt(self.mid) | !lower;
        (reached(lower, upper), (lower & upper).any())
    }
}

/// The primitives as the build files them: triangles (indices `0..T`), then solids.
pub(super) struct Filing<'a> {
    pub(super) triangles: &'a [[Vec3; 3]],
    /// Each solid's reject box (where its test can hit; `SolidExtent::reach`), empty for an
    /// unbounded one.
    pub(super) reach: Vec<Aabb>,
    /// How each solid is filed (primitive `T + j` is solid `j`).
    pub(super) solids: &'a [SolidExtent],
    /// How far every cell is grown before the overlap test: the rounding error bound of the test
    /// at the scene's magnitude, so the test never misses a primitive that reaches into a cell.
    pub(super) margin: f32,
}

impl Filing<'_> {
    /// Which of the children `cells` primitive `t`, filed in their parent, touches: bit `c` for
    /// child `c`.
    #[inline]
    pub(super) fn children_touched(&self, cells: &ChildCells, t: usize) -> u8 {
        match self.triangles.get(t) {
            Some(p) => self.triangle_children(cells, p),
            None => self.solid_children(cells, t - self.triangles.len()),
        }
    }

    /// [`Filing::children_touched`] for the triangle `p`. Its box is computed from its vertices
    /// (the same comparisons as with a stored box), so the build loads one record per triangle.
    #[inline]
    fn triangle_children(&self, cells: &ChildCells, p: &[Vec3; 3]) -> u8 {
        let v = p.map(Vec3A::from);
        let (min, max) = (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2]));
        let (candidates, straddles) = cells.candidates(min, max);
        if !straddles {
            return candidates;
        }
        let held = candidates & (cells.holding(v[0]) | cells.holding(v[1]) | cells.holding(v[2]));
        let mut mask = held;
        for c in bits(candidates & !held) {
            mask |= u8::from(triangle_box_overlap(cells.centers[c], cells.halves[c], p)) << c;
        }
        mask
    }

    /// [`Filing::children_touched`] for solid `j`.
    fn solid_children(&self, cells: &ChildCells, j: usize) -> u8 {
        let b = &self.reach[j];
        let (candidates, straddles) = cells.candidates(b.min.into(), b.max.into());
        if !straddles {
            return candidates;
        }
        let mut mask = 0;
        for c in bits(candidates) {
            let (lo, hi) = cells.grown[c];
            mask |= u8::from(self.solid_touches(j, lo, hi)) << c;
        }
        mask
    }

    /// True if solid `j` touches the grown box `lo..hi`: a lone sphere where its surface is, a
    /// lone cylinder or cone near its axis and within its reject box, another solid by its reject
    /// box.
    fn solid_touches(&self, j: usize, lo: Vec3, hi: Vec3) -> bool {
        let reach = &self.reach[j];
        let in_reach = || reach.min.cmple(hi).all() && reach.max.cmpge(lo).all();
        match self.solids.get(j) {
            Some(&SolidExtent::Sphere {
                center,
                radius,
                margin,
                ..
            }) => sphere_surface_box_overlap(center, radius, margin, lo, hi),
            Some(&SolidExtent::Cone {
                a,
                b,
                radius,
                margin,
                ..
            }) => in_reach() && segment_box_overlap(a, b, radius + margin, lo, hi),
            _ => in_reach(),
        }
    }
}

/// The indices of the bits set in `mask`, lowest first.
pub(super) fn bits(mut mask: u8) -> impl Iterator<Item = usize> {
    core::iter::from_fn(move || {
        let c = mask.trailing_zeros() as usize;
        mask &= mask.wrapping_sub(1);
        (c < 8).then_some(c)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::octree::xorshift;
    use crate::geom::solid::extent::reject_box;

    /// Which children primitive `t` touches, child by child: a candidate (its box reaches the
    /// child's side of every centre plane, or lies on no other side) that holds a vertex in
    /// its grown box or passes the separating-axis test; a solid by its own test. `boxes` are
    /// every primitive's (a triangle's, then a solid's reject box).
    fn touched_child_by_child(f: &Filing, boxes: &[Aabb], cell: &Aabb, t: usize) -> u8 {
        let mid = cell.center();
        let b = &boxes[t];
        let m = Vec3::splat(f.margin);
        let mut mask = 0;
        for c in 0..8 {
            let candidate = (0..3).all(|a| {
                let lower_side = b.min[a] < mid[a];
                let upper_side = b.max[a] > mid[a] || !lower_side;
                if c >> a & 1 == 1 {
                    upper_side
                } else {
                    lower_side
                }
            });
            if !candidate {
                continue;
            }
            let cb = child_box(cell, mid, c);
            let (lo, hi) = (cb.min - m, cb.max + m);
            let touched = match f.triangles.get(t) {
                Some(p) => {
                    p.iter().any(|v| v.cmpge(lo).all() && v.cmple(hi).all())
                        || triangle_box_overlap(cb.center(), (cb.max - cb.min) * 0.5 + m, p)
                }
                None => f.solid_touches(t - f.triangles.len(), lo, hi),
            };
            mask |= u8::from(touched) << c;
        }
        mask
    }

    /// Coordinates around the cell `0..4` on every axis: its faces and centre planes, the grown
    /// children's sides, values a rounding step off them, and values spread between and beyond.
    fn coordinates() -> impl FnMut() -> f32 {
        let mut next = xorshift(0x2545_f491);
        move || {
            let state = next();
            // The planes, the grown cells' sides (margin 1e-5), and a rounding step past them.
            let special = [
                0.0,
                2.0,
                4.0,
                -1e-5,
                2.0 - 1e-5,
                2.0 + 1e-5,
                4.0 + 1e-5,
                2.000_001,
                1.999_999,
                4.000_001,
            ];
            if state % 4 == 0 {
                special[(state >> 8) as usize % special.len()]
            } else {
                (state as f32 / u32::MAX as f32) * 6.0 - 1.0
            }
        }
    }

    fn point(next: &mut impl FnMut() -> f32) -> Vec3 {
        Vec3::new(next(), next(), next())
    }

    #[test]
    fn children_touched_is_the_child_by_child_answer() {
        let mut next = coordinates();
        // Small triangles near the planes and large ones across the cell.
        let triangles: Vec<[Vec3; 3]> = (0..30_000)
            .map(|i| {
                let a = point(&mut next);
                let scale = if i % 2 == 0 { 0.3 } else { 1.0 };
                [
                    a,
                    a + (point(&mut next) - a) * scale,
                    a + (point(&mut next) - a) * scale,
                ]
            })
            .collect();
        let solids: Vec<SolidExtent> = (0..3_000)
            .map(|i| {
                let (center, radius) = (point(&mut next), next().abs() * 0.8 + 0.05);
                let bounds = Aabb {
                    min: center - Vec3::splat(radius),
                    max: center + Vec3::splat(radius),
                };
                let margin = 1e-4;
                match i % 3 {
                    0 => SolidExtent::Sphere {
                        bounds,
                        center,
                        radius,
                        margin,
                    },
                    // A cylinder along the box's diagonal.
                    1 => SolidExtent::Cone {
                        bounds,
                        a: bounds.min + Vec3::splat(radius * 0.3),
                        b: bounds.max - Vec3::splat(radius * 0.3),
                        radius: radius * 0.3,
                        margin,
                    },
                    _ => SolidExtent::Box(bounds),
                }
            })
            .collect();
        let reach: Vec<Aabb> = solids
            .iter()
            .map(|s| reject_box(&s.bounds().unwrap_or(Aabb::EMPTY)))
            .collect();
        let mut boxes: Vec<Aabb> = triangles.iter().map(Aabb::of_triangle).collect();
        boxes.extend_from_slice(&reach);
        let filing = Filing {
            triangles: &triangles,
            reach,
            solids: &solids,
            margin: 1e-5,
        };
        let cell = Aabb {
            min: Vec3::ZERO,
            max: Vec3::splat(4.0),
        };
        let cells = ChildCells::new(&cell, filing.margin);
        let mut counts = [0usize; 9];
        let (lo, hi) = (
            cell.min - Vec3::splat(filing.margin),
            cell.max + Vec3::splat(filing.margin),
        );
        let in_parent = |t: usize| match triangles.get(t) {
            Some(p) => {
                p.iter().any(|v| v.cmpge(lo).all() && v.cmple(hi).all())
                    || triangle_box_overlap(cell.center(), (hi - lo) * 0.5, p)
            }
            None => filing.solid_touches(t - triangles.len(), lo, hi),
        };
        // The primitives filed in the cell, as its parent's filing would have.
        for t in (0..triangles.len() + solids.len()).filter(|&t| in_parent(t)) {
            let got = filing.children_touched(&cells, t);
            assert_eq!(
                got,
                touched_child_by_child(&filing, &boxes, &cell, t),
                "primitive {t}"
            );
            counts[got.count_ones() as usize] += 1;
        }
        // Every number of children from one to all eight occurs.
        assert!(counts[1..].iter().all(|&n| n > 500), "{counts:?}");
    }
}
