//! Why a line cannot be rendered: a small `Copy` enum.

use core::fmt;

/// Why `render_line` cannot render the requested line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum RenderError {
    /// The line number is not below the image height.
    LineOutOfRange,
    /// The output buffer's (or mask's) length does not fit the image width.
    WrongBufferLength,
    /// A second-pass request for a scene without adaptive multisampling.
    NotAdaptive,
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::LineOutOfRange => write!(f, "line number is not below the image height"),
            RenderError::WrongBufferLength => {
                write!(
                    f,
                    "pixel buffer or mask length does not fit the image width"
                )
            }
            RenderError::NotAdaptive => {
                write!(f, "the scene does not use adaptive multisampling")
            }
        }
    }
}

impl core::error::Error for RenderError {}
