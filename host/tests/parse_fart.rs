//! Tests of the `.fart` loader: what each construct puts into the `SceneDesc`, the exact place
//! and wording of errors, and that every example of `scenes/FORMATS.md` section 9 and every
//! scene in `scenes/fart/` loads and renders.

use std::path::{Path, PathBuf};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::geom::solid::{CsgOp, Shape, SolidNode};
use strahl_core::math::transform::Transform;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::scene::camera::Camera;
use strahl_core::scene::{Blend, Scene, SceneDesc, Shader};
use strahl_core::Vec3;
use strahl_host::formats::error::LoadError;
use strahl_host::formats::fart::{load_fart, load_fart_source};

type TestResult = Result<(), Box<dyn std::error::Error>>;

/// The repository root (the parent of the host crate).
fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default()
}

/// Writes `text` as `scene.fart` in a fresh folder and loads it.
fn load_text(text: &str) -> Result<SceneDesc, LoadError> {
    let dir = tempfile::tempdir().map_err(|source| LoadError::Io {
        path: PathBuf::from("tempdir"),
        source,
    })?;
    let path = dir.path().join("scene.fart");
    std::fs::write(&path, text).map_err(|source| LoadError::Io {
        path: path.clone(),
        source,
    })?;
    load_fart(&path)
}

/// The scene around `body`: a camera and a light, so only `body` is under test.
fn with_body(body: &str) -> String {
    format!(
        "scene {{\n  camera {{ position <0, 0, 10> look_at <0, 0, 0> }}\n  light {{ position <5, 5, 5> }}\n{body}\n}}\n"
    )
}

fn load_body(body: &str) -> Result<SceneDesc, LoadError> {
    load_text(&with_body(body))
}

/// The error of loading `text`, as `line:column: message` (the temporary path left out).
fn error_of(text: &str) -> String {
    match load_text(text) {
        Ok(_) => "loaded without error".to_string(),
        Err(LoadError::AtColumn {
            path,
            line,
            column,
            message,
        }) => {
            assert_eq!(
                path.file_name().and_then(|n| n.to_str()),
                Some("scene.fart")
            );
            format!("{line}:{column}: {message}")
        }
        Err(other) => format!("not an AtColumn error: {other}"),
    }
}

/// Renders `desc` at 16×12 and returns its pixels.
fn render_small(desc: &SceneDesc) -> Result<Vec<Pixel>, String> {
    let mut desc = desc.clone();
    desc.settings.width = 16;
    desc.settings.height = 12;
    let scene = Scene::build(&desc, &OctreeParams::default()).map_err(|e| e.to_string())?;
    let mut pixels = Vec::new();
    for y in 0..12 {
        let mut line = vec![Pixel::default(); 16];
        render_line(&scene, y, &mut line).map_err(|e| format!("{e:?}"))?;
        pixels.extend(line);
    }
    Ok(pixels)
}

/// Loads and renders `path` small; fails if every pixel is the background.
fn check_renders(path: &Path, desc: &SceneDesc) -> TestResult {
    let pixels = render_small(desc).map_err(|e| format!("{}: {e}", path.display()))?;
    let background = Pixel::from_color(desc.settings.background);
    assert!(
        pixels.iter().any(|p| *p != background),
        "{}: every pixel is the background",
        path.display()
    );
    Ok(())
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

fn leaf(desc: &SceneDesc, i: u32) -> (Shape, Transform, Shader) {
    match desc.solids[i as usize] {
        SolidNode::Leaf {
            shape,
            transform,
            shader,
        } => (shape, transform, desc.shaders[shader as usize]),
        _ => panic!("solid {i} is not a leaf"),
    }
}

const DEFAULT: Shader = Shader {
    ambient: Vec3::splat(0.1),
    diffuse: Vec3::splat(0.8),
    specular: Vec3::ZERO,
    shininess: 20.0,
    reflection: 0.0,
    transparency: 0.0,
    ior: 1.0,
    blend: Blend::Share,
};

// ---- good input ----

#[test]
fn settings_camera_and_lights() -> TestResult {
    let desc = load_text(
        "scene {
  options { width 800 height 600 multisample 3 max_depth 8 ambient_occlusion 2 background <0.1, 0.1, 0.2> }
  camera { position <0, 2, 10> look_at <0, 0, 0> up <0, 1, 0> vfov 40 }
  light { position <5, 10, 5> color <1, 0.5, 1> intensity 0.5 shadows off }
  light { position <-5, 10, 5> }
}",
    )?;
    let s = desc.settings;
    assert_eq!(
        (s.width, s.height, s.samples, s.max_depth),
        (800, 600, 3, 8)
    );
    assert_eq!(s.ambient_occlusion, 2);
    assert_eq!(s.background, Vec3::new(0.1, 0.1, 0.2));
    let Camera::LookAt(cam) = desc.camera else {
        panic!("not a look-at camera");
    };
    assert_eq!(cam.position, Vec3::new(0.0, 2.0, 10.0));
    assert_eq!(cam.look_at, Vec3::ZERO);
    assert_eq!(cam.up, Vec3::Y);
    assert_eq!(cam.vfov_deg, 40.0);
    assert_eq!(desc.lights.len(), 2);
    assert_eq!(desc.lights[0].color, Vec3::new(1.0, 0.5, 1.0));
    assert_eq!(desc.lights[0].amount, 0.5);
    assert!(!desc.lights[0].casts_shadows);
    assert_eq!(desc.lights[1].amount, 1.0);
    assert!(desc.lights[1].casts_shadows);
    assert_eq!(desc.lights[1].color, Vec3::ONE);
    Ok(())
}

#[test]
fn defaults_without_options() -> TestResult {
    let desc = load_body("")?;
    let s = desc.settings;
    assert_eq!(
        (s.width, s.height, s.samples, s.max_depth),
        (640, 480, 1, 16)
    );
    assert_eq!((s.ambient_occlusion, s.background), (0, Vec3::ZERO));
    let Camera::LookAt(cam) = desc.camera else {
        panic!("not a look-at camera");
    };
    assert_eq!((cam.up, cam.vfov_deg), (Vec3::Y, 45.0));
    // An empty scene still has the default shader, so it validates.
    assert_eq!(desc.shaders, vec![DEFAULT]);
    Ok(())
}

#[test]
fn shapes_and_their_parameters() -> TestResult {
    let desc = load_body(
        "sphere { radius 2 }
         box { size <2, 1, 3> }
         box { size 2 }
         cyl { size <1, 0.5, 2> }
         plane { position <0, 2, 0>, 4 }",
    )?;
    assert_eq!(desc.objects, vec![0, 1, 2, 3, 4]);
    assert_eq!(leaf(&desc, 0).0, Shape::Sphere { radius: 2.0 });
    assert_eq!(
        leaf(&desc, 1).0,
        Shape::Cuboid {
            size: Vec3::new(2.0, 1.0, 3.0)
        }
    );
    assert_eq!(
        leaf(&desc, 2).0,
        Shape::Cuboid {
            size: Vec3::splat(2.0)
        }
    );
    assert_eq!(
        leaf(&desc, 3).0,
        Shape::Cylinder {
            bottom_radius: 1.0,
            top_radius: 0.5,
            height: 2.0
        }
    );
    // n·p = d with n = (0, 2, 0), d = 4 is the plane y = 2: stored with a unit normal.
    assert_eq!(
        leaf(&desc, 4).0,
        Shape::Plane {
            normal: Vec3::Y,
            d: 2.0
        }
    );
    for i in 0..5 {
        assert_eq!(leaf(&desc, i).1, Transform::IDENTITY);
        assert_eq!(leaf(&desc, i).2, DEFAULT);
    }
    assert_eq!(desc.shaders.len(), 1, "identical shaders are shared");
    Ok(())
}

#[test]
fn transforms_apply_in_the_order_written() -> TestResult {
    let desc = load_body(
        "sphere { scale 2 translate <1, 0, 0> }
         sphere { translate <1, 0, 0> scale 2 }
         sphere { rotate <0, 0, 90> translate <0, 0, 5> scale <1, 2, 3> }",
    )?;
    let p = |i: u32| leaf(&desc, i).1.point(Vec3::X);
    // Scale first, then move: (1,0,0) -> (2,0,0) -> (3,0,0).
    assert!(close(p(0), Vec3::new(3.0, 0.0, 0.0)), "{:?}", p(0));
    // Move first, then scale: (1,0,0) -> (2,0,0) -> (4,0,0).
    assert!(close(p(1), Vec3::new(4.0, 0.0, 0.0)), "{:?}", p(1));
    // Rotate X onto Y, move by 5 in z, then scale: (0,1,5) -> (0,2,15).
    assert!(close(p(2), Vec3::new(0.0, 2.0, 15.0)), "{:?}", p(2));
    let expected = Transform::scale(Vec3::new(1.0, 2.0, 3.0))
        .after(&Transform::translate(Vec3::new(0.0, 0.0, 5.0)))
        .after(&Transform::rotate_xyz_deg(Vec3::new(0.0, 0.0, 90.0)));
    assert_eq!(leaf(&desc, 2).1, expected);
    Ok(())
}

#[test]
fn material_mapping_and_defaults() -> TestResult {
    let desc = load_body(
        "sphere { material { color <1, 0.5, 0> ambient 0.2 diffuse 0.6 specular 0.4 shininess 50 reflectance 0.3 transparency 0.5 ior 1.5 } }
         sphere { material { } }
         sphere { material { color <0, 1, 0> } }",
    )?;
    assert_eq!(
        leaf(&desc, 0).2,
        Shader {
            ambient: Vec3::new(0.2, 0.1, 0.0),
            diffuse: Vec3::new(0.6, 0.3, 0.0),
            specular: Vec3::splat(0.4),
            shininess: 50.0,
            reflection: 0.3,
            transparency: 0.5,
            ior: 1.5,
            blend: Blend::Share,
        }
    );
    assert_eq!(leaf(&desc, 1).2, DEFAULT);
    let green = leaf(&desc, 2).2;
    assert_eq!(green.ambient, Vec3::new(0.0, 0.1, 0.0));
    assert_eq!(green.diffuse, Vec3::new(0.0, 0.8, 0.0));
    assert_eq!(desc.shaders.len(), 3);
    Ok(())
}

#[test]
fn subtract_takes_the_first_minus_all_the_others() -> TestResult {
    let many = load_body(
        "subtract { box { size 2 } sphere { radius 0.5 } cyl { } sphere { translate <1, 0, 0> } }",
    )?;
    let explicit = load_body(
        "subtract { box { size 2 } union { sphere { radius 0.5 } cyl { } sphere { translate <1, 0, 0> } } }",
    )?;
    assert_eq!(
        many.solids, explicit.solids,
        "A minus the union of B, C and D"
    );
    let root = many.solids[*many.objects.first().ok_or("no object")? as usize];
    assert!(
        matches!(
            root,
            SolidNode::Csg {
                op: CsgOp::Subtract,
                a: 0,
                ..
            }
        ),
        "{root:?}"
    );
    Ok(())
}

#[test]
fn csg_arena_order_ops_transforms_and_inheritance() -> TestResult {
    let desc = load_body(
        "subtract {
           union { sphere { radius 1 } box { size 1 material { color <0, 0, 1> } } }
           sphere { radius 0.5 translate <1, 0, 0> }
           translate <0, 5, 0>
           material { color <1, 0, 0> }
         }",
    )?;
    // Post-order: the union's operands, the union, the subtrahend, the subtract.
    assert_eq!(desc.solids.len(), 5);
    assert_eq!(desc.objects, vec![4]);
    assert_eq!(
        desc.solids[2],
        SolidNode::Csg {
            op: CsgOp::Union,
            a: 0,
            b: 1
        }
    );
    assert_eq!(
        desc.solids[4],
        SolidNode::Csg {
            op: CsgOp::Subtract,
            a: 2,
            b: 3
        }
    );
    let red = |s: Shader| s.diffuse == Vec3::new(0.8, 0.0, 0.0);
    let blue = |s: Shader| s.diffuse == Vec3::new(0.0, 0.0, 0.8);
    // Leaves without a material inherit the subtract's; the box keeps its own.
    assert!(red(leaf(&desc, 0).2) && blue(leaf(&desc, 1).2) && red(leaf(&desc, 3).2));
    // The node's translation composes after each leaf's own transform.
    assert_eq!(
        leaf(&desc, 0).1,
        Transform::translate(Vec3::new(0.0, 5.0, 0.0))
    );
    assert!(close(
        leaf(&desc, 3).1.point(Vec3::ZERO),
        Vec3::new(1.0, 5.0, 0.0)
    ));
    Ok(())
}

#[test]
fn union_of_many_is_a_balanced_tree_of_all_operands() -> TestResult {
    let desc = load_body(
        "union { for i in 0 .. 100 { sphere { radius 0.1 translate <i, 0, 0> } } }
         intersect { sphere { } box { } sphere { radius 0.9 } }",
    )?;
    let leaves = desc
        .solids
        .iter()
        .filter(|n| matches!(n, SolidNode::Leaf { .. }))
        .count();
    assert_eq!(leaves, 103);
    assert_eq!(desc.solids.len(), 103 + 99 + 2);
    assert_eq!(desc.objects.len(), 2);
    // Every operand comes before its node (validate checks it too) and the first object is a union.
    for (i, n) in desc.solids.iter().enumerate() {
        if let SolidNode::Csg { a, b, .. } = *n {
            assert!((a as usize) < i && (b as usize) < i);
        }
    }
    assert!(matches!(
        desc.solids[desc.objects[0] as usize],
        SolidNode::Csg {
            op: CsgOp::Union,
            ..
        }
    ));
    assert!(matches!(
        desc.solids[desc.objects[1] as usize],
        SolidNode::Csg {
            op: CsgOp::Intersect,
            ..
        }
    ));
    Ok(())
}

#[test]
fn define_and_references() -> TestResult {
    let desc = load_body(
        "define glass material { color <1, 1, 1> transparency 0.9 ior 1.5 }
         define pip sphere { radius 0.1 translate <0, 1, 0> material { color <1, 0, 0> } }
         pip { translate <1, 0, 0> }
         pip { scale 2 material glass }
         sphere { material glass }",
    )?;
    assert_eq!(desc.objects.len(), 3);
    let (shape, t, sh) = leaf(&desc, 0);
    assert_eq!(shape, Shape::Sphere { radius: 0.1 });
    // The use's transforms apply after the definition's own.
    assert!(close(t.point(Vec3::ZERO), Vec3::new(1.0, 1.0, 0.0)));
    assert_eq!(sh.diffuse, Vec3::new(0.8, 0.0, 0.0));
    let (_, t, sh) = leaf(&desc, 1);
    assert!(close(t.point(Vec3::ZERO), Vec3::new(0.0, 2.0, 0.0)));
    // A material at the use replaces the definition's.
    assert_eq!((sh.transparency, sh.ior), (0.9, 1.5));
    assert_eq!(leaf(&desc, 2).2, sh);
    Ok(())
}

#[test]
fn defined_csg_keeps_inner_materials_and_takes_the_uses() -> TestResult {
    let desc = load_body(
        "define thing union { sphere { } sphere { translate <1, 0, 0> material { color <0, 1, 0> } } }
         thing { material { color <1, 0, 0> } translate <0, 3, 0> }",
    )?;
    assert_eq!(desc.solids.len(), 3);
    assert_eq!(leaf(&desc, 0).2.diffuse, Vec3::new(0.8, 0.0, 0.0));
    assert_eq!(leaf(&desc, 1).2.diffuse, Vec3::new(0.0, 0.8, 0.0));
    assert!(close(
        leaf(&desc, 1).1.point(Vec3::ZERO),
        Vec3::new(1.0, 3.0, 0.0)
    ));
    Ok(())
}

#[test]
fn a_ring_of_100_spheres_in_five_lines() -> TestResult {
    let desc = load_body(
        "for i in 0 .. 100 {
           let a = i * 3.6
           sphere { radius 0.1 translate <cos(a) * 3, 0, sin(a) * 3> }
         }",
    )?;
    assert_eq!(desc.objects.len(), 100);
    for i in 0..100u32 {
        let a = (i as f64 * 3.6).to_radians();
        let want = Vec3::new((a.cos() * 3.0) as f32, 0.0, (a.sin() * 3.0) as f32);
        let got = leaf(&desc, i).1.point(Vec3::ZERO);
        assert!(close(got, want), "sphere {i}: {got:?} != {want:?}");
    }
    Ok(())
}

#[test]
fn loops_with_steps_conditions_and_scopes() -> TestResult {
    let desc = load_body(
        "let n = 0
         for i in 0 .. 10 step 3 { let n = n + 1 }          // 0 3 6 9: n changes outside
         for i in 5 .. 0 step -2 { sphere { radius 0.1 translate <i, n, 0> } }   // 5 3 1
         for i in 0 .. 4 {
           for j in 0 .. 4 {
             if (i + j) % 2 == 0 { box { translate <i, j, -1> } }
             else if i == 3 && j != 0 { cyl { translate <i, j, -2> } }
             else { }
           }
         }
         if !(n == 4) { sphere { } }
         for k in 3 .. 3 { sphere { } }",
    )?;
    let positions: Vec<Vec3> = (0..3).map(|i| leaf(&desc, i).1.point(Vec3::ZERO)).collect();
    assert_eq!(
        positions,
        vec![
            Vec3::new(5.0, 4.0, 0.0),
            Vec3::new(3.0, 4.0, 0.0),
            Vec3::new(1.0, 4.0, 0.0)
        ]
    );
    let boxes = desc
        .solids
        .iter()
        .filter(|n| {
            matches!(
                n,
                SolidNode::Leaf {
                    shape: Shape::Cuboid { .. },
                    ..
                }
            )
        })
        .count();
    let cyls = desc
        .solids
        .iter()
        .filter(|n| {
            matches!(
                n,
                SolidNode::Leaf {
                    shape: Shape::Cylinder { .. },
                    ..
                }
            )
        })
        .count();
    assert_eq!((boxes, cyls), (8, 1));
    assert_eq!(desc.objects.len(), 3 + 8 + 1);
    Ok(())
}

#[test]
fn expressions() -> TestResult {
    let desc = load_body(
        "let v = <1, 2, 3> * 2 - <1, 1, 1> / 2
         let w = -(v + <0.5, 0.5, 0.5>)
         sphere { translate v }
         sphere { translate w }
         sphere { translate <7 % 3, -7 % 3, 2 + 3 * 4 - 8 / 2> }
         sphere { translate <sqrt(16) + abs(-1), floor(2.7) + ceil(0.2), pow(2, 10)> }
         sphere { translate <min(3, -2), max(3, -2), (1 < 2) + (2 <= 2) + (3 > 4) + (1 >= 2) + (1 == 1) + (1 != 1)> }
         sphere { translate <sin(90), cos(180), tan(45)> }
         sphere { translate <pi, (0 || 2) + (1 && 0), !0> }",
    )?;
    let p = |i: u32| leaf(&desc, i).1.point(Vec3::ZERO);
    assert_eq!(p(0), Vec3::new(1.5, 3.5, 5.5));
    assert_eq!(p(1), Vec3::new(-2.0, -4.0, -6.0));
    assert_eq!(p(2), Vec3::new(1.0, 2.0, 10.0), "% is never negative");
    assert_eq!(p(3), Vec3::new(5.0, 3.0, 1024.0));
    assert_eq!(p(4), Vec3::new(-2.0, 3.0, 3.0));
    assert!(
        close(p(5), Vec3::new(1.0, -1.0, 1.0)),
        "degrees: {:?}",
        p(5)
    );
    assert_eq!(p(6), Vec3::new(std::f32::consts::PI, 1.0, 1.0));
    Ok(())
}

#[test]
fn inline_mesh_and_mesh_file() -> TestResult {
    let dir = tempfile::tempdir()?;
    std::fs::write(
        dir.path().join("quad.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n",
    )?;
    let path = dir.path().join("scene.fart");
    std::fs::write(
        &path,
        with_body(
            "mesh { vertices { <0, 0, 0> <1, 0, 0> <0, 1, 0> } triangles { <0, 1, 2> } translate <0, 0, 1> }
             mesh { file \"quad.obj\" scale 2 material { color <1, 0, 0> } }
             sphere { }",
        ),
    )?;
    let desc = load_fart(&path)?;
    assert_eq!(desc.points.len(), 3 + 4);
    assert_eq!(desc.triangles.len(), 1 + 2);
    assert_eq!(desc.points[1], Vec3::new(1.0, 0.0, 1.0));
    assert_eq!(desc.points[5], Vec3::new(2.0, 2.0, 0.0));
    assert_eq!(desc.triangles[0].points, [0, 1, 2]);
    assert_eq!(desc.triangles[1].points, [3, 4, 5]);
    assert_eq!(desc.shaders[desc.triangles[0].shader as usize], DEFAULT);
    assert_eq!(
        desc.shaders[desc.triangles[1].shader as usize].diffuse,
        Vec3::new(0.8, 0.0, 0.0)
    );
    assert_eq!(desc.objects.len(), 1);
    Ok(())
}

#[test]
fn comments_and_csg_statements() -> TestResult {
    let desc = load_body(
        "/* a block
            comment */ union { // line comment
           let r = 0.5
           define s sphere { radius r }
           for i in 0 .. 3 { s { translate <i, 0, 0> } }
           translate <0, r, 0>
         }",
    )?;
    assert_eq!(desc.solids.len(), 5);
    assert!(close(
        leaf(&desc, 2).1.point(Vec3::ZERO),
        Vec3::new(2.0, 0.5, 0.0)
    ));
    assert_eq!(leaf(&desc, 0).0, Shape::Sphere { radius: 0.5 });
    Ok(())
}

// ---- bad input ----

#[test]
fn error_positions_and_messages() {
    let cases: &[(&str, &str)] = &[
        (
            "scene {\n  camera { position <0,0,5> look_at <0,0,0> }\n  sphere { radius }\n}",
            "3:19: expected a number after `radius`, found `}`",
        ),
        (
            "scene {\n  sphere { radius 1\n",
            "3:1: expected `}` to close the `sphere` opened at 2:3, found the end of the file",
        ),
        (
            "scene {\n  sphere radius 1 }\n}",
            "2:10: expected `{` after `sphere`, found `radius`",
        ),
        (
            "scene {\n  camera { position <0,0,5> look_at <0,0,0> }\n",
            "3:1: expected `}` to close the `scene` opened at 1:1, found the end of the file",
        ),
        (
            "scene {\n  plane { radius 1 }\n}",
            "2:11: `radius` does not belong in a `plane`; expected `position`, `translate`, `rotate`, `scale`, `material` or `}`",
        ),
        (
            "scene {\n  sphere { size <1, 1, 1> }\n}",
            "2:12: `size` does not belong in a `sphere`; expected `radius`, `translate`, `rotate`, `scale`, `material` or `}`",
        ),
        (
            "scene {\n  sphere { radis 1 }\n}",
            "2:12: unknown keyword `radis` in a `sphere`; expected `radius`, `translate`, `rotate`, `scale`, `material` or `}`",
        ),
        (
            "scene {\n  sphre { radius 1 }\n}",
            "2:3: expected a shape, found `sphre`, which is not defined (shapes are sphere, plane, box, cyl, mesh, union, intersect, subtract, or a name given by `define`)",
        ),
        (
            "scene {\n  lamp 3\n}",
            "2:3: unknown keyword `lamp` at scene level; expected a shape, `light`, `camera`, `options`, `let`, `define`, `for`, `if` or `}` (a defined shape is used as `lamp { ... }`)",
        ),
        (
            "scene {\n  sphere { radius 1e-50 }\n}",
            "2:19: the radius 1e-50 is too small: it rounds to 0 in single precision",
        ),
        (
            "scene {\n  union { sphere { }\n    sphere { scale 1e-30 } }\n}",
            "3:5: this shape's translations, rotations and scales together leave the range of single precision (a scale too small or too large, or a translation too far): its placement cannot be inverted",
        ),
        (
            "scene {\n  mesh { vertices { <0,0,0> <1,0,0> <0,1,0> } triangles { <0,1,2> } scale 1e30 scale 1e30 }\n}",
            "2:3: this shape's translations, rotations and scales together leave the range of single precision (a scale too small or too large, or a translation too far): its placement cannot be inverted",
        ),
        (
            "scene {\n  sphere { radius r }\n}",
            "2:19: undefined variable `r`; set it with `let r = ...` first",
        ),
        (
            "scene {\n  subtract { sphere { } }\n}",
            "2:25: expected at least two shapes in a `subtract` (the first, minus all the others), found 1",
        ),
        (
            "scene {\n  light { position <1, 1, 1> }\n  sphere { }\n}",
            "4:1: expected a `camera { ... }` in the scene, found its closing `}` without one",
        ),
        (
            "scene {\n  camera { position <0,0,5> look_at <0,0,0> }\n  sphere { }\n}",
            "4:1: expected at least one `light { ... }` in the scene, found its closing `}` without one",
        ),
        (
            "scene {\n  let x = 4 / (2 - 2)\n}",
            "2:13: division by zero: the right side of `/` is 0",
        ),
        (
            "scene {\n  camera { position <0,0,5> look_at <0,0,0> }\n  camera { position <0,0,5> look_at <0,0,0> }\n}",
            "3:3: expected exactly one `camera`, found a second one (the first is at 2:3)",
        ),
        (
            "scene {\n  for i in 0 .. 2.5 { }\n}",
            "2:17: expected a whole number for the end of the range, found the number 2.5",
        ),
        (
            "scene {\n  for i in 0 .. 100000000 { }\n}",
            "2:12: the range 0 .. 100000000 has 100000000 values; a `for` may run at most 1000000 times",
        ),
        (
            "scene {\n  let x = sqrt(-1)\n}",
            "2:11: expected a number at least 0 for `sqrt`, found -1",
        ),
        (
            "scene {\n  let x = pow(10, 400)\n}",
            "2:11: `pow` of 10, 400 is not a finite number",
        ),
        (
            "scene {\n  let x = 1e300 * 1e300\n}",
            "2:17: the result of `*` is not a finite number",
        ),
        (
            "scene {\n  sphere { radius <1, 2, 3> }\n}",
            "2:19: expected a positive number after `radius`, found the vector <1, 2, 3>",
        ),
        (
            "scene {\n  sphere { radius -1 }\n}",
            "2:19: expected a positive number after `radius`, found -1",
        ),
        (
            "scene {\n  sphere { material { reflectance 0.6 transparency 0.6 } }\n}",
            "2:39: expected `reflectance` + `transparency` to be at most 1, found 0.6 + 0.6",
        ),
        (
            "scene {\n  sphere { material { color <1e30, 1, 1> diffuse 1e30 } }\n}",
            "2:12: expected a material whose `color` times `ambient` and `diffuse` stays within single precision (about 3.4e38)",
        ),
        (
            "scene {\n  camera { position <3e38, 0, 0> look_at <-3e38, 0, 0> }\n}",
            "2:42: expected `look_at` within single precision (about 3.4e38) of the camera's `position`",
        ),
        (
            "scene {\n  sphere { radius 1e300 }\n}",
            "2:19: the number 1e300 is too large",
        ),
        (
            "scene {\n  sphere { material { ior 0 } }\n}",
            "2:27: expected a positive number after `ior`, found 0",
        ),
        (
            "scene {\n  union { sphere { } }\n}",
            "2:22: expected at least two shapes in a `union`, found 1",
        ),
        (
            "scene {\n  union { light { position <0, 0, 0> } }\n}",
            "2:11: `light` does not belong in a `union`; lights, the camera and options are written at scene level",
        ),
        (
            "scene {\n  translate <1, 0, 0>\n}",
            "2:3: `translate` does not belong at scene level; write it inside the shape it belongs to",
        ),
        (
            "scene {\n  sphere { material glass }\n}",
            "2:21: expected a material after `material`, found `glass`, which is not defined (write `define glass material { ... }` before it)",
        ),
        (
            "scene {\n  define s sphere { }\n  sphere { material s }\n}",
            "3:21: expected a material after `material`, found `s`, which is a shape",
        ),
        (
            "scene {\n  sphere { translate <1, 2> }\n}",
            "2:27: expected `,` and the z component of the vector opened at 2:22, found `>` (a vector has three components)",
        ),
        (
            "scene {\n  sphere { radius 1 radius 2 }\n}",
            "2:21: `radius` is given twice in this `sphere` (first at 2:12)",
        ),
        (
            "scene {\n  sphere { scale <1, 0, 1> }\n}",
            "2:18: expected a scale with no zero factor after `scale`, found <1, 0, 1>",
        ),
        (
            "scene {\n  let let = 1\n}",
            "2:7: expected a name after `let`, found the keyword `let`, which cannot be a name",
        ),
        (
            "scene {\n  if <1, 0, 0> { }\n}",
            "2:6: expected a number as the condition of `if` (0 is false), found the vector <1, 0, 0>",
        ),
        (
            "scene {\n  let x = <1, 2, 3> * <1, 2, 3>\n}",
            "2:21: cannot apply `*` to the vector <1, 2, 3> and the vector <1, 2, 3>",
        ),
        (
            "scene { } extra",
            "1:11: expected the end of the file after the scene's closing `}`, found `extra`",
        ),
        ("sphere { }", "1:1: expected `scene {` at the start of the file, found `sphere`"),
        (
            "scene {\n  let x = 1 @ 2\n}",
            "2:13: unexpected character `@`",
        ),
        (
            "scene {\n  /* never closed\n}",
            "2:3: this `/*` comment is never closed; expected `*/`, found the end of the file",
        ),
        (
            "scene {\n  plane { position <0, 0, 0>, 1 }\n}",
            "2:20: expected a non-zero normal after `position`, found <0, 0, 0>",
        ),
        (
            "scene {\n  light { position <0, 0, 0> shadows maybe }\n}",
            "2:38: expected `on` or `off` after `shadows`, found `maybe`",
        ),
        (
            "scene {\n  options { multisample 17 }\n}",
            "2:25: expected a whole number from 1 to 16 after `multisample`, found 17",
        ),
        (
            "scene {\n  mesh { vertices { <0, 0, 0> <1, 0, 0> <0, 1, 0> } triangles { <0, 1, 3> } }\n}",
            "2:65: expected point indices from 0 to 2 (the mesh has 3 vertices), found <0, 1, 3>",
        ),
        (
            "scene {\n  let x = foo(1)\n}",
            "2:11: unknown function `foo`; the functions are sin, cos, tan, sqrt, abs, floor, ceil, min, max, pow",
        ),
        (
            "scene {\n  camera { position <0, 0, 5> look_at <0, 0, 0> up <0, 0, 1> }\n}",
            "2:52: expected an `up` vector that is not zero nor parallel to the view direction (from `position` to `look_at`)",
        ),
    ];
    let mut failures = Vec::new();
    for (text, want) in cases {
        let got = error_of(text);
        if got != *want {
            failures.push(format!("input:\n{text}\nwant: {want}\ngot:  {got}\n"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn degenerate_triangles_in_a_csg_mesh_are_counted_and_change_nothing() -> TestResult {
    let body = |extra: &str| {
        format!(
            "  subtract {{\n    box {{ size 2 }}\n    mesh {{\n      vertices {{ <0, 1, 0> <-1, -1, -1> <1, -1, -1> <0, -1, 1> <0, -1, -1> }}\n      triangles {{ <0, 2, 1> <0, 3, 2> <0, 1, 3> <1, 2, 3> {extra} }}\n      translate <0, 0.5, 0>\n    }}\n  }}"
        )
    };
    let clean = load_body(&body(""))?;
    // Collinear (vertex 4 is halfway between 1 and 2), a repeated corner, one point thrice.
    let dirty = load_body(&body("<1, 4, 2> <0, 0, 3> <3, 3, 3>"))?;
    assert_eq!(dirty.solid_triangles.len(), 7);
    let count = |d: &SceneDesc| -> Result<u32, String> {
        Ok(Scene::build(d, &OctreeParams::default())
            .map_err(|e| e.to_string())?
            .degenerate_triangles)
    };
    assert_eq!(count(&clean)?, 0);
    assert_eq!(
        count(&dirty)?,
        3,
        "counted at load, like the scene's own triangles"
    );
    assert_eq!(render_small(&clean)?, render_small(&dirty)?);
    Ok(())
}

#[test]
fn mesh_in_csg_becomes_a_closed_mesh_solid_in_object_space() -> TestResult {
    let desc = load_body(
        "  subtract {\n    box { size 2 }\n    mesh {\n      vertices { <0, 1, 0> <-1, -1, -1> <1, -1, -1> <0, -1, 1> }\n      triangles { <0, 2, 1> <0, 3, 2> <0, 1, 3> <1, 2, 3> }\n      translate <0, 0.5, 0>\n    }\n  }",
    )?;
    // The mesh is a CSG operand, not scene triangles: its four faces are kept untransformed and
    // its transform travels with the node.
    assert!(desc.triangles.is_empty(), "{:?}", desc.triangles);
    assert_eq!(desc.solid_triangles.len(), 4);
    assert_eq!(desc.solid_triangles[0][0], Vec3::new(0.0, 1.0, 0.0));
    let mesh = desc
        .solids
        .iter()
        .find_map(|n| match n {
            SolidNode::Mesh {
                first,
                count,
                transform,
                ..
            } => Some((*first, *count, *transform)),
            _ => None,
        })
        .ok_or("no mesh node")?;
    assert_eq!((mesh.0, mesh.1), (0, 4));
    assert_eq!(mesh.2.point(Vec3::ZERO), Vec3::new(0.0, 0.5, 0.0));
    assert!(matches!(
        desc.solids.last(),
        Some(SolidNode::Csg {
            op: CsgOp::Subtract,
            ..
        })
    ));
    // And it renders: the scene builds and the middle line sees the solid, not only the
    // (black) background.
    let mut small = desc;
    small.settings.width = 8;
    small.settings.height = 6;
    let scene = Scene::build(&small, &OctreeParams::default())?;
    let mut line = vec![Pixel::default(); 8];
    render_line(&scene, 3, &mut line)?;
    assert!(
        line.iter().any(|p| *p != Pixel::default()),
        "the middle line shows only background: {line:?}"
    );
    Ok(())
}

#[test]
fn error_display_names_the_file() {
    let err = load_text("scene {\n  sphere { radius }\n}").err();
    let text = err.map(|e| e.to_string()).unwrap_or_default();
    assert!(
        text.ends_with("scene.fart:2:19: expected a number after `radius`, found `}`"),
        "{text}"
    );
}

#[test]
fn text_that_is_not_utf8_is_an_error_at_its_place() -> TestResult {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("bad.fart");
    std::fs::write(&path, b"scene {\n  \xff }\n")?;
    let err = load_fart(&path)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        err.ends_with("bad.fart:2:3: the file is not valid UTF-8 text"),
        "{err}"
    );
    Ok(())
}

#[test]
fn missing_mesh_file_is_an_error_at_its_place() {
    let got = error_of(&with_body("mesh { file \"nowhere.obj\" }"));
    assert!(
        got.starts_with("4:8: cannot read the mesh file `nowhere.obj`"),
        "{got}"
    );
}

#[test]
fn limits_end_in_errors_not_crashes() {
    // Deep nesting of blocks and of parentheses.
    let deep_blocks = format!(
        "scene {{ {} sphere {{ }} sphere {{ }} {} }}",
        "union { sphere { } ".repeat(500),
        "}".repeat(500)
    );
    assert!(error_of(&deep_blocks).contains("nested more than 128 levels deep"));
    let deep_parens = format!(
        "scene {{ let x = {}1{} }}",
        "(".repeat(100_000),
        ")".repeat(100_000)
    );
    assert!(error_of(&deep_parens).contains("nested more than 128 levels deep"));
    let long_sum = format!("scene {{ let x = 1{} }}", " + 1".repeat(100_000));
    assert!(error_of(&long_sum).contains("more than 256 levels of operators"));
    let negations = format!("scene {{ let x = {}1 }}", "-".repeat(100_000));
    assert!(error_of(&negations).contains("nested more than 128 levels deep"));
    // Too many shapes, too many iterations, CSG too deep.
    let many = with_body("for i in 0 .. 1000 { for j in 0 .. 1001 { sphere { } } }");
    assert!(
        error_of(&many).contains("more than 1000000 shapes"),
        "{}",
        error_of(&many)
    );
    let spin = with_body("for i in 0 .. 1000000 { for j in 0 .. 1000000 { } }");
    assert!(error_of(&spin).contains("the loops run more than 10000000 times"));
    let doubling = with_body(
        "define d sphere { }
         for i in 0 .. 40 { define d union { d { } d { translate <1, 0, 0> } } }
         d { }",
    );
    assert!(
        error_of(&doubling).contains("more than 1000000 shapes"),
        "{}",
        error_of(&doubling)
    );
    let chain = with_body(
        "define d sphere { }
         for i in 0 .. 100 { define d union { d { } sphere { } } }",
    );
    assert!(
        error_of(&chain).contains("CSG nested more than 64 levels deep"),
        "{}",
        error_of(&chain)
    );
}

#[test]
fn nesting_just_under_the_limits_works() -> TestResult {
    // 60 nested `if`s around a sphere whose radius is in 60 parentheses: with the scene's braces
    // 121 of the 128 levels of nesting.
    let body = format!(
        "{} sphere {{ radius {}1{} }} {}",
        "if 1 { ".repeat(60),
        "(".repeat(60),
        ")".repeat(60),
        "}".repeat(60)
    );
    let desc = load_body(&body)?;
    assert_eq!(desc.objects.len(), 1);
    // CSG 64 levels deep is allowed, 65 is not.
    let csg = |n: usize| {
        with_body(&format!(
            "define d sphere {{ }} for i in 0 .. {n} {{ define d subtract {{ d {{ }} sphere {{ radius 0.5 }} }} }} d {{ }}"
        ))
    };
    let desc = load_text(&csg(64))?;
    assert_eq!(desc.solids.len(), 1 + 2 * 64);
    assert!(error_of(&csg(65)).contains("CSG nested more than 64 levels deep"));
    Ok(())
}

#[test]
fn deepest_accepted_nesting_fits_a_small_stack() -> TestResult {
    // Every kind of nesting at (or just over) its limit, loaded on a thread with 2 MiB of stack
    // (Rust's default for spawned threads; an unoptimised build needs more than 1 MiB).
    let deep_csg = with_body(&format!(
        "{} sphere {{ }} {}",
        "union { sphere { } ".repeat(125),
        "}".repeat(125)
    ));
    let deep_ifs = with_body(&format!(
        "{} sphere {{ }} {}",
        "if 1 { ".repeat(125),
        "}".repeat(125)
    ));
    let deep_parens = with_body(&format!("let x = {}1{}", "-(".repeat(62), ")".repeat(62)));
    let long_sum = with_body(&format!("let x = 1{}", " + 1".repeat(255)));
    let texts = [deep_csg, deep_ifs, deep_parens, long_sum];
    let results = std::thread::Builder::new()
        .stack_size(2 << 20)
        .spawn(move || texts.iter().map(|t| error_of(t)).collect::<Vec<_>>())?
        .join()
        .map_err(|_| "the loader overflowed a 2 MiB stack")?;
    assert!(
        results[0].contains("CSG nested more than 64 levels deep"),
        "{}",
        results[0]
    );
    assert_eq!(results[1..], ["loaded without error"; 3]);
    Ok(())
}

// ---- examples and scenes ----

/// Every ```fart block of `text`, with the line it starts on.
fn fart_blocks(text: &str) -> Vec<(usize, String)> {
    let mut blocks = Vec::new();
    let mut current: Option<(usize, String)> = None;
    for (i, line) in text.lines().enumerate() {
        match current.as_mut() {
            None if line.trim() == "```fart" => current = Some((i + 2, String::new())),
            None => {}
            Some(_) if line.trim() == "```" => blocks.extend(current.take()),
            Some((_, body)) => {
                body.push_str(line);
                body.push('\n');
            }
        }
    }
    blocks
}

#[test]
fn every_fart_example_in_formats_md_loads_and_renders() -> TestResult {
    let doc = std::fs::read_to_string(repo().join("scenes/FORMATS.md"))?;
    let blocks = fart_blocks(&doc);
    assert!(blocks.len() >= 10, "only {} ```fart blocks", blocks.len());
    for (line, body) in blocks {
        // As if the block were a file in scenes/fart/, where the mesh example's OBJ file is.
        let path = repo().join(format!("scenes/fart/FORMATS.md-line-{line}.fart"));
        let desc = load_fart_source(&path, &body)
            .map_err(|e| format!("FORMATS.md block at line {line}: {e}"))?;
        check_renders(Path::new(&format!("FORMATS.md:{line}")), &desc)?;
    }
    Ok(())
}

#[test]
fn every_scene_in_scenes_fart_loads_and_renders() -> TestResult {
    let mut count = 0;
    for entry in std::fs::read_dir(repo().join("scenes/fart"))? {
        let path = entry?.path();
        if path.extension().and_then(|e| e.to_str()) != Some("fart") {
            continue;
        }
        let desc = load_fart(&path)?;
        check_renders(&path, &desc)?;
        count += 1;
    }
    assert!(count >= 4, "only {count} scenes");
    Ok(())
}

/// Renders every scene of `scenes/fart/` (or of the folder `STRAHL_FART_SRC_DIR`) at its own size
/// into PNGs in the folder named by `STRAHL_FART_PNG_DIR` (a check by eye; ignored unless asked
/// for).
#[test]
#[ignore = "writes images; run with STRAHL_FART_PNG_DIR=/tmp/x -- --ignored"]
fn render_scenes_to_png() -> TestResult {
    let Some(out) = std::env::var_os("STRAHL_FART_PNG_DIR") else {
        return Ok(());
    };
    let src = std::env::var_os("STRAHL_FART_SRC_DIR")
        .map_or_else(|| repo().join("scenes/fart"), PathBuf::from);
    for entry in std::fs::read_dir(src)? {
        let path = entry?.path();
        if path.extension().and_then(|e| e.to_str()) != Some("fart") {
            continue;
        }
        let desc = load_fart(&path)?;
        let scene = Scene::build(&desc, &OctreeParams::default()).map_err(|e| e.to_string())?;
        let (w, h) = (desc.settings.width, desc.settings.height);
        let mut img = image::RgbImage::new(w, h);
        let rows: Vec<Vec<Pixel>> = std::thread::scope(|s| {
            let workers: Vec<_> = (0..2u32)
                .map(|k| {
                    let scene = &scene;
                    s.spawn(move || {
                        (0..h)
                            .filter(|y| y % 2 == k)
                            .map(|y| {
                                let mut line = vec![Pixel::default(); w as usize];
                                let _ = render_line(scene, y, &mut line);
                                (y, line)
                            })
                            .collect::<Vec<_>>()
                    })
                })
                .collect();
            let mut rows = vec![Vec::new(); h as usize];
            for wk in workers {
                for (y, line) in wk.join().unwrap_or_default() {
                    rows[y as usize] = line;
                }
            }
            rows
        });
        for (y, row) in rows.iter().enumerate() {
            for (x, p) in row.iter().enumerate() {
                img.put_pixel(x as u32, y as u32, image::Rgb(p.to_rgb8()));
            }
        }
        let name = path.with_extension("png");
        let file = Path::new(&out).join(name.file_name().unwrap_or_default());
        img.save(&file)?;
    }
    Ok(())
}

#[test]
fn a_mesh_file_takes_its_mtl_materials_unless_the_mesh_gives_one() -> TestResult {
    let dir = tempfile::tempdir()?;
    std::fs::write(
        dir.path().join("two.mtl"),
        "newmtl red\nKd 0.9 0.1 0.1\nnewmtl blue\nKd 0.1 0.1 0.9\n",
    )?;
    std::fs::write(
        dir.path().join("two.obj"),
        "mtllib two.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n\
         usemtl red\nf 1 2 3\nusemtl blue\nf 2 4 3\nusemtl nothing\nf 1 2 4\n",
    )?;
    let scene = |mesh: &str| {
        format!(
            "scene {{\n  camera {{ position <0, 0, 5> look_at <0, 0, 0> }}\n  \
             light {{ position <1, 1, 5> }}\n  {mesh}\n}}\n"
        )
    };
    let path = dir.path().join("scene.fart");
    std::fs::write(&path, scene("mesh { file \"two.obj\" }"))?;
    let desc = strahl_host::formats::fart::load_fart(&path)?;
    let diffuse: Vec<Vec3> = desc
        .triangles
        .iter()
        .map(|t| desc.shaders[t.shader as usize].diffuse)
        .collect();
    assert_eq!(diffuse[0], Vec3::new(0.9, 0.1, 0.1), "red from the .mtl");
    assert_eq!(diffuse[1], Vec3::new(0.1, 0.1, 0.9), "blue from the .mtl");
    assert_ne!(
        diffuse[2], diffuse[0],
        "an unknown material keeps the default"
    );
    assert_ne!(diffuse[2], diffuse[1]);
    // The mesh's own material beats the OBJ's.
    std::fs::write(
        &path,
        scene("mesh { file \"two.obj\" material { color <0, 1, 0> } }"),
    )?;
    let desc = strahl_host::formats::fart::load_fart(&path)?;
    let shaders: Vec<u32> = desc.triangles.iter().map(|t| t.shader).collect();
    assert!(shaders.iter().all(|&s| s == shaders[0]), "{shaders:?}");
    assert!(
        desc.shaders[shaders[0] as usize].diffuse.y > 0.5,
        "the mesh's green"
    );
    Ok(())
}
