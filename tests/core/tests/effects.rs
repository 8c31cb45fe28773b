//! "Simulate only the effects a scene calls for": exact ray counts on crafted scenes, the
//! `skip_effects` switch that proves the shortcuts never change a pixel, and adaptive
//! multisampling (`aa_threshold`).
//!
//! Every scene is built by hand and rendered with `render_image` (every line's `render_line`,
//! then adaptive multisampling's second pass); the ray counts are what it returns. Unless a test says otherwise the camera is the seed's
//! default (at the origin, looking along +Y, 90° horizontal field of view), so the centre ray of
//! pixel `(x, y)` of a `w × h` image has the direction `(u, 1, v)` with `u = (2x + 1)/w − 1` and
//! `v = (h − 2y − 1)/w`.

use glam::Vec3;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::geom::solid::{CsgOp, Shape, SolidNode};
use strahl_core::math::transform::Transform;
use strahl_core::render::adaptive::{edge_mask, mask_len, merge_refined, refine_line};
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;
use strahl_core::render::{render_image, render_line};
use strahl_core::scene::camera::{Camera, LookAtCamera};
use strahl_core::scene::{Blend, Light, RenderSettings, Scene, SceneDesc, Shader, TriangleDesc};

/// Image size of the small crafted scenes.
const W: u32 = 16;
const H: u32 = 12;
/// Pixels of the small crafted scenes.
const WH: u64 = (W * H) as u64;

// ---------------------------------------------------------------------------------------------
// Scene building
// ---------------------------------------------------------------------------------------------

/// An opaque shader: grey ambient and diffuse, no specular, reflection `r`.
fn shader(ambient: f32, diffuse: f32, reflection: f32) -> Shader {
    Shader {
        ambient: Vec3::splat(ambient),
        diffuse: Vec3::splat(diffuse),
        specular: Vec3::ZERO,
        shininess: 1.0,
        reflection,
        transparency: 0.0,
        ior: 1.0,
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

/// A scene of `W × H` pixels with these shaders and lights and nothing in it yet; skipping on.
fn empty(shaders: Vec<Shader>, lights: Vec<Light>) -> SceneDesc {
    SceneDesc {
        shaders,
        lights,
        settings: RenderSettings {
            width: W,
            height: H,
            skip_effects: true,
            ..RenderSettings::default()
        },
        ..SceneDesc::default()
    }
}

/// Adds a quad (two triangles with their own points) to `desc`.
fn quad(desc: &mut SceneDesc, corners: [Vec3; 4], shader: u32) {
    let base = desc.points.len() as u32;
    desc.points.extend_from_slice(&corners);
    desc.triangles
        .push(TriangleDesc::new([base, base + 1, base + 2], shader));
    desc.triangles
        .push(TriangleDesc::new([base, base + 2, base + 3], shader));
}

/// Adds the rectangle `x ∈ [x0, x1]`, `z ∈ [z0, z1]` in the plane at `y`.
fn wall_part(desc: &mut SceneDesc, y: f32, (x0, x1): (f32, f32), (z0, z1): (f32, f32), sh: u32) {
    quad(
        desc,
        [
            Vec3::new(x0, y, z0),
            Vec3::new(x1, y, z0),
            Vec3::new(x1, y, z1),
            Vec3::new(x0, y, z1),
        ],
        sh,
    );
}

/// Adds a 200 × 200 wall in the plane at `y`, centred on the Y axis: seen from the origin it
/// fills the whole view.
fn wall(desc: &mut SceneDesc, y: f32, shader: u32) {
    wall_part(desc, y, (-100.0, 100.0), (-100.0, 100.0), shader);
}

/// One wall at `y = 10` facing the camera and filling the view, with shader 0 and these lights.
fn wall_scene(sh: Shader, lights: Vec<Light>) -> SceneDesc {
    let mut desc = empty(vec![sh], lights);
    wall(&mut desc, 10.0, 0);
    desc
}

/// Adds a solid leaf and makes it a scene object; returns its arena index.
fn solid(desc: &mut SceneDesc, shape: Shape, transform: Transform, shader: u32) -> u32 {
    let i = desc.solids.len() as u32;
    desc.solids.push(SolidNode::Leaf {
        shape,
        transform,
        shader,
    });
    desc.objects.push(i);
    i
}

/// The direction of the centre ray of pixel `(x, y)` for the default camera (see the module
/// documentation).
fn centre_dir(x: u32, y: u32, w: u32, h: u32) -> Vec3 {
    let u = (2 * x + 1) as f32 / w as f32 - 1.0;
    let v = (h as f32 - (2 * y + 1) as f32) / w as f32;
    Vec3::new(u, 1.0, v)
}

// ---------------------------------------------------------------------------------------------
// Rendering and comparing
// ---------------------------------------------------------------------------------------------

/// Renders the image; returns it and the ray counts.
fn render(desc: &SceneDesc) -> (Vec<Pixel>, RayCounts) {
    let scene = Scene::build(desc, &OctreeParams::default()).expect("valid scene");
    let w = desc.settings.width as usize;
    let mut image = vec![Pixel::default(); w * desc.settings.height as usize];
    let counts = render_image(&scene, &mut image).expect("image renders");
    (image, counts)
}

/// Reads one kind of ray count.
type Kind = fn(&RayCounts) -> u64;

/// The ray kinds, by name.
const KINDS: [(&str, Kind); 6] = [
    ("primary", |c| c.primary),
    ("extra_samples", |c| c.extra_samples),
    ("shadow", |c| c.shadow),
    ("reflection", |c| c.reflection),
    ("refraction", |c| c.refraction),
    ("occlusion", |c| c.occlusion),
];

/// Asserts that two images are the same, naming the first pixel that differs.
fn assert_same_image(what: &str, a: &[Pixel], b: &[Pixel], width: u32) {
    assert_eq!(a.len(), b.len(), "{what}: image sizes differ");
    if let Some(i) = (0..a.len()).find(|&i| a[i] != b[i]) {
        let w = width as usize;
        panic!(
            "{what}: pixel ({}, {}) differs: {:?} vs {:?}",
            i % w,
            i / w,
            a[i],
            b[i]
        );
    }
}

/// Renders `desc` with skipping on and off. The images must be byte-identical; the kinds named
/// in `skipped` must grow strictly with skipping off, every other kind must stay the same.
/// Returns the counts with skipping on and off.
fn assert_skipping_is_invisible(
    what: &str,
    desc: &SceneDesc,
    skipped: &[&str],
) -> (RayCounts, RayCounts) {
    for s in skipped {
        assert!(KINDS.iter().any(|(k, _)| k == s), "unknown kind {s}");
    }
    let mut on = desc.clone();
    on.settings.skip_effects = true;
    let mut off = desc.clone();
    off.settings.skip_effects = false;
    let (img_on, c_on) = render(&on);
    let (img_off, c_off) = render(&off);
    assert_same_image(
        &format!("{what}: skipping off changed the image"),
        &img_on,
        &img_off,
        desc.settings.width,
    );
    for (kind, get) in KINDS {
        let (a, b) = (get(&c_on), get(&c_off));
        if skipped.contains(&kind) {
            assert!(
                b > a,
                "{what}: {kind} rays must grow with skipping off: {a} on, {b} off\n\
                 on:  {c_on:?}\noff: {c_off:?}"
            );
        } else {
            assert_eq!(
                a, b,
                "{what}: {kind} rays must not change with skipping off\n\
                 on:  {c_on:?}\noff: {c_off:?}"
            );
        }
    }
    (c_on, c_off)
}

// ---------------------------------------------------------------------------------------------
// Exact counts on crafted scenes
// ---------------------------------------------------------------------------------------------

/// The ray kinds that skipping leaves out in a scene with every effect and adaptive
/// multisampling.
const ADAPTIVE_KINDS: &[&str] = &[
    "extra_samples",
    "shadow",
    "reflection",
    "refraction",
    "occlusion",
];

#[test]
fn opaque_scene_traces_no_mirror_or_refraction_rays() {
    // No reflective and no transparent shader; a light at the eye lights every hit.
    let desc = wall_scene(shader(0.1, 0.5, 0.0), vec![light(Vec3::ZERO, true)]);
    let (_, c) = render(&desc);
    assert_eq!(
        c,
        RayCounts {
            primary: WH,
            extra_samples: 0,
            shadow: WH,
            reflection: 0,
            refraction: 0,
            occlusion: 0,
            work: c.work,
        }
    );
    // Skipping off: a mirror and a (straight-through, ior 1) refraction ray at every hit.
    let (_, off) =
        assert_skipping_is_invisible("opaque wall", &desc, &["reflection", "refraction"]);
    assert_eq!(off.reflection, WH, "one dropped mirror ray per hit");
}

#[test]
fn non_casting_lights_and_shadows_off_trace_no_shadow_rays() {
    // Three lights in front of the wall, none casting shadows.
    let lights = vec![
        light(Vec3::ZERO, false),
        light(Vec3::new(3.0, 2.0, 1.0), false),
        light(Vec3::new(-4.0, 5.0, -2.0), false),
    ];
    let desc = wall_scene(shader(0.1, 0.5, 0.0), lights);
    let (img, c) = render(&desc);
    assert_eq!(c.shadow, 0, "{c:?}");
    assert_eq!(c.primary, WH);
    assert!(
        img.iter().all(|p| p.0[0] > 0),
        "the lights still light the wall"
    );
    let (_, off) = assert_skipping_is_invisible(
        "non-casting lights",
        &desc,
        &["shadow", "reflection", "refraction"],
    );
    assert_eq!(
        off.shadow,
        3 * WH,
        "skipping off: a dropped ray to every light"
    );

    // A casting light, but shadows switched off.
    let mut desc = wall_scene(shader(0.1, 0.5, 0.0), vec![light(Vec3::ZERO, true)]);
    desc.settings.shadows = false;
    let (_, c) = render(&desc);
    assert_eq!(c.shadow, 0, "{c:?}");
    let (_, off) = assert_skipping_is_invisible(
        "shadows off",
        &desc,
        &["shadow", "reflection", "refraction"],
    );
    assert_eq!(off.shadow, WH);
}

#[test]
fn lights_behind_every_surface_trace_no_shadow_rays() {
    // Both casting lights are behind the wall (y > 10): N·L < 0 at every hit.
    let lights = vec![
        light(Vec3::new(0.0, 20.0, 0.0), true),
        light(Vec3::new(5.0, 30.0, -5.0), true),
    ];
    let desc = wall_scene(shader(0.1, 0.5, 0.0), lights);
    let (img, c) = render(&desc);
    assert_eq!(c.shadow, 0, "{c:?}");
    let ambient_only = Pixel::from_color(Vec3::splat(0.1));
    assert!(img.iter().all(|&p| p == ambient_only), "ambient only");
    let (_, off) = assert_skipping_is_invisible(
        "lights behind the wall",
        &desc,
        &["shadow", "reflection", "refraction"],
    );
    assert_eq!(off.shadow, 2 * WH);

    // The same with a solid: a big box whose front face is the wall, lights behind it.
    let mut desc = empty(
        vec![shader(0.1, 0.5, 0.0)],
        vec![light(Vec3::new(0.0, 40.0, 0.0), true)],
    );
    solid(
        &mut desc,
        Shape::Cuboid {
            size: Vec3::new(200.0, 2.0, 200.0),
        },
        Transform::translate(Vec3::new(0.0, 11.0, 0.0)),
        0,
    );
    let (_, c) = render(&desc);
    assert_eq!((c.primary, c.shadow), (WH, 0), "{c:?}");
}

#[test]
fn multisampling_counts_one_primary_and_m_squared_minus_one_extra_rays_per_pixel() {
    let mut desc = wall_scene(shader(0.1, 0.5, 0.0), vec![light(Vec3::ZERO, true)]);
    let (_, c) = render(&desc);
    assert_eq!(
        (c.primary, c.extra_samples),
        (WH, 0),
        "multisample 1: {c:?}"
    );
    for m in [2u64, 3, 5] {
        desc.settings.samples = m as u32;
        let (img, c) = render(&desc);
        assert_eq!(c.primary, WH, "m = {m}: {c:?}");
        assert_eq!(c.extra_samples, (m * m - 1) * WH, "m = {m}: {c:?}");
        // Every sample hits the wall and sees the light once.
        assert_eq!(c.shadow, m * m * WH, "m = {m}: {c:?}");
        assert!(img.iter().all(|p| p.0[0] > 0));
    }
    desc.settings.samples = 3;
    assert_skipping_is_invisible("multisample 3", &desc, &["reflection", "refraction"]);
}

#[test]
fn ambient_occlusion_traces_n_squared_rays_per_ambient_hit() {
    // Level 0: none.
    let mut desc = wall_scene(shader(0.2, 0.5, 0.0), vec![light(Vec3::ZERO, true)]);
    let (_, c) = render(&desc);
    assert_eq!(c.occlusion, 0, "{c:?}");
    // Level n on a flat wall that every primary ray hits: n² rays per hit (all of them above the
    // surface, since the smooth normal of a flat quad is its face normal).
    for n in 1..=3u64 {
        desc.settings.ambient_occlusion = n as u32;
        let (_, c) = render(&desc);
        assert_eq!(c.occlusion, n * n * WH, "level {n}: {c:?}");
        assert_eq!(c.primary, WH);
    }
    desc.settings.ambient_occlusion = 2;
    // Occlusion is called for here, so skipping off sends no more occlusion rays.
    assert_skipping_is_invisible("occlusion 2", &desc, &["reflection", "refraction"]);
}

#[test]
fn shader_without_ambient_traces_no_occlusion_rays() {
    // The whole wall has ambient 0.
    let mut desc = wall_scene(shader(0.0, 0.5, 0.0), vec![light(Vec3::ZERO, true)]);
    desc.settings.ambient_occlusion = 2;
    let (_, c) = render(&desc);
    assert_eq!(c.occlusion, 0, "{c:?}");
    let (_, off) = assert_skipping_is_invisible(
        "no ambient",
        &desc,
        &["occlusion", "reflection", "refraction"],
    );
    assert_eq!(
        off.occlusion,
        4 * WH,
        "skipping off: occlusion rays everywhere"
    );

    // Left half (x < 0) without ambient, right half with: only the right half's hits send
    // occlusion rays. Pixel centres lie at x = ±0.625, ±1.875, ... on the wall, far from x = 0.
    let mut desc = empty(
        vec![shader(0.0, 0.5, 0.0), shader(0.3, 0.5, 0.0)],
        vec![light(Vec3::ZERO, true)],
    );
    wall_part(&mut desc, 10.0, (-100.0, 0.0), (-100.0, 100.0), 0);
    wall_part(&mut desc, 10.0, (0.0, 100.0), (-100.0, 100.0), 1);
    desc.settings.ambient_occlusion = 3;
    let (_, c) = render(&desc);
    assert_eq!(c.occlusion, 9 * WH / 2, "{c:?}");
    assert_skipping_is_invisible(
        "half without ambient",
        &desc,
        &["occlusion", "reflection", "refraction"],
    );
}

#[test]
fn reflection_under_the_cut_off_traces_no_mirror_rays() {
    // r = 0.05 < 10%: not traced at all.
    let desc = wall_scene(shader(0.1, 0.5, 0.05), vec![light(Vec3::ZERO, true)]);
    assert_eq!(desc.settings.min_reflection_weight, 0.1);
    let (_, c) = render(&desc);
    assert_eq!(c.reflection, 0, "{c:?}");
    assert_eq!(c.shadow, WH, "the local colour is lit as usual");
    let (_, off) = assert_skipping_is_invisible("r = 0.05", &desc, &["reflection", "refraction"]);
    assert_eq!(off.reflection, WH);

    // r = 0.1 is at the cut-off and traced ("at or above"): one mirror ray per pixel, which
    // leaves the scene (nothing behind the camera).
    let desc = wall_scene(shader(0.1, 0.5, 0.1), vec![light(Vec3::ZERO, true)]);
    let (_, c) = render(&desc);
    assert_eq!(c.reflection, WH, "{c:?}");
}

/// The camera at the origin, a perfect mirror (shader 1, `r = 1`) at `y = 5` covering
/// `x, z ∈ [−1, 1]`, a wall at `y = 10` behind it and a wall at `y = −10` behind the camera (which
/// only the mirror shows), both shader 0; a shadow-casting light at the eye.
fn mirror_before_wall() -> SceneDesc {
    let mut desc = empty(
        vec![shader(0.1, 0.5, 0.0), shader(0.1, 0.5, 1.0)],
        vec![light(Vec3::ZERO, true)],
    );
    wall(&mut desc, 10.0, 0);
    wall(&mut desc, -10.0, 0);
    wall_part(&mut desc, 5.0, (-1.0, 1.0), (-1.0, 1.0), 1);
    desc
}

/// Pixels whose centre ray hits the mirror of [`mirror_before_wall`].
fn mirror_pixels() -> u64 {
    let mut n = 0;
    for y in 0..H {
        for x in 0..W {
            let p = centre_dir(x, y, W, H) * 5.0;
            if p.x.abs() < 1.0 && p.z.abs() < 1.0 {
                n += 1;
            }
        }
    }
    n
}

#[test]
fn perfect_mirror_has_no_local_colour_and_sends_no_shadow_rays() {
    let desc = mirror_before_wall();
    let m = mirror_pixels();
    // Columns and rows at u, v = ±1/16, ±3/16 (the mirror reaches 0.2, the next centre is 5/16).
    assert_eq!(m, 16);
    let (img, c) = render(&desc);
    assert_eq!(c.primary, WH);
    assert_eq!(
        c.reflection, m,
        "one mirror ray per pixel that sees the mirror: {c:?}"
    );
    // One shadow ray per wall hit: W·H − m on the front wall, m on the back wall seen in the
    // mirror, none at the mirror itself.
    assert_eq!(c.shadow, WH, "{c:?}");
    assert_eq!((c.refraction, c.occlusion, c.extra_samples), (0, 0, 0));
    // The mirror shows the lit back wall.
    let centre = img[(H / 2 * W + W / 2) as usize];
    assert!(centre.0[0] > 0, "{centre:?}");

    let (_, off) = assert_skipping_is_invisible(
        "mirror before a wall",
        &desc,
        &["shadow", "reflection", "refraction"],
    );
    assert_eq!(
        off.shadow,
        WH + m,
        "skipping off: the mirror's hits are lit too"
    );
}

#[test]
fn additive_perfect_mirror_is_lit_and_skipping_still_changes_no_pixel() {
    // NFF's rule: the mirror keeps its whole local colour, so its hits are lit (shadow rays) and
    // only the walls' zero-share mirror rays and the opaque surfaces' refraction rays are left
    // out with skipping on.
    let mut desc = mirror_before_wall();
    desc.shaders[1].blend = Blend::Additive;
    let m = mirror_pixels();
    let (img, c) = render(&desc);
    assert_eq!(c.reflection, m, "{c:?}");
    assert_eq!(c.shadow, WH + m, "the mirror's hits are lit too: {c:?}");
    let (share, _) = render(&mirror_before_wall());
    let centre = (H / 2 * W + W / 2) as usize;
    assert!(
        (0..3).all(|k| img[centre].0[k] > share[centre].0[k]),
        "the local colour is added: {:?} against {:?}",
        img[centre],
        share[centre]
    );
    let (_, off) = assert_skipping_is_invisible(
        "additive mirror before a wall",
        &desc,
        &["reflection", "refraction"],
    );
    assert_eq!(off.shadow, WH + m);
}

/// Two perfect mirrors (half-space solids, `r = 1`) at `y = 10` and `y = −10` facing each other,
/// the camera between them; a light at the eye.
fn parallel_mirrors(max_depth: u32) -> SceneDesc {
    let mut desc = empty(vec![shader(0.1, 0.5, 1.0)], vec![light(Vec3::ZERO, true)]);
    // y ≥ 10 and y ≤ −10.
    solid(
        &mut desc,
        Shape::Plane {
            normal: Vec3::NEG_Y,
            d: -10.0,
        },
        Transform::IDENTITY,
        0,
    );
    solid(
        &mut desc,
        Shape::Plane {
            normal: Vec3::Y,
            d: -10.0,
        },
        Transform::IDENTITY,
        0,
    );
    desc.settings.max_depth = max_depth;
    desc
}

#[test]
fn parallel_perfect_mirrors_stop_at_the_depth_cap() {
    for n in [1u64, 3, 7] {
        let desc = parallel_mirrors(n as u32);
        let (img, c) = render(&desc);
        assert_eq!(c.primary, WH);
        assert_eq!(
            c.reflection,
            n * WH,
            "max_depth {n}: N mirror rays per pixel: {c:?}"
        );
        // Only the hit at the cap is lit: one shadow ray per pixel.
        assert_eq!(c.shadow, WH, "max_depth {n}: {c:?}");
        assert!(img.iter().all(|p| p.0[0] > 0), "the last hit is lit");
        assert_skipping_is_invisible(
            &format!("parallel mirrors, depth {n}"),
            &desc,
            &["shadow", "reflection", "refraction"],
        );
    }
}

// ---------------------------------------------------------------------------------------------
// A rich scene
// ---------------------------------------------------------------------------------------------

/// Floor (half-space, slightly reflective), a back wall of triangles, a mirror ball, a glass ball,
/// a box without ambient colour, a CSG object; casting, non-casting and hidden lights;
/// multisample 2, occlusion 2, adaptive threshold 0.05.
fn rich_scene() -> SceneDesc {
    let glass = Shader {
        ambient: Vec3::splat(0.02),
        diffuse: Vec3::new(0.1, 0.1, 0.15),
        specular: Vec3::splat(0.5),
        shininess: 40.0,
        reflection: 0.1,
        transparency: 0.75,
        ior: 1.5,
        blend: Blend::Share,
    };
    let shaders = vec![
        // 0: floor
        shader(0.1, 0.6, 0.2),
        // 1: wall, shiny
        Shader {
            specular: Vec3::splat(0.4),
            shininess: 20.0,
            ..shader(0.15, 0.6, 0.0)
        },
        // 2: mirror ball
        Shader {
            ambient: Vec3::new(0.1, 0.0, 0.0),
            diffuse: Vec3::new(0.5, 0.1, 0.1),
            ..shader(0.0, 0.0, 0.8)
        },
        // 3: glass
        glass,
        // 4: box without ambient
        Shader {
            diffuse: Vec3::new(0.2, 0.7, 0.2),
            ..shader(0.0, 0.0, 0.0)
        },
    ];
    let lights = vec![
        light(Vec3::new(-4.0, -6.0, 8.0), true),
        Light {
            amount: 0.4,
            ..light(Vec3::new(4.0, -4.0, 5.0), false)
        },
        // Behind the back wall and under the floor.
        light(Vec3::new(0.0, 12.0, 5.0), true),
        Light {
            amount: 0.5,
            ..light(Vec3::new(0.0, 2.0, -5.0), true)
        },
    ];
    let mut desc = SceneDesc {
        shaders,
        lights,
        camera: Camera::LookAt(LookAtCamera {
            position: Vec3::new(0.0, -8.0, 3.0),
            look_at: Vec3::new(0.0, 0.0, 1.0),
            up: Vec3::Z,
            vfov_deg: 50.0,
        }),
        settings: RenderSettings {
            width: 32,
            height: 24,
            background: Vec3::new(0.05, 0.05, 0.1),
            samples: 2,
            ambient_occlusion: 2,
            aa_threshold: Some(0.05),
            max_depth: 6,
            skip_effects: true,
            ..RenderSettings::default()
        },
        ..SceneDesc::default()
    };
    solid(
        &mut desc,
        Shape::Plane {
            normal: Vec3::Z,
            d: 0.0,
        },
        Transform::IDENTITY,
        0,
    );
    quad(
        &mut desc,
        [
            Vec3::new(-10.0, 6.0, 0.0),
            Vec3::new(10.0, 6.0, 0.0),
            Vec3::new(10.0, 6.0, 10.0),
            Vec3::new(-10.0, 6.0, 10.0),
        ],
        1,
    );
    solid(
        &mut desc,
        Shape::Sphere { radius: 1.0 },
        Transform::translate(Vec3::new(-1.6, 1.0, 1.0)),
        2,
    );
    solid(
        &mut desc,
        Shape::Sphere { radius: 1.0 },
        Transform::translate(Vec3::new(1.4, -0.5, 1.0)),
        3,
    );
    solid(
        &mut desc,
        Shape::Cuboid {
            size: Vec3::new(1.0, 1.0, 2.0),
        },
        Transform::translate(Vec3::new(0.2, 3.0, 1.0))
            .after(&Transform::rotate_xyz_deg(Vec3::new(0.0, 0.0, 30.0))),
        4,
    );
    // A box with a ball cut out of it (CSG arena nodes, only the difference is an object).
    let a = desc.solids.len() as u32;
    desc.solids.push(SolidNode::Leaf {
        shape: Shape::Cuboid {
            size: Vec3::splat(1.4),
        },
        transform: Transform::translate(Vec3::new(3.2, 2.5, 0.7)),
        shader: 1,
    });
    desc.solids.push(SolidNode::Leaf {
        shape: Shape::Sphere { radius: 0.9 },
        transform: Transform::translate(Vec3::new(2.8, 1.9, 1.2)),
        shader: 3,
    });
    desc.solids.push(SolidNode::Csg {
        op: CsgOp::Subtract,
        a,
        b: a + 1,
    });
    desc.objects.push(a + 2);
    desc
}

#[test]
fn rich_scene_skipping_changes_no_pixel() {
    let desc = rich_scene();
    let (img, on) = render(&desc);
    // Sanity: every effect is present.
    assert!(on.reflection > 0 && on.refraction > 0 && on.shadow > 0 && on.occlusion > 0);
    let distinct: std::collections::BTreeSet<[u16; 3]> = img.iter().map(|p| p.0).collect();
    assert!(
        distinct.len() > 20,
        "a varied image: {} colours",
        distinct.len()
    );
    // Skipping off: dropped shadow rays to hidden and non-casting lights, dropped mirror and
    // refraction rays, occlusion at the box without ambient colour, and all samples of every
    // pixel (adaptive multisampling), all without changing a pixel.
    assert_skipping_is_invisible("rich scene", &desc, ADAPTIVE_KINDS);
    // The same without adaptive multisampling: then the samples do not change.
    let mut full = desc.clone();
    full.settings.aa_threshold = None;
    assert_skipping_is_invisible(
        "rich scene, full multisampling",
        &full,
        &["shadow", "reflection", "refraction", "occlusion"],
    );
}

#[test]
fn rich_scene_with_additive_shaders_skipping_changes_no_pixel() {
    let share = rich_scene();
    let mut desc = share.clone();
    for sh in &mut desc.shaders {
        sh.blend = Blend::Additive;
    }
    let (img, on) = render(&desc);
    assert!(on.reflection > 0 && on.refraction > 0 && on.shadow > 0 && on.occlusion > 0);
    assert_ne!(img, render(&share).0, "the additive rule changes the image");
    // Without adaptive multisampling (which refines the pixels that differ, so other ones for
    // another image): the rules weigh mirror and refraction rays alike, so the cut-off keeps the
    // same ones; every pixel is at least as bright as under the seed's rule, and some are
    // brighter.
    let mut full = desc.clone();
    full.settings.aa_threshold = None;
    let mut full_share = share.clone();
    full_share.settings.aa_threshold = None;
    let (a, ca) = render(&full);
    let (b, cb) = render(&full_share);
    assert_eq!(
        (ca.reflection, ca.refraction),
        (cb.reflection, cb.refraction)
    );
    assert!(a
        .iter()
        .zip(&b)
        .all(|(a, b)| (0..3).all(|k| a.0[k] >= b.0[k])));
    assert!(a.iter().zip(&b).any(|(a, b)| a != b));
    assert_skipping_is_invisible("rich scene, additive", &desc, ADAPTIVE_KINDS);
    assert_skipping_is_invisible(
        "rich scene, additive, full multisampling",
        &full,
        &["shadow", "reflection", "refraction", "occlusion"],
    );
}

// ---------------------------------------------------------------------------------------------
// Adaptive multisampling
// ---------------------------------------------------------------------------------------------

/// Size of the adaptive-multisampling scenes.
const AW: u32 = 32;
const AH: u32 = 24;

/// A white box (ambient 1, no diffuse or specular) on a black background: its front face at
/// `y = 10` covers `x ∈ [−3, 3]`, `z ∈ [−2, 2]`, whose edges lie between pixel centres.
fn white_box(samples: u32, aa_threshold: Option<f32>) -> SceneDesc {
    white_cuboid(Vec3::new(6.0, 1.0, 4.0), samples, aa_threshold)
}

/// [`white_box`] with a box of `size`.
fn white_cuboid(size: Vec3, samples: u32, aa_threshold: Option<f32>) -> SceneDesc {
    let white = Shader {
        ambient: Vec3::ONE,
        ..shader(0.0, 0.0, 0.0)
    };
    let mut desc = empty(vec![white], vec![light(Vec3::new(0.0, -5.0, 0.0), false)]);
    solid(
        &mut desc,
        Shape::Cuboid { size },
        Transform::translate(Vec3::new(0.0, 10.5, 0.0)),
        0,
    );
    desc.settings.width = AW;
    desc.settings.height = AH;
    desc.settings.samples = samples;
    desc.settings.aa_threshold = aa_threshold;
    desc
}

/// A diffuse wall lit from close by: a smooth gradient where almost every neighbour differs.
fn gradient(samples: u32, aa_threshold: Option<f32>) -> SceneDesc {
    let mut desc = wall_scene(
        shader(0.0, 1.0, 0.0),
        vec![light(Vec3::new(2.0, 8.0, 1.0), true)],
    );
    desc.settings.width = AW;
    desc.settings.height = AH;
    desc.settings.samples = samples;
    desc.settings.aa_threshold = aa_threshold;
    desc
}

/// For each pixel of `img` (`w × h`), whether some 4-neighbour has another value.
fn differs_from_a_neighbour(img: &[Pixel], w: u32, h: u32) -> Vec<bool> {
    let (w, h) = (w as usize, h as usize);
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let p = img[i];
            (x > 0 && img[i - 1] != p)
                || (x + 1 < w && img[i + 1] != p)
                || (y > 0 && img[i - w] != p)
                || (y + 1 < h && img[i + w] != p)
        })
        .collect()
}

/// The extra samples adaptive multisampling counts for an image: `m²` per supersampled pixel
/// and nothing else (the centres are the primary rays).
fn adaptive_extra(m: u32, supersampled: u64) -> u64 {
    u64::from(m * m) * supersampled
}

#[test]
fn adaptive_multisampling_supersamples_only_the_edge() {
    let m = 4u32;
    let (single, c1) = render(&white_box(1, None));
    let (full, cf) = render(&white_box(m, None));
    let (adaptive, ca) = render(&white_box(m, Some(0.05)));
    let pixels = u64::from(AW * AH);
    let black = Pixel::from_color(Vec3::ZERO);
    let white = Pixel::from_color(Vec3::ONE);
    assert!(single.iter().all(|&p| p == black || p == white));
    assert!(single.contains(&white) && single.contains(&black));
    assert_eq!(c1.extra_samples, 0);
    assert_eq!(cf.extra_samples, u64::from(m * m - 1) * pixels);

    let edge = differs_from_a_neighbour(&single, AW, AH);
    let n_edge = edge.iter().filter(|&&e| e).count() as u64;
    // A 10 × 6 pixel face: 28 pixels inside its border, 32 outside.
    assert_eq!(n_edge, 60);
    assert_eq!(ca.primary, pixels);
    assert!(ca.extra_samples > 0);
    assert!(
        ca.extra_samples < cf.extra_samples / 2,
        "adaptive {} vs full {}",
        ca.extra_samples,
        cf.extra_samples
    );
    assert_eq!(
        ca.extra_samples,
        adaptive_extra(m, n_edge),
        "m² per edge pixel"
    );
    for i in 0..adaptive.len() {
        let (x, y) = (i as u32 % AW, i as u32 / AW);
        if edge[i] {
            assert_eq!(
                adaptive[i], full[i],
                "edge pixel ({x}, {y}) is supersampled"
            );
        } else {
            assert_eq!(
                adaptive[i], single[i],
                "flat pixel ({x}, {y}) is its centre sample"
            );
            assert_eq!(full[i], single[i], "flat pixel ({x}, {y})");
        }
    }
    assert!(
        adaptive.iter().any(|&p| p != black && p != white),
        "the edge is antialiased"
    );

    // Skipping off: every pixel gets all its samples (and every hit its dropped ray to the
    // non-casting light, mirror and refraction rays), and the image stays the same.
    let (c_on, c_off) = assert_skipping_is_invisible(
        "white box, adaptive",
        &white_box(m, Some(0.05)),
        &["extra_samples", "shadow", "reflection", "refraction"],
    );
    assert_eq!(c_on, ca);
    assert_eq!(c_off.extra_samples, adaptive_extra(m, pixels));
}

#[test]
fn aa_threshold_zero_supersamples_every_pixel_with_a_differing_neighbour() {
    let m = 2u32;
    // Hard edge: exactly the pixels with a differing neighbour.
    let (single, _) = render(&white_box(1, None));
    let (_, c0) = render(&white_box(m, Some(0.0)));
    let edge = differs_from_a_neighbour(&single, AW, AH);
    let n_edge = edge.iter().filter(|&&e| e).count() as u64;
    assert_eq!(c0.extra_samples, adaptive_extra(m, n_edge), "{c0:?}");

    // Gradient: every pixel whose single-sample value differs from a neighbour's is supersampled
    // (its pixel equals the full-multisampling one), m² extra rays each and no others.
    let (single, _) = render(&gradient(1, None));
    let (full, _) = render(&gradient(m, None));
    let (adaptive, c) = render(&gradient(m, Some(0.0)));
    let edge = differs_from_a_neighbour(&single, AW, AH);
    let n_edge = edge.iter().filter(|&&e| e).count();
    assert!(
        n_edge > (AW * AH) as usize / 2,
        "a gradient: {n_edge} edge pixels"
    );
    for (i, &e) in edge.iter().enumerate() {
        let expected = if e { full[i] } else { single[i] };
        assert_eq!(
            adaptive[i],
            expected,
            "pixel ({}, {}) (differs from a neighbour: {e})",
            i as u32 % AW,
            i as u32 / AW
        );
    }
    assert_eq!(c.primary, u64::from(AW * AH));
    assert_eq!(c.extra_samples, adaptive_extra(m, n_edge as u64));
}

#[test]
fn adaptive_multisampling_traces_nothing_extra_in_a_flat_image() {
    // A white box's face filling the whole view, and an empty view: every centre equals its
    // neighbours, so no pixel gets more than its centre ray, and the shadow rays are exactly
    // those of one sample per pixel.
    let m = 4u32;
    let close_up =
        |samples, threshold| white_cuboid(Vec3::new(100.0, 1.0, 100.0), samples, threshold);
    let empty_view = |samples, threshold| {
        let mut d = white_box(samples, threshold);
        d.solids.clear();
        d.objects.clear();
        d
    };
    for (name, scene) in [
        ("face", &close_up as &dyn Fn(u32, Option<f32>) -> SceneDesc),
        ("background", &empty_view),
    ] {
        let (single, c1) = render(&scene(1, None));
        let (adaptive, ca) = render(&scene(m, Some(0.0)));
        assert!(single.iter().all(|&p| p == single[0]), "{name}: flat");
        assert_eq!(adaptive, single, "{name}");
        assert_eq!(ca.primary, u64::from(AW * AH), "{name}");
        assert_eq!(ca.extra_samples, 0, "{name}: {ca:?}");
        // The rays, not the walks' work: one sample per pixel skips the walk where the
        // camera's cover says a packet meets no cell, and the adaptive centres walk alone.
        let rays = |c: RayCounts| RayCounts {
            work: Default::default(),
            ..c
        };
        assert_eq!(
            rays(ca),
            rays(c1),
            "{name}: the same rays as one sample per pixel"
        );
    }
}

/// Renders the image as a master would with its lines in the order `ys`: each line's first
/// pass, then each line's second pass in the same order.
fn render_in_order(desc: &SceneDesc, ys: &[u32]) -> (Vec<Pixel>, RayCounts) {
    let scene = Scene::build(desc, &OctreeParams::default()).expect("valid scene");
    let s = &desc.settings;
    let w = s.width as usize;
    let mut centres = vec![Pixel::default(); w * s.height as usize];
    let mut counts = RayCounts::default();
    for &y in ys {
        let line = &mut centres[y as usize * w..(y as usize + 1) * w];
        counts += render_line(&scene, y, line).expect("line renders");
    }
    let mut image = centres.clone();
    for &y in ys {
        let mut mask = vec![0u8; mask_len(s.width)];
        if edge_mask(
            s.aa_threshold.expect("an adaptive scene"),
            &centres,
            s.width,
            y,
            &mut mask,
        ) > 0
        {
            let mut refined = vec![Pixel::default(); w];
            counts += refine_line(&scene, y, &mask, &mut refined).expect("line refines");
            merge_refined(
                &mask,
                &refined,
                &mut image[y as usize * w..(y as usize + 1) * w],
            );
        }
    }
    (image, counts)
}

#[test]
fn adaptive_multisampling_is_independent_of_line_order() {
    for desc in [white_box(4, Some(0.05)), rich_scene()] {
        let h = desc.settings.height;
        let (image, counts) = render(&desc);
        let reverse: Vec<u32> = (0..h).rev().collect();
        let scattered: Vec<u32> = (0..h).map(|i| (i * 7 + 3) % h).collect();
        for order in [&reverse, &scattered] {
            let (again, c) = render_in_order(&desc, order);
            assert_eq!(again, image, "order {order:?}");
            assert_eq!(c, counts, "rays in order {order:?}");
        }
    }
}
