//! A discrete-event model of a render on a cluster, for machines this one does not have.
//!
//! The model runs the master's real [`LineScheduler`] and window policy
//! ([`LineScheduler::fill_window`]) in virtual time: each worker answers its
//! requests in order, a line costs what it cost on this machine divided by the worker's speed,
//! every message takes the link's one-way latency, and the master (one thread) spends a fixed
//! time on each result before it sends the next request, which is what limits large clusters. Line
//! costs come from measuring every line of the scene here, so uneven lines (a mirror in one
//! corner) are uneven in the model too. `strahl bench scaling` uses it beyond the cores this
//! machine has, next to real measurements that show how close it comes.

use crate::cluster::schedule::LineScheduler;
use std::cmp::Ordering;
use std::collections::{BinaryHeap, VecDeque};

/// What the model needs.
#[derive(Clone, Debug)]
pub struct ModelParams {
    /// Seconds each line took on one core of this machine.
    pub line_costs: Vec<f64>,
    /// Speed of each worker relative to this machine's core (1.0 = as fast).
    pub speeds: Vec<f64>,
    /// One-way link latency in seconds.
    pub latency: f64,
    /// Seconds the master spends on each result (receiving, checking, copying, answering);
    /// results are handled one at a time.
    pub master_time: f64,
    /// Requests each worker has outstanding.
    pub window: u32,
}

/// What the model predicts.
#[derive(Clone, Debug, PartialEq)]
pub struct ModelResult {
    /// Seconds from the first request to the last result.
    pub makespan: f64,
    /// Lines whose first result came from each worker.
    pub lines: Vec<u32>,
    /// Results that arrived after a line was done (copies).
    pub duplicates: u32,
}

/// A result arriving at the master.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Arrival {
    at: f64,
    worker: usize,
    line: u32,
}

impl Eq for Arrival {}

impl Ord for Arrival {
    fn cmp(&self, o: &Self) -> Ordering {
        // Earliest first (the heap is a max-heap), ties by worker then line: deterministic.
        o.at.total_cmp(&self.at)
            .then_with(|| o.worker.cmp(&self.worker))
            .then_with(|| o.line.cmp(&self.line))
    }
}

impl PartialOrd for Arrival {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}

struct ModelWorker {
    speed: f64,
    /// When the worker finishes what it has been given.
    free_at: f64,
    outstanding: VecDeque<u32>,
}

/// Runs the model. With no workers or no lines the makespan is 0.
pub fn simulate(p: &ModelParams) -> ModelResult {
    let height = p.line_costs.len() as u32;
    let mut sched = LineScheduler::new(height);
    let mut workers: Vec<ModelWorker> = p
        .speeds
        .iter()
        .map(|&s| ModelWorker {
            speed: s.max(1e-9),
            free_at: 0.0,
            outstanding: VecDeque::new(),
        })
        .collect();
    let mut lines = vec![0u32; workers.len()];
    let mut duplicates = 0;
    let mut heap = BinaryHeap::new();
    let mut now = 0.0f64;
    let mut master_free = 0.0f64;
    let send = |w: &mut ModelWorker, id: usize, line: u32, now: f64, heap: &mut BinaryHeap<_>| {
        let arrival = now + p.latency;
        let start = arrival.max(w.free_at);
        let end = start + p.line_costs[line as usize] / w.speed;
        w.free_at = end;
        w.outstanding.push_back(line);
        heap.push(Arrival {
            at: end + p.latency,
            worker: id,
            line,
        });
    };
    loop {
        for (id, w) in workers.iter_mut().enumerate() {
            for line in sched.fill_window(w.outstanding.len(), p.window) {
                send(w, id, line, now, &mut heap);
            }
        }
        if sched.is_complete() {
            break;
        }
        let Some(a) = heap.pop() else {
            break;
        };
        // The master takes results one at a time and sends new requests when done with one.
        now = a.at.max(master_free) + p.master_time;
        master_free = now;
        let w = &mut workers[a.worker];
        if let Some(i) = w.outstanding.iter().position(|&l| l == a.line) {
            w.outstanding.remove(i);
        }
        if sched.complete(a.line, true) {
            lines[a.worker] += 1;
        } else {
            duplicates += 1;
        }
    }
    ModelResult {
        makespan: now,
        lines,
        duplicates,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(costs: Vec<f64>, speeds: Vec<f64>, latency: f64, window: u32) -> ModelParams {
        ModelParams {
            line_costs: costs,
            speeds,
            latency,
            master_time: 0.0,
            window,
        }
    }

    #[test]
    fn one_worker_without_latency_takes_the_sum() {
        let r = simulate(&params(vec![1.0, 2.0, 3.0], vec![1.0], 0.0, 1));
        assert_eq!(r.makespan, 6.0);
        assert_eq!(r.lines, vec![3]);
    }

    #[test]
    fn a_window_hides_latency() {
        let costs = vec![1.0; 10];
        let w1 = simulate(&params(costs.clone(), vec![1.0], 0.5, 1));
        let w2 = simulate(&params(costs, vec![1.0], 0.5, 2));
        // Window 1 pays a round trip per line; window 2 pays it once.
        assert_eq!(w1.makespan, 20.0);
        assert_eq!(w2.makespan, 11.0);
    }

    #[test]
    fn equal_workers_split_equal_lines() {
        let r = simulate(&params(vec![1.0; 12], vec![1.0; 4], 0.0, 1));
        assert_eq!(r.makespan, 3.0);
        assert_eq!(r.lines, vec![3, 3, 3, 3]);
    }

    #[test]
    fn the_master_limits_a_large_cluster() {
        // 100 lines of 1 s, 0.1 s of master time per result: at most 10 results a second.
        let mut p = params(vec![1.0; 100], vec![1.0; 50], 0.0, 1);
        p.master_time = 0.1;
        let r = simulate(&p);
        assert!(r.makespan >= 10.0, "{}", r.makespan);
        p.speeds = vec![1.0; 5];
        let small = simulate(&p);
        // Five workers are not limited by the master: 20 rounds of ~1.1 s.
        assert!(
            small.makespan > r.makespan,
            "{} {}",
            small.makespan,
            r.makespan
        );
    }

    #[test]
    fn a_slow_worker_does_not_hold_up_the_end() {
        // Worker 1 is 100× slower: its one line is copied to worker 0, which finishes it first.
        let r = simulate(&params(vec![1.0; 4], vec![1.0, 0.01], 0.0, 1));
        assert_eq!(r.makespan, 4.0);
        assert_eq!(r.lines, vec![4, 0]);
    }
}
