//! The master: hands out lines to workers over their links, collects the results, survives
//! workers that die, hang or garble frames.
//!
//! [`run_master`] ties the parts together: the link threads (`link_threads`)
//! turn each worker's frames into events, the session (`session`) (no I/O)
//! decides what to send and which results count, and the assembly (`assembly`)
//! builds the image. At the end the master says `EndSession` to every worker left and waits a
//! moment ([`END_SESSION_GRACE`]) for the links to close.

use crate::cluster::checkpoint::Record;
use crate::cluster::link::Link;
use crate::cluster::link_threads::Links;
use crate::cluster::report::WorkerState;
use crate::cluster::session::{Event, OnFinal, OnResult, Session, Wire};
use crate::util::sys::POLL_INTERVAL;
use std::collections::HashSet;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, TryRecvError};
use std::time::{Duration, Instant};
use strahl_core::render::stats::RayCounts;
use strahl_core::wire::message::MasterMessage;

pub use crate::cluster::job::{AdaptiveJob, ClusterError, ClusterImage, ClusterJob, MasterOptions};
pub use crate::cluster::session::{refusal_text, FinalLine};

/// How long the master, at the end, waits for its `EndSession`s to be written and for the
/// workers to close their links before it cuts those that did not.
pub const END_SESSION_GRACE: Duration = Duration::from_secs(2);

/// How often [`Hooks::on_tick`] is told the workers' states.
pub const TICK: Duration = Duration::from_millis(250);

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
    let hooks = Hooks {
        on_line,
        log,
        on_result: None,
        on_final: None,
        on_tick: None,
        resume: &[],
        stop: None,
    };
    run_master_with(job, links, joins, opts, &hooks)
}

/// Where the workers' states go each [`TICK`].
pub type OnTick<'a> = &'a (dyn Fn(&[WorkerState]) + Sync);

/// What a render reports as it goes, what it resumes from, and when it stops early.
pub struct Hooks<'a> {
    /// Called with each line's final pixels' line number and rays.
    pub on_line: &'a (dyn Fn(u32, RayCounts) + Sync),
    /// Called with a message for each worker lost.
    pub log: &'a (dyn Fn(&str) + Sync),
    /// Called with every result used (task number, rays, pixels): a checkpoint.
    pub on_result: Option<OnResult<'a>>,
    /// Called with each line's final pixels and the worker that delivered them: a live view.
    pub on_final: Option<OnFinal<'a>>,
    /// Called about every [`TICK`] with each worker's state, and once at the end (after the
    /// workers' links are closed).
    pub on_tick: Option<OnTick<'a>>,
    /// Results of an earlier run of the same job, taken first.
    pub resume: &'a [Record],
    /// Once set (Ctrl-C), the render ends with [`ClusterError::Interrupted`].
    pub stop: Option<&'a AtomicBool>,
}

/// [`run_master`] with a checkpoint to write, results to resume from, and a stop flag.
///
/// # Errors
/// As [`run_master`], and [`ClusterError::Interrupted`] once `hooks.stop` is set.
pub fn run_master_with(
    job: &ClusterJob,
    links: Vec<Link>,
    joins: Option<&Receiver<Link>>,
    opts: &MasterOptions,
    hooks: &Hooks<'_>,
) -> Result<ClusterImage, ClusterError> {
    let (mut wire, events) = Links::new(job.width);
    let mut session = Session::new(job, opts, hooks.on_line, hooks.log);
    if let Some(on_final) = hooks.on_final {
        session.report_final_lines(on_final);
    }
    session.replay(hooks.resume);
    if let Some(record) = hooks.on_result {
        session.record_results(record);
    }
    for link in links {
        add(&mut session, &mut wire, link);
    }
    let mut joins_open = joins.is_some();
    let mut alone_since = Instant::now();
    let mut last_check = Instant::now();
    let mut last_tick = Instant::now();
    let mut stopped = false;
    while !session.is_complete() {
        if hooks.stop.is_some_and(|s| s.load(Ordering::Relaxed)) {
            stopped = true;
            break;
        }
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
        if let Some(tick) = hooks
            .on_tick
            .filter(|_| now.duration_since(last_tick) >= TICK)
        {
            last_tick = now;
            tick(&session.worker_states());
        }
        if session.any_alive() {
            alone_since = now;
        } else if !joins_open || now.duration_since(alone_since) >= opts.wait_for_workers {
            break;
        }
    }
    let (finished, total) = session.progress();
    let image = finish(session, wire, &events, hooks.on_tick);
    if stopped {
        return Err(ClusterError::Interrupted { finished, total });
    }
    image
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

/// Ends the session with every worker left, tells `on_tick` the workers' last states (a worker
/// timed out while the master waited for the links to close is lost there too), and gives the
/// image or why there is none.
fn finish(
    mut session: Session<'_>,
    mut wire: Links,
    events: &Receiver<Event>,
    on_tick: Option<OnTick<'_>>,
) -> Result<ClusterImage, ClusterError> {
    let live: HashSet<usize> = session.alive().collect();
    for id in 0..session.workers() {
        if live.contains(&id) {
            wire.send(id, &MasterMessage::EndSession);
        }
        wire.close(id);
    }
    // Give the writers a moment to deliver `EndSession` (or a rejection), so workers know the
    // session is over before this process exits; a writer stuck on a dead link is not waited
    // for, nor one whose link was cut.
    let deadline = Instant::now() + END_SESSION_GRACE;
    let writing: HashSet<usize> = (0..session.workers())
        .filter(|&id| !wire.is_cut(id))
        .collect();
    let finished = wire.wait_for_writers(&writing, deadline);
    let finished: HashSet<usize> = finished.intersection(&live).copied().collect();
    // Then read until each worker that got `EndSession` closes its end (what it still sends
    // is dropped): a socket closed while the worker's frames sit unread in it would reset
    // the connection, and the worker could lose `EndSession` and report a failed session.
    // The time-out still holds: a worker that hung with requests in flight is lost (and
    // cut) once it is due, not waited for to the deadline and reported `ok`.
    let mut open = finished.clone();
    while !open.is_empty() {
        let now = Instant::now();
        session.time_out_silent(now, &mut wire);
        open.retain(|&id| session.is_alive(id));
        if open.is_empty() || now >= deadline {
            break;
        }
        let left = deadline.saturating_duration_since(now).min(POLL_INTERVAL);
        match events.recv_timeout(left) {
            Ok(Event::Closed(id, _)) => {
                open.remove(&id);
            }
            Ok(_) | Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
    }
    // A writer stuck on a dead link, or a worker that does not close: cut the link so its
    // threads end.
    for id in session.alive() {
        if !finished.contains(&id) || open.contains(&id) {
            wire.cut(id);
        }
    }
    if let Some(tick) = on_tick {
        tick(&session.worker_states());
    }
    session.into_image()
}
