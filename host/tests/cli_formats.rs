//! `strahl render` with `.fart` and `.nff` scenes, FART's command-line options beating the scene
//! file, and `strahl convert`, all through the binary.

use std::error::Error;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

type TestResult = Result<(), Box<dyn Error>>;

fn strahl(cwd: &Path, args: &[&str]) -> std::io::Result<Output> {
    Command::new(env!("CARGO_BIN_EXE_strahl"))
        .current_dir(cwd)
        .args(args)
        .output()
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// A small `.fart` scene whose options ask for 64×48, 1 sample, no occlusion.
const SCENE: &str = "scene {
  options { width 64 height 48 multisample 1 max_depth 4 ambient_occlusion 0 }
  camera { position <0, 1, 6> look_at <0, 0, 0> vfov 40 }
  light { position <4, 6, 5> }
  plane { position <0, 1, 0>, -1 material { color <0.8, 0.8, 0.8> } }
  subtract {
    box { size 2 material { color <0.9, 0.3, 0.2> reflectance 0.2 } }
    sphere { radius 1.3 material { color <0.2, 0.3, 0.9> } }
  }
  sphere { radius 0.6 translate <1.6, 0, 0.5> material { transparency 0.8 ior 1.5 } }
}
";

fn size_of(path: &Path) -> Result<(u32, u32), Box<dyn Error>> {
    let img = image::open(path)?;
    Ok((img.width(), img.height()))
}

#[test]
fn fart_scene_renders_with_its_own_options_and_named_after_the_scene() -> TestResult {
    let dir = tempfile::tempdir()?;
    std::fs::write(dir.path().join("cut.fart"), SCENE)?;
    let out = strahl(dir.path(), &["render", "cut.fart", "-q"])?;
    assert!(out.status.success(), "{}", stderr(&out));
    // No -o: the scene's name with .bmp, in the current folder.
    assert_eq!(size_of(&dir.path().join("cut.bmp"))?, (64, 48));
    Ok(())
}

#[test]
fn command_line_beats_the_fart_file() -> TestResult {
    let dir = tempfile::tempdir()?;
    std::fs::write(dir.path().join("cut.fart"), SCENE)?;
    let stats = dir.path().join("stats.json");
    let stats_arg = stats.to_string_lossy().into_owned();
    let out = strahl(
        dir.path(),
        &[
            "render",
            "cut.fart",
            "-o",
            "big.png",
            "-w",
            "40",
            "-h",
            "30",
            "-m",
            "2",
            "-f",
            "60",
            "-d",
            "2",
            "-a",
            "1",
            "--stats-json",
            &stats_arg,
            "-q",
        ],
    )?;
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(size_of(&dir.path().join("big.png"))?, (40, 30));
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&stats)?)?;
    assert_eq!(json["samples"], 2);
    assert_eq!(json["rays"]["extra_samples"], 3 * 40 * 30);
    assert!(
        json["rays"]["occlusion"].as_u64().unwrap_or(0) > 0,
        "{json}"
    );
    assert!(
        json["rays"]["refraction"].as_u64().unwrap_or(0) > 0,
        "{json}"
    );
    // The effects derived before rendering: what this scene and these options call for.
    let e = &json["effects"];
    assert_eq!(e["refraction"], true, "{json}");
    assert_eq!(e["reflection"], true, "{json}");
    assert_eq!(e["multisampling"], 2, "{json}");
    assert_eq!(e["ambient_occlusion"], 1, "{json}");
    assert_eq!(e["shadow_lights"], 1, "{json}");
    assert_eq!(e["lights"], 1, "{json}");
    // -p is FART's preview (400×300); an explicit -w still beats it.
    let out = strahl(
        dir.path(),
        &["render", "cut.fart", "-p", "-w", "20", "-o", "p.bmp", "-q"],
    )?;
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(size_of(&dir.path().join("p.bmp"))?, (20, 300));
    Ok(())
}

#[test]
fn dash_h_is_the_height_and_help_is_long() -> TestResult {
    let dir = tempfile::tempdir()?;
    let help = strahl(dir.path(), &["render", "--help"])?;
    assert!(help.status.success());
    let text = String::from_utf8_lossy(&help.stdout);
    for flag in [
        "-h, --height",
        "-w, --width",
        "-m, --multisample",
        "-f, --field-of-view",
        "-d, --max-depth",
        "-a, --ambient-occlusion",
        "-p, --preview",
        "--hosts",
        "-o, --output-file",
    ] {
        assert!(text.contains(flag), "missing {flag} in:\n{text}");
    }
    Ok(())
}

#[test]
fn bad_fart_file_names_line_and_column_and_writes_nothing() -> TestResult {
    let dir = tempfile::tempdir()?;
    std::fs::write(
        dir.path().join("bad.fart"),
        "scene {\n  camera { position <0, 0, 5> look_at <0, 0, 0> }\n  light { position <1, 1, 1> }\n  plane { radius 2 }\n}\n",
    )?;
    let out = strahl(dir.path(), &["render", "bad.fart", "-o", "x.bmp"])?;
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(err.contains("bad.fart:4:11: "), "{err}");
    assert!(err.contains("radius"), "{err}");
    assert!(!dir.path().join("x.bmp").exists());
    Ok(())
}

#[test]
fn nff_scene_renders_from_the_command_line() -> TestResult {
    let dir = tempfile::tempdir()?;
    std::fs::write(
        dir.path().join("two.nff"),
        "v\nfrom 0 -6 1\nat 0 0 0\nup 0 0 1\nangle 40\nhither 0.1\nresolution 32 32\n\
         b 0.1 0.2 0.4\nl 3 -4 5\nf 0.9 0.2 0.2 0.8 0.2 20 0 1\ns 0 0 0 1\n\
         f 0.8 0.8 0.8 0.9 0 1 0 1\np 4\n-5 -5 -1\n5 -5 -1\n5 5 -1\n-5 5 -1\n",
    )?;
    let out = strahl(dir.path(), &["render", "two.nff", "-h", "24", "-q"])?;
    assert!(out.status.success(), "{}", stderr(&out));
    // The file's resolution, with the height from the command line.
    assert_eq!(size_of(&dir.path().join("two.bmp"))?, (32, 24));
    Ok(())
}

#[test]
fn fart_scenes_in_the_repository_render_through_the_cli() -> TestResult {
    let dir = tempfile::tempdir()?;
    for name in ["die", "glass", "mirrors", "ring"] {
        let scene = repo().join("scenes/fart").join(format!("{name}.fart"));
        let scene = scene.to_string_lossy().into_owned();
        let out = strahl(
            dir.path(),
            &["render", &scene, "-w", "32", "-h", "24", "-q"],
        )?;
        assert!(out.status.success(), "{name}: {}", stderr(&out));
        assert_eq!(size_of(&dir.path().join(format!("{name}.bmp")))?, (32, 24));
    }
    Ok(())
}

#[test]
fn convert_turns_an_obj_into_a_renderable_seed_scene() -> TestResult {
    let dir = tempfile::tempdir()?;
    let obj = repo().join("scenes/fart/pyramid.obj");
    let obj = obj.to_string_lossy().into_owned();
    let out = strahl(dir.path(), &["convert", &obj, "-o", "PYRAMID.txt"])?;
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stderr(&out).contains("triangles"), "{}", stderr(&out));
    let out = strahl(
        dir.path(),
        &[
            "render",
            "raytracer.cfg",
            "-w",
            "32",
            "-h",
            "24",
            "-o",
            "p.bmp",
            "-q",
        ],
    )?;
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(size_of(&dir.path().join("p.bmp"))?, (32, 24));
    // Converting again does not replace what is there, unless --force.
    let config = std::fs::read(dir.path().join("raytracer.cfg"))?;
    let out = strahl(dir.path(), &["convert", &obj, "-o", "OTHER.txt"])?;
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("raytracer.cfg: the file is there already"),
        "{}",
        stderr(&out)
    );
    assert!(stderr(&out).contains("--force"), "{}", stderr(&out));
    assert_eq!(std::fs::read(dir.path().join("raytracer.cfg"))?, config);
    assert!(!dir.path().join("OTHER.txt").exists());
    let out = strahl(
        dir.path(),
        &["convert", &obj, "-o", "PYRAMID.txt", "--force"],
    )?;
    assert!(out.status.success(), "{}", stderr(&out));
    // A missing input is an error naming it.
    let out = strahl(dir.path(), &["convert", "nope.obj", "-o", "X.txt"])?;
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("nope.obj"), "{}", stderr(&out));
    Ok(())
}

#[test]
fn zero_area_triangles_are_reported_at_load() -> TestResult {
    let dir = tempfile::tempdir()?;
    std::fs::write(
        dir.path().join("flat.fart"),
        "scene {
  camera { position <0, 0, 5> look_at <0, 0, 0> }
  light { position <1, 1, 5> }
  mesh {
    vertices { <-1, -1, 0> <1, -1, 0> <0, 1, 0> <2, 2, 0> <3, 3, 0> <4, 4, 0> }
    triangles { <0, 1, 2> <3, 4, 5> <0, 0, 1> }
  }
}
",
    )?;
    let out = strahl(dir.path(), &["render", "flat.fart", "-w", "16", "-h", "12"])?;
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(
        err.contains("warning: ") && err.contains("2 of 3 triangles have zero area"),
        "{err}"
    );
    Ok(())
}
