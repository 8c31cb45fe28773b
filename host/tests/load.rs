//! Tests of `load_config_scene`: the configuration file, overrides and the data file together.

use glam::Vec3;
use std::path::{Path, PathBuf};
use strahl_core::scene::{Blend, RenderSettings};
use strahl_host::formats::error::LoadError;
use strahl_host::formats::load::{load_config_scene, load_scene, Overrides};

const ROOM: &str = "_SHD 0.1 0.1 0.1 0.5 0.5 0.5 0 0 0 1 0\n_LIGHT 0 0 10 1 1 1 1 1\n\
                    _PT 0 0 0\n_PT 1 0 0\n_PT 0 1 0\n_TR 0 1 2 0\n";

fn write(path: &Path, text: &str) {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).expect("create folder");
    }
    std::fs::write(path, text).expect("write fixture");
}

/// A temporary folder with `sub/raytracer.cfg` holding `cfg` and `sub/ROOM.txt` holding `ROOM`.
fn scene(cfg: &str) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("tempdir");
    let cfg_path = dir.path().join("sub/raytracer.cfg");
    write(&cfg_path, cfg);
    write(&dir.path().join("sub/ROOM.txt"), ROOM);
    (dir, cfg_path)
}

#[test]
fn seed_example_loads() {
    let cfg = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/seed/raytracer.cfg");
    let s = load_config_scene(&cfg, &Overrides::default()).expect("the seed's example loads");
    let folder = cfg.parent().expect("folder");
    assert_eq!(s.output, folder.join("output.bmp"));
    assert_eq!(s.data_path, folder.join("ROOM.txt"));
    assert_eq!(s.config_path, cfg);
    let d = &s.desc;
    assert_eq!(
        (
            d.points.len(),
            d.triangles.len(),
            d.shaders.len(),
            d.lights.len()
        ),
        (4, 2, 1, 1)
    );
    let strahl_core::scene::camera::Camera::Seed(cam) = d.camera else {
        panic!("a seed scene has the seed's camera: {:?}", d.camera);
    };
    assert_eq!(cam.position, Vec3::new(0.0, -100.0, 25.0));
    assert_eq!(
        (cam.angle_x_deg, cam.angle_z_deg, cam.zoom),
        (-15.0, 0.0, 1.5)
    );
    let st = d.settings;
    assert_eq!(
        (st.width, st.height, st.shadows, st.reflections),
        (640, 480, true, false)
    );
    assert_eq!(st.background, Vec3::ZERO);
    let def = RenderSettings::default();
    assert_eq!(
        (st.min_reflection_weight, st.max_depth),
        (def.min_reflection_weight, def.max_depth)
    );
}

#[test]
fn relative_paths_resolve_against_the_config_folder() {
    let (dir, cfg) = scene("$IMAGE_NAME out/pic.bmp\n$INPUT_DATA ROOM.txt\n");
    let s = load_config_scene(&cfg, &Overrides::default()).expect("loads");
    assert_eq!(s.output, dir.path().join("sub/out/pic.bmp"));
    assert_eq!(s.data_path, dir.path().join("sub/ROOM.txt"));
    assert_eq!(s.desc.triangles.len(), 1);
}

#[test]
fn data_in_a_folder_with_spaces() {
    let dir = tempfile::tempdir().expect("tempdir");
    let cfg = dir.path().join("raytracer.cfg");
    write(
        &cfg,
        "$IMAGE_NAME my image.bmp\n$INPUT_DATA my data/the room.txt\n",
    );
    write(&dir.path().join("my data/the room.txt"), ROOM);
    let s = load_config_scene(&cfg, &Overrides::default()).expect("loads");
    assert_eq!(s.output, dir.path().join("my image.bmp"));
    assert_eq!(s.data_path, dir.path().join("my data/the room.txt"));
}

#[test]
fn absolute_data_path_is_kept() {
    let dir = tempfile::tempdir().expect("tempdir");
    let data = dir.path().join("elsewhere/ROOM.txt");
    write(&data, ROOM);
    let cfg = dir.path().join("cfg/raytracer.cfg");
    write(
        &cfg,
        &format!("$IMAGE_NAME o.bmp\n$INPUT_DATA {}\n", data.display()),
    );
    let s = load_config_scene(&cfg, &Overrides::default()).expect("loads");
    assert_eq!(s.data_path, data);
}

#[test]
fn overrides_beat_the_file() {
    let (_dir, cfg) = scene(
        "$IMAGE_NAME a.bmp\n$INPUT_DATA ROOM.txt\n$IMAGE_WIDTH 10\n$IMAGE_HEIGHT 20\n\
         $SHADOWS 1\n$REFLECTIONS 0\n$INDEX_BASE 1\n",
    );
    let over = Overrides {
        output: Some(PathBuf::from("rel/out.bmp")),
        width: Some(30),
        height: Some(40),
        shadows: Some(false),
        reflections: Some(true),
        index_base: Some(0),
        ..Overrides::default()
    };
    let s = load_config_scene(&cfg, &over).expect("loads");
    // `-o` is used as given, relative to the current directory.
    assert_eq!(s.output, PathBuf::from("rel/out.bmp"));
    let st = s.desc.settings;
    assert_eq!(
        (st.width, st.height, st.shadows, st.reflections),
        (30, 40, false, true)
    );
    // Index base 0 from the command line: `_TR 0 1 2 0` is fine.
    assert_eq!(s.desc.triangles[0].points, [0, 1, 2]);
    // Without the override, the file's `$INDEX_BASE 1` rejects `_TR 0 ...` at its line.
    let err = load_config_scene(&cfg, &Overrides::default()).expect_err("index base 1");
    let data = cfg.with_file_name("ROOM.txt");
    let msg = err.to_string();
    assert!(msg.starts_with(&format!("{}:6: ", data.display())), "{msg}");
    assert!(msg.contains("index 0 with index base 1"), "{msg}");
}

#[test]
fn fart_options_apply_to_seed_scenes() {
    let (_dir, cfg) = scene(
        "$IMAGE_NAME a.bmp\n$INPUT_DATA ROOM.txt\n$IMAGE_WIDTH 100\n$IMAGE_HEIGHT 50\n\
         $CAM_POS_ZOOM 3\n$INDEX_BASE 1\n",
    );
    let base = Overrides {
        index_base: Some(0),
        ..Overrides::default()
    };
    // -p: FART's preview values (-w400 -h300 -m1 -d8 -a0) replace the file's.
    let preview = load_config_scene(
        &cfg,
        &Overrides {
            preview: true,
            ..base.clone()
        },
    )
    .expect("loads");
    let st = preview.desc.settings;
    assert_eq!(
        (
            st.width,
            st.height,
            st.samples,
            st.max_depth,
            st.ambient_occlusion
        ),
        (400, 300, 1, 8, 0)
    );
    // Explicit options beat the preview; -f becomes the seed camera's zoom for that height.
    let o = Overrides {
        preview: true,
        width: Some(200),
        samples: Some(3),
        max_depth: Some(2),
        ambient_occlusion: Some(4),
        field_of_view: Some(90.0),
        ..base.clone()
    };
    let s = load_config_scene(&cfg, &o).expect("loads");
    let st = s.desc.settings;
    assert_eq!(
        (
            st.width,
            st.height,
            st.samples,
            st.max_depth,
            st.ambient_occlusion
        ),
        (200, 300, 3, 2, 4)
    );
    let strahl_core::scene::camera::Camera::Seed(cam) = s.desc.camera else {
        panic!("seed camera expected");
    };
    // 90° vertical over an image 1.5 times as tall as wide: zoom = 1.5 / tan(45°).
    assert!((cam.zoom - 1.5).abs() < 1e-6, "{}", cam.zoom);
    // Out of range on the command line: an error naming the file.
    let bad = Overrides {
        ambient_occlusion: Some(10),
        ..base
    };
    let err = load_config_scene(&cfg, &bad).expect_err("ao 10");
    assert!(err.to_string().contains("ambient occlusion"), "{err}");
}

#[test]
fn no_overrides_keep_the_file() {
    let (_dir, cfg) = scene(
        "$IMAGE_NAME a.bmp\n$INPUT_DATA ROOM.txt\n$IMAGE_WIDTH 10\n$SHADOWS 0\n$COLOR_BG_B 1\n",
    );
    let s = load_config_scene(&cfg, &Overrides::default()).expect("loads");
    let st = s.desc.settings;
    assert_eq!(
        (st.width, st.height, st.shadows, st.reflections),
        (10, 480, false, true)
    );
    assert_eq!(st.background, Vec3::Z);
}

#[test]
fn override_out_of_range_is_an_error() {
    let (_dir, cfg) = scene("$IMAGE_NAME a.bmp\n$INPUT_DATA ROOM.txt\n");
    for over in [
        Overrides {
            width: Some(0),
            ..Overrides::default()
        },
        Overrides {
            height: Some(32769),
            ..Overrides::default()
        },
        Overrides {
            index_base: Some(2),
            ..Overrides::default()
        },
    ] {
        let err = load_config_scene(&cfg, &over).expect_err("out of range");
        assert!(matches!(err, LoadError::File { .. }), "{err}");
        assert!(err.to_string().contains("command line"), "{err}");
    }
}

#[test]
fn image_name_is_required_unless_given_on_the_command_line() {
    let (_dir, cfg) = scene("$INPUT_DATA ROOM.txt\n");
    let err = load_config_scene(&cfg, &Overrides::default()).expect_err("no $IMAGE_NAME");
    assert!(matches!(err, LoadError::File { .. }));
    let msg = err.to_string();
    assert!(msg.starts_with(&format!("{}: ", cfg.display())), "{msg}");
    assert!(msg.contains("`$IMAGE_NAME` is missing"), "{msg}");
    let over = Overrides {
        output: Some(PathBuf::from("x.bmp")),
        ..Overrides::default()
    };
    assert_eq!(
        load_config_scene(&cfg, &over).expect("loads").output,
        PathBuf::from("x.bmp")
    );
}

#[test]
fn input_data_is_required() {
    let (_dir, cfg) = scene("$IMAGE_NAME a.bmp\n");
    let err = load_config_scene(&cfg, &Overrides::default()).expect_err("no $INPUT_DATA");
    let msg = err.to_string();
    assert!(msg.starts_with(&format!("{}: ", cfg.display())), "{msg}");
    assert!(msg.contains("`$INPUT_DATA` is missing"), "{msg}");
}

#[test]
fn missing_config_file_is_an_io_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let cfg = dir.path().join("raytracer.cfg");
    let err = load_config_scene(&cfg, &Overrides::default()).expect_err("missing");
    assert!(
        matches!(&err, LoadError::Io { path, .. } if *path == cfg),
        "{err}"
    );
}

#[test]
fn missing_data_file_is_an_io_error_naming_it() {
    let (dir, cfg) = scene("$IMAGE_NAME a.bmp\n$INPUT_DATA NOPE.txt\n");
    let err = load_config_scene(&cfg, &Overrides::default()).expect_err("missing data");
    let data = dir.path().join("sub/NOPE.txt");
    assert!(
        matches!(&err, LoadError::Io { path, .. } if *path == data),
        "{err}"
    );
    assert!(
        err.to_string()
            .starts_with(&format!("{}: cannot read: ", data.display())),
        "{err}"
    );
}

#[test]
fn config_errors_name_the_config_line() {
    let (_dir, cfg) = scene("$IMAGE_NAME a.bmp\n$INPUT_DATA ROOM.txt\n$IMAGE_WIDTH -3\n");
    let msg = load_config_scene(&cfg, &Overrides::default())
        .expect_err("bad")
        .to_string();
    assert!(msg.starts_with(&format!("{}:3: ", cfg.display())), "{msg}");
}

#[test]
fn data_errors_name_the_data_line() {
    let (dir, cfg) = scene("$IMAGE_NAME a.bmp\n$INPUT_DATA ROOM.txt\n");
    let data = dir.path().join("sub/ROOM.txt");
    write(&data, &format!("{ROOM}_TR 0 1 9 0\n"));
    let msg = load_config_scene(&cfg, &Overrides::default())
        .expect_err("bad")
        .to_string();
    assert_eq!(
        msg,
        format!(
            "{}:7: `_TR`: point index 9 out of range (3 points)",
            data.display()
        )
    );
    write(&data, "_PT 0 0 0\n_LIGHT 0 0 0 1 1 1 1 0\n");
    let msg = load_config_scene(&cfg, &Overrides::default())
        .expect_err("no shader")
        .to_string();
    assert!(
        msg.starts_with(&format!("{}: no shader", data.display())),
        "{msg}"
    );
}

#[test]
fn nff_shaders_add_and_the_seed_formats_keep_the_seed_rule() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let blends = |path: &Path| -> Vec<Blend> {
        let s = load_scene(path, &Overrides::default())
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(!s.desc.shaders.is_empty(), "{}", path.display());
        s.desc.shaders.iter().map(|sh| sh.blend).collect()
    };
    let nff = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/nff/every_entity.nff");
    assert!(blends(&nff).iter().all(|&b| b == Blend::Additive));
    // The seed's configuration and data files, an OBJ converted by `strahl convert`, and FART
    // scenes.
    let dir = tempfile::tempdir().expect("tempdir");
    strahl_host::formats::convert::convert_obj(
        &repo.join("scenes/fart/pyramid.obj"),
        &dir.path().join("PYRAMID.txt"),
    )
    .unwrap_or_else(|e| panic!("{e:#}"));
    let mut seed = vec![
        repo.join("scenes/room/raytracer.cfg"),
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/seed/raytracer.cfg"),
        dir.path().join("raytracer.cfg"),
    ];
    for name in ["die", "glass", "mirrors", "ring"] {
        seed.push(repo.join("scenes/fart").join(format!("{name}.fart")));
    }
    for path in seed {
        assert!(
            blends(&path).iter().all(|&b| b == Blend::Share),
            "{}",
            path.display()
        );
    }
}
