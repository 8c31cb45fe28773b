//! The scene on the wire: encoded, named by its digest, chunked, reassembled.
//!
//! The master encodes a [`SceneBundle`] (the scene description and the octree parameters) once
//! with postcard into a [`SceneBlob`], whose SHA-256 digest names it. Workers that already hold a
//! scene with that digest skip the transfer; others receive it in chunks of at most
//! [`MAX_CHUNK_LEN`] bytes and put it back together with a [`SceneAssembler`], which checks the
//! digest before anything is decoded. Workers therefore need no shared file system.

use crate::accel::octree::{OctreeParams, BYTES_PER_PRIMITIVE};
use crate::geom::solid::SolidNode;
use crate::scene::SceneDesc;
use crate::wire::error::ProtocolError;
use crate::wire::message::Digest;
use crate::wire::{MAX_CHUNK_LEN, MAX_SCENE_LEN};
use alloc::vec::Vec;
use serde::{Deserialize, Serialize};
use sha2::{Digest as _, Sha256};

/// Everything a worker needs to build the scene exactly as the master would.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SceneBundle {
    /// The scene.
    pub desc: SceneDesc,
    /// How to build its octree.
    pub octree: OctreeParams,
}

/// The borrowed twin of [`SceneBundle`]; encodes to the same bytes.
#[derive(Serialize)]
struct SceneBundleRef<'a> {
    desc: &'a SceneDesc,
    octree: &'a OctreeParams,
}

/// A scene's encoding and its digest.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneBlob {
    /// The postcard encoding of a [`SceneBundle`].
    pub bytes: Vec<u8>,
    /// SHA-256 of `bytes`.
    pub digest: Digest,
}

/// SHA-256 of `bytes`.
pub fn digest(bytes: &[u8]) -> Digest {
    Sha256::digest(bytes).into()
}

impl SceneBlob {
    /// Encodes the scene and its octree parameters.
    ///
    /// # Errors
    /// [`ProtocolError::Encode`] if postcard fails, [`ProtocolError::SceneTooLarge`] if the
    /// encoding is longer than [`MAX_SCENE_LEN`].
    pub fn encode(desc: &SceneDesc, octree: &OctreeParams) -> Result<Self, ProtocolError> {
        let bytes = postcard::to_allocvec(&SceneBundleRef { desc, octree })
            .map_err(|_| ProtocolError::Encode)?;
        if bytes.len() > MAX_SCENE_LEN as usize {
            return Err(ProtocolError::SceneTooLarge);
        }
        let digest = digest(&bytes);
        Ok(SceneBlob { bytes, digest })
    }

    /// The encoding's length as the protocol carries it.
    pub fn len(&self) -> u32 {
        // `encode` checked the length against MAX_SCENE_LEN.
        self.bytes.len() as u32
    }

    /// Whether the encoding is empty (never, for an encoded scene).
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// The chunk that starts at `offset`: at most [`MAX_CHUNK_LEN`] bytes, empty past the end.
    pub fn chunk_at(&self, offset: u32) -> &[u8] {
        let start = (offset as usize).min(self.bytes.len());
        let end = (start + MAX_CHUNK_LEN).min(self.bytes.len());
        &self.bytes[start..end]
    }
}

/// Decodes a bundle from a reassembled, digest-checked encoding.
///
/// # Errors
/// [`ProtocolError::Decode`] if the bytes are not a bundle or have bytes left over.
pub fn decode_bundle(bytes: &[u8]) -> Result<SceneBundle, ProtocolError> {
    match postcard::take_from_bytes::<SceneBundle>(bytes) {
        Ok((bundle, [])) => Ok(bundle),
        _ => Err(ProtocolError::Decode),
    }
}

/// Bytes a worker needs to hold a scene: its encoding plus the prepared scene, an estimate used
/// to refuse scenes a small node cannot hold before it tries. Per triangle: its corners and
/// normals (72 bytes), shader index (4) and the octree's budget
/// ([`BYTES_PER_PRIMITIVE`]); per analytic shape or CSG node: the node itself, its place in
/// the object list, its bounding box (24) and the octree's budget.
pub fn memory_estimate(encoded_len: u32, desc: Option<&SceneDesc>) -> u64 {
    let octree = BYTES_PER_PRIMITIVE as u64;
    let prepared = desc.map_or(0, |d| {
        let solid = core::mem::size_of::<SolidNode>() as u64 + 4 + 24 + octree;
        d.points.len() as u64 * 12
            + d.triangles.len() as u64 * (36 + 36 + 4 + octree)
            + d.solids.len() as u64 * solid
    });
    u64::from(encoded_len) + prepared
}

/// What [`SceneAssembler::push`] did with a chunk.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChunkOutcome {
    /// The chunk was the next one; more are needed.
    Appended,
    /// The chunk was the last one: call [`SceneAssembler::finish`].
    Complete,
    /// The chunk starts past the next expected byte (one was lost): ask again from `expected`.
    Gap {
        /// The first byte still missing.
        expected: u32,
    },
    /// The chunk belongs to another scene or repeats bytes already held; ignored.
    Stale,
}

/// Collects a scene's chunks in order.
#[derive(Clone, Debug)]
pub struct SceneAssembler {
    digest: Digest,
    len: u32,
    bytes: Vec<u8>,
}

impl SceneAssembler {
    /// An assembler for the scene `digest` of `len` bytes; reserves exactly `len` bytes.
    ///
    /// # Errors
    /// [`ProtocolError::SceneTooLarge`] if `len` is 0, over the limit, or cannot be allocated.
    pub fn new(digest: Digest, len: u32) -> Result<Self, ProtocolError> {
        if len == 0 || len > MAX_SCENE_LEN {
            return Err(ProtocolError::SceneTooLarge);
        }
        let mut bytes = Vec::new();
        bytes
            .try_reserve_exact(len as usize)
            .map_err(|_| ProtocolError::SceneTooLarge)?;
        Ok(SceneAssembler { digest, len, bytes })
    }

    /// The scene being assembled.
    pub fn digest(&self) -> &Digest {
        &self.digest
    }

    /// The first byte not yet received.
    pub fn expected(&self) -> u32 {
        self.bytes.len() as u32
    }

    /// Takes the chunk `bytes` at `offset` of scene `digest`.
    pub fn push(&mut self, digest: &Digest, offset: u32, bytes: &[u8]) -> ChunkOutcome {
        let expected = self.expected();
        let end = u64::from(offset) + bytes.len() as u64;
        if *digest != self.digest || offset < expected || end > u64::from(self.len) {
            return ChunkOutcome::Stale;
        }
        if offset > expected {
            return ChunkOutcome::Gap { expected };
        }
        self.bytes.extend_from_slice(bytes);
        if self.bytes.len() as u64 == u64::from(self.len) {
            ChunkOutcome::Complete
        } else {
            ChunkOutcome::Appended
        }
    }

    /// The complete encoding, after its digest is checked.
    ///
    /// # Errors
    /// [`ProtocolError::DigestMismatch`] if bytes are missing or do not match the digest.
    pub fn finish(self) -> Result<Vec<u8>, ProtocolError> {
        if self.bytes.len() as u64 != u64::from(self.len) || digest(&self.bytes) != self.digest {
            return Err(ProtocolError::DigestMismatch);
        }
        Ok(self.bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::solid::{CsgOp, SolidNode};

    #[test]
    fn the_estimate_counts_solids_as_well_as_triangles() {
        let mut desc = SceneDesc::default();
        let empty = memory_estimate(100, Some(&desc));
        assert_eq!(empty, 100);
        let node = SolidNode::Csg {
            op: CsgOp::Union,
            a: 0,
            b: 0,
        };
        desc.solids = alloc::vec![node; 1000];
        let with_solids = memory_estimate(100, Some(&desc));
        assert!(
            with_solids >= empty + 1000 * (BYTES_PER_PRIMITIVE as u64 + 24),
            "{with_solids}"
        );
    }
}
