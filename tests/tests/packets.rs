//! Four neighbouring camera rays find their first hits together (`Scene::closest_hits4`, which
//! `render_line` uses for one sample per pixel), and so do the four pixels' next rays (mirror and
//! refracted rays) while each has one: each ray's hit is the one it finds alone, and the pixels
//! are those of tracing each pixel's ray alone, on scenes of every kind of primitive, mirrors
//! and glass included.

use std::fmt::Write as _;
use std::path::Path;
use strahl_core::accel::octree::{OctreeParams, LANES};
use strahl_core::render::intersect::QueryScratch;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::render::sampling::{mix, pixel_sample, pixel_seed};
use strahl_core::render::shade::{trace, TraceScratch};
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::Scene;
use strahl_formats::load::{load_config_scene, load_scene, Overrides};

/// One sample per pixel at `width × height` (also the camera cover's tests').
pub(crate) fn overrides(width: u32, height: u32) -> Overrides {
    Overrides {
        width: Some(width),
        height: Some(height),
        samples: Some(1),
        ..Overrides::default()
    }
}

fn build(desc: &strahl_core::scene::SceneDesc) -> Scene {
    Scene::build(desc, &OctreeParams::default()).expect("valid scene")
}

/// An NFF scene of every primitive the octree files: spheres, cones, polygons, patches, a
/// floor, mirrors; `n × n` spheres on the floor.
fn nff_scene(n: u32) -> String {
    let mut s = String::from(
        "b 0.1 0.2 0.3\nv\nfrom 9 -14 7\nat 0 0 0.5\nup 0 0 1\nangle 35\nhither 0.01\n\
         resolution 64 48\nl 8 -6 12\nl -9 -4 9\nf 0.9 0.6 0.3 0.6 0.3 20 0 1\n\
         p 4\n-20 -20 0\n20 -20 0\n20 20 0\n-20 20 0\nf 0.3 0.7 0.9 0.5 0.4 30 0.3 1\n",
    );
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (i as f32 - n as f32 / 2.0, j as f32 - n as f32 / 2.0);
            writeln!(s, "s {x} {y} 0.45 0.45").expect("write to a String");
            writeln!(s, "c\n{x} {y} 0.9 0.1\n{} {} 1.6 0.02", x + 0.3, y + 0.2)
                .expect("write to a String");
        }
    }
    s.push_str("f 0.8 0.8 0.2 0.7 0.2 40 0 1\npp 3\n-3 5 0 0 -1 1\n3 5 0 0 -1 1\n0 5 4 0 -1 0.2\n");
    s
}

/// How the camera packets of a scene went.
struct Packets {
    /// Packets whose rays went the same way along every axis (walked together).
    together: usize,
    /// Packets whose four rays hit nothing (coloured without ray trees).
    missed: usize,
}

/// For every line: the four-ray hits against the one-ray hits, and `render_line`'s pixels
/// against each pixel's ray traced alone.
fn compare(scene: &Scene) -> Packets {
    let (w, h) = (scene.settings.width, scene.settings.height);
    let mut query = QueryScratch::default();
    let mut scratch = TraceScratch::default();
    let mut counts = RayCounts::default();
    let mut line = vec![Pixel::default(); w as usize];
    let (mut together, mut missed) = (0, 0);
    for y in 0..h {
        let samples: Vec<_> = (0..w)
            .map(|x| {
                let seed = pixel_seed(x, y);
                let (dx, dy) = pixel_sample(seed, 0, 1);
                (scene.camera.ray(x as f32 + dx, y as f32 + dy), mix(seed, 0))
            })
            .collect();
        for (k, four) in samples.chunks_exact(LANES).enumerate() {
            let rays: [_; LANES] = std::array::from_fn(|l| four[l].0);
            let signs = |l: usize| rays[l].dir.to_array().map(|d| d < 0.0);
            together += usize::from((1..LANES).all(|l| signs(l) == signs(0)));
            let hits = scene.closest_hits4(&rays, f32::INFINITY, [None; LANES], &mut query);
            missed += usize::from(hits == [None; LANES]);
            for (l, ray) in rays.iter().enumerate() {
                let alone = scene.closest_hit(ray, f32::INFINITY, &mut query);
                assert_eq!(hits[l], alone, "line {y}, pixel {}", k * LANES + l);
            }
        }
        render_line(scene, y, &mut line).expect("line renders");
        for (x, &(ray, seed)) in samples.iter().enumerate() {
            let alone = Pixel::from_color(trace(scene, ray, seed, &mut scratch, &mut counts));
            assert_eq!(line[x], alone, "line {y}, pixel {x}");
        }
    }
    Packets { together, missed }
}

#[test]
fn nff_primitives_of_every_kind() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("kinds.nff");
    std::fs::write(&path, nff_scene(5)).expect("write scene");
    // 66 wide: the last two pixels of a line go one at a time.
    let loaded = load_scene(&path, &overrides(66, 50)).expect("scene loads");
    let together = compare(&build(&loaded.desc)).together;
    assert!(together > 600, "only {together} packets walked together");
}

/// Objects floating in the middle of the view, background all around: packets whose four rays
/// hit nothing, outside the octree's root cell or through its empty cells, are coloured
/// without ray trees, as each ray alone colours its pixel, in scenes whose spheres are tested
/// one at a time and in groups.
#[test]
fn packets_that_hit_nothing() {
    for crowd in [0u32, 400] {
        let mut s = String::from(
            "b 0.2 0.4 0.7\nv\nfrom 0 -12 3\nat 0 0 0.5\nup 0 0 1\nangle 50\nhither 0.01\n\
             resolution 64 48\nl 8 -6 12\nf 0.9 0.6 0.3 0.6 0.3 20 0.2 1.3\n\
             s 0 0 0.5 0.5\ns 0 1.5 2.5 0.3\nc\n2.5 1 0 0.3\n2.5 1 1.5 0.05\n\
             p 3\n-3 -1 0\n-2 -1 0\n-2.5 -1 1.2\n",
        );
        for k in 0..crowd {
            let f = |m: u32| (k * m % 97) as f32 / 97.0 - 0.5;
            let r = 0.3 + f(13) * 0.4;
            writeln!(s, "s {} {} {} {r}", f(31), f(57), 1.0 + f(71)).expect("write");
        }
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("floating.nff");
        std::fs::write(&path, s).expect("write scene");
        let loaded = load_scene(&path, &overrides(64, 48)).expect("scene loads");
        let scene = build(&loaded.desc);
        assert_eq!(scene.group_spheres, crowd > 0, "{crowd} spheres");
        let missed = compare(&scene).missed;
        assert!(
            (100..16 * 48).contains(&missed),
            "{missed} packets of 768 hit nothing"
        );
    }
}

/// Hundreds of spheres crowded into one spot: leaves too large to split, whose spheres the
/// queries test in groups (there the rays go one at a time).
#[test]
fn crowded_spheres_tested_in_groups() {
    let mut s = nff_scene(0);
    for k in 0..400u32 {
        let f = |m: u32| (k * m % 97) as f32 / 97.0 - 0.5;
        writeln!(
            s,
            "s {} {} {} {}",
            f(31),
            f(57),
            1.0 + f(71),
            0.3 + f(13) * 0.4
        )
        .expect("write to a String");
    }
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("crowd.nff");
    std::fs::write(&path, s).expect("write scene");
    let loaded = load_scene(&path, &overrides(48, 36)).expect("scene loads");
    let scene = build(&loaded.desc);
    assert!(scene.group_spheres, "the crowd's spheres are not grouped");
    compare(&scene);
}

#[test]
fn the_fart_scenes_and_the_room() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    for name in ["die", "glass", "mirrors", "ring"] {
        let path = root.join(format!("fart/{name}.fart"));
        let loaded = load_scene(&path, &overrides(40, 30)).expect("scene loads");
        let together = compare(&build(&loaded.desc)).together;
        assert!(
            together > 100,
            "{name}: only {together} packets walked together"
        );
    }
    let cfg = root.join("room/raytracer.cfg");
    let room = load_config_scene(&cfg, &overrides(80, 60)).expect("room loads");
    let together = compare(&build(&room.desc)).together;
    assert!(
        together > 500,
        "room: only {together} packets walked together"
    );
}

/// With `m × m` samples per pixel, four samples of a pixel are traced together: every pixel of
/// `render_line` is the mean of its samples traced alone, added in sample order.
#[test]
fn samples_of_a_pixel_traced_four_at_a_time() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("kinds.nff");
    std::fs::write(&path, nff_scene(3)).expect("write scene");
    let mut scratch = TraceScratch::default();
    let mut counts = RayCounts::default();
    // 2 × 2 samples: one packet; 3 × 3: two packets and one sample alone.
    for m in [2u32, 3] {
        let loaded = load_scene(
            &path,
            &Overrides {
                samples: Some(m),
                ..overrides(20, 16)
            },
        )
        .expect("scene loads");
        let scene = build(&loaded.desc);
        let (w, h) = (scene.settings.width, scene.settings.height);
        let mut line = vec![Pixel::default(); w as usize];
        for y in 0..h {
            render_line(&scene, y, &mut line).expect("line renders");
            for x in 0..w {
                let seed = pixel_seed(x, y);
                let mut sum = glam::Vec3::ZERO;
                for k in 0..m * m {
                    let (dx, dy) = pixel_sample(seed, k, m);
                    let ray = scene.camera.ray(x as f32 + dx, y as f32 + dy);
                    sum += trace(&scene, ray, mix(seed, k), &mut scratch, &mut counts);
                }
                let alone = Pixel::from_color(sum / (m * m) as f32);
                assert_eq!(line[x as usize], alone, "m {m}, line {y}, pixel {x}");
            }
        }
    }
}
