//! Fixed-point pixels and the one place where colours become numbers in an image.
//!
//! `render_line` produces [`Pixel`]s: colours clamped to `[0, 1]` and stored as 16-bit fixed point
//! (the form that travels on the wire). [`Pixel::to_rgb8`] makes the 8-bit channels of the image
//! file. Every code path goes through these two functions, so a local and a distributed render
//! quantise identically.

use glam::Vec3;

/// One pixel: red, green, blue as fixed-point fractions of 65535.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Pixel(pub [u16; 3]);

/// Clamps one colour channel to `[0, 1]` (NaN becomes 0) and rounds it to 16-bit fixed point.
#[inline]
pub fn quantize_channel(c: f32) -> u16 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    // c·65535 + 0.5 lies in [0.5, 65535.5]; truncation rounds half up, identically everywhere.
    (c * 65535.0 + 0.5) as u16
}

impl Pixel {
    /// The pixel for a linear colour; channels outside `[0, 1]` are clamped.
    #[inline]
    pub fn from_color(c: Vec3) -> Self {
        Pixel([
            quantize_channel(c.x),
            quantize_channel(c.y),
            quantize_channel(c.z),
        ])
    }

    /// The 8-bit channels written to the image file (round to nearest).
    #[inline]
    pub fn to_rgb8(self) -> [u8; 3] {
        let q = |v: u16| ((v as u32 * 255 + 32767) / 65535) as u8;
        [q(self.0[0]), q(self.0[1]), q(self.0[2])]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clamps_and_rounds() {
        assert_eq!(
            Pixel::from_color(Vec3::new(-1.0, 2.0, f32::NAN)).0,
            [0, 65535, 0]
        );
        assert_eq!(
            Pixel::from_color(Vec3::new(0.5, 1.0, 0.0)).to_rgb8(),
            [128, 255, 0]
        );
        for v in 0..=255u8 {
            let p = Pixel::from_color(Vec3::splat(v as f32 / 255.0));
            assert_eq!(p.to_rgb8(), [v, v, v]);
        }
    }
}
