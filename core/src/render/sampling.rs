//! Deterministic sample patterns: sub-pixel positions for multisampling and hemisphere directions
//! for ambient occlusion.
//!
//! Every pattern is a pure function of integers (pixel, sample, level) through an integer hash, so
//! a pixel gets the same samples on every worker, transport and machine, and distributed renders
//! stay byte-identical. Patterns are stratified: an `m × m` grid of cells, one jittered sample per
//! cell.

use crate::math::lanes::sqrt;
use glam::Vec3;

/// A 32-bit integer hash with good avalanche (the "lowbias32" finaliser by Chris Wellons).
#[inline]
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^= x >> 16;
    x
}

/// Combines a seed with one more integer.
#[inline]
pub fn mix(seed: u32, v: u32) -> u32 {
    hash32(seed ^ hash32(v.wrapping_add(0x9e37_79b9)))
}

/// A number in `[0, 1)` from 24 bits of `h` (exact in `f32`).
#[inline]
pub fn unit(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The seed of pixel `(x, y)`.
#[inline]
pub fn pixel_seed(x: u32, y: u32) -> u32 {
    mix(hash32(x), y)
}

/// Offset inside the pixel, each coordinate in `[0, 1)`, of sample `k` of `m × m` (row-major
/// cells). With `m = 1` it is the pixel centre, as the seed renders.
#[inline]
pub fn pixel_sample(seed: u32, k: u32, m: u32) -> (f32, f32) {
    if m <= 1 {
        return (0.5, 0.5);
    }
    let (cx, cy) = (k % m, k / m);
    let h = mix(seed, k);
    let jx = unit(h);
    let jy = unit(hash32(h));
    let inv = 1.0 / m as f32;
    ((cx as f32 + jx) * inv, (cy as f32 + jy) * inv)
}

/// Direction `k` of `n × n` stratified, cosine-weighted directions on the hemisphere around the
/// unit normal `normal`, jittered by `seed`.
pub fn hemisphere(normal: Vec3, seed: u32, k: u32, n: u32) -> Vec3 {
    let h = mix(seed, k);
    let u1 = ((k % n) as f32 + unit(h)) / n as f32;
    let u2 = ((k / n) as f32 + unit(hash32(h))) / n as f32;
    let r = sqrt(u1);
    let phi = 2.0 * core::f32::consts::PI * u2;
    let local = Vec3::new(
        r * libm::cosf(phi),
        r * libm::sinf(phi),
        sqrt((1.0 - u1).max(0.0)),
    );
    let (t, b) = basis(normal);
    t * local.x + b * local.y + normal * local.z
}

/// Two unit tangents completing `n` to an orthonormal basis (Duff et al. 2017, branch on sign).
#[inline]
fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = if n.z >= 0.0 { 1.0 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::norm::Norm;

    #[test]
    fn one_sample_is_the_pixel_centre_and_m_samples_fill_their_cells() {
        assert_eq!(pixel_sample(7, 0, 1), (0.5, 0.5));
        for k in 0..9 {
            let (x, y) = pixel_sample(pixel_seed(3, 4), k, 3);
            assert_eq!(((x * 3.0) as u32, (y * 3.0) as u32), (k % 3, k / 3));
        }
    }

    #[test]
    fn hemisphere_directions_are_unit_and_above_the_surface() {
        for n in [Vec3::Z, Vec3::NEG_Z, Vec3::new(0.6, 0.0, 0.8), Vec3::NEG_Y] {
            for k in 0..16 {
                let d = hemisphere(n, 99, k, 4);
                assert!((d.norm() - 1.0).abs() < 1e-5, "{d:?}");
                assert!(d.dot(n) >= 0.0, "{d:?} below {n:?}");
            }
        }
    }
}
