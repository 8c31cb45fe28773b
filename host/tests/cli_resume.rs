//! Nothing lost: a render killed (SIGKILL) or interrupted (Ctrl-C, SIGINT) keeps the lines it
//! finished in `OUTPUT.checkpoint`, `--resume` renders only the others, and the image is byte
//! for byte the one an uninterrupted render gives. A checkpoint of other settings is refused,
//! a fresh render does not overwrite a checkpoint, and no temporary file is left behind.

mod support;

use std::error::Error;
use std::path::Path;
use std::process::Command;
use std::thread;
use std::time::{Duration, Instant};
use support::*;

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
