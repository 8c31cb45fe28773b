//! Tests of the NFF reader (`strahl_host::formats::nff`): the SPD benchmark scenes, every entity's mapping,
//! exact error messages, rendering, and the examples of `scenes/FORMATS.md` section 10.

use glam::Vec3;
use std::path::{Path, PathBuf};
use std::time::Instant;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::geom::solid::{Shape, SolidNode};
use strahl_core::math::transform::Transform;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::scene::camera::{Camera, LookAtCamera};
use strahl_core::scene::{Blend, Light, Scene, SceneDesc, TriangleDesc};
use strahl_host::formats::error::LoadError;
use strahl_host::formats::nff::{
    cone_transform, load_nff, parse_nff, shader_from_nff, NFF_MIN_RAY_WEIGHT,
};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/nff")
        .join(name)
}

/// The folder of the SPD scenes: `$STRAHL_SPD_DIR`, else `/work/shared/spd`.
fn spd_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("STRAHL_SPD_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("/work/shared/spd"));
    dir.is_dir().then_some(dir)
}

fn spheres(desc: &SceneDesc) -> usize {
    desc.solids
        .iter()
        .filter(|s| {
            matches!(
                s,
                SolidNode::Leaf {
                    shape: Shape::Sphere { .. },
                    ..
                }
            )
        })
        .count()
}

/// Renders `desc` and returns how many pixels differ from the background.
fn lit_pixels(desc: &SceneDesc) -> usize {
    let scene = Scene::build(desc, &OctreeParams::default()).expect("the scene builds");
    let background = Pixel::from_color(desc.settings.background);
    let mut line = vec![Pixel::default(); desc.settings.width as usize];
    let mut lit = 0;
    for y in 0..desc.settings.height {
        render_line(&scene, y, &mut line).expect("render a line");
        lit += line.iter().filter(|&&p| p != background).count();
    }
    lit
}

#[test]
fn every_spd_scene_loads_with_its_counts() {
    let Some(dir) = spd_dir() else {
        eprintln!("SPD scenes not found (set STRAHL_SPD_DIR); skipped");
        return;
    };
    // name, spheres, triangles, lights, shaders, shading normals
    // (balls_4: 1 + 9 + 81 + 729 + 6561 = 7381 spheres, the SPD README's table says 7,382.)
    let expected: [(&str, usize, usize, usize, usize, usize); 8] = [
        ("balls_3", 820, 2, 3, 2, 0),
        ("balls_4", 7381, 2, 3, 2, 0),
        ("mount_6", 4, 8192, 1, 2, 0),
        ("mount_8", 4, 131_072, 1, 2, 0),
        ("teapot_6", 0, 72 + 2256, 2, 3, 3 * 2256),
        ("teapot_12", 0, 288 + 9120, 2, 3, 3 * 9120),
        ("tetra_6", 0, 4096, 1, 1, 0),
        ("tetra_8", 0, 65_536, 1, 1, 0),
    ];
    for (name, n_spheres, n_triangles, n_lights, n_shaders, n_normals) in expected {
        let path = dir.join(format!("{name}.nff"));
        let start = Instant::now();
        let desc = load_nff(&path).unwrap_or_else(|e| panic!("{e}"));
        eprintln!(
            "{name}.nff parsed in {:.1} ms",
            start.elapsed().as_secs_f64() * 1e3
        );
        assert_eq!(spheres(&desc), n_spheres, "{name} spheres");
        assert_eq!(desc.solids.len(), n_spheres, "{name}: only spheres");
        assert_eq!(desc.objects.len(), n_spheres, "{name} objects");
        assert_eq!(desc.triangles.len(), n_triangles, "{name} triangles");
        assert_eq!(desc.lights.len(), n_lights, "{name} lights");
        assert_eq!(desc.shaders.len(), n_shaders, "{name} shaders");
        assert_eq!(desc.normals.len(), n_normals, "{name} normals");
        assert_eq!(
            (desc.settings.width, desc.settings.height),
            (512, 512),
            "{name}"
        );
        // Light amounts as in SPD's POV-Ray files: 1/sqrt(number of lights).
        let amount = 1.0 / (n_lights as f32).sqrt();
        assert!(desc.lights.iter().all(|l| l.amount == amount), "{name}");
        assert!(matches!(desc.camera, Camera::LookAt(_)), "{name}");
    }
}

#[test]
fn spd_materials_match_the_pov_files() {
    let Some(dir) = spd_dir() else {
        eprintln!("SPD scenes not found (set STRAHL_SPD_DIR); skipped");
        return;
    };
    // balls_3.pov: floor `ambient 0.2 diffuse 0.8`, spheres `ambient 0 diffuse 0.5 reflection 0.5`.
    let balls = load_nff(&dir.join("balls_3.nff")).unwrap_or_else(|e| panic!("{e}"));
    let floor = balls.shaders[0];
    assert!(
        (floor.ambient - Vec3::new(1.0, 0.75, 0.33) * 0.2)
            .abs()
            .max_element()
            < 1e-6
    );
    assert_eq!(floor.diffuse, Vec3::new(1.0, 0.75, 0.33) * 0.8);
    assert_eq!(floor.reflection, 0.0);
    let ball = balls.shaders[1];
    assert_eq!(ball.ambient, Vec3::ZERO);
    assert_eq!((ball.reflection, ball.specular), (0.5, Vec3::splat(0.5)));
    assert_eq!(ball.shininess, 3.0827);
    // mount_6.pov: glass spheres `filter 0.9 reflection 0.1 refraction 1.0 ior 1.5`, ambient 0.
    let mount = load_nff(&dir.join("mount_6.nff")).unwrap_or_else(|e| panic!("{e}"));
    let glass = mount.shaders[0];
    assert_eq!(
        (glass.transparency, glass.ior, glass.reflection),
        (0.9, 1.5, 0.1)
    );
    assert_eq!(glass.ambient, Vec3::ZERO);
    // The terrain's `f ... 0 0` has ior 0, meaningless without transmission: 1.
    assert_eq!(
        (mount.shaders[1].transparency, mount.shaders[1].ior),
        (0.0, 1.0)
    );
    // balls_3.pov's camera: location <2.1, 1.3, 1.7>, and `up` of length 2·tan(45°/2).
    let Camera::LookAt(cam) = balls.camera else {
        panic!("an NFF scene has a look-at camera");
    };
    assert_eq!(
        cam,
        LookAtCamera {
            position: Vec3::new(2.1, 1.3, 1.7),
            look_at: Vec3::ZERO,
            up: Vec3::Z,
            vfov_deg: 45.0
        }
    );
    assert_eq!(balls.settings.background, Vec3::new(0.078, 0.361, 0.753));
}

#[test]
fn each_entity_maps_to_exact_scene_values() {
    let desc = load_nff(&fixture("every_entity.nff")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        desc.camera,
        Camera::LookAt(LookAtCamera {
            position: Vec3::new(0.0, -10.0, 2.0),
            look_at: Vec3::new(0.0, 0.0, 1.0),
            up: Vec3::Z,
            vfov_deg: 40.0,
        })
    );
    let s = desc.settings;
    assert_eq!((s.width, s.height), (32, 24));
    assert_eq!(s.background, Vec3::new(0.1, 0.2, 0.3));
    // Rays are traced down to POV-Ray's adc_bailout, not the seed's 10 %.
    assert_eq!(s.min_reflection_weight, NFF_MIN_RAY_WEIGHT);
    assert_eq!(NFF_MIN_RAY_WEIGHT, 1.0 / 255.0);
    let amount = 1.0 / 2f32.sqrt();
    assert_eq!(
        desc.lights,
        vec![
            Light {
                position: Vec3::new(5.0, -5.0, 10.0),
                color: Vec3::ONE,
                amount,
                casts_shadows: true
            },
            Light {
                position: Vec3::new(-5.0, -5.0, 10.0),
                color: Vec3::new(0.5, 0.6, 0.7),
                amount,
                casts_shadows: true
            },
        ]
    );
    let c0 = Vec3::new(1.0, 0.5, 0.25);
    let sh0 = desc.shaders[0];
    assert_eq!(sh0, shader_from_nff(c0, 0.6, 0.3, 20.0, 0.0, 1.0));
    assert_eq!(sh0.ambient, c0 * (1.0f32 - 0.6 - 0.3 - 0.0));
    // NFF's material model is additive: every `f` shades by local + Ks · reflected + T · refracted.
    assert_eq!(sh0.blend, Blend::Additive);
    assert!(desc.shaders.iter().all(|sh| sh.blend == Blend::Additive));
    assert_eq!(sh0.diffuse, c0 * 0.6);
    assert_eq!(sh0.specular, Vec3::splat(0.3));
    assert_eq!(
        (sh0.shininess, sh0.reflection, sh0.transparency, sh0.ior),
        (20.0, 0.3, 0.0, 1.0)
    );
    let sh1 = desc.shaders[1];
    assert_eq!(sh1.ambient, Vec3::ZERO, "1 - Kd - Ks - T is below 0");
    assert_eq!(sh1.diffuse, Vec3::new(0.2, 0.4, 0.6) * 0.5);
    assert_eq!((sh1.reflection, sh1.transparency, sh1.ior), (0.2, 0.5, 1.5));

    assert_eq!(desc.objects, vec![0, 1]);
    assert_eq!(
        desc.solids[0],
        SolidNode::Leaf {
            shape: Shape::Sphere { radius: 0.5 },
            transform: Transform::translate(Vec3::new(1.0, 2.0, 3.0)),
            shader: 0,
        }
    );
    let SolidNode::Leaf {
        shape:
            Shape::Cylinder {
                bottom_radius,
                top_radius,
                height,
            },
        transform,
        shader,
    } = desc.solids[1]
    else {
        panic!("a cone: {:?}", desc.solids[1]);
    };
    assert_eq!(
        (bottom_radius, top_radius, height, shader),
        (1.0, 0.5, 2.0, 1)
    );
    let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-6;
    assert!(close(
        transform.point(Vec3::new(0.0, -1.0, 0.0)),
        Vec3::ZERO
    ));
    assert!(close(
        transform.point(Vec3::new(0.0, 1.0, 0.0)),
        Vec3::new(0.0, 0.0, 2.0)
    ));
    // The bottom cap's rim keeps its radius.
    let rim = transform.point(Vec3::new(1.0, -1.0, 0.0));
    assert!(
        (rim.length() - 1.0).abs() < 1e-6 && rim.z.abs() < 1e-6,
        "{rim:?}"
    );

    // p 4: a fan of two triangles over its own four points; pp 3: one triangle with normals.
    assert_eq!(desc.points.len(), 7);
    assert_eq!(desc.points[0], Vec3::new(-5.0, -5.0, 0.0));
    assert_eq!(desc.points[6], Vec3::new(0.0, 1.0, 0.0));
    assert_eq!(
        desc.triangles,
        vec![
            TriangleDesc::new([0, 1, 2], 1),
            TriangleDesc::new([0, 2, 3], 1),
            TriangleDesc {
                points: [4, 5, 6],
                shader: 1,
                normals: Some([0, 1, 2])
            },
        ]
    );
    assert_eq!(
        desc.normals,
        vec![Vec3::Z, Vec3::new(0.0, 0.0, 2.0), Vec3::Z]
    );
}

#[test]
fn cones_land_on_their_base_and_apex_in_any_direction() {
    let cases = [
        (Vec3::ZERO, Vec3::new(0.0, 3.0, 0.0)),
        (Vec3::ZERO, Vec3::new(0.0, -3.0, 0.0)),
        (Vec3::new(1.0, 2.0, 3.0), Vec3::new(-4.0, 0.5, 7.0)),
        (Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, -5.0)),
    ];
    for (base, apex) in cases {
        let (t, h) = cone_transform(base, apex).expect("distinct points");
        assert!((h - (apex - base).length()).abs() < 1e-6);
        assert!(
            (t.point(Vec3::new(0.0, -h / 2.0, 0.0)) - base).length() < 1e-5,
            "{base} {apex}"
        );
        assert!(
            (t.point(Vec3::new(0.0, h / 2.0, 0.0)) - apex).length() < 1e-5,
            "{base} {apex}"
        );
        assert!(t.is_valid());
        assert!((t.matrix.determinant() - 1.0).abs() < 1e-5, "a rotation");
    }
    assert!(cone_transform(Vec3::ONE, Vec3::ONE).is_none());
}

const VIEW: &str = "v\nfrom 0 -5 0\nat 0 0 0\nup 0 0 1\nangle 45\nhither 0.01\nresolution 16 16\n";

/// Parses `text` as `bad.nff` and returns the error's text.
fn error_of(text: &str) -> (LoadError, String) {
    let err = parse_nff(Path::new("bad.nff"), text).expect_err("the text is rejected");
    let msg = err.to_string();
    (err, msg)
}

#[test]
fn bad_input_gives_exact_messages() {
    let l = "l 1 2 3\n";
    let f = "f 1 1 1 1 0 1 0 1\n";
    // VIEW is lines 1-7.
    let cases: Vec<(String, &str)> = vec![
        (
            format!("{VIEW}{l}q 1 2\n"),
            "bad.nff:9: unknown keyword `q`; expected v, b, l, f, c, s, p, pp or a # comment",
        ),
        (
            format!("{VIEW}{l}{f}s 1 2 3\n"),
            "bad.nff:10: `s`: expected 4 numbers (x y z radius), found 3",
        ),
        (
            format!("{VIEW}{l}{f}s 1 2 3 4 5\n"),
            "bad.nff:10: unexpected number `5` after the complete `s` record of line 10; expected a keyword (v, b, l, f, c, s, p, pp) or a # comment",
        ),
        (
            format!("{VIEW}{l}{f}s 1 2 nan 1\n"),
            "bad.nff:10: `s`: `nan` is not a finite number",
        ),
        (
            format!("{VIEW}l 1 inf 3\n"),
            "bad.nff:8: `l`: `inf` is not a finite number",
        ),
        (
            format!(
                "v\nfrom 3e38 -3e38 2\nat -3e38 3e38 0\nup 0 0 1\nangle 45\nhither 0.01\n\
                 resolution 16 16\n{l}"
            ),
            "bad.nff:3: `at`: the distance from `from` is beyond single precision (about 3.4e38)",
        ),
        (
            format!("{VIEW}{l}{f}c -3e38 0 0 1 3e38 0 0 1\n"),
            "bad.nff:10: `c`: the distance from the base to the apex is beyond single precision (about 3.4e38)",
        ),
        (
            format!("{VIEW}{l}f 1e20 1 1 1e20 0 10 0 1\n"),
            "bad.nff:9: `f`: the colour times Kd is beyond single precision (about 3.4e38)",
        ),
        (
            format!("{VIEW}l 1 2 3 4\n"),
            "bad.nff:8: `l`: expected 3 numbers (x y z) or 6 (x y z r g b), found 4",
        ),
        (
            format!("{VIEW}{l}{f}s 1 2 x 1\n"),
            "bad.nff:10: `s`: `x` is not a number",
        ),
        (
            format!("{VIEW}{l}s 0 0 0 1\n"),
            "bad.nff:9: `s` before the first `f`; a primitive takes the material of the last `f` above it",
        ),
        (
            format!("{VIEW}{l}{f}s 0 0 0 0\n"),
            "bad.nff:10: `s`: the radius must be above 0, found 0",
        ),
        (
            format!("{VIEW}{l}{f}p 3\n0 0 0\n1 0 0\n"),
            "bad.nff:10: `p` vertex 3 of 3: expected 3 numbers (x y z), found 0",
        ),
        (
            format!("{VIEW}{l}{f}p 3\n0 0 0\n1 0\ns 0 1 0 1\n"),
            "bad.nff:10: `p` vertex 2 of 3: expected 3 numbers (x y z), found 2 before the next keyword `s` (line 13)",
        ),
        (
            format!("{VIEW}{l}{f}p 3\n0 0 0\n1 0 x\n0 1 0\n"),
            "bad.nff:12: `p` vertex 2 of 3: `x` is not a number",
        ),
        (
            format!("{VIEW}{l}{f}p 2\n0 0 0\n1 0 0\n"),
            "bad.nff:10: `p`: a polygon needs at least 3 vertices, found 2",
        ),
        (
            format!("{VIEW}{l}{f}p three\n"),
            "bad.nff:10: `p`: `three` is not a number of vertices (a whole number, 3 or more)",
        ),
        (
            format!("{VIEW}{l}{f}pp 3\n0 0 0 0 0 1\n1 0 0 0 0 0\n0 1 0 0 0 1\n"),
            "bad.nff:12: `pp` vertex 2 of 3: the normal (0 0 0) has zero length",
        ),
        (
            format!("{VIEW}{l}{f}c\n0 0 0 1\n0 0 0 1\n"),
            "bad.nff:12: `c`: the apex is the base point; they must differ",
        ),
        (
            format!("{VIEW}{l}{f}c\n0 0 0 -1\n0 0 1 1\n"),
            "bad.nff:11: `c`: a negative radius needs the other one negative too (both negative shows the inside)",
        ),
        (
            format!("{VIEW}{l}{f}c 1\n"),
            "bad.nff:10: `c`: expected 8 numbers (base x y z radius, apex x y z radius), found 1",
        ),
        (
            format!("{VIEW}{l}f 1 1 1 1 0.6 1 0.6 1.5\n"),
            "bad.nff:9: `f`: Ks + T must be at most 1 (reflected and transmitted shares), found 1.2",
        ),
        (
            format!("{VIEW}{l}f 1 1 1 1 0 1 0.5 0\n"),
            "bad.nff:9: `f`: ior must be above 0 for a transparent material, found 0",
        ),
        (
            format!("{VIEW}{l}f 1 1 1 1 0 1 0\n"),
            "bad.nff:9: `f`: expected 8 numbers (r g b Kd Ks Shine T ior), found 7",
        ),
        (
            "v\nfrom 0 -5 0\nup 0 0 1\n".to_string(),
            "bad.nff:3: expected `at` (the `v` block is v, from, at, up, angle, hither, resolution, in this order), found `up`",
        ),
        (
            format!("{VIEW}{VIEW}"),
            "bad.nff:8: a second `v` block; the viewpoint is given once",
        ),
        (
            VIEW.replace("angle 45", "angle 180"),
            "bad.nff:5: `angle` must be above 0 and below 180 degrees, found 180",
        ),
        (
            VIEW.replace("resolution 16 16", "resolution 0 16"),
            "bad.nff:7: `resolution`: `0` is not an image side; expected a whole number from 1 to 32768",
        ),
        (
            VIEW.replace("up 0 0 1", "up 0 2 0"),
            "bad.nff:4: `up`: parallel to the view direction (or zero); it must point across the view",
        ),
        (
            "v\nfrom 0 0 0\n".to_string(),
            "bad.nff:1: the file ends inside the `v` block; expected `at`",
        ),
        (
            format!("{l}from 0 0 0\n"),
            "bad.nff:2: `from` outside a `v` block; it belongs after `v`",
        ),
        (
            format!("b 0 0 0\n{VIEW}b 1 1 1\n"),
            "bad.nff:9: a second `b`; the background colour is given once",
        ),
        (
            format!("{VIEW}{f}"),
            "bad.nff: no light (`l`) in the file; at least one is required",
        ),
        (
            format!("{l}{f}"),
            "bad.nff: no viewpoint in the file; a `v` block (from, at, up, angle, hither, resolution) is required",
        ),
    ];
    for (text, expected) in &cases {
        let (_, msg) = error_of(text);
        assert_eq!(&msg, expected, "for\n{text}");
    }
    // Line errors are `LoadError::At`, whole-file ones `LoadError::File`.
    assert!(matches!(
        error_of(&cases[0].0).0,
        LoadError::At { line: 9, .. }
    ));
    let last = &cases[cases.len() - 1].0;
    assert!(matches!(error_of(last).0, LoadError::File { .. }));
}

#[test]
fn comments_blank_lines_and_crlf_are_skipped() {
    let text = "# a comment\r\n\r\nv\r\n# inside the block\r\nfrom 0 -5 0\r\nat 0 0 0\r\n\
                up 0 0 1\r\nangle 45\r\nhither 0.01\r\nresolution 16 16\r\nl 0 -5 5\r\n\
                f 1 0 0 1 0 1 0 1\r\np 3\r\n# between vertices\r\n0 0 0\r\n1 0 0\r\n0 0 1\r\n";
    let desc = parse_nff(Path::new("crlf.nff"), text).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(desc.triangles.len(), 1);
    let err = parse_nff(Path::new("crlf.nff"), &format!("{text}s 0 0\r\n")).expect_err("bad");
    assert_eq!(
        err.to_string(),
        "crlf.nff:18: `s`: expected 4 numbers (x y z radius), found 2"
    );
}

/// Parses `body` after a view, a light and a material, as `layout.nff`.
fn scene_of(body: &str) -> SceneDesc {
    let text = format!("{VIEW}l 1 -5 5\nf 1 1 1 1 0 1 0 1\n{body}");
    parse_nff(Path::new("layout.nff"), &text).unwrap_or_else(|e| panic!("{e}\n{text}"))
}

#[test]
fn a_cone_on_one_line_equals_the_three_line_cone() {
    // SPD's programs write `c` with its 8 numbers on one line; the NFF specification puts the
    // base and the apex on the two lines after `c`.
    let three_lines = scene_of("c\n0 0 0 1\n0 0 2 0.5\n");
    let one_line = scene_of("c 0 0 0 1 0 0 2 0.5\n");
    assert_eq!(three_lines.solids.len(), 1);
    assert_eq!(one_line.solids, three_lines.solids);
    assert_eq!(format!("{one_line:?}"), format!("{three_lines:?}"));
    assert_eq!(one_line, three_lines);
    // Any other split of the 8 numbers, with a comment line and a blank line among them.
    let odd = scene_of("c 0 0\n# the rest of the base\n0 1 0\n\n0\n2 0.5\n");
    assert_eq!(odd, three_lines);
}

#[test]
fn a_polygon_split_oddly_over_lines_equals_one_vertex_per_line() {
    let per_line = scene_of("p 4\n-5 -5 0\n5 -5 0\n5 5 0\n-5 5 0\ns 0 0 1 0.5\n");
    assert_eq!(per_line.triangles.len(), 2);
    for odd in [
        "p 4 -5 -5 0 5 -5 0 5 5 0 -5 5 0\ns 0 0 1 0.5\n",
        "p 4 -5\n-5 0 5 -5\n0 5 5 0 -5 5\n0 s 0 0 1 0.5\n",
        "p\n4\n-5 -5 0 5 -5 0\n5 5 0 -5 5 0 s\n0 0 1\n0.5\n",
    ] {
        assert_eq!(scene_of(odd), per_line, "for\n{odd}");
    }
    let pp = "pp 3\n0 0 0 0 0 1\n1 0 0 0 0 2\n0 1 0 0 0 1\n";
    assert_eq!(
        scene_of("pp 3 0 0 0 0 0 1 1 0 0\n0 0 2 0 1 0 0 0 1\n"),
        scene_of(pp)
    );
}

#[test]
fn the_view_and_light_records_may_run_over_lines() {
    let ball = "f 1 1 1 1 0 1 0 1\ns 0 0 0 1\n";
    let one_per_line = format!("{VIEW}l 1 2 3 0.5 0.5 0.5\n{ball}");
    let one_per_line =
        parse_nff(Path::new("a.nff"), &one_per_line).unwrap_or_else(|e| panic!("{e}"));
    let run_on = format!(
        "v from\n0 -5 0 at 0 0 0\nup 0 0 1 angle 45 hither\n0.01 resolution 16\n16\n\
         l 1 2 3\n0.5 0.5 0.5\n{ball}"
    );
    let desc = parse_nff(Path::new("b.nff"), &run_on).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(desc, one_per_line);
    assert_eq!(desc.lights[0].color, Vec3::splat(0.5));
}

#[test]
fn a_cone_cut_short_by_the_next_keyword_names_its_line() {
    // `c` is on line 10; its seventh number is on line 11, and `s` on line 12 cuts it short.
    let (err, msg) = error_of(&format!(
        "{VIEW}l 1 2 3\nf 1 1 1 1 0 1 0 1\nc 0 0 0 1\n0 0 1\ns 0 0 0 1\n"
    ));
    assert!(matches!(err, LoadError::At { line: 10, .. }), "{err:?}");
    assert_eq!(
        msg,
        "bad.nff:10: `c`: expected 8 numbers (base x y z radius, apex x y z radius), found 7 \
         before the next keyword `s` (line 12)"
    );
}

#[test]
fn a_cone_cut_short_by_the_end_of_the_file_names_its_line() {
    let (err, msg) = error_of(&format!(
        "{VIEW}l 1 2 3\nf 1 1 1 1 0 1 0 1\nc\n0 0 0 1\n0 0 1\n"
    ));
    assert!(matches!(err, LoadError::At { line: 10, .. }), "{err:?}");
    assert_eq!(
        msg,
        "bad.nff:10: `c`: expected 8 numbers (base x y z radius, apex x y z radius), found 7"
    );
}

#[test]
fn a_stray_number_where_a_keyword_belongs_is_an_error() {
    let expected = "expected a keyword (v, b, l, f, c, s, p, pp) or a # comment";
    let cases = [
        (
            format!("{VIEW}l 1 2 3\nf 1 1 1 1 0 1 0 1\np 3\n0 0 0\n1 0 0\n0 1 0\n1 1 1\n"),
            format!(
                "bad.nff:14: unexpected number `1` after the complete `p` record of line 10; \
                 {expected}"
            ),
        ),
        (
            format!("{VIEW}l 1 2 3\nf 1 1 1 1 0 1 0 1\ns 0 0 0 1 2\n"),
            format!(
                "bad.nff:10: unexpected number `2` after the complete `s` record of line 10; \
                 {expected}"
            ),
        ),
        (
            "# a comment\n0.5 v\n".to_string(),
            format!("bad.nff:2: unexpected number `0.5`; {expected}"),
        ),
    ];
    for (text, message) in &cases {
        let (err, msg) = error_of(text);
        assert_eq!(&msg, message, "for\n{text}");
        assert!(matches!(err, LoadError::At { .. }));
    }
}

#[test]
fn missing_file_names_the_path() {
    let path = fixture("no-such-file.nff");
    let err = load_nff(&path).expect_err("missing");
    assert!(matches!(err, LoadError::Io { .. }));
    assert!(err
        .to_string()
        .starts_with(&format!("{}: cannot read: ", path.display())));
}

#[test]
fn a_small_nff_renders() {
    let mut desc = load_nff(&fixture("every_entity.nff")).unwrap_or_else(|e| panic!("{e}"));
    desc.settings.width = 16;
    desc.settings.height = 16;
    let lit = lit_pixels(&desc);
    assert!(lit > 16, "only {lit} of 256 pixels are not background");
}

/// The fenced ```nff blocks of `text`.
fn nff_blocks(text: &str) -> Vec<String> {
    let mut blocks = Vec::new();
    let mut current: Option<String> = None;
    for line in text.lines() {
        match &mut current {
            None if line.trim_start() == "```nff" => current = Some(String::new()),
            None => {}
            Some(_) if line.trim_start().starts_with("```") => {
                blocks.extend(current.take());
            }
            Some(block) => {
                block.push_str(line);
                block.push('\n');
            }
        }
    }
    blocks
}

/// Every ```nff example of `scenes/FORMATS.md` loads and renders something besides background.
/// (It fails until the NFF section is merged into FORMATS.md: it insists on at least one block.)
#[test]
fn formats_md_nff_examples_load_and_render() {
    let doc = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/FORMATS.md");
    let text = std::fs::read_to_string(&doc).expect("read scenes/FORMATS.md");
    let blocks = nff_blocks(&text);
    assert!(
        !blocks.is_empty(),
        "no ```nff example in {}; section 10 should have one per entity",
        doc.display()
    );
    for (i, block) in blocks.iter().enumerate() {
        let name = format!("FORMATS.md nff example {}", i + 1);
        let mut desc =
            parse_nff(Path::new(&name), block).unwrap_or_else(|e| panic!("{e}\n{block}"));
        desc.settings.width = 24;
        desc.settings.height = 18;
        let lit = lit_pixels(&desc);
        assert!(lit > 0, "{name} renders only background:\n{block}");
    }
}

#[test]
fn more_solids_than_the_limit_is_an_error_at_the_line_that_passes_it() {
    use strahl_formats::limits::MAX_SHAPES;
    let mut text = String::from("v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\n");
    text.push_str("resolution 8 8\nb 0 0 0\nl 1 1 1\nf 1 0 0 1 0 0 0 1\n");
    for _ in 0..=MAX_SHAPES {
        text.push_str("s 0 0 0 1\n");
    }
    let err = strahl_formats::nff::parse_nff(std::path::Path::new("many.nff"), &text)
        .expect_err("one sphere too many");
    let line = 10 + MAX_SHAPES + 1;
    assert!(
        err.to_string()
            .starts_with(&format!("many.nff:{line}: more than {MAX_SHAPES}")),
        "{err}"
    );
}

/// A U in the plane y = 0 facing the camera: a 3 × 3 square with a 1 × 2 notch cut from the top
/// of its middle, its corners listed from the lower left, where the fan around the first corner
/// would cover part of the notch.
const U_CORNERS: [[f32; 2]; 8] = [
    [-1.5, -1.5],
    [1.5, -1.5],
    [1.5, 1.5],
    [0.5, 1.5],
    [0.5, -0.5],
    [-0.5, -0.5],
    [-0.5, 1.5],
    [-1.5, 1.5],
];

/// `p` records of the corners given, each `[x, z]` in the plane y = 0.
fn polygons(faces: &[&[[f32; 2]]]) -> String {
    faces
        .iter()
        .map(|corners| {
            let points: Vec<String> = corners.iter().map(|[x, z]| format!("{x} 0 {z}")).collect();
            format!("p {}\n{}\n", corners.len(), points.join("\n"))
        })
        .collect()
}

#[test]
fn a_concave_polygon_covers_itself_and_not_its_notch() {
    let desc = scene_of(&polygons(&[&U_CORNERS]));
    assert_eq!(desc.triangles.len(), 6);
    let corners = |t: &TriangleDesc| t.points.map(|i| desc.points[i as usize]);
    // Twice the area each triangle covers, seen from the camera (−y), and whether it holds `q`.
    let area = |[a, b, c]: [Vec3; 3]| (b - a).cross(c - a).y;
    let holds = |[a, b, c]: [Vec3; 3], q: Vec3| {
        [area([a, b, q]), area([b, c, q]), area([c, a, q])]
            .iter()
            .all(|&s| s * area([a, b, c]) > 0.0)
    };
    let total: f32 = desc.triangles.iter().map(|t| area(corners(t)).abs()).sum();
    assert_eq!(total, 2.0 * 7.0, "the U's area is 9 − 2");
    for (q, count) in [
        (Vec3::new(0.3, 0.0, 1.0), 0),
        (Vec3::new(-1.0, 0.0, 1.0), 1),
    ] {
        let n = desc
            .triangles
            .iter()
            .filter(|t| holds(corners(t), q))
            .count();
        assert_eq!(n, count, "{q}");
    }
    // Rendered, the U lights as many pixels as its three rectangles, and fewer than the fan
    // around its first corner, which fills part of the notch.
    let sized = |body: String| {
        let mut desc = scene_of(&body);
        (desc.settings.width, desc.settings.height) = (64, 64);
        lit_pixels(&desc)
    };
    let [a, b, c, d, e, f, g, h] = U_CORNERS;
    let rectangles = polygons(&[
        &[a, [-0.5, -1.5], f, g, h],
        &[[-0.5, -1.5], [0.5, -1.5], e, f],
        &[[0.5, -1.5], b, c, d, e],
    ]);
    let fan: Vec<[[f32; 2]; 3]> = U_CORNERS
        .windows(2)
        .skip(1)
        .map(|w| [a, w[0], w[1]])
        .collect();
    let fan = polygons(&fan.iter().map(|t| &t[..]).collect::<Vec<_>>());
    let u = sized(polygons(&[&U_CORNERS]));
    assert_eq!(u, sized(rectangles));
    assert!(u + 20 < sized(fan), "{u}");
}
