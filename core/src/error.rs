//! Errors of the core: small `Copy` enums that say what is wrong, for the host to put a place on.

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
    /// More points or triangles than a `u32` index can address.
    TooLarge,
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
                "the scene has more points or triangles than fit a u32 index"
            ),
        }
    }
}

/// Why `render_line` cannot render the requested line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum RenderError {
    /// The line number is not below the image height.
    LineOutOfRange,
    /// The output buffer's length is not the image width.
    WrongBufferLength,
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::LineOutOfRange => write!(f, "line number is not below the image height"),
            RenderError::WrongBufferLength => {
                write!(f, "pixel buffer length is not the image width")
            }
        }
    }
}

/// Why a message or scene from the wire cannot be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ProtocolError {
    /// The bytes are not a valid message (or scene) of this protocol version.
    Decode,
    /// The message could not be encoded.
    Encode,
    /// A name in a `Hello` is longer than [`crate::protocol::MAX_NAME_LEN`].
    NameTooLong,
    /// A scene chunk is empty, too long, or reaches past the largest scene.
    BadChunk,
    /// A line result's pixel bytes are empty, too many, or not whole pixels.
    BadPixels,
    /// A scene is empty or longer than [`crate::protocol::MAX_SCENE_LEN`].
    SceneTooLarge,
    /// A reassembled scene does not match its digest.
    DigestMismatch,
}

impl fmt::Display for ProtocolError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ProtocolError::Decode => "the bytes are not a valid message of this protocol version",
            ProtocolError::Encode => "the message cannot be encoded",
            ProtocolError::NameTooLong => "a node name is too long",
            ProtocolError::BadChunk => "a scene chunk is empty, too long or out of range",
            ProtocolError::BadPixels => {
                "a line result does not hold whole pixels of the image width"
            }
            ProtocolError::SceneTooLarge => "the scene is empty or larger than the protocol allows",
            ProtocolError::DigestMismatch => "the scene's bytes do not match their digest",
        })
    }
}
