//! The wire protocol below the worker loop: frames, messages and scene transfer.
//!
//! Checks that the largest legal messages fit the protocol's frame limits and the buffers sized
//! from them; that every message variant survives `FrameWriter` -> bytes -> `FrameReader` ->
//! `decode`; that bit flips, truncation, garbage, over-long frames and time-outs never produce a
//! wrong message, are reported as dropped where they cost a frame, and never lose the next good
//! frame; that `decode` enforces every size limit; the fixed-point pixel encoding; and that a
//! real scene survives chunking and reassembly while gaps, stale chunks and damaged bytes are
//! caught.

use embedded_io::{ErrorKind, ErrorType, Read, Write};
use glam::Vec3;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::accel::work::QueryWork;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;
use strahl_core::scene::camera::{Camera, SeedCamera};
use strahl_core::scene::error::SceneError;
use strahl_core::scene::{Blend, SceneDesc};
use strahl_core::wire::error::ProtocolError;
use strahl_core::wire::frame::{
    encode_into, DroppedFrame, FrameReader, FrameWriter, LinkError, ReadEvent,
};
use strahl_core::wire::message::{
    decode_pixels, encode_pixels, Hello, MasterMessage, Refusal, Rejection, WorkerMessage,
};
use strahl_core::wire::scene_blob::{
    decode_bundle, digest, ChunkOutcome, SceneAssembler, SceneBlob,
};
use strahl_core::wire::{
    frame_len, MAX_CHUNK_LEN, MAX_FRAME_LEN, MAX_LINES_PER_REQUEST, MAX_MASK_LEN,
    MAX_MASTER_FRAME_LEN, MAX_MASTER_PAYLOAD_LEN, MAX_NAME_LEN, MAX_PANIC_LEN, MAX_PAYLOAD_LEN,
    MAX_SCENE_LEN, MAX_WIDTH, PIXEL_WIRE_BYTES, PROTOCOL_VERSION,
};

// ---------------------------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------------------------

/// A link that hands out its bytes in pieces of the given sizes (cycled), optionally with a
/// `TimedOut` error before every piece after the first, then reports end of stream.
struct PieceLink {
    bytes: Vec<u8>,
    pos: usize,
    pieces: Vec<usize>,
    piece: usize,
    time_out_between: bool,
    timed_out_last: bool,
    /// `Err(Interrupted)` before every piece (the reader must retry it silently).
    interrupt_between: bool,
    interrupted_last: bool,
    time_outs: usize,
}

impl PieceLink {
    fn new(bytes: Vec<u8>, pieces: Vec<usize>) -> Self {
        assert!(pieces.iter().all(|&p| p > 0), "pieces must not be empty");
        PieceLink {
            bytes,
            pos: 0,
            pieces,
            piece: 0,
            time_out_between: false,
            timed_out_last: true,
            interrupt_between: false,
            interrupted_last: false,
            time_outs: 0,
        }
    }

    /// The whole stream in one read (as far as the reader's buffer allows).
    fn whole(bytes: Vec<u8>) -> Self {
        let n = bytes.len().max(1);
        PieceLink::new(bytes, vec![n])
    }
}

impl ErrorType for PieceLink {
    type Error = ErrorKind;
}

impl Read for PieceLink {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, ErrorKind> {
        if self.pos == self.bytes.len() {
            return Ok(0);
        }
        if self.interrupt_between && !self.interrupted_last {
            self.interrupted_last = true;
            return Err(ErrorKind::Interrupted);
        }
        if self.time_out_between && !self.timed_out_last {
            self.timed_out_last = true;
            self.time_outs += 1;
            return Err(ErrorKind::TimedOut);
        }
        self.timed_out_last = false;
        self.interrupted_last = false;
        let piece = self.pieces[self.piece % self.pieces.len()];
        self.piece += 1;
        let n = piece.min(buf.len()).min(self.bytes.len() - self.pos);
        buf[..n].copy_from_slice(&self.bytes[self.pos..self.pos + n]);
        self.pos += n;
        Ok(n)
    }
}

/// A link end that takes at most 3 bytes per write and remembers flushes.
#[derive(Default)]
struct Sink {
    bytes: Vec<u8>,
    flushes: usize,
}

impl ErrorType for Sink {
    type Error = ErrorKind;
}

impl Write for Sink {
    fn write(&mut self, buf: &[u8]) -> Result<usize, ErrorKind> {
        let n = buf.len().min(3);
        self.bytes.extend_from_slice(&buf[..n]);
        Ok(n)
    }

    fn flush(&mut self) -> Result<(), ErrorKind> {
        self.flushes += 1;
        Ok(())
    }
}

/// What a reader produced, owned.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Event {
    Frame(Vec<u8>),
    Dropped(DroppedFrame),
}

/// Reads every event until the link closes; time-outs are retried. Fails the test on any other
/// link error or if the reader does not terminate.
fn read_all<R: Read>(link: &mut R, buf_len: usize) -> Vec<Event> {
    let mut buf = vec![0u8; buf_len];
    let mut reader = FrameReader::new(&mut buf[..]);
    let mut events = Vec::new();
    for _ in 0..1_000_000 {
        match reader.next(link) {
            Ok(ReadEvent::Frame(p)) => events.push(Event::Frame(p.to_vec())),
            Ok(ReadEvent::Dropped(why)) => events.push(Event::Dropped(why)),
            Err(LinkError::TimedOut) => {}
            Err(LinkError::Closed) => return events,
            Err(e) => panic!("unexpected link error {e:?}"),
        }
    }
    panic!("the reader did not reach the end of the stream");
}

fn frames_of(events: &[Event]) -> Vec<&[u8]> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Frame(p) => Some(p.as_slice()),
            Event::Dropped(_) => None,
        })
        .collect()
}

fn dropped_of(events: &[Event]) -> Vec<DroppedFrame> {
    events
        .iter()
        .filter_map(|e| match e {
            Event::Dropped(d) => Some(*d),
            Event::Frame(_) => None,
        })
        .collect()
}

/// A message of either direction, encoded into a frame with a fresh `FrameWriter`.
trait Wire {
    /// The frame bytes, delimiters included.
    fn frame(&self) -> Vec<u8>;
}

impl Wire for MasterMessage<'_> {
    fn frame(&self) -> Vec<u8> {
        FrameWriter::new()
            .encode(self)
            .expect("a master message encodes")
            .to_vec()
    }
}

impl Wire for WorkerMessage<'_> {
    fn frame(&self) -> Vec<u8> {
        FrameWriter::new()
            .encode(self)
            .expect("a worker message encodes")
            .to_vec()
    }
}

/// The frame bytes (delimiters included) of `msg`.
fn frame_of<T: Wire>(msg: &T) -> Vec<u8> {
    msg.frame()
}

/// The payload (postcard bytes) of `msg`, as a reader hands it out.
fn payload_of<T: Wire>(msg: &T) -> Vec<u8> {
    let frame = frame_of(msg);
    let events = read_all(&mut PieceLink::whole(frame), MAX_FRAME_LEN + 16);
    assert_eq!(events.len(), 1, "one frame in, one event out: {events:?}");
    match &events[0] {
        Event::Frame(p) => p.clone(),
        Event::Dropped(d) => panic!("an intact frame was dropped: {d:?}"),
    }
}

/// A small deterministic generator (SplitMix64) for garbage and piece sizes.
struct SplitMix(u64);

impl SplitMix {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next_u64() % n
    }

    fn byte(&mut self) -> u8 {
        self.next_u64().to_le_bytes()[0]
    }
}

const NAME: &str = "worker-node-7";
const ARCH: &str = "x86_64";

fn long_name(c: char, len: usize) -> String {
    std::iter::repeat_n(c, len).collect()
}

/// Every master message variant (and a few field extremes).
fn master_samples<'a>(names: &'a str, chunk: &'a [u8]) -> Vec<MasterMessage<'a>> {
    vec![
        MasterMessage::Hello(Hello {
            version: PROTOCOL_VERSION,
            name: names,
            arch: ARCH,
            scene_memory: 0,
            threads: 0,
            nonce: [0x5A; 32],
            proof: None,
        }),
        MasterMessage::Job {
            job: 3,
            digest: [0xA5; 32],
            scene_len: 12_345,
        },
        MasterMessage::Job {
            job: u32::MAX,
            digest: [0; 32],
            scene_len: MAX_SCENE_LEN,
        },
        MasterMessage::SceneChunk {
            digest: [7; 32],
            offset: 1024,
            bytes: chunk,
        },
        MasterMessage::RenderLine { job: 3, line: 17 },
        MasterMessage::RenderLine {
            job: 0,
            line: u32::MAX,
        },
        MasterMessage::Fence { seq: 0xDEAD_BEEF },
        MasterMessage::EndSession,
        MasterMessage::RefineLine {
            job: 3,
            line: 17,
            mask: &[0b1010_0001, 0x7F],
        },
        MasterMessage::RenderLines {
            job: 3,
            first: 17,
            count: MAX_LINES_PER_REQUEST,
        },
        MasterMessage::Auth { proof: [0xC3; 32] },
        MasterMessage::Reject {
            reason: Rejection::WrongProof,
        },
    ]
}

/// Every worker message variant, every refusal among them.
fn worker_samples<'a>(pixels: &'a [u8]) -> Vec<WorkerMessage<'a>> {
    let mut v = vec![
        WorkerMessage::Hello(Hello {
            version: PROTOCOL_VERSION,
            name: NAME,
            arch: ARCH,
            scene_memory: 1 << 40,
            threads: 16,
            nonce: [0x5A; 32],
            proof: Some([0xA5; 32]),
        }),
        WorkerMessage::NeedScene {
            job: 3,
            offset: 4096,
            restart: true,
        },
        WorkerMessage::NeedScene {
            job: u32::MAX,
            offset: MAX_SCENE_LEN,
            restart: false,
        },
        WorkerMessage::Ready { job: 3 },
        WorkerMessage::LineResult {
            job: 3,
            line: 9,
            refined: false,
            rays: RayCounts {
                primary: 16,
                shadow: 40,
                reflection: 3,
                ..RayCounts::default()
            },
            pixels,
        },
        WorkerMessage::FenceAck { seq: 77 },
        WorkerMessage::Dropped { total: 2 },
        WorkerMessage::Panicked {
            message: "panicked at src/main.rs:3:5: memory allocation of 1441792 bytes failed",
        },
    ];
    let refusals = [
        Refusal::SceneTooLarge { limit: 1 << 20 },
        Refusal::BadScene(SceneError::NoLight),
        Refusal::BadScene(SceneError::PointIndexOutOfRange { triangle: 5 }),
        Refusal::CorruptScene,
        Refusal::UnknownJob,
        Refusal::LineOutOfRange,
        Refusal::BadMask,
        Refusal::Unauthenticated,
    ];
    v.extend(
        refusals
            .iter()
            .map(|&reason| WorkerMessage::Refused { job: 3, reason }),
    );
    v
}

/// The variant's position; the exhaustive match makes a new variant a compile error here.
fn master_variant(m: &MasterMessage<'_>) -> usize {
    match m {
        MasterMessage::Hello(_) => 0,
        MasterMessage::Job { .. } => 1,
        MasterMessage::SceneChunk { .. } => 2,
        MasterMessage::RenderLine { .. } => 3,
        MasterMessage::Fence { .. } => 4,
        MasterMessage::EndSession => 5,
        MasterMessage::RefineLine { .. } => 6,
        MasterMessage::RenderLines { .. } => 7,
        MasterMessage::Auth { .. } => 8,
        MasterMessage::Reject { .. } => 9,
    }
}

fn worker_variant(m: &WorkerMessage<'_>) -> usize {
    match m {
        WorkerMessage::Hello(_) => 0,
        WorkerMessage::NeedScene { .. } => 1,
        WorkerMessage::Ready { .. } => 2,
        WorkerMessage::LineResult { .. } => 3,
        WorkerMessage::FenceAck { .. } => 4,
        WorkerMessage::Dropped { .. } => 5,
        WorkerMessage::Refused { .. } => 6,
        WorkerMessage::Panicked { .. } => 7,
    }
}

/// A small real scene: the demo room seen by the seed's example camera.
fn small_room() -> SceneDesc {
    let mut desc = strahl_host::generate::room();
    desc.camera = Camera::Seed(SeedCamera {
        position: Vec3::new(0.0, -100.0, 25.0),
        angle_x_deg: -15.0,
        angle_z_deg: 0.0,
        zoom: 1.5,
    });
    desc.settings.width = 24;
    desc.settings.height = 16;
    desc
}

// ---------------------------------------------------------------------------------------------
// Limits: the largest legal messages fit
// ---------------------------------------------------------------------------------------------

#[test]
fn largest_line_result_fits_max_frame_len() {
    // 0xFF pixel bytes contain no zero, so COBS needs its worst-case overhead.
    let pixels = vec![0xFFu8; MAX_WIDTH as usize * PIXEL_WIRE_BYTES];
    let msg = WorkerMessage::LineResult {
        job: u32::MAX,
        line: u32::MAX,
        refined: false,
        rays: RayCounts {
            primary: u64::MAX,
            extra_samples: u64::MAX,
            shadow: u64::MAX,
            reflection: u64::MAX,
            refraction: u64::MAX,
            occlusion: u64::MAX,
            work: QueryWork {
                intersection_tests: u64::MAX,
                octree_cells: u64::MAX,
            },
        },
        pixels: &pixels,
    };
    let frame = frame_of(&msg);
    assert!(
        frame.len() <= MAX_FRAME_LEN,
        "largest line result is {} bytes on the wire, MAX_FRAME_LEN is {MAX_FRAME_LEN}",
        frame.len()
    );
    // A master-side reader with a buffer of exactly MAX_FRAME_LEN reads it back.
    let events = read_all(&mut PieceLink::whole(frame.clone()), MAX_FRAME_LEN);
    assert_eq!(events.len(), 1, "{:?}", dropped_of(&events));
    let payload = frames_of(&events)[0];
    assert!(
        payload.len() <= MAX_PAYLOAD_LEN,
        "payload {} > MAX_PAYLOAD_LEN {MAX_PAYLOAD_LEN}",
        payload.len()
    );
    assert_eq!(
        WorkerMessage::decode(payload).expect("largest line result decodes"),
        msg
    );
}

#[test]
fn largest_master_messages_fit_a_worker_buffer() {
    let chunk = vec![0xFFu8; MAX_CHUNK_LEN];
    let mask = vec![0xFFu8; MAX_MASK_LEN];
    let name = long_name('n', MAX_NAME_LEN);
    let arch = long_name('a', MAX_NAME_LEN);
    let msgs = [
        // The last legal offset for a full chunk.
        MasterMessage::SceneChunk {
            digest: [0xFF; 32],
            offset: MAX_SCENE_LEN - MAX_CHUNK_LEN as u32,
            bytes: &chunk,
        },
        MasterMessage::Hello(Hello {
            version: u32::MAX,
            name: &name,
            arch: &arch,
            scene_memory: u64::MAX,
            threads: u32::MAX,
            nonce: [0x5A; 32],
            proof: Some([0xA5; 32]),
        }),
        MasterMessage::Job {
            job: u32::MAX,
            digest: [0xFF; 32],
            scene_len: MAX_SCENE_LEN,
        },
        MasterMessage::RenderLine {
            job: u32::MAX,
            line: u32::MAX,
        },
        MasterMessage::RefineLine {
            job: u32::MAX,
            line: u32::MAX,
            mask: &mask,
        },
        MasterMessage::RenderLines {
            job: u32::MAX,
            first: u32::MAX,
            count: MAX_LINES_PER_REQUEST,
        },
        MasterMessage::Fence { seq: u32::MAX },
        MasterMessage::Auth { proof: [0xFF; 32] },
    ];
    let mut stream = Vec::new();
    for m in &msgs {
        let f = frame_of(m);
        assert!(
            f.len() <= MAX_MASTER_FRAME_LEN,
            "{m:?} is {} bytes on the wire, MAX_MASTER_FRAME_LEN is {MAX_MASTER_FRAME_LEN}",
            f.len()
        );
        assert!(f.len() <= frame_len(MAX_MASTER_PAYLOAD_LEN));
        stream.extend_from_slice(&f);
    }
    // A worker-side reader with a buffer of exactly MAX_MASTER_FRAME_LEN, fed in one go and in
    // small pieces, reads them all back.
    for pieces in [vec![stream.len()], vec![1], vec![7, 300, 1]] {
        let events = read_all(
            &mut PieceLink::new(stream.clone(), pieces.clone()),
            MAX_MASTER_FRAME_LEN,
        );
        let frames = frames_of(&events);
        assert_eq!(
            frames.len(),
            msgs.len(),
            "pieces {pieces:?}: dropped {:?}",
            dropped_of(&events)
        );
        for (payload, m) in frames.iter().zip(&msgs) {
            assert!(payload.len() <= MAX_MASTER_PAYLOAD_LEN);
            assert_eq!(&MasterMessage::decode(payload).expect("decodes"), m);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Round trips
// ---------------------------------------------------------------------------------------------

#[test]
fn a_panic_message_is_framed_without_the_heap_and_bounded() {
    let text = "é".repeat(MAX_PANIC_LEN / 2);
    let msg = WorkerMessage::Panicked { message: &text };
    let mut payload = [0u8; MAX_PANIC_LEN + 16];
    let mut frame = [0u8; frame_len(MAX_PANIC_LEN + 16)];
    let framed = encode_into(&msg, &mut payload, &mut frame).expect("fits");
    let mut writer = FrameWriter::new();
    assert_eq!(
        framed,
        writer.encode(&msg).expect("encodes"),
        "the same frame either way"
    );
    let events = read_all(&mut PieceLink::new(framed.to_vec(), vec![7]), MAX_FRAME_LEN);
    let frames = frames_of(&events);
    assert_eq!(WorkerMessage::decode(frames[0]), Ok(msg));
    // One byte over the limit does not decode; a buffer too small does not encode.
    let long = "x".repeat(MAX_PANIC_LEN + 1);
    let framed = writer
        .encode(&WorkerMessage::Panicked { message: &long })
        .expect("encodes")
        .to_vec();
    let events = read_all(&mut PieceLink::new(framed, vec![9]), MAX_FRAME_LEN);
    assert_eq!(
        WorkerMessage::decode(frames_of(&events)[0]),
        Err(ProtocolError::Decode)
    );
    let mut small = [0u8; 32];
    assert_eq!(
        encode_into(&msg, &mut small, &mut frame),
        Err(ProtocolError::Encode)
    );
}

#[test]
fn every_message_variant_round_trips() {
    let chunk: Vec<u8> = (0..=255u8).cycle().take(700).collect();
    let pixels: Vec<u8> = (0..=255u8).cycle().take(24 * PIXEL_WIRE_BYTES).collect();
    let masters = master_samples(NAME, &chunk);
    let workers = worker_samples(&pixels);

    let mut writer = FrameWriter::new();
    let mut master_stream = Vec::new();
    for m in &masters {
        master_stream.extend_from_slice(writer.encode(m).expect("encodes"));
    }
    let mut worker_stream = Vec::new();
    for m in &workers {
        worker_stream.extend_from_slice(writer.encode(m).expect("encodes"));
    }

    let events = read_all(
        &mut PieceLink::new(master_stream, vec![3, 1, 50]),
        MAX_MASTER_FRAME_LEN,
    );
    let frames = frames_of(&events);
    assert_eq!(frames.len(), masters.len(), "{events:?}");
    let mut seen = [false; 10];
    for (payload, m) in frames.iter().zip(&masters) {
        let got = MasterMessage::decode(payload).expect("master message decodes");
        assert_eq!(&got, m);
        seen[master_variant(&got)] = true;
    }
    assert!(seen.iter().all(|&s| s), "every master variant is covered");

    let events = read_all(
        &mut PieceLink::new(worker_stream, vec![5, 2, 99]),
        MAX_FRAME_LEN,
    );
    let frames = frames_of(&events);
    assert_eq!(frames.len(), workers.len(), "{events:?}");
    let mut seen = [false; 8];
    for (payload, m) in frames.iter().zip(&workers) {
        let got = WorkerMessage::decode(payload).expect("worker message decodes");
        assert_eq!(&got, m);
        seen[worker_variant(&got)] = true;
    }
    assert!(seen.iter().all(|&s| s), "every worker variant is covered");
}

#[test]
fn frame_writer_send_writes_the_encoded_frame() {
    let msg = MasterMessage::Fence { seq: 5 };
    let mut sink = Sink::default();
    FrameWriter::new()
        .send(&mut sink, &msg)
        .expect("the sink takes everything");
    assert_eq!(sink.flushes, 1, "send flushes once");
    let out = sink.bytes;
    assert_eq!(out, frame_of(&msg));
    assert_eq!(out.first(), Some(&0), "a frame starts with a delimiter");
    assert_eq!(out.last(), Some(&0), "a frame ends with a delimiter");
    assert!(
        !out[1..out.len() - 1].contains(&0),
        "COBS leaves no zero inside the frame"
    );
}

// ---------------------------------------------------------------------------------------------
// Damage: bit flips, truncation, garbage, over-long frames, time-outs
// ---------------------------------------------------------------------------------------------

#[test]
fn every_single_bit_flip_is_detected_and_the_next_frame_survives() {
    let chunk: Vec<u8> = (1..=200u8).collect();
    let pixels: Vec<u8> = (0..60u8).collect();
    let damaged_msgs: Vec<Vec<u8>> = vec![
        frame_of(&MasterMessage::Fence { seq: 0x0102_0304 }),
        frame_of(&MasterMessage::Job {
            job: 9,
            digest: [0; 32],
            scene_len: 4000,
        }),
        frame_of(&MasterMessage::SceneChunk {
            digest: [0x11; 32],
            offset: 2048,
            bytes: &chunk,
        }),
        frame_of(&WorkerMessage::LineResult {
            job: 1,
            line: 2,
            refined: false,
            rays: RayCounts {
                primary: 10,
                shadow: 0,
                reflection: 300,
                ..RayCounts::default()
            },
            pixels: &pixels,
        }),
    ];
    let good = MasterMessage::RenderLine { job: 9, line: 3 };
    let good_frame = frame_of(&good);
    let good_payload = payload_of(&good);

    let mut flips = 0usize;
    let mut detected = 0usize;
    for frame in &damaged_msgs {
        let original_payload = {
            let events = read_all(&mut PieceLink::whole(frame.clone()), MAX_FRAME_LEN);
            frames_of(&events)[0].to_vec()
        };
        for bit in 0..frame.len() * 8 {
            let mut damaged = frame.clone();
            damaged[bit / 8] ^= 1 << (bit % 8);
            let mut stream = damaged;
            stream.extend_from_slice(&good_frame);
            flips += 1;
            let events = read_all(&mut PieceLink::whole(stream), MAX_FRAME_LEN);
            let frames = frames_of(&events);
            // No frame but the intact one gets through: a flip never yields another message,
            // nor the damaged message itself.
            for f in &frames {
                assert_eq!(
                    *f,
                    good_payload.as_slice(),
                    "bit {bit} of {frame:02x?}: a damaged frame was accepted"
                );
                assert_ne!(*f, original_payload.as_slice());
            }
            assert_eq!(
                frames.len(),
                1,
                "bit {bit} of {frame:02x?}: the next intact frame must be read exactly once"
            );
            assert_eq!(
                events.last(),
                Some(&Event::Frame(good_payload.clone())),
                "bit {bit}: the intact frame comes last"
            );
            if dropped_of(&events)
                .iter()
                .all(|d| *d == DroppedFrame::Corrupt)
                && !dropped_of(&events).is_empty()
            {
                detected += 1;
            }
        }
    }
    assert_eq!(
        detected, flips,
        "every bit flip is reported as a dropped frame"
    );
    assert!(flips > 1000, "the test flipped {flips} bits");
}

#[test]
fn truncated_frames_cost_only_themselves() {
    let chunk: Vec<u8> = (0..300u32).map(|i| (i % 251) as u8).collect();
    let cut_msg = MasterMessage::SceneChunk {
        digest: [3; 32],
        offset: 0,
        bytes: &chunk,
    };
    let cut_frame = frame_of(&cut_msg);
    let good = MasterMessage::Job {
        job: 1,
        digest: [3; 32],
        scene_len: 300,
    };
    let good_frame = frame_of(&good);
    for cut in 1..cut_frame.len() {
        let mut stream = cut_frame[..cut].to_vec();
        stream.extend_from_slice(&good_frame);
        for pieces in [vec![stream.len()], vec![1], vec![13, 2]] {
            let events = read_all(&mut PieceLink::new(stream.clone(), pieces), 512);
            let decoded: Vec<MasterMessage<'_>> = frames_of(&events)
                .iter()
                .map(|p| MasterMessage::decode(p).expect("only intact frames get through"))
                .collect();
            if cut == cut_frame.len() - 1 {
                // Only the trailing delimiter is missing: the next frame's leading delimiter
                // ends the frame, and nothing is lost.
                assert_eq!(decoded, vec![cut_msg, good], "cut at {cut}");
                assert_eq!(dropped_of(&events), vec![], "cut at {cut}");
                continue;
            }
            assert_eq!(decoded, vec![good], "cut at {cut}");
            // Only the leading delimiter left: nothing is lost. Anything more is one dropped
            // (corrupt) frame.
            let expected: Vec<DroppedFrame> = if cut == 1 {
                vec![]
            } else {
                vec![DroppedFrame::Corrupt]
            };
            assert_eq!(dropped_of(&events), expected, "cut at {cut}");
        }
    }
}

#[test]
fn garbage_between_frames_costs_no_frame() {
    let mut rng = SplitMix(0x5EED_1234);
    let buf_len = 256;
    let goods: Vec<MasterMessage<'static>> = (0..200)
        .map(|i| match i % 3 {
            0 => MasterMessage::RenderLine { job: 1, line: i },
            1 => MasterMessage::Fence { seq: i },
            _ => MasterMessage::Job {
                job: i,
                digest: [i as u8; 32],
                scene_len: i + 1,
            },
        })
        .collect();
    let mut stream = Vec::new();
    let mut garbage_segments = 0usize;
    for (i, m) in goods.iter().enumerate() {
        stream.extend_from_slice(&frame_of(m));
        // Garbage between frames only: an unterminated tail is cut off by the end of the stream.
        if i + 1 < goods.len() && rng.below(3) != 0 {
            // Short garbage with zeros in it, or now and then a run without zeros longer than
            // the reader's buffer.
            let garbage: Vec<u8> = if rng.below(10) == 0 {
                let len = rng.below(600) as usize + buf_len + 1;
                (0..len).map(|_| rng.byte() | 1).collect()
            } else {
                let len = rng.below(24) as usize + 1;
                (0..len)
                    .map(|_| if rng.below(8) == 0 { 0 } else { rng.byte() })
                    .collect()
            };
            garbage_segments += garbage.split(|&b| b == 0).filter(|s| !s.is_empty()).count();
            stream.extend_from_slice(&garbage);
        }
    }
    let pieces: Vec<usize> = (0..64).map(|_| rng.below(40) as usize + 1).collect();
    let events = read_all(&mut PieceLink::new(stream, pieces), buf_len);
    let decoded: Vec<MasterMessage<'_>> = frames_of(&events)
        .iter()
        .map(|p| MasterMessage::decode(p).expect("only good frames get through"))
        .collect();
    assert_eq!(decoded, goods, "every good frame comes through, in order");
    let dropped = dropped_of(&events);
    assert_eq!(
        dropped.len(),
        garbage_segments,
        "each garbage segment is one dropped frame"
    );
    assert!(dropped.contains(&DroppedFrame::Corrupt));
    assert!(
        dropped.contains(&DroppedFrame::TooLong),
        "some garbage was longer than the buffer"
    );
}

#[test]
fn frame_longer_than_the_buffer_is_dropped_as_too_long() {
    let chunk = vec![0x42u8; 200];
    let long = frame_of(&MasterMessage::SceneChunk {
        digest: [1; 32],
        offset: 0,
        bytes: &chunk,
    });
    let next = MasterMessage::Fence { seq: 11 };
    let mut stream = long.clone();
    stream.extend_from_slice(&frame_of(&next));
    for pieces in [vec![stream.len()], vec![1], vec![63, 64, 65]] {
        let events = read_all(&mut PieceLink::new(stream.clone(), pieces.clone()), 64);
        assert_eq!(
            events,
            vec![
                Event::Dropped(DroppedFrame::TooLong),
                Event::Frame(payload_of(&next))
            ],
            "pieces {pieces:?}"
        );
    }

    // A worker's buffer cannot hold a wide line result: dropped, and the next frame is read.
    let pixels = vec![1u8; 1000 * PIXEL_WIRE_BYTES];
    let wide = frame_of(&WorkerMessage::LineResult {
        job: 0,
        line: 0,
        refined: false,
        rays: RayCounts::default(),
        pixels: &pixels,
    });
    assert!(wide.len() > MAX_MASTER_FRAME_LEN);
    let mut stream = wide;
    stream.extend_from_slice(&frame_of(&next));
    let events = read_all(&mut PieceLink::whole(stream), MAX_MASTER_FRAME_LEN);
    assert_eq!(
        events,
        vec![
            Event::Dropped(DroppedFrame::TooLong),
            Event::Frame(payload_of(&next))
        ]
    );

    // A frame whose body exactly fills the buffer (no room for its delimiter) is too long; one
    // byte shorter fits.
    let body_len = long.len() - 2;
    let events = read_all(&mut PieceLink::whole(long.clone()), body_len);
    assert_eq!(events, vec![Event::Dropped(DroppedFrame::TooLong)]);
    let events = read_all(&mut PieceLink::whole(long), body_len + 1);
    assert_eq!(frames_of(&events).len(), 1, "{events:?}");
}

#[test]
fn time_out_in_the_middle_of_a_frame_keeps_the_partial_frame() {
    let chunk: Vec<u8> = (0..500u32).map(|i| (i * 7) as u8).collect();
    let msgs = [
        MasterMessage::SceneChunk {
            digest: [9; 32],
            offset: 512,
            bytes: &chunk,
        },
        MasterMessage::Fence { seq: 1 },
        MasterMessage::EndSession,
    ];
    let stream: Vec<u8> = msgs.iter().flat_map(frame_of).collect();
    let mut link = PieceLink::new(stream, vec![17, 1, 5]);
    link.time_out_between = true;
    let mut buf = [0u8; MAX_MASTER_FRAME_LEN];
    let mut reader = FrameReader::new(&mut buf[..]);
    let mut time_outs_seen = 0usize;
    let mut got = Vec::new();
    loop {
        match reader.next(&mut link) {
            Ok(ReadEvent::Frame(p)) => got.push(p.to_vec()),
            Ok(ReadEvent::Dropped(d)) => panic!("a time-out cost a frame: {d:?}"),
            Err(LinkError::TimedOut) => time_outs_seen += 1,
            Err(LinkError::Closed) => break,
            Err(e) => panic!("unexpected link error {e:?}"),
        }
    }
    assert!(
        time_outs_seen > 10,
        "the link timed out mid-frame many times"
    );
    assert_eq!(
        time_outs_seen, link.time_outs,
        "each time-out is reported to the caller"
    );
    let decoded: Vec<MasterMessage<'_>> = got
        .iter()
        .map(|p| MasterMessage::decode(p).expect("decodes"))
        .collect();
    assert_eq!(decoded, msgs);
}

#[test]
fn interrupted_reads_are_retried_silently() {
    let msgs = [
        MasterMessage::Fence { seq: 1 },
        MasterMessage::RenderLine { job: 2, line: 3 },
    ];
    let stream: Vec<u8> = msgs.iter().flat_map(frame_of).collect();
    let mut link = PieceLink::new(stream, vec![2]);
    link.interrupt_between = true;
    let mut buf = [0u8; 128];
    let mut reader = FrameReader::new(&mut buf[..]);
    for m in &msgs {
        match reader.next(&mut link) {
            Ok(ReadEvent::Frame(p)) => {
                assert_eq!(&MasterMessage::decode(p).expect("decodes"), m);
            }
            other => panic!("expected a frame, got {other:?}"),
        }
    }
    assert_eq!(
        reader.next(&mut link).map(|_| ()),
        Err(LinkError::Closed),
        "end of stream is reported as a closed link"
    );
}

#[test]
fn link_errors_are_classified() {
    assert_eq!(
        LinkError::from_kind(ErrorKind::TimedOut),
        LinkError::TimedOut
    );
    for kind in [
        ErrorKind::BrokenPipe,
        ErrorKind::ConnectionReset,
        ErrorKind::ConnectionAborted,
        ErrorKind::NotConnected,
    ] {
        assert_eq!(LinkError::from_kind(kind), LinkError::Closed, "{kind:?}");
    }
    assert_eq!(
        LinkError::from_kind(ErrorKind::InvalidData),
        LinkError::Io(ErrorKind::InvalidData)
    );
}

// ---------------------------------------------------------------------------------------------
// Decode validation
// ---------------------------------------------------------------------------------------------

#[test]
fn line_result_pixels_must_be_whole_and_bounded() {
    let line = |pixels: &[u8]| {
        payload_of(&WorkerMessage::LineResult {
            job: 1,
            line: 0,
            refined: false,
            rays: RayCounts::default(),
            pixels,
        })
    };
    for len in [0, 1, 5, 7, 13, PIXEL_WIRE_BYTES * 10 + 1] {
        let p = line(&vec![1u8; len]);
        assert_eq!(
            WorkerMessage::decode(&p),
            Err(ProtocolError::BadPixels),
            "{len} pixel bytes"
        );
    }
    let too_wide = line(&vec![1u8; (MAX_WIDTH as usize + 1) * PIXEL_WIRE_BYTES]);
    assert_eq!(
        WorkerMessage::decode(&too_wide),
        Err(ProtocolError::BadPixels)
    );
    for len in [PIXEL_WIRE_BYTES, 12, MAX_WIDTH as usize * PIXEL_WIRE_BYTES] {
        let p = line(&vec![1u8; len]);
        assert!(WorkerMessage::decode(&p).is_ok(), "{len} pixel bytes");
    }
}

#[test]
fn refine_masks_are_bounded() {
    let refine = |mask: &[u8]| {
        payload_of(&MasterMessage::RefineLine {
            job: 1,
            line: 0,
            mask,
        })
    };
    for len in [0, MAX_MASK_LEN + 1] {
        assert_eq!(
            MasterMessage::decode(&refine(&vec![1u8; len])),
            Err(ProtocolError::BadMask),
            "{len} mask bytes"
        );
    }
    for len in [1, 80, MAX_MASK_LEN] {
        let p = refine(&vec![1u8; len]);
        assert!(MasterMessage::decode(&p).is_ok(), "{len} mask bytes");
    }
}

#[test]
fn multi_line_requests_are_bounded() {
    let request = |count| {
        payload_of(&MasterMessage::RenderLines {
            job: 1,
            first: 5,
            count,
        })
    };
    for count in [0, MAX_LINES_PER_REQUEST + 1, u32::MAX] {
        assert_eq!(
            MasterMessage::decode(&request(count)),
            Err(ProtocolError::BadRequest),
            "{count} lines"
        );
    }
    for count in [1, 2, MAX_LINES_PER_REQUEST] {
        assert!(
            MasterMessage::decode(&request(count)).is_ok(),
            "{count} lines"
        );
    }
}

#[test]
fn hello_names_are_bounded() {
    let ok = long_name('x', MAX_NAME_LEN);
    let long = long_name('x', MAX_NAME_LEN + 1);
    fn hello<'a>(name: &'a str, arch: &'a str) -> Hello<'a> {
        Hello {
            version: PROTOCOL_VERSION,
            name,
            arch,
            scene_memory: 0,
            threads: 0,
            nonce: [0x5A; 32],
            proof: None,
        }
    }
    for (name, arch) in [(long.as_str(), ARCH), (NAME, long.as_str())] {
        let m = payload_of(&MasterMessage::Hello(hello(name, arch)));
        assert_eq!(MasterMessage::decode(&m), Err(ProtocolError::NameTooLong));
        let w = payload_of(&WorkerMessage::Hello(hello(name, arch)));
        assert_eq!(WorkerMessage::decode(&w), Err(ProtocolError::NameTooLong));
    }
    let m = payload_of(&MasterMessage::Hello(hello(&ok, &ok)));
    assert_eq!(
        MasterMessage::decode(&m),
        Ok(MasterMessage::Hello(hello(&ok, &ok)))
    );
    let w = payload_of(&WorkerMessage::Hello(hello(&ok, "")));
    assert_eq!(
        WorkerMessage::decode(&w),
        Ok(WorkerMessage::Hello(hello(&ok, "")))
    );
}

#[test]
fn scene_chunks_are_bounded() {
    let chunk = |offset: u32, len: usize| {
        payload_of(&MasterMessage::SceneChunk {
            digest: [2; 32],
            offset,
            bytes: &vec![9u8; len],
        })
    };
    for (offset, len) in [
        (0, 0),
        (5, 0),
        (0, MAX_CHUNK_LEN + 1),
        (0, 4 * MAX_CHUNK_LEN),
        (MAX_SCENE_LEN - MAX_CHUNK_LEN as u32 + 1, MAX_CHUNK_LEN),
        (MAX_SCENE_LEN, 1),
        (u32::MAX, 1),
    ] {
        assert_eq!(
            MasterMessage::decode(&chunk(offset, len)),
            Err(ProtocolError::BadChunk),
            "offset {offset}, {len} bytes"
        );
    }
    for (offset, len) in [
        (0, 1),
        (0, MAX_CHUNK_LEN),
        (MAX_SCENE_LEN - MAX_CHUNK_LEN as u32, MAX_CHUNK_LEN),
        (MAX_SCENE_LEN - 1, 1),
    ] {
        assert!(
            MasterMessage::decode(&chunk(offset, len)).is_ok(),
            "offset {offset}, {len} bytes"
        );
    }
}

#[test]
fn job_scene_len_is_bounded() {
    let job = |scene_len: u32| {
        payload_of(&MasterMessage::Job {
            job: 1,
            digest: [0; 32],
            scene_len,
        })
    };
    for len in [0, MAX_SCENE_LEN + 1, u32::MAX] {
        assert_eq!(
            MasterMessage::decode(&job(len)),
            Err(ProtocolError::SceneTooLarge),
            "scene_len {len}"
        );
    }
    for len in [1, MAX_SCENE_LEN] {
        assert!(MasterMessage::decode(&job(len)).is_ok(), "scene_len {len}");
    }
}

#[test]
fn bytes_that_are_no_message_do_not_decode() {
    // Unknown variant tags, and messages cut short.
    for payload in [&[0x40u8][..], &[6], &[0xFF, 0xFF, 0xFF, 0xFF, 0x0F], &[]] {
        assert_eq!(
            MasterMessage::decode(payload),
            Err(ProtocolError::Decode),
            "{payload:02x?}"
        );
    }
    for payload in [&[7u8][..], &[0x40], &[]] {
        assert_eq!(
            WorkerMessage::decode(payload),
            Err(ProtocolError::Decode),
            "{payload:02x?}"
        );
    }
    let job = payload_of(&MasterMessage::Job {
        job: 1,
        digest: [5; 32],
        scene_len: 100,
    });
    for cut in 0..job.len() {
        assert_eq!(
            MasterMessage::decode(&job[..cut]),
            Err(ProtocolError::Decode),
            "job cut at {cut}"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Pixels
// ---------------------------------------------------------------------------------------------

#[test]
fn pixels_round_trip_little_endian() {
    let pixels = [
        Pixel([0, 0, 0]),
        Pixel([0x0102, 0x0304, 0x0506]),
        Pixel([u16::MAX, 1, 0x8000]),
        Pixel::from_color(Vec3::new(0.25, 0.5, 0.75)),
    ];
    let mut wire = vec![0u8; pixels.len() * PIXEL_WIRE_BYTES];
    encode_pixels(&pixels, &mut wire).expect("lengths match");
    assert_eq!(&wire[6..12], &[0x02, 0x01, 0x04, 0x03, 0x06, 0x05]);
    assert_eq!(&wire[12..18], &[0xFF, 0xFF, 0x01, 0x00, 0x00, 0x80]);
    let mut back = [Pixel::default(); 4];
    decode_pixels(&wire, &mut back).expect("lengths match");
    assert_eq!(back, pixels);

    // Empty lines are consistent too.
    encode_pixels(&[], &mut []).expect("empty");
    decode_pixels(&[], &mut []).expect("empty");
}

#[test]
fn pixel_length_mismatches_are_errors() {
    let pixels = [Pixel([1, 2, 3]); 3];
    for len in [0, 17, 19, 6, 24] {
        let mut wire = vec![0u8; len];
        assert_eq!(
            encode_pixels(&pixels, &mut wire),
            Err(ProtocolError::BadPixels),
            "{len} bytes for 3 pixels"
        );
    }
    let wire = [7u8; 18];
    for n in [0, 2, 4] {
        let mut out = vec![Pixel::default(); n];
        assert_eq!(
            decode_pixels(&wire, &mut out),
            Err(ProtocolError::BadPixels),
            "18 bytes into {n} pixels"
        );
        assert!(
            out.iter().all(|p| *p == Pixel::default()),
            "nothing is written on error"
        );
    }
    let mut out = [Pixel::default(); 3];
    assert_eq!(
        decode_pixels(&wire[..17], &mut out),
        Err(ProtocolError::BadPixels)
    );
}

// ---------------------------------------------------------------------------------------------
// Scene blob and assembler
// ---------------------------------------------------------------------------------------------

fn room_blob() -> (SceneDesc, OctreeParams, SceneBlob) {
    let desc = small_room();
    let params = OctreeParams {
        max_depth: 12,
        max_leaf_triangles: 6,
    };
    let blob = SceneBlob::encode(&desc, &params).expect("the room encodes");
    (desc, params, blob)
}

fn chunk_offsets(blob: &SceneBlob) -> Vec<u32> {
    (0..blob.len()).step_by(MAX_CHUNK_LEN).collect()
}

#[test]
fn scene_survives_chunking_and_reassembly() {
    let (desc, params, blob) = room_blob();
    assert!(!blob.is_empty());
    assert_eq!(blob.len() as usize, blob.bytes.len());
    assert_eq!(blob.digest, digest(&blob.bytes));
    let offsets = chunk_offsets(&blob);
    assert!(
        offsets.len() > 10,
        "the room needs many chunks ({} bytes)",
        blob.len()
    );
    assert!(blob.chunk_at(blob.len()).is_empty(), "nothing past the end");
    assert!(blob.chunk_at(u32::MAX).is_empty());

    let mut asm = SceneAssembler::new(blob.digest, blob.len()).expect("legal length");
    assert_eq!(asm.digest(), &blob.digest);
    for (i, &offset) in offsets.iter().enumerate() {
        assert_eq!(asm.expected(), offset);
        let chunk = blob.chunk_at(offset);
        assert!(!chunk.is_empty() && chunk.len() <= MAX_CHUNK_LEN);
        let outcome = asm.push(&blob.digest, offset, chunk);
        let want = if i + 1 == offsets.len() {
            ChunkOutcome::Complete
        } else {
            ChunkOutcome::Appended
        };
        assert_eq!(outcome, want, "chunk at {offset}");
    }
    let bytes = asm.finish().expect("digest matches");
    assert_eq!(bytes, blob.bytes);
    let bundle = decode_bundle(&bytes).expect("the bundle decodes");
    assert_eq!(bundle.desc, desc);
    assert_eq!(bundle.octree, params);

    // The same scene encodes to the same bytes (the digest names it).
    let again = SceneBlob::encode(&desc, &params).expect("encodes");
    assert_eq!(again, blob);
    // Another scene has another digest.
    let mut other = desc.clone();
    other.settings.width += 1;
    let other = SceneBlob::encode(&other, &params).expect("encodes");
    assert_ne!(other.digest, blob.digest);
}

#[test]
fn shader_blend_travels_with_the_scene() {
    let (desc, params, share) = room_blob();
    assert!(desc.shaders.iter().all(|sh| sh.blend == Blend::Share));
    let mut additive = desc.clone();
    additive.shaders[0].blend = Blend::Additive;
    let blob = SceneBlob::encode(&additive, &params).expect("encodes");
    assert_ne!(blob.digest, share.digest, "the blend is part of the scene");
    let bundle = decode_bundle(&blob.bytes).expect("the bundle decodes");
    assert_eq!(bundle.desc.shaders[0].blend, Blend::Additive);
    assert_eq!(bundle.desc, additive);
}

#[test]
fn decode_bundle_rejects_leftover_and_short_bytes() {
    let (_, _, blob) = room_blob();
    let mut longer = blob.bytes.clone();
    longer.push(0);
    assert_eq!(decode_bundle(&longer).err(), Some(ProtocolError::Decode));
    assert_eq!(
        decode_bundle(&blob.bytes[..blob.bytes.len() - 1]).err(),
        Some(ProtocolError::Decode)
    );
}

#[test]
fn assembler_reports_gaps() {
    let (_, _, blob) = room_blob();
    let offsets = chunk_offsets(&blob);
    let mut asm = SceneAssembler::new(blob.digest, blob.len()).expect("legal length");
    assert_eq!(
        asm.push(&blob.digest, 0, blob.chunk_at(0)),
        ChunkOutcome::Appended
    );
    let expected = offsets[1];
    for &skip_to in &offsets[2..5] {
        assert_eq!(
            asm.push(&blob.digest, skip_to, blob.chunk_at(skip_to)),
            ChunkOutcome::Gap { expected },
            "chunk at {skip_to}"
        );
        assert_eq!(asm.expected(), expected, "a gap appends nothing");
    }
    // Resending from the expected byte completes the scene.
    for (i, &offset) in offsets.iter().enumerate().skip(1) {
        let outcome = asm.push(&blob.digest, offset, blob.chunk_at(offset));
        assert_eq!(
            outcome,
            if i + 1 == offsets.len() {
                ChunkOutcome::Complete
            } else {
                ChunkOutcome::Appended
            }
        );
    }
    assert_eq!(asm.finish().expect("complete"), blob.bytes);
}

#[test]
fn assembler_ignores_stale_chunks() {
    let (_, _, blob) = room_blob();
    let mut asm = SceneAssembler::new(blob.digest, blob.len()).expect("legal length");
    let first = blob.chunk_at(0);
    let second = blob.chunk_at(MAX_CHUNK_LEN as u32);
    assert_eq!(asm.push(&blob.digest, 0, first), ChunkOutcome::Appended);
    // A duplicate, a partial overlap, and a chunk of another scene.
    assert_eq!(asm.push(&blob.digest, 0, first), ChunkOutcome::Stale);
    assert_eq!(
        asm.push(&blob.digest, 10, &first[10..]),
        ChunkOutcome::Stale
    );
    let mut wrong = blob.digest;
    wrong[31] ^= 1;
    assert_eq!(
        asm.push(&wrong, MAX_CHUNK_LEN as u32, second),
        ChunkOutcome::Stale
    );
    // A chunk reaching past the scene's end.
    let past = vec![0u8; blob.len() as usize];
    assert_eq!(
        asm.push(&blob.digest, MAX_CHUNK_LEN as u32, &past),
        ChunkOutcome::Stale
    );
    assert_eq!(
        asm.expected(),
        MAX_CHUNK_LEN as u32,
        "stale chunks append nothing"
    );
    assert_eq!(
        asm.push(&blob.digest, MAX_CHUNK_LEN as u32, second),
        ChunkOutcome::Appended
    );
}

#[test]
fn damaged_or_missing_bytes_fail_the_digest() {
    let (_, _, blob) = room_blob();
    let offsets = chunk_offsets(&blob);
    let damaged_at = offsets[3] as usize + 100;
    let mut damaged = blob.bytes.clone();
    damaged[damaged_at] ^= 0x10;
    let mut asm = SceneAssembler::new(blob.digest, blob.len()).expect("legal length");
    let mut last = ChunkOutcome::Stale;
    for &offset in &offsets {
        let start = offset as usize;
        let end = (start + MAX_CHUNK_LEN).min(damaged.len());
        last = asm.push(&blob.digest, offset, &damaged[start..end]);
    }
    assert_eq!(last, ChunkOutcome::Complete);
    assert_eq!(asm.finish(), Err(ProtocolError::DigestMismatch));

    // An incomplete scene never passes either.
    let mut asm = SceneAssembler::new(blob.digest, blob.len()).expect("legal length");
    assert_eq!(
        asm.push(&blob.digest, 0, blob.chunk_at(0)),
        ChunkOutcome::Appended
    );
    assert_eq!(asm.finish(), Err(ProtocolError::DigestMismatch));
}

#[test]
fn assembler_rejects_illegal_lengths() {
    assert_eq!(
        SceneAssembler::new([0; 32], 0).err(),
        Some(ProtocolError::SceneTooLarge)
    );
    assert_eq!(
        SceneAssembler::new([0; 32], MAX_SCENE_LEN + 1).err(),
        Some(ProtocolError::SceneTooLarge)
    );
    let mut asm = SceneAssembler::new([4; 32], 3).expect("legal length");
    assert_eq!(asm.push(&[4; 32], 0, &[1, 2]), ChunkOutcome::Appended);
    assert_eq!(asm.push(&[4; 32], 2, &[3]), ChunkOutcome::Complete);
    assert_eq!(
        asm.finish(),
        Err(ProtocolError::DigestMismatch),
        "[4; 32] is not the digest of [1, 2, 3]"
    );
    let d = digest(&[1, 2, 3]);
    let mut asm = SceneAssembler::new(d, 3).expect("legal length");
    assert_eq!(asm.push(&d, 0, &[1, 2, 3]), ChunkOutcome::Complete);
    assert_eq!(asm.finish(), Ok(vec![1, 2, 3]));
}

#[test]
fn payload_with_bytes_left_over_is_not_a_message() {
    let mut payload = payload_of(&MasterMessage::Fence { seq: 7 });
    assert_eq!(
        MasterMessage::decode(&payload),
        Ok(MasterMessage::Fence { seq: 7 })
    );
    payload.extend_from_slice(&[1, 2, 3]);
    assert_eq!(MasterMessage::decode(&payload), Err(ProtocolError::Decode));
    let mut payload = payload_of(&WorkerMessage::FenceAck { seq: 7 });
    payload.push(0);
    assert_eq!(WorkerMessage::decode(&payload), Err(ProtocolError::Decode));
}

#[test]
fn long_runs_of_delimiters_are_skipped_in_linear_time() {
    // A master-sized buffer full of zeros, then a frame: the zeros are empty frames. Skipping
    // them one copy at a time would take on the order of MAX_FRAME_LEN² byte moves; the reader
    // must get through a few MiB of them with the frame intact (a hang here fails the suite).
    let mut bytes = vec![0u8; 8 * MAX_FRAME_LEN];
    let frame = frame_of(&MasterMessage::Fence { seq: 9 });
    bytes.extend_from_slice(&frame);
    let events = read_all(&mut PieceLink::whole(bytes), MAX_FRAME_LEN);
    assert_eq!(frames_of(&events).len(), 1, "{events:?}");
    assert!(dropped_of(&events).is_empty(), "{events:?}");
}
