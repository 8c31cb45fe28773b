//! Whether a primitive must be filed in a cell: triangle/box overlap by the separating-axis
//! theorem (Akenine-Möller 2001), and a sphere's surface against a box (Arvo 1990: the nearest
//! and the farthest point of the box from the centre).

use glam::{Vec3, Vec3A, Vec3Swizzles};

/// True if the surface of the sphere `center`, `radius` comes within `margin` of the box
/// `lo..hi`: the box reaches the sphere grown by `margin` and is not inside the sphere shrunk by
/// it. A ray can only hit the sphere where its surface is, so a cell wholly inside or outside
/// it needs no test of it. In `f64`, whose rounding is far below any margin a caller gives.
pub(super) fn sphere_surface_box_overlap(
    center: Vec3,
    radius: f32,
    margin: f32,
    lo: Vec3,
    hi: Vec3,
) -> bool {
    let (mut near, mut far) = (0.0f64, 0.0f64);
    for a in 0..3 {
        let c = f64::from(center[a]);
        let (l, h) = (f64::from(lo[a]), f64::from(hi[a]));
        let d = if c < l {
            l - c
        } else if c > h {
            c - h
        } else {
            0.0
        };
        near += d * d;
        let f = (c - l).abs().max((h - c).abs());
        far += f * f;
    }
    let outer = f64::from(radius) + f64::from(margin);
    let inner = (f64::from(radius) - f64::from(margin)).max(0.0);
    near <= outer * outer && far >= inner * inner
}

/// True if the segment `a`–`b` comes within `reach` of the box `lo..hi`: it crosses the box
/// grown by `reach` on every side (which holds every point within `reach` of the box, and the
/// corners' neighbourhoods besides), by the slab test in `f64`, whose rounding is far below any
/// reach a caller gives. A cylinder or cone lies within its larger radius of its axis, so a box
/// its axis passes farther from holds no point of it.
pub(super) fn segment_box_overlap(a: Vec3, b: Vec3, reach: f32, lo: Vec3, hi: Vec3) -> bool {
    let (mut enter, mut leave) = (0.0f64, 1.0f64);
    for axis in 0..3 {
        let (from, to) = (f64::from(a[axis]), f64::from(b[axis]));
        let grown_lo = f64::from(lo[axis]) - f64::from(reach);
        let grown_hi = f64::from(hi[axis]) + f64::from(reach);
        let d = to - from;
        if d == 0.0 {
            if from < grown_lo || from > grown_hi {
                return false;
            }
            continue;
        }
        let (t0, t1) = ((grown_lo - from) / d, (grown_hi - from) / d);
        enter = enter.max(t0.min(t1));
        leave = leave.min(t0.max(t1));
    }
    enter <= leave
}

/// True unless one of the 13 separating axes (3 box faces, the triangle's plane, 9 edge cross
/// products) separates the triangle from the box `centre ± half`. Touching counts as overlap.
///
/// Each group of three axes is decided in the lanes of one [`Vec3A`]: lane `a` computes exactly
/// what a scalar test of axis `a` computes (the same products and sums in the same order), and
/// the comparisons replace the minimum and maximum of three projections (the same answer for
/// the finite coordinates the build files), so the answer is the scalar test's on every target.
pub(super) fn triangle_box_overlap(center: Vec3, half: Vec3, tri: &[Vec3; 3]) -> bool {
    let (c, h) = (Vec3A::from(center), Vec3A::from(half));
    let v = [
        Vec3A::from(tri[0]) - c,
        Vec3A::from(tri[1]) - c,
        Vec3A::from(tri[2]) - c,
    ];
    // Box face normals: the triangle's extent on each axis.
    if separated(v, h) {
        return false;
    }
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    // The triangle's plane: `Vec3::cross` and `Vec3::dot` lane by lane, summed in their order.
    let n = e[0].yzx() * e[1].zxy() - e[1].yzx() * e[0].zxy();
    let sum = |p: Vec3A| p.x + p.y + p.z;
    if sum(n * v[0]).abs() > sum(h * n.abs()) {
        return false;
    }
    // Cross products of the box axes with an edge: axis `a` crossed with the edge has a zero in
    // component `a`, so each projection is a sum of two products (the same numbers as the full
    // dot products, but for the sign of a zero, which no comparison sees). In lane `a`, with
    // `(i, j)` the two axes after `a`: unit(a) × edge = (.., −edge[j] at i, edge[i] at j, ..).
    let (hi, hj) = (h.yzx(), h.zxy());
    for edge in e {
        let (ai, aj) = (-edge.zxy(), edge.yzx());
        let project = |p: Vec3A| ai * p.yzx() + aj * p.zxy();
        let r = hi * ai.abs() + hj * aj.abs();
        if separated([project(v[0]), project(v[1]), project(v[2])], r) {
            return false;
        }
    }
    true
}

/// True if in some lane all three of `p` lie above `r` or all below `−r`: the interval the
/// three projections span misses `−r..r` on that lane's axis.
#[inline]
fn separated(p: [Vec3A; 3], r: Vec3A) -> bool {
    let above = p[0].cmpgt(r) & p[1].cmpgt(r) & p[2].cmpgt(r);
    let below = p[0].cmplt(-r) & p[1].cmplt(-r) & p[2].cmplt(-r);
    (above | below).any()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::octree::xorshift;

    #[test]
    fn a_sphere_is_filed_where_its_surface_is() {
        let (lo, hi) = (Vec3::splat(-0.1), Vec3::splat(0.1));
        // The box around the centre, inside the sphere: no surface there.
        assert!(!sphere_surface_box_overlap(Vec3::ZERO, 1.0, 1e-4, lo, hi));
        // The surface passes through the box.
        assert!(sphere_surface_box_overlap(
            Vec3::new(1.0, 0.0, 0.0),
            1.0,
            1e-4,
            lo,
            hi
        ));
        // Outside, beyond the margin; then within it.
        let c = Vec3::new(1.2, 0.0, 0.0);
        assert!(!sphere_surface_box_overlap(c, 1.0, 1e-4, lo, hi));
        assert!(sphere_surface_box_overlap(c, 1.0, 0.11, lo, hi));
        // Inside, the box's far corner 0.05 below the surface: kept only with a wider margin.
        let far_corner = libm::sqrtf(3.0 * 0.01);
        assert!(sphere_surface_box_overlap(
            Vec3::ZERO,
            far_corner + 0.05,
            0.06,
            lo,
            hi
        ));
        assert!(!sphere_surface_box_overlap(
            Vec3::ZERO,
            far_corner + 0.05,
            0.04,
            lo,
            hi
        ));
    }

    /// Points on the unit sphere, spread evenly (a Fibonacci lattice).
    fn surface_points(n: usize) -> impl Iterator<Item = Vec3> {
        let golden = core::f32::consts::PI * (3.0 - libm::sqrtf(5.0));
        (0..n).map(move |i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = libm::sqrtf(1.0 - z * z);
            let a = golden * i as f32;
            Vec3::new(r * libm::cosf(a), r * libm::sinf(a), z)
        })
    }

    /// A box centred within `spread` of the origin, of half sizes from 0.01 to `size` + 0.01,
    /// from the numbers `next` gives (in `0..1`).
    fn sample_box(next: &mut impl FnMut() -> f32, spread: f32, size: f32) -> (Vec3, Vec3) {
        let c = (Vec3::new(next(), next(), next()) * 2.0 - Vec3::ONE) * spread;
        let half = Vec3::new(next(), next(), next()) * size + Vec3::splat(0.01);
        (c - half, c + half)
    }

    /// True if the box `lo..hi` holds one of `points`.
    fn holds_one(points: &[Vec3], lo: Vec3, hi: Vec3) -> bool {
        points
            .iter()
            .any(|p| p.cmpge(lo).all() && p.cmple(hi).all())
    }

    #[test]
    fn every_box_that_holds_a_point_of_the_surface_is_kept() {
        let points: alloc::vec::Vec<Vec3> = surface_points(4000).collect();
        // Boxes of many sizes around the sphere, from a fixed sequence.
        let mut state = xorshift(0x2545_f491);
        let mut next = move || state() as f32 / u32::MAX as f32;
        let (mut kept, mut dropped) = (0, 0);
        for _ in 0..3000 {
            let (lo, hi) = sample_box(&mut next, 1.2, 0.3);
            let holds = holds_one(&points, lo, hi);
            let filed = sphere_surface_box_overlap(Vec3::ZERO, 1.0, 0.0, lo, hi);
            assert!(filed || !holds, "box {lo:?}..{hi:?} holds a surface point");
            kept += usize::from(filed);
            dropped += usize::from(!filed);
        }
        // The test sees both answers (boxes inside and outside the sphere are dropped).
        assert!(
            kept > 500 && dropped > 500,
            "{kept} kept, {dropped} dropped"
        );
    }

    #[test]
    fn every_box_that_holds_a_point_of_a_cone_is_kept() {
        // Cones from `a` to `b`, radius 0.4 at `a` and 0.1 at `b`, at several slants; points on
        // their sides and caps.
        let mut state = xorshift(0x1234_5679);
        let mut next = move || state() as f32 / u32::MAX as f32;
        let (mut kept, mut dropped) = (0, 0);
        for slant in 0..8 {
            let a = Vec3::new(-0.9, -0.3 * slant as f32 / 8.0, 0.2);
            let b = Vec3::new(0.8, 0.1 * slant as f32, -0.4 + 0.1 * slant as f32);
            let axis = (b - a).normalize();
            let u = axis.any_orthonormal_vector();
            let v = axis.cross(u);
            let points: alloc::vec::Vec<Vec3> = (0..3000)
                .map(|_| {
                    let (s, angle, cap) = (next(), next() * core::f32::consts::TAU, next());
                    let r = (0.4 + (0.1 - 0.4) * s) * if cap < 0.2 { next() } else { 1.0 };
                    a + (b - a) * s + (u * libm::cosf(angle) + v * libm::sinf(angle)) * r
                })
                .collect();
            for _ in 0..400 {
                let (lo, hi) = sample_box(&mut next, 1.5, 0.2);
                let holds = holds_one(&points, lo, hi);
                let filed = segment_box_overlap(a, b, 0.4 + 1e-4, lo, hi);
                assert!(
                    filed || !holds,
                    "box {lo:?}..{hi:?} holds a point of cone {slant}"
                );
                kept += usize::from(filed);
                dropped += usize::from(!filed);
            }
        }
        assert!(
            kept > 300 && dropped > 1000,
            "{kept} kept, {dropped} dropped"
        );
        // A segment along an axis (touching the grown box, then missing it), and one that is a
        // point.
        let (lo, hi) = (Vec3::ZERO, Vec3::ONE);
        let along = |y: f32| Vec3::new(0.5, y, 1.25);
        assert!(segment_box_overlap(along(-1.0), along(2.0), 0.25, lo, hi));
        assert!(!segment_box_overlap(along(-1.0), along(2.0), 0.125, lo, hi));
        assert!(segment_box_overlap(along(0.5), along(0.5), 0.25, lo, hi));
        assert!(!segment_box_overlap(along(-1.0), along(-0.5), 0.3, lo, hi));
    }

    /// The separating-axis test with every edge axis built as a full cross product and every
    /// projection as a full dot product: what [`triangle_box_overlap`] computed before its edge
    /// axes were written out.
    fn overlap_with_full_products(center: Vec3, half: Vec3, tri: &[Vec3; 3]) -> bool {
        let v = [tri[0] - center, tri[1] - center, tri[2] - center];
        faces_and_plane_overlap(half, &v) && edge_axes_overlap(half, &v)
    }

    /// The box's face axes and the triangle's plane (`v` relative to the box's centre).
    fn faces_and_plane_overlap(half: Vec3, v: &[Vec3; 3]) -> bool {
        for a in 0..3 {
            let lo = v[0][a].min(v[1][a]).min(v[2][a]);
            let hi = v[0][a].max(v[1][a]).max(v[2][a]);
            if lo > half[a] || hi < -half[a] {
                return false;
            }
        }
        let n = (v[1] - v[0]).cross(v[2] - v[1]);
        n.dot(v[0]).abs() <= half.dot(n.abs())
    }

    /// The nine edge axes, as full cross and dot products.
    fn edge_axes_overlap(half: Vec3, v: &[Vec3; 3]) -> bool {
        for edge in [v[1] - v[0], v[2] - v[1], v[0] - v[2]] {
            for unit in [Vec3::X, Vec3::Y, Vec3::Z] {
                let axis = unit.cross(edge);
                let p = [axis.dot(v[0]), axis.dot(v[1]), axis.dot(v[2])];
                let r = half.dot(axis.abs());
                if p[0].min(p[1]).min(p[2]) > r || p[0].max(p[1]).max(p[2]) < -r {
                    return false;
                }
            }
        }
        true
    }

    /// A fixed sequence of coordinates around the box `[-1, 1]³`: its faces, its centre, values
    /// a rounding step off them, and values spread between.
    fn coordinates() -> impl FnMut() -> f32 {
        let mut next = xorshift(0x9e37_79b9);
        move || {
            let state = next();
            let special = [-1.0, 1.0, 0.0, -1.000_000_1, 1.000_000_1, 0.999_999_94, 3.0];
            let u = state as f32 / u32::MAX as f32;
            if state % 3 == 0 {
                special[(state >> 8) as usize % special.len()]
            } else {
                u * 6.0 - 3.0
            }
        }
    }

    #[test]
    fn written_out_edge_axes_in_lanes_decide_as_full_products() {
        let mut next = coordinates();
        let (mut overlaps, mut by_edges) = (0, 0);
        // Centres off the origin too, where `tri − center` rounds.
        let centers = [
            Vec3::ZERO,
            Vec3::new(0.3, -1.7, 2.9),
            Vec3::new(-1e3, 37.1, 0.01),
        ];
        for k in 0..200_000 {
            let center = centers[k % centers.len()];
            let tri = [(); 3].map(|_| Vec3::new(next(), next(), next()) + center);
            let half = Vec3::ONE + Vec3::new(next(), 0.0, next()).abs() * 0.25;
            let got = triangle_box_overlap(center, half, &tri);
            assert_eq!(
                got,
                overlap_with_full_products(center, half, &tri),
                "{tri:?} around {center}"
            );
            overlaps += usize::from(got);
            let v = tri.map(|p| p - center);
            by_edges += usize::from(!got && faces_and_plane_overlap(half, &v));
        }
        // Both answers occur often, and many separations are found by an edge axis alone.
        assert!(
            overlaps > 20_000 && by_edges > 5_000,
            "{overlaps} / {by_edges}"
        );
    }

    #[test]
    fn separates_and_touches() {
        let c = Vec3::ZERO;
        let h = Vec3::ONE;
        let inside = [
            Vec3::new(-0.5, 0.0, 0.0),
            Vec3::new(0.5, 0.0, 0.0),
            Vec3::new(0.0, 0.5, 0.0),
        ];
        assert!(triangle_box_overlap(c, h, &inside));
        let far = inside.map(|p| p + Vec3::new(5.0, 0.0, 0.0));
        assert!(!triangle_box_overlap(c, h, &far));
        // Touches the face x = 1 at a vertex.
        let touch = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 0.5, 0.0),
        ];
        assert!(triangle_box_overlap(c, h, &touch));
        // Its bounding box overlaps the corner, the triangle does not (diagonal edge axis).
        let diag = [
            Vec3::new(2.5, 0.0, 0.0),
            Vec3::new(0.0, 2.5, 0.0),
            Vec3::new(2.5, 2.5, 0.0),
        ];
        assert!(!triangle_box_overlap(c, h, &diag));
    }
}
