//! Hard cases for the renderer, one named test each, every one asserting a concrete outcome:
//! closed meshes seen exactly through their shared edges and vertices, rays parallel and nearly
//! parallel to a surface, degenerate triangles, one scene at scales from 1e-6 to 1e6, zero and
//! negative-zero direction components, a camera or light inside objects or on a surface,
//! coplanar triangles, facing perfect mirrors, bad numbers in the input files, and property tests
//! of the octree, of hit points and of reflected rays.
//!
//! Colours are checked before quantisation too: [`Pixel`] turns NaN into 0, so every render here
//! also traces each pixel's centre ray itself and asserts the colour is finite (and quantises to
//! the pixel `render_line` produced). Expected pixels come from a small `f64` reference
//! ([`Reference`]) that leaves out pixels within a margin of an edge or a shadow boundary.

use glam::Vec3;
use proptest::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use strahl_core::accel::octree::{brute_force_closest_hit, Hit, Octree, OctreeParams};
use strahl_core::geom::hit::RayHit;
use strahl_core::geom::solid::{Shape, SolidNode};
use strahl_core::geom::triangle::{hit_point, intersect, unit_normal, RayFrame};
use strahl_core::math::aabb::Aabb;
use strahl_core::math::float::{next_float_down, next_float_up};
use strahl_core::math::ray::{offset_ray_origin, Ray};
use strahl_core::math::transform::Transform;
use strahl_core::render::intersect::PrimitiveHit;
use strahl_core::render::intersect::QueryScratch;
use strahl_core::render::optics::reflect;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::camera::{Camera, CameraFrame, SeedCamera};
use strahl_core::scene::error::SceneError;
use strahl_core::scene::mesh::Rng;
use strahl_core::scene::triangle_shading::TriangleShadings;
use strahl_core::scene::{Light, RenderSettings, Scene, SceneDesc, Shader, TriangleDesc};
use strahl_core_tests::checked::*;
use strahl_core_tests::meshes::{boundary_grid, closed_sphere, positions, random_soup};
use strahl_host::cluster::local::render_local;
use strahl_host::cluster::prepared::PreparedScene;
use strahl_host::formats::load::{load_config_scene, Overrides};

// ---------------------------------------------------------------------------------------------
// f64 vectors (the workspace builds glam without its f64 types)
// ---------------------------------------------------------------------------------------------

/// A vector of three `f64`s, for reference computations.
#[derive(Clone, Copy, Debug, PartialEq)]
struct V64 {
    x: f64,
    y: f64,
    z: f64,
}

impl V64 {
    const ZERO: V64 = V64::new(0.0, 0.0, 0.0);

    const fn new(x: f64, y: f64, z: f64) -> V64 {
        V64 { x, y, z }
    }
    fn dot(self, o: V64) -> f64 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    fn cross(self, o: V64) -> V64 {
        V64::new(
            self.y * o.z - self.z * o.y,
            self.z * o.x - self.x * o.z,
            self.x * o.y - self.y * o.x,
        )
    }
    fn length(self) -> f64 {
        self.dot(self).sqrt()
    }
    fn normalize(self) -> V64 {
        self / self.length()
    }
    fn abs(self) -> V64 {
        V64::new(self.x.abs(), self.y.abs(), self.z.abs())
    }
    fn as_f32(self) -> Vec3 {
        Vec3::new(self.x as f32, self.y as f32, self.z as f32)
    }
}

impl std::ops::Add for V64 {
    type Output = V64;
    fn add(self, o: V64) -> V64 {
        V64::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}

impl std::ops::Sub for V64 {
    type Output = V64;
    fn sub(self, o: V64) -> V64 {
        V64::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}

impl std::ops::Neg for V64 {
    type Output = V64;
    fn neg(self) -> V64 {
        V64::new(-self.x, -self.y, -self.z)
    }
}

impl std::ops::Mul<f64> for V64 {
    type Output = V64;
    fn mul(self, k: f64) -> V64 {
        V64::new(self.x * k, self.y * k, self.z * k)
    }
}

impl std::ops::Div<f64> for V64 {
    type Output = V64;
    fn div(self, k: f64) -> V64 {
        V64::new(self.x / k, self.y / k, self.z / k)
    }
}

impl std::iter::Sum for V64 {
    fn sum<I: Iterator<Item = V64>>(iter: I) -> V64 {
        iter.fold(V64::ZERO, |a, b| a + b)
    }
}

/// `Vec3` to [`V64`], exactly.
trait ToF64 {
    fn to_f64(self) -> V64;
}

impl ToF64 for Vec3 {
    fn to_f64(self) -> V64 {
        V64::new(f64::from(self.x), f64::from(self.y), f64::from(self.z))
    }
}

// ---------------------------------------------------------------------------------------------
// Scene building
// ---------------------------------------------------------------------------------------------

/// The background of every render here: no surface is this blue.
const BACKGROUND: Vec3 = Vec3::new(0.0, 0.0, 1.0);

/// A shader showing only its ambient colour (lights change nothing).
fn flat(color: Vec3) -> Shader {
    Shader::phong(color, Vec3::ZERO, Vec3::ZERO, 1.0, 0.0)
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

/// A perfect mirror.
fn mirror() -> Shader {
    Shader::phong(Vec3::splat(0.1), Vec3::splat(0.2), Vec3::ZERO, 1.0, 1.0)
}

fn point_light(position: Vec3, casts_shadows: bool) -> Light {
    Light {
        position,
        color: Vec3::ONE,
        amount: 1.0,
        casts_shadows,
    }
}

/// The seed's camera at `position`, looking along +Y tilted by `angle_x_deg`. Untilted, every
/// primary ray direction is exactly `(u, zoom, v)`, `u` and `v` the pixel's image-plane
/// coordinates.
fn eye(position: Vec3, angle_x_deg: f32, zoom: f32) -> Camera {
    Camera::Seed(SeedCamera {
        position,
        angle_x_deg,
        angle_z_deg: 0.0,
        zoom,
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

/// Points and triangles for triangle positions with shader indices; bit-identical positions of
/// triangles with the same shader become one point, as in a mesh file (so objects of different
/// shaders do not share smooth normals).
fn mesh(tris: &[([Vec3; 3], u32)]) -> (Vec<Vec3>, Vec<TriangleDesc>) {
    let mut index: HashMap<([u32; 3], u32), u32> = HashMap::new();
    let mut points = Vec::new();
    let triangles = tris
        .iter()
        .map(|(t, shader)| {
            let ids = t.map(|p| {
                *index
                    .entry((p.to_array().map(f32::to_bits), *shader))
                    .or_insert_with(|| {
                        points.push(p);
                        (points.len() - 1) as u32
                    })
            });
            TriangleDesc::new(ids, *shader)
        })
        .collect();
    (points, triangles)
}

/// A scene of triangles (with shader indices), nothing else.
fn triangle_desc(
    tris: &[([Vec3; 3], u32)],
    shaders: Vec<Shader>,
    lights: Vec<Light>,
    camera: Camera,
    settings: RenderSettings,
) -> SceneDesc {
    let (points, triangles) = mesh(tris);
    SceneDesc {
        points,
        triangles,
        shaders,
        lights,
        camera,
        settings,
        ..SceneDesc::default()
    }
}

fn with_shader(tris: &[[Vec3; 3]], shader: u32) -> Vec<([Vec3; 3], u32)> {
    tris.iter().map(|&t| (t, shader)).collect()
}

fn build(desc: &SceneDesc) -> Scene {
    Scene::build(desc, &OctreeParams::default()).expect("valid scene")
}

/// A sphere solid of `radius` around `centre`.
fn sphere_node(centre: Vec3, radius: f32, shader: u32) -> SolidNode {
    SolidNode::Leaf {
        shape: Shape::Sphere { radius },
        transform: Transform::translate(centre),
        shader,
    }
}

/// The axis-aligned box `lo..hi` as outward-facing triangles (counter-clockwise seen from
/// outside), each face split into a grid of `cells[axis]` cells along each axis. Grid
/// coordinates are computed in `f64`, so they are exact where the values are representable.
fn box_triangles(lo: Vec3, hi: Vec3, cells: [u32; 3]) -> Vec<[Vec3; 3]> {
    let coord = |i: u32, axis: usize| -> f32 {
        let (l, h) = (f64::from(lo[axis]), f64::from(hi[axis]));
        (l + (h - l) * f64::from(i) / f64::from(cells[axis])) as f32
    };
    let mut out = Vec::new();
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        for side in [false, true] {
            for j in 0..cells[c] {
                for i in 0..cells[b] {
                    let corner = |di: u32, dj: u32| {
                        let mut p = Vec3::ZERO;
                        p[a] = if side { hi[a] } else { lo[a] };
                        p[b] = coord(i + di, b);
                        p[c] = coord(j + dj, c);
                        p
                    };
                    // e_b × e_c = e_a: this order faces +a.
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                    let q = if side { q } else { [q[0], q[3], q[2], q[1]] };
                    out.push([q[0], q[1], q[2]]);
                    out.push([q[0], q[2], q[3]]);
                }
            }
        }
    }
    out
}

/// The same triangles with the opposite winding.
fn flipped(tris: &[[Vec3; 3]]) -> Vec<[Vec3; 3]> {
    tris.iter().map(|t| [t[0], t[2], t[1]]).collect()
}

/// A quad (two triangles) of corners `a b c d` in order.
fn quad(c: [Vec3; 4]) -> [[Vec3; 3]; 2] {
    [[c[0], c[1], c[2]], [c[0], c[2], c[3]]]
}

// ---------------------------------------------------------------------------------------------
// Rendering
// ---------------------------------------------------------------------------------------------

fn background_pixel() -> Pixel {
    Pixel::from_color(BACKGROUND)
}

// ---------------------------------------------------------------------------------------------
// An f64 reference: flat triangles and spheres, diffuse shaders, one point light
// ---------------------------------------------------------------------------------------------

/// Barycentric margin and relative tangency margin inside which the reference is unsure.
const MARGIN: f64 = 1e-3;

/// Expected pixels from exact-ish `f64` geometry. It knows flat triangles and spheres, shaders
/// `ambient + diffuse · max(0, N·L)` (grey, no highlights) and one shadow-casting point light.
struct Reference {
    tris: Vec<([V64; 3], usize)>,
    spheres: Vec<(V64, f64, usize)>,
    /// (ambient, diffuse) of each shader.
    shaders: Vec<(f64, f64)>,
    light: V64,
    /// Distance in world units inside which the reference is unsure too: the rounding of
    /// positions at the scene's magnitude.
    abs_margin: f64,
    /// Whether a surface through the light itself (a crossing at `t ≈ 1` of a shadow ray)
    /// leaves the reference unsure; otherwise it does not block the light.
    unsure_at_light: bool,
}

/// What a pixel should show.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Expect {
    Background,
    Grey(f64),
}

/// What a reference ray meets.
#[derive(Clone, Copy, Debug)]
enum Seen {
    /// Nothing, clearly.
    Miss,
    /// Too close to an edge, a silhouette or another surface to say.
    Unsure,
    /// A surface, clearly: where, its unit normal facing the ray, and its shader.
    Surface(V64, V64, usize),
}

/// A crossing of a reference ray: `t`, whether it is near a boundary, the unit normal, shader.
type Crossing = (f64, bool, V64, usize);

impl Reference {
    /// The reference of `desc`'s triangles and sphere solids (translated spheres only), with
    /// the first light. Shaders must be grey.
    fn of(desc: &SceneDesc) -> Reference {
        let tris = desc
            .triangles
            .iter()
            .map(|t| {
                (
                    t.points.map(|i| desc.points[i as usize].to_f64()),
                    t.shader as usize,
                )
            })
            .collect();
        let spheres = desc
            .objects
            .iter()
            .map(|&o| match desc.solids[o as usize] {
                SolidNode::Leaf {
                    shape: Shape::Sphere { radius },
                    transform,
                    shader,
                } => {
                    assert_eq!(transform.matrix, glam::Mat3::IDENTITY);
                    (
                        transform.translation.to_f64(),
                        f64::from(radius),
                        shader as usize,
                    )
                }
                ref other => panic!("the reference knows spheres only: {other:?}"),
            })
            .collect();
        let mut magnitude = desc.lights[0].position.abs().max_element();
        for p in &desc.points {
            magnitude = magnitude.max(p.abs().max_element());
        }
        if let Camera::Seed(c) = desc.camera {
            magnitude = magnitude.max(c.position.abs().max_element());
        }
        Reference {
            abs_margin: f64::from(magnitude) * 1e-6,
            unsure_at_light: false,
            tris,
            spheres,
            shaders: desc
                .shaders
                .iter()
                .map(|s| (f64::from(s.ambient.x), f64::from(s.diffuse.x)))
                .collect(),
            light: desc.lights[0].position.to_f64(),
        }
    }

    /// Every crossing of `o + t·d` with any surface (any `t`), near boundaries flagged.
    fn crossings(&self, o: V64, d: V64) -> Vec<Crossing> {
        let mut out = Vec::new();
        for (p, shader) in &self.tris {
            let e1 = p[1] - p[0];
            let e2 = p[2] - p[0];
            let pv = d.cross(e2);
            let det = e1.dot(pv);
            let n = e1.cross(e2).normalize();
            // Parallel to the plane, within the reference's own resolution.
            if det.abs() <= 1e-12 * e1.length() * e2.length() * d.length() {
                continue;
            }
            let s = o - p[0];
            let u = s.dot(pv) / det;
            let q = s.cross(e1);
            let v = d.dot(q) / det;
            let t = e2.dot(q) / det;
            let m = u.min(v).min(1.0 - u - v);
            // Distances to the edges: barycentric times the altitude onto that edge.
            let area2 = e1.cross(e2).length();
            let dist = (u * area2 / e2.length())
                .min(v * area2 / e1.length())
                .min((1.0 - u - v) * area2 / (p[2] - p[1]).length());
            if m > -MARGIN || dist > -self.abs_margin {
                let facing = if n.dot(d) < 0.0 { n } else { -n };
                let near = m < MARGIN || dist < self.abs_margin;
                out.push((t, near, facing, *shader));
            }
        }
        for &(c, r, shader) in &self.spheres {
            let oc = o - c;
            let a = d.dot(d);
            let b = oc.dot(d);
            let dist2 = (oc.dot(oc) - b * b / a).max(0.0);
            let dist = dist2.sqrt();
            let slack = (r * MARGIN).max(self.abs_margin);
            if dist > r + slack {
                continue;
            }
            let near = dist > r - slack;
            let half = ((r * r - dist2).max(0.0) / a).sqrt();
            let mid = -b / a;
            for t in [mid - half, mid + half] {
                let n = (o + d * t - c).normalize();
                let facing = if n.dot(d) < 0.0 { n } else { -n };
                out.push((t, near, facing, shader));
            }
        }
        out
    }

    /// What the ray from `o` along `d` meets first (`t > 0`).
    fn first(&self, o: V64, d: V64) -> Seen {
        let mut c: Vec<Crossing> = self
            .crossings(o, d)
            .into_iter()
            .filter(|x| x.0 > 1e-9)
            .collect();
        c.sort_by(|a, b| a.0.total_cmp(&b.0));
        let Some(&(t, near, n, shader)) = c.first() else {
            return Seen::Miss;
        };
        let close_second = c
            .get(1)
            .is_some_and(|x| x.0 - t <= MARGIN * t || (x.0 - t) * d.length() <= self.abs_margin);
        if near || close_second {
            return Seen::Unsure;
        }
        Seen::Surface(o + d * t, n, shader)
    }

    /// Whether the light is visible from surface point `p`: `Some(true)` clearly lit,
    /// `Some(false)` clearly shadowed, `None` unsure. Crossings at the point itself and at the
    /// light itself (`t` within 1e-9 of 0 or 1) do not count.
    fn light_visible(&self, p: V64) -> Option<bool> {
        let d = self.light - p;
        let mut unsure = false;
        let slack = 1e-4f64.max(self.abs_margin / d.length());
        for (t, near, _, _) in self.crossings(p, d) {
            if self.unsure_at_light && (t - 1.0).abs() <= slack {
                unsure = true;
                continue;
            }
            if !(1e-9..=1.0 - 1e-9).contains(&t) {
                continue;
            }
            if near || t < slack || t > 1.0 - slack {
                unsure = true;
            } else {
                return Some(false);
            }
        }
        (!unsure).then_some(true)
    }

    /// The expected grey of the centre ray of a pixel, or `None` if unsure.
    fn expected(&self, ray: &Ray) -> Option<Expect> {
        let (o, d) = (ray.origin.to_f64(), ray.dir.to_f64());
        match self.first(o, d) {
            Seen::Miss => Some(Expect::Background),
            Seen::Unsure => None,
            Seen::Surface(p, n, shader) => {
                let (ambient, diffuse) = self.shaders[shader];
                let l = (self.light - p).normalize();
                let n_dot_l = n.dot(l);
                if n_dot_l <= 1e-3 {
                    // Unlit, or lit so little that shadowing is within the tolerance.
                    return Some(Expect::Grey(ambient + diffuse * n_dot_l.max(0.0)));
                }
                Some(Expect::Grey(match self.light_visible(p)? {
                    true => ambient + diffuse * n_dot_l,
                    false => ambient,
                }))
            }
        }
    }
}

/// A 16-bit channel for a grey value.
fn q16(v: f64) -> i32 {
    i32::from(Pixel::from_color(Vec3::splat(v as f32)).0[0])
}

/// What [`check_against_reference`] found.
#[derive(Clone, Copy, Debug, Default)]
struct Agreement {
    /// Pixels the reference is sure about (all were checked).
    checked: usize,
    /// Of those, pixels lit by the light (brighter than their ambient colour).
    lit: usize,
    /// The largest difference seen, in 16-bit steps.
    worst: i32,
}

/// Compares every pixel the reference is sure about with it: all three channels within `tol`
/// 16-bit steps.
fn check_against_reference(
    name: &str,
    scene: &Scene,
    img: &Rendered,
    r: &Reference,
    tol: i32,
) -> Agreement {
    let (w, h) = (
        scene.settings.width as usize,
        scene.settings.height as usize,
    );
    let mut found = Agreement::default();
    for y in 0..h {
        for x in 0..w {
            let ray = pixel_ray(scene, x, y);
            let Some(expected) = r.expected(&ray) else {
                continue;
            };
            found.checked += 1;
            let got = img.at(x, y);
            let want = match expected {
                Expect::Background => background_pixel().0.map(i32::from),
                Expect::Grey(v) => [q16(v); 3],
            };
            if let (Seen::Surface(_, _, shader), Expect::Grey(v)) =
                (r.first(ray.origin.to_f64(), ray.dir.to_f64()), expected)
            {
                if v > r.shaders[shader].0 + 1e-3 {
                    found.lit += 1;
                }
            }
            for (ch, &wanted) in want.iter().enumerate() {
                let g = i32::from(got.0[ch]);
                found.worst = found.worst.max((g - wanted).abs());
                assert!(
                    (g - wanted).abs() <= tol,
                    "{name}: pixel ({x}, {y}) channel {ch} is {g}, expected {} ({expected:?}): \
                     {} by more than the tolerance of {tol}/65535; colour {:?}",
                    wanted,
                    if g < wanted {
                        "darker (shadow acne?)"
                    } else {
                        "brighter (a light leak?)"
                    },
                    img.colors[y * w + x]
                );
            }
        }
    }
    found
}

// ---------------------------------------------------------------------------------------------
// Closed meshes seen through their shared edges and vertices
// ---------------------------------------------------------------------------------------------

/// How a ray from outside meets a convex closed mesh with outward normals, in `f64`: through
/// its inside (with the parameter where it enters), touching its boundary only, or not at all.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Cover {
    Inside(f64),
    Boundary,
    Outside,
}

fn cover(outward: &[[Vec3; 3]], ray: &Ray) -> Cover {
    let (o, d) = (ray.origin.to_f64(), ray.dir.to_f64());
    let (mut t_in, mut t_out) = (f64::NEG_INFINITY, f64::INFINITY);
    for t in outward {
        let p = t.map(|v| v.to_f64());
        let n = (p[1] - p[0]).cross(p[2] - p[0]);
        let (num, den) = (n.dot(p[0] - o), n.dot(d));
        if den < 0.0 {
            t_in = t_in.max(num / den);
        } else if den > 0.0 {
            t_out = t_out.min(num / den);
        } else if num < 0.0 {
            return Cover::Outside;
        }
    }
    let tol = 1e-9 * t_out.abs().max(1.0);
    if t_in <= 0.0 || t_out < t_in - tol {
        Cover::Outside
    } else if t_out - t_in > tol {
        Cover::Inside(t_in)
    } else {
        Cover::Boundary
    }
}

/// True if a ray from the origin along `d` passes exactly through an edge or vertex of `tris`.
/// Exact in `f64` for the small dyadic coordinates used here.
fn through_edge(tris: &[[Vec3; 3]], d: Vec3) -> bool {
    let d = d.to_f64();
    tris.iter().any(|t| {
        (0..3).any(|k| {
            let (a, b) = (t[k].to_f64(), t[(k + 1) % 3].to_f64());
            let ab = a.cross(b);
            d.dot(ab) == 0.0 && a.cross(d).dot(ab) >= 0.0 && d.cross(b).dot(ab) >= 0.0
                || a.cross(d) == V64::ZERO && a.dot(d) > 0.0
        })
    })
}

/// Flips every triangle whose normal points towards the centroid of all vertices.
fn orient_outward(tris: Vec<[Vec3; 3]>) -> Vec<[Vec3; 3]> {
    let all: Vec<V64> = tris.iter().flatten().map(|p| p.to_f64()).collect();
    let c = all.iter().copied().sum::<V64>() / all.len() as f64;
    tris.into_iter()
        .map(|t| {
            let p = t.map(|v| v.to_f64());
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            if n.dot((p[0] + p[1] + p[2]) / 3.0 - c) < 0.0 {
                [t[0], t[2], t[1]]
            } else {
                t
            }
        })
        .collect()
}

#[test]
fn closed_mesh_has_no_leaks_through_shared_edges_and_vertices() {
    // The seed camera at the origin looking along +Y with zoom 1 and a 32 × 32 image: the centre
    // ray of pixel (x, y) has the exact direction ((2x − 31)/32, 1, (31 − 2y)/32), so it passes
    // exactly through the point (2x − 31, 32, 31 − 2y): pixel centres land on the odd integer
    // coordinates of the plane y = 32 (and on multiples of them further away).
    const W: u32 = 32;
    let camera = eye(Vec3::ZERO, 0.0, 1.0);
    let frame = CameraFrame::new(&camera, W, W);
    let dir = |x: u32, y: u32| frame.ray(x as f32 + 0.5, y as f32 + 0.5).dir;
    assert_eq!(dir(0, 0) * 32.0, Vec3::new(-31.0, 32.0, 31.0));
    assert_eq!(dir(16, 16) * 32.0, Vec3::new(1.0, 32.0, -1.0));

    // An octahedron whose six vertices lie exactly on pixel centre rays: the front apex in the
    // middle of the silhouette, four ring vertices on its outline, the back apex behind.
    let front = dir(16, 16) * 32.0;
    let back = dir(16, 16) * 96.0;
    let ring = [dir(24, 16), dir(16, 8), dir(8, 16), dir(16, 24)].map(|d| d * 64.0);
    let mut octahedron = Vec::new();
    for k in 0..4 {
        octahedron.push([front, ring[k], ring[(k + 1) % 4]]);
        octahedron.push([back, ring[(k + 1) % 4], ring[k]]);
    }
    let octahedron = orient_outward(octahedron);

    let v = Vec3::new;
    let objects: Vec<(&str, Vec<[Vec3; 3]>, usize)> = vec![
        // (name, outward triangles, least interior pixels exactly on an edge or vertex)
        (
            "12-triangle cube (pixel centres on the front face's diagonal)",
            box_triangles(v(-9.0, 32.0, -9.0), v(9.0, 50.0, 9.0), [1, 1, 1]),
            7,
        ),
        (
            "gridded cube (every pixel centre on a vertex of six triangles)",
            box_triangles(v(-9.0, 32.0, -9.0), v(9.0, 50.0, 9.0), [9, 9, 9]),
            64,
        ),
        (
            "gridded cube (every pixel centre on a cell's diagonal)",
            box_triangles(v(-10.0, 32.0, -10.0), v(10.0, 52.0, 10.0), [10, 10, 10]),
            100,
        ),
        (
            "box seen from the side (front and side faces share an inner edge)",
            box_triangles(v(3.0, 32.0, -9.0), v(15.0, 96.0, 9.0), [6, 4, 9]),
            30,
        ),
        ("octahedron on pixel rays", octahedron, 20),
    ];
    let red = Vec3::new(1.0, 0.0, 0.0);
    for (name, outward, least_on_edges) in &objects {
        // Expected coverage of every pixel, from the outward mesh in f64.
        let covers: Vec<(Cover, bool)> = (0..W * W)
            .map(|i| {
                let d = dir(i % W, i / W);
                (
                    cover(outward, &Ray::new(Vec3::ZERO, d)),
                    through_edge(outward, d),
                )
            })
            .collect();
        let inside = covers
            .iter()
            .filter(|c| matches!(c.0, Cover::Inside(_)))
            .count();
        let on_edges = covers
            .iter()
            .filter(|c| matches!(c.0, Cover::Inside(_)) && c.1)
            .count();
        assert!(
            on_edges >= *least_on_edges,
            "{name}: {on_edges} of {inside} inside pixels pass exactly through an edge or vertex"
        );
        for (winding, tris) in [("outward", outward.clone()), ("inward", flipped(outward))] {
            for params in [
                OctreeParams::default(),
                OctreeParams {
                    max_depth: 20,
                    max_leaf_triangles: 1,
                },
            ] {
                let desc = triangle_desc(
                    &with_shader(&tris, 0),
                    vec![flat(red)],
                    vec![point_light(Vec3::new(0.0, -5.0, 0.0), true)],
                    camera,
                    settings(W, W),
                );
                let scene = Scene::build(&desc, &params).expect("valid scene");
                let img = render(&scene);
                let mut scratch = QueryScratch::default();
                for (i, &(c, on_edge)) in covers.iter().enumerate() {
                    let (x, y) = (i % W as usize, i / W as usize);
                    let ray = pixel_ray(&scene, x, y);
                    let hit = scene.closest_hit(&ray, f32::INFINITY, &mut scratch);
                    let any = scene.any_hit(&ray, f32::INFINITY, &mut scratch);
                    let at = format!(
                        "{name}, {winding} winding, {params:?}: pixel ({x}, {y}){}",
                        if on_edge {
                            " (exactly through an edge or vertex)"
                        } else {
                            ""
                        }
                    );
                    match c {
                        Cover::Inside(t_in) => {
                            let h = hit.unwrap_or_else(|| panic!("{at}: leak, no hit"));
                            // A leak through the front could still hit the back: check t.
                            let t = f64::from(h.t());
                            assert!(
                                (t - t_in).abs() <= 1e-6 * t_in,
                                "{at}: hit at t = {t}, the front surface is at {t_in}"
                            );
                            assert!(any, "{at}: any-hit leak");
                            assert_eq!(img.at(x, y), Pixel::from_color(red), "{at}");
                        }
                        Cover::Outside => {
                            assert!(hit.is_none() && !any, "{at}: hit outside the silhouette");
                            assert_eq!(img.at(x, y), background_pixel(), "{at}");
                        }
                        Cover::Boundary => {
                            // The ray only touches the outline (an edge or vertex on the
                            // silhouette): edges count as inside, so it hits too.
                            assert!(hit.is_some() && any, "{at}: the outline leaks");
                            assert_eq!(img.at(x, y), Pixel::from_color(red), "{at}");
                        }
                    }
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Rays parallel and nearly parallel to a surface
// ---------------------------------------------------------------------------------------------

#[test]
fn grazing_rays_parallel_to_a_triangle() {
    // A big triangle and a quad in the plane z = 0, and the same plane as a solid half-space.
    let v = Vec3::new;
    let tri = [
        v(-100.0, -100.0, 0.0),
        v(100.0, -100.0, 0.0),
        v(0.0, 100.0, 0.0),
    ];
    let sq = quad([
        v(-50.0, -50.0, 0.0),
        v(50.0, -50.0, 0.0),
        v(50.0, 50.0, 0.0),
        v(-50.0, 50.0, 0.0),
    ]);
    let tris = vec![tri, sq[0], sq[1]];
    let tree = Octree::build(&tris, &OctreeParams::default());
    let desc = SceneDesc {
        solids: vec![SolidNode::Leaf {
            shape: Shape::Plane {
                normal: Vec3::Z,
                d: 0.0,
            },
            transform: Transform::IDENTITY,
            shader: 0,
        }],
        objects: vec![0],
        ..triangle_desc(
            &with_shader(&tris, 0),
            vec![flat(Vec3::X)],
            vec![point_light(v(0.0, 0.0, 10.0), true)],
            eye(v(0.0, -200.0, 0.0), 0.0, 1.0),
            settings(8, 8),
        )
    };
    let scene = build(&desc);
    let mut scratch = QueryScratch::default();
    let mut rng = Rng::new(7);
    let tiny = f32::from_bits(1); // the smallest subnormal
    let heights = [
        0.0,
        -0.0,
        tiny,
        -tiny,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        1e-30,
        -1e-30,
        1e-7,
        -1e-3,
        1.0,
    ];
    let mut rays = 0;
    for &z in &heights {
        for k in 0..200 {
            let o = v(rng.range(-150.0, 150.0), rng.range(-150.0, 150.0), z);
            // A random point, a vertex and an edge's midpoint (in the plane when z is ±0).
            let origins = [
                o,
                v(tri[k % 3].x, tri[k % 3].y, z),
                v((sq[0][0].x + sq[0][2].x) * 0.5, sq[0][1].y, z),
            ];
            for o in origins {
                let target = tris[k % 3][(k / 3) % 3];
                let mut dirs = vec![
                    rng.direction(),
                    target - o,
                    tri[1] - tri[0],
                    sq[0][2] - sq[0][0],
                    Vec3::X,
                    -Vec3::Y,
                ];
                for d in &mut dirs {
                    // Parallel to the plane: z exactly +0 or −0.
                    d.z = if k % 2 == 0 { 0.0 } else { -0.0 };
                }
                for d in dirs {
                    if d.x == 0.0 && d.y == 0.0 {
                        continue;
                    }
                    let ray = Ray::new(o, d);
                    let at = format!("parallel ray {ray:?}");
                    let frame = RayFrame::new(&ray);
                    for t in &tris {
                        assert_eq!(intersect(&frame, t, f32::INFINITY), None, "{at} hit {t:?}");
                    }
                    assert_eq!(
                        brute_force_closest_hit(&tris, &ray, f32::INFINITY),
                        None,
                        "{at}"
                    );
                    assert_eq!(tree.closest_hit(&tris, &ray, f32::INFINITY), None, "{at}");
                    assert!(!tree.any_hit(&tris, &ray, f32::INFINITY), "{at}");
                    assert_eq!(
                        scene.closest_hit(&ray, f32::INFINITY, &mut scratch),
                        None,
                        "{at}"
                    );
                    assert!(!scene.any_hit(&ray, f32::INFINITY, &mut scratch), "{at}");
                    rays += 1;
                }
            }
        }
    }
    assert!(rays > 10_000);

    // A camera on the floor plane, and one above it: with an odd height the middle line's rays
    // are exactly parallel to the floor (direction z = 0). (At z = 1 every floor hit is at
    // t ≥ 16.5; for an eye 1e-3 above it see `camera_just_above_a_large_floor_sees_it`.)
    for eye_z in [0.0f32, 1.0] {
        let scene = build(&low_eye_over_a_large_floor(eye_z));
        assert_eq!(pixel_ray(&scene, 5, 16).dir.z, 0.0);
        let img = render(&scene);
        for y in 0..33 {
            for x in 0..33 {
                // On the floor nothing is seen (rays leave the surface they start on); above it,
                // the lines below the middle see the floor, the middle and above do not.
                let want = if eye_z > 0.0 && y > 16 {
                    Pixel::from_color(Vec3::X)
                } else {
                    background_pixel()
                };
                assert_eq!(img.at(x, y), want, "eye at z = {eye_z}: pixel ({x}, {y})");
            }
        }
    }
}

/// A floor ±1e4 wide and a camera 1e-3 above it, looking along it (odd height: the middle line
/// is parallel to the floor).
fn low_eye_over_a_large_floor(eye_z: f32) -> SceneDesc {
    let v = Vec3::new;
    let floor = quad([
        v(-1e4, -1e4, 0.0),
        v(1e4, -1e4, 0.0),
        v(1e4, 1e4, 0.0),
        v(-1e4, 1e4, 0.0),
    ]);
    triangle_desc(
        &with_shader(&floor, 0),
        vec![flat(Vec3::X)],
        vec![point_light(v(0.0, 0.0, 10.0), true)],
        eye(v(0.0, 0.0, eye_z), 0.0, 1.0),
        settings(33, 33),
    )
}

#[test]
fn camera_just_above_a_large_floor_sees_it() {
    // Every pixel below the middle line sees the floor. The hits are 0.001 to 0.0165 away, and
    // the f32 bound on their `t` grows with the farthest vertex's distance along the ray (1e4)
    // to about 0.3: `triangle::intersect` must decide them in f64 rather than reject them.
    let scene = build(&low_eye_over_a_large_floor(1e-3));
    let img = render(&scene);
    for y in 17..33 {
        for x in 0..33 {
            assert_eq!(img.at(x, y), Pixel::from_color(Vec3::X), "pixel ({x}, {y})");
        }
    }
}

/// Checks a hit of a ray nearly parallel to the plane of `tri` (unit normal `n`, in f64);
/// returns its `t`.
fn check_near_parallel(tri: &[Vec3; 3], ray: &Ray, hit: Option<Hit>, at: &str) -> f32 {
    let hit = hit.unwrap_or_else(|| panic!("{at}: no hit"));
    let p = tri.map(|v| v.to_f64());
    let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
    let (o, d) = (ray.origin.to_f64(), ray.dir.to_f64());
    let t_exact = n.dot(p[0] - o) / n.dot(d);
    let t = hit.tri.t;
    assert!(
        t.is_finite() && hit.tri.t_error.is_finite(),
        "{at}: t = {t}"
    );
    assert!(
        (f64::from(t) - t_exact).abs() <= f64::from(hit.tri.t_error),
        "{at}: t = {t} but the exact t is {t_exact}: off by {:e}, more than its error bound {:e}",
        (f64::from(t) - t_exact).abs(),
        hit.tri.t_error
    );
    let (point, err) = hit_point(tri, hit.tri.b);
    assert!(point.is_finite() && err.is_finite(), "{at}");
    let dist = n.dot(point.to_f64() - p[0]);
    let bound = n.abs().dot(err.to_f64());
    assert!(
        dist.abs() <= bound,
        "{at}: hit point {point:?} is {dist:e} off the plane, error bound {bound:e}"
    );
    t
}

/// Rays from 1 unit above a plane at angles from `10^-first` down to `10^-last` radians to
/// it (50 per decade), each against a quad of a power-of-two half-size 1.5 to 3 times its hit
/// distance (1 / angle). Two planes: z = 0, and the tilted z = x/4 + y/2 (power-of-two corners
/// lie exactly on it). Every ray must hit, `t` must grow as the angle shrinks, and `t` and the
/// hit point must be right within their error bounds. Returns the rays shot.
fn near_parallel_sweep(first: i32, last: i32) -> usize {
    let v = Vec3::new;
    let mut rng = Rng::new(11);
    let mut rays = 0;
    for tilted in [false, true] {
        let name = if tilted {
            "tilted plane"
        } else {
            "level plane"
        };
        let corner = |x: f32, y: f32| {
            if tilted {
                v(x, y, x / 4.0 + y / 2.0)
            } else {
                v(x, y, 0.0)
            }
        };
        let quad_of = |half: f32| {
            quad([
                corner(-half, -half),
                corner(half, -half),
                corner(half, half),
                corner(-half, half),
            ])
        };
        let mut quads: HashMap<i32, (Vec<[Vec3; 3]>, Octree)> = HashMap::new();
        let p = quad_of(1.0)[0].map(|v| v.to_f64());
        let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        // An orthonormal frame of the plane.
        let e1 = (p[1] - p[0]).normalize();
        let e2 = n.cross(e1);
        for start in 0..4 {
            // A point of the plane near its centre, lifted 1 unit off it.
            let base =
                e1 * f64::from(rng.range(-10.0, 10.0)) + e2 * f64::from(rng.range(-10.0, 10.0));
            let foot = base - n * n.dot(base - p[0]);
            let o = (foot + n).as_f32();
            let h = n.dot(o.to_f64() - p[0]);
            assert!(
                (h - 1.0).abs() < 1e-3,
                "{name}: origin {o:?} is {h} off the plane"
            );
            for azimuth in 0..8 {
                // Along the edges, the diagonal and in between.
                let phi =
                    f64::from(azimuth) * std::f64::consts::FRAC_PI_4 + 0.05 * f64::from(start);
                let along = e1 * phi.cos() + e2 * phi.sin();
                let (mut last_t, mut last_sin) = (0.0f32, f64::INFINITY);
                for k in 0..=(50 * (last - first)) {
                    let theta = 10f64.powf(-f64::from(first) - f64::from(k) / 50.0);
                    let exp = (1.5 / theta).log2().ceil() as i32;
                    let (tris, tree) = quads.entry(exp).or_insert_with(|| {
                        let tris = quad_of(2f32.powi(exp)).to_vec();
                        let tree = Octree::build(&tris, &OctreeParams::default());
                        (tris, tree)
                    });
                    // Rounding the direction to f32 moves its angle by up to about 6e-8
                    // radians: aim a little higher until the f32 direction's angle with the
                    // plane is at least `theta`.
                    let mut aim = theta;
                    let (d, sin_actual) = loop {
                        let d = (along * aim.cos() - n * aim.sin()).as_f32();
                        let dd = d.to_f64();
                        let sin_actual = -n.dot(dd) / dd.length();
                        if sin_actual >= theta.sin() {
                            break (d, sin_actual);
                        }
                        aim += theta * 1e-4 + 1e-10;
                    };
                    let ray = Ray::new(o, d);
                    let at = format!("{name}, quad ±2^{exp}, angle {sin_actual:e}: {ray:?}");
                    let hit = tree.closest_hit(tris, &ray, f32::INFINITY);
                    let brute = brute_force_closest_hit(tris, &ray, f32::INFINITY);
                    assert_eq!(hit, brute, "{at}: octree and brute force differ");
                    let tri = &tris[hit.map_or(0, |h| h.triangle as usize)];
                    let t = check_near_parallel(tri, &ray, hit, &at);
                    // Continuously: t grows as the angle shrinks (within its error bound). Near
                    // 1e-7 the f32 directions are so coarse that two aims may share an angle.
                    let bound = hit.map_or(0.0, |h| h.tri.t_error);
                    if sin_actual <= last_sin {
                        assert!(t >= last_t - bound, "{at}: t = {t} after {last_t}");
                    }
                    (last_t, last_sin) = (t, sin_actual);
                    rays += 1;
                }
            }
        }
    }
    rays
}

#[test]
fn near_parallel_rays_hit_continuously() {
    // 1e-3 to 1e-5 radians; below that see the test after this one.
    let rays = near_parallel_sweep(3, 5);
    assert_eq!(rays, 2 * 4 * 8 * 101);
}

#[test]
fn near_parallel_rays_below_ten_micro_radians_hit() {
    // 1e-5 to 1e-7 radians: the hits lie 1e5 to 1e7 away on quads up to ±2^24, where the f32
    // error bound on `t` exceeds `t`, so `triangle::intersect` decides these hits in f64.
    let rays = near_parallel_sweep(5, 7);
    assert_eq!(rays, 2 * 4 * 8 * 101);
}

// ---------------------------------------------------------------------------------------------
// Degenerate triangles
// ---------------------------------------------------------------------------------------------

/// An `n × n` grid of quads from `origin` along `u` and `v`, as triangles.
fn grid(origin: Vec3, u: Vec3, v: Vec3, n: u32) -> Vec<[Vec3; 3]> {
    let mut m = strahl_core::scene::mesh::MeshBuilder::default();
    m.grid(origin, u, v, n, 0);
    positions(&m)
}

fn write_file(path: &Path, text: &str) {
    std::fs::write(path, text).expect("write a test file");
}

#[test]
fn degenerate_triangles_never_hit_and_are_reported() {
    let v = Vec3::new;
    // A lit floor and a wall facing the camera.
    let floor = grid(v(-4.0, -2.0, 0.0), v(8.0, 0.0, 0.0), v(0.0, 8.0, 0.0), 4);
    let wall = flipped(&grid(
        v(-4.0, 6.0, 0.0),
        v(8.0, 0.0, 0.0),
        v(0.0, 0.0, 4.0),
        4,
    ));
    let good: Vec<[Vec3; 3]> = floor.iter().chain(&wall).copied().collect();

    // Degenerate triangles, all in view in front of the wall; some share the floor's and the
    // wall's points (so they touch the smooth normals' sums if they are not left out).
    let (a, b) = (v(-1.0, 2.0, 1.0), v(1.0, 2.0, 2.0));
    let rounded = (1.0f64 + 1e-9) as f32;
    assert_eq!(rounded, 1.0, "equal after rounding to f32");
    let big = (1e8f64 + 3.0) as f32;
    assert_eq!(big, 1e8);
    let degenerate: Vec<(&str, [Vec3; 3])> = vec![
        ("one point three times", [a, a, a]),
        ("repeated first point", [a, a, b]),
        ("repeated last point", [a, b, b]),
        ("repeated outer points", [b, a, b]),
        ("collinear", [a, b, a + (b - a) * 2.0]),
        (
            "collinear along x",
            [v(-2.0, 1.0, 1.0), v(0.0, 1.0, 1.0), v(2.0, 1.0, 1.0)],
        ),
        (
            "equal after rounding",
            [v(1.0, 3.0, 1.5), v(rounded, 3.0, 1.5), v(2.0, 3.0, 0.5)],
        ),
        (
            "equal after rounding, far away",
            [v(1e8, 2.0, 1.0), v(big, 2.0, 1.0), v(1e8, 2.0, 5.0)],
        ),
        (
            "area underflows",
            [v(0.0, 0.0, 0.0), v(1e-20, 0.0, 0.0), v(0.0, 0.0, 1e-20)],
        ),
        (
            "along a floor edge, sharing its points",
            [floor[0][0], floor[0][1], floor[2][1]],
        ),
        ("on wall points", [wall[5][0], wall[5][1], wall[5][1]]),
    ];
    assert_eq!(degenerate[4].1[2], v(3.0, 2.0, 3.0));
    for (name, t) in &degenerate {
        assert_eq!(unit_normal(t), None, "{name} must count as degenerate");
    }

    let settings = RenderSettings {
        shadows: true,
        ..settings(48, 36)
    };
    let camera = eye(v(0.0, -6.0, 2.0), -10.0, 1.0);
    let scene_of = |tris: Vec<([Vec3; 3], u32)>| {
        triangle_desc(
            &tris,
            vec![matte(0.1, 0.8), matte(0.2, 0.7)],
            vec![point_light(v(2.0, -3.0, 5.0), true)],
            camera,
            settings,
        )
    };
    let without = scene_of(
        good.iter()
            .enumerate()
            .map(|(i, &t)| (t, (i >= floor.len()) as u32))
            .collect(),
    );
    // The same good triangles in the same order, with a degenerate one before every other.
    let mut mixed = Vec::new();
    let mut rest = degenerate.iter();
    for (i, &t) in good.iter().enumerate() {
        if i % 2 == 0 {
            if let Some((_, d)) = rest.next() {
                mixed.push((*d, 1));
            }
        }
        mixed.push((t, (i >= floor.len()) as u32));
    }
    mixed.extend(rest.map(|(_, d)| (*d, 0)));
    let with = scene_of(mixed);
    let scene_without = build(&without);
    let scene_with = build(&with);
    assert_eq!(scene_without.degenerate_triangles, 0);
    assert_eq!(scene_with.degenerate_triangles as usize, degenerate.len());
    assert_eq!(
        scene_with.octree.stats().filed_triangles as usize,
        good.len()
    );
    assert_eq!(scene_with.bounds, scene_without.bounds);
    // Degenerate triangles are not flat, so the corner normals are kept and checked.
    assert_eq!(scene_with.triangle_normals.len(), with.triangles.len());
    for (i, n) in scene_with.triangle_normals.iter().enumerate() {
        assert!(
            n.iter().all(|c| c.is_finite()),
            "triangle {i}: normals {n:?} are not finite"
        );
    }

    // Never hit: rays at their points and centroids, from the camera and from around them.
    let mut rng = Rng::new(17);
    for (name, t) in &degenerate {
        let centroid = (t[0] + t[1] + t[2]) / 3.0;
        for target in [t[0], t[1], t[2], centroid, (t[0] + t[1]) * 0.5] {
            let mut origins = vec![v(0.0, -6.0, 2.0)];
            origins.extend((0..20).map(|_| target + rng.direction() * 3.0));
            for o in origins {
                for ray in [Ray::new(o, target - o), Ray::new(o, (target - o) * 1e-3)] {
                    if ray.dir == Vec3::ZERO {
                        continue;
                    }
                    let frame = RayFrame::new(&ray);
                    assert_eq!(intersect(&frame, t, f32::INFINITY), None, "{name}: {ray:?}");
                }
            }
        }
    }

    // The image does not change by a bit, nor the rays traced.
    let a = render(&scene_without);
    let b = render(&scene_with);
    assert!(
        a.pixels == b.pixels,
        "degenerate triangles changed the image"
    );
    // The work may differ: the extra indices share the walk's mailbox slots differently.
    let rays = |c: RayCounts| RayCounts {
        work: Default::default(),
        ..c
    };
    assert_eq!(rays(a.counts), rays(b.counts));

    // Loaded from the seed's files: collinear, repeated and equal-after-rounding points.
    let dir = tempfile::tempdir().expect("temporary folder");
    let cfg = dir.path().join("raytracer.cfg");
    write_file(&cfg, "$IMAGE_NAME out.bmp\n$INPUT_DATA ROOM.txt\n");
    write_file(
        &dir.path().join("ROOM.txt"),
        "_SHD 0.1 0.1 0.1 0.5 0.5 0.5 0 0 0 1 0\n_LIGHT 0 0 10 1 1 1 1 1\n\
         _PT 0 5 0\n_PT 1 5 0\n_PT 0 5 1\n_PT 2 5 0\n_PT 1.00000001 5 0\n\
         _TR 0 1 2 0\nREM collinear\n_TR 0 1 3 0\nREM repeated\n_TR 0 0 2 0\n\
         REM equal after rounding\n_TR 1 4 2 0\n",
    );
    let loaded = load_config_scene(&cfg, &Overrides::default()).expect("degenerate triangles load");
    let scene = build(&loaded.desc);
    assert_eq!(scene.degenerate_triangles, 3);
    assert_eq!(scene.octree.stats().filed_triangles, 1);
    // The host warns about them when it renders (`cli::render::run`: "N of M triangles have zero
    // area ... and are never hit"); that path writes to the terminal and is not checked here.
}

// ---------------------------------------------------------------------------------------------
// Flat triangles
// ---------------------------------------------------------------------------------------------

/// `scene` with every triangle's flat mark cleared and its corner normals loaded: the shading
/// every triangle got before flat triangles read their geometric normal instead.
fn without_flat_marks(desc: &SceneDesc, mut scene: Scene) -> Scene {
    if scene.triangle_normals.is_empty() {
        // Every triangle is flat: its corners hold its unit normal.
        scene.triangle_normals = scene
            .triangle_points
            .iter()
            .map(|p| [unit_normal(p).expect("hit triangles are not degenerate"); 3])
            .collect();
    }
    let shaders = desc.triangles.iter().map(|t| t.shader);
    let not_flat = vec![[Vec3::ZERO; 3]; desc.triangles.len()];
    scene.triangle_shading = TriangleShadings::new(&scene.triangle_points, &not_flat, shaders);
    scene
}

/// Triangles with points of their own (NFF's `p` polygons) are flat, and a hit shades them
/// from the normal of the points it tested instead of loading their corner normals: the same
/// pixels, with highlights and mirrors that read the shading normal, with one shader for all
/// or two, and beside a smooth sphere mesh whose shared points give other normals. A scene of
/// flat triangles alone keeps no corner normals at all.
#[test]
fn flat_triangles_shade_as_their_corner_normals_do() {
    let mut rng = Rng::new(40);
    let soup: Vec<[Vec3; 3]> = random_soup(2000, &mut rng)
        .into_iter()
        .filter(|t| unit_normal(t).is_some())
        .collect();
    let ball = positions(&closed_sphere(12, 8, 0.05, &mut rng))
        .into_iter()
        .map(|t| t.map(|p| p * 0.6 + Vec3::new(0.4, 0.5, -0.3)));
    let shiny = Shader::phong(Vec3::splat(0.1), Vec3::splat(0.6), Vec3::ONE, 20.0, 0.0);
    let scene_of = |tris: Vec<([Vec3; 3], u32)>| {
        triangle_desc(
            &tris,
            vec![shiny, mirror()],
            vec![point_light(Vec3::new(2.0, -3.0, 3.0), true)],
            eye(Vec3::new(0.0, -2.5, 0.0), 0.0, 1.0),
            settings(96, 72),
        )
    };
    let mut tris: Vec<([Vec3; 3], u32)> = soup
        .iter()
        .enumerate()
        .map(|(i, &t)| (t, (i % 3 == 0) as u32))
        .collect();
    let flat_alone = scene_of(tris.clone());
    // One shader for all: the scene keeps one shading for every triangle.
    let one_shader = scene_of(tris.iter().map(|&(t, _)| (t, 0)).collect());
    tris.extend(ball.map(|t| (t, 0)));
    let mixed = scene_of(tris);
    for (name, desc, all_flat) in [
        ("flat alone", &flat_alone, true),
        ("flat with one shader", &one_shader, true),
        ("with a smooth mesh", &mixed, false),
    ] {
        let scene = build(desc);
        let flat = (0..desc.triangles.len())
            .filter(|&t| scene.triangle_shading.get(t).flat())
            .count();
        assert_eq!(
            flat,
            soup.len(),
            "{name}: the triangles with points of their own"
        );
        assert_eq!(scene.triangle_shading.all_flat(), all_flat, "{name}");
        assert_eq!(scene.triangle_normals.is_empty(), all_flat, "{name}");
        let fast = render_pixels(&scene);
        let slow = render_pixels(&without_flat_marks(desc, build(desc)));
        let lit = fast.iter().filter(|&&p| p != background_pixel()).count();
        assert!(
            lit > fast.len() / 10,
            "{name}: only {lit} pixels show a triangle"
        );
        let differ = fast.iter().zip(&slow).filter(|(a, b)| a != b).count();
        assert_eq!(
            differ, 0,
            "{name}: {differ} pixels differ from the corner normals' shading"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// One scene at every scale
// ---------------------------------------------------------------------------------------------

/// A floor, two floating triangles and a ball resting on the floor, lit by one shadow-casting
/// light; every position is `p · scale + offset`.
fn scaled_scene(scale: f32, offset: Vec3) -> SceneDesc {
    let v = Vec3::new;
    let place = |p: Vec3| p * scale + offset;
    let mut tris: Vec<([Vec3; 3], u32)> = with_shader(
        &grid(v(-12.0, -6.0, 0.0), v(24.0, 0.0, 0.0), v(0.0, 24.0, 0.0), 4),
        0,
    );
    tris.push(([v(-3.0, 4.0, 2.0), v(0.0, 3.0, 2.5), v(-1.0, 7.0, 2.0)], 1));
    tris.push(([v(4.0, 9.0, 0.0), v(7.0, 9.0, 0.0), v(5.5, 9.0, 4.0)], 1));
    let tris: Vec<([Vec3; 3], u32)> = tris.into_iter().map(|(t, s)| (t.map(place), s)).collect();
    SceneDesc {
        solids: vec![SolidNode::Leaf {
            shape: Shape::Sphere { radius: scale },
            transform: Transform::translate(place(v(2.0, 4.0, 1.0))),
            shader: 2,
        }],
        objects: vec![0],
        ..triangle_desc(
            &tris,
            vec![matte(0.1, 0.8), matte(0.2, 0.6), matte(0.15, 0.7)],
            vec![point_light(place(v(-5.0, 0.0, 8.0)), true)],
            eye(place(v(0.0, -7.0, 7.0)), -35.0, 1.0),
            settings(96, 72),
        )
    }
}

#[test]
fn same_scene_at_every_scale_agrees() {
    let offset = Vec3::splat(1e5);
    let variants = [
        (1e-6f32, Vec3::ZERO),
        (1e-3, Vec3::ZERO),
        (1.0, Vec3::ZERO),
        (1e3, Vec3::ZERO),
        (1e6, Vec3::ZERO),
        (1.0, offset),
        (1e3, offset),
    ];
    let base_desc = scaled_scene(1.0, Vec3::ZERO);
    let base_scene = build(&base_desc);
    let base_reference = Reference::of(&base_desc);
    let reference_image = render(&base_scene);
    let rgb = |img: &Rendered| -> Vec<[u8; 3]> { img.pixels.iter().map(|p| p.to_rgb8()).collect() };
    let base = rgb(&reference_image);
    for (scale, offset) in variants {
        let name = format!("scale {scale:e}, offset {offset:?}");
        let desc = scaled_scene(scale, offset);
        let scene = build(&desc);
        let img = render(&scene);
        // Against the f64 reference of this very scene (its f32 numbers): every pixel it is sure
        // about, within 16/65535. Lit pixels darker than that would be shadow acne (a shadow ray
        // hitting the surface it starts on), brighter shadowed ones a light leak.
        // Tolerance: 4/65535 untranslated; moved by 1e5, hit points are rounded to 1/128 and
        // shading follows them, so 256/65535 (0.4%) there.
        let tol = if offset == Vec3::ZERO { 4 } else { 256 };
        let found = check_against_reference(&name, &scene, &img, &Reference::of(&desc), tol);
        let (checked, lit) = (found.checked, found.lit);
        let total = img.pixels.len();
        assert!(
            checked * 10 >= total * 9,
            "{name}: the reference is sure of only {checked} of {total} pixels"
        );
        assert!(lit * 2 >= total, "{name}: only {lit} pixels are lit");
        // Against scale 1, in 8-bit steps. Tolerance: scaled alone, every pixel within one step
        // (the scene's numbers scale by powers of ten, which round, so a pixel may round the
        // other way). Moved by 1e5 as well, its vertices round to 1/128: pixels whose centre ray
        // passes that close to an edge or a shadow boundary may flip, so at least 99% within one
        // step, and every pixel that both references are sure of within two steps.
        let pixels = rgb(&img);
        let sure = |r: &Reference, s: &Scene, i: usize| {
            r.expected(&pixel_ray(
                s,
                i % s.settings.width as usize,
                i / s.settings.width as usize,
            ))
            .is_some()
        };
        let here = Reference::of(&desc);
        let mut close = 0;
        for (i, (p, q)) in pixels.iter().zip(&base).enumerate() {
            let d = (0..3)
                .map(|c| (i32::from(p[c]) - i32::from(q[c])).abs())
                .max()
                .unwrap_or(0);
            close += usize::from(d <= 1);
            let limit = if offset == Vec3::ZERO {
                1
            } else if sure(&here, &scene, i) && sure(&base_reference, &base_scene, i) {
                2
            } else {
                255
            };
            assert!(d <= limit, "{name}: pixel {i} is {p:?}, at scale 1 {q:?}");
        }
        assert!(
            close * 100 >= total * 99,
            "{name}: only {close} of {total} pixels within 1 step"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Zero and negative-zero direction components
// ---------------------------------------------------------------------------------------------

fn hit_key(h: Option<Hit>) -> Option<(u32, u32)> {
    h.map(|h| (h.triangle, h.tri.t.to_bits()))
}

/// The planes of the octree's cells down to `levels` below the root, per axis: the root's
/// faces and the centre planes of the cells, computed as the traversal computes them.
fn cell_planes(b: Aabb, levels: u32) -> [Vec<f32>; 3] {
    let mut cells = vec![b];
    let mut planes: [Vec<f32>; 3] = [vec![], vec![], vec![]];
    for (a, plane) in planes.iter_mut().enumerate() {
        plane.extend([b.min[a], b.max[a]]);
    }
    for _ in 0..levels {
        let mut next = Vec::new();
        for c in &cells {
            let mid = c.center();
            for a in 0..3 {
                planes[a].push(mid[a]);
            }
            for k in 0..8 {
                let mut child = *c;
                for a in 0..3 {
                    if (k >> a) & 1 == 1 {
                        child.min[a] = mid[a];
                    } else {
                        child.max[a] = mid[a];
                    }
                }
                next.push(child);
            }
        }
        cells = next;
    }
    for p in &mut planes {
        p.sort_by(f32::total_cmp);
        p.dedup();
    }
    planes
}

/// Directions with every combination of −1, −0, +0 and +1 per axis (but not all zero), and
/// random ones with one or two components set to ±0.
fn zero_directions(rng: &mut Rng) -> Vec<Vec3> {
    let values = [-1.0f32, -0.0, 0.0, 1.0];
    let mut dirs = Vec::new();
    for &x in &values {
        for &y in &values {
            for &z in &values {
                if x != 0.0 || y != 0.0 || z != 0.0 {
                    dirs.push(Vec3::new(x, y, z));
                }
            }
        }
    }
    for i in 0..40 {
        let mut d = rng.direction();
        let zero = if i % 2 == 0 { 0.0 } else { -0.0 };
        d[i % 3] = zero;
        if i % 4 < 2 {
            d[(i + 1) % 3] = -zero;
        }
        dirs.push(d);
    }
    dirs
}

#[test]
fn zero_and_negative_zero_direction_components() {
    let mut rng = Rng::new(23);
    let dirs = zero_directions(&mut rng);
    let params = OctreeParams {
        max_depth: 10,
        max_leaf_triangles: 1,
    };
    let mut compared = 0;
    let mut hits = 0;
    for (name, tris) in [
        // Unit quads on integer coordinates: edges on the cell planes.
        ("boundary grid", positions(&boundary_grid(16))),
        ("random soup", random_soup(300, &mut Rng::new(29))),
    ] {
        let tree = Octree::build(&tris, &params);
        let b = tree.bounds();
        let planes = cell_planes(b, 3);
        let pick =
            |rng: &mut Rng, a: usize| planes[a][(rng.next_u64() % planes[a].len() as u64) as usize];
        let mut origins = Vec::new();
        for i in 0..300 {
            // One, two or three coordinates exactly on a cell plane (a face, an edge, a corner
            // of cells), the others anywhere around the bounds.
            let mut o = b.min
                + (b.max - b.min)
                    * Vec3::new(
                        rng.range(-0.2, 1.2),
                        rng.range(-0.2, 1.2),
                        rng.range(-0.2, 1.2),
                    );
            for a in 0..=(i % 3) {
                let axis = (i + a) % 3;
                o[axis] = pick(&mut rng, axis);
            }
            origins.push(o);
        }
        origins.push(b.center());
        origins.push(b.min);
        origins.push(b.max);
        for o in origins {
            for &d in &dirs {
                let ray = Ray::new(o, d);
                let expected = brute_force_closest_hit(&tris, &ray, f32::INFINITY);
                let got = tree.closest_hit(&tris, &ray, f32::INFINITY);
                assert_eq!(hit_key(got), hit_key(expected), "{name}: {ray:?}");
                assert_eq!(
                    tree.any_hit(&tris, &ray, f32::INFINITY),
                    expected.is_some(),
                    "{name}: any-hit, {ray:?}"
                );
                if let Some(h) = got {
                    assert!(
                        h.tri.t.is_finite()
                            && h.tri.t_error.is_finite()
                            && h.tri.b.iter().all(|c| c.is_finite()),
                        "{name}: {h:?}"
                    );
                }
                compared += 1;
                hits += usize::from(expected.is_some());
            }
        }
    }
    assert!(hits * 10 > compared, "only {hits} of {compared} rays hit");

    // The slab test against an f64 answer: a ray with a zero component is inside that slab
    // exactly when its origin is (faces included), whatever the zero's sign.
    let boxes = [
        Aabb {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        },
        Aabb {
            min: Vec3::new(-3.0, 2.0, -1e-3),
            max: Vec3::new(5.0, 2.0, 1e6),
        }, // flat in y
        Aabb {
            min: Vec3::splat(-1e-30),
            max: Vec3::splat(1e-30),
        },
    ];
    for bx in boxes {
        for i in 0..3000 {
            // Origins on the slab planes, just off them, inside and outside.
            let mut o = Vec3::ZERO;
            for a in 0..3 {
                let (lo, hi) = (bx.min[a], bx.max[a]);
                o[a] = match (i / 7usize.pow(a as u32)) % 7 {
                    0 => lo,
                    1 => hi,
                    2 => next_float_down(lo),
                    3 => next_float_up(hi),
                    4 => lo + (hi - lo) * 0.5,
                    5 => lo - (hi - lo).max(1.0),
                    _ => hi + (hi - lo).max(1.0),
                };
            }
            for &d in &dirs {
                let ray = Ray::new(o, d);
                let inv = Vec3::ONE / d;
                let got = bx.intersect(&ray, inv, f32::INFINITY);
                if let Some((t0, t1)) = got {
                    assert!(
                        !t0.is_nan() && !t1.is_nan() && t0 <= t1,
                        "{bx:?} {ray:?}: {got:?}"
                    );
                }
                // Exact answer in f64: the interval of t ≥ 0 inside every slab.
                let (mut lo_t, mut hi_t) = (0.0f64, f64::INFINITY);
                let mut parallel_miss = false;
                for a in 0..3 {
                    let (o, d) = (f64::from(o[a]), f64::from(d[a]));
                    let (lo, hi) = (f64::from(bx.min[a]), f64::from(bx.max[a]));
                    if d == 0.0 {
                        parallel_miss |= o < lo || o > hi;
                    } else {
                        let (n, f) = ((lo - o) / d, (hi - o) / d);
                        lo_t = lo_t.max(n.min(f));
                        hi_t = hi_t.min(n.max(f));
                    }
                }
                if parallel_miss {
                    assert_eq!(
                        got, None,
                        "{bx:?} {ray:?}: outside a slab it runs parallel to"
                    );
                } else if lo_t <= hi_t {
                    assert!(
                        got.is_some(),
                        "{bx:?} {ray:?}: misses, the exact interval is [{lo_t}, {hi_t}]"
                    );
                }
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// A camera or a light inside an object, or on a surface
// ---------------------------------------------------------------------------------------------

/// Solid scene objects: each node its own object.
fn solid_objects(nodes: Vec<SolidNode>) -> (Vec<SolidNode>, Vec<u32>) {
    let objects = (0..nodes.len() as u32).collect();
    (nodes, objects)
}

#[test]
fn camera_inside_a_closed_object() {
    let v = Vec3::new;
    let inside_light = point_light(v(1.0, 1.0, 1.0), true);
    let outside_light = point_light(v(0.0, -50.0, 0.0), true);
    // A closed box of triangles ([-4, 4]³, two per face and a gridded one), a ball and a cuboid
    // solid; the camera inside each: at its centre (the corner rays run exactly at the box's
    // corners), off-centre, and exactly on the box's back wall, looking in.
    let boxes = [
        box_triangles(Vec3::splat(-4.0), Vec3::splat(4.0), [1, 1, 1]),
        box_triangles(Vec3::splat(-4.0), Vec3::splat(4.0), [4, 4, 4]),
    ];
    let solids = [
        SolidNode::Leaf {
            shape: Shape::Sphere { radius: 4.0 },
            transform: Transform::IDENTITY,
            shader: 0,
        },
        SolidNode::Leaf {
            shape: Shape::Cuboid {
                size: Vec3::splat(8.0),
            },
            transform: Transform::rotate_xyz_deg(v(10.0, 20.0, 30.0)),
            shader: 0,
        },
    ];
    let eyes = [
        v(0.0, 0.0, 0.0),
        v(0.5, -1.0, 0.25),
        v(0.0, -4.0, 0.0),
        v(3.9, 3.9, -3.9),
    ];
    for light in [inside_light, outside_light] {
        let mut descs: Vec<(String, SceneDesc)> = Vec::new();
        for (k, b) in boxes.iter().enumerate() {
            for winding in [b.clone(), flipped(b)] {
                descs.push((
                    format!("box {k}"),
                    triangle_desc(
                        &with_shader(&winding, 0),
                        vec![matte(0.2, 0.7)],
                        vec![light],
                        Camera::default(),
                        settings(24, 18),
                    ),
                ));
            }
        }
        for (k, node) in solids.iter().enumerate() {
            let (solids, objects) = solid_objects(vec![*node]);
            descs.push((
                format!("solid {k}"),
                SceneDesc {
                    shaders: vec![matte(0.2, 0.7)],
                    lights: vec![light],
                    solids,
                    objects,
                    settings: settings(24, 18),
                    ..SceneDesc::default()
                },
            ));
        }
        for (name, desc) in &mut descs {
            for &e in &eyes {
                let inside = match desc.solids.first() {
                    Some(SolidNode::Leaf {
                        shape: Shape::Sphere { radius },
                        ..
                    }) => e.length() < *radius,
                    // Rotations only: the transposed matrix takes the eye into object space.
                    Some(SolidNode::Leaf { transform, .. }) => {
                        (transform.matrix.transpose() * e).abs().max_element() < 4.0
                    }
                    _ => true,
                };
                if !inside {
                    continue;
                }
                desc.camera = eye(e, 10.0, 1.0);
                let scene = build(desc);
                let img = render(&scene);
                let mut scratch = QueryScratch::default();
                let mut lit = 0;
                for y in 0..18 {
                    for x in 0..24 {
                        let at = format!(
                            "{name}, eye {e:?}, light {:?}: pixel ({x}, {y})",
                            light.position
                        );
                        let ray = pixel_ray(&scene, x, y);
                        assert!(
                            scene
                                .closest_hit(&ray, f32::INFINITY, &mut scratch)
                                .is_some(),
                            "{at}: sees out"
                        );
                        let c = img.colors[y * 24 + x];
                        // The inside walls: ambient 0.2 everywhere, more where the inner light
                        // reaches, never the background; the outer light reaches nothing.
                        assert!(c.x == c.z && c.x >= 0.2 - 1e-6, "{at}: colour {c:?}");
                        if light.position == outside_light.position {
                            assert_eq!(c, Vec3::splat(0.2), "{at}: the outside light leaks in");
                        }
                        lit += usize::from(c.x > 0.21);
                    }
                }
                if light.position == inside_light.position {
                    assert!(
                        lit > 0,
                        "{name}, eye {e:?}: nothing lit by the light inside"
                    );
                }
            }
        }
    }
}

/// Scenes with the light exactly on a surface: a floor (z = 0, 4 × 4 quads of 2 units), a wall
/// (y = 6, facing −y) and a ball of radius 1 resting on the floor, seen from two cameras above.
fn light_on_surface_scenes() -> Vec<(String, SceneDesc)> {
    let v = Vec3::new;
    let floor = grid(v(-4.0, -2.0, 0.0), v(8.0, 0.0, 0.0), v(0.0, 8.0, 0.0), 4);
    let wall = flipped(&grid(
        v(-4.0, 6.0, 0.0),
        v(8.0, 0.0, 0.0),
        v(0.0, 0.0, 4.0),
        4,
    ));
    let mut tris = with_shader(&floor, 0);
    tris.extend(with_shader(&wall, 1));
    let ball = v(-2.0, 3.0, 1.0);
    let lights = [
        ("inside a floor quad", v(1.25, 0.75, 0.0)),
        ("on a floor vertex", v(0.0, 2.0, 0.0)),
        ("on a floor edge", v(1.0, 2.0, 0.0)),
        ("on a floor diagonal", v(1.0, 1.0, 0.0)),
        ("on the wall", v(0.5, 6.0, 1.5)),
        ("on top of the ball", ball + Vec3::Z),
        ("where the ball touches the floor", ball - Vec3::Z),
    ];
    let mut out = Vec::new();
    for (name, position) in lights {
        for (k, camera) in [
            eye(v(0.0, -9.0, 9.0), -40.0, 1.0),
            eye(v(0.0, -4.0, 7.0), -45.0, 1.0),
        ]
        .into_iter()
        .enumerate()
        {
            out.push((
                format!("light {name}, camera {k}"),
                SceneDesc {
                    solids: vec![sphere_node(ball, 1.0, 2)],
                    objects: vec![0],
                    ..triangle_desc(
                        &tris,
                        vec![matte(0.1, 0.8), matte(0.15, 0.7), matte(0.05, 0.9)],
                        vec![point_light(position, true)],
                        camera,
                        settings(48, 36),
                    )
                },
            ));
        }
    }
    out
}

#[test]
fn light_exactly_on_a_surface() {
    // The light lies in the plane of the surface it is on (or in the ball's tangent plane), so
    // that surface gets no diffuse light (N·L = 0 exactly, no NaN from a zero distance), and
    // everything in front of it is lit unless something else stands in between: the reference
    // decides each pixel it is sure of. Then the pixels whose shadow ray reaches the light where
    // it crosses the light's own surface (`t = 1`): there must be many, and every one lit.
    let (mut lit, mut speckled) = (0, 0);
    for (name, desc) in light_on_surface_scenes() {
        let scene = build(&desc);
        let img = render(&scene);
        let strict = Reference::of(&desc);
        let lenient = Reference {
            unsure_at_light: true,
            ..Reference::of(&desc)
        };
        let found = check_against_reference(&name, &scene, &img, &lenient, 4);
        assert!(
            found.checked * 2 >= img.pixels.len(),
            "{name}: only {} pixels checked",
            found.checked
        );
        for y in 0..36 {
            for x in 0..48 {
                let ray = pixel_ray(&scene, x, y);
                let (o, d) = (ray.origin.to_f64(), ray.dir.to_f64());
                let (None, Some(Expect::Grey(v)), Seen::Surface(_, _, shader)) = (
                    lenient.expected(&ray),
                    strict.expected(&ray),
                    strict.first(o, d),
                ) else {
                    continue;
                };
                let got = i32::from(img.at(x, y).0[0]);
                if (got - q16(v)).abs() <= 4 {
                    lit += 1;
                } else if (got - q16(strict.shaders[shader].0)).abs() <= 4 {
                    speckled += 1;
                } else {
                    panic!(
                        "{name}: pixel ({x}, {y}) is {got}, neither lit ({}) nor shadowed",
                        q16(v)
                    );
                }
            }
        }
    }
    assert!(
        lit > 500,
        "only {lit} pixels lit through the light's own surface"
    );
    assert_eq!(
        speckled, 0,
        "pixels shadowed by the light's own surface ({lit} lit)"
    );
}

#[test]
fn light_exactly_on_a_surface_lights_what_faces_it() {
    // The light sits on the floor's diagonal and on top of the ball. Shadow rays reach it exactly
    // where its own surface is crossed (`t = 1`); the crossing's computed `t` may come out below
    // 1, but only by less than its error bound (large for a grazing floor hit or a sphere), so
    // the surface the light sits on must not block it: no speckle against the reference.
    for (name, desc) in light_on_surface_scenes() {
        let scene = build(&desc);
        let img = render(&scene);
        check_against_reference(&name, &scene, &img, &Reference::of(&desc), 4);
    }
}

#[test]
fn light_inside_an_object() {
    let v = Vec3::new;
    // A floor (z = −3) and a closed object around the only light; the camera outside. The light
    // must reach nothing outside: every pixel shows its ambient colour or the background.
    let floor = with_shader(
        &grid(
            v(-20.0, -10.0, -3.0),
            v(40.0, 0.0, 0.0),
            v(0.0, 40.0, 0.0),
            4,
        ),
        0,
    );
    let light = point_light(v(0.5, 0.25, -0.5), true);
    let mut descs: Vec<(&str, SceneDesc)> = Vec::new();
    for (name, b) in [
        (
            "12-triangle box",
            box_triangles(Vec3::splat(-2.0), Vec3::splat(2.0), [1, 1, 1]),
        ),
        (
            "gridded box",
            box_triangles(Vec3::splat(-2.0), Vec3::splat(2.0), [3, 3, 3]),
        ),
        (
            "inward box",
            flipped(&box_triangles(
                Vec3::splat(-2.0),
                Vec3::splat(2.0),
                [1, 1, 1],
            )),
        ),
    ] {
        let mut tris = floor.clone();
        tris.extend(with_shader(&b, 1));
        descs.push((
            name,
            triangle_desc(
                &tris,
                vec![],
                vec![light],
                Camera::default(),
                settings(48, 36),
            ),
        ));
    }
    for (name, node) in [
        ("ball", sphere_node(Vec3::ZERO, 2.0, 1)),
        (
            "cuboid",
            SolidNode::Leaf {
                shape: Shape::Cuboid {
                    size: Vec3::splat(4.0),
                },
                transform: Transform::rotate_xyz_deg(v(0.0, 0.0, 30.0)),
                shader: 1,
            },
        ),
    ] {
        let (solids, objects) = solid_objects(vec![node]);
        descs.push((
            name,
            SceneDesc {
                solids,
                objects,
                ..triangle_desc(
                    &floor,
                    vec![],
                    vec![light],
                    Camera::default(),
                    settings(48, 36),
                )
            },
        ));
    }
    let ambient = [0.1f32, 0.25];
    for (name, desc) in &mut descs {
        desc.shaders = ambient.iter().map(|&a| matte(a, 0.8)).collect();
        for (e, tilt) in [(v(0.0, -12.0, 6.0), -30.0), (v(7.0, -9.0, 1.0), -5.0)] {
            desc.camera = eye(e, tilt, 1.0);
            let scene = build(desc);
            let img = render(&scene);
            let allowed: Vec<Pixel> = ambient
                .iter()
                .map(|&a| Pixel::from_color(Vec3::splat(a)))
                .chain([background_pixel()])
                .collect();
            let mut seen = [0usize; 3];
            for (i, p) in img.pixels.iter().enumerate() {
                let k = allowed.iter().position(|a| a == p).unwrap_or_else(|| {
                    let c = img.colors[i];
                    panic!("{name}, eye {e:?}: pixel {i} is {p:?} ({c:?}): lit by the light inside")
                });
                seen[k] += 1;
            }
            assert!(
                seen[1] > 0,
                "{name}, eye {e:?}: the object is not in view: {seen:?}"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Coplanar triangles
// ---------------------------------------------------------------------------------------------

/// Renders every line of `scene` into 8-bit pixels (no colour checks: for many octrees).
fn render_pixels(scene: &Scene) -> Vec<Pixel> {
    let w = scene.settings.width as usize;
    let mut pixels = vec![Pixel::default(); w * scene.settings.height as usize];
    for (y, line) in pixels.chunks_mut(w).enumerate() {
        render_line(scene, y as u32, line).expect("line renders");
    }
    pixels
}

#[test]
fn coplanar_overlapping_triangles_pick_the_same_winner() {
    let v = Vec3::new;
    // In the plane z = 0: an 8 × 8 grid (shader 0) overlapped by a 5 × 5 grid shifted by
    // (1, 0.5) (shader 1), their edges crossing; and one quad twice, bit for bit (shaders 2 and
    // 3, or 3 and 2). The camera looks straight down.
    let a = grid(v(0.0, 0.0, 0.0), v(8.0, 0.0, 0.0), v(0.0, 8.0, 0.0), 8);
    let b = grid(v(1.0, 0.5, 0.0), v(8.0, 0.0, 0.0), v(0.0, 8.0, 0.0), 5);
    let dup = quad([
        v(-6.0, 0.0, 0.0),
        v(-1.0, 0.0, 0.0),
        v(-1.0, 8.0, 0.0),
        v(-6.0, 8.0, 0.0),
    ]);
    let colors = [Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0), Vec3::ONE];
    for dup_first in [2u32, 3] {
        let mut tris = with_shader(&a, 0);
        tris.extend(with_shader(&b, 1));
        tris.extend(with_shader(&dup, dup_first));
        tris.extend(with_shader(&dup, 5 - dup_first));
        let desc = triangle_desc(
            &tris,
            colors.iter().map(|&c| flat(c)).collect(),
            vec![point_light(v(0.0, 0.0, 20.0), true)],
            eye(v(1.5, 4.0, 12.0), -90.0, 1.0),
            settings(40, 40),
        );
        let scene = build(&desc);
        let img = render(&scene);
        // Each pixel shows the triangle that testing every triangle picks: the smallest t, ties
        // (bit-identical t) to the lowest index.
        let mut ties = [0usize; 2];
        for y in 0..40 {
            for x in 0..40 {
                let ray = pixel_ray(&scene, x, y);
                let hit = brute_force_closest_hit(&scene.triangle_points, &ray, f32::INFINITY);
                let want = hit.map_or(background_pixel(), |h| {
                    Pixel::from_color(
                        colors[scene.triangle_shading.get(h.triangle as usize).shader() as usize],
                    )
                });
                assert_eq!(
                    img.at(x, y),
                    want,
                    "duplicate {dup_first} first: pixel ({x}, {y})"
                );
                let Some(h) = hit else { continue };
                let frame = RayFrame::new(&ray);
                let tied: Vec<usize> = scene
                    .triangle_points
                    .iter()
                    .enumerate()
                    .filter(|(_, t)| {
                        intersect(&frame, t, f32::INFINITY).is_some_and(|o| o.t == h.tri.t)
                    })
                    .map(|(i, _)| i)
                    .collect();
                if tied.len() > 1 {
                    assert_eq!(
                        tied[0], h.triangle as usize,
                        "pixel ({x}, {y}): lowest index wins"
                    );
                    let shader = scene.triangle_shading.get(h.triangle as usize).shader();
                    ties[usize::from(shader >= 2)] += 1;
                    if shader >= 2 {
                        assert_eq!(shader, dup_first, "pixel ({x}, {y}): the first copy wins");
                    }
                }
            }
        }
        assert!(
            ties[0] > 20 && ties[1] > 100,
            "exact ties (grids, copies): {ties:?}"
        );

        // The same pixels every time: again, for every octree, and from 1, 2 and 3 workers.
        assert!(
            render_pixels(&scene) == img.pixels,
            "a second render differs"
        );
        for max_depth in 1..=16 {
            for max_leaf_triangles in 1..=8 {
                let params = OctreeParams {
                    max_depth,
                    max_leaf_triangles,
                };
                let scene = Scene::build(&desc, &params).expect("valid scene");
                assert!(
                    render_pixels(&scene) == img.pixels,
                    "{params:?} changed the image"
                );
            }
        }
        for params in [
            OctreeParams::default(),
            OctreeParams {
                max_depth: 1,
                max_leaf_triangles: 1,
            },
            OctreeParams {
                max_depth: 16,
                max_leaf_triangles: 1,
            },
        ] {
            let prepared = PreparedScene::new(&desc, &params).expect("valid scene");
            for workers in 1..=3 {
                let image = render_local(&prepared, workers, &|_, _| {}).expect("local render");
                assert!(
                    image.pixels == img.pixels,
                    "{workers} workers, {params:?}: the image differs"
                );
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Facing perfect mirrors
// ---------------------------------------------------------------------------------------------

#[test]
fn parallel_perfect_mirrors_stop_at_the_depth_cap() {
    let v = Vec3::new;
    // Two perfect mirrors facing each other at y = ±10, the camera between them looking along +Y
    // (5 × 5 pixels: the middle one's ray meets both at right angles and comes straight back):
    // as triangles (quads 2e5 wide, so no ray leaves them before the cap) and as half-spaces.
    let big = 1e5;
    let near = quad([
        v(-big, -10.0, -big),
        v(-big, -10.0, big),
        v(big, -10.0, big),
        v(big, -10.0, -big),
    ]);
    let far = quad([
        v(-big, 10.0, -big),
        v(big, 10.0, -big),
        v(big, 10.0, big),
        v(-big, 10.0, big),
    ]);
    let mirrors_of_triangles = triangle_desc(
        &with_shader(&[near, far].concat(), 0),
        vec![mirror()],
        vec![point_light(v(1.0, 2.0, 3.0), true)],
        eye(Vec3::ZERO, 0.0, 1.0),
        settings(5, 5),
    );
    let half_space = |normal: Vec3| SolidNode::Leaf {
        shape: Shape::Plane { normal, d: -10.0 },
        transform: Transform::IDENTITY,
        shader: 0,
    };
    let (solids, objects) = solid_objects(vec![half_space(Vec3::Y), half_space(Vec3::NEG_Y)]);
    let mirrors_of_solids = SceneDesc {
        solids,
        objects,
        ..mirrors_of_triangles.clone()
    };
    let mirrors_of_solids = SceneDesc {
        points: vec![],
        triangles: vec![],
        ..mirrors_of_solids
    };
    for (name, desc) in [
        ("triangles", mirrors_of_triangles),
        ("half-spaces", mirrors_of_solids),
    ] {
        for max_depth in [0, 1, 2, 5, 16, 64] {
            let mut desc = desc.clone();
            desc.settings.max_depth = max_depth;
            let scene = build(&desc);
            let img = render(&scene);
            assert_eq!(img.counts.primary, 25, "{name}");
            assert_eq!(
                img.counts.reflection,
                25 * u64::from(max_depth),
                "{name}, depth cap {max_depth}: every pixel bounces exactly up to the cap"
            );
            assert_eq!(img.counts.refraction, 0);
            // Only the last bounce is shaded (r = 1 leaves no local share before it): one shadow
            // ray per pixel at most.
            assert!(img.counts.shadow <= 25, "{name}: {:?}", img.counts);
            assert!(
                img.colors.iter().all(|c| c.min_element() > 0.0),
                "{name}: a black pixel"
            );
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Bad numbers in the input
// ---------------------------------------------------------------------------------------------

const GOOD_DATA: &str = "REM one of everything\n\
_SHD 0.1 0.1 0.1 0.5 0.5 0.5 0 0 0 1 0\n\
_LIGHT 0 0 10 1 1 1 1 1\n\
_PT 0 5 0\n\
_PT 1 5 0\n\
_PT 0 5 1\n\
_TR 0 1 2 0\n";

const GOOD_CONFIG: &str = "$IMAGE_NAME out.bmp\n\
$INPUT_DATA ROOM.txt\n\
$IMAGE_WIDTH 8\n\
$IMAGE_HEIGHT 6\n\
$CAM_POS_X 0\n\
$CAM_POS_Y -5\n\
$CAM_POS_Z 1\n\
$CAM_POS_ANGLE_X 0\n\
$CAM_POS_ANGLE_Z 0\n\
$CAM_POS_ZOOM 1\n\
$COLOR_BG_R 0\n";

/// `text` with word `word` (0 is the record name) of line `line` (1-based) replaced.
fn replace_word(text: &str, line: usize, word: usize, with: &str) -> String {
    text.lines()
        .enumerate()
        .map(|(i, l)| {
            if i + 1 == line {
                let mut words: Vec<&str> = l.split(' ').collect();
                words[word] = with;
                words.join(" ")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

#[test]
fn bad_numbers_in_input_are_load_errors() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let cfg: PathBuf = dir.path().join("raytracer.cfg");
    let data: PathBuf = dir.path().join("ROOM.txt");
    let load = |config: &str, room: &str| {
        write_file(&cfg, config);
        write_file(&data, room);
        load_config_scene(&cfg, &Overrides::default())
    };
    let good = load(GOOD_CONFIG, GOOD_DATA).expect("the good files load");
    build(&good.desc);

    let bad_words = [
        "NaN",
        "nan",
        "inf",
        "-inf",
        "infinity",
        "-Infinity",
        "1e39",
        "-1e39",
        "3.5e38",
    ];
    // Every number of every record: (line, words after the name).
    let data_numbers = [(2, 11), (3, 7), (4, 3), (5, 3), (6, 3)];
    let mut errors = 0;
    for bad in bad_words {
        for (line, count) in data_numbers {
            for word in 1..=count {
                let room = replace_word(GOOD_DATA, line, word, bad);
                let err = load(GOOD_CONFIG, &room).expect_err("a bad number must not load");
                let shown = err.to_string();
                let place = format!("{}:{line}:", data.display());
                assert!(
                    shown.starts_with(&place) && shown.contains(bad),
                    "`{bad}`, data line {line}, word {word}: {shown:?} must start {place}, quote it"
                );
                errors += 1;
            }
        }
        // The camera's numbers and a colour of the configuration file.
        for line in 5..=11 {
            let config = replace_word(GOOD_CONFIG, line, 1, bad);
            let err = load(&config, GOOD_DATA).expect_err("a bad number must not load");
            let shown = err.to_string();
            let place = format!("{}:{line}:", cfg.display());
            assert!(
                shown.starts_with(&place) && shown.contains(bad),
                "`{bad}` on config line {line}: {shown:?} must start {place}, quote it"
            );
            errors += 1;
        }
    }
    assert_eq!(errors, bad_words.len() * (27 + 7));

    // The core's own check: a shading normal of zero length is an error (whatever the zeros'
    // signs), a normal too short to normalise is not, and renders without a NaN.
    let mut desc = good.desc.clone();
    desc.normals = vec![Vec3::Z, Vec3::new(-0.0, 0.0, -0.0)];
    desc.triangles[0].normals = Some([0, 1, 0]);
    assert_eq!(desc.validate(), Err(SceneError::ZeroNormal { normal: 1 }));
    assert!(matches!(
        Scene::build(&desc, &OctreeParams::default()),
        Err(SceneError::ZeroNormal { normal: 1 })
    ));
    desc.normals = vec![Vec3::ZERO];
    desc.triangles[0].normals = Some([0, 0, 0]);
    assert_eq!(desc.validate(), Err(SceneError::ZeroNormal { normal: 0 }));
    desc.normals = vec![Vec3::new(1e-30, 0.0, 0.0)];
    assert_eq!(desc.validate(), Ok(()));
    render(&build(&desc));
    // And numbers that are not finite, given to the core directly.
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let mut d = good.desc.clone();
        d.points[1].y = bad;
        assert_eq!(d.validate(), Err(SceneError::NonFiniteNumber));
        let mut d = good.desc.clone();
        d.normals = vec![Vec3::new(bad, 0.0, 1.0)];
        d.triangles[0].normals = Some([0, 0, 0]);
        assert_eq!(d.validate(), Err(SceneError::NonFiniteNumber));
        let mut d = good.desc.clone();
        d.lights[0].amount = bad;
        assert_eq!(d.validate(), Err(SceneError::NonFiniteNumber));
    }
}

// ---------------------------------------------------------------------------------------------
// Property tests
// ---------------------------------------------------------------------------------------------

fn unit_cube_point() -> impl Strategy<Value = Vec3> {
    prop::array::uniform3(-1.0f32..1.0).prop_map(Vec3::from_array)
}

/// A triangle soup: 1 to 60 triangles of three sizes (many overlapping), some repeated exactly.
fn soup() -> impl Strategy<Value = Vec<[Vec3; 3]>> {
    let triangle = (
        unit_cube_point(),
        prop_oneof![Just(0.05f32), Just(0.3), Just(1.0)],
        prop::array::uniform3(unit_cube_point()),
    )
        .prop_map(|(c, size, offsets)| offsets.map(|o| c + o * size));
    (prop::collection::vec(triangle, 1..60), 0usize..4).prop_map(|(mut tris, copies)| {
        for k in 0..copies.min(tris.len()) {
            tris.push(tris[k]);
        }
        tris
    })
}

/// A ray of a property test: an origin, a direction, how to aim it and which components to zero.
fn ray_parts() -> impl Strategy<Value = (Vec3, Vec3, u8, u16)> {
    (
        unit_cube_point().prop_map(|p| p * 2.0),
        unit_cube_point(),
        any::<u8>(),
        any::<u16>(),
    )
}

/// The ray described by `parts` among `tris`: mode (bits 0–1) a random direction, at a vertex,
/// at an edge's midpoint, or along an axis; bits 2–4 make those direction components zero (an
/// aimed ray keeps its aim: its origin moves into the target's plane), bit 5 with −0.
fn make_ray(tris: &[[Vec3; 3]], (mut o, d, bits, pick): (Vec3, Vec3, u8, u16)) -> Option<Ray> {
    let t = &tris[pick as usize % tris.len()];
    let k = (pick as usize / tris.len()) % 3;
    let target = match bits & 3 {
        1 => Some(t[k]),
        2 => Some((t[k] + t[(k + 1) % 3]) * 0.5),
        _ => None,
    };
    let zero = if bits & 32 != 0 { -0.0 } else { 0.0 };
    for a in 0..3 {
        if bits & (4 << a) != 0 {
            if let Some(target) = target {
                o[a] = target[a];
            }
        }
    }
    let mut d = match (bits & 3, target) {
        (_, Some(target)) => target - o,
        (0, _) => d,
        _ => {
            let mut a = Vec3::ZERO;
            a[k] = if d.x < 0.0 { -1.0 } else { 1.0 };
            a
        }
    };
    for a in 0..3 {
        if bits & (4 << a) != 0 {
            d[a] = zero;
        }
    }
    (d != Vec3::ZERO && d.is_finite()).then(|| Ray::new(o, d))
}

/// A 3 × 3 matrix (columns) inverted in f64.
fn inverse3(m: glam::Mat3) -> [V64; 3] {
    let c = [m.x_axis.to_f64(), m.y_axis.to_f64(), m.z_axis.to_f64()];
    let (r0, r1, r2) = (c[1].cross(c[2]), c[2].cross(c[0]), c[0].cross(c[1]));
    let det = c[0].dot(r0);
    // Rows of the inverse are the cross products over the determinant.
    [r0 / det, r1 / det, r2 / det]
}

/// `rows · v` for the rows of [`inverse3`].
fn apply_rows(rows: &[V64; 3], v: V64) -> V64 {
    V64::new(rows[0].dot(v), rows[1].dot(v), rows[2].dot(v))
}

/// A solid of kind `kind` (sphere, rotated box, half-space) at `centre` of size `size`, and the
/// signed distance (f64) with unit normal of a world point to its face `face`.
fn placed_solid(kind: u8, centre: Vec3, size: f32, tilt: Vec3) -> SolidNode {
    let rotation = Transform::rotate_xyz_deg(tilt * 180.0);
    match kind % 3 {
        0 => sphere_node(centre, size, 0),
        1 => SolidNode::Leaf {
            shape: Shape::Cuboid {
                size: Vec3::new(2.0, 1.0, 0.5) * size,
            },
            transform: Transform::translate(centre).after(&rotation),
            shader: 0,
        },
        _ => SolidNode::Leaf {
            shape: Shape::Plane {
                normal: tilt + Vec3::new(0.0, 0.0, 1.5),
                d: 0.0,
            },
            transform: Transform::translate(centre),
            shader: 0,
        },
    }
}

fn surface_distance(node: &SolidNode, face: u8, p: Vec3) -> (f64, V64) {
    let SolidNode::Leaf {
        shape, transform, ..
    } = node
    else {
        unreachable!("leaves only")
    };
    let inv = inverse3(transform.matrix);
    let q = apply_rows(&inv, p.to_f64() - transform.translation.to_f64());
    // Gradient in object space, taken to world space by the inverse transpose.
    let (f, grad) = match *shape {
        // At the centre (a ball smaller than the rounding of its position) any direction will do.
        Shape::Sphere { radius } if q == V64::ZERO => (-f64::from(radius), V64::new(0.0, 0.0, 1.0)),
        Shape::Sphere { radius } => (q.length() - f64::from(radius), q.normalize()),
        Shape::Plane { normal, d } => {
            let n = normal.to_f64().normalize();
            (n.dot(q) - f64::from(d), n)
        }
        Shape::Cuboid { size } => {
            let axis = usize::from(face / 2);
            let sign = if face % 2 == 1 { 1.0 } else { -1.0 };
            let mut g = [0.0; 3];
            g[axis] = sign;
            let qa = [q.x, q.y, q.z][axis];
            (
                sign * qa - 0.5 * f64::from(size[axis]),
                V64::new(g[0], g[1], g[2]),
            )
        }
        _ => unreachable!("not placed here"),
    };
    let world_grad = inv[0] * grad.x + inv[1] * grad.y + inv[2] * grad.z;
    (f / world_grad.length(), world_grad.normalize())
}

/// A triangle placed at `10^exp` scale and moved by `offset · 10^shift`.
fn placed_triangle(tri: [Vec3; 3], exp: i32, offset: Vec3, shift: i32) -> [Vec3; 3] {
    let s = 10f32.powi(exp);
    let t = offset * 10f32.powi(shift);
    tri.map(|p| p * s + t)
}

/// A ray at the point of `tri` with barycentrics `(u, v)`, from `away` (scaled to the triangle).
fn ray_at_triangle(tri: &[Vec3; 3], u: f32, v: f32, away: Vec3) -> (Ray, f32) {
    let (u, v) = if u + v > 1.0 {
        (1.0 - u, 1.0 - v)
    } else {
        (u, v)
    };
    let p = tri.map(|p| p.to_f64());
    let target = (p[0] + (p[1] - p[0]) * f64::from(u) + (p[2] - p[0]) * f64::from(v)).as_f32();
    let size = (tri[1] - tri[0]).length().max((tri[2] - tri[0]).length());
    let origin = target + away * (size * 2.0);
    (Ray::new(origin, target - origin), u.min(v).min(1.0 - u - v))
}

/// The inputs of one case of the hit-point and reflection properties.
#[derive(Clone, Copy, Debug)]
struct Placed {
    tri: [Vec3; 3],
    exp: i32,
    offset: Vec3,
    shift: i32,
    u: f32,
    v: f32,
    away: Vec3,
    kind: u8,
    tilt: Vec3,
}

fn placed() -> impl Strategy<Value = Placed> {
    (
        prop::array::uniform3(unit_cube_point()),
        -6i32..=6,
        unit_cube_point(),
        0i32..=5,
        (0.0f32..1.0, 0.0f32..1.0),
        unit_cube_point(),
        0u8..3,
        unit_cube_point(),
    )
        .prop_map(
            |(tri, exp, offset, shift, (u, v), away, kind, tilt)| Placed {
                tri,
                exp,
                offset,
                shift,
                u,
                v,
                away,
                kind,
                tilt,
            },
        )
}

impl Placed {
    fn random(rng: &mut Rng) -> Placed {
        let mut point = || {
            Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            )
        };
        let (tri, offset, away, tilt) = ([point(), point(), point()], point(), point(), point());
        Placed {
            tri,
            exp: (rng.next_u64() % 13) as i32 - 6,
            offset,
            shift: (rng.next_u64() % 6) as i32,
            u: rng.next_f32(),
            v: rng.next_f32(),
            away,
            kind: (rng.next_u64() % 3) as u8,
            tilt,
        }
    }

    /// The triangle: at `10^exp` scale, moved by up to `10^(shift + max(exp, 0))` (≤ 1e11).
    fn triangle(&self) -> [Vec3; 3] {
        placed_triangle(
            self.tri,
            self.exp,
            self.offset,
            self.shift + self.exp.max(0),
        )
    }

    /// The scene of one solid of the same scale and place, and a ray at it from outside.
    fn solid(&self, kinds: u8) -> (SolidNode, Scene, Ray) {
        let s = 10f32.powi(self.exp);
        let centre = self.offset * 10f32.powi(self.shift + self.exp.max(0));
        let node = placed_solid(self.kind % kinds, centre, s, self.tilt);
        let desc = SceneDesc {
            shaders: vec![flat(Vec3::ONE)],
            lights: vec![point_light(Vec3::ZERO, true)],
            solids: vec![node],
            objects: vec![0],
            ..SceneDesc::default()
        };
        let target = centre + Vec3::new(self.u - 0.5, self.v - 0.5, 0.0) * s;
        let away = self.away.normalize_or(Vec3::Z);
        (
            node,
            build(&desc),
            Ray::new(target + away * (4.0 * s), -away * s),
        )
    }
}

/// One case of `hit_points_lie_on_the_surface_within_their_error_bound`; returns whether the
/// triangle and the solid were hit.
fn hit_points_case(c: &Placed) -> Result<(bool, bool), TestCaseError> {
    let tri = c.triangle();
    let (ray, margin) = ray_at_triangle(&tri, c.u, c.v, c.away);
    let mut hits = (false, false);
    if ray.dir != Vec3::ZERO && ray.dir.is_finite() {
        let hit = intersect(&RayFrame::new(&ray), &tri, f32::INFINITY);
        match (unit_normal(&tri), hit) {
            (None, h) => prop_assert_eq!(h, None, "degenerate {:?} hit", tri),
            (Some(_), Some(h)) => {
                prop_assert!(h.t.is_finite() && h.t > 0.0 && h.b.iter().all(|b| b.is_finite()));
                let (p, err) = hit_point(&tri, h.b);
                let q = tri.map(|v| v.to_f64());
                let n = (q[1] - q[0]).cross(q[2] - q[0]).normalize();
                let dist = n.dot(p.to_f64() - q[0]);
                let bound = n.abs().dot(err.to_f64());
                prop_assert!(
                    dist.abs() <= bound,
                    "{:?}: hit point {:?} is {:e} off the plane, bound {:e}",
                    tri,
                    p,
                    dist,
                    bound
                );
                hits.0 = true;
            }
            (Some(n), None) => {
                // Aimed well inside a triangle that is not a sliver, not from the side, and
                // large against the rounding of its coordinates: it must hit.
                let area = (tri[1] - tri[0]).cross(tri[2] - tri[0]).length();
                let long = (tri[1] - tri[0])
                    .length()
                    .max((tri[2] - tri[1]).length())
                    .max((tri[0] - tri[2]).length());
                let grazing = n.dot(ray.dir.normalize()).abs() < 0.05;
                let magnitude = tri
                    .iter()
                    .chain([&ray.origin])
                    .map(|p| p.abs().max_element())
                    .fold(0.0, f32::max);
                let coarse = magnitude * f32::EPSILON * 1e3 > area.sqrt();
                prop_assert!(
                    margin < 0.05 || area < 0.05 * long * long || grazing || coarse,
                    "missed {:?} with {:?}",
                    tri,
                    ray
                );
            }
        }
    }

    // A solid (ball, turned box or half-space) at the same scale and place.
    let (node, scene, ray) = c.solid(3);
    let mut scratch = QueryScratch::default();
    if let Some(PrimitiveHit::Solid(j, h)) = scene.closest_hit(&ray, f32::INFINITY, &mut scratch) {
        prop_assert_eq!(j, 0);
        let surface = scene.solids.surface(&ray, &h);
        prop_assert!(
            surface.point.is_finite()
                && surface.point_error.is_finite()
                && surface.normal.is_finite()
        );
        if let SolidNode::Leaf {
            shape: Shape::Sphere { radius },
            transform,
            ..
        } = node
        {
            // The box of the point's error bound must reach the sphere (exactly, not to first
            // order: a ball smaller than the rounding at its place is all inside that box).
            let c = transform.translation.to_f64();
            let (lo, hi) = (
                (surface.point - surface.point_error).to_f64(),
                (surface.point + surface.point_error).to_f64(),
            );
            let clamp = |v: f64, a: f64, b: f64| v.max(a).min(b);
            let nearest = V64::new(
                clamp(c.x, lo.x, hi.x),
                clamp(c.y, lo.y, hi.y),
                clamp(c.z, lo.z, hi.z),
            );
            let farthest = V64::new(
                if (c.x - lo.x).abs() > (c.x - hi.x).abs() {
                    lo.x
                } else {
                    hi.x
                },
                if (c.y - lo.y).abs() > (c.y - hi.y).abs() {
                    lo.y
                } else {
                    hi.y
                },
                if (c.z - lo.z).abs() > (c.z - hi.z).abs() {
                    lo.z
                } else {
                    hi.z
                },
            );
            let r = f64::from(radius);
            let (near, far) = ((nearest - c).length(), (farthest - c).length());
            prop_assert!(
                near <= r * (1.0 + 1e-9) && far >= r * (1.0 - 1e-9),
                "{:?}: the error box of {:?} is {:e} to {:e} from the centre, the radius {:e}",
                node,
                surface,
                near,
                far,
                r
            );
        } else {
            // Flat faces: the distance along the normal against the bound's extent along it.
            let (dist, n) = surface_distance(&node, h.face as u8, surface.point);
            let bound = n.abs().dot(surface.point_error.to_f64());
            prop_assert!(
                dist.abs() <= bound * (1.0 + 1e-6),
                "{:?}: {:?} is {:e} off the surface, bound {:e}",
                node,
                surface,
                dist,
                bound
            );
        }
        hits.1 = true;
    }
    Ok(hits)
}

/// One case of `reflected_rays_leave_on_the_correct_side`; returns whether a mirror ray was
/// checked for the triangle and for the solid.
fn reflection_case(c: &Placed) -> Result<(bool, bool), TestCaseError> {
    // Triangles: the offset origin lies strictly on the side the ray came from, and the mirror
    // ray from it does not hit the triangle again.
    let mut checked = (false, false);
    let tri = c.triangle();
    let (ray, _) = ray_at_triangle(&tri, c.u, c.v, c.away);
    if let (Some(n), true) = (
        unit_normal(&tri),
        ray.dir != Vec3::ZERO && ray.dir.is_finite(),
    ) {
        if let Some(h) = intersect(&RayFrame::new(&ray), &tri, f32::INFINITY) {
            let (p, err) = hit_point(&tri, h.b);
            let n = if n.dot(ray.dir) > 0.0 { -n } else { n };
            let r = reflect(ray.dir.normalize(), n);
            if r.dot(n) > 0.0 {
                let o = offset_ray_origin(p, err, n, r);
                let q = tri.map(|v| v.to_f64());
                let exact_n = (q[1] - q[0]).cross(q[2] - q[0]);
                let side = |x: Vec3| exact_n.dot(x.to_f64() - q[0]);
                prop_assert!(
                    side(o) * side(ray.origin) > 0.0,
                    "{:?}: offset origin {:?} (from {:?}) is not on the incoming side",
                    tri,
                    o,
                    p
                );
                let again = intersect(&RayFrame::new(&Ray::new(o, r)), &tri, f32::INFINITY);
                prop_assert_eq!(
                    again,
                    None,
                    "{:?}: the mirror ray from {:?} hits it again",
                    tri,
                    o
                );
                checked.0 = true;
            }
        }
    }

    // Convex solids (ball, turned box) hit from outside: the mirror ray's origin is outside and
    // the ray never meets the solid again.
    let (node, scene, ray) = c.solid(2);
    let mut scratch = QueryScratch::default();
    if let Some(PrimitiveHit::Solid(_, h)) = scene.closest_hit(&ray, f32::INFINITY, &mut scratch) {
        let surface = scene.solids.surface(&ray, &h);
        let n = if surface.normal.dot(ray.dir) > 0.0 {
            -surface.normal
        } else {
            surface.normal
        };
        let r = reflect(ray.dir.normalize(), n);
        if r.dot(n) > 0.0 {
            let o = offset_ray_origin(surface.point, surface.point_error, n, r);
            let (dist, _) = surface_distance(&node, h.face as u8, o);
            let outside = match node {
                SolidNode::Leaf {
                    shape: Shape::Sphere { .. },
                    ..
                } => dist > 0.0,
                // Outside a box: beyond at least one face's plane.
                _ => (0..6u8).any(|f| surface_distance(&node, f, o).0 > 0.0),
            };
            prop_assert!(
                outside,
                "{:?}: mirror origin {:?} is inside ({:e})",
                node,
                o,
                dist
            );
            let again = scene.closest_hit(&Ray::new(o, r), f32::INFINITY, &mut scratch);
            prop_assert_eq!(
                again,
                None,
                "{:?}: the mirror ray from {:?} hits it again",
                node,
                o
            );
            checked.1 = true;
        }
    }
    Ok(checked)
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 256,
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    #[test]
    fn octree_equals_brute_force(
        tris in soup(),
        max_depth in 0u32..=20,
        max_leaf_triangles in 1u32..=8,
        rays in prop::collection::vec(ray_parts(), 48),
    ) {
        let params = OctreeParams { max_depth, max_leaf_triangles };
        let tree = Octree::build(&tris, &params);
        for parts in rays {
            let Some(ray) = make_ray(&tris, parts) else { continue };
            let expected = brute_force_closest_hit(&tris, &ray, f32::INFINITY);
            prop_assert_eq!(
                hit_key(tree.closest_hit(&tris, &ray, f32::INFINITY)),
                hit_key(expected),
                "{:?}", ray
            );
            let any = tree.any_hit(&tris, &ray, f32::INFINITY);
            prop_assert_eq!(any, expected.is_some(), "{:?}", ray);
            // Bounded at the hit, nothing is closer.
            if let Some(h) = expected {
                prop_assert_eq!(tree.closest_hit(&tris, &ray, h.tri.t), None);
            }
        }
    }

    #[test]
    fn hit_points_lie_on_the_surface_within_their_error_bound(c in placed()) {
        hit_points_case(&c)?;
    }

    #[test]
    fn reflected_rays_leave_on_the_correct_side(c in placed()) {
        reflection_case(&c)?;
    }
}

#[test]
fn property_tests_are_not_vacuous() {
    // The same checks on 500 fixed random cases, counting how often they had something to check.
    let mut rng = Rng::new(31);
    let (mut hits, mut mirrored) = ((0, 0), (0, 0));
    for _ in 0..500 {
        let c = Placed::random(&mut rng);
        let h = hit_points_case(&c).unwrap_or_else(|e| panic!("{c:?}: {e}"));
        let m = reflection_case(&c).unwrap_or_else(|e| panic!("{c:?}: {e}"));
        hits = (hits.0 + usize::from(h.0), hits.1 + usize::from(h.1));
        mirrored = (mirrored.0 + usize::from(m.0), mirrored.1 + usize::from(m.1));
    }
    assert!(
        hits.0 > 250 && hits.1 > 250,
        "hits (triangle, solid): {hits:?}"
    );
    assert!(
        mirrored.0 > 250 && mirrored.1 > 250,
        "mirror rays (triangle, solid): {mirrored:?}"
    );
    let tris = random_soup(50, &mut rng);
    let tree = Octree::build(&tris, &OctreeParams::default());
    let mut hit = 0;
    for i in 0..500u16 {
        let parts = (
            Vec3::new(
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
                rng.range(-2.0, 2.0),
            ),
            rng.direction(),
            (i % 64) as u8,
            i,
        );
        if let Some(ray) = make_ray(&tris, parts) {
            hit += usize::from(tree.closest_hit(&tris, &ray, f32::INFINITY).is_some());
        }
    }
    assert!(hit > 150, "octree rays that hit: {hit}");
}
