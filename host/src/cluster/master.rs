//! The master: hands out lines to workers over their links, collects the results, survives
//! workers that die, hang or garble frames.
//!
//! Each link gets a reader thread (frames in, decoded and checked, as events on one channel)
//! and a writer thread (frames out, from a queue), so the master's loop never blocks on a slow
//! or dead peer. The loop runs the handshake of each worker (`Hello`, `Job`, scene chunks,
//! `Ready`), keeps each ready worker's window of outstanding requests full from the
//! [`LineScheduler`], and takes results: the first result of a line is used, later copies are
//! counted and dropped. With adaptive multisampling each line has a second task, queued once the
//! first passes of the line and its neighbours are in and some pixel needs more samples
//! (`RefineLine` with the flagged pixels' mask); its pixels are merged into the line.
//!
//! Lost work is found three ways. Workers answer requests in order, so a result for a later
//! request means the earlier ones were lost on the link. A dropped frame (either side) or a
//! silent worker gets a `Fence`; its `FenceAck` marks every request sent before it as lost. A
//! worker silent for the whole time-out, closed, or refusing the job is dropped. Lost lines go
//! back to the front of the queue.

use crate::cluster::link::Link;
use crate::cluster::report::WorkerReport;
use crate::cluster::schedule::LineScheduler;
use embedded_io_adapters::std::FromStd;
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use strahl_core::render::adaptive::{edge_mask, mask_len, merge_refined};
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;
use strahl_core::wire::frame::{FrameReader, FrameWriter, LinkError, ReadEvent};
use strahl_core::wire::message::{decode_pixels, Hello, MasterMessage, Refusal, WorkerMessage};
use strahl_core::wire::scene_blob::SceneBlob;
use strahl_core::wire::{
    frame_len, MAX_HEADER_LEN, PIXEL_WIRE_BYTES, PROTOCOL_VERSION, SCENE_WINDOW,
};

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

/// A worker's message, decoded and checked in its reader thread, owning its data.
#[derive(Debug)]
enum Incoming {
    Hello {
        version: u32,
        name: String,
        arch: String,
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
}

/// What the link threads tell the master loop.
#[derive(Debug)]
enum Event {
    Message(usize, Incoming),
    BadFrame(usize),
    Closed(usize, String),
}

/// Turns a decoded message into an [`Incoming`]; `None` if its pixels are not one line.
fn incoming(msg: WorkerMessage<'_>, width: u32) -> Option<Incoming> {
    Some(match msg {
        WorkerMessage::Hello(Hello {
            version,
            name,
            arch,
            ..
        }) => Incoming::Hello {
            version,
            name: name.to_string(),
            arch: arch.to_string(),
        },
        WorkerMessage::NeedScene {
            job,
            offset,
            restart,
        } => Incoming::NeedScene {
            job,
            offset,
            restart,
        },
        WorkerMessage::Ready { job } => Incoming::Ready { job },
        WorkerMessage::LineResult {
            job,
            line,
            refined,
            rays,
            pixels,
        } => {
            let mut out = vec![Pixel::default(); width as usize];
            decode_pixels(pixels, &mut out).ok()?;
            Incoming::Line {
                job,
                line,
                refined,
                rays,
                pixels: out,
            }
        }
        WorkerMessage::FenceAck { seq } => Incoming::FenceAck { seq },
        WorkerMessage::Dropped { .. } => Incoming::Dropped,
        WorkerMessage::Refused { job, reason } => Incoming::Refused { job, reason },
    })
}

/// The reader thread: frames from one worker become events until the link closes.
fn read_loop(id: usize, reader: Box<dyn Read + Send>, width: u32, events: &Sender<Event>) {
    let mut link = FromStd::new(reader);
    let mut frames = FrameReader::new(vec![
        0u8;
        frame_len(
            width as usize * PIXEL_WIRE_BYTES + MAX_HEADER_LEN
        )
    ]);
    loop {
        let event = match frames.next(&mut link) {
            Ok(ReadEvent::Frame(payload)) => match WorkerMessage::decode(payload)
                .ok()
                .and_then(|m| incoming(m, width))
            {
                Some(msg) => Event::Message(id, msg),
                None => Event::BadFrame(id),
            },
            Ok(ReadEvent::Dropped(_)) => Event::BadFrame(id),
            Err(LinkError::TimedOut) => continue,
            Err(LinkError::Closed) => Event::Closed(id, "the connection closed".to_string()),
            Err(LinkError::Io(kind)) => Event::Closed(id, format!("read error: {kind:?}")),
        };
        let last = matches!(event, Event::Closed(..));
        if events.send(event).is_err() || last {
            return;
        }
    }
}

/// A frame for the writer thread.
#[derive(Debug)]
struct Outgoing {
    frame: Vec<u8>,
    /// A scene chunk (its progress on the wire keeps a loading worker from timing out).
    chunk: bool,
}

/// What the master and a writer thread share about one link's outgoing frames.
#[derive(Debug)]
struct Outbox {
    /// Bytes queued and not yet written.
    queued: AtomicUsize,
    /// When the writer last finished writing a scene chunk (or the link was set up).
    last_chunk_write: Mutex<Instant>,
    /// Set when the worker is dropped: the writer stops at the next frame.
    cut: AtomicBool,
}

impl Outbox {
    fn last_chunk_write(&self) -> Instant {
        *self
            .last_chunk_write
            .lock()
            .unwrap_or_else(|e| e.into_inner())
    }
}

/// How a link ends when its writer thread stops.
struct Ending<'a> {
    /// After the last queued frame (the session is over): the master's side only.
    hang_up: &'a (dyn Fn() + Send + Sync),
    /// After a failed write or when the worker is dropped: the whole link.
    cut: &'a (dyn Fn() + Send + Sync),
}

/// The writer thread: queued frames go out until the queue closes (then the master hangs up its
/// side) or the worker is dropped or a write fails (then the link is cut).
fn write_loop(
    id: usize,
    mut writer: Box<dyn Write + Send>,
    frames: &Receiver<Outgoing>,
    outbox: &Outbox,
    events: &Sender<Event>,
    ending: &Ending<'_>,
    done: &Sender<usize>,
) {
    let mut graceful = true;
    for Outgoing { frame, chunk } in frames {
        if outbox.cut.load(Ordering::Relaxed) {
            graceful = false;
            break;
        }
        if let Err(e) = writer.write_all(&frame).and_then(|()| writer.flush()) {
            let _ = events.send(Event::Closed(id, format!("write failed: {e}")));
            graceful = false;
            break;
        }
        outbox.queued.fetch_sub(frame.len(), Ordering::Relaxed);
        if chunk {
            *outbox
                .last_chunk_write
                .lock()
                .unwrap_or_else(|e| e.into_inner()) = Instant::now();
        }
    }
    if graceful {
        (ending.hang_up)();
    } else {
        (ending.cut)();
    }
    let _ = done.send(id);
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

/// One outstanding request: task `y` is line `y`'s (first) pass, task `height + y` its
/// adaptive second pass.
#[derive(Clone, Copy, Debug)]
struct Request {
    task: u32,
    seq: u32,
    sent: Instant,
}

/// The master's view of one worker.
struct Slot {
    report: WorkerReport,
    tx: Option<Sender<Outgoing>>,
    outbox: Arc<Outbox>,
    closer: Arc<dyn Fn() + Send + Sync>,
    state: State,
    /// The last step forward: its `Hello`, a `NeedScene` further on than before, `Ready`, a
    /// result for a line it was asked for (or the request that ended an idle spell). Fence
    /// answers, drop notices, bad frames and stale messages are no progress: a worker that is
    /// alive but delivers nothing is dropped like a silent one.
    last_progress: Instant,
    last_probe: Instant,
    requests: VecDeque<Request>,
    next_seq: u32,
    /// The pending fence: its number, the first request sequence number sent after it, and
    /// when it was sent.
    fence: Option<(u32, u32, Instant)>,
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

/// The master loop's state.
struct Master<'a> {
    job: &'a ClusterJob,
    opts: &'a MasterOptions,
    slots: Vec<Slot>,
    sched: LineScheduler,
    pixels: Vec<Pixel>,
    /// With adaptive multisampling: every line's first-pass pixels (centres), each line's
    /// flagged pixels once known, and the rays of its first pass.
    centres: Vec<Pixel>,
    edges: Vec<Option<Vec<u8>>>,
    first_rays: Vec<RayCounts>,
    rays: RayCounts,
    frames: FrameWriter,
    events_tx: Sender<Event>,
    /// Writer threads report here when they have sent everything and cut their link.
    writers_done_tx: Sender<usize>,
    writers_done: Receiver<usize>,
    on_line: &'a (dyn Fn(u32, RayCounts) + Sync),
    log: &'a (dyn Fn(&str) + Sync),
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
    let (events_tx, events) = mpsc::channel();
    let (writers_done_tx, writers_done) = mpsc::channel();
    let mut m = Master {
        job,
        opts,
        slots: Vec::new(),
        sched: match job.adaptive {
            Some(_) => LineScheduler::with_pending(2 * job.height, job.height),
            None => LineScheduler::new(job.height),
        },
        pixels: vec![Pixel::default(); job.width as usize * job.height as usize],
        centres: Vec::new(),
        edges: Vec::new(),
        first_rays: Vec::new(),
        rays: RayCounts::default(),
        frames: FrameWriter::new(),
        events_tx,
        writers_done_tx,
        writers_done,
        on_line,
        log,
    };
    if job.adaptive.is_some() {
        m.centres = m.pixels.clone();
        m.edges = vec![None; job.height as usize];
        m.first_rays = vec![RayCounts::default(); job.height as usize];
    }
    for link in links {
        m.add(link);
    }
    let mut joins_open = joins.is_some();
    let mut alone_since = Instant::now();
    let mut last_check = Instant::now();
    let tick = Duration::from_millis(20);
    while !m.sched.is_complete() {
        if let Some(joins) = joins {
            loop {
                match joins.try_recv() {
                    Ok(link) => m.add(link),
                    Err(TryRecvError::Empty) => break,
                    Err(TryRecvError::Disconnected) => {
                        joins_open = false;
                        break;
                    }
                }
            }
        }
        match events.recv_timeout(tick) {
            Ok(event) => m.handle(event),
            Err(RecvTimeoutError::Timeout) => {}
            // The master holds a sender itself, so this does not happen.
            Err(RecvTimeoutError::Disconnected) => break,
        }
        let now = Instant::now();
        if now.duration_since(last_check) >= tick {
            last_check = now;
            m.check_timeouts(now);
        }
        m.fill_windows();
        if m.slots.iter().any(|s| s.state != State::Gone) {
            alone_since = now;
        } else if !joins_open || now.duration_since(alone_since) >= opts.wait_for_workers {
            break;
        }
    }
    m.finish(&events)
}

impl Master<'_> {
    fn add(&mut self, link: Link) {
        let id = self.slots.len();
        let (tx, rx) = mpsc::channel::<Outgoing>();
        let closer: Arc<dyn Fn() + Send + Sync> = Arc::from(link.closer);
        let report = WorkerReport::new(&link.address, link.kind);
        let events = self.events_tx.clone();
        let width = self.job.width;
        let reader = link.reader;
        let reader_ok = std::thread::Builder::new()
            .name(format!("strahl-rx-{id}"))
            .spawn(move || read_loop(id, reader, width, &events))
            .is_ok();
        let events = self.events_tx.clone();
        let writer = link.writer;
        let hang_up = link.hang_up;
        let thread_closer = Arc::clone(&closer);
        let done = self.writers_done_tx.clone();
        let now = Instant::now();
        let outbox = Arc::new(Outbox {
            queued: AtomicUsize::new(0),
            last_chunk_write: Mutex::new(now),
            cut: AtomicBool::new(false),
        });
        let thread_outbox = Arc::clone(&outbox);
        let writer_ok = std::thread::Builder::new()
            .name(format!("strahl-tx-{id}"))
            .spawn(move || {
                write_loop(
                    id,
                    writer,
                    &rx,
                    &thread_outbox,
                    &events,
                    &Ending {
                        hang_up: &*hang_up,
                        cut: &*thread_closer,
                    },
                    &done,
                );
            })
            .is_ok();
        self.slots.push(Slot {
            report,
            tx: Some(tx),
            outbox,
            closer,
            state: State::Greeting,
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
        if reader_ok && writer_ok {
            self.send_hello(id);
        } else {
            self.lose(id, "cannot start its link threads".to_string());
        }
    }

    fn send(&mut self, id: usize, msg: &MasterMessage<'_>) {
        let Ok(frame) = self.frames.encode(msg) else {
            return;
        };
        let frame = frame.to_vec();
        let chunk = matches!(msg, MasterMessage::SceneChunk { .. });
        let slot = &self.slots[id];
        if let Some(tx) = &slot.tx {
            slot.outbox.queued.fetch_add(frame.len(), Ordering::Relaxed);
            // A closed queue means the writer already reported the link closed.
            let _ = tx.send(Outgoing { frame, chunk });
        }
    }

    fn send_hello(&mut self, id: usize) {
        let name = self.opts.name.clone();
        self.send(
            id,
            &MasterMessage::Hello(Hello {
                version: PROTOCOL_VERSION,
                name: &name,
                arch: std::env::consts::ARCH,
                scene_memory: 0,
            }),
        );
    }

    fn send_job(&mut self, id: usize) {
        let (job, digest, scene_len) = (self.job.id, self.job.blob.digest, self.job.blob.len());
        self.send(
            id,
            &MasterMessage::Job {
                job,
                digest,
                scene_len,
            },
        );
    }

    fn send_fence(&mut self, id: usize) {
        let slot = &mut self.slots[id];
        let seq = slot.next_seq;
        slot.next_seq += 1;
        slot.fence = Some((seq, seq, Instant::now()));
        self.send(id, &MasterMessage::Fence { seq });
    }

    fn handle(&mut self, event: Event) {
        let id = match &event {
            Event::Message(id, _) | Event::BadFrame(id) | Event::Closed(id, _) => *id,
        };
        if self.slots[id].state == State::Gone {
            return;
        }
        let now = Instant::now();
        match event {
            Event::Closed(_, reason) => self.lose(id, reason),
            Event::BadFrame(_) => {
                self.slots[id].report.frames_dropped += 1;
                self.fence_after_loss(id);
            }
            Event::Message(_, msg) => self.take(id, msg, now),
        }
    }

    /// After a frame was lost on a working worker's link, asks which requests survived (again,
    /// if the pending fence is older than a probe interval: the fence itself may be lost).
    fn fence_after_loss(&mut self, id: usize) {
        let slot = &self.slots[id];
        let pending = slot
            .fence
            .is_some_and(|(_, _, sent)| sent.elapsed() < self.opts.probe_interval);
        if slot.state == State::Working && !pending {
            self.send_fence(id);
        }
    }

    /// Queues scene chunks for a loading worker: up to two windows past what it asked for, and
    /// no more than [`SCENE_QUEUE_LIMIT`] bytes waiting at once.
    fn pump_scene(&mut self, id: usize) {
        let Some(asked) = self.slots[id].scene_asked else {
            return;
        };
        let blob = Arc::clone(&self.job.blob);
        let until = blob.len().min(asked.saturating_add(2 * SCENE_WINDOW));
        while self.slots[id].scene_sent_upto < until
            && self.slots[id].outbox.queued.load(Ordering::Relaxed) < SCENE_QUEUE_LIMIT
        {
            let at = self.slots[id].scene_sent_upto;
            let bytes = blob.chunk_at(at);
            if bytes.is_empty() {
                break;
            }
            self.slots[id].scene_sent_upto = at + bytes.len() as u32;
            self.send(
                id,
                &MasterMessage::SceneChunk {
                    digest: blob.digest,
                    offset: at,
                    bytes,
                },
            );
        }
    }

    fn take(&mut self, id: usize, msg: Incoming, now: Instant) {
        let job = self.job.id;
        match msg {
            Incoming::Hello {
                version,
                name,
                arch,
            } => {
                if self.slots[id].state != State::Greeting {
                    return;
                }
                if version != PROTOCOL_VERSION {
                    return self.lose(
                        id,
                        format!(
                            "it speaks protocol version {version}, this master speaks version \
                             {PROTOCOL_VERSION}"
                        ),
                    );
                }
                let slot = &mut self.slots[id];
                slot.last_progress = now;
                slot.report.name = name;
                slot.report.arch = arch;
                slot.state = State::Loading;
                self.send_job(id);
            }
            Incoming::NeedScene {
                job: j,
                offset,
                restart,
            } if j == job => {
                let slot = &mut self.slots[id];
                if !matches!(slot.state, State::Greeting | State::Loading) {
                    return;
                }
                slot.state = State::Loading;
                if slot.scene_asked.is_none_or(|a| offset > a) {
                    slot.last_progress = now;
                }
                slot.scene_asked = Some(slot.scene_asked.map_or(offset, |a| a.max(offset)));
                if restart || offset > slot.scene_sent_upto {
                    slot.scene_sent_upto = offset;
                }
                self.pump_scene(id);
            }
            Incoming::Ready { job: j } if j == job => {
                let slot = &mut self.slots[id];
                if matches!(slot.state, State::Greeting | State::Loading) {
                    slot.state = State::Working;
                    slot.last_progress = now;
                    slot.idle = true;
                }
            }
            Incoming::Line {
                job: j,
                line,
                refined,
                rays,
                pixels,
            } if j == job
                && line < self.job.height
                && (!refined || self.job.adaptive.is_some()) =>
            {
                let task = if refined {
                    self.job.height + line
                } else {
                    line
                };
                self.take_line(id, task, rays, &pixels, now);
            }
            Incoming::FenceAck { seq } => {
                let slot = &mut self.slots[id];
                if let Some((fence, upto, _)) = slot.fence {
                    if fence == seq {
                        slot.fence = None;
                        let lost: Vec<u32> = slot
                            .requests
                            .iter()
                            .filter(|r| r.seq < upto)
                            .map(|r| r.task)
                            .collect();
                        slot.requests.retain(|r| r.seq >= upto);
                        self.release(id, &lost);
                    }
                }
            }
            Incoming::Dropped => {
                self.slots[id].report.frames_dropped += 1;
                self.fence_after_loss(id);
            }
            Incoming::Refused { job: j, reason } if j == job => {
                self.lose(id, format!("it refused the job: {}", refusal_text(reason)));
            }
            // Messages about another job (an earlier one), or a line outside the image.
            Incoming::NeedScene { .. }
            | Incoming::Ready { .. }
            | Incoming::Line { .. }
            | Incoming::Refused { .. } => {
                self.slots[id].report.frames_dropped += 1;
            }
        }
    }

    fn take_line(&mut self, id: usize, task: u32, rays: RayCounts, pixels: &[Pixel], now: Instant) {
        let slot = &mut self.slots[id];
        // Only answers to requests count; anything else is a peer's mistake, not a pixel.
        let Some(i) = slot.requests.iter().position(|r| r.task == task) else {
            slot.report.frames_dropped += 1;
            return;
        };
        slot.last_progress = now;
        // Requests are answered in order: those before this one were lost.
        let lost: Vec<u32> = slot.requests.drain(..i).map(|r| r.task).collect();
        if let Some(r) = slot.requests.pop_front() {
            let started = slot.last_result.map_or(r.sent, |t| t.max(r.sent));
            slot.report.busy += now.saturating_duration_since(started);
        }
        slot.last_result = Some(now);
        slot.idle = slot.requests.is_empty() && lost.is_empty();
        slot.report.rays += rays;
        if self.sched.complete(task, true) {
            self.slots[id].report.lines += 1;
            self.rays += rays;
            self.use_result(task, rays, pixels);
        } else {
            self.slots[id].report.duplicates += 1;
        }
        self.release(id, &lost);
    }

    /// Puts the first result of `task` into the image.
    fn use_result(&mut self, task: u32, rays: RayCounts, pixels: &[Pixel]) {
        let (w, h) = (self.job.width as usize, self.job.height);
        let Some(adaptive) = self.job.adaptive else {
            let at = task as usize * w;
            self.pixels[at..at + w].copy_from_slice(pixels);
            (self.on_line)(task, rays);
            return;
        };
        if task >= h {
            // A second pass: its flagged pixels replace the centres.
            let line = task - h;
            let at = line as usize * w;
            if let Some(edges) = &self.edges[line as usize] {
                merge_refined(edges, pixels, &mut self.pixels[at..at + w]);
            }
            let mut all = self.first_rays[line as usize];
            all += rays;
            (self.on_line)(line, all);
            return;
        }
        let at = task as usize * w;
        self.pixels[at..at + w].copy_from_slice(pixels);
        self.centres[at..at + w].copy_from_slice(pixels);
        self.first_rays[task as usize] = rays;
        // This line and its neighbours may now know which pixels to supersample.
        for line in task.saturating_sub(1)..(task + 2).min(h) {
            let first_done = |l: u32| self.sched.is_done(l);
            let ready = self.edges[line as usize].is_none()
                && first_done(line)
                && (line == 0 || first_done(line - 1))
                && (line + 1 == h || first_done(line + 1));
            if !ready {
                continue;
            }
            let mut mask = vec![0u8; mask_len(self.job.width)];
            let flagged = edge_mask(
                adaptive.threshold,
                &self.centres,
                self.job.width,
                line,
                &mut mask,
            );
            self.edges[line as usize] = Some(mask);
            if flagged > 0 || adaptive.refine_all {
                self.sched.queue(h + line);
            } else if self.sched.complete(h + line, false) {
                (self.on_line)(line, self.first_rays[line as usize]);
            }
        }
    }

    /// Gives `lines` of worker `id` back to the scheduler.
    fn release(&mut self, id: usize, lines: &[u32]) {
        for &line in lines {
            if self.sched.release(line) {
                self.slots[id].report.reissued += 1;
            }
        }
    }

    /// Drops worker `id`: its lines go back to the queue and its link is cut.
    fn lose(&mut self, id: usize, reason: String) {
        let slot = &mut self.slots[id];
        if slot.state == State::Gone {
            return;
        }
        slot.state = State::Gone;
        slot.tx = None;
        slot.outbox.cut.store(true, Ordering::Relaxed);
        (slot.closer)();
        let lines: Vec<u32> = slot.requests.drain(..).map(|r| r.task).collect();
        let before = slot.report.reissued;
        self.release(id, &lines);
        let slot = &mut self.slots[id];
        let requeued = slot.report.reissued - before;
        let who = if slot.report.name == slot.report.address {
            slot.report.name.clone()
        } else {
            format!("{} ({})", slot.report.name, slot.report.address)
        };
        (self.log)(&format!(
            "worker {who} lost: {reason}; {requeued} line{} re-queued",
            if requeued == 1 { "" } else { "s" }
        ));
        slot.report.lost = Some(reason);
    }

    fn check_timeouts(&mut self, now: Instant) {
        for id in 0..self.slots.len() {
            let slot = &self.slots[id];
            let waiting_on_it = match slot.state {
                State::Gone => continue,
                State::Working => !slot.requests.is_empty(),
                State::Greeting | State::Loading => true,
            };
            if !waiting_on_it {
                continue;
            }
            // While scene chunks are still going out, the worker cannot answer yet: the time
            // counts from the last chunk written (probes do not count).
            let since = match slot.state {
                State::Loading => slot.last_progress.max(slot.outbox.last_chunk_write()),
                _ => slot.last_progress,
            };
            let stalled = now.saturating_duration_since(since);
            if stalled >= self.opts.worker_timeout {
                self.lose(id, format!("no answer for {:.1} s", stalled.as_secs_f64()));
                continue;
            }
            if stalled < self.opts.probe_interval
                || now.duration_since(slot.last_probe) < self.opts.probe_interval
            {
                continue;
            }
            self.slots[id].last_probe = now;
            match self.slots[id].state {
                State::Greeting => self.send_hello(id),
                State::Loading => self.send_job(id),
                State::Working => self.send_fence(id),
                State::Gone => {}
            }
        }
    }

    fn fill_windows(&mut self) {
        let now = Instant::now();
        for id in 0..self.slots.len() {
            if self.slots[id].state == State::Loading {
                self.pump_scene(id);
            }
            if self.slots[id].state != State::Working {
                continue;
            }
            while self.slots[id].requests.len() < self.opts.window.max(1) as usize {
                let Some(line) = self.sched.next_waiting() else {
                    break;
                };
                self.request(id, line, now);
            }
            if self.slots[id].requests.is_empty() {
                let slot = &self.slots[id];
                let held = |l: u32| slot.requests.iter().any(|r| r.task == l);
                if let Some(line) = self.sched.next_copy(held) {
                    self.request(id, line, now);
                }
            }
        }
    }

    fn request(&mut self, id: usize, task: u32, now: Instant) {
        let slot = &mut self.slots[id];
        let seq = slot.next_seq;
        slot.next_seq += 1;
        if slot.idle {
            // A worker that answered everything it was asked was not hanging while it waited.
            slot.last_progress = now;
            slot.idle = false;
        }
        slot.requests.push_back(Request {
            task,
            seq,
            sent: now,
        });
        let job = self.job.id;
        let h = self.job.height;
        if task < h {
            self.send(id, &MasterMessage::RenderLine { job, line: task });
            return;
        }
        let line = task - h;
        // The flagged pixels, or every pixel without skipping (only flagged ones are kept).
        let mask = match (self.job.adaptive, &self.edges[line as usize]) {
            (Some(a), Some(edges)) if !a.refine_all => edges.clone(),
            _ => vec![0xffu8; mask_len(self.job.width)],
        };
        self.send(
            id,
            &MasterMessage::RefineLine {
                job,
                line,
                mask: &mask,
            },
        );
    }

    /// Lines whose final pixels are in.
    fn lines_finished(&self) -> u32 {
        let h = self.job.height;
        match self.job.adaptive {
            Some(_) => (h..2 * h).filter(|&t| self.sched.is_done(t)).count() as u32,
            None => self.sched.finished(),
        }
    }

    fn finish(mut self, events: &Receiver<Event>) -> Result<ClusterImage, ClusterError> {
        let mut live = 0;
        for id in 0..self.slots.len() {
            if self.slots[id].state != State::Gone {
                self.send(id, &MasterMessage::EndSession);
                live += 1;
            }
            // Dropping the queue lets the writer send what is queued, then cut the link.
            self.slots[id].tx = None;
        }
        // Give the writers a moment to deliver `EndSession`, so workers know the session is
        // over before this process exits; a writer stuck on a dead link is not waited for.
        let deadline = Instant::now() + Duration::from_secs(2);
        let mut finished = std::collections::HashSet::new();
        while finished.len() < live {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.writers_done.recv_timeout(left) {
                Ok(id) => {
                    if self.slots[id].state != State::Gone {
                        finished.insert(id);
                    }
                }
                Err(_) => break,
            }
        }
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
        for (id, slot) in self.slots.iter().enumerate() {
            if slot.state != State::Gone && (!finished.contains(&id) || open.contains(&id)) {
                slot.outbox.cut.store(true, Ordering::Relaxed);
                (slot.closer)();
            }
        }
        let finished = self.lines_finished();
        let workers: Vec<WorkerReport> = self.slots.into_iter().map(|s| s.report).collect();
        if !self.sched.is_complete() {
            return Err(ClusterError::AllWorkersLost {
                finished,
                total: self.job.height,
                workers,
            });
        }
        Ok(ClusterImage {
            pixels: self.pixels,
            rays: self.rays,
            workers,
        })
    }
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
    }
}
