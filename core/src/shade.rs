//! Phong shading with shadows and reflections (seed sections 1.2.6, 3.2.2.2 and 3.2.3.1).
//!
//! A path starts at a primary ray. At each hit the local colour is
//! `ambient + Σ lights visibility · amount · colour · (diffuse · N·L + specular · max(0, R·V)^shininess)`
//! (a light contributes only where `N·L > 0`), and the surface's colour is
//! `(1 − r) · local + r · reflected`. The reflected ray is traced only while reflections are on
//! and the path weight (product of `r` along it) stays at or above the cut-off, and never past the
//! depth cap; otherwise the surface shows its local colour alone. Because reflection never
//! branches, the path is a loop, not a recursion, and its floating-point order is fixed.

use crate::octree::Hit;
use crate::ray::{offset_ray_origin, Ray};
use crate::scene::Scene;
use crate::triangle::{hit_point, unit_normal};
use glam::Vec3;

/// Rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RayCounts {
    /// Rays from the camera.
    pub primary: u64,
    /// Rays towards lights.
    pub shadow: u64,
    /// Mirror rays.
    pub reflection: u64,
}

impl RayCounts {
    /// All rays together.
    pub fn total(&self) -> u64 {
        self.primary + self.shadow + self.reflection
    }
}

impl core::ops::AddAssign for RayCounts {
    fn add_assign(&mut self, o: RayCounts) {
        self.primary += o.primary;
        self.shadow += o.shadow;
        self.reflection += o.reflection;
    }
}

/// Shadow rays end just short of the light: `t = 1` is the light itself, known to a few roundings.
const SHADOW_T_MAX: f32 = 1.0 - 4.0 * crate::float::MACHINE_EPSILON;

/// The surface at a hit, oriented towards the incoming ray.
struct Surface {
    point: Vec3,
    point_error: Vec3,
    /// Geometric normal, unit length, facing the incoming ray.
    geometric: Vec3,
    /// Smooth shading normal, unit length, on the same side as `geometric`.
    shading: Vec3,
}

fn surface(scene: &Scene, ray: &Ray, hit: &Hit) -> Surface {
    let t = hit.triangle as usize;
    let p = &scene.triangle_points[t];
    let (point, point_error) = hit_point(p, hit.tri.b);
    // Hit triangles are never degenerate (the octree leaves those out); Z only avoids a panic path.
    let mut geometric = unit_normal(p).unwrap_or(Vec3::Z);
    if geometric.dot(ray.dir) > 0.0 {
        geometric = -geometric;
    }
    let n = &scene.triangle_normals[t];
    let b = hit.tri.b;
    let mut shading = (n[0] * b[0] + n[1] * b[1] + n[2] * b[2]).normalize_or_zero();
    if shading == Vec3::ZERO {
        shading = geometric;
    } else if shading.dot(geometric) < 0.0 {
        shading = -shading;
    }
    Surface {
        point,
        point_error,
        geometric,
        shading,
    }
}

/// The local (Phong) colour at a surface seen from direction `view` (unit, towards the eye).
fn local_color(
    scene: &Scene,
    s: &Surface,
    shader: usize,
    view: Vec3,
    counts: &mut RayCounts,
) -> Vec3 {
    let sh = &scene.shaders[shader];
    let mut color = sh.ambient;
    for light in &scene.lights {
        let to_light = light.position - s.point;
        let dist = to_light.length();
        if dist == 0.0 {
            continue;
        }
        let l = to_light / dist;
        let n_dot_l = s.shading.dot(l);
        if n_dot_l <= 0.0 {
            continue;
        }
        if scene.settings.shadows && light.casts_shadows {
            let origin = offset_ray_origin(s.point, s.point_error, s.geometric, to_light);
            let shadow = Ray::new(origin, light.position - origin);
            counts.shadow += 1;
            if scene
                .octree
                .any_hit(&scene.triangle_points, &shadow, SHADOW_T_MAX)
            {
                continue;
            }
        }
        let r = s.shading * (2.0 * n_dot_l) - l;
        let r_dot_v = r.dot(view);
        let spec = if r_dot_v > 0.0 {
            libm::powf(r_dot_v, sh.shininess)
        } else {
            0.0
        };
        let term = sh.diffuse * n_dot_l + sh.specular * spec;
        color += light.color * light.amount * term;
    }
    color
}

/// The colour seen along a primary ray, following its reflections.
pub fn trace(scene: &Scene, primary: Ray, counts: &mut RayCounts) -> Vec3 {
    let settings = &scene.settings;
    let mut ray = primary;
    let mut weight = 1.0f32;
    let mut color = Vec3::ZERO;
    let mut depth = 0u32;
    loop {
        let Some(hit) = scene
            .octree
            .closest_hit(&scene.triangle_points, &ray, f32::INFINITY)
        else {
            color += settings.background * weight;
            return color;
        };
        let s = surface(scene, &ray, &hit);
        let view = -ray.dir.normalize();
        let shader = scene.triangle_shader[hit.triangle as usize] as usize;
        let local = local_color(scene, &s, shader, view, counts);
        let r = scene.shaders[shader].reflection.clamp(0.0, 1.0);
        let next_weight = weight * r;
        let reflect = settings.reflections
            && r > 0.0
            && next_weight >= settings.min_reflection_weight
            && depth < settings.max_reflection_depth;
        if !reflect {
            color += local * weight;
            return color;
        }
        color += local * ((1.0 - r) * weight);
        weight = next_weight;
        depth += 1;
        // Mirror about the shading normal; if that dips under the surface, about the true one.
        let d = -view;
        let mut dir = d - s.shading * (2.0 * d.dot(s.shading));
        if dir.dot(s.geometric) <= 0.0 {
            dir = d - s.geometric * (2.0 * d.dot(s.geometric));
        }
        let origin = offset_ray_origin(s.point, s.point_error, s.geometric, dir);
        ray = Ray::new(origin, dir);
        counts.reflection += 1;
    }
}
