//! The scene model, as the seed's files describe it, and its prepared form.
//!
//! [`SceneDesc`] is what a loader produces: points, triangles, shaders, lights (seed section 2.6),
//! plus the camera and settings of the configuration file (section 2.5). [`Scene::build`] checks
//! it, computes the smooth vertex normals (area-weighted average of the adjacent faces' normals,
//! seed section 3.2.2.1) and builds the octree. Renderers only ever see a [`Scene`].

use crate::camera::{Camera, CameraFrame};
use crate::error::SceneError;
use crate::octree::{Octree, OctreeParams};
use crate::triangle::{area_normal, unit_normal};
use alloc::vec::Vec;
use glam::Vec3;

/// The largest image side, in pixels, that a scene accepts.
pub const MAX_IMAGE_SIDE: u32 = 32768;

/// A Phong material (`_SHD`): colours per channel in `[0, 1]`, a shininess exponent and the share
/// of reflected colour.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Shader {
    /// Ambient colour, added regardless of lights.
    pub ambient: Vec3,
    /// Diffuse colour, scaled by `max(0, N·L)`.
    pub diffuse: Vec3,
    /// Specular colour, scaled by `max(0, R·V)^shininess`.
    pub specular: Vec3,
    /// Phong exponent.
    pub shininess: f32,
    /// Reflection-Amount `r`: colour = (1 − r)·local + r·reflected.
    pub reflection: f32,
}

/// A point light (`_LIGHT`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Light {
    /// Position.
    pub position: Vec3,
    /// Colour.
    pub color: Vec3,
    /// Intensity factor ("Amount").
    pub amount: f32,
    /// Whether the light casts shadows (ShadowCasting flag).
    pub casts_shadows: bool,
}

/// A triangle (`_TR`): three point indices and a shader index, all 0-based.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct TriangleDesc {
    /// Indices into [`SceneDesc::points`].
    pub points: [u32; 3],
    /// Index into [`SceneDesc::shaders`].
    pub shader: u32,
}

/// Global render settings (the configuration file's switches and image size).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RenderSettings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Colour of rays that hit nothing.
    pub background: Vec3,
    /// `$SHADOWS`: shadow rays for shadow-casting lights.
    pub shadows: bool,
    /// `$REFLECTIONS`: reflection rays for reflective shaders.
    pub reflections: bool,
    /// A reflection is traced only while the path weight (product of the reflection amounts along
    /// it) stays at or above this; the seed's value is 10%.
    pub min_reflection_weight: f32,
    /// Hard cap on reflection bounces: a mirror with `r = 1` never falls under the weight limit.
    pub max_reflection_depth: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 480,
            background: Vec3::ZERO,
            shadows: true,
            reflections: true,
            min_reflection_weight: 0.1,
            max_reflection_depth: 16,
        }
    }
}

/// A scene as loaded from files: geometry, materials, lights, camera and settings.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SceneDesc {
    /// Vertex positions (`_PT`).
    pub points: Vec<Vec3>,
    /// Triangles (`_TR`).
    pub triangles: Vec<TriangleDesc>,
    /// Shaders (`_SHD`).
    pub shaders: Vec<Shader>,
    /// Lights (`_LIGHT`).
    pub lights: Vec<Light>,
    /// The camera.
    pub camera: Camera,
    /// Image size and switches.
    pub settings: RenderSettings,
}

/// A scene prepared for rendering: validated, with vertex normals and the octree.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Image size and switches.
    pub settings: RenderSettings,
    /// Shaders, indexed by [`Scene::triangle_shader`].
    pub shaders: Vec<Shader>,
    /// Lights.
    pub lights: Vec<Light>,
    /// The camera's frame for the image size.
    pub camera: CameraFrame,
    /// Vertex positions of each triangle, by triangle index.
    pub triangle_points: Vec<[Vec3; 3]>,
    /// Smooth normal at each corner of each triangle, by triangle index (unit length).
    pub triangle_normals: Vec<[Vec3; 3]>,
    /// Shader index of each triangle.
    pub triangle_shader: Vec<u32>,
    /// Number of triangles with zero area (kept, but never hit).
    pub degenerate_triangles: u32,
    /// The acceleration structure over the triangles.
    pub octree: Octree,
}

fn finite(v: Vec3) -> bool {
    v.x.is_finite() && v.y.is_finite() && v.z.is_finite()
}

impl Scene {
    /// Validates `desc`, computes smooth vertex normals and builds the octree with `params`.
    ///
    /// # Errors
    /// A [`SceneError`] for a missing shader or light, an index out of range, a non-finite number,
    /// a bad image size, or more elements than `u32` indices address.
    pub fn build(desc: &SceneDesc, params: &OctreeParams) -> Result<Scene, SceneError> {
        desc.validate()?;
        let n_points = desc.points.len();
        let triangle_points: Vec<[Vec3; 3]> = desc
            .triangles
            .iter()
            .map(|t| t.points.map(|i| desc.points[i as usize]))
            .collect();

        // Area-weighted vertex normals: the unnormalised face normal has length 2·area.
        let mut point_normals = alloc::vec![Vec3::ZERO; n_points];
        let mut degenerate = 0u32;
        let mut face_normals = Vec::with_capacity(triangle_points.len());
        for (t, p) in desc.triangles.iter().zip(&triangle_points) {
            let unit = unit_normal(p);
            match unit {
                None => degenerate += 1,
                Some(_) => {
                    let n = area_normal(p);
                    for &i in &t.points {
                        point_normals[i as usize] += n;
                    }
                }
            }
            face_normals.push(unit.unwrap_or(Vec3::ZERO));
        }
        let triangle_normals = desc
            .triangles
            .iter()
            .zip(&face_normals)
            .map(|(t, &face)| {
                t.points.map(|i| {
                    let n = point_normals[i as usize].normalize_or_zero();
                    // A corner whose neighbours cancel out falls back to the face normal.
                    if n == Vec3::ZERO {
                        face
                    } else {
                        n
                    }
                })
            })
            .collect();

        let octree = Octree::build(&triangle_points, params);
        Ok(Scene {
            settings: desc.settings,
            shaders: desc.shaders.clone(),
            lights: desc.lights.clone(),
            camera: CameraFrame::new(&desc.camera, desc.settings.width, desc.settings.height),
            triangle_points,
            triangle_normals,
            triangle_shader: desc.triangles.iter().map(|t| t.shader).collect(),
            degenerate_triangles: degenerate,
            octree,
        })
    }
}

impl SceneDesc {
    /// Checks the rules the seed states and every index and number.
    ///
    /// # Errors
    /// The first [`SceneError`] found.
    pub fn validate(&self) -> Result<(), SceneError> {
        let s = &self.settings;
        if s.width == 0 || s.height == 0 || s.width > MAX_IMAGE_SIDE || s.height > MAX_IMAGE_SIDE {
            return Err(SceneError::BadImageSize);
        }
        if self.shaders.is_empty() {
            return Err(SceneError::NoShader);
        }
        if self.lights.is_empty() {
            return Err(SceneError::NoLight);
        }
        if u32::try_from(self.points.len()).is_err() || u32::try_from(self.triangles.len()).is_err()
        {
            return Err(SceneError::TooLarge);
        }
        let cam = &self.camera;
        let numbers_ok = self.points.iter().all(|&p| finite(p))
            && self.shaders.iter().all(|sh| {
                finite(sh.ambient)
                    && finite(sh.diffuse)
                    && finite(sh.specular)
                    && sh.shininess.is_finite()
                    && sh.reflection.is_finite()
            })
            && self
                .lights
                .iter()
                .all(|l| finite(l.position) && finite(l.color) && l.amount.is_finite())
            && finite(cam.position)
            && cam.angle_x_deg.is_finite()
            && cam.angle_z_deg.is_finite()
            && cam.zoom.is_finite()
            && finite(s.background)
            && s.min_reflection_weight.is_finite();
        if !numbers_ok {
            return Err(SceneError::NonFiniteNumber);
        }
        for (i, t) in self.triangles.iter().enumerate() {
            if t.points.iter().any(|&p| p as usize >= self.points.len()) {
                return Err(SceneError::PointIndexOutOfRange { triangle: i as u32 });
            }
            if t.shader as usize >= self.shaders.len() {
                return Err(SceneError::ShaderIndexOutOfRange { triangle: i as u32 });
            }
        }
        Ok(())
    }
}
