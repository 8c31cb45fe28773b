//! `strahl bench accuracy` from the command line, on a tiny image with the quick sweep.

use std::process::Command;

const ROOM: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/room/raytracer.cfg");

#[test]
fn accuracy_report_has_every_knob_and_exact_octree_rows() {
    let dir = tempfile::tempdir().expect("tempdir");
    let md_path = dir.path().join("accuracy.md");
    let out = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(["bench", "accuracy", "--scene", ROOM])
        .args(["--size", "32x24", "--runs", "1", "--quick", "--out"])
        .arg(&md_path)
        .output()
        .expect("strahl runs");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("multisample"), "{stdout}");

    let md = std::fs::read_to_string(&md_path).expect("the report is written");
    assert!(
        md.contains("| scene | knob | value | median s | × baseline | RMSE | PSNR dB | SSIM |"),
        "{md}"
    );
    for knob in [
        "multisample",
        "adaptive threshold (m 4)",
        "reflection cut-off",
        "depth cap",
        "ambient occlusion",
        "octree depth",
        "octree leaf size",
        "pixel precision",
    ] {
        assert!(
            md.lines()
                .any(|l| l.starts_with('|') && l.contains(&format!("| {knob} |"))),
            "no row for {knob}"
        );
    }
    let octree_rows: Vec<&str> = md
        .lines()
        .filter(|l| l.contains("| octree depth |") || l.contains("| octree leaf size |"))
        .collect();
    assert!(octree_rows.len() >= 4, "{octree_rows:?}");
    for row in octree_rows {
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        // | scene | knob | value | s | ratio | RMSE | PSNR | SSIM | rays | compared with |
        assert_eq!(cells[6], "0", "octree row with an error: {row}");
        assert_eq!(cells[7], "∞", "{row}");
        assert_eq!(cells[8], "1", "{row}");
    }
    assert!(md.contains("f32 against f64"));

    // The references' residuals are measured and shown.
    assert!(md.contains("### References and their residuals"), "{md}");
    assert!(
        md.lines().any(|l| l.starts_with("| ")
            && l.contains("| reference |")
            && l.contains("| multisample 8 |")),
        "no residual row for the main reference (multisample 16 against 8): {md}"
    );
    // The 8-bit row's bytes on the wire: 6 against 3 bytes per pixel of the 32-pixel lines.
    assert!(
        md.contains("the protocol carries 16-bit pixels only"),
        "{md}"
    );
    assert!(md.contains("bytes per line of 32 pixels"), "{md}");
    assert!(md.contains("(192 of them pixel bytes)"), "{md}");
    assert!(md.contains("(96 pixel bytes)"), "{md}");
    // Every knob's paragraph ends with a conclusion.
    let knobs = md
        .split("\n## What each knob buys\n")
        .nth(1)
        .expect("the knob section");
    for section in knobs.split("\n### ").skip(1) {
        let title = section.lines().next().unwrap_or_default();
        if title.starts_with("Floating point") {
            continue;
        }
        let items: Vec<&str> = section.lines().filter(|l| l.starts_with("- **")).collect();
        assert!(!items.is_empty(), "no paragraph under {title}");
        for item in items {
            // One conclusion, after the figures and notes it rests on.
            assert_eq!(item.matches(" Conclusion: ").count(), 1, "{title}: {item}");
            let tail = item.split(" Conclusion: ").nth(1).unwrap_or_default();
            assert!(
                !tail.contains("identical images") && !tail.contains(" RMSE reduction from "),
                "{title}: figures after the conclusion in {item}"
            );
        }
    }
    assert!(md.contains("(accuracy.svg)"));

    let svg =
        std::fs::read_to_string(dir.path().join("accuracy.svg")).expect("the plot is written");
    assert!(svg.starts_with("<svg"), "{svg}");
    assert!(svg.trim_end().ends_with("</svg>"));
    assert!(svg.contains("<polyline class=\"pareto\""));
    assert_eq!(
        svg.matches("<svg").count(),
        svg.matches("</svg>").count(),
        "unbalanced svg"
    );
}

#[test]
fn accuracy_names_a_missing_scene() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args([
            "bench",
            "accuracy",
            "--scene",
            "/nonexistent/scene.cfg",
            "--out",
        ])
        .arg(dir.path().join("a.md"))
        .output()
        .expect("strahl runs");
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/nonexistent/scene.cfg"));
    // A report that is there is not replaced (before anything is rendered) without --force.
    let kept = dir.path().join("kept.md");
    std::fs::write(&kept, "committed\n").expect("written");
    let out = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(["bench", "accuracy", "--scene", ROOM, "--out"])
        .arg(&kept)
        .output()
        .expect("strahl runs");
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("kept.md: the file is there already") && err.contains("--force"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(&kept).ok().as_deref(),
        Some("committed\n")
    );
}

#[test]
fn accuracy_rejects_a_bad_size() {
    let out = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .args(["bench", "accuracy", "--size", "32by24"])
        .output()
        .expect("strahl runs");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("WIDTHxHEIGHT"));
}
