//! Phong shading with shadows, reflection, refraction and ambient occlusion (seed sections 1.2.6,
//! 3.2.2.2 and 3.2.3.1; FART's transparency).
//!
//! A path starts at a primary ray. At each hit the local colour is
//! `ambient · visible + Σ lights visibility · amount · colour · (diffuse · N·L + specular · max(0, R·V)^shininess)`
//! (a light contributes only where `N·L > 0`; `visible` is the share of ambient-occlusion rays that
//! escape, 1 with occlusion off), and the surface's colour follows its shader's [`Blend`]:
//! `(1 − r − t) · local + r · reflected + t · refracted` for the seed's [`Share`](Blend::Share),
//! `local + r · reflected + t · refracted` for NFF's [`Additive`](Blend::Additive). A reflected or
//! refracted ray is traced only while its switch is on, the path weight (product of the shares
//! along it) stays at or above the cut-off, and the depth cap is not reached. A share not traced
//! goes to the local colour under `Share` and adds nothing under `Additive` (as POV-Ray drops a
//! reflection under `adc_bailout`).
//! Total internal reflection sends the refracted share along the mirror ray. Rays that cannot
//! change a pixel are not made: no lighting where the local share is 0 (a perfect `Share`
//! mirror), no shadow ray towards a light behind the surface, no occlusion rays for a shader
//! without ambient colour.
//!
//! [`RenderSettings::skip_effects`](crate::scene::RenderSettings) off turns those shortcuts into
//! rays whose answers are dropped (shadow rays to every light, mirror and refraction rays at every
//! hit, occlusion rays everywhere, all samples of adaptive multisampling), which proves the
//! shortcuts never change a pixel.
//!
//! Branches are kept on an explicit stack and taken in a fixed order, so the floating-point sum of
//! a pixel is the same everywhere. Each pending ray carries the stack of media it is inside (for
//! nested transparent objects), so leaving an inner object returns to the outer one's index.
//! A sample's stack and colour so far are a `RayTree`, which takes each ray's closest hit from
//! its caller: [`trace4`] follows four samples' trees side by side and lets their primary rays,
//! then their next rays (mirror and refracted rays), find their hits together while all four
//! have one. Each tree's rays, hits and sums are the ones it has traced alone. A ray refracted
//! into a glass sphere, or reflected inside one, is marked, and finds its hit from the sphere
//! and its few neighbours where that answers ([`Scene::closest_hit_inside`]).

use crate::accel::octree::{per_lane, LANES};
use crate::geom::triangle::{hit_point, unit_normal};
use crate::math::norm::Norm;
use crate::math::ray::{LeavingOrigins, Ray};
use crate::render::intersect::{PrimitiveHit, QueryScratch, ShadowMemory};
use crate::render::optics::{reflect, refract};
use crate::render::sampling::{hemisphere, mix};
use crate::render::stats::RayCounts;
use crate::scene::effects::{
    highlight_matters, mirror_ray_matters, occlusion_matters, refraction_ray_matters,
    shadow_ray_matters,
};
use crate::scene::{Blend, Scene};
use alloc::vec::Vec;
use glam::{Vec3, Vec3A};

/// Shadow rays run from the surface (`t = 0`) to the light (`t = 1`). `Scene::any_hit` counts a
/// blocker only if it is provably before the light (`t + t_error < 1`), so a surface the light
/// lies on does not shadow it.
const SHADOW_T_MAX: f32 = 1.0;

/// How many nested media a path remembers; deeper nesting forgets the outermost.
const MAX_MEDIA: usize = 4;

/// The transparent objects a ray is inside, innermost last, with their indices of refraction.
#[derive(Clone, Copy, Debug)]
struct Media {
    keys: [u32; MAX_MEDIA],
    iors: [f32; MAX_MEDIA],
    len: usize,
}

impl Media {
    const OUTSIDE: Media = Media {
        keys: [0; MAX_MEDIA],
        iors: [1.0; MAX_MEDIA],
        len: 0,
    };

    /// Index of refraction around the ray (1 outside everything).
    fn current(&self) -> f32 {
        if self.len == 0 {
            1.0
        } else {
            self.iors[self.len - 1]
        }
    }

    fn entered(&self, key: u32, ior: f32) -> Media {
        let mut m = *self;
        if m.len == MAX_MEDIA {
            m.keys.copy_within(1.., 0);
            m.iors.copy_within(1.., 0);
            m.len -= 1;
        }
        m.keys[m.len] = key;
        m.iors[m.len] = ior;
        m.len += 1;
        m
    }

    fn ior_of(&self, key: u32) -> Option<f32> {
        (0..self.len)
            .rev()
            .find(|&i| self.keys[i] == key)
            .map(|i| self.iors[i])
    }

    fn left(&self, key: u32) -> Media {
        let mut m = *self;
        if let Some(i) = (0..m.len).rev().find(|&i| m.keys[i] == key) {
            m.keys.copy_within(i + 1..m.len, i);
            m.iors.copy_within(i + 1..m.len, i);
            m.len -= 1;
        }
        m
    }
}

/// A ray waiting to be traced, with its share of the pixel.
#[derive(Clone, Copy, Debug)]
struct Pending {
    ray: Ray,
    /// The triangle the ray leaves, which it cannot meet again ([`Scene::closest_hits4`]).
    leaving: Option<u32>,
    weight: f32,
    depth: u32,
    media: Media,
    /// The transparent lone sphere the ray starts inside, where its closest hit can be found
    /// without a walk ([`Scene::closest_hit_inside`]).
    inside: Option<u32>,
}

impl Pending {
    /// A primary ray: the whole pixel's share, outside every medium.
    fn primary(ray: Ray) -> Pending {
        Pending {
            ray,
            leaving: None,
            weight: 1.0,
            depth: 0,
            media: Media::OUTSIDE,
            inside: None,
        }
    }

    /// The ray's closest hit: from the sphere it starts inside where that answers, else the
    /// walk's.
    fn closest_hit(&self, scene: &Scene, query: &mut QueryScratch) -> Option<PrimitiveHit> {
        match self
            .inside
            .and_then(|j| scene.closest_hit_inside(j, &self.ray, query))
        {
            Some(hit) => hit,
            None => scene.closest_hit(&self.ray, f32::INFINITY, query),
        }
    }
}

/// Buffers a tracer reuses from ray to ray (one per render thread).
#[derive(Clone, Debug, Default)]
pub struct TraceScratch {
    query: QueryScratch,
    /// The pending rays of the samples traced: four together ([`trace4`]), or the first alone
    /// ([`trace`]).
    packet: [Vec<Pending>; LANES],
    /// Per light, what it remembers of its latest shadow rays (see [`Scene::shadowed`]).
    blockers: Vec<ShadowMemory>,
}

impl TraceScratch {
    /// Makes room for what each light of `scene` remembers of its shadow rays.
    fn prepare(&mut self, scene: &Scene) {
        self.blockers
            .resize(scene.lights.len(), ShadowMemory::default());
    }
}

/// The surface at a hit, oriented towards the incoming ray.
struct Surface {
    point: Vec3,
    /// Geometric normal, unit length, facing the incoming ray.
    geometric: Vec3,
    /// Smooth shading normal, unit length, on the same side as `geometric`. Kept in a SIMD
    /// register's layout: the lighting loop reads it whole, and a 16-byte load of a `Vec3`
    /// written as 8 and 4 bytes waited on the stores (a sixth of `trace4`'s samples on SPD's
    /// teapot, `perf annotate`).
    shading: Vec3A,
    /// True if the ray arrives from the outside (against the outward normal).
    entering: bool,
    /// Shader index.
    shader: usize,
    /// Which transparent object this surface bounds (for nested media).
    medium: u32,
    /// The triangle hit, if a triangle was: a ray leaving its plane cannot meet it again.
    triangle: Option<u32>,
    /// The origins of the rays that leave the surface here, each side's made once.
    origins: LeavingOrigins,
    /// The transparent lone sphere this surface bounds, where rays inside it need no walk.
    sphere: Option<u32>,
}

/// Marks medium keys of triangle meshes (keyed by shader) apart from solids (keyed by object).
const MESH_MEDIUM: u32 = 1 << 31;

fn surface(scene: &Scene, ray: &Ray, hit: &PrimitiveHit) -> Surface {
    match hit {
        PrimitiveHit::Triangle(t, h) => {
            let t = *t as usize;
            let p = &scene.triangle_points[t];
            let (point, point_error) = hit_point(p, h.b);
            // Hit triangles are never degenerate (the octree leaves those out); Z only avoids a
            // panic path.
            let outward = unit_normal(p).unwrap_or(Vec3::Z);
            let entering = outward.dot(ray.dir) <= 0.0;
            let geometric = if entering { outward } else { -outward };
            let shading_of = scene.triangle_shading.get(t);
            // A flat triangle's corners hold `outward`, bit for bit: nothing to load.
            let n = &if shading_of.flat() {
                [outward; 3]
            } else {
                scene.triangle_normals[t]
            };
            let b = h.b;
            let mut shading = (n[0] * b[0] + n[1] * b[1] + n[2] * b[2]).unit_or_zero();
            if shading == Vec3::ZERO {
                shading = geometric;
            } else if shading.dot(geometric) < 0.0 {
                shading = -shading;
            }
            let shader = shading_of.shader();
            Surface {
                point,
                geometric,
                shading: shading.into(),
                entering,
                shader: shader as usize,
                medium: MESH_MEDIUM | shader,
                triangle: Some(t as u32),
                origins: LeavingOrigins::new(point, point_error, geometric),
                sphere: None,
            }
        }
        PrimitiveHit::Solid(object, h) => {
            let s = scene.solids.surface(ray, h);
            let entering = s.normal.dot(ray.dir) <= 0.0;
            let geometric = if entering { s.normal } else { -s.normal };
            Surface {
                point: s.point,
                geometric,
                shading: geometric.into(),
                entering,
                shader: s.shader as usize,
                medium: *object,
                triangle: None,
                origins: LeavingOrigins::new(s.point, s.point_error, geometric),
                sphere: scene.sphere_interiors.holds(*object).then_some(*object),
            }
        }
    }
}

/// The share of occlusion rays from `s` that escape within the scene's occlusion distance.
fn ambient_visibility(
    scene: &Scene,
    s: &Surface,
    seed: u32,
    spans: &mut QueryScratch,
    counts: &mut RayCounts,
) -> f32 {
    let n = scene.settings.ambient_occlusion;
    let total = n * n;
    let mut free = 0u32;
    for k in 0..total {
        let dir = hemisphere(s.shading.into(), seed, k, n);
        if dir.dot(s.geometric) <= 0.0 {
            // Below the true surface: the surface itself occludes it.
            continue;
        }
        let origin = s.origins.towards(dir);
        counts.occlusion += 1;
        if !scene.any_hit(&Ray::new(origin, dir), scene.ao_distance, spans) {
            free += 1;
        }
    }
    free as f32 / total as f32
}

/// The local (Phong) colour at a surface seen from direction `view` (unit, towards the eye).
fn local_color(
    scene: &Scene,
    s: &Surface,
    view: Vec3,
    seed: u32,
    spans: &mut QueryScratch,
    blockers: &mut [ShadowMemory],
    counts: &mut RayCounts,
) -> Vec3 {
    let sh = &scene.shaders[s.shader];
    let settings = &scene.settings;
    let naive = !settings.skip_effects;
    let mut color = sh.ambient;
    if settings.ambient_occlusion > 0 && (occlusion_matters(settings, sh) || naive) {
        color *= ambient_visibility(scene, s, seed, spans, counts);
    }
    for (index, (light, last_blocker)) in scene.lights.iter().zip(blockers.iter_mut()).enumerate() {
        let to_light = light.position - s.point;
        let dist = to_light.norm();
        if dist == 0.0 {
            continue;
        }
        let l = to_light / dist;
        let n_dot_l = s.shading.dot(l.into());
        let casts = shadow_ray_matters(settings, light);
        if naive && !(casts && n_dot_l > 0.0) {
            // Without skipping: the ray a naive tracer sends, whose answer cannot matter.
            let origin = s.origins.towards(to_light);
            counts.shadow += 1;
            let _ = scene.any_hit(
                &Ray::new(origin, light.position - origin),
                SHADOW_T_MAX,
                spans,
            );
        }
        if n_dot_l <= 0.0 {
            continue;
        }
        if casts {
            let origin = s.origins.towards(to_light);
            let shadow = Ray::new(origin, light.position - origin);
            counts.shadow += 1;
            if scene.shadowed(
                &shadow,
                SHADOW_T_MAX,
                spans,
                (Some(index), last_blocker, s.triangle),
            ) {
                continue;
            }
        }
        let r = s.shading * (2.0 * n_dot_l) - Vec3A::from(l);
        let r_dot_v = r.dot(view.into());
        // No highlight without a specular colour (the product would be zero anyway).
        let spec = if r_dot_v > 0.0 && highlight_matters(sh) {
            crate::math::pow::powf(r_dot_v, sh.shininess)
        } else {
            0.0
        };
        let term = sh.diffuse * n_dot_l + sh.specular * spec;
        color += light.color * light.amount * term;
    }
    color
}

/// The direction and media of the ray refracted at `s`, or `None` on total internal reflection.
fn refracted(scene: &Scene, s: &Surface, d: Vec3, media: &Media) -> Option<(Vec3, Media)> {
    let ior = scene.shaders[s.shader].ior;
    let (n1, n2, next) = if s.entering {
        (media.current(), ior, media.entered(s.medium, ior))
    } else {
        let next = media.left(s.medium);
        (media.ior_of(s.medium).unwrap_or(ior), next.current(), next)
    };
    let mut dir = refract(d, s.shading.into(), n1, n2)?;
    if dir.dot(s.geometric) >= 0.0 {
        // The smooth normal bent the ray back out; use the true one.
        dir = refract(d, s.geometric, n1, n2)?;
    }
    Some((dir, next))
}

/// How a hit weighs the path's colour: the mirror ray's share, the refracted ray (direction and
/// the media it enters) with its share, and the local colour's weight.
struct Split {
    mirror_share: f32,
    refraction: Option<(Vec3, Media)>,
    refract_share: f32,
    local_share: f32,
}

/// The colour seen along a primary ray, following its reflections and refractions. `seed`
/// selects the sample pattern of ambient occlusion (see [`crate::render::sampling`]).
pub fn trace(
    scene: &Scene,
    primary: Ray,
    seed: u32,
    scratch: &mut TraceScratch,
    counts: &mut RayCounts,
) -> Vec3 {
    let mut tree = RayTree::start(primary, seed, core::mem::take(&mut scratch.packet[0]));
    scratch.prepare(scene);
    let color = tree.finish(scene, scratch, counts);
    scratch.packet[0] = tree.pending;
    counts.work += core::mem::take(&mut scratch.query.work);
    color
}

/// [`trace`] for four samples (primary ray and occlusion seed: neighbouring pixels', or four of
/// one pixel's), each the colour it gives alone. The four rays find their closest hits together
/// ([`Scene::closest_hits4`]), and so do the next rays of the four ray trees while each has one
/// (a mirror or refracted ray, mostly); the rest are followed one at a time. Four primary rays
/// that hit nothing give the background without any tree. With `beside_tree` the caller knows
/// the primary rays enter no cell that holds a primitive (a clear packet of the camera's
/// cover): their hits are found without a walk.
pub(crate) fn trace4(
    scene: &Scene,
    samples: [(Ray, u32); LANES],
    beside_tree: bool,
    scratch: &mut TraceScratch,
    counts: &mut RayCounts,
) -> [Vec3; LANES] {
    let primaries = per_lane(|l| samples[l].0);
    let query = &mut scratch.query;
    let hits = if beside_tree {
        scene.closest_hits4_beside_tree(&primaries, query)
    } else {
        scene.closest_hits4(&primaries, f32::INFINITY, [None; LANES], query)
    };
    counts.work += core::mem::take(&mut scratch.query.work);
    if hits == [None; LANES] {
        // Four background samples (most of some scenes' pixels): what each tree would gather,
        // its colour (zero) plus its primary ray's miss, without making the trees. Summed as a
        // tree sums it, so a −0 background channel gives +0 here too.
        let mut color = Vec3::ZERO;
        color += missed(scene, 1.0);
        return [color; LANES];
    }
    scratch.prepare(scene);
    let mut trees = per_lane(|l| {
        let pending = core::mem::take(&mut scratch.packet[l]);
        RayTree::empty(samples[l].1, pending)
    });
    for ((tree, hit), ray) in trees.iter_mut().zip(hits).zip(primaries) {
        tree.follow_ray(scene, &Pending::primary(ray), hit, scratch, counts);
    }
    while let [Some(a), Some(b), Some(c), Some(d)] = per_lane(|l| trees[l].pending.last()) {
        let rays = [a.ray, b.ray, c.ray, d.ray];
        let leaving = [a.leaving, b.leaving, c.leaving, d.leaving];
        let query = &mut scratch.query;
        let hits = if [a.inside, b.inside, c.inside, d.inside] == [None; LANES] {
            scene.closest_hits4(&rays, f32::INFINITY, leaving, query)
        } else {
            // Rays inside glass spheres mostly need no walk: each goes alone.
            per_lane(|l| trees[l].pending.last()?.closest_hit(scene, query))
        };
        for (tree, hit) in trees.iter_mut().zip(hits) {
            tree.follow(scene, hit, scratch, counts);
        }
    }
    let colors = per_lane(|l| trees[l].finish(scene, scratch, counts));
    // The buffers taken back in place: moving the trees into an iterator copied all four.
    for (buffer, tree) in scratch.packet.iter_mut().zip(&mut trees) {
        *buffer = core::mem::take(&mut tree.pending);
    }
    counts.work += core::mem::take(&mut scratch.query.work);
    colors
}

/// One sample's rays in progress: the colour gathered so far and the rays still to follow, the
/// next last. Each ray followed adds its local colour and pushes the rays it spawns, so a tree's
/// colour is summed in the same order however its hits were found.
struct RayTree {
    color: Vec3,
    pending: Vec<Pending>,
    /// Surfaces shaded so far (each one's occlusion pattern is `mix(seed, bounce)`).
    bounce: u32,
    seed: u32,
}

impl RayTree {
    /// The tree of `primary`, in the (cleared) buffer `pending`.
    fn start(primary: Ray, seed: u32, pending: Vec<Pending>) -> RayTree {
        let mut tree = RayTree::empty(seed, pending);
        tree.pending.push(Pending::primary(primary));
        tree
    }

    /// A tree with no ray yet, in the (cleared) buffer `pending`: its primary ray is followed by
    /// the caller ([`RayTree::follow_ray`]).
    fn empty(seed: u32, mut pending: Vec<Pending>) -> RayTree {
        pending.clear();
        RayTree {
            color: Vec3::ZERO,
            pending,
            bounce: 0,
            seed,
        }
    }

    /// Follows every ray left, finding each one's closest hit alone; returns the colour.
    fn finish(
        &mut self,
        scene: &Scene,
        scratch: &mut TraceScratch,
        counts: &mut RayCounts,
    ) -> Vec3 {
        while let Some(p) = self.pending.last() {
            let hit = p.closest_hit(scene, &mut scratch.query);
            self.follow(scene, hit, scratch, counts);
        }
        self.color
    }

    /// Follows the next ray, whose closest hit is `hit`: the background where it hits nothing,
    /// else the surface's local colour and the rays it spawns.
    fn follow(
        &mut self,
        scene: &Scene,
        hit: Option<PrimitiveHit>,
        scratch: &mut TraceScratch,
        counts: &mut RayCounts,
    ) {
        if let Some(p) = self.pending.pop() {
            self.follow_ray(scene, &p, hit, scratch, counts);
        }
    }

    /// Follows `p`, whose closest hit is `hit`, as [`RayTree::follow`] does the next ray.
    fn follow_ray(
        &mut self,
        scene: &Scene,
        p: &Pending,
        hit: Option<PrimitiveHit>,
        scratch: &mut TraceScratch,
        counts: &mut RayCounts,
    ) {
        let settings = &scene.settings;
        let Some(hit) = hit else {
            self.color += missed(scene, p.weight);
            return;
        };
        let spans = &mut scratch.query;
        let s = surface(scene, &p.ray, &hit);
        let view = -p.ray.dir.unit();
        let d = -view;
        let split = split(scene, &s, d, p);
        let naive = !settings.skip_effects;
        if split.local_share > 0.0 || naive {
            let blockers = &mut scratch.blockers;
            let seed = mix(self.seed, self.bounce);
            let local = local_color(scene, &s, view, seed, spans, blockers, counts);
            if split.local_share > 0.0 {
                self.color += local * (split.local_share * p.weight);
            }
        }
        self.bounce += 1;
        if naive {
            trace_dropped_branches(scene, &s, d, p, &split, spans, counts);
        }
        push_branches(&s, d, p, split, &mut self.pending, counts);
    }
}

/// The shares of a hit: the mirror ray, unless its share cannot matter; the refracted ray
/// likewise, with total internal reflection adding the refracted share to the mirror ray. The
/// local share is what the traced rays leave for [`Blend::Share`], and always 1 for
/// [`Blend::Additive`] (a ray not traced then adds nothing).
fn split(scene: &Scene, s: &Surface, d: Vec3, p: &Pending) -> Split {
    let settings = &scene.settings;
    let sh = &scene.shaders[s.shader];
    let r = sh.reflection;
    // Validation checks `r + t <= 1` on the rounded sum; the clamp makes `t <= 1 - r` exact.
    let tr = sh.transparency.clamp(0.0, 1.0 - r);
    let mut mirror_share = 0.0f32;
    if mirror_ray_matters(settings, r, p.weight, p.depth) {
        mirror_share = r;
    }
    let mut refraction = None;
    if refraction_ray_matters(settings, tr, p.weight, p.depth) {
        match refracted(scene, s, d, &p.media) {
            Some(t) => refraction = Some(t),
            None => mirror_share += tr,
        }
    }
    let refract_share = if refraction.is_some() { tr } else { 0.0 };
    let local_share = match sh.blend {
        Blend::Share => 1.0 - mirror_share - refract_share,
        Blend::Additive => 1.0,
    };
    Split {
        mirror_share,
        refraction,
        refract_share,
        local_share,
    }
}

/// What a ray carrying `weight` of its sample adds to the sample's colour where it hits nothing:
/// its share of the background.
#[inline]
fn missed(scene: &Scene, weight: f32) -> Vec3 {
    scene.settings.background * weight
}

/// `--skip-effects off`: the mirror and refraction rays [`split`] left out, traced once and their
/// answers dropped, as a naive tracer would send them.
fn trace_dropped_branches(
    scene: &Scene,
    s: &Surface,
    d: Vec3,
    p: &Pending,
    split: &Split,
    spans: &mut QueryScratch,
    counts: &mut RayCounts,
) {
    if split.mirror_share == 0.0 {
        let dir = reflect(d, s.geometric);
        let origin = s.origins.towards(dir);
        counts.reflection += 1;
        let _ = scene.closest_hit(&Ray::new(origin, dir), f32::INFINITY, spans);
    }
    if split.refraction.is_none() {
        if let Some((dir, _)) = refracted(scene, s, d, &p.media) {
            let origin = s.origins.towards(dir);
            counts.refraction += 1;
            let _ = scene.closest_hit(&Ray::new(origin, dir), f32::INFINITY, spans);
        }
    }
}

/// Queues the refracted ray, then the mirror ray, so the mirror ray is traced first.
fn push_branches(
    s: &Surface,
    d: Vec3,
    p: &Pending,
    split: Split,
    pending: &mut Vec<Pending>,
    counts: &mut RayCounts,
) {
    if let Some((dir, media)) = split.refraction {
        let origin = s.origins.towards(dir);
        pending.push(Pending {
            ray: Ray::new(origin, dir),
            leaving: s.triangle,
            weight: p.weight * split.refract_share,
            depth: p.depth + 1,
            media,
            // Refracted in through the surface: inside the sphere.
            inside: s.sphere.filter(|_| s.entering),
        });
        counts.refraction += 1;
    }
    if split.mirror_share > 0.0 {
        // Mirror about the shading normal; if that dips under the surface, about the true one.
        let mut dir = reflect(d, s.shading.into());
        if dir.dot(s.geometric) <= 0.0 {
            dir = reflect(d, s.geometric);
        }
        let origin = s.origins.towards(dir);
        pending.push(Pending {
            ray: Ray::new(origin, dir),
            leaving: s.triangle,
            weight: p.weight * split.mirror_share,
            depth: p.depth + 1,
            media: p.media,
            // Reflected back from inside: still inside.
            inside: s.sphere.filter(|_| !s.entering),
        });
        counts.reflection += 1;
    }
}
