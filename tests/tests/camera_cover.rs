//! The camera's cover (`accel::camera_cover`): a four-pixel packet it clears has no camera ray,
//! anywhere in its pixels, that meets a primitive filed in the octree, and `render_line` gives
//! the same pixels with the cover as without it, on scenes seen from outside, from inside and
//! from within the tree's cells, with and without primitives set apart from the tree.

use crate::packets::overrides;
use std::fmt::Write as _;
use std::path::Path;
use strahl_core::accel::octree::{OctreeParams, LANES};
use strahl_core::render::intersect::{PrimitiveHit, QueryScratch};
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::scene::Scene;
use strahl_formats::load::{load_config_scene, load_scene, Overrides};

/// Sierpinski tetrahedra of `level` levels (4^level tetrahedra each, SPD's tetra) centred at
/// `centres`, seen from `from`, with a floor under them if `floor`.
fn tetra_scene(level: u32, centres: &[[f32; 3]], from: [f32; 3], floor: bool) -> String {
    let mut s = format!(
        "b 0.1 0.3 0.7\nv\nfrom {} {} {}\nat 0 0 0.2\nup 0 0 1\nangle 45\nhither 0.01\n\
         resolution 64 64\nl 2 -18 5\nf 1 0.2 0.2 1 0 10 0 0\n",
        from[0], from[1], from[2]
    );
    if floor {
        s.push_str("p 4\n-30 -30 -1.5\n30 -30 -1.5\n30 30 -1.5\n-30 30 -1.5\n");
    }
    let corners = [
        [1.0f32, 1.0, 1.0],
        [-1.0, -1.0, 1.0],
        [-1.0, 1.0, -1.0],
        [1.0, -1.0, -1.0],
    ];
    let mut tetras: Vec<([f32; 3], f32)> = centres.iter().map(|&c| (c, 1.0)).collect();
    for _ in 0..level {
        tetras = tetras
            .iter()
            .flat_map(|&(c, size)| {
                corners.map(|k| {
                    (
                        std::array::from_fn(|a| c[a] + k[a] * size / 2.0),
                        size / 2.0,
                    )
                })
            })
            .collect();
    }
    for (c, size) in tetras {
        let p = corners.map(|k| -> [f32; 3] { std::array::from_fn(|a| c[a] + k[a] * size) });
        for face in [[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]] {
            s.push_str("p 3\n");
            for v in face {
                writeln!(s, "{} {} {}", p[v][0], p[v][1], p[v][2]).expect("write to a String");
            }
        }
    }
    s
}

fn load(text: &str, width: u32, height: u32) -> Scene {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("scene.nff");
    std::fs::write(&path, text).expect("write scene");
    let loaded = load_scene(&path, &overrides(width, height)).expect("scene loads");
    Scene::build(&loaded.desc, &OctreeParams::default()).expect("valid scene")
}

/// True if `hit` is of a primitive filed in the tree: not one set apart from it, not an
/// unbounded solid.
fn in_tree(scene: &Scene, hit: &PrimitiveHit) -> bool {
    let i = match *hit {
        PrimitiveHit::Triangle(i, _) => i,
        PrimitiveHit::Solid(j, _) if scene.unbounded.contains(&j) => return false,
        PrimitiveHit::Solid(j, _) => scene.triangle_points.len() as u32 + j,
    };
    !scene.octree.large().contains(&i)
}

/// Checks the cover of `scene` ray by ray: every ray through a point of a cleared packet's
/// pixels (their centres, corners and edges' middles) finds no primitive of the tree; and the
/// lines render as they do without the cover. Returns the packets cleared, of all.
fn check(scene: &Scene) -> (usize, usize) {
    let (w, h) = (scene.settings.width, scene.settings.height);
    let Some(cover) = scene.cover() else {
        return (0, 0);
    };
    let mut query = QueryScratch::default();
    let (mut cleared, mut packets) = (0, 0);
    for y in 0..h {
        for x in (0..w).step_by(LANES) {
            packets += 1;
            if !cover.clear(x, y) {
                continue;
            }
            cleared += 1;
            for px in x..(x + LANES as u32).min(w) {
                for (dx, dy) in [0.0, 0.5, 1.0]
                    .into_iter()
                    .flat_map(|a| [(a, 0.0), (a, 0.5), (a, 1.0)])
                {
                    let ray = scene.camera.ray(px as f32 + dx, y as f32 + dy);
                    let hit = scene.closest_hit(&ray, f32::INFINITY, &mut query);
                    assert!(
                        !hit.is_some_and(|h| in_tree(scene, &h)),
                        "pixel {px}, line {y} (+{dx}, +{dy}) is cleared, and its ray hits {hit:?}"
                    );
                }
            }
        }
    }
    let mut without = scene.clone();
    without.camera_cover = None;
    let (mut a, mut b) = (
        vec![Pixel::default(); w as usize],
        vec![Pixel::default(); w as usize],
    );
    for y in 0..h {
        render_line(scene, y, &mut a).expect("line renders");
        render_line(&without, y, &mut b).expect("line renders");
        assert_eq!(a, b, "line {y}");
    }
    (cleared, packets)
}

#[test]
fn a_cleared_packet_meets_nothing_in_the_tree() {
    // From outside (near and far, above), with and without a floor set apart from the tree.
    for (from, floor) in [
        ([1.0, -3.2, -2.2], false),
        ([1.0, -3.2, -2.2], true),
        ([0.3, -9.0, 4.0], false),
        ([6.0, 5.0, 1.0], true),
    ] {
        let scene = load(&tetra_scene(4, &[[0.0; 3]], from, floor), 64, 64);
        assert_eq!(scene.octree.large().is_empty(), !floor, "{from:?}");
        let (cleared, packets) = check(&scene);
        assert!(
            cleared * 5 > packets && cleared < packets,
            "{from:?}: {cleared} of {packets} packets cleared"
        );
    }
}

/// A camera among the tree's cells: where a leaf lies across the camera's plane the cover is
/// not made (every packet may meet that leaf); where only interior cells do, the cells behind
/// the camera mark nothing and those in front mark what they should.
#[test]
fn a_camera_inside_the_tree() {
    for from in [[0.05, -0.1, 0.0], [0.9, 0.9, 0.9]] {
        let scene = load(&tetra_scene(3, &[[0.0; 3]], from, false), 48, 40);
        assert!(scene.cover().is_none(), "{from:?}: a cover made");
    }
    // Between two tetrahedra, the root cell around both.
    let scene = load(
        &tetra_scene(3, &[[0.0; 3], [0.0, -7.0, 0.0]], [0.0, -3.5, 0.2], false),
        48,
        40,
    );
    let (cleared, packets) = check(&scene);
    assert!(
        cleared * 10 > packets && cleared < packets,
        "{cleared} of {packets} packets cleared"
    );
}

/// With `m × m` samples per pixel (all of them, not adaptively), four samples of a cleared
/// pixel skip the walk too: the same pixels as without the cover, fewer cells entered; the
/// last sample of 3 × 3 goes alone.
#[test]
fn multisampled_pixels_as_without_the_cover() {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join("scene.nff");
    std::fs::write(&path, tetra_scene(4, &[[0.0; 3]], [1.0, -3.2, 2.2], true)).expect("write");
    for m in [2u32, 3] {
        let samples = Overrides {
            samples: Some(m),
            ..overrides(40, 32)
        };
        let mut desc = load_scene(&path, &samples).expect("scene loads").desc;
        // Every sample of every pixel (not adaptive, whose first pass traces centres alone).
        desc.settings.aa_threshold = None;
        let scene = Scene::build(&desc, &OctreeParams::default()).expect("valid scene");
        let cover = scene.cover().expect("a cover");
        let cleared = (0..32)
            .flat_map(|y| (0..40).step_by(LANES).map(move |x| (x, y)))
            .filter(|&(x, y)| cover.clear(x, y))
            .count();
        assert!(cleared > 40, "{m} × {m}: {cleared} packets cleared");
        let mut without = scene.clone();
        without.camera_cover = None;
        let (mut a, mut b) = (vec![Pixel::default(); 40], vec![Pixel::default(); 40]);
        let (mut walked, mut walked_without) = (0, 0);
        for y in 0..32 {
            walked += render_line(&scene, y, &mut a)
                .expect("line renders")
                .work
                .octree_cells;
            walked_without += render_line(&without, y, &mut b)
                .expect("line renders")
                .work
                .octree_cells;
            assert_eq!(a, b, "{m} × {m}, line {y}");
        }
        // The cleared pixels' samples entered no cell.
        assert!(
            walked < walked_without,
            "{m} × {m}: {walked} cells entered, {walked_without} without the cover"
        );
    }
}

#[test]
fn the_fart_scenes_and_the_room() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let mut cleared = 0;
    for name in ["die", "glass", "mirrors", "ring"] {
        let path = root.join(format!("fart/{name}.fart"));
        let loaded = load_scene(&path, &overrides(40, 30)).expect("scene loads");
        let scene = Scene::build(&loaded.desc, &OctreeParams::default()).expect("valid scene");
        cleared += check(&scene).0;
    }
    let cfg = root.join("room/raytracer.cfg");
    let room = load_config_scene(&cfg, &overrides(80, 60)).expect("room loads");
    check(&Scene::build(&room.desc, &OctreeParams::default()).expect("valid scene"));
    assert!(cleared > 0, "no packet of the FART scenes cleared");
}
