//! Triangle sets to shoot rays at: random soups, closed jittered spheres, grids on octree cell
//! planes, and their bounds.

use glam::Vec3;
use strahl_core::scene::mesh::{MeshBuilder, Rng};

/// Vertex positions per triangle, as the octree and brute force take them.
pub fn positions(m: &MeshBuilder) -> Vec<[Vec3; 3]> {
    m.triangles
        .iter()
        .map(|t| t.points.map(|i| m.points[i as usize]))
        .collect()
}

/// `n` random triangles of mixed sizes in the cube `[-1, 1]³`, many overlapping.
pub fn random_soup(n: usize, rng: &mut Rng) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|_| {
            let c = Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
            );
            let size = if rng.next_f32() < 0.1 { 1.0 } else { 0.15 };
            [0; 3].map(|_| c + rng.direction() * (size * rng.next_f32()))
        })
        .collect()
}

/// A closed, jittered UV sphere of radius 1 at the origin.
pub fn closed_sphere(segments: u32, rings: u32, jitter: f32, rng: &mut Rng) -> MeshBuilder {
    let mut m = MeshBuilder::default();
    m.sphere(Vec3::ZERO, 1.0, segments, rings, jitter, 0, rng);
    m
}

/// Axis-aligned unit grid quads on integer coordinates: every edge lies on an octree cell plane.
pub fn boundary_grid(n: u32) -> MeshBuilder {
    let mut m = MeshBuilder::default();
    let s = n as f32;
    m.grid(
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(s, 0.0, 0.0),
        Vec3::new(0.0, s, 0.0),
        n,
        0,
    );
    m.grid(
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(s, 0.0, 0.0),
        Vec3::new(0.0, 0.0, s),
        n,
        0,
    );
    m.grid(
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.0, s, 0.0),
        Vec3::new(0.0, 0.0, s),
        n,
        0,
    );
    m.grid(
        Vec3::new(0.0, 0.0, s / 2.0),
        Vec3::new(s, 0.0, 0.0),
        Vec3::new(0.0, s, 0.0),
        n,
        0,
    );
    m
}

/// The box around a triangle set.
///
/// ```
/// use glam::Vec3;
/// let tris = [[Vec3::ZERO, Vec3::X, Vec3::new(0.0, 2.0, -1.0)]];
/// assert_eq!(strahl_core_tests::meshes::bounds(&tris), (Vec3::new(0.0, 0.0, -1.0), Vec3::new(1.0, 2.0, 0.0)));
/// ```
pub fn bounds(tris: &[[Vec3; 3]]) -> (Vec3, Vec3) {
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for t in tris {
        for p in t {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
    }
    (lo, hi)
}
