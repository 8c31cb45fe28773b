//! End-to-end tests of `strahl render --stats-json` and the switches that choose which rays are
//! traced (`--skip-effects`, `-m`, `--aa-threshold`), on the repository's demo room at 64 × 48.

use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

type TestResult = Result<(), Box<dyn std::error::Error>>;

const WIDTH: u64 = 64;
const HEIGHT: u64 = 48;

/// The demo room's configuration file (its image name is never used: every render passes `-o`).
fn room_config() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room/raytracer.cfg")
}

/// `strahl render <room> -w 64 -h 48 --quiet ARGS...` in folder `cwd`, with `--workers 2`
/// unless `ARGS` name the workers.
fn render_room(cwd: &Path, args: &[&str]) -> std::io::Result<Output> {
    let cfg = room_config();
    let mut all: Vec<&str> = vec![
        "render",
        cfg.to_str().expect("a UTF-8 path"),
        "-w",
        "64",
        "-h",
        "48",
        "--quiet",
    ];
    if !args.contains(&"--workers") {
        all.extend_from_slice(&["--workers", "2"]);
    }
    all.extend_from_slice(args);
    Command::new(env!("CARGO_BIN_EXE_strahl"))
        .current_dir(cwd)
        .args(&all)
        .output()
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "exit {:?}, stderr:\n{}",
        out.status.code(),
        stderr(out)
    );
}

/// Renders the room into `dir` as `<name>.bmp` with statistics `<name>.json`; returns the image
/// bytes and the parsed statistics.
fn render_with_stats(
    dir: &Path,
    name: &str,
    args: &[&str],
) -> Result<(Vec<u8>, Value), Box<dyn std::error::Error>> {
    let image = format!("{name}.bmp");
    let stats = format!("{name}.json");
    let mut all = vec!["-o", image.as_str(), "--stats-json", stats.as_str()];
    all.extend_from_slice(args);
    let out = render_room(dir, &all)?;
    assert_success(&out);
    let bytes = std::fs::read(dir.join(&image))?;
    let json: Value = serde_json::from_str(&std::fs::read_to_string(dir.join(&stats))?)?;
    Ok((bytes, json))
}

/// A non-negative integer field, failing with the JSON if it is missing.
fn uint(v: &Value, path: &[&str]) -> u64 {
    let mut cur = v;
    for key in path {
        cur = &cur[*key];
    }
    cur.as_u64()
        .unwrap_or_else(|| panic!("{} is not a non-negative integer in {v:#}", path.join(".")))
}

const KINDS: [&str; 6] = [
    "primary",
    "extra_samples",
    "shadow",
    "reflection",
    "refraction",
    "occlusion",
];

#[test]
fn stats_json_describes_the_render() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (bytes, s) = render_with_stats(dir.path(), "room", &[])?;
    assert_eq!(&bytes[..2], b"BM");
    assert_eq!(uint(&s, &["width"]), WIDTH);
    assert_eq!(uint(&s, &["height"]), HEIGHT);
    assert_eq!(uint(&s, &["samples"]), 1);
    assert!(uint(&s, &["triangles"]) > 0, "{s:#}");
    assert!(
        s["output"]
            .as_str()
            .is_some_and(|o| o.ends_with("room.bmp")),
        "{s:#}"
    );
    for key in ["total", "load", "preparing", "octree", "tracing", "writing"] {
        assert!(
            s["seconds"][key].as_f64().is_some_and(|t| t >= 0.0),
            "seconds.{key} in {s:#}"
        );
    }
    // The tracing ends when the last line is in, the writing of the file follows: both are
    // parts of the total.
    let secs = |key: &str| s["seconds"][key].as_f64().unwrap_or(f64::NAN);
    assert!(
        secs("tracing") + secs("writing") <= secs("total"),
        "seconds in {s:#}"
    );
    // The octree's build is part of the scene's preparation, and that of the total.
    assert!(
        secs("octree") > 0.0
            && secs("octree") < secs("preparing")
            && secs("load") + secs("preparing") + secs("tracing") <= secs("total"),
        "seconds in {s:#}"
    );

    // Rays: one primary per pixel, no extra samples, and the total is the sum of the kinds.
    let rays = &s["rays"];
    assert_eq!(uint(rays, &["primary"]), WIDTH * HEIGHT);
    assert_eq!(uint(rays, &["extra_samples"]), 0);
    assert!(uint(rays, &["shadow"]) > 0, "the room has a casting light");
    let sum: u64 = KINDS.iter().map(|k| uint(rays, &[k])).sum();
    assert_eq!(uint(rays, &["total"]), sum, "{rays:#}");

    // Workers: two of them, whose first-delivered lines cover the image once. A worker's rays
    // count every line it delivered, also a copy that lost the race to another worker at the
    // end of the image, so together they are at least the image's rays, in whole lines.
    let workers = s["workers"].as_array().ok_or("workers is not an array")?;
    assert_eq!(workers.len(), 2, "{s:#}");
    let lines: u64 = workers.iter().map(|w| uint(w, &["lines"])).sum();
    assert_eq!(lines, HEIGHT, "{s:#}");
    for kind in KINDS {
        let by_workers: u64 = workers.iter().map(|w| uint(w, &["rays", kind])).sum();
        assert!(
            by_workers >= uint(rays, &[kind]),
            "{kind} rays of the workers: {s:#}"
        );
    }
    let primary: u64 = workers.iter().map(|w| uint(w, &["rays", "primary"])).sum();
    assert_eq!(primary % WIDTH, 0, "whole lines: {s:#}");
    for w in workers {
        assert!(w["name"].is_string(), "{w:#}");
        assert!(w["lost"].is_null(), "no worker is lost: {w:#}");
    }
    Ok(())
}

#[test]
fn skip_effects_off_keeps_the_image_and_traces_more_rays() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (on_bytes, on) = render_with_stats(dir.path(), "on", &["--skip-effects", "on"])?;
    let (default_bytes, _) = render_with_stats(dir.path(), "default", &[])?;
    let (off_bytes, off) = render_with_stats(dir.path(), "off", &["--skip-effects", "off"])?;
    assert!(on_bytes == default_bytes, "skipping is on by default");
    assert!(
        on_bytes == off_bytes,
        "--skip-effects off changed the image file"
    );
    let kind = |s: &Value, k: &str| uint(&s["rays"], &[k]);
    assert_eq!(kind(&off, "primary"), kind(&on, "primary"));
    assert_eq!(kind(&off, "extra_samples"), kind(&on, "extra_samples"));
    // The room has a non-casting light, and surfaces facing away from the lights.
    assert!(
        kind(&off, "shadow") > kind(&on, "shadow"),
        "shadow rays: {} on, {} off",
        kind(&on, "shadow"),
        kind(&off, "shadow")
    );
    // Reflections are off in the room's configuration: the dropped mirror rays appear.
    assert_eq!(kind(&on, "reflection"), 0);
    assert!(kind(&off, "reflection") > 0);
    assert!(uint(&off, &["rays", "total"]) > uint(&on, &["rays", "total"]));
    Ok(())
}

#[test]
fn multisample_two_adds_three_extra_samples_per_pixel() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (_, s) = render_with_stats(dir.path(), "m2", &["-m", "2"])?;
    assert_eq!(uint(&s, &["samples"]), 2);
    assert_eq!(uint(&s["rays"], &["primary"]), WIDTH * HEIGHT);
    assert_eq!(uint(&s["rays"], &["extra_samples"]), 3 * WIDTH * HEIGHT);
    Ok(())
}

#[test]
fn aa_threshold_above_one_is_a_usage_error() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = render_room(dir.path(), &["-o", "x.bmp", "--aa-threshold", "2"])?;
    assert_eq!(out.status.code(), Some(2), "stderr:\n{}", stderr(&out));
    assert!(stderr(&out).contains("--aa-threshold"), "{}", stderr(&out));
    assert!(!dir.path().join("x.bmp").exists(), "nothing rendered");
    // The bounds themselves are accepted.
    for ok in ["0", "1"] {
        let out = render_room(
            dir.path(),
            &["-o", "x.bmp", "-m", "2", "--aa-threshold", ok],
        )?;
        assert_success(&out);
    }
    Ok(())
}

#[test]
fn a_depth_cap_above_the_limit_is_a_usage_error() -> TestResult {
    // Two facing mirrors under a cap of 4e9 bounces would trace for ever; the cap is bounded.
    let dir = tempfile::tempdir()?;
    let out = render_room(dir.path(), &["-o", "x.bmp", "-d", "4000000000"])?;
    assert_eq!(out.status.code(), Some(2), "stderr:\n{}", stderr(&out));
    assert!(stderr(&out).contains("--max-depth"), "{}", stderr(&out));
    assert!(stderr(&out).contains("0..=100"), "{}", stderr(&out));
    assert!(!dir.path().join("x.bmp").exists(), "nothing rendered");
    let out = render_room(dir.path(), &["-o", "x.bmp", "-d", "100"])?;
    assert_success(&out);
    Ok(())
}

#[test]
fn unwritable_stats_path_fails_naming_it() -> TestResult {
    let dir = tempfile::tempdir()?;
    let missing = dir.path().join("no-such-folder").join("stats.json");
    let folder = dir.path().to_path_buf();
    // A device: written to, it would take the statistics but not keep them.
    let device = std::path::PathBuf::from("/dev/null");
    for stats in [missing, folder, device] {
        let stats_arg = stats.to_str().ok_or("path")?;
        let out = render_room(dir.path(), &["-o", "x.bmp", "--stats-json", stats_arg])?;
        assert_eq!(out.status.code(), Some(1), "{stats_arg}: {}", stderr(&out));
        assert!(
            stderr(&out).contains(&format!("{stats_arg}: cannot write the statistics")),
            "the message names {stats_arg}:\n{}",
            stderr(&out)
        );
        assert!(
            !dir.path().join("x.bmp").exists(),
            "{stats_arg}: no image without its statistics"
        );
    }
    assert!(!dir.path().join("no-such-folder").exists());
    Ok(())
}

#[test]
fn one_worker_delivers_every_line_and_every_ray() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (_, s) = render_with_stats(dir.path(), "one", &["--workers", "1"])?;
    let workers = s["workers"].as_array().ok_or("workers is not an array")?;
    assert_eq!(workers.len(), 1, "{s:#}");
    assert_eq!(uint(&workers[0], &["lines"]), HEIGHT);
    for kind in KINDS {
        assert_eq!(
            uint(&workers[0], &["rays", kind]),
            uint(&s["rays"], &[kind]),
            "{kind}: {s:#}"
        );
    }
    Ok(())
}

#[test]
fn work_counts_are_the_same_for_any_worker_count_and_match_their_per_ray_figures() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (_, one) = render_with_stats(dir.path(), "one", &["--workers", "1"])?;
    let (_, two) = render_with_stats(dir.path(), "two", &["--workers", "2"])?;
    let work = &one["work"];
    let tests = uint(work, &["intersection_tests"]);
    let cells = uint(work, &["octree_cells"]);
    // Every primary ray of the closed room enters the octree and tests something.
    assert!(tests >= WIDTH * HEIGHT, "{work:#}");
    assert!(cells >= WIDTH * HEIGHT, "{work:#}");
    // The counts travel with each line, so they add up to the same whoever rendered it.
    assert_eq!(work, &two["work"], "work with 1 and 2 workers");
    let total = uint(&one["rays"], &["total"]) as f64;
    // JSON's decimal text may round the last bit of an f64.
    let close = |key: &str, want: f64| {
        let got = work[key].as_f64().unwrap_or(f64::NAN);
        assert!(
            (got - want).abs() <= 1e-12 * want,
            "{key}: {got} against {want}"
        );
    };
    close("tests_per_ray", tests as f64 / total);
    close("cells_per_ray", cells as f64 / total);
    // The peak memory, in bytes: at least the image buffer and the code, at most this machine.
    let peak = uint(&one, &["peak_memory_bytes"]);
    assert!((1 << 20..1 << 40).contains(&peak), "peak memory {peak}");
    // The octree's figures come with them.
    let octree = &one["octree"];
    assert!(uint(octree, &["nodes"]) >= 1, "{octree:#}");
    let per_primitive = uint(octree, &["bytes"]) as f64 / uint(&one, &["triangles"]) as f64;
    let got = octree["bytes_per_primitive"].as_f64().unwrap_or(f64::NAN);
    assert!(
        (got - per_primitive).abs() <= 1e-6 * per_primitive,
        "{octree:#}"
    );
    Ok(())
}

/// An NFF scene of `n` balls along a shrinking spiral, each overlapping hundreds of its
/// neighbours (as SPD's shells), in front of the camera.
fn spiral_of_balls(n: usize) -> String {
    let mut nff = String::from(
        "v\nfrom 0 -12 3\nat 0 0 3\nup 0 0 1\nangle 40\nhither 0.01\nresolution 32 24\n\
         b 0 0 0\nl 5 -10 10\nf 0.8 0.6 0.3 0.8 0.2 20 0 1\n",
    );
    for k in 0..n {
        let a = k as f32 * 0.004;
        let grow = 1.0 - k as f32 / (n as f32 + 100.0);
        let (x, y, z) = ((a * 6.0).cos() * grow, (a * 6.0).sin() * grow, a * grow);
        nff.push_str(&format!("s {x} {y} {z} {}\n", 0.4 * grow));
    }
    nff
}

#[test]
fn sphere_groups_are_reported_beside_the_octree() -> TestResult {
    let dir = tempfile::tempdir()?;
    let (_, room) = render_with_stats(dir.path(), "room", &[])?;
    assert_eq!(
        uint(&room, &["octree", "sphere_group_bytes"]),
        0,
        "{room:#}"
    );
    let scene = dir.path().join("spiral.nff");
    std::fs::write(&scene, spiral_of_balls(1500))?;
    let out = Command::new(env!("CARGO_BIN_EXE_strahl"))
        .current_dir(dir.path())
        .args(["render", "spiral.nff", "--quiet", "--workers", "1"])
        .args(["-o", "spiral.bmp", "--stats-json", "spiral.json"])
        .output()?;
    assert_success(&out);
    let s: Value = serde_json::from_str(&std::fs::read_to_string(dir.path().join("spiral.json"))?)?;
    // At least one group of 16 spheres (392 bytes with its indices, besides its box).
    let groups = uint(&s, &["octree", "sphere_group_bytes"]);
    assert!(groups >= 392, "{s:#}");
    Ok(())
}

#[test]
fn a_dash_writes_the_statistics_to_standard_output_unless_the_image_goes_there() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = render_room(dir.path(), &["-o", "room.bmp", "--stats-json", "-"])?;
    assert_success(&out);
    let json: Value = serde_json::from_slice(&out.stdout)?;
    assert_eq!(uint(&json, &["width"]), 64);
    assert!(dir.path().join("room.bmp").is_file());
    assert!(!dir.path().join("-").exists(), "no file named `-`");

    let out = render_room(dir.path(), &["-o", "-", "--stats-json", "-"])?;
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("both write to standard output"),
        "{}",
        stderr(&out)
    );
    assert!(out.stdout.is_empty(), "nothing rendered");
    Ok(())
}
