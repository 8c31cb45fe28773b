//! The build's queue of leaves, best first: a max-queue of distinct `u128` keys that pops them in
//! exactly the order one binary heap over all of them would.
//!
//! Many keys the build pushes are never popped: the build ends at its budget with the tree's
//! last leaves still queued. In one heap those keys make every pop sift through more levels of a
//! larger array, mostly outside the processor's caches. Here the heap keeps the best keys, a few
//! thousand, and the others wait unordered in a list:
//! - every key in the heap is at least `floor`, every key in the list is below it, so the
//!   heap's top is the best key of all;
//! - a push goes to the heap if it is at least `floor`, else to the list;
//! - when the heap is empty, the best of the list move to it ([`Queue::refill_size`] of them)
//!   and `floor` falls to the least of them;
//! - when the heap grows past twice that many, its lower half moves to the list and `floor`
//!   rises to the least key it keeps.
//!
//! On SPD's mount_8 (131,072 triangles) this cut the build's time to 0.94 of one heap's (0.955
//! in the profile-guided build), together with the slot carried in the key (`build.rs`,
//! `queue_key`); see `docs/performance.md`, twenty-ninth round.

use alloc::collections::BinaryHeap;
use alloc::vec::Vec;

/// The fewest keys an empty heap takes from the list at once: 64 KiB of keys. The heap holds at
/// most twice a refill, 128 KiB while the list is short, within the processor's second-level
/// cache.
const MIN_REFILL: usize = 4096;

/// A max-queue of distinct keys (see the module's doc).
#[derive(Default)]
pub(super) struct Queue {
    heap: BinaryHeap<u128>,
    rest: Vec<u128>,
    floor: u128,
}

impl Queue {
    /// Adds `key`, which is not in the queue already.
    pub(super) fn push(&mut self, key: u128) {
        if key < self.floor {
            self.rest.push(key);
            return;
        }
        self.heap.push(key);
        if self.heap.len() > 2 * self.refill_size() {
            self.spill();
        }
    }

    /// Takes the greatest key out.
    pub(super) fn pop(&mut self) -> Option<u128> {
        if self.heap.is_empty() {
            self.refill();
        }
        self.heap.pop()
    }

    /// The greatest key in the heap, which [`Queue::pop`] takes next unless a greater one is
    /// pushed first; `None` where the heap is empty (the next pop refills it).
    pub(super) fn peek(&self) -> Option<u128> {
        self.heap.peek().copied()
    }

    /// How many keys an empty heap takes from the list: [`MIN_REFILL`], or an eighth of the list
    /// if that is more. A refill's selection reads the whole list, so it is paid once per eighth
    /// of the list at most, however long the list grows.
    fn refill_size(&self) -> usize {
        MIN_REFILL.max(self.rest.len() / 8)
    }

    /// Moves the heap's lower half to the list (its keys are below the half it keeps).
    fn spill(&mut self) {
        let mut keys = core::mem::take(&mut self.heap).into_vec();
        let at = keys.len() - keys.len() / 2;
        let (lower, least_kept, _) = keys.select_nth_unstable(at);
        self.floor = *least_kept;
        self.rest.extend_from_slice(lower);
        keys.drain(..at);
        self.heap = BinaryHeap::from(keys);
    }

    /// Moves the list's best [`Queue::refill_size`] keys (or all of them) to the empty heap.
    fn refill(&mut self) {
        let take = self.rest.len().min(self.refill_size());
        if take == 0 {
            return;
        }
        let at = self.rest.len() - take;
        let (_, least_taken, _) = self.rest.select_nth_unstable(at);
        self.floor = *least_taken;
        self.heap = BinaryHeap::from(self.rest.split_off(at));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::octree::xorshift;

    /// Pops and pushes mixed as the build mixes them: every pop answers what one binary heap of
    /// the same keys would, past many spills and refills, and every peek that names a key names
    /// that heap's top.
    #[test]
    fn pops_in_the_order_one_heap_would() {
        let mut next = xorshift(0x2545_f491);
        let (mut queue, mut heap) = (Queue::default(), BinaryHeap::new());
        let mut serial = 0u128;
        let (mut most_waiting, mut peeks) = (0, 0);
        let mut key = |r: u32| {
            serial += 1;
            u128::from(r) << 32 | serial
        };
        for round in 0..60_000u32 {
            // Pushes outnumber pops at first (the queue grows past several spills), then pops
            // outnumber pushes (refills from the list until both are empty).
            let pushes = if round < 30_000 {
                next() % 4
            } else {
                next() % 2
            };
            for _ in 0..pushes {
                let k = key(next() >> (next() % 20));
                queue.push(k);
                heap.push(k);
            }
            // A peek names the next pop, or nothing where the heap waits for a refill.
            let peeked = queue.peek();
            assert!(
                peeked.is_none() || peeked == heap.peek().copied(),
                "round {round}"
            );
            peeks += usize::from(peeked.is_some());
            assert_eq!(queue.pop(), heap.pop(), "round {round}");
            most_waiting = most_waiting.max(queue.rest.len());
        }
        while let Some(k) = heap.pop() {
            assert_eq!(queue.pop(), Some(k));
        }
        assert_eq!(queue.pop(), None);
        assert!(peeks > 50_000, "{peeks} of 60,000 peeks named a key");
        // The list held more than one refill's keys: the heap spilled, and refilled from it.
        assert!(
            most_waiting > MIN_REFILL,
            "{most_waiting} keys waited at most"
        );
    }
}
