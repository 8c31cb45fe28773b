//! `strahl generate` and `strahl bench` from the command line.

use std::process::Command;

fn strahl(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(args)
        .output()
        .expect("strahl runs")
}

#[test]
fn generate_room_writes_the_committed_room() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = strahl(&[
        "generate",
        "room",
        "-o",
        dir.path().to_str().expect("utf-8 path"),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let written = std::fs::read(dir.path().join("ROOM.txt")).expect("ROOM.txt written");
    let committed = std::fs::read(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../scenes/room/ROOM.txt"
    ))
    .expect("committed room");
    assert!(
        written == committed,
        "generate room differs from scenes/room/ROOM.txt"
    );
}

#[test]
fn generated_large_scene_renders() {
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path().to_str().expect("utf-8 path");
    let out = strahl(&["generate", "large", "--triangles", "2000", "-o", d]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let cfg = dir.path().join("raytracer.cfg");
    let img = dir.path().join("small.png");
    let out = strahl(&[
        "render",
        cfg.to_str().expect("utf-8 path"),
        "--width",
        "40",
        "--height",
        "30",
        "-o",
        img.to_str().expect("utf-8 path"),
        "--quiet",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(dir.path().join("LARGE.txt")).expect("LARGE.txt");
    assert!(text.lines().filter(|l| l.starts_with("_TR ")).count() >= 2000);
    let decoded = image::open(&img).expect("a PNG").to_rgb8();
    assert_eq!(decoded.dimensions(), (40, 30));
}

#[test]
fn generate_into_a_missing_folder_fails_cleanly() {
    let out = strahl(&["generate", "room", "-o", "/nonexistent/strahl-test"]);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("/nonexistent/strahl-test: no such folder")
    );
}

#[test]
fn bench_reports_the_issue_figures() {
    let out = strahl(&[
        "bench",
        "--triangles",
        "1000",
        "--size",
        "16",
        "--runs",
        "1",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    for needle in [
        "octree build:",
        "per million triangles",
        "bytes per triangle",
        "primary rays, shading off",
    ] {
        assert!(text.contains(needle), "missing {needle:?} in:\n{text}");
    }
}
