//! Rays and the error-bounded offset of a new ray's origin from the surface it leaves.

use crate::math::float::{next_float_down, next_float_up};
use glam::Vec3;

/// A ray `origin + t · dir`. `dir` need not be normalised; `t` is measured in units of `dir`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Where the ray starts.
    pub origin: Vec3,
    /// Its direction (not necessarily of unit length, never all zero).
    pub dir: Vec3,
}

impl Ray {
    /// A ray from `origin` along `dir`.
    #[inline]
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Ray { origin, dir }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }
}

/// Moves a point `p` with per-axis error bound `p_error` off its surface (geometric normal `n`)
/// to the side that `w` points to, far enough that a ray from there along `w` cannot re-hit the
/// surface it left (pbrt-v4's `OffsetRayOrigin`).
#[inline]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(p_error);
    let mut offset = n * d;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let mut po = p + offset;
    // Round away from p so the offset survives the addition's rounding.
    for axis in 0..3 {
        if offset[axis] > 0.0 {
            po[axis] = next_float_up(po[axis]);
        } else if offset[axis] < 0.0 {
            po[axis] = next_float_down(po[axis]);
        }
    }
    po
}
