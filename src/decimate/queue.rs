//! The pair queue: lowest weight first; ties (frequent in axis-aligned models, where many
//! weights are exactly 1, 2 or 6) go to the pair whose smaller cell has the smaller volume
//! (absorb small cells before joining large ones), then to the lower cell ids. Pops form
//! one total order, so every run (and every queue variant) gives the same sequence.
//!
//! Two variants, one answer:
//! - [`QueueMode::Exact`]: every live pair is in a `PriorityQueue` (crate `priority-queue`,
//!   re-weighing is `change_priority`).
//! - [`QueueMode::Auto`] with a `threshold:W` stop: pairs whose weight is `≥ W` are
//!   *parked* in a plain map instead of the heap (no heap cost; they move into the heap if
//!   a re-weigh brings them below `W`). Identical pops, proof: the heap holds exactly the
//!   live pairs with weight `< W`, so while it is non-empty its minimum is the global
//!   minimum (every parked key is `≥ W` and so larger); when it is empty the global minimum
//!   is `≥ W` — the exact queue would stop there, and the parked minimum *is* the global
//!   minimum it reports. Other stop rules always use the exact heap. The test
//!   `parking_queue_gives_the_identical_sequence` runs both and compares every step.

use priority_queue::PriorityQueue;
use serde::{Deserialize, Serialize};
use std::cmp::{Ordering, Reverse};
use std::collections::HashMap;
use std::collections::hash_map::DefaultHasher;
use std::hash::BuildHasherDefault;

/// Deterministic hasher (no per-process random keys).
pub(crate) type DetState = BuildHasherDefault<DefaultHasher>;
/// Deterministic hash map.
pub(crate) type DetMap<K, V> = HashMap<K, V, DetState>;

/// Which queue implementation drives the collapses (both give identical sequences).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum QueueMode {
    /// Every pair in the heap.
    Exact,
    /// Park pairs at or above a `threshold:W` stop outside the heap.
    #[default]
    Auto,
}

/// A pair's place in the order: weight, the smaller of the two cell volumes, then the
/// lower and higher cell id.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Key {
    pub w: f64,
    pub v: f64,
    pub lo: u32,
    pub hi: u32,
}

impl Eq for Key {}
impl PartialOrd for Key {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Key {
    fn cmp(&self, o: &Self) -> Ordering {
        self.w
            .total_cmp(&o.w)
            .then(self.v.total_cmp(&o.v))
            .then(self.lo.cmp(&o.lo))
            .then(self.hi.cmp(&o.hi))
    }
}

/// Counters for the report.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct QueueStats {
    /// Insertions into the heap.
    pub heap_pushes: u64,
    /// Priority changes of pairs already in the heap.
    pub heap_updates: u64,
    /// Pairs parked (or re-parked) outside the heap.
    pub parked: u64,
    /// Largest number of pairs parked at once.
    pub parked_max: u64,
}

pub(crate) struct Queue {
    heap: PriorityQueue<u32, Reverse<Key>, DetState>,
    park_at: Option<f64>,
    parked: DetMap<u32, Key>,
    pub stats: QueueStats,
}

impl Queue {
    /// `park_at`: weights `>= park_at` are parked (None: exact heap).
    pub fn new(capacity: usize, park_at: Option<f64>) -> Self {
        Queue {
            heap: PriorityQueue::with_capacity_and_default_hasher(capacity),
            park_at,
            parked: DetMap::default(),
            stats: QueueStats::default(),
        }
    }

    /// Inserts a pair or changes its key.
    pub fn set(&mut self, p: u32, k: Key) {
        if self.park_at.is_some_and(|t| k.w >= t) {
            self.heap.remove(&p);
            self.parked.insert(p, k);
            self.stats.parked += 1;
            self.stats.parked_max = self.stats.parked_max.max(self.parked.len() as u64);
            return;
        }
        self.parked.remove(&p);
        if self.heap.change_priority(&p, Reverse(k)).is_some() {
            self.stats.heap_updates += 1;
        } else {
            self.heap.push(p, Reverse(k));
            self.stats.heap_pushes += 1;
        }
    }

    /// Removes a pair (no-op when absent).
    pub fn remove(&mut self, p: u32) {
        if self.heap.remove(&p).is_none() {
            self.parked.remove(&p);
        }
    }

    /// The lowest pair in the heap.
    pub fn peek(&self) -> Option<(u32, Key)> {
        self.heap.peek().map(|(&p, &Reverse(k))| (p, k))
    }

    /// Removes the lowest pair in the heap.
    pub fn pop(&mut self) -> Option<(u32, Key)> {
        self.heap.pop().map(|(p, Reverse(k))| (p, k))
    }

    /// The parked pairs in key order (used when the heap runs dry; the engine refreshes
    /// stale keys from the front).
    pub fn parked_sorted(&self) -> Vec<(u32, Key)> {
        let mut v: Vec<(u32, Key)> = self.parked.iter().map(|(&p, &k)| (p, k)).collect();
        v.sort_unstable_by_key(|a| a.1);
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn order_is_weight_then_ids_and_parking_is_transparent() {
        let keys = [(5.0, 1, 2), (1.0, 3, 4), (1.0, 2, 9), (7.0, 0, 1), (0.5, 8, 9)];
        let mut exact = Queue::new(8, None);
        let mut parked = Queue::new(8, Some(4.0));
        for (i, &(w, lo, hi)) in keys.iter().enumerate() {
            exact.set(i as u32, Key { w, v: 0.0, lo, hi });
            parked.set(i as u32, Key { w, v: 0.0, lo, hi });
        }
        // Re-weigh pair 0 below and pair 1 above the threshold.
        exact.set(
            0,
            Key {
                w: 0.75,
                v: 0.0,
                lo: 1,
                hi: 2,
            },
        );
        parked.set(
            0,
            Key {
                w: 0.75,
                v: 0.0,
                lo: 1,
                hi: 2,
            },
        );
        exact.set(
            1,
            Key {
                w: 6.0,
                v: 0.0,
                lo: 3,
                hi: 4,
            },
        );
        parked.set(
            1,
            Key {
                w: 6.0,
                v: 0.0,
                lo: 3,
                hi: 4,
            },
        );
        let mut seq = vec![];
        while let Some((p, k)) = exact.pop() {
            if k.w >= 4.0 {
                assert_eq!(parked.peek(), None);
                assert_eq!(parked.parked_sorted().first().map(|e| e.1), Some(k));
                break;
            }
            assert_eq!(parked.pop(), Some((p, k)));
            seq.push(p);
        }
        assert_eq!(seq, vec![4, 0, 2]);
    }
}
