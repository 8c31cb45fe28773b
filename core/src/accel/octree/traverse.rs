//! Octree traversal: the cells a ray crosses, nearest first, with a fixed-size stack.
//!
//! A cell is entered with the ray-parameter interval `[t0, t1]` in which the ray is inside it. The
//! three centre planes cut that interval into at most four pieces, one per child crossed; pieces
//! share their computed plane-crossing values, so they leave no gap, and each is widened by the
//! rounding error bound of that crossing so a ray near a plane visits both cells. Stack entries
//! hold no box: a cell's box is cut from its parent's when it is entered, with the build's own
//! `child_box`, so the walk's cells are the build's to the bit.

use super::build::child_box;
use super::{Hit, Octree, MAX_DEPTH_LIMIT};
use crate::accel::work::QueryWork;
use crate::geom::hit::{closer, RayHit};
use crate::geom::triangle::{intersect, RayFrame};
use crate::math::aabb::Aabb;
use crate::math::float::{gamma, MACHINE_EPSILON};
use crate::math::ray::Ray;
use glam::Vec3;

/// How much a piece of a ray's interval is widened, relatively, around a crossing of a centre
/// plane: twice the error bound of the three roundings in a crossing `(mid − o) · (1/d)`.
const WIDEN: f32 = 2.0 * gamma(3);

/// Each level pushes at most four cells and pops one.
const STACK_SIZE: usize = 3 * MAX_DEPTH_LIMIT as usize + 2;

/// The primitives one query has tested lately, direct-mapped by index. A primitive filed in
/// several cells the ray crosses is then tested once instead of once per cell, as long as no
/// other primitive took its slot in between. Skipping a repeat changes no answer: a test's hit
/// does not depend on the bound it is given, only whether it is reported (see
/// [`Octree::closest_hit_with`]), so a repeat could only report the same hit again or nothing.
struct Mailbox([u32; MAILBOX_SLOTS]);

const MAILBOX_SLOTS: usize = 16;

impl Mailbox {
    fn new() -> Self {
        // No primitive has index u32::MAX (indices count triangles and solids, both below it).
        Mailbox([u32::MAX; MAILBOX_SLOTS])
    }

    /// True the first time `i` is seen since its slot last held another primitive.
    #[inline(always)]
    fn first_visit(&mut self, i: u32) -> bool {
        let slot = &mut self.0[i as usize % MAILBOX_SLOTS];
        let first = *slot != i;
        *slot = i;
        first
    }
}

/// A cell waiting on the walk's stack: its node, the ray's interval `[t0, t1]` in it, its depth
/// and which child of its parent it is. Its box is not stored: it is derived from the parent's
/// when the cell is entered (see [`Path`]), so leaves and skipped cells never compute one.
#[derive(Clone, Copy, Default)]
struct Entry {
    node: u32,
    t0: f32,
    t1: f32,
    depth: u16,
    child: u16,
}

/// The box of the interior cell the walk entered last at each depth. The walk is depth first, so
/// the parent of a cell popped at depth `d` is the cell entered last at depth `d − 1`: its box
/// is `boxes[d − 1]`, and the child's is cut from it exactly as the build cut it.
struct Path {
    boxes: [Aabb; MAX_DEPTH_LIMIT as usize + 1],
}

impl Path {
    /// The box of the cell `e`, an interior node, which the walk enters now (remembered for its
    /// children).
    #[inline(always)]
    fn enter(&mut self, e: &Entry, root: Aabb) -> Aabb {
        let d = e.depth as usize;
        let cell = match d.checked_sub(1) {
            None => root,
            Some(up) => {
                let parent = &self.boxes[up];
                child_box(parent, parent.center(), e.child as usize)
            }
        };
        self.boxes[d] = cell;
        cell
    }
}

impl Octree {
    /// The closest hit of `ray` with `0 < t < t_max`: the smallest `t`, ties to the smallest
    /// triangle index, exactly as [`super::brute_force_closest_hit`] finds it.
    pub fn closest_hit(&self, triangles: &[[Vec3; 3]], ray: &Ray, t_max: f32) -> Option<Hit> {
        self.closest_hit_counted(triangles, ray, t_max, &mut QueryWork::default())
    }

    /// [`Octree::closest_hit`], adding the cells entered and the tests made to `work`.
    pub fn closest_hit_counted(
        &self,
        triangles: &[[Vec3; 3]],
        ray: &Ray,
        t_max: f32,
        work: &mut QueryWork,
    ) -> Option<Hit> {
        let frame = RayFrame::new(ray);
        self.closest_hit_with(ray, t_max, work, |i, bound| {
            intersect(&frame, &triangles[i as usize], bound)
        })
        .map(|(triangle, tri)| Hit { triangle, tri })
    }

    /// The closest hit of `ray` with `0 < t < t_max` among the filed primitives, each tested by
    /// `test(index, bound)`, which returns a hit with `t < bound` or `None`. Ties go to the
    /// smallest index, so the result does not depend on the order cells are visited in. The cells
    /// entered and the tests made are added to `work`.
    pub fn closest_hit_with<H: RayHit>(
        &self,
        ray: &Ray,
        t_max: f32,
        work: &mut QueryWork,
        mut test: impl FnMut(u32, f32) -> Option<H>,
    ) -> Option<(u32, H)> {
        let mut best: Option<(u32, H)> = None;
        // Tests are bounded by the best hit so far, loosened by four roundings so that only hits
        // that lose the comparison anyway are cut early (the winner stays exact).
        let mut bound = t_max;
        let mut mailbox = Mailbox::new();
        let mut tests = 0u64;
        work.octree_cells += self.walk(ray, t_max, |indices| {
            for &i in indices {
                if !mailbox.first_visit(i) {
                    continue;
                }
                tests += 1;
                if let Some(h) = test(i, bound) {
                    if closer(h.t(), i, &best) {
                        best = Some((i, h));
                        bound = bound.min(h.t() * (1.0 + 4.0 * MACHINE_EPSILON));
                    }
                }
            }
            // Cells that start beyond the best hit (plus its error bound) cannot hold a closer one.
            match &best {
                Some((_, b)) => b.t() + b.t_error(),
                None => f32::INFINITY,
            }
        });
        work.intersection_tests += tests;
        best
    }

    /// True if `ray` hits any triangle provably before `t_max`: `0 < t` and `t + t_error < t_max`
    /// (shadow rays: a surface the light lies on, within rounding, does not block it). Stops at
    /// the first hit.
    pub fn any_hit(&self, triangles: &[[Vec3; 3]], ray: &Ray, t_max: f32) -> bool {
        self.any_hit_counted(triangles, ray, t_max, &mut QueryWork::default())
    }

    /// [`Octree::any_hit`], adding the cells entered and the tests made to `work`.
    pub fn any_hit_counted(
        &self,
        triangles: &[[Vec3; 3]],
        ray: &Ray,
        t_max: f32,
        work: &mut QueryWork,
    ) -> bool {
        let frame = RayFrame::new(ray);
        self.any_hit_with(ray, t_max, work, |i| {
            intersect(&frame, &triangles[i as usize], t_max)
                .is_some_and(|h| h.t + h.t_error < t_max)
        })
    }

    /// True if `test(index)` holds for any filed primitive in a cell the ray crosses before
    /// `t_max`. Stops at the first. The cells entered and the tests made are added to `work`.
    pub fn any_hit_with(
        &self,
        ray: &Ray,
        t_max: f32,
        work: &mut QueryWork,
        mut test: impl FnMut(u32) -> bool,
    ) -> bool {
        let mut found = false;
        let mut mailbox = Mailbox::new();
        let mut tests = 0u64;
        work.octree_cells += self.walk(ray, t_max, |indices| {
            found = indices.iter().any(|&i| {
                let first = mailbox.first_visit(i);
                tests += u64::from(first);
                first && test(i)
            });
            if found {
                f32::NEG_INFINITY
            } else {
                f32::INFINITY
            }
        });
        work.intersection_tests += tests;
        found
    }

    /// Visits the non-empty leaves the ray crosses, nearest first. `leaf` gets each leaf's triangle
    /// indices and returns a cut-off: cells entered beyond it are skipped (`-∞` ends the walk).
    /// Returns how many cells it entered.
    fn walk(&self, ray: &Ray, t_max: f32, mut leaf: impl FnMut(&[u32]) -> f32) -> u64 {
        let inv_dir = Vec3::ONE / ray.dir;
        let Some((t0, t1)) = self.bounds.intersect(ray, inv_dir, t_max) else {
            return 0;
        };
        let mut cells = 0u64;
        // All-zero entries and boxes: the compiler clears them with one fill each.
        let mut stack = [Entry::default(); STACK_SIZE];
        let mut path = Path {
            boxes: [Aabb {
                min: Vec3::ZERO,
                max: Vec3::ZERO,
            }; MAX_DEPTH_LIMIT as usize + 1],
        };
        stack[0] = Entry {
            t0: t0 * (1.0 - WIDEN),
            t1,
            ..Entry::default()
        };
        let mut top = 1usize;
        let mut cutoff = f32::INFINITY;
        while top > 0 {
            top -= 1;
            let e = stack[top];
            if e.t0 > cutoff {
                if cutoff == f32::NEG_INFINITY {
                    return cells;
                }
                continue;
            }
            cells += 1;
            let node = self.nodes[e.node as usize];
            if node.is_leaf() {
                let start = node.first as usize;
                cutoff = leaf(&self.indices[start..start + node.count as usize]);
                continue;
            }
            let cell = path.enter(&e, self.bounds);
            top = push_children(ray, inv_dir, &e, node, cell.center(), &mut stack, top);
        }
        cells
    }
}

/// Pushes the occupied children of interior node `node` (entered as `e`, its centre `mid`) that
/// the ray crosses, farthest first, so the nearest is popped next; returns the new stack top.
/// The pieces of the entry's interval `[t0, c1], [c1, c2], ..., [cn, t1]` are cut at the ray's
/// crossings `c` of the centre planes and widened by [`WIDEN`] around each. They are written
/// straight into the stack, field by field: a piece array returned by value and copied (an
/// earlier version) made the processor wait for its stores on every interior cell.
#[inline(always)]
fn push_children(
    ray: &Ray,
    inv_dir: Vec3,
    e: &Entry,
    node: super::Node,
    mid: Vec3,
    stack: &mut [Entry; STACK_SIZE],
    mut top: usize,
) -> usize {
    // Where the ray crosses each centre plane, and on which side it starts.
    let mut cross = [f32::INFINITY; 3];
    let mut child = 0usize;
    for a in 0..3 {
        let d = ray.dir[a];
        let upper = if d == 0.0 {
            ray.origin[a] >= mid[a]
        } else {
            cross[a] = (mid[a] - ray.origin[a]) * inv_dir[a];
            if d > 0.0 {
                e.t0 >= cross[a]
            } else {
                e.t0 < cross[a]
            }
        };
        child |= (upper as usize) << a;
    }
    // Plane crossings inside the interval, in ray order.
    let mut events = [(f32::INFINITY, 0usize); 3];
    let mut n = 0;
    for (a, &c) in cross.iter().enumerate() {
        if c > e.t0 && c < e.t1 {
            events[n] = (c, a);
            n += 1;
        }
    }
    sort3(&mut events);
    // The last piece's child has crossed every plane; walk back from it.
    for &(_, a) in &events[..n] {
        child ^= 1 << a;
    }
    let mut end = e.t1;
    for k in (0..=n).rev() {
        let start = if k == 0 {
            e.t0
        } else {
            events[k - 1].0 * (1.0 - WIDEN)
        };
        if node.child_occupied(child) {
            stack[top] = Entry {
                node: node.first + child as u32,
                t0: start,
                t1: end,
                depth: e.depth + 1,
                child: child as u16,
            };
            top += 1;
        }
        if k > 0 {
            let (c, a) = events[k - 1];
            child ^= 1 << a;
            end = c * (1.0 + WIDEN);
        }
    }
    top
}

/// Sorts three (t, axis) pairs by t; infinities (unused slots) sort last.
#[inline]
fn sort3(v: &mut [(f32, usize); 3]) {
    if v[1].0 < v[0].0 {
        v.swap(0, 1);
    }
    if v[2].0 < v[1].0 {
        v.swap(1, 2);
    }
    if v[1].0 < v[0].0 {
        v.swap(0, 1);
    }
}
