//! The fuzzing entry points: each takes arbitrary bytes and must return without panicking,
//! hanging or allocating beyond its input's worth. The same functions run under `cargo fuzz`
//! (`fuzz/fuzz_targets/*.rs` include this file) and in the normal test suite over a
//! proptest-generated corpus (`tests/tests/fuzz_corpus.rs`), so CI catches a panic without
//! nightly tooling. `docs/robustness.md` lists the targets and what running them found.

#![allow(dead_code)]

use std::path::Path;
use strahl_core::scene::Scene;
use strahl_core::wire::frame::{FrameReader, FrameWriter, LinkError, ReadEvent};
use strahl_core::wire::message::{MasterMessage, WorkerMessage};
use strahl_core::wire::scene_blob::{decode_bundle, memory_estimate};
use strahl_core::wire::{MAX_FRAME_LEN, MAX_MASTER_FRAME_LEN};
use strahl_core::worker::{serve, NodeInfo, SceneCache};

/// An entry point.
pub type Target = fn(&[u8]);

/// Every entry point by name, for the corpus test.
pub const TARGETS: [(&str, Target); 7] = [
    ("frames", frames),
    ("worker_session", worker_session),
    ("scene_bundle", scene_bundle),
    ("config_and_data", config_and_data),
    ("fart", fart),
    ("nff", nff),
    ("obj", obj),
];

/// Frames from the bytes as both sides read them; every message that decodes must encode and
/// decode to itself.
pub fn frames(data: &[u8]) {
    for limit in [MAX_MASTER_FRAME_LEN, MAX_FRAME_LEN] {
        let mut link = data;
        let mut reader = FrameReader::new(vec![0u8; limit]);
        let mut writer = FrameWriter::new();
        loop {
            match reader.next(&mut link) {
                Ok(ReadEvent::Frame(payload)) => {
                    if let Ok(m) = MasterMessage::decode(payload) {
                        let again = writer.encode(&m).expect("a decoded message encodes");
                        assert!(!again.is_empty());
                    }
                    if let Ok(m) = WorkerMessage::decode(payload) {
                        let again = writer.encode(&m).expect("a decoded message encodes");
                        assert!(!again.is_empty());
                    }
                }
                Ok(ReadEvent::Dropped(_)) | Err(LinkError::TimedOut) => {}
                Err(_) => break,
            }
        }
    }
}

/// A link that reads the fuzzer's bytes and swallows what the worker writes.
struct Script<'a> {
    input: &'a [u8],
}

impl embedded_io::ErrorType for Script<'_> {
    type Error = embedded_io::ErrorKind;
}

impl embedded_io::Read for Script<'_> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        let n = buf.len().min(self.input.len());
        buf[..n].copy_from_slice(&self.input[..n]);
        self.input = &self.input[n..];
        Ok(n)
    }
}

impl embedded_io::Write for Script<'_> {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        Ok(buf.len())
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// A whole worker session fed the bytes as the master's side of the link: greeting, jobs,
/// scene chunks (a worker with 1 MiB for scenes), requests, fences.
pub fn worker_session(data: &[u8]) {
    let node = NodeInfo {
        name: "fuzz",
        arch: "fuzz",
        scene_memory: 1 << 20,
        threads: 1,
        secret: None,
        nonce: || [0; 32],
    };
    let mut link = Script { input: data };
    let _ = serve(&mut link, &node, &mut SceneCache::new());
}

/// A scene's encoding as a worker receives it: decoded, checked against a 16 MiB budget as the
/// worker does, and built.
pub fn scene_bundle(data: &[u8]) {
    let Ok(bundle) = decode_bundle(data) else {
        return;
    };
    if memory_estimate(data.len() as u32, Some(&bundle.desc)) > 16 << 20 {
        return;
    }
    let _ = Scene::build(&bundle.desc, &bundle.octree);
}

fn text(data: &[u8]) -> String {
    String::from_utf8_lossy(data).into_owned()
}

/// The seed's two formats: the bytes as a `raytracer.cfg`, and as a data file (both index
/// bases).
pub fn config_and_data(data: &[u8]) {
    let t = text(data);
    let _ = strahl_formats::config::parse_config(Path::new("fuzz.cfg"), &t);
    for base in [0, 1] {
        let _ = strahl_formats::datafile::parse_data(Path::new("FUZZ.txt"), &t, base);
    }
}

/// FART's language: lexed, parsed and expanded into a scene.
pub fn fart(data: &[u8]) {
    let _ = strahl_formats::fart::load_fart_source(Path::new("fuzz.fart"), &text(data));
}

/// NFF.
pub fn nff(data: &[u8]) {
    let _ = strahl_formats::nff::parse_nff(Path::new("fuzz.nff"), &text(data));
}

/// Wavefront OBJ (geometry; materials need files).
pub fn obj(data: &[u8]) {
    let _ = strahl_formats::obj::parse_obj(Path::new("fuzz.obj"), data);
}
