//! A `strahl worker` started without options renders on every CPU of its machine. This test has
//! a binary of its own so that no other test of the same run competes for the CPUs it measures
//! (cargo runs test binaries one after another).

mod support;

use std::thread;
use std::time::{Duration, Instant};
use support::*;

#[test]
fn a_worker_started_without_options_keeps_every_core_busy() -> TestResult {
    // `strahl worker` with no --threads renders on every CPU: its CPU time during a render is
    // near the number of CPUs (at most 2 counted) times the wall time. The machine is shared,
    // so one of three renders has to show it.
    let cpus = thread::available_parallelism().map_or(1, |n| n.get());
    let (worker, address) = Proc::listening_worker("all-cores")?;
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let tick = Duration::from_millis(10);
    let mut ratios = Vec::new();
    for _ in 0..3 {
        let before = cpu_ticks(worker.pid()).ok_or("no /proc/PID/stat")?;
        let start = Instant::now();
        let r = render(LARGE, &out, &["--workers", "0", "--worker", &address])?;
        let wall = start.elapsed();
        let after = cpu_ticks(worker.pid()).ok_or("no /proc/PID/stat")?;
        r.assert_success();
        let rows = table(&r.stderr);
        let w = row(&rows, "all-cores", &r.stderr)?;
        assert_eq!(w.threads as usize, cpus, "{}", r.stderr);
        let cpu = tick * (after - before) as u32;
        ratios.push(cpu.as_secs_f64() / wall.as_secs_f64());
        if cpus < 2 || ratios.last().is_some_and(|&q| q >= 1.4) {
            break;
        }
    }
    let want = if cpus >= 2 { 1.4 } else { 0.5 };
    assert!(
        ratios.iter().any(|&q| q >= want),
        "CPU time / wall time of the worker: {ratios:?}, {cpus} CPUs"
    );
    Ok(())
}
