//! The 8-bit formats written row by row: the seed's 24-bit BMP and binary PPM (`P6`), straight
//! from the renderer's 16-bit pixels, one row of 8-bit bytes at a time. An image of any size
//! then needs no 8-bit copy of itself (a third more memory: 3 GiB for 32768 × 32768), and
//! standard output needs no encoded copy. The bytes are those the `image` crate writes for the
//! same pixels (a test holds them together); every value is quantised by [`Pixel::to_rgb8`].

use std::io::{self, Write};
use strahl_core::render::pixel::Pixel;

/// Bytes of a BMP's two headers (file, then `BITMAPINFOHEADER`).
const BMP_HEADERS: u32 = 14 + 40;

/// Writes `pixels` (row-major, top row first, `width × height` of them) as a 24-bit BMP:
/// rows bottom-up, blue-green-red, each padded to a multiple of 4 bytes.
///
/// # Errors
/// An image too large for the format's 32-bit sizes, or the writer's error.
pub fn write_bmp(w: &mut impl Write, width: u32, height: u32, pixels: &[Pixel]) -> io::Result<()> {
    let row = u64::from(width) * 3;
    let padded = row.div_ceil(4) * 4;
    let data = u32::try_from(padded * u64::from(height))
        .ok()
        .filter(|d| d.checked_add(BMP_HEADERS).is_some())
        .ok_or_else(|| io::Error::other("the image is too large for a BMP (4 GiB at most)"))?;
    let dims = |n: u32| i32::try_from(n).map_err(|_| io::Error::other("too wide for a BMP"));
    let mut head = Vec::with_capacity(BMP_HEADERS as usize);
    head.extend_from_slice(b"BM");
    head.extend_from_slice(&(BMP_HEADERS + data).to_le_bytes());
    head.extend_from_slice(&0u32.to_le_bytes());
    head.extend_from_slice(&BMP_HEADERS.to_le_bytes());
    head.extend_from_slice(&40u32.to_le_bytes());
    head.extend_from_slice(&dims(width)?.to_le_bytes());
    head.extend_from_slice(&dims(height)?.to_le_bytes());
    head.extend_from_slice(&1u16.to_le_bytes());
    head.extend_from_slice(&24u16.to_le_bytes());
    head.extend_from_slice(&0u32.to_le_bytes());
    head.extend_from_slice(&data.to_le_bytes());
    // Resolution (pixels per metre), colours used, colours important: none said.
    head.extend_from_slice(&[0u8; 16]);
    w.write_all(&head)?;
    let mut bytes = vec![0u8; padded as usize];
    for y in (0..height as usize).rev() {
        for (out, p) in bytes.chunks_exact_mut(3).zip(line(pixels, width, y)) {
            let [r, g, b] = p.to_rgb8();
            out.copy_from_slice(&[b, g, r]);
        }
        w.write_all(&bytes)?;
    }
    w.flush()
}

/// Writes `pixels` as a binary PPM (`P6`, 8 bits per channel), rows top-down.
///
/// # Errors
/// The writer's error.
pub fn write_ppm(w: &mut impl Write, width: u32, height: u32, pixels: &[Pixel]) -> io::Result<()> {
    write!(w, "P6\n{width} {height} 255\n")?;
    let mut bytes = vec![0u8; width as usize * 3];
    for y in 0..height as usize {
        for (out, p) in bytes.chunks_exact_mut(3).zip(line(pixels, width, y)) {
            out.copy_from_slice(&p.to_rgb8());
        }
        w.write_all(&bytes)?;
    }
    w.flush()
}

/// Row `y` of a `width`-wide image (shorter at the end of a short buffer; callers check the
/// length first).
fn line(pixels: &[Pixel], width: u32, y: usize) -> &[Pixel] {
    let start = (y * width as usize).min(pixels.len());
    &pixels[start..(start + width as usize).min(pixels.len())]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::to_rgb_image;
    use image::codecs::pnm::{PnmEncoder, PnmSubtype, SampleEncoding};

    fn pixels(width: u32, height: u32) -> Vec<Pixel> {
        (0..width * height)
            .map(|i| Pixel([(i * 4099) as u16, (i * 31_337) as u16, (i * 977) as u16]))
            .collect()
    }

    #[test]
    fn bmp_and_ppm_bytes_are_the_image_crates() -> anyhow::Result<()> {
        for (width, height) in [(1, 1), (2, 3), (3, 2), (4, 4), (5, 7), (13, 1)] {
            let px = pixels(width, height);
            let img = image::DynamicImage::ImageRgb8(to_rgb_image(width, height, &px)?);
            let mut theirs = io::Cursor::new(Vec::new());
            img.write_to(&mut theirs, image::ImageFormat::Bmp)?;
            let mut ours = Vec::new();
            write_bmp(&mut ours, width, height, &px)?;
            assert_eq!(ours, theirs.into_inner(), "BMP {width}x{height}");

            let mut theirs = Vec::new();
            img.write_with_encoder(
                PnmEncoder::new(&mut theirs)
                    .with_subtype(PnmSubtype::Pixmap(SampleEncoding::Binary)),
            )?;
            let mut ours = Vec::new();
            write_ppm(&mut ours, width, height, &px)?;
            assert_eq!(ours, theirs, "PPM {width}x{height}");
        }
        Ok(())
    }
}
