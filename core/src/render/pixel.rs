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
    ///
    /// [`quantize_channel`] of each channel, to the bit, with the three channels in vector
    /// lanes (`wide`'s `f32x4`): its maximum with 0 turns NaN into 0 on every target, the
    /// product and sum are the same IEEE operations, and the truncation of a value in
    /// `[0.5, 65535.5]` is exact. Channel by channel, the saturating casts and the NaN and
    /// clamp tests cost about 54 instructions a pixel, a quarter of a background pixel's work
    /// on SPD's tetra (`docs/performance.md`, fifty-second round).
    #[inline]
    pub fn from_color(c: Vec3) -> Self {
        use wide::f32x4;
        let v = f32x4::new([c.x, c.y, c.z, 0.0])
            .max(f32x4::ZERO)
            .min(f32x4::ONE);
        let q = (v * f32x4::splat(65535.0) + f32x4::splat(0.5))
            .fast_trunc_int()
            .to_array();
        Pixel([q[0] as u16, q[1] as u16, q[2] as u16])
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

    /// The lanes give each channel's [`quantize_channel`]: zeros of both signs, NaNs,
    /// infinities, values just inside and outside `[0, 1]`, a sweep of bit patterns and one
    /// over `[−0.1, 1.1]`.
    #[test]
    fn lanes_quantize_as_each_channel_does() {
        let special = [
            0.0,
            -0.0,
            f32::NAN,
            -f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1.0,
            1.0 + f32::EPSILON,
            1.0 - f32::EPSILON / 2.0,
            f32::MIN_POSITIVE,
            f32::from_bits(1),
            -f32::from_bits(1),
            0.5 / 65535.0,
            f32::MAX,
            f32::MIN,
        ];
        let bits = (0..300_000u32).map(|k| f32::from_bits(k.wrapping_mul(14_327)));
        let around = (0..300_000u32).map(|k| k as f32 / 250_000.0 - 0.1);
        let values: alloc::vec::Vec<f32> = special.into_iter().chain(bits).chain(around).collect();
        let mut inside = 0;
        for c in values.chunks_exact(3) {
            let got = Pixel::from_color(Vec3::new(c[0], c[1], c[2])).0;
            assert_eq!(got, [0, 1, 2].map(|k| quantize_channel(c[k])), "{c:?}");
            inside += got.iter().filter(|&&q| q > 0 && q < 65535).count();
        }
        assert!(inside > 150_000, "only {inside} channels strictly inside");
    }
}
