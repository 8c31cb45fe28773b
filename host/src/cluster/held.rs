//! The outbox of `strahl render`'s in-process workers: answers held back and written together.
//!
//! Every write to an in-process [`pipe`](crate::cluster::pipe) wakes the master's reading
//! thread, a futex wake the worker pays: on SPD's tetra, whose lines take 70 µs, one write per
//! line cost the worker a tenth of its time. [`Held`] encodes each answer as the core's worker
//! loop gives it and writes what it holds when the loop says the master's message is answered
//! ([`Outbox::flush`]), so the lines of one `RenderLines` (about 2 ms of work) go out in one
//! write, in order. An answer that has waited [`HOLD_LIMIT`] goes out with the next line, so
//! the master sees a request of slow lines progress line by line.

use embedded_io::Write;
use std::time::{Duration, Instant};
use strahl_core::wire::frame::{write_all, FrameWriter};
use strahl_core::wire::message::WorkerMessage;
use strahl_core::worker::{LineBuffers, LineRequest, Outbox, WorkerError};

/// The answers [`Inline`](strahl_core::worker::Inline) gives, encoded as they are given and
/// written to the link together when the master's message they answer is done
/// ([`Outbox::flush`]): the lines of one `RenderLines` reach the master in one write, in
/// order, the request's time after the first of them. Answers held for [`HOLD_LIMIT`] go out
/// with the next line: a request of slow lines (`--lines-per-request`) still shows the master
/// its progress line by line, so it never looks hung.
#[derive(Debug)]
pub struct Held {
    writer: FrameWriter,
    buffers: LineBuffers,
    /// The frames given since the last flush, back to back.
    held: Vec<u8>,
    /// When the oldest of them was given.
    since: Option<Instant>,
    /// The clock (`Instant::now`; tests give their own).
    now: fn() -> Instant,
}

impl Default for Held {
    fn default() -> Self {
        Held::with_clock(Instant::now)
    }
}

/// The longest [`Held`] keeps an answer while it renders more lines (the master's requests
/// are about 2 ms of work, `docs/protocol.md`).
pub const HOLD_LIMIT: Duration = Duration::from_millis(50);

impl Held {
    /// An outbox holding nothing, whose time is `now()`.
    pub fn with_clock(now: fn() -> Instant) -> Self {
        Held {
            writer: FrameWriter::new(),
            buffers: LineBuffers::new(),
            held: Vec::new(),
            since: None,
            now,
        }
    }

    /// Writes the held answers if the oldest has waited for [`HOLD_LIMIT`].
    fn release_if_due<L: Write>(&mut self, link: &mut L) -> Result<(), WorkerError> {
        let now = (self.now)();
        if now.saturating_duration_since(*self.since.get_or_insert(now)) >= HOLD_LIMIT {
            return Outbox::flush(self, link);
        }
        Ok(())
    }
}

/// Appends `msg`'s frame, encoded by `writer`, to `held`.
fn hold(
    writer: &mut FrameWriter,
    held: &mut Vec<u8>,
    msg: &WorkerMessage<'_>,
) -> Result<(), WorkerError> {
    held.extend_from_slice(writer.encode(msg).map_err(WorkerError::Encode)?);
    Ok(())
}

impl<L: Write> Outbox<L> for Held {
    fn send(&mut self, link: &mut L, msg: &WorkerMessage<'_>) -> Result<(), WorkerError> {
        hold(&mut self.writer, &mut self.held, msg)?;
        self.release_if_due(link)
    }

    fn render(&mut self, link: &mut L, request: LineRequest<'_>) -> Result<(), WorkerError> {
        let answer = self.buffers.answer(request)?;
        hold(&mut self.writer, &mut self.held, &answer)?;
        self.release_if_due(link)
    }

    fn flush(&mut self, link: &mut L) -> Result<(), WorkerError> {
        self.since = None;
        if self.held.is_empty() {
            return Ok(());
        }
        let written = write_all(link, &self.held);
        self.held.clear();
        written.map_err(WorkerError::Link)
    }
}
