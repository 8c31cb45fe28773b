//! The master's cost per result, without rendering: in-process workers that answer every line
//! request at once with a black line ([`Echo`]), so the master thread, the link threads and the
//! pipes are all that run. Part of `strahl bench scaling`.
//!
//! [`measure`] renders a tall image with them and reports the results per second achieved, the
//! master thread's CPU time per result (its cost on one core, read from the thread's CPU clock,
//! so other threads on the same cores do not count), the share of the wall time the master
//! thread was busy, and the lines per request the master chose.

use super::stats::median;
use crate::cluster::local::spawn_pipe_workers;
use crate::cluster::master::{run_master, MasterOptions};
use crate::cluster::pipe::PipeEnd;
use crate::cluster::prepared::PreparedScene;
use crate::util::sys::thread_cpu_time;
use anyhow::{anyhow, Context as _};
use embedded_io_adapters::std::FromStd;
use std::time::{Duration, Instant};
use strahl_core::render::stats::RayCounts;
use strahl_core::wire::frame::FrameWriter;
use strahl_core::wire::message::WorkerMessage;
use strahl_core::wire::PIXEL_WIRE_BYTES;
use strahl_core::worker::{LineRequest, Outbox, WorkerError};

/// An outbox that answers each line request with a black line at once.
#[derive(Default)]
struct Echo {
    writer: FrameWriter,
    pixels: Vec<u8>,
}

impl Outbox<FromStd<PipeEnd>> for Echo {
    fn send(
        &mut self,
        link: &mut FromStd<PipeEnd>,
        msg: &WorkerMessage<'_>,
    ) -> Result<(), WorkerError> {
        Ok(self.writer.send(link, msg)?)
    }

    fn render(
        &mut self,
        link: &mut FromStd<PipeEnd>,
        request: LineRequest<'_>,
    ) -> Result<(), WorkerError> {
        let width = request.scene.settings.width as usize;
        self.pixels.resize(width * PIXEL_WIRE_BYTES, 0);
        // The counts a real line has: one primary ray per pixel in a first pass.
        let rays = RayCounts {
            primary: if request.mask.is_some() {
                0
            } else {
                width as u64
            },
            ..RayCounts::default()
        };
        let msg = WorkerMessage::LineResult {
            job: request.job,
            line: request.line,
            refined: request.mask.is_some(),
            rays,
            pixels: &self.pixels,
        };
        Ok(self.writer.send(link, &msg)?)
    }
}

/// What the master did with echoing workers (medians of the runs).
#[derive(Clone, Copy, Debug)]
pub struct MasterLoad {
    /// Line results per run (the image height).
    pub results: u32,
    /// Wall time of a run.
    pub wall: Duration,
    /// The master thread's CPU time in a run; `None` where the system has no thread clock.
    pub master_cpu: Option<Duration>,
    /// Lines per request the master chose, on average over the workers (the last run).
    pub lines_per_request: f64,
}

impl MasterLoad {
    /// Results per second, wall time.
    pub fn results_per_second(&self) -> f64 {
        f64::from(self.results) / self.wall.as_secs_f64()
    }

    /// Results per second of the master thread's CPU time: what one core could take.
    pub fn results_per_core_second(&self) -> Option<f64> {
        self.master_cpu
            .map(|cpu| f64::from(self.results) / cpu.as_secs_f64().max(1e-9))
    }

    /// The master thread's CPU time per result, in seconds.
    pub fn seconds_per_result(&self) -> Option<f64> {
        self.master_cpu
            .map(|cpu| cpu.as_secs_f64() / f64::from(self.results))
    }

    /// The share of the wall time the master thread was busy.
    pub fn busy_share(&self) -> Option<f64> {
        self.master_cpu
            .map(|cpu| cpu.as_secs_f64() / self.wall.as_secs_f64().max(1e-9))
    }
}

/// Renders `prepared` (its image size; nothing is traced) with `workers` echoing workers,
/// `runs` times, and gives the medians.
///
/// # Errors
/// If a thread cannot be started or the render fails.
pub fn measure(
    prepared: &PreparedScene,
    workers: usize,
    runs: usize,
    opts: &MasterOptions,
) -> anyhow::Result<MasterLoad> {
    let job = prepared.job();
    let mut walls = Vec::new();
    let mut cpus = Vec::new();
    let mut per_request = 0.0;
    for _ in 0..runs.max(1) {
        let links = spawn_pipe_workers(workers.max(1), &prepared.cache(), "echo", Echo::default)
            .context("cannot start the echoing workers")?;
        let cpu_before = thread_cpu_time();
        let start = Instant::now();
        let image = run_master(&job, links, None, opts, &|_, _| {}, &|_| {})
            .map_err(|e| anyhow!("the master with echoing workers: {e}"))?;
        walls.push(start.elapsed());
        if let (Some(before), Some(after)) = (cpu_before, thread_cpu_time()) {
            cpus.push(after.saturating_sub(before));
        }
        let (requests, lines) = image.workers.iter().fold((0u32, 0u32), |(r, l), w| {
            (r + w.requests, l + w.requested_lines)
        });
        per_request = f64::from(lines) / f64::from(requests.max(1));
    }
    Ok(MasterLoad {
        results: job.height,
        wall: median(walls),
        master_cpu: (!cpus.is_empty()).then(|| median(cpus)),
        lines_per_request: per_request,
    })
}
