//! The messages: [`MasterMessage`] from master to worker, [`WorkerMessage`] back.
//!
//! Messages borrow their byte fields (names, scene chunks, pixels) from the frame they were
//! decoded from, so decoding allocates nothing. [`MasterMessage::decode`] and
//! [`WorkerMessage::decode`] check every size limit; checks that need context (does this line
//! exist, is this the job in progress, is the pixel count the image width) are the receiver's.
//! Pixels travel as fixed-point integers ([`encode_pixels`], [`decode_pixels`]), never as floats.

use crate::render::pixel::Pixel;
use crate::render::stats::RayCounts;
use crate::scene::error::SceneError;
use crate::wire::auth::{Nonce, Proof};
use crate::wire::error::ProtocolError;
use crate::wire::{
    MAX_CHUNK_LEN, MAX_LINES_PER_REQUEST, MAX_MASK_LEN, MAX_NAME_LEN, MAX_PANIC_LEN, MAX_SCENE_LEN,
    MAX_WIDTH, PIXEL_WIRE_BYTES,
};
use serde::{Deserialize, Serialize};

/// A SHA-256 digest that names a scene's encoding.
pub type Digest = [u8; 32];

/// The first message each side sends: protocol version and what the node is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Hello<'a> {
    /// [`crate::wire::PROTOCOL_VERSION`] of the sender. Always the first field.
    pub version: u32,
    /// The node's name (host name, board name), at most [`MAX_NAME_LEN`] bytes.
    pub name: &'a str,
    /// The node's architecture (`x86_64`, `thumbv7em`, ...), at most [`MAX_NAME_LEN`] bytes.
    pub arch: &'a str,
    /// Bytes of memory the node can give a scene (0 from a master).
    pub scene_memory: u64,
    /// Lines the node renders at once (a worker's threads, at least 1; 0 from a master).
    pub threads: u32,
    /// A fresh random value for this handshake ([`crate::wire::auth`]).
    pub nonce: Nonce,
    /// A worker with a secret: its proof over both nonces; `None` from a master or a worker
    /// without a secret.
    pub proof: Option<Proof>,
}

impl Hello<'_> {
    fn check(&self) -> Result<(), ProtocolError> {
        if self.name.len() > MAX_NAME_LEN || self.arch.len() > MAX_NAME_LEN {
            return Err(ProtocolError::NameTooLong);
        }
        Ok(())
    }
}

/// Master to worker.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum MasterMessage<'a> {
    /// Opens (or restarts) a session. Stays variant 0 in every protocol version.
    #[serde(borrow)]
    Hello(Hello<'a>),
    /// Announces the job the next line requests belong to and the scene it renders. The worker
    /// answers `Ready` if it has the scene cached, `NeedScene` otherwise, `Refused` if it cannot
    /// hold it. Sent again if no answer comes.
    Job {
        /// Job number, chosen by the master.
        job: u32,
        /// Digest of the scene's encoding.
        digest: Digest,
        /// Length of the scene's encoding in bytes, 1 to [`MAX_SCENE_LEN`].
        scene_len: u32,
    },
    /// Bytes `offset..offset + bytes.len()` of the scene named by `digest`.
    SceneChunk {
        /// The scene these bytes belong to.
        digest: Digest,
        /// Position of the first byte in the scene's encoding.
        offset: u32,
        /// At most [`MAX_CHUNK_LEN`] bytes.
        #[serde(serialize_with = "as_bytes")]
        bytes: &'a [u8],
    },
    /// Render one line of the job's image and send a `LineResult` (`refined: false`). With
    /// adaptive multisampling this is the first pass: the pixels' centre colours. Requests are
    /// answered in the order they arrive.
    RenderLine {
        /// The job.
        job: u32,
        /// The line, 0 is the top.
        line: u32,
    },
    /// Answered by `FenceAck` with the same number after every earlier request: a request that
    /// has no answer by then was lost on the link.
    Fence {
        /// Any number; echoed back.
        seq: u32,
    },
    /// The master is done with this worker; the worker waits for the next master.
    EndSession,
    /// Adaptive multisampling's second pass: supersample the pixels of one line flagged in
    /// `mask` and send a `LineResult` (`refined: true`) with them (other pixels black).
    RefineLine {
        /// The job.
        job: u32,
        /// The line, 0 is the top.
        line: u32,
        /// One bit per pixel (`crate::render::adaptive::mask_len` bytes), at most [`MAX_MASK_LEN`].
        #[serde(serialize_with = "as_bytes")]
        mask: &'a [u8],
    },
    /// Render lines `first..first + count` (1 to [`MAX_LINES_PER_REQUEST`]): the same as
    /// `count` `RenderLine`s in a row, answered by one `LineResult` per line, in order.
    RenderLines {
        /// The job.
        job: u32,
        /// The first line.
        first: u32,
        /// How many lines.
        count: u32,
    },
    /// The master's proof of the shared secret over both `Hello`s' nonces; a worker with a
    /// secret takes no job before it.
    Auth {
        /// `HMAC(secret, "strahl master" ‖ version ‖ master nonce ‖ worker nonce)`.
        proof: Proof,
    },
    /// The master will not work with this worker and ends the session.
    Reject {
        /// Why.
        reason: Rejection,
    },
}

/// Why a master rejects a worker after its `Hello`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Rejection {
    /// The master needs a proof of the secret and the worker gave none.
    NoProof,
    /// The worker's proof does not match the master's secret.
    WrongProof,
    /// The worker gave a proof but the master has no secret to check it or answer with.
    MasterHasNoSecret,
}

/// Why a worker refuses a job or request.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Refusal {
    /// The scene needs more memory than the worker can give it.
    SceneTooLarge {
        /// The worker's limit in bytes.
        limit: u64,
    },
    /// The scene arrived but does not describe a renderable scene.
    BadScene(SceneError),
    /// The scene's bytes did not decode or did not match their digest.
    CorruptScene,
    /// A request named a job the worker has not been given, or whose scene is not loaded yet.
    UnknownJob,
    /// A request named a line outside the image.
    LineOutOfRange,
    /// A `RefineLine` whose mask does not fit the image width, or for a scene without adaptive
    /// multisampling.
    BadMask,
    /// The worker has a secret and the master has not proved it holds it (no `Auth`, or a
    /// wrong one); the worker ends the session.
    Unauthenticated,
}

/// Worker to master.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum WorkerMessage<'a> {
    /// The answer to the master's `Hello`. Stays variant 0 in every protocol version.
    #[serde(borrow)]
    Hello(Hello<'a>),
    /// The worker does not have the job's scene and wants its chunks from `offset` on.
    NeedScene {
        /// The job.
        job: u32,
        /// First byte wanted.
        offset: u32,
        /// `true`: (re)start sending at `offset` (the first request, or bytes were lost);
        /// `false`: a window arrived whole, send the next one.
        restart: bool,
    },
    /// The worker holds the job's scene and takes line requests.
    Ready {
        /// The job.
        job: u32,
    },
    /// One rendered line.
    LineResult {
        /// The job it answers.
        job: u32,
        /// The line it answers.
        line: u32,
        /// `true` for a `RefineLine`'s answer, `false` for a `RenderLine`'s.
        refined: bool,
        /// Rays traced for it, by kind.
        rays: RayCounts,
        /// The line's pixels, [`PIXEL_WIRE_BYTES`] each ([`encode_pixels`]).
        #[serde(serialize_with = "as_bytes")]
        pixels: &'a [u8],
    },
    /// The answer to `Fence`.
    FenceAck {
        /// The fence's number.
        seq: u32,
    },
    /// The worker dropped a frame it could not read (so a request may be lost).
    Dropped {
        /// Frames dropped since the session began.
        total: u32,
    },
    /// The worker cannot do what was asked.
    Refused {
        /// The job concerned.
        job: u32,
        /// Why.
        reason: Refusal,
    },
    /// The worker panicked and halts: its panic message, at most [`MAX_PANIC_LEN`] bytes, sent
    /// by a panic handler that can still write to the link (the firmware's). Nothing follows it.
    Panicked {
        /// The panic message.
        message: &'a str,
    },
}

impl<'a> MasterMessage<'a> {
    /// Decodes a frame payload and checks the size limits.
    ///
    /// # Errors
    /// [`ProtocolError::Decode`] if the bytes are not a message, or the limit it breaks.
    pub fn decode(payload: &'a [u8]) -> Result<Self, ProtocolError> {
        let msg: MasterMessage<'a> = decode_exact(payload)?;
        match msg {
            MasterMessage::Hello(h) => h.check()?,
            MasterMessage::Job { scene_len, .. } => {
                if scene_len == 0 || scene_len > MAX_SCENE_LEN {
                    return Err(ProtocolError::SceneTooLarge);
                }
            }
            MasterMessage::SceneChunk { offset, bytes, .. } => {
                if bytes.is_empty()
                    || bytes.len() > MAX_CHUNK_LEN
                    || u64::from(offset) + bytes.len() as u64 > u64::from(MAX_SCENE_LEN)
                {
                    return Err(ProtocolError::BadChunk);
                }
            }
            MasterMessage::RefineLine { mask, .. } => {
                if mask.is_empty() || mask.len() > MAX_MASK_LEN {
                    return Err(ProtocolError::BadMask);
                }
            }
            MasterMessage::RenderLines { count, .. } => {
                if count == 0 || count > MAX_LINES_PER_REQUEST {
                    return Err(ProtocolError::BadRequest);
                }
            }
            MasterMessage::RenderLine { .. }
            | MasterMessage::Fence { .. }
            | MasterMessage::EndSession
            | MasterMessage::Auth { .. }
            | MasterMessage::Reject { .. } => {}
        }
        Ok(msg)
    }
}

impl<'a> WorkerMessage<'a> {
    /// Decodes a frame payload and checks the size limits.
    ///
    /// # Errors
    /// [`ProtocolError::Decode`] if the bytes are not a message, or the limit it breaks.
    pub fn decode(payload: &'a [u8]) -> Result<Self, ProtocolError> {
        let msg: WorkerMessage<'a> = decode_exact(payload)?;
        match msg {
            WorkerMessage::Hello(h) => h.check()?,
            WorkerMessage::LineResult { pixels, .. } => {
                if pixels.is_empty()
                    || pixels.len() % PIXEL_WIRE_BYTES != 0
                    || pixels.len() > MAX_WIDTH as usize * PIXEL_WIRE_BYTES
                {
                    return Err(ProtocolError::BadPixels);
                }
            }
            WorkerMessage::Panicked { message } => {
                if message.len() > MAX_PANIC_LEN {
                    return Err(ProtocolError::Decode);
                }
            }
            WorkerMessage::NeedScene { .. }
            | WorkerMessage::Ready { .. }
            | WorkerMessage::FenceAck { .. }
            | WorkerMessage::Dropped { .. }
            | WorkerMessage::Refused { .. } => {}
        }
        Ok(msg)
    }
}

/// Serializes a byte field as bytes (postcard: its length, then the bytes copied whole). Serde
/// writes a `&[u8]` as a sequence, one `u8` at a time; postcard encodes both the same way, so
/// this changes no byte on the wire, only the time: a line's pixels went through serde one byte
/// at a time.
fn as_bytes<S: serde::Serializer>(bytes: &&[u8], serializer: S) -> Result<S::Ok, S::Error> {
    serializer.serialize_bytes(bytes)
}

/// Decodes a whole payload: bytes left over make it invalid too.
fn decode_exact<'a, T: Deserialize<'a>>(payload: &'a [u8]) -> Result<T, ProtocolError> {
    match postcard::take_from_bytes(payload) {
        Ok((msg, [])) => Ok(msg),
        _ => Err(ProtocolError::Decode),
    }
}

/// Writes `pixels` as little-endian `u16` channels into `out`, which must be
/// `pixels.len() × PIXEL_WIRE_BYTES` long.
///
/// # Errors
/// [`ProtocolError::BadPixels`] if `out` has the wrong length.
pub fn encode_pixels(pixels: &[Pixel], out: &mut [u8]) -> Result<(), ProtocolError> {
    if out.len() != pixels.len() * PIXEL_WIRE_BYTES {
        return Err(ProtocolError::BadPixels);
    }
    for (p, o) in pixels.iter().zip(out.chunks_exact_mut(PIXEL_WIRE_BYTES)) {
        for (c, b) in p.0.iter().zip(o.chunks_exact_mut(2)) {
            b.copy_from_slice(&c.to_le_bytes());
        }
    }
    Ok(())
}

/// Reads pixels written by [`encode_pixels`]; `bytes` must hold exactly `out.len()` pixels.
///
/// # Errors
/// [`ProtocolError::BadPixels`] if the lengths do not match.
pub fn decode_pixels(bytes: &[u8], out: &mut [Pixel]) -> Result<(), ProtocolError> {
    if bytes.len() != out.len() * PIXEL_WIRE_BYTES {
        return Err(ProtocolError::BadPixels);
    }
    for (p, b) in out.iter_mut().zip(bytes.chunks_exact(PIXEL_WIRE_BYTES)) {
        *p = Pixel([
            u16::from_le_bytes([b[0], b[1]]),
            u16::from_le_bytes([b[2], b[3]]),
            u16::from_le_bytes([b[4], b[5]]),
        ]);
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use alloc::vec::Vec;

    /// The byte fields are written as bytes ([`as_bytes`]) but must keep the layout serde gives
    /// a sequence of `u8` (a `Vec<u8>`, written one element at a time): each message equals
    /// the tuple of its variant number and its fields, the bytes as such a sequence.
    #[test]
    fn byte_fields_keep_the_layout_of_a_sequence() {
        let bytes: Vec<u8> = (0..=255u8).cycle().take(700).collect();
        let rays = RayCounts {
            primary: 512,
            shadow: 77,
            ..RayCounts::default()
        };
        let line = WorkerMessage::LineResult {
            job: 9,
            line: 300,
            refined: true,
            rays,
            pixels: &bytes[..600],
        };
        let want = postcard::to_allocvec(&(3u32, 9u32, 300u32, true, rays, bytes[..600].to_vec()));
        assert_eq!(encoded(&line), want.ok());
        let chunk = MasterMessage::SceneChunk {
            digest: [7; 32],
            offset: 70_000,
            bytes: &bytes,
        };
        let want = postcard::to_allocvec(&(2u32, [7u8; 32], 70_000u32, bytes.clone()));
        assert_eq!(encoded(&chunk), want.ok());
        let refine = MasterMessage::RefineLine {
            job: 1,
            line: 2,
            mask: &bytes[..64],
        };
        let want = postcard::to_allocvec(&(6u32, 1u32, 2u32, bytes[..64].to_vec()));
        assert_eq!(encoded(&refine), want.ok());
    }

    fn encoded<T: Serialize>(message: &T) -> Option<Vec<u8>> {
        postcard::to_allocvec(message).ok()
    }
}
