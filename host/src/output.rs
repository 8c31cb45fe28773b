//! Image files: 24-bit uncompressed BMP or PNG, written atomically (through
//! [`crate::formats::fs::write_atomically`]).
//!
//! The format follows the file name's extension, case-insensitively: `.bmp` gives a BMP, `.png` a
//! PNG, and anything else is an error. [`check_output_path`] checks the name and the destination
//! folder before any rendering starts, so a bad `-o` fails at once. [`write_image`] writes into a
//! temporary file in the destination folder and renames it over the destination only when the
//! image is complete, so a failed run never leaves a partial or empty image behind.

use crate::formats::fs::{destination_folder, write_atomically};
use anyhow::{bail, Context as _};
use std::path::Path;
use strahl_core::render::pixel::Pixel;

/// The image file formats the renderer writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageKind {
    /// Windows bitmap, 24 bits per pixel, uncompressed.
    Bmp,
    /// Portable Network Graphics, 8 bits per channel RGB.
    Png,
}

impl ImageKind {
    /// The `image` crate's format.
    fn format(self) -> image::ImageFormat {
        match self {
            ImageKind::Bmp => image::ImageFormat::Bmp,
            ImageKind::Png => image::ImageFormat::Png,
        }
    }
}

/// The image format for `path`'s extension.
///
/// # Errors
/// When the extension is neither `.bmp` nor `.png` (in any letter case).
pub fn image_kind(path: &Path) -> anyhow::Result<ImageKind> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("bmp") => Ok(ImageKind::Bmp),
        Some("png") => Ok(ImageKind::Png),
        Some(other) => bail!(
            "{}: unknown image type `.{other}`; the output file name must end in .bmp or .png",
            path.display()
        ),
        None => bail!(
            "{}: the output file name must end in .bmp or .png",
            path.display()
        ),
    }
}

/// Checks, before rendering, that an image can be written to `path`: a known extension, an
/// existing destination folder that takes a new file, and no folder of that name.
///
/// # Errors
/// A message naming the path and what is wrong with it.
pub fn check_output_path(path: &Path) -> anyhow::Result<ImageKind> {
    let kind = image_kind(path)?;
    let dir = destination_folder(path);
    match std::fs::metadata(&dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => bail!(
            "{}: cannot write the image: {} is not a folder",
            path.display(),
            dir.display()
        ),
        Err(e) => bail!(
            "{}: cannot write the image: folder {} does not exist or cannot be read ({e})",
            path.display(),
            dir.display()
        ),
    }
    if path.is_dir() {
        bail!("{}: cannot write the image: it is a folder", path.display());
    }
    // The image is written through a temporary file in the folder: try one now.
    tempfile::Builder::new()
        .prefix(".strahl-")
        .suffix(".tmp")
        .tempfile_in(&dir)
        .map_err(|e| {
            anyhow::anyhow!(
                "{}: cannot write the image: folder {} takes no new file ({e})",
                path.display(),
                dir.display()
            )
        })?;
    Ok(kind)
}

/// Bytes a `width × height` render holds at its peak: the 16-bit pixels the master assembles
/// and the 8-bit copy the image file is written from.
pub fn image_memory(width: u32, height: u32) -> u64 {
    u64::from(width) * u64::from(height) * (6 + 3)
}

/// The 8-bit RGB image of `pixels` (row-major, top row first).
///
/// # Errors
/// When `pixels` does not hold exactly `width × height` pixels.
pub fn to_rgb_image(width: u32, height: u32, pixels: &[Pixel]) -> anyhow::Result<image::RgbImage> {
    let expected = width as usize * height as usize;
    if pixels.len() != expected {
        bail!(
            "cannot write a {width}x{height} image from {} pixels ({expected} expected)",
            pixels.len()
        );
    }
    // Sized once: a large image must not pass through a growing buffer's copies.
    let mut raw: Vec<u8> = Vec::with_capacity(expected * 3);
    for p in pixels {
        raw.extend_from_slice(&p.to_rgb8());
    }
    // The length was checked above, so `from_raw` cannot refuse the buffer.
    image::RgbImage::from_raw(width, height, raw)
        .context("cannot write the image: its pixel buffer does not match its size")
}

/// Writes `pixels` (row-major, top row first) as a `width × height` image to `path`: BMP or PNG
/// by the extension, through a temporary file in the same folder that is renamed into place at
/// the end.
///
/// # Errors
/// A bad extension or folder (see [`check_output_path`]), a pixel count that does not match the
/// size, or any I/O error, each naming `path`. On error no file is left at `path` (an existing
/// file there is left as it was) and the temporary file is removed.
pub fn write_image(path: &Path, width: u32, height: u32, pixels: &[Pixel]) -> anyhow::Result<()> {
    let kind = check_output_path(path)?;
    let img = to_rgb_image(width, height, pixels)?;
    write_atomically(path, |w| {
        img.write_to(w, kind.format())
            .with_context(|| format!("{}: cannot write the image", path.display()))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extensions() {
        assert_eq!(image_kind(Path::new("a.bmp")).ok(), Some(ImageKind::Bmp));
        assert_eq!(image_kind(Path::new("a.BMP")).ok(), Some(ImageKind::Bmp));
        assert_eq!(
            image_kind(Path::new("dir/a.Png")).ok(),
            Some(ImageKind::Png)
        );
        assert!(image_kind(Path::new("a.jpg")).is_err());
        assert!(image_kind(Path::new("a")).is_err());
        assert!(image_kind(Path::new("bmp")).is_err());
    }

    #[test]
    fn writes_bmp_and_png_and_rejects_bad_sizes() -> anyhow::Result<()> {
        let dir = tempfile::tempdir()?;
        let pixels: Vec<Pixel> = (0..6u16).map(|i| Pixel([i * 10000, 65535, 0])).collect();
        for name in ["x.bmp", "x.png"] {
            let path = dir.path().join(name);
            write_image(&path, 3, 2, &pixels)?;
            let img = image::open(&path)?.to_rgb8();
            assert_eq!(img.dimensions(), (3, 2));
            assert_eq!(img.get_pixel(2, 1).0, pixels[5].to_rgb8());
        }
        let bmp = std::fs::read(dir.path().join("x.bmp"))?;
        assert_eq!(&bmp[..2], b"BM");
        assert_eq!(
            u16::from_le_bytes([bmp[28], bmp[29]]),
            24,
            "24 bits per pixel"
        );
        assert_eq!(
            u32::from_le_bytes([bmp[30], bmp[31], bmp[32], bmp[33]]),
            0,
            "uncompressed"
        );

        let bad = dir.path().join("bad.bmp");
        assert!(write_image(&bad, 4, 2, &pixels).is_err());
        assert!(!bad.exists());
        let names: Vec<_> = std::fs::read_dir(dir.path())?.collect::<Result<_, _>>()?;
        assert_eq!(names.len(), 2, "no temporary file is left behind");
        Ok(())
    }

    #[test]
    fn missing_folder_is_named() {
        let msg = match check_output_path(Path::new("/nonexistent-strahl-dir/x.bmp")) {
            Ok(kind) => panic!("accepted as {kind:?}"),
            Err(e) => format!("{e:#}"),
        };
        assert!(msg.contains("/nonexistent-strahl-dir"), "{msg}");
    }
}
