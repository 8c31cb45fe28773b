//! One shape against one ray, in the shape's object space.
//!
//! [`span`] returns the interval of `t` in which the ray is inside the (convex) shape, with the
//! face crossed at each end. Each crossing carries a bound on the error of its `t`, so callers can
//! tell a crossing at the ray's origin from one in front of it and merge crossings that coincide.
//! [`surface`] puts a hit back on the exact surface (pbrt-v4's re-projection) with the error bound
//! of the point, and [`normal`] gives the outward normal of a face.

use super::cylinder_miss::surely_misses_side;
use super::sphere_miss::surely_misses;
use super::Shape;
use crate::math::aabb::Aabb;
use crate::math::float::gamma;
use crate::math::lanes::sqrt;
use crate::math::norm::Norm;
use glam::Vec3;

/// Which face of a shape a crossing lies on (box: `2·axis + (1 if +side)`; cylinder: 0 side,
/// 1 bottom cap, 2 top cap; mesh: the triangle's index in the mesh; sphere and plane: 0).
pub type Face = u32;

/// Where a ray crosses a shape's surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crossing {
    /// Ray parameter (may be infinite for the open end of an unbounded span).
    pub t: f32,
    /// Bound on the error of `t` as a distance along the ray: a crossing closer to the origin than
    /// this is at the origin.
    pub t_error: f32,
    /// Bound on the error of `t` from the error of the crossing point across the surface: the
    /// point's error divided by the cosine of the angle of incidence (large for grazing rays).
    /// Coinciding faces of CSG operands are merged within it.
    pub merge_error: f32,
    /// The face crossed.
    pub face: Face,
}

/// The part of a ray inside a convex shape: from `enter.t` to `exit.t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeSpan {
    /// Where the ray goes in (`t = −∞` if it starts inside an unbounded shape).
    pub enter: Crossing,
    /// Where it comes out (`t = +∞` if it never does).
    pub exit: Crossing,
}

const OPEN: Crossing = Crossing {
    t: f32::INFINITY,
    t_error: 0.0,
    merge_error: 0.0,
    face: 0,
};

/// Bound on the error of a crossing at `t` of the ray `o + t·d`: the rounding of the hit point
/// (at the scale of the origin and the point) measured in units of `d`.
#[inline]
fn crossing_error(o: Vec3, d: Vec3, t: f32) -> f32 {
    position_error(o, d, t) / d.abs().max_element()
}

/// Bound on the rounding of the crossing point `o + t·d`, at the scale of the origin and the
/// point (world units of the shape's object space).
#[inline]
fn position_error(o: Vec3, d: Vec3, t: f32) -> f32 {
    gamma(16) * (o.abs().max_element() + (o + d * t).abs().max_element())
}

/// The two roots of `a·t² + b·t + c = 0` in increasing order, computed without cancellation.
/// `lone_sphere.rs` computes the same for several spheres at once, operation for operation.
#[inline]
fn quadratic(a: f32, b: f32, disc: f32, c: f32) -> Option<(f32, f32)> {
    if disc < 0.0 || a == 0.0 {
        return None;
    }
    let root = sqrt(disc);
    let q = if b < 0.0 {
        -0.5 * (b - root)
    } else {
        -0.5 * (b + root)
    };
    if q == 0.0 {
        return Some((0.0, 0.0));
    }
    let (t0, t1) = (q / a, c / q);
    Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
}

/// A crossing at `t` on `face`, where the ray's direction has component `along` on the surface's
/// unit normal.
fn crossing(o: Vec3, d: Vec3, t: f32, face: Face, along: f32) -> Crossing {
    let position = position_error(o, d, t);
    let t_error = position / d.abs().max_element();
    let merge_error = (position / along.abs()).max(t_error);
    Crossing {
        t,
        t_error,
        merge_error: if merge_error.is_nan() {
            f32::INFINITY
        } else {
            merge_error
        },
        face,
    }
}

/// The span of the ray `o + t·d` (object space, `d` not zero) inside `shape`, or `None` if the
/// ray misses it. The span may lie partly or wholly behind the origin.
pub fn span(shape: &Shape, o: Vec3, d: Vec3) -> Option<ShapeSpan> {
    match *shape {
        Shape::Sphere { radius } => sphere(radius, o, d),
        Shape::Plane { normal, d: offset } => plane(normal, offset, o, d),
        Shape::Cuboid { size } => cuboid(size * 0.5, o, d),
        Shape::Cylinder {
            bottom_radius,
            top_radius,
            height,
        } => cylinder(bottom_radius, top_radius, height, o, d),
    }
}

/// True if a crossing at `t` with error bound `t_error` lies provably in front of the ray's
/// origin (and is a real crossing, not the open end of an unbounded span).
#[inline]
pub fn in_front(t: f32, t_error: f32) -> bool {
    t > t_error && t.is_finite()
}

/// The first crossing of the ray `o + t·d` with `shape`'s surface in front of its origin (beyond
/// the crossing's error bound) and below `t_max`, as `(t, t_error, face)`: exactly the first
/// front end of [`span`], found with less work. A sphere's roots and a cylinder's ends are
/// compared with `t_max` before any error bound is computed, and the exit's bound only when the
/// entry is behind.
#[inline]
pub fn first_crossing(shape: &Shape, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32, Face)> {
    match *shape {
        Shape::Sphere { radius } => sphere_first_crossing(radius, o, d, t_max),
        Shape::Cylinder {
            bottom_radius,
            top_radius,
            height,
        } => {
            let ends = cylinder_ends(bottom_radius, top_radius, height, o, d)?;
            first_end_in_front(o, d, ends, t_max)
        }
        _ => {
            let s = span(shape, o, d)?;
            let first = [s.enter, s.exit]
                .into_iter()
                .find(|c| in_front(c.t, c.t_error))?;
            (first.t < t_max).then_some((first.t, first.t_error, first.face))
        }
    }
}

/// [`first_crossing`] for the sphere of radius `radius` around the origin.
#[inline(always)]
pub fn sphere_first_crossing(
    radius: f32,
    o: Vec3,
    d: Vec3,
    t_max: f32,
) -> Option<(f32, f32, Face)> {
    let roots = sphere_roots(radius, o, d)?;
    first_root_in_front(o, d, roots, t_max)
}

/// Of a sphere's roots `(t0, t1)` (in increasing order) on the ray `o + t·d`, the first in front
/// of the origin, if it is below `t_max`: the rest of [`sphere_first_crossing`].
#[inline(always)]
pub fn first_root_in_front(
    o: Vec3,
    d: Vec3,
    (t0, t1): (f32, f32),
    t_max: f32,
) -> Option<(f32, f32, Face)> {
    if t0 >= t_max {
        // Both roots are at or past t_max, so whichever is in front is too.
        return None;
    }
    if !(t0 > 0.0 || t1 > 0.0) {
        // A root is in front only above its error bound, which is not negative: both are
        // behind (or NaN), and no bound needs computing.
        return None;
    }
    for t in [t0, t1] {
        let t_error = crossing_error(o, d, t);
        if in_front(t, t_error) {
            return (t < t_max).then_some((t, t_error, 0));
        }
    }
    None
}

/// Where the ray `o + t·d` meets the sphere of radius `r` around the origin, in increasing order.
/// `lone_sphere.rs` computes the same for several spheres at once, operation for operation.
#[inline]
fn sphere_roots(r: f32, o: Vec3, d: Vec3) -> Option<(f32, f32)> {
    if surely_misses(r, o, d) {
        // What the distance form below finds too, without its division.
        return None;
    }
    let a = d.dot(d);
    let b = 2.0 * o.dot(d);
    let c = o.dot(o) - r * r;
    // The discriminant from the distance of the centre to the line (pbrt-v4): no cancellation
    // between b² and 4ac when the ray passes far from the centre.
    let f = o - d * (o.dot(d) / a);
    let disc = 4.0 * a * (r * r - f.dot(f));
    quadratic(a, b, disc, c)
}

fn sphere(r: f32, o: Vec3, d: Vec3) -> Option<ShapeSpan> {
    let (t0, t1) = sphere_roots(r, o, d)?;
    Some(ShapeSpan {
        enter: crossing(o, d, t0, 0, d.dot(o + d * t0) / r),
        exit: crossing(o, d, t1, 0, d.dot(o + d * t1) / r),
    })
}

fn plane(n: Vec3, offset: f32, o: Vec3, d: Vec3) -> Option<ShapeSpan> {
    let unit = n.unit();
    let dist = unit.dot(o) - offset; // > 0: outside
    let speed = unit.dot(d);
    if speed == 0.0 {
        return (dist <= 0.0).then_some(ShapeSpan {
            enter: Crossing {
                t: f32::NEG_INFINITY,
                ..OPEN
            },
            exit: OPEN,
        });
    }
    let t = -dist / speed;
    let t_error =
        gamma(8) * (unit.abs().dot(o.abs()) + offset.abs()) / speed.abs() + crossing_error(o, d, t);
    let c = Crossing {
        t,
        t_error,
        merge_error: t_error,
        face: 0,
    };
    Some(if speed < 0.0 {
        ShapeSpan {
            enter: c,
            exit: OPEN,
        }
    } else {
        ShapeSpan {
            enter: Crossing {
                t: f32::NEG_INFINITY,
                ..OPEN
            },
            exit: c,
        }
    })
}

fn cuboid(half: Vec3, o: Vec3, d: Vec3) -> Option<ShapeSpan> {
    // Each axis's slab as (near, far, near face, far face); `None` where the ray runs parallel to
    // the slab and inside it.
    let mut slabs = [None; 3];
    for a in 0..3 {
        if d[a] == 0.0 {
            if !in_slab_parallel(o[a], half[a], position_error(o, d, 0.0)) {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d[a];
        let (near, far) = ((-half[a] - o[a]) * inv, (half[a] - o[a]) * inv);
        let (near_face, far_face) = (2 * a as u32, 2 * a as u32 + 1);
        slabs[a] = Some(if near <= far {
            (near, far, near_face, far_face)
        } else {
            (far, near, far_face, near_face)
        });
    }
    for a in 0..3 {
        if in_face_plane(half, o, d, a, &slabs) {
            slabs[a] = None;
        }
    }
    let mut enter = Crossing {
        t: f32::NEG_INFINITY,
        ..OPEN
    };
    let mut exit = OPEN;
    for (a, slab) in slabs.iter().enumerate() {
        let Some((near, far, near_face, far_face)) = *slab else {
            continue;
        };
        // Ties go to the lower axis, so a ray through an edge names one face on every machine.
        if near > enter.t {
            enter = crossing(o, d, near, near_face, d[a]);
        }
        if far < exit.t {
            exit = crossing(o, d, far, far_face, d[a]);
        }
    }
    touching(enter, exit)
}

/// Whether a ray parallel to the slab `−h ≤ x ≤ h` at coordinate `x` (known within `error`) is
/// inside it. Exactly on a face plane the slab is half-open, `[−h, h)`: two boxes that share a
/// face exactly claim its plane once, so their union has no crack along it and their
/// intersection, of zero volume, stays empty. Within `error` of a plane but not on it, the ray
/// counts as inside: where two operands' faces coincide only up to rounding (a rotated union of
/// boxes sharing a face), neither can drop it, so it cannot fall through a crack between them.
fn in_slab_parallel(x: f32, h: f32, error: f32) -> bool {
    if x == h {
        false
    } else {
        x == -h || (x.abs() - h).abs() <= error || (-h < x && x < h)
    }
}

/// True if the ray stays within its rounding error of one of axis `a`'s face planes all the way
/// through the other two slabs: as far as f32 can tell it runs parallel to that plane, and its
/// crossing of the plane is noise. The slab then counts as inside by [`in_slab_parallel`]'s
/// rule for rays near a plane.
fn in_face_plane(
    half: Vec3,
    o: Vec3,
    d: Vec3,
    a: usize,
    slabs: &[Option<(f32, f32, Face, Face)>; 3],
) -> bool {
    if slabs[a].is_none() {
        return false;
    }
    let (mut lo, mut hi) = (f32::NEG_INFINITY, f32::INFINITY);
    for (b, slab) in slabs.iter().enumerate() {
        if let (true, Some((near, far, ..))) = (b != a, slab) {
            lo = lo.max(*near);
            hi = hi.min(*far);
        }
    }
    if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
        return false;
    }
    // Within the point's rounding error of the face plane at both ends (the second end and its
    // error are only computed when the first is, as almost every ray fails there).
    let on_face = |t: f32| {
        let x = o[a] + d[a] * t;
        ((x.abs() - half[a]).abs() <= position_error(o, d, t)).then_some(x < 0.0)
    };
    match on_face(lo) {
        Some(below) => on_face(hi) == Some(below),
        None => false,
    }
}

/// The parameter of the point of the ray `o + t·d` nearest the object-space origin (0 if `d` is
/// too short for its square to be finite and non-zero).
#[inline]
fn nearest_to_centre(o: Vec3, d: Vec3) -> f32 {
    let s = -o.dot(d) / d.dot(d);
    if s.is_finite() {
        s
    } else {
        0.0
    }
}

/// The span from `enter` to `exit`; a ray that only touches the shape, with `exit` before
/// `enter` by less than their error bounds, gets a span of length zero at `enter` (so spans
/// stay ordered), and one that passes farther away misses.
fn touching(enter: Crossing, mut exit: Crossing) -> Option<ShapeSpan> {
    if enter.t <= exit.t {
        return Some(ShapeSpan { enter, exit });
    }
    if enter.t <= exit.t + exit.t_error + enter.t_error {
        exit.t = enter.t;
        return Some(ShapeSpan { enter, exit });
    }
    None
}

fn cylinder(r0: f32, r1: f32, h: f32, o: Vec3, d: Vec3) -> Option<ShapeSpan> {
    let (lo, hi, lo_face, hi_face) = cylinder_ends(r0, r1, h, o, d)?;
    let along = |t: f32, face: Face| {
        if face == 0 {
            let p = o + d * t;
            d.dot(normal(
                &Shape::Cylinder {
                    bottom_radius: r0,
                    top_radius: r1,
                    height: h,
                },
                p,
                0,
            ))
        } else {
            d.y
        }
    };
    let enter = crossing(o, d, lo, lo_face, along(lo, lo_face));
    let exit = crossing(o, d, hi, hi_face, along(hi, hi_face));
    touching(enter, exit)
}

/// Where the ray enters and leaves a cylinder or cone, `(lo, hi, lo_face, hi_face)`, before the
/// crossings' error bounds: the caps' slab cut by the side's span.
#[inline]
fn cylinder_ends(r0: f32, r1: f32, h: f32, o: Vec3, d: Vec3) -> Option<(f32, f32, Face, Face)> {
    if is_cylinder(r0, r1, h) && surely_misses_side(r0, o, d) {
        // What `cone_side` finds too, without the divisions of the slab and the quadratic.
        return None;
    }
    let half = 0.5 * h;
    let (mut lo, mut hi, mut lo_face, mut hi_face) = cap_slab(o, d, half)?;
    let (side_lo, side_hi) = cone_side(r0, r1, h, o, d, (lo, hi))?;
    if side_lo > lo {
        lo = side_lo;
        lo_face = 0;
    }
    if side_hi < hi {
        hi = side_hi;
        hi_face = 0;
    }
    Some((lo, hi, lo_face, hi_face))
}

/// True if the cone with radii `r0`, `r1` and height `h` is a cylinder whose slope terms
/// vanish in [`cone_side`] (equal radii, a finite height that is not zero): the shapes
/// [`surely_misses_side`] answers for.
#[inline(always)]
pub fn is_cylinder(r0: f32, r1: f32, h: f32) -> bool {
    r0 == r1 && h.is_finite() && h != 0.0
}

/// Of the ends `(lo, hi, lo_face, hi_face)` of a span, the first in front of the origin if it
/// is below `t_max`: what [`span`] and [`touching`] give, with each end's error bound computed
/// only when it is looked at, and without the merge bounds (and the normals they need), which
/// only CSG uses.
#[inline]
fn first_end_in_front(
    o: Vec3,
    d: Vec3,
    (lo, hi, lo_face, hi_face): (f32, f32, Face, Face),
    t_max: f32,
) -> Option<(f32, f32, Face)> {
    if lo >= t_max {
        // Both ends are at or past t_max (an exit merged into the entry takes the entry's t).
        return None;
    }
    let enter_error = crossing_error(o, d, lo);
    let exit_t = if lo <= hi {
        hi
    } else {
        let exit_error = crossing_error(o, d, hi);
        if lo <= hi + exit_error + enter_error {
            lo
        } else {
            return None;
        }
    };
    if in_front(lo, enter_error) {
        return (lo < t_max).then_some((lo, enter_error, lo_face));
    }
    let exit_error = crossing_error(o, d, hi);
    (in_front(exit_t, exit_error) && exit_t < t_max).then_some((exit_t, exit_error, hi_face))
}

/// The span of `t` between a cylinder's caps at `y = ±half`, with the faces (1 bottom, 2 top)
/// where it enters and leaves; `None` for a ray parallel to the caps and outside their slab.
fn cap_slab(o: Vec3, d: Vec3, half: f32) -> Option<(f32, f32, Face, Face)> {
    if d.y == 0.0 {
        // Parallel to the caps: the box's rule for rays in a face plane.
        if !in_slab_parallel(o.y, half, position_error(o, d, 0.0)) {
            return None;
        }
        return Some((f32::NEG_INFINITY, f32::INFINITY, 1, 2));
    }
    let (a, b) = ((-half - o.y) / d.y, (half - o.y) / d.y);
    Some(if a <= b { (a, b, 1, 2) } else { (b, a, 2, 1) })
}

/// The span of `t` inside a cylinder's or cone's side, `x² + z² = (r0 + k·(y + h/2))²` (inside
/// where the left side is smaller), given the caps' span `slab`.
///
/// It is solved for `t − s` from the ray's point nearest the centre, `m = o + s·d`, not from
/// `o`: from a far origin, `b²` and `4ac` would be huge and nearly equal, and their difference
/// would lose the roots to cancellation (off by far more than a crossing's error bound). From
/// `m`, every coefficient has the size of the shape (the remedy the sphere's discriminant uses
/// too).
pub(super) fn cone_side(
    r0: f32,
    r1: f32,
    h: f32,
    o: Vec3,
    d: Vec3,
    slab: (f32, f32),
) -> Option<(f32, f32)> {
    let (lo, hi) = slab;
    let half = 0.5 * h;
    let s = nearest_to_centre(o, d);
    let m = o + d * s;
    let k = (r1 - r0) / h;
    let r_m = r0 + k * (m.y + half);
    let a = d.x * d.x + d.z * d.z - k * k * d.y * d.y;
    let b = 2.0 * (m.x * d.x + m.z * d.z - k * r_m * d.y);
    let c = m.x * m.x + m.z * m.z - r_m * r_m;
    let disc = b * b - 4.0 * a * c;
    if a == 0.0 {
        // Along a cone's generator (or the axis of a cylinder): linear.
        return if b == 0.0 {
            if c > 0.0 {
                return None;
            }
            Some((f32::NEG_INFINITY, f32::INFINITY))
        } else if b > 0.0 {
            Some((f32::NEG_INFINITY, s - c / b))
        } else {
            Some((s - c / b, f32::INFINITY))
        };
    }
    let (t0, t1) = quadratic(a, b, disc, c)?;
    let (t0, t1) = (s + t0, s + t1);
    if a > 0.0 {
        return Some((t0, t1));
    }
    // Inside the double cone outside the roots: keep the piece that overlaps the slab most (the
    // other nappe lies beyond the apex, outside the caps).
    let below = (lo.max(f32::NEG_INFINITY), hi.min(t0));
    let above = (lo.max(t1), hi.min(f32::INFINITY));
    Some(if below.1 - below.0 >= above.1 - above.0 {
        (f32::NEG_INFINITY, t0)
    } else {
        (t1, f32::INFINITY)
    })
}

/// The outward normal (unit length) of `face` of `shape` at the object-space point `p`.
pub fn normal(shape: &Shape, p: Vec3, face: Face) -> Vec3 {
    match *shape {
        Shape::Sphere { .. } => p.unit_or_zero(),
        Shape::Plane { normal, .. } => normal.unit(),
        Shape::Cuboid { .. } => {
            let axis = (face / 2) as usize;
            let mut n = Vec3::ZERO;
            n[axis] = if face % 2 == 1 { 1.0 } else { -1.0 };
            n
        }
        Shape::Cylinder {
            bottom_radius,
            top_radius,
            height,
        } => match face {
            1 => Vec3::NEG_Y,
            2 => Vec3::Y,
            _ => {
                let k = (top_radius - bottom_radius) / height;
                let r = bottom_radius + k * (p.y + 0.5 * height);
                Vec3::new(p.x, -k * r, p.z).unit_or_zero()
            }
        },
    }
}

/// The hit at `t` (error bound `t_error`) of the object-space ray `o + t·d` on `face`, moved onto
/// the exact surface (up to rounding), and the per-axis bound on its remaining error.
pub fn surface(shape: &Shape, o: Vec3, d: Vec3, t: f32, t_error: f32, face: Face) -> (Vec3, Vec3) {
    let p = o + d * t;
    // Before re-projection the point is off by the error of t along d, plus the sum's rounding.
    let rough = d.abs() * t_error + (o.abs() + p.abs()) * gamma(3);
    match *shape {
        Shape::Sphere { radius } => {
            let len = p.norm();
            if len == 0.0 {
                return (p, rough);
            }
            let q = p * (radius / len);
            (q, q.abs() * gamma(5))
        }
        Shape::Plane { normal, d } => {
            let unit = normal.unit();
            let q = p - unit * (unit.dot(p) - d);
            (q, (q.abs() + Vec3::splat(d.abs())) * gamma(8))
        }
        Shape::Cuboid { size } => cuboid_surface(size, p, rough, face),
        Shape::Cylinder {
            bottom_radius,
            top_radius,
            height,
        } => cylinder_surface((bottom_radius, top_radius, height), p, rough, face),
    }
}

/// A box's hit point `p` (error bound `rough`) on `face`, put exactly on the face plane and
/// within the face.
fn cuboid_surface(size: Vec3, p: Vec3, rough: Vec3, face: Face) -> (Vec3, Vec3) {
    let half = size * 0.5;
    let axis = (face / 2) as usize;
    let mut q = p;
    q[axis] = if face % 2 == 1 {
        half[axis]
    } else {
        -half[axis]
    };
    let mut err = rough;
    err[axis] = 0.0;
    // A ray within its rounding error of a face plane counts as inside that slab
    // (`in_slab_parallel`, `in_face_plane`), and a ray that only touches an edge gets a
    // span of length zero: either way the point may lie just beyond the face it names.
    // It is pulled back onto the face, and the distance moved joins its error bound.
    for b in (0..3).filter(|&b| b != axis) {
        let inside = q[b].clamp(-half[b], half[b]);
        err[b] += (q[b] - inside).abs();
        q[b] = inside;
    }
    (q, err)
}

/// A cylinder's or cone's hit point `p` (error bound `rough`) on `face`, put on the cap or the
/// side at its height.
fn cylinder_surface(shape: (f32, f32, f32), p: Vec3, rough: Vec3, face: Face) -> (Vec3, Vec3) {
    let (bottom_radius, top_radius, height) = shape;
    let half = 0.5 * height;
    let mut q = p;
    let across = sqrt(p.x * p.x + p.z * p.z);
    if face != 0 {
        // On a cap: exactly on its plane, and (like a box's face) pulled back onto the
        // disc if a ray that counts as inside the caps' slab or only touches the rim
        // put it just beyond, the distance moved joining the error bound.
        q.y = if face == 2 { half } else { -half };
        let mut err = rough;
        err.y = 0.0;
        let r = if face == 2 { top_radius } else { bottom_radius };
        if across > r {
            q.x = p.x * (r / across);
            q.z = p.z * (r / across);
            err.x += (p.x - q.x).abs();
            err.z += (p.z - q.z).abs();
        }
        return (q, err);
    }
    // On the side: between the caps (pulled back like a cap's point), moved across the
    // axis onto the radius at its height.
    q.y = p.y.clamp(-half, half);
    let moved = (p.y - q.y).abs();
    let k = (top_radius - bottom_radius) / height;
    let r = (bottom_radius + k * (q.y + half)).max(0.0);
    if across == 0.0 {
        let mut err = rough;
        err.y += moved;
        return (q, err);
    }
    q.x = p.x * (r / across);
    q.z = p.z * (r / across);
    let mut err = q.abs() * gamma(8);
    err.y += moved;
    (q, err)
}

/// The object-space box around `shape` (infinite for a plane).
pub fn object_bounds(shape: &Shape) -> Aabb {
    match *shape {
        Shape::Sphere { radius } => Aabb {
            min: Vec3::splat(-radius),
            max: Vec3::splat(radius),
        },
        Shape::Plane { .. } => Aabb {
            min: Vec3::splat(f32::NEG_INFINITY),
            max: Vec3::splat(f32::INFINITY),
        },
        Shape::Cuboid { size } => Aabb {
            min: -size * 0.5,
            max: size * 0.5,
        },
        Shape::Cylinder {
            bottom_radius,
            top_radius,
            height,
        } => {
            let r = bottom_radius.max(top_radius);
            Aabb {
                min: Vec3::new(-r, -0.5 * height, -r),
                max: Vec3::new(r, 0.5 * height, r),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_span_from_outside_and_inside() {
        let s = Shape::Sphere { radius: 1.0 };
        let sp = span(&s, Vec3::new(0.0, 0.0, -3.0), Vec3::Z).expect("hit");
        assert_eq!((sp.enter.t, sp.exit.t), (2.0, 4.0));
        let inside = span(&s, Vec3::ZERO, Vec3::Z).expect("hit");
        assert_eq!((inside.enter.t, inside.exit.t), (-1.0, 1.0));
        assert!(span(&s, Vec3::new(2.0, 0.0, -3.0), Vec3::Z).is_none());
    }

    #[test]
    fn box_faces_and_normals() {
        let s = Shape::Cuboid {
            size: Vec3::new(2.0, 4.0, 6.0),
        };
        let sp = span(&s, Vec3::new(0.0, -10.0, 0.0), Vec3::Y).expect("hit");
        assert_eq!((sp.enter.t, sp.exit.t), (8.0, 12.0));
        assert_eq!(normal(&s, Vec3::ZERO, sp.enter.face), Vec3::NEG_Y);
        assert_eq!(normal(&s, Vec3::ZERO, sp.exit.face), Vec3::Y);
        assert!(span(&s, Vec3::new(1.5, -10.0, 0.0), Vec3::Y).is_none());
    }

    #[test]
    fn plane_is_a_half_space() {
        let s = Shape::Plane {
            normal: Vec3::Y,
            d: 1.0,
        };
        let down = span(&s, Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y).expect("hit");
        assert_eq!(down.enter.t, 4.0);
        assert_eq!(down.exit.t, f32::INFINITY);
        let parallel_outside = span(&s, Vec3::new(0.0, 5.0, 0.0), Vec3::X);
        assert!(parallel_outside.is_none());
    }

    #[test]
    fn cylinder_side_and_caps() {
        let s = Shape::Cylinder {
            bottom_radius: 1.0,
            top_radius: 1.0,
            height: 2.0,
        };
        let across = span(&s, Vec3::new(-5.0, 0.0, 0.0), Vec3::X).expect("hit");
        assert_eq!((across.enter.t, across.exit.t), (4.0, 6.0));
        assert_eq!(across.enter.face, 0);
        let down = span(&s, Vec3::new(0.0, 5.0, 0.0), Vec3::NEG_Y).expect("hit");
        assert_eq!((down.enter.t, down.exit.t), (4.0, 6.0));
        assert_eq!((down.enter.face, down.exit.face), (2, 1));
        // A cone with its apex at the top: a horizontal ray near the top is short.
        let cone = Shape::Cylinder {
            bottom_radius: 1.0,
            top_radius: 0.0,
            height: 2.0,
        };
        let near_top = span(&cone, Vec3::new(-5.0, 0.5, 0.0), Vec3::X).expect("hit");
        assert!((near_top.exit.t - near_top.enter.t - 0.5).abs() < 1e-5);
        let n = normal(&cone, Vec3::new(0.5, 0.0, 0.0), 0);
        assert!(n.x > 0.0 && n.y > 0.0, "cone side leans up: {n:?}");
    }
}
