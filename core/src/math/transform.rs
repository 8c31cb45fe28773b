//! Affine transforms that place an analytic shape in the world.
//!
//! A [`Transform`] maps object space to world space: `world = matrix · object + translation`.
//! Loaders build it from `translate`, `rotate` and `scale` steps; the renderer keeps it together
//! with its inverse ([`Placement`]) so rays go into object space and hits and normals come back out.
//! All products use glam's scalar `Mat3`/`Vec3`, so every machine rounds them identically.

use super::norm::Norm;
use crate::math::float::gamma;
use glam::{Mat3, Vec3, Vec4};

/// An affine map from object space to world space.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Transform {
    /// The linear part (rotation, scale, shear).
    pub matrix: Mat3,
    /// Where the object's origin lands.
    pub translation: Vec3,
}

impl Default for Transform {
    fn default() -> Self {
        Transform::IDENTITY
    }
}

impl Transform {
    /// Leaves everything where it is.
    pub const IDENTITY: Transform = Transform {
        matrix: Mat3::IDENTITY,
        translation: Vec3::ZERO,
    };

    /// A move by `v`.
    pub fn translate(v: Vec3) -> Transform {
        Transform {
            matrix: Mat3::IDENTITY,
            translation: v,
        }
    }

    /// A scale by `s` per axis.
    pub fn scale(s: Vec3) -> Transform {
        Transform {
            matrix: Mat3::from_diagonal(s),
            translation: Vec3::ZERO,
        }
    }

    /// Rotations about X, then Y, then Z, by the given angles in degrees (right-handed).
    pub fn rotate_xyz_deg(angles: Vec3) -> Transform {
        let r = Mat3::from_rotation_z(angles.z.to_radians())
            * Mat3::from_rotation_y(angles.y.to_radians())
            * Mat3::from_rotation_x(angles.x.to_radians());
        Transform {
            matrix: r,
            translation: Vec3::ZERO,
        }
    }

    /// `self` applied after `first`: `self.after(first)` maps `p` to `self(first(p))`.
    pub fn after(&self, first: &Transform) -> Transform {
        Transform {
            matrix: self.matrix * first.matrix,
            translation: self.matrix * first.translation + self.translation,
        }
    }

    /// Maps a point.
    #[inline]
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.matrix * p + self.translation
    }

    /// Maps a direction (no translation).
    #[inline]
    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.matrix * v
    }

    /// True if every number is finite and the matrix can be inverted.
    pub fn is_valid(&self) -> bool {
        let finite = self.matrix.is_finite() && self.translation.is_finite();
        if !finite {
            return false;
        }
        let det = self.matrix.determinant();
        det != 0.0 && det.is_finite() && self.matrix.inverse().is_finite()
    }
}

/// A transform prepared for rendering: both directions and the transposed inverse for normals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Object to world.
    pub to_world: Transform,
    /// World to object: `inverse · (p − translation)`.
    pub inverse: Mat3,
    /// Maps object-space normals to world space (up to length).
    pub normal_matrix: Mat3,
    /// Absolute values of `to_world.matrix`, for error bounds.
    abs_matrix: Mat3,
}

impl Placement {
    /// Prepares `t`, which must be [`Transform::is_valid`].
    pub fn new(t: &Transform) -> Placement {
        let inverse = t.matrix.inverse();
        Placement {
            to_world: *t,
            inverse,
            normal_matrix: inverse.transpose(),
            abs_matrix: Mat3::from_cols(
                t.matrix.x_axis.abs(),
                t.matrix.y_axis.abs(),
                t.matrix.z_axis.abs(),
            ),
        }
    }

    /// A world point in object space.
    #[inline]
    pub fn point_to_object(&self, p: Vec3) -> Vec3 {
        self.inverse * (p - self.to_world.translation)
    }

    /// A world direction in object space.
    #[inline]
    pub fn vector_to_object(&self, v: Vec3) -> Vec3 {
        self.inverse * v
    }

    /// [`Placement::point_to_object`] and [`Placement::vector_to_object`] of four points and
    /// four directions, given and returned per axis lane by lane: each lane by the very
    /// operations of the one-ray maps (glam's `Mat3 · Vec3` sums the columns' products in
    /// column order), so each lane is theirs to the bit.
    #[inline(always)]
    pub fn to_object4(&self, p: &[Vec4; 3], v: &[Vec4; 3]) -> ([Vec4; 3], [Vec4; 3]) {
        let t = self.to_world.translation;
        let moved = [0, 1, 2].map(|c| p[c] - Vec4::splat(t[c]));
        let map = |w: &[Vec4; 3]| {
            let m = &self.inverse;
            [0, 1, 2].map(|k| {
                Vec4::splat(m.x_axis[k]) * w[0]
                    + Vec4::splat(m.y_axis[k]) * w[1]
                    + Vec4::splat(m.z_axis[k]) * w[2]
            })
        };
        (map(&moved), map(v))
    }

    /// An object-space normal in world space, unit length (or zero if it vanishes).
    #[inline]
    pub fn normal_to_world(&self, n: Vec3) -> Vec3 {
        (self.normal_matrix * n).unit_or_zero()
    }

    /// An object-space point with per-axis error `error` mapped to world space, with the error
    /// bound of the result: the mapped error plus the rounding of the product and the sum.
    #[inline]
    pub fn point_to_world(&self, p: Vec3, error: Vec3) -> (Vec3, Vec3) {
        let world = self.to_world.point(p);
        let spread = self.abs_matrix * p.abs() + self.to_world.translation.abs();
        let err = self.abs_matrix * error * (1.0 + gamma(3)) + spread * gamma(3);
        (world, err)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Four points and directions mapped lane by lane are the one-ray maps' to the bit, for
    /// rotations, scales and shears, zero, infinite and NaN components included.
    #[test]
    fn four_lanes_map_as_one() {
        let mut rng = crate::scene::mesh::Rng::new(41);
        let mut unit = move || rng.next_f32() * 2.0 - 1.0;
        let special = [0.0, -0.0, f32::INFINITY, f32::NAN, 1e30, -1e-30];
        for case in 0..5_000usize {
            let mut v = || Vec3::new(unit(), unit(), unit());
            let t = Transform {
                matrix: Mat3::from_cols(v() * 3.0, v(), v() * 0.5),
                translation: v() * 10.0,
            };
            if !t.is_valid() {
                continue;
            }
            let placement = Placement::new(&t);
            let mut points: [Vec3; 4] = core::array::from_fn(|_| v() * 100.0);
            let dirs: [Vec3; 4] = core::array::from_fn(|_| v());
            points[case % 4][case % 3] = special[case % special.len()];
            let lanes =
                |w: &[Vec3; 4]| [0, 1, 2].map(|k| Vec4::new(w[0][k], w[1][k], w[2][k], w[3][k]));
            let (o, d) = placement.to_object4(&lanes(&points), &lanes(&dirs));
            for l in 0..4 {
                let one = (
                    placement.point_to_object(points[l]),
                    placement.vector_to_object(dirs[l]),
                );
                let four = (
                    Vec3::new(o[0][l], o[1][l], o[2][l]),
                    Vec3::new(d[0][l], d[1][l], d[2][l]),
                );
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                assert_eq!(bits(four.0), bits(one.0), "case {case} lane {l}");
                assert_eq!(bits(four.1), bits(one.1), "case {case} lane {l}");
            }
        }
    }

    #[test]
    fn composition_applies_right_to_left() {
        let s = Transform::scale(Vec3::splat(2.0));
        let t = Transform::translate(Vec3::X);
        // Scale first, then move: (1,0,0) -> (2,0,0) -> (3,0,0).
        assert_eq!(t.after(&s).point(Vec3::X), Vec3::new(3.0, 0.0, 0.0));
        assert_eq!(s.after(&t).point(Vec3::X), Vec3::new(4.0, 0.0, 0.0));
    }

    #[test]
    fn rotation_about_z_turns_x_into_y() {
        let r = Transform::rotate_xyz_deg(Vec3::new(0.0, 0.0, 90.0));
        let p = r.point(Vec3::X);
        assert!((p - Vec3::Y).norm() < 1e-6, "{p:?}");
    }

    #[test]
    fn normals_stay_perpendicular_under_non_uniform_scale() {
        let t = Transform::scale(Vec3::new(4.0, 1.0, 1.0));
        let pl = Placement::new(&t);
        // The plane x + y = 0 has normal (1,1,0); scaled, its tangent (1,-1,0) becomes (4,-1,0).
        let n = pl.normal_to_world(Vec3::new(1.0, 1.0, 0.0));
        assert!(n.dot(Vec3::new(4.0, -1.0, 0.0)).abs() < 1e-6);
        assert!(!Transform::scale(Vec3::new(1.0, 0.0, 1.0)).is_valid());
    }
}
