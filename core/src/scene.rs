//! The scene model, as the seed's files describe it, and its prepared form.
//!
//! [`SceneDesc`] is what a loader produces: points, triangles, shaders, lights (seed section 2.6),
//! plus the camera and settings of the configuration file (section 2.5). [`Scene::build`] checks
//! it, computes the smooth vertex normals (area-weighted average of the adjacent faces' normals,
//! seed section 3.2.2.1) and builds the octree. Renderers only ever see a [`Scene`].

use crate::aabb::Aabb;
use crate::camera::{Camera, CameraFrame};
use crate::effects::Effects;
use crate::error::SceneError;
use crate::octree::{Octree, OctreeParams};
use crate::solid::prepared::Solids;
use crate::solid::{SolidNode, MAX_CSG_DEPTH};
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
    /// Reflection-Amount `r`: colour = (1 − r − t)·local + r·reflected + t·refracted.
    pub reflection: f32,
    /// Transparency `t`: the share of colour seen through the surface (0 for the seed's shaders).
    pub transparency: f32,
    /// Index of refraction of the material behind the surface (1 for the seed's shaders).
    pub ior: f32,
}

impl Shader {
    /// An opaque Phong shader with the seed's fields.
    pub fn phong(
        ambient: Vec3,
        diffuse: Vec3,
        specular: Vec3,
        shininess: f32,
        reflection: f32,
    ) -> Self {
        Shader {
            ambient,
            diffuse,
            specular,
            shininess,
            reflection,
            transparency: 0.0,
            ior: 1.0,
        }
    }
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
    /// Indices into [`SceneDesc::normals`] for the corners' shading normals (OBJ `vn`, NFF `pp`);
    /// `None` computes smooth normals from the neighbouring faces, as the seed does.
    pub normals: Option<[u32; 3]>,
}

impl TriangleDesc {
    /// A triangle with computed smooth normals.
    pub fn new(points: [u32; 3], shader: u32) -> Self {
        TriangleDesc {
            points,
            shader,
            normals: None,
        }
    }
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
    /// Refraction rays for transparent shaders (same cut-off and depth cap as reflections).
    pub refractions: bool,
    /// Hard cap on bounces (reflection and refraction together): a mirror with `r = 1` never
    /// falls under the weight limit.
    pub max_depth: u32,
    /// Samples per pixel side: `samples × samples` stratified samples per pixel (1 to
    /// [`MAX_SAMPLES`]).
    pub samples: u32,
    /// Ambient-occlusion level 0 to [`MAX_AMBIENT_OCCLUSION`]: level `n` traces `n × n` occlusion
    /// rays at each shaded point and scales the ambient term by the share that escapes.
    pub ambient_occlusion: u32,
    /// How far an occlusion ray looks; 0 picks a tenth of the scene's bounding-box diagonal.
    pub ao_distance: f32,
    /// Adaptive multisampling: a pixel gets its `samples × samples` rays only if its centre
    /// sample differs from a neighbour's (left, right, above, below) by more than this in some
    /// channel (colours in `[0, 1]`); below 0 (the default) every pixel is supersampled.
    pub aa_threshold: f32,
    /// Leave out rays that cannot change a pixel (the default). Off, the tracer also sends them
    /// and drops their answers: the image must not change by a bit.
    pub skip_effects: bool,
}

/// The most samples per pixel side (`-m`).
pub const MAX_SAMPLES: u32 = 16;

/// The highest ambient-occlusion level (`-a`), as in FART.
pub const MAX_AMBIENT_OCCLUSION: u32 = 9;

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 480,
            background: Vec3::ZERO,
            shadows: true,
            reflections: true,
            min_reflection_weight: 0.1,
            refractions: true,
            max_depth: 16,
            samples: 1,
            ambient_occlusion: 0,
            ao_distance: 0.0,
            aa_threshold: -1.0,
            skip_effects: true,
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
    /// Shading normals that triangles may name ([`TriangleDesc::normals`]).
    pub normals: Vec<Vec3>,
    /// The arena of analytic solids and CSG nodes.
    pub solids: Vec<SolidNode>,
    /// The solids that are scene objects: indices of root nodes in [`SceneDesc::solids`].
    pub objects: Vec<u32>,
    /// Object-space triangles of the closed meshes used as solids ([`SolidNode::Mesh`]).
    pub solid_triangles: Vec<[Vec3; 3]>,
    /// The camera.
    pub camera: Camera,
    /// Image size and switches.
    pub settings: RenderSettings,
}

/// A scene prepared for rendering: validated, with vertex normals, solids and the octree.
///
/// Primitives are numbered triangles first (`0..T`), then solid objects (`T..`); the octree files
/// both, and unbounded solids (half-spaces and what contains them) are tested beside it.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Image size and switches.
    pub settings: RenderSettings,
    /// Shaders, indexed by [`Scene::triangle_shader`] and the solids' leaves.
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
    /// Number of triangles with zero area, in the triangle list and in the meshes of CSG
    /// solids (kept, but never hit).
    pub degenerate_triangles: u32,
    /// The analytic solids and CSG objects.
    pub solids: Solids,
    /// Solid objects with no bounding box (indices into the objects), tested for every ray.
    pub unbounded: Vec<u32>,
    /// The box around every bounded primitive.
    pub bounds: Aabb,
    /// How far occlusion rays look (resolved from [`RenderSettings::ao_distance`]).
    pub ao_distance: f32,
    /// The effects that can change a pixel, derived before rendering.
    pub effects: Effects,
    /// The acceleration structure over triangles and bounded solids.
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
                if let Some(given) = t.normals {
                    // Checked by `validate`: in range and not zero.
                    return given.map(|i| desc.normals[i as usize].normalize_or_zero());
                }
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

        degenerate += desc
            .solid_triangles
            .iter()
            .filter(|p| unit_normal(p).is_none())
            .count() as u32;
        let solids = Solids::new(&desc.solids, &desc.objects, &desc.solid_triangles);
        let unbounded = (0..solids.len() as u32)
            .filter(|&j| solids.bounds()[j as usize].is_none())
            .collect();
        let octree = Octree::build_mixed(&triangle_points, solids.bounds(), params);
        let bounds = octree.bounds();
        let ao_distance = if desc.settings.ao_distance > 0.0 {
            desc.settings.ao_distance
        } else {
            let diagonal = (bounds.max - bounds.min).length();
            if diagonal > 0.0 && diagonal.is_finite() {
                0.1 * diagonal
            } else {
                1.0
            }
        };
        Ok(Scene {
            settings: desc.settings,
            shaders: desc.shaders.clone(),
            lights: desc.lights.clone(),
            camera: CameraFrame::new(&desc.camera, desc.settings.width, desc.settings.height),
            triangle_points,
            triangle_normals,
            triangle_shader: desc.triangles.iter().map(|t| t.shader).collect(),
            degenerate_triangles: degenerate,
            solids,
            unbounded,
            bounds,
            ao_distance,
            effects: Effects::derive(
                &desc.shaders,
                &desc
                    .lights
                    .iter()
                    .map(|l| l.casts_shadows)
                    .collect::<Vec<_>>(),
                &desc.settings,
            ),
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
        if u32::try_from(self.normals.len()).is_err() || u32::try_from(self.solids.len()).is_err() {
            return Err(SceneError::TooLarge);
        }
        let numbers_ok = self.points.iter().all(|&p| finite(p))
            && self.normals.iter().all(|&n| finite(n))
            && self.solid_triangles.iter().flatten().all(|&p| finite(p))
            && self.shaders.iter().all(|sh| {
                finite(sh.ambient)
                    && finite(sh.diffuse)
                    && finite(sh.specular)
                    && sh.shininess.is_finite()
                    && sh.reflection.is_finite()
                    && sh.transparency.is_finite()
                    && sh.ior.is_finite()
            })
            && self
                .lights
                .iter()
                .all(|l| finite(l.position) && finite(l.color) && l.amount.is_finite())
            && finite(s.background)
            && s.min_reflection_weight.is_finite()
            && s.ao_distance.is_finite()
            && s.aa_threshold.is_finite();
        if !numbers_ok {
            return Err(SceneError::NonFiniteNumber);
        }
        if !self.camera.is_valid() {
            return Err(match self.camera {
                Camera::Seed(_) => SceneError::NonFiniteNumber,
                Camera::LookAt(_) => SceneError::BadCamera,
            });
        }
        if s.samples == 0
            || s.samples > MAX_SAMPLES
            || s.ambient_occlusion > MAX_AMBIENT_OCCLUSION
            || s.ao_distance < 0.0
        {
            return Err(SceneError::BadSettings);
        }
        for (i, sh) in self.shaders.iter().enumerate() {
            let unit = |v: f32| (0.0..=1.0).contains(&v);
            if !unit(sh.reflection)
                || !unit(sh.transparency)
                || sh.reflection + sh.transparency > 1.0
                || sh.ior <= 0.0
            {
                return Err(SceneError::BadShader { shader: i as u32 });
            }
        }
        if let Some(i) = self.normals.iter().position(|&n| n == Vec3::ZERO) {
            return Err(SceneError::ZeroNormal { normal: i as u32 });
        }
        self.validate_solids()?;
        for (i, t) in self.triangles.iter().enumerate() {
            if t.points.iter().any(|&p| p as usize >= self.points.len()) {
                return Err(SceneError::PointIndexOutOfRange { triangle: i as u32 });
            }
            if t.shader as usize >= self.shaders.len() {
                return Err(SceneError::ShaderIndexOutOfRange { triangle: i as u32 });
            }
            if let Some(n) = t.normals {
                if n.iter().any(|&k| k as usize >= self.normals.len()) {
                    return Err(SceneError::NormalIndexOutOfRange { triangle: i as u32 });
                }
            }
        }
        Ok(())
    }

    /// Checks the solid arena: parameters, transforms, shaders, operand order and depth.
    fn validate_solids(&self) -> Result<(), SceneError> {
        let mut depth: Vec<u32> = Vec::with_capacity(self.solids.len());
        for (i, node) in self.solids.iter().enumerate() {
            let solid = i as u32;
            let d = match *node {
                SolidNode::Leaf {
                    shape,
                    transform,
                    shader,
                } => {
                    if !shape.is_valid() || !transform.is_valid() {
                        return Err(SceneError::BadSolid { solid });
                    }
                    if shader as usize >= self.shaders.len() {
                        return Err(SceneError::SolidShaderOutOfRange { solid });
                    }
                    0
                }
                SolidNode::Mesh {
                    first,
                    count,
                    transform,
                    shader,
                } => {
                    let end = u64::from(first) + u64::from(count);
                    if count == 0
                        || end > self.solid_triangles.len() as u64
                        || !transform.is_valid()
                    {
                        return Err(SceneError::BadSolid { solid });
                    }
                    if shader as usize >= self.shaders.len() {
                        return Err(SceneError::SolidShaderOutOfRange { solid });
                    }
                    0
                }
                SolidNode::Csg { a, b, .. } => {
                    if a >= solid || b >= solid {
                        return Err(SceneError::SolidIndexOutOfRange { solid });
                    }
                    1 + depth[a as usize].max(depth[b as usize])
                }
            };
            if d > MAX_CSG_DEPTH {
                return Err(SceneError::CsgTooDeep);
            }
            depth.push(d);
        }
        for (i, &root) in self.objects.iter().enumerate() {
            if root as usize >= self.solids.len() {
                return Err(SceneError::SolidIndexOutOfRange { solid: i as u32 });
            }
        }
        Ok(())
    }
}
