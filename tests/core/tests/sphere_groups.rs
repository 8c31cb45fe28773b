//! Closest hits among many overlapping spheres, tested in groups (`Scene::group_spheres`), are
//! the hits of testing them one by one, to the bit: on a spiral of overlapping balls like SPD's
//! shells, with triangles, a cylinder and scaled spheres (not lone) mixed into the same cells.

use glam::Vec3;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::geom::solid::{Shape, SolidNode};
use strahl_core::math::ray::Ray;
use strahl_core::math::transform::Transform;
use strahl_core::render::intersect::{PrimitiveHit, QueryScratch, ShadowMemory};
use strahl_core::scene::mesh::Rng;
use strahl_core::scene::{Scene, SceneDesc};
use strahl_core_tests::meshes::random_soup;
use strahl_core_tests::scenes::{add_triangles, lit};

fn leaf(shape: Shape, transform: Transform) -> SolidNode {
    SolidNode::Leaf {
        shape,
        transform,
        shader: 0,
    }
}

/// 1,500 balls along a shrinking spiral, each overlapping hundreds of its neighbours, plus a
/// triangle soup, cylinders and scaled balls in the same space.
fn shell(rng: &mut Rng) -> Scene {
    let mut desc = lit(Vec3::new(0.0, 0.0, 10.0));
    add_triangles(&mut desc, &random_soup(200, rng));
    let add = |desc: &mut SceneDesc, node: SolidNode| {
        desc.objects.push(desc.solids.len() as u32);
        desc.solids.push(node);
    };
    for k in 0..1500 {
        let a = k as f32 * 0.004;
        let grow = 1.0 - k as f32 / 1600.0;
        let centre = Vec3::new((a * 6.0).cos(), (a * 6.0).sin(), a) * grow;
        let ball = Shape::Sphere { radius: 0.4 * grow };
        add(&mut desc, leaf(ball, Transform::translate(centre)));
        if k % 100 == 0 {
            let cylinder = Shape::Cylinder {
                bottom_radius: 0.1,
                top_radius: 0.05,
                height: 0.5,
            };
            add(&mut desc, leaf(cylinder, Transform::translate(centre)));
            let scaled = Transform::translate(centre).after(&Transform::scale(Vec3::splat(0.3)));
            add(&mut desc, leaf(Shape::Sphere { radius: 1.0 }, scaled));
        }
    }
    Scene::build(&desc, &OctreeParams::default()).expect("valid scene")
}

fn key(h: Option<PrimitiveHit>) -> Option<(u32, u32, u32)> {
    h.map(|h| match h {
        PrimitiveHit::Triangle(i, t) => (i, t.t.to_bits(), t.t_error.to_bits()),
        PrimitiveHit::Solid(j, s) => (1 << 31 | j, s.t.to_bits(), s.t_error.to_bits()),
    })
}

/// The shell twice: testing lone spheres in groups, and one by one.
fn grouped_and_single(rng: &mut Rng) -> (Scene, Scene) {
    let grouped = shell(rng);
    assert!(grouped.group_spheres, "the shell's leaves are not grouped");
    let mut single = grouped.clone();
    single.group_spheres = false;
    (grouped, single)
}

#[test]
fn grouped_closest_hits_are_the_one_by_one_hits() {
    let mut rng = Rng::new(23);
    let (grouped, single) = grouped_and_single(&mut rng);
    let mut scratch = QueryScratch::default();
    let (mut solids, mut triangles) = (0, 0);
    for i in 0..20_000 {
        // From around the shell and from inside it (reflection rays start in the cluster).
        let origin = if i % 4 == 0 {
            Vec3::new(
                rng.range(-1.0, 1.0),
                rng.range(-1.0, 1.0),
                rng.range(0.0, 6.0),
            )
        } else {
            rng.direction() * rng.range(3.0, 8.0)
        };
        let target = Vec3::new(
            rng.range(-1.2, 1.2),
            rng.range(-1.2, 1.2),
            rng.range(0.0, 6.0),
        );
        let ray = Ray::new(origin, target - origin);
        let t_max = if i % 5 == 0 {
            rng.range(0.5, 3.0)
        } else {
            f32::INFINITY
        };
        let expected = single.closest_hit(&ray, t_max, &mut scratch);
        let got = grouped.closest_hit(&ray, t_max, &mut scratch);
        assert_eq!(key(got), key(expected), "ray {i}: {ray:?}");
        match expected {
            Some(PrimitiveHit::Solid(..)) => solids += 1,
            Some(PrimitiveHit::Triangle(..)) => triangles += 1,
            None => {}
        }
    }
    assert!(
        solids > 5_000 && triangles > 50,
        "{solids} solid and {triangles} triangle hits"
    );
}

#[test]
fn grouped_shadow_rays_are_blocked_as_one_by_one() {
    let mut rng = Rng::new(29);
    let (grouped, single) = grouped_and_single(&mut rng);
    let mut scratch = QueryScratch::default();
    let (mut blocked, mut free) = (0, 0);
    for i in 0..20_000 {
        // Between points in and around the shell: from its surface out, through it, and past it.
        let from = Vec3::new(
            rng.range(-1.2, 1.2),
            rng.range(-1.2, 1.2),
            rng.range(0.0, 6.0),
        );
        let to = rng.direction() * rng.range(0.5, 8.0) + Vec3::new(0.0, 0.0, 3.0);
        let ray = Ray::new(from, to - from);
        let expected = single.any_hit(&ray, 1.0, &mut scratch);
        let (mut last, mut last_single) = (ShadowMemory::default(), ShadowMemory::default());
        let got = grouped.shadowed(&ray, 1.0, &mut scratch, (None, &mut last, None));
        let one_by_one = single.shadowed(&ray, 1.0, &mut scratch, (None, &mut last_single, None));
        assert_eq!(got, expected, "ray {i}: {ray:?}");
        assert_eq!(one_by_one, expected, "ray {i}: {ray:?}");
        // What the grouped query remembers really blocks the ray.
        if let Some(b) = last.blockers[0] {
            let mut only = ShadowMemory::default();
            only.blockers[0] = Some(b);
            assert!(single.shadowed(&ray, 1.0, &mut scratch, (None, &mut only, None)));
        }
        if expected {
            blocked += 1;
        } else {
            free += 1;
        }
    }
    assert!(
        blocked > 2_000 && free > 2_000,
        "{blocked} blocked, {free} free"
    );
}
