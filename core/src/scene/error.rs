//! Why a scene description cannot be prepared: a small `Copy` enum for the host to put a
//! place on.

use core::fmt;

/// Why a scene description cannot be prepared for rendering.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[non_exhaustive]
pub enum SceneError {
    /// The scene has no shader; the seed requires at least one.
    NoShader,
    /// The scene has no light; the seed requires at least one.
    NoLight,
    /// Triangle `triangle` names a point index that does not exist.
    PointIndexOutOfRange {
        /// Index of the offending triangle.
        triangle: u32,
    },
    /// Triangle `triangle` names a shader index that does not exist.
    ShaderIndexOutOfRange {
        /// Index of the offending triangle.
        triangle: u32,
    },
    /// A number in the scene (point, shader, light or camera) is NaN or infinite.
    NonFiniteNumber,
    /// The image is 0 pixels or larger than [`crate::scene::MAX_IMAGE_SIDE`] on a side.
    BadImageSize,
    /// More points or triangles than a `u32` index can address, or more shaders than
    /// [`MAX_SHADERS`](crate::scene::triangle_shading::MAX_SHADERS).
    TooLarge,
    /// Triangle `triangle` names a shading normal that does not exist.
    NormalIndexOutOfRange {
        /// Index of the offending triangle.
        triangle: u32,
    },
    /// Shading normal `normal` has zero length.
    ZeroNormal {
        /// Index into the scene's normals.
        normal: u32,
    },
    /// Solid node `solid` has a parameter out of range (radius, size, height, plane normal) or a
    /// transform that cannot be inverted.
    BadSolid {
        /// Index of the node.
        solid: u32,
    },
    /// Solid node `solid` names an operand that is not an earlier node, or an object names a
    /// node that does not exist.
    SolidIndexOutOfRange {
        /// Index of the node (or of the object).
        solid: u32,
    },
    /// Solid node `solid` names a shader that does not exist.
    SolidShaderOutOfRange {
        /// Index of the node.
        solid: u32,
    },
    /// CSG nesting deeper than [`crate::geom::solid::MAX_CSG_DEPTH`].
    CsgTooDeep,
    /// The camera looks nowhere: zero view direction, up parallel to it, or a field of view
    /// outside (0°, 180°).
    BadCamera,
    /// A setting is out of its range in [`crate::scene::settings`]: samples per side, ambient
    /// occlusion, bounce cap, adaptive threshold, or an occlusion distance that is not above 0.
    BadSettings,
    /// Shader `shader` has a reflection or transparency outside `[0, 1]`, a sum of both above 1,
    /// or an index of refraction that is not positive.
    BadShader {
        /// Index of the shader.
        shader: u32,
    },
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneError::NoShader => write!(
                f,
                "the scene has no shader (_SHD); at least one is required"
            ),
            SceneError::NoLight => write!(
                f,
                "the scene has no light (_LIGHT); at least one is required"
            ),
            SceneError::PointIndexOutOfRange { triangle } => {
                write!(f, "triangle {triangle} names a point that does not exist")
            }
            SceneError::ShaderIndexOutOfRange { triangle } => {
                write!(f, "triangle {triangle} names a shader that does not exist")
            }
            SceneError::NonFiniteNumber => write!(f, "a number in the scene is NaN or infinite"),
            SceneError::BadImageSize => write!(
                f,
                "the image size must be 1 to {} pixels per side",
                crate::scene::MAX_IMAGE_SIDE
            ),
            SceneError::TooLarge => write!(
                f,
                "the scene has more points or triangles than fit a u32 index, or more than 2^31 \
                 shaders"
            ),
            SceneError::NormalIndexOutOfRange { triangle } => {
                write!(f, "triangle {triangle} names a normal that does not exist")
            }
            SceneError::ZeroNormal { normal } => write!(f, "normal {normal} has zero length"),
            SceneError::BadSolid { solid } => write!(
                f,
                "solid {solid} has a size out of range or a transform that cannot be inverted"
            ),
            SceneError::SolidIndexOutOfRange { solid } => {
                write!(f, "solid {solid} names an operand that is not an earlier solid")
            }
            SceneError::SolidShaderOutOfRange { solid } => {
                write!(f, "solid {solid} names a shader that does not exist")
            }
            SceneError::CsgTooDeep => write!(
                f,
                "CSG is nested deeper than {} levels",
                crate::geom::solid::MAX_CSG_DEPTH
            ),
            SceneError::BadCamera => write!(
                f,
                "the camera has no view direction, an up vector along it, or a field of view outside (0, 180) degrees"
            ),
            SceneError::BadSettings => write!(
                f,
                "samples per side must be 1 to {}, ambient occlusion 0 to {}, the bounce cap 0 to {}, the adaptive threshold 0 to 1, occlusion distance above 0",
                crate::scene::MAX_SAMPLES,
                crate::scene::MAX_AMBIENT_OCCLUSION,
                crate::scene::settings::MAX_BOUNCES
            ),
            SceneError::BadShader { shader } => write!(
                f,
                "shader {shader}: reflection and transparency must lie in [0, 1] with a sum of at most 1, and the index of refraction must be positive"
            ),
        }
    }
}

impl core::error::Error for SceneError {}
