//! The worker loop: one session with one master, over any `embedded_io` link.
//!
//! [`serve`] answers the master's `Hello`, receives or finds the job's scene, and renders the
//! requested lines in the order they arrive, until the master ends the session or the link
//! closes. The same function runs in a thread of `strahl render`, in `strahl worker` over a
//! serial port, and on a microcontroller. It allocates the scene and one line's buffers, sized
//! from the scene; frames from the master are read into a buffer of
//! [`crate::wire::MAX_MASTER_FRAME_LEN`] bytes on the stack. The scene
//! arrives in windows of [`SCENE_WINDOW`] bytes, each asked for with `NeedScene`. Frames it cannot
//! read are dropped and reported to the master with `Dropped`, so the master can find out
//! (with a `Fence`) which requests were lost.
//!
//! The session decides every answer; where the answers go is an [`Outbox`]. [`serve`] uses
//! [`Inline`], which renders each line request at once ([`LineBuffers::answer`]) and writes to
//! the link. [`serve_with`] takes any outbox that keeps the answers in order: `strahl worker`
//! over TCP renders on several threads that way (`strahl_tcp::threads`), and a benchmark
//! answers without rendering to measure the master alone.
//!
//! The [`SceneCache`] outlives sessions: a worker that serves the next master, or the next job
//! of the same master, with a scene it already has skips the transfer.

use crate::render::adaptive::refine_line;
use crate::render::error::RenderError;
use crate::render::pixel::Pixel;
use crate::render::render_line;
use crate::scene::Scene;
use crate::wire::auth::{self, Nonce, Role};
use crate::wire::error::ProtocolError;
use crate::wire::frame::{FrameReader, FrameWriteError, FrameWriter, LinkError, ReadEvent};
use crate::wire::message::{
    encode_pixels, Digest, Hello, MasterMessage, Refusal, Rejection, WorkerMessage,
};
use crate::wire::scene_blob::{decode_bundle, memory_estimate, ChunkOutcome, SceneAssembler};
use crate::wire::{MAX_MASTER_FRAME_LEN, PIXEL_WIRE_BYTES, PROTOCOL_VERSION, SCENE_WINDOW};
use alloc::sync::Arc;
use alloc::vec::Vec;
use embedded_io::{Read, Write};

/// What a worker tells the master about itself, and the secret it requires of masters.
#[derive(Clone, Copy, Debug)]
pub struct NodeInfo<'a> {
    /// The node's name, at most [`crate::wire::MAX_NAME_LEN`] bytes.
    pub name: &'a str,
    /// The node's architecture, at most [`crate::wire::MAX_NAME_LEN`] bytes.
    pub arch: &'a str,
    /// Bytes of memory the node can give a scene; larger scenes are refused.
    pub scene_memory: u64,
    /// Lines it renders at once (its render threads; 0 counts as 1).
    pub threads: u32,
    /// The shared secret a master must prove it holds ([`crate::wire::auth`]); `None`: any
    /// master may use this worker.
    pub secret: Option<&'a [u8]>,
    /// A fresh random nonce for each handshake (the host's random source, a board's RNG).
    pub nonce: fn() -> Nonce,
}

/// The last scene a worker prepared, kept across jobs and sessions.
#[derive(Clone, Debug, Default)]
pub struct SceneCache {
    entry: Option<(Digest, Arc<Scene>)>,
}

impl SceneCache {
    /// An empty cache.
    pub fn new() -> Self {
        SceneCache::default()
    }

    /// A cache that already holds `scene` under `digest` (an in-process worker shares the
    /// master's prepared scene instead of building its own).
    pub fn with_scene(digest: Digest, scene: Arc<Scene>) -> Self {
        SceneCache {
            entry: Some((digest, scene)),
        }
    }

    /// The scene named `digest`, if held.
    pub fn get(&self, digest: &Digest) -> Option<Arc<Scene>> {
        match &self.entry {
            Some((d, s)) if d == digest => Some(Arc::clone(s)),
            _ => None,
        }
    }

    fn put(&mut self, digest: Digest, scene: Arc<Scene>) {
        self.entry = Some((digest, scene));
    }
}

/// How a session ended normally.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SessionEnd {
    /// The master sent `EndSession`.
    Ended,
    /// The link closed.
    Closed {
        /// Frames the worker could not read since the session's last `Hello` (from its start
        /// if none came): a damaged link, or a peer that does not speak the protocol.
        unreadable: u32,
    },
}

/// Why a session ended abnormally.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WorkerError {
    /// The link failed (other than closing).
    Link(LinkError),
    /// The master speaks another protocol version; the worker answered with its `Hello` and
    /// ended the session.
    VersionMismatch {
        /// The master's version.
        master: u32,
    },
    /// A message could not be encoded (an internal error).
    Encode(ProtocolError),
    /// The worker has a secret and the master did not prove it holds it; the worker answered
    /// `Refused{Unauthenticated}` and ended the session.
    Unauthenticated,
    /// The master rejected this worker.
    Rejected(Rejection),
}

impl From<FrameWriteError> for WorkerError {
    fn from(e: FrameWriteError) -> Self {
        match e {
            FrameWriteError::Encode(e) => WorkerError::Encode(e),
            FrameWriteError::Link(e) => WorkerError::Link(e),
        }
    }
}

/// One line request for an [`Outbox`] to render: the first pass of `line`, or with `mask`
/// adaptive multisampling's second pass.
#[derive(Clone, Copy, Debug)]
pub struct LineRequest<'a> {
    /// The job's scene.
    pub scene: &'a Arc<Scene>,
    /// The job.
    pub job: u32,
    /// The line, 0 is the top.
    pub line: u32,
    /// The second pass's pixels, one bit each.
    pub mask: Option<&'a [u8]>,
}

/// Where a session's answers go. Every answer reaches the master in the order it is given here,
/// line results included, so a master can tell from a later answer that an earlier request was
/// lost (and a `FenceAck` follows every result asked for before its `Fence`).
///
/// [`Inline`] renders each request at once on the session's own thread; a host can render on
/// several threads (`strahl_tcp::threads`) as long as it keeps that order.
pub trait Outbox<L> {
    /// Sends `msg` after every earlier answer.
    ///
    /// # Errors
    /// The link's or the encoder's error; the session ends with it.
    fn send(&mut self, link: &mut L, msg: &WorkerMessage<'_>) -> Result<(), WorkerError>;

    /// Renders `request` and sends its answer ([`LineBuffers::answer`]) after every earlier one.
    ///
    /// # Errors
    /// The link's or the encoder's error; the session ends with it.
    fn render(&mut self, link: &mut L, request: LineRequest<'_>) -> Result<(), WorkerError>;

    /// The session's handshake is over: the master greeted, and proved the secret when the
    /// worker has one. Called once per session (again after a new `Hello`). A transport that
    /// gives a handshake less time than a session between frames lifts that limit here.
    fn established(&mut self) {}

    /// Every answer to one master message has been given ([`serve_with`] calls this after each
    /// message it handles, a `RenderLines` of many lines included): an outbox that holds
    /// answers back writes them now. [`Inline`] holds none back.
    ///
    /// # Errors
    /// The link's error; the session ends with it.
    fn flush(&mut self, _link: &mut L) -> Result<(), WorkerError> {
        Ok(())
    }
}

/// One line's buffers, sized from the scene on first use.
#[derive(Clone, Debug, Default)]
pub struct LineBuffers {
    pixels: Vec<Pixel>,
    wire: Vec<u8>,
}

impl LineBuffers {
    /// Empty buffers.
    pub fn new() -> Self {
        LineBuffers::default()
    }

    /// Renders `request` and gives its answer: a `LineResult`, or a `Refused` for a line
    /// outside the image or a mask that does not fit.
    ///
    /// # Errors
    /// [`WorkerError::Encode`] on an internal error.
    pub fn answer(&mut self, request: LineRequest<'_>) -> Result<WorkerMessage<'_>, WorkerError> {
        let LineRequest {
            scene,
            job,
            line,
            mask,
        } = request;
        let width = scene.settings.width as usize;
        self.pixels.resize(width, Pixel::default());
        self.wire.resize(width * PIXEL_WIRE_BYTES, 0);
        let rendered = match mask {
            None => render_line(scene, line, &mut self.pixels),
            Some(mask) => refine_line(scene, line, mask, &mut self.pixels),
        };
        let reason = match rendered {
            Ok(rays) => {
                encode_pixels(&self.pixels, &mut self.wire).map_err(WorkerError::Encode)?;
                return Ok(WorkerMessage::LineResult {
                    job,
                    line,
                    refined: mask.is_some(),
                    rays,
                    pixels: &self.wire,
                });
            }
            Err(RenderError::LineOutOfRange) => Refusal::LineOutOfRange,
            // The line buffers are sized from the scene, so only a mask can misfit.
            Err(RenderError::WrongBufferLength) => {
                debug_assert!(mask.is_some(), "line buffers sized from the scene");
                Refusal::BadMask
            }
            Err(RenderError::NotAdaptive) => Refusal::BadMask,
        };
        Ok(WorkerMessage::Refused { job, reason })
    }
}

/// The outbox of [`serve`]: renders each request at once and writes every answer to the link.
#[derive(Debug, Default)]
pub struct Inline {
    writer: FrameWriter,
    buffers: LineBuffers,
}

impl Inline {
    /// An outbox with empty buffers.
    pub fn new() -> Self {
        Inline::default()
    }
}

impl<L: Write> Outbox<L> for Inline {
    fn send(&mut self, link: &mut L, msg: &WorkerMessage<'_>) -> Result<(), WorkerError> {
        Ok(self.writer.send(link, msg)?)
    }

    fn render(&mut self, link: &mut L, request: LineRequest<'_>) -> Result<(), WorkerError> {
        let answer = self.buffers.answer(request)?;
        Ok(self.writer.send(link, &answer)?)
    }
}

/// The job a session works on.
struct Job {
    id: u32,
    digest: Digest,
    stage: Stage,
}

enum Stage {
    /// Receiving the scene; `asked` is the offset last asked for after a gap.
    Loading {
        assembler: SceneAssembler,
        asked: Option<u32>,
    },
    /// Rendering.
    Ready(Arc<Scene>),
    /// The job was refused; line requests for it are refused too.
    Refused(Refusal),
}

/// Where a session stands with the shared secret.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Trust {
    /// The worker has no secret: any master may use it.
    Open,
    /// The worker has a secret; the master's `Auth` for the greeting's nonces is awaited.
    Awaiting,
    /// The master proved it holds the secret.
    Proven,
}

/// The two nonces of a session's handshake.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Greeting {
    master: Nonce,
    worker: Nonce,
}

/// One session's state; its answers go through an [`Outbox`].
struct Session<'n> {
    node: &'n NodeInfo<'n>,
    /// The nonces of the master's `Hello` and of the answer; `None` before a `Hello`.
    greeting: Option<Greeting>,
    trust: Trust,
    job: Option<Job>,
    dropped: u32,
}

/// Serves one master over `link` until it ends the session or the link closes, rendering each
/// request at once ([`Inline`]).
///
/// Read time-outs (a serial port with nothing to say) are waited through. A `Hello` in the
/// middle of a session starts it afresh, keeping the cache; the same `Hello` again is answered
/// as before and changes nothing.
///
/// # Errors
/// [`WorkerError::VersionMismatch`] if the master speaks another version,
/// [`WorkerError::Link`] if the link fails, [`WorkerError::Encode`] on an internal error.
pub fn serve<L: Read + Write>(
    link: &mut L,
    node: &NodeInfo<'_>,
    cache: &mut SceneCache,
) -> Result<SessionEnd, WorkerError> {
    serve_with(link, &mut Inline::new(), node, cache)
}

/// Serves one master: reads its requests from `link` and answers through `out` (which may write
/// to `link` or elsewhere), until the master ends the session or the link closes. As [`serve`]
/// otherwise.
///
/// # Errors
/// As [`serve`], and whatever `out` reports.
pub fn serve_with<L: Read, O: Outbox<L>>(
    link: &mut L,
    out: &mut O,
    node: &NodeInfo<'_>,
    cache: &mut SceneCache,
) -> Result<SessionEnd, WorkerError> {
    let mut rx = [0u8; MAX_MASTER_FRAME_LEN];
    let mut reader = FrameReader::new(&mut rx[..]);
    let mut session = Session {
        node,
        greeting: None,
        trust: Trust::Open,
        job: None,
        dropped: 0,
    };
    loop {
        let event = match reader.next(link) {
            Ok(event) => event,
            Err(LinkError::TimedOut) => continue,
            Err(LinkError::Closed) => {
                let unreadable = session.dropped;
                return Ok(SessionEnd::Closed { unreadable });
            }
            Err(e) => return Err(WorkerError::Link(e)),
        };
        let msg = match event {
            ReadEvent::Frame(payload) => MasterMessage::decode(payload),
            ReadEvent::Dropped(_) => Err(ProtocolError::Decode),
        };
        let mut io = Io { link, out };
        let handled = match msg {
            Ok(msg) => session.handle(msg, cache, &mut io),
            Err(_) => {
                session.dropped = session.dropped.saturating_add(1);
                let total = session.dropped;
                if session.greeting.is_some() {
                    io.send(&WorkerMessage::Dropped { total }).map(|()| None)
                } else {
                    Ok(None)
                }
            }
        };
        // What was answered goes out even when the session ends with an error (a `Hello`
        // answered before a version mismatch, a refusal before the session ends unproven).
        let flushed = io.out.flush(io.link);
        let end = handled?;
        flushed?;
        if let Some(end) = end {
            return Ok(end);
        }
    }
}

/// The link and the outbox of one session, borrowed while a message is handled.
struct Io<'a, L, O> {
    link: &'a mut L,
    out: &'a mut O,
}

impl<L, O: Outbox<L>> Io<'_, L, O> {
    fn send(&mut self, msg: &WorkerMessage<'_>) -> Result<(), WorkerError> {
        self.out.send(self.link, msg)
    }

    fn render(&mut self, request: LineRequest<'_>) -> Result<(), WorkerError> {
        self.out.render(self.link, request)
    }
}

impl Session<'_> {
    /// Handles one message; `Some` ends the session.
    fn handle<L, O: Outbox<L>>(
        &mut self,
        msg: MasterMessage<'_>,
        cache: &mut SceneCache,
        io: &mut Io<'_, L, O>,
    ) -> Result<Option<SessionEnd>, WorkerError> {
        match msg {
            MasterMessage::Hello(h) => self.greet(&h, io)?,
            // Nothing but a Hello opens a session.
            _ if self.greeting.is_none() => {}
            MasterMessage::Reject { reason } => return Err(WorkerError::Rejected(reason)),
            MasterMessage::EndSession => return Ok(Some(SessionEnd::Ended)),
            MasterMessage::Auth { proof } => self.check_auth(&proof, io)?,
            // A worker with a secret serves only a master that proved it.
            msg if self.trust == Trust::Awaiting => {
                io.send(&WorkerMessage::Refused {
                    job: request_job(&msg),
                    reason: Refusal::Unauthenticated,
                })?;
                return Err(WorkerError::Unauthenticated);
            }
            MasterMessage::Job {
                job,
                digest,
                scene_len,
            } => io.send(&self.start_job(job, digest, scene_len, cache))?,
            MasterMessage::SceneChunk {
                digest,
                offset,
                bytes,
            } => {
                if let Some(answer) = self.take_chunk(&digest, offset, bytes, cache) {
                    io.send(&answer)?;
                }
            }
            MasterMessage::RenderLine { job, line } => self.render(job, line, None, io)?,
            MasterMessage::RenderLines { job, first, count } => {
                for line in (first..first.saturating_add(count)).take(count as usize) {
                    self.render(job, line, None, io)?;
                }
            }
            MasterMessage::RefineLine { job, line, mask } => {
                self.render(job, line, Some(mask), io)?;
            }
            MasterMessage::Fence { seq } => io.send(&WorkerMessage::FenceAck { seq })?,
        }
        Ok(None)
    }

    /// Answers a master's `Hello`. The same `Hello` again (a master that heard no answer, or
    /// waited while another session ran, probes with it) gets the same answer and changes
    /// nothing, so the master's `Auth` for the first answer still holds; another `Hello` starts
    /// the session afresh.
    fn greet<L, O: Outbox<L>>(
        &mut self,
        h: &Hello<'_>,
        io: &mut Io<'_, L, O>,
    ) -> Result<(), WorkerError> {
        let node = self.node;
        let repeat = self.greeting.filter(|g| g.master == h.nonce);
        let worker = repeat.map_or_else(node.nonce, |g| g.worker);
        io.send(&WorkerMessage::Hello(Hello {
            version: PROTOCOL_VERSION,
            name: node.name,
            arch: node.arch,
            scene_memory: node.scene_memory,
            threads: node.threads.max(1),
            nonce: worker,
            proof: node
                .secret
                .map(|k| auth::prove(k, Role::Worker, &h.nonce, &worker)),
        }))?;
        if h.version != PROTOCOL_VERSION {
            return Err(WorkerError::VersionMismatch { master: h.version });
        }
        if repeat.is_some() {
            return Ok(());
        }
        self.greeting = Some(Greeting {
            master: h.nonce,
            worker,
        });
        self.trust = match node.secret {
            Some(_) => Trust::Awaiting,
            None => Trust::Open,
        };
        self.job = None;
        self.dropped = 0;
        if self.trust == Trust::Open {
            io.out.established();
        }
        Ok(())
    }

    /// Checks the master's `Auth`: the session goes on if it proves the secret, and ends with
    /// a refusal if it does not. Without a secret, or once proven, an `Auth` changes nothing.
    fn check_auth<L, O: Outbox<L>>(
        &mut self,
        proof: &auth::Proof,
        io: &mut Io<'_, L, O>,
    ) -> Result<(), WorkerError> {
        let (Trust::Awaiting, Some(secret), Some(g)) =
            (self.trust, self.node.secret, self.greeting)
        else {
            return Ok(());
        };
        if auth::verify(secret, Role::Master, &g.master, &g.worker, proof) {
            self.trust = Trust::Proven;
            io.out.established();
            return Ok(());
        }
        io.send(&WorkerMessage::Refused {
            job: 0,
            reason: Refusal::Unauthenticated,
        })?;
        Err(WorkerError::Unauthenticated)
    }

    /// Starts (or re-announces) a job and gives the answer to its `Job` message.
    fn start_job(
        &mut self,
        id: u32,
        digest: Digest,
        scene_len: u32,
        cache: &mut SceneCache,
    ) -> WorkerMessage<'static> {
        // The same job announced again (the master heard nothing): answer where we stand.
        if let Some(job) = &self.job {
            if job.id == id && job.digest == digest {
                return stage_answer(id, &job.stage, true);
            }
        }
        let stage = if let Some(scene) = cache.get(&digest) {
            Stage::Ready(scene)
        } else if memory_estimate(scene_len, None) > self.node.scene_memory {
            Stage::Refused(Refusal::SceneTooLarge {
                limit: self.node.scene_memory,
            })
        } else {
            match SceneAssembler::new(digest, scene_len) {
                Ok(assembler) => Stage::Loading {
                    assembler,
                    asked: None,
                },
                Err(_) => Stage::Refused(Refusal::SceneTooLarge {
                    limit: self.node.scene_memory,
                }),
            }
        };
        let answer = stage_answer(id, &stage, false);
        self.job = Some(Job { id, digest, stage });
        answer
    }

    /// Takes a scene chunk; gives the answer it calls for, if any.
    fn take_chunk(
        &mut self,
        digest: &Digest,
        offset: u32,
        bytes: &[u8],
        cache: &mut SceneCache,
    ) -> Option<WorkerMessage<'static>> {
        let job = self.job.as_mut()?;
        let Stage::Loading { assembler, asked } = &mut job.stage else {
            return None;
        };
        let id = job.id;
        match assembler.push(digest, offset, bytes) {
            ChunkOutcome::Stale => None,
            ChunkOutcome::Appended => {
                let expected = assembler.expected();
                // Crossing a window boundary asks for the next window.
                (expected / SCENE_WINDOW != offset / SCENE_WINDOW).then_some(
                    WorkerMessage::NeedScene {
                        job: id,
                        offset: expected,
                        restart: false,
                    },
                )
            }
            ChunkOutcome::Gap { expected } => {
                if *asked == Some(expected) {
                    return None;
                }
                *asked = Some(expected);
                Some(WorkerMessage::NeedScene {
                    job: id,
                    offset: expected,
                    restart: true,
                })
            }
            ChunkOutcome::Complete => {
                // Take the assembler out of the stage; the stage is set again just below.
                let loading =
                    core::mem::replace(&mut job.stage, Stage::Refused(Refusal::CorruptScene));
                if let Stage::Loading { assembler, .. } = loading {
                    job.stage = match prepare(assembler, self.node.scene_memory) {
                        Ok(scene) => {
                            cache.put(job.digest, Arc::clone(&scene));
                            Stage::Ready(scene)
                        }
                        Err(reason) => Stage::Refused(reason),
                    };
                }
                Some(stage_answer(id, &job.stage, true))
            }
        }
    }

    /// Renders `line` (the first pass), or with `mask` the second pass of adaptive
    /// multisampling, through the outbox; refuses a request for another job or a refused one.
    fn render<L, O: Outbox<L>>(
        &mut self,
        id: u32,
        line: u32,
        mask: Option<&[u8]>,
        io: &mut Io<'_, L, O>,
    ) -> Result<(), WorkerError> {
        let reason = match &self.job {
            Some(Job {
                id: current,
                stage: Stage::Ready(scene),
                ..
            }) if *current == id => {
                return io.render(LineRequest {
                    scene,
                    job: id,
                    line,
                    mask,
                });
            }
            Some(Job {
                id: current,
                stage: Stage::Refused(reason),
                ..
            }) if *current == id => *reason,
            _ => Refusal::UnknownJob,
        };
        io.send(&WorkerMessage::Refused { job: id, reason })
    }
}

/// The job a request names (0 for messages that name none).
fn request_job(msg: &MasterMessage<'_>) -> u32 {
    match *msg {
        MasterMessage::Job { job, .. }
        | MasterMessage::RenderLine { job, .. }
        | MasterMessage::RenderLines { job, .. }
        | MasterMessage::RefineLine { job, .. } => job,
        _ => 0,
    }
}

/// The answer that says where job `id` stands: `NeedScene` (from the next byte wanted; a
/// fresh job asks from 0 with `restart`), `Ready` or `Refused`.
fn stage_answer(id: u32, stage: &Stage, again: bool) -> WorkerMessage<'static> {
    match stage {
        Stage::Loading { assembler, .. } => WorkerMessage::NeedScene {
            job: id,
            offset: if again { assembler.expected() } else { 0 },
            restart: true,
        },
        Stage::Ready(_) => WorkerMessage::Ready { job: id },
        Stage::Refused(reason) => WorkerMessage::Refused {
            job: id,
            reason: *reason,
        },
    }
}

/// Checks, decodes and builds a received scene.
fn prepare(assembler: SceneAssembler, memory: u64) -> Result<Arc<Scene>, Refusal> {
    let bytes = assembler.finish().map_err(|_| Refusal::CorruptScene)?;
    let bundle = decode_bundle(&bytes).map_err(|_| Refusal::CorruptScene)?;
    let needed = memory_estimate(bytes.len() as u32, Some(&bundle.desc));
    if needed > memory {
        return Err(Refusal::SceneTooLarge { limit: memory });
    }
    drop(bytes);
    // The lights' buffers only speed shadow rays up: they get what the scene leaves.
    Scene::build_within(&bundle.desc, &bundle.octree, memory - needed)
        .map(Arc::new)
        .map_err(Refusal::BadScene)
}
