//! The scene as loaders describe it: geometry, materials, lights, camera and settings (seed
//! sections 2.5 and 2.6). Nothing here is checked; [`SceneDesc::validate`](super::validate) is.

use super::camera::Camera;
use super::settings::RenderSettings;
use crate::geom::solid::SolidNode;
use alloc::vec::Vec;
use core::ops::RangeInclusive;
use glam::Vec3;
/// The largest image side, in pixels, that a scene accepts.
pub const MAX_IMAGE_SIDE: u32 = 32768;

/// How a surface adds up its local colour and the colours its mirror and refracted rays bring back
/// (`r` is [`Shader::reflection`], `t` [`Shader::transparency`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Blend {
    /// The seed's rule, for its data files, FART scenes and OBJ materials: the shares split the
    /// colour, `(1 − r − t)·local + r·reflected + t·refracted`. The share of a ray that is not
    /// traced (under the cut-off, past the depth cap, its switch off) goes to the local colour.
    #[default]
    Share,
    /// NFF's rule (NFF.TXT: "it is not required that Kd + Ks == 1"), which POV-Ray's
    /// `reflection` and SPD's `.pov` files follow as well: `local + r·reflected + t·refracted`,
    /// the local colour never scaled down. A ray that is not traced adds nothing, as in POV-Ray,
    /// which drops a reflection whose weight is under `adc_bailout`.
    Additive,
}

/// A Phong material (`_SHD`): colours per channel in `[0, 1]`, a shininess exponent, the shares
/// of reflected and transmitted colour and how they add up ([`Blend`]).
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
    /// Reflection-Amount `r`: the weight of the mirror ray's colour. With [`Blend::Share`]
    /// colour = (1 − r − t)·local + r·reflected + t·refracted; with [`Blend::Additive`]
    /// colour = local + r·reflected + t·refracted.
    pub reflection: f32,
    /// Transparency `t`: the weight of the colour seen through the surface (0 for the seed's
    /// shaders).
    pub transparency: f32,
    /// Index of refraction of the material behind the surface (1 for the seed's shaders).
    pub ior: f32,
    /// How the local, reflected and refracted colours add up: [`Blend::Share`] (the seed's rule)
    /// for every format but NFF, whose reader sets [`Blend::Additive`].
    pub blend: Blend,
}

/// The range of a shader's reflection and of its transparency: shares of the colour.
pub const SHARE: RangeInclusive<f32> = 0.0..=1.0;

/// Whether a reflection and a transparency are shares that fit together: each in [`SHARE`], and
/// at most 1 together (with [`Blend::Share`] the rest is the local colour; [`Blend::Additive`]
/// shaders keep the same bound, which the NFF reader checks as `Ks + T <= 1`). Readers check it
/// where they can name the line; [`SceneDesc::validate`] checks it for every scene.
pub fn shares_fit(reflection: f32, transparency: f32) -> bool {
    SHARE.contains(&reflection) && SHARE.contains(&transparency) && reflection + transparency <= 1.0
}

impl Shader {
    /// Whether every colour and number of the shader is finite. A reader checks it where it
    /// can name the line (a colour times a factor may overflow); [`SceneDesc::validate`]
    /// checks it for every scene.
    pub fn is_finite(&self) -> bool {
        [self.ambient, self.diffuse, self.specular]
            .iter()
            .all(|c| c.is_finite())
            && [self.shininess, self.reflection, self.transparency, self.ior]
                .iter()
                .all(|x| x.is_finite())
    }

    /// An opaque Phong shader with the seed's fields and the seed's [`Blend::Share`].
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
            blend: Blend::Share,
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
