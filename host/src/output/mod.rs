//! Image files: the seed's 24-bit BMP, PNG with 8 or 16 bits per channel, binary PPM and
//! 32-bit float OpenEXR, written atomically (through [`crate::formats::fs::write_atomically`]),
//! or to standard output for `-o -`.
//!
//! The format is `--format`'s, else the file name's extension (case-insensitively); an unknown
//! one is a usage error that lists the formats. [`check_output_path`] checks the name and the
//! destination folder before any rendering starts, so a bad `-o` fails at once. [`write_image`]
//! writes into a temporary file in the destination folder and renames it over the destination
//! only when the image is complete, so a failed run never leaves a partial or empty image
//! behind. BMP and PPM are written row by row ([`rows`]), with no 8-bit copy of the image.
//! Every 8-bit format quantises with [`Pixel::to_rgb8`]; PNG 16 and EXR carry the
//! wire's 16-bit values (clamped to `[0, 1]` by the renderer, so EXR holds no value above 1).

mod rows;

use crate::formats::fs::{
    destination_folder, refuse_to_replace_input, temporary_file_in, write_atomically, write_target,
};
use crate::formats::load::LoadedScene;
use crate::util::usage::usage;
use anyhow::{bail, Context as _};
use std::io::Write as _;
use std::path::Path;
use strahl_core::render::pixel::Pixel;

/// The image file formats the renderer writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageKind {
    /// Windows bitmap, 24 bits per pixel, uncompressed (the seed's).
    Bmp,
    /// Portable Network Graphics, 8 bits per channel RGB.
    Png,
    /// Portable Network Graphics, 16 bits per channel RGB: the wire's pixels as they are.
    Png16,
    /// Binary portable pixmap (P6), 8 bits per channel.
    Ppm,
    /// OpenEXR, 32-bit float RGB.
    Exr,
}

/// Each format's `--format` name, the extension that picks it, and what it is.
pub const FORMATS: [(&str, &str, ImageKind); 5] = [
    ("bmp", "bmp", ImageKind::Bmp),
    ("png", "png", ImageKind::Png),
    ("png16", "png", ImageKind::Png16),
    ("ppm", "ppm", ImageKind::Ppm),
    ("exr", "exr", ImageKind::Exr),
];

/// The formats in words, for messages.
pub const FORMAT_LIST: &str = "bmp (.bmp, the seed's 24-bit BMP), png (.png, 8 bits per \
    channel), png16 (16 bits per channel, --format png16), ppm (.ppm, binary 8-bit), exr (.exr, \
    32-bit float OpenEXR)";

impl ImageKind {
    /// The format `--format NAME` names.
    ///
    /// # Errors
    /// An unknown name, with the list.
    pub fn from_name(name: &str) -> Result<ImageKind, String> {
        FORMATS
            .iter()
            .find(|(n, _, _)| n.eq_ignore_ascii_case(name))
            .map(|&(_, _, kind)| kind)
            .ok_or_else(|| format!("unknown image format `{name}`; Strahl writes {FORMAT_LIST}"))
    }

    /// The format's `--format` name.
    pub fn name(self) -> &'static str {
        FORMATS
            .iter()
            .find(|&&(_, _, kind)| kind == self)
            .map_or("bmp", |&(name, _, _)| name)
    }

    /// The `image` crate's format (BMP and PPM are written by [`rows`] instead).
    fn format(self) -> image::ImageFormat {
        match self {
            ImageKind::Bmp => image::ImageFormat::Bmp,
            ImageKind::Png | ImageKind::Png16 => image::ImageFormat::Png,
            ImageKind::Ppm => image::ImageFormat::Pnm,
            ImageKind::Exr => image::ImageFormat::OpenExr,
        }
    }
}

/// Whether `path` is `-`: standard output.
pub fn is_stdout(path: &Path) -> bool {
    path.as_os_str() == "-"
}

/// The image format for `path`: `format` when given, else the extension's (`-` is BMP unless
/// `format` says otherwise).
///
/// # Errors
/// A usage error when the extension names no format Strahl writes.
pub fn image_kind(path: &Path, format: Option<ImageKind>) -> anyhow::Result<ImageKind> {
    if let Some(kind) = format {
        return Ok(kind);
    }
    if is_stdout(path) {
        return Ok(ImageKind::Bmp);
    }
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let found = FORMATS
        .iter()
        .find(|(_, e, _)| Some(*e) == ext.as_deref())
        .map(|&(_, _, kind)| kind);
    match (found, ext) {
        (Some(kind), _) => Ok(kind),
        (None, Some(other)) => Err(usage(format!(
            "{}: unknown image type `.{other}`; Strahl writes {FORMAT_LIST}",
            path.display()
        ))),
        (None, None) => Err(usage(format!(
            "{}: the output file name has no extension; Strahl writes {FORMAT_LIST} (or give \
             --format)",
            path.display()
        ))),
    }
}

/// Checks, before rendering, that an image can be written to `path`: a known extension, an
/// existing destination folder that takes a new file, and nothing there but a regular file
/// (or a link to one: [`write_target`]).
///
/// # Errors
/// A message naming the path and what is wrong with it.
pub fn check_output_path(path: &Path, format: Option<ImageKind>) -> anyhow::Result<ImageKind> {
    let kind = image_kind(path, format)?;
    if !is_stdout(path) {
        check_destination(path, "the image")?;
    }
    Ok(kind)
}

/// Checks, before anything is rendered, that `what` (a file, for messages: "the image") can be
/// written at `path`: what it would replace ([`write_target`]), that the folder it goes in is
/// there, and that a temporary file can be made in it, as every file is written through one.
///
/// # Errors
/// `path: cannot write WHAT: why`.
pub fn check_destination(path: &Path, what: &str) -> anyhow::Result<()> {
    let cannot = |why: &dyn std::fmt::Display| {
        anyhow::anyhow!("{}: cannot write {what}: {why}", path.display())
    };
    let target = write_target(path).map_err(|why| cannot(&why))?;
    let dir = destination_folder(&target);
    match std::fs::metadata(&dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(cannot(&format_args!("{} is not a folder", dir.display()))),
        Err(e) => {
            let why = format!(
                "folder {} does not exist or cannot be read ({e})",
                dir.display()
            );
            return Err(cannot(&why));
        }
    }
    temporary_file_in(&dir).map_err(|why| cannot(&why))?;
    Ok(())
}

/// [`check_output_path`] for the image of `loaded`, which must not replace a file the scene was
/// loaded from ([`refuse_to_replace_input`]).
///
/// # Errors
/// As [`check_output_path`], and the input the image would replace.
pub fn check_scene_output(
    loaded: &LoadedScene,
    format: Option<ImageKind>,
) -> anyhow::Result<ImageKind> {
    let kind = check_output_path(&loaded.output, format)?;
    if !is_stdout(&loaded.output) {
        refuse_to_replace_input(&loaded.output, &loaded.inputs, "the image")?;
    }
    Ok(kind)
}

/// Bytes a `width × height` render written as `kind` holds at its peak: the 16-bit pixels the
/// master assembles (6 a pixel), and the copy the `image` crate encodes from (3 a pixel for
/// PNG, 6 for PNG 16, 12 for EXR; none for BMP and PPM, written row by row by [`rows`]).
pub fn image_memory(kind: ImageKind, width: u32, height: u32) -> u64 {
    let copy = match kind {
        ImageKind::Bmp | ImageKind::Ppm => 0,
        ImageKind::Png => 3,
        ImageKind::Png16 => 6,
        ImageKind::Exr => 12,
    };
    u64::from(width) * u64::from(height) * (6 + copy)
}

/// The 8-bit RGB image of `pixels` (row-major, top row first).
///
/// # Errors
/// When `pixels` does not hold exactly `width × height` pixels.
pub fn to_rgb_image(width: u32, height: u32, pixels: &[Pixel]) -> anyhow::Result<image::RgbImage> {
    check_pixel_count(width, height, pixels)?;
    let expected = width as usize * height as usize;
    // Sized once: a large image must not pass through a growing buffer's copies.
    let mut raw: Vec<u8> = Vec::with_capacity(expected * 3);
    for p in pixels {
        raw.extend_from_slice(&p.to_rgb8());
    }
    // The length was checked above, so `from_raw` cannot refuse the buffer.
    image::RgbImage::from_raw(width, height, raw)
        .context("cannot write the image: its pixel buffer does not match its size")
}

/// Writes `pixels` (row-major, top row first) as a `width × height` image of `kind` to `path`
/// (`-`: standard output), through a temporary file in the same folder that is renamed into
/// place at the end.
///
/// # Errors
/// A bad folder (see [`check_output_path`]), a pixel count that does not match the size, or
/// any I/O error, each naming `path`. On error no file is left at `path` (an existing file
/// there is left as it was) and the temporary file is removed.
pub fn write_image(
    path: &Path,
    kind: ImageKind,
    width: u32,
    height: u32,
    pixels: &[Pixel],
) -> anyhow::Result<()> {
    check_output_path(path, Some(kind))?;
    check_pixel_count(width, height, pixels)?;
    let failed = |e| anyhow::anyhow!("{}: cannot write the image: {e}", path.display());
    if is_stdout(path) {
        return write_stdout(kind, width, height, pixels)
            .context("cannot write the image to standard output");
    }
    write_atomically(path, |w| {
        encode(kind, width, height, pixels, w).map_err(|e| failed(format!("{e:#}")))
    })
}

/// Writes the image to standard output: BMP and PPM row by row, the others encoded first (the
/// `image` crate's encoders want to seek).
fn write_stdout(kind: ImageKind, width: u32, height: u32, pixels: &[Pixel]) -> anyhow::Result<()> {
    let mut out = std::io::BufWriter::new(std::io::stdout().lock());
    match kind {
        ImageKind::Bmp => rows::write_bmp(&mut out, width, height, pixels)?,
        ImageKind::Ppm => rows::write_ppm(&mut out, width, height, pixels)?,
        _ => {
            let mut bytes = std::io::Cursor::new(Vec::new());
            encode(kind, width, height, pixels, &mut bytes)?;
            out.write_all(bytes.get_ref())?;
            out.flush()?;
        }
    }
    Ok(())
}

/// Writes the image to `w`: BMP and PPM row by row ([`rows`]), the others through the `image`
/// crate.
fn encode(
    kind: ImageKind,
    width: u32,
    height: u32,
    pixels: &[Pixel],
    w: &mut (impl std::io::Write + std::io::Seek),
) -> anyhow::Result<()> {
    match kind {
        ImageKind::Bmp => rows::write_bmp(w, width, height, pixels)?,
        ImageKind::Ppm => rows::write_ppm(w, width, height, pixels)?,
        _ => encode_image(kind, width, height, pixels)?.write_to(w, kind.format())?,
    }
    Ok(())
}

/// Fails unless `pixels` holds exactly `width × height` pixels.
fn check_pixel_count(width: u32, height: u32, pixels: &[Pixel]) -> anyhow::Result<()> {
    let expected = width as usize * height as usize;
    if pixels.len() != expected {
        bail!(
            "cannot write a {width}x{height} image from {} pixels ({expected} expected)",
            pixels.len()
        );
    }
    Ok(())
}

/// The `image` crate's image of `pixels` in the precision `kind` keeps.
fn encode_image(
    kind: ImageKind,
    width: u32,
    height: u32,
    pixels: &[Pixel],
) -> anyhow::Result<image::DynamicImage> {
    check_pixel_count(width, height, pixels)?;
    let mismatch =
        || anyhow::anyhow!("cannot write the image: its pixel buffer does not match its size");
    Ok(match kind {
        ImageKind::Bmp | ImageKind::Png | ImageKind::Ppm => {
            image::DynamicImage::ImageRgb8(to_rgb_image(width, height, pixels)?)
        }
        ImageKind::Png16 => {
            let raw: Vec<u16> = pixels.iter().flat_map(|p| p.0).collect();
            let img = image::ImageBuffer::from_raw(width, height, raw).ok_or_else(mismatch)?;
            image::DynamicImage::ImageRgb16(img)
        }
        ImageKind::Exr => {
            let raw: Vec<f32> = pixels
                .iter()
                .flat_map(|p| p.0.map(|c| f32::from(c) / 65535.0))
                .collect();
            let img = image::ImageBuffer::from_raw(width, height, raw).ok_or_else(mismatch)?;
            image::DynamicImage::ImageRgb32F(img)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn extensions() {
        let kind = |p: &str| image_kind(Path::new(p), None).ok();
        assert_eq!(kind("a.bmp"), Some(ImageKind::Bmp));
        assert_eq!(kind("a.BMP"), Some(ImageKind::Bmp));
        assert_eq!(kind("dir/a.Png"), Some(ImageKind::Png));
        assert_eq!(kind("a.ppm"), Some(ImageKind::Ppm));
        assert_eq!(kind("a.exr"), Some(ImageKind::Exr));
        assert_eq!(kind("-"), Some(ImageKind::Bmp));
        assert_eq!(
            image_kind(Path::new("a.png"), Some(ImageKind::Png16)).ok(),
            Some(ImageKind::Png16)
        );
        for bad in ["a.jpg", "a", "bmp"] {
            let e = image_kind(Path::new(bad), None).expect_err(bad);
            assert!(
                e.is::<crate::util::usage::UsageError>(),
                "{bad}: a usage error"
            );
            assert!(e.to_string().contains("png16"), "{e}");
        }
        assert_eq!(ImageKind::from_name("PNG16"), Ok(ImageKind::Png16));
        assert!(ImageKind::from_name("jpeg").is_err());
    }

    #[test]
    fn writes_bmp_and_png_and_rejects_bad_sizes() -> anyhow::Result<()> {
        let dir = tempfile::tempdir()?;
        let pixels: Vec<Pixel> = (0..6u16).map(|i| Pixel([i * 10000, 65535, 0])).collect();
        for name in ["x.bmp", "x.png", "x.ppm"] {
            let path = dir.path().join(name);
            write_image(&path, image_kind(&path, None)?, 3, 2, &pixels)?;
            let img = image::open(&path)?.to_rgb8();
            assert_eq!(img.dimensions(), (3, 2));
            assert_eq!(img.get_pixel(2, 1).0, pixels[5].to_rgb8());
        }
        let deep = dir.path().join("deep.png");
        write_image(&deep, ImageKind::Png16, 3, 2, &pixels)?;
        let img = image::open(&deep)?.to_rgb16();
        assert_eq!(img.get_pixel(2, 1).0, pixels[5].0, "16 bits kept");
        let hdr = dir.path().join("x.exr");
        write_image(&hdr, ImageKind::Exr, 3, 2, &pixels)?;
        let img = image::open(&hdr)?.to_rgb32f();
        assert_eq!(img.get_pixel(1, 0).0, [10000.0 / 65535.0, 1.0, 0.0]);
        let ppm = std::fs::read(dir.path().join("x.ppm"))?;
        assert!(ppm.starts_with(b"P6\n3 2 255\n"), "binary PPM");
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
        assert!(write_image(&bad, ImageKind::Bmp, 4, 2, &pixels).is_err());
        assert!(!bad.exists());
        let names: Vec<_> = std::fs::read_dir(dir.path())?.collect::<Result<_, _>>()?;
        assert_eq!(names.len(), 5, "no temporary file is left behind");
        Ok(())
    }

    #[test]
    fn missing_folder_is_named() {
        let msg = match check_output_path(Path::new("/nonexistent-strahl-dir/x.bmp"), None) {
            Ok(kind) => panic!("accepted as {kind:?}"),
            Err(e) => format!("{e:#}"),
        };
        assert!(msg.contains("/nonexistent-strahl-dir"), "{msg}");
    }
}
