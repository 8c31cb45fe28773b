//! Rays and the error-bounded offset of a new ray's origin from the surface it leaves.

use crate::math::float::{next_float_down, next_float_up};
use core::cell::Cell;
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
    offset_to_side(p, p_error, n, below(n, w))
}

/// True where `w` points to the side of the surface that `n` points away from: the side
/// [`offset_ray_origin`] moves to, the only thing it reads of `w`.
#[inline]
fn below(n: Vec3, w: Vec3) -> bool {
    w.dot(n) < 0.0
}

/// [`offset_ray_origin`] to the side `n` points to, or to the other where `below`.
#[inline]
fn offset_to_side(p: Vec3, p_error: Vec3, n: Vec3, below: bool) -> Vec3 {
    let d = n.abs().dot(p_error);
    let mut offset = n * d;
    if below {
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

/// The origins of the rays that leave one surface point: [`offset_ray_origin`] reads a ray's
/// direction only for the side of the surface it points to, so each side's origin is computed
/// once, the first time a ray asks for it, however many rays leave (shadow rays to every light,
/// the mirror and refracted rays).
pub struct LeavingOrigins {
    p: Vec3,
    p_error: Vec3,
    n: Vec3,
    /// The origin on the side `n` points to, then on the other, once asked for.
    sides: [Cell<Option<Vec3>>; 2],
}

impl LeavingOrigins {
    /// The origins around point `p` (error bound `p_error`) of the surface with geometric
    /// normal `n`.
    #[inline]
    pub fn new(p: Vec3, p_error: Vec3, n: Vec3) -> Self {
        LeavingOrigins {
            p,
            p_error,
            n,
            sides: [Cell::new(None), Cell::new(None)],
        }
    }

    /// The origin of a ray leaving along `w`: `offset_ray_origin(p, p_error, n, w)`, to the bit.
    #[inline]
    pub fn towards(&self, w: Vec3) -> Vec3 {
        let side = below(self.n, w);
        let cached = &self.sides[usize::from(side)];
        cached.get().unwrap_or_else(|| {
            let origin = offset_to_side(self.p, self.p_error, self.n, side);
            cached.set(Some(origin));
            origin
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each side's origin, asked in any order and again, is the one `offset_ray_origin` gives,
    /// bit for bit, for directions on either side, in the surface and not numbers.
    #[test]
    fn leaving_origins_are_offset_ray_origins() {
        let mut rng = crate::scene::mesh::Rng::new(11);
        let mut v =
            move || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 200.0 - 100.0;
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        for _ in 0..2_000 {
            let (p, n) = (v(), v());
            let p_error = v().abs() * 1e-6;
            let origins = LeavingOrigins::new(p, p_error, n);
            let in_plane = n.cross(Vec3::X);
            for w in [v(), -n, n, v(), in_plane, Vec3::NAN, -n] {
                let want = offset_ray_origin(p, p_error, n, w);
                assert_eq!(bits(origins.towards(w)), bits(want), "p {p} n {n} w {w}");
            }
            assert_ne!(
                bits(origins.towards(n)),
                bits(origins.towards(-n)),
                "the two sides differ"
            );
        }
    }
}
