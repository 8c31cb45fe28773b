//! Polygons split into triangles, for the formats whose faces may have more than three corners
//! (NFF's `p` and `pp`, OBJ's `f`).
//!
//! A polygon that the fan around its first corner covers once (every fan triangle turns the way
//! the polygon does: all convex polygons, and concave ones whose every corner the first one
//! sees) is split into that fan, as these readers always did. Another (SPD's gears: a gear's
//! face is one polygon of 144 corners around its teeth) is split by ear clipping, for the fan
//! would cover some gaps between the teeth and render them as face: each step cuts off the
//! corner whose cut is shortest among those that hold no other corner, so the triangles stay
//! compact. A polygon no ear can be cut from (one that crosses itself) is fanned from the
//! corners left.
//!
//! The decisions are made in `f64` from the `f32` corners, with error bounds, so a fan triangle
//! that turns no way at all (three corners in a line) never counts as turning the wrong way.

use glam::{DVec2, DVec3, Vec3};
use std::cmp::Reverse;
use std::collections::BinaryHeap;

/// The relative error bound of a turn computed in `f64` from `f32` corners: a turn is a dot
/// product of a cross product of differences, at most six roundings deep, so it is within
/// `γ(6)` (about 3 `f64::EPSILON`) of its value times the product of its vectors' lengths
/// (Higham); the rest covers the differences' own rounding where corners lie far apart in
/// magnitude.
const TURN_BOUND: f64 = 32.0 * f64::EPSILON;

/// Appends to `out` the triangles of the polygon `corners` (in order around it), as indices into
/// `corners` in the polygon's own turning order: `corners.len() − 2` of them.
pub fn triangulate(corners: &[Vec3], out: &mut Vec<[u32; 3]>) {
    let n = corners.len() as u32;
    let normal = newell_normal(corners);
    let fan_covers_once = (1..n.saturating_sub(1)).all(|k| {
        let [a, b, c] = [0, k, k + 1].map(|i| corners[i as usize].as_dvec3());
        !turns_against(normal, b - a, c - a)
    });
    if fan_covers_once {
        out.extend((1..n.saturating_sub(1)).map(|k| [0, k, k + 1]));
    } else {
        clip_ears(&project(corners, normal), out);
    }
}

/// The polygon's normal by Newell's method: the sum of its edges' cross terms, whose length is
/// twice its area and whose direction is the one it turns about.
fn newell_normal(corners: &[Vec3]) -> DVec3 {
    let mut normal = DVec3::ZERO;
    for (k, p) in corners.iter().enumerate() {
        let (a, b) = (p.as_dvec3(), corners[(k + 1) % corners.len()].as_dvec3());
        normal += DVec3::new(
            (a.y - b.y) * (a.z + b.z),
            (a.z - b.z) * (a.x + b.x),
            (a.x - b.x) * (a.y + b.y),
        );
    }
    normal
}

/// True if going from `u` to `v` turns against `normal` by more than the rounding bound (the
/// squares compared, so a turn the right way costs no square root).
fn turns_against(normal: DVec3, u: DVec3, v: DVec3) -> bool {
    let turn = normal.dot(u.cross(v));
    let bound_squared =
        TURN_BOUND * TURN_BOUND * normal.length_squared() * u.length_squared() * v.length_squared();
    turn < 0.0 && turn * turn > bound_squared
}

/// The corners in the plane of the axes other than `normal`'s largest, ordered so that the
/// polygon turns counter-clockwise there.
fn project(corners: &[Vec3], normal: DVec3) -> Vec<DVec2> {
    let a = normal.abs();
    let (drop, sign) = if a.x >= a.y && a.x >= a.z {
        (0, normal.x)
    } else if a.y >= a.z {
        (1, normal.y)
    } else {
        (2, normal.z)
    };
    // The two axes after the dropped one, in cyclic order, keep its sense of turning.
    let (i, j) = ((drop + 1) % 3, (drop + 2) % 3);
    corners
        .iter()
        .map(|p| {
            let p = p.as_dvec3();
            let v = DVec2::new(p[i], p[j]);
            if sign < 0.0 {
                DVec2::new(v.x, -v.y)
            } else {
                v
            }
        })
        .collect()
}

/// Ear clipping of the counter-clockwise polygon `p`: the shortest cut first, ties to the lower
/// corner (a heap of the ears by cut). Only a reflex corner can lie in an ear's triangle when no
/// corner of a simple polygon does, so the test asks only the reflex corners, found through a
/// grid ([`ReflexGrid`]): on a gear's face of 16,384 corners this takes milliseconds, where
/// asking every corner took most of a second.
fn clip_ears(p: &[DVec2], out: &mut Vec<[u32; 3]>) {
    let n = p.len();
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut reflex: Vec<bool> = (0..n)
        .map(|i| turn(p[prev[i]], p[i], p[next[i]]) < 0.0)
        .collect();
    let grid = ReflexGrid::new(p, &reflex);
    let mut alive = vec![true; n];
    let ear = |i: usize, prev: &[usize], next: &[usize], reflex: &[bool], alive: &[bool]| {
        is_ear(p, [prev[i], i, next[i]], &grid, reflex, alive)
    };
    // A cut is a square, so its bits order as its value.
    let key = |cut: f64, i: usize| Reverse((cut.to_bits(), i));
    let mut cuts: Vec<Option<f64>> = (0..n)
        .map(|i| ear(i, &prev, &next, &reflex, &alive))
        .collect();
    let mut heap: BinaryHeap<_> = (0..n)
        .filter_map(|i| cuts[i].map(|cut| key(cut, i)))
        .collect();
    let mut left = n;
    let mut last = 0;
    while left > 3 {
        let Some(Reverse((bits, b))) = heap.pop() else {
            break;
        };
        if !alive[b] || cuts[b].map(f64::to_bits) != Some(bits) {
            continue;
        }
        let (a, c) = (prev[b], next[b]);
        out.push([a as u32, b as u32, c as u32]);
        (next[a], prev[c]) = (c, a);
        alive[b] = false;
        left -= 1;
        last = a;
        for v in [a, c] {
            reflex[v] = reflex[v] && turn(p[prev[v]], p[v], p[next[v]]) < 0.0;
        }
        for v in [a, c] {
            cuts[v] = ear(v, &prev, &next, &reflex, &alive);
            heap.extend(cuts[v].map(|cut| key(cut, v)));
        }
    }
    // The last triangle, or a fan of what no ear could be cut from.
    let first = if alive[last] {
        last
    } else {
        (0..n).find(|&i| alive[i]).unwrap_or(0)
    };
    let mut k = next[first];
    while next[k] != first {
        out.push([first as u32, k as u32, next[k] as u32]);
        k = next[k];
    }
}

/// The squared length of the cut `a`–`c` if the corner `b` between them is an ear: it turns
/// counter-clockwise (or not at all) and no reflex corner still in the polygon lies in the
/// triangle `a b c` or on its sides.
fn is_ear(
    p: &[DVec2],
    [a, b, c]: [usize; 3],
    grid: &ReflexGrid,
    reflex: &[bool],
    alive: &[bool],
) -> Option<f64> {
    let (pa, pb, pc) = (p[a], p[b], p[c]);
    if turn(pa, pb, pc) < -turn_bound(pa, pb, pc) {
        return None;
    }
    let (lo, hi) = (pa.min(pb).min(pc), pa.max(pb).max(pc));
    let blocked = grid.within(lo, hi).any(|r| {
        let q = p[r];
        let outside = turn(pa, pb, q) < 0.0 || turn(pb, pc, q) < 0.0 || turn(pc, pa, q) < 0.0;
        reflex[r] && alive[r] && !outside && q != pa && q != pb && q != pc
    });
    (!blocked).then(|| (pc - pa).length_squared())
}

/// The polygon's reflex corners filed in a square grid over its box, about one per cell.
struct ReflexGrid {
    lo: DVec2,
    /// Cells per unit of length, and cells per side.
    scale: f64,
    side: usize,
    /// The corners of cell `k` are `corners[starts[k]..starts[k + 1]]`.
    starts: Vec<usize>,
    corners: Vec<usize>,
}

impl ReflexGrid {
    fn new(p: &[DVec2], reflex: &[bool]) -> ReflexGrid {
        let count = reflex.iter().filter(|&&r| r).count();
        let lo = p.iter().fold(DVec2::INFINITY, |m, &q| m.min(q));
        let hi = p.iter().fold(DVec2::NEG_INFINITY, |m, &q| m.max(q));
        let side = ((count as f64).sqrt() as usize).max(1);
        let extent = (hi - lo).max_element();
        let scale = if extent > 0.0 {
            side as f64 / extent
        } else {
            0.0
        };
        let mut grid = ReflexGrid {
            lo,
            scale,
            side,
            starts: vec![0; side * side + 1],
            corners: vec![0; count],
        };
        let cells: Vec<usize> = (0..p.len()).map(|i| grid.cell(p[i])).collect();
        for (i, &cell) in cells.iter().enumerate() {
            grid.starts[cell + 1] += usize::from(reflex[i]);
        }
        for k in 0..side * side {
            grid.starts[k + 1] += grid.starts[k];
        }
        let mut fill = grid.starts.clone();
        for (i, &cell) in cells.iter().enumerate().filter(|&(i, _)| reflex[i]) {
            grid.corners[fill[cell]] = i;
            fill[cell] += 1;
        }
        grid
    }

    /// The column and row of the cell holding `q` (clamped to the grid).
    fn column_row(&self, q: DVec2) -> (usize, usize) {
        let at = |v: f64| ((v * self.scale) as usize).min(self.side - 1);
        (at(q.x - self.lo.x), at(q.y - self.lo.y))
    }

    fn cell(&self, q: DVec2) -> usize {
        let (x, y) = self.column_row(q);
        y * self.side + x
    }

    /// The reflex corners in the cells the box `lo..hi` reaches.
    fn within(&self, lo: DVec2, hi: DVec2) -> impl Iterator<Item = usize> + '_ {
        let ((x0, y0), (x1, y1)) = (self.column_row(lo), self.column_row(hi));
        (y0..=y1).flat_map(move |y| {
            let row = y * self.side;
            self.corners[self.starts[row + x0]..self.starts[row + x1 + 1]]
                .iter()
                .copied()
        })
    }
}

/// Twice the signed area of the triangle `a b c`: positive where it turns counter-clockwise.
fn turn(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    (b - a).perp_dot(c - a)
}

/// The rounding bound of [`turn`] for these corners.
fn turn_bound(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    TURN_BOUND * (b - a).length() * (c - a).length()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The triangles of `corners`.
    fn split(corners: &[Vec3]) -> Vec<[u32; 3]> {
        let mut out = Vec::new();
        triangulate(corners, &mut out);
        assert_eq!(out.len(), corners.len() - 2, "{out:?}");
        out
    }

    /// True if the point `q` (in the plane z = 0) is inside the polygon, by the even-odd rule.
    fn inside(corners: &[Vec3], q: DVec2) -> bool {
        let mut crossings = false;
        for (k, a) in corners.iter().enumerate() {
            let b = corners[(k + 1) % corners.len()];
            let (a, b) = (a.as_dvec3().truncate(), b.as_dvec3().truncate());
            if (a.y > q.y) != (b.y > q.y) && q.x < a.x + (q.y - a.y) * (b.x - a.x) / (b.y - a.y) {
                crossings = !crossings;
            }
        }
        crossings
    }

    /// How many of the triangles cover `q` (strictly inside).
    fn covering(corners: &[Vec3], triangles: &[[u32; 3]], q: DVec2) -> usize {
        let at = |i: u32| corners[i as usize].as_dvec3().truncate();
        triangles
            .iter()
            .filter(|t| {
                let [a, b, c] = t.map(at);
                let s = turn(a, b, c).signum();
                [turn(a, b, q), turn(b, c, q), turn(c, a, q)]
                    .iter()
                    .all(|&x| x * s > 0.0)
            })
            .count()
    }

    /// A gear's outline in the plane z = 0 (as SPD's gears writes its faces): `teeth` teeth
    /// between radii 0.8 and 1, four corners each, starting on a tooth.
    fn gear(teeth: usize) -> Vec<Vec3> {
        (0..4 * teeth)
            .map(|k| {
                let angle = core::f32::consts::TAU * k as f32 / (4 * teeth) as f32;
                let r = if k % 4 < 2 { 1.0 } else { 0.8 };
                Vec3::new(r * libm::cosf(angle), r * libm::sinf(angle), 0.0)
            })
            .collect()
    }

    #[test]
    fn a_convex_polygon_is_fanned_from_its_first_corner() {
        // A hexagon, and a square with a corner in the middle of a side.
        let hexagon: Vec<Vec3> = (0..6)
            .map(|k| {
                let a = k as f32 * core::f32::consts::TAU / 6.0;
                Vec3::new(libm::cosf(a), 0.5, libm::sinf(a))
            })
            .collect();
        let fan: Vec<[u32; 3]> = (1..5).map(|k| [0, k, k + 1]).collect();
        assert_eq!(split(&hexagon), fan);
        let square = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::new(1.0, 0.5, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::Y,
        ];
        assert_eq!(split(&square), vec![[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
    }

    #[test]
    fn a_gear_face_is_covered_once_inside_and_nowhere_outside() {
        for (teeth, turn_over) in [(36, false), (36, true), (7, false)] {
            let mut corners = gear(teeth);
            if turn_over {
                corners.reverse();
            }
            let triangles = split(&corners);
            // The fan from the first corner would cover gaps between the teeth.
            let fan: Vec<[u32; 3]> = (1..corners.len() as u32 - 1)
                .map(|k| [0, k, k + 1])
                .collect();
            let (mut fan_wrong, mut inside_points) = (0, 0);
            for i in 0..200 {
                for j in 0..200 {
                    // A grid that no side of a triangle passes through.
                    let q = DVec2::new(i as f64 / 90.3 - 1.1003, j as f64 / 90.7 - 1.1007);
                    let expected = usize::from(inside(&corners, q));
                    assert_eq!(covering(&corners, &triangles, q), expected, "{q} {teeth}");
                    fan_wrong += usize::from(covering(&corners, &fan, q).min(1) != expected);
                    inside_points += expected;
                }
            }
            assert!(
                fan_wrong > 100 && inside_points > 10_000,
                "{fan_wrong} {inside_points}"
            );
            // Every triangle turns the polygon's way.
            let at = |i: u32| corners[i as usize].as_dvec3().truncate();
            let sense = if turn_over { -1.0 } else { 1.0 };
            for t in &triangles {
                let [a, b, c] = t.map(at);
                assert!(turn(a, b, c) * sense > 0.0, "{t:?}");
            }
        }
    }

    /// A star-shaped polygon around the origin with `n` corners at radii from 0.2 to 1 that
    /// `next` picks (in `0..1`): simple, and concave at most corners.
    fn star(n: usize, next: &mut impl FnMut() -> f64) -> Vec<Vec3> {
        (0..n)
            .map(|k| {
                let angle = std::f64::consts::TAU * k as f64 / n as f64;
                let r = 0.2 + 0.8 * next();
                Vec3::new((r * angle.cos()) as f32, (r * angle.sin()) as f32, 0.0)
            })
            .collect()
    }

    #[test]
    fn star_shaped_polygons_are_covered_once_inside_and_nowhere_outside() {
        let mut state = 0x2545_f491u32;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            f64::from(state) / f64::from(u32::MAX)
        };
        let mut clipped = 0;
        for n in (4..64).step_by(3) {
            let corners = star(n, &mut next);
            let triangles = split(&corners);
            clipped += usize::from(triangles.iter().any(|t| t[0] != 0));
            for i in 0..60 {
                for j in 0..60 {
                    let q = DVec2::new(i as f64 / 28.3 - 1.05, j as f64 / 28.7 - 1.04);
                    let expected = usize::from(inside(&corners, q));
                    assert_eq!(covering(&corners, &triangles, q), expected, "{q} {n}");
                }
            }
        }
        assert!(clipped > 15, "{clipped}");
    }

    #[test]
    fn a_polygon_that_crosses_itself_still_gets_its_triangles() {
        // A bow tie and a pentagram: no simple polygon, every corner used.
        let bow_tie = [Vec3::ZERO, Vec3::ONE.with_z(0.0), Vec3::X, Vec3::Y];
        split(&bow_tie);
        let pentagram: Vec<Vec3> = (0..5)
            .map(|k| {
                let a = (2 * k) as f32 * core::f32::consts::TAU / 5.0;
                Vec3::new(libm::cosf(a), libm::sinf(a), 0.0)
            })
            .collect();
        split(&pentagram);
        // All corners in a line, corners repeated, and a large face of 16,384 corners.
        split(&[Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::X * 3.0]);
        split(&[Vec3::ZERO, Vec3::X, Vec3::X, Vec3::Y, Vec3::Y, Vec3::ZERO]);
        split(&gear(4096));
    }
}
