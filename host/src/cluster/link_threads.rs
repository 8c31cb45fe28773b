//! The link threads, the master's I/O: for each worker a reader thread (frames in, decoded and
//! checked, as [`Event`]s on one channel) and a writer thread (frames out, from a queue), so
//! the master's loop never blocks on a slow or dead peer. The events wait in a bounded queue
//! ([`EVENT_QUEUE`]). [`Links`] owns the queues and is the
//! [`Wire`] over which the [`session`](crate::cluster::session) talks.

use crate::cluster::link::Link;
use crate::cluster::session::{Event, Incoming, Wire};
use embedded_io_adapters::std::FromStd;
use std::collections::HashSet;
use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use strahl_core::render::pixel::Pixel;
use strahl_core::wire::frame::{FrameReader, FrameWriter, LinkError, ReadEvent};
use strahl_core::wire::message::{decode_pixels, Hello, MasterMessage, WorkerMessage};
use strahl_core::wire::{frame_len, MAX_HEADER_LEN, PIXEL_WIRE_BYTES};

/// Turns a decoded message into an [`Incoming`]; `None` if its pixels are not one line. (The
/// field-by-field copy is the price of owning the data; `tests/tests/protocol_worker.rs` has a
/// similar one for its own owned type.)
fn incoming(msg: WorkerMessage<'_>, width: u32) -> Option<Incoming> {
    Some(match msg {
        WorkerMessage::Hello(Hello {
            version,
            name,
            arch,
            threads,
            nonce,
            proof,
            ..
        }) => Incoming::Hello {
            version,
            name: name.to_string(),
            arch: arch.to_string(),
            threads,
            nonce,
            proof,
        },
        WorkerMessage::NeedScene {
            job,
            offset,
            restart,
        } => Incoming::NeedScene {
            job,
            offset,
            restart,
        },
        WorkerMessage::Ready { job } => Incoming::Ready { job },
        WorkerMessage::LineResult {
            job,
            line,
            refined,
            rays,
            pixels,
        } => {
            let mut out = vec![Pixel::default(); width as usize];
            decode_pixels(pixels, &mut out).ok()?;
            Incoming::Line {
                job,
                line,
                refined,
                rays,
                pixels: out,
            }
        }
        WorkerMessage::FenceAck { seq } => Incoming::FenceAck { seq },
        WorkerMessage::Dropped { .. } => Incoming::Dropped,
        WorkerMessage::Refused { job, reason } => Incoming::Refused { job, reason },
        WorkerMessage::Panicked { message } => Incoming::Panicked {
            message: message.to_string(),
        },
    })
}

/// The reader thread: frames from one worker become events until the link closes. It alone
/// reports the link closed, so that whatever the worker sent before the link failed is passed
/// on first, also where a write found the link broken ([`write_loop`]).
fn read_loop(
    id: usize,
    reader: Box<dyn Read + Send>,
    width: u32,
    outbox: &Outbox,
    events: &SyncSender<Event>,
) {
    let mut link = FromStd::new(reader);
    let mut frames = FrameReader::new(vec![
        0u8;
        frame_len(
            width as usize * PIXEL_WIRE_BYTES + MAX_HEADER_LEN
        )
    ]);
    loop {
        let event = match frames.next(&mut link) {
            Ok(ReadEvent::Frame(payload)) => match WorkerMessage::decode(payload)
                .ok()
                .and_then(|m| incoming(m, width))
            {
                Some(msg) => Event::Message(id, msg),
                None => Event::BadFrame(id),
            },
            Ok(ReadEvent::Dropped(_)) => Event::BadFrame(id),
            Err(LinkError::TimedOut) => continue,
            Err(LinkError::Closed) => Event::Closed(id, outbox.why_closed("the connection closed")),
            Err(LinkError::Io(kind)) => {
                Event::Closed(id, outbox.why_closed(&format!("read error: {kind:?}")))
            }
        };
        let last = matches!(event, Event::Closed(..));
        if events.send(event).is_err() || last {
            return;
        }
    }
}

/// Events the link threads may have waiting for the master loop at once. A reader that finds
/// the queue full waits, and so reads no more from its link: a peer that sends faster than the
/// master takes its frames (a flood of small bad frames, say) is slowed by its own connection
/// instead of growing the master's memory.
pub(crate) const EVENT_QUEUE: usize = 4096;

/// A frame for the writer thread.
#[derive(Debug)]
struct Outgoing {
    frame: Vec<u8>,
    /// A scene chunk (its progress on the wire keeps a loading worker from timing out).
    chunk: bool,
}

/// What the master and a writer thread share about one link's outgoing frames.
#[derive(Debug)]
struct Outbox {
    /// Bytes queued and not yet written.
    queued: AtomicUsize,
    /// When the writer last finished writing a scene chunk (or the link was set up).
    last_chunk_write: Mutex<Instant>,
    /// Set when the worker is dropped: the writer stops at the next frame.
    cut: AtomicBool,
    /// Why a write failed, for the reader to report when the link ends.
    write_error: Mutex<Option<String>>,
}

impl Outbox {
    /// Why the link ended: a failed write's error if there was one (the read that ended then
    /// only followed from it), else `read`.
    fn why_closed(&self, read: &str) -> String {
        let failed = self.write_error.lock().unwrap_or_else(|e| e.into_inner());
        failed.clone().unwrap_or_else(|| read.to_string())
    }

    fn last_chunk_write(&self) -> Instant {
        *self
            .last_chunk_write
            .lock()
            .unwrap_or_else(|e| e.into_inner())
    }
}

/// How a link ends when its writer thread stops.
struct Ending<'a> {
    /// After the last queued frame (the session is over) or a failed write: the master's side
    /// only.
    hang_up: &'a (dyn Fn() + Send + Sync),
    /// When the worker is dropped: the whole link.
    cut: &'a (dyn Fn() + Send + Sync),
}

/// The writer thread: queued frames go out until the queue closes or a write fails (then the
/// master hangs up its side) or the worker is dropped (then the link is cut).
///
/// A failed write is not reported here but kept for the reader, which reports the link closed
/// when its reads end (a broken link's reads end too: at once over TCP and in-process pipes, at
/// the next read time-out on a serial port, as the hang-up closes its reader). Reported here,
/// the loss could overtake line results the reader had still to pass on, and those were lost
/// with the link (`cut_connection_loses_the_worker_and_the_image_is_complete` in
/// `host/tests/cli_tcp.rs` saw it under load).
fn write_loop(
    id: usize,
    mut writer: Box<dyn Write + Send>,
    frames: &Receiver<Outgoing>,
    outbox: &Outbox,
    ending: &Ending<'_>,
    done: &Sender<usize>,
) {
    let mut dropped = false;
    for Outgoing { frame, chunk } in frames {
        if outbox.cut.load(Ordering::Relaxed) {
            dropped = true;
            break;
        }
        if let Err(e) = writer.write_all(&frame).and_then(|()| writer.flush()) {
            *outbox.write_error.lock().unwrap_or_else(|e| e.into_inner()) =
                Some(format!("write failed: {e}"));
            break;
        }
        outbox.queued.fetch_sub(frame.len(), Ordering::Relaxed);
        if chunk {
            *outbox
                .last_chunk_write
                .lock()
                .unwrap_or_else(|e| e.into_inner()) = Instant::now();
        }
    }
    if dropped {
        (ending.cut)();
    } else {
        (ending.hang_up)();
    }
    let _ = done.send(id);
}

/// The master's side of one worker's link threads.
struct LinkEnd {
    /// The writer's queue; `None` once closed (the writer sends what is queued, then ends).
    tx: Option<Sender<Outgoing>>,
    outbox: Arc<Outbox>,
    closer: Arc<dyn Fn() + Send + Sync>,
}

/// Every worker's link threads, and the channels they report on.
pub(crate) struct Links {
    ends: Vec<LinkEnd>,
    width: u32,
    frames: FrameWriter,
    events_tx: SyncSender<Event>,
    /// Writer threads report here when they have sent everything and ended their link.
    writers_done_tx: Sender<usize>,
    writers_done: Receiver<usize>,
}

impl Links {
    /// No links yet, for lines `width` pixels wide; the receiver gets every link's events.
    pub(crate) fn new(width: u32) -> (Links, Receiver<Event>) {
        let (events_tx, events) = mpsc::sync_channel(EVENT_QUEUE);
        let (writers_done_tx, writers_done) = mpsc::channel();
        let links = Links {
            ends: Vec::new(),
            width,
            frames: FrameWriter::new(),
            events_tx,
            writers_done_tx,
            writers_done,
        };
        (links, events)
    }

    /// Starts the threads of `link`, whose events carry the next number. Returns whether both
    /// threads started (if not, the link is to be cut).
    pub(crate) fn add(&mut self, link: Link) -> bool {
        let id = self.ends.len();
        let (tx, rx) = mpsc::channel::<Outgoing>();
        let closer: Arc<dyn Fn() + Send + Sync> = Arc::from(link.closer);
        let outbox = Arc::new(Outbox {
            queued: AtomicUsize::new(0),
            last_chunk_write: Mutex::new(Instant::now()),
            cut: AtomicBool::new(false),
            write_error: Mutex::new(None),
        });
        let events = self.events_tx.clone();
        let width = self.width;
        let reader = link.reader;
        let reader_outbox = Arc::clone(&outbox);
        let reader_ok = std::thread::Builder::new()
            .name(format!("strahl-rx-{id}"))
            .spawn(move || read_loop(id, reader, width, &reader_outbox, &events))
            .is_ok();
        let writer = link.writer;
        let hang_up = link.hang_up;
        let thread_closer = Arc::clone(&closer);
        let done = self.writers_done_tx.clone();
        let thread_outbox = Arc::clone(&outbox);
        let writer_ok = std::thread::Builder::new()
            .name(format!("strahl-tx-{id}"))
            .spawn(move || {
                let ending = Ending {
                    hang_up: &*hang_up,
                    cut: &*thread_closer,
                };
                write_loop(id, writer, &rx, &thread_outbox, &ending, &done);
            })
            .is_ok();
        self.ends.push(LinkEnd {
            tx: Some(tx),
            outbox,
            closer,
        });
        reader_ok && writer_ok
    }

    /// Whether worker `id`'s link was cut (its writer stops without sending what is queued).
    pub(crate) fn is_cut(&self, id: usize) -> bool {
        self.ends[id].outbox.cut.load(Ordering::Relaxed)
    }

    /// Waits until `deadline` for the writers of `live` links to finish; returns those that
    /// did (a writer stuck on a dead link is not waited for past it).
    pub(crate) fn wait_for_writers(
        &self,
        live: &HashSet<usize>,
        deadline: Instant,
    ) -> HashSet<usize> {
        let mut finished = HashSet::new();
        while finished.len() < live.len() {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.writers_done.recv_timeout(left) {
                Ok(id) => {
                    if live.contains(&id) {
                        finished.insert(id);
                    }
                }
                Err(_) => break,
            }
        }
        finished
    }
}

impl Wire for Links {
    fn send(&mut self, id: usize, msg: &MasterMessage<'_>) {
        let Ok(frame) = self.frames.encode(msg) else {
            return;
        };
        let frame = frame.to_vec();
        let chunk = matches!(msg, MasterMessage::SceneChunk { .. });
        let end = &self.ends[id];
        if let Some(tx) = &end.tx {
            end.outbox.queued.fetch_add(frame.len(), Ordering::Relaxed);
            // A closed queue means the writer already reported the link closed.
            let _ = tx.send(Outgoing { frame, chunk });
        }
    }

    fn queued(&self, id: usize) -> usize {
        self.ends[id].outbox.queued.load(Ordering::Relaxed)
    }

    fn last_chunk_write(&self, id: usize) -> Instant {
        self.ends[id].outbox.last_chunk_write()
    }

    fn close(&mut self, id: usize) {
        // Closing the queue lets the writer send what is queued, then hang up.
        self.ends[id].tx = None;
    }

    fn cut(&mut self, id: usize) {
        let end = &mut self.ends[id];
        end.tx = None;
        end.outbox.cut.store(true, Ordering::Relaxed);
        (end.closer)();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cluster::link::LinkKind;
    use std::io;
    use std::sync::mpsc::RecvTimeoutError;
    use std::time::Duration;
    use strahl_core::wire::frame::FrameWriter;

    /// A link whose writes fail and whose reader holds one frame back until the writer thread
    /// has ended the link (hung up or cut it): a worker's answer still unread when the master
    /// found the link broken.
    fn broken_link(answer: Vec<u8>) -> Link {
        let (ended_tx, ended) = mpsc::channel::<()>();
        let cut_tx = ended_tx.clone();
        struct Failing;
        impl Write for Failing {
            fn write(&mut self, _: &[u8]) -> io::Result<usize> {
                Err(io::ErrorKind::BrokenPipe.into())
            }
            fn flush(&mut self) -> io::Result<()> {
                Ok(())
            }
        }
        struct Held {
            ended: Option<Receiver<()>>,
            answer: io::Cursor<Vec<u8>>,
        }
        impl Read for Held {
            fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
                // Ten seconds at most: the test fails on the missing event, not by hanging.
                if let Some(ended) = self.ended.take() {
                    let _ = ended.recv_timeout(Duration::from_secs(10));
                }
                self.answer.read(buf)
            }
        }
        Link {
            address: "broken".into(),
            kind: LinkKind::InProcess,
            reader: Box::new(Held {
                ended: Some(ended),
                answer: io::Cursor::new(answer),
            }),
            writer: Box::new(Failing),
            closer: Box::new(move || {
                let _ = cut_tx.send(());
            }),
            hang_up: Box::new(move || {
                let _ = ended_tx.send(());
            }),
        }
    }

    #[test]
    fn what_the_worker_sent_before_a_write_failed_comes_before_the_loss() {
        let answer = FrameWriter::new()
            .encode(&WorkerMessage::FenceAck { seq: 7 })
            .map(<[u8]>::to_vec)
            .expect("a fence's answer encodes");
        let (mut links, events) = Links::new(4);
        assert!(links.add(broken_link(answer)));
        links.send(0, &MasterMessage::Fence { seq: 7 });
        let next = || match events.recv_timeout(Duration::from_secs(20)) {
            Ok(event) => event,
            Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => {
                panic!("no event from the link threads")
            }
        };
        let first = next();
        assert!(
            matches!(first, Event::Message(0, Incoming::FenceAck { seq: 7 })),
            "the answer must come first, got {first:?}"
        );
        let second = next();
        let Event::Closed(0, reason) = second else {
            panic!("then the link's loss, got {second:?}");
        };
        assert!(reason.starts_with("write failed: "), "{reason}");
    }
}
