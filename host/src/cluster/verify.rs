//! Trust but verify (`--verify FRACTION`): every image is byte-identical whatever renders it,
//! so the master can check workers exactly. A sampled task's first result is held, not used,
//! and the task goes to another worker; the two results must match byte for byte. When they
//! differ, the master renders the task itself and every worker whose result differs from its
//! own is convicted: dropped for the rest of the render, and the unchecked tasks it delivered
//! before are rendered again elsewhere.
//!
//! This module is the bookkeeping (which tasks are sampled, the held results, who delivered
//! what unchecked); the session acts on it.

use std::collections::HashMap;
use strahl_core::render::pixel::Pixel;
use strahl_core::render::stats::RayCounts;

/// A result held until a second worker's confirms it.
#[derive(Clone, Debug)]
pub(crate) struct Held {
    pub(crate) worker: usize,
    pub(crate) rays: RayCounts,
    pub(crate) pixels: Vec<Pixel>,
}

impl Held {
    /// Whether another result is byte for byte this one.
    pub(crate) fn matches(&self, rays: RayCounts, pixels: &[Pixel]) -> bool {
        self.rays == rays && self.pixels == pixels
    }
}

/// The verification state of one render.
#[derive(Debug, Default)]
pub(crate) struct Verifier {
    fraction: f64,
    /// Tasks below this index (first passes, with adaptive multisampling) are all sampled.
    all_below: u32,
    held: HashMap<u32, Held>,
    /// For each task used without a check, the worker whose result it was.
    unchecked: HashMap<u32, usize>,
}

impl Verifier {
    /// Samples `fraction` (0 to 1) of the tasks; every task below `all_below` once any is.
    pub(crate) fn new(fraction: f64, all_below: u32) -> Self {
        let fraction = if fraction.is_finite() {
            fraction.clamp(0.0, 1.0)
        } else {
            0.0
        };
        Verifier {
            fraction,
            all_below: if fraction > 0.0 { all_below } else { 0 },
            ..Verifier::default()
        }
    }

    /// Whether task `index` is checked: a fixed, even spread of `fraction` of the tasks
    /// (Fibonacci hashing of the index), the same in every run.
    pub(crate) fn sampled(&self, index: u32) -> bool {
        if self.fraction <= 0.0 {
            return false;
        }
        let spread = f64::from(index.wrapping_mul(0x9E37_79B9)) / 4_294_967_296.0;
        index < self.all_below || self.fraction >= 1.0 || spread < self.fraction
    }

    /// The held result of task `index`, if any.
    pub(crate) fn held(&self, index: u32) -> Option<&Held> {
        self.held.get(&index)
    }

    /// Holds `held` as task `index`'s first result.
    pub(crate) fn hold(&mut self, index: u32, held: Held) {
        self.held.insert(index, held);
    }

    /// Takes task `index`'s held result out.
    pub(crate) fn take(&mut self, index: u32) -> Option<Held> {
        self.held.remove(&index)
    }

    /// Whether `worker` must not get task `index` (it gave the result being checked).
    pub(crate) fn excluded(&self, worker: usize, index: u32) -> bool {
        self.held.get(&index).is_some_and(|h| h.worker == worker)
    }

    /// Records that task `index` was used, unchecked, from `worker`.
    pub(crate) fn used_unchecked(&mut self, index: u32, worker: usize) {
        if self.fraction > 0.0 {
            self.unchecked.insert(index, worker);
        }
    }

    /// A convicted worker's unchecked tasks, to render again; its held results are dropped.
    pub(crate) fn convict(&mut self, worker: usize) -> Vec<u32> {
        self.held.retain(|_, h| h.worker != worker);
        let mut tasks: Vec<u32> = self
            .unchecked
            .iter()
            .filter(|&(_, &w)| w == worker)
            .map(|(&t, _)| t)
            .collect();
        tasks.sort_unstable();
        for t in &tasks {
            self.unchecked.remove(t);
        }
        tasks
    }

    /// Held tasks, for the workers that can no longer be checked by another.
    pub(crate) fn held_tasks(&self) -> Vec<(u32, usize)> {
        let mut v: Vec<(u32, usize)> = self.held.iter().map(|(&t, h)| (t, h.worker)).collect();
        v.sort_unstable();
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_fraction_samples_about_that_share_the_same_every_time() {
        let v = Verifier::new(0.25, 0);
        let n = (0..10_000).filter(|&i| v.sampled(i)).count();
        assert!((2_300..2_700).contains(&n), "{n}");
        assert!((0..100).all(|i| Verifier::new(1.0, 0).sampled(i)));
        assert!((0..100).all(|i| !Verifier::new(0.0, 50).sampled(i)));
        let adaptive = Verifier::new(0.01, 50);
        assert!((0..50).all(|i| adaptive.sampled(i)), "every first pass");
    }

    #[test]
    fn a_convicted_worker_gives_back_its_unchecked_tasks() {
        let mut v = Verifier::new(0.5, 0);
        v.used_unchecked(3, 1);
        v.used_unchecked(1, 1);
        v.used_unchecked(2, 0);
        let held = Held {
            worker: 1,
            rays: RayCounts::default(),
            pixels: vec![],
        };
        v.hold(7, held);
        assert!(v.excluded(1, 7) && !v.excluded(0, 7));
        assert_eq!(v.convict(1), [1, 3]);
        assert!(v.held(7).is_none());
        assert_eq!(v.convict(1), [0u32; 0]);
    }
}
