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
    // Again: the file is there and is not replaced without --force.
    std::fs::write(dir.path().join("ROOM.txt"), "mine\n").expect("written");
    let d = dir.path().to_str().expect("utf-8 path");
    let again = strahl(&["generate", "room", "-o", d]);
    assert_eq!(again.status.code(), Some(1));
    let err = String::from_utf8_lossy(&again.stderr);
    assert!(
        err.contains("ROOM.txt: the file is there already") && err.contains("--force"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("ROOM.txt"))
            .ok()
            .as_deref(),
        Some("mine\n")
    );
    let forced = strahl(&["generate", "room", "-o", d, "--force"]);
    assert!(forced.status.success());
    assert!(std::fs::read(dir.path().join("ROOM.txt")).expect("read") == committed);
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
        "per million primitives",
        "bytes per primitive",
        "primary rays, shading off",
    ] {
        assert!(text.contains(needle), "missing {needle:?} in:\n{text}");
    }
}

#[test]
fn bench_measures_a_scene_file_and_names_a_bad_one() {
    let fixture = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/fixtures/nff/every_entity.nff"
    );
    let out = strahl(&["bench", "--scene", fixture, "--size", "16", "--runs", "1"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains(&format!("primitives ({fixture})")),
        "the report names the scene:\n{text}"
    );
    assert!(text.contains("primary rays, shading off"), "{text}");
    let dir = tempfile::tempdir().expect("temporary folder");
    let bad = dir.path().join("bad.nff");
    std::fs::write(&bad, "v\nfrom 0 0 0\nq\n").expect("write the bad scene");
    let out = strahl(&[
        "bench",
        "--scene",
        &bad.display().to_string(),
        "--runs",
        "1",
    ]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("bad.nff:"), "the error names the file: {err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bench_scaling_prints_a_speedup_table() {
    let out = strahl(&[
        "bench",
        "scaling",
        "--width",
        "32",
        "--height",
        "24",
        "--runs",
        "1",
        "--max-real",
        "2",
        "--up-to",
        "4",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let rows: Vec<Vec<&str>> = text
        .lines()
        .filter(|l| {
            l.trim_start()
                .chars()
                .next()
                .is_some_and(|c| c.is_ascii_digit())
        })
        .map(|l| l.split_whitespace().filter(|w| *w != "|").collect())
        .collect();
    assert_eq!(rows.len(), 4, "{text}");
    // workers | in-process s, speedup, master busy, lines/request | TCP s, speedup | one
    // process on N threads s, speedup | model s, speedup, efficiency.
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row.len(), 12, "{text}");
        assert_eq!(row[0], (i + 1).to_string(), "{text}");
        // Measured columns for 1 and 2 workers, model for all.
        let measured = [1, 2, 4, 5, 6, 7, 8]
            .iter()
            .all(|&c| row[c].parse::<f64>().is_ok())
            && row[3].ends_with('%');
        assert_eq!(measured, i < 2, "row {}: {text}", i + 1);
        let model: f64 = row[9].parse().unwrap_or(f64::NAN);
        assert!(model > 0.0, "{text}");
    }
    // Speedup of one worker against itself is 1 in every column.
    assert_eq!(
        (rows[0][2], rows[0][6], rows[0][8], rows[0][10]),
        ("1.00", "1.00", "1.00", "1.00")
    );
    // The master's load without rendering: results per second on one core.
    let per_core = text
        .split(" results/s on one core")
        .next()
        .and_then(|t| t.rsplit(' ').next())
        .and_then(|n| n.parse::<f64>().ok());
    assert!(per_core.is_some_and(|r| r > 0.0), "{text}");
}

#[test]
fn bench_output_into_a_closed_pipe_is_not_a_panic() {
    use std::io::Read as _;
    use std::process::{Command, Stdio};
    let mut child = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args([
            "bench", "scaling", "--width", "16", "--height", "16", "--runs", "1",
        ])
        .args(["--no-tcp", "--up-to", "200"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start strahl");
    // Close our end of stdout at once: the table's lines meet a broken pipe.
    drop(child.stdout.take());
    let mut err = String::new();
    if let Some(mut e) = child.stderr.take() {
        e.read_to_string(&mut err).expect("read stderr");
    }
    let status = child.wait().expect("wait");
    assert!(!err.contains("panicked"), "{err}");
    assert!(status.success(), "{status}: {err}");
}
