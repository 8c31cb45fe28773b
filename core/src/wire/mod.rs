//! The wire protocol between a master and its workers, the same on every transport.
//!
//! It reads bottom up:
//! - [`cobs`]: the byte stuffing that keeps `0x00` out of a frame's body.
//! - [`frame`]: a frame is a postcard payload followed by its CRC-32, COBS-encoded, with a `0x00`
//!   byte before and after. A frame that fails its CRC or does not decode is dropped, never used;
//!   the next `0x00` resynchronises the stream. [`frame::FrameReader`] reads frames from any
//!   `embedded_io::Read`, [`frame::FrameWriter`] writes them to any `embedded_io::Write`.
//! - [`message`]: the two message enums, [`message::MasterMessage`] (master to worker) and
//!   [`message::WorkerMessage`] (worker to master), with their size checks and the fixed-point
//!   pixel encoding.
//! - [`scene_blob`]: a scene as bytes: encoded with postcard, named by its SHA-256 digest, sent in
//!   chunks and put back together by [`scene_blob::SceneAssembler`].
//! - [`auth`]: the shared-secret handshake's proofs (HMAC-SHA256 over both sides' nonces).
//! - [`error`]: [`ProtocolError`](error::ProtocolError), why bytes from the wire cannot be used.
//!
//! Wire code is pure: it turns bytes into validated messages and back and never renders; the
//! worker loop that acts on the messages is [`crate::worker`]. Inside the layer: `error` and
//! `cobs` ← `frame`, `message` ← `scene_blob`. The layer uses `scene` (the scene description
//! it transfers) and `render` (pixels and ray counts it carries).
//!
//! The limits below are part of the protocol: a peer that exceeds one is sending bad frames.
//! `docs/protocol.md` describes the message sequence.

pub mod auth;
pub mod cobs;
pub mod error;
pub mod frame;
pub mod message;
pub mod scene_blob;

/// The protocol version both ends announce in their `Hello`. Peers with different versions do not
/// talk: the worker answers with its own `Hello` (so the master can report both versions) and
/// ends the session. `Hello` stays the first variant of both message enums, with the version as
/// its first field, in every version.
pub const PROTOCOL_VERSION: u32 = 7;

/// The most bytes of a worker's last words ([`message::WorkerMessage::Panicked`]).
pub const MAX_PANIC_LEN: usize = 200;

/// The widest image line a line result carries, in pixels (the scene's own limit).
pub const MAX_WIDTH: u32 = crate::scene::MAX_IMAGE_SIDE;

/// Bytes per pixel on the wire: three little-endian `u16` channels.
pub const PIXEL_WIRE_BYTES: usize = 6;

/// The most scene bytes one `SceneChunk` carries.
pub const MAX_CHUNK_LEN: usize = 1024;

/// Scene bytes in flight per transfer window: a worker asks for the next window (`NeedScene`
/// with its current offset) each time it has received a multiple of this many bytes, and a
/// master keeps at most two windows unanswered, so slow links are never flooded.
pub const SCENE_WINDOW: u32 = 16 * MAX_CHUNK_LEN as u32;

/// The most lines one `RenderLines` request asks for.
pub const MAX_LINES_PER_REQUEST: u32 = 64;

/// The longest node name or architecture string in a `Hello`, in bytes.
pub const MAX_NAME_LEN: usize = 64;

/// The largest encoded scene a master may offer, in bytes (1 GiB).
pub const MAX_SCENE_LEN: u32 = 1 << 30;

/// An upper bound on a message's encoding besides its one variable byte field (pixels, chunk or
/// names); the largest messages are checked against it in tests.
pub const MAX_HEADER_LEN: usize = 128;

/// Bytes of the CRC-32 that follows each payload.
pub const CRC_LEN: usize = 4;

/// The largest payload (postcard bytes, before the CRC) of any legal message: a line result of
/// [`MAX_WIDTH`] pixels.
pub const MAX_PAYLOAD_LEN: usize = MAX_WIDTH as usize * PIXEL_WIRE_BYTES + MAX_HEADER_LEN;

/// The longest `RefineLine` mask: one bit per pixel of a [`MAX_WIDTH`] line.
pub const MAX_MASK_LEN: usize = MAX_WIDTH.div_ceil(8) as usize;

/// The largest payload a master sends: a scene chunk, a `Hello` with two names, or a refine
/// request's mask.
pub const MAX_MASTER_PAYLOAD_LEN: usize =
    MAX_HEADER_LEN + max(max(MAX_CHUNK_LEN, 2 * MAX_NAME_LEN), MAX_MASK_LEN);

/// The longest frame on the wire: COBS overhead and the two `0x00` delimiters included.
pub const MAX_FRAME_LEN: usize = frame_len(MAX_PAYLOAD_LEN);

/// The longest frame a master sends; a worker's receive buffer needs no more.
pub const MAX_MASTER_FRAME_LEN: usize = frame_len(MAX_MASTER_PAYLOAD_LEN);

/// The encoded frame length, delimiters included, for a payload of `payload_len` bytes.
pub const fn frame_len(payload_len: usize) -> usize {
    cobs::max_encoding_length(payload_len + CRC_LEN) + 2
}

const fn max(a: usize, b: usize) -> usize {
    if a > b {
        a
    } else {
        b
    }
}
