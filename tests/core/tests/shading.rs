//! The shading rules of `scenes/FORMATS.md`, checked on crafted scenes with known answers.

use glam::Vec3;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::camera::{Camera, CameraFrame, SeedCamera};
use strahl_core::scene::mesh::MeshBuilder;
use strahl_core::scene::{Light, RenderSettings, Scene, SceneDesc, Shader};

fn shader(ambient: f32, diffuse: f32, reflection: f32) -> Shader {
    Shader {
        transparency: 0.0,
        ior: 1.0,
        ambient: Vec3::splat(ambient),
        diffuse: Vec3::splat(diffuse),
        specular: Vec3::ZERO,
        shininess: 1.0,
        reflection,
    }
}

fn light(position: Vec3, casts_shadows: bool) -> Light {
    Light {
        position,
        color: Vec3::ONE,
        amount: 1.0,
        casts_shadows,
    }
}

/// Renders every line; returns the image and the ray counts.
fn render(desc: &SceneDesc) -> (Vec<Pixel>, RayCounts) {
    let scene = Scene::build(desc, &OctreeParams::default()).expect("valid scene");
    let w = desc.settings.width as usize;
    let mut image = vec![Pixel::default(); w * desc.settings.height as usize];
    let mut counts = RayCounts::default();
    for (y, line) in image.chunks_mut(w).enumerate() {
        counts += render_line(&scene, y as u32, line).expect("line renders");
    }
    (image, counts)
}

/// A wall at y = 10 facing the camera at the origin, filling the view.
fn wall(shader0: Shader, lights: Vec<Light>) -> SceneDesc {
    let mut m = MeshBuilder::default();
    m.quad(
        [
            Vec3::new(-100.0, 10.0, -100.0),
            Vec3::new(100.0, 10.0, -100.0),
            Vec3::new(100.0, 10.0, 100.0),
            Vec3::new(-100.0, 10.0, 100.0),
        ],
        0,
    );
    SceneDesc {
        points: m.points,
        triangles: m.triangles,
        shaders: vec![shader0],
        lights,
        settings: RenderSettings {
            width: 9,
            height: 9,
            ..RenderSettings::default()
        },
        ..SceneDesc::default()
    }
}

#[test]
fn phong_pixel_matches_the_formula() {
    // Light at the eye: N·L = 1 at the centre, so colour = ambient + diffuse = 0.1 + 0.5.
    let (img, counts) = render(&wall(shader(0.1, 0.5, 0.0), vec![light(Vec3::ZERO, true)]));
    assert_eq!(img[4 * 9 + 4].to_rgb8(), [153, 153, 153]);
    assert_eq!(counts.primary, 81);
    assert_eq!(counts.shadow, 81, "one shadow ray per lit hit");
    assert_eq!(counts.reflection, 0, "no reflective shader");
}

#[test]
fn light_behind_the_surface_adds_nothing_and_casts_no_ray() {
    let (img, counts) = render(&wall(
        shader(0.1, 0.5, 0.0),
        vec![light(Vec3::new(0.0, 20.0, 0.0), true)],
    ));
    assert!(
        img.iter().all(|p| p.to_rgb8() == [26, 26, 26]),
        "ambient only"
    );
    assert_eq!(counts.shadow, 0);
}

#[test]
fn non_casting_lights_and_shadows_off_trace_no_shadow_rays() {
    let (_, counts) = render(&wall(shader(0.1, 0.5, 0.0), vec![light(Vec3::ZERO, false)]));
    assert_eq!(counts.shadow, 0);
    let mut desc = wall(shader(0.1, 0.5, 0.0), vec![light(Vec3::ZERO, true)]);
    desc.settings.shadows = false;
    assert_eq!(render(&desc).1.shadow, 0);
}

/// Two parallel mirrors at y = ±10 facing each other; the camera between them looks along +Y.
fn mirrors(r: f32) -> SceneDesc {
    let mut desc = wall(shader(0.1, 0.2, r), vec![light(Vec3::ZERO, false)]);
    let mut m = MeshBuilder {
        points: desc.points.clone(),
        triangles: desc.triangles.clone(),
    };
    m.quad(
        [
            Vec3::new(-1000.0, -10.0, -1000.0),
            Vec3::new(-1000.0, -10.0, 1000.0),
            Vec3::new(1000.0, -10.0, 1000.0),
            Vec3::new(1000.0, -10.0, -1000.0),
        ],
        0,
    );
    // Wide enough that corner rays stay between the mirrors for every bounce up to the cap.
    desc.points = m
        .points
        .iter()
        .map(|p| Vec3::new(p.x * 10.0, p.y, p.z * 10.0))
        .collect();
    desc.triangles = m.triangles;
    desc.settings.width = 3;
    desc.settings.height = 3;
    desc
}

#[test]
fn perfect_mirrors_stop_at_the_depth_cap() {
    let desc = mirrors(1.0);
    let (img, counts) = render(&desc);
    let cap = u64::from(desc.settings.max_depth);
    assert_eq!(
        counts.reflection,
        9 * cap,
        "every pixel bounces exactly up to the cap"
    );
    assert!(img.iter().all(|p| p.0.iter().all(|&c| c > 0)));
}

#[test]
fn reflection_stops_under_ten_percent_weight() {
    // r = 0.3: the first bounce has weight 0.3 (traced), the second 0.09 (< 10%, not traced).
    let (_, counts) = render(&mirrors(0.3));
    assert_eq!(counts.reflection, 9);
    // r = 0.5: weights 0.5, 0.25, 0.125 are traced, 0.0625 is not.
    let (_, counts) = render(&mirrors(0.5));
    assert_eq!(counts.reflection, 27);
    // Reflections off: none at all.
    let mut desc = mirrors(0.5);
    desc.settings.reflections = false;
    assert_eq!(render(&desc).1.reflection, 0);
}

#[test]
fn seed_example_camera_looks_at_the_room_from_the_front_and_above() {
    let cam = Camera::Seed(SeedCamera {
        position: Vec3::new(0.0, -100.0, 25.0),
        angle_x_deg: -15.0,
        angle_z_deg: 0.0,
        zoom: 1.5,
    });
    let f = CameraFrame::new(&cam, 640, 480);
    let centre = f.ray(320.0, 240.0).dir.normalize();
    assert!(centre.y > 0.9, "looks into the room (+Y): {centre:?}");
    assert!(centre.z < 0.0, "slightly down: {centre:?}");
    assert!(
        (centre.z + (15f32).to_radians().sin()).abs() < 1e-5,
        "15° down"
    );
    // Zoom 1.5: half the horizontal field of view is atan(1/1.5).
    let edge = f.ray(640.0, 240.0).dir;
    let half = (edge.x / (edge.y * edge.y + edge.z * edge.z).sqrt()).atan();
    assert!((half - (1.0f32 / 1.5).atan()).abs() < 1e-5);
}
