//! The live view end to end in headless Chromium: `strahl render --view` fills the page's
//! canvas with exactly the pixels of the written image while it renders, and `strahl view`'s
//! form starts, stops and resumes renders whose images and statistics follow the form.
//! Skipped, with the reason printed, only where Chromium is not installed (`.ci/setup`
//! installs it); `STRAHL_REQUIRE_BROWSER=1` (set by `.ci/run`) turns the skip into a failure.

use crate::browser;
use crate::support;

use browser::Browser;
use std::error::Error;
use std::path::Path;
use std::time::Duration;
use support::{room_config, Proc, TestResult};

/// How long a page may take to show a finished render.
const PAGE_TIMEOUT: Duration = Duration::from_secs(90);

/// The browser, or `None` (with the reason printed) where the tests cannot run.
fn browser() -> Result<Option<Browser>, Box<dyn Error>> {
    if let Some(why) = browser::missing() {
        if std::env::var_os("STRAHL_REQUIRE_BROWSER").is_some_and(|v| v == "1") {
            return Err(format!("STRAHL_REQUIRE_BROWSER=1 but {why}").into());
        }
        eprintln!("SKIPPED: {why}");
        return Ok(None);
    }
    Ok(Some(Browser::start()?))
}

/// The URL a `strahl` process printed as `view: URL`.
fn view_url(p: &Proc) -> Result<String, Box<dyn Error>> {
    let (found, text) = p.wait_stderr(Duration::from_secs(30), |t| t.contains("view: http"));
    if !found {
        return Err(format!("`{}` printed no view URL:\n{text}", p.what).into());
    }
    let at = text.find("view: http").ok_or("no URL")? + "view: ".len();
    Ok(text[at..]
        .split_whitespace()
        .next()
        .ok_or("no URL")?
        .to_string())
}

/// The address a listening master printed: `listening for workers on ADDR`.
fn workers_address(p: &Proc) -> Result<String, Box<dyn Error>> {
    const MARK: &str = "listening for workers on ";
    let (found, text) = p.wait_stderr(Duration::from_secs(30), |t| t.contains(MARK));
    let line = text.lines().find(|l| l.contains(MARK));
    match (found, line) {
        (true, Some(line)) => Ok(line.rsplit(' ').next().ok_or("no address")?.to_string()),
        _ => Err(format!("`{}` printed no address for workers:\n{text}", p.what).into()),
    }
}

/// The 8-bit RGB pixels of the image file at `path`.
fn file_rgb(path: &Path) -> Result<(u32, u32, Vec<u8>), Box<dyn Error>> {
    let img = image::open(path)?.to_rgb8();
    Ok((img.width(), img.height(), img.into_raw()))
}

/// Fails unless the page's canvas holds exactly the pixels of the image at `path`.
fn assert_canvas_is_file(b: &Browser, path: &Path) -> TestResult {
    let (cw, ch, canvas) = b.canvas_rgb()?;
    let (fw, fh, file) = file_rgb(path)?;
    assert_eq!((cw, ch), (fw, fh), "canvas size against the image's");
    let differing = canvas.iter().zip(&file).filter(|(a, b)| a != b).count();
    assert_eq!(
        differing,
        0,
        "{differing} channel values of the canvas differ from {}",
        path.display()
    );
    Ok(())
}

/// Fails unless `bytes` are those of the file at `path` (`what` names the bytes).
fn assert_same_file(bytes: &[u8], path: &Path, what: &str) {
    let file = std::fs::read(path).unwrap_or_default();
    let differing = bytes.iter().zip(&file).filter(|(a, b)| a != b).count();
    assert!(
        bytes.len() == file.len() && differing == 0,
        "{what}: {} bytes against {} in {}, {differing} differ",
        bytes.len(),
        file.len(),
        path.display()
    );
}

/// Waits until the page says the render `run` is done with every line drawn.
fn wait_done(b: &Browser, run: u64) -> TestResult {
    b.wait_for(
        &format!(
            "const s = window.strahl; return !!(s && s.run >= {run} && s.status && s.status.state === 'done'
                && s.progress && s.progress.done === s.progress.total && s.linesDrawn > 0);"
        ),
        PAGE_TIMEOUT,
    )
}

#[test]
fn render_view_shows_the_image_as_it_fills_and_the_canvas_equals_the_file() -> TestResult {
    let Some(b) = browser()? else { return Ok(()) };
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("room.bmp");
    // The master waits for a worker to dial in, so the page connects before any line is
    // rendered however slow the browser is to start; the worker is started once the page has
    // seen the render unfinished.
    let args = support::render_args(
        support::LARGE,
        &out,
        &[
            "-m",
            "2",
            "--workers",
            "0",
            "--listen",
            "127.0.0.1:0",
            "--view",
            "127.0.0.1:0",
        ],
    );
    let mut p = Proc::spawn(&args)?;
    let url = view_url(&p)?;
    let master = workers_address(&p)?;
    b.open(&url)?;
    // Progress below the total, seen by the page before the worker joins, and again with some
    // lines in: it watched the render fill in.
    b.run("window.partial = false; window.midway = false; setInterval(() => { const p = window.strahl.progress; if (p && p.done < p.total) { window.partial = true; if (p.done > 0) window.midway = true; } }, 20); return true;")?;
    b.wait_for("return window.partial === true;", PAGE_TIMEOUT)?;
    let _worker = Proc::spawn(&["worker", "--connect", &master, "--threads", "1"])?;
    wait_done(&b, 1)?;
    assert_canvas_is_file(&b, &out)?;
    let seen = b.run("return [window.midway, document.querySelectorAll('#worker-rows tr').length, document.getElementById('lines').textContent, document.getElementById('download').hidden];")?;
    assert_eq!(
        seen[0],
        serde_json::json!(true),
        "the page never saw the render part-way: {seen}"
    );
    assert_eq!(
        seen[1],
        serde_json::json!(1),
        "one worker row in the table: {seen}"
    );
    assert_eq!(seen[2], serde_json::json!("960 / 960"), "{seen}");
    assert_eq!(
        seen[3],
        serde_json::json!(false),
        "the download link shows: {seen}"
    );
    // The process keeps serving, and says so.
    let (said, text) = p.wait_stderr(Duration::from_secs(30), |t| t.contains("until Ctrl-C"));
    assert!(said, "no word that the view keeps serving:\n{text}");
    assert!(p.is_running(), "the render with --view exited:\n{text}");
    // The image offered for download is the file.
    let download = ureq::get(&format!("{url}image")).call()?;
    let mut bytes = Vec::new();
    std::io::Read::read_to_end(&mut download.into_reader(), &mut bytes)?;
    assert_same_file(&bytes, &out, "the download");
    Ok(())
}

/// `render --view --region`, with and without adaptive multisampling (which renders every
/// line): the page's canvas is the written region, and its progress reaches the lines the
/// render delivered (all 240 lines with adaptive multisampling, the region's 120 without).
#[test]
fn render_view_with_a_region_shows_the_region_and_counts_its_lines() -> TestResult {
    let Some(b) = browser()? else { return Ok(()) };
    let dir = tempfile::tempdir()?;
    for (run, extra, lines) in [
        (1, &[][..], "120 / 120"),
        (2, &["-m", "2", "--aa-threshold", "0.1"][..], "240 / 240"),
    ] {
        let out = dir.path().join(format!("region-{run}.bmp"));
        let mut flags = vec!["--region", "40,60,200,180", "--workers", "1"];
        flags.extend_from_slice(&["--view", "127.0.0.1:0"]);
        flags.extend_from_slice(extra);
        let size = support::Size {
            width: 320,
            height: 240,
        };
        let p = Proc::spawn(&support::render_args(size, &out, &flags))?;
        let url = view_url(&p)?;
        let (said, text) = p.wait_stderr(Duration::from_secs(60), |t| t.contains("until Ctrl-C"));
        assert!(said, "the render did not finish:\n{text}");
        b.open(&url)?;
        wait_done(&b, 1)?;
        assert_canvas_is_file(&b, &out)?;
        let seen = b.run("return document.getElementById('lines').textContent;")?;
        assert_eq!(seen, serde_json::json!(lines), "{extra:?}");
    }
    Ok(())
}

#[test]
fn view_form_starts_stops_and_resumes_renders_that_follow_its_settings() -> TestResult {
    let Some(b) = browser()? else { return Ok(()) };
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("room.bmp");
    let scene = room_config().display().to_string();
    let out_arg = out.display().to_string();
    let p = Proc::spawn(&["view", &scene, "127.0.0.1:0", "-o", &out_arg])?;
    let url = view_url(&p)?;
    b.open(&url)?;
    b.wait_for(
        "return !!(window.strahl && window.strahl.settings);",
        PAGE_TIMEOUT,
    )?;
    let form = b.run("return window.strahl.settings;")?;
    assert_eq!(
        form["shadows"],
        serde_json::json!(true),
        "the room has shadows on: {form}"
    );
    assert_eq!(form["width"], serde_json::json!(640), "{form}");

    // The scene's own settings first, at a smaller size.
    b.run("document.getElementById('width').value = 160; document.getElementById('height').value = 120; document.getElementById('workers').value = 2; return true;")?;
    b.click("#start")?;
    wait_done(&b, 1)?;
    let shadow_rays = |b: &Browser| -> Result<u64, Box<dyn Error>> {
        let text = b.run("return document.getElementById('rays-shadow').textContent;")?;
        Ok(text.as_str().ok_or("no text")?.parse()?)
    };
    assert!(
        shadow_rays(&b)? > 0,
        "a render with shadows traces shadow rays"
    );
    assert_canvas_is_file(&b, &out)?;

    // Shadows off in the form: the new image is the command line's with --shadows off.
    b.click("#shadows")?;
    b.click("#start")?;
    wait_done(&b, 2)?;
    assert_eq!(
        shadow_rays(&b)?,
        0,
        "the page's statistics show no shadow rays"
    );
    assert_canvas_is_file(&b, &out)?;
    let reference = dir.path().join("reference.bmp");
    let cli = support::finish(Proc::spawn(&[
        "render",
        &scene,
        "-o",
        &reference.display().to_string(),
        "-w",
        "160",
        "-h",
        "120",
        "--shadows",
        "off",
        "--workers",
        "1",
        "-q",
    ])?)?;
    cli.assert_success();
    assert_same_file(&std::fs::read(&out)?, &reference, "the page's render");

    // A larger render stopped from the page and resumed gives the uninterrupted image.
    b.run("document.getElementById('width').value = 640; document.getElementById('height').value = 480; document.getElementById('multisample').value = 2; document.getElementById('workers').value = 1; return true;")?;
    b.click("#start")?;
    b.wait_for(
        "const s = window.strahl; return s.run >= 3 && s.progress && s.progress.done > 0;",
        PAGE_TIMEOUT,
    )?;
    b.click("#stop")?;
    b.wait_for(
        "const s = window.strahl; return s.status.state === 'stopped';",
        PAGE_TIMEOUT,
    )?;
    let stopped = b.run("return window.strahl.status;")?;
    let finished = stopped["finished"].as_u64().ok_or("no finished count")?;
    assert!(
        finished > 0 && finished < 480,
        "stopped part-way: {stopped}"
    );
    b.click("#resume")?;
    wait_done(&b, 4)?;
    assert_canvas_is_file(&b, &out)?;
    let full = dir.path().join("full.bmp");
    let cli = support::finish(Proc::spawn(&[
        "render",
        &scene,
        "-o",
        &full.display().to_string(),
        "-m",
        "2",
        "--shadows",
        "off",
        "--workers",
        "1",
        "-q",
    ])?)?;
    cli.assert_success();
    assert_same_file(&std::fs::read(&out)?, &full, "the resumed render");
    Ok(())
}

#[test]
fn a_view_beyond_this_machine_needs_a_secret_and_writes_nothing_without() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("room.bmp");
    let args = support::render_args(support::SMALL, &out, &["--view", "0.0.0.0:0"]);
    let r = support::finish(Proc::spawn(&args)?)?;
    assert!(!r.status.success(), "served beyond loopback:\n{}", r.stderr);
    assert!(
        r.stderr
            .contains("--view 0.0.0.0:0: without a shared secret"),
        "{}",
        r.stderr
    );
    assert!(!out.exists(), "no image from a refused render");
    let args = support::render_args(support::SMALL, &out, &["--view", "room.cfg"]);
    let r = support::finish(Proc::spawn(&args)?)?;
    assert_eq!(r.status.code(), Some(2), "a bad address is a usage error");
    assert!(
        r.stderr.contains("'room.cfg'") && r.stderr.contains("expected PORT or HOST:PORT"),
        "{}",
        r.stderr
    );
    let r = support::finish(Proc::spawn(&[
        "view",
        "/nonexistent/scene.fart",
        "127.0.0.1:0",
    ])?)?;
    assert!(!r.status.success());
    assert!(r.stderr.contains("/nonexistent/scene.fart"), "{}", r.stderr);
    Ok(())
}
