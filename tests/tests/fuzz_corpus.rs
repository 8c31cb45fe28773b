//! The fuzzing entry points (`fuzz_entry`, shared with `fuzz/`) over a generated corpus: the
//! repository's own scenes and protocol messages, each damaged by a few random byte edits, and
//! plain random bytes. Every input must come back without a panic. `cargo fuzz` runs the same
//! functions far longer (`docs/robustness.md`); this catches a regression in CI without
//! nightly tooling.

use crate::fuzz_entry;

use proptest::prelude::*;
use std::path::Path;
use strahl_core::accel::octree::OctreeParams;
use strahl_core::wire::frame::FrameWriter;
use strahl_core::wire::message::{Hello, MasterMessage};
use strahl_core::wire::scene_blob::SceneBlob;

/// The seed inputs of every target: real files and real protocol traffic.
fn seeds() -> Vec<Vec<u8>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut seeds: Vec<Vec<u8>> = [
        "scenes/room/raytracer.cfg",
        "scenes/fart/die.fart",
        "scenes/fart/glass.fart",
        "scenes/fart/mirrors.fart",
        "scenes/fart/ring.fart",
        "scenes/fart/pyramid.obj",
    ]
    .iter()
    .map(|f| std::fs::read(root.join(f)).unwrap_or_default())
    .collect();
    // The first lines of the room's data file (all of it is slow to parse a thousand times).
    let room = std::fs::read_to_string(root.join("scenes/room/ROOM.txt")).unwrap_or_default();
    seeds.push(
        room.lines()
            .take(60)
            .collect::<Vec<_>>()
            .join("\n")
            .into_bytes(),
    );
    seeds.push(
        b"v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 8 8\nb 0 0 0\n\
          l 1 1 1\nf 1 0 0 .5 .5 3 0 1\ns 0 0 0 1\np 3 0 0 0 1 0 0 0 1 0\nc 0 0 0 1 0 1 0 .5\n"
            .to_vec(),
    );
    // A master's opening of a session, as frames, and a small scene's encoding.
    let mut desc = strahl_host::generate::room();
    desc.settings.width = 8;
    desc.settings.height = 4;
    desc.triangles.truncate(40);
    if let Ok(blob) = SceneBlob::encode(&desc, &OctreeParams::default()) {
        let mut frames = FrameWriter::new();
        let mut traffic = Vec::new();
        let msgs = [
            MasterMessage::Hello(Hello {
                version: strahl_core::wire::PROTOCOL_VERSION,
                name: "m",
                arch: "x",
                scene_memory: 0,
                threads: 0,
                nonce: [3; 32],
                proof: None,
            }),
            MasterMessage::Job {
                job: 1,
                digest: blob.digest,
                scene_len: blob.len(),
            },
            MasterMessage::SceneChunk {
                digest: blob.digest,
                offset: 0,
                bytes: blob.chunk_at(0),
            },
            MasterMessage::RenderLines {
                job: 1,
                first: 0,
                count: 4,
            },
            MasterMessage::Fence { seq: 1 },
        ];
        for m in &msgs {
            traffic.extend_from_slice(frames.encode(m).unwrap_or_default());
        }
        seeds.push(traffic);
        seeds.push(blob.bytes.clone());
    }
    seeds.retain(|s| !s.is_empty());
    seeds
}

/// A seed with up to eight random byte edits (replace, insert, delete), or random bytes.
fn inputs() -> impl Strategy<Value = Vec<u8>> {
    let seeds = seeds();
    let n = seeds.len();
    let edits = prop::collection::vec((any::<u16>(), any::<u8>(), 0u8..3), 0..8);
    prop_oneof![
        (0..n, edits).prop_map(move |(i, edits)| {
            let mut s = seeds[i].clone();
            for (at, byte, kind) in edits {
                if s.is_empty() {
                    break;
                }
                let at = usize::from(at) % s.len();
                match kind {
                    0 => s[at] = byte,
                    1 => s.insert(at, byte),
                    _ => {
                        s.remove(at);
                    }
                }
            }
            s
        }),
        prop::collection::vec(any::<u8>(), 0..512),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn no_entry_point_panics_on_damaged_input(input in inputs()) {
        for (_, target) in fuzz_entry::TARGETS {
            target(&input);
        }
    }
}

#[test]
fn every_seed_is_taken_whole() {
    // The undamaged seeds run through every target too (a seed that panics is a bug as well).
    for seed in seeds() {
        for (_, target) in fuzz_entry::TARGETS {
            target(&seed);
        }
    }
}
