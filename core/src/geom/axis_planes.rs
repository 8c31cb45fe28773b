//! Triangles that share one axis-aligned plane: a floor split into two triangles, the triangles
//! of a gear's face cut from one polygon.
//!
//! A shadow ray leaves a triangle from a point moved off the triangle's plane to the side it
//! goes, so it meets that plane at `t ≤ 0`, and the triangle test, which reports only a `t`
//! provably above 0, never reports that triangle
//! ([`Scene::shadowed`](crate::scene::Scene::shadowed)). The same holds for every triangle in
//! the same plane, and whether two triangles share their plane exactly can be told without
//! arithmetic where the plane is aligned with an axis: all six vertices have the same
//! coordinate on that axis. [`AxisPlanes`] numbers those planes that hold two triangles or more,
//! so a shadow ray can pass over the other triangles of the plane it leaves (on SPD's floors,
//! the quad's other half, which the test could only reject after its edge functions).

use alloc::collections::BTreeMap;
use alloc::vec::Vec;
use glam::Vec3;

/// Per triangle, the number of the axis-aligned plane it lies in, where that plane holds two
/// triangles or more.
#[derive(Clone, Debug, Default)]
pub struct AxisPlanes {
    /// Per triangle, its plane's number or [`AxisPlanes::NONE`]; empty where no plane is shared.
    of: Vec<u32>,
}

impl AxisPlanes {
    /// The number of no plane: a triangle in no axis-aligned plane or alone in its plane, or a
    /// primitive that is not a triangle.
    pub const NONE: u32 = u32::MAX;

    /// The shared axis-aligned planes of `triangles`.
    pub fn new(triangles: &[[Vec3; 3]]) -> AxisPlanes {
        // Per plane, its number and how many triangles lie in it.
        let mut planes: BTreeMap<(usize, u32), (u32, u32)> = BTreeMap::new();
        for key in triangles.iter().filter_map(axis_plane) {
            let next = planes.len() as u32;
            planes.entry(key).or_insert((next, 0)).1 += 1;
        }
        if planes.values().all(|&(_, count)| count < 2) {
            return AxisPlanes::default();
        }
        let of = triangles
            .iter()
            .map(|t| match axis_plane(t).and_then(|k| planes.get(&k)) {
                Some(&(number, count)) if count >= 2 => number,
                _ => AxisPlanes::NONE,
            })
            .collect();
        AxisPlanes { of }
    }

    /// The number of primitive `i`'s shared axis-aligned plane, or [`AxisPlanes::NONE`].
    #[inline]
    pub fn of(&self, i: u32) -> u32 {
        self.of.get(i as usize).copied().unwrap_or(AxisPlanes::NONE)
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.of.len() * core::mem::size_of::<u32>()
    }
}

/// The axis and coordinate (as bits, a zero of either sign as +0) that all three points of
/// `t` share, the first such axis; `None` if they share none.
fn axis_plane(t: &[Vec3; 3]) -> Option<(usize, u32)> {
    (0..3)
        .find(|&a| t[0][a] == t[1][a] && t[1][a] == t[2][a])
        .map(|a| (a, (t[0][a] + 0.0).to_bits()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad(z: f32, shift: f32) -> [[Vec3; 3]; 2] {
        let p = |x: f32, y: f32| Vec3::new(x + shift, y, z);
        [
            [p(0.0, 0.0), p(1.0, 0.0), p(1.0, 1.0)],
            [p(0.0, 0.0), p(1.0, 1.0), p(0.0, 1.0)],
        ]
    }

    #[test]
    fn triangles_in_one_axis_plane_share_a_number_and_others_have_none() {
        let mut triangles = Vec::new();
        triangles.extend(quad(0.0, 0.0)); // 0, 1: z = 0
        triangles.extend(quad(-0.0, 5.0)); // 2, 3: z = -0, the same plane
        triangles.extend(quad(2.0, 0.0)); // 4, 5: z = 2
                                          // 6: alone in the plane y = 3; 7: tilted; 8: z = 2 again, far away.
        triangles.push([
            Vec3::new(0.0, 3.0, 0.0),
            Vec3::X + Vec3::Y * 3.0,
            Vec3::new(0.0, 3.0, 1.0),
        ]);
        triangles.push([Vec3::ZERO, Vec3::X, Vec3::new(0.0, 1.0, 1e-7)]);
        triangles.push([
            Vec3::new(9.0, 9.0, 2.0),
            Vec3::new(8.0, 9.0, 2.0),
            Vec3::new(9.0, 8.0, 2.0),
        ]);
        let planes = AxisPlanes::new(&triangles);
        let of: Vec<u32> = (0..10).map(|i| planes.of(i)).collect();
        assert!(
            of[..4].iter().all(|&n| n == of[0] && n != AxisPlanes::NONE),
            "{of:?}"
        );
        assert!(
            of[4] == of[5] && of[5] == of[8] && of[4] != AxisPlanes::NONE,
            "{of:?}"
        );
        assert_ne!(of[0], of[4]);
        assert_eq!(&of[6..8], &[AxisPlanes::NONE; 2]);
        assert_eq!(of[9], AxisPlanes::NONE, "not a triangle");
    }

    #[test]
    fn no_shared_plane_keeps_nothing() {
        let lone = [
            [Vec3::ZERO, Vec3::X, Vec3::Y],
            [Vec3::Z, Vec3::ONE, Vec3::new(0.0, 2.0, 3.0)],
        ];
        let planes = AxisPlanes::new(&lone);
        assert_eq!(planes.bytes(), 0);
        assert_eq!(planes.of(0), AxisPlanes::NONE);
    }
}
