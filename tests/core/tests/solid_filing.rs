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

/// One object per node, the tree over their extents, and the tree over their boxes alone; `by`
/// says which extents file an object by more than its box: all but the last node's must.
fn trees(nodes: &[SolidNode], by: fn(&SolidExtent) -> bool) -> (Solids, Octree) {
    let objects: Vec<u32> = (0..nodes.len() as u32).collect();
    let solids = Solids::new(nodes, &objects, &[]);
    let extents = solids.extents();
    let filed_by_shape = extents.iter().filter(|e| by(e)).count();
    assert_eq!(filed_by_shape, nodes.len() - 1, "all but the last");
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
        "filing by shape files fewer references: {:?} against {:?}",
        tree.stats(),
        boxes.stats()
    );
    (solids, tree)
}

/// Rays aimed near `targets` find through `tree` the closest hit and the any-hit answer that
/// testing every object finds; returns how many rays hit something.
fn as_brute_force_finds(solids: &Solids, tree: &Octree, targets: &[Vec3], rng: &mut Rng) -> usize {
    let mut scratch = SpanScratch::default();
    let mut hits = 0;
    for i in 0..50_000 {
        let target = targets[i % targets.len()];
        // Origins far out (a camera a thousand times the objects' size away too), near the
        // targets (inside the objects) and near the origin.
        let origin = match i % 5 {
            0 => target + rng.direction() * 8.0,
            1 => target + rng.direction() * rng.next_f32() * 0.5,
            2 => rng.direction() * rng.next_f32() * 0.05,
            3 => target + rng.direction() * 1000.0,
            _ => target + rng.direction() * rng.next_f32() * 2.5,
        };
        let aim = target + rng.direction() * rng.next_f32() * 1.5;
        let ray = Ray::new(origin, aim - origin);
        let want = brute_force(solids, &ray, &mut scratch);
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
    hits
}

#[test]
fn spheres_filed_by_their_surface_are_found_as_testing_every_sphere_finds_them() {
    let mut rng = Rng::new(5);
    let (solids, tree) = trees(&spheres(&mut rng), |e| {
        matches!(e, SolidExtent::Sphere { .. })
    });
    let targets = [
        Vec3::ZERO,
        Vec3::new(-3.0, 0.0, 0.0),
        Vec3::new(3.0, 0.0, 0.0),
    ];
    let hits = as_brute_force_finds(&solids, &tree, &targets, &mut rng);
    assert!(hits > 25_000, "most rays hit something: {hits}");
}

fn cylinder(r0: f32, r1: f32, h: f32, center: Vec3, transform: Transform) -> SolidNode {
    SolidNode::Leaf {
        shape: Shape::Cylinder {
            bottom_radius: r0,
            top_radius: r1,
            height: h,
        },
        transform: Transform::translate(center).after(&transform),
        shader: 0,
    }
}

/// Rings of thin cylinders joining points on circles at slants (as SPD's rings), cones to a
/// point, tiny ones, long ones across the scene, rotated and scaled ones, and a squashed one.
fn cylinders(rng: &mut Rng) -> Vec<SolidNode> {
    let mut nodes = Vec::new();
    for ring in 0..6 {
        let tilt = Vec3::new(ring as f32 * 23.0, ring as f32 * 41.0, 0.0);
        let turn = Transform::rotate_xyz_deg(tilt);
        let at = Vec3::new(ring as f32 * 0.7 - 1.8, 0.0, 0.0);
        for k in 0..24 {
            let a = k as f32 * core::f32::consts::TAU / 24.0;
            // A cylinder along the ring's tangent at angle `a`: its y axis turned to the
            // tangent, then the ring's tilt.
            let along = Transform::rotate_xyz_deg(Vec3::new(0.0, 0.0, a.to_degrees()));
            let place = turn
                .after(&Transform::translate(Vec3::new(a.cos(), a.sin(), 0.0)))
                .after(&along);
            nodes.push(cylinder(0.05, 0.05, 0.27, at, place));
        }
    }
    for _ in 0..200 {
        let angles = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 360.0;
        let c = rng.direction() * rng.next_f32() * 2.5;
        let (r0, r1) = (0.002 + 0.1 * rng.next_f32(), 0.1 * rng.next_f32());
        let h = 0.01 + 0.6 * rng.next_f32();
        nodes.push(cylinder(r0, r1, h, c, Transform::rotate_xyz_deg(angles)));
    }
    let long = Transform::rotate_xyz_deg(Vec3::new(35.0, 10.0, 55.0));
    nodes.push(cylinder(0.02, 0.02, 7.0, Vec3::ZERO, long));
    nodes.push(cylinder(0.3, 0.0, 1.2, Vec3::new(0.0, 2.0, 0.5), long));
    let turned = Transform::rotate_xyz_deg(Vec3::new(30.0, 45.0, 60.0))
        .after(&Transform::scale(Vec3::splat(1.7)));
    nodes.push(cylinder(0.1, 0.2, 0.8, Vec3::new(0.0, -2.0, 0.0), turned));
    let squashed = Transform::rotate_xyz_deg(Vec3::new(0.0, 0.0, 45.0))
        .after(&Transform::scale(Vec3::new(2.0, 0.5, 1.0)));
    nodes.push(cylinder(0.2, 0.2, 1.0, Vec3::new(2.0, -2.0, 0.0), squashed));
    nodes
}

#[test]
fn cylinders_filed_by_their_axis_are_found_as_testing_every_cylinder_finds_them() {
    let mut rng = Rng::new(9);
    let (solids, tree) = trees(&cylinders(&mut rng), |e| {
        matches!(e, SolidExtent::Cone { .. })
    });
    let targets = [
        Vec3::ZERO,
        Vec3::new(-1.8, 0.0, 0.0),
        Vec3::new(1.0, 0.5, 0.0),
    ];
    let hits = as_brute_force_finds(&solids, &tree, &targets, &mut rng);
    assert!(hits > 10_000, "many rays hit something: {hits}");
}
