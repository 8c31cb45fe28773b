//! Progress on stderr: lines done of all lines, the recent rays per second and the time left.
//!
//! On a terminal it is a bar redrawn in place; when stderr is not a terminal (a batch log) it is
//! a plain line every [`LOG_INTERVAL`]; with `--quiet` it is nothing. The rate and the time
//! left come from the last [`WINDOW`] of the render, not from its start: a render whose lower
//! half is costlier shows its time left growing as it gets there, and waiting for workers
//! does not dilute the rate. Before the first line the time left is not guessed, and while a
//! listening master has no worker the line says so.

use crate::util::units::format_ray_rate;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::collections::VecDeque;
use std::io::IsTerminal as _;
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};
use strahl_core::render::stats::RayCounts;

/// How often the bar redraws (its elapsed time) when no line arrives.
const REDRAW_INTERVAL: Duration = Duration::from_millis(250);

/// How often a progress line is written when stderr is not a terminal.
pub const LOG_INTERVAL: Duration = Duration::from_secs(5);

/// The stretch of the render the rate and the time left are measured over.
pub const WINDOW: Duration = Duration::from_secs(10);

/// Progress of a render, safe to update from many threads.
#[derive(Debug)]
pub struct Progress {
    bar: Option<ProgressBar>,
    /// Plain lines on stderr (not a terminal, not quiet).
    log: bool,
    state: Mutex<State>,
}

#[derive(Debug)]
struct State {
    total: u32,
    done: u32,
    rays: u64,
    /// (when, lines done, rays) at each change, the oldest within [`WINDOW`] of the newest.
    samples: VecDeque<(Instant, u32, u64)>,
    /// Where a listening master waits for workers, and how many are there.
    waiting: Option<(String, usize)>,
    last_log: Instant,
}

impl Progress {
    /// Progress of `lines` image lines: a bar if stderr is a terminal, plain lines if it is not,
    /// nothing if `quiet`.
    pub fn new(lines: u32, quiet: bool) -> Self {
        let terminal = std::io::stderr().is_terminal();
        let bar = (!quiet && terminal).then(|| {
            let bar =
                ProgressBar::with_draw_target(Some(u64::from(lines)), ProgressDrawTarget::stderr());
            let style =
                ProgressStyle::with_template("{elapsed:>4} [{wide_bar}] {pos}/{len} lines, {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> ");
            bar.set_style(style);
            bar.set_message("starting");
            bar.enable_steady_tick(REDRAW_INTERVAL);
            bar
        });
        let now = Instant::now();
        Progress {
            bar,
            log: !quiet && !terminal,
            state: Mutex::new(State {
                total: lines,
                done: 0,
                rays: 0,
                samples: VecDeque::from([(now, 0, 0)]),
                waiting: None,
                last_log: now,
            }),
        }
    }

    /// A progress display that never draws.
    pub fn hidden() -> Self {
        let mut p = Progress::new(0, true);
        p.log = false;
        p
    }

    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Whether a bar is drawn.
    pub fn is_visible(&self) -> bool {
        self.bar.is_some()
    }

    /// The master listens for workers at `address`: until the first line, say so.
    pub fn waiting_on(&self, address: &str) {
        self.lock().waiting = Some((address.to_string(), 0));
        self.show();
    }

    /// `joined` workers are in the session (the master's tick); writes a log line when due.
    pub fn tick(&self, joined: usize) {
        if let Some((_, n)) = &mut self.lock().waiting {
            *n = joined;
        }
        self.show();
    }

    /// Records one finished line that traced `rays`.
    pub fn line_done(&self, rays: RayCounts) {
        {
            let mut s = self.lock();
            s.done += 1;
            s.rays = s.rays.saturating_add(rays.total());
            let sample = (Instant::now(), s.done, s.rays);
            s.samples.push_back(sample);
            while s.samples.len() > 2 && sample.0.duration_since(s.samples[1].0) > WINDOW {
                s.samples.pop_front();
            }
        }
        if let Some(bar) = &self.bar {
            bar.inc(1);
        }
        self.show();
    }

    /// Updates the bar's message, or writes a log line when one is due.
    fn show(&self) {
        let mut s = self.lock();
        let text = s.describe();
        if let Some(bar) = &self.bar {
            bar.set_message(text);
        } else if self.log && s.last_log.elapsed() >= LOG_INTERVAL {
            s.last_log = Instant::now();
            eprintln!("progress: {}/{} lines, {text}", s.done, s.total);
        }
    }

    /// Prints a message line on stderr above the bar (or plainly, when no bar is drawn).
    pub fn println(&self, msg: &str) {
        match &self.bar {
            Some(bar) => bar.println(msg),
            None => eprintln!("{msg}"),
        }
    }

    /// Removes the bar from the terminal, so that the summary line follows a clean prompt.
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

impl State {
    /// The rate and time left, or what the render waits for.
    fn describe(&self) -> String {
        match &self.waiting {
            Some((address, joined)) if self.done == 0 => {
                return format!("waiting for workers on {address}: {joined} joined");
            }
            _ => {}
        }
        let (Some(&(t0, d0, r0)), Some(&(t1, d1, r1))) =
            (self.samples.front(), self.samples.back())
        else {
            return "starting".to_string();
        };
        let secs = t1.duration_since(t0).as_secs_f64();
        if d1 == d0 || secs <= 0.0 {
            return "starting".to_string();
        }
        let rate = format_ray_rate(r1 - r0, secs);
        let per_line = secs / f64::from(d1 - d0);
        let left = per_line * f64::from(self.total.saturating_sub(self.done));
        format!("{rate}, about {} left", format_seconds(left))
    }
}

/// Seconds as `12 s`, `3 min 5 s` or `2 h 10 min`.
pub fn format_seconds(secs: f64) -> String {
    let s = secs.max(0.0).round() as u64;
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {} s", s / 60, s % 60),
        _ => format!("{} h {} min", s / 3600, (s % 3600) / 60),
    }
}

impl Drop for Progress {
    fn drop(&mut self) {
        // An error path must not leave a half-drawn bar in front of the error message.
        self.finish();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quiet_never_draws() {
        let p = Progress::new(10, true);
        assert!(!p.is_visible());
        p.line_done(RayCounts {
            primary: 3,
            shadow: 2,
            reflection: 1,
            ..RayCounts::default()
        });
        assert_eq!(p.lock().rays, 6);
    }

    #[test]
    fn waiting_is_said_until_the_first_line_and_no_time_left_is_guessed() {
        let p = Progress::hidden();
        p.lock().total = 4;
        assert_eq!(p.lock().describe(), "starting");
        p.waiting_on("127.0.0.1:7418");
        p.tick(0);
        assert_eq!(
            p.lock().describe(),
            "waiting for workers on 127.0.0.1:7418: 0 joined"
        );
        p.tick(2);
        assert!(p.lock().describe().ends_with(": 2 joined"));
        std::thread::sleep(Duration::from_millis(20));
        p.line_done(RayCounts {
            primary: 1000,
            ..RayCounts::default()
        });
        let text = p.lock().describe();
        assert!(text.contains("rays/s, about "), "{text}");
    }

    #[test]
    fn time_left_follows_the_recent_lines() {
        let p = Progress::hidden();
        let t = Instant::now();
        let mut s = p.lock();
        s.total = 100;
        s.done = 50;
        // 40 cheap lines long ago, then 10 lines in the last 10 s: 1 s each now.
        s.samples = VecDeque::from([(t, 40, 0), (t + Duration::from_secs(10), 50, 1000)]);
        assert_eq!(s.describe(), "100 rays/s, about 50 s left");
    }

    #[test]
    fn seconds_read_well() {
        assert_eq!(format_seconds(0.4), "0 s");
        assert_eq!(format_seconds(59.4), "59 s");
        assert_eq!(format_seconds(185.0), "3 min 5 s");
        assert_eq!(format_seconds(7800.0), "2 h 10 min");
    }
}
