//! The shadow cache (`Scene::shadowed`, the last blockers per light) gives `Scene::any_hit`'s
//! answer whatever blockers it remembers, remembers the primitive that blocked first, and tries
//! no remembered blocker right after a ray that reached its light.

use glam::Vec3;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::geom::solid::Shape;
use strahl_core::math::ray::Ray;
use strahl_core::math::transform::Transform;
use strahl_core::render::intersect::{QueryScratch, ShadowMemory, SHADOW_CACHE};
use strahl_core::scene::mesh::Rng;
use strahl_core::scene::Scene;
use strahl_core_tests::meshes::random_soup;
use strahl_core_tests::scenes::{add_solid, add_triangles, lit};

/// Balls, a triangle soup and a floor half-space: every kind of primitive `any_hit` walks.
fn scene(rng: &mut Rng) -> Scene {
    let soup = random_soup(300, rng);
    let mut desc = lit(Vec3::new(0.0, 6.0, 0.0));
    add_triangles(&mut desc, &soup);
    for _ in 0..200 {
        let centre = Vec3::new(
            rng.range(-2.0, 2.0),
            rng.range(-2.0, 2.0),
            rng.range(-2.0, 2.0),
        );
        add_solid(
            &mut desc,
            Shape::Sphere {
                radius: rng.range(0.02, 0.3),
            },
            Transform::translate(centre),
        );
    }
    let floor = Shape::Plane {
        normal: Vec3::Y,
        d: -2.5,
    };
    add_solid(&mut desc, floor, Transform::IDENTITY);
    Scene::build(&desc, &OctreeParams::default()).expect("valid scene")
}

#[test]
fn shadowed_answers_as_any_hit_whatever_it_remembers() {
    let mut rng = Rng::new(17);
    let scene = scene(&mut rng);
    let primitives = (scene.triangle_points.len() + scene.solids.len()) as u32;
    let mut scratch = QueryScratch::default();
    let mut last = ShadowMemory::default();
    let (mut blocked, mut free, mut remembered_hits, mut second_hits) = (0, 0, 0, 0);
    let mut skipped = 0;
    for k in 0..20_000 {
        // Shadow rays (t from 0 to 1) between two points of the cloud, so that remembered
        // primitives lie before, on and beyond the light.
        let origin = Vec3::new(
            rng.range(-2.5, 2.5),
            rng.range(-2.5, 2.5),
            rng.range(-2.5, 2.5),
        );
        let light = Vec3::new(
            rng.range(-2.5, 2.5),
            rng.range(-2.5, 2.5),
            rng.range(-2.5, 2.5),
        );
        let ray = Ray::new(origin, light - origin);
        let want = scene.any_hit(&ray, 1.0, &mut scratch);
        // Every third ray starts from an unrelated remembered primitive, every 100th from an
        // index no primitive of this scene has (a scratch carried over from a larger scene).
        if k % 3 == 0 {
            last.blockers[k as usize % SHADOW_CACHE] = Some(rng.next_u64() as u32 % primitives);
        }
        if k % 100 == 1 {
            last.blockers[0] = Some(primitives + k);
        }
        // At times the light is said to have been reached by a ray it was not.
        if k % 7 == 0 {
            last.reached = !last.reached;
        }
        let before = last;
        let (cells, tests) = (scratch.work.octree_cells, scratch.work.intersection_tests);
        let got = scene.shadowed(&ray, 1.0, &mut scratch, (None, &mut last, None));
        // No cell entered: settled before the walk (by a remembered blocker, where it is one).
        let cached = scratch.work.octree_cells == cells;
        assert_eq!(got, want, "ray {k}: {ray:?}, remembered {before:?}");
        assert_eq!(
            last.reached, !want,
            "ray {k}: remembers whether it reached the light"
        );
        if before.reached && before.blockers.iter().any(Option::is_some) {
            // Right after a ray that reached the light, the walk alone answers: the same
            // tests as with nothing remembered.
            let mut nothing = ShadowMemory::default();
            let after = scratch.work.intersection_tests;
            scene.shadowed(&ray, 1.0, &mut scratch, (None, &mut nothing, None));
            let alone = scratch.work.intersection_tests - after;
            assert_eq!(after - tests, alone, "ray {k}: tried a remembered blocker");
            skipped += 1;
        }
        if want {
            blocked += 1;
            let b = last.blockers[0].expect("a blocked ray leaves its blocker first");
            // What it remembers first really blocks this ray.
            let mut only = ShadowMemory::default();
            only.blockers[0] = Some(b);
            assert!(
                scene.shadowed(&ray, 1.0, &mut scratch, (None, &mut only, None)),
                "ray {k}: remembered {b} does not block"
            );
            if cached && before.blockers.contains(&Some(b)) {
                remembered_hits += 1;
                second_hits += u32::from(before.blockers[0] != Some(b));
            }
        } else {
            free += 1;
            assert_eq!(
                last.blockers, before.blockers,
                "ray {k}: an unblocked ray keeps what was remembered"
            );
        }
    }
    // The rays cover both answers, and the cache is really used (a blocker found again).
    assert!(
        blocked > 1000 && free > 1000,
        "{blocked} blocked, {free} free"
    );
    assert!(
        remembered_hits > 20 && second_hits > 5 && skipped > 1000,
        "{remembered_hits} rays settled by a remembered blocker, {second_hits} by a later one, \
         {skipped} after a ray that reached the light"
    );
}
