//! Span lists and the CSG operations on them.
//!
//! A solid's intersection with a ray is a sorted list of disjoint [`Span`]s, the intervals of `t`
//! inside it. Each end is a [`Boundary`] that remembers the leaf shape it lies on and whether that
//! shape's normal must be turned round (FART's `A − B`: where the surface comes from `B`, the
//! composite's outward normal is `B`'s inward one). [`combine`] sweeps the boundaries of two lists
//! in order and keeps the parts where the operation says "inside".
//!
//! Boundaries of the two operands that coincide within their error bounds (shared faces, shared
//! edges) must not leave slivers: after the sweep, spans shorter than the error bounds of both
//! ends are dropped and gaps narrower than that are closed. So a union of two boxes that share a face has no
//! inner wall, and an intersection of two boxes that only touch is empty.

use super::CsgOp;
use alloc::vec::Vec;

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

/// Appends to `out` the spans of `op(a, b)`. Both inputs must be sorted and disjoint; so is the
/// result.
pub fn combine(op: CsgOp, a: &[Span], b: &[Span], out: &mut Vec<Span>) {
    let start = out.len();
    // Cursors over the boundary sequences: index 2k is span k's entry, 2k + 1 its exit.
    let (mut ia, mut ib) = (0usize, 0usize);
    let (na, nb) = (2 * a.len(), 2 * b.len());
    let at = |s: &[Span], i: usize| {
        if i % 2 == 0 {
            s[i / 2].enter
        } else {
            s[i / 2].exit
        }
    };
    let (mut in_a, mut in_b) = (false, false);
    let mut open: Option<Boundary> = None;
    while ia < na || ib < nb {
        let take_a = ib >= nb || (ia < na && at(a, ia).t <= at(b, ib).t);
        let mut bound = if take_a {
            in_a = ia % 2 == 0;
            ia += 1;
            at(a, ia - 1)
        } else {
            in_b = ib % 2 == 0;
            ib += 1;
            at(b, ib - 1)
        };
        if !take_a && op == CsgOp::Subtract {
            bound.flip = !bound.flip;
        }
        let now = inside(op, in_a, in_b);
        match (open, now) {
            (None, true) => open = Some(bound),
            (Some(enter), false) => {
                out.push(Span { enter, exit: bound });
                open = None;
            }
            _ => {}
        }
    }
    tidy(out, start);
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
        combine(op, a, b, &mut out);
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
