//! Worker threads in this process: the default executor of `strahl render`.
//!
//! Each thread runs the core's worker loop over an in-process [`pipe`](crate::cluster::pipe),
//! so a local render goes through the same scheduler, frames and checks as a cluster render.
//! The threads share the master's prepared scene through a pre-filled
//! [`SceneCache`]: they answer the job with `Ready` at once, and nothing is built twice. Their
//! outbox is [`Held`], which writes the answers to one request together.

use crate::cluster::held::Held;
use crate::cluster::link::Link;
use crate::cluster::master::{run_master, ClusterError, ClusterImage, MasterOptions};
use crate::cluster::pipe::{duplex, LinkModel, PipeEnd};
use crate::cluster::prepared::PreparedScene;
use crate::util::secret::random_nonce;
use embedded_io_adapters::std::FromStd;
use strahl_core::render::stats::RayCounts;
use strahl_core::worker::{serve_with, NodeInfo, Outbox, SceneCache};

/// The most in-process workers a render takes (`--workers`, the view's form).
pub const MAX_WORKERS: u32 = 1024;

/// The memory an in-process worker offers a scene: all there is (it shares the master's).
pub const LOCAL_SCENE_MEMORY: u64 = u64::MAX;

/// Starts `count` worker threads, each with a copy of `cache`, and returns the master's links to
/// them, named `local-1`, `local-2`, ...: the names the workers give in their `Hello`, so the
/// worker table reads the same whether or not a worker was greeted before the render ended.
///
/// # Errors
/// If a thread cannot be started.
pub fn spawn_local_workers(count: usize, cache: &SceneCache) -> std::io::Result<Vec<Link>> {
    spawn_pipe_workers(count, cache, "local", Held::default)
}

/// Starts `count` worker threads named `NAME-1`, `NAME-2`, ... that answer through the outbox
/// `outbox()` makes: [`Inline`] renders (the local workers), others answer without rendering
/// (the master's load in `strahl bench scaling`).
///
/// # Errors
/// If a thread cannot be started.
pub fn spawn_pipe_workers<O>(
    count: usize,
    cache: &SceneCache,
    name: &str,
    outbox: fn() -> O,
) -> std::io::Result<Vec<Link>>
where
    O: Outbox<FromStd<PipeEnd>> + 'static,
{
    (1..=count)
        .map(|i| {
            let (master_end, worker_end) = duplex(LinkModel::default(), LinkModel::default());
            let cache = cache.clone();
            let name = format!("{name}-{i}");
            let link = Link::from_pipe(name.clone(), master_end);
            std::thread::Builder::new()
                .name(format!("strahl-{name}"))
                .spawn(move || run_pipe_worker(&name, worker_end, cache, outbox()))?;
            Ok(link)
        })
        .collect()
}

/// One in-process worker: serves one session, then ends.
fn run_pipe_worker<O: Outbox<FromStd<PipeEnd>>>(
    name: &str,
    end: PipeEnd,
    mut cache: SceneCache,
    mut outbox: O,
) {
    let node = NodeInfo {
        name,
        arch: std::env::consts::ARCH,
        scene_memory: LOCAL_SCENE_MEMORY,
        threads: 1,
        secret: None,
        nonce: random_nonce,
    };
    let mut link = FromStd::new(end);
    // However the session ends, the master sees it on the link; nothing to report here.
    let _ = serve_with(&mut link, &mut outbox, &node, &mut cache);
}

/// Renders `prepared` with `workers` in-process workers (at least 1) through the master, and
/// calls `on_line(y, rays)` for each finished line.
///
/// # Errors
/// [`ClusterError::Spawn`] if a thread cannot be started; [`ClusterError::AllWorkersLost`]
/// only if in-process workers fail, which is a bug.
pub fn render_local(
    prepared: &PreparedScene,
    workers: usize,
    on_line: &(dyn Fn(u32, RayCounts) + Sync),
) -> Result<ClusterImage, ClusterError> {
    let links = spawn_local_workers(workers.max(1), &prepared.cache())?;
    run_master(
        &prepared.job(),
        links,
        None,
        &MasterOptions::default(),
        on_line,
        &|_| {},
    )
}
