//! Clearance: the distance from a point to the nearest of a set of polygons, answered by a
//! bounding-volume hierarchy over the polygons' fan triangles.
//!
//! The tree is built by the binned surface area heuristic down to `SAH_DEPTH` levels and
//! by median splits on the longest axis of the triangles' centroid box below, leaves of at
//! most `LEAF` (4) triangles. Each triangle's centroid and box are computed once for the
//! build (an [`Item`]), not at every level: the same bins and boxes, bit for bit (`min`
//! and `max` are exact), so the same tree, in half the time. A query is a best-first
//! descent that skips only nodes whose box is at least as far as the nearest triangle
//! found so far, so its answer is the minimum of the point–triangle distances (Ericson
//! 2005, 5.1.5) over *all* triangles, whatever the tree's shape: the same inputs give the
//! same bits.
//!
//! **Warm start.** Queries come in runs of nearby points (the samples of one cell, the
//! marching along a segment), so each thread remembers the triangle nearest to its last
//! query ([`HINT`]) and a search starts with that triangle's distance as its best so far:
//! one of the candidates, so the minimum — the answer — is unchanged, while the descent
//! prunes from the first node on instead of only after its first leaf.

use crate::base::vec::{dot, sub};

/// Triangles per leaf.
const LEAF: usize = 4;

thread_local! {
    /// The index (in its field's `tris`) of the triangle nearest to this thread's last
    /// query: the warm start of the next one. Only a hint: any value (another field's, out
    /// of range) gives the same answers, since the answer is the minimum over all
    /// triangles whatever the search starts with.
    static HINT: std::cell::Cell<u32> = const { std::cell::Cell::new(u32::MAX) };
}

type P3 = [f64; 3];

#[derive(Clone, Copy, Debug)]
struct Node {
    lo: P3,
    hi: P3,
    /// Leaf: `first..first + count` in `tris`; inner: `first` is the right child
    /// (the left child is the next node) and `count == 0`.
    first: u32,
    count: u32,
}

/// Nearest-polygon distance queries on a model.
#[derive(Clone, Debug)]
pub struct ClearanceField {
    tris: Vec<[P3; 3]>,
    nodes: Vec<Node>,
}

fn add_scaled(a: P3, b: P3, s: f64) -> P3 {
    [a[0] + b[0] * s, a[1] + b[1] * s, a[2] + b[2] * s]
}

/// Squared distance from `p` to the box `[lo, hi]` (0 inside).
fn box_dist2(p: P3, lo: P3, hi: P3) -> f64 {
    let mut d = 0.0;
    for k in 0..3 {
        let e = (lo[k] - p[k]).max(0.0).max(p[k] - hi[k]);
        d += e * e;
    }
    d
}

/// The point of triangle `t` closest to `p` (Ericson, Real-Time Collision Detection, 5.1.5).
fn closest_on_triangle(p: P3, t: &[P3; 3]) -> P3 {
    let [a, b, c] = *t;
    let ab = sub(&b, &a);
    let ac = sub(&c, &a);
    let ap = sub(&p, &a);
    let d1 = dot(&ab, &ap);
    let d2 = dot(&ac, &ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(&p, &b);
    let d3 = dot(&ab, &bp);
    let d4 = dot(&ac, &bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return add_scaled(a, ab, v);
    }
    let cp = sub(&p, &c);
    let d5 = dot(&ab, &cp);
    let d6 = dot(&ac, &cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return add_scaled(a, ac, w);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return add_scaled(b, sub(&c, &b), w);
    }
    let denom = 1.0 / (va + vb + vc);
    let v = vb * denom;
    let w = vc * denom;
    add_scaled(add_scaled(a, ab, v), ac, w)
}

#[inline(always)]
fn tri_dist2(p: P3, t: &[P3; 3]) -> f64 {
    let q = closest_on_triangle(p, t);
    let d = sub(&p, &q);
    dot(&d, &d)
}

impl ClearanceField {
    /// The field of convex (or star-shaped from their first vertex) polygons, each fanned
    /// into triangles.
    pub fn from_polygons<'a>(polygons: impl IntoIterator<Item = &'a [P3]>) -> Self {
        let mut tris = Vec::new();
        for v in polygons {
            for i in 1..v.len().saturating_sub(1) {
                tris.push([v[0], v[i], v[i + 1]]);
            }
        }
        Self::from_triangles(tris)
    }

    /// The field of a triangle list.
    pub fn from_triangles(mut tris: Vec<[P3; 3]>) -> Self {
        let nodes = if tris.is_empty() {
            Vec::new()
        } else {
            build_par(&mut tris, PAR_MIN)
        };
        ClearanceField { tris, nodes }
    }

    /// Distance from `p` to the nearest triangle (`+inf` for an empty model).
    pub fn distance(&self, p: P3) -> f64 {
        self.search(p, f64::INFINITY, -1.0).unwrap_or(f64::INFINITY)
    }

    /// [`ClearanceField::distance`] given an upper bound `ub` of it (e.g. the distance at a
    /// nearby point plus the way from there: the field is 1-Lipschitz). The bound only
    /// prunes the search: the answer has the same bits as `distance(p)`; a bound that is
    /// too low (by rounding) costs a second, unbounded search.
    pub fn distance_below(&self, p: P3, ub: f64) -> f64 {
        // A relative rounding margin on the bound (not a geometric tolerance): the search
        // finds the nearest triangle whenever it is strictly below the bound.
        const MARGIN: f64 = 1.0 + 1.0 / (1u64 << 40) as f64;
        if !(ub.is_finite() && ub >= 0.0) {
            return self.distance(p);
        }
        let b = ub * MARGIN;
        match self.search(p, b * b, -1.0) {
            Some(d) => d,
            None => self.distance(p),
        }
    }

    /// [`ClearanceField::distance_below`] for a caller that only needs the distance when it
    /// is above `lb`: the same bits as `distance(p)` when that is above `lb`, else some
    /// value `v` with `distance(p) <= v <= lb` (the distance to a triangle found at or
    /// below `lb`, where the search stops). Every answer above `lb` is exact, so a caller
    /// that treats all values at or below `lb` alike (a maximum with `lb`, a test `> lb`)
    /// decides as with `distance_below`, at the price of a search that stops at the first
    /// triangle at or below `lb` (often the warm start's), or none when the bound `ub` is
    /// already below `lb` (the answer is then `lb`). `lb <= 0` or NaN never stops early.
    pub fn distance_above(&self, p: P3, lb: f64, ub: f64) -> f64 {
        // The same rounding margin as `distance_below`'s, here also on the stop: the
        // squared threshold is a little below `lb²`, so the square root of a distance that
        // stops the search is at or below `lb` whatever the rounding.
        const MARGIN: f64 = 1.0 + 1.0 / (1u64 << 40) as f64;
        let stop2 = if lb > 0.0 && lb.is_finite() {
            lb * lb / MARGIN
        } else {
            -1.0
        };
        let bound2 = if ub.is_finite() && ub >= 0.0 {
            let b = ub * MARGIN;
            b * b
        } else {
            f64::INFINITY
        };
        // The bound is already at or below the floor (well past rounding: `MARGIN`
        // twice): the distance is too, and `lb` is such a value. No search.
        if bound2 <= stop2 {
            return lb;
        }
        match self.search(p, bound2, stop2) {
            Some(d) => d,
            None if bound2.is_finite() => self.search(p, f64::INFINITY, stop2).unwrap_or(f64::INFINITY),
            None => f64::INFINITY,
        }
    }

    /// Best-first search for the nearest triangle strictly closer than `sqrt(bound2)`:
    /// its distance, or `None` when there is none (or the model is empty). Nodes whose box
    /// is at least as far as the best so far (or the bound) are skipped, so the answer is
    /// the minimum of the point–triangle distances over all triangles, whatever the bound,
    /// when that minimum is below it. The best so far starts at this thread's hint
    /// triangle ([`HINT`], one of the candidates), and the nearest triangle found becomes
    /// the next hint. The search stops as soon as the best so far is at or below `stop2`
    /// (a negative `stop2` never stops it), returning that triangle's distance.
    fn search(&self, p: P3, bound2: f64, stop2: f64) -> Option<f64> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut best = f64::INFINITY;
        let mut arg = HINT.with(|h| h.get());
        if let Some(t) = self.tris.get(arg as usize) {
            let d = tri_dist2(p, t);
            // A NaN distance (a degenerate triangle) is never the minimum.
            if d < best {
                best = d;
            }
        }
        if best <= stop2 {
            return Some(best.sqrt());
        }
        // Depth-first, the nearer child first: at most one pending sibling per level, and
        // the tree is below `SAH_DEPTH + 32` levels (median splits past `SAH_DEPTH`).
        // The nearer child is visited at once rather than pushed and popped, and a farther
        // child already at least as far as the best so far is not pushed (the pop would
        // skip it: the best only decreases): the nodes visited, and their order, are those
        // of pushing both children and testing each at its pop.
        let mut stack = [(0.0f64, 0u32); 64];
        let mut len = 0usize;
        let mut ni = 0u32;
        // The root is at distance 0 (as if popped with 0).
        let mut visit = 0.0 < best.min(bound2);
        loop {
            if visit {
                let n = self.nodes[ni as usize];
                if n.count > 0 {
                    for (i, t) in self.tris[n.first as usize..(n.first + n.count) as usize]
                        .iter()
                        .enumerate()
                    {
                        let d = tri_dist2(p, t);
                        if d < best {
                            best = d;
                            arg = n.first + i as u32;
                        }
                    }
                    if best <= stop2 {
                        break;
                    }
                } else {
                    let (l, r) = (ni + 1, n.first);
                    let dl = box_dist2(p, self.nodes[l as usize].lo, self.nodes[l as usize].hi);
                    let dr = box_dist2(p, self.nodes[r as usize].lo, self.nodes[r as usize].hi);
                    // The left child first when strictly nearer, else the right.
                    let ((dn, near), (df, far)) = if dl < dr {
                        ((dl, l), (dr, r))
                    } else {
                        ((dr, r), (dl, l))
                    };
                    let lim = best.min(bound2);
                    if !(df >= lim) {
                        stack[len] = (df, far);
                        len += 1;
                    }
                    if !(dn >= lim) {
                        ni = near;
                        continue;
                    }
                }
            }
            // The next pending node still nearer than the best so far.
            if len == 0 {
                break;
            }
            len -= 1;
            let (d, next) = stack[len];
            visit = !(d >= best.min(bound2));
            ni = next;
        }
        HINT.with(|h| h.set(arg));
        (best < bound2).then(|| best.sqrt())
    }
}

/// Depth up to which nodes are split by the surface area heuristic; deeper ones by the
/// median (which halves a range, so the tree stays below `SAH_DEPTH + 32` levels and the
/// search's fixed stack of 64 suffices).
const SAH_DEPTH: usize = 24;

/// Bins per axis of the binned surface area heuristic.
const BINS: usize = 16;

/// Half the surface area of the box `[lo, hi]` (empty: 0).
fn half_area(lo: P3, hi: P3) -> f64 {
    let d = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    if d[0] < 0.0 || d[1] < 0.0 || d[2] < 0.0 {
        return 0.0;
    }
    d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
}

fn grow(lo: &mut P3, hi: &mut P3, t: &[P3; 3]) {
    for v in t {
        for k in 0..3 {
            lo[k] = lo[k].min(v[k]);
            hi[k] = hi[k].max(v[k]);
        }
    }
}

/// The split of `tris` by the binned surface area heuristic (Wald 2007): the axis and bin
/// boundary of least `area(left) * n_left + area(right) * n_right` over `BINS` bins of the
/// centroids along each axis, with the triangles partitioned in place (left first): the
/// left part's length, or `None` when no boundary separates the centroids (then the
/// caller splits at the median). Architecture's flat clusters (a floor, a wall) get flat
/// boxes of their own, which a query beside them skips, where median splits on the longest
/// axis cut across a room and keep boxes that contain the query point for several levels.
fn sah_split(tris: &mut [Item], clo: P3, chi: P3) -> Option<usize> {
    let bin_of = |c: f64, k: usize| -> usize {
        let e = chi[k] - clo[k];
        let b = ((c - clo[k]) / e * BINS as f64) as usize;
        b.min(BINS - 1)
    };
    let mut best: Option<(f64, usize, usize)> = None;
    // The bins of the three axes filled in one pass over the triangles (counts and boxes
    // do not depend on the order they are filled in).
    let axis_ok = |k: usize| {
        let e = chi[k] - clo[k];
        e > 0.0 && e.is_finite()
    };
    let ok = [axis_ok(0), axis_ok(1), axis_ok(2)];
    let mut counts = [[0usize; BINS]; 3];
    let mut blos = [[[f64::INFINITY; 3]; BINS]; 3];
    let mut bhis = [[[f64::NEG_INFINITY; 3]; BINS]; 3];
    for t in tris.iter() {
        for k in 0..3 {
            if ok[k] {
                let b = bin_of(t.c[k], k);
                counts[k][b] += 1;
                grow_box(&mut blos[k][b], &mut bhis[k][b], t);
            }
        }
    }
    for k in 0..3 {
        if !ok[k] {
            continue;
        }
        let (count, blo, bhi) = (&counts[k], &blos[k], &bhis[k]);
        // Right-to-left sweep: the cost of each right part.
        let mut right = [0.0f64; BINS];
        let (mut lo, mut hi, mut n) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], 0usize);
        for b in (1..BINS).rev() {
            for j in 0..3 {
                lo[j] = lo[j].min(blo[b][j]);
                hi[j] = hi[j].max(bhi[b][j]);
            }
            n += count[b];
            right[b] = half_area(lo, hi) * n as f64;
        }
        let (mut lo, mut hi, mut n) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], 0usize);
        for b in 0..BINS - 1 {
            for j in 0..3 {
                lo[j] = lo[j].min(blo[b][j]);
                hi[j] = hi[j].max(bhi[b][j]);
            }
            n += count[b];
            if n == 0 || n == tris.len() {
                continue;
            }
            let cost = half_area(lo, hi) * n as f64 + right[b + 1];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, k, b));
            }
        }
    }
    let (_, k, b) = best?;
    // In-place partition: centroids in bins 0..=b first.
    let mut i = 0;
    let mut j = tris.len();
    while i < j {
        if bin_of(tris[i].c[k], k) <= b {
            i += 1;
        } else {
            j -= 1;
            tris.swap(i, j);
        }
    }
    (i > 0 && i < tris.len()).then_some(i)
}

/// Ranges of at least this many triangles build their two subtrees in parallel.
const PAR_MIN: usize = 1 << 15;

/// The tree of `tris` (partitioned in place), as [`build_at`] gives it: the same nodes in
/// the same depth-first order, bit for bit, whatever the number of threads. Ranges of at
/// least `par_min` ([`PAR_MIN`]) triangles build their two subtrees in parallel (rayon).
/// A subtree of `k` triangles has at most `2k - 1` nodes, so each parallel subtree writes
/// into its own region of that many slots of one buffer (reserved, never initialised: only
/// the pages written become resident), and the used runs are then copied into the exactly
/// sized tree with the right-child indices moved along. No subtree list is built and
/// concatenated level by level, which left up to five generations of freed node lists in
/// the worker threads' malloc arena (about 50 MiB at a million triangles).
fn build_par(tris: &mut [[P3; 3]], par_min: usize) -> Vec<Node> {
    use rayon::prelude::*;
    let mut items = items_of(tris);
    let nodes = build_items(&mut items, par_min);
    // Only the order is kept: the items (80 bytes a triangle) are freed before the
    // triangles are copied, so the two are never held at once.
    let order: Vec<u32> = items.iter().map(|it| it.t).collect();
    drop(items);
    let sorted: Vec<[P3; 3]> = order.par_iter().map(|&i| tris[i as usize]).collect();
    tris.copy_from_slice(&sorted);
    nodes
}

/// A triangle as the build sees it: its centroid and box (computed once, not at every
/// level), and its index in the input.
#[derive(Clone, Copy, Debug)]
struct Item {
    c: P3,
    lo: P3,
    hi: P3,
    t: u32,
}

fn items_of(tris: &[[P3; 3]]) -> Vec<Item> {
    use rayon::prelude::*;
    tris.par_iter()
        .enumerate()
        .with_min_len(1 << 12)
        .map(|(i, t)| {
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            grow(&mut lo, &mut hi, t);
            Item {
                c: centroid(t),
                lo,
                hi,
                t: i as u32,
            }
        })
        .collect()
}

/// The box of a box and an item's (the same bits as growing it by the item's vertices:
/// `min` and `max` are exact).
fn grow_box(lo: &mut P3, hi: &mut P3, t: &Item) {
    for k in 0..3 {
        lo[k] = lo[k].min(t.lo[k]);
        hi[k] = hi[k].max(t.hi[k]);
    }
}

/// [`build_par`] on the items (permuted in place: the tree's triangle order).
fn build_items(tris: &mut [Item], par_min: usize) -> Vec<Node> {
    let n = tris.len();
    if n < par_min.max(2) {
        let mut nodes = Vec::with_capacity(2 * n / LEAF + 1);
        build_at(tris, 0, 0, n, 0, &mut nodes);
        return nodes;
    }
    let mut buf: Vec<Node> = Vec::with_capacity(2 * n - 1);
    let slots = &mut buf.spare_capacity_mut()[..2 * n - 1];
    let runs = fill(tris, 0, 0, slots, 0, par_min);
    // Where each run lands in the tree: runs are in slot order, which is depth-first order.
    let mut starts = Vec::with_capacity(runs.len());
    let mut total = 0usize;
    for &(s, e) in &runs {
        starts.push((s, total));
        total += e - s;
    }
    let moved = |x: u32| -> u32 {
        let i = starts.partition_point(|&(s, _)| s <= x as usize) - 1;
        let (s, to) = starts[i];
        (x as usize - s + to) as u32
    };
    let mut nodes = Vec::with_capacity(total);
    for &(s, e) in &runs {
        for slot in &slots[s..e] {
            // SAFETY: `fill` returns exactly the slots it wrote, each once, as its runs.
            let mut x = unsafe { slot.assume_init() };
            if x.count == 0 {
                x.first = moved(x.first);
            }
            nodes.push(x);
        }
    }
    nodes
}

/// Writes the subtree of `tris` (triangles `base..` of the field) into `out`, its region of
/// `2 * tris.len() - 1` slots starting at slot `at` of the buffer: the root at `out[0]`,
/// the left subtree's region next, then the right one's (inner nodes name their right
/// child by buffer slot). Returns the runs of slots written, `[start, end)`, in order.
fn fill(
    tris: &mut [Item],
    base: usize,
    depth: usize,
    out: &mut [std::mem::MaybeUninit<Node>],
    at: usize,
    par_min: usize,
) -> Vec<(usize, usize)> {
    let k = tris.len();
    if k < par_min.max(2) {
        let mut nodes = Vec::with_capacity(2 * k / LEAF + 1);
        build_at(tris, base, 0, k, depth, &mut nodes);
        // A binary tree whose leaves hold at least one triangle each; the runs returned
        // must be slots written (the caller reads them as initialised).
        assert!(
            nodes.len() <= out.len(),
            "a subtree of {k} triangles has {} nodes",
            nodes.len()
        );
        for (slot, mut x) in out.iter_mut().zip(nodes.iter().copied()) {
            if x.count == 0 {
                x.first += at as u32;
            }
            slot.write(x);
        }
        return vec![(at, at + nodes.len())];
    }
    let (me, split) = node_and_split(tris, base, 0, k, depth);
    let Some(mid) = split else {
        out[0].write(me);
        return vec![(at, at + 1)];
    };
    let (l, r) = tris.split_at_mut(mid);
    let (head, rest) = out.split_at_mut(1);
    let (lo, ro) = rest.split_at_mut(2 * mid - 1);
    let right_at = at + 2 * mid;
    let (lr, rr) = rayon::join(
        || fill(l, base, depth + 1, lo, at + 1, par_min),
        || fill(r, base + mid, depth + 1, ro, right_at, par_min),
    );
    head[0].write(Node {
        first: right_at as u32,
        count: 0,
        ..me
    });
    let mut runs = Vec::with_capacity(1 + lr.len() + rr.len());
    runs.push((at, at + 1));
    runs.extend(lr);
    runs.extend(rr);
    runs
}

/// The node of `tris[first..end]` (a leaf's triangles are `base + first..` of the field)
/// and, unless it is a leaf, where the range splits (its triangles partitioned in place).
fn node_and_split(tris: &mut [Item], base: usize, first: usize, end: usize, depth: usize) -> (Node, Option<usize>) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    let mut clo = [f64::INFINITY; 3];
    let mut chi = [f64::NEG_INFINITY; 3];
    for t in &tris[first..end] {
        grow_box(&mut lo, &mut hi, t);
        let c = t.c;
        for k in 0..3 {
            clo[k] = clo[k].min(c[k]);
            chi[k] = chi[k].max(c[k]);
        }
    }
    let me = Node {
        lo,
        hi,
        first: (base + first) as u32,
        count: (end - first) as u32,
    };
    if end - first <= LEAF {
        return (me, None);
    }
    let sah = if depth < SAH_DEPTH {
        sah_split(&mut tris[first..end], clo, chi)
    } else {
        None
    };
    let mid = match sah {
        Some(left) => first + left,
        None => {
            let axis = (0..3)
                .max_by(|&a, &b| (chi[a] - clo[a]).total_cmp(&(chi[b] - clo[b])))
                .unwrap_or(0);
            let mid = (first + end) / 2;
            tris[first..end].select_nth_unstable_by(mid - first, |a, b| a.c[axis].total_cmp(&b.c[axis]));
            mid
        }
    };
    (me, Some(mid))
}

/// Appends the subtree of `tris[first..end]` to `nodes` in depth-first order (a node, its
/// left subtree, its right subtree; an inner node's `first` is its right child's index in
/// `nodes`): its root's index.
fn build_at(tris: &mut [Item], base: usize, first: usize, end: usize, depth: usize, nodes: &mut Vec<Node>) -> u32 {
    let (node, split) = node_and_split(tris, base, first, end, depth);
    let me = nodes.len() as u32;
    nodes.push(node);
    if let Some(mid) = split {
        build_at(tris, base, first, mid, depth + 1, nodes);
        let right = build_at(tris, base, mid, end, depth + 1, nodes);
        nodes[me as usize].first = right;
        nodes[me as usize].count = 0;
    }
    me
}

fn centroid(t: &[P3; 3]) -> P3 {
    [
        (t[0][0] + t[1][0] + t[2][0]) / 3.0,
        (t[0][1] + t[1][1] + t[2][1]) / 3.0,
        (t[0][2] + t[1][2] + t[2][2]) / 3.0,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::base::rng::SplitMix64;

    struct Rng(SplitMix64);
    impl Rng {
        fn new(seed: u64) -> Self {
            Rng(SplitMix64(seed))
        }
        fn f(&mut self) -> f64 {
            self.0.unit()
        }
    }

    #[test]
    fn parallel_build_gives_the_serial_tree_bit_for_bit() {
        let mut rng = Rng::new(7);
        // Clustered triangles (flat slabs and a cloud), so SAH and median splits both occur.
        let mut tris = Vec::new();
        for i in 0..3000 {
            let c = [
                rng.f() * 10.0,
                rng.f() * 10.0,
                if i % 3 == 0 { 0.0 } else { rng.f() * 10.0 },
            ];
            let t = [
                c,
                add_scaled(c, [rng.f(), rng.f(), 0.0], 0.3),
                add_scaled(c, [0.0, rng.f(), rng.f()], 0.3),
            ];
            tris.push(t);
        }
        let key = |n: &Node| (n.lo.map(f64::to_bits), n.hi.map(f64::to_bits), n.first, n.count);
        let mut serial_items = items_of(&tris);
        let mut serial = Vec::new();
        let n = tris.len();
        build_at(&mut serial_items, 0, 0, n, 0, &mut serial);
        let serial_tris: Vec<[P3; 3]> = serial_items.iter().map(|it| tris[it.t as usize]).collect();
        for par_min in [0, 1, 2, 5, 64, 1000, n + 1] {
            let mut t = tris.clone();
            let nodes = build_par(&mut t, par_min);
            assert_eq!(nodes.len(), serial.len(), "par_min {par_min}");
            assert!(
                nodes.iter().zip(&serial).all(|(a, b)| key(a) == key(b)),
                "par_min {par_min}"
            );
            assert!(t.iter().zip(&serial_tris).all(|(a, b)| a == b), "par_min {par_min}");
        }
    }

    fn brute(tris: &[[P3; 3]], p: P3) -> f64 {
        tris.iter()
            .map(|t| tri_dist2(p, t))
            .fold(f64::INFINITY, f64::min)
            .sqrt()
    }

    /// The search before the warm start (best so far from infinity, nothing remembered):
    /// the frozen reference that the warm-started search must equal bit for bit.
    fn reference_search(f: &ClearanceField, p: P3, bound2: f64) -> Option<f64> {
        if f.nodes.is_empty() {
            return None;
        }
        let mut best = f64::INFINITY;
        let mut stack = vec![(0.0f64, 0u32)];
        while let Some((d, ni)) = stack.pop() {
            if d >= best.min(bound2) {
                continue;
            }
            let n = f.nodes[ni as usize];
            if n.count > 0 {
                for t in &f.tris[n.first as usize..(n.first + n.count) as usize] {
                    best = best.min(tri_dist2(p, t));
                }
                continue;
            }
            let (l, r) = (ni + 1, n.first);
            let dl = box_dist2(p, f.nodes[l as usize].lo, f.nodes[l as usize].hi);
            let dr = box_dist2(p, f.nodes[r as usize].lo, f.nodes[r as usize].hi);
            if dl < dr {
                stack.extend([(dr, r), (dl, l)]);
            } else {
                stack.extend([(dl, l), (dr, r)]);
            }
        }
        (best < bound2).then(|| best.sqrt())
    }

    /// The warm start changes no bit, whatever the hint: random soups and a grid of
    /// axis-aligned squares (many equidistant triangles, ties), queried along a walk (good
    /// hints), at random (poor hints) and with planted hints (out of range, another
    /// triangle), by `distance` and `distance_below`, against the reference search.
    #[test]
    fn warm_start_has_the_bits_of_the_cold_search() {
        let mut rng = Rng::new(23);
        let mut soup = Vec::new();
        for _ in 0..600 {
            let a = [rng.f(), rng.f(), rng.f()];
            let b = add_scaled(a, [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5], 0.1);
            let c = add_scaled(a, [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5], 0.1);
            soup.push([a, b, c]);
        }
        let mut grid = Vec::new();
        for i in 0..12 {
            for j in 0..12 {
                let (x, y) = (i as f64 * 0.25, j as f64 * 0.25);
                for z in [0.0, 1.0] {
                    grid.push([[x, y, z], [x + 0.25, y, z], [x + 0.25, y + 0.25, z]]);
                    grid.push([[x, y, z], [x + 0.25, y + 0.25, z], [x, y + 0.25, z]]);
                }
            }
        }
        for tris in [soup, grid] {
            let n = tris.len() as u32;
            let f = ClearanceField::from_triangles(tris);
            let mut p = [0.5, 0.5, 0.5];
            for i in 0..3000 {
                p = if i % 3 == 0 {
                    [rng.f() * 3.0 - 0.2, rng.f() * 3.0 - 0.2, rng.f() * 1.4 - 0.2]
                } else {
                    add_scaled(p, [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5], 0.02)
                };
                if i % 7 == 0 {
                    let planted = [u32::MAX, n, (rng.f() * n as f64) as u32][i % 3];
                    HINT.with(|h| h.set(planted));
                }
                let want = reference_search(&f, p, f64::INFINITY).unwrap_or(f64::INFINITY);
                assert_eq!(f.distance(p).to_bits(), want.to_bits(), "query {i}");
                for ub in [want * 1.25, want, want * 0.5] {
                    assert_eq!(
                        f.distance_below(p, ub).to_bits(),
                        want.to_bits(),
                        "query {i}, bound {ub}"
                    );
                }
                // `distance_above`: exact above the floor, else in [distance, floor].
                for lb in [want * 0.5, want, want * 1.5, 0.0] {
                    for ub in [want * 1.25, f64::INFINITY] {
                        let v = f.distance_above(p, lb, ub);
                        if want > lb {
                            assert_eq!(v.to_bits(), want.to_bits(), "query {i}, floor {lb}");
                        } else {
                            assert!(want <= v && v <= lb, "query {i}: {want} {v} {lb}");
                        }
                    }
                }
                // A hint planted right before a bounded search.
                HINT.with(|h| h.set((rng.f() * n as f64) as u32));
                let b2 = (want * 1.1) * (want * 1.1);
                assert_eq!(
                    f.search(p, b2, -1.0).map(f64::to_bits),
                    reference_search(&f, p, b2).map(f64::to_bits),
                    "query {i}, bounded"
                );
            }
        }
    }

    /// The search's answer is the minimum over all triangles, bit for bit (the brute
    /// force's), on soups, on grids of equidistant triangles (ties), and on a rooms-like
    /// set of flat, axis-aligned clusters (the surface area heuristic's splits), warm and
    /// bounded; and the tree stays within the search's stack.
    #[test]
    fn search_equals_the_brute_force_minimum_bit_for_bit() {
        let mut rng = Rng::new(31);
        let mut sets: Vec<Vec<[P3; 3]>> = Vec::new();
        let mut soup = Vec::new();
        for _ in 0..700 {
            let a = [rng.f() * 2.0, rng.f() * 2.0, rng.f()];
            let b = add_scaled(a, [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5], 0.2);
            let c = add_scaled(a, [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5], 0.2);
            soup.push([a, b, c]);
        }
        sets.push(soup);
        // Boxes of quads (floor, ceiling, walls of rooms 1 x 1 x 0.75, 4 quads a side).
        let mut rooms = Vec::new();
        for i in 0..3 {
            for j in 0..2 {
                let (x0, y0) = (i as f64 * 1.1, j as f64 * 1.1);
                for u in 0..4 {
                    for v in 0..4 {
                        let (s, t, d) = (u as f64 * 0.25, v as f64 * 0.25, 0.25);
                        for q in [
                            [
                                [x0 + s, y0 + t, 0.0],
                                [x0 + s + d, y0 + t, 0.0],
                                [x0 + s + d, y0 + t + d, 0.0],
                                [x0 + s, y0 + t + d, 0.0],
                            ],
                            [
                                [x0 + s, y0 + t, 0.75],
                                [x0 + s + d, y0 + t, 0.75],
                                [x0 + s + d, y0 + t + d, 0.75],
                                [x0 + s, y0 + t + d, 0.75],
                            ],
                            [
                                [x0 + s, y0, t * 0.75],
                                [x0 + s + d, y0, t * 0.75],
                                [x0 + s + d, y0, (t + d) * 0.75],
                                [x0 + s, y0, (t + d) * 0.75],
                            ],
                            [
                                [x0, y0 + s, t * 0.75],
                                [x0, y0 + s + d, t * 0.75],
                                [x0, y0 + s + d, (t + d) * 0.75],
                                [x0, y0 + s, (t + d) * 0.75],
                            ],
                            [
                                [x0 + 1.0, y0 + s, t * 0.75],
                                [x0 + 1.0, y0 + s + d, t * 0.75],
                                [x0 + 1.0, y0 + s + d, (t + d) * 0.75],
                                [x0 + 1.0, y0 + s, (t + d) * 0.75],
                            ],
                        ] {
                            rooms.push([q[0], q[1], q[2]]);
                            rooms.push([q[0], q[2], q[3]]);
                        }
                    }
                }
            }
        }
        sets.push(rooms);
        // Many copies of one triangle and a degenerate one (equal centroids, zero area).
        let mut same = vec![[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]; 40];
        same.push([[0.5, 0.5, 0.5]; 3]);
        sets.push(same);
        for tris in sets {
            let f = ClearanceField::from_triangles(tris.clone());
            let depth = tree_depth(&f, 0);
            assert!(depth < 60, "depth {depth}");
            let mut p = [0.5, 0.5, 0.4];
            for i in 0..1500 {
                p = if i % 4 == 0 {
                    [rng.f() * 3.6 - 0.2, rng.f() * 2.4 - 0.2, rng.f() * 1.2 - 0.2]
                } else {
                    add_scaled(p, [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5], 0.05)
                };
                let want = brute(&tris, p);
                assert_eq!(f.distance(p).to_bits(), want.to_bits(), "query {i} at {p:?}");
                assert_eq!(
                    f.distance_below(p, want * 1.5).to_bits(),
                    want.to_bits(),
                    "query {i}, bounded"
                );
            }
        }
    }

    fn tree_depth(f: &ClearanceField, ni: usize) -> usize {
        let n = f.nodes[ni];
        if n.count > 0 {
            1
        } else {
            1 + tree_depth(f, ni + 1).max(tree_depth(f, n.first as usize))
        }
    }

    #[test]
    fn closest_point_regions() {
        let t = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let near = |p: P3, q: P3| (0..3).all(|k| (p[k] - q[k]).abs() <= 1e-15);
        // Above the face, off each vertex, off each edge.
        assert!(near(closest_on_triangle([0.2, 0.2, 5.0], &t), [0.2, 0.2, 0.0]));
        assert!(near(closest_on_triangle([-1.0, -1.0, 0.0], &t), [0.0, 0.0, 0.0]));
        assert!(near(closest_on_triangle([3.0, -1.0, 0.0], &t), [1.0, 0.0, 0.0]));
        assert!(near(closest_on_triangle([-1.0, 3.0, 0.0], &t), [0.0, 1.0, 0.0]));
        assert!(near(closest_on_triangle([0.5, -2.0, 0.0], &t), [0.5, 0.0, 0.0]));
        assert!(near(closest_on_triangle([-2.0, 0.5, 0.0], &t), [0.0, 0.5, 0.0]));
        assert!(near(closest_on_triangle([1.0, 1.0, 0.0], &t), [0.5, 0.5, 0.0]));
    }

    #[test]
    fn tree_matches_brute_force() {
        let mut rng = Rng::new(7);
        let mut tris = Vec::new();
        for _ in 0..500 {
            let a = [rng.f(), rng.f(), rng.f()];
            let b = add_scaled(a, [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5], 0.1);
            let c = add_scaled(a, [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5], 0.1);
            tris.push([a, b, c]);
        }
        let f = ClearanceField::from_triangles(tris.clone());
        for _ in 0..300 {
            let p = [rng.f() * 1.4 - 0.2, rng.f() * 1.4 - 0.2, rng.f() * 1.4 - 0.2];
            let (got, want) = (f.distance(p), brute(&tris, p));
            assert!((got - want).abs() <= 1e-12 * (1.0 + want), "{got} vs {want}");
        }
        assert_eq!(
            ClearanceField::from_triangles(Vec::new()).distance([0.0; 3]),
            f64::INFINITY
        );
    }

    #[test]
    fn bounded_query_has_the_same_bits() {
        let mut rng = Rng::new(11);
        let mut tris = Vec::new();
        for _ in 0..400 {
            let a = [rng.f(), rng.f(), rng.f()];
            let b = add_scaled(a, [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5], 0.1);
            let c = add_scaled(a, [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5], 0.1);
            tris.push([a, b, c]);
        }
        let f = ClearanceField::from_triangles(tris);
        let mut prev = [0.5, 0.5, 0.5];
        let mut dprev = f.distance(prev);
        for i in 0..500 {
            let p = add_scaled(prev, [rng.f() - 0.5, rng.f() - 0.5, rng.f() - 0.5], 0.05);
            let want = f.distance(p);
            let step = {
                let d = sub(&p, &prev);
                dot(&d, &d).sqrt()
            };
            // The Lipschitz bound, the exact value, and bounds too low (a second search).
            for ub in [dprev + step, want, want * 0.5, 0.0, f64::INFINITY, f64::NAN] {
                assert_eq!(
                    f.distance_below(p, ub).to_bits(),
                    want.to_bits(),
                    "query {i}, bound {ub}"
                );
            }
            (prev, dprev) = (p, want);
        }
        let empty = ClearanceField::from_triangles(Vec::new());
        assert_eq!(empty.distance_below([0.0; 3], 1.0), f64::INFINITY);
    }
}
