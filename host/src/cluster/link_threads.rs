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

/// The reader thread: frames from one worker become events until the link closes.
fn read_loop(id: usize, reader: Box<dyn Read + Send>, width: u32, events: &SyncSender<Event>) {
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
            Err(LinkError::Closed) => Event::Closed(id, "the connection closed".to_string()),
            Err(LinkError::Io(kind)) => Event::Closed(id, format!("read error: {kind:?}")),
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
}

impl Outbox {
    fn last_chunk_write(&self) -> Instant {
        *self
            .last_chunk_write
            .lock()
            .unwrap_or_else(|e| e.into_inner())
    }
}

/// How a link ends when its writer thread stops.
struct Ending<'a> {
    /// After the last queued frame (the session is over): the master's side only.
    hang_up: &'a (dyn Fn() + Send + Sync),
    /// After a failed write or when the worker is dropped: the whole link.
    cut: &'a (dyn Fn() + Send + Sync),
}

/// The writer thread: queued frames go out until the queue closes (then the master hangs up its
/// side) or the worker is dropped or a write fails (then the link is cut).
fn write_loop(
    id: usize,
    mut writer: Box<dyn Write + Send>,
    frames: &Receiver<Outgoing>,
    outbox: &Outbox,
    events: &SyncSender<Event>,
    ending: &Ending<'_>,
    done: &Sender<usize>,
) {
    let mut graceful = true;
    for Outgoing { frame, chunk } in frames {
        if outbox.cut.load(Ordering::Relaxed) {
            graceful = false;
            break;
        }
        if let Err(e) = writer.write_all(&frame).and_then(|()| writer.flush()) {
            let _ = events.send(Event::Closed(id, format!("write failed: {e}")));
            graceful = false;
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
    if graceful {
        (ending.hang_up)();
    } else {
        (ending.cut)();
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
        let events = self.events_tx.clone();
        let width = self.width;
        let reader = link.reader;
        let reader_ok = std::thread::Builder::new()
            .name(format!("strahl-rx-{id}"))
            .spawn(move || read_loop(id, reader, width, &events))
            .is_ok();
        let events = self.events_tx.clone();
        let writer = link.writer;
        let hang_up = link.hang_up;
        let thread_closer = Arc::clone(&closer);
        let done = self.writers_done_tx.clone();
        let outbox = Arc::new(Outbox {
            queued: AtomicUsize::new(0),
            last_chunk_write: Mutex::new(Instant::now()),
            cut: AtomicBool::new(false),
        });
        let thread_outbox = Arc::clone(&outbox);
        let writer_ok = std::thread::Builder::new()
            .name(format!("strahl-tx-{id}"))
            .spawn(move || {
                let ending = Ending {
                    hang_up: &*hang_up,
                    cut: &*thread_closer,
                };
                write_loop(id, writer, &rx, &thread_outbox, &events, &ending, &done);
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
