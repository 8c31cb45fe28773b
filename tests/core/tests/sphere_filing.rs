//! Spheres filed in the octree by their surface (not their box) are found exactly as testing
//! every sphere finds them: the same sphere and the bit-identical `t`, for closest hits and for
//! shadow-style any-hit queries, from rays outside (near and far), inside and on the spheres:
//! nested and overlapping spheres, a cluster of tiny ones inside a big one, rotated and scaled
//! placements, and an ellipsoid (filed by its box).

use glam::Vec3;
use strahl_core::accel::octree::{Octree, OctreeParams};
use strahl_core::accel::work::QueryWork;
use strahl_core::geom::hit::closer;
use strahl_core::geom::solid::extent::SolidExtent;
use strahl_core::geom::solid::prepared::{SolidHit, Solids, SpanScratch};
use strahl_core::geom::solid::{Shape, SolidNode};
use strahl_core::math::ray::Ray;
use strahl_core::math::transform::Transform;
use strahl_core::scene::mesh::Rng;

fn sphere(center: Vec3, radius: f32, transform: Transform) -> SolidNode {
    SolidNode::Leaf {
        shape: Shape::Sphere { radius },
        transform: Transform::translate(center).after(&transform),
        shader: 0,
    }
}

/// Spheres of many sizes: a spiral of overlapping ones shrinking to a point (as SPD's shells),
/// nested shells, a cluster of tiny ones inside a big one, rotated and scaled ones, and an
/// ellipsoid.
fn spheres(rng: &mut Rng) -> Vec<SolidNode> {
    let mut nodes = Vec::new();
    for k in 0..400 {
        let a = k as f32 * 0.15;
        let r = 0.002 * 1.012f32.powi(k);
        let c = Vec3::new(a.cos(), a.sin(), 0.3 * a.sin()) * r * 6.0;
        nodes.push(sphere(c, r * 4.0, Transform::IDENTITY));
    }
    for k in 1..6 {
        nodes.push(sphere(
            Vec3::new(3.0, 0.0, 0.0),
            k as f32 * 0.4,
            Transform::IDENTITY,
        ));
    }
    for _ in 0..300 {
        let c = Vec3::new(-3.0, 0.0, 0.0) + rng.direction() * rng.next_f32() * 0.8;
        nodes.push(sphere(c, 0.01 + 0.05 * rng.next_f32(), Transform::IDENTITY));
    }
    nodes.push(sphere(Vec3::new(-3.0, 0.0, 0.0), 1.5, Transform::IDENTITY));
    let turned = Transform::rotate_xyz_deg(Vec3::new(30.0, 45.0, 60.0))
        .after(&Transform::scale(Vec3::splat(1.7)));
    nodes.push(sphere(Vec3::new(0.0, 3.0, 0.0), 0.5, turned));
    let squashed = Transform::scale(Vec3::new(2.0, 0.5, 1.0));
    nodes.push(sphere(Vec3::new(0.0, -3.0, 0.0), 0.5, squashed));
    nodes
}

/// The closest hit over every object, ties to the smallest index.
fn brute_force(solids: &Solids, ray: &Ray, scratch: &mut SpanScratch) -> Option<(u32, SolidHit)> {
    let mut best: Option<(u32, SolidHit)> = None;
    for j in 0..solids.len() as u32 {
        if let Some(h) = solids.first_hit(j, ray, f32::INFINITY, scratch) {
            if closer(h.t, j, &best) {
                best = Some((j, h));
            }
        }
    }
    best
}

#[test]
fn spheres_filed_by_their_surface_are_found_as_testing_every_sphere_finds_them() {
    let mut rng = Rng::new(5);
    let nodes = spheres(&mut rng);
    let objects: Vec<u32> = (0..nodes.len() as u32).collect();
    let solids = Solids::new(&nodes, &objects, &[]);
    let extents = solids.extents();
    let filed_by_surface = extents
        .iter()
        .filter(|e| matches!(e, SolidExtent::Sphere { .. }))
        .count();
    assert_eq!(filed_by_surface, nodes.len() - 1, "all but the ellipsoid");
    assert!(matches!(extents.last(), Some(SolidExtent::Box(_))));
    let params = OctreeParams::default();
    let tree = Octree::build_mixed(&[], &extents, &params);
    let boxes = Octree::build_mixed(
        &[],
        &extents
            .iter()
            .map(|e| e.bounds().map_or(SolidExtent::Unbounded, SolidExtent::Box))
            .collect::<Vec<_>>(),
        &params,
    );
    assert!(
        tree.stats().references < boxes.stats().references,
        "filing by surface files fewer references: {:?} against {:?}",
        tree.stats(),
        boxes.stats()
    );
    let mut scratch = SpanScratch::default();
    let mut hits = 0;
    for i in 0..50_000 {
        let target = match i % 3 {
            0 => Vec3::ZERO,
            1 => Vec3::new(-3.0, 0.0, 0.0),
            _ => Vec3::new(3.0, 0.0, 0.0),
        };
        // Origins far out (a camera a thousand times the spheres' size away too), near the
        // centres (inside the spheres) and on the spiral.
        let origin = match i % 5 {
            0 => target + rng.direction() * 8.0,
            1 => target + rng.direction() * rng.next_f32() * 0.5,
            2 => rng.direction() * rng.next_f32() * 0.05,
            3 => target + rng.direction() * 1000.0,
            _ => target + rng.direction() * rng.next_f32() * 2.5,
        };
        let aim = target + rng.direction() * rng.next_f32() * 1.5;
        let ray = Ray::new(origin, aim - origin);
        let want = brute_force(&solids, &ray, &mut scratch);
        let got = tree.closest_hit_with(
            &ray,
            f32::INFINITY,
            &mut QueryWork::default(),
            |j, bound| solids.first_hit(j, &ray, bound, &mut scratch),
        );
        let key = |h: &Option<(u32, SolidHit)>| h.as_ref().map(|(j, h)| (*j, h.t.to_bits()));
        assert_eq!(key(&got), key(&want), "ray {ray:?}");
        // A shadow ray to the brute-force hit's far side: blocked exactly when a hit lies
        // provably before it.
        let t_max = want.as_ref().map_or(4.0, |(_, h)| h.t * 1.5);
        let blocked = |j: u32, scratch: &mut SpanScratch| {
            solids
                .first_hit(j, &ray, t_max, scratch)
                .is_some_and(|h| h.t + h.t_error < t_max)
        };
        let want_any = (0..solids.len() as u32).any(|j| blocked(j, &mut scratch));
        let got_any = tree.any_hit_with(&ray, t_max, &mut QueryWork::default(), |j| {
            blocked(j, &mut scratch)
        });
        assert_eq!(got_any, want_any, "ray {ray:?} t_max {t_max}");
        hits += usize::from(want.is_some());
    }
    assert!(hits > 25_000, "most rays hit something: {hits}");
}
