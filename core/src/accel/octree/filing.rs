//! Which children of a cell a primitive is filed in when the cell is split.
//!
//! [`ChildCells`] holds a cell's eight children as the tests need them (their boxes grown by the
//! build's margin, per axis the two grown halves, and their centres relative to the cell's);
//! [`Filing`] holds the primitives and answers [`Filing::children_touched`]. The answer for one
//! primitive comes in three steps, from cheap to dear:
//! 1. Its box against the centre planes (exact comparisons, no margin) gives the candidate
//!    children. A box on one side of every plane has one candidate, and the parent's test
//!    already said the primitive touches the parent, so that is the answer.
//! 2. For a triangle, every child whose grown box holds one of its vertices is touched: each
//!    vertex is placed in the grown halves of each axis (four comparisons of three lanes per
//!    vertex, however many candidates there are).
//!
//!    Steps 1 and 2 compare all three axes in the lanes of one [`Vec3A`] and look the children
//!    up in [`REACHED`] by which sides of the planes were reached.
//! 3. The remaining candidates get the separating-axis test (triangles: the triangle's axes and
//!    its extent along them made once, [`TriangleAxes`], then each child's offset projected),
//!    the sphere-surface test (lone spheres), the axis test (lone cylinders and cones) or the
//!    box test (other solids). The solids' tests look at a box one axis at a time, so each
//!    axis's lower and upper side is looked at once for all the children
//!    ([`ChildCells::sides`]): a sphere's eight children are then answered together in lanes
//!    ([`sphere_surface_children`]), another solid's candidates one by one
//!    ([`ChildCells::children_where`]).
//!
//! A triangle is filed in every candidate child it touches and in none it misses by more than
//! twice the margin (the margin covers the test's rounding; the tests below check both against
//! the test in `f64`, also for triangles that touch a child at a corner alone).

use super::overlap::{
    axis_terms, segment_within, slab_interval, sphere_surface_children, TriangleAxes,
};
use crate::accel::prefetch::prefetch;
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
    /// Each child's centre relative to `mid`, and the largest of their half sizes grown by the
    /// margin, for the separating-axis test ([`TriangleAxes`]).
    offsets: [Vec3A; 8],
    half: Vec3A,
    /// Each child's box grown by the margin: (lower corner, upper corner).
    grown: [(Vec3A, Vec3A); 8],
    /// The lower and the upper half of the cell grown by the margin, each as (low, high) per
    /// axis: the same numbers as the grown boxes' sides.
    lower: (Vec3A, Vec3A),
    upper: (Vec3A, Vec3A),
}

impl ChildCells {
    /// The children of `cell`, each grown by `margin`. Each child's numbers are lane by lane
    /// those of the cell's lower or upper half, the same as from its box (`child_box`).
    pub(super) fn new(cell: &Aabb, margin: f32) -> ChildCells {
        let (min, max) = (Vec3A::from(cell.min), Vec3A::from(cell.max));
        let mid = (min + max) * 0.5;
        let m = Vec3A::splat(margin);
        let lower = (min - m, mid + m);
        let upper = (mid - m, max + m);
        let (below, above) = ((min + mid) * 0.5 - mid, (mid + max) * 0.5 - mid);
        let child = |c: usize| BVec3A::new(c & 1 != 0, c & 2 != 0, c & 4 != 0);
        let pick = |c: usize, (a, b): (Vec3A, Vec3A)| Vec3A::select(child(c), b, a);
        ChildCells {
            mid,
            offsets: core::array::from_fn(|c| pick(c, (below, above))),
            half: ((mid - min) * 0.5).max((max - mid) * 0.5) + m,
            grown: core::array::from_fn(|c| {
                (pick(c, (lower.0, upper.0)), pick(c, (lower.1, upper.1)))
            }),
            lower,
            upper,
        }
    }

    /// The children whose grown box holds the point `v` (bit `c` for child `c`): per axis the
    /// halves that hold its coordinate, intersected over the axes.
    #[inline]
    fn holding(&self, v: Vec3A) -> u8 {
        let inside = |(lo, hi): (Vec3A, Vec3A)| v.cmpge(lo) & v.cmple(hi);
        reached(inside(self.lower), inside(self.upper))
    }

    /// Per axis `a`, `side(a, l, h)` of the side `l..h` of the cell's lower and upper grown
    /// half along it.
    #[inline]
    fn sides<T>(&self, side: impl Fn(usize, f32, f32) -> T) -> [[T; 2]; 3] {
        core::array::from_fn(|a| {
            let half = |(lo, hi): (Vec3A, Vec3A)| side(a, lo[a], hi[a]);
            [half(self.lower), half(self.upper)]
        })
    }

    /// The children among `candidates` whose grown box passes `test`, where a child's box is
    /// its sides along the three axes, each a side of the cell's lower or upper grown half:
    /// `side(a, l, h)` says what a test needs of the side `l..h` along axis `a`, and is asked
    /// once for each of the six halves; `test` gets a child's three answers, axis by axis. So a
    /// test that looks at a box one axis at a time gives each child the answer it gives that
    /// child's box, to the bit, with six sides computed where each child took three.
    #[inline]
    fn children_where<T: Copy>(
        &self,
        candidates: u8,
        side: impl Fn(usize, f32, f32) -> T,
        test: impl Fn([T; 3]) -> bool,
    ) -> u8 {
        let sides = self.sides(side);
        let mut mask = 0;
        for c in bits(candidates) {
            mask |= u8::from(test(core::array::from_fn(|a| sides[a][c >> a & 1]))) << c;
        }
        mask
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

    /// Asks for primitive `t`'s record ([`prefetch`]), which [`Filing::children_touched`]
    /// reads.
    #[inline(always)]
    pub(super) fn prefetch(&self, t: usize) {
        match self.triangles.get(t) {
            Some(p) => {
                // Both ends: a record of 36 bytes often spans two cache lines.
                prefetch(&p[0]);
                prefetch(&p[2].z);
            }
            None => {
                if let Some(b) = self.reach.get(t - self.triangles.len()) {
                    prefetch(b);
                }
            }
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
        let rest = candidates & !held;
        if rest == 0 {
            return held;
        }
        let axes = TriangleAxes::new(p, cells.mid, cells.half);
        let mut mask = held;
        for c in bits(rest) {
            let (lo, hi) = cells.grown[c];
            mask |= u8::from(!axes.misses(cells.offsets[c], lo, hi)) << c;
        }
        mask
    }

    /// [`Filing::children_touched`] for solid `j`: among the candidates, the children it
    /// touches: a lone sphere where its surface is, a lone cylinder or cone near its axis and
    /// within its reject box, another solid by its reject box. Each test looks at a box one axis
    /// at a time, so each axis's two sides are computed once ([`ChildCells::sides`]);
    /// the tests check every answer against `solid_touches`, the same tests on one child's box.
    fn solid_children(&self, cells: &ChildCells, j: usize) -> u8 {
        let reach = &self.reach[j];
        let (candidates, straddles) = cells.candidates(reach.min.into(), reach.max.into());
        if !straddles {
            return candidates;
        }
        // The reject box meets a box where it meets each of its sides (`Aabb::meets`).
        let meets = |a: usize, l: f32, h: f32| reach.min[a] <= h && reach.max[a] >= l;
        match self.solids.get(j) {
            Some(&SolidExtent::Sphere {
                center,
                radius,
                margin,
                ..
            }) => {
                let terms = cells.sides(|a, l, h| axis_terms(center[a], l, h));
                candidates & sphere_surface_children(radius, margin, terms)
            }
            Some(&SolidExtent::Cone {
                a: from,
                b: to,
                radius,
                margin,
                ..
            }) => cells.children_where(
                candidates,
                |a, l, h| {
                    (
                        meets(a, l, h),
                        slab_interval(from[a], to[a], radius + margin, l, h),
                    )
                },
                |sides| sides.iter().all(|s| s.0) && segment_within(sides.map(|s| s.1)),
            ),
            _ => cells.children_where(candidates, meets, |sides| sides.iter().all(|&m| m)),
        }
    }

    /// True if solid `j` touches the grown box `lo..hi`, as [`Filing::solid_children`] decides
    /// for a child: the tests' reference, one box at a time.
    #[cfg(test)]
    fn solid_touches(&self, j: usize, lo: Vec3, hi: Vec3) -> bool {
        let reach = &self.reach[j];
        let in_reach = || reach.meets(&Aabb { min: lo, max: hi });
        match self.solids.get(j) {
            Some(&SolidExtent::Sphere {
                center,
                radius,
                margin,
                ..
            }) => super::overlap::sphere_surface_box_overlap(center, radius, margin, lo, hi),
            Some(&SolidExtent::Cone {
                a,
                b,
                radius,
                margin,
                ..
            }) => in_reach() && super::overlap::segment_box_overlap(a, b, radius + margin, lo, hi),
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
    use crate::accel::octree::child_box;
    use crate::accel::octree::overlap::{cell_margin, touches_in_f64};
    use crate::accel::octree::xorshift;
    use crate::geom::solid::extent::reject_box;
    use crate::math::float::{next_float_down, next_float_up};

    /// The children of `cell` whose side of every centre plane the box `b` reaches (or lies on
    /// no other side of): where a primitive with that box may be filed.
    fn candidates(cell: &Aabb, b: &Aabb) -> u8 {
        let mid = cell.center();
        (0..8).fold(0, |mask, c| {
            let candidate = (0..3).all(|a| {
                let lower_side = b.min[a] < mid[a];
                let upper_side = b.max[a] > mid[a] || !lower_side;
                if c >> a & 1 == 1 {
                    upper_side
                } else {
                    lower_side
                }
            });
            mask | u8::from(candidate) << c
        })
    }

    /// Checks the children `got` that primitive `t` (box `b`), filed in `cell`, was given, child
    /// by child: a triangle is given every candidate child it touches (in `f64`, on the child's
    /// own box) and none it misses by more than twice the margin; a solid the candidates its own
    /// test finds.
    fn check_children(f: &Filing, b: &Aabb, cell: &Aabb, t: usize, got: u8) {
        let mid = cell.center();
        let m = Vec3::splat(f.margin);
        let candidates = candidates(cell, b);
        for c in 0..8 {
            let cb = child_box(cell, mid, c);
            let given = got >> c & 1 == 1;
            let Some(p) = f.triangles.get(t) else {
                let touched = f.solid_touches(t - f.triangles.len(), cb.min - m, cb.max + m);
                assert_eq!(
                    given,
                    candidates >> c & 1 == 1 && touched,
                    "solid {t}, child {c}"
                );
                continue;
            };
            if candidates >> c & 1 == 1 && touches_in_f64(p, cb.min, cb.max) {
                assert!(given, "triangle {t} {p:?} touches child {c} of {cell:?}");
            }
            if given {
                let near = touches_in_f64(p, cb.min - m * 2.0, cb.max + m * 2.0);
                assert!(near, "triangle {t} {p:?} is far from child {c} of {cell:?}");
            }
        }
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

    /// Triangles and solids in and around the cell `0..4` moved by `corner`.
    fn primitives(corner: Vec3) -> (Vec<[Vec3; 3]>, Vec<SolidExtent>) {
        let mut next = coordinates();
        let mut point = move || point(&mut next) + corner;
        // Small triangles near the planes and large ones across the cell.
        let triangles: Vec<[Vec3; 3]> = (0..30_000)
            .map(|i| {
                let a = point();
                let scale = if i % 2 == 0 { 0.3 } else { 1.0 };
                [a, a + (point() - a) * scale, a + (point() - a) * scale]
            })
            .collect();
        let mut next = coordinates();
        let solids: Vec<SolidExtent> = (0..3_000)
            .map(|i| {
                let (center, radius) = (point(), next().abs() * 0.8 + 0.05);
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
        (triangles, solids)
    }

    /// Files the primitives filed in the cell `0..4` moved by `corner` (as its parent's filing
    /// would have) in its children with the build's margin for that place, or `margin` if
    /// larger, and checks each answer; returns how often each number of children was given.
    fn file_and_check(corner: Vec3, margin: f32) -> [usize; 9] {
        let (triangles, solids) = primitives(corner);
        let reach: Vec<Aabb> = solids
            .iter()
            .map(|s| reject_box(&s.bounds().unwrap_or(Aabb::EMPTY)))
            .collect();
        let mut boxes: Vec<Aabb> = triangles.iter().map(Aabb::of_triangle).collect();
        boxes.extend_from_slice(&reach);
        let cell = Aabb {
            min: corner,
            max: corner + Vec3::splat(4.0),
        };
        let filing = Filing {
            triangles: &triangles,
            reach,
            solids: &solids,
            margin: margin.max(cell_margin(&cell)),
        };
        let cells = ChildCells::new(&cell, filing.margin);
        let mut counts = [0usize; 9];
        let (lo, hi) = (
            cell.min - Vec3::splat(filing.margin),
            cell.max + Vec3::splat(filing.margin),
        );
        let in_parent = |t: usize| match triangles.get(t) {
            Some(p) => touches_in_f64(p, lo, hi),
            None => filing.solid_touches(t - triangles.len(), lo, hi),
        };
        for t in (0..triangles.len() + solids.len()).filter(|&t| in_parent(t)) {
            let got = filing.children_touched(&cells, t);
            check_children(&filing, &boxes[t], &cell, t, got);
            counts[got.count_ones() as usize] += 1;
        }
        counts
    }

    #[test]
    fn children_touched_holds_every_child_touched_and_none_far() {
        // Around the origin, with a margin wider than the rounding, so that the coordinates
        // placed a rounding step off the grown children's sides are told apart.
        let counts = file_and_check(Vec3::ZERO, 1e-5);
        // Every number of children from one to all eight occurs.
        assert!(counts[1..].iter().all(|&n| n > 500), "{counts:?}");
        // Far from the origin, with the build's margin: there a rounding step is 2⁻¹⁴ (a
        // 65,536th of the cell's width), and the margin about 24 steps.
        let counts = file_and_check(Vec3::new(1000.0, -1000.0, 250.0), 0.0);
        assert!(counts[1..].iter().all(|&n| n > 100), "{counts:?}");
    }

    /// Triangles that touch the corner `k` of a box whose centre lies towards `−s` (a sign per
    /// axis) at that corner alone, with their vertices then moved by up to four rounding steps
    /// (`next` picks): one whose plane holds the corner inside the triangle (the plane's axis
    /// decides), and one with an edge through it (an edge axis decides).
    fn grazing(k: Vec3, s: Vec3, next: &mut impl FnMut() -> u32) -> [[Vec3; 3]; 2] {
        let mut size = || 0.25 * (1 + next() % 8) as f32;
        let (a, b, c) = (size(), size(), size());
        // Two directions square to `s`.
        let u = Vec3::new(a * s.x, -a * s.y, 0.0);
        let v = Vec3::new(0.0, b * s.y, -b * s.z);
        let mut nudge = |x: f32| {
            let steps = next() % 9;
            (0..steps % 5).fold(x, |x, _| {
                if steps > 4 {
                    next_float_up(x)
                } else {
                    next_float_down(x)
                }
            })
        };
        [
            [k + u * 2.0, k + v * 2.0, k - (u + v) * 2.0],
            [k + u, k - u, k + s * c],
        ]
        .map(|t| t.map(|p| Vec3::new(nudge(p.x), nudge(p.y), nudge(p.z))))
    }

    #[test]
    fn triangles_grazing_a_child_at_a_corner_are_filed_in_it() {
        let cell = Aabb {
            min: Vec3::new(1000.0, -1000.0, 250.0),
            max: Vec3::new(1004.0, -996.0, 254.0),
        };
        let mut triangles = Vec::new();
        let mut next = xorshift(0x1b87_3593);
        let mid = cell.center();
        for c in 0..8 {
            let b = child_box(&cell, mid, c);
            for corner in 0..8 {
                // Bit `a` of `corner` picks the upper side on axis `a`.
                let upper = glam::BVec3::new(corner & 1 != 0, corner & 2 != 0, corner & 4 != 0);
                let s = Vec3::select(upper, Vec3::ONE, -Vec3::ONE);
                let k = Vec3::select(upper, b.max, b.min);
                for _ in 0..400 {
                    triangles.extend(grazing(k, s, &mut next));
                }
            }
        }
        let filing = Filing {
            triangles: &triangles,
            reach: Vec::new(),
            solids: &[],
            margin: cell_margin(&cell),
        };
        let cells = ChildCells::new(&cell, filing.margin);
        let m = Vec3::splat(filing.margin);
        let mut grazes = 0;
        for (t, p) in triangles.iter().enumerate() {
            let got = filing.children_touched(&cells, t);
            check_children(&filing, &Aabb::of_triangle(p), &cell, t, got);
            // Children touched with no corner of the triangle in their grown box: decided by
            // the separating axes.
            grazes += (0..8)
                .filter(|&c| {
                    let b = child_box(&cell, mid, c);
                    let held = p
                        .iter()
                        .any(|v| v.cmpge(b.min - m).all() && v.cmple(b.max + m).all());
                    !held && touches_in_f64(p, b.min, b.max)
                })
                .count();
        }
        assert!(grazes > 10_000, "{grazes}");
    }
}
