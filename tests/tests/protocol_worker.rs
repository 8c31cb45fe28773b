//! The worker loop, `strahl_core::worker::serve`, over an in-memory link.
//!
//! Each test scripts what a master sends (frames built with `FrameWriter`, then the end of the
//! stream), runs `serve` on it, and decodes every frame the worker wrote. It checks the session
//! (greeting, scene transfer with its window requests, rendering, fences, the end), that the
//! rendered lines are byte-identical to `render_line` on the same scene, that the scene cache
//! skips a second transfer, and how the worker answers version mismatches, messages before
//! `Hello`, requests it cannot serve, scenes too large or corrupt, damaged frames and lost chunks.
//! The outbox of `strahl render`'s in-process workers (`Held`) must send the same bytes, and
//! write each master message's answers together (sooner once one has waited 50 ms).

use embedded_io::{ErrorKind, ErrorType, Read, Write};
use glam::Vec3;
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::render::adaptive::{mask_len, refine_line};
use strahl_core::render::pixel::Pixel;
use strahl_core::render::render_line;
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::camera::{Camera, SeedCamera};
use strahl_core::scene::error::SceneError;
use strahl_core::scene::{Scene, SceneDesc};
use strahl_core::wire::auth::{self, Role};
use strahl_core::wire::frame::{FrameReader, FrameWriter, LinkError, ReadEvent};
use strahl_core::wire::message::{
    decode_pixels, Hello, MasterMessage, Refusal, Rejection, WorkerMessage,
};
use strahl_core::wire::scene_blob::{memory_estimate, SceneBlob};
use strahl_core::wire::{
    MAX_CHUNK_LEN, MAX_FRAME_LEN, PIXEL_WIRE_BYTES, PROTOCOL_VERSION, SCENE_WINDOW,
};
use strahl_core::worker::{serve, serve_with, NodeInfo, SceneCache, SessionEnd, WorkerError};
use strahl_host::cluster::held::{Held, HOLD_LIMIT};
use strahl_tcp::threads::serve_threaded;

// ---------------------------------------------------------------------------------------------
// The link and the script
// ---------------------------------------------------------------------------------------------

/// A link whose read side hands out a fixed script in pieces, then reports end of stream, and
/// whose write side collects everything written.
struct ScriptLink {
    input: Vec<u8>,
    pos: usize,
    piece: usize,
    output: Vec<u8>,
}

impl ErrorType for ScriptLink {
    type Error = ErrorKind;
}

impl Read for ScriptLink {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, ErrorKind> {
        let n = self.piece.min(buf.len()).min(self.input.len() - self.pos);
        buf[..n].copy_from_slice(&self.input[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

impl Write for ScriptLink {
    fn write(&mut self, buf: &[u8]) -> Result<usize, ErrorKind> {
        self.output.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), ErrorKind> {
        Ok(())
    }
}

/// What the master sends, as frames.
#[derive(Default)]
struct Script {
    writer: FrameWriter,
    bytes: Vec<u8>,
}

impl Script {
    fn send(&mut self, msg: MasterMessage<'_>) -> &mut Self {
        let frame = self.writer.encode(&msg).expect("a master message encodes");
        self.bytes.extend_from_slice(frame);
        self
    }

    fn raw(&mut self, bytes: &[u8]) -> &mut Self {
        self.bytes.extend_from_slice(bytes);
        self
    }

    fn hello(&mut self) -> &mut Self {
        self.hello_with(MASTER_NONCE)
    }

    /// A master's `Hello` with `nonce` (another master, or the same starting afresh).
    fn hello_with(&mut self, nonce: [u8; 32]) -> &mut Self {
        self.send(MasterMessage::Hello(Hello {
            version: PROTOCOL_VERSION,
            name: "master",
            arch: "x86_64",
            scene_memory: 0,
            threads: 0,
            nonce,
            proof: None,
        }))
    }

    fn job(&mut self, job: u32, blob: &SceneBlob) -> &mut Self {
        self.send(MasterMessage::Job {
            job,
            digest: blob.digest,
            scene_len: blob.len(),
        })
    }

    /// The chunks of `blob` from `from` to the end, in order.
    fn chunks_from(&mut self, blob: &SceneBlob, from: u32) -> &mut Self {
        for offset in (from..blob.len()).step_by(MAX_CHUNK_LEN) {
            self.chunk(blob, offset);
        }
        self
    }

    fn chunk(&mut self, blob: &SceneBlob, offset: u32) -> &mut Self {
        self.send(MasterMessage::SceneChunk {
            digest: blob.digest,
            offset,
            bytes: blob.chunk_at(offset),
        })
    }

    fn line(&mut self, job: u32, line: u32) -> &mut Self {
        self.send(MasterMessage::RenderLine { job, line })
    }

    fn lines(&mut self, job: u32, first: u32, count: u32) -> &mut Self {
        self.send(MasterMessage::RenderLines { job, first, count })
    }
}

/// A worker message, owned, with the pixels decoded.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Out {
    Hello {
        version: u32,
        name: String,
        arch: String,
        scene_memory: u64,
        threads: u32,
        nonce: [u8; 32],
        proof: Option<[u8; 32]>,
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
        rays: RayCounts,
        pixels: Vec<Pixel>,
    },
    /// The answer to a `RefineLine`.
    Refined {
        job: u32,
        line: u32,
        rays: RayCounts,
        pixels: Vec<Pixel>,
    },
    FenceAck {
        seq: u32,
    },
    Dropped {
        total: u32,
    },
    Refused {
        job: u32,
        reason: Refusal,
    },
    /// Not sent by the core's loop (only by the firmware's panic handler).
    Panicked {
        message: String,
    },
}

impl Out {
    fn from_message(m: WorkerMessage<'_>) -> Self {
        match m {
            WorkerMessage::Hello(h) => Out::Hello {
                version: h.version,
                name: h.name.to_owned(),
                arch: h.arch.to_owned(),
                scene_memory: h.scene_memory,
                threads: h.threads,
                nonce: h.nonce,
                proof: h.proof,
            },
            WorkerMessage::NeedScene {
                job,
                offset,
                restart,
            } => Out::NeedScene {
                job,
                offset,
                restart,
            },
            WorkerMessage::Ready { job } => Out::Ready { job },
            WorkerMessage::LineResult {
                job,
                line,
                refined,
                rays,
                pixels,
            } => {
                let mut decoded = vec![Pixel::default(); pixels.len() / PIXEL_WIRE_BYTES];
                decode_pixels(pixels, &mut decoded).expect("whole pixels");
                if refined {
                    Out::Refined {
                        job,
                        line,
                        rays,
                        pixels: decoded,
                    }
                } else {
                    Out::Line {
                        job,
                        line,
                        rays,
                        pixels: decoded,
                    }
                }
            }
            WorkerMessage::FenceAck { seq } => Out::FenceAck { seq },
            WorkerMessage::Dropped { total } => Out::Dropped { total },
            WorkerMessage::Refused { job, reason } => Out::Refused { job, reason },
            WorkerMessage::Panicked { message } => Out::Panicked {
                message: message.to_owned(),
            },
        }
    }
}

/// Everything the worker wrote, decoded; every frame must be intact and a legal message.
fn decode_output(bytes: &[u8]) -> Vec<Out> {
    let mut link = bytes;
    let mut buf = vec![0u8; MAX_FRAME_LEN];
    let mut reader = FrameReader::new(&mut buf[..]);
    let mut out = Vec::new();
    loop {
        match reader.next(&mut link) {
            Ok(ReadEvent::Frame(p)) => out.push(Out::from_message(
                WorkerMessage::decode(p).expect("the worker sends legal messages"),
            )),
            Ok(ReadEvent::Dropped(d)) => panic!("the worker wrote a bad frame: {d:?}"),
            Err(LinkError::Closed) => return out,
            Err(e) => panic!("reading a slice failed: {e:?}"),
        }
    }
}

const NAME: &str = "test-worker";
const ARCH: &str = "riscv64";
const MEMORY: u64 = 256 << 20;

fn node(scene_memory: u64) -> NodeInfo<'static> {
    NodeInfo {
        name: NAME,
        arch: ARCH,
        scene_memory,
        threads: 1,
        secret: None,
        nonce: || WORKER_NONCE,
    }
}

/// The nonces of the scripted handshakes (fixed, so the proofs can be checked).
const MASTER_NONCE: [u8; 32] = [0x11; 32];
const WORKER_NONCE: [u8; 32] = [0x22; 32];

fn worker_hello(scene_memory: u64) -> Out {
    Out::Hello {
        version: PROTOCOL_VERSION,
        name: NAME.to_owned(),
        arch: ARCH.to_owned(),
        scene_memory,
        threads: 1,
        nonce: WORKER_NONCE,
        proof: None,
    }
}

/// A std reader that gives the script in pieces of `piece` bytes.
struct StdPieces<'a> {
    input: &'a [u8],
    piece: usize,
}

impl std::io::Read for StdPieces<'_> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.piece.min(buf.len()).min(self.input.len());
        buf[..n].copy_from_slice(&self.input[..n]);
        self.input = &self.input[n..];
        Ok(n)
    }
}

/// A std writer into a shared buffer (the threaded worker's writer runs on its own thread).
#[derive(Clone, Default)]
struct SharedOutput(Arc<std::sync::Mutex<Vec<u8>>>);

impl std::io::Write for SharedOutput {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let mut out = self.0.lock().map_err(|_| std::io::ErrorKind::Other)?;
        out.extend_from_slice(buf);
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

/// Runs `serve` on the script, fed in pieces of `piece` bytes; returns its result and what the
/// worker sent. The same script through the threaded worker of `strahl worker`
/// (`strahl_tcp::threads`, 3 render threads, with a copy of the cache) and through the outbox
/// of `strahl render`'s in-process workers (`Held`, which writes a message's answers together)
/// must give the same result and the same bytes, in the same order.
fn run_pieces(
    script: &Script,
    node: &NodeInfo<'_>,
    cache: &mut SceneCache,
    piece: usize,
) -> (Result<SessionEnd, WorkerError>, Vec<Out>) {
    let mut threaded_cache = cache.clone();
    let mut held_cache = cache.clone();
    let mut link = ScriptLink {
        input: script.bytes.clone(),
        pos: 0,
        piece,
        output: Vec::new(),
    };
    let result = serve(&mut link, node, cache);
    let output = SharedOutput::default();
    let reader = StdPieces {
        input: &script.bytes,
        piece,
    };
    let threaded = serve_threaded(
        reader,
        output.clone(),
        &|| {},
        &|| {},
        node,
        &mut threaded_cache,
        3,
    );
    assert_eq!(
        threaded, result,
        "the threaded worker ends the session alike"
    );
    let threaded_bytes = output.0.lock().expect("not poisoned").clone();
    assert!(
        threaded_bytes == link.output,
        "the threaded worker sends other bytes: {:?}",
        decode_output(&threaded_bytes)
    );
    let mut held_link = ScriptLink {
        input: script.bytes.clone(),
        pos: 0,
        piece,
        output: Vec::new(),
    };
    let held = serve_with(&mut held_link, &mut Held::default(), node, &mut held_cache);
    assert_eq!(held, result, "the held outbox ends the session alike");
    assert!(
        held_link.output == link.output,
        "the held outbox sends other bytes: {:?}",
        decode_output(&held_link.output)
    );
    (result, decode_output(&link.output))
}

fn run(
    script: &Script,
    node: &NodeInfo<'_>,
    cache: &mut SceneCache,
) -> (Result<SessionEnd, WorkerError>, Vec<Out>) {
    run_pieces(script, node, cache, 61)
}

// ---------------------------------------------------------------------------------------------
// Scenes and expectations
// ---------------------------------------------------------------------------------------------

const WIDTH: u32 = 24;
const HEIGHT: u32 = 16;

/// The demo room, small, seen by the seed's example camera.
fn room_desc() -> SceneDesc {
    let mut desc = strahl_host::generate::room();
    desc.camera = Camera::Seed(SeedCamera {
        position: Vec3::new(0.0, -100.0, 25.0),
        angle_x_deg: -15.0,
        angle_z_deg: 0.0,
        zoom: 1.5,
    });
    desc.settings.width = WIDTH;
    desc.settings.height = HEIGHT;
    desc
}

/// A scene as the master holds it: its description, encoding, and prepared form.
struct Fixture {
    desc: SceneDesc,
    blob: SceneBlob,
    scene: Scene,
}

fn fixture(desc: SceneDesc) -> Fixture {
    let params = OctreeParams::default();
    let blob = SceneBlob::encode(&desc, &params).expect("the scene encodes");
    let scene = Scene::build(&desc, &params).expect("the scene builds");
    Fixture { desc, blob, scene }
}

fn room() -> Fixture {
    fixture(room_desc())
}

/// What `render_line` gives for `line` of the fixture's scene, as a worker should answer it.
fn expected_line(f: &Fixture, job: u32, line: u32) -> Out {
    let mut pixels = vec![Pixel::default(); f.scene.settings.width as usize];
    let rays = render_line(&f.scene, line, &mut pixels).expect("the line exists");
    Out::Line {
        job,
        line,
        rays,
        pixels,
    }
}

/// The worker's answers to the chunks from `from` to the end, sent in order: a window request
/// each time a window boundary is crossed, and `Ready` after the last chunk.
fn transfer_answers(blob: &SceneBlob, job: u32, from: u32) -> Vec<Out> {
    let mut out = Vec::new();
    for offset in (from..blob.len()).step_by(MAX_CHUNK_LEN) {
        let end = offset + blob.chunk_at(offset).len() as u32;
        if end == blob.len() {
            out.push(Out::Ready { job });
        } else if end / SCENE_WINDOW != offset / SCENE_WINDOW {
            out.push(Out::NeedScene {
                job,
                offset: end,
                restart: false,
            });
        }
    }
    out
}

/// A frame that fails its CRC: a Fence frame with one bit flipped inside.
fn corrupt_frame() -> Vec<u8> {
    let mut frame = FrameWriter::new()
        .encode(&MasterMessage::Fence { seq: 0x0101_0101 })
        .expect("encodes")
        .to_vec();
    let mid = frame.len() / 2;
    frame[mid] ^= 0x04;
    assert_ne!(frame[mid], 0, "the flip must not make a delimiter");
    frame
}

// ---------------------------------------------------------------------------------------------
// Sessions
// ---------------------------------------------------------------------------------------------

#[test]
fn full_session_transfers_renders_and_ends() {
    let f = room();
    assert!(
        f.blob.len() > 2 * SCENE_WINDOW,
        "the room spans several windows ({} bytes)",
        f.blob.len()
    );
    let lines = [0, 5, HEIGHT - 1, 7];
    let mut script = Script::default();
    script.hello().job(1, &f.blob).chunks_from(&f.blob, 0);
    for &y in &lines {
        script.line(1, y);
    }
    script.send(MasterMessage::EndSession);
    // Nothing after EndSession is read.
    script.send(MasterMessage::Fence { seq: 9 });

    for piece in [1, 61, 4096] {
        let mut cache = SceneCache::new();
        let (result, out) = run_pieces(&script, &node(MEMORY), &mut cache, piece);
        assert_eq!(result, Ok(SessionEnd::Ended), "piece {piece}");

        let mut want = vec![
            worker_hello(MEMORY),
            Out::NeedScene {
                job: 1,
                offset: 0,
                restart: true,
            },
        ];
        want.extend(transfer_answers(&f.blob, 1, 0));
        want.extend(lines.iter().map(|&y| expected_line(&f, 1, y)));
        assert_eq!(out, want, "piece {piece}");
        assert!(
            cache.get(&f.blob.digest).is_some(),
            "the loaded scene is cached"
        );
    }

    // The comparison means something: the lines show the room, not one flat colour, and every
    // pixel traced at least its primary ray.
    let Out::Line { pixels, rays, .. } = expected_line(&f, 1, HEIGHT / 2) else {
        unreachable!("expected_line makes lines");
    };
    assert!(pixels.iter().any(|p| *p != pixels[0]), "a varied line");
    assert!(rays.primary == u64::from(WIDTH) && rays.shadow > 0);
}

#[test]
fn end_of_stream_closes_the_session() {
    let mut cache = SceneCache::new();
    let (result, out) = run(&Script::default(), &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    assert_eq!(out, vec![]);

    let mut script = Script::default();
    script
        .hello()
        .send(MasterMessage::Fence { seq: 1 })
        // A partial frame at the end is lost with the link.
        .raw(&[0, 5, 6, 7]);
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    assert_eq!(out, vec![worker_hello(MEMORY), Out::FenceAck { seq: 1 }]);
}

#[test]
fn cached_scene_skips_the_transfer() {
    let f = room();
    let mut cache = SceneCache::new();
    let mut first = Script::default();
    first
        .hello()
        .job(1, &f.blob)
        .chunks_from(&f.blob, 0)
        .send(MasterMessage::EndSession);
    let (result, out) = run(&first, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Ended));
    assert_eq!(out.last(), Some(&Out::Ready { job: 1 }));

    // The next master (a new session, same cache) announces the same scene under another job.
    let other = fixture({
        let mut d = room_desc();
        d.settings.width = WIDTH + 1;
        d
    });
    let mut second = Script::default();
    second
        .hello()
        .job(2, &f.blob)
        .line(2, 3)
        .job(3, &other.blob)
        .send(MasterMessage::EndSession);
    let (result, out) = run(&second, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Ended));
    assert_eq!(
        out,
        vec![
            worker_hello(MEMORY),
            Out::Ready { job: 2 },
            expected_line(&f, 2, 3),
            // Another scene is not in the cache.
            Out::NeedScene {
                job: 3,
                offset: 0,
                restart: true,
            },
        ]
    );

    // A cache made from the master's prepared scene works the same.
    let mut shared = SceneCache::with_scene(f.blob.digest, Arc::new(f.scene.clone()));
    let mut third = Script::default();
    third.hello().job(4, &f.blob).line(4, HEIGHT - 1);
    let (result, out) = run(&third, &node(MEMORY), &mut shared);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    assert_eq!(
        out,
        vec![
            worker_hello(MEMORY),
            Out::Ready { job: 4 },
            expected_line(&f, 4, HEIGHT - 1)
        ]
    );
}

#[test]
fn a_multi_line_request_is_answered_line_by_line_in_order() {
    let f = room();
    let mut cache = SceneCache::with_scene(f.blob.digest, Arc::new(f.scene.clone()));
    let mut script = Script::default();
    script
        .hello()
        .job(1, &f.blob)
        .send(MasterMessage::RenderLines {
            job: 1,
            first: 3,
            count: 4,
        })
        // Past the bottom: the lines that exist are rendered, the others refused one by one.
        .send(MasterMessage::RenderLines {
            job: 1,
            first: HEIGHT - 1,
            count: 2,
        })
        .send(MasterMessage::RenderLines {
            job: 7,
            first: 0,
            count: 2,
        })
        .send(MasterMessage::Fence { seq: 5 });
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    let mut want = vec![worker_hello(MEMORY), Out::Ready { job: 1 }];
    want.extend((3..7).map(|y| expected_line(&f, 1, y)));
    want.push(expected_line(&f, 1, HEIGHT - 1));
    want.push(Out::Refused {
        job: 1,
        reason: Refusal::LineOutOfRange,
    });
    want.extend(
        [Refusal::UnknownJob; 2]
            .into_iter()
            .map(|reason| Out::Refused { job: 7, reason }),
    );
    want.push(Out::FenceAck { seq: 5 });
    assert_eq!(out, want);
}

/// A link that keeps each write apart.
#[derive(Default)]
struct Writes {
    input: Vec<u8>,
    pos: usize,
    writes: Vec<Vec<u8>>,
}

impl ErrorType for Writes {
    type Error = ErrorKind;
}

impl Read for Writes {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, ErrorKind> {
        let n = buf.len().min(self.input.len() - self.pos);
        buf[..n].copy_from_slice(&self.input[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

impl Write for Writes {
    fn write(&mut self, buf: &[u8]) -> Result<usize, ErrorKind> {
        self.writes.push(buf.to_vec());
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), ErrorKind> {
        Ok(())
    }
}

/// What `Held` (with the clock `now`) writes for the room fixture's `script` (after the
/// greeting and a job for the cached room), each write decoded apart.
fn held_writes(f: &Fixture, script: &Script, now: fn() -> std::time::Instant) -> Vec<Vec<Out>> {
    let mut cache = SceneCache::with_scene(f.blob.digest, Arc::new(f.scene.clone()));
    let mut link = Writes {
        input: script.bytes.clone(),
        ..Writes::default()
    };
    let mut outbox = Held::with_clock(now);
    let end = serve_with(&mut link, &mut outbox, &node(MEMORY), &mut cache);
    assert_eq!(end, Ok(SessionEnd::Closed { unreadable: 0 }));
    link.writes.iter().map(|w| decode_output(w)).collect()
}

/// What a worker answers for lines `ys` of job 1 of the fixture.
fn lines_of(f: &Fixture, ys: core::ops::Range<u32>) -> Vec<Out> {
    ys.map(|y| expected_line(f, 1, y)).collect()
}

#[test]
fn the_held_outbox_writes_each_messages_answers_at_once() {
    // A clock that stands still, so no answer waits past the limit on a slow machine.
    fn frozen() -> std::time::Instant {
        static NOW: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
        *NOW.get_or_init(std::time::Instant::now)
    }
    let f = room();
    let mut script = Script::default();
    script
        .hello()
        .job(1, &f.blob)
        .lines(1, 2, 5)
        .line(1, 9)
        .send(MasterMessage::Fence { seq: 3 });
    // One write per message answered: the greeting, the job, the five lines, the one line, the
    // fence.
    assert_eq!(
        held_writes(&f, &script, frozen),
        vec![
            vec![worker_hello(MEMORY)],
            vec![Out::Ready { job: 1 }],
            lines_of(&f, 2..7),
            lines_of(&f, 9..10),
            vec![Out::FenceAck { seq: 3 }],
        ]
    );
}

#[test]
fn the_held_outbox_writes_what_waited_its_limit_with_the_next_line() {
    // A clock that moves 20 ms each time it is read: the first line is held, the second (20 ms
    // later) too, the third (40 ms) too, the fourth (60 ms, past the 50 ms limit) goes out with
    // the three before it; then the fifth and sixth wait for the end of the request.
    static TICKS: AtomicU8 = AtomicU8::new(0);
    fn clock() -> std::time::Instant {
        static START: std::sync::OnceLock<std::time::Instant> = std::sync::OnceLock::new();
        let start = *START.get_or_init(std::time::Instant::now);
        let tick = u64::from(TICKS.fetch_add(1, Ordering::SeqCst));
        start + std::time::Duration::from_millis(20 * tick)
    }
    assert_eq!(HOLD_LIMIT, std::time::Duration::from_millis(50));
    let f = room();
    let mut script = Script::default();
    script.hello().job(1, &f.blob).lines(1, 0, 6);
    assert_eq!(
        held_writes(&f, &script, clock),
        vec![
            vec![worker_hello(MEMORY)],
            vec![Out::Ready { job: 1 }],
            lines_of(&f, 0..4),
            lines_of(&f, 4..6),
        ]
    );
}

const SECRET: &[u8] = b"sixteen or more bytes of secret";

/// A worker that requires [`SECRET`].
fn guarded_node() -> NodeInfo<'static> {
    NodeInfo {
        secret: Some(SECRET),
        ..node(MEMORY)
    }
}

/// The `Hello` a worker with [`SECRET`] answers [`Script::hello`] with: its proof over both
/// nonces.
fn guarded_hello() -> Out {
    Out::Hello {
        version: PROTOCOL_VERSION,
        name: NAME.to_owned(),
        arch: ARCH.to_owned(),
        scene_memory: MEMORY,
        threads: 1,
        nonce: WORKER_NONCE,
        proof: Some(auth::prove(
            SECRET,
            Role::Worker,
            &MASTER_NONCE,
            &WORKER_NONCE,
        )),
    }
}

#[test]
fn a_worker_with_a_secret_serves_a_master_that_proves_it() {
    let f = room();
    let mut cache = SceneCache::with_scene(f.blob.digest, Arc::new(f.scene.clone()));
    let proof = auth::prove(SECRET, Role::Master, &MASTER_NONCE, &WORKER_NONCE);
    let mut script = Script::default();
    script
        .hello()
        .send(MasterMessage::Auth { proof })
        .job(1, &f.blob)
        .line(1, 2)
        .send(MasterMessage::EndSession);
    let (result, out) = run(&script, &guarded_node(), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Ended));
    assert_eq!(
        out,
        vec![
            guarded_hello(),
            Out::Ready { job: 1 },
            expected_line(&f, 1, 2)
        ]
    );
}

#[test]
fn a_worker_with_a_secret_refuses_a_master_that_does_not_prove_it() {
    let f = room();
    let refused = |job| Out::Refused {
        job,
        reason: Refusal::Unauthenticated,
    };
    // No Auth at all: the job is refused and the session ends.
    let mut cache = SceneCache::with_scene(f.blob.digest, Arc::new(f.scene.clone()));
    let mut script = Script::default();
    script.hello().job(1, &f.blob).line(1, 2);
    let (result, out) = run(&script, &guarded_node(), &mut cache);
    assert_eq!(result, Err(WorkerError::Unauthenticated));
    assert_eq!(out, vec![guarded_hello(), refused(1)]);
    // A proof made with another secret, another worker nonce (a replay of another session),
    // or the worker's own proof reflected back: all refused.
    let wrong = [
        auth::prove(
            b"another secret, 16+",
            Role::Master,
            &MASTER_NONCE,
            &WORKER_NONCE,
        ),
        auth::prove(SECRET, Role::Master, &MASTER_NONCE, &[0x33; 32]),
        auth::prove(SECRET, Role::Worker, &MASTER_NONCE, &WORKER_NONCE),
    ];
    for proof in wrong {
        let mut script = Script::default();
        script
            .hello()
            .send(MasterMessage::Auth { proof })
            .job(1, &f.blob);
        let (result, out) = run(&script, &guarded_node(), &mut cache);
        assert_eq!(result, Err(WorkerError::Unauthenticated));
        assert_eq!(out, vec![guarded_hello(), refused(0)]);
    }
}

/// A worker with [`SECRET`] whose nonce differs at every handshake (1, 2, ... in every byte).
fn guarded_counting_node() -> NodeInfo<'static> {
    static CALLS: AtomicU8 = AtomicU8::new(0);
    CALLS.store(0, Ordering::SeqCst);
    NodeInfo {
        nonce: || [CALLS.fetch_add(1, Ordering::SeqCst) + 1; 32],
        ..guarded_node()
    }
}

#[test]
fn the_same_hello_again_gets_the_same_answer_and_changes_nothing() {
    // A master probes a worker that has not answered (it was serving another session) with its
    // Hello again; the worker reads them all at once. The master proves the secret over the
    // first answer: a fresh nonce for each Hello made that proof fail, and a Hello after the
    // proof reopened the handshake, so the job was refused.
    let f = room();
    let first: [u8; 32] = [1; 32];
    let proof = auth::prove(SECRET, Role::Master, &MASTER_NONCE, &first);
    let mut script = Script::default();
    script
        .hello()
        .hello()
        .send(MasterMessage::Auth { proof })
        .hello()
        .job(1, &f.blob)
        .line(1, 2)
        .send(MasterMessage::EndSession);
    let mut cache = SceneCache::with_scene(f.blob.digest, Arc::new(f.scene.clone()));
    // One run (`run` would run the script twice, and the nonces count on).
    let mut link = ScriptLink {
        input: script.bytes.clone(),
        pos: 0,
        piece: 61,
        output: Vec::new(),
    };
    let result = serve(&mut link, &guarded_counting_node(), &mut cache);
    let out = decode_output(&link.output);
    assert_eq!(result, Ok(SessionEnd::Ended));
    let hello = Out::Hello {
        version: PROTOCOL_VERSION,
        name: NAME.to_owned(),
        arch: ARCH.to_owned(),
        scene_memory: MEMORY,
        threads: 1,
        nonce: first,
        proof: Some(auth::prove(SECRET, Role::Worker, &MASTER_NONCE, &first)),
    };
    assert_eq!(
        out,
        vec![
            hello.clone(),
            hello.clone(),
            hello,
            Out::Ready { job: 1 },
            expected_line(&f, 1, 2)
        ]
    );
}

#[test]
fn a_rejected_worker_ends_the_session_with_the_reason() {
    let mut script = Script::default();
    script.hello().send(MasterMessage::Reject {
        reason: Rejection::NoProof,
    });
    let (result, out) = run(&script, &node(MEMORY), &mut SceneCache::new());
    assert_eq!(result, Err(WorkerError::Rejected(Rejection::NoProof)));
    assert_eq!(out, vec![worker_hello(MEMORY)]);
}

#[test]
fn version_mismatch_answers_hello_and_ends() {
    let f = room();
    let mut script = Script::default();
    script
        .send(MasterMessage::Hello(Hello {
            version: PROTOCOL_VERSION + 1,
            name: "future-master",
            arch: "x86_64",
            scene_memory: 0,
            threads: 0,
            nonce: MASTER_NONCE,
            proof: None,
        }))
        .job(1, &f.blob)
        .send(MasterMessage::Fence { seq: 1 });
    let mut cache = SceneCache::new();
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(
        result,
        Err(WorkerError::VersionMismatch {
            master: PROTOCOL_VERSION + 1
        })
    );
    assert_eq!(
        out,
        vec![worker_hello(MEMORY)],
        "only the worker's Hello, nothing for the later messages"
    );
}

#[test]
fn messages_before_hello_are_ignored() {
    let f = room();
    let mut before = Script::default();
    before
        .job(1, &f.blob)
        .chunks_from(&f.blob, 0)
        .line(1, 0)
        .send(MasterMessage::Fence { seq: 1 })
        .raw(&corrupt_frame())
        .send(MasterMessage::EndSession);
    let mut cache = SceneCache::new();
    let (result, out) = run(&before, &node(MEMORY), &mut cache);
    assert_eq!(out, vec![], "no answer to anything before Hello");
    assert_eq!(
        result,
        Ok(SessionEnd::Closed { unreadable: 1 }),
        "EndSession before Hello is ignored too"
    );
    assert!(
        cache.get(&f.blob.digest).is_none(),
        "chunks before Hello load nothing"
    );

    // After a Hello the session starts clean: no job, no dropped frames counted.
    before
        .hello()
        .line(1, 0)
        .raw(&corrupt_frame())
        .send(MasterMessage::Fence { seq: 2 });
    let (result, out) = run(&before, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 1 }));
    assert_eq!(
        out,
        vec![
            worker_hello(MEMORY),
            Out::Refused {
                job: 1,
                reason: Refusal::UnknownJob
            },
            Out::Dropped { total: 1 },
            Out::FenceAck { seq: 2 },
        ]
    );
}

#[test]
fn requests_that_cannot_be_served_are_refused() {
    let f = room();
    let mut script = Script::default();
    script
        .hello()
        // No job yet.
        .line(1, 0)
        .job(1, &f.blob)
        .chunk(&f.blob, 0)
        // The scene is still loading.
        .line(1, 0)
        .chunks_from(&f.blob, MAX_CHUNK_LEN as u32)
        .line(1, HEIGHT)
        .line(1, u32::MAX)
        .line(99, 0)
        .line(1, HEIGHT - 1);
    let mut cache = SceneCache::new();
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    let refused = |job, reason| Out::Refused { job, reason };
    let mut want = vec![
        worker_hello(MEMORY),
        refused(1, Refusal::UnknownJob),
        Out::NeedScene {
            job: 1,
            offset: 0,
            restart: true,
        },
        refused(1, Refusal::UnknownJob),
    ];
    want.extend(transfer_answers(&f.blob, 1, 0));
    want.extend([
        refused(1, Refusal::LineOutOfRange),
        refused(1, Refusal::LineOutOfRange),
        refused(99, Refusal::UnknownJob),
        // The job still works after refusals.
        expected_line(&f, 1, HEIGHT - 1),
    ]);
    assert_eq!(out, want);
}

#[test]
fn refine_requests_supersample_the_flagged_pixels() {
    // The room with adaptive 2×2 multisampling: `RenderLine` answers the centres, `RefineLine`
    // the flagged pixels' samples (the others black), exactly as `refine_line` computes them.
    let mut desc = room_desc();
    desc.settings.samples = 2;
    desc.settings.aa_threshold = Some(0.05);
    let f = fixture(desc);
    let w = WIDTH as usize;
    let mut mask = vec![0u8; mask_len(WIDTH)];
    mask[0] = 0b1000_0001;
    let last = mask.len() - 1;
    mask[last] = 0x80 >> (8 * mask.len() - w);
    let mut refined = vec![Pixel::default(); w];
    let refined_rays = refine_line(&f.scene, 3, &mask, &mut refined).expect("refines");
    assert_eq!(refined_rays.extra_samples, 3 * 4, "three flagged pixels");
    for (x, p) in refined.iter().enumerate() {
        if ![0, 7, w - 1].contains(&x) {
            assert_eq!(*p, Pixel::default(), "pixel {x} is not flagged: black");
        }
    }
    let mut script = Script::default();
    script
        .hello()
        .job(1, &f.blob)
        .chunks_from(&f.blob, 0)
        .line(1, 3)
        .send(MasterMessage::RefineLine {
            job: 1,
            line: 3,
            mask: &mask,
        })
        // A mask one byte short, and a line outside the image.
        .send(MasterMessage::RefineLine {
            job: 1,
            line: 3,
            mask: &mask[1..],
        })
        .send(MasterMessage::RefineLine {
            job: 1,
            line: HEIGHT,
            mask: &mask,
        });
    let mut cache = SceneCache::new();
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    let mut want = vec![
        worker_hello(MEMORY),
        Out::NeedScene {
            job: 1,
            offset: 0,
            restart: true,
        },
    ];
    want.extend(transfer_answers(&f.blob, 1, 0));
    want.extend([
        expected_line(&f, 1, 3),
        Out::Refined {
            job: 1,
            line: 3,
            rays: refined_rays,
            pixels: refined,
        },
        Out::Refused {
            job: 1,
            reason: Refusal::BadMask,
        },
        Out::Refused {
            job: 1,
            reason: Refusal::LineOutOfRange,
        },
    ]);
    assert_eq!(out, want);

    // A scene without adaptive multisampling has no second pass.
    let plain = room();
    let mut script = Script::default();
    script
        .hello()
        .job(2, &plain.blob)
        .chunks_from(&plain.blob, 0)
        .send(MasterMessage::RefineLine {
            job: 2,
            line: 0,
            mask: &mask,
        });
    let (_, out) = run(&script, &node(MEMORY), &mut SceneCache::new());
    assert_eq!(
        out.last(),
        Some(&Out::Refused {
            job: 2,
            reason: Refusal::BadMask,
        })
    );
}

#[test]
fn fence_is_answered_after_earlier_requests() {
    let f = room();
    let mut script = Script::default();
    script
        .hello()
        .job(7, &f.blob)
        .chunks_from(&f.blob, 0)
        .line(7, 0)
        .line(7, 1)
        .line(7, 2)
        .send(MasterMessage::Fence { seq: 42 })
        .line(7, 3)
        .line(8, 0)
        .send(MasterMessage::Fence { seq: 43 });
    let mut cache = SceneCache::new();
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    let after_load = out
        .iter()
        .position(|o| *o == Out::Ready { job: 7 })
        .expect("the scene loads");
    assert_eq!(
        out[after_load + 1..],
        [
            expected_line(&f, 7, 0),
            expected_line(&f, 7, 1),
            expected_line(&f, 7, 2),
            Out::FenceAck { seq: 42 },
            expected_line(&f, 7, 3),
            Out::Refused {
                job: 8,
                reason: Refusal::UnknownJob
            },
            Out::FenceAck { seq: 43 },
        ]
    );
}

#[test]
fn scene_larger_than_memory_is_refused() {
    let f = room();
    let mut cache = SceneCache::new();

    // Smaller than the encoding: refused at once, and so are its lines and a repeated Job.
    let tiny = u64::from(f.blob.len()) - 1;
    let mut script = Script::default();
    script
        .hello()
        .job(1, &f.blob)
        .chunks_from(&f.blob, 0)
        .line(1, 0)
        .job(1, &f.blob);
    let (result, out) = run(&script, &node(tiny), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    let refused = Out::Refused {
        job: 1,
        reason: Refusal::SceneTooLarge { limit: tiny },
    };
    assert_eq!(
        out,
        vec![
            worker_hello(tiny),
            refused.clone(),
            refused.clone(),
            refused
        ]
    );
    assert!(cache.get(&f.blob.digest).is_none());

    // Room for the encoding but not for the prepared scene: refused once it has arrived.
    let estimate = memory_estimate(f.blob.len(), Some(&f.desc));
    assert!(estimate > u64::from(f.blob.len()));
    let limit = estimate - 1;
    let mut script = Script::default();
    script
        .hello()
        .job(2, &f.blob)
        .chunks_from(&f.blob, 0)
        .line(2, 0);
    let (result, out) = run(&script, &node(limit), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    let refused = Out::Refused {
        job: 2,
        reason: Refusal::SceneTooLarge { limit },
    };
    let mut want = vec![
        worker_hello(limit),
        Out::NeedScene {
            job: 2,
            offset: 0,
            restart: true,
        },
    ];
    let mut answers = transfer_answers(&f.blob, 2, 0);
    assert_eq!(answers.pop(), Some(Out::Ready { job: 2 }));
    want.extend(answers);
    want.extend([refused.clone(), refused]);
    assert_eq!(out, want);
    assert!(cache.get(&f.blob.digest).is_none());

    // Exactly the estimate is enough; it leaves the lights' buffers nothing (the same pixels
    // as with them, more work for the shadow rays).
    let (result, out) = run(&script, &node(estimate), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    let bare = Scene::build_within(&f.desc, &OctreeParams::default(), 0).expect("it builds");
    assert!(bare.light_buffers.iter().all(Option::is_none));
    assert!(f.scene.light_buffers.iter().any(Option::is_some));
    let full = expected_line(&f, 2, 0);
    let want = expected_line(&Fixture { scene: bare, ..f }, 2, 0);
    assert_eq!(out.last(), Some(&want));
    let (
        Out::Line { pixels, rays, .. },
        Out::Line {
            pixels: full_pixels,
            rays: full_rays,
            ..
        },
    ) = (&want, &full)
    else {
        unreachable!("expected_line makes lines")
    };
    assert_eq!(pixels, full_pixels);
    assert!(rays.work.octree_cells > full_rays.work.octree_cells);
}

#[test]
fn corrupt_frames_after_hello_are_reported() {
    let mut script = Script::default();
    script
        .hello()
        .raw(&corrupt_frame())
        .send(MasterMessage::Fence { seq: 1 })
        // Garbage between frames.
        .raw(&[0x13, 0x37, 0xFF])
        .send(MasterMessage::Fence { seq: 2 })
        // An intact frame that breaks a limit (scene_len 0) counts as dropped too.
        .send(MasterMessage::Job {
            job: 1,
            digest: [0; 32],
            scene_len: 0,
        })
        .send(MasterMessage::Fence { seq: 3 })
        // A new Hello starts counting afresh.
        .hello_with([0x44; 32])
        .raw(&corrupt_frame());
    let mut cache = SceneCache::new();
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 1 }));
    assert_eq!(
        out,
        vec![
            worker_hello(MEMORY),
            Out::Dropped { total: 1 },
            Out::FenceAck { seq: 1 },
            Out::Dropped { total: 2 },
            Out::FenceAck { seq: 2 },
            Out::Dropped { total: 3 },
            Out::FenceAck { seq: 3 },
            worker_hello(MEMORY),
            Out::Dropped { total: 1 },
        ]
    );
}

#[test]
fn frame_too_long_for_the_worker_is_dropped() {
    // A wide line result is no master message and does not fit the worker's buffer.
    let pixels = vec![1u8; 2000 * PIXEL_WIRE_BYTES];
    let long = FrameWriter::new()
        .encode(&WorkerMessage::LineResult {
            job: 0,
            line: 0,
            refined: false,
            rays: RayCounts::default(),
            pixels: &pixels,
        })
        .expect("encodes")
        .to_vec();
    let mut script = Script::default();
    script
        .hello()
        .raw(&long)
        .send(MasterMessage::Fence { seq: 5 });
    let mut cache = SceneCache::new();
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 1 }));
    assert_eq!(
        out,
        vec![
            worker_hello(MEMORY),
            Out::Dropped { total: 1 },
            Out::FenceAck { seq: 5 }
        ]
    );
}

#[test]
fn lost_chunk_is_asked_for_once_and_resending_completes() {
    let f = room();
    let step = MAX_CHUNK_LEN as u32;
    let mut script = Script::default();
    script
        .hello()
        .job(1, &f.blob)
        .chunk(&f.blob, 0)
        // The chunk at 1024 is lost; the next three arrive.
        .chunk(&f.blob, 2 * step)
        .chunk(&f.blob, 3 * step)
        .chunk(&f.blob, 4 * step)
        // The master resends from the byte asked for.
        .chunks_from(&f.blob, step)
        .line(1, 2);
    let mut cache = SceneCache::new();
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    let mut want = vec![
        worker_hello(MEMORY),
        Out::NeedScene {
            job: 1,
            offset: 0,
            restart: true,
        },
        Out::NeedScene {
            job: 1,
            offset: step,
            restart: true,
        },
    ];
    want.extend(transfer_answers(&f.blob, 1, step));
    want.push(expected_line(&f, 1, 2));
    assert_eq!(out, want);
    assert!(cache.get(&f.blob.digest).is_some());
}

#[test]
fn job_announced_again_is_answered_where_it_stands() {
    let f = room();
    let step = MAX_CHUNK_LEN as u32;
    let mut script = Script::default();
    script
        .hello()
        .job(1, &f.blob)
        .chunk(&f.blob, 0)
        .chunk(&f.blob, step)
        .job(1, &f.blob)
        .chunks_from(&f.blob, 2 * step)
        .job(1, &f.blob);
    let mut cache = SceneCache::new();
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    let mut want = vec![
        worker_hello(MEMORY),
        Out::NeedScene {
            job: 1,
            offset: 0,
            restart: true,
        },
        Out::NeedScene {
            job: 1,
            offset: 2 * step,
            restart: true,
        },
    ];
    want.extend(transfer_answers(&f.blob, 1, 2 * step));
    want.push(Out::Ready { job: 1 });
    assert_eq!(out, want);
}

#[test]
fn corrupt_or_bad_scenes_are_refused() {
    let f = room();
    // One byte damaged on the way: the digest does not match.
    let mut damaged = f.blob.clone();
    damaged.bytes[MAX_CHUNK_LEN + 17] ^= 0x01;
    let mut script = Script::default();
    script
        .hello()
        .job(1, &f.blob)
        .send(MasterMessage::SceneChunk {
            digest: f.blob.digest,
            offset: 0,
            bytes: damaged.chunk_at(0),
        })
        .send(MasterMessage::SceneChunk {
            digest: f.blob.digest,
            offset: MAX_CHUNK_LEN as u32,
            bytes: damaged.chunk_at(MAX_CHUNK_LEN as u32),
        })
        .chunks_from(&f.blob, 2 * MAX_CHUNK_LEN as u32)
        .line(1, 0);
    let mut cache = SceneCache::new();
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    let refused = Out::Refused {
        job: 1,
        reason: Refusal::CorruptScene,
    };
    assert_eq!(out[out.len() - 2..], [refused.clone(), refused]);
    assert!(!out.contains(&Out::Ready { job: 1 }));
    assert!(cache.get(&f.blob.digest).is_none());

    // A scene that arrives intact but cannot be rendered (no light).
    let mut dark = room_desc();
    dark.lights.clear();
    let params = OctreeParams::default();
    let blob = SceneBlob::encode(&dark, &params).expect("encodes");
    let mut script = Script::default();
    script
        .hello()
        .job(2, &blob)
        .chunks_from(&blob, 0)
        .line(2, 0);
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    let refused = Out::Refused {
        job: 2,
        reason: Refusal::BadScene(SceneError::NoLight),
    };
    assert_eq!(out[out.len() - 2..], [refused.clone(), refused]);
}

#[test]
fn hello_mid_session_restarts_it_keeping_the_cache() {
    let f = room();
    let mut script = Script::default();
    script
        .hello()
        .job(1, &f.blob)
        .chunks_from(&f.blob, 0)
        .hello_with([0x44; 32])
        .line(1, 0)
        .job(1, &f.blob)
        .line(1, 0);
    let mut cache = SceneCache::new();
    let (result, out) = run(&script, &node(MEMORY), &mut cache);
    assert_eq!(result, Ok(SessionEnd::Closed { unreadable: 0 }));
    let after_load = out
        .iter()
        .position(|o| *o == Out::Ready { job: 1 })
        .expect("the scene loads");
    assert_eq!(
        out[after_load + 1..],
        [
            worker_hello(MEMORY),
            Out::Refused {
                job: 1,
                reason: Refusal::UnknownJob
            },
            Out::Ready { job: 1 },
            expected_line(&f, 1, 0),
        ]
    );
}
