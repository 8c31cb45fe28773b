//! Tests of the OBJ reader (`strahl_host::formats::obj`), `append_mesh` and `strahl convert`'s
//! `convert_obj`.

use glam::{Mat3, Vec3};
use std::path::{Path, PathBuf};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::math::transform::Transform;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::scene::camera::Camera;
use strahl_core::scene::{Scene, SceneDesc, TriangleDesc};
use strahl_host::formats::convert::{convert_obj, convert_obj_with, y_up_to_z_up, ConvertOptions};
use strahl_host::formats::error::LoadError;
use strahl_host::formats::load::{load_config_scene, Overrides};
use strahl_host::formats::mesh::append_mesh;
use strahl_host::formats::obj::{read_obj, read_obj_file, ObjTriangle};

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/obj")
        .join(name)
}

fn write(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
    let path = dir.path().join(name);
    std::fs::write(&path, text).expect("write fixture");
    path
}

const CUBE_POINTS: [Vec3; 8] = [
    Vec3::new(0.0, 0.0, 0.0),
    Vec3::new(1.0, 0.0, 0.0),
    Vec3::new(1.0, 1.0, 0.0),
    Vec3::new(0.0, 1.0, 0.0),
    Vec3::new(0.0, 0.0, 1.0),
    Vec3::new(1.0, 0.0, 1.0),
    Vec3::new(1.0, 1.0, 1.0),
    Vec3::new(0.0, 1.0, 1.0),
];

#[test]
fn cube_without_normals_is_twelve_triangles() {
    let mesh = read_obj(&fixture("cube.obj")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(mesh.points, CUBE_POINTS);
    assert!(mesh.normals.is_empty());
    assert_eq!(mesh.triangles.len(), 12, "six quads, two triangles each");
    // `f 1 4 3 2` is split into a fan around its first corner.
    assert_eq!(
        mesh.triangles[..2],
        [
            ObjTriangle {
                points: [0, 3, 2],
                normals: None
            },
            ObjTriangle {
                points: [0, 2, 1],
                normals: None
            },
        ]
    );
    assert!(mesh.triangles.iter().all(|t| t.normals.is_none()));
}

#[test]
fn cube_with_normals_keeps_their_indices() {
    let mesh = read_obj(&fixture("cube_normals.obj")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(mesh.points, CUBE_POINTS);
    assert_eq!(mesh.normals.len(), 6);
    assert_eq!(mesh.triangles.len(), 12, "both objects merged");
    assert_eq!(
        mesh.triangles[0],
        ObjTriangle {
            points: [0, 3, 2],
            normals: Some([0, 0, 0])
        }
    );
    // `f 5/1/2 ...`: texture coordinates are skipped, normals kept.
    assert_eq!(mesh.triangles[2].normals, Some([1, 1, 1]));
    // `f -6//-2 -5//-2 -1//-2 -2//-2` with 8 points and 6 normals: points 3 4 8 7, normal 5.
    assert_eq!(
        mesh.triangles[8],
        ObjTriangle {
            points: [2, 3, 7],
            normals: Some([4, 4, 4])
        }
    );
    assert_eq!(mesh.triangles[9].points, [2, 7, 6]);
    // Every normal points out of the cube through its triangle.
    let centre = Vec3::splat(0.5);
    for t in &mesh.triangles {
        let n = mesh.normals[t.normals.expect("normals")[0] as usize];
        let p = mesh.points[t.points[0] as usize];
        let q = mesh.points[t.points[1] as usize];
        let r = mesh.points[t.points[2] as usize];
        let mid = (p + q + r) / 3.0;
        assert!(n.dot(mid - centre) > 0.0, "{t:?}");
    }
}

#[test]
fn materials_and_warnings() {
    let file = read_obj_file(&fixture("cube_normals.obj")).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = file.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names, ["red", "grey"]);
    let red = &file.materials[0];
    assert_eq!(red.ambient, Some(Vec3::new(0.2, 0.0, 0.0)));
    assert_eq!(red.diffuse, Some(Vec3::new(0.8, 0.1, 0.1)));
    assert_eq!(red.specular, Some(Vec3::splat(0.5)));
    assert_eq!(red.shininess, Some(40.0));
    let grey = &file.materials[1];
    assert_eq!(grey.diffuse, Some(Vec3::splat(0.5)), "one value is grey");
    assert_eq!(grey.dissolve, Some(0.5));
    let mut expected = vec![Some(0); 4];
    expected.extend([Some(1); 6]);
    expected.extend([None; 2]);
    assert_eq!(file.triangle_materials, expected);
    assert_eq!(file.warnings.len(), 1, "{:?}", file.warnings);
    assert!(
        file.warnings[0].contains("`usemtl nosuch` names no material"),
        "{:?}",
        file.warnings
    );
    // A missing .mtl is a warning too, and `read_obj` never looks at materials.
    let dir = tempfile::tempdir().expect("tempdir");
    let obj = write(
        &dir,
        "m.obj",
        "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    let file = read_obj_file(&obj).unwrap_or_else(|e| panic!("{e}"));
    assert!(file.warnings[0].contains("gone.mtl: cannot read the material file"));
    assert_eq!(file.triangle_materials, [None]);
    read_obj(&obj).unwrap_or_else(|e| panic!("{e}"));
    // A bad .mtl line is an error naming the .mtl file and line.
    write(&dir, "bad.mtl", "newmtl a\nKd 0.5 0.5\n");
    let obj = write(
        &dir,
        "b.obj",
        "mtllib bad.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    let err = read_obj_file(&obj).expect_err("bad mtl");
    assert_eq!(
        err.to_string(),
        format!(
            "{}:2: `Kd`: expected 3 numbers (r g b) or 1 (grey), found 2",
            dir.path().join("bad.mtl").display()
        )
    );
}

#[test]
fn append_mesh_places_points_and_normals() {
    let mesh = read_obj(&fixture("cube_normals.obj")).unwrap_or_else(|e| panic!("{e}"));
    let mut desc = SceneDesc {
        points: vec![Vec3::ONE; 3],
        normals: vec![Vec3::Z],
        triangles: vec![TriangleDesc::new([0, 1, 2], 0)],
        ..SceneDesc::default()
    };
    // Scale x by 2, then move by (10, 0, 0).
    let transform = Transform {
        matrix: Mat3::from_diagonal(Vec3::new(2.0, 1.0, 1.0)),
        translation: Vec3::new(10.0, 0.0, 0.0),
    };
    append_mesh(&mut desc, &mesh, &transform, 7);
    assert_eq!(desc.points.len(), 3 + 8);
    assert_eq!(desc.points[3 + 6], Vec3::new(12.0, 1.0, 1.0));
    assert_eq!(desc.normals.len(), 1 + 6);
    assert_eq!(desc.triangles.len(), 1 + 12);
    assert_eq!(
        desc.triangles[1],
        TriangleDesc {
            points: [3, 6, 5],
            shader: 7,
            normals: Some([1, 1, 1])
        }
    );
    // Axis normals stay axis normals (unit length) under the scale.
    assert_eq!(desc.normals[1 + 3], Vec3::X);
    // A slanted normal follows the inverse transpose: (1,1,0) under x·2 becomes (0.5,1,0)/|…|.
    let slanted = strahl_host::formats::obj::ObjMesh {
        points: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        normals: vec![Vec3::new(1.0, 1.0, 0.0)],
        triangles: vec![ObjTriangle {
            points: [0, 1, 2],
            normals: Some([0, 0, 0]),
        }],
    };
    append_mesh(&mut desc, &slanted, &transform, 0);
    let n = *desc.normals.last().expect("a normal");
    assert!(
        (n - Vec3::new(0.5, 1.0, 0.0).normalize()).length() < 1e-6,
        "{n:?}"
    );
    // Without normals the triangles keep `None`.
    let plain = read_obj(&fixture("cube.obj")).unwrap_or_else(|e| panic!("{e}"));
    let mut d2 = SceneDesc::default();
    append_mesh(&mut d2, &plain, &Transform::IDENTITY, 0);
    assert!(d2.normals.is_empty() && d2.triangles.iter().all(|t| t.normals.is_none()));
}

#[test]
fn bad_files_give_clear_errors() {
    let dir = tempfile::tempdir().expect("tempdir");
    let tri = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    let cases: Vec<(String, Option<usize>, &str)> = vec![
        (
            format!("{tri}f 1 2 9\n"),
            Some(4),
            "`f`: vertex index 9 out of range (3 vertices defined so far)",
        ),
        (
            format!("{tri}f 1 2 -4\n"),
            Some(4),
            "`f`: vertex index -4 out of range (3 vertices defined so far)",
        ),
        (
            format!("{tri}f 0 1 2\n"),
            Some(4),
            "`f`: vertex index 0; OBJ indices count from 1 (or back from -1)",
        ),
        (
            format!("{tri}vn 0 0 1\nf 1//1 2//2 3//1\n"),
            Some(5),
            "`f`: normal index 2 out of range (1 normal defined so far)",
        ),
        (
            format!("{tri}vn 0 0 1\nf 1//1 2 3//1\n"),
            Some(5),
            "`f`: some corners have a normal (v//vn) and others do not; give all or none",
        ),
        (
            format!("{tri}f 1 2\n"),
            Some(4),
            "`f`: a face needs at least 3 corners, found 2",
        ),
        (
            format!("{tri}f 1 2 x\n"),
            Some(4),
            "`f`: `x` is not a vertex index (a whole number)",
        ),
        (
            format!("{tri}f 1/1/1/1 2 3\n"),
            Some(4),
            "`f`: `1/1/1/1` is not a corner; expected v, v/vt, v//vn or v/vt/vn",
        ),
        (
            format!("v 0 0 nan\n{tri}f 1 2 3\n"),
            Some(1),
            "`v`: `nan` is not a finite number",
        ),
        (
            format!("{tri}v 1 inf 0\nf 1 2 3\n"),
            Some(4),
            "`v`: `inf` is not a finite number",
        ),
        (
            format!("{tri}v 1 2\n"),
            Some(4),
            "`v`: expected 3 numbers (x y z), 4 (x y z w) or 6 (x y z r g b), found 2",
        ),
        (
            format!("{tri}v 1 2 3 0\n"),
            Some(4),
            "`v`: the weight w is 0",
        ),
        (
            format!("{tri}vn 0 0 1\nvn 0 0 0\nf 1//1 2//1 3//1\n"),
            Some(5),
            "normal 2 has zero length",
        ),
        (
            format!("{tri}vn 0 1\n"),
            Some(4),
            "`vn`: expected 3 numbers (x y z), found 2",
        ),
        (
            format!("{tri}# no faces\n"),
            None,
            "no faces (`f`) in the file; a mesh needs at least one triangle",
        ),
    ];
    for (i, (text, line, message)) in cases.iter().enumerate() {
        let path = write(&dir, &format!("bad{i}.obj"), text);
        let err = read_obj(&path).expect_err("rejected");
        let expected = match line {
            Some(l) => format!("{}:{l}: {message}", path.display()),
            None => format!("{}: {message}", path.display()),
        };
        assert_eq!(err.to_string(), expected, "for\n{text}");
        match line {
            Some(l) => assert!(matches!(err, LoadError::At { line, .. } if line == *l)),
            None => assert!(matches!(err, LoadError::File { .. })),
        }
    }
    let missing = dir.path().join("missing.obj");
    let err = read_obj(&missing).expect_err("missing");
    assert!(matches!(err, LoadError::Io { .. }));
    assert!(err
        .to_string()
        .starts_with(&format!("{}: cannot read: ", missing.display())));
}

#[test]
fn lenient_details() {
    let dir = tempfile::tempdir().expect("tempdir");
    // CRLF, trailing comments, `v x y z w`, vertex colours, relative indices, `l`/`p` ignored,
    // a pentagon as a fan of three.
    let text = "v 0 0 0 # origin\r\nv 2 0 0 2\r\nv 1 1 0 0.5 0.5 0.5\r\nv 0 1 0\r\nv -1 0.5 0\r\n\
                l 1 2\r\np 1\r\ng part\r\ns off\r\nf 1 2 3 4 5 # pentagon\r\nf -3 -2 -1\r\n";
    let path = write(&dir, "ok.obj", text);
    let mesh = read_obj(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(mesh.points[1], Vec3::new(1.0, 0.0, 0.0));
    assert_eq!(mesh.points[2], Vec3::new(1.0, 1.0, 0.0));
    let points: Vec<[u32; 3]> = mesh.triangles.iter().map(|t| t.points).collect();
    assert_eq!(points, [[0, 1, 2], [0, 2, 3], [0, 3, 4], [2, 3, 4]]);
}

/// Renders `desc` at a small size and returns how many pixels differ from the background.
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
fn convert_output_loads_and_renders() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("CUBE.txt");
    let summary =
        convert_obj(&fixture("cube_normals.obj"), &out).unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(
        (
            summary.points,
            summary.triangles,
            summary.shaders,
            summary.lights
        ),
        // A point per face at each corner: the cube's 90° edges are sharper than the default
        // crease angle.
        (24, 12, 3, 1)
    );
    assert_eq!(summary.normals_dropped, 6);
    assert_eq!(summary.config_file, dir.path().join("raytracer.cfg"));
    let report = summary.to_string();
    assert!(
        report.contains("normals from the OBJ are dropped; the seed computes smooth normals"),
        "{report}"
    );
    assert!(report.contains("wrote "), "{report}");
    assert!(report.contains("warning: "), "{report}");
    assert!(
        summary
            .warnings
            .iter()
            .any(|w| w.contains("`grey` is partly transparent")),
        "{:?}",
        summary.warnings
    );
    let data = std::fs::read_to_string(&out).expect("data file");
    assert!(
        data.starts_with("REM Converted from cube_normals.obj"),
        "{data}"
    );
    assert!(data.ends_with("QUIT\n"));

    let loaded = load_config_scene(&summary.config_file, &Overrides::default())
        .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(loaded.data_path, out);
    assert_eq!(loaded.output, dir.path().join("CUBE.bmp"));
    let mut desc = loaded.desc;
    assert_eq!(
        desc.points.len(),
        24,
        "3 per corner: the data file carries the hard edges"
    );
    assert_eq!(desc.points[6], y_up_to_z_up(Vec3::ONE));
    assert_eq!(desc.points[6], Vec3::new(1.0, -1.0, 1.0));
    assert_eq!(desc.triangles.len(), 12);
    assert!(desc.triangles.iter().all(|t| t.normals.is_none()));
    // Materials in order of first use: red, grey, then the default grey for `usemtl nosuch`.
    assert_eq!(
        desc.triangles.iter().map(|t| t.shader).collect::<Vec<_>>(),
        [0, 0, 0, 0, 1, 1, 1, 1, 1, 1, 2, 2]
    );
    assert_eq!(desc.shaders[0].diffuse, Vec3::new(0.8, 0.1, 0.1));
    assert!((desc.shaders[0].ambient - Vec3::new(0.02, 0.0, 0.0)).length() < 1e-7);
    assert!(matches!(desc.camera, Camera::Seed(_)));
    let light = desc.lights[0];
    assert!(
        light.position.z > 1.0 && light.position.y < -1.0,
        "above and in front"
    );
    // The camera sees the cube: render a small image.
    desc.settings.width = 32;
    desc.settings.height = 24;
    let lit = lit_pixels(&desc);
    assert!(lit > 40, "only {lit} pixels show the cube");
    // Not all of the image: the cube is framed with a margin.
    assert!(lit < 32 * 24, "the cube fills the whole image");
}

#[test]
fn convert_can_keep_z_up_and_rejects_bad_names() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("plain.txt");
    let s = convert_obj_with(
        &fixture("cube.obj"),
        &out,
        &ConvertOptions {
            y_up: false,
            ..ConvertOptions::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!((s.shaders, s.normals_dropped), (1, 0), "one grey shader");
    assert!(!s.to_string().contains("normals from the OBJ"));
    let loaded =
        load_config_scene(&s.config_file, &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        loaded.desc.points[..8],
        CUBE_POINTS,
        "the OBJ's points first"
    );
    assert_eq!(
        loaded.desc.points.len(),
        24,
        "then their copies at the hard edges"
    );
    // At 180° every edge is smooth and every point shared, as before crease angles.
    let smooth = dir.path().join("smooth");
    std::fs::create_dir(&smooth).expect("folder");
    let all_smooth = ConvertOptions {
        y_up: false,
        crease_degrees: 180.0,
        ..ConvertOptions::default()
    };
    let s = convert_obj_with(&fixture("cube.obj"), &smooth.join("c.txt"), &all_smooth)
        .unwrap_or_else(|e| panic!("{e:#}"));
    assert_eq!(s.points, 8);
    assert!(!s.to_string().contains("kept hard"), "{s}");

    let err = convert_obj(&fixture("cube.obj"), &dir.path().join("raytracer.cfg"))
        .expect_err("clashes with the configuration file");
    assert!(
        err.to_string().contains("cannot be called raytracer.cfg"),
        "{err}"
    );
    let err = convert_obj(
        &fixture("cube.obj"),
        &dir.path().join("no/such/folder/x.txt"),
    )
    .expect_err("no folder");
    assert!(err.to_string().contains("x.txt"), "{err:#}");
    // What is there is not replaced without --force: the data file, or the seed's own config.
    let err = convert_obj(&fixture("cube.obj"), &out).expect_err("plain.txt is there");
    assert!(
        err.to_string()
            .contains("plain.txt: the file is there already"),
        "{err}"
    );
    assert!(err.to_string().contains("--force"), "{err}");
    let seed = tempfile::tempdir().expect("tempdir");
    let cfg = seed.path().join("raytracer.cfg");
    std::fs::write(&cfg, "REM   Datei nicht verändern!!!\n").expect("written");
    let err = convert_obj(&fixture("cube.obj"), &seed.path().join("MODEL.txt")).expect_err("cfg");
    assert!(
        err.to_string()
            .contains("raytracer.cfg: the file is there already"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(&cfg).ok().as_deref(),
        Some("REM   Datei nicht verändern!!!\n")
    );
    assert!(!seed.path().join("MODEL.txt").exists(), "nothing written");
    let forced = ConvertOptions {
        force: true,
        ..ConvertOptions::default()
    };
    convert_obj_with(&fixture("cube.obj"), &out, &forced).unwrap_or_else(|e| panic!("{e:#}"));

    let fresh = tempfile::tempdir().expect("tempdir");
    let err = convert_obj(&dir.path().join("nothing.obj"), &fresh.path().join("x.txt"))
        .expect_err("no input");
    assert!(
        err.to_string().contains("nothing.obj: cannot read"),
        "{err}"
    );
}

#[test]
fn a_concave_face_is_cut_into_ears_and_a_convex_one_fanned() {
    // An L of six corners with normals, from the corner that does not see the whole of it, then
    // a convex quad.
    let dir = tempfile::tempdir().expect("temp dir");
    let obj = write(
        &dir,
        "l.obj",
        "v 2 0 0\nv 2 1 0\nv 1 1 0\nv 1 2 0\nv 0 2 0\nv 0 0 0\nvn 0 0 1\n\
         f 1//1 2//1 3//1 4//1 5//1 6//1\nf 1 2 3 6\n",
    );
    let mesh = read_obj(&obj).unwrap_or_else(|e| panic!("{e}"));
    let corners = |t: &ObjTriangle| t.points.map(|i| mesh.points[i as usize]);
    let area = |[a, b, c]: [Vec3; 3]| (b - a).cross(c - a).z;
    let (l, quad) = mesh.triangles.split_at(4);
    // Every triangle of the L turns as the face does, and they cover its area (4 − 1) once.
    assert!(l.iter().all(|t| area(corners(t)) > 0.0));
    assert_eq!(l.iter().map(|t| area(corners(t))).sum::<f32>(), 2.0 * 3.0);
    assert!(l.iter().all(|t| t.normals == Some([0, 0, 0])));
    // The fan around the first corner would have turned backwards across the notch.
    let first = Vec3::new(2.0, 0.0, 0.0);
    assert!(area([first, Vec3::new(1.0, 1.0, 0.0), Vec3::new(1.0, 2.0, 0.0)]) < 0.0);
    let fanned: Vec<[u32; 3]> = quad.iter().map(|t| t.points).collect();
    assert_eq!(fanned, vec![[0, 1, 2], [0, 2, 5]]);
}

#[test]
fn convert_never_replaces_its_obj_or_mtl_nor_a_folder_and_names_no_temporary_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    for name in ["cube_normals.obj", "cube.mtl"] {
        std::fs::copy(fixture(name), d.join(name)).expect("copied");
    }
    let obj = d.join("cube_normals.obj");
    let forced = ConvertOptions {
        force: true,
        ..ConvertOptions::default()
    };
    for name in ["cube_normals.obj", "cube.mtl"] {
        let before = std::fs::read(d.join(name)).expect("read");
        let err = convert_obj_with(&obj, &d.join(name), &forced).expect_err(name);
        assert!(
            err.to_string().contains("would replace the input"),
            "{name}: {err}"
        );
        assert_eq!(std::fs::read(d.join(name)).expect("read"), before, "{name}");
    }
    std::fs::create_dir(d.join("folder.txt")).expect("folder");
    let err = convert_obj_with(&obj, &d.join("folder.txt"), &forced).expect_err("a folder");
    assert!(
        err.to_string().ends_with("folder.txt: it is a folder"),
        "{err}"
    );
    let err = convert_obj(&obj, &d.join("missing/x.txt")).expect_err("no folder");
    let text = format!("{err:#}");
    assert!(text.contains("does not exist"), "{text}");
    assert!(
        !text.contains(".strahl-"),
        "no temporary file named: {text}"
    );
}
