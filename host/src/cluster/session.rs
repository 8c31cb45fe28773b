//! The session state machine of the master, with no I/O and no threads: where each worker is
//! in its session, which tasks it has in flight, what is re-issued when requests or workers are
//! lost, and which results are duplicates. It takes [`Event`]s and answers through a [`Wire`]
//! (the [`link threads`](crate::cluster::link_threads), or a recorder in tests).
//!
//! Each worker is greeted (`Hello`), given the job (`Job`, then scene chunks as it asks for
//! them) and, once `Ready`, kept with a full window of requests from the [`LineScheduler`]'s
//! window policy. The first result of a task goes to the [`Assembly`]; later copies are counted
//! and dropped. Lost work is found three ways. Workers answer requests in order, so a result for
//! a later request means the earlier ones were lost on the link. A dropped frame (either side)
//! or a silent worker gets a `Fence`; its `FenceAck` marks every request sent before it as lost.
//! A worker silent for the whole time-out, closed, or refusing the job is dropped. Lost tasks go
//! back to the front of the queue.

use crate::cluster::assembly::{Assembly, Decided};
use crate::cluster::checkpoint::Record;
use crate::cluster::job::{ClusterError, ClusterImage, ClusterJob, MasterOptions};
use crate::cluster::link::LinkKind;
use crate::cluster::report::{Activity, WorkerReport, WorkerState};
use crate::cluster::schedule::{LineScheduler, Task};
use crate::cluster::verify::{Held, Verifier};
use crate::util::secret::random_nonce;
use crate::util::text::printable;
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::{Duration, Instant};
use strahl_core::render::pixel::Pixel;
use strahl_core::render::ray_limit::LinePass;
use strahl_core::render::stats::RayCounts;
use strahl_core::wire::auth::{self, Nonce, Proof, Role};
use strahl_core::wire::message::{
    decode_pixels, Hello, MasterMessage, Refusal, Rejection, WorkerMessage,
};
use strahl_core::wire::{MAX_LINES_PER_REQUEST, PROTOCOL_VERSION, SCENE_WINDOW};
use strahl_core::worker::{LineBuffers, LineRequest};

/// Where the session sends its messages to workers.
pub(crate) trait Wire {
    /// Queues `msg` for worker `id` (nothing once its link is cut).
    fn send(&mut self, id: usize, msg: &MasterMessage<'_>);
    /// Bytes queued for worker `id` and not yet written.
    fn queued(&self, id: usize) -> usize;
    /// When a scene chunk to worker `id` was last written (or its link was set up).
    fn last_chunk_write(&self, id: usize) -> Instant;
    /// Cuts worker `id`'s link: nothing more goes out, blocked reads and writes return.
    fn cut(&mut self, id: usize);
    /// Closes worker `id`'s link once what is queued for it is written.
    fn close(&mut self, id: usize);
}

/// A worker's message, decoded and checked in its reader thread, owning its data. It mirrors
/// [`strahl_core::wire::message::WorkerMessage`] field for field (which borrows the frame,
/// so cannot cross the channel), keeping only what the session reads.
#[derive(Debug)]
pub(crate) enum Incoming {
    Hello {
        version: u32,
        name: String,
        arch: String,
        threads: u32,
        nonce: Nonce,
        proof: Option<Proof>,
    },
    NeedScene {
        job: u32,
        offset: u32,
        restart: bool,
    },
    Ready {
        job: u32,
    },
    Line {
        job: u32,
        line: u32,
        refined: bool,
        rays: RayCounts,
        pixels: Vec<Pixel>,
    },
    FenceAck {
        seq: u32,
    },
    Dropped,
    Refused {
        job: u32,
        reason: Refusal,
    },
    Panicked {
        message: String,
    },
}

/// What the link threads tell the master loop.
#[derive(Debug)]
pub(crate) enum Event {
    Message(usize, Incoming),
    BadFrame(usize),
    Closed(usize, String),
}

/// Where a worker is in its session.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    /// `Hello` sent, waiting for the worker's.
    Greeting,
    /// `Job` sent; the scene may be in transfer.
    Loading,
    /// Ready for line requests.
    Working,
    /// Dropped; see the report.
    Gone,
}

/// What a silent worker is sent to see whether it is still there.
#[derive(Clone, Copy, Debug)]
enum Probe {
    /// `Hello` again (it has not greeted).
    Hello,
    /// `Job` again (it is loading the scene).
    Job,
    /// A `Fence` (it is working).
    Fence,
}

/// One outstanding request.
#[derive(Clone, Copy, Debug)]
struct Request {
    task: Task,
    seq: u32,
    sent: Instant,
}

/// The pending fence of a worker.
#[derive(Clone, Copy, Debug)]
struct Fence {
    /// Its number.
    seq: u32,
    /// The first request sequence number sent after it: requests before it are lost once it is
    /// answered.
    upto: u32,
    sent: Instant,
}

/// The session's view of one worker.
struct Peer {
    report: WorkerReport,
    state: State,
    /// The master's nonce in every `Hello` to this worker ([`strahl_core::wire::auth`]).
    nonce: Nonce,
    /// The last step forward: its `Hello`, a `NeedScene` further on than before, `Ready`, a
    /// result for a line it was asked for (or the request that ended an idle spell). Fence
    /// answers, drop notices, bad frames and stale messages are no progress: a worker that is
    /// alive but delivers nothing is dropped like a silent one.
    last_progress: Instant,
    last_probe: Instant,
    requests: VecDeque<Request>,
    next_seq: u32,
    fence: Option<Fence>,
    last_result: Option<Instant>,
    /// Scene bytes queued for sending so far (from the last restart).
    scene_sent_upto: u32,
    /// The furthest offset the worker has asked for.
    scene_asked: Option<u32>,
    /// Every request it got has its answer (requests lost on the link do not count).
    idle: bool,
}

/// Scene bytes a master keeps queued for one worker at most: the two windows the protocol
/// allows in flight, plus frame overhead.
const SCENE_QUEUE_LIMIT: usize = 2 * SCENE_WINDOW as usize + 4096;

/// One thread's work a multi-line request should carry: enough that the cost of a request
/// (a frame each way through the link threads and the session) is small beside it.
pub const REQUEST_WORK: Duration = Duration::from_millis(2);

/// Results needed before the cost of a line counts as measured.
const COST_SAMPLES: u32 = 8;

/// The most lines one worker holds at once, whatever its threads.
const MAX_OUTSTANDING: u32 = 4096;

/// `tasks` cut into requests: runs of up to `per_request` consecutive first passes; a second
/// pass (it has a mask) is a request of its own.
fn runs(tasks: &[Task], per_request: u32) -> Vec<&[Task]> {
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=tasks.len() {
        let joins = match (tasks.get(i - 1), tasks.get(i)) {
            (Some(Task::Line(a)), Some(Task::Line(b))) => {
                *b == a + 1 && (i - start) < per_request as usize
            }
            _ => false,
        };
        if !joins {
            out.push(&tasks[start..i]);
            start = i;
        }
    }
    out
}

/// The master's session with every worker of one render.
pub(crate) struct Session<'a> {
    job: &'a ClusterJob,
    opts: &'a MasterOptions,
    peers: Vec<Peer>,
    sched: LineScheduler,
    image: Assembly,
    verify: Verifier,
    on_line: &'a (dyn Fn(u32, RayCounts) + Sync),
    log: &'a (dyn Fn(&str) + Sync),
    /// Told each result used (task number, rays, pixels): the checkpoint.
    on_result: Option<OnResult<'a>>,
    /// Told each line's final pixels and who delivered them: the live view.
    on_final: Option<OnFinal<'a>>,
    /// The worker whose result last went into each line (`None`: resumed or the master's own).
    authors: Vec<Option<usize>>,
    /// When the first line was asked for.
    first_request: Option<Instant>,
}

/// A line whose pixels are final, as [`OnFinal`] is told.
pub struct FinalLine<'p> {
    /// The line, counted from the top.
    pub y: u32,
    /// The rays it took in all.
    pub rays: RayCounts,
    /// Its final pixels.
    pub pixels: &'p [Pixel],
    /// The worker (numbered from 0 in the order they joined) whose result went in last;
    /// `None` for a line resumed from a checkpoint or rendered by the master itself.
    pub worker: Option<usize>,
}

/// Where each line's final pixels go.
pub type OnFinal<'a> = &'a (dyn Fn(FinalLine<'_>) + Sync);

/// Where each result used goes (task number, rays, pixels).
pub type OnResult<'a> = &'a (dyn Fn(u32, RayCounts, &[Pixel]) + Sync);

impl<'a> Session<'a> {
    /// A session for `job` with no worker yet; `on_line(y, rays)` is called for each line's
    /// final pixels, `log` with a message for each worker lost.
    pub(crate) fn new(
        job: &'a ClusterJob,
        opts: &'a MasterOptions,
        on_line: &'a (dyn Fn(u32, RayCounts) + Sync),
        log: &'a (dyn Fn(&str) + Sync),
    ) -> Self {
        let sched = match job.adaptive {
            Some(_) => LineScheduler::with_pending(2 * job.height, job.height),
            None => LineScheduler::for_lines(job.height, job.lines.clone()),
        };
        Session {
            job,
            opts,
            peers: Vec::new(),
            sched,
            image: Assembly::new(job),
            // Verification needs the scene, to render a line itself when two workers differ.
            verify: Verifier::new(
                if job.scene.is_some() {
                    opts.verify
                } else {
                    0.0
                },
                if job.adaptive.is_some() {
                    job.height
                } else {
                    0
                },
            ),
            on_line,
            log,
            on_result: None,
            on_final: None,
            authors: vec![None; job.height as usize],
            first_request: None,
        }
    }

    /// Tells `on_result` about every result used from now on.
    pub(crate) fn record_results(&mut self, on_result: OnResult<'a>) {
        self.on_result = Some(on_result);
    }

    /// Tells `on_final` about every line whose pixels are final from now on.
    pub(crate) fn report_final_lines(&mut self, on_final: OnFinal<'a>) {
        self.on_final = Some(on_final);
    }

    /// Takes the results of an earlier run of the same job (a checkpoint) as if they had just
    /// arrived, in their order; a task recorded twice takes its later result, except a first
    /// pass with adaptive multisampling, whose first result decided its neighbours.
    pub(crate) fn replay(&mut self, records: &[Record]) {
        for r in records {
            let task = Task::from_index(r.task, self.job.height);
            let (Task::Line(y) | Task::Refine(y)) = task;
            // A checkpoint of the same scene made with another region.
            if !self.job.lines.contains(&y) {
                continue;
            }
            let decided = self.job.adaptive.is_some() && matches!(task, Task::Line(_));
            if self.sched.complete(r.task, false) || !decided {
                self.apply_result(task, None, r.rays, &r.pixels);
            }
        }
    }

    /// Adds a worker reached at `address` over `kind`, numbered in order from 0, and greets it.
    /// If its link threads did not start (`link_ok` false) it is dropped at once instead.
    pub(crate) fn add(
        &mut self,
        address: &str,
        kind: LinkKind,
        link_ok: bool,
        wire: &mut dyn Wire,
    ) {
        let id = self.peers.len();
        let now = Instant::now();
        self.peers.push(Peer {
            report: WorkerReport::new(address, kind),
            state: State::Greeting,
            nonce: random_nonce(),
            last_progress: now,
            last_probe: now,
            requests: VecDeque::new(),
            next_seq: 0,
            fence: None,
            last_result: None,
            scene_sent_upto: 0,
            scene_asked: None,
            idle: false,
        });
        if link_ok {
            self.send_hello(id, wire);
        } else {
            self.lose(id, "cannot start its link threads".to_string(), wire);
        }
    }

    /// Whether every task has its result.
    pub(crate) fn is_complete(&self) -> bool {
        self.sched.is_complete()
    }

    /// Whether some worker is still in the session.
    pub(crate) fn any_alive(&self) -> bool {
        (0..self.peers.len()).any(|id| self.is_alive(id))
    }

    /// The workers still in the session.
    pub(crate) fn alive(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.peers.len()).filter(|&id| self.is_alive(id))
    }

    /// Whether worker `id` is still in the session.
    pub(crate) fn is_alive(&self, id: usize) -> bool {
        self.peers[id].state != State::Gone
    }

    /// How many workers joined.
    pub(crate) fn workers(&self) -> usize {
        self.peers.len()
    }

    fn send_hello(&self, id: usize, wire: &mut dyn Wire) {
        let msg = MasterMessage::Hello(Hello {
            version: PROTOCOL_VERSION,
            name: &self.opts.name,
            arch: std::env::consts::ARCH,
            scene_memory: 0,
            threads: 0,
            nonce: self.peers[id].nonce,
            proof: None,
        });
        wire.send(id, &msg);
    }

    fn send_job(&self, id: usize, wire: &mut dyn Wire) {
        let (job, digest, scene_len) = (self.job.id, self.job.blob.digest, self.job.blob.len());
        wire.send(
            id,
            &MasterMessage::Job {
                job,
                digest,
                scene_len,
            },
        );
    }

    fn send_fence(&mut self, id: usize, now: Instant, wire: &mut dyn Wire) {
        let peer = &mut self.peers[id];
        let seq = peer.next_seq;
        peer.next_seq += 1;
        peer.fence = Some(Fence {
            seq,
            upto: seq,
            sent: now,
        });
        wire.send(id, &MasterMessage::Fence { seq });
    }

    /// Takes one event from the link threads.
    pub(crate) fn handle(&mut self, event: Event, wire: &mut dyn Wire) {
        let id = match &event {
            Event::Message(id, _) | Event::BadFrame(id) | Event::Closed(id, _) => *id,
        };
        if self.peers[id].state == State::Gone {
            return;
        }
        let now = Instant::now();
        match event {
            Event::Closed(_, reason) => self.lose(id, reason, wire),
            Event::BadFrame(_) => {
                self.peers[id].report.frames_dropped += 1;
                self.fence_after_loss(id, now, wire);
            }
            Event::Message(_, msg) => self.take(id, msg, now, wire),
        }
    }

    /// After a frame was lost on a working worker's link, asks which requests survived (again,
    /// if the pending fence is older than a probe interval: the fence itself may be lost).
    fn fence_after_loss(&mut self, id: usize, now: Instant, wire: &mut dyn Wire) {
        let peer = &self.peers[id];
        let pending = peer
            .fence
            .is_some_and(|f| now.saturating_duration_since(f.sent) < self.opts.probe_interval);
        if peer.state == State::Working && !pending {
            self.send_fence(id, now, wire);
        }
    }

    /// Queues scene chunks for a loading worker: up to two windows past what it asked for, and
    /// no more than [`SCENE_QUEUE_LIMIT`] bytes waiting at once.
    fn pump_scene(&mut self, id: usize, wire: &mut dyn Wire) {
        let Some(asked) = self.peers[id].scene_asked else {
            return;
        };
        let blob = Arc::clone(&self.job.blob);
        let until = blob.len().min(asked.saturating_add(2 * SCENE_WINDOW));
        while self.peers[id].scene_sent_upto < until && wire.queued(id) < SCENE_QUEUE_LIMIT {
            let at = self.peers[id].scene_sent_upto;
            let bytes = blob.chunk_at(at);
            if bytes.is_empty() {
                break;
            }
            self.peers[id].scene_sent_upto = at + bytes.len() as u32;
            wire.send(
                id,
                &MasterMessage::SceneChunk {
                    digest: blob.digest,
                    offset: at,
                    bytes,
                },
            );
        }
    }

    fn take(&mut self, id: usize, msg: Incoming, now: Instant, wire: &mut dyn Wire) {
        let job = self.job.id;
        match msg {
            Incoming::Hello {
                version,
                name,
                arch,
                threads,
                nonce,
                proof,
            } => self.on_hello(
                id,
                (version, name, arch, threads),
                (nonce, proof),
                now,
                wire,
            ),
            Incoming::NeedScene {
                job: j,
                offset,
                restart,
            } if j == job => self.on_need_scene(id, offset, restart, now, wire),
            Incoming::Ready { job: j } if j == job => {
                let peer = &mut self.peers[id];
                if matches!(peer.state, State::Greeting | State::Loading) {
                    peer.state = State::Working;
                    peer.last_progress = now;
                    peer.idle = true;
                }
            }
            Incoming::Line {
                job: j,
                line,
                refined,
                rays,
                pixels,
            } if j == job
                && self.job.lines.contains(&line)
                && (!refined || self.job.adaptive.is_some()) =>
            {
                let task = Task::from_wire(line, refined);
                // A count that a line cannot have comes from a broken or hostile worker.
                let pass = if refined {
                    LinePass::Refined
                } else {
                    LinePass::First
                };
                if let Some(impossible) = self.job.ray_limits.check(&rays, pass) {
                    let reason = format!("it reported {impossible} (line {line})");
                    return self.lose(id, reason, wire);
                }
                self.take_line(id, task, (rays, &pixels), now, wire);
            }
            Incoming::FenceAck { seq } => self.on_fence_ack(id, seq),
            Incoming::Dropped => {
                self.peers[id].report.frames_dropped += 1;
                self.fence_after_loss(id, now, wire);
            }
            Incoming::Refused {
                reason: Refusal::Unauthenticated,
                ..
            } => {
                let reason = "it refused this master: it requires the shared secret \
                              (--secret-file), and this master has another or none";
                self.lose(id, reason.to_string(), wire);
            }
            Incoming::Panicked { message } => {
                let reason = format!("it halted: {}", printable(&message.replace('\n', " ")));
                self.lose(id, reason, wire);
            }
            Incoming::Refused { job: j, reason } if j == job => {
                let reason = format!("it refused the job: {}", refusal_text(reason));
                self.lose(id, reason, wire);
            }
            // Messages about another job (an earlier one), or a line not rendered.
            Incoming::NeedScene { .. }
            | Incoming::Ready { .. }
            | Incoming::Line { .. }
            | Incoming::Refused { .. } => {
                self.peers[id].report.frames_dropped += 1;
            }
        }
    }

    /// A worker's `Hello`: its version, then its name, architecture and threads
    /// ([`hello_fault`]), which are taken, then its proof of the secret, then the job.
    fn on_hello(
        &mut self,
        id: usize,
        (version, name, arch, threads): (u32, String, String, u32),
        (nonce, proof): (Nonce, Option<Proof>),
        now: Instant,
        wire: &mut dyn Wire,
    ) {
        if self.peers[id].state != State::Greeting {
            return;
        }
        if version != PROTOCOL_VERSION {
            return self.lose(
                id,
                format!(
                    "it speaks protocol version {version}, this master speaks version \
                     {PROTOCOL_VERSION}"
                ),
                wire,
            );
        }
        if let Some(fault) = hello_fault(&name, &arch, threads) {
            return self.lose(id, fault, wire);
        }
        let report = &mut self.peers[id].report;
        (report.name, report.arch, report.threads) = (name, arch, threads);
        if let Err((rejection, reason)) = self.authenticate(id, &nonce, proof.as_ref(), wire) {
            return self.reject(id, rejection, reason, wire);
        }
        let peer = &mut self.peers[id];
        peer.last_progress = now;
        peer.state = State::Loading;
        self.send_job(id, wire);
    }

    /// Checks worker `id`'s proof of the secret (`worker` is its nonce) and proves the
    /// master's; or says why the worker is rejected.
    fn authenticate(
        &self,
        id: usize,
        worker: &Nonce,
        proof: Option<&Proof>,
        wire: &mut dyn Wire,
    ) -> Result<(), (Rejection, &'static str)> {
        let master = &self.peers[id].nonce;
        // Workers in this process share the master's trust: they have no secret to prove.
        if self.peers[id].report.kind == LinkKind::InProcess {
            return Ok(());
        }
        match (&self.opts.secret, proof) {
            (None, None) => Ok(()),
            (None, Some(_)) => Err((
                Rejection::MasterHasNoSecret,
                "it requires a shared secret: give this master the same --secret-file",
            )),
            (Some(_), None) => Err((
                Rejection::NoProof,
                "it has no shared secret: start it with --secret-file",
            )),
            (Some(k), Some(p)) if auth::verify(k.bytes(), Role::Worker, master, worker, p) => {
                let proof = auth::prove(k.bytes(), Role::Master, master, worker);
                wire.send(id, &MasterMessage::Auth { proof });
                Ok(())
            }
            (Some(_), Some(_)) => Err((
                Rejection::WrongProof,
                "its proof of the shared secret is wrong (another secret)",
            )),
        }
    }

    fn on_need_scene(
        &mut self,
        id: usize,
        offset: u32,
        restart: bool,
        now: Instant,
        wire: &mut dyn Wire,
    ) {
        let peer = &mut self.peers[id];
        if !matches!(peer.state, State::Greeting | State::Loading) {
            return;
        }
        peer.state = State::Loading;
        if peer.scene_asked.is_none_or(|a| offset > a) {
            peer.last_progress = now;
        }
        peer.scene_asked = Some(peer.scene_asked.map_or(offset, |a| a.max(offset)));
        if restart || offset > peer.scene_sent_upto {
            peer.scene_sent_upto = offset;
        }
        self.pump_scene(id, wire);
    }

    fn on_fence_ack(&mut self, id: usize, seq: u32) {
        let peer = &mut self.peers[id];
        let Some(fence) = peer.fence.filter(|f| f.seq == seq) else {
            return;
        };
        peer.fence = None;
        let lost: Vec<Task> = peer
            .requests
            .iter()
            .filter(|r| r.seq < fence.upto)
            .map(|r| r.task)
            .collect();
        peer.requests.retain(|r| r.seq >= fence.upto);
        self.release(id, &lost);
    }

    fn take_line(
        &mut self,
        id: usize,
        task: Task,
        (rays, pixels): (RayCounts, &[Pixel]),
        now: Instant,
        wire: &mut dyn Wire,
    ) {
        let peer = &mut self.peers[id];
        // Only answers to requests count; anything else is a peer's mistake, not a pixel.
        let Some(i) = peer.requests.iter().position(|r| r.task == task) else {
            peer.report.frames_dropped += 1;
            return;
        };
        peer.last_progress = now;
        // Requests are answered in order: those before this one were lost.
        let lost: Vec<Task> = peer.requests.drain(..i).map(|r| r.task).collect();
        if let Some(r) = peer.requests.pop_front() {
            let started = peer.last_result.map_or(r.sent, |t| t.max(r.sent));
            peer.report.busy += now.saturating_duration_since(started);
        }
        peer.last_result = Some(now);
        peer.idle = peer.requests.is_empty() && lost.is_empty();
        peer.report.rays += rays;
        let index = task.index(self.job.height);
        if self.verify.sampled(index) && !self.sched.is_done(index) {
            self.check_result(id, task, rays, pixels, wire);
        } else if self.sched.complete(index, true) {
            self.peers[id].report.lines += 1;
            self.verify.used_unchecked(index, id);
            self.use_result(task, Some(id), rays, pixels);
        } else {
            self.peers[id].report.duplicates += 1;
        }
        self.release(id, &lost);
    }

    /// A sampled task's result from worker `id` (`--verify`): the first is held and the task
    /// goes to another worker; the second must match it byte for byte. If they differ, the
    /// master renders the task itself and convicts whoever differs from that.
    fn check_result(
        &mut self,
        id: usize,
        task: Task,
        rays: RayCounts,
        pixels: &[Pixel],
        wire: &mut dyn Wire,
    ) {
        let index = task.index(self.job.height);
        let first = match self.verify.held(index).map(|h| h.worker) {
            None => {
                let pixels = pixels.to_vec();
                self.verify.hold(
                    index,
                    Held {
                        worker: id,
                        rays,
                        pixels,
                    },
                );
                self.sched.release(index);
                return;
            }
            // Its own result again (a re-issued request): still no second opinion.
            Some(w) if w == id => {
                self.peers[id].report.duplicates += 1;
                self.sched.release(index);
                return;
            }
            Some(_) => self.verify.take(index),
        };
        let Some(first) = first else { return };
        if first.matches(rays, pixels) {
            self.peers[first.worker].report.verified += 1;
            self.peers[id].report.verified += 1;
            // The first result is used; the second, which confirmed it, is a copy.
            self.peers[id].report.duplicates += 1;
            self.finish_checked(first.worker, task, rays, pixels);
            return;
        }
        let second = Held {
            worker: id,
            rays,
            pixels: pixels.to_vec(),
        };
        self.settle(task, [Some(first), Some(second)], wire);
    }

    /// Decides task `task` from the master's own render: every held result that differs from
    /// it convicts its worker; the master's result is used.
    fn settle(&mut self, task: Task, results: [Option<Held>; 2], wire: &mut dyn Wire) {
        let Some((rays, pixels)) = self.render_here(task) else {
            return;
        };
        let mut credited = None;
        for held in results.into_iter().flatten() {
            if held.matches(rays, &pixels) {
                self.peers[held.worker].report.verified += 1;
                if credited.replace(held.worker).is_some() {
                    self.peers[held.worker].report.duplicates += 1;
                }
            } else {
                // A result not used: counted with the copies.
                self.peers[held.worker].report.duplicates += 1;
                self.convict(held.worker, task, wire);
            }
        }
        match credited {
            Some(w) => self.finish_checked(w, task, rays, &pixels),
            None => {
                // Nobody's result was right: the master's own is used.
                if self.sched.complete(task.index(self.job.height), false) {
                    self.use_result(task, None, rays, &pixels);
                }
            }
        }
    }

    /// Uses a checked result of `task`, crediting worker `w` with it.
    fn finish_checked(&mut self, w: usize, task: Task, rays: RayCounts, pixels: &[Pixel]) {
        if self.sched.complete(task.index(self.job.height), true) {
            self.peers[w].report.lines += 1;
            self.use_result(task, Some(w), rays, pixels);
        }
    }

    /// Drops worker `w`, whose result for `task` was wrong, and renders again elsewhere the
    /// tasks it delivered that were not checked.
    fn convict(&mut self, w: usize, task: Task, wire: &mut dyn Wire) {
        for index in self.verify.convict(w) {
            self.sched.reopen(index);
            let report = &mut self.peers[w].report;
            // Its result for the task is no longer used: it becomes a copy, re-issued.
            report.lines = report.lines.saturating_sub(1);
            report.duplicates += 1;
            report.reissued += 1;
        }
        let (what, y) = match task {
            Task::Line(y) => ("line", y),
            Task::Refine(y) => ("second pass of line", y),
        };
        let reason = format!(
            "its pixels for the {what} {y} differ from another worker's and from the master's \
             own render (--verify)"
        );
        self.lose(w, reason, wire);
    }

    /// Renders `task` on the master, as a worker would answer it; `None` without the scene.
    fn render_here(&self, task: Task) -> Option<(RayCounts, Vec<Pixel>)> {
        let scene = self.job.scene.as_ref()?;
        let mask = match task {
            Task::Line(_) => None,
            Task::Refine(y) => Some(self.image.refine_mask(y)),
        };
        let (Task::Line(line) | Task::Refine(line)) = task;
        let mut buffers = LineBuffers::new();
        let request = LineRequest {
            scene,
            job: self.job.id,
            line,
            mask: mask.as_deref(),
        };
        match buffers.answer(request) {
            Ok(WorkerMessage::LineResult { rays, pixels, .. }) => {
                let mut out = vec![Pixel::default(); self.job.width as usize];
                decode_pixels(pixels, &mut out).ok()?;
                Some((rays, out))
            }
            _ => None,
        }
    }

    /// Held results that no other worker is left to check are checked by the master itself.
    fn settle_unchecked(&mut self, wire: &mut dyn Wire) {
        for (index, holder) in self.verify.held_tasks() {
            let others =
                (0..self.peers.len()).any(|p| p != holder && self.peers[p].state != State::Gone);
            // (A convicted worker's held results are gone already.)
            if let (false, Some(held)) = (others, self.verify.take(index)) {
                let task = Task::from_index(index, self.job.height);
                self.settle(task, [Some(held), None], wire);
            }
        }
    }

    /// Puts the first result of `task`, from `worker`, into the image; queues or finishes the
    /// second passes it decides.
    fn use_result(&mut self, task: Task, worker: Option<usize>, rays: RayCounts, pixels: &[Pixel]) {
        if let Some(record) = self.on_result {
            record(task.index(self.job.height), rays, pixels);
        }
        self.apply_result(task, worker, rays, pixels);
    }

    /// [`Session::use_result`] without telling the checkpoint.
    fn apply_result(
        &mut self,
        task: Task,
        worker: Option<usize>,
        rays: RayCounts,
        pixels: &[Pixel],
    ) {
        let h = self.job.height;
        let (Task::Line(y) | Task::Refine(y)) = task;
        self.authors[y as usize] = worker;
        match task {
            Task::Line(y) => match self.image.put_line(y, rays, pixels) {
                Decided::Final => self.line_final(y, rays),
                Decided::Refine(lines) => {
                    for (line, refine) in lines.into_iter().flatten() {
                        let second = Task::Refine(line).index(h);
                        if refine {
                            self.sched.queue(second);
                        } else if self.sched.complete(second, false) {
                            self.line_final(line, self.image.first_rays(line));
                        }
                    }
                }
            },
            Task::Refine(y) => {
                let all = self.image.put_refined(y, rays, pixels);
                self.line_final(y, all);
            }
        }
    }

    /// Tells the hooks that line `y`'s pixels are final, taking `rays` in all.
    fn line_final(&self, y: u32, rays: RayCounts) {
        (self.on_line)(y, rays);
        if let Some(on_final) = self.on_final {
            on_final(FinalLine {
                y,
                rays,
                pixels: self.image.line(y),
                worker: self.authors[y as usize],
            });
        }
    }

    /// Gives `tasks` of worker `id` back to the scheduler: those no one else holds go to the
    /// front of the queue in their order (the last is put in front first).
    fn release(&mut self, id: usize, tasks: &[Task]) {
        for &task in tasks.iter().rev() {
            if self.sched.release(task.index(self.job.height)) {
                self.peers[id].report.reissued += 1;
            }
        }
    }

    /// Drops worker `id`: its tasks go back to the queue and its link is cut.
    fn lose(&mut self, id: usize, reason: String, wire: &mut dyn Wire) {
        if self.peers[id].state != State::Gone {
            wire.cut(id);
            self.forget(id, reason);
        }
    }

    /// Rejects worker `id` after its `Hello`: it is told why (`Reject`), its link closes once
    /// that is written, and it is dropped.
    fn reject(&mut self, id: usize, rejection: Rejection, reason: &str, wire: &mut dyn Wire) {
        if self.peers[id].state != State::Gone {
            wire.send(id, &MasterMessage::Reject { reason: rejection });
            wire.close(id);
            self.forget(id, reason.to_string());
        }
    }

    /// Marks worker `id` gone (its link already cut or closing): its tasks go back to the
    /// queue, and the loss is logged and reported.
    fn forget(&mut self, id: usize, reason: String) {
        let peer = &mut self.peers[id];
        peer.state = State::Gone;
        let tasks: Vec<Task> = peer.requests.drain(..).map(|r| r.task).collect();
        let before = peer.report.reissued;
        self.release(id, &tasks);
        let peer = &mut self.peers[id];
        let requeued = peer.report.reissued - before;
        let who = if peer.report.name == peer.report.address {
            peer.report.name.clone()
        } else {
            format!("{} ({})", peer.report.name, peer.report.address)
        };
        (self.log)(&format!(
            "worker {who} lost: {reason}; {requeued} line{} re-queued",
            if requeued == 1 { "" } else { "s" }
        ));
        peer.report.lost = Some(reason);
    }

    /// Drops workers silent for the time-out, and probes those silent for a probe interval.
    pub(crate) fn check_timeouts(&mut self, now: Instant, wire: &mut dyn Wire) {
        self.settle_unchecked(wire);
        for id in 0..self.peers.len() {
            let Some((stalled, probe)) = self.stall(id, now, wire) else {
                continue;
            };
            if self.time_out(id, stalled, wire) {
                continue;
            }
            let peer = &self.peers[id];
            if stalled < self.opts.probe_interval
                || now.duration_since(peer.last_probe) < self.opts.probe_interval
            {
                continue;
            }
            self.peers[id].last_probe = now;
            match probe {
                Probe::Hello => self.send_hello(id, wire),
                Probe::Job => self.send_job(id, wire),
                Probe::Fence => self.send_fence(id, now, wire),
            }
        }
    }

    /// After the image is complete, while the master waits for the workers to close: drops
    /// those silent for the time-out, as during the render, but probes none (the session is
    /// over). A worker that hung with requests in flight is reported lost, not `ok`.
    pub(crate) fn time_out_silent(&mut self, now: Instant, wire: &mut dyn Wire) {
        for id in 0..self.peers.len() {
            if let Some((stalled, _)) = self.stall(id, now, wire) {
                self.time_out(id, stalled, wire);
            }
        }
    }

    /// How long worker `id` has kept the master waiting, and what would ask it again; `None`
    /// for a worker the master does not wait on (gone, or working with nothing in flight).
    fn stall(&self, id: usize, now: Instant, wire: &dyn Wire) -> Option<(Duration, Probe)> {
        let peer = &self.peers[id];
        let probe = match peer.state {
            State::Gone => return None,
            State::Working if peer.requests.is_empty() => return None,
            State::Working => Probe::Fence,
            State::Greeting => Probe::Hello,
            State::Loading => Probe::Job,
        };
        // While scene chunks are still going out, the worker cannot answer yet: the time
        // counts from the last chunk written (probes do not count).
        let since = match peer.state {
            State::Loading => peer.last_progress.max(wire.last_chunk_write(id)),
            _ => peer.last_progress,
        };
        Some((now.saturating_duration_since(since), probe))
    }

    /// Drops worker `id` if it has been `stalled` for the time-out; returns whether it did.
    fn time_out(&mut self, id: usize, stalled: Duration, wire: &mut dyn Wire) -> bool {
        if stalled < self.opts.worker_timeout {
            return false;
        }
        let mut reason = format!("no answer for {:.1} s", stalled.as_secs_f64());
        let unreadable = self.peers[id].report.frames_dropped;
        if unreadable > 0 {
            reason += &format!("; {}", unreadable_frames(unreadable));
        }
        self.lose(id, reason, wire);
        true
    }

    /// Sends loading workers more scene and fills working workers' windows: each may hold
    /// `window × threads` requests of [`Session::lines_per_request`] lines, and gets whole
    /// requests only.
    pub(crate) fn fill_windows(&mut self, now: Instant, wire: &mut dyn Wire) {
        let per_request = self.lines_per_request();
        for id in 0..self.peers.len() {
            if self.peers[id].state == State::Loading {
                self.pump_scene(id, wire);
            }
            if self.peers[id].state != State::Working {
                continue;
            }
            let outstanding = self.peers[id].requests.len();
            let limit = (self.opts.window.max(1) * self.peers[id].report.threads * per_request)
                .min(MAX_OUTSTANDING) as usize;
            let room = limit.saturating_sub(outstanding) / per_request as usize;
            if room == 0 {
                continue;
            }
            let window = (outstanding + room * per_request as usize) as u32;
            let verify = &self.verify;
            let tasks: Vec<Task> = self
                .sched
                .fill_window_except(outstanding, window, |t| verify.excluded(id, t))
                .into_iter()
                .map(|index| Task::from_index(index, self.job.height))
                .collect();
            for run in runs(&tasks, per_request) {
                self.request(id, run, now, wire);
            }
        }
    }

    /// Lines per request: the option, or as many as make [`REQUEST_WORK`] of one thread's
    /// work at the cost of a line measured so far (1 until [`COST_SAMPLES`] results are in).
    fn lines_per_request(&self) -> u32 {
        if let Some(n) = self.opts.lines_per_request {
            return n.clamp(1, MAX_LINES_PER_REQUEST);
        }
        let (mut work, mut results) = (0.0, 0u32);
        for p in &self.peers {
            work += p.report.busy.as_secs_f64() * f64::from(p.report.threads);
            results += p.report.lines + p.report.duplicates;
        }
        if results < COST_SAMPLES || work <= 0.0 {
            return 1;
        }
        let cost = work / f64::from(results);
        ((REQUEST_WORK.as_secs_f64() / cost).ceil() as u32).clamp(1, MAX_LINES_PER_REQUEST)
    }

    /// Sends one request for `tasks` (consecutive first passes, or one task) to worker `id`.
    fn request(&mut self, id: usize, tasks: &[Task], now: Instant, wire: &mut dyn Wire) {
        self.first_request.get_or_insert(now);
        let peer = &mut self.peers[id];
        let seq = peer.next_seq;
        peer.next_seq += 1;
        if peer.idle {
            // A worker that answered everything it was asked was not hanging while it waited.
            peer.last_progress = now;
            peer.idle = false;
        }
        peer.report.requests += 1;
        peer.report.requested_lines += tasks.len() as u32;
        peer.requests.extend(tasks.iter().map(|&task| Request {
            task,
            seq,
            sent: now,
        }));
        let job = self.job.id;
        match *tasks {
            [Task::Line(line)] => wire.send(id, &MasterMessage::RenderLine { job, line }),
            [Task::Refine(line)] => {
                let mask = self.image.refine_mask(line);
                wire.send(
                    id,
                    &MasterMessage::RefineLine {
                        job,
                        line,
                        mask: &mask,
                    },
                );
            }
            [Task::Line(first), ..] => wire.send(
                id,
                &MasterMessage::RenderLines {
                    job,
                    first,
                    count: tasks.len() as u32,
                },
            ),
            _ => debug_assert!(false, "a request of {tasks:?}"),
        }
    }

    /// Every worker's report so far and what it is doing, in the order they joined.
    pub(crate) fn worker_states(&self) -> Vec<WorkerState> {
        self.peers
            .iter()
            .map(|p| WorkerState {
                report: p.report.clone(),
                activity: match p.state {
                    State::Gone => Activity::Lost,
                    State::Greeting | State::Loading => Activity::Joining,
                    State::Working if p.requests.is_empty() => Activity::Idle,
                    State::Working => Activity::Busy,
                },
            })
            .collect()
    }

    /// Lines whose final pixels are in, and lines in the image.
    pub(crate) fn progress(&self) -> (u32, u32) {
        (self.lines_finished(), self.job.height)
    }

    /// Lines whose final pixels are in.
    fn lines_finished(&self) -> u32 {
        let h = self.job.height;
        match self.job.adaptive {
            Some(_) => (0..h)
                .filter(|&y| self.sched.is_done(Task::Refine(y).index(h)))
                .count() as u32,
            None => self.sched.finished(),
        }
    }

    /// The image, or why there is none.
    pub(crate) fn into_image(self) -> Result<ClusterImage, ClusterError> {
        let finished = self.lines_finished();
        let workers: Vec<WorkerReport> = self.peers.into_iter().map(|p| p.report).collect();
        if !self.sched.is_complete() {
            return Err(ClusterError::AllWorkersLost {
                finished,
                total: self.job.height,
                workers,
            });
        }
        let (pixels, rays) = self.image.into_parts();
        Ok(ClusterImage {
            pixels,
            rays,
            workers,
            first_request: self.first_request,
        })
    }
}

/// `n` frames a peer sent that could not be read, and what that usually means: for a message
/// about a lost worker, and a worker's about its master.
pub fn unreadable_frames(n: u32) -> String {
    let frames = if n == 1 { "frame" } else { "frames" };
    format!(
        "{n} {frames} it sent could not be read (a damaged link, or a program that does not \
         speak Strahl's protocol)"
    )
}

/// A refusal in words.
pub fn refusal_text(reason: Refusal) -> String {
    match reason {
        Refusal::SceneTooLarge { limit } => {
            format!("the scene needs more than the {limit} bytes it can give")
        }
        Refusal::BadScene(e) => format!("the scene is not renderable: {e}"),
        Refusal::CorruptScene => "the scene arrived corrupted".to_string(),
        Refusal::UnknownJob => "it does not know the job".to_string(),
        Refusal::LineOutOfRange => "a line outside the image was requested".to_string(),
        Refusal::BadMask => "a refine request did not fit the scene".to_string(),
        Refusal::Unauthenticated => "the master did not prove the shared secret".to_string(),
    }
}

/// What is wrong with a worker's `Hello` that names it `name` on `arch` and renders `threads`
/// lines at once, if anything: the protocol asks for at least one thread, and the name and
/// architecture are shown in the master's table and messages, where a control character would
/// move the cursor, ring or recolour the operator's terminal.
fn hello_fault(name: &str, arch: &str, threads: u32) -> Option<String> {
    if threads == 0 {
        return Some("its Hello says it renders 0 lines at once (at least 1)".to_string());
    }
    [("name", name), ("architecture", arch)]
        .into_iter()
        .find(|(_, text)| text.chars().any(char::is_control))
        .map(|(what, text)| {
            format!(
                "its {what} `{}` holds control characters",
                text.escape_default()
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cluster::job::AdaptiveJob;
    use std::sync::Mutex;
    use strahl_core::render::ray_limit::LineRayLimits;
    use strahl_core::scene::settings::RenderSettings;
    use strahl_core::wire::scene_blob::{digest, SceneBlob};

    /// A wire that writes down what the session sends and cuts.
    #[derive(Default)]
    struct Recorder {
        sent: Vec<(usize, String)>,
        cut: Vec<usize>,
    }

    impl Recorder {
        /// What was sent since the last call.
        fn take(&mut self) -> Vec<(usize, String)> {
            std::mem::take(&mut self.sent)
        }
    }

    impl Wire for Recorder {
        fn send(&mut self, id: usize, msg: &MasterMessage<'_>) {
            let text = match msg {
                MasterMessage::Hello(_) => "Hello".to_string(),
                MasterMessage::Job { .. } => "Job".to_string(),
                MasterMessage::SceneChunk { offset, .. } => format!("SceneChunk {offset}"),
                MasterMessage::RenderLine { line, .. } => format!("RenderLine {line}"),
                MasterMessage::RenderLines { first, count, .. } => {
                    format!("RenderLines {first}+{count}")
                }
                MasterMessage::Auth { .. } => "Auth".to_string(),
                MasterMessage::Reject { reason } => format!("Reject {reason:?}"),
                MasterMessage::RefineLine { line, mask, .. } => {
                    format!("RefineLine {line} {mask:?}")
                }
                MasterMessage::Fence { seq } => format!("Fence {seq}"),
                MasterMessage::EndSession => "EndSession".to_string(),
            };
            self.sent.push((id, text));
        }

        fn queued(&self, _: usize) -> usize {
            0
        }

        fn last_chunk_write(&self, _: usize) -> Instant {
            Instant::now()
        }

        fn cut(&mut self, id: usize) {
            self.cut.push(id);
        }

        fn close(&mut self, id: usize) {
            self.sent.push((id, "(close)".to_string()));
        }
    }

    fn job(width: u32, height: u32, adaptive: Option<AdaptiveJob>) -> ClusterJob {
        let bytes = vec![7u8; 100];
        ClusterJob {
            id: 3,
            blob: Arc::new(SceneBlob {
                digest: digest(&bytes),
                bytes,
            }),
            width,
            height,
            lines: 0..height,
            adaptive,
            scene: None,
            ray_limits: LineRayLimits::new(
                &RenderSettings {
                    width,
                    height,
                    samples: if adaptive.is_some() { 2 } else { 1 },
                    aa_threshold: adaptive.map(|a| a.threshold),
                    ..RenderSettings::default()
                },
                1,
            ),
        }
    }

    fn line(job: &ClusterJob, y: u32, refined: bool, value: u16) -> Event {
        line_from(0, job, y, refined, value)
    }

    /// Worker `id`'s result for line `y`, every pixel `value`.
    fn line_from(id: usize, job: &ClusterJob, y: u32, refined: bool, value: u16) -> Event {
        Event::Message(
            id,
            Incoming::Line {
                job: job.id,
                line: y,
                refined,
                rays: RayCounts {
                    primary: if refined { 0 } else { u64::from(job.width) },
                    ..RayCounts::default()
                },
                pixels: vec![Pixel([value; 3]); job.width as usize],
            },
        )
    }

    /// Greets worker 0, loads it and makes it ready.
    fn ready_worker(s: &mut Session<'_>, job: &ClusterJob, wire: &mut Recorder) {
        ready_worker_n(s, job, wire, 0);
    }

    /// Adds worker `id` (the next one), greets it, loads it and makes it ready.
    fn ready_worker_n(s: &mut Session<'_>, job: &ClusterJob, wire: &mut Recorder, id: usize) {
        s.add(&format!("w{id}"), LinkKind::InProcess, true, wire);
        let hello = Incoming::Hello {
            version: PROTOCOL_VERSION,
            name: ["zero", "one"][id].to_string(),
            arch: "test".to_string(),
            threads: 1,
            nonce: [id as u8; 32],
            proof: None,
        };
        s.handle(Event::Message(id, hello), wire);
        let need = Incoming::NeedScene {
            job: job.id,
            offset: 0,
            restart: false,
        };
        s.handle(Event::Message(id, need), wire);
        s.handle(Event::Message(id, Incoming::Ready { job: job.id }), wire);
    }

    #[test]
    fn a_lost_multi_line_request_is_reissued_line_by_line() {
        let job = job(2, 5, None);
        let opts = MasterOptions {
            window: 1,
            lines_per_request: Some(3),
            ..MasterOptions::default()
        };
        let done = Mutex::new(Vec::new());
        let on_line = |y, _| done.lock().expect("not poisoned").push(y);
        let mut s = Session::new(&job, &opts, &on_line, &|_| {});
        let mut wire = Recorder::default();
        ready_worker(&mut s, &job, &mut wire);
        wire.take();
        s.fill_windows(Instant::now(), &mut wire);
        assert_eq!(wire.take(), [(0, "RenderLines 0+3".into())]);
        // Line 0 arrives, then the worker is gone with lines 1 and 2 of its request.
        s.handle(line(&job, 0, false, 5), &mut wire);
        s.handle(Event::Closed(0, "killed".into()), &mut wire);
        ready_worker_n(&mut s, &job, &mut wire, 1);
        wire.take();
        s.fill_windows(Instant::now(), &mut wire);
        // Only the lost lines go out again (in front of the waiting ones), in whole requests.
        assert_eq!(wire.take(), [(1, "RenderLines 1+3".into())]);
        for y in 1..4 {
            s.handle(line_from(1, &job, y, false, 5), &mut wire);
        }
        s.fill_windows(Instant::now(), &mut wire);
        assert_eq!(wire.take(), [(1, "RenderLine 4".into())]);
        s.handle(line_from(1, &job, 4, false, 5), &mut wire);
        assert!(s.is_complete());
        // Every line was used once.
        assert_eq!(*done.lock().expect("not poisoned"), [0, 1, 2, 3, 4]);
        let image = s.into_image().expect("complete");
        let (zero, one) = (&image.workers[0], &image.workers[1]);
        assert_eq!((zero.lines, zero.reissued, zero.requests), (1, 2, 1));
        assert_eq!((one.lines, one.duplicates, one.requests), (4, 0, 2));
        assert_eq!(one.lines_per_request(), Some(2.0));
    }

    #[test]
    fn a_worker_is_loaded_given_a_window_and_its_lost_requests_reissued() {
        let job = job(2, 3, None);
        let opts = MasterOptions::default();
        let done = Mutex::new(Vec::new());
        let on_line = |y, _| done.lock().expect("not poisoned").push(y);
        let mut s = Session::new(&job, &opts, &on_line, &|_| {});
        let mut wire = Recorder::default();
        ready_worker(&mut s, &job, &mut wire);
        let sent: Vec<String> = wire.take().into_iter().map(|(_, m)| m).collect();
        assert_eq!(sent, ["Hello", "Job", "SceneChunk 0"]);
        s.fill_windows(Instant::now(), &mut wire);
        assert_eq!(
            wire.take(),
            [(0, "RenderLine 0".into()), (0, "RenderLine 1".into())]
        );
        // The answer to line 1 says the request for line 0 was lost: it is issued again.
        s.handle(line(&job, 1, false, 5), &mut wire);
        s.fill_windows(Instant::now(), &mut wire);
        assert_eq!(
            wire.take(),
            [(0, "RenderLine 0".into()), (0, "RenderLine 2".into())]
        );
        s.handle(line(&job, 0, false, 5), &mut wire);
        s.handle(line(&job, 2, false, 5), &mut wire);
        // A second answer for a line is counted, not used.
        s.handle(line(&job, 2, false, 9), &mut wire);
        assert!(s.is_complete());
        assert_eq!(*done.lock().expect("not poisoned"), [1, 0, 2]);
        let image = s.into_image().expect("complete");
        let w = &image.workers[0];
        assert_eq!((w.name.as_str(), w.lines, w.reissued), ("zero", 3, 1));
        assert_eq!(w.frames_dropped, 1, "the unasked-for copy of line 2");
        assert!(image.pixels.iter().all(|p| *p == Pixel([5; 3])));
    }

    #[test]
    fn a_worker_silent_when_the_image_completes_is_timed_out_without_probes() {
        let job = job(2, 4, None);
        let opts = MasterOptions::default();
        let mut s = Session::new(&job, &opts, &|_, _| {}, &|_| {});
        let mut wire = Recorder::default();
        ready_worker_n(&mut s, &job, &mut wire, 0);
        ready_worker_n(&mut s, &job, &mut wire, 1);
        let start = Instant::now();
        // Worker 1 answers all it is sent (at the end, copies of worker 0's lines); worker 0
        // answers nothing.
        for _ in 0..10 {
            s.fill_windows(start, &mut wire);
            for (id, m) in wire.take() {
                if let (1, Some(y)) = (id, m.strip_prefix("RenderLine ")) {
                    let y = y.parse().expect("a line number");
                    s.handle(line_from(1, &job, y, false, 5), &mut wire);
                }
            }
        }
        assert!(s.is_complete());
        assert!(s.is_alive(0) && s.is_alive(1));
        s.time_out_silent(start + opts.worker_timeout / 2, &mut wire);
        assert!(s.is_alive(0), "timed out early");
        s.time_out_silent(start + opts.worker_timeout, &mut wire);
        assert!(!s.is_alive(0), "the silent worker was not timed out");
        assert!(
            s.is_alive(1),
            "the worker with nothing in flight was timed out"
        );
        assert_eq!(wire.cut, [0]);
        assert!(wire.take().is_empty(), "a probe went out after the end");
        let image = s.into_image().expect("complete");
        let lost = image.workers[0].lost.as_deref().unwrap_or_default();
        assert!(lost.starts_with("no answer for "), "{lost}");
        assert!(image.workers[1].lost.is_none());
    }

    #[test]
    fn a_second_pass_is_asked_for_once_the_neighbours_are_in() {
        let adaptive = AdaptiveJob {
            threshold: 0.1,
            refine_all: false,
        };
        let job = job(2, 3, Some(adaptive));
        let opts = MasterOptions {
            window: 3,
            ..MasterOptions::default()
        };
        let done = Mutex::new(Vec::new());
        let on_line = |y, _| done.lock().expect("not poisoned").push(y);
        let mut s = Session::new(&job, &opts, &on_line, &|_| {});
        let mut wire = Recorder::default();
        ready_worker(&mut s, &job, &mut wire);
        s.fill_windows(Instant::now(), &mut wire);
        wire.take();
        // Lines 0 and 1 are alike, line 2 differs: lines 1 and 2 need a second pass.
        s.handle(line(&job, 0, false, 0), &mut wire);
        s.handle(line(&job, 1, false, 0), &mut wire);
        // Line 0 (the top) is decided by line 1 and needs no second pass; line 1 waits for 2.
        assert_eq!(*done.lock().expect("not poisoned"), [0]);
        s.fill_windows(Instant::now(), &mut wire);
        assert_eq!(wire.take(), []);
        s.handle(line(&job, 2, false, 60000), &mut wire);
        assert_eq!(*done.lock().expect("not poisoned"), [0]);
        s.fill_windows(Instant::now(), &mut wire);
        let sent: Vec<String> = wire.take().into_iter().map(|(_, m)| m).collect();
        assert_eq!(sent, ["RefineLine 1 [3]", "RefineLine 2 [3]"]);
        s.handle(line(&job, 1, true, 7), &mut wire);
        s.handle(line(&job, 2, true, 7), &mut wire);
        assert!(s.is_complete());
        assert_eq!(*done.lock().expect("not poisoned"), [0, 1, 2]);
        let pixels = s.into_image().expect("complete").pixels;
        assert_eq!(pixels[0], Pixel([0; 3]));
        assert!(pixels[2..].iter().all(|p| *p == Pixel([7; 3])));
    }

    /// Worker 0, greeted, loaded and asked for lines, then sent what `msg` makes of the job: the
    /// reason it was dropped for, if it was (and its link cut).
    fn dropped_after(msg: impl FnOnce(&ClusterJob) -> Incoming) -> Option<String> {
        let job = job(2, 3, None);
        let opts = MasterOptions::default();
        let mut s = Session::new(&job, &opts, &|_, _| {}, &|_| {});
        let mut wire = Recorder::default();
        ready_worker(&mut s, &job, &mut wire);
        s.fill_windows(Instant::now(), &mut wire);
        s.handle(Event::Message(0, msg(&job)), &mut wire);
        if wire.cut.is_empty() {
            return None;
        }
        let image = s.into_image();
        let Err(ClusterError::AllWorkersLost { workers, .. }) = image else {
            panic!("the only worker is lost");
        };
        workers[0].lost.clone()
    }

    /// Worker 0's first line, with `rays` for counts: the reason it was dropped for, if it was.
    fn dropped_for(rays: RayCounts) -> Option<String> {
        dropped_after(|job| {
            let Event::Message(_, Incoming::Line { pixels, .. }) = line(job, 0, false, 5) else {
                unreachable!("line() makes a line result")
            };
            Incoming::Line {
                job: job.id,
                line: 0,
                refined: false,
                rays,
                pixels,
            }
        })
    }

    #[test]
    fn a_result_with_impossible_ray_counts_drops_the_worker() {
        let honest = RayCounts {
            primary: 2,
            // Depth 16, one light: a line of 2 pixels makes at most 2 × (2^17 − 1) hits.
            shadow: 2 * ((1 << 17) - 1),
            ..RayCounts::default()
        };
        assert_eq!(dropped_for(honest), None);
        let cases = [
            (
                RayCounts {
                    primary: u64::MAX,
                    ..honest
                },
                "18446744073709551615 primary rays where a line has exactly 2",
            ),
            (
                RayCounts {
                    shadow: honest.shadow + 1,
                    ..honest
                },
                "262143 shadow rays where a line has at most 262142",
            ),
            (
                RayCounts {
                    extra_samples: 5,
                    ..honest
                },
                "5 extra sample rays where a line has exactly 0",
            ),
        ];
        for (rays, expected) in cases {
            let reason = dropped_for(rays).unwrap_or_default();
            assert!(reason.contains(expected), "{reason}");
        }
    }

    #[test]
    fn a_worker_that_panicked_is_dropped_at_once_with_its_message() {
        let reason = dropped_after(|_| Incoming::Panicked {
            message: "memory allocation of 1441792 bytes failed\u{1b}[2J".to_string(),
        });
        assert_eq!(
            reason.as_deref(),
            Some("it halted: memory allocation of 1441792 bytes failed\\u{1b}[2J")
        );
    }

    #[test]
    fn a_refusal_drops_the_worker_and_cuts_its_link() {
        let job = job(2, 1, None);
        let opts = MasterOptions::default();
        let log = Mutex::new(Vec::new());
        let log_fn = |m: &str| log.lock().expect("not poisoned").push(m.to_string());
        let mut s = Session::new(&job, &opts, &|_, _| {}, &log_fn);
        let mut wire = Recorder::default();
        ready_worker(&mut s, &job, &mut wire);
        s.fill_windows(Instant::now(), &mut wire);
        let refused = Incoming::Refused {
            job: job.id,
            reason: Refusal::CorruptScene,
        };
        s.handle(Event::Message(0, refused), &mut wire);
        assert_eq!(wire.cut, [0]);
        assert!(!s.any_alive());
        assert_eq!(
            *log.lock().expect("not poisoned"),
            [
                "worker zero (w0) lost: it refused the job: the scene arrived corrupted; 1 line \
              re-queued"
            ]
        );
        assert!(matches!(
            s.into_image(),
            Err(ClusterError::AllWorkersLost { finished: 0, .. })
        ));
    }
}
