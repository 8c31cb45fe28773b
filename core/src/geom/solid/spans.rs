//! Span lists and the CSG operations on them.
//!
//! A solid's intersection with a ray is a sorted list of disjoint [`Span`]s, the intervals of `t`
//! inside it. Each end is a [`Boundary`] that remembers the leaf shape it lies on and whether that
//! shape's normal must be turned round (FART's `A − B`: where the surface comes from `B`, the
//! composite's outward normal is `B`'s inward one). [`combine`] sweeps the boundaries of two lists
//! in order and keeps the parts where the operation says "inside".
//!
//! Boundaries of the two operands that coincide within their error bounds (shared faces, shared
//! edges) must not leave slivers or walls. The sweep crosses such a cluster of boundaries as one
//! step, so only the state before and after it counts; where the composite begins or ends at a
//! cluster, its surface is a boundary that is not an inner wall between the operands (one whose
//! normal is opposite to a boundary of the other operand moving the composite the other way).
//! Spans and gaps still shorter than both neighbouring ends' error bounds are then dropped or
//! closed. So a union of two boxes that share a face has no inner wall, even for a ray through
//! the edge of that face, and an intersection of two boxes that only touch is empty.

use super::CsgOp;
use alloc::vec::Vec;
use glam::Vec3;

/// One end of a span.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Boundary {
    /// Ray parameter (±∞ for the open end of an unbounded span).
    pub t: f32,
    /// Bound on the error of `t` along the ray (a boundary nearer than this is at the origin).
    pub t_error: f32,
    /// Bound on the error of `t` across the surface (see
    /// [`Crossing::merge_error`](super::shape::Crossing)): coinciding boundaries merge within it.
    pub merge_error: f32,
    /// The leaf node (index into the solid arena) whose surface this is.
    pub leaf: u32,
    /// Which face of the leaf's shape (see [`super::shape::Face`]).
    pub face: u32,
    /// True if the leaf's outward normal points into the composite here.
    pub flip: bool,
}

/// An interval of the ray inside a solid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Span {
    /// Where the ray enters.
    pub enter: Boundary,
    /// Where it leaves.
    pub exit: Boundary,
}

#[inline]
fn inside(op: CsgOp, a: bool, b: bool) -> bool {
    match op {
        CsgOp::Union => a || b,
        CsgOp::Intersect => a && b,
        CsgOp::Subtract => a && !b,
    }
}

/// One boundary of the sweep: the boundary itself (with `B`'s normal already turned for
/// `A − B`), which operand it belongs to, and whether crossing it can only move the composite
/// towards "inside" (`opens`).
#[derive(Clone, Copy)]
struct Event {
    bound: Boundary,
    from_a: bool,
    opens: bool,
}

/// The two operands' spans with cursors over their boundary sequences: index 2k is span k's
/// entry, 2k + 1 its exit.
#[derive(Clone, Copy)]
struct Sweep<'s> {
    op: CsgOp,
    a: &'s [Span],
    b: &'s [Span],
    ia: usize,
    ib: usize,
}

/// The cosine below which two unit normals count as opposite. The normals of coinciding faces
/// agree up to rounding (about 1e-6); distinct faces meeting at an edge of a box are 90° apart.
const OPPOSITE: f32 = -0.99;

impl Sweep<'_> {
    /// The next boundary in order of `t` (ties: `a` first), without consuming it.
    #[inline(always)]
    fn peek(&self) -> Option<Event> {
        let (op, a, b) = (self.op, self.a, self.b);
        let at = |s: &[Span], i: usize| {
            if i % 2 == 0 {
                s[i / 2].enter
            } else {
                s[i / 2].exit
            }
        };
        let (na, nb) = (2 * a.len(), 2 * b.len());
        if self.ia >= na && self.ib >= nb {
            return None;
        }
        let take_a = self.ib >= nb || (self.ia < na && at(a, self.ia).t <= at(b, self.ib).t);
        Some(if take_a {
            Event {
                bound: at(a, self.ia),
                from_a: true,
                opens: self.ia % 2 == 0,
            }
        } else {
            let mut bound = at(b, self.ib);
            let enters = self.ib % 2 == 0;
            if op == CsgOp::Subtract {
                bound.flip = !bound.flip;
            }
            Event {
                bound,
                from_a: false,
                opens: enters != (op == CsgOp::Subtract),
            }
        })
    }

    /// Consumes the boundary [`Sweep::peek`] returns.
    #[inline]
    fn advance(&mut self, e: &Event) {
        if e.from_a {
            self.ia += 1;
        } else {
            self.ib += 1;
        }
    }
}

/// Appends to `out` the spans of `op(a, b)`. Both inputs must be sorted and disjoint; so is the
/// result.
///
/// Boundaries that follow each other within their merge error bounds form a cluster, which is
/// crossed as one: only the state before and after it counts, so touching operands leave neither
/// slivers nor gaps. Where a cluster makes the composite begin or end, the boundary that names
/// its surface is chosen by `surface_of_cluster`, using `normal` (a boundary's outward normal
/// as the composite sees it) to recognise the inner walls of shared faces.
pub fn combine<N>(op: CsgOp, a: &[Span], b: &[Span], out: &mut Vec<Span>, mut normal: N)
where
    N: FnMut(&Boundary) -> Vec3,
{
    let start = out.len();
    let mut sweep = Sweep {
        op,
        a,
        b,
        ia: 0,
        ib: 0,
    };
    let mut open: Option<Boundary> = None;
    // Each boundary is looked at once: `next` is the one after the cluster being gathered.
    let mut next = sweep.peek();
    while let Some(first) = next {
        let before = inside(op, sweep.ia % 2 == 1, sweep.ib % 2 == 1);
        let cluster = sweep;
        sweep.advance(&first);
        let (mut last, mut count) = (first, 1);
        next = sweep.peek();
        while let Some(e) = next {
            let link = 2.0 * last.bound.merge_error.min(e.bound.merge_error);
            // (False for NaN gaps too, between infinite ends.)
            let linked = e.bound.t - last.bound.t <= link;
            if !linked {
                break;
            }
            sweep.advance(&e);
            (last, count) = (e, count + 1);
            next = sweep.peek();
        }
        let after = inside(op, sweep.ia % 2 == 1, sweep.ib % 2 == 1);
        if before == after {
            continue;
        }
        let chosen = if count == 1 {
            first.bound
        } else {
            surface_of_cluster(cluster, count, after, first.bound, &mut normal)
        };
        match open.take() {
            None => open = Some(chosen),
            Some(enter) => out.push(Span {
                enter,
                exit: chosen,
            }),
        }
    }
    tidy(out, start);
}

/// The boundary that names the composite's surface where the `count` boundaries from `cluster`
/// on (the first of them is `first`) make it begin (`opens`) or end: the first one that moves the composite that way and is not
/// an inner wall. An inner wall is a face one operand shares with the other, crossed from one
/// operand straight into the other: its normal is opposite to that of a boundary of the other
/// operand in the cluster that moves the composite the other way (a ray through the edge of the
/// shared face of two boxes' union crosses the top face, not the wall).
fn surface_of_cluster<N>(
    cluster: Sweep<'_>,
    count: usize,
    opens: bool,
    first: Boundary,
    normal: &mut N,
) -> Boundary
where
    N: FnMut(&Boundary) -> Vec3,
{
    let events = || {
        let mut s = cluster;
        (0..count).filter_map(move |_| {
            let e = s.peek()?;
            s.advance(&e);
            Some(e)
        })
    };
    let mut fallback = None;
    for c in events().filter(|e| e.opens == opens) {
        fallback.get_or_insert(c.bound);
        let nc = normal(&c.bound);
        let wall = events()
            .filter(|w| w.from_a != c.from_a && w.opens != opens)
            .any(|w| nc.dot(normal(&w.bound)) < OPPOSITE);
        if !wall {
            return c.bound;
        }
    }
    // Every candidate is a wall (only in clusters too degenerate to tell): the first one names
    // a surface through this point as well as any. (A cluster that begins or ends the composite
    // has a candidate; the cluster's `first` boundary stands in otherwise.)
    fallback.unwrap_or(first)
}

/// Drops spans of `out[start..]` shorter than both their ends' merge error bounds and closes gaps
/// narrower than that between neighbours.
fn tidy(out: &mut Vec<Span>, start: usize) {
    let mut w = start;
    for r in start..out.len() {
        let s = out[r];
        // Both ends must be uncertain enough to coincide: a span with one well-placed end is
        // real even if its other end is a grazing crossing known only roughly.
        let slack = 2.0 * s.enter.merge_error.min(s.exit.merge_error);
        if s.exit.t - s.enter.t <= slack {
            continue;
        }
        if w > start {
            let prev = &mut out[w - 1];
            if s.enter.t - prev.exit.t <= 2.0 * s.enter.merge_error.min(prev.exit.merge_error) {
                prev.exit = s.exit;
                continue;
            }
        }
        out[w] = s;
        w += 1;
    }
    out.truncate(w);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn b(t: f32, leaf: u32) -> Boundary {
        Boundary {
            t,
            t_error: 1e-6,
            merge_error: 1e-6,
            leaf,
            face: 0,
            flip: false,
        }
    }

    fn s(t0: f32, t1: f32, leaf: u32) -> Span {
        Span {
            enter: b(t0, leaf),
            exit: b(t1, leaf),
        }
    }

    fn run(op: CsgOp, a: &[Span], b: &[Span]) -> Vec<(f32, u32, bool, f32, u32, bool)> {
        let mut out = Vec::new();
        combine(op, a, b, &mut out, |_| Vec3::ZERO);
        out.iter()
            .map(|s| {
                (
                    s.enter.t,
                    s.enter.leaf,
                    s.enter.flip,
                    s.exit.t,
                    s.exit.leaf,
                    s.exit.flip,
                )
            })
            .collect()
    }

    #[test]
    fn union_merges_touching_spans() {
        let r = run(CsgOp::Union, &[s(1.0, 2.0, 0)], &[s(2.0, 3.0, 1)]);
        assert_eq!(r, [(1.0, 0, false, 3.0, 1, false)]);
    }

    #[test]
    fn intersect_of_touching_spans_is_empty() {
        assert!(run(CsgOp::Intersect, &[s(1.0, 2.0, 0)], &[s(2.0, 3.0, 1)]).is_empty());
        let r = run(CsgOp::Intersect, &[s(1.0, 3.0, 0)], &[s(2.0, 4.0, 1)]);
        assert_eq!(r, [(2.0, 1, false, 3.0, 0, false)]);
    }

    #[test]
    fn subtract_turns_the_normals_of_b() {
        let r = run(CsgOp::Subtract, &[s(1.0, 4.0, 0)], &[s(2.0, 3.0, 1)]);
        assert_eq!(
            r,
            [(1.0, 0, false, 2.0, 1, true), (3.0, 1, true, 4.0, 0, false)]
        );
        // B covering A's front: the ray enters through B's back face, turned.
        let r = run(CsgOp::Subtract, &[s(1.0, 4.0, 0)], &[s(0.0, 2.0, 1)]);
        assert_eq!(r, [(2.0, 1, true, 4.0, 0, false)]);
    }
}
