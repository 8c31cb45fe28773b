//! A ray leaving a triangle (its origin moved off the plane with `offset_ray_origin`, as the
//! shader moves it) never meets that triangle again: the triangle test reports no hit, so
//! `Scene::shadowed` may leave it untested. Checked on small triangles, a soup, and a floor
//! 100 units wide far from the origin, where `f32` cannot tell the sign of `t` (the case that
//! sent every shadow ray of SPD's tree to `f64`), towards lights in every direction. Nor does it
//! meet another triangle of the same axis-aligned plane (`AxisPlanes`: a floor's other half, the
//! rest of a gear's fanned face), which `Scene::shadowed` leaves untested too. And a shadow ray
//! that misses the triangle its light remembers is mostly settled by one listed next to it.
//! Four rays leaving a triangle, walked together with it named as the one they leave (as the
//! tracer walks mirror and refracted rays), find the hits they find alone without testing it.

use glam::Vec3;
use strahl_core::accel::octree::{OctreeParams, LANES};
use strahl_core::geom::axis_planes::AxisPlanes;
use strahl_core::geom::triangle::{hit_point, intersect, unit_normal, RayFrame};
use strahl_core::math::ray::{offset_ray_origin, Ray};
use strahl_core::render::intersect::{QueryScratch, ShadowMemory, SHADOW_CACHE};
use strahl_core::scene::mesh::Rng;
use strahl_core::scene::Scene;
use strahl_core_tests::meshes::random_soup;
use strahl_core_tests::scenes::{add_triangles, lit};

/// A random point of `tri` (barycentrics), with its error bound, as the shader computes it.
fn point_on(tri: &[Vec3; 3], rng: &mut Rng) -> (Vec3, Vec3) {
    let (u, v) = (rng.next_f32(), rng.next_f32());
    let (u, v) = if u + v > 1.0 {
        (1.0 - u, 1.0 - v)
    } else {
        (u, v)
    };
    hit_point(tri, [1.0 - u - v, u, v])
}

fn triangles(rng: &mut Rng) -> Vec<[Vec3; 3]> {
    let mut tris = random_soup(300, rng);
    // A floor like SPD's tree's, and one far out.
    for offset in [Vec3::ZERO, Vec3::new(1000.0, -700.0, 30.0)] {
        let c = [
            Vec3::new(50.0, 50.0, 0.0),
            Vec3::new(-50.0, 50.0, 0.0),
            Vec3::new(-50.0, -50.0, 0.0),
            Vec3::new(50.0, -50.0, 0.0),
        ]
        .map(|p| p + offset);
        tris.push([c[0], c[1], c[2]]);
        tris.push([c[0], c[2], c[3]]);
    }
    tris
}

/// A polygon of `n` corners around `centre`, in the plane `z = centre.z`, each at a random
/// distance from `radius · (1 − wobble)` to `radius`, fanned into triangles from its first
/// corner, as SPD's gears write their faces.
fn fan(centre: Vec3, radius: f32, n: usize, wobble: f32, rng: &mut Rng) -> Vec<[Vec3; 3]> {
    let corners: Vec<Vec3> = (0..n)
        .map(|k| {
            let a = k as f32 / n as f32 * std::f32::consts::TAU;
            let r = radius * rng.range(1.0 - wobble, 1.0);
            centre + Vec3::new(r * a.cos(), r * a.sin(), 0.0)
        })
        .collect();
    (1..n - 1)
        .map(|k| [corners[0], corners[k], corners[k + 1]])
        .collect()
}

/// [`triangles`] and three fanned faces, two of them in one plane far apart.
fn with_fans(rng: &mut Rng) -> Vec<[Vec3; 3]> {
    let mut tris = triangles(rng);
    for (centre, radius) in [
        (Vec3::new(-0.3121, 2.7, 1.0), 2.0),
        (Vec3::new(6.0, -5.0, 1.0), 1.5),
        (Vec3::new(300.7, -20.1, -77.3), 40.0),
    ] {
        tris.extend(fan(centre, radius, 48, 0.2, rng));
    }
    tris
}

#[test]
fn a_ray_leaving_a_triangle_never_meets_another_of_its_axis_plane() {
    let mut rng = Rng::new(41);
    let tris = with_fans(&mut rng);
    let planes = AxisPlanes::new(&tris);
    let shared: Vec<usize> = (0..tris.len())
        .filter(|&i| planes.of(i as u32) != AxisPlanes::NONE)
        .collect();
    assert_eq!(shared.len(), 4 + 3 * 46, "the floors' halves and the fans");
    for k in 0..200_000 {
        let i = shared[k % shared.len()];
        let plane = planes.of(i as u32);
        let mates: Vec<usize> = shared
            .iter()
            .copied()
            .filter(|&j| j != i && planes.of(j as u32) == plane)
            .collect();
        let j = mates[(rng.next_u64() % mates.len() as u64) as usize];
        let (tri, mate) = (&tris[i], &tris[j]);
        let n = unit_normal(tri).expect("a fan's triangles have area");
        let (p, err) = point_on(tri, &mut rng);
        // Towards anywhere: steep, grazing (almost in the plane) and across the mate.
        let w = match k % 3 {
            0 => rng.direction(),
            1 => (rng.direction() + n * rng.range(-1e-3, 1e-3)).normalize(),
            _ => point_on(mate, &mut rng).0 - p + n * rng.range(-1e-2, 1e-2),
        };
        let ray = Ray::new(offset_ray_origin(p, err, n, w), w);
        let hit = intersect(&RayFrame::new(&ray), mate, f32::INFINITY);
        assert!(
            hit.is_none(),
            "ray {k} leaving triangle {i} meets {j} of its plane: {hit:?}, {ray:?}"
        );
    }
}

/// Checks `Scene::shadowed` against `any_hit` on 20,000 shadow rays, each leaving a random
/// triangle of `tris` (in `scene`) for the light at `light_at(rng)`, asked as light `light`;
/// `prime(k, i, memory)` sets what the query remembers. Both answers must occur often.
fn shadowed_answers_as_any_hit(
    scene: &Scene,
    tris: &[[Vec3; 3]],
    rng: &mut Rng,
    (light, mut light_at): (Option<usize>, impl FnMut(&mut Rng) -> Vec3),
    mut prime: impl FnMut(u32, u32, &mut ShadowMemory),
) {
    let mut scratch = QueryScratch::default();
    let mut last = ShadowMemory::default();
    let (mut blocked, mut free) = (0, 0);
    for k in 0..20_000u32 {
        let i = (rng.next_u64() % tris.len() as u64) as u32;
        let tri = &tris[i as usize];
        let Some(n) = unit_normal(tri) else { continue };
        let (p, err) = point_on(tri, rng);
        let to = light_at(rng);
        let origin = offset_ray_origin(p, err, n, to - p);
        let ray = Ray::new(origin, to - origin);
        let want = scene.any_hit(&ray, 1.0, &mut scratch);
        prime(k, i, &mut last);
        let got = scene.shadowed(&ray, 1.0, &mut scratch, (light, &mut last, Some(i)));
        assert_eq!(got, want, "ray {k} leaving {i}: {ray:?}");
        if want {
            blocked += 1;
        } else {
            free += 1;
        }
    }
    assert!(
        blocked > 1000 && free > 1000,
        "{blocked} blocked, {free} free"
    );
}

#[test]
fn shadowed_leaving_a_shared_plane_answers_as_any_hit_through_the_lights_buffer() {
    let mut rng = Rng::new(43);
    let tris = with_fans(&mut rng);
    let light = Vec3::new(0.5, 1.5, 8.0);
    let mut desc = lit(light);
    add_triangles(&mut desc, &tris);
    let scene = Scene::build(&desc, &OctreeParams::default()).expect("valid scene");
    assert!(scene.light_buffers[0].is_some(), "the light has a buffer");
    // What the query remembers is carried from one to the next, as a tracer's is.
    let at_light = (Some(0), |_: &mut Rng| light);
    shadowed_answers_as_any_hit(&scene, &tris, &mut rng, at_light, |_, _, _| {});
}

#[test]
fn a_ray_leaving_a_triangle_never_meets_it() {
    let mut rng = Rng::new(31);
    let tris = triangles(&mut rng);
    let mut floor_rays = 0;
    for k in 0..200_000 {
        let i = if k % 2 == 0 {
            tris.len() - 1 - k % 4
        } else {
            k % tris.len()
        };
        let tri = &tris[i];
        let Some(n) = unit_normal(tri) else { continue };
        let (p, err) = point_on(tri, &mut rng);
        // Towards anywhere: steep, grazing (almost in the plane) and through the triangle.
        let w = match k % 3 {
            0 => rng.direction(),
            1 => (rng.direction() + n * rng.range(-1e-3, 1e-3)).normalize(),
            _ => rng.direction() * rng.range(1.0, 60.0),
        };
        let origin = offset_ray_origin(p, err, n, w);
        let ray = Ray::new(origin, w);
        let hit = intersect(&RayFrame::new(&ray), tri, f32::INFINITY);
        assert!(
            hit.is_none(),
            "ray {k} leaving triangle {i} meets it: {hit:?}, {ray:?}"
        );
        floor_rays += usize::from(i >= tris.len() - 4);
    }
    assert!(floor_rays > 90_000, "{floor_rays} rays leave the floors");
}

#[test]
fn shadowed_leaving_a_triangle_answers_as_any_hit() {
    let mut rng = Rng::new(37);
    let tris = triangles(&mut rng);
    let mut desc = lit(Vec3::new(0.0, 0.0, 10.0));
    add_triangles(&mut desc, &tris);
    let scene = Scene::build(&desc, &OctreeParams::default()).expect("valid scene");
    let anywhere = |rng: &mut Rng| {
        Vec3::new(
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
            rng.range(-3.0, 3.0),
        )
    };
    // Remembering the triangle it leaves changes nothing either.
    let remember_it = |k: u32, i: u32, last: &mut ShadowMemory| {
        *last = ShadowMemory::default();
        last.blockers[k as usize % SHADOW_CACHE] = Some(i).filter(|_| k % 3 != 0);
    };
    shadowed_answers_as_any_hit(&scene, &tris, &mut rng, (None, anywhere), remember_it);
}

/// Shadow rays from points sweeping under a fanned face (a regular 48-gon fanned from its first
/// corner, as SPD's gears write their faces) towards a light far above it: each is blocked, and
/// where the sweep passes from one of the fan's triangles to the next, the triangle listed next
/// to the remembered blocker settles the query. Without trying the neighbours every such step
/// walks the octree (the sweep crosses 24 of the triangles); with them only the first query
/// walks.
#[test]
fn shadow_rays_crossing_a_fan_are_settled_by_the_remembered_triangles_neighbours() {
    // A regular polygon: convex, so its fan covers the disc the sweep stays in.
    let tris = fan(Vec3::new(0.0, 0.0, 1.0), 2.0, 48, 0.0, &mut Rng::new(47));
    let light = Vec3::new(0.0, 0.0, 1000.0);
    let mut desc = lit(light);
    add_triangles(&mut desc, &tris);
    let scene = Scene::build(&desc, &OctreeParams::default()).expect("valid scene");
    let mut scratch = QueryScratch::default();
    let mut memory = ShadowMemory::default();
    let (mut blocked, mut walked, mut blockers) = (0, 0, std::collections::BTreeSet::new());
    for k in 0..2000 {
        let a = 0.3 + (std::f32::consts::TAU - 0.6) * k as f32 / 2000.0;
        let p = Vec3::new(1.4 * a.cos(), 1.4 * a.sin(), 0.0);
        let ray = Ray::new(p, light - p);
        let cells = scratch.work.octree_cells;
        let got = scene.shadowed(&ray, 1.0, &mut scratch, (None, &mut memory, None));
        assert_eq!(
            got,
            scene.any_hit(&ray, 1.0, &mut QueryScratch::default()),
            "ray {k}"
        );
        blocked += usize::from(got);
        walked += usize::from(scratch.work.octree_cells > cells);
        blockers.extend(memory.blockers[0]);
    }
    assert_eq!(blocked, 2000, "every ray crosses the face");
    assert!(blockers.len() > 20, "{} triangles blocked", blockers.len());
    assert!(walked <= 2, "{walked} queries walked the octree");
}

/// Four rays leaving one triangle, walked together with it named as the triangle each leaves
/// (`Scene::closest_hits4`'s `leaving`, as the tracer names it for mirror and refracted rays):
/// each finds the hit it finds alone and the hit the packet finds without the names, and the
/// walk tests fewer primitives (the triangle left is not tested).
#[test]
fn packets_leaving_a_triangle_find_their_hits_without_testing_it() {
    let mut rng = Rng::new(41);
    let tris = triangles(&mut rng);
    let mut desc = lit(Vec3::new(0.0, 0.0, 10.0));
    add_triangles(&mut desc, &tris);
    let scene = Scene::build(&desc, &OctreeParams::default()).expect("valid scene");
    let mut scratch = QueryScratch::default();
    let tests = |scratch: &mut QueryScratch| std::mem::take(&mut scratch.work).intersection_tests;
    let (mut named, mut unnamed, mut packets, mut hits) = (0, 0, 0, 0);
    for k in 0..20_000 {
        let i = k % tris.len();
        let tri = &tris[i];
        let Some(n) = unit_normal(tri) else { continue };
        let towards = rng.direction();
        let rays: [Ray; LANES] = std::array::from_fn(|_| {
            let (p, err) = point_on(tri, &mut rng);
            let w = (towards + rng.direction() * 0.05).normalize();
            Ray::new(offset_ray_origin(p, err, n, w), w)
        });
        let signs = |r: &Ray| r.dir.to_array().map(|d| d < 0.0);
        packets += usize::from(rays.iter().all(|r| signs(r) == signs(&rays[0])));
        tests(&mut scratch);
        let leaving =
            scene.closest_hits4(&rays, f32::INFINITY, [Some(i as u32); LANES], &mut scratch);
        named += tests(&mut scratch);
        let anonymous = scene.closest_hits4(&rays, f32::INFINITY, [None; LANES], &mut scratch);
        unnamed += tests(&mut scratch);
        for (l, ray) in rays.iter().enumerate() {
            assert_eq!(leaving[l], anonymous[l], "packet {k}, ray {l}");
            let alone = scene.closest_hit(ray, f32::INFINITY, &mut scratch);
            assert_eq!(leaving[l], alone, "packet {k}, ray {l}");
            hits += usize::from(alone.is_some());
        }
    }
    assert!(packets > 15_000, "only {packets} packets walked together");
    assert!(hits > 5_000, "only {hits} rays hit something");
    assert!(
        unnamed - named > 3 * packets as u64,
        "{named} tests naming the triangle left, {unnamed} without ({packets} packets)"
    );
}
