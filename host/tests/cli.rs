//! End-to-end tests of `strahl render`, running the built binary on tiny scenes in temporary
//! folders.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A wall facing the camera, a small triangle in front of it that shadows it, one shader each and
/// a shadow-casting light off to the side.
const DATA: &str = include_str!("fixtures/wall/room.txt");

/// The configuration: a 32×24 image `out.bmp`, camera 10 units in front of the origin.
const CONFIG: &str = include_str!("fixtures/wall/scene.cfg");

type TestResult = Result<(), Box<dyn std::error::Error>>;

/// A temporary folder holding `scene.cfg` and `room.txt`.
fn scene_dir(config: &str, data: &str) -> std::io::Result<tempfile::TempDir> {
    let dir = tempfile::tempdir()?;
    std::fs::write(dir.path().join("scene.cfg"), config)?;
    std::fs::write(dir.path().join("room.txt"), data)?;
    Ok(dir)
}

/// Runs `strahl` with `args` in folder `cwd`.
fn strahl(cwd: &Path, args: &[&str]) -> std::io::Result<Output> {
    Command::new(env!("CARGO_BIN_EXE_strahl"))
        .current_dir(cwd)
        .args(args)
        .output()
}

/// `strahl render scene.cfg ARGS...` in `dir`.
fn render(dir: &Path, args: &[&str]) -> std::io::Result<Output> {
    let mut all = vec!["render", "scene.cfg"];
    all.extend_from_slice(args);
    strahl(dir, &all)
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Fails with the process's stderr unless it exited with code 0.
fn assert_success(out: &Output) {
    assert!(
        out.status.success(),
        "exit {:?}, stderr:\n{}",
        out.status.code(),
        stderr(out)
    );
}

/// The names of the entries in `dir`.
fn listing(dir: &Path) -> std::io::Result<BTreeSet<PathBuf>> {
    std::fs::read_dir(dir)?
        .map(|e| e.map(|e| PathBuf::from(e.file_name())))
        .collect()
}

fn names(list: &[&str]) -> BTreeSet<PathBuf> {
    list.iter().map(PathBuf::from).collect()
}

#[test]
fn renders_bmp_of_configured_size_next_to_config() -> TestResult {
    let dir = scene_dir(CONFIG, DATA)?;
    // Run from elsewhere: $IMAGE_NAME and $INPUT_DATA are relative to the configuration file.
    let elsewhere = tempfile::tempdir()?;
    let cfg = dir.path().join("scene.cfg");
    let out = strahl(elsewhere.path(), &["render", cfg.to_str().ok_or("path")?])?;
    assert_success(&out);
    assert!(listing(elsewhere.path())?.is_empty());
    assert_eq!(
        listing(dir.path())?,
        names(&["scene.cfg", "room.txt", "out.bmp"])
    );
    let path = dir.path().join("out.bmp");
    let bytes = std::fs::read(&path)?;
    assert_eq!(&bytes[..2], b"BM");
    assert_eq!(
        u16::from_le_bytes([bytes[28], bytes[29]]),
        24,
        "24 bits per pixel"
    );
    assert_eq!(
        image::ImageFormat::from_path(&path)?,
        image::ImageFormat::Bmp
    );
    let img = image::open(&path)?.to_rgb8();
    assert_eq!(img.dimensions(), (32, 24));
    let distinct: BTreeSet<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    assert!(distinct.len() > 3, "the scene is visible: {distinct:?}");
    Ok(())
}

#[test]
fn output_option_writes_png_and_size_options_override() -> TestResult {
    let dir = scene_dir(CONFIG, DATA)?;
    let out = render(
        dir.path(),
        &["-o", "x.PNG", "--width", "20", "--height", "10"],
    )?;
    assert_success(&out);
    assert_eq!(
        listing(dir.path())?,
        names(&["scene.cfg", "room.txt", "x.PNG"])
    );
    let bytes = std::fs::read(dir.path().join("x.PNG"))?;
    assert_eq!(image::guess_format(&bytes)?, image::ImageFormat::Png);
    let img = image::load_from_memory(&bytes)?;
    assert_eq!((img.width(), img.height()), (20, 10));
    Ok(())
}

#[test]
fn worker_count_does_not_change_the_image() -> TestResult {
    let dir = scene_dir(CONFIG, DATA)?;
    let mut files = Vec::new();
    for workers in ["1", "3", "7"] {
        let name = format!("w{workers}.bmp");
        let out = render(
            dir.path(),
            &["--workers", workers, "-o", &name, "--width", "41"],
        )?;
        assert_success(&out);
        files.push(std::fs::read(dir.path().join(&name))?);
    }
    assert_eq!(files[0], files[1]);
    assert_eq!(files[0], files[2]);
    Ok(())
}

#[test]
fn shadows_off_changes_pixels() -> TestResult {
    let dir = scene_dir(CONFIG, DATA)?;
    assert_success(&render(dir.path(), &["-o", "on.bmp", "--shadows", "on"])?);
    assert_success(&render(dir.path(), &["-o", "off.bmp", "--shadows", "off"])?);
    assert_success(&render(dir.path(), &["-o", "default.bmp"])?);
    let on = std::fs::read(dir.path().join("on.bmp"))?;
    let off = std::fs::read(dir.path().join("off.bmp"))?;
    let default = std::fs::read(dir.path().join("default.bmp"))?;
    assert_ne!(on, off, "the occluder's shadow disappears");
    assert_eq!(on, default, "shadows are on by default");
    Ok(())
}

#[test]
fn reflections_switch_changes_pixels() -> TestResult {
    let dir = scene_dir(CONFIG, DATA)?;
    assert_success(&render(
        dir.path(),
        &["-o", "on.bmp", "--reflections", "1"],
    )?);
    assert_success(&render(
        dir.path(),
        &["-o", "off.bmp", "--reflections", "0"],
    )?);
    let on = std::fs::read(dir.path().join("on.bmp"))?;
    let off = std::fs::read(dir.path().join("off.bmp"))?;
    assert_ne!(on, off);
    Ok(())
}

#[test]
fn bad_data_file_names_the_line_and_writes_nothing() -> TestResult {
    let data = DATA.replace("_PT 2 2 -2", "_PT 2 oops -2");
    let dir = scene_dir(CONFIG, &data)?;
    let before = listing(dir.path())?;
    let out = render(dir.path(), &[])?;
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(err.starts_with("error: "), "{err}");
    assert!(err.contains("room.txt:6:"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert_eq!(
        listing(dir.path())?,
        before,
        "no image and no temporary file"
    );
    Ok(())
}

#[test]
fn bad_triangle_index_base_is_reported() -> TestResult {
    // With 1-based indices, `_TR 0 1 2 0` names point 0, which does not exist.
    let dir = scene_dir(CONFIG, DATA)?;
    let before = listing(dir.path())?;
    let out = render(dir.path(), &["--index-base", "1"])?;
    assert_eq!(out.status.code(), Some(1));
    assert!(stderr(&out).contains("room.txt:"), "{}", stderr(&out));
    assert_eq!(listing(dir.path())?, before);
    Ok(())
}

#[test]
fn missing_output_folder_fails_before_rendering() -> TestResult {
    let dir = scene_dir(CONFIG, DATA)?;
    let before = listing(dir.path())?;
    // A huge image: if the check came after rendering, this test would take very long.
    let out = render(
        dir.path(),
        &[
            "-o",
            "nowhere/x.bmp",
            "--width",
            "30000",
            "--height",
            "30000",
        ],
    )?;
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(err.contains("nowhere"), "{err}");
    assert!(!err.contains("rendered"), "{err}");
    assert_eq!(listing(dir.path())?, before);
    Ok(())
}

#[test]
fn unknown_image_extension_fails_before_rendering() -> TestResult {
    let dir = scene_dir(CONFIG, DATA)?;
    let before = listing(dir.path())?;
    let out = render(
        dir.path(),
        &["-o", "x.jpg", "--width", "30000", "--height", "30000"],
    )?;
    assert_eq!(out.status.code(), Some(2), "a usage error");
    let err = stderr(&out);
    assert!(err.contains("x.jpg") && err.contains(".png"), "{err}");
    for format in ["bmp", "png16", "ppm", "exr"] {
        assert!(err.contains(format), "the formats are listed: {err}");
    }
    assert_eq!(listing(dir.path())?, before);
    Ok(())
}

#[test]
fn failed_run_keeps_an_existing_image() -> TestResult {
    let dir = scene_dir(CONFIG, DATA)?;
    std::fs::write(dir.path().join("out.bmp"), b"old")?;
    std::fs::write(dir.path().join("room.txt"), "_PT 1 2\n")?;
    let out = render(dir.path(), &[])?;
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(std::fs::read(dir.path().join("out.bmp"))?, b"old");
    Ok(())
}

#[test]
fn usage_errors_exit_2() -> TestResult {
    let dir = scene_dir(CONFIG, DATA)?;
    for args in [
        &["--workers", "1025"][..],
        &["--workers", "x"],
        &["--window", "0"],
        &["--worker-timeout", "-1"],
        &["--shadows", "yes"],
        &["--index-base", "2"],
        &["--width", "0"],
        &["--width", "-5"],
        &["--aa-threshold", "-0.1"],
        &["--aa-threshold", "1.5"],
        &["--bogus"],
    ] {
        let out = render(dir.path(), args)?;
        assert_eq!(out.status.code(), Some(2), "{args:?}: {}", stderr(&out));
        assert!(!stderr(&out).is_empty());
        // A negative number is read as the option's value, not as an unknown option `-0`.
        if args.len() == 2 && args[1].starts_with('-') {
            assert!(
                stderr(&out).contains(&format!("invalid value '{}'", args[1])),
                "{args:?}: {}",
                stderr(&out)
            );
        }
    }
    let out = strahl(dir.path(), &["render"])?;
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(listing(dir.path())?, names(&["scene.cfg", "room.txt"]));
    Ok(())
}

#[test]
fn a_workers_name_is_not_empty_and_holds_no_control_characters() -> TestResult {
    let dir = tempfile::tempdir()?;
    for (name, says) in [
        ("", "must not be empty"),
        (
            "ev\u{1b}[31mil",
            "`ev\\u{1b}[31mil` holds control characters",
        ),
        ("tab\there", "holds control characters"),
    ] {
        let args = ["worker", "--connect", "127.0.0.1:9", "--name", name];
        let out = strahl(dir.path(), &args)?;
        assert_eq!(out.status.code(), Some(2), "{name:?}: {}", stderr(&out));
        assert!(stderr(&out).contains(says), "{name:?}: {}", stderr(&out));
        assert!(!stderr(&out).contains('\u{1b}'), "{:?}", stderr(&out));
    }
    Ok(())
}

#[test]
fn no_worker_at_all_is_an_error() -> TestResult {
    let dir = scene_dir(CONFIG, DATA)?;
    let out = render(dir.path(), &["--workers", "0"])?;
    assert_eq!(out.status.code(), Some(2), "a usage error");
    assert!(stderr(&out).contains("no worker"), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("--worker HOST[:PORT]"),
        "says how: {}",
        stderr(&out)
    );
    assert_eq!(listing(dir.path())?, names(&["scene.cfg", "room.txt"]));
    Ok(())
}

#[test]
fn missing_config_is_an_error_naming_it() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = strahl(dir.path(), &["render", "nope.cfg"])?;
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(err.starts_with("error: nope.cfg"), "{err}");
    Ok(())
}

#[test]
fn quiet_prints_nothing() -> TestResult {
    let dir = scene_dir(CONFIG, DATA)?;
    let out = render(dir.path(), &["--quiet"])?;
    assert_success(&out);
    assert!(out.stderr.is_empty(), "{}", stderr(&out));
    assert!(out.stdout.is_empty());
    assert!(dir.path().join("out.bmp").is_file());
    Ok(())
}

#[test]
fn glass_reports_reflection_and_a_useless_threshold_is_warned_about() -> TestResult {
    // glass.fart's reflectance is under the cut-off, but total internal reflection still sends
    // mirror rays: the effects line must name both. --aa-threshold at multisample 1 does nothing
    // and says so.
    let dir = tempfile::tempdir()?;
    let glass = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/fart/glass.fart");
    let glass = glass.display().to_string();
    let out = strahl(
        dir.path(),
        &[
            "render",
            &glass,
            "-o",
            "g.bmp",
            "-w",
            "40",
            "-h",
            "30",
            "-m",
            "1",
            "--aa-threshold",
            "0.1",
        ],
    )?;
    assert_success(&out);
    let err = stderr(&out);
    let effects = err
        .lines()
        .find(|l| l.starts_with("effects: "))
        .unwrap_or_default();
    assert!(effects.contains("reflection, refraction"), "{err}");
    assert!(
        err.contains("warning: --aa-threshold has no effect at multisample 1"),
        "{err}"
    );
    let out = strahl(
        dir.path(),
        &[
            "render",
            &glass,
            "-o",
            "g.bmp",
            "-w",
            "40",
            "-h",
            "30",
            "-m",
            "2",
            "--aa-threshold",
            "0.1",
        ],
    )?;
    assert_success(&out);
    assert!(!stderr(&out).contains("warning"), "{}", stderr(&out));
    Ok(())
}

#[test]
fn summary_names_size_rays_and_output() -> TestResult {
    let dir = scene_dir(CONFIG, DATA)?;
    let out = render(dir.path(), &["--workers", "2", "--reflections", "off"])?;
    assert_success(&out);
    assert!(out.stdout.is_empty());
    let err = stderr(&out);
    // stderr is not a terminal here: no progress bar (a render this short writes no progress
    // line), just the summary (five lines), the effects line and the worker table (a header and
    // one line per worker).
    assert_eq!(err.lines().count(), 9, "{err}");
    assert_eq!(
        err.lines().nth(5),
        Some("effects: shadows 1/1 lights, highlights"),
        "{err}"
    );
    let table: Vec<&str> = err.lines().skip(6).collect();
    assert!(table[0].starts_with("worker "), "{err}");
    assert!(
        table[1].starts_with("local-1 ") && table[1].ends_with(" ok"),
        "{err}"
    );
    assert!(
        table[2].starts_with("local-2 ") && table[2].ends_with(" ok"),
        "{err}"
    );
    assert!(err.lines().all(|l| l.chars().count() <= 100), "{err}");
    assert!(table.iter().all(|l| l.chars().count() <= 80), "{err}");
    assert!(err.starts_with("rendered 32x24 in "), "{err}");
    assert!(err.contains("  scene:   2 triangles"), "{err}");
    assert!(
        err.contains(&format!("  rays:    {} primary, ", 32 * 24)),
        "{err}"
    );
    assert!(
        err.contains("no extra samples, reflection, refraction or occlusion rays"),
        "{err}"
    );
    assert!(
        err.contains("  workers: 2 workers (2 finished, 0 lost)"),
        "{err}"
    );
    assert!(
        err.lines().next().unwrap_or("").ends_with("out.bmp"),
        "{err}"
    );
    Ok(())
}

/// An NFF scene whose tenth line is a record with a bad last word, `word`, with line ends
/// `end`.
fn nff_with_bad_word(end: &str, word: &str) -> String {
    let lines = [
        "v",
        "from 0 0 5",
        "at 0 0 0",
        "up 0 1 0",
        "angle 40",
        "hither 1",
        "resolution 8 8",
        "b 0 0 0",
        "l 1 1 1",
    ];
    let mut text = lines.join(end);
    text.push_str(end);
    text.push_str(&format!("f 1 0 0 1 0 0 0 {word}{end}"));
    text
}

#[test]
fn old_mac_line_ends_count_as_lines() -> TestResult {
    let dir = tempfile::tempdir()?;
    std::fs::write(dir.path().join("cr.nff"), nff_with_bad_word("\r", "x"))?;
    let out = strahl(dir.path(), &["render", "cr.nff", "-o", "cr.bmp", "-q"])?;
    assert!(!out.status.success());
    assert!(stderr(&out).contains("cr.nff:10:"), "{}", stderr(&out));
    Ok(())
}

#[test]
fn error_messages_escape_control_bytes_and_shorten_long_words() -> TestResult {
    let dir = tempfile::tempdir()?;
    std::fs::write(
        dir.path().join("esc.nff"),
        nff_with_bad_word("\n", "1\u{1b}[31mRED"),
    )?;
    let out = strahl(dir.path(), &["render", "esc.nff", "-o", "e.bmp", "-q"])?;
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(!err.contains('\u{1b}'), "a raw escape byte: {err:?}");
    assert!(err.contains("\\u{1b}[31mRED"), "{err}");
    let long = "7".repeat(1 << 20) + "x";
    std::fs::write(dir.path().join("long.nff"), nff_with_bad_word("\n", &long))?;
    let out = strahl(dir.path(), &["render", "long.nff", "-o", "l.bmp", "-q"])?;
    assert!(!out.status.success());
    assert!(
        stderr(&out).len() < 400,
        "{} bytes of error",
        stderr(&out).len()
    );
    assert!(stderr(&out).contains("more characters"), "{}", stderr(&out));
    Ok(())
}

#[test]
fn an_output_folder_that_takes_no_file_fails_before_rendering() -> TestResult {
    // /proc exists but takes no new file, even for root (permission bits would not stop root).
    let dir = scene_dir(CONFIG, DATA)?;
    let out = render(dir.path(), &["-o", "/proc/strahl-out.bmp"])?;
    assert!(!out.status.success());
    let err = stderr(&out);
    assert!(err.contains("takes no new file"), "{err}");
    assert!(!err.contains("rendered"), "{err}");
    Ok(())
}

#[test]
fn a_closed_stderr_or_stdout_never_ends_a_render() -> TestResult {
    // `2>&-` and `>&-`: the progress bar and the summary have nowhere to go.
    let dir = scene_dir(CONFIG, DATA)?;
    let bin = env!("CARGO_BIN_EXE_strahl");
    for close in ["2>&-", ">&-", ">&- 2>&-"] {
        let status = Command::new("sh")
            .arg("-c")
            .arg(format!("'{bin}' render scene.cfg -o closed.bmp {close}"))
            .current_dir(dir.path())
            .status()?;
        assert!(status.success(), "{close}: {status}");
        assert!(dir.path().join("closed.bmp").exists(), "{close}");
        std::fs::remove_file(dir.path().join("closed.bmp"))?;
    }
    Ok(())
}

#[test]
fn slow_lines_asked_together_show_the_master_their_progress() -> TestResult {
    // The demo room, 64 lines asked of the one local worker in a single request, each line
    // tens of milliseconds (16 × 16 samples a pixel), the worker declared hung after a second
    // of silence: the whole request takes seconds, so the worker must send its lines
    // as it goes (it holds answers back for at most 50 ms, then sends them with the next
    // line), or the master drops it and no image is written. (With a quarter of a second, a
    // line of this debug build on a busy two-core machine running the other tests took longer
    // than that once: lost after 2 of 64 lines.)
    let dir = tempfile::tempdir()?;
    let room = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/room/raytracer.cfg");
    let out = dir.path().join("slow.bmp");
    let args = [
        "render",
        room.to_str().ok_or("a UTF-8 path")?,
        "-w",
        "512",
        "-h",
        "64",
        "-m",
        "16",
        "--workers",
        "1",
        "--lines-per-request",
        "64",
        "--worker-timeout",
        "1",
        "-o",
        out.to_str().ok_or("a UTF-8 path")?,
        "--quiet",
    ];
    let started = std::time::Instant::now();
    let r = strahl(dir.path(), &args)?;
    assert_success(&r);
    assert!(out.exists(), "no image:\n{}", stderr(&r));
    // The request took longer than the worker timeout (3.3 s on the machine this was written
    // on), so the test says something.
    assert!(
        started.elapsed() > std::time::Duration::from_millis(1500),
        "the render took only {:?}",
        started.elapsed()
    );
    Ok(())
}
