//! A `strahl worker` started without options renders on every CPU of its machine. This test has
//! a binary of its own so that no other test of the same run competes for the CPUs it measures
//! (cargo runs test binaries one after another).

mod support;

use std::collections::BTreeMap;
use std::thread;
use std::time::{Duration, Instant};
use support::*;

/// Records the CPU time (clock ticks) of each thread of process `pid` into `seen` (by thread
/// id; the last value read), from `/proc`.
fn sample_threads(pid: u32, seen: &mut BTreeMap<u32, u64>) {
    let Ok(tasks) = std::fs::read_dir(format!("/proc/{pid}/task")) else {
        return;
    };
    for tid in tasks
        .filter_map(|t| t.ok())
        .filter_map(|t| t.file_name().to_str().and_then(|s| s.parse::<u32>().ok()))
    {
        let ticks = std::fs::read_to_string(format!("/proc/{pid}/task/{tid}/stat"))
            .ok()
            .and_then(|stat| {
                let fields: Vec<u64> = stat[stat.rfind(')')? + 1..]
                    .split_whitespace()
                    .skip(11)
                    .take(2)
                    .filter_map(|f| f.parse().ok())
                    .collect();
                Some(fields.iter().sum::<u64>())
            });
        if let Some(t) = ticks {
            seen.insert(tid, t);
        }
    }
}

#[test]
fn a_worker_started_without_options_keeps_every_core_busy() -> TestResult {
    // `strahl worker` with no --threads renders on every CPU. Two ways to see it:
    // - its CPU time during a render is near the number of CPUs (at most 2 counted) times the
    //   wall time, which holds when the machine is otherwise idle;
    // - its work is spread over as many render threads as CPUs, each with at least a fifth of
    //   the worker's CPU time, which holds however busy the (shared) machine is.
    // A one-thread worker fails both.
    let cpus = thread::available_parallelism().map_or(1, |n| n.get());
    let (worker, address) = Proc::listening_worker("all-cores")?;
    let dir = tempfile::tempdir()?;
    let out = dir.path().join("out.bmp");
    let tick = Duration::from_millis(10);
    let mut ratios = Vec::new();
    let mut spreads = Vec::new();
    for _ in 0..3 {
        // Each session has render threads of its own.
        let mut seen = BTreeMap::new();
        let before = cpu_ticks(worker.pid()).ok_or("no /proc/PID/stat")?;
        let start = Instant::now();
        let mut master = Proc::spawn(&render_args(
            LARGE,
            &out,
            &["--workers", "0", "--worker", &address],
        ))?;
        while master.is_running() {
            sample_threads(worker.pid(), &mut seen);
            thread::sleep(Duration::from_millis(5));
        }
        let r = finish(master)?;
        let wall = start.elapsed();
        let after = cpu_ticks(worker.pid()).ok_or("no /proc/PID/stat")?;
        r.assert_success();
        let rows = table(&r.stderr);
        let w = row(&rows, "all-cores", &r.stderr)?;
        assert_eq!(w.threads as usize, cpus, "{}", r.stderr);
        let cpu = tick * (after - before) as u32;
        ratios.push(cpu.as_secs_f64() / wall.as_secs_f64());
        // The threads this session started (those seen before it have not grown).
        let mut threads: Vec<u64> = seen.into_values().filter(|&t| t > 0).collect();
        threads.sort_unstable_by(|a, b| b.cmp(a));
        spreads.push(threads);
    }
    // A render's threads that each did at least a fifth of its work.
    let busy = |threads: &Vec<u64>| {
        let total: u64 = threads.iter().sum();
        threads.iter().filter(|&&t| t * 5 >= total).count()
    };
    let spread = spreads.iter().all(|t| busy(t) >= cpus.min(2));
    let want = if cpus >= 2 { 1.4 } else { 0.5 };
    let fast = ratios.iter().any(|&q| q >= want);
    assert!(
        spread,
        "the work is not spread over {cpus} threads: {spreads:?}; CPU/wall {ratios:?}"
    );
    eprintln!("CPU time / wall time per render: {ratios:?} (at least {want} on an idle machine: {fast}); threads' CPU ticks {spreads:?}");
    Ok(())
}
