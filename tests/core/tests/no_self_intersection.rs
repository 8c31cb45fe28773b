//! Shadow and reflection rays spawned from a hit never re-hit the triangle they leave, for
//! scenes scaled from 1e-6 to 1e6: the origin offset follows the hit's error bound, not a fixed
//! epsilon.

use glam::Vec3;
use strahl_core::accel::octree::{Octree, OctreeParams};
use strahl_core::geom::triangle::{area_normal, hit_point, intersect, RayFrame};
use strahl_core::math::ray::{offset_ray_origin, Ray};
use strahl_core::scene::mesh::Rng;
use strahl_core_tests::meshes::{bounds, closed_sphere, positions, random_soup};

fn check_scale(scale: f32, seed: u64) -> usize {
    let mut rng = Rng::new(seed);
    let mut tris = random_soup(300, &mut rng);
    tris.extend(positions(&closed_sphere(24, 12, 0.1, &mut rng)));
    let tris: Vec<[Vec3; 3]> = tris.iter().map(|t| t.map(|p| p * scale)).collect();
    let tree = Octree::build(&tris, &OctreeParams::default());
    let (lo, hi) = bounds(&tris);
    let ext = hi - lo;
    let mut spawned = 0;
    for _ in 0..20_000 {
        let origin =
            lo - ext + ext * 3.0 * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let target = lo + ext * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let ray = Ray::new(origin, target - origin);
        let Some(hit) = tree.closest_hit(&tris, &ray, f32::INFINITY) else {
            continue;
        };
        let tri = &tris[hit.triangle as usize];
        let (p, err) = hit_point(tri, hit.tri.b);
        let mut n = area_normal(tri).normalize();
        if n.dot(ray.dir) > 0.0 {
            n = -n;
        }
        // Mirror ray, and rays towards random lights on the near side of the surface.
        let d = ray.dir.normalize();
        let mirror = d - n * (2.0 * d.dot(n));
        let mut dirs = vec![mirror];
        for _ in 0..3 {
            let mut w = rng.direction();
            if w.dot(n) < 0.0 {
                w = -w;
            }
            dirs.push(w);
        }
        for w in dirs {
            if w.dot(n) <= 0.0 {
                continue;
            }
            let o = offset_ray_origin(p, err, n, w);
            let spawned_ray = Ray::new(o, w);
            let own = intersect(&RayFrame::new(&spawned_ray), tri, f32::INFINITY);
            assert!(
                own.is_none(),
                "scale {scale}: ray from {p:?} re-hit its own triangle: {own:?}"
            );
            // As a shadow ray towards a light at distance 1 (in units of w), it never reports
            // its own triangle either.
            if let Some(h) = tree.closest_hit(&tris, &spawned_ray, f32::INFINITY) {
                assert_ne!(
                    h.triangle, hit.triangle,
                    "scale {scale}: closest hit is its own triangle"
                );
            }
            spawned += 1;
        }
    }
    spawned
}

#[test]
fn spawned_rays_never_rehit_their_triangle_at_any_scale() {
    for (k, scale) in [1e-6f32, 1e-3, 1.0, 1e3, 1e6].into_iter().enumerate() {
        let n = check_scale(scale, 100 + k as u64);
        assert!(n > 10_000, "scale {scale}: only {n} spawned rays");
    }
}

#[test]
fn fixed_epsilon_offset_would_fail_at_small_scale() {
    // The test above can fail: a fixed 1e-4 offset breaks at scale 1e-6 (it jumps right over
    // whole triangles), which is why the offset follows the error bound instead.
    let tri = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1e-6, 0.0, 0.0),
        Vec3::new(0.0, 1e-6, 0.0),
    ];
    let p = Vec3::new(2e-7, 2e-7, 0.0);
    let o = p + Vec3::Z * 1e-4;
    let back = Ray::new(o, Vec3::new(0.0, 0.0, -1.0));
    assert!(intersect(&RayFrame::new(&back), &tri, f32::INFINITY).is_some());
    let bounded = offset_ray_origin(p, Vec3::splat(1e-13), Vec3::Z, Vec3::Z);
    assert!(
        bounded.z > 0.0 && bounded.z < 1e-11,
        "bounded offset is tiny: {bounded:?}"
    );
}
