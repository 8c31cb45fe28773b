//! The chaos test: one render over real TCP workers while things go wrong at once. Two workers
//! behave; one is killed with SIGKILL mid-render, one is stopped with SIGSTOP (alive, silent);
//! one peer sends garbage instead of frames; one speaks the protocol perfectly but answers with
//! wrong pixels, and the render runs with `--verify 1`. The image must be complete and byte for
//! byte the `--workers 1` image, and the table must name what happened to each worker.
//!
//! The render is [`HUGE`]: the stopped worker must stay silent for the whole `--worker-timeout`
//! while the image is still unfinished. On a smaller image the others finish its lines as
//! end-game copies before the time-out, and the stop goes unnoticed, as it should.
//!
//! The garbage sender and the liar are threads of this test behind their own TCP ports (the
//! liar runs the core's worker session with the simulated cluster's lying outbox, which changes
//! one pixel per line); the others are `strahl worker` processes.

use crate::support::*;
use embedded_io_adapters::std::FromStd;
use std::error::Error;
use std::io::{Read as _, Write as _};
use std::net::TcpListener;
use std::process::Command;
use std::thread;
use std::time::Duration;
use strahl_core::worker::{serve_with, NodeInfo, SceneCache};
use strahl_host::cluster::sim::Liar;

/// A lying worker on a loopback port: serves one master, then ends.
fn start_liar() -> Result<String, Box<dyn Error>> {
    let listener = TcpListener::bind("127.0.0.1:0")?;
    let address = listener.local_addr()?.to_string();
    thread::spawn(move || {
        let Ok((stream, _)) = listener.accept() else {
            return;
        };
        let node = NodeInfo {
            name: "liar",
            arch: "test",
            scene_memory: u64::MAX,
            threads: 1,
            secret: None,
            nonce: || [1; 32],
        };
        let mut link = FromStd::new(stream);
        let _ = serve_with(
            &mut link,
            &mut Liar::default(),
            &node,
            &mut SceneCache::new(),
        );
    });
    Ok(address)
}

/// A peer on a loopback port that answers with bytes that are no frames, forever.
fn start_garbage() -> Result<String, Box<dyn Error>> {
    let listener = TcpListener::bind("127.0.0.1:0")?;
    let address = listener.local_addr()?.to_string();
    thread::spawn(move || {
        let Ok((mut stream, _)) = listener.accept() else {
            return;
        };
        let mut buf = [0u8; 256];
        let _ = stream.read(&mut buf);
        let mut x: u32 = 0x1234_5678;
        loop {
            for b in &mut buf {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                *b = x as u8 | 1; // never the frame delimiter 0
            }
            if stream.write_all(&buf).is_err() {
                return;
            }
            thread::sleep(Duration::from_millis(5));
        }
    });
    Ok(address)
}

#[test]
fn a_render_survives_kills_a_stop_garbage_and_a_liar_under_verify() -> TestResult {
    let (_a, a) = Proc::listening_worker_with("good-a", &["--threads", "1"])?;
    let (_b, b) = Proc::listening_worker_with("good-b", &["--threads", "1"])?;
    let (mut killed, k) = Proc::listening_worker_with("killed", &["--threads", "1"])?;
    let (mut stopped, s) = Proc::listening_worker_with("stopped", &["--threads", "1"])?;
    let liar = start_liar()?;
    let garbage = start_garbage()?;
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let mut master = Proc::spawn(&render_args(
        HUGE,
        &out,
        &[
            "--workers",
            "0",
            "--verify",
            "1",
            "--worker-timeout",
            "1",
            "--worker",
            &a,
            "--worker",
            &b,
            "--worker",
            &k,
            "--worker",
            &s,
            "--worker",
            &liar,
            "--worker",
            &garbage,
        ],
    ))?;
    wait_until_rendering(&mut stopped)?;
    let status = Command::new("kill")
        .args(["-STOP", &stopped.pid().to_string()])
        .status()?;
    assert!(status.success(), "kill -STOP");
    kill_mid_render(&mut master, &mut [&mut killed])?;
    let r = finish(master)?;
    r.assert_success();
    assert_reference_image(&out, HUGE)?;
    assert_ok(&r, "good-a")?;
    assert_ok(&r, "good-b")?;
    assert_lost(&r, "killed")?;
    let stop = assert_lost(&r, "stopped")?;
    assert!(stop.contains("no answer"), "{stop}:\n{}", r.stderr);
    let rows = table(&r.stderr);
    let lie = &row(&rows, "liar", &r.stderr)?.status;
    assert!(
        lie.contains("--verify"),
        "the liar is caught:\n{}",
        r.stderr
    );
    let junk = &row(&rows, &garbage, &r.stderr)?.status;
    assert_ne!(junk, "ok", "the garbage sender is dropped:\n{}", r.stderr);
    assert!(
        r.stderr
            .contains("results confirmed by a second worker (--verify)"),
        "{}",
        r.stderr
    );
    Ok(())
}
