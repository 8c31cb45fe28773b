//! Why a message or scene from the wire cannot be used: a small `Copy` enum.

use core::fmt;

/// Why a message or scene from the wire cannot be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum ProtocolError {
    /// The bytes are not a valid message (or scene) of this protocol version.
    Decode,
    /// The message could not be encoded.
    Encode,
    /// A name in a `Hello` is longer than [`crate::wire::MAX_NAME_LEN`].
    NameTooLong,
    /// A scene chunk is empty, too long, or reaches past the largest scene.
    BadChunk,
    /// A line result's pixel bytes are empty, too many, or not whole pixels.
    BadPixels,
    /// A scene is empty or longer than [`crate::wire::MAX_SCENE_LEN`].
    SceneTooLarge,
    /// A reassembled scene does not match its digest.
    DigestMismatch,
    /// A `RefineLine` mask is empty or longer than [`crate::wire::MAX_MASK_LEN`].
    BadMask,
    /// A `RenderLines` asks for no line or more than [`crate::wire::MAX_LINES_PER_REQUEST`].
    BadRequest,
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
            ProtocolError::BadMask => "a refine request's mask is empty or too long",
            ProtocolError::BadRequest => "a request asks for no line or too many lines",
        })
    }
}

impl core::error::Error for ProtocolError {}
