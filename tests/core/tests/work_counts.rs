//! The octree's work counts: every primitive test made is counted once, a primitive the mailbox
//! skips is not, and a ray that misses the tree enters no cell.

use glam::Vec3;
use strahl_core::accel::octree::{Octree, OctreeParams};
use strahl_core::accel::work::QueryWork;
use strahl_core::geom::triangle::{intersect, RayFrame};
use strahl_core::math::ray::Ray;
use strahl_core::scene::mesh::Rng;
use strahl_core_tests::meshes::{bounds, random_soup};

#[test]
fn counted_tests_are_the_tests_made_and_repeats_are_skipped() {
    let mut rng = Rng::new(7);
    let tris = random_soup(3000, &mut rng);
    let tree = Octree::build(&tris, &OctreeParams::default());
    let (lo, hi) = bounds(&tris);
    let (mut all, mut cells_seen) = (0u64, 0u64);
    for _ in 0..2000 {
        let origin = lo + (hi - lo) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let ray = Ray::new(origin, rng.direction());
        let frame = RayFrame::new(&ray);
        let mut work = QueryWork::default();
        let mut tested = Vec::new();
        let _ = tree.closest_hit_with(&ray, f32::INFINITY, &mut work, |i, bound| {
            tested.push(i);
            intersect(&frame, &tris[i as usize], bound)
        });
        assert_eq!(work.intersection_tests, tested.len() as u64);
        let mut any_calls = 0u64;
        let mut any_work = QueryWork::default();
        let _ = tree.any_hit_with(&ray, f32::INFINITY, &mut any_work, |i| {
            any_calls += 1;
            intersect(&frame, &tris[i as usize], f32::INFINITY).is_some()
        });
        assert_eq!(any_work.intersection_tests, any_calls);
        assert!(work.octree_cells >= 1, "a ray from inside enters the root");
        all += work.intersection_tests;
        cells_seen += work.octree_cells;
        // A primitive is tested again only if the mailbox forgot it: with one slot per index
        // modulo 16, another index of the same slot was tested in between.
        for (k, &i) in tested.iter().enumerate() {
            if let Some(prev) = tested[..k].iter().rposition(|&j| j == i) {
                let evicted = tested[prev + 1..k].iter().any(|&j| j % 16 == i % 16);
                assert!(evicted, "{i} tested twice without eviction: {tested:?}");
            }
        }
    }
    assert!(all > 0 && cells_seen > 2000);
}

#[test]
fn a_ray_that_misses_the_tree_costs_nothing() {
    let tris = [[Vec3::ZERO, Vec3::X, Vec3::Y]];
    let tree = Octree::build(&tris, &OctreeParams::default());
    let ray = Ray::new(Vec3::new(5.0, 5.0, 5.0), Vec3::Z);
    let mut work = QueryWork::default();
    let hit = tree.closest_hit_with(
        &ray,
        f32::INFINITY,
        &mut work,
        |_, _| -> Option<strahl_core::geom::triangle::TriangleHit> {
            unreachable!("no primitive can be tested")
        },
    );
    assert!(hit.is_none());
    assert_eq!(work, QueryWork::default());
    // One leaf (the root) entered and its one triangle tested.
    let ray = Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z);
    let frame = RayFrame::new(&ray);
    let mut work = QueryWork::default();
    let hit = tree.closest_hit_with(&ray, f32::INFINITY, &mut work, |i, b| {
        intersect(&frame, &tris[i as usize], b)
    });
    assert!(hit.is_some());
    assert_eq!(
        work,
        QueryWork {
            intersection_tests: 1,
            octree_cells: 1
        }
    );
}
