//! Whether a primitive must be filed in a cell: triangle/box overlap by the separating-axis
//! theorem (Akenine-Möller 2001), and a sphere's surface against a box (Arvo 1990: the nearest
//! and the farthest point of the box from the centre).

use crate::math::aabb::Aabb;
use crate::math::float::gamma;
use glam::{Vec3, Vec3A, Vec3Swizzles};
use wide::{f64x4, CmpGe, CmpLe};

/// True if the surface of the sphere `center`, `radius` comes within `margin` of the box
/// `lo..hi`: the box reaches the sphere grown by `margin` and is not inside the sphere shrunk by
/// it. A ray can only hit the sphere where its surface is, so a cell wholly inside or outside
/// it needs no test of it. In `f64`, whose rounding is far below any margin a caller gives.
///
/// The build asks this of a cell's eight children at once ([`sphere_surface_children`], from
/// each axis's [`axis_terms`] of its two sides); this one-box form is the tests' reference.
#[cfg(test)]
pub(super) fn sphere_surface_box_overlap(
    center: Vec3,
    radius: f32,
    margin: f32,
    lo: Vec3,
    hi: Vec3,
) -> bool {
    let terms: [(f64, f64); 3] = core::array::from_fn(|a| axis_terms(center[a], lo[a], hi[a]));
    let near = terms[0].0 + terms[1].0 + terms[2].0;
    let far = terms[0].1 + terms[1].1 + terms[2].1;
    let (outer, inner) = shell(radius, margin);
    near <= outer && far >= inner
}

/// Along one axis, the squared distances from the centre coordinate `c` to the nearest and the
/// farthest point of the box's side `l..h`: Arvo's terms, in `f64`.
#[inline]
pub(super) fn axis_terms(c: f32, l: f32, h: f32) -> (f64, f64) {
    let (c, l, h) = (f64::from(c), f64::from(l), f64::from(h));
    let d = if c < l {
        l - c
    } else if c > h {
        c - h
    } else {
        0.0
    };
    let f = (c - l).abs().max((h - c).abs());
    (d * d, f * f)
}

/// The children of a cell (bit `c` for child `c`) whose box the surface of a sphere of `radius`
/// comes within `margin` of: its nearest point within the sphere grown by `margin`, its farthest
/// outside the sphere shrunk by it. `terms[a]` holds the [`axis_terms`] of the lower and the
/// upper side along axis `a`; child `c` has the upper one where bit `a` of `c` is set. Children
/// 0–3 and 4–7 fill the lanes of two `f64x4`, summed axis by axis as for one box alone
/// (`sphere_surface_box_overlap`, the tests' reference): each answer to the bit.
#[inline]
pub(super) fn sphere_surface_children(radius: f32, margin: f32, terms: [[(f64, f64); 2]; 3]) -> u8 {
    let near = children_sums(terms.map(|sides| sides.map(|t| t.0)));
    let far = children_sums(terms.map(|sides| sides.map(|t| t.1)));
    let (outer, inner) = shell(radius, margin);
    let (outer, inner) = (f64x4::splat(outer), f64x4::splat(inner));
    let within = |k: usize| (near[k].cmp_le(outer) & far[k].cmp_ge(inner)).move_mask() as u8;
    within(0) | within(1) << 4
}

/// Per child (children 0–3 in the first `f64x4`, 4–7 in the second), the sum of its three
/// sides' values `[x, y, z]` (each the lower and the upper side's), added x, y, z in turn.
#[inline(always)]
fn children_sums([x, y, z]: [[f64; 2]; 3]) -> [f64x4; 2] {
    let xy = f64x4::new([x[0], x[1], x[0], x[1]]) + f64x4::new([y[0], y[0], y[1], y[1]]);
    [xy + f64x4::splat(z[0]), xy + f64x4::splat(z[1])]
}

/// The squared radii of the sphere of `radius` grown and shrunk by `margin` (not below zero).
#[inline]
fn shell(radius: f32, margin: f32) -> (f64, f64) {
    let outer = f64::from(radius) + f64::from(margin);
    let inner = (f64::from(radius) - f64::from(margin)).max(0.0);
    (outer * outer, inner * inner)
}

/// True if the segment `a`–`b` comes within `reach` of the box `lo..hi`: it crosses the box
/// grown by `reach` on every side (which holds every point within `reach` of the box, and the
/// corners' neighbourhoods besides), by the slab test in `f64`, whose rounding is far below any
/// reach a caller gives. A cylinder or cone lies within its larger radius of its axis, so a box
/// its axis passes farther from holds no point of it.
///
/// The build asks this of a cell's children through [`slab_interval`] and [`segment_within`];
/// this one-box form is the tests' reference.
#[cfg(test)]
pub(super) fn segment_box_overlap(a: Vec3, b: Vec3, reach: f32, lo: Vec3, hi: Vec3) -> bool {
    segment_within(core::array::from_fn(|k| {
        slab_interval(a[k], b[k], reach, lo[k], hi[k])
    }))
}

/// Along one axis, the part `t0..t1` of the segment `from`–`to` (`t` from 0 to 1) within the
/// box's side `l..h` grown by `reach`, in `f64`: everything (`−∞..∞`) for a segment square to
/// the axis within it, nothing (`∞..−∞`) for one outside it.
#[inline]
pub(super) fn slab_interval(from: f32, to: f32, reach: f32, l: f32, h: f32) -> (f64, f64) {
    let (from, to) = (f64::from(from), f64::from(to));
    let grown_lo = f64::from(l) - f64::from(reach);
    let grown_hi = f64::from(h) + f64::from(reach);
    let d = to - from;
    if d == 0.0 {
        return if from < grown_lo || from > grown_hi {
            (f64::INFINITY, f64::NEG_INFINITY)
        } else {
            (f64::NEG_INFINITY, f64::INFINITY)
        };
    }
    let (t0, t1) = ((grown_lo - from) / d, (grown_hi - from) / d);
    (t0.min(t1), t0.max(t1))
}

/// True if the segment crosses the grown box whose [`slab_interval`]s are `slabs`: its part
/// `0..1` cut by each, not empty.
#[inline]
pub(super) fn segment_within(slabs: [(f64, f64); 3]) -> bool {
    let (mut enter, mut leave) = (0.0f64, 1.0f64);
    for (t0, t1) in slabs {
        enter = enter.max(t0);
        leave = leave.min(t1);
    }
    enter <= leave
}

/// A triangle's separating axes (Akenine-Möller's 13: the box's faces, the triangle's plane,
/// and each edge crossed with each box axis), with the triangle's extent along each, made once
/// and asked about several children of one cell ([`TriangleAxes::misses`]). Positions are taken
/// relative to the cell's centre `mid`; a child is the box `mid + offset ± half`.
///
/// The extents along the plane and edge axes are widened by the children's radius along them
/// (`half` projected), so a child needs only the projection of its offset: a child is separated
/// where that lies outside the widened extent. Touching counts as overlap.
///
/// Rounding: any axis separates if the projections are exact, so only they need a bound. With
/// `M` the largest coordinate of the root cell (every vertex and cell lies within it) and `S` an
/// axis's sum of absolute components, the vertices' projections are within 6 ε·M·S of exact
/// (ε = 2⁻²⁴: the vertex's difference from `mid`, two products and a sum), the radius 2 ε·M·S,
/// the widening 3 ε·M·S, the offset's projection 2 ε·M·S, and the child's offset and half 4 ε·M·S
/// from its box ([`super::filing::ChildCells`]): 17 ε·M·S; on the plane axis (three products
/// and two sums each) 21 ε·M·S. The build grows `half` by `gamma(`[`MARGIN_GAMMA`]`)`·M (a little
/// over 24 ε·M), which adds that times `S` to every radius, so a child the triangle touches is
/// never found separated.
pub(super) struct TriangleAxes {
    /// The triangle's box.
    min: Vec3A,
    max: Vec3A,
    /// The plane's normal, and the triangle's extent along it widened by the children's radius.
    normal: Vec3A,
    plane: (f32, f32),
    /// Per edge, lane `a` for its cross product with axis `a`.
    edges: [EdgeAxes; 3],
}

/// The three axes of one edge: lane `a` holds unit(a) × edge, whose nonzero components are `i`
/// at axis `a + 1` and `j` at axis `a + 2` (`−edge[a + 2]` and `edge[a + 1]`), and the
/// triangle's extent along it, widened by the children's radius.
struct EdgeAxes {
    i: Vec3A,
    j: Vec3A,
    lo: Vec3A,
    hi: Vec3A,
}

/// The margin's factor in [`gamma`](crate::math::float::gamma)s of the root's largest
/// coordinate: it covers [`TriangleAxes`]' rounding (at most 21 ε of it).
pub(super) const MARGIN_GAMMA: u32 = 24;

/// How far the build grows every cell before it files a primitive in it, for a tree whose root
/// cell is `root`: [`MARGIN_GAMMA`] roundings of the root's largest coordinate. The build and
/// every structure that relies on its filing ([`Octree::margin`](super::Octree::margin)) take
/// it from here.
pub(super) fn cell_margin(root: &Aabb) -> f32 {
    root.min.abs().max(root.max.abs()).max_element() * gamma(MARGIN_GAMMA)
}

impl TriangleAxes {
    /// The axes of `tri` for children of half size `half` (grown by the margin) of the cell
    /// centred at `mid`.
    pub(super) fn new(tri: &[Vec3; 3], mid: Vec3A, half: Vec3A) -> TriangleAxes {
        let p = tri.map(Vec3A::from);
        let u = p.map(|p| p - mid);
        let e = [u[1] - u[0], u[2] - u[1], u[0] - u[2]];
        let normal = e[0].yzx() * e[1].zxy() - e[1].yzx() * e[0].zxy();
        let sum = |v: Vec3A| v.x + v.y + v.z;
        let d = u.map(|u| sum(normal * u));
        let r = sum(half * normal.abs());
        let (hi, hj) = (half.yzx(), half.zxy());
        TriangleAxes {
            min: p[0].min(p[1]).min(p[2]),
            max: p[0].max(p[1]).max(p[2]),
            normal,
            plane: (d[0].min(d[1]).min(d[2]) - r, d[0].max(d[1]).max(d[2]) + r),
            edges: e.map(|edge| {
                let (i, j) = (-edge.zxy(), edge.yzx());
                let at = u.map(|u| i * u.yzx() + j * u.zxy());
                let r = hi * i.abs() + hj * j.abs();
                EdgeAxes {
                    i,
                    j,
                    lo: at[0].min(at[1]).min(at[2]) - r,
                    hi: at[0].max(at[1]).max(at[2]) + r,
                }
            }),
        }
    }

    /// True if one of the axes separates the triangle from the child `mid + offset ± half`,
    /// whose box grown by the margin is `lo..hi` (for the face axes, compared exactly).
    #[inline]
    pub(super) fn misses(&self, offset: Vec3A, lo: Vec3A, hi: Vec3A) -> bool {
        if (self.min.cmpgt(hi) | self.max.cmplt(lo)).any() {
            return true;
        }
        let at = offset * self.normal;
        let at = at.x + at.y + at.z;
        if at < self.plane.0 || at > self.plane.1 {
            return true;
        }
        self.edges.iter().any(|e| {
            let at = e.i * offset.yzx() + e.j * offset.zxy();
            (at.cmplt(e.lo) | at.cmpgt(e.hi)).any()
        })
    }
}

/// The separating-axis test in `f64` against the box `lo..hi`, from the triangle's `f32`
/// vertices: the reference for the `f32` filing's error bound, whose rounding (about 10⁻¹⁶ of the
/// coordinates) is far below the margin's.
#[cfg(test)]
pub(super) fn touches_in_f64(tri: &[Vec3; 3], lo: Vec3, hi: Vec3) -> bool {
    type D3 = [f64; 3];
    let sub = |a: D3, b: D3| -> D3 { core::array::from_fn(|k| a[k] - b[k]) };
    let dot = |a: D3, b: D3| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
    let cross = |a: D3, b: D3| -> D3 {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let wide = |v: Vec3| -> D3 { v.to_array().map(f64::from) };
    let (lo, hi) = (wide(lo), wide(hi));
    let c: D3 = core::array::from_fn(|k| (lo[k] + hi[k]) * 0.5);
    let h: D3 = core::array::from_fn(|k| (hi[k] - lo[k]) * 0.5);
    let v = tri.map(|p| sub(wide(p), c));
    let e = [sub(v[1], v[0]), sub(v[2], v[1]), sub(v[0], v[2])];
    let units = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let mut axes = alloc::vec![units[0], units[1], units[2], cross(e[0], e[1])];
    for edge in e {
        axes.extend(units.map(|unit| cross(unit, edge)));
    }
    axes.iter().all(|&axis| {
        let p = v.map(|v| dot(axis, v));
        let r = dot(h, axis.map(f64::abs));
        p[0].min(p[1]).min(p[2]) <= r && p[0].max(p[1]).max(p[2]) >= -r
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::octree::xorshift;
    use crate::math::lanes::sqrt;
    use crate::math::norm::Norm;

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
        let far_corner = sqrt(3.0 * 0.01);
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
        let golden = core::f32::consts::PI * (3.0 - sqrt(5.0));
        (0..n).map(move |i| {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / n as f32;
            let r = sqrt(1.0 - z * z);
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
            let axis = (b - a).unit();
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

    /// The separating-axis test in one call: the triangle against the box `center ± half`.
    fn overlaps(center: Vec3, half: Vec3, tri: &[Vec3; 3]) -> bool {
        let (c, h) = (Vec3A::from(center), Vec3A::from(half));
        let axes = TriangleAxes::new(tri, c, h);
        !axes.misses(Vec3A::ZERO, c - h, c + h)
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
        assert!(overlaps(c, h, &inside));
        let far = inside.map(|p| p + Vec3::new(5.0, 0.0, 0.0));
        assert!(!overlaps(c, h, &far));
        // Touches the face x = 1 at a vertex.
        let touch = [
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(2.0, 0.5, 0.0),
        ];
        assert!(overlaps(c, h, &touch));
        // Its bounding box overlaps the corner, the triangle does not (diagonal edge axis).
        let diag = [
            Vec3::new(2.5, 0.0, 0.0),
            Vec3::new(0.0, 2.5, 0.0),
            Vec3::new(2.5, 2.5, 0.0),
        ];
        assert!(!overlaps(c, h, &diag));
        // A slanted triangle whose box holds the whole box, its plane (x + y + z = −3.3) passing
        // beyond the corner at −3: found by the plane's axis alone.
        let slanted = [
            Vec3::new(16.7, -10.0, -10.0),
            Vec3::new(-10.0, 16.7, -10.0),
            Vec3::new(-10.0, -10.0, 16.7),
        ];
        assert!(!overlaps(c, h, &slanted));
        assert!(overlaps(c, h * 1.2, &slanted));
    }
}
