//! Frames: `0x00`, COBS(payload ‖ CRC-32 little-endian), `0x00`.
//!
//! COBS removes every `0x00` from the encoded bytes, so `0x00` only ever delimits frames: a reader
//! that joins a stream mid-frame, or loses bytes to line noise, drops at most the frame it is in
//! and resynchronises at the next delimiter. The CRC-32 (IEEE) catches bit flips; a frame whose
//! CRC does not match, or whose COBS encoding is broken, is reported as dropped and never decoded.
//! The leading `0x00` ends any garbage the line picked up between frames, so garbage costs no
//! frame. Empty frames (two delimiters in a row) are skipped silently.

use crate::wire::cobs;
use crate::wire::error::ProtocolError;
use crate::wire::{frame_len, CRC_LEN};
use alloc::vec::Vec;
use embedded_io::{Error as _, ErrorKind, ErrorType, Read, Write};
use serde::Serialize;

/// Why a frame was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DroppedFrame {
    /// The CRC did not match or the COBS encoding was broken.
    Corrupt,
    /// The frame did not fit the reader's buffer (no legal frame is that long).
    TooLong,
}

/// What reading from a link can end with, other than a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LinkError {
    /// The peer closed the link (end of stream, or a broken pipe or reset connection).
    Closed,
    /// No data arrived within the link's read timeout; a partial frame is kept.
    TimedOut,
    /// Any other I/O error.
    Io(ErrorKind),
}

impl LinkError {
    /// Classifies an I/O error: closed links and time-outs get their own variants.
    pub fn from_kind(kind: ErrorKind) -> Self {
        match kind {
            ErrorKind::BrokenPipe
            | ErrorKind::ConnectionReset
            | ErrorKind::ConnectionAborted
            | ErrorKind::NotConnected => LinkError::Closed,
            ErrorKind::TimedOut => LinkError::TimedOut,
            other => LinkError::Io(other),
        }
    }
}

fn link_error<E: embedded_io::Error>(e: E) -> LinkError {
    LinkError::from_kind(e.kind())
}

/// One step of [`FrameReader::next`].
#[derive(Debug, PartialEq, Eq)]
pub enum ReadEvent<'a> {
    /// A frame whose CRC matched: its payload (postcard bytes, CRC removed).
    Frame(&'a [u8]),
    /// A frame was dropped.
    Dropped(DroppedFrame),
}

/// Reads frames from a byte stream into a caller-provided buffer, which bounds the frame length.
///
/// The buffer holds bytes read but not yet consumed; a frame is decoded in place, so no other
/// memory is used. A worker gives it [`crate::wire::MAX_MASTER_FRAME_LEN`] bytes, a master
/// [`crate::wire::MAX_FRAME_LEN`].
pub struct FrameReader<B> {
    buf: B,
    /// The current frame starts at `start`; bytes before it are spent.
    start: usize,
    /// Bytes `..filled` of `buf` hold data read from the link.
    filled: usize,
    /// Bytes `start..scanned` are known to contain no delimiter.
    scanned: usize,
    /// Discarding an over-long frame up to the next delimiter.
    skipping: bool,
}

impl<B: AsMut<[u8]>> FrameReader<B> {
    /// A reader that uses `buf` (its whole length) for buffering.
    pub fn new(buf: B) -> Self {
        FrameReader {
            buf,
            start: 0,
            filled: 0,
            scanned: 0,
            skipping: false,
        }
    }

    /// Reads until the next frame ends and returns its payload, or reports a dropped frame.
    ///
    /// # Errors
    /// [`LinkError::Closed`] at the end of the stream (a partial frame is lost),
    /// [`LinkError::TimedOut`] when the link's read timed out (call again; nothing is lost),
    /// [`LinkError::Io`] for other I/O errors.
    pub fn next<R: Read>(&mut self, link: &mut R) -> Result<ReadEvent<'_>, LinkError> {
        loop {
            let buf = self.buf.as_mut();
            if let Some(i) = buf[self.scanned..self.filled].iter().position(|&b| b == 0) {
                let end = self.scanned + i;
                let start = self.start;
                self.start = end + 1;
                self.scanned = end + 1;
                if self.skipping {
                    self.skipping = false;
                    return Ok(ReadEvent::Dropped(DroppedFrame::TooLong));
                }
                if end == start {
                    // An empty frame (two delimiters in a row): nothing to report.
                    continue;
                }
                // A fresh borrow of the buffer for the returned slice only.
                let body = &mut self.buf.as_mut()[start..end];
                return Ok(match decode_frame(body) {
                    Some(n) => ReadEvent::Frame(&body[..n]),
                    None => ReadEvent::Dropped(DroppedFrame::Corrupt),
                });
            }
            // No delimiter in what we have: move the partial frame to the front, read more.
            if self.start > 0 {
                buf.copy_within(self.start..self.filled, 0);
                self.filled -= self.start;
                self.start = 0;
            }
            self.scanned = self.filled;
            if self.filled == buf.len() {
                // No legal frame is this long: drop it up to its delimiter.
                self.skipping = true;
                self.filled = 0;
                self.scanned = 0;
            }
            let n = loop {
                match link.read(&mut buf[self.filled..]) {
                    Ok(n) => break n,
                    Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                    Err(e) => return Err(link_error(e)),
                }
            };
            if n == 0 {
                return Err(LinkError::Closed);
            }
            self.filled += n;
        }
    }
}

/// Decodes a COBS-encoded frame body in place and checks its CRC; returns the payload length.
fn decode_frame(body: &mut [u8]) -> Option<usize> {
    let n = cobs::decode_in_place(body)?;
    let payload_len = n.checked_sub(CRC_LEN)?;
    let (payload, crc) = body[..n].split_at(payload_len);
    let expected = u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]);
    (crc32fast::hash(payload) == expected).then_some(payload_len)
}

/// Encodes messages into frames and writes them; keeps its two buffers between frames.
#[derive(Debug, Default)]
pub struct FrameWriter {
    payload: Vec<u8>,
    frame: Vec<u8>,
}

impl FrameWriter {
    /// A writer with empty buffers (they grow to the largest frame written).
    pub fn new() -> Self {
        FrameWriter::default()
    }

    /// Encodes `msg` into a frame and returns its bytes, delimiters included.
    ///
    /// # Errors
    /// [`ProtocolError::Encode`] if postcard cannot encode the message.
    pub fn encode<T: Serialize>(&mut self, msg: &T) -> Result<&[u8], ProtocolError> {
        self.payload.clear();
        let payload = core::mem::take(&mut self.payload);
        let mut payload = postcard::to_extend(msg, payload).map_err(|_| ProtocolError::Encode)?;
        let crc = crc32fast::hash(&payload);
        payload.extend_from_slice(&crc.to_le_bytes());
        self.frame.clear();
        self.frame.resize(frame_len(payload.len() - CRC_LEN), 0);
        let n = delimit(&payload, &mut self.frame);
        self.frame.truncate(n);
        self.payload = payload;
        Ok(&self.frame)
    }

    /// Encodes `msg` and writes the whole frame to `link`, then flushes it.
    ///
    /// # Errors
    /// [`FrameWriteError::Encode`] if the message cannot be encoded, [`FrameWriteError::Link`]
    /// if the link fails.
    pub fn send<T: Serialize, W: Write>(
        &mut self,
        link: &mut W,
        msg: &T,
    ) -> Result<(), FrameWriteError> {
        let frame = self.encode(msg).map_err(FrameWriteError::Encode)?;
        write_all(link, frame).map_err(FrameWriteError::Link)
    }
}

/// Encodes `msg` into a frame without allocating: `payload` holds the encoding and its CRC,
/// `frame` the frame; returns the frame's bytes, delimiters included. For a panic handler, which
/// cannot count on the heap.
///
/// # Errors
/// [`ProtocolError::Encode`] if the message does not fit `payload` (less [`CRC_LEN`]) or its
/// frame does not fit `frame`.
pub fn encode_into<'f, T: Serialize>(
    msg: &T,
    payload: &mut [u8],
    frame: &'f mut [u8],
) -> Result<&'f [u8], ProtocolError> {
    let room = payload.len().saturating_sub(CRC_LEN);
    let len = postcard::to_slice(msg, &mut payload[..room])
        .map_err(|_| ProtocolError::Encode)?
        .len();
    let crc = crc32fast::hash(&payload[..len]);
    payload[len..len + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
    if frame.len() < frame_len(len) {
        return Err(ProtocolError::Encode);
    }
    let n = delimit(&payload[..len + CRC_LEN], frame);
    Ok(&frame[..n])
}

/// Writes `0x00 | COBS(payload_and_crc) | 0x00` into `frame` (at least [`frame_len`] of the
/// payload long) and returns the frame's length.
fn delimit(payload_and_crc: &[u8], frame: &mut [u8]) -> usize {
    frame[0] = 0;
    let n = cobs::encode(payload_and_crc, &mut frame[1..]);
    frame[n + 1] = 0;
    n + 2
}

/// Why [`FrameWriter::send`] failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameWriteError {
    /// The message could not be encoded.
    Encode(ProtocolError),
    /// The link failed.
    Link(LinkError),
}

/// Writes all of `bytes` and flushes, retrying interrupted writes.
///
/// # Errors
/// The link's error, classified; a write of 0 bytes counts as a closed link.
pub fn write_all<W: Write + ErrorType>(link: &mut W, mut bytes: &[u8]) -> Result<(), LinkError> {
    while !bytes.is_empty() {
        match link.write(bytes) {
            Ok(0) => return Err(LinkError::Closed),
            Ok(n) => bytes = &bytes[n..],
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(link_error(e)),
        }
    }
    link.flush().map_err(link_error)
}
