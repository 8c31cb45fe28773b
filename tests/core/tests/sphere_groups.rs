//! Closest hits among many overlapping spheres, tested in groups (`Scene::group_spheres`), are
//! the hits of testing them one by one, to the bit: on a spiral of overlapping balls like SPD's
//! shells, with triangles, a cylinder and scaled spheres (not lone) mixed into the same cells.
//! Both ways of grouping are checked: the large leaves' groups made when the scene is prepared
//! (`Scene::leaf_spheres`), and groups gathered per leaf where there was no memory for those.

use glam::Vec3;
use strahl_core::accel::leaf_spheres::LeafSpheres;
use strahl_core::accel::octree::{OctreeParams, GROUP};
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
    Scene::build(&shell_desc(rng), &OctreeParams::default()).expect("valid scene")
}

/// [`shell`]'s description.
fn shell_desc(rng: &mut Rng) -> SceneDesc {
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
    desc
}

fn key(h: Option<PrimitiveHit>) -> Option<(u32, u32, u32)> {
    h.map(|h| match h {
        PrimitiveHit::Triangle(i, t) => (i, t.t.to_bits(), t.t_error.to_bits()),
        PrimitiveHit::Solid(j, s) => (1 << 31 | j, s.t.to_bits(), s.t_error.to_bits()),
    })
}

/// The shell three times: testing lone spheres in the groups made when it was prepared, in
/// groups gathered per leaf, and one by one.
fn grouped_and_single(rng: &mut Rng) -> (Scene, Scene, Scene) {
    let grouped = shell(rng);
    assert!(grouped.group_spheres, "the shell's leaves are not grouped");
    assert!(
        !grouped.leaf_spheres.is_empty(),
        "no leaf's groups were made"
    );
    let mut gathered = grouped.clone();
    gathered.leaf_spheres = LeafSpheres::default();
    let mut single = grouped.clone();
    single.group_spheres = false;
    (grouped, gathered, single)
}

#[test]
fn the_groups_are_kept_only_within_the_memory_given() {
    let desc = shell_desc(&mut Rng::new(19));
    let params = OctreeParams::default();
    let kept = Scene::build(&desc, &params).expect("valid scene");
    let bytes = kept.leaf_spheres.bytes() as u64;
    let light = |s: &Scene| {
        s.light_buffers
            .iter()
            .flatten()
            .map(|b| b.bytes())
            .sum::<u64>()
    };
    let fits = Scene::build_within(&desc, &params, light(&kept) + bytes).expect("valid scene");
    assert_eq!(fits.leaf_spheres.bytes() as u64, bytes);
    let short = Scene::build_within(&desc, &params, light(&kept) + bytes - 1).expect("valid");
    assert!(light(&short) == light(&kept) && short.leaf_spheres.is_empty());
    assert!(bytes > 0 && short.group_spheres, "{bytes} bytes");
}

#[test]
fn every_large_leaf_keeps_its_primitives_in_order() {
    let scene = shell(&mut Rng::new(17));
    let n = scene.triangle_points.len() as u32;
    let mut large = 0;
    for (start, indices) in scene.octree.leaves() {
        let Some(leaf) = scene.leaf_spheres.leaf(start) else {
            assert!(indices.len() < GROUP, "large leaf at {start} has no groups");
            continue;
        };
        assert!(indices.len() >= GROUP, "small leaf at {start} has groups");
        large += 1;
        let lone = |i: &u32| i.checked_sub(n).and_then(|j| scene.solids.lone_sphere(j));
        let spheres: Vec<u32> = indices
            .iter()
            .copied()
            .filter(|i| lone(i).is_some())
            .collect();
        let others: Vec<u32> = indices
            .iter()
            .copied()
            .filter(|i| lone(i).is_none())
            .collect();
        let grouped: Vec<u32> = leaf
            .groups
            .iter()
            .flat_map(|g| g.indices().to_vec())
            .collect();
        assert_eq!(grouped, spheres, "leaf at {start}");
        assert_eq!(leaf.others, &others[..], "leaf at {start}");
        let full = leaf.groups.iter().filter(|g| g.len() == GROUP).count();
        assert!(
            full + 1 >= leaf.groups.len(),
            "leaf at {start}: groups not filled"
        );
    }
    assert!(large > 10, "{large} large leaves");
}

#[test]
fn grouped_closest_hits_are_the_one_by_one_hits() {
    let mut rng = Rng::new(23);
    let (grouped, gathered, single) = grouped_and_single(&mut rng);
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
        let got = gathered.closest_hit(&ray, t_max, &mut scratch);
        assert_eq!(key(got), key(expected), "gathered, ray {i}: {ray:?}");
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
    let (grouped, gathered, single) = grouped_and_single(&mut rng);
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
        let mut last_gathered = ShadowMemory::default();
        let gathered = gathered.shadowed(&ray, 1.0, &mut scratch, (None, &mut last_gathered, None));
        assert_eq!(got, expected, "ray {i}: {ray:?}");
        assert_eq!(gathered, expected, "gathered, ray {i}: {ray:?}");
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

/// Rays from far away (10³ to 10⁵ units) that graze the shell's balls, where the sphere test's
/// rounding is largest: the groups' reach (a box around their spheres, skipped where a ray
/// misses it) must never drop a hit or a blocker that testing one by one finds.
#[test]
fn grazing_rays_from_far_away_find_what_one_by_one_finds() {
    let mut rng = Rng::new(31);
    let (grouped, _, single) = grouped_and_single(&mut rng);
    let mut scratch = QueryScratch::default();
    let (mut hits, mut blocked) = (0, 0);
    for i in 0..20_000 {
        // A ball of the spiral, seen from far off along a random direction, aimed at its rim.
        let k = (rng.next_u64() % 1500) as f32;
        let a = k * 0.004;
        let grow = 1.0 - k / 1600.0;
        let centre = Vec3::new((a * 6.0).cos(), (a * 6.0).sin(), a) * grow;
        let radius = 0.4 * grow;
        let towards = rng.direction();
        let across = towards.any_orthonormal_vector();
        let rim = centre + across * radius * rng.range(0.999, 1.001);
        let origin = rim - towards * 10f32.powf(rng.range(3.0, 5.0));
        let ray = Ray::new(origin, rim - origin);
        let expected = single.closest_hit(&ray, f32::INFINITY, &mut scratch);
        let got = grouped.closest_hit(&ray, f32::INFINITY, &mut scratch);
        assert_eq!(key(got), key(expected), "ray {i}: {ray:?}");
        hits += usize::from(expected.is_some());
        let (mut last, mut last_single) = (ShadowMemory::default(), ShadowMemory::default());
        let shadow = grouped.shadowed(&ray, 1.0, &mut scratch, (None, &mut last, None));
        let one = single.shadowed(&ray, 1.0, &mut scratch, (None, &mut last_single, None));
        assert_eq!(shadow, one, "shadow ray {i}: {ray:?}");
        blocked += usize::from(one);
    }
    assert!(
        hits > 5_000 && blocked > 5_000,
        "{hits} hits, {blocked} blocked"
    );
}
