//! The progress bar on stderr: lines done of all lines, rays per second and the time left.
//!
//! It is drawn only when stderr is a terminal and the user did not ask for quiet; otherwise
//! [`Progress`] does nothing, so logs and pipes never see control characters.

use crate::util::units::format_ray_rate;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal as _;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;
use strahl_core::render::stats::RayCounts;

/// How often the bar redraws (its elapsed time and ETA) when no line arrives.
const REDRAW_INTERVAL: Duration = Duration::from_millis(250);

/// Progress of a render, safe to update from many worker threads.
#[derive(Debug)]
pub struct Progress {
    bar: Option<ProgressBar>,
    rays: AtomicU64,
}

impl Progress {
    /// A progress display for `lines` image lines: a bar on stderr if stderr is a terminal and
    /// `quiet` is false, nothing otherwise.
    pub fn new(lines: u32, quiet: bool) -> Self {
        let bar = (!quiet && std::io::stderr().is_terminal()).then(|| {
            let bar =
                ProgressBar::with_draw_target(Some(u64::from(lines)), ProgressDrawTarget::stderr());
            let style = ProgressStyle::with_template(
                "{elapsed:>4} [{wide_bar}] {pos}/{len} lines, {msg}, ETA {eta}",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> ");
            bar.set_style(style);
            bar.set_message("- rays/s");
            bar.enable_steady_tick(REDRAW_INTERVAL);
            bar
        });
        Progress {
            bar,
            rays: AtomicU64::new(0),
        }
    }

    /// A progress display that never draws.
    pub fn hidden() -> Self {
        Progress {
            bar: None,
            rays: AtomicU64::new(0),
        }
    }

    /// Whether a bar is drawn.
    pub fn is_visible(&self) -> bool {
        self.bar.is_some()
    }

    /// Records one finished line that traced `rays`.
    pub fn line_done(&self, rays: RayCounts) {
        let total = self.rays.fetch_add(rays.total(), Ordering::Relaxed) + rays.total();
        if let Some(bar) = &self.bar {
            bar.inc(1);
            bar.set_message(format_ray_rate(total, bar.elapsed().as_secs_f64()));
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
        assert_eq!(p.rays.load(Ordering::Relaxed), 6);
    }
}
