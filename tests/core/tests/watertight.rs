//! Rays from inside a closed, jittered sphere mesh always hit it: through faces, exactly at
//! vertices and along edges. A leak here is a background pixel inside a closed object.

use glam::Vec3;
use strahl_core::accel::octree::{Octree, OctreeParams};
use strahl_core::math::ray::Ray;
use strahl_core::scene::mesh::Rng;
use strahl_core_tests::meshes::{closed_sphere, positions};

#[test]
fn rays_from_inside_a_closed_mesh_always_hit() {
    let mut rng = Rng::new(21);
    let mesh = closed_sphere(64, 32, 0.05, &mut rng);
    let tris = positions(&mesh);
    let tree = Octree::build(&tris, &OctreeParams::default());
    let mut shots = 0;
    let mut shoot = |origin: Vec3, target: Vec3| {
        let dir = target - origin;
        if dir == Vec3::ZERO {
            return;
        }
        let ray = Ray::new(origin, dir);
        assert!(
            tree.closest_hit(&tris, &ray, f32::INFINITY).is_some(),
            "leak: {ray:?}"
        );
        assert!(
            tree.any_hit(&tris, &ray, f32::INFINITY),
            "any-hit leak: {ray:?}"
        );
        shots += 1;
    };
    // Origins: the centre, points on the axes and random points well inside (radius ≤ 0.5).
    let mut origins = vec![
        Vec3::ZERO,
        Vec3::new(0.0, 0.0, 0.3),
        Vec3::new(0.2, -0.1, 0.0),
    ];
    origins.extend((0..20).map(|_| rng.direction() * (0.5 * rng.next_f32())));
    for &o in &origins {
        // Exactly at every vertex.
        for &p in &mesh.points {
            shoot(o, p);
        }
        // Along every edge: its midpoint and random points on it, as computed in f32.
        for t in &tris {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                shoot(o, (a + b) * 0.5);
                let s = rng.next_f32();
                shoot(o, a + (b - a) * s);
            }
        }
        // Random directions, some with zero components.
        for i in 0..2000 {
            let mut d = rng.direction();
            if i % 5 == 0 {
                d[i % 3] = 0.0;
            }
            shoot(o, o + d);
        }
    }
    assert!(shots > 500_000, "only {shots} rays");
}
