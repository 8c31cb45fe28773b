//! Nothing lost: a render killed (SIGKILL) or interrupted (Ctrl-C, SIGINT) keeps the lines it
//! finished in `OUTPUT.checkpoint`, `--resume` renders only the others, and the image is byte
//! for byte the one an uninterrupted render gives. A checkpoint of other settings is refused,
//! a fresh render does not overwrite a checkpoint, and no temporary file is left behind. A
//! checkpoint resumed with a region gives the region's lines it holds.
//! SIGTERM stops a render as Ctrl-C does; a signal while the image is written lets it finish.

use crate::support::*;
use std::error::Error;
use std::path::Path;
use std::process::Command;
use std::thread;
use std::time::{Duration, Instant};

/// The files in `dir`, sorted.
fn files(dir: &Path) -> Result<Vec<String>, Box<dyn Error>> {
    let mut v: Vec<String> = std::fs::read_dir(dir)?
        .map(|e| e.map(|e| e.file_name().to_string_lossy().into_owned()))
        .collect::<Result<_, _>>()?;
    v.sort();
    Ok(v)
}

/// Starts a LARGE render to `out` on one in-process worker and waits until its checkpoint
/// holds some results (it grows past its header).
fn start_and_wait_for_results(out: &Path) -> Result<Proc, Box<dyn Error>> {
    start_with(out, &["--workers", "1"])
}

/// [`start_and_wait_for_results`] with other options.
fn start_with(out: &Path, extra: &[&str]) -> Result<Proc, Box<dyn Error>> {
    let mut p = Proc::spawn(&render_args(LARGE, out, extra))?;
    let checkpoint = format!("{}.checkpoint", out.display());
    let start = Instant::now();
    loop {
        let len = std::fs::metadata(&checkpoint).map_or(0, |m| m.len());
        if len > 64 * 1024 {
            return Ok(p);
        }
        if !p.is_running() || start.elapsed() > Duration::from_secs(60) {
            return Err(format!("no checkpoint grew:\n{}", p.stderr()).into());
        }
        thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn a_killed_render_resumes_to_the_same_image() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let mut p = start_and_wait_for_results(&out)?;
    p.kill();
    assert!(!out.exists(), "no image after the kill");
    assert_eq!(
        files(dir.path())?,
        ["out.bmp.checkpoint"],
        "only the checkpoint"
    );

    // A render that does not say --resume does not overwrite the checkpoint.
    let r = render(LARGE, &out, &["--workers", "1"])?;
    assert!(!r.status.success());
    assert!(r.stderr.contains("--resume"), "{}", r.stderr);
    // Nor does a resume with other settings use it.
    let r = render(
        LARGE,
        &out,
        &["--workers", "1", "--resume", "--shadows", "off"],
    )?;
    assert!(!r.status.success());
    assert!(
        r.stderr.contains("another scene or other settings"),
        "{}",
        r.stderr
    );

    let r = render(LARGE, &out, &["--workers", "2", "--resume"])?;
    r.assert_success();
    assert!(r.stderr.contains("resuming:"), "{}", r.stderr);
    assert_reference_image(&out, LARGE)?;
    assert_eq!(files(dir.path())?, ["out.bmp"], "the checkpoint is gone");
    // The rays reported are those of the whole image (1280×960), not only the lines rendered
    // now.
    assert!(
        r.stderr.contains("rays:    1,228,800 primary"),
        "{}",
        r.stderr
    );
    Ok(())
}

#[test]
fn ctrl_c_keeps_the_checkpoint_and_prints_the_command_that_resumes() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let mut p = start_and_wait_for_results(&out)?;
    let status = Command::new("kill")
        .args(["-INT", &p.pid().to_string()])
        .status()?;
    assert!(status.success());
    let status = p.wait(Duration::from_secs(30))?;
    assert!(!status.success(), "an interrupted render fails");
    let err = p.stderr();
    assert!(err.contains("interrupted"), "{err}");
    assert!(err.contains("--resume"), "the command that resumes:\n{err}");
    assert_eq!(files(dir.path())?, ["out.bmp.checkpoint"], "{err}");
    // Resuming twice in a row is fine: the second run finds no checkpoint and says so.
    let r = render(LARGE, &out, &["--workers", "1", "--resume"])?;
    r.assert_success();
    assert_reference_image(&out, LARGE)?;
    let r = render(LARGE, &out, &["--workers", "1", "--resume"])?;
    assert!(!r.status.success());
    assert!(
        r.stderr.contains("no checkpoint to resume from"),
        "{}",
        r.stderr
    );
    Ok(())
}

/// Sends `signal` to process `pid` with `kill`.
fn signal(signal: &str, pid: u32) -> TestResult {
    let status = Command::new("kill")
        .args([&format!("-{signal}"), &pid.to_string()])
        .status()?;
    assert!(status.success(), "kill -{signal} {pid}");
    Ok(())
}

#[test]
fn sigterm_stops_a_render_as_ctrl_c_does() -> TestResult {
    // `kill` and Slurm's `scancel` send SIGTERM: the render stops as Ctrl-C stops it.
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let mut p = start_and_wait_for_results(&out)?;
    signal("TERM", p.pid())?;
    let status = p.wait(Duration::from_secs(30))?;
    let err = p.stderr();
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(err.contains("interrupted"), "{err}");
    assert!(err.contains("--resume"), "the command that resumes:\n{err}");
    assert_eq!(files(dir.path())?, ["out.bmp.checkpoint"], "{err}");
    Ok(())
}

#[test]
fn a_signal_while_the_image_is_written_lets_the_write_finish() -> TestResult {
    // One sphere at 4000×4000: a 48 MB BMP, written in about a tenth of a second, long enough
    // to see its temporary file grow and signal the render then.
    let dir = tempfile::tempdir()?;
    let scene = dir.path().join("one.nff");
    std::fs::write(
        &scene,
        "v\nfrom 0 0 -10\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 64 64\n\
         b 0.2 0.3 0.5\nl 5 5 -5\nf 1 0 0 0.8 0.2 10 0 1\ns 0 0 0 2\n",
    )?;
    let s = scene.display().to_string();
    let args = |out: &Path| {
        let o = out.display().to_string();
        ["render", &s, "-o", &o, "-w", "4000", "-h", "4000", "-q"].map(String::from)
    };
    let reference = dir.path().join("reference.bmp");
    finish(Proc::spawn(&args(&reference))?)?.assert_success();
    let expected = std::fs::read(&reference)?;
    std::fs::remove_file(&reference)?;
    for name in ["INT", "TERM", "HUP"] {
        let out = dir.path().join("out.bmp");
        let _ = std::fs::remove_file(&out);
        let mut p = Proc::spawn(&args(&out))?;
        wait_for_the_write(&mut p, dir.path())?;
        signal(name, p.pid())?;
        let r = finish(p)?;
        r.assert_success();
        assert!(
            std::fs::read(&out)? == expected,
            "SIG{name}: the image differs"
        );
        assert_eq!(files(dir.path())?, ["one.nff", "out.bmp"], "SIG{name}");
    }
    Ok(())
}

/// Waits until a temporary file of the image in `dir` holds bytes (the render is writing it).
fn wait_for_the_write(p: &mut Proc, dir: &Path) -> TestResult {
    let start = Instant::now();
    while start.elapsed() < RENDER_TIMEOUT {
        for entry in std::fs::read_dir(dir)? {
            let entry = entry?;
            let name = entry.file_name().to_string_lossy().into_owned();
            // A vanished file is fine: the write was done before it was looked at.
            let len = entry.metadata().map_or(0, |m| m.len());
            if name.starts_with(".strahl-") && name.ends_with(".tmp") && len > 0 {
                return Ok(());
            }
        }
        if !p.is_running() {
            return Err(format!("the write was not seen before the end:\n{}", p.stderr()).into());
        }
        thread::sleep(Duration::from_millis(1));
    }
    Err("no write within the render time-out".into())
}

#[test]
fn a_checkpoint_resumed_with_a_region_uses_the_lines_they_share() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let mut p = start_and_wait_for_results(&out)?;
    p.kill();
    // The checkpoint holds the first lines (over 64 KiB of them, 7.5 KiB each): the region
    // leaves the first four out and takes the others.
    let r = render(
        LARGE,
        &out,
        &["--workers", "2", "--resume", "--region", "100,4,400,700"],
    )?;
    r.assert_success();
    assert!(r.stderr.contains("resuming:"), "{}", r.stderr);
    let want = image::load_from_memory(&reference(LARGE)?)?.to_rgb8();
    let got = image::open(&out)?.to_rgb8();
    assert_eq!(got.dimensions(), (300, 696));
    for (x, y, p) in got.enumerate_pixels() {
        assert_eq!(p, want.get_pixel(x + 100, y + 4), "({x}, {y})");
    }
    assert_eq!(files(dir.path())?, ["out.bmp"], "the checkpoint is gone");
    Ok(())
}

#[test]
fn an_adaptive_render_resumes_to_the_same_image() -> TestResult {
    // Adaptive multisampling: the second passes depend on the neighbours' first passes, which
    // the checkpoint replays. The reference is an uninterrupted render with the same options.
    let dir = tempfile::tempdir()?;
    let adaptive = ["-m", "2", "--aa-threshold", "0.05"];
    let whole = dir.path().join("whole.bmp");
    let mut args = vec!["--workers", "1"];
    args.extend_from_slice(&adaptive);
    render(LARGE, &whole, &args)?.assert_success();
    let out = dir.path().join("out.bmp");
    let mut p = start_with(&out, &args)?;
    p.kill();
    args.push("--resume");
    render(LARGE, &out, &args)?.assert_success();
    assert!(
        std::fs::read(&out)? == std::fs::read(&whole)?,
        "the resumed image differs"
    );
    Ok(())
}
