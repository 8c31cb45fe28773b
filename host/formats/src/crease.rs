//! Hard edges for formats without normals: a vertex shared by faces that meet at a sharp angle
//! is split into one copy per group of faces that meet smoothly.
//!
//! The seed's data format carries no normals: the renderer averages the normals of the faces
//! that share a point (by index, not by position; `scenes/FORMATS.md` §3.2.2.1). So a cube whose
//! corners are shared by three faces comes out as a rounded blob. [`split_creases`] gives each
//! corner one point per face group, so each face averages only with its own group and a crease
//! stays sharp: a converted cube has 24 points, 3 per corner, and flat faces.
//!
//! Grouping: at each point, every face that uses it (in file order) joins the first group whose
//! first face's normal is within the crease angle of its own, or starts a group. Faces with no
//! normal (zero area) keep the point they had.

use glam::Vec3;
use strahl_core::scene::TriangleDesc;

/// The crease angle `strahl convert` uses unless told otherwise, in degrees.
pub const DEFAULT_CREASE_DEGREES: f32 = 60.0;

/// Splits the points of `triangles` (indices into `points`) where faces meet at more than
/// `degrees`: copies are appended to `points` and the triangles renumbered. Returns how many
/// points were added. 180° or more changes nothing.
pub fn split_creases(
    points: &mut Vec<Vec3>,
    triangles: &mut [TriangleDesc],
    degrees: f32,
) -> usize {
    if degrees >= 180.0 {
        return 0;
    }
    let cos_limit = libm::cosf(degrees.to_radians());
    let normals: Vec<Option<Vec3>> = triangles
        .iter()
        .map(|t| face_normal(t.points.map(|i| points[i as usize])))
        .collect();
    let mut users: Vec<Vec<(usize, usize)>> = vec![Vec::new(); points.len()];
    for (f, t) in triangles.iter().enumerate() {
        for (corner, &p) in t.points.iter().enumerate() {
            users[p as usize].push((f, corner));
        }
    }
    let before = points.len();
    for (p, faces) in users.iter().enumerate() {
        // Each group: its first face's normal and the point index it gets.
        let mut groups: Vec<(Vec3, u32)> = Vec::new();
        for &(f, corner) in faces {
            let Some(n) = normals[f] else { continue };
            let index = match groups.iter().find(|(first, _)| first.dot(n) >= cos_limit) {
                Some(&(_, index)) => index,
                None => {
                    let index = if groups.is_empty() {
                        p as u32
                    } else {
                        points.push(points[p]);
                        (points.len() - 1) as u32
                    };
                    groups.push((n, index));
                    index
                }
            };
            triangles[f].points[corner] = index;
        }
    }
    points.len() - before
}

/// The unit normal of a triangle, or `None` for one without area.
fn face_normal([a, b, c]: [Vec3; 3]) -> Option<Vec3> {
    let n = (b - a).cross(c - a);
    let len = n.length();
    (len > 0.0 && len.is_finite()).then(|| n / len)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube: 8 points, 12 triangles.
    fn cube() -> (Vec<Vec3>, Vec<TriangleDesc>) {
        let points: Vec<Vec3> = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let triangles = quads
            .iter()
            .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
            .map(|t| TriangleDesc::new(t, 0))
            .collect();
        (points, triangles)
    }

    #[test]
    fn a_cube_gets_a_point_per_face_at_each_corner() {
        let (mut points, mut triangles) = cube();
        assert_eq!(split_creases(&mut points, &mut triangles, 60.0), 16);
        assert_eq!(points.len(), 24);
        // Every point is used by faces of one plane only.
        for p in 0..points.len() as u32 {
            let ns: Vec<Vec3> = triangles
                .iter()
                .filter(|t| t.points.contains(&p))
                .filter_map(|t| face_normal(t.points.map(|i| points[i as usize])))
                .collect();
            assert!(
                ns.windows(2).all(|w| w[0].dot(w[1]) > 0.999),
                "point {p}: {ns:?}"
            );
        }
        // Positions are kept: each triangle still spans the same corners.
        let (before, original) = cube();
        for (t, o) in triangles.iter().zip(&original) {
            assert_eq!(
                t.points.map(|i| points[i as usize]),
                o.points.map(|i| before[i as usize])
            );
        }
    }

    #[test]
    fn smooth_enough_surfaces_and_180_degrees_stay_shared() {
        let (mut points, mut triangles) = cube();
        assert_eq!(split_creases(&mut points, &mut triangles, 180.0), 0);
        assert_eq!(points.len(), 8);
        // At 95° the cube's 90° edges are smooth enough to share.
        let (mut points, mut triangles) = cube();
        assert_eq!(split_creases(&mut points, &mut triangles, 95.0), 0);
        // A flat fan of two triangles never splits.
        let mut points = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE.with_z(0.0)];
        let mut triangles = vec![
            TriangleDesc::new([0, 1, 2], 0),
            TriangleDesc::new([1, 3, 2], 0),
        ];
        assert_eq!(split_creases(&mut points, &mut triangles, 1.0), 0);
    }
}
