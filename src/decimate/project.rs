//! The portal plane, its canonical 2D frame, and the 2D measures of projected cells:
//! bounding rectangle, convex hull area, and the exact area of a union of convex polygons.

use crate::predicates::P3;

/// A 2D point in a [`Frame`].
pub type P2 = [f64; 2];

/// Relative tolerance (of the extent of the input) under which a polygon edge counts as
/// lying on another polygon's edge line in [`union_area`].
pub const UNION_COLLINEAR_REL: f64 = 1e-9;

/// An orthonormal frame on a plane: canonical unit normal `n`, in-plane axes `u`, `v`
/// (`u × v = n`), and an origin `o` (coordinates are taken relative to it, so projection
/// loses nothing to large absolute coordinates).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Unit normal, sign-canonical: its largest-magnitude component (first on ties) is > 0.
    pub n: P3,
    /// First in-plane axis.
    pub u: P3,
    /// Second in-plane axis.
    pub v: P3,
    /// Origin.
    pub o: P3,
}

use crate::base::vec::{cross, dot, norm, sub};

impl Frame {
    /// The canonical frame for a (non-zero) normal direction: `n` is normalized and its sign
    /// fixed (largest-magnitude component positive, the first one on ties), so both
    /// orientations of a portal give the same frame. `u` is `e_k × n` normalized, where
    /// `e_k` is the coordinate axis along which `|n|` is smallest (the first on ties), and
    /// `v = n × u`. Returns `None` for a zero or non-finite normal.
    pub fn new(normal: P3, origin: P3) -> Option<Self> {
        let l = norm(&normal);
        if l.is_nan() || l <= 0.0 || !l.is_finite() {
            return None;
        }
        let mut n = [normal[0] / l, normal[1] / l, normal[2] / l];
        let big = (0..3).fold(0, |m, k| if n[k].abs() > n[m].abs() { k } else { m });
        if n[big] < 0.0 {
            n = [-n[0], -n[1], -n[2]];
        }
        let small = (0..3).fold(0, |m, k| if n[k].abs() < n[m].abs() { k } else { m });
        let mut e = [0.0; 3];
        e[small] = 1.0;
        let u0 = cross(&e, &n);
        let lu = norm(&u0);
        let u = [u0[0] / lu, u0[1] / lu, u0[2] / lu];
        let v = cross(&n, &u);
        Some(Frame { n, u, v, o: origin })
    }

    /// In-plane coordinates of `p` (orthogonal projection onto the plane through `o`).
    pub fn project(&self, p: &P3) -> P2 {
        let d = sub(p, &self.o);
        [dot(&d, &self.u), dot(&d, &self.v)]
    }
}

fn cross2(o: &P2, a: &P2, b: &P2) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

/// Convex hull (Andrew's monotone chain), counter-clockwise, without collinear points.
/// The result depends only on the *set* of input points (they are sorted first).
pub fn hull2(mut pts: Vec<P2>) -> Vec<P2> {
    let mut h: Vec<P2> = Vec::with_capacity(2 * pts.len());
    hull2_into(&mut pts, &mut h);
    h
}

/// [`hull2`] of `pts` (sorted and deduplicated in place: a scratch buffer), appended to
/// `out`: the same points in the same order, without a new allocation per call.
pub(crate) fn hull2_into(pts: &mut Vec<P2>, out: &mut Vec<P2>) {
    pts.sort_unstable_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    pts.dedup();
    if pts.len() < 3 {
        out.extend_from_slice(pts);
        return;
    }
    let base = out.len();
    for p in pts.iter() {
        while out.len() >= base + 2 && cross2(&out[out.len() - 2], &out[out.len() - 1], p) <= 0.0 {
            out.pop();
        }
        out.push(*p);
    }
    let lower = out.len() + 1;
    for p in pts.iter().rev().skip(1) {
        while out.len() >= lower && cross2(&out[out.len() - 2], &out[out.len() - 1], p) <= 0.0 {
            out.pop();
        }
        out.push(*p);
    }
    out.pop();
}

/// Signed area (positive counter-clockwise), relative to the first vertex.
pub fn polygon_area(p: &[P2]) -> f64 {
    if p.len() < 3 {
        return 0.0;
    }
    let o = p[0];
    let mut s = 0.0;
    for i in 1..p.len() - 1 {
        s += cross2(&o, &p[i], &p[i + 1]);
    }
    0.5 * s
}

/// Area of the axis-aligned bounding rectangle of the points.
pub fn bbox_area(pts: &[P2]) -> f64 {
    if pts.is_empty() {
        return 0.0;
    }
    let (lo, hi) = bbox2(pts);
    (hi[0] - lo[0]) * (hi[1] - lo[1])
}

/// The axis-aligned bounding box `(lo, hi)` of the points (inverted, infinite, if none).
pub(crate) fn bbox2<'p>(p: impl IntoIterator<Item = &'p P2>) -> (P2, P2) {
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for q in p {
        for k in 0..2 {
            lo[k] = lo[k].min(q[k]);
            hi[k] = hi[k].max(q[k]);
        }
    }
    (lo, hi)
}

fn overlaps(a: &(P2, P2), b: &(P2, P2), tol: f64) -> bool {
    a.0[0] <= b.1[0] + tol && b.0[0] <= a.1[0] + tol && a.0[1] <= b.1[1] + tol && b.0[1] <= a.1[1] + tol
}

/// Polygons prepared for coverage queries: the non-degenerate ones with their boxes, and
/// for larger sets a uniform grid over the boxes, so that a query costs about the number of
/// polygons near the segment instead of all of them.
struct Prepared<'a> {
    polys: Vec<&'a [P2]>,
    boxes: Vec<(P2, P2)>,
    grid: Option<BoxGrid>,
    scratch: std::cell::RefCell<Vec<u32>>,
}

/// Sets with more polygons than this get a [`BoxGrid`].
const GRID_FROM: usize = 48;

#[cfg(not(test))]
fn grid_from() -> usize {
    GRID_FROM
}

#[cfg(test)]
thread_local! {
    /// Tests switch the grid off to compare against the plain scan.
    static GRID_FROM_TEST: std::cell::Cell<usize> = const { std::cell::Cell::new(GRID_FROM) };
}

#[cfg(test)]
fn grid_from() -> usize {
    GRID_FROM_TEST.with(|c| c.get())
}

/// A uniform grid of about one polygon box per cell (compressed rows: `items[start[c]..
/// start[c + 1]]` are the polygons whose boxes meet cell `c`).
struct BoxGrid {
    lo: P2,
    inv: [f64; 2],
    n: [usize; 2],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl BoxGrid {
    fn new(boxes: &[(P2, P2)]) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for b in boxes {
            for k in 0..2 {
                lo[k] = lo[k].min(b.0[k]);
                hi[k] = hi[k].max(b.1[k]);
            }
        }
        let side = ((boxes.len() as f64).sqrt().ceil() as usize).clamp(1, 512);
        let n = [side, side];
        let inv = [0, 1].map(|k| {
            let w = hi[k] - lo[k];
            if w > 0.0 { n[k] as f64 / w } else { 0.0 }
        });
        let mut g = BoxGrid {
            lo,
            inv,
            n,
            start: vec![0; n[0] * n[1] + 1],
            items: Vec::new(),
        };
        for b in boxes {
            let (r0, r1) = g.range(b, 0.0);
            for y in r0[1]..=r1[1] {
                for x in r0[0]..=r1[0] {
                    g.start[y * n[0] + x + 1] += 1;
                }
            }
        }
        for c in 1..g.start.len() {
            g.start[c] += g.start[c - 1];
        }
        let mut fill = g.start.clone();
        g.items = vec![0; *g.start.last().unwrap_or(&0) as usize];
        for (i, b) in boxes.iter().enumerate() {
            let (r0, r1) = g.range(b, 0.0);
            for y in r0[1]..=r1[1] {
                for x in r0[0]..=r1[0] {
                    let c = y * n[0] + x;
                    g.items[fill[c] as usize] = i as u32;
                    fill[c] += 1;
                }
            }
        }
        g
    }

    /// The cell range covered by box `b` grown by `tol` (clamped to the grid).
    fn range(&self, b: &(P2, P2), tol: f64) -> ([usize; 2], [usize; 2]) {
        let cell = |v: f64, k: usize| -> usize {
            let t = ((v - self.lo[k]) * self.inv[k]).floor();
            if t.is_nan() || t < 0.0 {
                0
            } else {
                (t as usize).min(self.n[k] - 1)
            }
        };
        (
            [cell(b.0[0] - tol, 0), cell(b.0[1] - tol, 1)],
            [cell(b.1[0] + tol, 0), cell(b.1[1] + tol, 1)],
        )
    }

    /// Appends to `out` (sorted, without repeats) the polygons whose boxes may meet the
    /// segment `a → b` grown by `tol`: for a segment crossing many grid cells diagonally,
    /// only the cells along it (column by column), not all cells of its box — a long edge
    /// would otherwise visit most of the grid. A superset of the polygons that can cover
    /// any part of the segment (those meet its `tol`-neighbourhood), so the coverage
    /// intervals are those of the plain scan.
    fn candidates_seg(&self, a: &P2, b: &P2, tol: f64, out: &mut Vec<u32>) {
        let sb = ([a[0].min(b[0]), a[1].min(b[1])], [a[0].max(b[0]), a[1].max(b[1])]);
        let (r0, r1) = self.range(&sb, tol);
        let dx = b[0] - a[0];
        let slope = (b[1] - a[1]) / dx;
        if (r1[0] - r0[0] + 1) * (r1[1] - r0[1] + 1) <= 8 || self.inv[0] <= 0.0 || !slope.is_finite() {
            return self.candidates(&sb, tol, out);
        }
        out.clear();
        let pad = 2.0 * tol;
        let y_at = |x: f64| a[1] + (x.clamp(sb.0[0], sb.1[0]) - a[0]) * slope;
        for x in r0[0]..=r1[0] {
            let x0 = self.lo[0] + x as f64 / self.inv[0];
            let x1 = self.lo[0] + (x + 1) as f64 / self.inv[0];
            let (ya, yb) = (y_at(x0 - pad), y_at(x1 + pad));
            let (ylo, yhi) = (ya.min(yb) - pad, ya.max(yb) + pad);
            let rows = if ylo.is_finite() && yhi.is_finite() {
                let (q0, q1) = self.range(&([x0, ylo], [x0, yhi]), 0.0);
                (q0[1].max(r0[1]), q1[1].min(r1[1]))
            } else {
                (r0[1], r1[1])
            };
            for y in rows.0..=rows.1 {
                let c = y * self.n[0] + x;
                out.extend_from_slice(&self.items[self.start[c] as usize..self.start[c + 1] as usize]);
            }
        }
        out.sort_unstable();
        out.dedup();
    }

    /// Appends to `out` (sorted, without repeats) the polygons whose boxes may meet `b`
    /// grown by `tol`.
    fn candidates(&self, b: &(P2, P2), tol: f64, out: &mut Vec<u32>) {
        out.clear();
        let (r0, r1) = self.range(b, tol);
        for y in r0[1]..=r1[1] {
            for x in r0[0]..=r1[0] {
                let c = y * self.n[0] + x;
                out.extend_from_slice(&self.items[self.start[c] as usize..self.start[c + 1] as usize]);
            }
        }
        out.sort_unstable();
        out.dedup();
    }
}

impl<'a> Prepared<'a> {
    /// The polygons with at least 3 vertices and positive area that are not *slivers*:
    /// a polygon whose width is within the collinearity tolerance of the input's extent
    /// has all its edges on one line as far as the tie rules can tell, and they would
    /// count it as having an inside on both sides of that line (which removed a real
    /// polygon's edge that the sliver lay along). Dropping one changes the union by at most
    /// its own area, under `2 · tolerance · diameter`.
    fn new(polys: &'a [Vec<P2>]) -> Self {
        Prepared::of_slices(polys.iter().map(Vec::as_slice))
    }

    /// As [`Prepared::new`], for polygons given as slices (of one flat buffer, say).
    fn of_slices(polys: impl Iterator<Item = &'a [P2]>) -> Self {
        let mut kept: Vec<(&[P2], (P2, P2), f64)> = polys
            .filter(|p| p.len() >= 3)
            .map(|p| (p, bbox2(p), polygon_area(p)))
            .filter(|e| e.2 > 0.0)
            .collect();
        let (lo, hi) = bbox2(kept.iter().flat_map(|(_, b, _)| [&b.0, &b.1]));
        let tol = UNION_COLLINEAR_REL * (hi[0] - lo[0]).max(hi[1] - lo[1]);
        // Width ≤ 2·area/diameter (a convex polygon holds a triangle on its diameter),
        // and the diameter is at least the box diagonal over √2.
        kept.retain(|(_, b, area)| {
            let diag = ((b.1[0] - b.0[0]).powi(2) + (b.1[1] - b.0[1]).powi(2)).sqrt();
            2.0 * std::f64::consts::SQRT_2 * area > tol * diag
        });
        let boxes = kept.iter().map(|e| e.1).collect();
        Prepared::with(kept.into_iter().map(|e| e.0).collect(), boxes)
    }

    fn with(polys: Vec<&'a [P2]>, boxes: Vec<(P2, P2)>) -> Self {
        let grid = (polys.len() > grid_from()).then(|| BoxGrid::new(&boxes));
        Prepared {
            polys,
            boxes,
            grid,
            scratch: std::cell::RefCell::new(Vec::new()),
        }
    }

    /// As [`Prepared::new`], without the polygons that lie inside one of the
    /// [`PRUNE_AGAINST`] largest kept ones (within the collinearity tolerance): they change
    /// neither the union nor its boundary. Projections of small faces are often hidden behind
    /// a few large ones, so this removes many of them cheaply.
    fn pruned(polys: &'a [Vec<P2>]) -> Self {
        Prepared::pruned_of(Prepared::new(polys))
    }

    /// [`Prepared::pruned`] of an already prepared set.
    fn pruned_of(all: Prepared<'a>) -> Self {
        if all.polys.len() <= 2 {
            return all;
        }
        let (_, extent) = all.extent(None);
        let tol = UNION_COLLINEAR_REL * extent;
        let mut order: Vec<(f64, usize)> = all
            .polys
            .iter()
            .enumerate()
            .map(|(i, p)| (polygon_area(p), i))
            .collect();
        order.sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let mut keep: Vec<usize> = Vec::with_capacity(order.len());
        for &(_, i) in &order {
            let p = all.polys[i];
            let (lo, hi) = all.boxes[i];
            let hidden = keep.iter().take(PRUNE_AGAINST).any(|&j| {
                let (qlo, qhi) = all.boxes[j];
                qlo[0] <= lo[0] + tol
                    && qlo[1] <= lo[1] + tol
                    && qhi[0] >= hi[0] - tol
                    && qhi[1] >= hi[1] - tol
                    && p.iter().all(|v| inside(all.polys[j], v, tol))
            });
            if !hidden {
                keep.push(i);
            }
        }
        // Restore input order (the tie rules follow it).
        keep.sort_unstable();
        Prepared::with(
            keep.iter().map(|&i| all.polys[i]).collect(),
            keep.iter().map(|&i| all.boxes[i]).collect(),
        )
    }

    /// Appends to `out` the parameter intervals of segment `a → b` covered by the polygons
    /// of this set other than `skip`; `wins(j)`: whether polygon `j` keeps a boundary
    /// shared on the same side.
    fn cover(
        &self,
        a: &P2,
        b: &P2,
        skip: Option<usize>,
        wins: impl Fn(usize) -> bool,
        tol: f64,
        out: &mut Vec<(f64, f64)>,
    ) {
        let sb = ([a[0].min(b[0]), a[1].min(b[1])], [a[0].max(b[0]), a[1].max(b[1])]);
        let mut visit = |j: usize| {
            if Some(j) == skip || !overlaps(&sb, &self.boxes[j], tol) {
                return;
            }
            if let Some(iv) = covered(a, b, self.polys[j], wins(j), tol) {
                out.push(iv);
            }
        };
        match &self.grid {
            // Candidates in increasing index order, like the plain loop: same intervals.
            Some(g) => {
                let mut c = self.scratch.borrow_mut();
                g.candidates_seg(a, b, tol, &mut c);
                for &j in c.iter() {
                    visit(j as usize);
                }
            }
            None => (0..self.polys.len()).for_each(visit),
        }
    }

    fn extent(&self, other: Option<&Prepared>) -> ((P2, P2), f64) {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for b in self.boxes.iter().chain(other.iter().flat_map(|o| o.boxes.iter())) {
            for k in 0..2 {
                lo[k] = lo[k].min(b.0[k]);
                hi[k] = hi[k].max(b.1[k]);
            }
        }
        ((lo, hi), (hi[0] - lo[0]).max(hi[1] - lo[1]))
    }
}

/// How many of the largest polygons [`Prepared::pruned`] tests containment against.
const PRUNE_AGAINST: usize = 32;

/// `v` is inside convex CCW polygon `q` or within `tol` of it.
fn inside(q: &[P2], v: &P2, tol: f64) -> bool {
    let m = q.len();
    (0..m).all(|k| {
        let (a, b) = (q[k], q[(k + 1) % m]);
        let e = [b[0] - a[0], b[1] - a[1]];
        let le = (e[0] * e[0] + e[1] * e[1]).sqrt();
        le == 0.0 || (e[0] * (v[1] - a[1]) - e[1] * (v[0] - a[0])) >= -tol * le
    })
}

/// Sorts and merges intervals in place.
fn merge_intervals(iv: &mut Vec<(f64, f64)>) {
    iv.sort_unstable_by(|x, y| x.0.total_cmp(&y.0));
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(iv.len());
    for &(s, e) in iv.iter() {
        match out.last_mut() {
            Some(l) if s <= l.1 => l.1 = l.1.max(e),
            _ => out.push((s, e)),
        }
    }
    *iv = out;
}

/// `∫ x dy − y dx` (relative to `c`) over the parts of segment `a → b` that lie in `keep`
/// (all of it when `None`) and in none of `drop` (both merged interval lists).
fn edge_integral(a: &P2, b: &P2, c: &P2, keep: Option<&[(f64, f64)]>, drop: &[(f64, f64)]) -> f64 {
    let lerp = |s: f64| [a[0] + s * (b[0] - a[0]) - c[0], a[1] + s * (b[1] - a[1]) - c[1]];
    let seg = |s: f64, e: f64| {
        if e > s {
            let (pa, pb) = (lerp(s), lerp(e));
            pa[0] * pb[1] - pa[1] * pb[0]
        } else {
            0.0
        }
    };
    let full = [(0.0, 1.0)];
    let keep = keep.unwrap_or(&full);
    let mut total = 0.0;
    for &(ks, ke) in keep {
        // Walk the complement of `drop` inside [ks, ke].
        let mut t = ks.max(0.0);
        let end = ke.min(1.0);
        for &(ds, de) in drop {
            if de <= t {
                continue;
            }
            if ds >= end {
                break;
            }
            total += seg(t, ds.min(end));
            t = t.max(de);
            if t >= end {
                break;
            }
        }
        if t < end {
            total += seg(t, end);
        }
    }
    total
}

/// Exact (up to rounding) area of the union of convex counter-clockwise polygons.
///
/// Method: by Green's theorem the union's area is `½∮ x dy − y dx` over its boundary, and
/// that boundary is made of the portions of the polygons' edges that lie in no *other*
/// polygon. For each edge, every other polygon whose bounding box meets it is clipped
/// against it (Cyrus–Beck) to the parameter interval it covers; the uncovered parts
/// contribute. An edge lying on another polygon's edge line (within
/// [`UNION_COLLINEAR_REL`] of the input extent) is decided by a tie rule: polygons on the
/// *same* side (same edge direction) overlap there, and only the lower-indexed one keeps
/// the shared boundary; polygons on *opposite* sides abut there, and the shared part is
/// interior (both contributions would cancel anyway). Polygons with fewer than 3 vertices,
/// zero area, or a width within that tolerance (slivers, which the tie rules would read as
/// inside on both sides of their line) are ignored; a sliver's own area is below
/// `2 · tolerance · diameter`.
///
/// Polygons inside one of the largest others are dropped first (`Prepared::pruned`).
/// Cost: `O(Σ_P |P| · Σ_{Q meets P} |Q|)` over the remaining polygons — quadratic in the
/// number of mutually overlapping polygons, linear when few overlap.
pub fn union_area(polys: &[Vec<P2>]) -> f64 {
    let u = Prepared::pruned(polys);
    match u.polys.len() {
        0 => return 0.0,
        1 => return polygon_area(u.polys[0]),
        _ => {}
    }
    let ((lo, hi), extent) = u.extent(None);
    let tol = UNION_COLLINEAR_REL * extent;
    // Integrate relative to the centre of the input's box (area is translation invariant).
    let c = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    let mut total = 0.0;
    let mut iv: Vec<(f64, f64)> = Vec::new();
    for (i, p) in u.polys.iter().enumerate() {
        let n = p.len();
        for k in 0..n {
            let (a, b) = (p[k], p[(k + 1) % n]);
            iv.clear();
            u.cover(&a, &b, Some(i), |j| j < i, tol, &mut iv);
            merge_intervals(&mut iv);
            total += edge_integral(&a, &b, &c, None, &iv);
        }
    }
    0.5 * total
}

/// `area(∪U ∪ ∪V) − area(∪U)`: what the polygons `v` add to the union of the polygons `u`.
///
/// Only the parts of the boundary that change are integrated: the edges of `V` outside
/// `U` (and outside the other `V`), minus the parts of `∂(∪U)` that `V` covers. `U` may
/// be restricted to the polygons whose boxes meet `V`'s (the others cannot contribute),
/// which makes this local. Ties as in [`union_area`] with the `U` polygons ordered
/// before the `V` polygons, so `area(∪U) + delta` equals `union_area` of `U ++ V` up to
/// rounding.
pub fn union_area_delta(u: &[Vec<P2>], v: &[Vec<P2>]) -> f64 {
    delta_prepared(Prepared::pruned(u), Prepared::new(v))
}

fn delta_prepared(u: Prepared, v: Prepared) -> f64 {
    if v.polys.is_empty() {
        return 0.0;
    }
    let ((lo, hi), extent) = u.extent(Some(&v));
    let tol = UNION_COLLINEAR_REL * extent;
    let c = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    let mut total = 0.0;
    let (mut iv, mut jv) = (Vec::new(), Vec::new());
    // Edges of V not covered by U (U wins same-side ties) nor by the other V.
    for (i, p) in v.polys.iter().enumerate() {
        let n = p.len();
        for k in 0..n {
            let (a, b) = (p[k], p[(k + 1) % n]);
            iv.clear();
            u.cover(&a, &b, None, |_| true, tol, &mut iv);
            v.cover(&a, &b, Some(i), |j| j < i, tol, &mut iv);
            merge_intervals(&mut iv);
            total += edge_integral(&a, &b, &c, None, &iv);
        }
    }
    // Minus the boundary of ∪U that V covers (V loses same-side ties against U).
    for (i, p) in u.polys.iter().enumerate() {
        let n = p.len();
        for k in 0..n {
            let (a, b) = (p[k], p[(k + 1) % n]);
            jv.clear();
            v.cover(&a, &b, None, |_| false, tol, &mut jv);
            if jv.is_empty() {
                continue;
            }
            merge_intervals(&mut jv);
            iv.clear();
            u.cover(&a, &b, Some(i), |j| j < i, tol, &mut iv);
            merge_intervals(&mut iv);
            total -= edge_integral(&a, &b, &c, Some(&jv), &iv);
        }
    }
    0.5 * total
}

/// [`union_area`] of polygons given as slices, without the pruning pass, and integrating
/// only the edges that are not *paired*: an edge `a → b` of one polygon whose exact reverse
/// `b → a` is an edge of exactly one other polygon (and no other polygon has `a → b`) lies
/// on the common boundary of two abutting polygons; each of the two edges is covered by
/// the other polygon (opposite sides: the tie rule counts the shared line as inside), so
/// their contributions vanish and are skipped. The projected front faces of a solid tile
/// its silhouette region this way: only the silhouette edges (and the edges of overlapping
/// layers) are integrated. Same area as [`union_area`] up to rounding.
pub fn union_area_paired(polys: &[&[P2]]) -> f64 {
    let u = Prepared::of_slices(polys.iter().copied());
    match u.polys.len() {
        0 => return 0.0,
        1 => return polygon_area(u.polys[0]),
        _ => {}
    }
    let ((lo, hi), extent) = u.extent(None);
    let tol = UNION_COLLINEAR_REL * extent;
    let c = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])];
    let paired = EdgeTable::paired(&u.polys);
    let mut total = 0.0;
    let mut iv: Vec<(f64, f64)> = Vec::new();
    let mut e = 0;
    for (i, p) in u.polys.iter().enumerate() {
        let n = p.len();
        for k in 0..n {
            let skip = paired[e];
            e += 1;
            if skip {
                continue;
            }
            let (a, b) = (p[k], p[(k + 1) % n]);
            iv.clear();
            u.cover(&a, &b, Some(i), |j| j < i, tol, &mut iv);
            merge_intervals(&mut iv);
            total += edge_integral(&a, &b, &c, None, &iv);
        }
    }
    0.5 * total
}

/// Directed edges keyed by their endpoints' bit patterns (open addressing, linear probing).
struct EdgeTable {
    keys: Vec<[u64; 4]>,
    counts: Vec<u32>,
    mask: usize,
}

impl EdgeTable {
    fn key(a: &P2, b: &P2) -> [u64; 4] {
        [a[0].to_bits(), a[1].to_bits(), b[0].to_bits(), b[1].to_bits()]
    }

    fn slot(&self, k: &[u64; 4]) -> usize {
        let mut h: u64 = 0x243F_6A88_85A3_08D3;
        for x in k {
            h = (h ^ x).wrapping_mul(0x9E37_79B9_7F4A_7C15);
            h ^= h >> 29;
        }
        h as usize & self.mask
    }

    /// The slot of `k`, or of the empty slot where it would go (count 0).
    fn find(&self, k: &[u64; 4]) -> usize {
        let mut i = self.slot(k);
        while self.counts[i] != 0 && self.keys[i] != *k {
            i = (i + 1) & self.mask;
        }
        i
    }

    /// For every edge of `polys` in order (polygon by polygon, edge `k` from vertex `k`):
    /// whether it is paired (see [`union_area_paired`]).
    fn paired(polys: &[&[P2]]) -> Vec<bool> {
        let m: usize = polys.iter().map(|p| p.len()).sum();
        let size = (2 * m).next_power_of_two().max(16);
        let mut t = EdgeTable {
            keys: vec![[0; 4]; size],
            counts: vec![0; size],
            mask: size - 1,
        };
        let edges = || {
            polys
                .iter()
                .flat_map(|p| (0..p.len()).map(move |k| (p[k], p[(k + 1) % p.len()])))
        };
        for (a, b) in edges() {
            let k = EdgeTable::key(&a, &b);
            let i = t.find(&k);
            t.keys[i] = k;
            t.counts[i] += 1;
        }
        edges()
            .map(|(a, b)| {
                // A zero-length edge has itself as its reverse: never paired.
                a != b
                    && t.counts[t.find(&EdgeTable::key(&a, &b))] == 1
                    && t.counts[t.find(&EdgeTable::key(&b, &a))] == 1
            })
            .collect()
    }
}

/// [`union_area_delta`] of polygons given as slices.
pub fn union_area_delta_slices(u: &[&[P2]], v: &[&[P2]]) -> f64 {
    delta_prepared(
        Prepared::pruned_of(Prepared::of_slices(u.iter().copied())),
        Prepared::of_slices(v.iter().copied()),
    )
}

/// The parameter interval of segment `a → b` inside convex CCW polygon `q`, or `None`.
/// `wins_tie`: whether `q` keeps a boundary shared on the same side (see [`union_area`]).
fn covered(a: &P2, b: &P2, q: &[P2], wins_tie: bool, tol: f64) -> Option<(f64, f64)> {
    let d = [b[0] - a[0], b[1] - a[1]];
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    let m = q.len();
    for k in 0..m {
        let (q0, q1) = (q[k], q[(k + 1) % m]);
        let e = [q1[0] - q0[0], q1[1] - q0[1]];
        let le = (e[0] * e[0] + e[1] * e[1]).sqrt();
        if le == 0.0 {
            continue;
        }
        // Signed distances of a and b from the edge line, positive inside (left).
        let f0 = (e[0] * (a[1] - q0[1]) - e[1] * (a[0] - q0[0])) / le;
        let f1 = (e[0] * (b[1] - q0[1]) - e[1] * (b[0] - q0[0])) / le;
        if f0.abs() <= tol && f1.abs() <= tol {
            let same = e[0] * d[0] + e[1] * d[1] > 0.0;
            if same && !wins_tie {
                return None;
            }
            continue;
        }
        if f0 <= 0.0 && f1 <= 0.0 {
            return None;
        }
        if f0 < 0.0 {
            t0 = t0.max(f0 / (f0 - f1));
        } else if f1 < 0.0 {
            t1 = t1.min(f0 / (f0 - f1));
        }
        if t0 >= t1 {
            return None;
        }
    }
    Some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rect(x0: f64, y0: f64, x1: f64, y1: f64) -> Vec<P2> {
        vec![[x0, y0], [x1, y0], [x1, y1], [x0, y1]]
    }

    #[test]
    fn grid_index_gives_the_same_union_as_the_plain_scan() {
        // 300 random convex polygons (triangles and boxes, many overlapping and some
        // sharing edges exactly): the grid only filters candidates, so the merged
        // intervals and hence the areas must agree to the last bit.
        let mut rng = crate::base::rng::SplitMix64(99);
        let mut unit = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        let mut polys: Vec<Vec<P2>> = Vec::new();
        for k in 0..300 {
            let (x, y) = (10.0 * unit(), 10.0 * unit());
            if k % 3 == 0 {
                polys.push(rect(x.floor(), y.floor(), x.floor() + 1.0, y.floor() + 1.0));
            } else {
                let p = vec![[x, y], [x + unit(), y + 0.1 * unit()], [x + 0.5 * unit(), y + unit()]];
                polys.push(hull2(p));
            }
        }
        // Long thin diagonal triangles, which the grid walks cell by cell along their edges.
        for k in 0..40 {
            let (x, y) = (unit(), 10.0 * unit());
            let d = if k % 2 == 0 { 1.0 } else { -1.0 };
            polys.push(hull2(vec![
                [x, y],
                [x + 9.0, y + d * 0.9 * y.min(10.0 - y)],
                [x + 0.1, y + 0.05],
            ]));
        }
        let slices: Vec<&[P2]> = polys.iter().map(Vec::as_slice).collect();
        let with_grid = union_area(&polys);
        let paired_grid = union_area_paired(&slices);
        let (u, v) = polys.split_at(170);
        let delta_grid = union_area_delta(u, v);
        GRID_FROM_TEST.with(|c| c.set(usize::MAX));
        let plain = union_area(&polys);
        let paired_plain = union_area_paired(&slices);
        let delta_plain = union_area_delta(u, v);
        GRID_FROM_TEST.with(|c| c.set(GRID_FROM));
        assert_eq!(with_grid.to_bits(), plain.to_bits(), "{with_grid} vs {plain}");
        assert_eq!(
            paired_grid.to_bits(),
            paired_plain.to_bits(),
            "{paired_grid} vs {paired_plain}"
        );
        assert_eq!(delta_grid.to_bits(), delta_plain.to_bits());
        assert!(with_grid > 10.0 && with_grid < 121.0);
    }

    /// Regression (found by projecting boundary faces nearly edge-on, rotated four-room
    /// scene): two triangles sharing an edge, plus two sliver triangles of area ~1e-13
    /// lying along their bottom edges. The tie rules read each sliver as an inside on both
    /// sides of its line and dropped the real bottom edges: 4.1346 instead of 4.5962
    /// (reference: shapely's `unary_union` of the same polygons).
    #[test]
    fn sliver_polygons_along_edges_do_not_remove_them() {
        let polys: Vec<Vec<P2>> = vec![
            vec![
                [-2.1943763778583962, -1.0884449054946372],
                [-0.4567131227837584, -0.7635966148063513],
                [0.9134262455671704, 1.52719322961295],
            ],
            vec![
                [-2.1943763778583962, -1.0884449054946372],
                [1.280950132291134, -0.4387483241183688],
                [-0.4567131227837584, -0.7635966148063513],
            ],
            vec![
                [-0.4567131227837584, -0.7635966148063513],
                [1.280950132291134, -0.4387483241183688],
                [2.3235480853359265, -0.2438393497054296],
            ],
            vec![
                [-0.4567131227837584, -0.7635966148063513],
                [2.3235480853359265, -0.2438393497054296],
                [0.9134262455671704, 1.52719322961295],
            ],
        ];
        let a = union_area(&polys);
        assert!((a - 4.596194077712642).abs() < 1e-12, "{a}");
        let (u, v) = polys.split_at(2);
        let d = union_area_delta(u, v);
        assert!((union_area(u) + d - a).abs() < 1e-12);
    }

    /// Random triangles, each edge shadowed by a sliver lying along its line (overlapping
    /// the edge, running past its ends, or both): the slivers add at most their own
    /// (~1e-12) area, so the union must not move by more than that.
    #[test]
    fn slivers_do_not_change_unions_of_random_triangles() {
        let mut rng = crate::base::rng::SplitMix64(7);
        let mut unit = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        for _ in 0..50 {
            let mut clean: Vec<Vec<P2>> = Vec::new();
            for _ in 0..8 {
                let (x, y) = (4.0 * unit(), 4.0 * unit());
                clean.push(hull2(vec![
                    [x, y],
                    [x + unit(), y + 0.2 * unit()],
                    [x + 0.3 * unit(), y + unit()],
                ]));
            }
            let mut slivers: Vec<Vec<P2>> = Vec::new();
            for t in &clean {
                for k in 0..3 {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    let at = |s: f64, off: f64| {
                        [
                            a[0] + s * (b[0] - a[0]) - off * (b[1] - a[1]),
                            a[1] + s * (b[1] - a[1]) + off * (b[0] - a[0]),
                        ]
                    };
                    // Two points on the edge's line and one within 1e-12 of it, from half
                    // an edge before it to half an edge past it; every other edge keeps
                    // its own first vertex.
                    let p = if k % 2 == 0 { a } else { at(2.0 * unit() - 0.5, 0.0) };
                    let q = at(2.0 * unit() - 0.5, 0.0);
                    let r = at(2.0 * unit() - 0.5, (unit() - 0.5) * 2e-12);
                    let sliver = hull2(vec![p, q, r]);
                    if sliver.len() == 3 {
                        slivers.push(sliver);
                    }
                }
            }
            // Slivers first: the tie rules favour lower indices.
            let noisy: Vec<Vec<P2>> = slivers.into_iter().chain(clean.iter().cloned()).collect();
            let (x, y) = (union_area(&clean), union_area(&noisy));
            assert!((x - y).abs() < 1e-9, "clean {x} with slivers {y}");
        }
    }

    /// Brute-force reference: vertical slabs between all vertex abscissae and all edge
    /// crossings; inside a slab the union's cross-section length is linear in `x`, so the
    /// length at the slab's middle times its width is its exact area.
    fn slab_union_area(polys: &[Vec<P2>]) -> f64 {
        let polys: Vec<&Vec<P2>> = polys.iter().filter(|p| p.len() >= 3).collect();
        let edges: Vec<(P2, P2)> = polys
            .iter()
            .flat_map(|p| (0..p.len()).map(move |k| (p[k], p[(k + 1) % p.len()])))
            .collect();
        let mut xs: Vec<f64> = polys.iter().flat_map(|p| p.iter().map(|v| v[0])).collect();
        for (i, &(p, q)) in edges.iter().enumerate() {
            for &(r, s) in &edges[i + 1..] {
                let d = [q[0] - p[0], q[1] - p[1]];
                let e = [s[0] - r[0], s[1] - r[1]];
                let den = d[0] * e[1] - d[1] * e[0];
                if den == 0.0 {
                    continue;
                }
                let w = [r[0] - p[0], r[1] - p[1]];
                let t = (w[0] * e[1] - w[1] * e[0]) / den;
                let u = (w[0] * d[1] - w[1] * d[0]) / den;
                if (0.0..=1.0).contains(&t) && (0.0..=1.0).contains(&u) {
                    xs.push(p[0] + t * d[0]);
                }
            }
        }
        xs.sort_by(f64::total_cmp);
        xs.dedup();
        let mut area = 0.0;
        for w in xs.windows(2) {
            let xm = 0.5 * (w[0] + w[1]);
            let mut iv: Vec<(f64, f64)> = Vec::new();
            for p in &polys {
                let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
                for k in 0..p.len() {
                    let (a, b) = (p[k], p[(k + 1) % p.len()]);
                    if (a[0] - xm) * (b[0] - xm) < 0.0 {
                        let y = a[1] + (xm - a[0]) / (b[0] - a[0]) * (b[1] - a[1]);
                        lo = lo.min(y);
                        hi = hi.max(y);
                    }
                }
                if hi > lo {
                    iv.push((lo, hi));
                }
            }
            merge_intervals(&mut iv);
            area += (w[1] - w[0]) * iv.iter().map(|(a, b)| b - a).sum::<f64>();
        }
        area
    }

    /// Random sets with every case the tie rules and the pairing see: tilings of a grid
    /// by triangles (exactly shared edges: paired), random convex polygons overlapping
    /// them, duplicates (an edge twice on one side: not paired), nested polygons, and
    /// rectangles sharing edge lines.
    fn random_sets(seed: u64, count: usize) -> Vec<Vec<Vec<P2>>> {
        let mut rng = crate::base::rng::SplitMix64(seed);
        let mut unit = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        let mut sets = Vec::new();
        for s in 0..count {
            let mut polys: Vec<Vec<P2>> = Vec::new();
            // A jittered grid of n × n quads, each split into two triangles along a diagonal.
            let n = 2 + s % 5;
            let jit: Vec<Vec<P2>> = (0..=n)
                .map(|i| {
                    (0..=n)
                        .map(|j| [i as f64 + 0.3 * (unit() - 0.5), j as f64 + 0.3 * (unit() - 0.5)])
                        .collect()
                })
                .collect();
            for i in 0..n {
                for j in 0..n {
                    let (a, b, c, d) = (jit[i][j], jit[i + 1][j], jit[i + 1][j + 1], jit[i][j + 1]);
                    if unit() < 0.85 {
                        polys.push(hull2(vec![a, b, c]));
                        polys.push(hull2(vec![a, c, d]));
                    }
                }
            }
            for _ in 0..(s % 7) {
                let (x, y) = (n as f64 * unit(), n as f64 * unit());
                let r = 0.2 + unit();
                polys.push(hull2((0..6).map(|_| [x + r * unit(), y + r * unit()]).collect()));
            }
            if s % 3 == 0 && !polys.is_empty() {
                let k = (unit() * polys.len() as f64) as usize % polys.len();
                polys.push(polys[k].clone());
            }
            if s % 4 == 1 {
                polys.push(rect(0.2, 0.2, 0.4, 0.4));
                polys.push(rect(-1.0, 0.0, 0.0, 1.0));
                polys.push(rect(-1.0, 0.5, 0.0, 1.5));
            }
            // Shuffle so that the tie rules meet every order.
            for i in (1..polys.len()).rev() {
                let j = (unit() * (i + 1) as f64) as usize % (i + 1);
                polys.swap(i, j);
            }
            sets.push(polys);
        }
        sets
    }

    #[test]
    fn paired_union_matches_the_slab_reference_and_union_area() {
        let mut paired_somewhere = 0;
        for polys in random_sets(2026, 60) {
            let slices: Vec<&[P2]> = polys.iter().map(Vec::as_slice).collect();
            let fast = union_area_paired(&slices);
            let reference = slab_union_area(&polys);
            let old = union_area(&polys);
            assert!(
                (fast - reference).abs() <= 1e-9 * reference.max(1.0),
                "paired {fast} slab {reference}"
            );
            assert!(
                (fast - old).abs() <= 1e-9 * old.max(1.0),
                "paired {fast} union_area {old}"
            );
            let kept = Prepared::of_slices(slices.iter().copied());
            paired_somewhere += EdgeTable::paired(&kept.polys).iter().filter(|&&p| p).count();
            // Split into two halves: the incremental form agrees too.
            let (u, v) = slices.split_at(slices.len() / 2);
            let inc = union_area_paired(u) + union_area_delta_slices(u, v);
            assert!(
                (inc - reference).abs() <= 1e-9 * reference.max(1.0),
                "incremental {inc} slab {reference}"
            );
        }
        assert!(paired_somewhere > 1000, "{paired_somewhere}");
    }

    #[test]
    fn slab_reference_is_right_on_known_unions() {
        assert!((slab_union_area(&[rect(0.0, 0.0, 2.0, 2.0), rect(1.0, 1.0, 3.0, 3.0)]) - 7.0).abs() < 1e-12);
        let tri = vec![vec![[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]], rect(0.0, 0.0, 1.0, 1.0)];
        assert!((slab_union_area(&tri) - 2.0).abs() < 1e-12);
    }

    #[test]
    fn frame_is_canonical_and_orthonormal() {
        let f = Frame::new([0.0, 0.0, -2.0], [1.0, 2.0, 3.0]).unwrap();
        assert_eq!(f.n, [0.0, 0.0, 1.0]);
        let g = Frame::new([0.0, 0.0, 5.0], [1.0, 2.0, 3.0]).unwrap();
        assert_eq!(f, g);
        let h = Frame::new([0.3, -0.4, 0.2], [0.0; 3]).unwrap();
        assert!(dot(&h.u, &h.v).abs() < 1e-15 && dot(&h.u, &h.n).abs() < 1e-15);
        assert!((norm(&h.u) - 1.0).abs() < 1e-15 && (norm(&h.v) - 1.0).abs() < 1e-15);
        assert!(Frame::new([0.0; 3], [0.0; 3]).is_none());
    }

    #[test]
    fn hull_and_bbox() {
        let pts = vec![[0.0, 0.0], [2.0, 0.0], [1.0, 1.0], [2.0, 2.0], [0.0, 2.0], [1.0, 0.0]];
        let h = hull2(pts.clone());
        assert_eq!(h.len(), 4);
        assert_eq!(polygon_area(&h), 4.0);
        assert_eq!(bbox_area(&pts), 4.0);
        let tri = hull2(vec![[0.0, 0.0], [2.0, 0.0], [0.0, 2.0]]);
        assert_eq!(polygon_area(&tri), 2.0);
        assert_eq!(bbox_area(&tri), 4.0);
    }

    #[test]
    fn union_of_overlapping_abutting_and_identical_rectangles() {
        // Two overlapping unit-offset squares: 4 + 4 - 1 = 7.
        let a = union_area(&[rect(0.0, 0.0, 2.0, 2.0), rect(1.0, 1.0, 3.0, 3.0)]);
        assert!((a - 7.0).abs() < 1e-12, "{a}");
        // Abutting (shared edge, opposite sides): 2 + 2.
        let a = union_area(&[rect(0.0, 0.0, 1.0, 2.0), rect(1.0, 0.0, 2.0, 2.0)]);
        assert!((a - 4.0).abs() < 1e-12, "{a}");
        // Identical and nested.
        let a = union_area(&[
            rect(0.0, 0.0, 1.0, 1.0),
            rect(0.0, 0.0, 1.0, 1.0),
            rect(0.2, 0.2, 0.5, 0.5),
        ]);
        assert!((a - 1.0).abs() < 1e-12, "{a}");
        // Same-side overlap along a shared edge line: [0,2]x[0,1] and [1,3]x[0,1] -> 3.
        let a = union_area(&[rect(0.0, 0.0, 2.0, 1.0), rect(1.0, 0.0, 3.0, 1.0)]);
        assert!((a - 3.0).abs() < 1e-12, "{a}");
        // Disjoint.
        let a = union_area(&[rect(0.0, 0.0, 1.0, 1.0), rect(5.0, 5.0, 6.0, 7.0)]);
        assert!((a - 3.0).abs() < 1e-12, "{a}");
    }

    #[test]
    fn union_matches_grid_sampling_on_random_triangles() {
        let mut s = 12345u64;
        let mut r = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 11) as f64 / (1u64 << 53) as f64
        };
        for _ in 0..5 {
            let polys: Vec<Vec<P2>> = (0..12)
                .map(|_| hull2((0..5).map(|_| [r() * 10.0, r() * 10.0]).collect()))
                .collect();
            let exact = union_area(&polys);
            // Midpoint sampling on a fine grid.
            let n = 800;
            let mut inside = 0usize;
            for i in 0..n {
                for j in 0..n {
                    let p = [(i as f64 + 0.5) * 10.0 / n as f64, (j as f64 + 0.5) * 10.0 / n as f64];
                    if polys
                        .iter()
                        .any(|q| (0..q.len()).all(|k| cross2(&q[k], &q[(k + 1) % q.len()], &p) >= 0.0))
                    {
                        inside += 1;
                    }
                }
            }
            let sampled = inside as f64 * 100.0 / (n * n) as f64;
            assert!((exact - sampled).abs() < 0.05, "exact {exact} sampled {sampled}");
            // Never more than the sum, never less than the largest.
            let sum: f64 = polys.iter().map(|p| polygon_area(p)).sum();
            let max = polys.iter().map(|p| polygon_area(p)).fold(0.0, f64::max);
            assert!(exact <= sum + 1e-9 && exact >= max - 1e-9);
            // Incremental: the area of U plus what V adds equals the union of both.
            let (u, v) = polys.split_at(7);
            let inc = union_area(u) + union_area_delta(u, v);
            assert!((inc - exact).abs() < 1e-9 * exact, "incremental {inc} exact {exact}");
        }
    }

    #[test]
    fn delta_handles_shared_edges_and_duplicates() {
        let u = vec![rect(0.0, 0.0, 1.0, 1.0), rect(1.0, 0.0, 2.0, 1.0)];
        // Abutting, overlapping, identical and contained additions.
        for (v, want) in [
            (vec![rect(2.0, 0.0, 3.0, 1.0)], 1.0),
            (vec![rect(1.5, 0.0, 2.5, 1.0)], 0.5),
            (vec![rect(0.0, 0.0, 1.0, 1.0)], 0.0),
            (vec![rect(0.2, 0.2, 0.4, 0.4), rect(0.0, 1.0, 2.0, 2.0)], 2.0),
        ] {
            let d = union_area_delta(&u, &v);
            assert!((d - want).abs() < 1e-12, "{d} vs {want}");
        }
    }
}
