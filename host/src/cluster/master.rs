//! The master: hands out lines to workers over their links, collects the results, survives
//! workers that die, hang or garble frames.
//!
//! [`run_master`] ties the parts together: the link threads (`link_threads`)
//! turn each worker's frames into events, the session (`session`) (no I/O)
//! decides what to send and which results count, and the assembly (`assembly`)
//! builds the image. At the end the master says `EndSession` to every worker left and waits a
//! moment ([`END_SESSION_GRACE`]) for the links to close.

use crate::cluster::link::Link;
use crate::cluster::link_threads::Links;
use crate::cluster::report::WorkerReport;
use crate::cluster::session::{Event, Session, Wire};
use crate::util::sys::POLL_INTERVAL;
use std::collections::HashSet;
use std::sync::mpsc::{Receiver, RecvTimeoutError, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant};
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;
use strahl_core::wire::message::MasterMessage;
use strahl_core::wire::scene_blob::SceneBlob;

pub use crate::cluster::session::refusal_text;

/// How long the master, at the end, waits for its `EndSession`s to be written and for the
/// workers to close their links before it cuts those that did not.
pub const END_SESSION_GRACE: Duration = Duration::from_secs(2);

/// How the master schedules and when it gives up on a worker.
#[derive(Clone, Debug)]
pub struct MasterOptions {
    /// Requests each worker has outstanding (1 is the seed's one line at a time).
    pub window: u32,
    /// Silence after which the master probes a worker (resends `Hello` or `Job`, or sends a
    /// `Fence`).
    pub probe_interval: Duration,
    /// Silence, with work outstanding, after which a worker counts as hung and is dropped.
    pub worker_timeout: Duration,
    /// While more workers may join, how long to wait with none alive before giving up.
    pub wait_for_workers: Duration,
    /// The master's name in its `Hello`.
    pub name: String,
}

impl Default for MasterOptions {
    fn default() -> Self {
        MasterOptions {
            window: 2,
            probe_interval: Duration::from_secs(2),
            worker_timeout: Duration::from_secs(60),
            wait_for_workers: Duration::from_secs(60),
            name: "strahl-master".to_string(),
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
    /// Adaptive multisampling's second pass, if the scene uses it.
    pub adaptive: Option<AdaptiveJob>,
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
    /// `width × height` pixels, row-major, top row first.
    pub pixels: Vec<Pixel>,
    /// Rays traced for the lines used.
    pub rays: RayCounts,
    /// What each worker did, in the order they joined.
    pub workers: Vec<WorkerReport>,
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

/// Renders `job` with the workers behind `links`, plus any that arrive on `joins` while it
/// runs. `on_line(y, rays)` is called for each line's first result, `log` with a message for
/// each worker lost.
///
/// # Errors
/// [`ClusterError::AllWorkersLost`] when no worker is left (and none can join, or none did
/// within [`MasterOptions::wait_for_workers`]) before the image is complete.
pub fn run_master(
    job: &ClusterJob,
    links: Vec<Link>,
    joins: Option<&Receiver<Link>>,
    opts: &MasterOptions,
    on_line: &(dyn Fn(u32, RayCounts) + Sync),
    log: &(dyn Fn(&str) + Sync),
) -> Result<ClusterImage, ClusterError> {
    let (mut wire, events) = Links::new(job.width);
    let mut session = Session::new(job, opts, on_line, log);
    for link in links {
        add(&mut session, &mut wire, link);
    }
    let mut joins_open = joins.is_some();
    let mut alone_since = Instant::now();
    let mut last_check = Instant::now();
    while !session.is_complete() {
        if let Some(joins) = joins {
            joins_open = take_joins(&mut session, &mut wire, joins);
        }
        match events.recv_timeout(POLL_INTERVAL) {
            Ok(event) => session.handle(event, &mut wire),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => {
                // The link threads' sender lives in `wire`, so the channel stays open.
                debug_assert!(false, "the event channel closed with the master holding it");
                break;
            }
        }
        let now = Instant::now();
        if now.duration_since(last_check) >= POLL_INTERVAL {
            last_check = now;
            session.check_timeouts(now, &mut wire);
        }
        session.fill_windows(now, &mut wire);
        if session.any_alive() {
            alone_since = now;
        } else if !joins_open || now.duration_since(alone_since) >= opts.wait_for_workers {
            break;
        }
    }
    finish(session, wire, &events)
}

/// Starts the link threads of `link` and adds its worker to the session.
fn add(session: &mut Session<'_>, wire: &mut Links, link: Link) {
    let (address, kind) = (link.address.clone(), link.kind);
    let ok = wire.add(link);
    session.add(&address, kind, ok, wire);
}

/// Adds the workers that have joined; returns whether more can join.
fn take_joins(session: &mut Session<'_>, wire: &mut Links, joins: &Receiver<Link>) -> bool {
    loop {
        match joins.try_recv() {
            Ok(link) => add(session, wire, link),
            Err(TryRecvError::Empty) => return true,
            Err(TryRecvError::Disconnected) => return false,
        }
    }
}

/// Ends the session with every worker left, and gives the image or why there is none.
fn finish(
    session: Session<'_>,
    mut wire: Links,
    events: &Receiver<Event>,
) -> Result<ClusterImage, ClusterError> {
    let live: HashSet<usize> = session.alive().collect();
    for id in 0..session.workers() {
        if live.contains(&id) {
            wire.send(id, &MasterMessage::EndSession);
        }
        // Closing the queue lets the writer send what is queued, then hang up.
        wire.close_queue(id);
    }
    // Give the writers a moment to deliver `EndSession`, so workers know the session is
    // over before this process exits; a writer stuck on a dead link is not waited for.
    let deadline = Instant::now() + END_SESSION_GRACE;
    let finished = wire.wait_for_writers(&live, deadline);
    // Then read until each worker that got `EndSession` closes its end (what it still sends
    // is dropped): a socket closed while the worker's frames sit unread in it would reset
    // the connection, and the worker could lose `EndSession` and report a failed session.
    let mut open = finished.clone();
    while !open.is_empty() {
        let left = deadline.saturating_duration_since(Instant::now());
        match events.recv_timeout(left) {
            Ok(Event::Closed(id, _)) => {
                open.remove(&id);
            }
            Ok(_) => {}
            Err(_) => break,
        }
    }
    // A writer stuck on a dead link, or a worker that does not close: cut the link so its
    // threads end.
    for id in session.alive() {
        if !finished.contains(&id) || open.contains(&id) {
            wire.cut(id);
        }
    }
    session.into_image()
}
