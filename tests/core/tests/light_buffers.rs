//! Shadow rays answered from a light's buffer (`Scene::shadowed` with the light's index) give
//! the octree walk's answer: on triangles, lone spheres, boxes and cones, a half-space, with
//! lights outside, inside and on a triangle's corner, from points in space and on surfaces, and
//! leaving the triangle a ray starts on; and the same far from the origin, tiny and huge, with a
//! light in a floor's plane, one far away and one inside a closed mesh.

use glam::Vec3;
use strahl_core::accel::light_buffer::{Candidates, LightBuffer, SIZED_FOR};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::geom::solid::Shape;
use strahl_core::math::ray::{offset_ray_origin, Ray};
use strahl_core::math::transform::Transform;
use strahl_core::render::intersect::{QueryScratch, ShadowMemory};
use strahl_core::scene::mesh::{MeshBuilder, Rng};
use strahl_core::scene::prepared::light_buffer_peak;
use strahl_core::scene::{Light, Scene, SceneDesc};
use strahl_core_tests::meshes::{positions, random_soup};
use strahl_core_tests::scenes::{add_solid, add_triangles, lit};

fn point(rng: &mut Rng, r: f32) -> Vec3 {
    Vec3::new(rng.range(-r, r), rng.range(-r, r), rng.range(-r, r))
}

/// A soup, spheres, boxes and cones, a floor half-space, and five lights: far, near, inside the
/// cloud, on a triangle's corner, and one that casts no shadows.
fn desc(rng: &mut Rng) -> (SceneDesc, Vec<[Vec3; 3]>) {
    let soup = random_soup(600, rng);
    let mut desc = lit(Vec3::new(0.0, 30.0, 4.0));
    add_triangles(&mut desc, &soup);
    // A triangle with a corner on a light, outside the cloud.
    let corner = Vec3::new(3.5, -1.0, 3.0);
    add_triangles(&mut desc, &[[corner, corner + Vec3::X, corner + Vec3::Z]]);
    for k in 0..120 {
        let shape = match k % 3 {
            0 => Shape::Sphere {
                radius: rng.range(0.02, 0.3),
            },
            1 => Shape::Cuboid {
                size: Vec3::splat(rng.range(0.05, 0.4)),
            },
            _ => Shape::Cylinder {
                bottom_radius: rng.range(0.05, 0.3),
                top_radius: 0.0,
                height: rng.range(0.1, 0.6),
            },
        };
        add_solid(&mut desc, shape, Transform::translate(point(rng, 2.0)));
    }
    let floor = Shape::Plane {
        normal: Vec3::Y,
        d: -2.5,
    };
    add_solid(&mut desc, floor, Transform::IDENTITY);
    let light = desc.lights[0];
    for (position, casts_shadows) in [
        (Vec3::new(3.0, 1.0, -2.5), true),
        (Vec3::new(0.1, -0.2, 0.3), true),
        (corner, true),
        (Vec3::new(-4.0, 2.0, 1.0), false),
    ] {
        desc.lights.push(Light {
            position,
            casts_shadows,
            ..light
        });
    }
    (desc, soup)
}

fn scene(rng: &mut Rng) -> (Scene, Vec<[Vec3; 3]>) {
    let (desc, soup) = desc(rng);
    let scene = Scene::build(&desc, &OctreeParams::default()).expect("valid scene");
    (scene, soup)
}

/// Shadow rays a buffer answered from a list, and how many of those were blocked and free.
#[derive(Default)]
struct Listed {
    listed: usize,
    blocked: usize,
    free: usize,
}

impl Listed {
    /// Counts `ray` if `buffer` answers it from a list; `blocked` is the walk's answer.
    fn count(&mut self, buffer: Option<&LightBuffer>, ray: &Ray, blocked: bool) {
        if buffer.is_some_and(|b| b.candidates(ray, 1.0) != Candidates::Walk) {
            self.listed += 1;
            self.blocked += usize::from(blocked);
            self.free += usize::from(!blocked);
        }
    }

    /// Asserts that over `listed` rays were answered from a list, over `each` of them blocked
    /// and over `each` free.
    fn assert_over(&self, listed: usize, each: usize) {
        let Listed {
            listed: n,
            blocked,
            free,
        } = *self;
        assert!(n > listed, "{n} rays answered from a buffer");
        assert!(
            blocked > each && free > each,
            "{blocked} blocked, {free} free"
        );
    }
}

#[test]
fn shadowed_by_a_light_buffer_answers_as_the_walk() {
    let mut rng = Rng::new(41);
    let (scene, soup) = scene(&mut rng);
    let lights = scene.lights.len();
    // The lights outside the cloud have buffers (one on a triangle's corner), and so has the
    // one inside it (each face files only what its pyramid sees); the one that casts no
    // shadows has none.
    assert!((0..4).all(|l| scene.light_buffers[l].is_some()));
    assert!(scene.light_buffers[4].is_none());
    let mut scratch = QueryScratch::default();
    let mut listed = Listed::default();
    let mut caches = vec![ShadowMemory::default(); lights];
    for k in 0..40_000usize {
        let l = k % lights;
        let light = scene.lights[l].position;
        // From points in space, and from points on the soup's triangles leaving them.
        let (origin, leaving) = if k % 2 == 0 {
            (point(&mut rng, 3.0), None)
        } else {
            let i = rng.next_u64() as usize % soup.len();
            let t = soup[i];
            let p = rng.point_in_triangle(&t);
            let n = (t[1] - t[0]).cross(t[2] - t[0]).normalize_or_zero();
            if n == Vec3::ZERO {
                continue;
            }
            let err = p.abs() * 1e-6;
            (offset_ray_origin(p, err, n, light - p), Some(i as u32))
        };
        let ray = Ray::new(origin, light - origin);
        let mut none = ShadowMemory::default();
        let want = scene.shadowed(&ray, 1.0, &mut scratch, (None, &mut none, leaving));
        if leaving.is_none() {
            assert_eq!(want, scene.any_hit(&ray, 1.0, &mut scratch), "ray {k}");
        }
        // Fresh, and with what the light remembers from earlier rays.
        let mut fresh = ShadowMemory::default();
        let got = scene.shadowed(&ray, 1.0, &mut scratch, (Some(l), &mut fresh, leaving));
        assert_eq!(
            got, want,
            "ray {k} to light {l}: {ray:?}, leaving {leaving:?}"
        );
        let remembered =
            scene.shadowed(&ray, 1.0, &mut scratch, (Some(l), &mut caches[l], leaving));
        assert_eq!(remembered, want, "ray {k} to light {l}, remembering");
        listed.count(scene.light_buffers[l].as_ref(), &ray, want);
    }
    // Most rays are answered from the buffers, both ways.
    listed.assert_over(20_000, 2000);
}

/// A scene of a few primitives (SPD's balls_1 has twelve: ten spheres and a floor's two
/// triangles) gets a buffer for its light too, and the buffer answers as the walk does.
#[test]
fn a_small_scene_has_a_light_buffer_that_answers_as_the_walk() {
    let mut rng = Rng::new(47);
    let mut desc = lit(Vec3::new(4.0, 6.0, 5.0));
    for _ in 0..10 {
        let sphere = Shape::Sphere {
            radius: rng.range(0.1, 0.6),
        };
        add_solid(
            &mut desc,
            sphere,
            Transform::translate(point(&mut rng, 1.5)),
        );
    }
    let floor = [-3.0, 3.0].map(|x| Vec3::new(x, -2.0, -3.0));
    let far = [3.0, -3.0].map(|x| Vec3::new(x, -2.0, 3.0));
    add_triangles(
        &mut desc,
        &[[floor[0], floor[1], far[0]], [floor[0], far[0], far[1]]],
    );
    let scene = Scene::build(&desc, &OctreeParams::default()).expect("valid scene");
    let buffer = scene.light_buffers[0].as_ref();
    assert!(
        buffer.is_some(),
        "a scene of 12 primitives gets a light buffer"
    );
    let light = scene.lights[0].position;
    let mut scratch = QueryScratch::default();
    let mut listed = Listed::default();
    for k in 0..5_000 {
        let origin = point(&mut rng, 2.5);
        let ray = Ray::new(origin, light - origin);
        let want = scene.any_hit(&ray, 1.0, &mut scratch);
        let mut memory = ShadowMemory::default();
        let got = scene.shadowed(&ray, 1.0, &mut scratch, (Some(0), &mut memory, None));
        assert_eq!(got, want, "ray {k}: {ray:?}");
        listed.count(buffer, &ray, want);
    }
    listed.assert_over(4_000, 300);
}

#[test]
fn light_buffers_save_the_walk() {
    let mut rng = Rng::new(43);
    let (scene, _) = scene(&mut rng);
    let light = scene.lights[0].position;
    let (mut walked, mut listed) = (QueryScratch::default(), QueryScratch::default());
    for _ in 0..5000 {
        let origin = point(&mut rng, 2.5);
        let ray = Ray::new(origin, light - origin);
        let (mut a, mut b) = (ShadowMemory::default(), ShadowMemory::default());
        scene.shadowed(&ray, 1.0, &mut walked, (None, &mut a, None));
        scene.shadowed(&ray, 1.0, &mut listed, (Some(0), &mut b, None));
    }
    // A lookup counts as one cell: far fewer cells, and fewer tests, than the walk.
    let (w, l) = (walked.work, listed.work);
    assert!(l.octree_cells * 2 < w.octree_cells, "{l:?} against {w:?}");
    assert!(
        l.intersection_tests < w.intersection_tests,
        "{l:?} against {w:?}"
    );
}

/// The same soup moved and scaled: far from the origin, tiny, huge; with a floor whose plane
/// holds a light, a light far away, and a light inside a closed sphere mesh.
#[test]
fn light_buffers_answer_as_the_walk_at_every_scale() {
    let mut rng = Rng::new(47);
    for (offset, scale) in [
        (Vec3::ZERO, 1.0),
        (Vec3::new(1e5, -3e4, 2e5), 1.0),
        (Vec3::new(-2e3, 1e3, 5e2), 1e-3),
        (Vec3::new(3.0, -1.0, 2.0), 1e4),
    ] {
        let place = |p: Vec3| offset + p * scale;
        let mut soup: Vec<[Vec3; 3]> = random_soup(400, &mut rng)
            .into_iter()
            .map(|t| t.map(place))
            .collect();
        // A floor at y = -1.5 and a closed ball around (2, 0, 0).
        let floor = [(-4.0, -4.0), (4.0, -4.0), (4.0, 4.0), (-4.0, 4.0)]
            .map(|(x, z)| place(Vec3::new(x, -1.5, z)));
        soup.push([floor[0], floor[1], floor[2]]);
        soup.push([floor[0], floor[2], floor[3]]);
        let mut ball = MeshBuilder::default();
        let centre = place(Vec3::new(2.0, 0.0, 0.0));
        ball.sphere(centre, 0.4 * scale, 12, 8, 0.0, 0, &mut rng);
        soup.extend(positions(&ball));
        let mut desc = lit(place(Vec3::new(0.5, 3.0, 1.0)));
        add_triangles(&mut desc, &soup);
        let light = desc.lights[0];
        for position in [
            place(Vec3::new(6.0, -1.5, 0.5)),
            place(Vec3::new(-3e3, 5e3, 1e3)),
            place(Vec3::new(2.0, 0.05, 0.0)),
        ] {
            desc.lights.push(Light { position, ..light });
        }
        let scene = Scene::build(&desc, &OctreeParams::default()).expect("valid scene");
        assert!(
            scene.light_buffers[0].is_some(),
            "offset {offset}, scale {scale}"
        );
        let mut scratch = QueryScratch::default();
        let mut listed = 0;
        for k in 0..8000usize {
            let l = k % scene.lights.len();
            let target = scene.lights[l].position;
            let t = soup[rng.next_u64() as usize % soup.len()];
            let on = rng.point_in_triangle(&t);
            let origin = if k % 3 == 0 {
                place(point(&mut rng, 3.0))
            } else {
                on
            };
            let ray = Ray::new(origin, target - origin);
            let mut none = ShadowMemory::default();
            let want = scene.shadowed(&ray, 1.0, &mut scratch, (None, &mut none, None));
            let mut fresh = ShadowMemory::default();
            let got = scene.shadowed(&ray, 1.0, &mut scratch, (Some(l), &mut fresh, None));
            assert_eq!(
                got, want,
                "offset {offset}, scale {scale}, light {l}: {ray:?}"
            );
            let buffer = scene.light_buffers[l].as_ref();
            listed +=
                usize::from(buffer.is_some_and(|b| b.candidates(&ray, 1.0) != Candidates::Walk));
        }
        assert!(
            listed > 2000,
            "offset {offset}, scale {scale}: {listed} answered from a buffer"
        );
    }
}

/// A node with little memory (a board's heap) builds buffers only where the most their build
/// can take fits in what the scene leaves, one light after the other, sized as finely as that
/// memory allows.
#[test]
fn light_buffers_stay_within_the_memory_given() {
    let (desc, _) = desc(&mut Rng::new(53));
    let params = OctreeParams::default();
    let within = |memory| Scene::build_within(&desc, &params, memory).expect("valid scene");
    let present = |scene: &Scene| {
        scene
            .light_buffers
            .iter()
            .map(Option::is_some)
            .collect::<Vec<_>>()
    };
    let built = |memory| present(&within(memory));
    let first_bytes = |scene: &Scene| scene.light_buffers[0].as_ref().map(|b| b.bytes());
    let unlimited = within(u64::MAX);
    assert_eq!(
        present(&unlimited),
        [true, true, true, true, false],
        "light 4 casts none"
    );
    let peak = |least| light_buffer_peak(desc.triangles.len(), desc.objects.len(), least);
    let [fine, coarse] = SIZED_FOR.map(peak);
    assert!(
        coarse < fine,
        "{coarse} bytes sized coarsely, {fine} finely"
    );
    assert_eq!(built(0), [false; 5]);
    assert_eq!(built(coarse - 1), [false; 5]);
    let first = first_bytes(&unlimited).expect("a buffer");
    let (coarsely, finely) = (within(coarse), within(fine));
    let first_coarse = first_bytes(&coarsely).expect("a buffer");
    // Enough for one: the first light's buffer leaves less than the next one may need.
    assert_eq!(present(&coarsely), [true, false, false, false, false]);
    assert_eq!(present(&finely), [true, false, false, false, false]);
    assert!(
        first < fine && first_coarse < coarse && first_coarse < first,
        "{first} bytes kept of {fine} at most, {first_coarse} of {coarse} sized coarsely"
    );
    assert_eq!(
        first_bytes(&finely),
        Some(first),
        "memory for the fine peak gets the fine buffer"
    );
    assert_eq!(built(fine + first), [true, true, false, false, false]);
}
