//! Which line goes to which worker: the bookkeeping of the master, with no I/O and no clock.
//!
//! Lines wait in a queue, top to bottom. A worker with room in its window takes the next waiting
//! line. When none is waiting, an idle worker gets a copy of a line still in flight (the one with
//! the fewest holders, then the lowest number), so one slow or dead worker cannot hold up the end
//! of the image; the first result wins ([`LineScheduler::complete`] says whether it was first).
//! A line given up by its last holder (worker lost, request lost) goes back to the front of the
//! queue. The simulated cluster's discrete-event model drives this same type.
//!
//! The master schedules [`Task`]s: with adaptive multisampling each line has two, its first
//! pass and its second, which is queued only once the first passes of the line and its
//! neighbours are in (or finished at once when no pixel needs it). The scheduler numbers them
//! ([`Task::index`]).

use std::collections::VecDeque;
use std::ops::Range;

/// What a worker is asked to do for one line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Task {
    /// The line's (first) pass: `RenderLine`, answered by a `LineResult` not marked refined.
    Line(u32),
    /// Adaptive multisampling's second pass of the line: `RefineLine`, answered by a
    /// `LineResult` marked refined.
    Refine(u32),
}

impl Task {
    /// The task a `LineResult` for `line` answers, `refined` or not.
    pub fn from_wire(line: u32, refined: bool) -> Task {
        if refined {
            Task::Refine(line)
        } else {
            Task::Line(line)
        }
    }

    /// The task's number in the [`LineScheduler`] of an image `height` lines high: first passes
    /// are `0..height`, second passes `height..2 × height`. This and [`Task::from_index`] are
    /// the one place that numbering is written.
    pub fn index(self, height: u32) -> u32 {
        match self {
            Task::Line(y) => y,
            Task::Refine(y) => height + y,
        }
    }

    /// The task numbered `index` in an image `height` lines high ([`Task::index`]).
    pub fn from_index(index: u32, height: u32) -> Task {
        match index.checked_sub(height) {
            Some(y) => Task::Refine(y),
            None => Task::Line(index),
        }
    }
}

/// The state of every line of one image.
#[derive(Clone, Debug)]
pub struct LineScheduler {
    /// Workers currently holding each line (a request is out).
    holders: Vec<u32>,
    done: Vec<bool>,
    waiting: VecDeque<u32>,
    finished: u32,
}

impl LineScheduler {
    /// A scheduler for `height` lines, all waiting.
    pub fn new(height: u32) -> Self {
        LineScheduler {
            holders: vec![0; height as usize],
            done: vec![false; height as usize],
            waiting: (0..height).collect(),
            finished: 0,
        }
    }

    /// A scheduler for the `lines` of an image `height` lines high, all waiting; the others
    /// count as done (`--region`).
    pub fn for_lines(height: u32, lines: Range<u32>) -> Self {
        let lines = lines.start.min(height)..lines.end.min(height);
        LineScheduler {
            holders: vec![0; height as usize],
            done: (0..height).map(|y| !lines.contains(&y)).collect(),
            finished: height - lines.len() as u32,
            waiting: lines.collect(),
        }
    }

    /// A scheduler for `total` tasks of which only the first `waiting` wait from the start; the
    /// others wait once [`LineScheduler::queue`]d (adaptive multisampling's second passes,
    /// which need their neighbours' first passes).
    pub fn with_pending(total: u32, waiting: u32) -> Self {
        LineScheduler {
            holders: vec![0; total as usize],
            done: vec![false; total as usize],
            waiting: (0..waiting.min(total)).collect(),
            finished: 0,
        }
    }

    /// Puts a pending task at the back of the queue.
    pub fn queue(&mut self, task: u32) {
        if !self.is_done(task) {
            self.waiting.push_back(task);
        }
    }

    /// Lines whose result has arrived.
    pub fn finished(&self) -> u32 {
        self.finished
    }

    /// Whether every line has its result.
    pub fn is_complete(&self) -> bool {
        self.finished as usize == self.done.len()
    }

    /// Whether line `line` has its result.
    pub fn is_done(&self, line: u32) -> bool {
        self.done.get(line as usize).copied().unwrap_or(false)
    }

    /// Takes the next waiting line, if any, for a worker.
    pub fn next_waiting(&mut self) -> Option<u32> {
        self.next_waiting_except(|_| false)
    }

    /// Takes the first waiting line that is not `excluded` for this worker (a line whose first
    /// result it gave, waiting for another worker's to check it); the others keep their place.
    pub fn next_waiting_except(&mut self, excluded: impl Fn(u32) -> bool) -> Option<u32> {
        let mut i = 0;
        while let Some(&line) = self.waiting.get(i) {
            // A line can be finished while waiting (a lost holder's result came in after all).
            if self.done[line as usize] {
                self.waiting.remove(i);
            } else if excluded(line) {
                i += 1;
            } else {
                self.waiting.remove(i);
                self.holders[line as usize] += 1;
                return Some(line);
            }
        }
        None
    }

    /// A copy of a line in flight for an idle worker that does not hold it (`held` says which
    /// lines it holds): the fewest holders first, then the lowest line. `None` if nothing is in
    /// flight that the worker does not already hold.
    pub fn next_copy(&mut self, held: impl Fn(u32) -> bool) -> Option<u32> {
        let mut best: Option<(u32, u32)> = None;
        for (line, (&h, &d)) in self.holders.iter().zip(&self.done).enumerate() {
            let line = line as u32;
            if h == 0 || d || held(line) {
                continue;
            }
            if best.is_none_or(|(bh, _)| h < bh) {
                best = Some((h, line));
            }
        }
        let (_, line) = best?;
        self.holders[line as usize] += 1;
        Some(line)
    }

    /// Records a result for `line` from one of its holders (or a former holder). Returns `true`
    /// if it is the first result, whose pixels are to be used.
    pub fn complete(&mut self, line: u32, was_holder: bool) -> bool {
        let i = line as usize;
        if i >= self.done.len() {
            return false;
        }
        if was_holder {
            self.holders[i] = self.holders[i].saturating_sub(1);
        }
        if self.done[i] {
            return false;
        }
        self.done[i] = true;
        self.finished += 1;
        true
    }

    /// The window policy, for the master and the model alike: the lines to hand a worker that
    /// has `outstanding` requests and room for `window` (at least 1). Waiting lines fill its
    /// window; a worker with nothing outstanding when nothing waits gets a copy of a line in
    /// flight ([`LineScheduler::next_copy`]; it holds no line, so any copy is one it lacks).
    pub fn fill_window(&mut self, outstanding: usize, window: u32) -> Vec<u32> {
        self.fill_window_except(outstanding, window, |_| false)
    }

    /// [`LineScheduler::fill_window`] for a worker that must not get the `excluded` lines.
    pub fn fill_window_except(
        &mut self,
        outstanding: usize,
        window: u32,
        excluded: impl Fn(u32) -> bool,
    ) -> Vec<u32> {
        let mut lines = Vec::new();
        while outstanding + lines.len() < window.max(1) as usize {
            let Some(line) = self.next_waiting_except(&excluded) else {
                break;
            };
            lines.push(line);
        }
        if outstanding == 0 && lines.is_empty() {
            lines.extend(self.next_copy(&excluded));
        }
        lines
    }

    /// Makes a finished line wait again, at the front (its result turned out to be wrong).
    pub fn reopen(&mut self, line: u32) {
        let i = line as usize;
        if self.done.get(i).copied().unwrap_or(false) {
            self.done[i] = false;
            self.finished -= 1;
            self.waiting.push_front(line);
        }
    }

    /// A holder gives `line` up without a result. Returns `true` if the line went back to the
    /// queue (no other holder, not finished).
    pub fn release(&mut self, line: u32) -> bool {
        let i = line as usize;
        if i >= self.done.len() {
            return false;
        }
        self.holders[i] = self.holders[i].saturating_sub(1);
        if self.holders[i] == 0 && !self.done[i] {
            self.waiting.push_front(line);
            return true;
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hands_out_lines_in_order_then_copies() {
        let mut s = LineScheduler::new(3);
        assert_eq!(s.next_waiting(), Some(0));
        assert_eq!(s.next_waiting(), Some(1));
        assert_eq!(s.next_waiting(), Some(2));
        assert_eq!(s.next_waiting(), None);
        // Worker A holds 0 and 1; its copy is line 2.
        assert_eq!(s.next_copy(|l| l < 2), Some(2));
        // Line 2 now has two holders; the next copy goes to line 0 (fewest holders, lowest).
        assert_eq!(s.next_copy(|_| false), Some(0));
        assert!(s.complete(2, true));
        assert!(
            !s.complete(2, true),
            "the second result of a line is a duplicate"
        );
        assert!(s.complete(0, true));
        assert!(!s.release(0), "a finished line is not re-queued");
        assert!(s.release(1), "line 1's only holder gave it up");
        assert_eq!(s.next_waiting(), Some(1));
        assert!(s.complete(1, true));
        assert!(s.is_complete());
        assert_eq!(s.next_copy(|_| false), None);
    }

    #[test]
    fn a_region_s_lines_alone_wait_and_the_others_count_as_done() {
        let mut s = LineScheduler::for_lines(6, 2..4);
        assert_eq!((s.finished(), s.is_complete()), (4, false));
        assert_eq!(s.fill_window(0, 8), [2, 3]);
        assert!(s.is_done(0) && s.is_done(5) && !s.is_done(2));
        assert!(!s.complete(5, false), "a line outside is done already");
        assert!(s.complete(2, true) && s.complete(3, true));
        assert!(s.is_complete());
    }

    #[test]
    fn pending_tasks_wait_until_queued() {
        // Two lines with adaptive second passes (tasks 2 and 3).
        let mut s = LineScheduler::with_pending(4, 2);
        assert_eq!(s.next_waiting(), Some(0));
        assert_eq!(s.next_waiting(), Some(1));
        assert_eq!(s.next_waiting(), None, "second passes are not waiting yet");
        assert!(s.complete(0, true) && s.complete(1, true));
        assert!(!s.is_complete());
        s.queue(3);
        // Task 2 needs no second pass: finished without being handed out.
        assert!(s.complete(2, false));
        s.queue(2);
        assert_eq!(s.next_waiting(), Some(3));
        assert_eq!(
            s.next_waiting(),
            None,
            "a finished task is never handed out"
        );
        assert!(s.complete(3, true));
        assert!(s.is_complete());
    }

    #[test]
    fn a_window_fills_with_waiting_lines_then_a_copy() {
        let mut s = LineScheduler::new(3);
        assert_eq!(s.fill_window(0, 2), [0, 1]);
        assert_eq!(s.fill_window(2, 2), [0u32; 0], "a full window gets nothing");
        assert_eq!(s.fill_window(0, 0), [2], "a window of 0 counts as 1");
        // Nothing waits: only a worker with nothing outstanding gets a copy.
        assert_eq!(s.fill_window(1, 2), [0u32; 0]);
        assert_eq!(s.fill_window(0, 2), [0]);
    }

    #[test]
    fn excluded_lines_wait_for_another_worker_and_reopened_ones_come_first() {
        let mut s = LineScheduler::new(4);
        assert_eq!(s.fill_window_except(0, 2, |l| l == 0), [1, 2]);
        assert_eq!(s.fill_window_except(0, 1, |_| false), [0]);
        assert!(s.complete(0, true));
        assert!(s.is_done(0));
        s.reopen(0);
        assert!(!s.is_done(0));
        assert_eq!(s.finished(), 0);
        assert_eq!(s.next_waiting(), Some(0));
        // A worker excluded from everything that waits gets no copy of it either.
        assert_eq!(s.fill_window_except(0, 1, |l| l != 3), [3]);
        assert_eq!(s.fill_window_except(0, 1, |_| true), [0u32; 0]);
    }

    #[test]
    fn released_line_goes_to_the_front() {
        let mut s = LineScheduler::new(5);
        let a = s.next_waiting();
        let b = s.next_waiting();
        assert_eq!((a, b), (Some(0), Some(1)));
        assert!(s.release(1));
        assert_eq!(s.next_waiting(), Some(1));
        assert_eq!(s.next_waiting(), Some(2));
    }

    #[test]
    fn a_late_result_of_a_released_line_still_counts() {
        let mut s = LineScheduler::new(2);
        assert_eq!(s.next_waiting(), Some(0));
        assert!(s.release(0));
        assert!(s.complete(0, false));
        // The re-queued copy of line 0 is skipped.
        assert_eq!(s.next_waiting(), Some(1));
        assert_eq!(s.finished(), 1);
    }
}
