//! Addresses as users type them, what listening processes print, and workers named once:
//! `PORT` and `:PORT` listen on this machine without a secret (and say so), a listening master
//! prints where workers find it, a bad address is a usage error (exit 2) with examples, a
//! worker named twice is used once, and two workers with one name get rows that tell them apart.

use crate::support::{
    assert_reference_image, finish, render_args, row, table, Proc, TestResult, SMALL,
};
use std::time::Duration;

#[test]
fn a_port_alone_listens_on_this_machine_and_a_master_says_where_it_listens() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("room.bmp");
    // The master listens on a free port of this machine and prints it.
    let master = Proc::spawn(&render_args(
        SMALL,
        &out,
        &["--listen", "0", "--worker-timeout", "30"],
    ))?;
    let (found, text) = master.wait_stderr(Duration::from_secs(30), |t| {
        t.contains("listening for workers on ")
    });
    assert!(found, "no listening address:\n{text}");
    assert!(text.contains("listens on this machine only"), "{text}");
    let line = text
        .lines()
        .find(|l| l.contains("listening for workers on "))
        .ok_or("no line")?;
    let address = line.rsplit(' ').next().ok_or("no address")?.to_string();
    assert!(
        address.starts_with("127.0.0.1:") && !address.ends_with(":0"),
        "{address}"
    );
    let port = address.rsplit(':').next().ok_or("no port")?;
    // The worker dials it by port alone, and says whom it dials.
    let worker = Proc::spawn(&["worker", "--connect", port, "--name", "dialler"])?;
    let r = finish(master)?;
    r.assert_success();
    assert_reference_image(&out, SMALL)?;
    let (said, text) = worker.wait_stderr(Duration::from_secs(10), |t| t.contains("dialling"));
    assert!(
        said && text.contains(&format!("localhost:{port}")),
        "{text}"
    );
    let rows = table(&r.stderr);
    assert_eq!(row(&rows, "dialler", &r.stderr)?.lines, SMALL.height);
    Ok(())
}

#[test]
fn bad_addresses_are_usage_errors_with_examples() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("x.bmp");
    for (flag, value) in [
        ("--worker", "a b"),
        ("--worker", "node1:99999"),
        ("--listen", "::1"),
        ("--worker", "[::1"),
        ("--view", "scene.nff"),
    ] {
        let r = finish(Proc::spawn(&render_args(SMALL, &out, &[flag, value]))?)?;
        assert_eq!(r.status.code(), Some(2), "{flag} {value}: {}", r.stderr);
        assert!(
            r.stderr.contains("for example"),
            "{flag} {value}: {}",
            r.stderr
        );
        assert!(r.stderr.contains(value), "{flag} {value}: {}", r.stderr);
    }
    for args in [["worker", "--listen", "x:y"], ["worker", "--connect", "0"]] {
        let r = finish(Proc::spawn(&args)?)?;
        assert_eq!(r.status.code(), Some(2), "{args:?}: {}", r.stderr);
        assert!(r.stderr.contains("for example"), "{}", r.stderr);
    }
    assert!(!out.exists());
    Ok(())
}

#[test]
fn a_worker_named_twice_is_used_once_and_namesakes_are_told_apart() -> TestResult {
    let (_a, a) = Proc::listening_worker("twin")?;
    let (_b, b) = Proc::listening_worker("twin")?;
    let port_a = a.rsplit(':').next().ok_or("no port")?.to_string();
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("room.bmp");
    let same_a = format!("localhost:{port_a}");
    let r = finish(Proc::spawn(&render_args(
        SMALL,
        &out,
        &[
            "--worker",
            &a,
            "--worker",
            &same_a,
            "--worker",
            &b,
            "--workers",
            "0",
        ],
    ))?)?;
    r.assert_success();
    assert_reference_image(&out, SMALL)?;
    assert!(
        r.stderr
            .contains(&format!("the worker at localhost:{port_a} is named twice")),
        "{}",
        r.stderr
    );
    let rows = table(&r.stderr);
    let names: Vec<&str> = rows.iter().map(|r| r.name.as_str()).collect();
    assert_eq!(
        names.len(),
        2,
        "one row per worker: {names:?}\n{}",
        r.stderr
    );
    assert!(names.iter().all(|n| n.starts_with("twin@")), "{names:?}");
    assert_ne!(names[0], names[1]);
    Ok(())
}

#[test]
fn quiet_failures_still_say_why() -> TestResult {
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("x.bmp");
    let r = finish(Proc::spawn(&render_args(
        SMALL,
        &out,
        &["-q", "--worker", "127.0.0.1:1"],
    ))?)?;
    assert_eq!(r.status.code(), Some(1));
    assert!(
        r.stderr.contains("cannot reach worker 127.0.0.1:1:"),
        "the reason is in the error: {}",
        r.stderr
    );
    let r = finish(Proc::spawn(&render_args(
        SMALL,
        &out,
        &["-q", "--listen", "0", "--worker-timeout", "0.5"],
    ))?)?;
    assert_eq!(r.status.code(), Some(1));
    assert!(
        r.stderr.contains("error: no worker joined at 127.0.0.1:"),
        "{}",
        r.stderr
    );
    assert!(
        r.stderr.contains("strahl worker --connect 127.0.0.1:"),
        "{}",
        r.stderr
    );
    assert!(!out.exists());
    Ok(())
}
