//! Octree traversal: the cells a ray crosses or touches, nearest first, with a fixed-size stack.
//!
//! A cell is entered with the ray-parameter interval `[t0, t1]` in which the ray is inside it. The
//! three centre planes cut that interval into at most four pieces, one per child crossed; pieces
//! share their computed plane-crossing values, so they leave no gap, and each is widened by
//! twice the rounding error bound of that crossing so a ray near a plane visits both cells.
//! The build files a primitive that touches a centre plane from one side on that side only, so
//! the walk also visits every cell a ray touches at a single point: around crossings too close
//! to order (a ray through a cell's edge or corner) it visits the cells of every order, and a
//! ray lying in a centre plane visits both sides of it (see [`push_children`]). Stack entries
//! hold no box: a cell's box is cut from its parent's when it is entered, with the build's own
//! `child_box`, so the walk's cells are the build's to the bit.

use super::child_box;
use super::{Hit, Octree, MAX_DEPTH_LIMIT};
use crate::accel::work::QueryWork;
use crate::geom::hit::{Closest, RayHit, GROUP};
use crate::geom::triangle::{intersect, RayFrame};
use crate::math::aabb::Aabb;
use crate::math::float::gamma;
use crate::math::ray::Ray;
use glam::{Vec3, Vec3A};

/// How much a piece of a ray's interval is widened, relatively, around a crossing of a centre
/// plane: twice the error bound of the three roundings in a crossing `(mid − o) · (1/d)`.
pub(super) const WIDEN: f32 = 2.0 * gamma(3);

/// The stack entries a walk of a tree `depth` deep needs: each level pushes at most eight cells
/// (the four on the ray's path and, where crossings tie, the others around them) and pops one.
const fn stack_size(depth: u32) -> usize {
    7 * depth as usize + 2
}

/// Trees at most this deep (most scenes') are walked with a smaller stack and path, and trees at
/// most [`MIDDLE_DEPTH`] deep with a middle-sized one: every query clears its stack and path.
const SHALLOW_DEPTH: u32 = 10;
const MIDDLE_DEPTH: u32 = 14;

/// A walk whose stack and path are sized at compile time, for [`sized`] to pick the size.
pub(super) trait SizedWalk {
    /// What the walk returns.
    type Out;
    /// Runs the walk with a stack of `S` entries and a path of `P` boxes, enough for a tree
    /// `P − 1` deep (`S` = [`stack_size`]`(P − 1)`).
    fn run<const S: usize, const P: usize>(self) -> Self::Out;
}

/// Runs `walk` with the smallest of three stack and path sizes that fits a tree `depth` deep.
#[inline(always)]
pub(super) fn sized<W: SizedWalk>(depth: u32, walk: W) -> W::Out {
    if depth <= SHALLOW_DEPTH {
        walk.run::<{ stack_size(SHALLOW_DEPTH) }, { SHALLOW_DEPTH as usize + 1 }>()
    } else if depth <= MIDDLE_DEPTH {
        walk.run::<{ stack_size(MIDDLE_DEPTH) }, { MIDDLE_DEPTH as usize + 1 }>()
    } else {
        walk.run::<{ stack_size(MAX_DEPTH_LIMIT) }, { MAX_DEPTH_LIMIT as usize + 1 }>()
    }
}

/// The primitives one query has tested lately, direct-mapped by index. A primitive filed in
/// several cells the ray crosses is then tested once instead of once per cell, as long as no
/// other primitive took its slot in between. Skipping a repeat changes no answer: a test's hit
/// does not depend on the bound it is given, only whether it is reported (see
/// [`Octree::closest_hit_with`]), so a repeat could only report the same hit again or nothing.
pub(super) struct Mailbox([u32; MAILBOX_SLOTS]);

pub(super) const MAILBOX_SLOTS: usize = 16;

impl Mailbox {
    pub(super) fn new() -> Self {
        // No primitive has index u32::MAX (indices count triangles and solids, both below it).
        Mailbox([u32::MAX; MAILBOX_SLOTS])
    }

    /// True the first time `i` is seen since its slot last held another primitive.
    #[inline(always)]
    pub(super) fn first_visit(&mut self, i: u32) -> bool {
        let slot = &mut self.0[i as usize % MAILBOX_SLOTS];
        let first = *slot != i;
        *slot = i;
        first
    }
}

/// How [`Octree::closest_hit_grouped`] tests the primitives of a leaf.
pub trait GroupTests<H> {
    /// Primitive `index`'s hit with `t < bound`, or `None`.
    fn test(&mut self, index: u32, bound: f32) -> Option<H>;
    /// Tests the primitives `group` (at most [`GROUP`], each new to the query) and offers their
    /// hits to `closest`. A hit's `t` must not depend on the bound it was found with, only
    /// whether it is offered.
    fn test_group(&mut self, group: &[u32], closest: &mut Closest<H>);
    /// Tests every primitive of the leaf whose indices start at `start` in
    /// [`Octree::indices`], where the tests keep that leaf's primitives ready, and offers
    /// their hits to `closest`; returns how many it tested, or `None` to be handed the leaf's
    /// primitives new to the query by [`GroupTests::test_group`] instead.
    #[inline(always)]
    fn test_leaf(&mut self, start: u32, closest: &mut Closest<H>) -> Option<u64> {
        let _ = (start, closest);
        None
    }
}

/// How [`Octree::any_hit_grouped`] tests the primitives of a leaf.
pub trait GroupBlocks {
    /// True if primitive `index` blocks the ray.
    fn blocks(&mut self, index: u32) -> bool;
    /// A primitive of `group` (at most [`GROUP`], each new to the query) that blocks the ray,
    /// if any.
    fn blocks_group(&mut self, group: &[u32]) -> Option<u32>;
    /// For the leaf whose indices start at `start` in [`Octree::indices`], where the tests keep
    /// that leaf's primitives ready: a primitive of it that blocks the ray, if any, and how many
    /// were tested; `None` to be handed the leaf by [`GroupBlocks::blocks_group`] instead.
    #[inline(always)]
    fn blocks_leaf(&mut self, start: u32) -> Option<(Option<u32>, u64)> {
        let _ = start;
        None
    }
}

/// [`GroupTests`] and [`GroupBlocks`] that test a group one primitive at a time.
struct OneByOne<F>(F);

impl<F: FnMut(u32) -> bool> GroupBlocks for OneByOne<F> {
    #[inline(always)]
    fn blocks(&mut self, index: u32) -> bool {
        (self.0)(index)
    }

    #[inline(always)]
    fn blocks_group(&mut self, group: &[u32]) -> Option<u32> {
        group.iter().copied().find(|&i| (self.0)(i))
    }
}

impl<H: RayHit, F: FnMut(u32, f32) -> Option<H>> GroupTests<H> for OneByOne<F> {
    #[inline(always)]
    fn test(&mut self, index: u32, bound: f32) -> Option<H> {
        (self.0)(index, bound)
    }

    #[inline(always)]
    fn test_group(&mut self, group: &[u32], closest: &mut Closest<H>) {
        for &i in group {
            if let Some(h) = (self.0)(i, closest.bound()) {
                closest.offer(i, h);
            }
        }
    }
}

/// Hands the primitives of a leaf, `indices`, that are new to the query (`mailbox`) to `test`
/// up to [`GROUP`] at a time, until `test` says to stop; returns how many it handed.
#[inline(always)]
fn in_groups(indices: &[u32], mailbox: &mut Mailbox, mut test: impl FnMut(&[u32]) -> bool) -> u64 {
    let mut group = [0u32; GROUP];
    let (mut n, mut handed) = (0, 0u64);
    for &i in indices {
        if mailbox.first_visit(i) {
            group[n] = i;
            n += 1;
            if n == GROUP {
                handed += GROUP as u64;
                n = 0;
                if test(&group) {
                    return handed;
                }
            }
        }
    }
    if n > 0 {
        handed += n as u64;
        test(&group[..n]);
    }
    handed
}

/// A cell waiting on the walk's stack: its node, the ray's interval `[t0, t1]` in it, its depth
/// and which child of its parent it is. Its box is not stored: it is derived from the parent's
/// when the cell is entered (see [`Path`]), so leaves and skipped cells never compute one.
#[derive(Clone, Copy, Default)]
pub(super) struct Entry {
    pub(super) node: u32,
    pub(super) t0: f32,
    pub(super) t1: f32,
    pub(super) depth: u16,
    pub(super) child: u16,
}

/// The box of the interior cell the walk entered last at each depth. The walk is depth first, so
/// the parent of a cell popped at depth `d` is the cell entered last at depth `d − 1`: its box
/// is `boxes[d − 1]`, and the child's is cut from it exactly as the build cut it.
///
/// The corners are kept as 16-byte vectors, each written and read whole: a child is often
/// entered right after its parent, while the parent's box is still on its way to the cache, and
/// a read that spans two narrower writes cannot be served from them (the processor waits until
/// they reach the cache: 17.8 against 15.5 ns per cell, teapot_12's primary rays walked with a
/// test that never hits).
pub(super) struct Path<const P: usize> {
    boxes: [(Vec3A, Vec3A); P],
}

impl<const P: usize> Path<P> {
    pub(super) fn new() -> Self {
        Path {
            boxes: [(Vec3A::ZERO, Vec3A::ZERO); P],
        }
    }

    /// The box of the cell at `depth` that is child `child` of the cell entered last one level
    /// up, an interior node the walk enters now (remembered for its children).
    #[inline(always)]
    pub(super) fn enter(&mut self, depth: u16, child: u16, root: Aabb) -> Aabb {
        let d = depth as usize;
        let cell = match d.checked_sub(1) {
            None => root,
            Some(up) => {
                let (min, max) = self.boxes[up];
                let parent = Aabb {
                    min: min.into(),
                    max: max.into(),
                };
                child_box(&parent, parent.center(), child as usize)
            }
        };
        self.boxes[d] = (cell.min.into(), cell.max.into());
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
        test: impl FnMut(u32, f32) -> Option<H>,
    ) -> Option<(u32, H)> {
        self.closest_hit_grouped(ray, t_max, work, &mut OneByOne(test))
    }

    /// [`Octree::closest_hit_with`] for tests that go faster together: a leaf of at least
    /// [`GROUP`] primitives (more than the build leaves unsplit where splits pay) is tested by
    /// [`GroupTests::test_group`], up to [`GROUP`] at a time, a smaller one by
    /// [`GroupTests::test`].
    pub fn closest_hit_grouped<H: RayHit>(
        &self,
        ray: &Ray,
        t_max: f32,
        work: &mut QueryWork,
        tests_of: &mut impl GroupTests<H>,
    ) -> Option<(u32, H)> {
        let mut closest = Closest::new(t_max);
        for &i in &self.large {
            if let Some(h) = tests_of.test(i, closest.bound()) {
                closest.offer(i, h);
            }
        }
        let mut mailbox = Mailbox::new();
        let mut tests = self.large.len() as u64;
        // A hit on a large primitive already bounds the walk.
        work.octree_cells += self.walk(ray, t_max.min(closest.cutoff()), |start, indices| {
            if indices.len() < GROUP {
                for &i in indices {
                    if mailbox.first_visit(i) {
                        tests += 1;
                        if let Some(h) = tests_of.test(i, closest.bound()) {
                            closest.offer(i, h);
                        }
                    }
                }
                return closest.cutoff();
            }
            tests += match tests_of.test_leaf(start, &mut closest) {
                Some(tested) => tested,
                None => in_groups(indices, &mut mailbox, |group| {
                    tests_of.test_group(group, &mut closest);
                    false
                }),
            };
            closest.cutoff()
        });
        work.intersection_tests += tests;
        closest.best()
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
        test: impl FnMut(u32) -> bool,
    ) -> bool {
        self.first_blocker_with(ray, t_max, work, test).is_some()
    }

    /// [`Octree::any_hit_with`], returning the primitive it stopped at.
    pub fn first_blocker_with(
        &self,
        ray: &Ray,
        t_max: f32,
        work: &mut QueryWork,
        test: impl FnMut(u32) -> bool,
    ) -> Option<u32> {
        self.any_hit_grouped(ray, t_max, work, &mut OneByOne(test))
    }

    /// [`Octree::any_hit_with`] for tests that go faster together, as in
    /// [`Octree::closest_hit_grouped`]: a leaf of at least [`GROUP`] primitives is tested by
    /// [`GroupBlocks::blocks_group`], up to [`GROUP`] at a time, a smaller one by
    /// [`GroupBlocks::blocks`]. Returns the blocker found.
    pub fn any_hit_grouped(
        &self,
        ray: &Ray,
        t_max: f32,
        work: &mut QueryWork,
        tests_of: &mut impl GroupBlocks,
    ) -> Option<u32> {
        let mut tests = 0u64;
        let mut found = self.large.iter().copied().find(|&i| {
            tests += 1;
            tests_of.blocks(i)
        });
        if found.is_some() {
            work.intersection_tests += tests;
            return found;
        }
        let mut mailbox = Mailbox::new();
        work.octree_cells += self.walk(ray, t_max, |start, indices| {
            if indices.len() < GROUP {
                found = indices.iter().copied().find(|&i| {
                    let first = mailbox.first_visit(i);
                    tests += u64::from(first);
                    first && tests_of.blocks(i)
                });
            } else if let Some((blocker, tested)) = tests_of.blocks_leaf(start) {
                (found, tests) = (blocker, tests + tested);
            } else {
                tests += in_groups(indices, &mut mailbox, |group| {
                    found = tests_of.blocks_group(group);
                    found.is_some()
                });
            }
            if found.is_some() {
                f32::NEG_INFINITY
            } else {
                f32::INFINITY
            }
        });
        work.intersection_tests += tests;
        found
    }

    /// Visits the non-empty leaves the ray crosses, nearest first. `leaf` gets each leaf's start
    /// in [`Octree::indices`] and its primitive indices, and returns a cut-off: cells entered
    /// beyond it are skipped (`-∞` ends the walk). Returns how many cells it entered.
    fn walk(&self, ray: &Ray, t_max: f32, leaf: impl FnMut(u32, &[u32]) -> f32) -> u64 {
        struct One<'a, F> {
            tree: &'a Octree,
            ray: &'a Ray,
            t_max: f32,
            leaf: F,
        }
        impl<F: FnMut(u32, &[u32]) -> f32> SizedWalk for One<'_, F> {
            type Out = u64;
            #[inline(always)]
            fn run<const S: usize, const P: usize>(self) -> u64 {
                self.tree.walk_in::<S, P>(self.ray, self.t_max, self.leaf)
            }
        }
        sized(
            self.stats.depth,
            One {
                tree: self,
                ray,
                t_max,
                leaf,
            },
        )
    }

    /// [`Octree::walk`] with a stack of `S` entries and a path of `P` boxes, enough for a tree
    /// `P − 1` deep (`S` = [`stack_size`]`(P − 1)`).
    fn walk_in<const S: usize, const P: usize>(
        &self,
        ray: &Ray,
        t_max: f32,
        mut leaf: impl FnMut(u32, &[u32]) -> f32,
    ) -> u64 {
        let inv_dir = inv_dir(ray);
        let Some((t0, t1)) = self.root.intersect(ray, inv_dir, t_max) else {
            return 0;
        };
        let mut cells = 0u64;
        // All-zero entries and boxes: the compiler clears them with one fill each.
        let mut stack = [Entry::default(); S];
        let mut path = Path::<P>::new();
        // The cell to enter next when it is not on the stack: the nearest child of the cell
        // entered last, kept in registers (a push and a pop of it would put a trip through
        // memory on the walk's critical path).
        let mut next = Some(Entry {
            t0: t0 * (1.0 - WIDEN),
            t1,
            ..Entry::default()
        });
        let mut top = 0usize;
        let mut cutoff = f32::INFINITY;
        while let Some(e) = next_cell(&mut next, &stack, &mut top) {
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
                cutoff = leaf(
                    node.first,
                    &self.indices[start..start + node.count as usize],
                );
                continue;
            }
            let cell = path.enter(e.depth, e.child, self.root);
            (top, next) = push_children(ray, inv_dir, &e, node, cell.center(), &mut stack, top);
        }
        cells
    }
}

/// The reciprocal of `ray`'s direction, as every walk takes it for its slab tests (the root's
/// included, so [`Octree::missed_by4`] answers as the walks do): one vector division for the
/// three lanes, each lane the scalar quotient.
#[inline(always)]
pub(super) fn inv_dir(ray: &Ray) -> Vec3 {
    Vec3::from(Vec3A::ONE / Vec3A::from(ray.dir))
}

/// The cell to enter next: `next`, the nearest child of the cell entered last, if it was
/// occupied, else the top of the stack; `None` when the walk is done.
#[inline(always)]
pub(super) fn next_cell<E: Copy>(next: &mut Option<E>, stack: &[E], top: &mut usize) -> Option<E> {
    if let Some(e) = next.take() {
        return Some(e);
    }
    *top = top.checked_sub(1)?;
    Some(stack[*top])
}

/// Pushes the occupied children of interior node `node` (entered as `e`, its centre `mid`) that
/// the ray may touch, farthest first along the ray; returns the new stack top and the nearest
/// child (if occupied), which is not pushed: the walk enters it next, as it would have popped
/// it next.
///
/// The build files a primitive that touches a centre plane from one side on that side only (see
/// `build.rs`), so the walk must reach every child the ray touches, even only at a point. The
/// pieces of the entry's
/// interval `[t0, c1], [c1, c2], ..., [cn, t1]` are cut at the ray's computed crossings `c` of
/// the centre planes and widened by [`WIDEN`], twice the crossing's rounding error bound, around
/// each:
/// - where two crossings are within the bound of each other, the true order is unknown, and the
///   children reached by crossing those planes in another order are pushed as well;
/// - a ray in a centre plane (zero direction component, origin on it) touches both sides.
///
/// Pieces are written straight into the stack, field by field: a piece array returned by value
/// and copied (an earlier version) made the processor wait for its stores on every interior cell.
#[inline(always)]
pub(super) fn push_children<const S: usize>(
    ray: &Ray,
    inv_dir: Vec3,
    e: &Entry,
    node: super::Node,
    mid: Vec3,
    stack: &mut [Entry; S],
    top: usize,
) -> (usize, Option<Entry>) {
    // Per axis, where the ray crosses the centre plane, and whether it starts on the upper side.
    // NaN where the ray is parallel to the plane: no crossing, never an event below.
    let mut cross = [f32::NAN; 3];
    let mut child = 0usize;
    // Axes whose centre plane the ray lies in: it touches both sides all along.
    let mut in_plane = 0usize;
    // Plain arrays: indexing a vector by a variable axis compiles to a three-way match.
    let (origin, dir, inv_dir, mid) = (
        ray.origin.to_array(),
        ray.dir.to_array(),
        inv_dir.to_array(),
        mid.to_array(),
    );
    for a in 0..3 {
        let d = dir[a];
        let upper = if d == 0.0 {
            in_plane |= usize::from(origin[a] == mid[a]) << a;
            origin[a] >= mid[a]
        } else {
            // An origin on the plane crosses it at 0, also where `1/d` overflows (0 · ∞).
            let gap = mid[a] - origin[a];
            cross[a] = if gap == 0.0 { 0.0 } else { gap * inv_dir[a] };
            // Both comparisons made and one kept without a branch (the sign of `d` is a coin
            // toss from ray to ray).
            let ahead = d > 0.0;
            (ahead & (e.t0 >= cross[a])) | (!ahead & (e.t0 < cross[a]))
        };
        child |= (upper as usize) << a;
    }
    // Plane crossings inside the interval, in ray order. The interval's ends are widened by
    // twice a crossing's error bound, so a crossing truly inside is computed inside: whether
    // the ray starts on the upper side is never decided by a rounded crossing.
    // Crossings and their axes in two arrays of 4-byte values: the sort's reads then match the
    // writes before them one for one. (Pairs of a float and an index were written in two
    // parts and read whole, and such a read waits until the writes reach the cache.)
    let mut ts = [f32::INFINITY; 3];
    let mut axes = [0u32; 3];
    let mut n = 0;
    // Each crossing is written at `n` (`∞` where it is outside, so the slots from `n` on stay
    // `∞`) and `n` moves on past those inside, instead of a branch around the writes: whether
    // a crossing is inside is a coin toss. The `∞` is chosen by a vector select: written as a
    // scalar choice it compiled to a branch around the `∞`, the walk's most mispredicted one
    // (`valgrind --branch-sim` on balls_4).
    let c = Vec3A::from_array(cross);
    let inside = c.cmpgt(Vec3A::splat(e.t0)) & c.cmplt(Vec3A::splat(e.t1));
    let outside_infinite = Vec3A::select(inside, c, Vec3A::INFINITY).to_array();
    let bits = inside.bitmask();
    for (a, &t) in outside_infinite.iter().enumerate() {
        ts[n] = t;
        axes[n] = a as u32;
        n += (bits >> a & 1) as usize;
    }
    sort3(&mut ts, &mut axes);
    let events: [(f32, usize); 3] = core::array::from_fn(|k| (ts[k], axes[k] as usize));
    if in_plane != 0 {
        let (t0, t1, depth) = (e.t0, e.t1, e.depth + 1);
        let top = push_both_sides(
            t0,
            t1,
            depth,
            node,
            (child, in_plane),
            (&events, n),
            stack,
            top,
        );
        return (top, None);
    }
    push_path(
        (e.t0, e.t1, e.depth + 1),
        node,
        child,
        (&events, n),
        stack,
        top,
    )
}

/// Pushes the children (cells at `depth`) along the ray's path through `[t0, t1]` from `child`
/// (the one it starts in), cutting at `events` (the first `n` of them, in ray order), and those
/// around crossings that tie; returns the new top and the first piece's cell (if occupied),
/// which it does not push (see [`push_children`]). The entry's fields come as values: an entry
/// passed whole is copied through memory, and its 16-byte load then waits on the narrower
/// stores that wrote it.
#[inline(always)]
fn push_path<const S: usize>(
    (t0, t1, depth): (f32, f32, u16),
    node: super::Node,
    mut child: usize,
    (events, n): (&[(f32, usize); 3], usize),
    stack: &mut [Entry; S],
    mut top: usize,
) -> (usize, Option<Entry>) {
    let tied = |k: usize| tie(events[k].0, events[k + 1].0);
    if n >= 2 && (tied(0) || (n == 3 && tied(1))) {
        top = push_unordered(depth, node, child, &events[..n], stack, top);
    }
    // The last piece's child has crossed every plane; walk back from it.
    for &(_, a) in &events[..n] {
        child ^= 1 << a;
    }
    let mut end = t1;
    for k in (1..=n).rev() {
        let start = events[k - 1].0 * (1.0 - WIDEN);
        top = push_child(depth, node, child, (start, end), stack, top);
        let (c, a) = events[k - 1];
        child ^= 1 << a;
        end = c * (1.0 + WIDEN);
    }
    let nearest = node.child_occupied(child).then_some(Entry {
        node: node.first + child as u32,
        t0,
        t1: end,
        depth,
        child: child as u16,
    });
    (top, nearest)
}

/// [`push_path`] for a ray that lies in the centre planes of the axes `in_plane`: once from each
/// child on either side of those planes. Rare (a ray along a cell face), so out of line.
#[cold]
#[inline(never)]
#[allow(clippy::too_many_arguments)] // t0 and t1 apart: as a pair they are loaded as one 8-byte word
fn push_both_sides<const S: usize>(
    t0: f32,
    t1: f32,
    depth: u16,
    node: super::Node,
    (child, in_plane): (usize, usize),
    events: (&[(f32, usize); 3], usize),
    stack: &mut [Entry; S],
    mut top: usize,
) -> usize {
    let mut side = in_plane;
    loop {
        let nearest;
        (top, nearest) = push_path((t0, t1, depth), node, child ^ side, events, stack, top);
        if let Some(e) = nearest {
            stack[top] = e;
            top += 1;
        }
        if side == 0 {
            return top;
        }
        side = (side - 1) & in_plane;
    }
}

/// True if crossings `c` and `next` (`c ≤ next`) are too close to tell which the ray meets
/// first: their widened values overlap.
#[inline(always)]
fn tie(c: f32, next: f32) -> bool {
    next * (1.0 - WIDEN) <= c * (1.0 + WIDEN)
}

/// Pushes child `c` of `node` (a cell at `depth`) over the ray interval `t` if it is occupied;
/// returns the new top.
#[inline(always)]
fn push_child<const S: usize>(
    depth: u16,
    node: super::Node,
    c: usize,
    (t0, t1): (f32, f32),
    stack: &mut [Entry; S],
    top: usize,
) -> usize {
    if !node.child_occupied(c) {
        return top;
    }
    stack[top] = Entry {
        node: node.first + c as u32,
        t0,
        t1,
        depth,
        child: c as u16,
    };
    top + 1
}

/// Pushes the children off the ray's computed path that it may still touch: within each run of
/// crossings (`events`, in ray order, starting from `child`) whose widened values overlap, every
/// child reached by crossing a subset of the run's planes that is not the run's own prefix,
/// over the run's widened span. Such runs are rare (rays through cell edges and corners), so
/// these cells go below the path's on the stack.
#[cold]
#[inline(never)]
fn push_unordered<const S: usize>(
    depth: u16,
    node: super::Node,
    mut child: usize,
    events: &[(f32, usize)],
    stack: &mut [Entry; S],
    mut top: usize,
) -> usize {
    let mut i = 0;
    while i < events.len() {
        let mut j = i;
        while j + 1 < events.len() && tie(events[j].0, events[j + 1].0) {
            j += 1;
        }
        if j > i {
            let run: usize = events[i..=j].iter().fold(0, |m, &(_, a)| m | 1 << a);
            let span = (events[i].0 * (1.0 - WIDEN), events[j].0 * (1.0 + WIDEN));
            let mut on_path = [0usize; 4];
            let mut flips = 0;
            for (k, &(_, a)) in events[i..=j].iter().enumerate() {
                flips |= 1 << a;
                on_path[k + 1] = flips;
            }
            // Every subset of the run's axes (bit masks within `run`).
            let mut subset = run;
            loop {
                if !on_path[..=j - i + 1].contains(&subset) {
                    top = push_child(depth, node, child ^ subset, span, stack, top);
                }
                if subset == 0 {
                    break;
                }
                subset = (subset - 1) & run;
            }
        }
        for &(_, a) in &events[i..=j] {
            child ^= 1 << a;
        }
        i = j + 1;
    }
    top
}

/// Sorts three crossings `ts` by value, their axes `axes` along; infinities (unused slots) sort
/// last, and equal values keep their order.
#[inline]
fn sort3(ts: &mut [f32; 3], axes: &mut [u32; 3]) {
    for (i, j) in [(0, 1), (1, 2), (0, 1)] {
        if ts[j] < ts[i] {
            ts.swap(i, j);
            axes.swap(i, j);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::sort3;

    /// `sort3` is a stable sort: every arrangement of crossings (distinct, tied, and `∞` for
    /// unused slots) comes out in increasing order, tied values and the `∞`s keeping their
    /// axes' order, as a stable library sort leaves them.
    #[test]
    fn sort3_sorts_stably() {
        let values = [0.5f32, 1.0, 1.0, 2.5, f32::INFINITY];
        for a in values {
            for b in values {
                for c in values {
                    let (mut ts, mut axes) = ([a, b, c], [0u32, 1, 2]);
                    sort3(&mut ts, &mut axes);
                    let mut want = [(a, 0u32), (b, 1), (c, 2)];
                    want.sort_by(|x, y| x.0.total_cmp(&y.0));
                    assert_eq!(ts, want.map(|w| w.0), "{a} {b} {c}");
                    assert_eq!(axes, want.map(|w| w.1), "{a} {b} {c}");
                }
            }
        }
    }
}
