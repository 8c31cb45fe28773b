//! Rays inside a transparent lone sphere find their closest hit from the sphere and the few
//! primitives near it (`Scene::closest_hit_inside`), to the walk's answer: from random points in
//! the sphere's box and from surface points moved inwards (as the shader moves a refracted ray's
//! origin), in spheres that touch, overlap, nest and are crossed by triangles. Spheres near more
//! primitives than `MAX_NEIGHBOURS`, and opaque ones, have no entry and are left to the walk.

use glam::Vec3;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::accel::sphere_interiors::MAX_NEIGHBOURS;
use strahl_core::geom::solid::{Shape, SolidNode};
use strahl_core::math::ray::{offset_ray_origin, Ray};
use strahl_core::math::transform::Transform;
use strahl_core::render::intersect::{PrimitiveHit, QueryScratch};
use strahl_core::scene::mesh::Rng;
use strahl_core::scene::{Scene, SceneDesc, Shader};
use strahl_core_tests::meshes::random_soup;
use strahl_core_tests::scenes::{add_solid, add_triangles, lit};

/// Adds a sphere of `radius` at `centre` with shader `shader`; returns its object index.
fn sphere(desc: &mut SceneDesc, centre: Vec3, radius: f32, shader: u32) -> u32 {
    let object = desc.objects.len() as u32;
    add_solid(desc, Shape::Sphere { radius }, Transform::translate(centre));
    if let Some(SolidNode::Leaf { shader: s, .. }) = desc.solids.last_mut() {
        *s = shader;
    }
    object
}

/// Glass spheres that touch (a pyramid as SPD's mount stacks them), overlap, nest, stand in a
/// triangle soup, and one far out; an opaque sphere; a glass sphere around a hundred
/// triangles. Shader 1 is glass.
fn scene(rng: &mut Rng) -> (Scene, Vec<u32>, u32, u32) {
    let mut desc = lit(Vec3::new(5.0, 6.0, 7.0));
    let mut glass = Shader::phong(Vec3::splat(0.1), Vec3::ZERO, Vec3::ONE, 20.0, 0.1);
    glass.transparency = 0.8;
    glass.ior = 1.5;
    desc.shaders.push(glass);
    add_triangles(&mut desc, &random_soup(200, rng));
    let mut clear = Vec::new();
    let r = 0.17;
    let top = Vec3::new(-0.8, 0.8, 1.20821);
    clear.push(sphere(&mut desc, top, r, 1));
    for c in [
        Vec3::new(-0.661196, 0.661196, 0.930598),
        Vec3::new(-0.749194, 0.98961, 0.930598),
        Vec3::new(-0.98961, 0.749194, 0.930598),
    ] {
        clear.push(sphere(&mut desc, c, r, 1));
    }
    // Overlapping, nested, in the soup, far out.
    clear.push(sphere(&mut desc, Vec3::new(3.0, 0.0, 0.0), 0.5, 1));
    clear.push(sphere(&mut desc, Vec3::new(3.6, 0.1, 0.0), 0.4, 1));
    clear.push(sphere(&mut desc, Vec3::new(0.0, -3.0, 0.0), 0.8, 1));
    sphere(&mut desc, Vec3::new(0.1, -3.1, 0.1), 0.2, 0);
    clear.push(sphere(&mut desc, Vec3::new(0.3, 0.2, -0.1), 0.25, 1));
    clear.push(sphere(&mut desc, Vec3::new(1000.5, -700.25, 30.0), 3.0, 1));
    let opaque = sphere(&mut desc, Vec3::new(-3.0, 2.0, 0.0), 0.5, 0);
    // A glass sphere around many small triangles.
    let crowded_centre = Vec3::new(0.0, 4.0, 0.0);
    let tris: Vec<[Vec3; 3]> = random_soup(100, rng)
        .into_iter()
        .map(|t| t.map(|p| crowded_centre + p * 0.3))
        .collect();
    add_triangles(&mut desc, &tris);
    let crowded = sphere(&mut desc, crowded_centre, 1.0, 1);
    let scene = Scene::build(&desc, &OctreeParams::default()).expect("a valid scene");
    (scene, clear, opaque, crowded)
}

#[test]
fn inside_rays_get_the_walks_hits() {
    let mut rng = Rng::new(7);
    let (scene, clear, _, _) = scene(&mut rng);
    let mut q = QueryScratch::default();
    let (mut asked, mut answered, mut other_won) = (0u32, 0u32, 0u32);
    for &j in &clear {
        let Some(inside) = scene.sphere_interiors.of(j) else {
            panic!("sphere {j} has no entry");
        };
        let b = inside.bounds;
        let centre = (b.min + b.max) * 0.5;
        let radius = (b.max.x - b.min.x) * 0.5;
        for k in 0..4000 {
            let dir = rng.direction() * rng.range(0.1, 10.0);
            let origin = if k % 2 == 0 {
                // Anywhere in the box, corners outside the sphere included.
                Vec3::new(
                    rng.range(b.min.x, b.max.x),
                    rng.range(b.min.y, b.max.y),
                    rng.range(b.min.z, b.max.z),
                )
            } else {
                // A surface point moved inwards, as a refracted ray's origin.
                let n_out = rng.direction();
                let p = centre + n_out * radius;
                let err = p.abs() * 4.0 * f32::EPSILON;
                let inward = if dir.dot(n_out) < 0.0 { dir } else { -dir };
                offset_ray_origin(p, err, n_out, inward)
            };
            let dir = if k % 2 == 1 && dir.dot(origin - centre) > 0.0 {
                -dir
            } else {
                dir
            };
            let ray = Ray::new(origin, dir);
            asked += 1;
            let walk = scene.closest_hit(&ray, f32::INFINITY, &mut q);
            if let Some(hit) = scene.closest_hit_inside(j, &ray, &mut q) {
                answered += 1;
                assert_eq!(hit, walk, "sphere {j}, ray {ray:?}");
                other_won += u32::from(!matches!(hit, Some(PrimitiveHit::Solid(o, _)) if o == j));
            }
        }
    }
    // Most rays are answered, and in some a neighbour comes first (so the neighbours matter).
    assert!(answered * 10 > asked * 8, "{answered} of {asked}");
    assert!(other_won > 100, "{other_won}");
}

#[test]
fn crowded_and_opaque_spheres_walk() {
    let mut rng = Rng::new(8);
    let (scene, _, opaque, crowded) = scene(&mut rng);
    assert!(scene.sphere_interiors.of(opaque).is_none());
    assert!(
        scene.sphere_interiors.of(crowded).is_none(),
        "more than {MAX_NEIGHBOURS} near"
    );
    let ray = Ray::new(Vec3::new(0.0, 4.0, 0.0), Vec3::X);
    assert!(scene
        .closest_hit_inside(crowded, &ray, &mut QueryScratch::default())
        .is_none());
}

#[test]
fn rays_starting_outside_the_box_walk() {
    let mut rng = Rng::new(9);
    let (scene, clear, _, _) = scene(&mut rng);
    let mut q = QueryScratch::default();
    let j = clear[0];
    let b = scene.sphere_interiors.of(j).expect("an entry").bounds;
    let ray = Ray::new(b.max + Vec3::splat(0.01), -Vec3::ONE);
    assert!(scene.closest_hit_inside(j, &ray, &mut q).is_none());
}
