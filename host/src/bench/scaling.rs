//! `strahl bench scaling`: the seed's runtime comparison over 1 to N machines (its section
//! 3.2.3.4), answered three ways in one run.
//!
//! - **In-process**: 1 to `cores` workers in this process (the default executor), measured.
//! - **TCP processes**: 1 to `cores` `strahl worker` processes on loopback, measured. They keep
//!   running between runs, so only the first run of each count transfers the scene.
//! - **Model**: 1 to `--up-to` workers in the discrete-event model
//!   ([`crate::cluster::model`]), fed with this machine's cost of every line and the master's
//!   time per result, measured here with an image whose rays hit nothing. Where real figures exist, the model's stand
//!   next to them, so its error is visible.
//!
//! Every time is the median of `--runs` runs; speedups are against the 1-worker time of the same
//! column in the same run.

use super::stats::median;
use crate::cluster::link::Link;
use crate::cluster::local::render_local;
use crate::cluster::master::{run_master, ClusterImage, MasterOptions};
use crate::cluster::model::{simulate, ModelParams};
use crate::cluster::prepared::PreparedScene;
use crate::generate;
use anyhow::{anyhow, bail, Context as _};
use std::io::{BufRead as _, BufReader, Write};
use std::num::NonZeroUsize;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use strahl_core::accel::octree::OctreeParams;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::scene::{RenderSettings, Scene, SceneDesc};

/// What `strahl bench scaling` measures (its command line is `cli::bench::ScalingArgs`).
#[derive(Clone, Debug)]
pub struct ScalingOptions {
    /// Image width of the demo room.
    pub width: u32,
    /// Image height of the demo room.
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

fn start_worker_process(index: u32) -> anyhow::Result<WorkerProcess> {
    let exe = std::env::current_exe().context("cannot find the strahl executable")?;
    let mut child = Command::new(exe)
        .args(["worker", "--listen", "127.0.0.1:0", "--name"])
        .arg(format!("bench-{index}"))
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

/// Worker processes 1 to `n`.
fn start_worker_processes(n: u32) -> anyhow::Result<Vec<WorkerProcess>> {
    (1..=n).map(start_worker_process).collect()
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

/// One row of the table.
struct Row {
    workers: u32,
    in_process: Option<Duration>,
    tcp: Option<Duration>,
    model: f64,
}

fn speedup(base: Option<Duration>, t: Option<Duration>) -> String {
    match (base, t) {
        (Some(b), Some(t)) if t > Duration::ZERO => {
            format!("{:.2}", b.as_secs_f64() / t.as_secs_f64())
        }
        _ => "-".to_string(),
    }
}

fn secs(t: Option<Duration>) -> String {
    t.map_or("-".to_string(), |t| format!("{:.3}", t.as_secs_f64()))
}

/// The median wall time of `runs` calls of `f`.
fn timed(runs: usize, mut f: impl FnMut() -> anyhow::Result<()>) -> anyhow::Result<Duration> {
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs {
        let t = Instant::now();
        f()?;
        times.push(t.elapsed());
    }
    Ok(median(times))
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

/// The scene `desc` with one tiny triangle out of view in place of its own: a render of it is
/// all protocol, framing and scheduling.
fn empty_scene(desc: &SceneDesc) -> anyhow::Result<PreparedScene> {
    let mut d = desc.clone();
    d.points = vec![
        glam::Vec3::new(0.0, -1e3, 0.0),
        glam::Vec3::new(1e-3, -1e3, 0.0),
        glam::Vec3::new(0.0, -1e3, 1e-3),
    ];
    // Behind the camera (at y = −100, looking along +y): every ray misses.
    d.triangles.truncate(1);
    if let Some(t) = d.triangles.first_mut() {
        t.points = [0, 1, 2];
    }
    PreparedScene::new(&d, &OctreeParams::default()).map_err(|e| anyhow!("empty scene: {e}"))
}

/// The median time of `prepared` on 1 to `max` in-process workers.
fn in_process_times(
    prepared: &PreparedScene,
    max: usize,
    runs: usize,
) -> anyhow::Result<Vec<Duration>> {
    (1..=max)
        .map(|n| {
            timed(runs, || {
                render_local(prepared, n, &|_, _| {})?;
                Ok(())
            })
        })
        .collect()
}

/// The median time of `prepared` on the first 1 to all of `procs`.
fn tcp_times(
    prepared: &PreparedScene,
    procs: &[WorkerProcess],
    opts: &MasterOptions,
    runs: usize,
) -> anyhow::Result<Vec<Duration>> {
    (1..=procs.len())
        .map(|n| {
            timed(runs, || {
                tcp_render(prepared, &procs[..n], opts)?;
                Ok(())
            })
        })
        .collect()
}

/// What the table is made of, measured.
struct Measured {
    cores: u32,
    max_real: u32,
    runs: usize,
    triangles: usize,
    /// Seconds to trace every line once on one core.
    traced: f64,
    /// The master's time per result, in seconds.
    master_time: f64,
    /// One-way latency in the model, in seconds.
    latency: f64,
    /// Whether the TCP worker processes ran.
    tcp_used: bool,
    in_process: Vec<Duration>,
    tcp: Vec<Duration>,
    rows: Vec<Row>,
}

/// Runs `strahl bench scaling` and prints the table on stdout.
///
/// # Errors
/// If a worker process cannot be started or reached, or a render fails.
pub fn run(args: &ScalingOptions) -> anyhow::Result<()> {
    let measured = measure(args)?;
    print_table(&mut std::io::stdout().lock(), args, &measured)
}

/// Measures the in-process and TCP times and runs the model.
fn measure(args: &ScalingOptions) -> anyhow::Result<Measured> {
    let cores = std::thread::available_parallelism().map_or(1, NonZeroUsize::get) as u32;
    let max_real = args.max_real.unwrap_or(cores).max(1);
    let runs = args.runs.max(1) as usize;
    let mut desc = generate::room();
    desc.settings = RenderSettings {
        width: args.width,
        height: args.height,
        reflections: true,
        ..desc.settings
    };
    let prepared = PreparedScene::new(&desc, &OctreeParams::default())
        .map_err(|e| anyhow!("demo room: {e}"))?;
    let opts = MasterOptions {
        window: args.window,
        ..MasterOptions::default()
    };
    let line_costs = line_costs(&prepared.scene, args.width, args.height, runs)?;
    let traced: f64 = line_costs.iter().sum();

    let in_process = in_process_times(&prepared, max_real as usize, runs)?;

    let tcp_procs = if args.no_tcp {
        None
    } else {
        Some(start_worker_processes(max_real)?)
    };
    let tcp = match &tcp_procs {
        Some(procs) => tcp_times(&prepared, procs, &opts, runs)?,
        None => Vec::new(),
    };

    // The master's time per result: a render of the same image size whose rays hit nothing,
    // over TCP where the workers run.
    let empty = empty_scene(&desc)?;
    let empty_time = timed(runs, || {
        if let Some(procs) = tcp_procs.as_deref() {
            tcp_render(&empty, &procs[..1], &opts)?;
        } else {
            render_local(&empty, 1, &|_, _| {})?;
        }
        Ok(())
    })?;
    let master_time = empty_time.as_secs_f64() / f64::from(args.height);
    let latency = 50e-6;
    let model = |n: u32| {
        simulate(&ModelParams {
            line_costs: line_costs.clone(),
            speeds: vec![1.0; n as usize],
            latency,
            master_time,
            window: args.window,
        })
        .makespan
    };
    let rows: Vec<Row> = (1..=args.up_to.max(max_real))
        .map(|n| Row {
            workers: n,
            in_process: in_process.get(n as usize - 1).copied(),
            tcp: tcp.get(n as usize - 1).copied(),
            model: model(n),
        })
        .collect();
    Ok(Measured {
        cores,
        max_real,
        runs,
        triangles: prepared.scene.triangle_points.len(),
        traced,
        master_time,
        latency,
        tcp_used: tcp_procs.is_some(),
        in_process,
        tcp,
        rows,
    })
}

/// The report: what was measured, then a row per worker count.
fn print_table(out: &mut impl Write, args: &ScalingOptions, m: &Measured) -> anyhow::Result<()> {
    let Measured {
        cores,
        max_real,
        runs,
        traced,
        master_time,
        latency,
        ..
    } = *m;
    writeln!(
        out,
        "strahl bench scaling: demo room {}x{} with reflections, {} triangles; {cores} CPUs here; \
         window {}; median of {runs} runs",
        args.width, args.height, m.triangles, args.window
    )?;
    writeln!(
        out,
        "tracing all lines on one core: {traced:.3} s; model: master time per result {:.1} µs \
         (measured with an empty image{}), one-way latency {:.0} µs",
        master_time * 1e6,
        if m.tcp_used {
            " over TCP"
        } else {
            " in-process"
        },
        latency * 1e6
    )?;
    writeln!(
        out,
        "{:>7} | {:>13} {:>7} | {:>13} {:>7} | {:>9} {:>7} {:>10}",
        "workers",
        "in-process s",
        "speedup",
        "TCP procs s",
        "speedup",
        "model s",
        "speedup",
        "efficiency"
    )?;
    let base_model = m.rows.first().map_or(0.0, |r| r.model);
    for r in &m.rows {
        let model_speedup = if r.model > 0.0 {
            base_model / r.model
        } else {
            0.0
        };
        writeln!(
            out,
            "{:>7} | {:>13} {:>7} | {:>13} {:>7} | {:>9.3} {:>7.2} {:>9.0}%",
            r.workers,
            secs(r.in_process),
            speedup(m.in_process.first().copied(), r.in_process),
            secs(r.tcp),
            speedup(m.tcp.first().copied(), r.tcp),
            r.model,
            model_speedup,
            100.0 * model_speedup / f64::from(r.workers),
        )?;
    }
    if max_real > cores {
        writeln!(
            out,
            "note: {max_real} real workers on {cores} CPUs share cores; their speedup cannot \
             exceed {cores}"
        )?;
    }
    Ok(())
}
