//! The live state of a render that pages watch, and the pages watching it.
//!
//! The master's hooks feed the [`Hub`] (a line's final pixels, the workers' states, the end);
//! it keeps what a page needs to draw the render from scratch (the 8-bit pixels so far of the
//! rectangle the render writes, who rendered each of its lines, progress, the worker table, the
//! status) and passes every change to the pages subscribed as server-sent events. With
//! `--region` the rectangle is the region ([`Shown`]): the hub holds its pixels alone, as the
//! master holds the region's lines alone, and progress counts the lines the render delivers.
//! A page that subscribes gets the whole state first, then the changes, with nothing missed or
//! repeated between the two (both happen under one lock).
//!
//! The render never waits for a page: each page has a queue of [`VIEWER_QUEUE`] events, and a
//! page whose queue is full is dropped (its browser reconnects and gets the state afresh).

use super::events::{self, Event, Settings, Status};
use crate::cluster::master::FinalLine;
use crate::cluster::region::Region;
use crate::cluster::report::WorkerState;
use std::ops::Range;
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

/// What the pages see of a render: the rectangle of a `width`-wide image they draw, and the
/// lines the render delivers (progress counts them). The rectangle's lines are among those.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shown {
    /// The image's width: a line's pixels.
    pub width: u32,
    /// The rectangle drawn: the whole image, or `--region`'s.
    pub rect: Region,
    /// The lines the render delivers, `(first, end)`: the rectangle's, or with adaptive
    /// multisampling every line ([`Region::rendered_lines`]).
    pub lines: (u32, u32),
}

impl Shown {
    /// The whole of a `width × height` image.
    pub fn whole(width: u32, height: u32) -> Shown {
        Shown::part(width, Region::whole(width, height), 0..height)
    }

    /// `rect` of a `width`-wide image, whose render delivers `lines`. The rectangle is cut to
    /// the image's columns and to `lines`.
    pub fn part(width: u32, rect: Region, lines: Range<u32>) -> Shown {
        let (y0, y1) = (rect.y0.max(lines.start), rect.y1.min(lines.end));
        let (x0, x1) = (rect.x0.min(width), rect.x1.min(width));
        Shown {
            width,
            rect: Region {
                x0,
                y0: y0.min(y1),
                x1: x1.max(x0),
                y1,
            },
            lines: (lines.start, lines.end.max(lines.start)),
        }
    }
}

/// The rectangle of one render as far as it has come.
struct Frame {
    shown: Shown,
    /// The rectangle's 8-bit pixels, row by row.
    rgb: Vec<u8>,
    /// The worker of each of the rectangle's lines (`None`: not done, resumed, or the master's
    /// own).
    authors: Vec<Option<usize>>,
    /// Per line delivered ([`Shown::lines`]): whether it is done.
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

    /// A new render begins, of which the pages see `shown`: they clear their canvas.
    pub fn begin(&self, shown: Shown) {
        let mut s = self.lock();
        s.run += 1;
        let frame = Frame::new(shown);
        let begin = frame.begin_event(s.run);
        s.frame = Some(frame);
        s.workers.clear();
        s.status = Status::Rendering;
        s.broadcast(begin);
        let status = Event::Status(&s.status).to_sse();
        s.broadcast(status);
    }

    /// A line's final pixels. A line outside the rectangle counts for progress alone.
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
            out.push(f.begin_event(self.run));
            let rect = f.shown.rect;
            for y in (rect.y0..rect.y1).filter(|&y| f.is_done(y)) {
                out.push(
                    Event::Line {
                        y,
                        worker: f.authors[(y - rect.y0) as usize],
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
            f.done.len() as u32,
            f.rays,
            f.started.elapsed().as_secs_f64(),
        );
        Some(Event::Progress(&progress).to_sse())
    }
}

impl Frame {
    /// Nothing drawn yet of `shown`.
    fn new(shown: Shown) -> Frame {
        let (width, height) = shown.rect.size();
        let (first, end) = shown.lines;
        Frame {
            shown,
            rgb: vec![0; width as usize * height as usize * 3],
            authors: vec![None; height as usize],
            done: vec![false; (end - first) as usize],
            lines_done: 0,
            rays: RayCounts::default(),
            started: Instant::now(),
        }
    }

    /// The event that clears a page's canvas for render `run`.
    fn begin_event(&self, run: u64) -> Arc<str> {
        let rect = self.shown.rect;
        let (width, height) = rect.size();
        Event::Begin {
            run,
            width,
            height,
            left: rect.x0,
            top: rect.y0,
        }
        .to_sse()
    }

    /// Whether image line `y`, one the render delivers, is done.
    fn is_done(&self, y: u32) -> bool {
        let at = y.wrapping_sub(self.shown.lines.0) as usize;
        self.done.get(at).copied().unwrap_or(false)
    }

    /// Puts a final line in: counts it, and keeps the rectangle's part of it. That part's
    /// 8-bit pixels, or `None` for a line of the wrong width, one the render does not deliver,
    /// or one outside the rectangle.
    fn put(&mut self, line: &FinalLine<'_>) -> Option<&[u8]> {
        let Shown {
            width,
            rect,
            lines: (first, _),
        } = self.shown;
        let at = line.y.wrapping_sub(first) as usize;
        if at >= self.done.len() || line.pixels.len() != width as usize {
            return None;
        }
        if !self.done[at] {
            self.done[at] = true;
            self.lines_done += 1;
        }
        self.rays += line.rays;
        if !(rect.y0..rect.y1).contains(&line.y) {
            return None;
        }
        let r = (line.y - rect.y0) as usize;
        self.authors[r] = line.worker;
        let w = rect.size().0 as usize * 3;
        let row = &mut self.rgb[r * w..(r + 1) * w];
        let pixels = &line.pixels[rect.x0 as usize..rect.x1 as usize];
        for (out, p) in row.chunks_exact_mut(3).zip(pixels) {
            out.copy_from_slice(&p.to_rgb8());
        }
        Some(row)
    }

    /// The rectangle's part of image line `y` (one of its lines).
    fn row(&self, y: u32) -> &[u8] {
        let w = self.shown.rect.size().0 as usize * 3;
        let r = (y - self.shown.rect.y0) as usize;
        &self.rgb[r * w..(r + 1) * w]
    }
}
