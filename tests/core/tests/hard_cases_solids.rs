//! Hard cases for the analytic solids (sphere, box, cylinder and cone, plane, and their CSG
//! union, intersection and difference), one named test each, every one asserting a concrete
//! outcome:
//!
//! - pixel grids whose centre rays pass exactly through box edges and vertices, through a
//!   cylinder's rims, and along the shared face of two boxes in a union: no background pixel
//!   strictly inside the silhouette (decided exactly, in integers), none outside it, no NaN;
//! - rays at distance `r(1 ∓ ε)` from a sphere's centre or a cylinder's axis hit or miss down to
//!   `ε = 1e-6`; exactly tangent rays give finite normals; rays at grazing angles down to `1e-7`
//!   rad that enter a box face or a cylinder side hit it, on the surface within the hit's error
//!   bound ([`SolidSurface::point_error`]);
//! - direction components of `+0.0` and `-0.0` with origins exactly on slab and cap planes: the
//!   same answer for both signs, no NaN, and the hit or miss of the documented half-open rule
//!   (`shape::in_slab_parallel`: exactly in a face plane the slab is `[−h, h)`);
//! - a camera inside a cylinder or a CSG object sees the inside of its walls (normals facing the
//!   ray once shading turns them), and a light inside one lights only what is inside.
//!
//! Colours are checked before quantisation: every render also traces each pixel's centre ray
//! itself and asserts the colour is finite ([`Pixel`] would turn NaN into 0).

use glam::{Mat3, Vec3};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::geom::solid::shape::{self, ShapeSpan};
use strahl_core::geom::solid::{CsgOp, Shape, SolidNode};
use strahl_core::math::ray::Ray;
use strahl_core::math::transform::Transform;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::shade::{trace, TraceScratch};
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::camera::{Camera, SeedCamera};
use strahl_core::scene::mesh::Rng;
use strahl_core::scene::{Light, RenderSettings, Scene, SceneDesc, Shader};
use strahl_core_tests::checked::*;

// ---------------------------------------------------------------------------------------------
// Scene building
// ---------------------------------------------------------------------------------------------

/// The background of every render here: no surface is this blue.
const BACKGROUND: Vec3 = Vec3::new(0.0, 0.0, 1.0);

/// A shader showing only its ambient grey (lights change nothing).
fn flat(grey: f32) -> Shader {
    Shader::phong(Vec3::splat(grey), Vec3::ZERO, Vec3::ZERO, 1.0, 0.0)
}

/// A grey diffuse shader without highlights.
fn matte(ambient: f32, diffuse: f32) -> Shader {
    Shader::phong(
        Vec3::splat(ambient),
        Vec3::splat(diffuse),
        Vec3::ZERO,
        1.0,
        0.0,
    )
}

fn point_light(position: Vec3) -> Light {
    Light {
        position,
        color: Vec3::ONE,
        amount: 1.0,
        casts_shadows: true,
    }
}

fn leaf(shape: Shape, transform: Transform, shader: u32) -> SolidNode {
    SolidNode::Leaf {
        shape,
        transform,
        shader,
    }
}

fn csg(op: CsgOp, a: u32, b: u32) -> SolidNode {
    SolidNode::Csg { op, a, b }
}

/// The axis-aligned box `lo..hi` (exact for the dyadic corners used here).
fn block(lo: Vec3, hi: Vec3, shader: u32) -> SolidNode {
    leaf(
        Shape::Cuboid { size: hi - lo },
        Transform::translate((lo + hi) * 0.5),
        shader,
    )
}

/// A ball of `radius` around `centre`.
fn ball(centre: Vec3, radius: f32, shader: u32) -> SolidNode {
    leaf(
        Shape::Sphere { radius },
        Transform::translate(centre),
        shader,
    )
}

/// A cylinder of `radius` and `height` around the axis through `centre` parallel to Y.
fn tube(centre: Vec3, radius: f32, height: f32, shader: u32) -> SolidNode {
    leaf(
        Shape::Cylinder {
            bottom_radius: radius,
            top_radius: radius,
            height,
        },
        Transform::translate(centre),
        shader,
    )
}

/// The half-space `z ≤ height`.
fn floor(height: f32, shader: u32) -> SolidNode {
    leaf(
        Shape::Plane {
            normal: Vec3::Z,
            d: height,
        },
        Transform::IDENTITY,
        shader,
    )
}

/// The seed's camera at `position`, looking along +Y tilted by `angle_x_deg` and turned by
/// `angle_z_deg`. Untilted and unturned, every primary ray direction is exactly `(u, zoom, v)`.
fn eye(position: Vec3, angle_x_deg: f32, angle_z_deg: f32) -> Camera {
    Camera::Seed(SeedCamera {
        position,
        angle_x_deg,
        angle_z_deg,
        zoom: 1.0,
    })
}

fn settings(width: u32, height: u32) -> RenderSettings {
    RenderSettings {
        width,
        height,
        background: BACKGROUND,
        ..RenderSettings::default()
    }
}

/// A scene of solids only.
fn scene_of(
    solids: Vec<SolidNode>,
    objects: Vec<u32>,
    shaders: Vec<Shader>,
    lights: Vec<Light>,
    camera: Camera,
    settings: RenderSettings,
) -> Scene {
    let desc = SceneDesc {
        shaders,
        lights,
        solids,
        objects,
        camera,
        settings,
        ..SceneDesc::default()
    };
    Scene::build(&desc, &OctreeParams::default()).expect("valid scene")
}

/// A scene of one object (the last node of `solids`) with flat shaders, for ray queries.
fn object_scene(solids: Vec<SolidNode>) -> Scene {
    let root = solids.len() as u32 - 1;
    scene_of(
        solids,
        vec![root],
        vec![flat(0.5), flat(0.75), flat(0.3)],
        vec![point_light(Vec3::new(0.0, 0.0, 100.0))],
        Camera::default(),
        settings(8, 8),
    )
}

/// Asserts that every number of a hit is finite and the normal has unit length.
fn assert_finite(f: &Found, at: &str) {
    let s = &f.surface;
    assert!(
        f.hit.t.is_finite() && f.hit.t_error.is_finite(),
        "{at}: t {} ± {}",
        f.hit.t,
        f.hit.t_error
    );
    assert!(
        s.point.is_finite() && s.point_error.is_finite() && s.normal.is_finite(),
        "{at}: surface {s:?}"
    );
    assert!(
        (s.normal.length() - 1.0).abs() < 1e-5,
        "{at}: normal {:?} is not of unit length",
        s.normal
    );
}

/// The colour of one ray, asserted finite.
fn traced(scene: &Scene, ray: Ray, at: &str) -> Vec3 {
    let mut scratch = TraceScratch::default();
    let mut counts = RayCounts::default();
    let c = trace(scene, ray, 0, &mut scratch, &mut counts);
    assert!(c.is_finite(), "{at}: colour {c:?} is not finite");
    c
}

// ---------------------------------------------------------------------------------------------
// Rendering
// ---------------------------------------------------------------------------------------------

// ---------------------------------------------------------------------------------------------
// An f64 reference for axis-aligned solids
// ---------------------------------------------------------------------------------------------

type V = [f64; 3];

fn v64(v: Vec3) -> V {
    [f64::from(v.x), f64::from(v.y), f64::from(v.z)]
}

/// A leaf solid placed by a translation only, in `f64` world coordinates.
#[derive(Clone, Copy, Debug)]
enum Ref {
    Ball {
        c: V,
        r: f64,
    },
    Block {
        lo: V,
        hi: V,
    },
    /// A cylinder around the axis through `c` parallel to Y, from `c.y − half` to `c.y + half`.
    Tube {
        c: V,
        r: f64,
        half: f64,
    },
    /// The half-space `z ≤ top`.
    Floor {
        top: f64,
    },
}

/// How a reference ray meets a solid.
#[derive(Clone, Debug, PartialEq)]
enum Reach {
    /// Inside during these closed intervals of `t` (sorted, disjoint; zero length only for a
    /// single leaf the ray touches).
    Spans(Vec<(f64, f64)>),
    /// A tangency makes the reference unsure.
    Unsure,
}

impl Ref {
    fn of(node: &SolidNode) -> Ref {
        let SolidNode::Leaf {
            shape, transform, ..
        } = *node
        else {
            panic!("not a leaf: {node:?}");
        };
        assert_eq!(transform.matrix, Mat3::IDENTITY, "translations only");
        let c = v64(transform.translation);
        match shape {
            Shape::Sphere { radius } => Ref::Ball {
                c,
                r: f64::from(radius),
            },
            Shape::Cuboid { size } => {
                let h = v64(size * 0.5);
                Ref::Block {
                    lo: [0, 1, 2].map(|a| c[a] - h[a]),
                    hi: [0, 1, 2].map(|a| c[a] + h[a]),
                }
            }
            Shape::Cylinder {
                bottom_radius,
                top_radius,
                height,
            } if bottom_radius == top_radius => Ref::Tube {
                c,
                r: f64::from(bottom_radius),
                half: 0.5 * f64::from(height),
            },
            Shape::Plane { normal, d } if normal == Vec3::Z => Ref::Floor {
                top: f64::from(d) + c[2],
            },
            _ => panic!("no reference for {shape:?}"),
        }
    }

    /// The span of the ray `o + t·d` inside the solid. Exactly in a face plane, a ray parallel
    /// to it is inside the slab `[lo, hi)` (the documented rule); the side of a cylinder and a
    /// ball are closed.
    fn reach(&self, o: V, d: V) -> Reach {
        let (mut enter, mut exit) = (f64::NEG_INFINITY, f64::INFINITY);
        let mut slab = |lo: f64, hi: f64, o: f64, d: f64| -> bool {
            if d == 0.0 {
                return lo <= o && o < hi;
            }
            let (a, b) = ((lo - o) / d, (hi - o) / d);
            enter = enter.max(a.min(b));
            exit = exit.min(a.max(b));
            true
        };
        let quadratic = |a: f64, b: f64, c: f64| -> Option<Result<(f64, f64), ()>> {
            let disc = b * b - 4.0 * a * c;
            if disc.abs() <= 1e-9 * (b * b + (4.0 * a * c).abs()) {
                return Some(Err(()));
            }
            if disc < 0.0 {
                return None;
            }
            let root = disc.sqrt();
            Some(Ok(((-b - root) / (2.0 * a), (-b + root) / (2.0 * a))))
        };
        match *self {
            Ref::Block { lo, hi } => {
                for a in 0..3 {
                    if !slab(lo[a], hi[a], o[a], d[a]) {
                        return Reach::Spans(vec![]);
                    }
                }
            }
            Ref::Floor { top } => {
                if !slab(f64::NEG_INFINITY, top, o[2], d[2]) && o[2] != top {
                    return Reach::Spans(vec![]);
                }
            }
            Ref::Ball { c, r } => {
                let p = [0, 1, 2].map(|a| o[a] - c[a]);
                let dot = |x: V, y: V| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
                match quadratic(dot(d, d), 2.0 * dot(p, d), dot(p, p) - r * r) {
                    None => return Reach::Spans(vec![]),
                    Some(Err(())) => return Reach::Unsure,
                    Some(Ok((t0, t1))) => (enter, exit) = (t0, t1),
                }
            }
            Ref::Tube { c, r, half } => {
                if !slab(c[1] - half, c[1] + half, o[1], d[1]) {
                    return Reach::Spans(vec![]);
                }
                let (px, pz) = (o[0] - c[0], o[2] - c[2]);
                let a = d[0] * d[0] + d[2] * d[2];
                if a == 0.0 {
                    let q = px * px + pz * pz - r * r;
                    if q == 0.0 {
                        return Reach::Unsure;
                    }
                    if q > 0.0 {
                        return Reach::Spans(vec![]);
                    }
                } else {
                    let b = 2.0 * (px * d[0] + pz * d[2]);
                    match quadratic(a, b, px * px + pz * pz - r * r) {
                        None => return Reach::Spans(vec![]),
                        Some(Err(())) => return Reach::Unsure,
                        Some(Ok((t0, t1))) => {
                            enter = enter.max(t0);
                            exit = exit.min(t1);
                        }
                    }
                }
            }
        }
        if enter > exit {
            return Reach::Spans(vec![]);
        }
        let round = matches!(self, Ref::Ball { .. } | Ref::Tube { .. });
        if round && exit - enter <= 1e-9 * (1.0 + enter.abs()) {
            // Touching a rim or a curved surface: rounding decides.
            return Reach::Unsure;
        }
        Reach::Spans(vec![(enter, exit)])
    }

    /// True if the box `p ± e` (world units) meets the solid's surface: it meets the closed
    /// solid and is not inside the open one (a box is connected).
    fn box_meets_surface(&self, p: Vec3, e: Vec3) -> bool {
        // A little slack for the f64 arithmetic itself.
        let scale = f64::from(p.abs().max_element()) + 1.0;
        let e = v64(e).map(|x| x + 1e-12 * scale);
        let p = v64(p);
        let (lo, hi) = (
            [0, 1, 2].map(|a| p[a] - e[a]),
            [0, 1, 2].map(|a| p[a] + e[a]),
        );
        // Nearest and farthest distances of the interval [l, h] from x.
        let near = |l: f64, h: f64, x: f64| (l - x).max(x - h).max(0.0);
        let far = |l: f64, h: f64, x: f64| (l - x).abs().max((h - x).abs());
        match *self {
            Ref::Ball { c, r } => {
                let n: f64 = (0..3).map(|a| near(lo[a], hi[a], c[a]).powi(2)).sum();
                let f: f64 = (0..3).map(|a| far(lo[a], hi[a], c[a]).powi(2)).sum();
                n <= r * r && r * r <= f
            }
            Ref::Block { lo: bl, hi: bh } => {
                let meets = (0..3).all(|a| lo[a] <= bh[a] && hi[a] >= bl[a]);
                let inside = (0..3).all(|a| bl[a] < lo[a] && hi[a] < bh[a]);
                meets && !inside
            }
            Ref::Tube { c, r, half } => {
                let (y0, y1) = (c[1] - half, c[1] + half);
                let n = near(lo[0], hi[0], c[0]).powi(2) + near(lo[2], hi[2], c[2]).powi(2);
                let f = far(lo[0], hi[0], c[0]).powi(2) + far(lo[2], hi[2], c[2]).powi(2);
                let meets = lo[1] <= y1 && hi[1] >= y0 && n <= r * r;
                let inside = y0 < lo[1] && hi[1] < y1 && f < r * r;
                meets && !inside
            }
            Ref::Floor { top } => lo[2] <= top && top <= hi[2],
        }
    }
}

/// A CSG tree of reference leaves.
#[derive(Clone, Debug)]
enum RefTree {
    Leaf(Ref),
    Op(CsgOp, Box<RefTree>, Box<RefTree>),
}

impl RefTree {
    /// The tree below node `root` of an arena.
    fn of(solids: &[SolidNode], root: u32) -> RefTree {
        match solids[root as usize] {
            SolidNode::Csg { op, a, b } => RefTree::Op(
                op,
                Box::new(RefTree::of(solids, a)),
                Box::new(RefTree::of(solids, b)),
            ),
            ref n => RefTree::Leaf(Ref::of(n)),
        }
    }

    fn reach(&self, o: V, d: V) -> Reach {
        match self {
            RefTree::Leaf(r) => r.reach(o, d),
            RefTree::Op(op, a, b) => match (a.reach(o, d), b.reach(o, d)) {
                (Reach::Spans(a), Reach::Spans(b)) => Reach::Spans(combine(*op, &a, &b)),
                _ => Reach::Unsure,
            },
        }
    }

    /// The first boundary strictly in front of the origin, `None` if there is none, or
    /// `Err(())` if the reference is unsure.
    fn first(&self, o: V, d: V) -> Result<Option<f64>, ()> {
        match self.reach(o, d) {
            Reach::Unsure => Err(()),
            Reach::Spans(spans) => Ok(spans
                .iter()
                .flat_map(|&(a, b)| [a, b])
                .find(|t| *t > 0.0 && t.is_finite())),
        }
    }
}

/// The intervals where `op` of the two interval lists is inside, of positive length only:
/// each elementary piece between consecutive ends is decided at its middle.
fn combine(op: CsgOp, a: &[(f64, f64)], b: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut ends: Vec<f64> = a.iter().chain(b).flat_map(|&(s, e)| [s, e]).collect();
    ends.sort_by(f64::total_cmp);
    ends.dedup();
    let inside = |list: &[(f64, f64)], t: f64| list.iter().any(|&(s, e)| s < t && t < e);
    let mut out: Vec<(f64, f64)> = Vec::new();
    for w in ends.windows(2) {
        let (s, e) = (w[0], w[1]);
        let mid = match (s.is_finite(), e.is_finite()) {
            (true, true) => 0.5 * (s + e),
            (false, true) => e - 1.0,
            (true, false) => s + 1.0,
            (false, false) => 0.0,
        };
        let (ia, ib) = (inside(a, mid), inside(b, mid));
        let keep = match op {
            CsgOp::Union => ia || ib,
            CsgOp::Intersect => ia && ib,
            CsgOp::Subtract => ia && !ib,
        };
        if !keep {
            continue;
        }
        match out.last_mut() {
            Some(last) if last.1 == s => last.1 = e,
            _ => out.push((s, e)),
        }
    }
    out
}

/// Asserts that a hit lies on the surface of the leaf it names within its error bound, and near
/// the ray's point at its `t` within the error bounds of both.
fn assert_on_surface(solids: &[SolidNode], ray: &Ray, f: &Found, at: &str) {
    assert_finite(f, at);
    let s = &f.surface;
    let r = Ref::of(&solids[f.hit.leaf as usize]);
    assert!(
        r.box_meets_surface(s.point, s.point_error),
        "{at}: hit {:?} ± {:?} (face {}, t = {}) is off the surface of {r:?}",
        s.point,
        s.point_error,
        f.hit.face,
        f.hit.t
    );
    // Near the ray: the point at t, off by the error of t (a distance |d|·t_error, in any
    // direction once the point is re-projected onto the surface) and the rounding of the sum.
    let on_ray = ray.at(f.hit.t);
    let slack = Vec3::splat(ray.dir.length() * f.hit.t_error)
        + (ray.origin.abs() + on_ray.abs()) * 1e-6
        + s.point_error;
    let off = (s.point - on_ray).abs();
    assert!(
        off.cmple(slack).all(),
        "{at}: hit {:?} is {off:?} from the ray's point {on_ray:?} at t = {} (slack {slack:?})",
        s.point,
        f.hit.t
    );
}

// ---------------------------------------------------------------------------------------------
// 1. Pixel grids on edges and rims
// ---------------------------------------------------------------------------------------------

/// Width and height of the perspective grid images: with the camera at the origin looking
/// along +Y, untilted, pixel `(i, j)`'s centre ray is exactly `(U/32, 1, V/32)` with
/// `U = 2i − 31` and `V = 31 − 2j`, both odd.
const GRID: usize = 32;

/// A convex part of a test object in the grid's exact units: x and z in eighths, y in whole
/// units (so the ray `(U/32, 1, V/32)` is at `y = t`).
#[derive(Clone, Copy, Debug)]
enum Part {
    Block {
        x: [i64; 2],
        y: [i64; 2],
        z: [i64; 2],
    },
    /// A cylinder around the axis `(x, ·, z)` parallel to Y.
    Tube { x: i64, z: i64, r: i64, y: [i64; 2] },
}

/// `a < b` for fractions with positive denominators.
fn less(a: (i64, i64), b: (i64, i64)) -> bool {
    a.0 * b.1 < b.0 * a.1
}

impl Part {
    /// Mirrored in x by `sx` and in z by `sz` (±1).
    fn mirrored(self, sx: i64, sz: i64) -> Part {
        let flip = |r: [i64; 2], s: i64| {
            let (a, b) = (r[0] * s, r[1] * s);
            [a.min(b), a.max(b)]
        };
        match self {
            Part::Block { x, y, z } => Part::Block {
                x: flip(x, sx),
                y,
                z: flip(z, sz),
            },
            Part::Tube { x, z, r, y } => Part::Tube {
                x: x * sx,
                z: z * sz,
                r,
                y,
            },
        }
    }

    fn node(self, shader: u32) -> SolidNode {
        let e = |v: i64| v as f32 / 8.0;
        match self {
            Part::Block { x, y, z } => block(
                Vec3::new(e(x[0]), y[0] as f32, e(z[0])),
                Vec3::new(e(x[1]), y[1] as f32, e(z[1])),
                shader,
            ),
            Part::Tube { x, z, r, y } => tube(
                Vec3::new(e(x), 0.5 * (y[0] + y[1]) as f32, e(z)),
                e(r),
                (y[1] - y[0]) as f32,
                shader,
            ),
        }
    }

    /// Whether the ray `(U/32, 1, V/32)·t`, `t > 0`, meets the part: its interior if `strict`,
    /// else the closed part. Exact.
    fn meets(self, u: i64, v: i64, strict: bool) -> bool {
        match self {
            Part::Block { x, y, z } => {
                let (mut lower, mut upper) = ((y[0], 1), (y[1], 1));
                for (range, w) in [(x, u), (z, v)] {
                    // t·w/32 between range/8: t·w between 4·range.
                    let (lo, hi) = if w > 0 {
                        ((4 * range[0], w), (4 * range[1], w))
                    } else {
                        ((-4 * range[1], -w), (-4 * range[0], -w))
                    };
                    if less(lower, lo) {
                        lower = lo;
                    }
                    if less(hi, upper) {
                        upper = hi;
                    }
                }
                if strict {
                    less(lower, upper)
                } else {
                    !less(upper, lower)
                }
            }
            Part::Tube { x, z, r, y } => {
                // 32²·(distance² − r²) at y = t: G(t) = |W|²t² − 8(W·C)t + 16(|C|² − R²).
                let ww = u * u + v * v;
                let wc = u * x + v * z;
                let cc = x * x + z * z - r * r;
                let g = |t: i64| ww * t * t - 8 * wc * t + 16 * cc;
                let vertex_in = y[0] * ww <= 4 * wc && 4 * wc <= y[1] * ww;
                if strict {
                    g(y[0]) < 0 || g(y[1]) < 0 || (vertex_in && cc * ww < wc * wc)
                } else {
                    g(y[0]) <= 0 || g(y[1]) <= 0 || (vertex_in && cc * ww <= wc * wc)
                }
            }
        }
    }
}

/// The test box `[−25/8, −15/8] × [4, 20] × [−25/8, −15/8]`, split along `axis` at
/// `x = −21/8`, `y = 12` or `z = −21/8` (no split for `axis` 3). Seen from the origin, its front
/// face (y = 4), its side x = −15/8 and its top z = −15/8 show; the ray of pixel (−15, −15)
/// passes exactly through the vertex where they meet, (−15, −19) and (−19, −15) through edges
/// of the front face, (−9, −9) and (−5, −5) through the edge of the side and the top,
/// (−21, −19), (−19, −21), (−5, −7) and (−7, −5) exactly through the lines where the split
/// planes cut the visible faces.
fn split_box(axis: usize) -> Vec<Part> {
    let (x, y, z) = ([-25, -15], [4, 20], [-25, -15]);
    match axis {
        0 => vec![
            Part::Block {
                x: [-25, -21],
                y,
                z,
            },
            Part::Block {
                x: [-21, -15],
                y,
                z,
            },
        ],
        1 => vec![
            Part::Block { x, y: [4, 12], z },
            Part::Block { x, y: [12, 20], z },
        ],
        2 => vec![
            Part::Block {
                x,
                y,
                z: [-25, -21],
            },
            Part::Block {
                x,
                y,
                z: [-21, -15],
            },
        ],
        _ => vec![Part::Block { x, y, z }],
    }
}

/// Pixels `(U, V)` whose rays pass exactly through edges, vertices and split lines of
/// [`split_box`], all strictly inside its silhouette.
const BOX_EDGE_PIXELS: [(i64, i64); 9] = [
    (-15, -15),
    (-15, -19),
    (-19, -15),
    (-9, -9),
    (-5, -5),
    (-5, -7),
    (-7, -5),
    (-21, -19),
    (-19, -21),
];

/// The test cylinder around `(−15/8, ·, −15/8)` of radius 5/4 from y = 4 to 20, whole or cut in
/// two at y = 12. Its near rim passes exactly through twelve pixel rays (Pythagorean points
/// 3-4-5 of the radius), its far rim through four.
fn split_tube(split: bool) -> Vec<Part> {
    let (x, z, r) = (-15, -15, 10);
    if split {
        vec![
            Part::Tube {
                x,
                z,
                r,
                y: [4, 12],
            },
            Part::Tube {
                x,
                z,
                r,
                y: [12, 20],
            },
        ]
    } else {
        vec![Part::Tube {
            x,
            z,
            r,
            y: [4, 20],
        }]
    }
}

/// Pixels `(U, V)` whose rays pass exactly through the rims of [`split_tube`] strictly inside its
/// silhouette: near-rim points on the side the cylinder's side shows, and a far-rim point.
const RIM_PIXELS: [(i64, i64); 5] = [(-9, -7), (-7, -9), (-5, -15), (-15, -5), (-5, -3)];

/// Renders the union of `parts` (one shader per part) from the origin and checks every pixel
/// against the exact silhouette: background exactly where the ray misses the closed parts, a
/// part's colour wherever it passes through the inside of one, either on the silhouette's
/// boundary. The `designed` pixels must be strictly inside.
fn check_silhouette(name: &str, parts: &[Part], designed: &[(i64, i64)]) {
    let mut solids: Vec<SolidNode> = parts
        .iter()
        .enumerate()
        .map(|(k, p)| p.node(k as u32))
        .collect();
    let mut root = 0;
    for k in 1..parts.len() as u32 {
        solids.push(csg(CsgOp::Union, root, k));
        root = solids.len() as u32 - 1;
    }
    let scene = scene_of(
        solids,
        vec![root],
        vec![flat(0.5), flat(0.75)],
        vec![point_light(Vec3::new(0.0, 0.0, 100.0))],
        eye(Vec3::ZERO, 0.0, 0.0),
        settings(GRID as u32, GRID as u32),
    );
    let img = render(&scene);
    let background = Pixel::from_color(BACKGROUND);
    let surfaces = [
        Pixel::from_color(Vec3::splat(0.5)),
        Pixel::from_color(Vec3::splat(0.75)),
    ];
    let mut inside = 0;
    for j in 0..GRID {
        for i in 0..GRID {
            let (u, v) = (2 * i as i64 - 31, 31 - 2 * j as i64);
            let ray = pixel_ray(&scene, i, j);
            assert_eq!(
                ray.dir,
                Vec3::new(u as f32 / 32.0, 1.0, v as f32 / 32.0),
                "the grid camera's rays are exact"
            );
            let p = img.at(i, j);
            let at = format!("{name}: pixel ({i}, {j}) = ray ({u}, {v})/32");
            if parts.iter().any(|q| q.meets(u, v, true)) {
                inside += 1;
                assert!(
                    surfaces.contains(&p),
                    "{at}: strictly inside the silhouette, shows {p:?}"
                );
            } else if !parts.iter().any(|q| q.meets(u, v, false)) {
                assert_eq!(p, background, "{at}: outside the silhouette, shows {p:?}");
            } else {
                assert!(
                    p == background || surfaces.contains(&p),
                    "{at}: on the silhouette, shows {p:?}"
                );
            }
        }
    }
    for &(u, v) in designed {
        assert!(
            parts.iter().any(|q| q.meets(u, v, true)),
            "{name}: designed pixel ({u}, {v}) is not strictly inside"
        );
    }
    assert!(inside >= 40, "{name}: only {inside} pixels inside");
}

#[test]
fn box_edges_and_vertices_on_pixel_centres_leave_no_hole() {
    for (sx, sz) in [(1, 1), (-1, 1), (1, -1), (-1, -1)] {
        let parts: Vec<Part> = split_box(3).iter().map(|p| p.mirrored(sx, sz)).collect();
        let designed: Vec<_> = BOX_EDGE_PIXELS.map(|(u, v)| (u * sx, v * sz)).to_vec();
        check_silhouette(&format!("box, mirror ({sx}, {sz})"), &parts, &designed);
    }
}

#[test]
fn union_of_boxes_sharing_a_face_has_no_crack_on_pixel_centres() {
    for axis in 0..3 {
        for (sx, sz) in [(1, 1), (-1, 1), (1, -1), (-1, -1)] {
            let parts: Vec<Part> = split_box(axis).iter().map(|p| p.mirrored(sx, sz)).collect();
            let designed: Vec<_> = BOX_EDGE_PIXELS.map(|(u, v)| (u * sx, v * sz)).to_vec();
            check_silhouette(
                &format!("union split along axis {axis}, mirror ({sx}, {sz})"),
                &parts,
                &designed,
            );
        }
    }
}

#[test]
fn cylinder_rims_on_pixel_centres_leave_no_hole() {
    for split in [false, true] {
        for (sx, sz) in [(1, 1), (-1, 1), (1, -1), (-1, -1)] {
            let parts: Vec<Part> = split_tube(split)
                .iter()
                .map(|p| p.mirrored(sx, sz))
                .collect();
            let designed: Vec<_> = RIM_PIXELS.map(|(u, v)| (u * sx, v * sz)).to_vec();
            check_silhouette(
                &format!("cylinder (split {split}), mirror ({sx}, {sz})"),
                &parts,
                &designed,
            );
        }
    }
}

/// Parallel rays along −Z from `(x, y, 4)` on a grid of quarter units, every direction with the
/// signs of its zero components varied; returns `(x, y, hit)` per grid point after checking the
/// variants agree and every colour is finite.
fn parallel_grid(scene: &Scene, name: &str) -> Vec<(f32, f32, Option<Found>)> {
    let mut out = Vec::new();
    for i in -6..=6 {
        for j in -6..=6 {
            let (x, y) = (i as f32 / 4.0, j as f32 / 4.0);
            let origin = Vec3::new(x, y, 4.0);
            let at = format!("{name}: ray from {origin:?}");
            let rays = [
                Vec3::new(0.0, 0.0, -1.0),
                Vec3::new(-0.0, 0.0, -1.0),
                Vec3::new(0.0, -0.0, -1.0),
                Vec3::new(-0.0, -0.0, -1.0),
            ]
            .map(|d| Ray::new(origin, d));
            let found = rays.map(|r| closest(scene, &r));
            for (r, f) in rays.iter().zip(&found) {
                if let Some(f) = f {
                    assert_finite(f, &at);
                }
                let c = traced(scene, *r, &at);
                assert_eq!(
                    f.map(|f| (f.hit, f.surface)),
                    found[0].map(|f| (f.hit, f.surface)),
                    "{at}: direction {:?} differs from +0",
                    r.dir
                );
                assert_eq!(c, traced(scene, rays[0], &at), "{at}: colours differ");
            }
            out.push((x, y, found[0]));
        }
    }
    out
}

#[test]
fn parallel_rays_on_box_edges_follow_the_half_open_rule() {
    // Rays straight down, exactly in the planes of the boxes' side faces and of the face two
    // boxes share. The documented rule: exactly in a face plane, a slab is [−h, h). So the box
    // [−1, 1]² × [−1, 1] and the union of [−1, 0] × … and [0, 1] × … both cover exactly
    // −1 ≤ x < 1, −1 ≤ y < 1 (no crack at x = 0), their intersection nothing, and the
    // differences −1 ≤ x < 0 and 0 ≤ x < 1.
    let whole = block(Vec3::splat(-1.0), Vec3::ONE, 0);
    let a = block(Vec3::splat(-1.0), Vec3::new(0.0, 1.0, 1.0), 0);
    let b = block(Vec3::new(0.0, -1.0, -1.0), Vec3::ONE, 1);
    type Rule = fn(f32) -> bool;
    let cases: [(&str, Vec<SolidNode>, Rule); 5] = [
        ("box", vec![whole], |x| (-1.0..1.0).contains(&x)),
        ("union", vec![a, b, csg(CsgOp::Union, 0, 1)], |x| {
            (-1.0..1.0).contains(&x)
        }),
        (
            "intersection",
            vec![a, b, csg(CsgOp::Intersect, 0, 1)],
            |_| false,
        ),
        ("A − B", vec![a, b, csg(CsgOp::Subtract, 0, 1)], |x| {
            (-1.0..0.0).contains(&x)
        }),
        ("B − A", vec![a, b, csg(CsgOp::Subtract, 1, 0)], |x| {
            (0.0..1.0).contains(&x)
        }),
    ];
    for (name, solids, covers) in cases {
        let scene = object_scene(solids);
        let mut hits = 0;
        for (x, y, found) in parallel_grid(&scene, name) {
            let want = covers(x) && (-1.0..1.0).contains(&y);
            let at = format!("{name}: ray at ({x}, {y})");
            match found {
                Some(f) => {
                    assert!(want, "{at}: hit {:?}, want a miss", f.surface.point);
                    assert_eq!(f.hit.t, 3.0, "{at}: the top face is 3 below");
                    assert_eq!(f.surface.point, Vec3::new(x, y, 1.0), "{at}");
                    assert_eq!(f.surface.normal, Vec3::Z, "{at}");
                    hits += 1;
                }
                None => assert!(!want, "{at}: missed, want the top face"),
            }
        }
        assert!(name == "intersection" || hits >= 32, "{name}: {hits} hits");
    }
}

#[test]
fn parallel_rays_down_a_cylinder_axis_hit_inside_the_rim() {
    // Rays along −Y (the cylinder's axis) from a grid of quarter units: the rim of radius 5/4
    // passes exactly through twelve of them. Strictly inside the rim: the top cap; strictly
    // outside: nothing; on it: either, finite.
    let r = 1.25f32;
    for (name, solids) in [
        ("cylinder", vec![tube(Vec3::ZERO, r, 2.0, 0)]),
        (
            "stacked cylinders",
            vec![
                tube(Vec3::new(0.0, 0.5, 0.0), r, 1.0, 0),
                tube(Vec3::new(0.0, -0.5, 0.0), r, 1.0, 1),
                csg(CsgOp::Union, 0, 1),
            ],
        ),
    ] {
        let scene = object_scene(solids);
        let mut rim = 0;
        for i in -6..=6 {
            for j in -6..=6 {
                let (x, z) = (i as f32 / 4.0, j as f32 / 4.0);
                let origin = Vec3::new(x, 4.0, z);
                let at = format!("{name}: ray from {origin:?}");
                let variants = [
                    Vec3::new(0.0, -1.0, 0.0),
                    Vec3::new(-0.0, -1.0, 0.0),
                    Vec3::new(0.0, -1.0, -0.0),
                    Vec3::new(-0.0, -1.0, -0.0),
                ];
                let found = variants.map(|d| closest(&scene, &Ray::new(origin, d)));
                for (d, f) in variants.iter().zip(&found) {
                    traced(&scene, Ray::new(origin, *d), &at);
                    if let Some(f) = f {
                        assert_finite(f, &at);
                    }
                    assert_eq!(
                        f.map(|f| (f.hit, f.surface)),
                        found[0].map(|f| (f.hit, f.surface)),
                        "{at}: direction {d:?} differs from +0"
                    );
                }
                let q = i * i + j * j;
                match (q.cmp(&25), found[0]) {
                    (std::cmp::Ordering::Less, Some(f)) => {
                        assert_eq!(f.hit.t, 3.0, "{at}");
                        assert_eq!(f.surface.normal, Vec3::Y, "{at}");
                    }
                    (std::cmp::Ordering::Less, None) => panic!("{at}: missed inside the rim"),
                    (std::cmp::Ordering::Greater, Some(f)) => {
                        panic!("{at}: hit {:?} outside the rim", f.surface.point)
                    }
                    (std::cmp::Ordering::Equal, _) => rim += 1,
                    (std::cmp::Ordering::Greater, None) => {}
                }
            }
        }
        assert_eq!(rim, 12, "{name}: rays exactly on the rim");
    }
}

// ---------------------------------------------------------------------------------------------
// 2. Tangent and near-parallel rays
// ---------------------------------------------------------------------------------------------

/// The distance in `f64` from the point `c` to the line of `ray`.
fn line_distance(ray: &Ray, c: V) -> f64 {
    let (o, d) = (v64(ray.origin), v64(ray.dir));
    let p = [0, 1, 2].map(|a| c[a] - o[a]);
    let dd: f64 = (0..3).map(|a| d[a] * d[a]).sum();
    let pd: f64 = (0..3).map(|a| p[a] * d[a]).sum();
    let pp: f64 = (0..3).map(|a| p[a] * p[a]).sum();
    (pp - pd * pd / dd).max(0.0).sqrt()
}

/// The relative distances `ε` the near-tangent tests go down to.
const EPSILONS: [f64; 7] = [1e-2, 1e-3, 1e-4, 1e-5, 4e-6, 2e-6, 1e-6];

/// A radius (f32) for which `distance` is `r·(1 + sign·ε)` within a tenth of `ε`.
fn radius_at(distance: f64, sign: f64, eps: f64) -> f32 {
    let r = (distance / (1.0 + sign * eps)) as f32;
    let actual = distance / f64::from(r) - 1.0;
    assert!(
        (actual - sign * eps).abs() <= 0.1 * eps,
        "construction: {actual:e} for {sign}·{eps:e}"
    );
    r
}

#[test]
fn near_tangent_rays_hit_a_sphere_inside_and_miss_it_outside() {
    // Random lines at distance D from a centre; the ball's radius is chosen so that D is
    // r(1 − ε) (must hit) or r(1 + ε) (must miss). The origin is two radii back from the point
    // of closest approach.
    let mut rng = Rng::new(17);
    let centres = [
        (Vec3::ZERO, 1.0f32),
        (Vec3::new(0.3, -0.7, 0.2), 1.3),
        (Vec3::new(1000.0, -2000.0, 500.0), 750.0),
        (Vec3::new(1e-3, 0.0, -2e-3), 2e-3),
    ];
    let mut checked = 0;
    for (c, size) in centres {
        for k in 0..40 {
            let d = rng.direction();
            let side = d.any_orthonormal_vector();
            let side = Mat3::from_axis_angle(d, rng.range(0.0, core::f32::consts::TAU)) * side;
            let origin = c + side * size - d * (2.0 * size);
            let dir = if k % 2 == 0 { d } else { d * 3.7 };
            let ray = Ray::new(origin, dir);
            let dist = line_distance(&ray, v64(c));
            for eps in EPSILONS {
                for (sign, want) in [(-1.0, true), (1.0, false)] {
                    let r = radius_at(dist, sign, eps);
                    let solids = vec![ball(c, r, 0)];
                    let scene = object_scene(solids.clone());
                    let at = format!("ball r = {r} at {c:?}, ε = {sign}·{eps:e}, ray {ray:?}");
                    let got = closest(&scene, &ray);
                    assert_eq!(got.is_some(), want, "{at}: {got:?}");
                    if let Some(f) = got {
                        assert_on_surface(&solids, &ray, &f, &at);
                        assert!(
                            f.surface.normal.dot(dir) <= 1e-3 * dir.length(),
                            "{at}: the first hit from outside faces the ray"
                        );
                    }
                    traced(&scene, ray, &at);
                    checked += 1;
                }
            }
        }
    }
    assert_eq!(checked, 4 * 40 * EPSILONS.len() * 2);
}

#[test]
fn near_tangent_rays_hit_a_cylinder_inside_and_miss_it_outside() {
    // As for the ball, with lines at distance D from the axis (measured across it): level ones
    // (d.y = ±0 or tiny) and slanted ones, all passing the axis well between the caps.
    let mut rng = Rng::new(23);
    let placements = [
        (Vec3::ZERO, 1.0f32),
        (Vec3::new(0.3, -0.7, 0.2), 1.3),
        (Vec3::new(1000.0, -2000.0, 500.0), 750.0),
    ];
    let mut checked = 0;
    for (c, size) in placements {
        for k in 0..30 {
            let phi = rng.range(0.0, core::f32::consts::TAU);
            let across = Vec3::new(phi.cos(), 0.0, phi.sin());
            let side = Vec3::new(-across.z, 0.0, across.x);
            let slope = match k % 3 {
                0 => 0.0,
                1 => -0.0,
                _ => rng.range(-0.5, 0.5),
            };
            let d = Vec3::new(across.x, slope, across.z);
            let origin = c + side * size - d * (2.0 * size);
            let ray = Ray::new(origin, d);
            // Across the axis: the distance of the lines' projections on the XZ plane.
            let flat_ray = Ray::new(Vec3::new(origin.x, 0.0, origin.z), Vec3::new(d.x, 0.0, d.z));
            let dist = line_distance(&flat_ray, [f64::from(c.x), 0.0, f64::from(c.z)]);
            for eps in EPSILONS {
                for (sign, want) in [(-1.0, true), (1.0, false)] {
                    let r = radius_at(dist, sign, eps);
                    let solids = vec![tube(c, r, 20.0 * size, 0)];
                    let scene = object_scene(solids.clone());
                    let at = format!("cylinder r = {r} at {c:?}, ε = {sign}·{eps:e}, {ray:?}");
                    let got = closest(&scene, &ray);
                    assert_eq!(got.is_some(), want, "{at}: {got:?}");
                    if let Some(f) = got {
                        assert_eq!(f.hit.face, 0, "{at}: the side");
                        assert_on_surface(&solids, &ray, &f, &at);
                    }
                    traced(&scene, ray, &at);
                    checked += 1;
                }
            }
        }
    }
    assert_eq!(checked, 3 * 30 * EPSILONS.len() * 2);
}

#[test]
fn cylinder_hits_from_far_away_have_t_within_its_error_bound() {
    // From 100 to 10⁴ radii away the side's quadratic has huge, nearly equal b² and 4ac: its
    // roots must not lose their accuracy to cancellation. Every hit's t must match the f64
    // reference within the hit's own error bound (and every sure reference hit be found).
    let mut rng = Rng::new(31);
    let c = Vec3::new(0.5, -0.25, 0.125);
    let solids = vec![tube(c, 1.0, 2.0, 0)];
    let scene = object_scene(solids.clone());
    let tree = RefTree::of(&solids, 0);
    let mut hits = 0;
    for far in [1e2f32, 1e3, 1e4] {
        for i in 0..300 {
            let target = c + Vec3::new(
                rng.range(-0.9, 0.9),
                rng.range(-0.9, 0.9),
                rng.range(-0.9, 0.9),
            );
            let ray = Ray::new(target + rng.direction() * far, rng.direction() * far);
            let ray = Ray::new(ray.origin, target - ray.origin);
            let at = format!("ray {i} from {far} away: {ray:?}");
            let got = closest(&scene, &ray);
            let Ok(want) = tree.first(v64(ray.origin), v64(ray.dir)) else {
                continue;
            };
            match (want, got) {
                (Some(t), Some(f)) => {
                    assert!(
                        (f64::from(f.hit.t) - t).abs() <= f64::from(f.hit.t_error),
                        "{at}: t = {} ± {}, want {t}",
                        f.hit.t,
                        f.hit.t_error
                    );
                    assert_on_surface(&solids, &ray, &f, &at);
                    hits += 1;
                }
                (None, None) => {}
                (want, got) => panic!("{at}: got {got:?}, want {want:?}"),
            }
        }
    }
    assert!(hits > 800, "only {hits} of 900 rays hit");
}

#[test]
fn exactly_tangent_rays_give_finite_normals() {
    let unit_ball = vec![ball(Vec3::ZERO, 1.0, 0)];
    let moved_ball = vec![ball(Vec3::new(0.5, -0.25, 2.0), 0.75, 0)];
    // Exactly tangent to the ball at (1, 0, 0), (0, 0, −1) and (0.5 + 0.75, −0.25, 2).
    let mut cases: Vec<(&str, Vec<SolidNode>, Ray)> = vec![
        (
            "ball",
            unit_ball.clone(),
            Ray::new(Vec3::new(1.0, -2.0, 0.0), Vec3::Y),
        ),
        (
            "ball",
            unit_ball,
            Ray::new(Vec3::new(-3.0, 0.0, -1.0), Vec3::new(2.0, 0.0, 0.0)),
        ),
        (
            "moved ball",
            moved_ball,
            Ray::new(Vec3::new(1.25, -0.25, -1.0), Vec3::Z),
        ),
    ];
    // Tangent up to the rounding of the radius: random lines, r = f32(distance).
    let mut rng = Rng::new(5);
    for _ in 0..60 {
        let d = rng.direction();
        let origin = d.any_orthonormal_vector() * rng.range(0.5, 2.0) - d * 3.0;
        let ray = Ray::new(origin, d);
        let r = line_distance(&ray, [0.0; 3]) as f32;
        cases.push(("ball at rounding", vec![ball(Vec3::ZERO, r, 0)], ray));
    }
    // A box's face planes, edges and vertices, run along.
    let cube = vec![block(Vec3::splat(-1.0), Vec3::ONE, 0)];
    for o in [
        Vec3::new(1.0, 0.0, -3.0),
        Vec3::new(-1.0, 0.0, -3.0),
        Vec3::new(1.0, 1.0, -3.0),
        Vec3::new(-1.0, -1.0, -3.0),
        Vec3::new(-1.0, 1.0, -3.0),
    ] {
        cases.push((
            "cube along a face or edge",
            cube.clone(),
            Ray::new(o, Vec3::Z),
        ));
    }
    cases.push((
        "cube through a vertex",
        cube.clone(),
        Ray::new(Vec3::new(-3.0, -1.0, -1.0), Vec3::new(2.0, 0.0, 0.0)),
    ));
    cases.push((
        "cube touching a vertex diagonally",
        cube,
        Ray::new(Vec3::new(-2.0, 0.0, -1.0), Vec3::new(1.0, 1.0, 0.0)),
    ));
    // The cylinder's side: tangent across, along a generator, and along the rim.
    let cylinder = vec![tube(Vec3::ZERO, 1.0, 2.0, 0)];
    for ray in [
        Ray::new(Vec3::new(-3.0, 0.0, 1.0), Vec3::X),
        Ray::new(Vec3::new(-3.0, 0.5, -1.0), Vec3::X),
        Ray::new(Vec3::new(1.0, -3.0, 0.0), Vec3::Y),
        Ray::new(Vec3::new(0.0, 3.0, -1.0), Vec3::NEG_Y),
        Ray::new(Vec3::new(-3.0, 1.0, 1.0), Vec3::X),
        Ray::new(Vec3::new(-3.0, -1.0, -1.0), Vec3::X),
    ] {
        cases.push(("cylinder", cylinder.clone(), ray));
    }
    // Rays leaving the top cap's rim outwards, crossing the cap's plane δ beyond the rim: they
    // touch the cylinder within their rounding error (and may count as hitting it there).
    for delta in [0.0f32, 1e-7, 1e-6, 2e-6, 3e-6, 3.5e-6, 4e-6] {
        for (o, d) in [
            (Vec3::new(delta, 2.0, 0.0), Vec3::new(1.0, -1.0, 0.0)),
            (Vec3::new(0.0, 2.0, -delta), Vec3::new(0.0, -1.0, -1.0)),
            (Vec3::new(-delta, -2.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)),
        ] {
            cases.push(("cylinder rim", cylinder.clone(), Ray::new(o, d)));
        }
    }
    // A cone along its generator: from (1, −1, 0) at the base to the apex (0, 1, 0).
    let cone = vec![leaf(
        Shape::Cylinder {
            bottom_radius: 1.0,
            top_radius: 0.0,
            height: 2.0,
        },
        Transform::IDENTITY,
        0,
    )];
    cases.push((
        "cone along a generator",
        cone.clone(),
        Ray::new(Vec3::new(2.0, -3.0, 0.0), Vec3::new(-1.0, 2.0, 0.0)),
    ));
    cases.push((
        "cone through its apex along the axis",
        cone,
        Ray::new(Vec3::new(0.0, 3.0, 0.0), Vec3::NEG_Y),
    ));
    let mut hits = 0;
    for (name, solids, ray) in cases {
        let scene = object_scene(solids.clone());
        let at = format!("{name}: {ray:?}");
        traced(&scene, ray, &at);
        let Some(f) = closest(&scene, &ray) else {
            continue;
        };
        hits += 1;
        assert_finite(&f, &at);
        if !name.starts_with("cone") {
            assert_on_surface(&solids, &ray, &f, &at);
        }
        // Follow the ray through: every later hit is finite too.
        let next = continue_past(&ray, &f);
        if let Some(g) = closest(&scene, &next) {
            assert_finite(&g, &format!("{at}, past the first hit"));
        }
        traced(&scene, next, &at);
    }
    // Tangent rays may count as touching or missing; most of these do touch.
    assert!(hits >= 40, "only {hits} tangent rays hit");
}

/// The grazing slopes: `s = m · 2^−k` from about 1e-3 down to about 1.2e-7 (1 ulp of 1), so
/// that `1 + s·L` is exact for the lengths `L` used.
fn grazing_slopes() -> Vec<f32> {
    let mut out = Vec::new();
    for k in 10..=23 {
        for m in [1.0f32, 3.0] {
            if k == 23 && m == 3.0 {
                continue;
            }
            out.push(m * 2f32.powi(-k));
        }
    }
    out
}

#[test]
fn grazing_rays_entering_a_box_face_hit_it() {
    // A ray slopes by s (angle ≈ s) towards face `a = σ` of the cube [−1, 1]³ (moved by a dyadic
    // offset) and crosses its plane at parameter L (L = 3: the face's middle line; L = 2:
    // exactly its edge), then runs on inside the box, s deep at its far side: it must hit, on
    // the box within the error bound, and from there go on and leave the box.
    let mut checked = 0;
    for offset in [Vec3::ZERO, Vec3::new(0.5, -0.25, 0.125)] {
        let solids = vec![block(offset - Vec3::ONE, offset + Vec3::ONE, 0)];
        let scene = object_scene(solids.clone());
        for a in 0..3 {
            let (b, c) = ((a + 1) % 3, (a + 2) % 3);
            for sigma in [1.0f32, -1.0] {
                for beta in [1.0f32, -1.0] {
                    for s in grazing_slopes() {
                        for l in [2.0f32, 3.0] {
                            let mut o = Vec3::ZERO;
                            o[a] = sigma * (1.0 + s * l);
                            o[b] = -3.0 * beta;
                            o[c] = -0.5;
                            let mut d = Vec3::ZERO;
                            d[a] = -sigma * s;
                            d[b] = beta;
                            d[c] = 0.25;
                            let ray = Ray::new(o + offset, d);
                            let at = format!("face {a}{sigma}, slope {s:e}, L = {l}: {ray:?}");
                            let f = closest(&scene, &ray)
                                .unwrap_or_else(|| panic!("{at}: a ray into the box missed"));
                            assert_on_surface(&solids, &ray, &f, &at);
                            assert!(
                                f.surface.normal.dot(d) <= 0.0,
                                "{at}: entering, the outward normal {:?} faces the ray",
                                f.surface.normal
                            );
                            let on = continue_past(&ray, &f);
                            let exit = closest(&scene, &on)
                                .unwrap_or_else(|| panic!("{at}: no way out of the box"));
                            assert_on_surface(&solids, &on, &exit, &format!("{at}, exit"));
                            assert!(
                                exit.surface.normal.dot(d) > 0.0,
                                "{at}: leaving through {:?}",
                                exit.surface.normal
                            );
                            traced(&scene, ray, &at);
                            checked += 1;
                        }
                    }
                }
            }
        }
    }
    assert_eq!(checked, 2 * 3 * 2 * 2 * grazing_slopes().len() * 2);
}

#[test]
fn grazing_rays_entering_a_cylinder_side_hit_it() {
    // A ray nearly along the axis slopes by s towards the side of a cylinder of radius 1 from
    // y = −1 to 1 (moved by a dyadic offset), from below its bottom cap, and crosses the side's
    // surface at parameter L (L = 2: at y = 0; L = 1: exactly on the bottom rim), then runs on
    // inside, s deep at the top cap: it must hit, on the cylinder within the error bound, and
    // from there go on and leave it.
    let mut checked = 0;
    for offset in [Vec3::ZERO, Vec3::new(0.5, -0.25, 0.125)] {
        let solids = vec![tube(offset, 1.0, 2.0, 0)];
        let scene = object_scene(solids.clone());
        for n in [Vec3::X, Vec3::NEG_X, Vec3::Z, Vec3::NEG_Z] {
            for s in grazing_slopes() {
                for l in [1.0f32, 2.0] {
                    let o = n * (1.0 + s * l) + Vec3::new(0.0, -2.0, 0.0);
                    let d = Vec3::Y - n * s;
                    let ray = Ray::new(o + offset, d);
                    let at = format!("side {n:?}, slope {s:e}, L = {l}: {ray:?}");
                    let f = closest(&scene, &ray)
                        .unwrap_or_else(|| panic!("{at}: a ray into the cylinder missed"));
                    assert_on_surface(&solids, &ray, &f, &at);
                    assert!(
                        f.surface.normal.dot(d) <= 0.0,
                        "{at}: entering, the outward normal {:?} faces the ray",
                        f.surface.normal
                    );
                    let on = continue_past(&ray, &f);
                    let exit = closest(&scene, &on)
                        .unwrap_or_else(|| panic!("{at}: no way out of the cylinder"));
                    assert_on_surface(&solids, &on, &exit, &format!("{at}, exit"));
                    assert!(
                        exit.surface.normal.dot(d) > 0.0,
                        "{at}: leaving through {:?}",
                        exit.surface.normal
                    );
                    traced(&scene, ray, &at);
                    checked += 1;
                }
            }
        }
    }
    assert_eq!(checked, 2 * 4 * grazing_slopes().len() * 2);
}

#[test]
fn rays_parallel_to_a_face_just_outside_it_hit_on_the_surface() {
    // A ray exactly parallel to a box face or a cylinder cap (that component ±0), a distance δ
    // outside or inside its plane, from near and from far away. Within the rounding error of
    // its origin, a ray outside counts as inside the slab (`in_slab_parallel`) and may hit the
    // next face: that hit must still lie on the solid within its error bound. Each solid is
    // tried alone and in a union with a second box that is not in the ray's way but widens the
    // object's bounds past the ray (alone, the octree's bounding box turns most of these rays
    // away before the solid sees them). Rays δ inside always hit the solid.
    let cube = block(Vec3::splat(-1.0), Vec3::ONE, 0);
    let cylinder = tube(Vec3::ZERO, 1.0, 2.0, 0);
    let with =
        |a: SolidNode, lo: Vec3, hi: Vec3| vec![a, block(lo, hi, 1), csg(CsgOp::Union, 0, 1)];
    let objects = [
        (
            "cube face x",
            vec![
                vec![cube],
                with(cube, Vec3::new(-1.5, -1.0, -3.0), Vec3::new(1.5, 1.0, -2.0)),
            ],
        ),
        (
            "cube face z",
            vec![
                vec![cube],
                with(cube, Vec3::new(-3.0, -1.0, -1.5), Vec3::new(-2.0, 1.0, 1.5)),
            ],
        ),
        (
            "cylinder cap",
            vec![
                vec![cylinder],
                with(
                    cylinder,
                    Vec3::new(2.0, -1.5, -1.0),
                    Vec3::new(3.0, 1.5, 1.0),
                ),
            ],
        ),
    ];
    let mut grazed = 0;
    for (name, variants) in &objects {
        for solids in variants {
            let scene = object_scene(solids.clone());
            for far in [4.0f32, 1e3] {
                for delta in [1.2e-7f32, 1e-6, 1e-5, 1e-4, 1e-3] {
                    for side in [1.0f32, -1.0] {
                        for sign in [1.0f32, -1.0] {
                            let level = side * (1.0 + sign * delta);
                            let ray = match *name {
                                "cube face x" => Ray::new(
                                    Vec3::new(level, -far, -0.5),
                                    Vec3::new(0.0, 1.0, 0.25 / far),
                                ),
                                "cube face z" => Ray::new(
                                    Vec3::new(0.25, far, level),
                                    Vec3::new(-0.125 / far, -1.0, -0.0),
                                ),
                                _ => Ray::new(
                                    Vec3::new(-far, level, 0.25),
                                    Vec3::new(1.0, 0.0, -0.125 / far),
                                ),
                            };
                            let at = format!(
                                "{name} ({} nodes), δ = {sign}·{delta:e}, from {far} away: \
                                 {ray:?}",
                                solids.len()
                            );
                            traced(&scene, ray, &at);
                            let f = closest(&scene, &ray);
                            if let Some(f) = f {
                                assert_on_surface(solids, &ray, &f, &at);
                            }
                            let on_solid = f.is_some_and(|f| f.hit.leaf == 0);
                            if sign < 0.0 {
                                assert!(on_solid, "{at}: a ray inside the slab missed: {f:?}");
                            } else {
                                grazed += usize::from(on_solid);
                            }
                        }
                    }
                }
            }
        }
    }
    // Rays outside by less than the rounding error of their origin count as inside.
    assert!(grazed >= 20, "only {grazed} rays outside a face plane hit");
}

// ---------------------------------------------------------------------------------------------
// 3. Direction components of +0 and −0
// ---------------------------------------------------------------------------------------------

/// Every direction with components from {+0, −0, +1, −1} (not all zero).
fn signed_zero_directions() -> Vec<Vec3> {
    let values = [0.0f32, -0.0, 1.0, -1.0];
    let mut out = Vec::new();
    for x in values {
        for y in values {
            for z in values {
                if x != 0.0 || y != 0.0 || z != 0.0 {
                    out.push(Vec3::new(x, y, z));
                }
            }
        }
    }
    out
}

/// `d` with every −0 component made +0.
fn positive_zeros(d: Vec3) -> Vec3 {
    Vec3::from_array(d.to_array().map(|x| if x == 0.0 { 0.0 } else { x }))
}

/// Shoots rays from every combination of `coords` (per axis) along every signed-zero
/// direction at object `solids` (its last node) and checks: the same hit (and the same leaf
/// span in object space) for +0 and −0, finite numbers and colours, and the hit or miss and the
/// `t` of the reference, where it is sure. Returns how many rays the reference was sure of and
/// how many of those hit.
fn check_signed_zeros(name: &str, solids: Vec<SolidNode>, coords: [&[f32]; 3]) -> (usize, usize) {
    let root = solids.len() as u32 - 1;
    let tree = RefTree::of(&solids, root);
    let scene = object_scene(solids.clone());
    let (mut sure, mut hits) = (0, 0);
    for &x in coords[0] {
        for &y in coords[1] {
            for &z in coords[2] {
                let o = Vec3::new(x, y, z);
                for d in signed_zero_directions() {
                    let ray = Ray::new(o, d);
                    let canonical = Ray::new(o, positive_zeros(d));
                    let at = format!("{name}: from {o:?} along {d:?}");
                    let got = closest(&scene, &ray);
                    let want = closest(&scene, &canonical);
                    assert_eq!(
                        got.map(|f| (f.hit, f.surface)),
                        want.map(|f| (f.hit, f.surface)),
                        "{at}: −0 and +0 differ"
                    );
                    // Leaf spans in object space, bit for bit.
                    for node in &solids {
                        if let SolidNode::Leaf {
                            shape, transform, ..
                        } = node
                        {
                            let local = o - transform.translation;
                            let sp: Option<ShapeSpan> = shape::span(shape, local, d);
                            let sp0 = shape::span(shape, local, positive_zeros(d));
                            assert_eq!(sp, sp0, "{at}: leaf span of {shape:?}");
                            if let Some(sp) = sp {
                                assert!(
                                    !sp.enter.t.is_nan()
                                        && !sp.exit.t.is_nan()
                                        && !sp.enter.t_error.is_nan()
                                        && !sp.exit.t_error.is_nan()
                                        && !sp.enter.merge_error.is_nan()
                                        && !sp.exit.merge_error.is_nan(),
                                    "{at}: NaN in {sp:?}"
                                );
                            }
                        }
                    }
                    if let Some(f) = got {
                        assert_finite(&f, &at);
                    }
                    let c = traced(&scene, ray, &at);
                    assert_eq!(c, traced(&scene, canonical, &at), "{at}: colours differ");
                    let Ok(first) = tree.first(v64(o), v64(d)) else {
                        continue;
                    };
                    sure += 1;
                    match (first, got) {
                        (None, None) => {}
                        (Some(t), Some(f)) => {
                            hits += 1;
                            assert!(
                                (f64::from(f.hit.t) - t).abs() <= 1e-5 * (1.0 + t),
                                "{at}: t = {}, want {t}",
                                f.hit.t
                            );
                            let p = v64(f.surface.point);
                            let q = [0, 1, 2].map(|a| v64(o)[a] + t * v64(d)[a]);
                            assert!(
                                (0..3).all(|a| (p[a] - q[a]).abs() <= 1e-5 * (1.0 + q[a].abs())),
                                "{at}: hit {p:?}, want {q:?}"
                            );
                        }
                        (want, got) => panic!(
                            "{at}: got {:?}, want {want:?}",
                            got.map(|f| (f.hit.t, f.surface.point))
                        ),
                    }
                }
            }
        }
    }
    (sure, hits)
}

#[test]
fn signed_zero_directions_through_a_box_on_its_face_planes() {
    // The box [−1, 1] × [−½, ½] × [−2, 2], at the origin and moved by a dyadic offset (the
    // offset keeps every origin exactly on its planes in object space).
    for offset in [Vec3::ZERO, Vec3::new(0.5, -0.25, 2.0)] {
        let half = Vec3::new(1.0, 0.5, 2.0);
        let coords = |a: usize| -> Vec<f32> {
            [-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0]
                .map(|k: f32| k * half[a] + offset[a])
                .to_vec()
        };
        let (xs, ys, zs) = (coords(0), coords(1), coords(2));
        let (sure, hits) = check_signed_zeros(
            &format!("box at {offset:?}"),
            vec![block(offset - half, offset + half, 0)],
            [&xs, &ys, &zs],
        );
        assert_eq!(sure, 7 * 7 * 7 * 56, "the box reference is always sure");
        assert!(hits > 2000, "only {hits} hits");
    }
}

#[test]
fn signed_zero_directions_through_a_cylinder_on_its_cap_planes() {
    // Radius 5/4 (the rim passes exactly through (±3/4, ·, ±1), (±1, ·, ±3/4), (±5/4, ·, 0)),
    // caps at y = ±1: origins exactly on the cap planes, on the side, on the axis.
    let xz: &[f32] = &[-2.0, -1.25, -1.0, -0.75, 0.0, 0.75, 1.0, 1.25, 2.0];
    let ys: &[f32] = &[-2.0, -1.0, -0.5, 0.0, 1.0, 2.0];
    let (sure, hits) = check_signed_zeros(
        "cylinder",
        vec![tube(Vec3::ZERO, 1.25, 2.0, 0)],
        [xz, ys, xz],
    );
    assert!(sure > 20_000, "the reference was sure of only {sure} rays");
    assert!(hits > 3000, "only {hits} hits");
}

#[test]
fn signed_zero_directions_through_csg_objects() {
    // Two unit-high boxes sharing the face x = 0 in every operation, a box minus a ball, a box
    // united with a cylinder, and a box cut by a half-space: origins on the shared plane and on
    // the other face planes.
    let a = block(Vec3::new(-1.0, -1.0, -1.0), Vec3::new(0.0, 1.0, 1.0), 0);
    let b = block(Vec3::new(0.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0), 1);
    let xs: &[f32] = &[-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0];
    let yz: &[f32] = &[-2.0, -1.0, 0.0, 1.0, 2.0];
    let objects: Vec<(&str, Vec<SolidNode>)> = vec![
        ("A ∪ B", vec![a, b, csg(CsgOp::Union, 0, 1)]),
        ("A ∩ B", vec![a, b, csg(CsgOp::Intersect, 0, 1)]),
        ("A − B", vec![a, b, csg(CsgOp::Subtract, 0, 1)]),
        ("B − A", vec![a, b, csg(CsgOp::Subtract, 1, 0)]),
        (
            "box − ball",
            vec![
                block(Vec3::splat(-1.0), Vec3::ONE, 0),
                ball(Vec3::new(0.0, 0.0, 1.0), 0.5, 1),
                csg(CsgOp::Subtract, 0, 1),
            ],
        ),
        (
            "box ∪ cylinder",
            vec![
                block(Vec3::new(-1.0, -0.5, -0.5), Vec3::new(1.0, 0.5, 0.5), 0),
                tube(Vec3::ZERO, 1.0, 1.0, 1),
                csg(CsgOp::Union, 0, 1),
            ],
        ),
        (
            "box ∩ half-space",
            vec![
                block(Vec3::splat(-1.0), Vec3::ONE, 0),
                floor(0.0, 1),
                csg(CsgOp::Intersect, 0, 1),
            ],
        ),
    ];
    for (name, solids) in objects {
        let (sure, hits) = check_signed_zeros(name, solids, [xs, yz, yz]);
        assert!(sure > 5000, "{name}: the reference was sure of only {sure}");
        assert!(
            name == "A ∩ B" || hits > 500,
            "{name}: only {hits} hits of {sure}"
        );
        if name == "A ∩ B" {
            assert_eq!(hits, 0, "A ∩ B has no volume");
        }
    }
}

#[test]
fn rays_in_the_shared_face_plane_follow_the_half_open_rule() {
    // The rule spelled out on the twin boxes: a ray lying in the plane x = 0 (d.x = ±0) belongs
    // to B ([0, 1)) and not to A ([−1, 0)), so the union and B − A are hit there, A ∩ B and
    // A − B are not; in the plane x = −1 only A is; in the plane x = 1 nothing is.
    let a = block(Vec3::new(-1.0, -1.0, -1.0), Vec3::new(0.0, 1.0, 1.0), 0);
    let b = block(Vec3::new(0.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0), 1);
    let ops = [
        ("A ∪ B", CsgOp::Union, 0, 1),
        ("A ∩ B", CsgOp::Intersect, 0, 1),
        ("A − B", CsgOp::Subtract, 0, 1),
        ("B − A", CsgOp::Subtract, 1, 0),
    ];
    for (name, op, first, second) in ops {
        let scene = object_scene(vec![a, b, csg(op, first, second)]);
        for (x, in_a, in_b) in [
            (0.0f32, false, true),
            (-1.0, true, false),
            (1.0, false, false),
        ] {
            let inside = match op {
                CsgOp::Union => in_a || in_b,
                CsgOp::Intersect => in_a && in_b,
                CsgOp::Subtract if first == 0 => in_a && !in_b,
                CsgOp::Subtract => in_b && !in_a,
            };
            for dx in [0.0f32, -0.0] {
                for (o, d) in [
                    (Vec3::new(x, 0.25, -3.0), Vec3::new(dx, 0.0, 1.0)),
                    (Vec3::new(x, -3.0, 0.25), Vec3::new(dx, 1.0, -0.0)),
                    (Vec3::new(x, 3.0, 3.0), Vec3::new(dx, -1.0, -1.0)),
                ] {
                    let ray = Ray::new(o, d);
                    let at = format!("{name}: plane x = {x}, from {o:?} along {d:?}");
                    let f = closest(&scene, &ray);
                    assert_eq!(f.is_some(), inside, "{at}: {f:?}");
                    if let Some(f) = f {
                        assert_finite(&f, &at);
                        assert_eq!(f.hit.t, 2.0, "{at}");
                        let want_leaf = if x == 0.0 { 1 } else { 0 };
                        assert_eq!(f.hit.leaf, want_leaf, "{at}: the operand hit");
                        assert!(f.surface.normal.dot(d) < 0.0, "{at}: outer face");
                        assert_eq!(f.surface.normal.x, 0.0, "{at}: not the shared wall");
                    }
                    traced(&scene, ray, &at);
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// 4. A camera or a light inside
// ---------------------------------------------------------------------------------------------

/// Renders `scene` from inside object `solids` (its last node) and checks every pixel's first
/// hit: the ray leaves the object there (outward normal along the ray, so the shaded normal,
/// turned, faces it), at the reference's first exit, on the surface within the error bound; no
/// background, no NaN. Returns how many pixels hit each leaf.
fn check_inside_view(name: &str, scene: &Scene, solids: &[SolidNode]) -> Vec<usize> {
    let root = solids.len() as u32 - 1;
    let tree = RefTree::of(solids, root);
    let img = render(scene);
    let background = Pixel::from_color(BACKGROUND);
    let (w, h) = (
        scene.settings.width as usize,
        scene.settings.height as usize,
    );
    let mut per_leaf = vec![0; solids.len()];
    for y in 0..h {
        for x in 0..w {
            let ray = pixel_ray(scene, x, y);
            let at = format!("{name}: pixel ({x}, {y})");
            assert_ne!(img.at(x, y), background, "{at}: sees out");
            let f = closest(scene, &ray).unwrap_or_else(|| panic!("{at}: no hit"));
            assert_on_surface(solids, &ray, &f, &at);
            let n = f.surface.normal;
            // What shading does: turn the outward normal towards the incoming ray.
            let entering = n.dot(ray.dir) <= 0.0;
            let shaded = if entering { n } else { -n };
            assert!(!entering, "{at}: the first hit enters the object ({n:?})");
            assert!(shaded.dot(ray.dir) < 0.0, "{at}: shaded normal faces away");
            let want = tree
                .first(v64(ray.origin), v64(ray.dir))
                .unwrap_or_else(|()| panic!("{at}: the reference is unsure"))
                .unwrap_or_else(|| panic!("{at}: the reference finds no way out"));
            assert!(
                (f64::from(f.hit.t) - want).abs() <= 1e-5 * (1.0 + want),
                "{at}: t = {}, want the exit at {want}",
                f.hit.t
            );
            per_leaf[f.hit.leaf as usize] += 1;
        }
    }
    per_leaf
}

#[test]
fn camera_inside_a_cylinder_sees_its_inner_walls() {
    // A cylinder of radius 2 from y = −3 to 3 (the seed's camera looks along +Y: down the
    // axis); cameras on the axis (the centre ray runs exactly along it), off it, and tilted or
    // turned to look at the side.
    let solids = vec![tube(Vec3::new(0.25, 0.0, -0.5), 2.0, 6.0, 0)];
    for (position, tilt, turn) in [
        (Vec3::new(0.25, -2.0, -0.5), 0.0, 0.0),
        (Vec3::new(0.25, 0.0, -0.5), 0.0, 0.0),
        (Vec3::new(1.0, -1.0, 0.5), 10.0, 0.0),
        (Vec3::new(-0.5, 2.5, -1.0), -30.0, 90.0),
        (Vec3::new(0.25, -2.999, 1.499), 0.0, 180.0),
    ] {
        let scene = scene_of(
            solids.clone(),
            vec![0],
            vec![matte(0.2, 0.7)],
            vec![point_light(Vec3::new(0.5, 1.0, 0.0))],
            eye(position, tilt, turn),
            settings(25, 19),
        );
        let name = format!("camera at {position:?}, tilt {tilt}, turn {turn}");
        check_inside_view(&name, &scene, &solids);
        if tilt == 0.0 && turn == 0.0 && position.x == 0.25 {
            // The centre pixel's ray runs exactly along the axis to the top cap's centre.
            let ray = pixel_ray(&scene, 12, 9);
            assert_eq!(ray.dir, Vec3::Y, "{name}");
            let f = closest(&scene, &ray).expect("the axis ray leaves");
            assert_eq!(f.surface.point, Vec3::new(0.25, 3.0, -0.5), "{name}");
            assert_eq!(f.surface.normal, Vec3::Y, "{name}");
        }
    }
}

#[test]
fn camera_inside_csg_objects_sees_their_inner_walls() {
    // In the solid part of a box minus a ball (the ball's hole in view: its surface is left
    // through the ball's turned normal), in the overlap of a box and a cylinder's union (no
    // inner wall in view), and in a cone-free intersection of a box and a ball.
    let cases: Vec<(&str, Vec<SolidNode>, Vec3, f32)> = vec![
        (
            "box − ball",
            vec![
                block(Vec3::splat(-2.0), Vec3::splat(2.0), 0),
                ball(Vec3::new(0.0, 0.5, 0.5), 1.0, 1),
                csg(CsgOp::Subtract, 0, 1),
            ],
            Vec3::new(0.3, -1.5, -1.0),
            20.0,
        ),
        (
            "box ∪ cylinder",
            vec![
                block(Vec3::new(-2.0, -1.0, -1.0), Vec3::new(2.0, 1.0, 1.0), 0),
                tube(Vec3::ZERO, 1.5, 5.0, 1),
                csg(CsgOp::Union, 0, 1),
            ],
            Vec3::new(0.2, -0.3, 0.1),
            0.0,
        ),
        (
            "box ∩ ball",
            vec![
                block(Vec3::splat(-1.0), Vec3::splat(1.0), 0),
                ball(Vec3::ZERO, 1.25, 1),
                csg(CsgOp::Intersect, 0, 1),
            ],
            Vec3::new(0.1, -0.5, 0.2),
            5.0,
        ),
    ];
    for (name, solids, position, tilt) in cases {
        for turn in [0.0, 90.0, 200.0] {
            let root = solids.len() as u32 - 1;
            let scene = scene_of(
                solids.clone(),
                vec![root],
                vec![matte(0.2, 0.7), matte(0.3, 0.6)],
                vec![point_light(position + Vec3::new(0.1, 0.2, 0.3))],
                eye(position, tilt, turn),
                settings(25, 19),
            );
            let per_leaf = check_inside_view(&format!("{name}, turn {turn}"), &scene, &solids);
            if turn == 0.0 {
                // Both operands' walls are in view, so both kinds of inside hit were checked.
                assert!(
                    per_leaf[0] > 0 && per_leaf[1] > 0,
                    "{name}: hits per leaf {per_leaf:?}"
                );
            }
        }
    }
}

#[test]
fn light_inside_a_cylinder_or_csg_object_lights_only_inside() {
    // A floor (the half-space z ≤ −3) and a closed object around the only light. Seen from
    // outside, nothing is lit: every pixel is an ambient colour or the background, and the
    // object and the floor are both in view. Seen from inside, the walls around the light are.
    let v = Vec3::new;
    let objects: Vec<(&str, Vec<SolidNode>, Vec3)> = vec![
        (
            "cylinder",
            vec![tube(v(0.0, 0.0, 0.0), 2.0, 6.0, 1)],
            v(0.5, 0.25, -0.5),
        ),
        (
            "box − ball",
            vec![
                block(Vec3::splat(-2.0), Vec3::splat(2.0), 1),
                ball(v(0.0, 0.5, 0.5), 1.0, 1),
                csg(CsgOp::Subtract, 0, 1),
            ],
            v(0.3, -1.5, -1.0),
        ),
        (
            "box ∪ cylinder",
            vec![
                block(v(-2.0, -1.0, -1.0), v(2.0, 1.0, 1.0), 1),
                tube(Vec3::ZERO, 1.5, 5.0, 1),
                csg(CsgOp::Union, 0, 1),
            ],
            v(1.5, 0.5, 0.0),
        ),
    ];
    let ambient = [0.1f32, 0.25];
    for (name, mut solids, light) in objects {
        let root = solids.len() as u32 - 1;
        solids.push(floor(-3.0, 0));
        let floor_node = solids.len() as u32 - 1;
        let outside: [(Vec3, f32); 2] = [(v(0.0, -12.0, 6.0), -30.0), (v(7.0, -9.0, 1.0), -5.0)];
        for (position, tilt) in outside {
            let scene = scene_of(
                solids.clone(),
                vec![root, floor_node],
                ambient.iter().map(|&a| matte(a, 0.8)).collect(),
                vec![point_light(light)],
                eye(position, tilt, 0.0),
                settings(48, 36),
            );
            let img = render(&scene);
            let allowed: Vec<Pixel> = ambient
                .iter()
                .map(|&a| Pixel::from_color(Vec3::splat(a)))
                .chain([Pixel::from_color(BACKGROUND)])
                .collect();
            let mut seen = [0usize; 3];
            for (i, p) in img.pixels.iter().enumerate() {
                let k = allowed.iter().position(|a| a == p).unwrap_or_else(|| {
                    panic!(
                        "{name}, eye {position:?}: pixel {i} is {p:?} ({:?}): lit by the light \
                         inside",
                        img.colors[i]
                    )
                });
                seen[k] += 1;
            }
            assert!(
                seen[0] > 0 && seen[1] > 0,
                "{name}, eye {position:?}: floor and object not both in view: {seen:?}"
            );
        }
        // From inside, next to the light: every wall at least ambient, and many lit.
        let scene = scene_of(
            solids.clone(),
            vec![root, floor_node],
            ambient.iter().map(|&a| matte(a, 0.8)).collect(),
            vec![point_light(light)],
            eye(light + v(0.05, -0.1, 0.05), 0.0, 0.0),
            settings(25, 19),
        );
        let img = render(&scene);
        let lit = img
            .colors
            .iter()
            .filter(|c| c.x > ambient[1] + 0.01)
            .count();
        for (i, c) in img.colors.iter().enumerate() {
            assert!(
                c.x >= ambient[1] - 1e-6 && c.x == c.y,
                "{name} from inside: pixel {i} is {c:?}"
            );
        }
        assert!(
            lit * 2 > img.colors.len(),
            "{name} from inside: only {lit} of {} pixels lit",
            img.colors.len()
        );
    }
}
