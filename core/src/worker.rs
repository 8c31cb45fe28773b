//! The worker loop: one session with one master, over any `embedded_io` link.
//!
//! [`serve`] answers the master's `Hello`, receives or finds the job's scene, and renders the
//! requested lines in the order they arrive, until the master ends the session or the link
//! closes. The same function runs in a thread of `strahl render`, in `strahl worker` over TCP or
//! a serial port, and on a microcontroller. It allocates the scene and one line's buffers, sized
//! from the scene; frames from the master are read into a buffer of
//! [`crate::wire::MAX_MASTER_FRAME_LEN`] bytes on the stack. The scene
//! arrives in windows of [`SCENE_WINDOW`] bytes, each asked for with `NeedScene`. Frames it cannot
//! read are dropped and reported to the master with `Dropped`, so the master can find out
//! (with a `Fence`) which requests were lost.
//!
//! The [`SceneCache`] outlives sessions: a worker that serves the next master, or the next job
//! of the same master, with a scene it already has skips the transfer.

use crate::render::adaptive::refine_line;
use crate::render::error::RenderError;
use crate::render::pixel::Pixel;
use crate::render::render_line;
use crate::scene::Scene;
use crate::wire::error::ProtocolError;
use crate::wire::frame::{FrameReader, FrameWriteError, FrameWriter, LinkError, ReadEvent};
use crate::wire::message::{encode_pixels, Digest, Hello, MasterMessage, Refusal, WorkerMessage};
use crate::wire::scene_blob::{decode_bundle, memory_estimate, ChunkOutcome, SceneAssembler};
use crate::wire::{MAX_MASTER_FRAME_LEN, PIXEL_WIRE_BYTES, PROTOCOL_VERSION, SCENE_WINDOW};
use alloc::sync::Arc;
use alloc::vec;
use alloc::vec::Vec;
use embedded_io::{Read, Write};

/// What a worker tells the master about itself.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NodeInfo<'a> {
    /// The node's name, at most [`crate::wire::MAX_NAME_LEN`] bytes.
    pub name: &'a str,
    /// The node's architecture, at most [`crate::wire::MAX_NAME_LEN`] bytes.
    pub arch: &'a str,
    /// Bytes of memory the node can give a scene; larger scenes are refused.
    pub scene_memory: u64,
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
    Closed,
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
}

impl From<FrameWriteError> for WorkerError {
    fn from(e: FrameWriteError) -> Self {
        match e {
            FrameWriteError::Encode(e) => WorkerError::Encode(e),
            FrameWriteError::Link(e) => WorkerError::Link(e),
        }
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
    /// Rendering: the scene and one line's buffers.
    Ready {
        scene: Arc<Scene>,
        pixels: Vec<Pixel>,
        wire: Vec<u8>,
    },
    /// The job was refused; line requests for it are refused too.
    Refused(Refusal),
}

/// One session's state.
struct Session<'n, L> {
    link: L,
    node: &'n NodeInfo<'n>,
    writer: FrameWriter,
    greeted: bool,
    job: Option<Job>,
    dropped: u32,
}

/// Serves one master over `link` until it ends the session or the link closes.
///
/// Read time-outs (a serial port with nothing to say) are waited through. A `Hello` in the
/// middle of a session starts it afresh, keeping the cache.
///
/// # Errors
/// [`WorkerError::VersionMismatch`] if the master speaks another version,
/// [`WorkerError::Link`] if the link fails, [`WorkerError::Encode`] on an internal error.
pub fn serve<L: Read + Write>(
    link: &mut L,
    node: &NodeInfo<'_>,
    cache: &mut SceneCache,
) -> Result<SessionEnd, WorkerError> {
    let mut rx = [0u8; MAX_MASTER_FRAME_LEN];
    let mut reader = FrameReader::new(&mut rx[..]);
    let mut session = Session {
        link,
        node,
        writer: FrameWriter::new(),
        greeted: false,
        job: None,
        dropped: 0,
    };
    loop {
        let event = match reader.next(session.link) {
            Ok(event) => event,
            Err(LinkError::TimedOut) => continue,
            Err(LinkError::Closed) => return Ok(SessionEnd::Closed),
            Err(e) => return Err(WorkerError::Link(e)),
        };
        let msg = match event {
            ReadEvent::Frame(payload) => MasterMessage::decode(payload),
            ReadEvent::Dropped(_) => Err(ProtocolError::Decode),
        };
        match msg {
            Ok(msg) => {
                if let Some(end) = session.handle(msg, cache)? {
                    return Ok(end);
                }
            }
            Err(_) => {
                session.dropped = session.dropped.saturating_add(1);
                if session.greeted {
                    let total = session.dropped;
                    session.send(&WorkerMessage::Dropped { total })?;
                }
            }
        }
    }
}

impl<L: Read + Write> Session<'_, &mut L> {
    fn send(&mut self, msg: &WorkerMessage<'_>) -> Result<(), WorkerError> {
        Ok(self.writer.send(self.link, msg)?)
    }

    /// Handles one message; `Some` ends the session.
    fn handle(
        &mut self,
        msg: MasterMessage<'_>,
        cache: &mut SceneCache,
    ) -> Result<Option<SessionEnd>, WorkerError> {
        match msg {
            MasterMessage::Hello(h) => {
                let node = self.node;
                self.send(&WorkerMessage::Hello(Hello {
                    version: PROTOCOL_VERSION,
                    name: node.name,
                    arch: node.arch,
                    scene_memory: node.scene_memory,
                }))?;
                if h.version != PROTOCOL_VERSION {
                    return Err(WorkerError::VersionMismatch { master: h.version });
                }
                self.greeted = true;
                self.job = None;
                self.dropped = 0;
            }
            // Nothing but a Hello opens a session.
            _ if !self.greeted => {}
            MasterMessage::Job {
                job,
                digest,
                scene_len,
            } => self.start_job(job, digest, scene_len, cache)?,
            MasterMessage::SceneChunk {
                digest,
                offset,
                bytes,
            } => self.take_chunk(&digest, offset, bytes, cache)?,
            MasterMessage::RenderLine { job, line } => self.render(job, line, None)?,
            MasterMessage::RefineLine { job, line, mask } => self.render(job, line, Some(mask))?,
            MasterMessage::Fence { seq } => self.send(&WorkerMessage::FenceAck { seq })?,
            MasterMessage::EndSession => return Ok(Some(SessionEnd::Ended)),
        }
        Ok(None)
    }

    fn start_job(
        &mut self,
        id: u32,
        digest: Digest,
        scene_len: u32,
        cache: &mut SceneCache,
    ) -> Result<(), WorkerError> {
        // The same job announced again (the master heard nothing): answer where we stand.
        if let Some(job) = &self.job {
            if job.id == id && job.digest == digest {
                let answer = match &job.stage {
                    Stage::Loading { assembler, .. } => WorkerMessage::NeedScene {
                        job: id,
                        offset: assembler.expected(),
                        restart: true,
                    },
                    Stage::Ready { .. } => WorkerMessage::Ready { job: id },
                    Stage::Refused(reason) => WorkerMessage::Refused {
                        job: id,
                        reason: *reason,
                    },
                };
                return self.send(&answer);
            }
        }
        let stage = if let Some(scene) = cache.get(&digest) {
            ready(scene)
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
        let answer = match &stage {
            Stage::Loading { .. } => WorkerMessage::NeedScene {
                job: id,
                offset: 0,
                restart: true,
            },
            Stage::Ready { .. } => WorkerMessage::Ready { job: id },
            Stage::Refused(reason) => WorkerMessage::Refused {
                job: id,
                reason: *reason,
            },
        };
        self.job = Some(Job { id, digest, stage });
        self.send(&answer)
    }

    fn take_chunk(
        &mut self,
        digest: &Digest,
        offset: u32,
        bytes: &[u8],
        cache: &mut SceneCache,
    ) -> Result<(), WorkerError> {
        let Some(job) = &mut self.job else {
            return Ok(());
        };
        let Stage::Loading { assembler, asked } = &mut job.stage else {
            return Ok(());
        };
        let id = job.id;
        match assembler.push(digest, offset, bytes) {
            ChunkOutcome::Stale => Ok(()),
            ChunkOutcome::Appended => {
                let expected = assembler.expected();
                // Crossing a window boundary asks for the next window.
                if expected / SCENE_WINDOW == offset / SCENE_WINDOW {
                    return Ok(());
                }
                self.send(&WorkerMessage::NeedScene {
                    job: id,
                    offset: expected,
                    restart: false,
                })
            }
            ChunkOutcome::Gap { expected } => {
                if *asked == Some(expected) {
                    return Ok(());
                }
                *asked = Some(expected);
                self.send(&WorkerMessage::NeedScene {
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
                            ready(scene)
                        }
                        Err(reason) => Stage::Refused(reason),
                    };
                }
                let answer = match &job.stage {
                    Stage::Refused(reason) => WorkerMessage::Refused {
                        job: id,
                        reason: *reason,
                    },
                    _ => WorkerMessage::Ready { job: id },
                };
                self.send(&answer)
            }
        }
    }

    /// Renders `line` (the first pass), or with `mask` the second pass of adaptive
    /// multisampling, and sends the result.
    fn render(&mut self, id: u32, line: u32, mask: Option<&[u8]>) -> Result<(), WorkerError> {
        let refusal = match &mut self.job {
            Some(Job {
                id: current,
                stage:
                    Stage::Ready {
                        scene,
                        pixels,
                        wire,
                    },
                ..
            }) if *current == id => {
                let rendered = match mask {
                    None => render_line(scene, line, pixels),
                    Some(mask) => refine_line(scene, line, mask, pixels),
                };
                match rendered {
                    Ok(rays) => {
                        encode_pixels(pixels, wire).map_err(WorkerError::Encode)?;
                        return Ok(self.writer.send(
                            self.link,
                            &WorkerMessage::LineResult {
                                job: id,
                                line,
                                refined: mask.is_some(),
                                rays,
                                pixels: wire,
                            },
                        )?);
                    }
                    Err(RenderError::LineOutOfRange) => Refusal::LineOutOfRange,
                    // The line buffers are sized from the scene, so only a mask can misfit.
                    Err(RenderError::WrongBufferLength) => {
                        debug_assert!(mask.is_some(), "line buffers sized from the scene");
                        Refusal::BadMask
                    }
                    Err(RenderError::NotAdaptive) => Refusal::BadMask,
                }
            }
            Some(Job {
                id: current,
                stage: Stage::Refused(reason),
                ..
            }) if *current == id => *reason,
            _ => Refusal::UnknownJob,
        };
        self.send(&WorkerMessage::Refused {
            job: id,
            reason: refusal,
        })
    }
}

/// The ready stage for `scene`, with one line's buffers.
fn ready(scene: Arc<Scene>) -> Stage {
    let width = scene.settings.width as usize;
    Stage::Ready {
        scene,
        pixels: vec![Pixel::default(); width],
        wire: vec![0; width * PIXEL_WIRE_BYTES],
    }
}

/// Checks, decodes and builds a received scene.
fn prepare(assembler: SceneAssembler, memory: u64) -> Result<Arc<Scene>, Refusal> {
    let bytes = assembler.finish().map_err(|_| Refusal::CorruptScene)?;
    let bundle = decode_bundle(&bytes).map_err(|_| Refusal::CorruptScene)?;
    if memory_estimate(bytes.len() as u32, Some(&bundle.desc)) > memory {
        return Err(Refusal::SceneTooLarge { limit: memory });
    }
    drop(bytes);
    Scene::build(&bundle.desc, &bundle.octree)
        .map(Arc::new)
        .map_err(Refusal::BadScene)
}
