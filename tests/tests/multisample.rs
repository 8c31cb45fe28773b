//! Multisampling and ambient occlusion: deterministic across worker counts, the documented ray
//! counts, antialiased edges, and darkened corners.

use glam::Vec3;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::geom::solid::{CsgOp, Shape, SolidNode};
use strahl_core::math::transform::Transform;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_image;
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::camera::{Camera, LookAtCamera};
use strahl_core::scene::{Blend, Light, RenderSettings, Scene, SceneDesc, Shader};
use strahl_host::cluster::local::render_local;
use strahl_host::cluster::prepared::PreparedScene;

// ---------------------------------------------------------------------------------------------
// Builders
// ---------------------------------------------------------------------------------------------

fn material(ambient: f32, diffuse: f32, reflection: f32, transparency: f32) -> Shader {
    Shader {
        ambient: Vec3::splat(ambient),
        diffuse: Vec3::splat(diffuse),
        specular: Vec3::splat(0.2),
        shininess: 20.0,
        reflection,
        transparency,
        ior: 1.5,
        blend: Blend::Share,
    }
}

/// Shows its ambient grey and nothing else.
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

fn cuboid(centre: Vec3, size: Vec3, shader: u32) -> SolidNode {
    leaf(Shape::Cuboid { size }, Transform::translate(centre), shader)
}

fn light(position: Vec3, casts_shadows: bool) -> Light {
    Light {
        position,
        color: Vec3::ONE,
        amount: 1.0,
        casts_shadows,
    }
}

/// Where the camera is, what it looks at, its vertical field of view and the image size.
struct View {
    eye: Vec3,
    at: Vec3,
    vfov_deg: f32,
    size: (u32, u32),
}

/// A scene of solids (every node a scene object unless `objects` is given).
fn desc(
    shaders: Vec<Shader>,
    solids: Vec<SolidNode>,
    objects: Option<Vec<u32>>,
    lights: Vec<Light>,
    view: View,
) -> SceneDesc {
    let forward = (view.at - view.eye).normalize();
    let up = if forward.y.abs() > 0.9 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let objects = objects.unwrap_or_else(|| (0..solids.len() as u32).collect());
    SceneDesc {
        shaders,
        lights,
        solids,
        objects,
        camera: Camera::LookAt(LookAtCamera {
            position: view.eye,
            look_at: view.at,
            up,
            vfov_deg: view.vfov_deg,
        }),
        settings: RenderSettings {
            width: view.size.0,
            height: view.size.1,
            ..RenderSettings::default()
        },
        ..SceneDesc::default()
    }
}

/// Renders the image in this thread (`render_image`); returns the image and the rays.
fn render(desc: &SceneDesc) -> (Vec<Pixel>, RayCounts) {
    let scene = Scene::build(desc, &OctreeParams::default()).expect("valid scene");
    let w = desc.settings.width as usize;
    let mut image = vec![Pixel::default(); w * desc.settings.height as usize];
    let counts = render_image(&scene, &mut image).expect("image renders");
    (image, counts)
}

/// A channel as a fraction.
fn value(p: Pixel) -> f32 {
    f32::from(p.0[0]) / 65535.0
}

// ---------------------------------------------------------------------------------------------
// Determinism
// ---------------------------------------------------------------------------------------------

/// Solids of every kind, CSG, a mirror, a glass ball and a floor half-space, lit by two lights.
fn showcase(samples: u32, ambient_occlusion: u32) -> SceneDesc {
    let shaders = vec![
        material(0.3, 0.5, 0.0, 0.0),
        material(0.2, 0.3, 0.4, 0.0),
        material(0.05, 0.1, 0.05, 0.85),
        material(0.4, 0.4, 0.0, 0.0),
    ];
    let rot = Transform::rotate_xyz_deg(Vec3::new(10.0, 35.0, -5.0));
    let solids = vec![
        // 0: the floor.
        leaf(
            Shape::Plane {
                normal: Vec3::Y,
                d: -1.0,
            },
            Transform::IDENTITY,
            0,
        ),
        // 1–3: a box with a ball cut out of its corner, reflective.
        leaf(
            Shape::Cuboid {
                size: Vec3::new(1.6, 1.6, 1.6),
            },
            Transform::translate(Vec3::new(-1.5, -0.2, 0.0)).after(&rot),
            1,
        ),
        leaf(
            Shape::Sphere { radius: 0.8 },
            Transform::translate(Vec3::new(-0.9, 0.4, 0.6)),
            3,
        ),
        SolidNode::Csg {
            op: CsgOp::Subtract,
            a: 1,
            b: 2,
        },
        // 4: a glass ball in front.
        leaf(
            Shape::Sphere { radius: 0.7 },
            Transform::translate(Vec3::new(0.4, -0.3, 1.5)),
            2,
        ),
        // 5, 6: a cylinder and a cone.
        leaf(
            Shape::Cylinder {
                bottom_radius: 0.4,
                top_radius: 0.4,
                height: 2.0,
            },
            Transform::translate(Vec3::new(1.6, 0.0, -0.5)),
            3,
        ),
        leaf(
            Shape::Cylinder {
                bottom_radius: 0.6,
                top_radius: 0.0,
                height: 1.2,
            },
            Transform::translate(Vec3::new(0.3, -0.4, -1.8)),
            0,
        ),
    ];
    let mut d = desc(
        shaders,
        solids,
        Some(vec![0, 3, 4, 5, 6]),
        vec![
            light(Vec3::new(4.0, 6.0, 5.0), true),
            light(Vec3::new(-5.0, 3.0, 2.0), false),
        ],
        View {
            eye: Vec3::new(0.0, 1.5, 6.0),
            at: Vec3::new(0.0, -0.3, 0.0),
            vfov_deg: 50.0,
            size: (36, 24),
        },
    );
    d.settings.samples = samples;
    d.settings.ambient_occlusion = ambient_occlusion;
    d.settings.background = Vec3::new(0.1, 0.15, 0.3);
    d
}

/// Renders `d` in this thread and with 1, 2, 3 and again 2 in-process workers behind the
/// master: byte-identical pixels and equal ray counts every time. Returns the one-thread render.
fn assert_same_for_any_worker_count(what: &str, d: &SceneDesc) -> (Vec<Pixel>, RayCounts) {
    let (reference, ref_rays) = render(d);
    let prepared = PreparedScene::new(d, &OctreeParams::default()).expect("valid scene");
    for workers in [1, 2, 3, 2] {
        let image = render_local(&prepared, workers, &|_, _| {}).expect("render");
        assert!(
            image.pixels == reference,
            "{what}, {workers} workers: {} pixels differ from the one-thread render",
            image
                .pixels
                .iter()
                .zip(&reference)
                .filter(|(a, b)| a != b)
                .count()
        );
        assert_eq!(
            image.rays, ref_rays,
            "{what}, {workers} workers: ray counts"
        );
    }
    // A second render in this thread is the same too.
    assert_eq!(
        render(d),
        (reference.clone(), ref_rays),
        "{what}: second render"
    );
    (reference, ref_rays)
}

#[test]
fn multisampled_occluded_render_is_identical_for_any_worker_count() {
    let d = showcase(3, 2);
    let (reference, rays) = assert_same_for_any_worker_count("m = 3, AO 2", &d);
    // The scene exercises what it should: extra samples, occlusion, refraction, reflection.
    assert!(rays.extra_samples > 0 && rays.occlusion > 0, "{rays:?}");
    assert!(rays.refraction > 0 && rays.reflection > 0, "{rays:?}");
    let distinct: std::collections::HashSet<Pixel> = reference.iter().copied().collect();
    assert!(
        distinct.len() > 100,
        "a varied image: {} colours",
        distinct.len()
    );

    // Adaptive multisampling looks at the neighbouring lines' centre samples: still the same
    // image whichever worker renders which line, and some pixels (not all) supersampled.
    let mut adaptive = d.clone();
    adaptive.settings.aa_threshold = Some(0.05);
    let (_, a_rays) = assert_same_for_any_worker_count("adaptive m = 3, AO 2", &adaptive);
    let pixels = u64::from(d.settings.width * d.settings.height);
    assert!(
        a_rays.extra_samples > 0 && a_rays.extra_samples < rays.extra_samples,
        "adaptive: {} extra samples, full: {}",
        a_rays.extra_samples,
        rays.extra_samples
    );
    assert_eq!(a_rays.primary, pixels);
}

// ---------------------------------------------------------------------------------------------
// Ray counts
// ---------------------------------------------------------------------------------------------

#[test]
fn each_pixel_traces_m_squared_camera_rays() {
    for m in [1u32, 2, 3, 5] {
        let mut d = showcase(m, 0);
        d.settings.width = 7;
        d.settings.height = 5;
        let (_, counts) = render(&d);
        assert_eq!(counts.primary, 35, "m = {m}: one primary ray per pixel");
        assert_eq!(
            counts.extra_samples,
            u64::from(m * m - 1) * 35,
            "m = {m}: m² − 1 extra samples per pixel"
        );
        assert_eq!(counts.occlusion, 0, "no occlusion rays at level 0");
    }
}

// ---------------------------------------------------------------------------------------------
// Antialiasing
// ---------------------------------------------------------------------------------------------

/// A white box face filling the image right of column 4.3 (of 8), seen head on: pixel 4 is 70%
/// covered.
fn edge(samples: u32) -> SceneDesc {
    // Camera at z = 10, 90° view, face at z = 0: column c sees x = 10·(2c/8 − 1).
    let mut d = desc(
        vec![glow(1.0)],
        // Thin, so that its side face (seen in perspective) adds nothing measurable.
        vec![cuboid(
            Vec3::new(50.375, 0.0, -0.0005),
            Vec3::new(99.25, 200.0, 0.001),
            0,
        )],
        None,
        vec![light(Vec3::new(0.0, 0.0, 10.0), false)],
        View {
            eye: Vec3::new(0.0, 0.0, 10.0),
            at: Vec3::ZERO,
            vfov_deg: 90.0,
            size: (8, 8),
        },
    );
    d.settings.samples = samples;
    d
}

#[test]
fn multisampling_antialiases_an_edge() {
    let (one, _) = render(&edge(1));
    let (many, _) = render(&edge(4));
    for y in 0..8 {
        for x in 0..8 {
            let (a, b) = (value(one[y * 8 + x]), value(many[y * 8 + x]));
            assert!(a == 0.0 || a == 1.0, "m = 1, ({x}, {y}): pure, got {a}");
            let want_one = if x >= 4 { 1.0 } else { 0.0 };
            assert_eq!(a, want_one, "m = 1, ({x}, {y}): the centre decides");
            if x == 4 {
                // 16 stratified samples, 4 per column of cells: cells 2 and 3 are inside, cell
                // 0 outside, cell 1 partly (its samples land in [0.25, 0.5), the edge at 0.3):
                // between 8/16 and 12/16 covered.
                assert!(
                    (0.5..=0.75).contains(&b),
                    "m = 4, ({x}, {y}): 70% covered, got {b}"
                );
            } else {
                assert_eq!(b, want_one, "m = 4, ({x}, {y}): away from the edge");
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Ambient occlusion
// ---------------------------------------------------------------------------------------------

/// A floor (top at y = 0, 20 × 20) and a wall standing on it (front face z = −9), seen from
/// above `spot` by one pixel looking straight down.
fn corner(spot: Vec3, ambient_occlusion: u32) -> SceneDesc {
    let mut d = desc(
        vec![material(0.5, 0.3, 0.0, 0.0)],
        vec![
            cuboid(Vec3::new(0.0, -0.5, 0.0), Vec3::new(20.0, 1.0, 20.0), 0),
            cuboid(Vec3::new(0.0, 2.5, -9.5), Vec3::new(20.0, 5.0, 1.0), 0),
        ],
        None,
        // Far above: the same direction at every spot, and no shadow of the wall near it.
        vec![light(Vec3::new(1.0, 1e4, 2.0), true)],
        View {
            eye: spot + Vec3::new(0.0, 3.0, 0.0),
            at: spot,
            vfov_deg: 10.0,
            size: (1, 1),
        },
    );
    d.settings.ambient_occlusion = ambient_occlusion;
    d.settings.ao_distance = Some(1.0);
    d
}

#[test]
fn ambient_occlusion_darkens_the_corner_and_leaves_the_open_floor() {
    let in_corner = Vec3::new(0.0, 0.0, -8.95);
    let open = Vec3::new(0.0, 0.0, 5.0);
    let (c0, _) = render(&corner(in_corner, 0));
    let (c3, rays) = render(&corner(in_corner, 3));
    assert_eq!(rays.occlusion, 9, "3 × 3 occlusion rays at the one hit");
    let (o0, _) = render(&corner(open, 0));
    let (o3, _) = render(&corner(open, 3));
    let rgb = |p: &[Pixel]| i32::from(p[0].to_rgb8()[0]);
    // Without occlusion the two spots look the same (same normal, light far away).
    assert!(
        (rgb(&c0) - rgb(&o0)).abs() <= 1,
        "{} vs {}",
        rgb(&c0),
        rgb(&o0)
    );
    // 0.05 from the wall, about half the hemisphere meets it within the occlusion distance:
    // the ambient term (0.5) loses a large share.
    assert!(
        rgb(&c3) + 20 < rgb(&c0),
        "the corner darkens: {} with AO 3, {} without",
        rgb(&c3),
        rgb(&c0)
    );
    assert!(
        (rgb(&o3) - rgb(&o0)).abs() <= 1,
        "the open floor keeps its value: {} with AO 3, {} without",
        rgb(&o3),
        rgb(&o0)
    );
}

#[test]
fn occlusion_rays_are_level_squared_per_shaded_hit() {
    // Looking down at the floor, which fills the view: every camera ray hits one opaque,
    // ambient surface once.
    for m in [1u32, 2] {
        for level in [0u32, 1, 2, 3] {
            let mut d = corner(Vec3::ZERO, level);
            d.camera = Camera::LookAt(LookAtCamera {
                position: Vec3::new(0.0, 5.0, 0.0),
                look_at: Vec3::ZERO,
                up: Vec3::Z,
                vfov_deg: 60.0,
            });
            d.settings.width = 6;
            d.settings.height = 6;
            d.settings.samples = m;
            let (_, counts) = render(&d);
            assert_eq!(
                counts.occlusion,
                36 * u64::from(m * m * level * level),
                "m = {m}, level {level}"
            );
            assert_eq!(counts.reflection + counts.refraction, 0);
        }
    }
    // A surface without ambient colour casts no occlusion rays.
    let mut d = corner(Vec3::ZERO, 3);
    d.shaders[0].ambient = Vec3::ZERO;
    assert_eq!(render(&d).1.occlusion, 0);
}
