//! Tests of the data file parser against `scenes/FORMATS.md`.

use glam::Vec3;
use proptest::prelude::*;
use std::path::Path;
use strahl_core::scene::{Blend, Light, Shader, TriangleDesc};
use strahl_host::formats::datafile::{parse_data, read_data, SceneData};
use strahl_host::formats::error::LoadError;

const SHD: &str = "_SHD 0.1 0.2 0.3 0.4 0.5 0.6 0.7 0.8 0.9 20 0.5\n";
const LIGHT: &str = "_LIGHT 1 2 3 0.5 0.6 0.7 0.8 1\n";
/// A shader, a light and three points: lines 1 to 5.
const HEAD: &str =
    "_SHD 0.1 0.2 0.3 0.4 0.5 0.6 0.7 0.8 0.9 20 0.5\n_LIGHT 1 2 3 0.5 0.6 0.7 0.8 1\n\
                    _PT 0 0 0\n_PT 1 0 0\n_PT 0 1 0\n";

use crate::common::{assert_at, write};

/// Reads `text` from a file with `base` and returns the message, which must name `line`.
fn error_at(text: &str, base: u32, line: usize) -> String {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(&dir, "ROOM.txt", text.as_bytes());
    let err = read_data(&path, base).expect_err("the text should be rejected");
    assert_at(err, &path, line)
}

/// Reads `text` from a file and returns a whole-file error's message.
fn file_error(text: &str) -> String {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(&dir, "ROOM.txt", text.as_bytes());
    let err = read_data(&path, 0).expect_err("the text should be rejected");
    let msg = err.to_string();
    assert!(matches!(err, LoadError::File { .. }), "{msg}");
    assert!(msg.starts_with(&format!("{}: ", path.display())), "{msg}");
    msg
}

fn parse(text: &str, base: u32) -> SceneData {
    parse_data(Path::new("ROOM.txt"), text, base).expect("the text should parse")
}

#[test]
fn every_record_is_read() {
    let text = format!(
        "REM a scene\n_OBJ 4 1 1 2\n{SHD}{LIGHT}_LIGHT -1 -2 -3 1 1 1 2.5 0\n_PT 0 0 0\n_PT 1.5 -2 3e2\n\
         _PT 0 1 0\n_TR 0 1 2 0\n_PT 9 9 9\n"
    );
    let d = parse(&text, 0);
    assert_eq!(
        d.shaders,
        vec![Shader {
            transparency: 0.0,
            ior: 1.0,
            ambient: Vec3::new(0.1, 0.2, 0.3),
            diffuse: Vec3::new(0.4, 0.5, 0.6),
            specular: Vec3::new(0.7, 0.8, 0.9),
            shininess: 20.0,
            reflection: 0.5,
            blend: Blend::Share,
        }]
    );
    assert_eq!(
        d.lights,
        vec![
            Light {
                position: Vec3::new(1.0, 2.0, 3.0),
                color: Vec3::new(0.5, 0.6, 0.7),
                amount: 0.8,
                casts_shadows: true,
            },
            Light {
                position: Vec3::new(-1.0, -2.0, -3.0),
                color: Vec3::ONE,
                amount: 2.5,
                casts_shadows: false,
            },
        ]
    );
    assert_eq!(
        d.points,
        vec![
            Vec3::ZERO,
            Vec3::new(1.5, -2.0, 300.0),
            Vec3::Y,
            Vec3::splat(9.0)
        ]
    );
    assert_eq!(
        d.triangles,
        vec![TriangleDesc {
            normals: None,
            points: [0, 1, 2],
            shader: 0
        }]
    );
}

#[test]
fn index_base_1_counts_from_1() {
    let d = parse(&format!("{HEAD}_TR 1 2 3 1\n_TR 3 2 1 1\n"), 1);
    assert_eq!(
        d.triangles,
        vec![
            TriangleDesc {
                normals: None,
                points: [0, 1, 2],
                shader: 0
            },
            TriangleDesc {
                normals: None,
                points: [2, 1, 0],
                shader: 0
            }
        ]
    );
}

#[test]
fn triangles_may_name_points_defined_later() {
    let d = parse(&format!("_TR 0 1 2 0\n{HEAD}"), 0);
    assert_eq!(d.triangles.len(), 1);
}

#[test]
fn obj_is_only_a_hint() {
    // Counts that do not match, and a huge count, are fine; `_OBJ` may come anywhere.
    let d = parse(
        &format!("_OBJ 4294967295 4294967295 4294967295 4294967295\n{HEAD}_OBJ 0 0 0 0\n"),
        0,
    );
    assert_eq!(d.points.len(), 3);
    let msg = error_at("_OBJ 1 2 3\n", 0, 1);
    assert!(msg.ends_with("`_OBJ`: expected 4 values, found 3"), "{msg}");
    let msg = error_at("REM\n_OBJ 1 2 -3 4\n", 0, 2);
    assert!(msg.contains("`-3` is negative"), "{msg}");
    error_at("_OBJ 1 2 3.5 4\n", 0, 1);
    error_at("_OBJ 1 2 3 4294967296\n", 0, 1);
}

#[test]
fn crlf_bom_and_tabs_parse_like_lf() {
    let lf = format!("REM room\n{HEAD}_TR 0 1 2 0\nQUIT\n");
    let odd = format!(
        "\u{feff}{}",
        lf.replace('\n', "\r\n").replace(' ', " \t\t ")
    );
    let dir = tempfile::tempdir().expect("tempdir");
    let a = write(&dir, "lf.txt", lf.as_bytes());
    let b = write(&dir, "crlf.txt", odd.as_bytes());
    assert_eq!(
        read_data(&a, 0).expect("LF"),
        read_data(&b, 0).expect("CRLF")
    );
}

#[test]
fn quit_ignores_everything_after_it() {
    let d = parse(
        &format!("{HEAD}QUIT\n_TR 7 8 9 10\ngarbage \u{0} here\n_PT x y z\n"),
        0,
    );
    assert_eq!((d.points.len(), d.triangles.len()), (3, 0));
}

#[test]
fn unknown_record_names_the_line() {
    let msg = error_at(&format!("{HEAD}_QUAD 0 1 2 3\n"), 0, 6);
    assert!(msg.ends_with("unknown record `_QUAD`"), "{msg}");
    let msg = error_at("_pt 1 2 3\n", 0, 1);
    assert!(msg.contains("unknown record `_pt`"), "{msg}");
    let msg = error_at("REM\n$IMAGE_WIDTH 5\n", 0, 2);
    assert!(msg.contains("unknown record `$IMAGE_WIDTH`"), "{msg}");
}

#[test]
fn wrong_number_of_values_for_every_record() {
    let cases = [
        ("_PT 1 2\n", "`_PT`: expected 3 values, found 2"),
        ("_PT 1 2 3 4\n", "`_PT`: expected 3 values, found 4"),
        ("_TR 0 1 2\n", "`_TR`: expected 4 values, found 3"),
        (
            "_SHD 1 1 1 1 1 1 1 1 1 1\n",
            "`_SHD`: expected 11 values, found 10",
        ),
        (
            "_LIGHT 1 2 3 1 1 1 1 1 1\n",
            "`_LIGHT`: expected 8 values, found 9",
        ),
        ("_OBJ\n", "`_OBJ`: expected 4 values, found 0"),
    ];
    for (record, expected) in cases {
        let msg = error_at(&format!("{HEAD}{record}"), 0, 6);
        assert!(msg.ends_with(expected), "{msg}");
    }
}

#[test]
fn a_value_that_is_not_a_number() {
    let msg = error_at(&format!("{HEAD}_PT 1 zwei 3\n"), 0, 6);
    assert!(msg.ends_with("`zwei` is not a number"), "{msg}");
    let msg = error_at("_SHD 0.1 0.2 0.3 0.4 0.5 0.6 0.7 0.8 0,9 20 0.5\n", 0, 1);
    assert!(msg.contains("`0,9` is not a number"), "{msg}");
    let msg = error_at(&format!("{HEAD}_TR 0 1 x 0\n"), 0, 6);
    assert!(msg.contains("`x` is not a number"), "{msg}");
    let msg = error_at(&format!("{HEAD}_TR 0 1 2.0 0\n"), 0, 6);
    assert!(msg.contains("`2.0` is not a whole number"), "{msg}");
    let msg = error_at(&format!("{HEAD}_TR 0 -1 2 0\n"), 0, 6);
    assert!(msg.contains("`-1` is negative"), "{msg}");
    error_at("_LIGHT 1 2 3 1 1 1 1 yes\n", 0, 1);
}

#[test]
fn nan_and_infinity_are_rejected() {
    for (record, word) in [
        ("_PT 1 NaN 3", "NaN"),
        ("_PT inf 0 0", "inf"),
        ("_SHD 0 0 0 0 0 0 0 0 0 -infinity 0", "-infinity"),
        ("_SHD 0 0 0 0 0 0 0 0 0 1 nan", "nan"),
        ("_LIGHT 0 0 1e40 1 1 1 1 1", "1e40"),
        ("_LIGHT 0 0 0 1 1 1 inf 1", "inf"),
    ] {
        let msg = error_at(&format!("REM\n{record}\n"), 0, 2);
        assert!(
            msg.ends_with(&format!("`{word}` is not a finite number")),
            "{msg}"
        );
    }
}

#[test]
fn shader_ranges() {
    let msg = error_at("_SHD 0 0 0 0 0 0 0 0 0 -1 0\n", 0, 1);
    assert!(
        msg.contains("shininess must be 0 or more, found `-1`"),
        "{msg}"
    );
    let msg = error_at("_SHD 0 0 0 0 0 0 0 0 0 1 1.5\n", 0, 1);
    assert!(
        msg.contains("reflection amount must be 0 to 1, found `1.5`"),
        "{msg}"
    );
    error_at("_SHD 0 0 0 0 0 0 0 0 0 1 -0.5\n", 0, 1);
    // Colours need only be finite; shininess 0 and reflection 0 and 1 are fine.
    let d = parse(
        &format!("_SHD 2 0 -1 0 0 0 0 0 0 0 1\n_SHD 0 0 0 0 0 0 0 0 0 0 0\n{LIGHT}"),
        0,
    );
    assert_eq!(d.shaders.len(), 2);
}

#[test]
fn light_shadow_flag_must_be_0_or_1() {
    let msg = error_at("_LIGHT 0 0 0 1 1 1 1 2\n", 0, 1);
    assert!(
        msg.contains("ShadowCasting must be 0 or 1, found `2`"),
        "{msg}"
    );
    error_at("_LIGHT 0 0 0 1 1 1 1 0.5\n", 0, 1);
}

#[test]
fn point_index_out_of_range_0_based() {
    let msg = error_at(&format!("{HEAD}_TR 0 1 2 0\n_TR 0 3 1 0\n"), 0, 7);
    assert!(
        msg.ends_with("`_TR`: point index 3 out of range (3 points)"),
        "{msg}"
    );
    let msg = error_at(
        &format!("{HEAD}_TR 0 1 2 0\n_TR 4 3 1 0\n_PT 5 5 5\n"),
        0,
        7,
    );
    assert!(
        msg.ends_with("`_TR`: point index 4 out of range (4 points)"),
        "{msg}"
    );
    // The point defined after the triangle counts; one more is out of range.
    parse(&format!("{HEAD}_TR 0 3 1 0\n_PT 5 5 5\n"), 0);
    let msg = error_at(&format!("{HEAD}_TR 0 1 17 0\n"), 0, 6);
    assert!(
        msg.contains("point index 17 out of range (3 points)"),
        "{msg}"
    );
}

#[test]
fn shader_index_out_of_range_0_based() {
    let msg = error_at(&format!("{HEAD}_TR 0 1 2 1\n"), 0, 6);
    assert!(
        msg.ends_with("`_TR`: shader index 1 out of range (1 shader)"),
        "{msg}"
    );
}

#[test]
fn index_out_of_range_1_based() {
    parse(&format!("{HEAD}_TR 1 2 3 1\n"), 1);
    let msg = error_at(&format!("{HEAD}_TR 1 2 3 1\n_TR 1 2 4 1\n"), 1, 7);
    assert!(
        msg.contains("point index 4 out of range (3 points)"),
        "{msg}"
    );
    let msg = error_at(&format!("{HEAD}_TR 1 2 3 2\n"), 1, 6);
    assert!(
        msg.contains("shader index 2 out of range (1 shader)"),
        "{msg}"
    );
}

#[test]
fn index_0_with_base_1() {
    let msg = error_at(&format!("{HEAD}_TR 1 2 3 1\n_TR 0 1 2 1\n"), 1, 7);
    assert!(msg.contains("index 0 with index base 1"), "{msg}");
    let msg = error_at(&format!("{HEAD}_TR 1 2 3 0\n"), 1, 6);
    assert!(msg.contains("index 0 with index base 1"), "{msg}");
}

#[test]
fn no_shader_is_a_file_error() {
    let msg = file_error(&format!("{LIGHT}_PT 0 0 0\n_TR 0 0 0 0\n"));
    assert!(
        msg.contains("no shader (_SHD) in the file; at least one is required"),
        "{msg}"
    );
}

#[test]
fn no_light_is_a_file_error() {
    let msg = file_error(&format!("{SHD}_PT 0 0 0\n"));
    assert!(
        msg.contains("no light (_LIGHT) in the file; at least one is required"),
        "{msg}"
    );
    // A light after QUIT does not count.
    file_error(&format!("{SHD}QUIT\n{LIGHT}"));
}

#[test]
fn index_base_must_be_0_or_1() {
    let err = parse_data(Path::new("ROOM.txt"), HEAD, 2).expect_err("base 2");
    assert!(matches!(err, LoadError::File { .. }), "{err}");
}

#[test]
fn non_utf8_names_the_line() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = write(&dir, "ROOM.txt", b"REM ok\nREM ok\n_PT 1 2 \xff\n");
    let msg = read_data(&path, 0).expect_err("not UTF-8").to_string();
    assert!(msg.starts_with(&format!("{}:3: ", path.display())), "{msg}");
}

#[test]
fn missing_file_is_an_io_error() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("ROOM.txt");
    let err = read_data(&path, 0).expect_err("missing");
    assert!(matches!(err, LoadError::Io { .. }));
    assert!(
        err.to_string()
            .starts_with(&format!("{}: cannot read: ", path.display())),
        "{err}"
    );
}

proptest! {
    /// Whatever the text, the parser answers without panicking, and a success has valid indices.
    #[test]
    fn never_panics(lines in proptest::collection::vec(
        prop_oneof![
            Just("_PT 0 0 0".to_string()),
            Just(SHD.trim_end().to_string()),
            Just(LIGHT.trim_end().to_string()),
            (0u32..5, 0u32..5, 0u32..5, 0u32..3).prop_map(|(a, b, c, s)| format!("_TR {a} {b} {c} {s}")),
            "[ -~\t\r]{0,30}",
            "(_PT|_TR|_OBJ|_SHD|_LIGHT|REM|QUIT)( [-0-9.eE]{1,4}){0,12}",
        ],
        0..20,
    ), base in 0u32..2) {
        let text = lines.join("\n");
        if let Ok(d) = parse_data(Path::new("p"), &text, base) {
            prop_assert!(!d.shaders.is_empty() && !d.lights.is_empty());
            for t in &d.triangles {
                prop_assert!(t.points.iter().all(|&p| (p as usize) < d.points.len()));
                prop_assert!((t.shader as usize) < d.shaders.len());
            }
        }
    }
}
