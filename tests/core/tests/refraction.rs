//! Refraction through solids: the lateral offset of a glass slab, total internal reflection at
//! the critical angle, nested media, and the weight cut-off and depth cap for refraction rays.

use glam::Vec3;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::geom::solid::prepared::SolidSurface;
use strahl_core::geom::solid::{CsgOp, Shape, SolidNode};
use strahl_core::math::ray::{offset_ray_origin, Ray};
use strahl_core::math::transform::Transform;
use strahl_core::render::intersect::PrimitiveHit;
use strahl_core::render::intersect::QueryScratch;
use strahl_core::render::optics::refract;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::render::shade::{trace, TraceScratch};
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::camera::{Camera, LookAtCamera};
use strahl_core::scene::{Blend, Light, RenderSettings, Scene, SceneDesc, Shader};

// ---------------------------------------------------------------------------------------------
// Builders
// ---------------------------------------------------------------------------------------------

/// A clear material: everything goes through, nothing is reflected or lit.
fn glass(ior: f32) -> Shader {
    Shader {
        ambient: Vec3::ZERO,
        diffuse: Vec3::ZERO,
        specular: Vec3::ZERO,
        shininess: 1.0,
        reflection: 0.0,
        transparency: 1.0,
        ior,
        blend: Blend::Share,
    }
}

/// An opaque material that shows its ambient grey and nothing else.
fn glow(grey: f32) -> Shader {
    Shader::phong(Vec3::splat(grey), Vec3::ZERO, Vec3::ZERO, 1.0, 0.0)
}

fn leaf(shape: Shape, transform: Transform, shader: u32) -> SolidNode {
    SolidNode::Leaf {
        shape,
        transform,
        shader,
    }
}

/// A scene of solids with a camera at `eye` looking at `at`, `width × height` pixels.
fn desc(
    shaders: Vec<Shader>,
    solids: Vec<SolidNode>,
    objects: Vec<u32>,
    eye: Vec3,
    at: Vec3,
    vfov_deg: f32,
    size: (u32, u32),
) -> SceneDesc {
    let forward = (at - eye).normalize();
    let up = if forward.y.abs() > 0.9 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    SceneDesc {
        shaders,
        lights: vec![Light {
            position: Vec3::new(0.0, 1000.0, 0.0),
            color: Vec3::ONE,
            amount: 1.0,
            casts_shadows: false,
        }],
        solids,
        objects,
        camera: Camera::LookAt(LookAtCamera {
            position: eye,
            look_at: at,
            up,
            vfov_deg,
        }),
        settings: RenderSettings {
            width: size.0,
            height: size.1,
            background: Vec3::ZERO,
            ..RenderSettings::default()
        },
        ..SceneDesc::default()
    }
}

fn build(desc: &SceneDesc) -> Scene {
    Scene::build(desc, &OctreeParams::default()).expect("valid scene")
}

/// Renders line `y`; returns the pixels and the rays.
fn line(scene: &Scene, y: u32) -> (Vec<Pixel>, RayCounts) {
    let mut px = vec![Pixel::default(); scene.settings.width as usize];
    let counts = render_line(scene, y, &mut px).expect("line renders");
    (px, counts)
}

/// A one-pixel scene whose only camera ray starts at `eye` and runs exactly along `dir`.
fn one_pixel(
    shaders: Vec<Shader>,
    solids: Vec<SolidNode>,
    objects: Vec<u32>,
    eye: Vec3,
    dir: Vec3,
) -> SceneDesc {
    desc(shaders, solids, objects, eye, eye + dir, 30.0, (1, 1))
}

#[derive(Clone, Copy, Debug)]
struct Found {
    object: u32,
    surface: SolidSurface,
}

fn closest(scene: &Scene, ray: &Ray) -> Option<Found> {
    let mut scratch = QueryScratch::default();
    match scene.closest_hit(ray, f32::INFINITY, &mut scratch)? {
        PrimitiveHit::Solid(object, hit) => Some(Found {
            object,
            surface: scene.solids.surface(ray, &hit),
        }),
        PrimitiveHit::Triangle(..) => panic!("these scenes have no triangles"),
    }
}

/// One refraction, done by hand with the core's pieces: the next hit, its normal turned to face
/// the ray, Snell's law from `n1` into `n2`, and the origin offset to the far side. `None` on
/// total internal reflection.
fn refract_at(scene: &Scene, ray: &Ray, n1: f32, n2: f32) -> (Found, Option<Ray>) {
    let f = closest(scene, ray).expect("the ray hits a surface");
    let d = ray.dir.normalize();
    let n = if f.surface.normal.dot(d) < 0.0 {
        f.surface.normal
    } else {
        -f.surface.normal
    };
    let next = refract(d, n, n1, n2).map(|t| {
        let o = offset_ray_origin(f.surface.point, f.surface.point_error, n, t);
        Ray::new(o, t)
    });
    (f, next)
}

/// The distance of the point `p` from the line through `o` along the unit vector `u`.
fn line_distance(p: Vec3, o: Vec3, u: Vec3) -> f32 {
    let v = p - o;
    (v - u * v.dot(u)).length()
}

// ---------------------------------------------------------------------------------------------
// The glass slab
// ---------------------------------------------------------------------------------------------

const SLAB_IOR: f32 = 1.5;

/// A slab 1000 wide and `thickness` thick across z, centred on the origin of `frame`.
fn slab(frame: Transform, thickness: f32) -> SolidNode {
    leaf(
        Shape::Cuboid {
            size: Vec3::new(1000.0, 1000.0, thickness),
        },
        frame,
        0,
    )
}

/// The lateral offset of a ray crossing a slab of thickness `d` at incidence `theta`.
fn slab_offset(theta: f32, d: f32) -> f32 {
    let theta_t = (theta.sin() / SLAB_IOR).asin();
    d * (theta - theta_t).sin() / theta_t.cos()
}

#[test]
fn glass_slab_offsets_a_ray_by_the_analytic_amount() {
    let frames = [
        Transform::IDENTITY,
        Transform::translate(Vec3::new(3.0, -1.0, 2.0))
            .after(&Transform::rotate_xyz_deg(Vec3::new(25.0, -10.0, 40.0))),
    ];
    for frame in frames {
        for thickness in [1.0f32, 0.3] {
            let s = build(&one_pixel(
                vec![glass(SLAB_IOR)],
                vec![slab(frame, thickness)],
                vec![0],
                Vec3::new(0.0, 0.0, 10.0),
                Vec3::NEG_Z,
            ));
            for deg in [0.0f32, 20.0, 45.0, 70.0] {
                let theta = deg.to_radians();
                // In the slab's frame: down through its top face, tilted towards +x.
                let u_local = Vec3::new(theta.sin(), 0.0, -theta.cos());
                let u = frame.vector(u_local).normalize();
                let o = frame.point(Vec3::new(0.3, 0.2, 0.5) - u_local * 10.0);
                let entry = Ray::new(o, u);
                let (top, inside) = refract_at(&s, &entry, 1.0, SLAB_IOR);
                let inside = inside.expect("entering glass never reflects totally");
                let (bottom, out) = refract_at(&s, &inside, SLAB_IOR, 1.0);
                let out = out.expect("leaves at the angle it came in");
                assert_eq!((top.object, bottom.object), (0, 0));
                // Both faces crossed: the top face (outward normal +z of the frame), then the
                // bottom face.
                let up = frame.vector(Vec3::Z).normalize();
                assert!(top.surface.normal.dot(up) > 0.999_99, "{deg}°: {top:?}");
                assert!(
                    bottom.surface.normal.dot(up) < -0.999_99,
                    "{deg}°: {bottom:?}"
                );
                // Tolerances: every point here has coordinates below ~30 (ulp ≤ 4e-6) and each
                // step (transform, hit, Snell) adds a few roundings of relative size 6e-8, so
                // the computed path is good to ~1e-5 in position and ~1e-6 in direction. 1e-6 on
                // direction and 2e-5 on the offset (which is 0.04–0.67 here) leave margin while
                // catching any wrong index, normal side or origin offset (each changes the
                // result by 1e-3 or more).
                assert!(
                    (out.dir - u).length() < 1e-6,
                    "{deg}°: leaves along {:?}, came in along {u:?}",
                    out.dir
                );
                let got = line_distance(bottom.surface.point, o, u);
                let want = slab_offset(theta, thickness);
                assert!(
                    (got - want).abs() < 2e-5,
                    "{deg}°, thickness {thickness}: offset {got}, want {want}"
                );
            }
        }
    }
}

/// The pixel column (fractional) of row `y` whose camera ray, after crossing `slab` (if any),
/// meets the plane z = `plane_z` at x = 0; by bisection on the geometric path.
fn column_seeing_x0(scene: &Scene, slab: Option<&Scene>, y: f32, plane_z: f32) -> f32 {
    let x_at = |col: f32| {
        let mut ray = scene.camera.ray(col, y);
        ray.dir = ray.dir.normalize();
        if let Some(s) = slab {
            let (_, inside) = refract_at(s, &ray, 1.0, SLAB_IOR);
            let (_, out) = refract_at(s, &inside.expect("enters"), SLAB_IOR, 1.0);
            ray = out.expect("leaves");
        }
        let t = (plane_z - ray.origin.z) / ray.dir.z;
        ray.at(t).x
    };
    let w = scene.settings.width as f32;
    let (mut lo, mut hi) = (0.0f32, w);
    let rising = x_at(hi) > x_at(lo);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if (x_at(mid) < 0.0) == rising {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// The brightness-weighted mean column of a line, in pixel units (centres at `x + 0.5`).
fn centroid(px: &[Pixel]) -> f32 {
    let (mut sum, mut weight) = (0.0f64, 0.0f64);
    for (x, p) in px.iter().enumerate() {
        let v = f64::from(p.0[0]);
        sum += v * (x as f64 + 0.5);
        weight += v;
    }
    assert!(weight > 0.0, "the stripe is visible");
    (sum / weight) as f32
}

#[test]
fn stripe_seen_through_the_slab_shifts_by_the_predicted_pixels() {
    // A thin bright stripe along y lies 3 below a slab 1 thick; the camera looks at it through
    // the slab at incidence θ from 40 away, so without the slab the stripe is at the image
    // centre. With the slab the image of the stripe moves by the slab's lateral offset; the
    // column that sees it is predicted by tracing camera rays through the slab by hand.
    let (w, h) = (200u32, 200u32);
    let row = h / 2;
    // Half the view is 0.02 rad across: 0.008 units per pixel at the stripe.
    let vfov = 2.0 * 0.02f32.atan().to_degrees();
    let stripe = leaf(
        Shape::Cuboid {
            size: Vec3::new(0.1, 100.0, 0.001),
        },
        Transform::translate(Vec3::new(0.0, 0.0, -3.0)),
        1,
    );
    for deg in [0.0f32, 20.0, 45.0, 70.0] {
        let theta = deg.to_radians();
        let u = Vec3::new(theta.sin(), 0.0, -theta.cos());
        let target = Vec3::new(0.0, 0.0, -3.0);
        let eye = target - u * 40.0;
        let shaders = vec![glass(SLAB_IOR), glow(1.0)];
        let scene_of = |with_slab: bool| {
            let (solids, objects) = if with_slab {
                (vec![slab(Transform::IDENTITY, 1.0), stripe], vec![0, 1])
            } else {
                (vec![stripe], vec![0])
            };
            let mut d = desc(shaders.clone(), solids, objects, eye, target, vfov, (w, h));
            d.settings.samples = 4;
            build(&d)
        };
        let (plain, glazed) = (scene_of(false), scene_of(true));
        let slab_only = build(&desc(
            shaders.clone(),
            vec![slab(Transform::IDENTITY, 1.0)],
            vec![0],
            eye,
            target,
            vfov,
            (w, h),
        ));
        let y = row as f32 + 0.5;
        let predicted = column_seeing_x0(&plain, Some(&slab_only), y, -3.0)
            - column_seeing_x0(&plain, None, y, -3.0);
        let measured = centroid(&line(&glazed, row).0) - centroid(&line(&plain, row).0);
        // The shift is 0 to ~83 pixels. With 4 × 4 stratified samples each edge pixel's
        // coverage is known to about 1/8 pixel, so the centroid of a stripe 3 to 10 pixels wide
        // is good to well under 0.3 pixel; a wrong index (e.g. 1.33 for 1.5) moves it by 3+.
        assert!(
            (measured - predicted).abs() < 0.3,
            "{deg}°: the stripe moved {measured} pixels, predicted {predicted}"
        );
        // And the prediction is the analytic offset over the footprint of a pixel at the
        // stripe, 40 away (up to the slab's small shift of the apparent distance).
        let per_pixel = 40.0 * 2.0 * 0.02 / w as f32;
        let analytic = slab_offset(theta, 1.0) / per_pixel;
        assert!(
            (predicted.abs() - analytic).abs() < 0.03 * analytic + 0.05,
            "{deg}°: predicted {predicted} pixels, analytic {analytic}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Total internal reflection
// ---------------------------------------------------------------------------------------------

/// A glass prism: the box [−1, 1]³ cut by the plane through the origin whose normal leans `phi`
/// from +z towards +x. A ray going up (+z) through the bottom face meets the cut at incidence
/// `phi`.
fn prism(phi: f32) -> (Vec<SolidNode>, Vec<u32>) {
    (
        vec![
            leaf(
                Shape::Cuboid {
                    size: Vec3::splat(2.0),
                },
                Transform::IDENTITY,
                0,
            ),
            leaf(
                Shape::Plane {
                    normal: Vec3::new(phi.sin(), 0.0, phi.cos()),
                    d: 0.0,
                },
                Transform::IDENTITY,
                0,
            ),
            SolidNode::Csg {
                op: CsgOp::Intersect,
                a: 0,
                b: 1,
            },
        ],
        vec![2],
    )
}

#[test]
fn total_internal_reflection_starts_at_the_critical_angle() {
    let critical = (1.0f32 / 1.5).asin();
    let eye = Vec3::new(0.3, 0.0, -10.0);
    for (delta, escapes) in [(-0.5f32, true), (0.5, false)] {
        let phi = critical + delta.to_radians();
        let (solids, objects) = prism(phi);
        let mut d = one_pixel(vec![glass(1.5)], solids, objects, eye, Vec3::Z);
        d.settings.background = Vec3::new(0.2, 0.4, 0.6);

        // By hand: through the bottom face at normal incidence, then the cut.
        let s = build(&d);
        let (bottom, inside) = refract_at(&s, &Ray::new(eye, Vec3::Z), 1.0, 1.5);
        assert!((bottom.surface.point.z + 1.0).abs() < 1e-6);
        let inside = inside.expect("enters");
        assert!((inside.dir - Vec3::Z).length() < 1e-6, "normal incidence");
        let (cut, out) = refract_at(&s, &inside, 1.5, 1.0);
        let cos_incidence = cut.surface.normal.dot(inside.dir);
        assert!(
            (cos_incidence - phi.cos()).abs() < 1e-6,
            "meets the cut at {phi}"
        );
        assert_eq!(
            out.is_some(),
            escapes,
            "{delta:+}° from the critical angle: {out:?}"
        );

        // Through the renderer, with the depth cap at 2 so that only the first two surfaces
        // spawn rays: the bottom face always refracts; the cut refracts below the critical
        // angle and turns its whole share into a mirror ray above it.
        d.settings.max_depth = 2;
        let (px, counts) = line(&build(&d), 0);
        if escapes {
            assert_eq!((counts.refraction, counts.reflection), (2, 0), "{counts:?}");
            // Out through the cut into the background: the pixel is the background.
            assert_eq!(px[0], Pixel::from_color(d.settings.background));
        } else {
            assert_eq!((counts.refraction, counts.reflection), (1, 1), "{counts:?}");
            // The mirror ray reaches the third face at the depth cap: the glass's own (black)
            // local colour.
            assert_eq!(px[0], Pixel([0, 0, 0]));
        }
        // Uncapped, the reflected ray leaves through the side x = −1 (near normal incidence).
        d.settings.max_depth = 16;
        let (px, counts) = line(&build(&d), 0);
        let want_reflections = if escapes { 0 } else { 1 };
        assert_eq!(
            (counts.refraction, counts.reflection),
            (2, want_reflections),
            "{counts:?}"
        );
        assert_eq!(px[0], Pixel::from_color(d.settings.background));
    }
}

// ---------------------------------------------------------------------------------------------
// Nested media
// ---------------------------------------------------------------------------------------------

const WATER: f32 = 1.33;
const GLASS: f32 = 1.5;

/// A water ball of radius 2 (object 0) with a glass ball of radius 1 inside (object 1), both
/// centred on the origin; `extra` objects follow.
fn nested(extra: Vec<SolidNode>) -> (Vec<Shader>, Vec<SolidNode>, Vec<u32>) {
    let mut solids = vec![
        leaf(Shape::Sphere { radius: 2.0 }, Transform::IDENTITY, 0),
        leaf(Shape::Sphere { radius: 1.0 }, Transform::IDENTITY, 1),
    ];
    solids.extend(extra);
    let objects = (0..solids.len() as u32).collect();
    (vec![glass(WATER), glass(GLASS), glow(1.0)], solids, objects)
}

/// Follows a ray through the four surfaces with the given indices (outside → water → glass →
/// water → outside in a correct model); returns the points and the final ray.
fn through_nested(s: &Scene, ray: Ray, iors: [f32; 5]) -> (Vec<Vec3>, Ray) {
    let mut ray = ray;
    let mut points = Vec::new();
    for k in 0..4 {
        let (f, next) = refract_at(s, &ray, iors[k], iors[k + 1]);
        points.push(f.surface.point);
        ray = next.unwrap_or_else(|| panic!("surface {k}: no total internal reflection here"));
    }
    (points, ray)
}

#[test]
fn ray_along_the_diameter_of_nested_balls_goes_straight_through() {
    let (shaders, solids, objects) = nested(vec![]);
    let eye = Vec3::new(0.0, 0.0, -10.0);
    let d = one_pixel(shaders, solids, objects, eye, Vec3::Z);
    let s = build(&d);
    let (points, out) = through_nested(&s, Ray::new(eye, Vec3::Z), [1.0, WATER, GLASS, WATER, 1.0]);
    for (p, z) in points.iter().zip([-2.0f32, -1.0, 1.0, 2.0]) {
        assert!(
            (*p - Vec3::new(0.0, 0.0, z)).length() < 1e-5,
            "{p:?}, want z = {z}"
        );
    }
    assert!(
        (out.dir - Vec3::Z).length() < 1e-6,
        "undeviated: {:?}",
        out.dir
    );
    assert!(out.origin.x == 0.0 && out.origin.y == 0.0);

    // The renderer: four refraction rays, none reflected, and it sees a target straight ahead.
    let (shaders, solids, objects) = nested(vec![leaf(
        Shape::Sphere { radius: 0.1 },
        Transform::translate(Vec3::new(0.0, 0.0, 20.0)),
        2,
    )]);
    let (px, counts) = line(
        &build(&one_pixel(shaders, solids, objects, eye, Vec3::Z)),
        0,
    );
    assert_eq!((counts.refraction, counts.reflection), (4, 0), "{counts:?}");
    assert_eq!(
        px[0],
        Pixel([65535; 3]),
        "the target straight ahead is seen"
    );
}

#[test]
fn off_axis_ray_through_nested_balls_bends_by_the_nested_indices() {
    let eye_at = |b: f32| Vec3::new(b, 0.0, -10.0);
    for b in [0.4f32, 0.8, 1.2] {
        let (shaders, solids, objects) = nested(vec![]);
        let s = build(&one_pixel(shaders, solids, objects, eye_at(b), Vec3::Z));
        let start = Ray::new(eye_at(b), Vec3::Z);
        let (points, out) = through_nested(&s, start, [1.0, WATER, GLASS, WATER, 1.0]);
        // Bouguer's invariant of a spherically layered medium: n·|p × d| is the same on every
        // segment (here b, in air).
        let mut ray_dirs = vec![Vec3::Z];
        let mut r = start;
        let iors = [1.0, WATER, GLASS, WATER, 1.0];
        for k in 0..4 {
            let (_, next) = refract_at(&s, &r, iors[k], iors[k + 1]);
            r = next.expect("refracts");
            ray_dirs.push(r.dir);
        }
        for (k, dir) in ray_dirs.iter().enumerate() {
            let p = if k == 0 { start.origin } else { points[k - 1] };
            let invariant = iors[k] * p.cross(dir.normalize()).length();
            assert!(
                (invariant - b).abs() < 1e-5,
                "b = {b}, segment {k}: n·|p × d| = {invariant}"
            );
        }
        // A media stack that forgot the water around the glass (leaving the glass into air)
        // sends the ray elsewhere, or reflects it totally: far more than the target's angular
        // radius (0.01) used below, so the render can tell the two apart.
        let mut r = start;
        let mut naive = Some(start);
        for (n1, n2) in [(1.0, WATER), (WATER, GLASS), (GLASS, 1.0), (WATER, 1.0)] {
            let (_, next) = refract_at(&s, &r, n1, n2);
            naive = next;
            match next {
                Some(n) => r = n,
                None => break,
            }
        }
        if let Some(naive) = naive {
            let angle = out.dir.dot(naive.dir.normalize()).clamp(-1.0, 1.0).acos();
            assert!(angle > 0.05, "b = {b}: models differ by only {angle} rad");
        }

        // The renderer sees a target placed where the correct exit ray goes, at distance 20.
        let exit = *points.last().expect("four points");
        let target = exit + out.dir.normalize() * 20.0;
        let (shaders, solids, objects) = nested(vec![leaf(
            Shape::Sphere { radius: 0.2 },
            Transform::translate(target),
            2,
        )]);
        let (px, counts) = line(
            &build(&one_pixel(shaders, solids, objects, eye_at(b), Vec3::Z)),
            0,
        );
        assert_eq!(
            (counts.refraction, counts.reflection),
            (4, 0),
            "b = {b}: {counts:?}"
        );
        assert_eq!(
            px[0],
            Pixel([65535; 3]),
            "b = {b}: the target on the exit ray is seen"
        );
    }
}

#[test]
fn nested_balls_render_finite_with_plausible_ray_counts() {
    // With every surface fully clear and nothing else in view, every camera ray must come out
    // with the background colour, after 0, 2 or 4 refractions by its distance b from the centre:
    // it meets the glass iff b < 1.33 (the refracted ray in water has impact parameter b/1.33).
    let (shaders, solids, objects) = nested(vec![]);
    let mut d = desc(
        shaders,
        solids,
        objects,
        Vec3::new(0.0, 0.0, -10.0),
        Vec3::ZERO,
        28.0,
        (32, 32),
    );
    d.settings.background = Vec3::new(0.2, 0.3, 0.4);
    let s = build(&d);
    let mut scratch = TraceScratch::default();
    let mut seen = [0usize; 3];
    for y in 0..32 {
        for x in 0..32 {
            let ray = s.camera.ray(x as f32 + 0.5, y as f32 + 0.5);
            let mut counts = RayCounts::default();
            let c = trace(&s, ray, 0, &mut scratch, &mut counts);
            assert!(c.is_finite(), "({x}, {y}): {c:?}");
            assert!(
                (c - d.settings.background).abs().max_element() < 1e-5,
                "({x}, {y}): {c:?}"
            );
            let u = ray.dir.normalize();
            let b = ray.origin.cross(u).length();
            let margin = 0.02;
            let want = if b < WATER - margin {
                4
            } else if b > WATER + margin && b < 2.0 - margin {
                2
            } else if b > 2.0 + margin {
                0
            } else {
                continue;
            };
            assert_eq!(
                (counts.refraction, counts.reflection),
                (want, 0),
                "({x}, {y}), b = {b}"
            );
            seen[want as usize / 2] += 1;
        }
    }
    assert!(seen.iter().all(|&n| n > 20), "every case covered: {seen:?}");
    // And the whole image through render_line: the same background everywhere.
    for y in 0..32 {
        let (px, _) = line(&s, y);
        assert!(px
            .iter()
            .all(|p| *p == Pixel::from_color(d.settings.background)));
    }
}

// ---------------------------------------------------------------------------------------------
// Cut-off and depth cap
// ---------------------------------------------------------------------------------------------

/// Ten slabs 1 thick at z ∈ [2i, 2i + 1], of a material with `transparency` and ambient 0.25;
/// one camera ray up the z axis.
fn slab_stack(transparency: f32) -> SceneDesc {
    let material = Shader {
        ambient: Vec3::splat(0.25),
        transparency,
        ..glass(1.5)
    };
    let solids: Vec<SolidNode> = (0..10)
        .map(|i| {
            leaf(
                Shape::Cuboid {
                    size: Vec3::new(50.0, 50.0, 1.0),
                },
                Transform::translate(Vec3::new(0.0, 0.0, 2.0 * i as f32 + 0.5)),
                0,
            )
        })
        .collect();
    let mut d = one_pixel(
        vec![material],
        solids,
        (0..10).collect(),
        Vec3::new(0.1, 0.2, -10.0),
        Vec3::Z,
    );
    d.settings.background = Vec3::splat(0.75);
    d
}

#[test]
fn refraction_generations_stop_at_the_depth_cap() {
    for cap in [0u32, 1, 3, 7, 19, 20, 25] {
        let mut d = slab_stack(1.0);
        d.settings.max_depth = cap;
        let (px, counts) = line(&build(&d), 0);
        let want = u64::from(cap.min(20));
        assert_eq!(counts.refraction, want, "max_depth {cap}: {counts:?}");
        assert_eq!(counts.reflection, 0);
        // Capped inside the stack, the last surface shows its own colour; otherwise the ray
        // comes out into the background.
        let want_px = if cap < 20 { 0.25 } else { 0.75 };
        assert_eq!(
            px[0],
            Pixel::from_color(Vec3::splat(want_px)),
            "max_depth {cap}"
        );
    }
}

#[test]
fn refraction_stops_under_the_weight_cut_off() {
    // Transparency ½: weights ½, ¼, ⅛ are traced, 1/16 is under the 10% cut-off.
    let (_, counts) = line(&build(&slab_stack(0.5)), 0);
    assert_eq!(counts.refraction, 3, "{counts:?}");
    // Cut-off 1%: ½ … 1/64 are traced, 1/128 is not.
    let mut d = slab_stack(0.5);
    d.settings.min_reflection_weight = 0.01;
    assert_eq!(line(&build(&d), 0).1.refraction, 6);
    // Refractions off: none, and the first surface is opaque.
    let mut d = slab_stack(1.0);
    d.settings.refractions = false;
    let (px, counts) = line(&build(&d), 0);
    assert_eq!(counts.refraction, 0);
    assert_eq!(px[0], Pixel::from_color(Vec3::splat(0.25)));
}

// ---------------------------------------------------------------------------------------------
// NFF's additive rule
// ---------------------------------------------------------------------------------------------

#[test]
fn additive_glass_adds_the_whole_local_colour_of_every_surface_it_passes() {
    // Transparency ½ under NFF's rule: each surface reached adds its whole local colour (0.25)
    // at the path's weight. Weights 1, ½, ¼ and ⅛ reach a surface; the refracted ray of weight
    // 1/16 is under the cut-off and adds nothing: 0.25 · (1 + ½ + ¼ + ⅛) = 0.46875.
    let mut d = slab_stack(0.5);
    d.shaders[0].blend = Blend::Additive;
    let (px, counts) = line(&build(&d), 0);
    assert_eq!(counts.refraction, 3, "{counts:?}");
    assert_eq!(px[0], Pixel::from_color(Vec3::splat(0.46875)));
    // The seed's rule on the same stack: local shares ½, ½ · ½, ½ · ¼, and the last surface
    // keeps the untraced share: 0.25 · (½ + ¼ + ⅛ + ⅛) = 0.25.
    let (px, counts) = line(&build(&slab_stack(0.5)), 0);
    assert_eq!(counts.refraction, 3, "{counts:?}");
    assert_eq!(px[0], Pixel::from_color(Vec3::splat(0.25)));
}

#[test]
fn additive_total_internal_reflection_sends_the_refracted_share_along_the_mirror_ray() {
    let critical = (1.0f32 / 1.5).asin();
    let eye = Vec3::new(0.3, 0.0, -10.0);
    let ambient = 0.0625f32;
    let background = Vec3::new(0.2, 0.4, 0.6);
    let material = Shader {
        ambient: Vec3::splat(ambient),
        blend: Blend::Additive,
        ..glass(1.5)
    };
    // Below the critical angle the ray passes two surfaces (bottom, cut); above it the cut
    // reflects it totally and it leaves through the side x = −1: three surfaces.
    for (delta, surfaces) in [(-0.5f32, 2u64), (0.5, 3)] {
        let (solids, objects) = prism(critical + delta.to_radians());
        let mut d = one_pixel(vec![material], solids, objects, eye, Vec3::Z);
        d.settings.background = background;
        let (px, counts) = line(&build(&d), 0);
        assert_eq!(
            (counts.refraction, counts.reflection),
            (2, surfaces - 2),
            "{delta:+}°: {counts:?}"
        );
        // Each surface adds its whole local colour at weight 1 (T = 1 goes on in full, along the
        // mirror ray at the cut above the critical angle), then the background.
        let mut want = Vec3::ZERO;
        for _ in 0..surfaces {
            want += Vec3::splat(ambient);
        }
        want += background;
        assert_eq!(px[0], Pixel::from_color(want), "{delta:+}°");
        // The seed's rule gives no share to the local colour of a surface whose rays are traced.
        d.shaders[0].blend = Blend::Share;
        let (px, _) = line(&build(&d), 0);
        assert_eq!(px[0], Pixel::from_color(background), "{delta:+}°");
    }
}
