//! Tests of the configuration file parser against `scenes/FORMATS.md`.

use glam::Vec3;
use std::path::{Path, PathBuf};
use strahl_core::scene::camera::SeedCamera;
use strahl_host::formats::config::{parse_config, read_config, Config};
use strahl_host::formats::error::LoadError;

use crate::common::{assert_at, write};

/// Parses `text` from a file and returns the error message, which must name `line`.
fn error_at(text: &str, line: usize) -> String {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(&dir, "raytracer.cfg", text.as_bytes());
    let err = read_config(&path).expect_err("the text should be rejected");
    assert_at(err, &path, line)
}

fn parse(text: &str) -> Config {
    parse_config(Path::new("raytracer.cfg"), text).expect("the text should parse")
}

fn seed_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/seed/raytracer.cfg")
}

#[test]
fn seed_example_parses_with_its_values() {
    let cfg = read_config(&seed_path()).expect("the seed's example parses");
    assert_eq!(
        cfg,
        Config {
            image_name: Some(PathBuf::from("output.bmp")),
            width: 640,
            height: 480,
            input_data: Some(PathBuf::from("ROOM.txt")),
            shadows: true,
            reflections: false,
            background: Vec3::ZERO,
            camera: SeedCamera {
                position: Vec3::new(0.0, -100.0, 25.0),
                angle_x_deg: -15.0,
                angle_z_deg: 0.0,
                zoom: 1.5,
            },
            index_base: 0,
        }
    );
}

#[test]
fn seed_example_keeps_its_german_comments() {
    let text = std::fs::read_to_string(seed_path()).expect("fixture");
    assert!(text.starts_with("REM   Datei nicht verändern!!!\n"));
    assert!(text.contains("$CAM_POS_ZOOM 1.5\n\nQUIT\n"));
}

#[test]
fn empty_file_gives_the_documented_defaults() {
    let cfg = parse("");
    assert_eq!(cfg, Config::default());
    assert_eq!((cfg.width, cfg.height), (640, 480));
    assert!(cfg.shadows && cfg.reflections);
    assert_eq!(cfg.background, Vec3::ZERO);
    assert_eq!(
        cfg.camera,
        SeedCamera {
            position: Vec3::ZERO,
            angle_x_deg: 0.0,
            angle_z_deg: 0.0,
            zoom: 1.0
        }
    );
    assert_eq!(cfg.index_base, 0);
    assert_eq!((cfg.image_name, cfg.input_data), (None, None));
}

#[test]
fn every_variable_is_read() {
    let cfg = parse(
        "$IMAGE_NAME a.bmp\n$IMAGE_WIDTH 32768\n$IMAGE_HEIGHT 1\n$INPUT_DATA d.txt\n$SHADOWS 0\n\
         $REFLECTIONS 1\n$COLOR_BG_R 0.25\n$COLOR_BG_G 1\n$COLOR_BG_B 0\n$CAM_POS_X 1.5\n\
         $CAM_POS_Y -2e1\n$CAM_POS_Z +3\n$CAM_POS_ANGLE_X 10\n$CAM_POS_ANGLE_Z -370\n\
         $CAM_POS_ZOOM 0.5\n$INDEX_BASE 1\n",
    );
    assert_eq!(cfg.image_name, Some(PathBuf::from("a.bmp")));
    assert_eq!(cfg.input_data, Some(PathBuf::from("d.txt")));
    assert_eq!((cfg.width, cfg.height), (32768, 1));
    assert!(!cfg.shadows && cfg.reflections);
    assert_eq!(cfg.background, Vec3::new(0.25, 1.0, 0.0));
    assert_eq!(
        cfg.camera,
        SeedCamera {
            position: Vec3::new(1.5, -20.0, 3.0),
            angle_x_deg: 10.0,
            angle_z_deg: -370.0,
            zoom: 0.5
        }
    );
    assert_eq!(cfg.index_base, 1);
}

#[test]
fn paths_take_the_rest_of_the_line() {
    let cfg = parse("$IMAGE_NAME \t my render  01.bmp \t\r\n$INPUT_DATA\tsub dir/ROOM.txt\n");
    assert_eq!(cfg.image_name, Some(PathBuf::from("my render  01.bmp")));
    assert_eq!(cfg.input_data, Some(PathBuf::from("sub dir/ROOM.txt")));
}

#[test]
fn a_path_variable_needs_a_value() {
    let msg = error_at("REM\n$IMAGE_NAME   \n", 2);
    assert!(msg.contains("`$IMAGE_NAME`: expected a file name"), "{msg}");
    error_at("$INPUT_DATA\n", 1);
}

#[test]
fn duplicated_variable_last_one_wins() {
    let cfg = parse("$IMAGE_WIDTH 10\n$IMAGE_WIDTH 20\n$IMAGE_NAME a\n$IMAGE_NAME b\n");
    assert_eq!(cfg.width, 20);
    assert_eq!(cfg.image_name, Some(PathBuf::from("b")));
}

#[test]
fn crlf_bom_and_tabs_parse_like_lf() {
    let lf = std::fs::read_to_string(seed_path()).expect("fixture");
    let odd = format!("\u{feff}{}", lf.replace('\n', "\r\n").replace(' ', "\t \t"));
    assert_ne!(lf, odd);
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(&dir, "crlf.cfg", odd.as_bytes());
    assert_eq!(
        read_config(&path).expect("CRLF parses"),
        read_config(&seed_path()).expect("LF parses")
    );
}

#[test]
fn quit_ignores_everything_after_it() {
    let cfg = parse("$IMAGE_WIDTH 100\nQUIT\n$IMAGE_WIDTH 0\nthis is garbage \u{1}\n$NOPE x y z\n");
    assert_eq!(cfg.width, 100);
    let cfg = parse("  QUIT trailing words\n$IMAGE_WIDTH abc\n");
    assert_eq!(cfg.width, 640);
}

#[test]
fn rem_lines_and_blank_lines_are_skipped() {
    let cfg = parse("REM $IMAGE_WIDTH 0 anything\n\n   \t\n\tREM indented\n$IMAGE_WIDTH 7\n");
    assert_eq!(cfg.width, 7);
}

#[test]
fn unknown_command_names_the_line() {
    let msg = error_at("REM ok\n\nFOO 1 2\n", 3);
    assert!(msg.ends_with("unknown command `FOO`"), "{msg}");
    // Names are case-sensitive.
    let msg = error_at("rem lower case\n", 1);
    assert!(msg.contains("unknown command `rem`"), "{msg}");
    let msg = error_at("$IMAGE_WIDTH 5\n_PT 1 2 3\n", 2);
    assert!(msg.contains("unknown command `_PT`"), "{msg}");
}

#[test]
fn unknown_variable_names_the_line() {
    let msg = error_at("$IMAGE_WIDTH 5\n$image_width 5\n", 2);
    assert!(msg.ends_with("unknown variable `$image_width`"), "{msg}");
    // The seed's table misspells `$SHADOWS` as `$$SHADOWS`; only the example's spelling counts.
    let msg = error_at("\n\n\n\n\n\n$$SHADOWS 1\n", 7);
    assert!(msg.contains("unknown variable `$$SHADOWS`"), "{msg}");
}

#[test]
fn wrong_number_of_values() {
    let msg = error_at("$IMAGE_WIDTH 640 480 1\n", 1);
    assert!(
        msg.ends_with("`$IMAGE_WIDTH`: expected 1 value, found 3"),
        "{msg}"
    );
    let msg = error_at("REM\n$CAM_POS_X\n", 2);
    assert!(msg.ends_with("expected 1 value, found 0"), "{msg}");
    error_at("$SHADOWS 1 0\n", 1);
    error_at("$COLOR_BG_R 0 0 0\n", 1);
}

#[test]
fn a_value_that_is_not_a_number() {
    let msg = error_at("$CAM_POS_X 1\n$CAM_POS_Y abc\n", 2);
    assert!(msg.ends_with("`abc` is not a number"), "{msg}");
    let msg = error_at("$CAM_POS_Z 1,5\n", 1);
    assert!(msg.contains("`1,5` is not a number"), "{msg}");
    let msg = error_at("$IMAGE_WIDTH wide\n", 1);
    assert!(msg.contains("`wide` is not a number"), "{msg}");
}

#[test]
fn nan_and_infinity_are_rejected() {
    for word in ["NaN", "nan", "inf", "-inf", "infinity", "1e39"] {
        let msg = error_at(&format!("REM\nREM\n$CAM_POS_ANGLE_X {word}\n"), 3);
        assert!(
            msg.ends_with(&format!("`{word}` is not a finite number")),
            "{msg}"
        );
    }
    error_at("$CAM_POS_ZOOM inf\n", 1);
}

#[test]
fn image_size_must_be_1_to_32768() {
    for word in ["0", "-1", "-640", "32769", "99999999999999999999999"] {
        let msg = error_at(&format!("$IMAGE_WIDTH 1\n$IMAGE_HEIGHT {word}\n"), 2);
        assert!(msg.contains("`$IMAGE_HEIGHT` must be 1 to 32768"), "{msg}");
    }
    let msg = error_at("$IMAGE_WIDTH 640.5\n", 1);
    assert!(msg.contains("`640.5` is not a whole number"), "{msg}");
    assert_eq!(parse("$IMAGE_WIDTH 32768\n$IMAGE_HEIGHT 1").width, 32768);
}

#[test]
fn flags_must_be_0_or_1() {
    let msg = error_at("$SHADOWS 2\n", 1);
    assert!(
        msg.contains("`$SHADOWS` must be 0 or 1, found `2`"),
        "{msg}"
    );
    error_at("$REFLECTIONS -1\n", 1);
    error_at("$REFLECTIONS on\n", 1);
    let msg = error_at("$INDEX_BASE 2\n", 1);
    assert!(msg.contains("`$INDEX_BASE` must be 0 or 1"), "{msg}");
}

#[test]
fn background_must_be_0_to_1() {
    let msg = error_at("$COLOR_BG_G 1.5\n", 1);
    assert!(
        msg.contains("`$COLOR_BG_G` must be 0 to 1, found `1.5`"),
        "{msg}"
    );
    error_at("$COLOR_BG_B -0.1\n", 1);
    assert_eq!(parse("$COLOR_BG_R 1.0").background, Vec3::X);
}

#[test]
fn zoom_must_be_above_0() {
    let msg = error_at("$CAM_POS_ZOOM 0\n", 1);
    assert!(msg.contains("`$CAM_POS_ZOOM` must be above 0"), "{msg}");
    error_at("$CAM_POS_ZOOM -1.5\n", 1);
}

#[test]
fn non_utf8_names_the_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(&dir, "latin1.cfg", b"$IMAGE_WIDTH 5\nREM ver\xe4ndern\n");
    let msg = read_config(&path).expect_err("not UTF-8").to_string();
    assert!(msg.starts_with(&format!("{}:2: ", path.display())), "{msg}");
    assert!(msg.contains("not UTF-8"), "{msg}");
}

#[test]
fn missing_file_is_an_io_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("nope.cfg");
    let err = read_config(&path).expect_err("missing");
    assert!(matches!(err, LoadError::Io { .. }));
    assert!(
        err.to_string()
            .starts_with(&format!("{}: cannot read: ", path.display())),
        "{err}"
    );
}
