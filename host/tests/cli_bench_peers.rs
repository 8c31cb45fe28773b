//! `strahl bench peers` from the command line, on the tiny scene pair of
//! `tests/fixtures/peers/` (a sphere and a square, as `tiny.nff` and `tiny.pov`).
//!
//! The comparison itself needs POV-Ray: where `povray` is not on the PATH that test fails,
//! saying so, rather than passing without having run (`.ci/run` installs it). The error tests
//! need no POV-Ray.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BEGIN: &str = "<!-- bench peers: begin -->";
const END: &str = "<!-- bench peers: end -->";
const HEADING: &str = "## Strahl against POV-Ray: `strahl bench peers`";

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/peers")
}

fn strahl(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_strahl"))
        .current_dir(dir)
        .args(args)
        .output()
        .expect("strahl runs")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Fails the test unless `povray` is on the PATH.
fn require_povray() {
    let path = std::env::var_os("PATH").unwrap_or_default();
    let found = std::env::split_paths(&path).any(|d| d.join("povray").is_file());
    assert!(
        found,
        "this test runs POV-Ray 3.7, and `povray` is not on the PATH: install it with \
         `apt-get install povray` (.ci/run installs it where it is missing)"
    );
}

/// The cells of the Markdown row of `table` that starts with `| name |`.
fn row<'a>(table: &'a str, name: &str) -> Vec<&'a str> {
    let line = table
        .lines()
        .find(|l| l.starts_with(&format!("| {name} |")))
        .unwrap_or_else(|| panic!("no row for {name} in:\n{table}"));
    line.trim_matches('|').split('|').map(str::trim).collect()
}

fn secs(cell: &str) -> f64 {
    let v: f64 = cell
        .parse()
        .unwrap_or_else(|_| panic!("`{cell}` is not seconds"));
    assert!(
        v >= 0.0 && cell.split_once('.').is_some_and(|(_, d)| d.len() == 3),
        "{cell}"
    );
    v
}

/// `ratio` is Strahl's printed time over POV-Ray's, to two decimals (`-` where POV-Ray's is 0).
fn assert_ratio(ratio: &str, povray: &str, strahl: &str) {
    let (p, s) = (secs(povray), secs(strahl));
    if p == 0.0 {
        assert_eq!(ratio, "-", "POV-Ray {povray}, Strahl {strahl}");
    } else {
        assert_eq!(
            ratio,
            format!("{:.2}", s / p),
            "POV-Ray {povray}, Strahl {strahl}"
        );
    }
}

/// The by-round cell of a run of one round: that round's ratio as its median, smallest and
/// largest (`0.19 (0.19–0.19)`), or `-` where POV-Ray reported no time.
fn assert_one_round(cell: &str) {
    if cell == "-" {
        return;
    }
    let (median, range) = cell.split_once(" (").unwrap_or_else(|| panic!("`{cell}`"));
    let (lo, hi) = range
        .strip_suffix(')')
        .and_then(|r| r.split_once('–'))
        .unwrap_or_else(|| panic!("`{cell}`"));
    let ratio: f64 = median.parse().unwrap_or_else(|_| panic!("`{cell}`"));
    assert!(ratio > 0.0, "`{cell}`");
    assert_eq!((lo, hi), (median, median), "one round: `{cell}`");
}

/// The two counts of `a / b` (thousands separated by commas).
fn counts(cell: &str) -> (u64, u64) {
    let n = |s: &str| -> u64 {
        s.trim()
            .replace(',', "")
            .parse()
            .unwrap_or_else(|_| panic!("`{cell}` is not two counts"))
    };
    let (a, b) = cell.split_once(" / ").expect("a / b");
    (n(a), n(b))
}

/// A figure Strahl may not report yet: `-`, or a number.
fn optional_number(cell: &str) {
    assert!(cell == "-" || cell.parse::<f64>().is_ok(), "`{cell}`");
}

/// Checks the comparison row of `stdout` and returns it as printed.
fn check_row(stdout: &str) -> String {
    let c = row(stdout, "tiny");
    assert_eq!(c.len(), 14, "{c:?}");
    assert_ratio(c[3], c[1], c[2]);
    assert_one_round(c[4]);
    assert_ratio(c[7], c[5], c[6]);
    assert!(
        secs(c[5]) > 0.0 && secs(c[6]) > 0.0,
        "whole processes take time: {c:?}"
    );
    let (s, p) = counts(c[8]);
    // 24×24 camera rays each, and shadow rays towards the one light.
    assert!(s > 576 && p > 576, "{c:?}");
    // tests/ray, cells/ray, octree depth, octree bytes (`1.3 MiB`).
    for cell in &c[9..13] {
        optional_number(cell.split(' ').next().unwrap_or_default());
    }
    let mad: Vec<f64> = c[13]
        .split(" / ")
        .map(|v| v.parse().expect("MAD is a number"))
        .collect();
    assert_eq!(mad.len(), 3, "{c:?}");
    // The same scene: the pictures agree roughly (a wrong camera or a swapped axis would not).
    assert!(mad.iter().all(|&m| (0.0..64.0).contains(&m)), "{mad:?}");

    let rays = row(
        stdout.split("Rays by kind").nth(1).expect("rays table"),
        "tiny",
    );
    assert_eq!(
        rays[1], "576 / 576",
        "one camera ray per pixel each: {rays:?}"
    );
    let kinds: u64 = rays[1..].iter().map(|c| counts(c).0).sum();
    assert_eq!(kinds, s, "Strahl's kinds add up to its total: {rays:?}");
    let kinds: u64 = rays[1..].iter().map(|c| counts(c).1).sum();
    assert_eq!(kinds, p, "POV-Ray's kinds add up to its total: {rays:?}");

    stdout
        .lines()
        .find(|l| l.starts_with("| tiny |"))
        .expect("row")
        .to_string()
}

#[test]
fn compares_the_tiny_pair_and_rewrites_its_section() {
    require_povray();
    let dir = tempfile::tempdir().expect("tempdir");
    let docs = dir.path().join("perf.md");
    std::fs::write(&docs, "# Performance\n\nBefore the section.\n").expect("write docs");
    // Relative to the folder it runs in, as the default `../shared/spd` is: both tracers must
    // find the scenes although POV-Ray runs in a folder of its own.
    let args = [
        "bench",
        "peers",
        "--scenes",
        "tests/fixtures/peers",
        "--size",
        "24",
        "--runs",
        "1",
        "--write-docs",
        docs.to_str().expect("utf-8 path"),
    ];

    let host = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = strahl(host, &args);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    let first_row = check_row(&stdout);

    let picture = dir.path().join("peers/tiny.png");
    let img = image::open(&picture).expect("side-by-side picture written");
    assert_eq!(
        (img.width(), img.height()),
        (48, 24),
        "Strahl and POV-Ray side by side"
    );

    let written = std::fs::read_to_string(&docs).expect("docs written");
    assert!(
        written.starts_with("# Performance\n\nBefore the section.\n"),
        "{written}"
    );
    for marker in [BEGIN, END, HEADING] {
        assert_eq!(
            written.matches(marker).count(),
            1,
            "{marker} once:\n{written}"
        );
    }
    let section = written
        .split(BEGIN)
        .nth(1)
        .and_then(|s| s.split(END).next())
        .expect("section");
    assert!(
        section.contains(&first_row),
        "the table is in the docs:\n{written}"
    );
    assert!(section.contains("[tiny](peers/tiny.png)"), "{section}");
    assert!(
        section.contains("--size 24 --runs 1 --write-docs"),
        "{section}"
    );
    assert!(section.contains("logical CPU"), "{section}");

    // A second run replaces the section and keeps what is around it.
    std::fs::write(
        &docs,
        format!("{written}\n## Later\n\nAfter the section.\n"),
    )
    .expect("edit");
    let out = strahl(host, &args);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    let second_row = check_row(&stdout);
    let rewritten = std::fs::read_to_string(&docs).expect("docs rewritten");
    for marker in [BEGIN, END, HEADING] {
        assert_eq!(
            rewritten.matches(marker).count(),
            1,
            "{marker} once:\n{rewritten}"
        );
    }
    assert_eq!(
        rewritten
            .lines()
            .filter(|l| l.starts_with("| tiny |"))
            .count(),
        2,
        "one comparison row and one rays row:\n{rewritten}"
    );
    assert!(rewritten.contains(&second_row), "{rewritten}");
    assert!(
        rewritten.starts_with("# Performance\n\nBefore the section.\n"),
        "{rewritten}"
    );
    assert!(
        rewritten.ends_with("## Later\n\nAfter the section.\n"),
        "{rewritten}"
    );
}

/// Runs `bench peers ARGS` on the fixtures and returns its stderr, checking it failed with
/// exit code `code` and did not panic.
fn fails(args: &[&str], path: Option<&Path>, code: i32) -> String {
    let dir = tempfile::tempdir().expect("tempdir");
    let scenes = fixtures();
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_strahl"));
    cmd.current_dir(dir.path())
        .args([
            "bench",
            "peers",
            "--scenes",
            scenes.to_str().expect("utf-8 path"),
        ])
        .args(args);
    if let Some(path) = path {
        cmd.env("PATH", path);
    }
    let out = cmd.output().expect("strahl runs");
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(
        !dir.path().join("docs").exists(),
        "nothing written before the inputs are checked"
    );
    stderr
}

#[test]
fn without_povray_on_the_path_it_says_how_to_install_it() {
    let empty = tempfile::tempdir().expect("tempdir");
    let stderr = fails(&["--size", "24", "--runs", "1"], Some(empty.path()), 1);
    assert!(stderr.contains("not on the PATH"), "{stderr}");
    assert!(stderr.contains("apt-get install povray"), "{stderr}");
}

#[test]
fn an_unknown_scene_is_named() {
    let stderr = fails(&["--only", "nosuch"], None, 1);
    assert!(stderr.contains("\"nosuch\""), "{stderr}");
    assert!(stderr.contains("the pairs there: tiny"), "{stderr}");
}

#[test]
fn a_folder_without_pairs_and_bad_numbers_are_errors() {
    let empty = tempfile::tempdir().expect("tempdir");
    let out = strahl(
        empty.path(),
        &[
            "bench",
            "peers",
            "--scenes",
            empty.path().to_str().expect("utf-8 path"),
        ],
    );
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("no scene pairs"), "{stderr}");

    for (flag, value) in [("--size", "big"), ("--runs", "0"), ("--depth", "101")] {
        let stderr = fails(&[flag, value], None, 2);
        assert!(stderr.contains(flag) && stderr.contains(value), "{stderr}");
    }
}

#[test]
fn pictures_go_to_the_folder_asked_for_and_nowhere_else() {
    require_povray();
    let dir = tempfile::tempdir().expect("tempdir");
    let scenes = fixtures();
    let args = [
        "bench",
        "peers",
        "--scenes",
        scenes.to_str().expect("utf-8 path"),
        "--size",
        "24",
        "--runs",
        "1",
        "--pictures",
        "out/pictures",
    ];
    let out = strahl(dir.path(), &args);
    let stdout = text(&out.stdout);
    assert!(out.status.success(), "{stdout}\n{}", text(&out.stderr));
    check_row(&stdout);
    let img = image::open(dir.path().join("out/pictures/tiny.png")).expect("picture written");
    assert_eq!((img.width(), img.height()), (48, 24), "side by side");
    assert!(
        !dir.path().join("docs").exists(),
        "no docs/peers/ beside the folder asked for"
    );

    // A file where the folder should be: named, and nothing else written.
    std::fs::write(dir.path().join("taken"), "a file").expect("write file");
    let mut taken = args;
    if let Some(folder) = taken.last_mut() {
        *folder = "taken";
    }
    let out = strahl(dir.path(), &taken);
    let stderr = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("taken: cannot create the folder"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn pictures_and_write_docs_do_not_go_together() {
    let stderr = fails(&["--write-docs", "perf.md", "--pictures", "pics"], None, 2);
    assert!(
        stderr.contains("--pictures") && stderr.contains("--write-docs"),
        "{stderr}"
    );
}
