//! A 4-ary max-heap, and the clearance merge's priority queue built on it ([`RunHeap`]: a
//! sorted run of the pairs added in bulk beside a heap of the pairs weighed again).
//!
//! `std::collections::BinaryHeap` is binary; at a million triangles the merge's heap holds
//! millions of entries and each pop walks ~22 levels, nearly each one a cache miss. Four
//! children per node halve the depth, and a node's four children are adjacent in memory
//! (one or two cache lines), so a sift costs about half the misses for a few more
//! comparisons.
//!
//! **Same sequence as `BinaryHeap`.** `pop` returns a greatest element, as `BinaryHeap`'s.
//! When `Ord` is a total order under which equal elements are indistinguishable (the merge's
//! `Entry` compares every field, floats by `total_cmp`, so `Equal` means the same bits), the
//! popped value depends only on the multiset of elements held, not on the heap's layout,
//! so any sequence of pushes and pops returns the same values as `BinaryHeap` would, and
//! building the heap at once ([`Heap4::extend_heapify`]) instead of by pushes changes
//! nothing (`pops_the_same_sequence_as_binary_heap`).

/// A 4-ary max-heap (see the module docs).
#[derive(Clone, Debug, Default)]
pub(crate) struct Heap4<T> {
    v: Vec<T>,
}

const D: usize = 4;

impl<T: Ord + Copy> Heap4<T> {
    pub(crate) fn with_capacity(n: usize) -> Self {
        Heap4 {
            v: Vec::with_capacity(n),
        }
    }

    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.v.len()
    }

    /// A greatest element, if any.
    pub(crate) fn peek(&self) -> Option<&T> {
        self.v.first()
    }

    /// The elements, in no particular order.
    #[cfg(test)]
    pub(crate) fn iter(&self) -> std::slice::Iter<'_, T> {
        self.v.iter()
    }

    pub(crate) fn push(&mut self, x: T) {
        self.v.push(x);
        self.sift_up(self.v.len() - 1);
    }

    /// Pushes every element of `xs`: when the heap was empty, by one bottom-up heap
    /// construction (linear), otherwise one by one.
    #[cfg(test)]
    pub(crate) fn extend_heapify(&mut self, xs: impl IntoIterator<Item = T>) {
        let from = self.v.len();
        for x in xs {
            self.push_unordered(x);
        }
        self.restore(from);
    }

    /// Appends `x` without restoring the heap order: [`Heap4::restore`] must follow before
    /// any `push` or `pop`.
    #[cfg(test)]
    pub(crate) fn push_unordered(&mut self, x: T) {
        self.v.push(x);
    }

    /// Restores the heap order after [`Heap4::push_unordered`] of the elements from index
    /// `from` on: one bottom-up construction (linear) when the heap held nothing before,
    /// else each new element sifted up in turn (as `push` would have).
    #[cfg(test)]
    pub(crate) fn restore(&mut self, from: usize) {
        let n = self.v.len();
        if from > 0 {
            for i in from..n {
                self.sift_up(i);
            }
            return;
        }
        if n < 2 {
            return;
        }
        for i in (0..=(n - 2) / D).rev() {
            self.sift_down(i);
        }
    }

    /// Removes and returns a greatest element.
    pub(crate) fn pop(&mut self) -> Option<T> {
        let last = self.v.pop()?;
        if self.v.is_empty() {
            return Some(last);
        }
        let top = std::mem::replace(&mut self.v[0], last);
        self.sift_down_to_bottom();
        Some(top)
    }

    /// The root's element moved down along the greatest children to a leaf, then up to its
    /// place (as `BinaryHeap::pop` does): the element that replaced the root is the last
    /// one, which mostly belongs near the bottom, so this saves the comparison with it at
    /// every level on the way down.
    fn sift_down_to_bottom(&mut self) {
        let n = self.v.len();
        let x = self.v[0];
        let mut i = 0;
        loop {
            let first = D * i + 1;
            if first >= n {
                break;
            }
            // The next level's candidates (the children of all four children, one
            // contiguous block) are fetched while this level's are compared: a large
            // heap's sift-down waits on a cache miss per level otherwise.
            self.prefetch(D * first + 1);
            let c = self.largest_child(first, n);
            self.v[i] = self.v[c];
            i = c;
        }
        self.v[i] = x;
        self.sift_up(i);
    }

    /// The index of the greatest of the children `first..first + D` (clipped to `n`);
    /// the first of equal ones, as the scan in order finds it.
    /// Hints the cache lines of `v[at..at + D * D]` (the part inside `v`) into the cache.
    /// Only a hint: it reads nothing and changes nothing.
    #[inline(always)]
    fn prefetch(&self, at: usize) {
        #[cfg(target_arch = "x86_64")]
        {
            let n = self.v.len();
            if at >= n {
                return;
            }
            let end = (at + D * D).min(n);
            let base = self.v.as_ptr() as *const i8;
            let (lo, hi) = (at * size_of::<T>(), end * size_of::<T>());
            let mut off = lo & !63;
            while off < hi {
                // SAFETY: `base + off` lies within `v`'s allocation (`off < hi <= n *
                // size_of::<T>()`); a prefetch does not access memory architecturally.
                #[allow(unused_unsafe)]
                unsafe {
                    std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(base.add(off));
                }
                off += 64;
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = at;
    }

    fn largest_child(&self, first: usize, n: usize) -> usize {
        let end = (first + D).min(n);
        let mut c = first;
        for k in first + 1..end {
            if self.v[k] > self.v[c] {
                c = k;
            }
        }
        c
    }

    fn sift_up(&mut self, mut i: usize) {
        let x = self.v[i];
        while i > 0 {
            let p = (i - 1) / D;
            if x <= self.v[p] {
                break;
            }
            self.v[i] = self.v[p];
            i = p;
        }
        self.v[i] = x;
    }

    #[cfg(test)]
    fn sift_down(&mut self, mut i: usize) {
        let n = self.v.len();
        let x = self.v[i];
        loop {
            let first = D * i + 1;
            if first >= n {
                break;
            }
            let c = self.largest_child(first, n);
            if self.v[c] <= x {
                break;
            }
            self.v[i] = self.v[c];
            i = c;
        }
        self.v[i] = x;
    }
}

/// A max-priority queue held as a **sorted run** of elements added in bulk and a
/// [`Heap4`] of those pushed one by one: a pop takes the greater of the run's last element
/// and the heap's top. The clearance merge adds every pair at once (millions at a million
/// triangles) and most are popped before any push could precede them; in the run they cost
/// one sort (on every core) and a pop from the end, instead of a sift through a heap of
/// millions, and the heap holds only the pairs weighed again, a fraction of the size.
///
/// **Same sequence as [`Heap4`].** Both parts together hold the multiset of elements
/// pushed and not popped, and a pop returns a greatest element of it (the greater of the
/// two parts' greatest; when they are equal, either, and equal elements are
/// indistinguishable under the total order the merge uses), so the popped values depend
/// only on the multiset, as with one heap (`run_heap_pops_the_same_sequence`).
#[derive(Clone, Debug, Default)]
pub(crate) struct RunHeap<T> {
    /// Ascending: the greatest last.
    run: Vec<T>,
    heap: Heap4<T>,
}

impl<T: Ord + Copy + Send> RunHeap<T> {
    /// Room for `n` elements pushed one by one (reserved, not touched).
    pub(crate) fn with_capacity(n: usize) -> Self {
        RunHeap {
            run: Vec::new(),
            heap: Heap4::with_capacity(n),
        }
    }

    #[cfg(test)]
    pub(crate) fn len(&self) -> usize {
        self.run.len() + self.heap.len()
    }

    pub(crate) fn push(&mut self, x: T) {
        self.heap.push(x);
    }

    /// Adds `xs` at once: sorted into the run, with what is left of it (in place, on every
    /// core; taken whole when the run is empty).
    pub(crate) fn extend_bulk(&mut self, xs: Vec<T>) {
        use rayon::prelude::*;
        if self.run.is_empty() {
            self.run = xs;
        } else {
            self.run.extend(xs);
        }
        self.run.par_sort_unstable();
    }

    /// Removes and returns a greatest element.
    pub(crate) fn pop(&mut self) -> Option<T> {
        match (self.run.last(), self.heap.peek()) {
            (Some(r), Some(h)) if h > r => self.heap.pop(),
            (Some(_), _) => self.run.pop(),
            (None, _) => self.heap.pop(),
        }
    }

    /// The elements, in no particular order.
    #[cfg(test)]
    pub(crate) fn iter(&self) -> impl Iterator<Item = &T> {
        self.run.iter().chain(self.heap.iter())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::rng::SplitMix64;
    use std::collections::BinaryHeap;

    /// Random interleavings of pushes and pops (many equal keys), with a bulk start:
    /// the same popped values as `BinaryHeap`'s, in the same order.
    #[test]
    fn pops_the_same_sequence_as_binary_heap() {
        let mut rng = SplitMix64(5);
        for round in 0..40 {
            let range = [3u64, 50, 1 << 40][round % 3];
            let start: Vec<(u64, u32)> = (0..(round * 37) as u32)
                .map(|i| ((rng.unit() * range as f64) as u64, i % 7))
                .collect();
            let mut a = Heap4::with_capacity(0);
            a.extend_heapify(start.iter().copied());
            let mut b: BinaryHeap<(u64, u32)> = start.into_iter().collect();
            for step in 0..3000u32 {
                if rng.unit() < 0.55 {
                    let x = ((rng.unit() * range as f64) as u64, step % 5);
                    a.push(x);
                    b.push(x);
                } else {
                    assert_eq!(a.pop(), b.pop(), "round {round}, step {step}");
                }
                if step % 1000 == 999 {
                    let more: Vec<(u64, u32)> = (0..50).map(|i| ((rng.unit() * range as f64) as u64, i)).collect();
                    a.extend_heapify(more.iter().copied());
                    b.extend(more);
                }
                assert_eq!(a.len(), b.len());
            }
            while let Some(x) = b.pop() {
                assert_eq!(a.pop(), Some(x));
            }
            assert_eq!(a.pop(), None);
        }
    }

    /// Random interleavings of pushes, bulk additions and pops (many equal keys): the same
    /// popped values as `BinaryHeap`'s, in the same order.
    #[test]
    fn run_heap_pops_the_same_sequence() {
        let mut rng = SplitMix64(11);
        for round in 0..40 {
            let range = [3u64, 50, 1 << 40][round % 3];
            let start: Vec<(u64, u32)> = (0..(round * 37) as u32)
                .map(|i| ((rng.unit() * range as f64) as u64, i % 7))
                .collect();
            let mut a = RunHeap::with_capacity(0);
            a.extend_bulk(start.clone());
            let mut b: BinaryHeap<(u64, u32)> = start.into_iter().collect();
            for step in 0..3000u32 {
                if rng.unit() < 0.55 {
                    let x = ((rng.unit() * range as f64) as u64, step % 5);
                    a.push(x);
                    b.push(x);
                } else {
                    assert_eq!(a.pop(), b.pop(), "round {round}, step {step}");
                }
                if step % 700 == 699 {
                    let more: Vec<(u64, u32)> = (0..50).map(|i| ((rng.unit() * range as f64) as u64, i)).collect();
                    a.extend_bulk(more.clone());
                    b.extend(more);
                }
                assert_eq!(a.len(), b.len());
            }
            while let Some(x) = b.pop() {
                assert_eq!(a.pop(), Some(x));
            }
            assert_eq!(a.pop(), None);
        }
    }
}
