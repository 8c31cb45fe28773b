//! The watertight ray/triangle test (Woop, Benthin and Wald 2013, with pbrt-v4's error bounds).
//!
//! The ray is made the +z axis of a sheared coordinate system ([`RayFrame`], computed once per
//! ray); the triangle's vertices are transformed into it and three 2D edge functions decide the hit.
//! Edges shared by two triangles evaluate to bit-identical edge functions from both sides, so a
//! ray through a shared edge or vertex hits at least one of them: closed meshes do not leak. Edge
//! functions that come out exactly zero are recomputed in `f64`.
//!
//! A hit's `t` comes with an error bound. When the `f32` bound cannot tell whether `t` is
//! positive (a hit very close to the origin compared with the triangle's size, or a ray nearly
//! parallel to a large triangle), `t` and its bound are computed again in `f64` (`refine_in_f64`),
//! whose bound is some 5·10⁸ times tighter; a hit whose `t` is still not provably positive is
//! rejected. The inside/outside decision is always the `f32` one, so watertightness is kept.
//!
//! [`intersect4`] takes the same steps for four rays that share an axis permutation
//! ([`RayFrame4`], a packet's rays), one ray a lane, and leaves to [`intersect`] the rays whose
//! answer needs an `f64` step: every answer is `intersect`'s to the bit.

use crate::math::float::{gamma, next_float_up, MACHINE_EPSILON};
use crate::math::norm::Norm;
use crate::math::ray::Ray;
use glam::{Vec3, Vec3A, Vec4};

/// The per-ray part of the watertight test: the axis permutation and shear that map the ray
/// direction to +z.
#[derive(Clone, Copy, Debug)]
pub struct RayFrame {
    /// The ray's origin.
    pub origin: Vec3,
    /// The ray's direction (for the `f64` refinement).
    dir: Vec3,
    /// Index of the largest direction component: the new z.
    kz: usize,
    kx: usize,
    ky: usize,
    /// The origin's components on the new x, y and z axes (`origin[kx]`, `origin[ky]`,
    /// `origin[kz]`).
    permuted_origin: [f32; 3],
    sx: f32,
    sy: f32,
    sz: f32,
}

/// A hit found by [`intersect`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Absolute error bound on `t`.
    pub t_error: f32,
    /// Barycentric weights of the three vertices (they sum to one).
    pub b: [f32; 3],
}

impl RayFrame {
    /// Prepares the shear for `ray`. The direction must not be all zero.
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let a = ray.dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        // Components picked by index from arrays, as in `intersect`.
        let (d, o): (&[f32; 3], &[f32; 3]) = (ray.dir.as_ref(), ray.origin.as_ref());
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        let dz = d[kz];
        if dz < 0.0 {
            core::mem::swap(&mut kx, &mut ky);
        }
        // `-d[kx] / dz`, `-d[ky] / dz` and `1 / dz` as one vector division, lane by lane.
        let shear = Vec3A::new(-d[kx], -d[ky], 1.0) / Vec3A::splat(dz);
        RayFrame {
            origin: ray.origin,
            dir: ray.dir,
            kz,
            kx,
            ky,
            permuted_origin: [o[kx], o[ky], o[kz]],
            sx: shear.x,
            sy: shear.y,
            sz: shear.z,
        }
    }
}

/// Intersects the ray prepared in `frame` with triangle `p`, accepting hits with
/// `0 < t < t_max` (the lower bound is the hit's own error bound). Always inlined: the
/// octree's leaf loops call it for most of their work, and a call costs each test the saving
/// of registers (callgrind, 256×256, with `Scene::test_primitive` inlined too: teapot_12
/// −2.6 %, balls_3 −2.2 %, gears_3 −1.5 %).
#[inline(always)]
pub fn intersect(frame: &RayFrame, p: &[Vec3; 3], t_max: f32) -> Option<TriangleHit> {
    let (kx, ky, kz) = (frame.kx, frame.ky, frame.kz);
    // Translate to the ray origin and permute so the ray runs along +z.
    // Each component is picked by index from the vertex as an array: a load at an offset.
    // (Indexing the vector itself compiles to a chain of branches on the index.) Picking before
    // subtracting gives the same values as subtracting the whole vectors.
    let [ox, oy, oz] = frame.permuted_origin;
    let moved = |q: &Vec3| {
        let q: &[f32; 3] = q.as_ref();
        (q[kx] - ox, q[ky] - oy, q[kz] - oz)
    };
    let (mut p0x, mut p0y, mut p0z) = moved(&p[0]);
    let (mut p1x, mut p1y, mut p1z) = moved(&p[1]);
    let (mut p2x, mut p2y, mut p2z) = moved(&p[2]);
    // Shear x and y; z is scaled only once the edge test passed.
    p0x += frame.sx * p0z;
    p0y += frame.sy * p0z;
    p1x += frame.sx * p1z;
    p1y += frame.sy * p1z;
    p2x += frame.sx * p2z;
    p2y += frame.sy * p2z;

    let mut e0 = p1x * p2y - p1y * p2x;
    let mut e1 = p2x * p0y - p2y * p0x;
    let mut e2 = p0x * p1y - p0y * p1x;
    if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
        // Exactly on an edge in f32: decide in f64, where these products are exact.
        let (a0x, a0y, a1x, a1y, a2x, a2y) = (
            p0x as f64, p0y as f64, p1x as f64, p1y as f64, p2x as f64, p2y as f64,
        );
        e0 = (a1x * a2y - a1y * a2x) as f32;
        e1 = (a2x * a0y - a2y * a0x) as f32;
        e2 = (a0x * a1y - a0y * a1x) as f32;
    }
    // Both signs: a miss. The comparisons are combined without branches (`|`, `&` on bools):
    // whether a ray misses is hard to predict, so one branch costs less than a chain of them.
    let negative = (e0 < 0.0) | (e1 < 0.0) | (e2 < 0.0);
    let positive = (e0 > 0.0) | (e1 > 0.0) | (e2 > 0.0);
    if negative & positive {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 {
        return None;
    }

    // Largest |z| in world units, before scaling: the shear added at most |sx| (|sy|) times this
    // to x (y); |sx|, |sy| ≤ 1 because z is the largest direction component.
    let max_z_world = p0z.abs().max(p1z.abs()).max(p2z.abs());
    p0z *= frame.sz;
    p1z *= frame.sz;
    p2z *= frame.sz;
    let t_scaled = e0 * p0z + e1 * p1z + e2 * p2z;
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;

    // Error bound on t (pbrt-v4, "Ensure that computed triangle t is conservatively greater than zero").
    let max_zt = p0z.abs().max(p1z.abs()).max(p2z.abs());
    let max_xt = p0x.abs().max(p1x.abs()).max(p2x.abs());
    let max_yt = p0y.abs().max(p1y.abs()).max(p2y.abs());
    let max_e = e0.abs().max(e1.abs()).max(e2.abs());
    let delta_t = t_error_bound(
        (|c| c, gamma),
        [max_xt, max_yt, max_zt],
        max_z_world,
        [frame.sx.abs(), frame.sy.abs()],
        max_e,
    ) * inv_det.abs();
    // Which `t` is returned must not depend on `t_max` (the octree narrows `t_max` to the best
    // hit so far and must agree with a test of every triangle), so `t_max` is checked last.
    if t > delta_t {
        return (t < t_max).then_some(TriangleHit {
            t,
            t_error: delta_t + t * MACHINE_EPSILON,
            b: [e0 * inv_det, e1 * inv_det, e2 * inv_det],
        });
    }
    if t < -delta_t {
        return None;
    }
    // f32 cannot tell the sign of t (or t is NaN): decide in f64.
    refine_in_f64(frame, p, t_max, [e0 * inv_det, e1 * inv_det, e2 * inv_det])
}

/// Four rays' frames with one axis permutation, lane by lane, for [`intersect4`].
#[derive(Clone, Copy, Debug)]
pub struct RayFrame4 {
    kx: usize,
    ky: usize,
    kz: usize,
    /// The origins' components on the new x, y and z axes.
    origin: [Vec4; 3],
    sx: Vec4,
    sy: Vec4,
    sz: Vec4,
}

impl RayFrame4 {
    /// The four frames in lanes, or `None` if their axis permutations differ.
    pub fn new(frames: &[RayFrame; 4]) -> Option<Self> {
        let axes = |f: &RayFrame| (f.kx, f.ky, f.kz);
        if frames[1..].iter().any(|f| axes(f) != axes(&frames[0])) {
            return None;
        }
        let lanes = |f: &dyn Fn(&RayFrame) -> f32| {
            Vec4::new(f(&frames[0]), f(&frames[1]), f(&frames[2]), f(&frames[3]))
        };
        Some(RayFrame4 {
            kx: frames[0].kx,
            ky: frames[0].ky,
            kz: frames[0].kz,
            origin: core::array::from_fn(|k| lanes(&|f| f.permuted_origin[k])),
            sx: lanes(&|f| f.sx),
            sy: lanes(&|f| f.sy),
            sz: lanes(&|f| f.sz),
        })
    }
}

/// What [`intersect4`] decided for four rays and one triangle: the rays that hit it, with their
/// hits in lanes, and the rays it left to [`intersect`].
#[derive(Clone, Copy, Debug)]
pub struct TriangleHits4 {
    /// The rays (bit `l` for ray `l`) that hit, as [`intersect`] would report it.
    pub hit: u32,
    /// The rays whose answer only [`intersect`] gives: an edge function of exactly zero (decided
    /// in `f64`), a `t` whose sign the `f32` bound cannot tell, or a zero or NaN determinant.
    pub undecided: u32,
    t: Vec4,
    t_error: Vec4,
    b: [Vec4; 3],
}

impl TriangleHits4 {
    /// Ray `l`'s hit (meaningful where bit `l` of [`TriangleHits4::hit`] is set).
    #[inline]
    pub fn of(&self, l: usize) -> TriangleHit {
        TriangleHit {
            t: self.t[l],
            t_error: self.t_error[l],
            b: self.b.map(|b| b[l]),
        }
    }
}

/// [`intersect`] for the rays among `lanes` (bit `l` for ray `l`), four at a time, against
/// ray `l`'s bound `t_max[l]`: each lane takes the very operations `intersect` takes, in its
/// order, so a hit it reports is `intersect`'s to the bit. The rays whose edge functions have
/// both signs (none zero) miss, as in `intersect`, and most tests end there; a ray whose answer
/// `intersect` finds by its `f64` steps is left to it ([`TriangleHits4::undecided`]).
#[inline]
pub fn intersect4(frame: &RayFrame4, p: &[Vec3; 3], lanes: u32, t_max: Vec4) -> TriangleHits4 {
    let mut four = TriangleHits4 {
        hit: 0,
        undecided: 0,
        t: Vec4::ZERO,
        t_error: Vec4::ZERO,
        b: [Vec4::ZERO; 3],
    };
    let [ox, oy, oz] = frame.origin;
    let moved = |q: &Vec3| {
        let q: &[f32; 3] = q.as_ref();
        (
            Vec4::splat(q[frame.kx]) - ox,
            Vec4::splat(q[frame.ky]) - oy,
            Vec4::splat(q[frame.kz]) - oz,
        )
    };
    let (p0x, p0y, p0z) = moved(&p[0]);
    let (p1x, p1y, p1z) = moved(&p[1]);
    let (p2x, p2y, p2z) = moved(&p[2]);
    let (sx, sy) = (frame.sx, frame.sy);
    let (p0x, p0y) = (p0x + sx * p0z, p0y + sy * p0z);
    let (p1x, p1y) = (p1x + sx * p1z, p1y + sy * p1z);
    let (p2x, p2y) = (p2x + sx * p2z, p2y + sy * p2z);
    let e0 = p1x * p2y - p1y * p2x;
    let e1 = p2x * p0y - p2y * p0x;
    let e2 = p0x * p1y - p0y * p1x;
    let zero = Vec4::ZERO;
    let some_zero = (e0.cmpeq(zero) | e1.cmpeq(zero) | e2.cmpeq(zero)).bitmask();
    let negative = e0.cmplt(zero) | e1.cmplt(zero) | e2.cmplt(zero);
    let positive = e0.cmpgt(zero) | e1.cmpgt(zero) | e2.cmpgt(zero);
    let missed = (negative & positive).bitmask() & !some_zero;
    let live = lanes & !missed;
    if live == 0 {
        return four;
    }
    let det = e0 + e1 + e2;
    let max_z_world = p0z.abs().max(p1z.abs()).max(p2z.abs());
    let (p0z, p1z, p2z) = (p0z * frame.sz, p1z * frame.sz, p2z * frame.sz);
    let t_scaled = e0 * p0z + e1 * p1z + e2 * p2z;
    let inv_det = Vec4::ONE / det;
    let t = t_scaled * inv_det;
    let max_abs = |a: Vec4, b: Vec4, c: Vec4| a.abs().max(b.abs()).max(c.abs());
    let delta_t = t_error_bound(
        (Vec4::splat, |n| Vec4::splat(gamma(n))),
        [
            max_abs(p0x, p1x, p2x),
            max_abs(p0y, p1y, p2y),
            max_abs(p0z, p1z, p2z),
        ],
        max_z_world,
        [sx.abs(), sy.abs()],
        max_abs(e0, e1, e2),
    ) * inv_det.abs();
    // A NaN anywhere above makes `t` NaN, which no comparison below passes (so the lanes'
    // `max`, which differs from `f32::max` only on NaN, decides nothing by itself).
    let sure = live & !some_zero & !det.cmpeq(zero).bitmask();
    let ahead = t.cmpgt(delta_t).bitmask();
    let within = t.cmplt(t_max).bitmask();
    let behind = t.cmplt(-delta_t).bitmask();
    four.hit = sure & ahead & within;
    four.undecided = live & !(sure & (ahead | behind));
    four.t = t;
    four.t_error = delta_t + t * MACHINE_EPSILON;
    four.b = [e0 * inv_det, e1 * inv_det, e2 * inv_det];
    four
}

/// The bound on `|t_computed − t| · |det|` for the watertight test (pbrt-v4's derivation), in
/// the precision (or the lanes) whose constants and `gamma` are given. `max_t` holds the
/// largest `|x|`, `|y|` of the sheared vertices and the largest scaled `|z|`; `max_z_world` is
/// the largest `|z|` before scaling and `shear` the shear factors' magnitudes `|sx|`, `|sy|`.
#[inline]
fn t_error_bound<F>(
    (constant, gamma): (impl Fn(f32) -> F, impl Fn(u32) -> F),
    max_t: [F; 3],
    max_z_world: F,
    shear: [F; 2],
    max_e: F,
) -> F
where
    F: Copy + core::ops::Add<Output = F> + core::ops::Mul<Output = F>,
{
    let [max_xt, max_yt, max_zt] = max_t;
    let [sx, sy] = shear;
    let delta_z = gamma(3) * max_zt;
    // pbrt-v4 writes `max_xt + max_zt` here, mixing world units with units of t; that is only
    // right for directions of unit length. The shear added `sx·z` to x (and `sy·z` to y), so
    // its rounding is bounded by `|sx|·max_z_world`: right at any scale, and tight for rays
    // nearly parallel to the triangle, where a bound with `|sx| = 1` would reject true hits.
    let delta_x = gamma(5) * (max_xt + sx * max_z_world);
    let delta_y = gamma(5) * (max_yt + sy * max_z_world);
    let delta_e =
        constant(2.0) * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    constant(3.0) * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e)
}

/// Recomputes the hit's `t` and its bound in `f64` from the ray and the vertices, for a hit the
/// `f32` test found inside the triangle but whose `t` it could not prove positive. Returns the
/// hit if `t` is provably in `(0, t_max)`; the barycentrics are the `f64` ones unless those fall
/// outside the triangle (then the `f32` ones, `b32`, are kept).
#[cold]
#[inline(never)]
fn refine_in_f64(
    frame: &RayFrame,
    p: &[Vec3; 3],
    t_max: f32,
    b32: [f32; 3],
) -> Option<TriangleHit> {
    let (kx, ky, kz) = (frame.kx, frame.ky, frame.kz);
    let (o, d) = (frame.origin, frame.dir);
    let dz = f64::from(d[kz]);
    let sx = -f64::from(d[kx]) / dz;
    let sy = -f64::from(d[ky]) / dz;
    let sz = 1.0 / dz;
    // Sheared x, y and unscaled z of each vertex.
    let v = p.map(|q| {
        let z = f64::from(q[kz]) - f64::from(o[kz]);
        [
            f64::from(q[kx]) - f64::from(o[kx]) + sx * z,
            f64::from(q[ky]) - f64::from(o[ky]) + sy * z,
            z,
        ]
    });
    let e = [
        v[1][0] * v[2][1] - v[1][1] * v[2][0],
        v[2][0] * v[0][1] - v[2][1] * v[0][0],
        v[0][0] * v[1][1] - v[0][1] * v[1][0],
    ];
    let det = e[0] + e[1] + e[2];
    if det == 0.0 {
        return None;
    }
    let inv_det = 1.0 / det;
    let t = (e[0] * v[0][2] * sz + e[1] * v[1][2] * sz + e[2] * v[2][2] * sz) * inv_det;
    let max_abs = |i: usize| v[0][i].abs().max(v[1][i].abs()).max(v[2][i].abs());
    let max_z_world = max_abs(2);
    let delta_t = t_error_bound(
        (f64::from, gamma_f64),
        [max_abs(0), max_abs(1), max_z_world * sz.abs()],
        max_z_world,
        [sx.abs(), sy.abs()],
        e[0].abs().max(e[1].abs()).max(e[2].abs()),
    ) * inv_det.abs();
    if !(t > delta_t && t < f64::from(t_max)) {
        return None;
    }
    let t32 = t as f32;
    if t32 >= t_max {
        return None;
    }
    let b64 = e.map(|x| x * inv_det);
    let b = if b64.iter().all(|&x| x >= 0.0) {
        b64.map(|x| x as f32)
    } else {
        b32
    };
    // The f64 bound, the f64 t's distance from its f32 rounding, and one more rounding up.
    let t_error = ((delta_t + (t - f64::from(t32)).abs()) * (1.0 + 1e-7)) as f32;
    Some(TriangleHit {
        t: t32,
        t_error: next_float_up(t_error),
        b,
    })
}

/// [`gamma`] for `f64`: the relative error bound of `n` rounded `f64` operations.
#[inline]
fn gamma_f64(n: u32) -> f64 {
    let ne = f64::from(n) * (f64::EPSILON * 0.5);
    ne / (1.0 - ne)
}

/// The hit point interpolated from barycentrics, with its per-axis absolute error bound.
#[inline]
pub fn hit_point(p: &[Vec3; 3], b: [f32; 3]) -> (Vec3, Vec3) {
    let a = p[0] * b[0];
    let c = p[1] * b[1];
    let d = p[2] * b[2];
    let point = a + c + d;
    let err = (a.abs() + c.abs() + d.abs()) * gamma(7);
    (point, err)
}

/// The unnormalised geometric normal `(p1 − p0) × (p2 − p0)`: twice the area, zero if degenerate.
#[inline]
pub fn area_normal(p: &[Vec3; 3]) -> Vec3 {
    (p[1] - p[0]).cross(p[2] - p[0])
}

/// The unit geometric normal, or `None` for a degenerate triangle: one whose normal cannot be
/// computed (zero area, or an area so small that its square underflows). This is the one
/// definition of "degenerate": such triangles are left out of the octree and never hit.
#[inline]
pub fn unit_normal(p: &[Vec3; 3]) -> Option<Vec3> {
    area_normal(p).try_unit()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri() -> [Vec3; 3] {
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]
    }

    /// `intersect4` answers each ray as `intersect` does, to the bit, or leaves it to it: rays
    /// at random points of random triangles, near them, and exactly at their vertices and edge
    /// midpoints (edge functions of zero, decided in `f64`), each with its own bound (none, one
    /// past the triangle or one before it, and one at the hit itself).
    #[test]
    fn four_rays_at_once_answer_as_one_at_a_time() {
        let mut rng = crate::scene::mesh::Rng::new(0x9e37_79b9);
        let mut unit = move || rng.next_f32();
        let (mut hits, mut misses, mut undecided, mut packets) = (0, 0, 0, 0);
        for case in 0..40_000 {
            let mut v = || Vec3::new(unit(), unit(), unit()) * 4.0 - 2.0;
            let p = [v(), v(), v()];
            let eye = v() * 3.0;
            let rays: [Ray; 4] = core::array::from_fn(|l| {
                let (a, b) = (unit() * 1.4 - 0.2, unit() * 1.4 - 0.2);
                let target = match (case + l) % 4 {
                    0 => p[l % 3],
                    1 => (p[l % 3] + p[(l + 1) % 3]) * 0.5,
                    _ => p[0] + (p[1] - p[0]) * a + (p[2] - p[0]) * b * (1.0 - a),
                };
                Ray::new(eye, target - eye)
            });
            let frames = rays.each_ref().map(RayFrame::new);
            let Some(four) = RayFrame4::new(&frames) else {
                continue;
            };
            packets += 1;
            let unbounded = frames.map(|f| intersect(&f, &p, f32::INFINITY));
            let bounds = Vec4::from(core::array::from_fn(|l| match (case / 4 + l) % 4 {
                0 => f32::INFINITY,
                1 => unit() * 2.0,
                _ => unbounded[l].map_or(1.0, |h| h.t),
            }));
            let lanes = 0b1011 | (case as u32 & 4);
            let got = intersect4(&four, &p, lanes, bounds);
            assert_eq!(
                (got.hit | got.undecided) & !lanes,
                0,
                "case {case}: a lane not asked"
            );
            assert_eq!(
                got.hit & got.undecided,
                0,
                "case {case}: a lane both hit and undecided"
            );
            for (l, frame) in frames.iter().enumerate() {
                if lanes >> l & 1 == 0 {
                    continue;
                }
                let want = intersect(frame, &p, bounds[l]);
                if got.undecided >> l & 1 == 1 {
                    undecided += 1;
                    continue;
                }
                let lane = (got.hit >> l & 1 == 1).then(|| got.of(l));
                let bits = |h: Option<TriangleHit>| {
                    h.map(|h| (h.t.to_bits(), h.t_error.to_bits(), h.b.map(f32::to_bits)))
                };
                assert_eq!(bits(lane), bits(want), "case {case} lane {l}");
                hits += usize::from(lane.is_some());
                misses += usize::from(lane.is_none());
            }
        }
        assert!(
            packets > 20_000,
            "only {packets} packets share a permutation"
        );
        assert!(hits > 10_000, "only {hits} hits found four at a time");
        assert!(misses > 10_000, "only {misses} misses found four at a time");
        assert!(
            undecided > 100,
            "only {undecided} rays left to the one-ray test"
        );
    }

    #[test]
    fn hits_inside_and_reports_barycentrics() {
        let r = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let h = intersect(&RayFrame::new(&r), &tri(), f32::INFINITY).expect("hit");
        assert_eq!(h.t, 1.0);
        let (p, _) = hit_point(&tri(), h.b);
        assert!((p - Vec3::new(0.25, 0.25, 0.0)).norm() < 1e-6);
    }

    #[test]
    fn misses_outside_behind_and_beyond_t_max() {
        let down = Vec3::new(0.0, 0.0, -1.0);
        let f =
            |o: Vec3, d: Vec3, tmax: f32| intersect(&RayFrame::new(&Ray::new(o, d)), &tri(), tmax);
        assert!(f(Vec3::new(0.75, 0.75, 1.0), down, f32::INFINITY).is_none());
        assert!(f(Vec3::new(0.25, 0.25, -1.0), down, f32::INFINITY).is_none());
        assert!(f(Vec3::new(0.25, 0.25, 1.0), down, 0.5).is_none());
    }

    #[test]
    fn degenerate_triangle_is_never_hit() {
        let p = [
            Vec3::ZERO,
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
        ];
        let r = Ray::new(Vec3::new(1.0, 1.0, 1.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(intersect(&RayFrame::new(&r), &p, f32::INFINITY).is_none());
    }

    #[test]
    fn t_error_bound_is_scale_invariant() {
        // Same geometry at every scale, direction length scaled too: t and its relative error
        // bound must not change (pbrt's original bound grew a thousandfold at scale 1e-3).
        let reference = {
            let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::new(0.0, 0.0, -1.0));
            intersect(&RayFrame::new(&r), &tri(), f32::INFINITY).expect("hit")
        };
        for s in [1e-6f32, 1e-3, 1e3, 1e6] {
            let p = tri().map(|v| v * s);
            let r = Ray::new(Vec3::new(0.2, 0.2, 1.0) * s, Vec3::new(0.0, 0.0, -1.0) * s);
            let h = intersect(&RayFrame::new(&r), &p, f32::INFINITY).expect("hit at every scale");
            assert!((h.t - 1.0).abs() < 1e-6, "scale {s}: t = {}", h.t);
            assert!(
                h.t_error < 2.0 * reference.t_error,
                "scale {s}: bound {} vs {}",
                h.t_error,
                reference.t_error
            );
        }
    }

    #[test]
    fn tiny_triangle_whose_area_underflows_is_degenerate() {
        // Edges of 1e-20: the area normal is a nonzero subnormal (about 1e-40), so an
        // `area_normal == 0` rule would file it, but its squared length underflows and no unit
        // normal exists: it must count as degenerate, or shading it would produce a NaN normal.
        let p = tri().map(|v| v * 1e-20);
        assert_ne!(area_normal(&p), Vec3::ZERO);
        assert!(unit_normal(&p).is_none());
        assert!(unit_normal(&tri()).is_some());
        let flat = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert!(unit_normal(&flat).is_none());
    }

    /// A floor ±1e4 wide; the f32 bound on `t` for a hit near the eye is about 0.3.
    fn big_floor() -> [Vec3; 3] {
        [
            Vec3::new(-1e4, -1e4, 0.0),
            Vec3::new(1e4, -1e4, 0.0),
            Vec3::new(0.0, 1e4, 0.0),
        ]
    }

    #[test]
    fn hit_near_the_eye_on_a_large_triangle_is_decided_in_f64() {
        // 1e-3 above the floor, descending at 1 in 10: the hit is 1e-2 away.
        let r = Ray::new(Vec3::new(0.3, 0.2, 1e-3), Vec3::new(1.0, 0.0, -0.1));
        let h = intersect(&RayFrame::new(&r), &big_floor(), f32::INFINITY).expect("hit");
        let exact = f64::from(1e-3f32) / f64::from(0.1f32);
        assert!(
            (f64::from(h.t) - exact).abs() <= f64::from(h.t_error),
            "t = {}",
            h.t
        );
        assert!(h.t_error < 1e-9, "the f64 bound is tight: {}", h.t_error);
        let (p, err) = hit_point(&big_floor(), h.b);
        assert!(p.z.abs() <= err.z, "{p:?}");
        // Leaving the floor upwards from just above it: the plane is behind, no hit.
        let up = Ray::new(Vec3::new(0.3, 0.2, 1e-6), Vec3::new(1.0, 0.0, 0.1));
        assert!(intersect(&RayFrame::new(&up), &big_floor(), f32::INFINITY).is_none());
    }

    #[test]
    fn the_hit_does_not_depend_on_t_max() {
        // Rays whose f32 `t` is ambiguous and rays whose f32 `t` is not: narrowing t_max only
        // drops hits at or beyond it, it never changes which `t` is reported.
        let rays = [
            Ray::new(Vec3::new(0.3, 0.2, 1e-3), Vec3::new(1.0, 0.0, -0.1)),
            Ray::new(Vec3::new(0.3, 0.2, 1.0), Vec3::new(0.1, 0.2, -1.0)),
            Ray::new(Vec3::new(-50.0, 3.0, 1e-2), Vec3::new(1.0, 1e-3, -1e-5)),
        ];
        for r in rays {
            let frame = RayFrame::new(&r);
            let full = intersect(&frame, &big_floor(), f32::INFINITY).expect("hit");
            for t_max in [full.t * 2.0, next_float_up(full.t), full.t, full.t * 0.5] {
                let got = intersect(&frame, &big_floor(), t_max);
                assert_eq!(
                    got,
                    (full.t < t_max).then_some(full),
                    "{r:?}, t_max {t_max}"
                );
            }
        }
    }
}
