//! A vector's length and its unit vector, as glam makes them to the bit, with the square root of
//! [`super::lanes::sqrt`].
//!
//! glam's own `Vec3::length`, `normalize` and the like take their root from `libm::sqrtf`, whose
//! legacy SSE instruction slows the x86-64-v3 core down (see [`super::lanes`]); the core uses
//! these instead (`core/clippy.toml` refuses glam's). Each does glam's arithmetic in glam's order
//! (its `dot`, one root, one reciprocal, one product per lane), so every result is glam's.

use super::lanes::sqrt;
use glam::Vec3;

/// Length and unit vector of a [`Vec3`] (glam's `length`, `normalize`, `try_normalize`,
/// `normalize_or` and `normalize_or_zero`, to the bit).
pub trait Norm: Sized {
    /// The length.
    fn norm(self) -> f32;
    /// The vector divided by its length (not finite for a zero or non-finite vector).
    fn unit(self) -> Self;
    /// The unit vector, if the reciprocal of the length is finite and above zero.
    fn try_unit(self) -> Option<Self>;
    /// The unit vector, or `fallback` where [`Norm::try_unit`] has none.
    fn unit_or(self, fallback: Self) -> Self;
    /// The unit vector, or zero where [`Norm::try_unit`] has none.
    fn unit_or_zero(self) -> Self;
}

impl Norm for Vec3 {
    #[inline]
    fn norm(self) -> f32 {
        sqrt(self.dot(self))
    }

    #[inline]
    fn unit(self) -> Vec3 {
        self * (1.0 / self.norm())
    }

    #[inline]
    fn try_unit(self) -> Option<Vec3> {
        let rcp = 1.0 / self.norm();
        (rcp.is_finite() && rcp > 0.0).then(|| self * rcp)
    }

    #[inline]
    fn unit_or(self, fallback: Vec3) -> Vec3 {
        self.try_unit().unwrap_or(fallback)
    }

    #[inline]
    fn unit_or_zero(self) -> Vec3 {
        self.unit_or(Vec3::ZERO)
    }
}

#[cfg(test)]
#[allow(clippy::disallowed_methods)] // glam's methods are the reference
mod tests {
    use super::*;

    /// Vectors of every scale, zeros, and non-finite ones: specials, then each component a
    /// sweep of bit patterns (as `lanes.rs`' samples), the three sweeps at different strides.
    fn samples() -> impl Iterator<Item = Vec3> {
        let special = [
            Vec3::ZERO,
            Vec3::new(-0.0, 0.0, -0.0),
            Vec3::new(f32::MIN_POSITIVE, 0.0, 0.0),
            Vec3::new(f32::MAX, f32::MAX, 1.0),
            Vec3::new(f32::INFINITY, 1.0, 0.0),
            Vec3::new(f32::NAN, 1.0, 2.0),
            Vec3::new(1e-30, -1e-30, 1e-30),
        ];
        let random = (0..100_000u32).map(|k| {
            let any = |stride: u32| f32::from_bits(k.wrapping_mul(stride));
            let v = Vec3::new(any(21_467), any(2_654_435_761), any(40_503));
            // Half of them at ordinary scales, where every result is finite.
            if k % 2 == 0 {
                Vec3::new(v.x % 1e3, v.y % 1e3, v.z % 1e3)
            } else {
                v
            }
        });
        special.into_iter().chain(random)
    }

    /// The same bits in every lane, or NaN in both (Rust leaves a NaN's bits to the compiler).
    fn same(a: Vec3, b: Vec3) -> bool {
        (0..3).all(|k| a[k].to_bits() == b[k].to_bits() || (a[k].is_nan() && b[k].is_nan()))
    }

    #[test]
    fn lengths_and_unit_vectors_are_glams_to_the_bit() {
        let mut finite = 0;
        for v in samples() {
            let (norm, length) = (v.norm(), v.length());
            assert!(
                norm.to_bits() == length.to_bits() || norm.is_nan() && length.is_nan(),
                "{v:?}"
            );
            assert!(same(v.unit(), v.normalize()), "{v:?}");
            assert_eq!(v.try_unit().is_some(), v.try_normalize().is_some(), "{v:?}");
            if let (Some(a), Some(b)) = (v.try_unit(), v.try_normalize()) {
                assert!(same(a, b), "{v:?}");
                finite += 1;
            }
            assert!(same(v.unit_or(Vec3::X), v.normalize_or(Vec3::X)), "{v:?}");
            assert!(same(v.unit_or_zero(), v.normalize_or_zero()), "{v:?}");
        }
        assert!(finite > 40_000, "{finite} vectors with a unit vector");
    }
}
