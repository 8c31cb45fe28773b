//! End-to-end tests of the shared secret: `strahl worker` and `strahl render` processes on
//! loopback with `--secret-file` (or `STRAHL_SECRET`), the same secret, another one, or none on
//! one side; and the rule that without a secret nothing listens beyond this machine unless
//! `--insecure`. Each refusal must be clear on the side refused and logged on the side that
//! refuses, and neither side may hang or crash.

use crate::support::*;
use std::error::Error;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// Writes `secret` (with a line break, as an editor would) to `dir/name`.
fn secret_file(dir: &Path, name: &str, secret: &str) -> Result<PathBuf, Box<dyn Error>> {
    let path = dir.join(name);
    std::fs::write(&path, format!("{secret}\n"))?;
    Ok(path)
}

/// A listening worker with `extra` options.
fn worker(name: &str, extra: &[&str]) -> Result<(Proc, String), Box<dyn Error>> {
    Proc::listening_worker_with(name, extra)
}

#[test]
fn workers_and_master_with_the_same_secret_render_the_reference_image() -> TestResult {
    let dir = tempfile::tempdir()?;
    let key = secret_file(dir.path(), "key", "correct horse battery staple")?;
    let key_arg = key.display().to_string();
    let (w, a) = worker("guarded", &["--secret-file", &key_arg])?;
    assert!(
        w.stderr().contains("masters must prove the shared secret"),
        "{}",
        w.stderr()
    );
    // The master's secret from the environment, the worker's from a file.
    let out = dir.path().join("out.bmp");
    let args = render_args(SMALL, &out, &["--workers", "0", "--worker", &a]);
    let r = finish(Proc::spawn_env(
        &args,
        &[("STRAHL_SECRET", "correct horse battery staple")],
    )?)?;
    r.assert_success();
    assert_reference_image(&out, SMALL)?;
    assert_ok(&r, "guarded")?;
    Ok(())
}

#[test]
fn a_master_with_another_secret_is_refused_and_told_why() -> TestResult {
    let dir = tempfile::tempdir()?;
    let key = secret_file(dir.path(), "key", "the worker's secret, long")?;
    let other = secret_file(dir.path(), "other", "the master's other secret")?;
    let (w, a) = worker("guarded", &["--secret-file", &key.display().to_string()])?;
    let out = dir.path().join("out.bmp");
    let r = render(
        SMALL,
        &out,
        &[
            "--workers",
            "0",
            "--worker",
            &a,
            "--secret-file",
            &other.display().to_string(),
        ],
    )?;
    assert!(!r.status.success(), "{}", r.stderr);
    assert!(!out.exists(), "no image is written");
    assert!(
        r.stderr.contains("its proof of the shared secret is wrong"),
        "the master says why:\n{}",
        r.stderr
    );
    let (logged, text) = w.wait_stderr(Duration::from_secs(20), |t| {
        t.contains("the master rejected this worker")
    });
    assert!(logged, "the worker logs the rejection:\n{text}");
    // The worker is still there for a master with the right secret.
    let r = render(
        SMALL,
        &out,
        &[
            "--workers",
            "0",
            "--worker",
            &a,
            "--secret-file",
            &key.display().to_string(),
        ],
    )?;
    r.assert_success();
    assert_reference_image(&out, SMALL)?;
    Ok(())
}

#[test]
fn a_secret_on_one_side_only_is_refused_on_both() -> TestResult {
    let dir = tempfile::tempdir()?;
    let key = secret_file(dir.path(), "key", "a secret only one side has")?;
    let key_arg = key.display().to_string();
    let out = dir.path().join("out.bmp");

    // The worker has a secret, the master none: the master rejects it (it cannot prove the
    // secret) and says what to do; the worker logs it.
    let (w, a) = worker("guarded", &["--secret-file", &key_arg])?;
    let r = render(SMALL, &out, &["--workers", "0", "--worker", &a])?;
    assert!(!r.status.success(), "{}", r.stderr);
    assert!(
        r.stderr.contains("it requires a shared secret"),
        "{}",
        r.stderr
    );
    let (logged, text) = w.wait_stderr(Duration::from_secs(20), |t| {
        t.contains("requires a shared secret and the master has none")
    });
    assert!(logged, "{text}");

    // The master has a secret, the worker none.
    let (open, b) = worker("open", &[])?;
    let r = render(
        SMALL,
        &out,
        &["--workers", "0", "--worker", &b, "--secret-file", &key_arg],
    )?;
    assert!(!r.status.success(), "{}", r.stderr);
    assert!(r.stderr.contains("it has no shared secret"), "{}", r.stderr);
    let (logged, text) = open.wait_stderr(Duration::from_secs(20), |t| {
        t.contains("start this worker with --secret-file")
    });
    assert!(logged, "{text}");
    Ok(())
}

#[test]
fn without_a_secret_nothing_listens_beyond_this_machine() -> TestResult {
    // A worker on all interfaces without a secret: refused, with what to do.
    let mut p = Proc::spawn(&["worker", "--listen", "0.0.0.0:0"])?;
    let status = p.wait(Duration::from_secs(20))?;
    assert!(!status.success());
    let err = p.stderr();
    assert!(
        err.contains("--secret-file") && err.contains("--insecure"),
        "{err}"
    );
    // With --insecure it listens, and warns.
    let p = Proc::spawn(&["worker", "--listen", "0.0.0.0:0", "--insecure"])?;
    let address = p.listen_address()?;
    assert!(address.starts_with("0.0.0.0:"), "{address}");
    assert!(p.stderr().contains("warning:"), "{}", p.stderr());
    // A master that listens for workers: the same rule.
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let r = render(SMALL, &out, &["--workers", "0", "--listen", "0.0.0.0:0"])?;
    assert!(!r.status.success());
    assert!(r.stderr.contains("--insecure"), "{}", r.stderr);
    // A secret too short is refused before anything starts.
    let short = secret_file(dir.path(), "short", "short")?;
    let r = render(
        SMALL,
        &out,
        &["--secret-file", &short.display().to_string()],
    )?;
    assert!(!r.status.success());
    assert!(r.stderr.contains("at least 16"), "{}", r.stderr);
    Ok(())
}
