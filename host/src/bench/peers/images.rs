//! How far the two images agree: the mean absolute difference of each colour channel (0 to
//! 255), and a side-by-side picture (Strahl left, POV-Ray right, each half at most
//! [`MAX_HALF_WIDTH`] pixels wide) written as PNG.

use anyhow::{bail, Context as _};
use image::{imageops, RgbImage};
use std::io::Write as _;
use std::path::Path;

/// The widest each half of a side-by-side picture is made (larger renders are scaled down).
pub const MAX_HALF_WIDTH: u32 = 256;

/// Reads an image file as 8-bit RGB.
///
/// # Errors
/// If it cannot be read or decoded.
pub fn load_rgb(path: &Path) -> anyhow::Result<RgbImage> {
    Ok(image::open(path)
        .with_context(|| format!("{}: cannot read the image", path.display()))?
        .to_rgb8())
}

/// The mean absolute difference of R, G and B over all pixels, in 0..=255.
///
/// # Errors
/// If the images differ in size.
pub fn mean_abs_diff(a: &RgbImage, b: &RgbImage) -> anyhow::Result<[f64; 3]> {
    if a.dimensions() != b.dimensions() {
        bail!(
            "the images differ in size: {}x{} against {}x{}",
            a.width(),
            a.height(),
            b.width(),
            b.height()
        );
    }
    let mut sum = [0u64; 3];
    for (pa, pb) in a.pixels().zip(b.pixels()) {
        for (c, s) in sum.iter_mut().enumerate() {
            *s += u64::from(pa.0[c].abs_diff(pb.0[c]));
        }
    }
    let n = (u64::from(a.width()) * u64::from(a.height())).max(1) as f64;
    Ok(sum.map(|s| s as f64 / n))
}

/// `img` scaled down (keeping its aspect) to at most [`MAX_HALF_WIDTH`] wide; as it is if it is
/// narrower already.
fn fit(img: &RgbImage) -> RgbImage {
    let (w, h) = img.dimensions();
    if w <= MAX_HALF_WIDTH {
        return img.clone();
    }
    let nh = ((u64::from(h) * u64::from(MAX_HALF_WIDTH)) / u64::from(w)).max(1);
    let nh = u32::try_from(nh).unwrap_or(u32::MAX);
    imageops::resize(img, MAX_HALF_WIDTH, nh, imageops::FilterType::Triangle)
}

/// Strahl's image on the left, POV-Ray's on the right, each scaled to fit.
pub fn side_by_side(strahl: &RgbImage, povray: &RgbImage) -> RgbImage {
    let (l, r) = (fit(strahl), fit(povray));
    let mut out = RgbImage::new(l.width() + r.width(), l.height().max(r.height()));
    imageops::replace(&mut out, &l, 0, 0);
    imageops::replace(&mut out, &r, i64::from(l.width()), 0);
    out
}

/// Writes `img` as PNG to `path` through a temporary file renamed into place.
///
/// # Errors
/// If it cannot be encoded or written.
pub fn write_png(path: &Path, img: &RgbImage) -> anyhow::Result<()> {
    let mut bytes = Vec::new();
    img.write_to(
        &mut std::io::Cursor::new(&mut bytes),
        image::ImageFormat::Png,
    )
    .with_context(|| format!("{}: cannot encode the PNG", path.display()))?;
    crate::formats::fs::write_atomically(path, |w| {
        w.write_all(&bytes)
            .with_context(|| format!("{}: cannot write", path.display()))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn difference_per_channel() {
        let a = RgbImage::from_pixel(2, 2, image::Rgb([10, 20, 30]));
        let mut b = a.clone();
        b.put_pixel(0, 0, image::Rgb([14, 20, 0]));
        let mad = mean_abs_diff(&a, &b).expect("same size");
        assert_eq!(mad, [1.0, 0.0, 7.5]);
        let c = RgbImage::new(3, 2);
        let err = mean_abs_diff(&a, &c).expect_err("sizes differ").to_string();
        assert!(err.contains("2x2 against 3x2"), "{err}");
    }

    #[test]
    fn halves_are_placed_and_scaled() {
        let small_l = RgbImage::from_pixel(24, 24, image::Rgb([255, 0, 0]));
        let small_r = RgbImage::from_pixel(24, 24, image::Rgb([0, 0, 255]));
        let s = side_by_side(&small_l, &small_r);
        assert_eq!(s.dimensions(), (48, 24));
        assert_eq!(s.get_pixel(0, 0).0, [255, 0, 0]);
        assert_eq!(s.get_pixel(47, 23).0, [0, 0, 255]);
        let big = RgbImage::new(512, 384);
        assert_eq!(side_by_side(&big, &big).dimensions(), (512, 192));
    }

    #[test]
    fn writes_a_png_that_reads_back() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("x.png");
        let img = RgbImage::from_pixel(3, 2, image::Rgb([1, 2, 3]));
        write_png(&path, &img).expect("written");
        assert_eq!(load_rgb(&path).expect("read back"), img);
    }
}
