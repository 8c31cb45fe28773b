//! The shading rules of `scenes/FORMATS.md`, checked on crafted scenes with known answers.

use glam::Vec3;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::camera::{Camera, CameraFrame, SeedCamera};
use strahl_core::scene::mesh::MeshBuilder;
use strahl_core::scene::{Blend, Light, RenderSettings, Scene, SceneDesc, Shader};

fn shader(ambient: f32, diffuse: f32, reflection: f32) -> Shader {
    Shader {
        transparency: 0.0,
        ior: 1.0,
        ambient: Vec3::splat(ambient),
        diffuse: Vec3::splat(diffuse),
        specular: Vec3::ZERO,
        shininess: 1.0,
        reflection,
        blend: Blend::Share,
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

/// A mirror wall (reflection `r`, ambient colour `c`, no diffuse or specular colour) under a
/// known background; the mirror rays go back past the camera into the background. `blend`
/// chooses the rule.
fn mirror_wall(r: f32, blend: Blend) -> SceneDesc {
    let sh = Shader {
        ambient: Vec3::new(0.25, 0.125, 0.0),
        blend,
        ..shader(0.0, 0.0, r)
    };
    let mut desc = wall(sh, vec![light(Vec3::ZERO, true)]);
    desc.settings.background = Vec3::new(0.5, 0.25, 1.0);
    desc
}

#[test]
fn additive_shader_adds_the_reflection_to_the_whole_local_colour() {
    // Every pixel sees the wall: local = ambient (the light adds diffuse 0 · N·L), and the mirror
    // ray brings back the background. All values are exact in binary.
    let local = Vec3::new(0.25, 0.125, 0.0);
    let background = Vec3::new(0.5, 0.25, 1.0);
    let r = 0.5;
    let (img, counts) = render(&mirror_wall(r, Blend::Additive));
    assert_eq!(counts.reflection, 81, "one mirror ray per pixel");
    let additive = Pixel::from_color(local + background * r);
    assert_eq!(additive, Pixel::from_color(Vec3::new(0.5, 0.25, 0.5)));
    assert!(img.iter().all(|&p| p == additive), "{:?}", img[40]);

    // The seed's rule on the same wall scales the local colour down by 1 − r.
    let (img, _) = render(&mirror_wall(r, Blend::Share));
    let share = Pixel::from_color(local * (1.0 - r) + background * r);
    assert_ne!(share, additive);
    assert!(img.iter().all(|&p| p == share), "{:?}", img[40]);
}

#[test]
fn additive_shader_reflection_not_traced_adds_nothing() {
    let local = Vec3::new(0.25, 0.125, 0.0);
    // Traced, the reflection adds r · background to the whole local colour.
    let (img, _) = render(&mirror_wall(0.5, Blend::Additive));
    assert_eq!(
        img[40],
        Pixel::from_color(local + Vec3::new(0.5, 0.25, 1.0) * 0.5)
    );
    let local = Pixel::from_color(local);
    // Under the 10 % cut-off, with reflections off and with depth cap 0, the mirror ray is not
    // traced: the additive wall shows its local colour alone (not lifted by the untraced share).
    let mut cases = vec![mirror_wall(0.05, Blend::Additive)];
    let mut off = mirror_wall(0.5, Blend::Additive);
    off.settings.reflections = false;
    cases.push(off);
    let mut capped = mirror_wall(0.5, Blend::Additive);
    capped.settings.max_depth = 0;
    cases.push(capped);
    for (i, desc) in cases.iter().enumerate() {
        let (img, counts) = render(desc);
        assert_eq!(counts.reflection, 0, "case {i}");
        assert!(img.iter().all(|&p| p == local), "case {i}: {:?}", img[40]);
    }
}

#[test]
fn additive_perfect_mirror_keeps_its_lit_local_colour() {
    // r = 1: the seed's rule leaves no local share (no lighting, no shadow rays); the additive
    // rule lights the surface in full and adds the reflection on top.
    let desc = |blend| {
        let mut d = wall(
            Shader {
                blend,
                ..shader(0.1, 0.5, 1.0)
            },
            vec![light(Vec3::ZERO, true)],
        );
        d.settings.background = Vec3::splat(0.25);
        d
    };
    let (share, c) = render(&desc(Blend::Share));
    assert_eq!((c.shadow, c.reflection), (0, 81), "{c:?}");
    assert!(share
        .iter()
        .all(|&p| p == Pixel::from_color(Vec3::splat(0.25))));
    let (additive, c) = render(&desc(Blend::Additive));
    assert_eq!((c.shadow, c.reflection), (81, 81), "{c:?}");
    // The centre pixel: ambient 0.1 + diffuse 0.5 (N·L = 1 with the light at the eye) plus the
    // background, 0.85 = 217 of 255.
    assert_eq!(additive[4 * 9 + 4].to_rgb8(), [217, 217, 217]);
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
