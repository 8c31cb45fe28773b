//! What a render asks of the master and what it gets back: the options, the job, the finished
//! image and the errors. Plain data, used by the session, the assembly and the master loop.

use crate::cluster::report::WorkerReport;
use crate::util::secret::Secret;
use std::ops::Range;
use std::sync::Arc;
use std::time::Duration;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::ray_limit::LineRayLimits;
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::Scene;
use strahl_core::wire::scene_blob::SceneBlob;

/// How the master schedules and when it gives up on a worker.
#[derive(Clone, Debug)]
pub struct MasterOptions {
    /// Requests each worker thread has outstanding (1 is the seed's one line at a time).
    pub window: u32,
    /// Lines per request: `None` chooses from the measured cost of a line
    /// ([`crate::cluster::session::REQUEST_WORK`]); 1 is the seed's one line at a time.
    pub lines_per_request: Option<u32>,
    /// Silence after which the master probes a worker (resends `Hello` or `Job`, or sends a
    /// `Fence`).
    pub probe_interval: Duration,
    /// Silence, with work outstanding, after which a worker counts as hung and is dropped.
    pub worker_timeout: Duration,
    /// While more workers may join, how long to wait with none alive before giving up.
    pub wait_for_workers: Duration,
    /// The master's name in its `Hello`.
    pub name: String,
    /// The share of tasks (0 to 1) rendered by a second worker and compared byte for byte
    /// before use (`--verify`); 0: none. With adaptive multisampling every first pass is
    /// checked once any is.
    pub verify: f64,
    /// The shared secret workers must prove, and the master proves to them; `None`: workers
    /// without a secret only.
    pub secret: Option<Secret>,
}

/// The longest silence before the master probes a worker (a shorter worker timeout probes at a
/// quarter of it).
pub const PROBE_INTERVAL: Duration = Duration::from_secs(2);

/// The default worker timeout and wait for workers (`--worker-timeout`).
pub const WORKER_TIMEOUT: Duration = Duration::from_secs(60);

/// The default number of lines a worker holds at once (`--window`).
pub const WINDOW: u32 = 2;

impl Default for MasterOptions {
    fn default() -> Self {
        MasterOptions {
            window: WINDOW,
            lines_per_request: None,
            probe_interval: PROBE_INTERVAL,
            worker_timeout: WORKER_TIMEOUT,
            wait_for_workers: WORKER_TIMEOUT,
            name: "strahl-master".to_string(),
            secret: None,
            verify: 0.0,
        }
    }
}

/// One render for the master: the scene's encoding and the image size.
#[derive(Clone, Debug)]
pub struct ClusterJob {
    /// Job number, sent with every request.
    pub id: u32,
    /// The scene as workers receive it.
    pub blob: Arc<SceneBlob>,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The lines rendered: `0..height` but for `--region` ([`ClusterJob::limited_to`],
    /// [`crate::cluster::region::Region::rendered_lines`]). The others are never asked for, and
    /// the image holds these lines alone.
    pub lines: Range<u32>,
    /// Adaptive multisampling's second pass, if the scene uses it.
    pub adaptive: Option<AdaptiveJob>,
    /// The rays a line result can report: a worker whose counts lie beyond them is dropped.
    pub ray_limits: LineRayLimits,
    /// The scene itself, where the master has it: with `--verify` it renders a line itself
    /// when two workers' results differ, to tell which is wrong.
    pub scene: Option<Arc<Scene>>,
}

impl ClusterJob {
    /// The job rendering `lines` alone (within `0..height`). With adaptive multisampling they
    /// must be every line ([`crate::cluster::region::Region::rendered_lines`]): the second
    /// passes are scheduled for all, so the job is left whole otherwise.
    pub fn limited_to(mut self, lines: Range<u32>) -> Self {
        debug_assert!(self.adaptive.is_none() || lines == (0..self.height));
        if self.adaptive.is_none() {
            self.lines = lines.start.min(self.height)..lines.end.min(self.height);
        }
        self
    }
}

/// How the master decides adaptive multisampling's second pass.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveJob {
    /// Pixels whose centre differs from a neighbour's by more than this are supersampled.
    pub threshold: f32,
    /// Ask for every pixel's samples and keep only the flagged ones (`--skip-effects off`).
    pub refine_all: bool,
}

/// A finished distributed render.
#[derive(Clone, Debug)]
pub struct ClusterImage {
    /// The job's [`lines`](ClusterJob::lines) (all `height` of them but for a region), `width`
    /// pixels each, row-major, top row first.
    pub pixels: Vec<Pixel>,
    /// Rays traced for the lines used.
    pub rays: RayCounts,
    /// What each worker did, in the order they joined.
    pub workers: Vec<WorkerReport>,
    /// When the first line was asked of a worker (the time before it was spent waiting for
    /// workers and the scene's transfer; `None` if every line was resumed).
    pub first_request: Option<std::time::Instant>,
}

/// Why a distributed render failed.
#[derive(Debug, thiserror::Error)]
pub enum ClusterError {
    /// Every worker was lost (or none came) before the image was complete.
    #[error("{}", lost_message(*.finished, *.total, .workers))]
    AllWorkersLost {
        /// Lines finished.
        finished: u32,
        /// Lines in the image.
        total: u32,
        /// Every worker, with why it was lost.
        workers: Vec<WorkerReport>,
    },
    /// The render was stopped (Ctrl-C) before the image was complete.
    #[error("interrupted: {finished} of {total} lines were finished, no image was written")]
    Interrupted {
        /// Lines finished.
        finished: u32,
        /// Lines in the image.
        total: u32,
    },
    /// A worker thread could not be started.
    #[error("cannot start a worker thread: {0}")]
    Spawn(#[from] std::io::Error),
}

fn lost_message(finished: u32, total: u32, workers: &[WorkerReport]) -> String {
    if workers.is_empty() {
        return format!("no worker to render with: 0 of {total} lines finished");
    }
    let lost: Vec<String> = workers
        .iter()
        .map(|w| {
            format!(
                "{} ({})",
                w.name,
                w.lost.as_deref().unwrap_or("no longer answering")
            )
        })
        .collect();
    format!(
        "all {} workers were lost; {finished} of {total} lines were finished, no image was \
         written. Lost: {}",
        workers.len(),
        lost.join(", ")
    )
}
