//! A worker that renders on several threads: the core's session over one link, with its line
//! requests rendered by a pool and its answers written in order.
//!
//! [`serve_threaded`] runs [`strahl_core::worker::serve_with`] on the calling thread, which
//! reads and decodes the master's frames. Its outbox, [`Pool`], numbers every answer in the
//! order the session gives it (a *ticket*). Answers that need no rendering are encoded at once;
//! line requests go to a queue from which `threads` render threads take them, each with its own
//! line buffers. A writer thread writes the answers in ticket order, several frames per system
//! call when several are ready. So the master sees exactly what a one-thread worker would send,
//! in the same order, only sooner: it still learns of a lost request from a later answer, and a
//! `FenceAck` still follows every result asked for before its `Fence`.
//!
//! Requests waiting or rendering are limited ([`Pool`] blocks the session while
//! `QUEUE_PER_THREAD × threads` answers are unwritten), so a master that sends requests faster
//! than they render meets back-pressure on the link, as with a one-thread worker. When the session ends, the
//! requests already read are still answered, as a one-thread worker answers them before it reads
//! on (a write that fails drops the rest), and every thread is joined before
//! [`serve_threaded`] returns.

use embedded_io_adapters::std::FromStd;
use std::collections::VecDeque;
use std::io::{BufWriter, Read, Write};
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use strahl_core::scene::Scene;
use strahl_core::wire::frame::{FrameWriter, LinkError};
use strahl_core::wire::message::WorkerMessage;
use strahl_core::worker::{
    serve_with, LineBuffers, LineRequest, NodeInfo, Outbox, SceneCache, SessionEnd, WorkerError,
};

/// Answers a worker keeps unwritten per render thread before the session waits.
const QUEUE_PER_THREAD: usize = 8;

/// A line request waiting for a render thread.
struct Task {
    ticket: u64,
    scene: Arc<Scene>,
    job: u32,
    line: u32,
    mask: Option<Vec<u8>>,
}

/// What the session, the render threads and the writer share.
#[derive(Default)]
struct Queue {
    /// Requests not yet taken by a render thread.
    tasks: VecDeque<Task>,
    /// Answers from ticket `written` on: a frame, or `None` while its line renders.
    slots: VecDeque<Option<Vec<u8>>>,
    /// Tickets written so far (the ticket of `slots[0]`).
    written: u64,
    /// The session is over: render threads finish the queue and stop, the writer writes every
    /// answer and stops.
    closing: bool,
    /// The first error of a render or writer thread; the session ends with it.
    failed: Option<WorkerError>,
}

struct Shared {
    queue: Mutex<Queue>,
    /// Signalled when a task is queued or the session closes (render threads wait on it).
    work: Condvar,
    /// Signalled when an answer is ready, a frame is written, or the session closes.
    changed: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Queue> {
        // A thread that panicked while holding the lock left the queue consistent (every
        // change is one statement), so the data is still usable.
        self.queue.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Stores the answer for `ticket` and wakes the writer.
    fn fill(&self, ticket: u64, frame: Vec<u8>) {
        let mut q = self.lock();
        if let Some(i) = ticket.checked_sub(q.written) {
            if let Some(slot) = q.slots.get_mut(i as usize) {
                *slot = Some(frame);
            }
        }
        drop(q);
        self.changed.notify_all();
    }

    fn fail(&self, e: WorkerError) {
        let mut q = self.lock();
        q.failed.get_or_insert(e);
        drop(q);
        self.changed.notify_all();
    }
}

/// The outbox of a threaded session: answers numbered in order, lines rendered by the pool.
pub struct Pool<'a> {
    shared: Arc<Shared>,
    writer: FrameWriter,
    limit: usize,
    next_ticket: u64,
    /// Told when the session's handshake is over.
    established: &'a (dyn Fn() + Sync),
}

impl Pool<'_> {
    /// Waits for room in the queue, then gives the next ticket with its slot filled or pending.
    fn push(&mut self, frame: Option<Vec<u8>>, task: Option<Task>) -> Result<(), WorkerError> {
        let mut q = self.shared.lock();
        while q.slots.len() >= self.limit && q.failed.is_none() {
            q = self
                .shared
                .changed
                .wait(q)
                .unwrap_or_else(|e| e.into_inner());
        }
        if let Some(e) = q.failed {
            return Err(e);
        }
        q.slots.push_back(frame);
        let queued_task = task.is_some();
        q.tasks.extend(task);
        self.next_ticket += 1;
        drop(q);
        if queued_task {
            self.shared.work.notify_one();
        } else {
            self.shared.changed.notify_all();
        }
        Ok(())
    }
}

impl<L> Outbox<L> for Pool<'_> {
    fn send(&mut self, _: &mut L, msg: &WorkerMessage<'_>) -> Result<(), WorkerError> {
        let frame = self
            .writer
            .encode(msg)
            .map_err(WorkerError::Encode)?
            .to_vec();
        self.push(Some(frame), None)
    }

    fn render(&mut self, _: &mut L, request: LineRequest<'_>) -> Result<(), WorkerError> {
        let task = Task {
            ticket: self.next_ticket,
            scene: Arc::clone(request.scene),
            job: request.job,
            line: request.line,
            mask: request.mask.map(<[u8]>::to_vec),
        };
        self.push(None, Some(task))
    }

    fn established(&mut self) {
        (self.established)();
    }
}

/// A render thread: takes requests until the session closes.
fn render_loop(shared: &Shared) {
    let mut buffers = LineBuffers::new();
    let mut frames = FrameWriter::new();
    loop {
        let task = {
            let mut q = shared.lock();
            loop {
                if q.failed.is_some() {
                    return;
                }
                if let Some(task) = q.tasks.pop_front() {
                    break task;
                }
                if q.closing {
                    return;
                }
                q = shared.work.wait(q).unwrap_or_else(|e| e.into_inner());
            }
        };
        let request = LineRequest {
            scene: &task.scene,
            job: task.job,
            line: task.line,
            mask: task.mask.as_deref(),
        };
        let frame = buffers
            .answer(request)
            .and_then(|answer| frames.encode(&answer).map_err(WorkerError::Encode));
        match frame {
            Ok(frame) => shared.fill(task.ticket, frame.to_vec()),
            Err(e) => return shared.fail(e),
        }
    }
}

/// The writer thread: writes answers in ticket order, flushing when none is ready, until the
/// session has closed and every answer is written, or a write fails.
fn write_loop<W: Write>(shared: &Shared, writer: W, hang_up: &(dyn Fn() + Sync)) {
    let mut out = BufWriter::with_capacity(1 << 16, writer);
    loop {
        let frame = {
            let mut q = shared.lock();
            loop {
                if let Some(Some(_)) = q.slots.front() {
                    q.written += 1;
                    break q.slots.pop_front().flatten();
                }
                // Nothing ready: what is buffered goes out before waiting.
                if out.buffer().is_empty() {
                    if (q.closing && q.slots.is_empty()) || q.failed.is_some() {
                        return;
                    }
                    q = shared.changed.wait(q).unwrap_or_else(|e| e.into_inner());
                } else {
                    drop(q);
                    if let Err(e) = out.flush() {
                        return write_failed(shared, &e, hang_up);
                    }
                    q = shared.lock();
                }
            }
        };
        shared.changed.notify_all();
        if let Some(frame) = frame {
            if let Err(e) = out.write_all(&frame) {
                return write_failed(shared, &e, hang_up);
            }
        }
    }
}

fn write_failed(shared: &Shared, e: &std::io::Error, hang_up: &(dyn Fn() + Sync)) {
    shared.fail(WorkerError::Link(LinkError::from_kind(e.kind().into())));
    // The session thread may be blocked reading: end the link so it returns.
    hang_up();
}

/// Serves one master like [`strahl_core::worker::serve`], rendering on `threads` threads (0
/// counts as 1): requests are read from `reader`, answers written to `writer` in the order a
/// one-thread worker would give them. `hang_up` ends the link (both directions) when a write
/// fails, so a blocked read returns; `established` is called when the handshake is over
/// ([`Outbox::established`]).
///
/// # Errors
/// As [`strahl_core::worker::serve`].
pub fn serve_threaded<R: Read, W: Write + Send>(
    reader: R,
    writer: W,
    hang_up: &(dyn Fn() + Sync),
    established: &(dyn Fn() + Sync),
    node: &NodeInfo<'_>,
    cache: &mut SceneCache,
    threads: usize,
) -> Result<SessionEnd, WorkerError> {
    let threads = threads.max(1);
    let shared = Arc::new(Shared {
        queue: Mutex::new(Queue::default()),
        work: Condvar::new(),
        changed: Condvar::new(),
    });
    let mut pool = Pool {
        shared: Arc::clone(&shared),
        writer: FrameWriter::new(),
        limit: QUEUE_PER_THREAD * threads,
        next_ticket: 0,
        established,
    };
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| render_loop(&shared));
        }
        s.spawn(|| write_loop(&shared, writer, hang_up));
        let mut link = FromStd::new(reader);
        let outcome = serve_with(&mut link, &mut pool, node, cache);
        shared.lock().closing = true;
        shared.work.notify_all();
        shared.changed.notify_all();
        outcome
    })
}
