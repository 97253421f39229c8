//! Planarity and convexity tests, and in-plane triangulation of polygons that fail them.
//!
//! All decisions use the exact predicates; the only floating-point quantity is the Newell
//! normal, used to choose the projection axis (any axis along which the plane is not seen
//! edge-on works) and the polygon's orientation in that projection.

use std::cmp::Ordering;

use crate::base::vec::{cross, dot, normalize, sub};
use crate::predicates::{collinear, orient2d_proj, orient3d};

/// What to do with a polygon.
#[derive(Debug, PartialEq)]
pub(crate) enum Shape {
    /// Planar and convex (or a triangle): keep as it is.
    Keep,
    /// Replace by these triangles (vertex ids, same winding as the polygon).
    Triangulated {
        tris: Vec<[u32; 3]>,
        nonplanar: bool,
        /// The projection was not simple; the triangulation is best-effort.
        fallback: bool,
        /// A non-planar polygon whose outline crosses itself in its projection, with at
        /// most [`MIN_AREA_MAX_VERTICES`] vertices: triangulated in 3D by minimum total
        /// area ([`min_area_3d`]) instead.
        min_area: bool,
    },
}

/// The two coordinates kept when dropping axis `k`, in [`orient2d_proj`]'s order.
fn proj_axes(k: usize) -> (usize, usize) {
    match k {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    }
}

/// Classifies polygon `poly` (vertex ids into `pts`). Precondition: at least 3 vertices, no two
/// consecutive equal, not all collinear, and `normal` (its Newell normal) is not zero.
pub(crate) fn classify(pts: &[[f64; 3]], poly: &[u32], normal: [f64; 3]) -> Shape {
    let n = poly.len();
    if n <= 3 {
        return Shape::Keep;
    }
    let p = |i: usize| &pts[poly[i] as usize];
    let a = p(0);
    let b = p(1);
    let Some(ci) = (2..n).find(|&i| !collinear(a, b, p(i))) else {
        // Violated precondition (all collinear): nothing sensible to triangulate.
        return Shape::Keep;
    };
    let c = p(ci);
    let planar = (2..n).all(|i| orient3d(a, b, c, p(i)) == 0);

    // Projection axis: the dominant axis of the normal; for a planar polygon make sure the
    // plane is not seen edge-on along it (exactly).
    let mut axes = [0usize, 1, 2];
    axes.sort_by(|&i, &j| normal[j].abs().partial_cmp(&normal[i].abs()).unwrap_or(Ordering::Equal));
    let k = if planar {
        axes.into_iter()
            .find(|&k| orient2d_proj(a, b, c, k) != 0)
            .unwrap_or(axes[0])
    } else {
        axes[0]
    };
    let s = if normal[k] < 0.0 {
        -1
    } else if normal[k] > 0.0 {
        1
    } else {
        // Only reachable for a planar polygon seen edge-on by the float normal; the exact
        // orientation of the first non-collinear triple is as good a guess as any.
        let o = orient2d_proj(a, b, c, k);
        if o == 0 { 1 } else { o }
    };

    let has_repeat = {
        let mut v = poly.to_vec();
        v.sort_unstable();
        v.windows(2).any(|w| w[0] == w[1])
    };
    if planar && !has_repeat && convex_2d(pts, poly, k, s) && corners(pts, poly) <= LARGE_CONVEX_VERTICES {
        return Shape::Keep;
    }

    // A quad whose projection is strictly convex: split along the shorter diagonal.
    if n == 4 && !has_repeat {
        let turns_ok = (0..4).all(|i| orient2d_proj(p((i + 3) % 4), p(i), p((i + 1) % 4), k) * s > 0);
        let winds_once = sign_changes(pts, poly, k) == 2;
        if turns_ok && winds_once {
            let d02 = dist2(p(0), p(2));
            let d13 = dist2(p(1), p(3));
            let tris = if d02 <= d13 {
                vec![[poly[0], poly[1], poly[2]], [poly[0], poly[2], poly[3]]]
            } else {
                vec![[poly[1], poly[2], poly[3]], [poly[1], poly[3], poly[0]]]
            };
            return Shape::Triangulated {
                tris,
                nonplanar: !planar,
                fallback: false,
                min_area: false,
            };
        }
    }

    // A non-planar polygon whose ear clipping gets stuck is never triangulated by it
    // (below: a quad's diagonal, the minimum-area fill, or a refusal), so it stops there:
    // the best-effort path costs O(n²) ear tests on an outline that crosses itself
    // everywhere (a face of 10k random vertex indices: 77 s before the refusal).
    let (tris, fallback) = ear_clip(pts, poly, k, s, !planar);
    if fallback && !planar && n == 4 && !has_repeat {
        // A warped quad whose outline crosses itself in projection (the
        // vertex noise of a thin face, or a bent quad of a scanned or exported mesh): it is
        // still exactly two triangles along either diagonal, which meet only on it (two
        // triangles sharing an edge and not coplanar cross nowhere else), with the quad's
        // outline as boundary and its winding. Split along the flatter one.
        return Shape::Triangulated {
            tris: warped_quad(pts, poly).to_vec(),
            nonplanar: true,
            fallback: false,
            min_area: false,
        };
    }
    // A non-planar polygon whose outline is not simple in the projection: ear clipping
    // either got stuck (`fallback`) or, worse, found ears anyway and returned triangles
    // whose union is not the outline's surface (the projection is the only thing it
    // sees). Such an outline has no in-plane triangulation; its boundary loop in 3D still
    // spans a surface, and the minimum-area one is the classic hole filling (Barequet &
    // Sharir 1995). O(n³), so only up to `MIN_AREA_MAX_VERTICES`; beyond that (a face of
    // random vertex indices) the caller refuses it.
    // (The exact simplicity test is O(n²): it runs up to `MIN_AREA_MAX_VERTICES`, where
    // its answer picks the minimum-area triangulation; a larger outline is judged by ear
    // clipping alone, as before, and refused only when that gets stuck.)
    if !planar && !has_repeat && (fallback || (n <= MIN_AREA_MAX_VERTICES && !simple_2d(pts, poly, k))) {
        if n <= MIN_AREA_MAX_VERTICES
            && let Some(tris) = min_area_3d(pts, poly)
        {
            return Shape::Triangulated {
                tris,
                nonplanar: true,
                fallback: false,
                min_area: true,
            };
        }
        return Shape::Triangulated {
            tris,
            nonplanar: true,
            fallback: true,
            min_area: false,
        };
    }
    Shape::Triangulated {
        tris,
        nonplanar: !planar,
        fallback,
        min_area: false,
    }
}

/// The most vertices a planar convex polygon keeps as one polygon. Splitting the cells by
/// a polygon clips it against every cell it meets, so one polygon of n vertices on a
/// surface of O(n) cells costs O(n²) (a 10k-gon cap: 12 s of splitting); a larger one is
/// ear-clipped like a non-convex polygon (`triangles_from_triangulation`), which on a
/// convex outline, going on two vertices after each ear, halves it pass by pass into
/// triangles no thinner than the outline's own corners need. Only corners count
/// (vertices not collinear with their neighbours): straight-angle vertices are dropped
/// from the polygon the splitting clips, so a floor whose four edges carry thousands of
/// wall vertices stays one polygon, clipped as a quad.
pub(crate) const LARGE_CONVEX_VERTICES: usize = 256;

/// The largest non-planar polygon with a self-crossing outline that [`min_area_3d`]
/// triangulates (its cost is O(n³): 64 vertices take ~44k triangle areas). A door frame
/// or window outline under noise has a few dozen at most; larger ones are refused.
pub(crate) const MIN_AREA_MAX_VERTICES: usize = 64;

/// Whether the outline of `poly` projected by dropping axis `k` is simple: no two
/// non-adjacent edges meet, and no two adjacent edges overlap (exact orientation tests).
/// O(n²); only non-planar polygons of at most [`MIN_AREA_MAX_VERTICES`] vertices reach it.
fn simple_2d(pts: &[[f64; 3]], poly: &[u32], k: usize) -> bool {
    let n = poly.len();
    let p = |i: usize| &pts[poly[i % n] as usize];
    // Does point c lie on the closed segment a-b (given the three are collinear)?
    let between = |a: &[f64; 3], b: &[f64; 3], c: &[f64; 3]| {
        let (u, v) = proj_axes(k);
        let within = |x: usize| c[x] >= a[x].min(b[x]) && c[x] <= a[x].max(b[x]);
        within(u) && within(v)
    };
    for i in 0..n {
        let (a, b) = (p(i), p(i + 1));
        // Adjacent edges: the next one must not fold back over this one.
        let c = p(i + 2);
        if orient2d_proj(a, b, c, k) == 0 && !goes_straight(a, b, c, k) {
            return false;
        }
        for j in i + 2..n {
            if i == 0 && j == n - 1 {
                continue; // adjacent through the closing edge
            }
            let (c, d) = (p(j), p(j + 1));
            let (o1, o2) = (orient2d_proj(a, b, c, k), orient2d_proj(a, b, d, k));
            let (o3, o4) = (orient2d_proj(c, d, a, k), orient2d_proj(c, d, b, k));
            if o1 * o2 < 0 && o3 * o4 < 0 {
                return false;
            }
            if (o1 == 0 && between(a, b, c))
                || (o2 == 0 && between(a, b, d))
                || (o3 == 0 && between(c, d, a))
                || (o4 == 0 && between(c, d, b))
            {
                return false;
            }
        }
    }
    true
}

/// The triangulation of the closed 3D loop `poly` (no repeated vertex) with the least
/// total area, by dynamic programming over its sub-chains: each triangle `(i, m, j)` with
/// `i < m < j` keeps the loop's winding. A triangle whose corners are exactly collinear
/// is never used; `None` when no triangulation avoids one. Areas are floating point (a
/// choice among exact triangles, never a geometric decision); ties go to the smallest
/// `m`, so a loop whose areas tie exactly may be triangulated differently when its face
/// starts at another vertex.
pub(crate) fn min_area_3d(pts: &[[f64; 3]], poly: &[u32]) -> Option<Vec<[u32; 3]>> {
    let n = poly.len();
    if n < 3 {
        return None;
    }
    let p = |i: usize| &pts[poly[i] as usize];
    let area = |i: usize, m: usize, j: usize| {
        if collinear(p(i), p(m), p(j)) {
            f64::INFINITY
        } else {
            let c = cross(&sub(p(m), p(i)), &sub(p(j), p(i)));
            dot(&c, &c).sqrt()
        }
    };
    let idx = |i: usize, j: usize| i * n + j;
    let mut cost = vec![0.0f64; n * n];
    let mut best = vec![0usize; n * n];
    for len in 2..n {
        for i in 0..n - len {
            let j = i + len;
            let mut c = f64::INFINITY;
            let mut bm = usize::MAX;
            for m in i + 1..j {
                let v = cost[idx(i, m)] + cost[idx(m, j)] + area(i, m, j);
                if v < c {
                    c = v;
                    bm = m;
                }
            }
            cost[idx(i, j)] = c;
            best[idx(i, j)] = bm;
        }
    }
    if !cost[idx(0, n - 1)].is_finite() {
        return None;
    }
    let mut tris = Vec::with_capacity(n - 2);
    let mut stack = vec![(0usize, n - 1)];
    while let Some((i, j)) = stack.pop() {
        if j < i + 2 {
            continue;
        }
        let m = best[idx(i, j)];
        tris.push([poly[i], poly[m], poly[j]]);
        stack.push((m, j));
        stack.push((i, m));
    }
    Some(tris)
}

/// The two triangles of a non-planar quad `poly` (four distinct vertices) along the diagonal
/// whose triangles' unit normals agree most (the less folded surface), then the shorter
/// diagonal, then 0–2. Both criteria are geometric, so the choice does not depend on which
/// vertex the face starts at (up to exact ties).
fn warped_quad(pts: &[[f64; 3]], poly: &[u32]) -> [[u32; 3]; 2] {
    let p = |i: usize| pts[poly[i % 4] as usize];
    let unit_normal = |a: [f64; 3], b: [f64; 3], c: [f64; 3]| normalize(&cross(&sub(&b, &a), &sub(&c, &a)));
    // Diagonal i–(i+2): triangles (i, i+1, i+2) and (i, i+2, i+3).
    let agreement = |i: usize| {
        let (m, n) = (
            unit_normal(p(i), p(i + 1), p(i + 2)),
            unit_normal(p(i), p(i + 2), p(i + 3)),
        );
        dot(&m, &n)
    };
    let (a0, a1) = (agreement(0), agreement(1));
    let first = match a0.partial_cmp(&a1) {
        Some(Ordering::Greater) => true,
        Some(Ordering::Less) => false,
        _ => dist2(&p(0), &p(2)) <= dist2(&p(1), &p(3)),
    };
    if first {
        [[poly[0], poly[1], poly[2]], [poly[0], poly[2], poly[3]]]
    } else {
        [[poly[1], poly[2], poly[3]], [poly[1], poly[3], poly[0]]]
    }
}

fn dist2(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    (0..3).map(|i| (a[i] - b[i]) * (a[i] - b[i])).sum()
}

/// Number of sign changes (cyclic, zeros skipped) of the first projected coordinate along the
/// polygon's edges. A polygon whose turns all have one sign winds once iff this is 2.
fn sign_changes(pts: &[[f64; 3]], poly: &[u32], k: usize) -> usize {
    let (u, _) = proj_axes(k);
    let n = poly.len();
    let signs: Vec<Ordering> = (0..n)
        .map(|i| {
            let a = pts[poly[i] as usize][u];
            let b = pts[poly[(i + 1) % n] as usize][u];
            b.partial_cmp(&a).unwrap_or(Ordering::Equal)
        })
        .filter(|o| *o != Ordering::Equal)
        .collect();
    (0..signs.len())
        .filter(|&i| signs[i] != signs[(i + 1) % signs.len()])
        .count()
}

/// True when the projected vertices `p, c, n` (collinear in the projection) go straight on at
/// `c`: `c` lies strictly between `p` and `n`.
fn goes_straight(p: &[f64; 3], c: &[f64; 3], n: &[f64; 3], k: usize) -> bool {
    let (u, v) = proj_axes(k);
    let d1 = (c[u].partial_cmp(&p[u]), c[v].partial_cmp(&p[v]));
    let d2 = (n[u].partial_cmp(&c[u]), n[v].partial_cmp(&c[v]));
    let moved = |d: (Option<Ordering>, Option<Ordering>)| d.0 != Some(Ordering::Equal) || d.1 != Some(Ordering::Equal);
    moved(d1) && d1 == d2
}

/// Convex in the projection dropping axis `k` with orientation `s`: no reflex turn, no spike,
/// winding once. Straight angles are allowed.
/// Vertices of `poly` not exactly collinear with their neighbours (see
/// [`crate::model::Model::is_corner`]): the splitting clips only these, so only these
/// count against [`LARGE_CONVEX_VERTICES`].
fn corners(pts: &[[f64; 3]], poly: &[u32]) -> usize {
    let n = poly.len();
    let p = |i: usize| &pts[poly[i % n] as usize];
    (0..n).filter(|&i| !collinear(p(i + n - 1), p(i), p(i + 1))).count()
}

fn convex_2d(pts: &[[f64; 3]], poly: &[u32], k: usize, s: i32) -> bool {
    let n = poly.len();
    let p = |i: usize| &pts[poly[i % n] as usize];
    for i in 0..n {
        let (a, b, c) = (p(i + n - 1), p(i), p(i + 1));
        let t = orient2d_proj(a, b, c, k) * s;
        if t < 0 || (t == 0 && !goes_straight(a, b, c, k)) {
            return false;
        }
    }
    sign_changes(pts, poly, k) == 2
}

/// Up to this many remaining vertices, an ear is tested against every one of them (any
/// turn); above it, only against the non-convex ones, found through [`ReflexGrid`].
const SMALL_EAR_SCAN: usize = 64;

/// The positions of a polygon's vertices whose turn is not convex (`turn <= 0`), bucketed
/// in a uniform grid over the projection (about one per cell), so that an ear test visits
/// only those under the ear's bounding box: ear clipping then costs about O(n) tests per
/// polygon instead of O(n²) (a non-planar or non-convex 100k-gon took about a minute).
/// A vertex inside a triangle lies within its bounding box, and the cell index is a
/// monotone function of each coordinate, so the filter never drops a vertex the exact
/// test would find. In a simple polygon clipping only turns reflex vertices convex; a
/// vertex that turns reflex (a polygon that is not simple) is inserted when it does.
struct ReflexGrid {
    /// The two kept axes ([`proj_axes`]).
    axes: (usize, usize),
    /// Projected coordinates (the two kept axes) per position.
    uv: Vec<[f64; 2]>,
    lo: [f64; 2],
    inv: [f64; 2],
    dim: usize,
    cells: Vec<Vec<u32>>,
    inside: Vec<bool>,
}

impl ReflexGrid {
    fn new(pts: &[[f64; 3]], poly: &[u32], k: usize, turn: &[i32]) -> Self {
        let (u, v) = proj_axes(k);
        let uv: Vec<[f64; 2]> = poly.iter().map(|&i| [pts[i as usize][u], pts[i as usize][v]]).collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in &uv {
            for d in 0..2 {
                lo[d] = lo[d].min(p[d]);
                hi[d] = hi[d].max(p[d]);
            }
        }
        let reflex = turn.iter().filter(|&&t| t <= 0).count();
        let dim = if poly.len() > SMALL_EAR_SCAN {
            ((reflex as f64).sqrt().ceil() as usize).clamp(1, 1024)
        } else {
            1
        };
        let inv = [0, 1].map(|d| {
            let e = hi[d] - lo[d];
            if e > 0.0 && e.is_finite() { dim as f64 / e } else { 0.0 }
        });
        let mut g = ReflexGrid {
            axes: (u, v),
            uv,
            lo,
            inv,
            dim,
            cells: vec![Vec::new(); dim * dim],
            inside: vec![false; poly.len()],
        };
        if poly.len() > SMALL_EAR_SCAN {
            for (i, &t) in turn.iter().enumerate() {
                if t <= 0 {
                    g.insert(i);
                }
            }
        }
        g
    }

    fn cell(&self, x: f64, d: usize) -> usize {
        let c = ((x - self.lo[d]) * self.inv[d]).floor();
        if c >= 0.0 { (c as usize).min(self.dim - 1) } else { 0 }
    }

    fn insert(&mut self, i: usize) {
        if self.inside[i] || self.uv.len() <= SMALL_EAR_SCAN {
            return;
        }
        self.inside[i] = true;
        let p = self.uv[i];
        let c = self.cell(p[1], 1) * self.dim + self.cell(p[0], 0);
        self.cells[c].push(i as u32);
    }

    /// Whether `f` holds for some position bucketed under the bounding box of `tri`
    /// (3D points, read on the grid's two axes).
    fn any_in_box(&self, tri: [&[f64; 3]; 3], mut f: impl FnMut(usize) -> bool) -> bool {
        let (u, v) = self.axes;
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for p in tri {
            for (d, x) in [p[u], p[v]].into_iter().enumerate() {
                lo[d] = lo[d].min(x);
                hi[d] = hi[d].max(x);
            }
        }
        let (c0, c1) = (self.cell(lo[0], 0), self.cell(hi[0], 0));
        for r in self.cell(lo[1], 1)..=self.cell(hi[1], 1) {
            for c in c0..=c1 {
                for &q in &self.cells[r * self.dim + c] {
                    let p = self.uv[q as usize];
                    if p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1] && f(q as usize) {
                        return true;
                    }
                }
            }
        }
        false
    }
}

/// Ear clipping of the projection dropping axis `k`, orientation `s`, with exact predicates.
/// Returns the triangles and whether the best-effort fallback was needed (projection not
/// simple). Triangles are never degenerate in the projection, so never degenerate in 3D.
/// With `stop_when_stuck`, it returns at the first cycle without an ear (the triangles so
/// far, and `true`).
fn ear_clip(pts: &[[f64; 3]], poly: &[u32], k: usize, s: i32, stop_when_stuck: bool) -> (Vec<[u32; 3]>, bool) {
    ear_clip_with(pts, poly, k, s, true, stop_when_stuck)
}

/// [`ear_clip`], finding the blockers of a large polygon's ears through the grid or (the
/// reference the tests compare it with, O(n²)) by walking every remaining vertex.
fn ear_clip_with(
    pts: &[[f64; 3]],
    poly: &[u32],
    k: usize,
    s: i32,
    use_grid: bool,
    stop_when_stuck: bool,
) -> (Vec<[u32; 3]>, bool) {
    let n = poly.len();
    let pos = |i: usize| &pts[poly[i] as usize];
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    let turn_of = |prev: &[usize], next: &[usize], i: usize| orient2d_proj(pos(prev[i]), pos(i), pos(next[i]), k) * s;
    let mut turn: Vec<i32> = (0..n).map(|i| turn_of(&prev, &next, i)).collect();
    let mut tris = Vec::with_capacity(n - 2);
    let mut fallback = false;
    let mut m = n;
    let mut cur = 0usize;

    // Positions clipped so far, and the grid of candidate blockers (see `ReflexGrid`).
    let mut removed = vec![false; n];
    let mut grid = ReflexGrid::new(pts, poly, k, &turn);

    // Is some remaining vertex (other than the triangle's own) in triangle (a, b, c)?
    // `closed` counts the triangle's boundary as inside.
    #[allow(clippy::too_many_arguments)]
    let blocked = |next: &[usize],
                   turn: &[i32],
                   removed: &[bool],
                   grid: &ReflexGrid,
                   m: usize,
                   a: usize,
                   b: usize,
                   c: usize,
                   closed: bool| {
        let (pa, pb, pc) = (pos(a), pos(b), pos(c));
        let (va, vb, vc) = (poly[a], poly[b], poly[c]);
        let test = |q: usize| {
            let vq = poly[q];
            if vq == va || vq == vb || vq == vc {
                return false;
            }
            let pq = pos(q);
            let o1 = orient2d_proj(pa, pb, pq, k) * s;
            let o2 = orient2d_proj(pb, pc, pq, k) * s;
            let o3 = orient2d_proj(pc, pa, pq, k) * s;
            if closed {
                o1 >= 0 && o2 >= 0 && o3 >= 0
            } else {
                o1 > 0 && o2 > 0 && o3 > 0
            }
        };
        if m > SMALL_EAR_SCAN && use_grid {
            // In a simple polygon, only a non-convex vertex can be the first to enter an
            // ear: the remaining ones with `turn <= 0`, from the grid cells under the
            // triangle's bounding box (the same set as the walk below, in another order;
            // the answer is whether the set holds one, so it is the walk's).
            return grid.any_in_box([pa, pb, pc], |q| {
                !removed[q] && q != a && q != b && q != c && turn[q] <= 0 && test(q)
            });
        }
        let mut q = next[c];
        while q != a {
            if (m <= SMALL_EAR_SCAN || turn[q] <= 0) && test(q) {
                return true;
            }
            q = next[q];
        }
        false
    };

    let mut tried = 0usize;
    while m > 3 {
        let mut clip = None;
        if tried < m {
            let (a, c) = (prev[cur], next[cur]);
            if turn[cur] > 0 && !blocked(&next, &turn, &removed, &grid, m, a, cur, c, true) {
                clip = Some(cur);
            } else {
                cur = next[cur];
                tried += 1;
                continue;
            }
        }
        let clip = match clip {
            Some(i) => i,
            None => {
                // No proper ear in a whole cycle: the projection is not simple. Take the first
                // convex vertex with an empty open triangle, else any convex vertex.
                if stop_when_stuck {
                    return (tris, true);
                }
                fallback = true;
                let mut found = None;
                for closed_pass in [false, true] {
                    let mut i = cur;
                    for _ in 0..m {
                        if turn[i] > 0
                            && (closed_pass || !blocked(&next, &turn, &removed, &grid, m, prev[i], i, next[i], false))
                        {
                            found = Some(i);
                            break;
                        }
                        i = next[i];
                    }
                    if found.is_some() {
                        break;
                    }
                }
                match found {
                    Some(i) => i,
                    // Nothing left with positive area.
                    None => return (tris, true),
                }
            }
        };
        let (a, c) = (prev[clip], next[clip]);
        tris.push([poly[a], poly[clip], poly[c]]);
        next[a] = c;
        prev[c] = a;
        removed[clip] = true;
        m -= 1;
        turn[a] = turn_of(&prev, &next, a);
        turn[c] = turn_of(&prev, &next, c);
        // A vertex that turns reflex (only in a polygon that is not simple) becomes a
        // candidate blocker like the others.
        for x in [a, c] {
            if turn[x] <= 0 {
                grid.insert(x);
            }
        }
        // Go on from the vertex after the ear; in a large polygon, from the one after
        // that (earcut's rule): continuing at `c` clips a convex stretch as a fan around
        // `a`, whose ever longer slivers cover ever more of the grid (O(n²) on a 100k-gon)
        // and make sliver cells in the complex.
        cur = if m > SMALL_EAR_SCAN { next[c] } else { c };
        tried = 0;
    }
    let (a, c) = (prev[cur], next[cur]);
    if turn_of(&prev, &next, cur) > 0 {
        tris.push([poly[a], poly[cur], poly[c]]);
    } else {
        fallback = true;
    }
    (tris, fallback)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::newell;

    fn run(pts: &[[f64; 3]], poly: &[u32]) -> Shape {
        let nrm = newell(poly.iter().map(|&i| &pts[i as usize]));
        classify(pts, poly, nrm)
    }

    fn area2(pts: &[[f64; 3]], t: &[u32; 3]) -> [f64; 3] {
        newell(t.iter().map(|&i| &pts[i as usize]))
    }

    fn check_tris(pts: &[[f64; 3]], poly: &[u32], tris: &[[u32; 3]]) {
        let pn = newell(poly.iter().map(|&i| &pts[i as usize]));
        let mut sum = [0.0; 3];
        for t in tris {
            let a = area2(pts, t);
            // Same winding as the polygon.
            let dot: f64 = (0..3).map(|i| a[i] * pn[i]).sum();
            assert!(dot > 0.0, "triangle {t:?} flipped");
            for i in 0..3 {
                sum[i] += a[i];
            }
        }
        for i in 0..3 {
            assert!((sum[i] - pn[i]).abs() < 1e-9, "area not preserved: {sum:?} vs {pn:?}");
        }
    }

    #[test]
    fn convex_planar_quad_kept() {
        let pts = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        assert_eq!(run(&pts, &[0, 1, 2, 3]), Shape::Keep);
        assert_eq!(run(&pts, &[3, 2, 1, 0]), Shape::Keep);
    }

    #[test]
    fn convex_with_straight_angle_kept() {
        // Square with an extra vertex in the middle of its bottom edge, tilted plane.
        let pts = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 1.0],
            [2.0, 0.0, 2.0],
            [2.0, 2.0, 2.0],
            [0.0, 2.0, 0.0],
        ];
        assert_eq!(run(&pts, &[0, 1, 2, 3, 4]), Shape::Keep);
    }

    #[test]
    fn spike_is_not_convex() {
        // 0 -> 1 -> 2 goes back along the same line.
        let pts = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
        match run(&pts, &[0, 1, 2, 3]) {
            Shape::Triangulated { .. } => {}
            s => panic!("{s:?}"),
        }
    }

    #[test]
    fn pentagram_is_not_convex() {
        let star: Vec<[f64; 3]> = (0..5)
            .map(|i| {
                let a = (i as f64) * 4.0 * std::f64::consts::PI / 5.0;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let poly = [0, 1, 2, 3, 4];
        match run(&star, &poly) {
            Shape::Triangulated { fallback, .. } => assert!(fallback),
            s => panic!("{s:?}"),
        }
    }

    #[test]
    fn l_shape_triangulated() {
        // L-shape in the plane y = 1, CCW seen from -y.
        let l2 = [[0.0, 0.0], [2.0, 0.0], [2.0, 1.0], [1.0, 1.0], [1.0, 2.0], [0.0, 2.0]];
        let pts: Vec<[f64; 3]> = l2.iter().map(|p| [p[0], 1.0, p[1]]).collect();
        let poly = [0u32, 1, 2, 3, 4, 5];
        match run(&pts, &poly) {
            Shape::Triangulated {
                tris,
                nonplanar,
                fallback,
                ..
            } => {
                assert_eq!(tris.len(), 4);
                assert!(!nonplanar && !fallback);
                check_tris(&pts, &poly, &tris);
            }
            s => panic!("{s:?}"),
        }
    }

    #[test]
    fn comb_triangulated() {
        // A comb with collinear vertices along its base, planar in z = 3.
        let c2 = [
            [0.0, 0.0],
            [1.0, 0.0],
            [2.0, 0.0],
            [3.0, 0.0],
            [4.0, 0.0],
            [4.0, 3.0],
            [3.0, 3.0],
            [3.0, 1.0],
            [2.0, 1.0],
            [2.0, 3.0],
            [1.0, 3.0],
            [1.0, 1.0],
            [0.5, 1.0],
            [0.0, 3.0],
        ];
        let pts: Vec<[f64; 3]> = c2.iter().map(|p| [p[0], p[1], 3.0]).collect();
        let poly: Vec<u32> = (0..pts.len() as u32).collect();
        match run(&pts, &poly) {
            Shape::Triangulated { tris, fallback, .. } => {
                assert!(!fallback);
                assert_eq!(tris.len(), pts.len() - 2);
                check_tris(&pts, &poly, &tris);
            }
            s => panic!("{s:?}"),
        }
    }

    #[test]
    fn big_convex_fan_with_many_vertices() {
        // A convex 256-gon is kept; a convex 2000-gon is triangulated (splitting by one
        // polygon is quadratic in its vertices), into triangles no thinner than needed:
        // halving passes, not a fan (whose smallest angle would be ~TAU/2000).
        let circle = |n: usize| -> Vec<[f64; 3]> {
            (0..n)
                .map(|i| {
                    let a = i as f64 * std::f64::consts::TAU / n as f64;
                    [a.cos(), a.sin(), 0.0]
                })
                .collect()
        };
        let kept = circle(LARGE_CONVEX_VERTICES);
        assert_eq!(run(&kept, &(0..kept.len() as u32).collect::<Vec<_>>()), Shape::Keep);
        let n = 2000;
        let mut pts = circle(n);
        let poly: Vec<u32> = (0..n as u32).collect();
        match run(&pts, &poly) {
            Shape::Triangulated {
                tris,
                nonplanar,
                fallback,
                min_area,
            } => {
                assert!(!nonplanar && !fallback && !min_area);
                assert_eq!(tris.len(), n - 2);
                check_tris(&pts, &poly, &tris);
                // No vertex is a corner of more than about a hundred triangles (a fan's
                // apex would be of n - 2; the last 64 vertices are clipped as in a small
                // polygon, so one of them may be a fan's apex there).
                let mut uses = vec![0usize; n];
                for t in &tris {
                    for &v in t {
                        uses[v as usize] += 1;
                    }
                }
                assert!(
                    uses.iter().all(|&u| u <= SMALL_EAR_SCAN + 2 * 11),
                    "{:?}",
                    uses.iter().max()
                );
            }
            s => panic!("{s:?}"),
        }
        pts[7] = [0.5, 0.1, 0.0];
        match run(&pts, &poly) {
            Shape::Triangulated { tris, fallback, .. } => {
                assert!(!fallback);
                assert_eq!(tris.len(), n - 2);
                check_tris(&pts, &poly, &tris);
            }
            s => panic!("{s:?}"),
        }
    }

    #[test]
    fn nonplanar_quad_split_along_shorter_diagonal() {
        let pts = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 1.0, 0.5], [0.0, 1.0, 0.0]];
        match run(&pts, &[0, 1, 2, 3]) {
            Shape::Triangulated {
                tris,
                nonplanar,
                fallback,
                ..
            } => {
                assert!(nonplanar && !fallback);
                // |0-2|^2 = 5.25, |1-3|^2 = 5: split along 1-3.
                assert_eq!(tris, vec![[1, 2, 3], [1, 3, 0]]);
            }
            s => panic!("{s:?}"),
        }
    }

    #[test]
    fn warped_quad_crossing_in_projection_is_split_along_its_flatter_diagonal() {
        // A bow tie seen from +z, the dominant axis of its Newell normal (0, 0, 1): edge
        // 0-1 crosses edge 2-3; vertices 1 and 3 are lifted out of the plane.
        let pts = [[0.0, 0.0, 0.0], [1.0, 1.0, 0.3], [1.0, 0.0, 0.0], [0.0, 2.0, 0.3]];
        let (tris, fallback) = ear_clip(&pts, &[0, 1, 2, 3], 2, 1, false);
        assert!(fallback, "the projection must cross itself for this test: {tris:?}");
        let poly = [0u32, 1, 2, 3];
        let shape = run(&pts, &poly);
        let Shape::Triangulated {
            tris,
            nonplanar,
            fallback,
            ..
        } = shape
        else {
            panic!("{shape:?}")
        };
        assert!(nonplanar && !fallback, "a warped quad is not a best-effort fallback");
        assert_eq!(tris.len(), 2);
        // The same diagonal from every starting vertex, and the quad's own boundary.
        for r in 0..4 {
            let rotated: Vec<u32> = (0..4).map(|i| poly[(i + r) % 4]).collect();
            let Shape::Triangulated { tris: t, .. } = run(&pts, &rotated) else {
                panic!()
            };
            let diag = |t: &[[u32; 3]]| {
                let mut d: Vec<u32> = t[0].iter().filter(|v| t[1].contains(v)).copied().collect();
                d.sort();
                d
            };
            assert_eq!(diag(&t), diag(&tris), "start {r}");
        }
        let all: Vec<(u32, u32)> = tris
            .iter()
            .flat_map(|t| (0..3).map(move |i| (t[i], t[(i + 1) % 3])))
            .collect();
        let mut edges: Vec<(u32, u32)> = all.iter().copied().filter(|&(a, b)| !all.contains(&(b, a))).collect();
        edges.sort();
        assert_eq!(edges, vec![(0, 1), (1, 2), (2, 3), (3, 0)]);
    }

    #[test]
    fn nonconvex_quad_uses_inner_diagonal() {
        // Dart: vertex 3 is reflex, so only diagonal 1-3 is inside.
        let pts = [[0.0, 0.0, 0.0], [2.0, 1.0, 0.0], [0.0, 2.0, 0.0], [0.5, 1.0, 0.0]];
        match run(&pts, &[0, 1, 2, 3]) {
            Shape::Triangulated { tris, .. } => {
                assert_eq!(tris.len(), 2);
                check_tris(&pts, &[0, 1, 2, 3], &tris);
                for t in &tris {
                    assert!(t.contains(&1) && t.contains(&3), "{tris:?}");
                }
            }
            s => panic!("{s:?}"),
        }
    }

    #[test]
    fn polygon_touching_itself_is_triangulated() {
        // Two squares sharing vertex 0 (figure eight with one touching point).
        let pts = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [-1.0, 0.0, 0.0],
            [-1.0, -1.0, 0.0],
            [0.0, -1.0, 0.0],
        ];
        let poly = [0u32, 1, 2, 3, 0, 4, 5, 6];
        // Newell of this is 2 * (1 + 1) in z; classify must not keep it.
        match run(&pts, &poly) {
            Shape::Triangulated { tris, .. } => check_tris(&pts, &poly, &tris),
            s => panic!("{s:?}"),
        }
    }

    /// Deterministic pseudo-random numbers in [0, 1).
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self) -> f64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    #[test]
    fn random_star_polygons_in_tilted_planes() {
        let mut rng = Lcg(42);
        let mut triangulated = 0;
        for case in 0..300 {
            let n = 4 + (rng.next() * 40.0) as usize;
            // Star-shaped (hence simple) around the origin: increasing angles, random radii.
            let mut angles: Vec<f64> = (0..n).map(|_| rng.next() * std::f64::consts::TAU).collect();
            angles.sort_by(|a, b| a.partial_cmp(b).unwrap());
            angles.dedup_by(|a, b| (*a - *b).abs() < 1e-3);
            // Star-shaped around the origin only if every angular gap is below pi.
            let wrap = angles[0] + std::f64::consts::TAU - angles[angles.len() - 1];
            let max_gap = angles.windows(2).map(|w| w[1] - w[0]).fold(wrap, f64::max);
            if angles.len() < 4 || wrap < 1e-3 || max_gap > 3.0 {
                continue;
            }
            let (u, v) = (
                [rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5],
                [rng.next() - 0.5, rng.next() - 0.5, rng.next() - 0.5],
            );
            let pts: Vec<[f64; 3]> = angles
                .iter()
                .map(|&a| {
                    let r = 0.2 + rng.next();
                    let (x, y) = (r * a.cos(), r * a.sin());
                    std::array::from_fn(|k| 10.0 + x * u[k] + y * v[k])
                })
                .collect();
            let poly: Vec<u32> = (0..pts.len() as u32).collect();
            match run(&pts, &poly) {
                Shape::Keep => {}
                Shape::Triangulated { tris, fallback, .. } => {
                    triangulated += 1;
                    assert!(!fallback, "case {case}");
                    assert_eq!(tris.len(), pts.len() - 2, "case {case}");
                    let pn = newell(poly.iter().map(|&i| &pts[i as usize]));
                    let mut sum = [0.0; 3];
                    for t in &tris {
                        let a = area2(&pts, t);
                        for i in 0..3 {
                            sum[i] += a[i];
                        }
                    }
                    for i in 0..3 {
                        assert!((sum[i] - pn[i]).abs() < 1e-9, "case {case}: {sum:?} vs {pn:?}");
                    }
                }
            }
        }
        assert!(triangulated > 100, "only {triangulated} cases triangulated");
    }

    /// The sum of the triangles' area vectors is the loop's Newell vector (true of any
    /// triangulation of a closed loop that keeps its winding), and each vertex is used.
    fn check_loop_surface(pts: &[[f64; 3]], poly: &[u32], tris: &[[u32; 3]]) {
        assert_eq!(tris.len(), poly.len() - 2);
        let pn = newell(poly.iter().map(|&i| &pts[i as usize]));
        let mut sum = [0.0; 3];
        for t in tris {
            let a = area2(pts, t);
            for i in 0..3 {
                sum[i] += a[i];
            }
        }
        for i in 0..3 {
            assert!((sum[i] - pn[i]).abs() < 1e-9, "{sum:?} vs {pn:?}");
        }
        for v in poly {
            assert!(tris.iter().any(|t| t.contains(v)), "vertex {v} unused");
        }
    }

    #[test]
    fn min_area_of_a_planar_convex_loop_is_its_area() {
        let pts: Vec<[f64; 3]> = (0..7)
            .map(|k| {
                let t = std::f64::consts::TAU * k as f64 / 7.0;
                [t.cos(), t.sin(), 0.5]
            })
            .collect();
        let poly: Vec<u32> = (0..7).collect();
        let tris = min_area_3d(&pts, &poly).unwrap();
        check_tris(&pts, &poly, &tris);
        // A loop with three collinear vertices in a row still has a triangulation that
        // avoids the degenerate triangle.
        let pts = [
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let tris = min_area_3d(&pts, &[0, 1, 2, 3, 4]).unwrap();
        check_tris(&pts, &[0, 1, 2, 3, 4], &tris);
    }

    /// A door frame bent by noise (the thesis-noisy variant's face 613): a U-shaped
    /// outline whose legs cross in every axis projection once one leg is bent through the
    /// other. No in-plane triangulation exists; the loop is filled by minimum area.
    #[test]
    fn bent_frame_crossing_itself_in_projection_is_filled_by_minimum_area() {
        // A U of width 0.2 in the plane x = 0 (legs 0.08 wide), then the right leg's top
        // pulled across the left leg and out of the plane.
        let mut pts = vec![
            [0.0, 0.0, 0.0],
            [0.0, 0.08, 0.0],
            [0.0, 0.08, 1.0],
            [0.0, 0.12, 1.0],
            [0.0, 0.12, 0.0],
            [0.0, 0.2, 0.0],
            [0.0, 0.2, 1.1],
            [0.0, 0.0, 1.1],
        ];
        pts[5] = [0.05, -0.05, 0.2];
        pts[6] = [0.1, -0.05, 1.1];
        let poly: Vec<u32> = (0..8).collect();
        let nrm = newell(poly.iter().map(|&i| &pts[i as usize]));
        let (k, _) = {
            let mut ax = [0usize, 1, 2];
            ax.sort_by(|&i, &j| nrm[j].abs().total_cmp(&nrm[i].abs()));
            (ax[0], ())
        };
        assert!(!simple_2d(&pts, &poly, k), "the test's outline must cross itself");
        match run(&pts, &poly) {
            Shape::Triangulated {
                tris,
                nonplanar,
                fallback,
                min_area,
            } => {
                assert!(nonplanar && min_area && !fallback);
                check_loop_surface(&pts, &poly, &tris);
            }
            s => panic!("{s:?}"),
        }
        // Too many vertices for the O(n³) fill: refused by the caller (best-effort flag).
        let n = MIN_AREA_MAX_VERTICES + 1;
        let big: Vec<[f64; 3]> = (0..n)
            .map(|k| {
                let t = std::f64::consts::TAU * (2 * k) as f64 / n as f64;
                [t.cos(), t.sin(), 0.01 * (k % 3) as f64]
            })
            .collect();
        let poly: Vec<u32> = (0..n as u32).collect();
        match run(&big, &poly) {
            Shape::Triangulated { fallback, min_area, .. } => assert!(fallback && !min_area),
            s => panic!("{s:?}"),
        }
    }

    #[test]
    fn simple_outlines_are_simple() {
        let sq = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        assert!(simple_2d(&sq, &[0, 1, 2, 3], 2));
        assert!(!simple_2d(&sq, &[0, 2, 1, 3], 2), "bowtie");
        // Touching itself: vertex 4 lies on edge 0-1.
        let t = [
            [0.0, 0.0, 0.0],
            [2.0, 0.0, 0.0],
            [2.0, 2.0, 0.0],
            [1.0, 2.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 2.0, 0.0],
        ];
        assert!(!simple_2d(&t, &[0, 1, 2, 3, 4, 5], 2));
    }

    /// The grid of candidate blockers gives the very triangles of walking every remaining
    /// vertex (the O(n²) reference), on large stars, combs and random self-crossing
    /// polygons with coarse (degenerate) coordinates, in every projection orientation.
    #[test]
    fn ear_clipping_through_the_grid_equals_the_walk() {
        let mut rng = Lcg(11);
        let mut cases: Vec<Vec<[f64; 3]>> = Vec::new();
        for n in [65usize, 200, 601] {
            cases.push(
                (0..n)
                    .map(|k| {
                        let t = std::f64::consts::TAU * k as f64 / n as f64;
                        let r = if k % 2 == 0 { 5.0 } else { 2.0 + rng.next() };
                        [r * t.cos(), r * t.sin(), 0.25 * rng.next()]
                    })
                    .collect(),
            );
            // A comb: teeth along x.
            let teeth = n / 4;
            let mut comb = vec![[0.0, -1.0, 0.0], [teeth as f64, -1.0, 0.0]];
            for t in (0..teeth).rev() {
                let x = t as f64;
                comb.extend([
                    [x + 0.75, 0.0, 0.0],
                    [x + 0.75, 3.0, 0.0],
                    [x + 0.25, 3.0, 0.0],
                    [x + 0.25, 0.0, 0.0],
                ]);
            }
            cases.push(comb);
            cases.push(
                (0..n)
                    .map(|_| {
                        let q = |x: f64| (x * 16.0).floor();
                        [q(rng.next()), q(rng.next()), q(rng.next())]
                    })
                    .collect(),
            );
        }
        let mut compared = 0;
        for pts in &cases {
            let poly: Vec<u32> = (0..pts.len() as u32).collect();
            for k in 0..3 {
                for s in [1, -1] {
                    let grid = ear_clip_with(pts, &poly, k, s, true, false);
                    let walk = ear_clip_with(pts, &poly, k, s, false, false);
                    assert_eq!(grid, walk, "{} vertices, axis {k}, orientation {s}", pts.len());
                    compared += 1;
                }
            }
        }
        assert_eq!(compared, 54);
    }

    #[test]
    fn random_self_intersecting_polygons_do_not_panic() {
        let mut rng = Lcg(7);
        for _ in 0..300 {
            let n = 4 + (rng.next() * 30.0) as usize;
            let flat = rng.next() < 0.5;
            let pts: Vec<[f64; 3]> = (0..n)
                .map(|_| {
                    // Coarse coordinates make exact degeneracies (collinear, coincident) likely.
                    let q = |x: f64| (x * 4.0).floor();
                    [q(rng.next()), q(rng.next()), if flat { 0.0 } else { q(rng.next()) }]
                })
                .collect();
            let mut poly: Vec<u32> = (0..n as u32).collect();
            // Identify coincident points as the same vertex, like welding would.
            for i in 0..n {
                if let Some(j) = (0..i).find(|&j| pts[j] == pts[i]) {
                    poly[i] = j as u32;
                }
            }
            poly.dedup();
            while poly.len() > 1 && poly.first() == poly.last() {
                poly.pop();
            }
            let vs: Vec<[f64; 3]> = poly.iter().map(|&i| pts[i as usize]).collect();
            let nrm = newell(vs.iter());
            if poly.len() < 4 || nrm == [0.0; 3] || vs.iter().all(|p| collinear(&vs[0], &vs[1], p)) {
                continue;
            }
            if let Shape::Triangulated { tris, .. } = classify(&pts, &poly, nrm) {
                assert!(tris.len() <= poly.len() - 2);
            }
        }
    }
}
