//! What the shading of a triangle hit reads besides its points: the triangle's shader, and
//! whether its corner normals are its geometric normal.
//!
//! A triangle whose three smooth normals are its unit geometric normal, bit for bit, is *flat*:
//! the hit reads that normal from the points it has just tested, where other triangles load
//! their corners' normals ([`Scene::triangle_normals`](crate::scene::prepared::Scene)), 36
//! bytes that on a large mesh mostly come from memory. NFF's `p` polygons of three points are
//! flat: each has its own points, so each corner's smooth normal is its one face's. The shading
//! sums the same normals either way, so the pixel is the same.
//!
//! A triangle's shader index and its flat mark share one `u32` ([`TriangleShading`]). Where
//! every triangle has the same one (SPD's tetra and mount: one shader, every triangle flat),
//! [`TriangleShadings`] keeps that value alone, and a hit reads nothing per triangle at all.
//! On SPD's tetra at 65,536 and 262,144 triangles the two together traced in 0.97 and 0.90 of
//! the time, mount_8 in 0.97 (`docs/performance.md`, fortieth round).

use crate::geom::triangle::unit_normal;
use alloc::vec::Vec;
use glam::Vec3;

/// The flat mark's bit; shader indices are below it ([`MAX_SHADERS`]).
const FLAT: u32 = 1 << 31;

/// The most shaders a scene may have: every shader index fits below [`FLAT`].
pub const MAX_SHADERS: usize = FLAT as usize;

/// A triangle's shader index and whether it is flat (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TriangleShading(u32);

impl TriangleShading {
    /// Shader `shader` (below [`MAX_SHADERS`]), flat or not.
    pub fn new(shader: u32, flat: bool) -> TriangleShading {
        debug_assert!((shader as usize) < MAX_SHADERS);
        TriangleShading(shader & !FLAT | if flat { FLAT } else { 0 })
    }

    /// The shader index.
    #[inline]
    pub fn shader(self) -> u32 {
        self.0 & !FLAT
    }

    /// True where the triangle's corner normals are its unit geometric normal, bit for bit.
    #[inline]
    pub fn flat(self) -> bool {
        self.0 & FLAT != 0
    }
}

/// Every triangle's [`TriangleShading`], or the one they all share.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TriangleShadings {
    each: Vec<TriangleShading>,
    /// The value every triangle has, where they all have one (then `each` is empty).
    all: Option<TriangleShading>,
}

impl TriangleShadings {
    /// The shadings of the triangles at `points` with corner normals `normals` and shaders
    /// `shaders` (each below [`MAX_SHADERS`]), by triangle index.
    pub fn new(
        points: &[[Vec3; 3]],
        normals: &[[Vec3; 3]],
        shaders: impl IntoIterator<Item = u32>,
    ) -> TriangleShadings {
        let each: Vec<TriangleShading> = points
            .iter()
            .zip(normals)
            .zip(shaders)
            .map(|((p, n), shader)| TriangleShading::new(shader, is_flat(p, n)))
            .collect();
        match each.split_first() {
            Some((&first, rest)) if rest.iter().all(|&s| s == first) => TriangleShadings {
                each: Vec::new(),
                all: Some(first),
            },
            _ => TriangleShadings { each, all: None },
        }
    }

    /// True where every triangle is flat: no hit reads the corner normals.
    pub fn all_flat(&self) -> bool {
        self.all
            .map_or_else(|| self.each.iter().all(|s| s.flat()), TriangleShading::flat)
    }

    /// Triangle `t`'s shading (`t` one of the triangles it was made for).
    #[inline]
    pub fn get(&self, t: usize) -> TriangleShading {
        match self.all {
            Some(s) => s,
            None => self.each[t],
        }
    }
}

/// True where the three corner normals `n` are the unit geometric normal of `p`, bit for bit.
fn is_flat(p: &[Vec3; 3], n: &[Vec3; 3]) -> bool {
    let bits = |v: Vec3| v.to_array().map(f32::to_bits);
    unit_normal(p).is_some_and(|u| n.iter().all(|&v| bits(v) == bits(u)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::norm::Norm;

    const TRIANGLE: [Vec3; 3] = [Vec3::ZERO, Vec3::X, Vec3::Y];

    #[test]
    fn a_triangle_is_flat_only_where_all_its_corners_hold_its_normal() {
        let unit = unit_normal(&TRIANGLE).unwrap_or(Vec3::NAN);
        assert!(is_flat(&TRIANGLE, &[unit; 3]));
        let tilted = (unit + Vec3::new(1e-3, 0.0, 0.0)).unit();
        assert!(!is_flat(&TRIANGLE, &[unit, unit, tilted]));
        // The same direction with another sign of zero is not the same bits.
        let signed = Vec3::new(-0.0, unit.y, unit.z);
        assert_eq!(unit.x, 0.0);
        assert!(!is_flat(&TRIANGLE, &[unit, signed, unit]));
        // A degenerate triangle has no normal to hold.
        assert!(!is_flat(&[Vec3::ZERO; 3], &[unit; 3]));
    }

    #[test]
    fn shader_and_mark_share_a_word_without_touching_each_other() {
        for (shader, flat) in [(0, true), (0, false), (7, true), (FLAT - 1, false)] {
            let s = TriangleShading::new(shader, flat);
            assert_eq!((s.shader(), s.flat()), (shader, flat));
        }
    }

    #[test]
    fn one_value_is_kept_alone_only_where_every_triangle_has_it() {
        let unit = unit_normal(&TRIANGLE).unwrap_or(Vec3::NAN);
        let points = [TRIANGLE; 3];
        let shared = TriangleShadings::new(&points, &[[unit; 3]; 3], [2, 2, 2]);
        assert_eq!(shared.all, Some(TriangleShading::new(2, true)));
        assert!(shared.each.is_empty());
        let normals = [[unit; 3], [unit; 3], [Vec3::X; 3]];
        let mixed = TriangleShadings::new(&points, &normals, [2, 2, 2]);
        assert_eq!(mixed.all, None);
        assert!(shared.all_flat() && !mixed.all_flat());
        let got: Vec<_> = (0..3).map(|t| mixed.get(t)).collect();
        let flat = TriangleShading::new(2, true);
        assert_eq!(got, [flat, flat, TriangleShading::new(2, false)]);
        let shaders = TriangleShadings::new(&points, &[[unit; 3]; 3], [2, 2, 3]);
        assert_eq!(shaders.get(2), TriangleShading::new(3, true));
        assert_eq!(shaders.get(0), TriangleShading::new(2, true));
        assert!(shaders.all_flat());
    }
}
