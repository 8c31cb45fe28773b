//! What the view tells its pages, as server-sent events: one [`Event`] per change, each a JSON
//! object under an event name the page's script listens for (`docs/view.md` lists them).

use crate::cluster::report::WorkerState;
use base64::Engine as _;
use serde::{Deserialize, Serialize};
use std::sync::Arc;
use strahl_core::render::stats::RayCounts;

/// One change the pages are told about.
pub enum Event<'a> {
    /// A new render begins: clear the canvas, which shows the rectangle of the image the
    /// render writes (all of it but for `--region`).
    Begin {
        /// Which render (a page ignores lines of an older one).
        run: u64,
        /// The rectangle's width in pixels.
        width: u32,
        /// The rectangle's height in pixels.
        height: u32,
        /// The image column of the rectangle's left side.
        left: u32,
        /// The image line of the rectangle's top.
        top: u32,
    },
    /// A line's final pixels, 8-bit RGB as in the image file.
    Line {
        /// The image line, from the image's top.
        y: u32,
        /// The worker that rendered it (its row in the table), if any.
        worker: Option<usize>,
        /// The rectangle's part of the line: its `width × 3` bytes.
        rgb: &'a [u8],
    },
    /// Lines done, rays, time.
    Progress(&'a Progress),
    /// The worker table.
    Workers(&'a [WorkerState]),
    /// What the render is doing.
    Status(&'a Status),
    /// The settings form (`strahl view`).
    Settings(&'a Settings),
}

impl Event<'_> {
    /// The event as the text of a server-sent event.
    pub fn to_sse(&self) -> Arc<str> {
        let (name, data) = match self {
            Event::Begin {
                run,
                width,
                height,
                left,
                top,
            } => (
                "begin",
                serde_json::json!({
                    "run": run, "width": width, "height": height, "left": left, "top": top,
                }),
            ),
            Event::Line { y, worker, rgb } => (
                "line",
                serde_json::json!({
                    "y": y,
                    "worker": worker,
                    "rgb": base64::engine::general_purpose::STANDARD.encode(rgb),
                }),
            ),
            Event::Progress(p) => ("progress", serde_json::json!(p)),
            Event::Workers(w) => ("workers", workers_json(w)),
            Event::Status(s) => ("status", serde_json::json!(s)),
            Event::Settings(s) => ("settings", serde_json::json!(s)),
        };
        Arc::from(format!("event: {name}\ndata: {data}\n\n"))
    }
}

/// The worker table as JSON rows.
fn workers_json(workers: &[WorkerState]) -> serde_json::Value {
    let rows: Vec<serde_json::Value> = workers
        .iter()
        .map(|w| {
            let r = &w.report;
            let secs = r.busy.as_secs_f64();
            serde_json::json!({
                "name": r.name,
                "address": r.address,
                "link": r.kind.to_string(),
                "threads": r.threads,
                "lines": r.lines,
                "rays": r.rays.total(),
                "rays_per_second": if secs > 0.0 { r.rays.total() as f64 / secs } else { 0.0 },
                "state": w.activity.word(),
                "reissued": r.reissued,
                "dropped": r.frames_dropped,
                "lost": r.lost,
            })
        })
        .collect();
    serde_json::Value::Array(rows)
}

/// How far a render has come.
#[derive(Clone, Debug, Serialize)]
pub struct Progress {
    /// Lines whose final pixels are in.
    pub done: u32,
    /// Lines in the image.
    pub total: u32,
    /// Rays of those lines, by kind.
    pub rays: RayCounts,
    /// Seconds since the render began.
    pub seconds: f64,
    /// Rays per second so far.
    pub rays_per_second: f64,
    /// Seconds left at the rate so far (`None` before the first line).
    pub seconds_left: Option<f64>,
}

impl Progress {
    /// The progress of `done` of `total` lines, `rays` traced in `seconds`.
    pub fn new(done: u32, total: u32, rays: RayCounts, seconds: f64) -> Self {
        let rays_per_second = if seconds > 0.0 {
            rays.total() as f64 / seconds
        } else {
            0.0
        };
        let seconds_left =
            (done > 0).then(|| seconds * f64::from(total.saturating_sub(done)) / f64::from(done));
        Progress {
            done,
            total,
            rays,
            seconds,
            rays_per_second,
            seconds_left,
        }
    }
}

/// What the render is doing, as the page shows it.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
#[serde(tag = "state", rename_all = "lowercase")]
pub enum Status {
    /// Nothing started yet (`strahl view` before Start).
    #[default]
    Idle,
    /// Rendering.
    Rendering,
    /// Finished; the image is written to `output` and can be downloaded.
    Done {
        /// The image file.
        output: String,
    },
    /// Stopped from the page (or Ctrl-C) with `finished` of `total` lines; Resume goes on.
    Stopped {
        /// Lines kept.
        finished: u32,
        /// Lines in the image.
        total: u32,
    },
    /// Failed, with the error in words.
    Failed {
        /// What went wrong.
        message: String,
    },
}

/// The settings `strahl view`'s form shows and sends back with Start.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Settings {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Shadows on.
    pub shadows: bool,
    /// Reflections on.
    pub reflections: bool,
    /// Samples per pixel side.
    pub multisample: u32,
    /// Adaptive multisampling threshold (`None`: every pixel).
    pub aa_threshold: Option<f32>,
    /// Bounce depth cap.
    pub max_depth: u32,
    /// Ambient-occlusion level.
    pub ambient_occlusion: u32,
    /// In-process workers.
    pub workers: u32,
    /// TCP workers, `HOST[:PORT]` each.
    pub tcp_workers: Vec<String>,
}
