//! `strahl bench scaling`: the seed's runtime comparison over 1 to N machines (its section
//! 3.2.3.4), answered several ways in one run, on the demo room or any scene (`--scene`).
//!
//! - **In-process**: 1 to `cores` workers in this process (the default executor), measured,
//!   with the share of the wall time the master thread was busy (its CPU clock).
//! - **TCP processes**: 1 to `cores` one-thread `strahl worker` processes on loopback, measured.
//!   They keep running between runs, so only the first run of each count transfers the scene.
//! - **One TCP process, N threads**: one `strahl worker --threads N` per count, measured the
//!   same way.
//! - **Model**: 1 to `--up-to` workers in the discrete-event model
//!   ([`crate::cluster::model`]), fed with this machine's cost of every line, the master's
//!   CPU time per result ([`super::master_load`]: workers that answer without rendering) and
//!   a one-way latency (`--latency-us`). Where real figures exist, the model's stand next to
//!   them, so its error is visible.
//!
//! Every time is the median of `--runs` runs; speedups are against the 1-worker time of the same
//! column in the same run.

use super::master_load::{self, MasterLoad};
use super::stats::median;
use crate::cluster::link::Link;
use crate::cluster::local::spawn_local_workers;
use crate::cluster::master::{run_master, ClusterImage, MasterOptions};
use crate::cluster::model::{simulate, ModelParams};
use crate::cluster::prepared::PreparedScene;
use crate::generate;
use crate::util::sys::thread_cpu_time;
use anyhow::{anyhow, bail, Context as _};
use std::io::{BufRead as _, BufReader, Write};
use std::num::NonZeroUsize;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::scene::{RenderSettings, Scene, SceneDesc};
use strahl_formats::load::{load_scene, Overrides};

/// What `strahl bench scaling` measures (its command line is `cli::bench::ScalingArgs`).
#[derive(Clone, Debug)]
pub struct ScalingOptions {
    /// The scene; `None`: the demo room with reflections.
    pub scene: Option<PathBuf>,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Runs per figure (the median is reported).
    pub runs: u32,
    /// Most workers measured for real; `None`: the number of CPUs.
    pub max_real: Option<u32>,
    /// Most workers in the model.
    pub up_to: u32,
    /// Requests each worker has outstanding.
    pub window: u32,
    /// Skip the TCP worker processes (in-process and model only).
    pub no_tcp: bool,
    /// One-way link latency in the model, in seconds.
    pub latency: f64,
    /// Lines per request; `None`: the master's choice.
    pub lines_per_request: Option<u32>,
}

/// A `strahl worker` process on loopback, killed when dropped.
struct WorkerProcess {
    child: Child,
    address: String,
}

impl Drop for WorkerProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts `strahl worker --listen 127.0.0.1:0 --threads THREADS`.
fn start_worker_process(index: u32, threads: u32) -> anyhow::Result<WorkerProcess> {
    let exe = std::env::current_exe().context("cannot find the strahl executable")?;
    let mut child = Command::new(exe)
        .args(["worker", "--listen", "127.0.0.1:0", "--threads"])
        .arg(threads.to_string())
        .arg("--name")
        .arg(format!("bench-{index}-{threads}t"))
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .context("cannot start a worker process")?;
    let stderr = child.stderr.take();
    // From here on the guard kills the process on any early return.
    let mut w = WorkerProcess {
        child,
        address: String::new(),
    };
    let Some(stderr) = stderr else {
        // Stdio::piped() above gives every child a stderr.
        debug_assert!(false, "a worker process without stderr");
        bail!("worker process without stderr");
    };
    let mut lines = BufReader::new(stderr).lines();
    let first = lines.next().transpose()?.unwrap_or_default();
    w.address = first
        .rsplit_once("listening on ")
        .map(|(_, a)| a.trim().to_string())
        .filter(|a| !a.is_empty())
        .ok_or_else(|| anyhow!("the worker process said `{first}` instead of its address"))?;
    // Keep draining its stderr so it never blocks on a full pipe.
    std::thread::spawn(move || lines.for_each(drop));
    Ok(w)
}

/// One-thread worker processes 1 to `n`.
fn start_worker_processes(n: u32) -> anyhow::Result<Vec<WorkerProcess>> {
    (1..=n).map(|i| start_worker_process(i, 1)).collect()
}

fn tcp_render(
    prepared: &PreparedScene,
    workers: &[WorkerProcess],
    opts: &MasterOptions,
) -> anyhow::Result<ClusterImage> {
    let mut links = Vec::new();
    for w in workers {
        let stream = strahl_tcp::connect(&w.address, strahl_tcp::CONNECT_TIMEOUT)
            .with_context(|| format!("cannot reach worker {}", w.address))?;
        links.push(Link::from_tcp(w.address.clone(), stream)?);
    }
    Ok(run_master(
        &prepared.job(),
        links,
        None,
        opts,
        &|_, _| {},
        &|_| {},
    )?)
}

/// A measured figure: medians over the runs of one configuration.
#[derive(Clone, Copy, Debug)]
struct Figure {
    wall: Duration,
    /// The share of the wall time the master thread was busy.
    master_busy: Option<f64>,
    /// Lines per request the master chose (the last run).
    per_request: f64,
}

/// One row of the table.
struct Row {
    workers: u32,
    in_process: Option<Figure>,
    tcp: Option<Figure>,
    threads: Option<Figure>,
    model: f64,
}

fn speedup(base: Option<&Figure>, t: Option<&Figure>) -> String {
    match (base, t) {
        (Some(b), Some(t)) if t.wall > Duration::ZERO => {
            format!("{:.2}", b.wall.as_secs_f64() / t.wall.as_secs_f64())
        }
        _ => "-".to_string(),
    }
}

fn secs(t: Option<&Figure>) -> String {
    t.map_or("-".to_string(), |t| format!("{:.3}", t.wall.as_secs_f64()))
}

fn percent(share: Option<f64>) -> String {
    share.map_or("-".to_string(), |s| format!("{:.1}%", 100.0 * s))
}

/// Runs `render` `runs` times on this thread (the master runs on the caller's thread) and
/// gives the medians of the wall time and of the master thread's CPU time.
fn timed(
    runs: usize,
    mut render: impl FnMut() -> anyhow::Result<ClusterImage>,
) -> anyhow::Result<Figure> {
    let mut walls = Vec::with_capacity(runs);
    let mut cpus = Vec::with_capacity(runs);
    let mut per_request = 1.0;
    for _ in 0..runs {
        let cpu = thread_cpu_time();
        let t = Instant::now();
        let image = render()?;
        walls.push(t.elapsed());
        if let (Some(before), Some(after)) = (cpu, thread_cpu_time()) {
            cpus.push(after.saturating_sub(before));
        }
        let (requests, lines) = image
            .workers
            .iter()
            .fold((0, 0), |(r, l), w| (r + w.requests, l + w.requested_lines));
        per_request = f64::from(lines) / f64::from(requests.max(1));
    }
    let wall = median(walls);
    let master_busy =
        (!cpus.is_empty()).then(|| median(cpus).as_secs_f64() / wall.as_secs_f64().max(1e-9));
    Ok(Figure {
        wall,
        master_busy,
        per_request,
    })
}

/// The cost in seconds of every line on one core, the model's input (median of the runs per
/// line).
fn line_costs(scene: &Scene, width: u32, height: u32, runs: usize) -> anyhow::Result<Vec<f64>> {
    let mut row = vec![Pixel::default(); width as usize];
    let mut costs = vec![Vec::with_capacity(runs); height as usize];
    for _ in 0..runs {
        for (y, c) in costs.iter_mut().enumerate() {
            let t = Instant::now();
            render_line(scene, y as u32, &mut row).map_err(|e| anyhow!("line {y}: {e}"))?;
            c.push(t.elapsed());
        }
    }
    Ok(costs.into_iter().map(|c| median(c).as_secs_f64()).collect())
}

/// Lines of the image the master's load is measured on (nothing is traced in it).
const ECHO_HEIGHT: u32 = 16384;

/// What the table is made of, measured.
struct Measured {
    name: String,
    cores: u32,
    max_real: u32,
    runs: usize,
    triangles: usize,
    /// Seconds to trace every line once on one core.
    traced: f64,
    /// The master with workers that answer without rendering.
    load: MasterLoad,
    /// Echoing workers in that measurement.
    echo_workers: u32,
    /// The master's time per result the model uses, in seconds.
    master_time: f64,
    /// Whether the TCP worker processes ran.
    tcp_used: bool,
    rows: Vec<Row>,
}

/// Runs `strahl bench scaling` and prints the table on stdout.
///
/// # Errors
/// If the scene cannot be loaded, a worker process cannot be started or reached, or a render
/// fails.
pub fn run(args: &ScalingOptions) -> anyhow::Result<()> {
    let measured = measure(args)?;
    print_table(&mut std::io::stdout().lock(), args, &measured)
}

/// The scene at the benchmark's size, and its name.
fn scene_desc(args: &ScalingOptions) -> anyhow::Result<(SceneDesc, String)> {
    let Some(path) = &args.scene else {
        let mut desc = generate::room();
        desc.settings = RenderSettings {
            width: args.width,
            height: args.height,
            reflections: true,
            ..desc.settings
        };
        return Ok((desc, "demo room with reflections".to_string()));
    };
    let overrides = Overrides {
        width: Some(args.width),
        height: Some(args.height),
        ..Overrides::default()
    };
    let loaded = load_scene(path, &overrides)?;
    Ok((loaded.desc, path.display().to_string()))
}

/// Times `render(n)` for n = 1 to `max`.
fn column(
    max: u32,
    runs: usize,
    mut render: impl FnMut(usize) -> anyhow::Result<ClusterImage>,
) -> anyhow::Result<Vec<Figure>> {
    (1..=max as usize)
        .map(|n| timed(runs, || render(n)))
        .collect()
}

/// The two TCP columns: 1 to `max` one-thread worker processes, and one process on 1 to `max`
/// threads.
fn tcp_columns(
    prepared: &PreparedScene,
    max: u32,
    runs: usize,
    opts: &MasterOptions,
) -> anyhow::Result<(Vec<Figure>, Vec<Figure>)> {
    let procs = start_worker_processes(max)?;
    let tcp = column(max, runs, |n| tcp_render(prepared, &procs[..n], opts))?;
    drop(procs);
    // One process per thread count, started before the runs (its first run brings it the
    // scene, as in the column before).
    let multi: Vec<WorkerProcess> = (1..=max)
        .map(|n| start_worker_process(0, n))
        .collect::<anyhow::Result<_>>()?;
    let threads = column(max, runs, |n| {
        tcp_render(prepared, std::slice::from_ref(&multi[n - 1]), opts)
    })?;
    Ok((tcp, threads))
}

/// Measures the in-process and TCP times and the master's load, and runs the model.
fn measure(args: &ScalingOptions) -> anyhow::Result<Measured> {
    let cores = std::thread::available_parallelism().map_or(1, NonZeroUsize::get) as u32;
    let max_real = args.max_real.unwrap_or(cores).max(1);
    let runs = args.runs.max(1) as usize;
    let (desc, name) = scene_desc(args)?;
    let prepared =
        PreparedScene::new(&desc, &OctreeParams::default()).map_err(|e| anyhow!("{name}: {e}"))?;
    let opts = MasterOptions {
        window: args.window,
        lines_per_request: args.lines_per_request,
        ..MasterOptions::default()
    };
    let line_costs = line_costs(&prepared.scene, args.width, args.height, runs)?;
    let traced: f64 = line_costs.iter().sum();

    let in_process = column(max_real, runs, |n| {
        let links = spawn_local_workers(n, &prepared.cache())?;
        Ok(run_master(
            &prepared.job(),
            links,
            None,
            &opts,
            &|_, _| {},
            &|_| {},
        )?)
    })?;
    let (tcp, threads) = if args.no_tcp {
        (Vec::new(), Vec::new())
    } else {
        tcp_columns(&prepared, max_real, runs, &opts)?
    };

    // The master's cost per result, with workers that answer without rendering.
    let mut tall = desc.clone();
    tall.settings.height = ECHO_HEIGHT;
    let tall =
        PreparedScene::new(&tall, &OctreeParams::default()).map_err(|e| anyhow!("{name}: {e}"))?;
    let echo_workers = cores;
    let load = master_load::measure(&tall, echo_workers as usize, runs, &opts)?;
    let master_time = load
        .seconds_per_result()
        .unwrap_or_else(|| 1.0 / load.results_per_second());
    let model = |n: u32| {
        simulate(&ModelParams {
            line_costs: line_costs.clone(),
            speeds: vec![1.0; n as usize],
            latency: args.latency,
            master_time,
            window: args.window,
        })
        .makespan
    };
    let rows: Vec<Row> = (1..=args.up_to.max(max_real))
        .map(|n| {
            let at = |v: &[Figure]| v.get(n as usize - 1).copied();
            Row {
                workers: n,
                in_process: at(&in_process),
                tcp: at(&tcp),
                threads: at(&threads),
                model: model(n),
            }
        })
        .collect();
    Ok(Measured {
        name,
        cores,
        max_real,
        runs,
        triangles: prepared.scene.triangle_points.len(),
        traced,
        load,
        echo_workers,
        master_time,
        tcp_used: !args.no_tcp,
        rows,
    })
}

/// What was measured before the table: the scene, the tracing time, the master's load.
fn print_header(out: &mut impl Write, args: &ScalingOptions, m: &Measured) -> anyhow::Result<()> {
    writeln!(
        out,
        "strahl bench scaling: {} at {}x{}, {} triangles; {} CPUs here; window {}; median of {} \
         runs",
        m.name, args.width, args.height, m.triangles, m.cores, args.window, m.runs
    )?;
    writeln!(
        out,
        "tracing all lines on one core: {:.3} s ({:.0} µs a line)",
        m.traced,
        1e6 * m.traced / f64::from(args.height.max(1))
    )?;
    let l = &m.load;
    writeln!(
        out,
        "master, {} in-process workers answering without rendering, {} lines: {:.0} results/s; \
         master thread {} CPU per result = {} results/s on one core, busy {}; {:.1} lines per \
         request",
        m.echo_workers,
        l.results,
        l.results_per_second(),
        l.seconds_per_result()
            .map_or("-".to_string(), |s| format!("{:.2} µs", s * 1e6)),
        l.results_per_core_second()
            .map_or("-".to_string(), |r| format!("{r:.0}")),
        percent(l.busy_share()),
        l.lines_per_request
    )?;
    writeln!(
        out,
        "model: master time per result {:.2} µs (the figure above), one-way latency {:.0} µs",
        m.master_time * 1e6,
        args.latency * 1e6
    )?;
    Ok(())
}

/// The report: what was measured, then a row per worker count.
fn print_table(out: &mut impl Write, args: &ScalingOptions, m: &Measured) -> anyhow::Result<()> {
    print_header(out, args, m)?;
    writeln!(
        out,
        "{:>7} | {:>9} {:>7} {:>7} {:>7} | {:>9} {:>7} | {:>11} {:>7} | {:>9} {:>7} {:>10}",
        "workers",
        "in-proc s",
        "speedup",
        "master",
        "l/req",
        "TCP s",
        "speedup",
        "1 proc N t",
        "speedup",
        "model s",
        "speedup",
        "efficiency"
    )?;
    let base_model = m.rows.first().map_or(0.0, |r| r.model);
    let first = m.rows.first();
    for r in &m.rows {
        let model_speedup = if r.model > 0.0 {
            base_model / r.model
        } else {
            0.0
        };
        writeln!(
            out,
            "{:>7} | {:>9} {:>7} {:>7} {:>7} | {:>9} {:>7} | {:>11} {:>7} | {:>9.3} {:>7.2} {:>9.0}%",
            r.workers,
            secs(r.in_process.as_ref()),
            speedup(first.and_then(|f| f.in_process.as_ref()), r.in_process.as_ref()),
            percent(r.in_process.and_then(|f| f.master_busy)),
            r.in_process
                .map_or("-".to_string(), |f| format!("{:.1}", f.per_request)),
            secs(r.tcp.as_ref()),
            speedup(first.and_then(|f| f.tcp.as_ref()), r.tcp.as_ref()),
            secs(r.threads.as_ref()),
            speedup(first.and_then(|f| f.threads.as_ref()), r.threads.as_ref()),
            r.model,
            model_speedup,
            100.0 * model_speedup / f64::from(r.workers),
        )?;
    }
    if m.max_real > m.cores {
        writeln!(
            out,
            "note: {} real workers on {} CPUs share cores; their speedup cannot exceed {}",
            m.max_real, m.cores, m.cores
        )?;
    }
    if !m.tcp_used {
        writeln!(out, "note: --no-tcp: no TCP worker processes were measured")?;
    }
    Ok(())
}
