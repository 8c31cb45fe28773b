//! What each worker did in a render: the per-worker table of the end summary.
//!
//! Ray rates are written by [`crate::util::units`], so the cluster does not depend on the
//! interface layer.

use crate::cluster::link::LinkKind;
use crate::util::units::format_rate_short;
use std::fmt;
use std::time::Duration;
use strahl_core::render::stats::RayCounts;

/// One worker's share of a render.
#[derive(Clone, Debug, PartialEq)]
pub struct WorkerReport {
    /// The name it gave in its `Hello` (its address until then).
    pub name: String,
    /// How the master reached it.
    pub address: String,
    /// What carried the link.
    pub kind: LinkKind,
    /// Its architecture, as it said.
    pub arch: String,
    /// Lines it renders at once, as it said (1 until it says).
    pub threads: u32,
    /// Line requests sent to it (a multi-line request counts once).
    pub requests: u32,
    /// Lines asked for in those requests.
    pub requested_lines: u32,
    /// Lines whose result from this worker was the first and was used.
    pub lines: u32,
    /// Results that arrived after another worker's (copies that lost the race).
    pub duplicates: u32,
    /// Rays in the lines it delivered (used or not).
    pub rays: RayCounts,
    /// Time it spent on lines: from each request (or the previous result, if later) to the
    /// result.
    pub busy: Duration,
    /// Lines taken back from it (lost requests or results, or the worker lost) and re-queued.
    pub reissued: u32,
    /// Frames that failed their CRC or checks, in either direction.
    pub frames_dropped: u32,
    /// Its results that another worker's matched byte for byte (`--verify`).
    pub verified: u32,
    /// Why the master stopped using it, if it did before the end.
    pub lost: Option<String>,
}

impl WorkerReport {
    /// An empty report for a worker at `address`.
    pub fn new(address: &str, kind: LinkKind) -> Self {
        WorkerReport {
            name: address.to_string(),
            address: address.to_string(),
            kind,
            arch: String::new(),
            threads: 1,
            requests: 0,
            requested_lines: 0,
            lines: 0,
            duplicates: 0,
            rays: RayCounts::default(),
            busy: Duration::ZERO,
            reissued: 0,
            frames_dropped: 0,
            verified: 0,
            lost: None,
        }
    }
}

/// What a worker is doing now, for a live table.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Activity {
    /// Joined; greeting or loading the scene.
    Joining,
    /// Has lines in flight.
    Busy,
    /// Ready, with nothing to do.
    Idle,
    /// Dropped (the report says why).
    Lost,
}

impl Activity {
    /// The word a table shows.
    pub fn word(self) -> &'static str {
        match self {
            Activity::Joining => "joining",
            Activity::Busy => "busy",
            Activity::Idle => "idle",
            Activity::Lost => "lost",
        }
    }
}

/// A worker's share of a render so far, and what it is doing.
#[derive(Clone, Debug, PartialEq)]
pub struct WorkerState {
    /// What it did so far.
    pub report: WorkerReport,
    /// What it is doing.
    pub activity: Activity,
}

impl WorkerReport {
    /// Lines per request sent to it, on average; `None` if it got none.
    pub fn lines_per_request(&self) -> Option<f64> {
        (self.requests > 0).then(|| f64::from(self.requested_lines) / f64::from(self.requests))
    }
}

/// The widest worker name the table shows in full.
const NAME_WIDTH: usize = 40;

/// The per-worker table printed after a render: one row of 80 columns per worker (wider only
/// for names over 14 characters); a lost worker's reason on an indented line below its row.
pub struct WorkerTable<'a>(pub &'a [WorkerReport]);

impl fmt::Display for WorkerTable<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names = unique_names(self.0);
        let width = names
            .iter()
            .map(|n| n.chars().count())
            .max()
            .unwrap_or(0)
            .clamp(6, NAME_WIDTH);
        writeln!(
            f,
            "{:<width$} {:<6} {:>3} {:>6} {:>4} {:>5} {:>8} {:>8} {:>5} {:>4}  status",
            "worker", "link", "thr", "lines", "dup", "l/req", "rays/s", "/thread", "reiss", "drop"
        )?;
        for (w, name) in self.0.iter().zip(names) {
            let secs = w.busy.as_secs_f64();
            let thread_secs = secs * f64::from(w.threads.max(1));
            writeln!(
                f,
                "{:<width$} {:<6} {:>3} {:>6} {:>4} {:>5} {:>8} {:>8} {:>5} {:>4}  {}",
                truncate(&name, NAME_WIDTH),
                w.kind.to_string(),
                w.threads,
                w.lines,
                w.duplicates,
                w.lines_per_request()
                    .map_or("-".to_string(), |r| format!("{r:.1}")),
                format_rate_short(w.rays.total(), secs),
                format_rate_short(w.rays.total(), thread_secs),
                w.reissued,
                w.frames_dropped,
                if w.lost.is_some() { "lost" } else { "ok" },
            )?;
            if let Some(why) = &w.lost {
                writeln!(f, "    lost: {why}")?;
            }
        }
        let checked: Vec<String> = self
            .0
            .iter()
            .filter(|w| w.verified > 0)
            .map(|w| format!("{} {}", w.name, w.verified))
            .collect();
        if !checked.is_empty() {
            writeln!(
                f,
                "results confirmed by a second worker (--verify): {}",
                checked.join(", ")
            )?;
        }
        Ok(())
    }
}

/// Each worker's name as tables show it: its own where no other worker has it, else
/// `name@address`.
pub fn unique_names(workers: &[WorkerReport]) -> Vec<String> {
    workers
        .iter()
        .map(|w| {
            let shared = workers.iter().filter(|o| o.name == w.name).count() > 1;
            if shared && w.name != w.address {
                format!("{}@{}", w.name, w.address)
            } else {
                w.name.clone()
            }
        })
        .collect()
}

fn truncate(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        let mut t: String = s.chars().take(n - 1).collect();
        t.push('~');
        t
    }
}
