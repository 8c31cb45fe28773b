//! The live state of a render that pages watch, and the pages watching it.
//!
//! The master's hooks feed the [`Hub`] (a line's final pixels, the workers' states, the end);
//! it keeps what a page needs to draw the render from scratch (the 8-bit image so far, who
//! rendered each line, progress, the worker table, the status) and passes every change to the
//! pages subscribed as server-sent events. A page that subscribes gets the whole state first,
//! then the changes, with nothing missed or repeated between the two (both happen under one
//! lock).
//!
//! The render never waits for a page: each page has a queue of [`VIEWER_QUEUE`] events, and a
//! page whose queue is full is dropped (its browser reconnects and gets the state afresh).

use super::events::{self, Event, Settings, Status};
use crate::cluster::master::FinalLine;
use crate::cluster::report::WorkerState;
use std::sync::mpsc::{sync_channel, Receiver, SyncSender, TrySendError};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;
use strahl_core::render::stats::RayCounts;

/// Events that may wait for one page before it is dropped.
pub const VIEWER_QUEUE: usize = 4096;

/// The most pages watching at once; more are refused (HTTP 503).
pub const MAX_VIEWERS: usize = 64;

/// A new page's events: those that draw the state now, and the queue of the changes after.
pub type Subscription = (Vec<Arc<str>>, Receiver<Arc<str>>);

/// The shared state of the view (see the module doc).
#[derive(Default)]
pub struct Hub {
    state: Mutex<State>,
}

#[derive(Default)]
struct State {
    /// Renders begun so far; a page draws the latest.
    run: u64,
    frame: Option<Frame>,
    status: Status,
    workers: Vec<WorkerState>,
    /// The settings form of `strahl view` (absent for `strahl render --view`).
    settings: Option<Settings>,
    viewers: Vec<SyncSender<Arc<str>>>,
}

/// The image of one render as far as it has come.
struct Frame {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
    /// The worker of each line (`None`: not done, resumed, or the master's own).
    authors: Vec<Option<usize>>,
    done: Vec<bool>,
    lines_done: u32,
    rays: RayCounts,
    started: Instant,
}

impl Hub {
    /// A hub with no render yet.
    pub fn new() -> Arc<Hub> {
        Arc::new(Hub::default())
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        // A panic elsewhere cannot leave the state half-changed in a way a page could not draw.
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Sets the form `strahl view` shows and tells the pages.
    pub fn set_settings(&self, settings: Settings) {
        let mut s = self.lock();
        let event = Event::Settings(&settings).to_sse();
        s.settings = Some(settings);
        s.broadcast(event);
    }

    /// A new render of `width × height` begins: the pages clear their canvas.
    pub fn begin(&self, width: u32, height: u32) {
        let mut s = self.lock();
        s.run += 1;
        let pixels = width as usize * height as usize;
        s.frame = Some(Frame {
            width,
            height,
            rgb: vec![0; pixels * 3],
            authors: vec![None; height as usize],
            done: vec![false; height as usize],
            lines_done: 0,
            rays: RayCounts::default(),
            started: Instant::now(),
        });
        s.workers.clear();
        s.status = Status::Rendering;
        let begin = Event::Begin {
            run: s.run,
            width,
            height,
        }
        .to_sse();
        s.broadcast(begin);
        let status = Event::Status(&s.status).to_sse();
        s.broadcast(status);
    }

    /// A line's final pixels.
    pub fn line(&self, line: &FinalLine<'_>) {
        let mut s = self.lock();
        let Some(frame) = s.frame.as_mut() else {
            return;
        };
        let Some(rgb) = frame.put(line) else {
            return;
        };
        let event = Event::Line {
            y: line.y,
            worker: line.worker,
            rgb,
        }
        .to_sse();
        s.broadcast(event);
    }

    /// The workers' states (the master's tick): the pages update their table and progress.
    pub fn workers(&self, workers: &[WorkerState]) {
        let mut s = self.lock();
        s.workers = workers.to_vec();
        let table = Event::Workers(&s.workers).to_sse();
        s.broadcast(table);
        if let Some(progress) = s.progress_event() {
            s.broadcast(progress);
        }
    }

    /// The render ended (or could not start): the pages show `status`.
    pub fn end(&self, status: Status) {
        let mut s = self.lock();
        s.status = status;
        if let Some(progress) = s.progress_event() {
            s.broadcast(progress);
        }
        let event = Event::Status(&s.status).to_sse();
        s.broadcast(event);
    }

    /// The status now.
    pub fn status(&self) -> Status {
        self.lock().status.clone()
    }

    /// Subscribes a page: the events that draw the state now, and the queue of the changes
    /// that follow. `None` when [`MAX_VIEWERS`] pages watch already.
    pub fn subscribe(&self) -> Option<Subscription> {
        let mut s = self.lock();
        s.viewers
            .retain(|v| v.try_send(Arc::from(": ping\n\n")).is_ok());
        if s.viewers.len() >= MAX_VIEWERS {
            return None;
        }
        let (tx, rx) = sync_channel(VIEWER_QUEUE);
        s.viewers.push(tx);
        Some((s.snapshot(), rx))
    }

    /// Pages watching now.
    pub fn viewers(&self) -> usize {
        self.lock().viewers.len()
    }
}

impl State {
    /// Sends `event` to every page; drops a page whose queue is full or whose connection ended.
    fn broadcast(&mut self, event: Arc<str>) {
        self.viewers
            .retain(|v| match v.try_send(Arc::clone(&event)) {
                Ok(()) => true,
                Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => false,
            });
    }

    /// The events that draw the state from scratch.
    fn snapshot(&self) -> Vec<Arc<str>> {
        let mut out = Vec::new();
        if let Some(settings) = &self.settings {
            out.push(Event::Settings(settings).to_sse());
        }
        if let Some(f) = &self.frame {
            out.push(
                Event::Begin {
                    run: self.run,
                    width: f.width,
                    height: f.height,
                }
                .to_sse(),
            );
            for y in (0..f.height).filter(|&y| f.done[y as usize]) {
                out.push(
                    Event::Line {
                        y,
                        worker: f.authors[y as usize],
                        rgb: f.row(y),
                    }
                    .to_sse(),
                );
            }
        }
        out.push(Event::Workers(&self.workers).to_sse());
        out.extend(self.progress_event());
        out.push(Event::Status(&self.status).to_sse());
        out
    }

    fn progress_event(&self) -> Option<Arc<str>> {
        let f = self.frame.as_ref()?;
        let progress = events::Progress::new(
            f.lines_done,
            f.height,
            f.rays,
            f.started.elapsed().as_secs_f64(),
        );
        Some(Event::Progress(&progress).to_sse())
    }
}

impl Frame {
    /// Puts a final line in; its 8-bit pixels, or `None` for a line outside the image.
    fn put(&mut self, line: &FinalLine<'_>) -> Option<&[u8]> {
        let y = line.y as usize;
        let w = self.width as usize;
        if y >= self.height as usize || line.pixels.len() != w {
            return None;
        }
        let row = &mut self.rgb[y * w * 3..(y + 1) * w * 3];
        for (out, p) in row.chunks_exact_mut(3).zip(line.pixels) {
            out.copy_from_slice(&p.to_rgb8());
        }
        if !self.done[y] {
            self.done[y] = true;
            self.lines_done += 1;
        }
        self.authors[y] = line.worker;
        self.rays += line.rays;
        Some(row)
    }

    fn row(&self, y: u32) -> &[u8] {
        let w = self.width as usize * 3;
        &self.rgb[y as usize * w..(y as usize + 1) * w]
    }
}
