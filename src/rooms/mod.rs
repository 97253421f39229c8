//! Rooms without an oracle: a scale-free merge of cells by the clearance field.
//!
//! The thesis's weights (cell-portal aspect, 4.1.4–4.3.3) compare a portal with the
//! cells' projected areas. They leave three problems open (4.3.3 spike cells, 4.3.5 noisy
//! and irregular models, 4.4 when to stop). This module answers them with one idea from
//! the segmentation literature: **rooms are the basins of the clearance field, and
//! doorways are its saddles** (Haumont, Debeir & Sillion 2003 flood a voxel distance field
//! with a watershed; Dey, Giesen & Goswami 2003 segment shapes by the flow of the Delaunay
//! distance function; Edelsbrunner, Letscher & Zomorodian 2002 define the persistence
//! that decides which basins are significant).
//!
//! **Field.** The clearance of a point is its distance to the nearest model polygon
//! ([`clearance::ClearanceField`], exact up to rounding). A cell's value `f(c)` is the
//! highest clearance among a few samples of it (its centroid, and the midpoints from the
//! centroid to each vertex and each face centroid): an estimate of the largest empty ball
//! centred in the cell. A portal's value is the lowest clearance along a real path from
//! one cell's best sample, straight to a sample of the portal (its centroid and the
//! midpoints to its vertices), and straight on to the other cell's best sample — the best
//! such path over the samples. Cells are convex, so each segment stays inside free space,
//! and the value is a *lower* bound of the true pass between the two samples. That is what
//! keeps spike cells — long thin cells reaching from a room corner through a doorway —
//! from bridging two rooms: any path through a spike from one room to the other still
//! squeezes through the doorway, and the marching along it sees the squeeze.
//!
//! **Merge.** Every active cell starts as its own component with peak `f(c)`. Two
//! neighbouring components (joined by portals) have the saddle
//! `s = max over portals between them of the portal's value` — the highest pass between
//! them — and the weight `w = min(peak_a, peak_b) / s`, the **relative persistence** of
//! the lower peak (≥ 1 up to sampling: a path is never higher than its ends). The lowest weight is collapsed first (ties: the higher saddle first, then
//! the cell ids), as in the thesis's bottom-up decimation, and each collapse's weight is
//! recorded (the weight curve). A cell that is not a local maximum joins a neighbour at
//! weight 1; a small bump of the field inside a room joins at a weight just above 1; a
//! room joins its neighbour only through its doorway, at the ratio of its inscribed-ball
//! radius to the doorway's.
//!
//! **Stop.** At `threshold:R` the merge stops when the lowest weight reaches `R`: when
//! every remaining pass is narrower than `1/R` of the smaller room it joins. Both sides
//! of that inequality are lengths of the same model, so the rule does not depend on the
//! model's scale, units, position or orientation (thesis 4.4's request for measures
//! normalised by values elsewhere in the model). [`DEFAULT_RATIO`] was chosen on the tuning
//! half of the ground-truth suite ([`crate::suite`]).

pub mod clearance;

use std::cmp::Ordering;
use std::collections::{BTreeMap, BinaryHeap};

use crate::complex::CellComplex;
use crate::decimate::{Step, StopReason, StopRule};
use crate::ids::CellId;
use crate::model::Model;

pub use clearance::ClearanceField;

/// The default stop ratio (`threshold:R` of the `clearance` heuristic): a pass must be
/// narrower than `1 / R` of the smaller of the two rooms it joins to keep them apart.
pub const DEFAULT_RATIO: f64 = 1.8;

/// The clearance field sampled on the cell complex (see the module docs).
#[derive(Clone, Debug)]
pub struct CellField {
    /// Peak value `f(c)` by cell id: the clearance at the cell's centroid (0 for cells
    /// that are not active).
    pub value: Vec<f64>,
    /// Passage value by portal (index into `CellComplex::portals`): the lowest clearance
    /// along the path from one cell's centroid through the portal to the other's, for the
    /// best of the portal's pieces.
    pub passage: Vec<f64>,
}

/// The lowest clearance on the segment `p..q` (which lies in free space), by marching:
/// a step is a quarter of the clearance where it starts (the field is 1-Lipschitz, so the
/// minimum is missed by at most that), and at least 1/64 of the segment.
fn segment_min(field: &ClearanceField, p: [f64; 3], q: [f64; 3]) -> f64 {
    let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let mut t = 0.0;
    let mut best = f64::INFINITY;
    loop {
        let x = [p[0] + d[0] * t, p[1] + d[1] * t, p[2] + d[2] * t];
        let c = field.distance(x);
        best = best.min(c);
        if t >= 1.0 || len == 0.0 {
            return best;
        }
        t = (t + (0.25 * c / len).max(1.0 / 64.0)).min(1.0);
    }
}

fn mid(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5, (a[2] + b[2]) * 0.5]
}

impl CellField {
    /// The field of the active cells of `cx`, with distances to `model`'s polygons.
    pub fn new(model: &Model, cx: &CellComplex) -> Self {
        let field = ClearanceField::new(model);
        let mut value = vec![0.0; cx.cells.len()];
        let mut best = vec![[0.0; 3]; cx.cells.len()];
        for (id, c) in cx.active_cells() {
            let i = id.idx();
            let g = c.poly.centroid();
            let mut samples = vec![g];
            samples.extend(c.poly.vertices().into_iter().map(|v| mid(g, v)));
            samples.extend(c.poly.faces.iter().map(|f| mid(g, f.centroid())));
            let (mut bv, mut bp) = (f64::NEG_INFINITY, g);
            for x in samples {
                let d = field.distance(x);
                if d > bv {
                    (bv, bp) = (d, x);
                }
            }
            value[i] = bv.max(0.0);
            best[i] = bp;
        }
        let passage = cx
            .portals
            .iter()
            .map(|p| {
                let [a, b] = p.cells;
                if !(cx.cells[a.idx()].active() && cx.cells[b.idx()].active()) {
                    return 0.0;
                }
                let (xa, xb) = (best[a.idx()], best[b.idx()]);
                let mut s = 0.0f64;
                for piece in &p.pieces {
                    let m = piece.centroid();
                    let mut ys = vec![m];
                    ys.extend(piece.verts.iter().map(|&v| mid(m, v)));
                    for y in ys {
                        // Upper bound first: the path cannot beat its own midpoint.
                        if field.distance(y) <= s {
                            continue;
                        }
                        s = s.max(segment_min(&field, xa, y).min(segment_min(&field, y, xb)));
                    }
                }
                s
            })
            .collect();
        CellField { value, passage }
    }
}

/// The result of [`merge`]: the collapses, in order, and why it stopped.
#[derive(Clone, Debug)]
pub struct Merge {
    /// The collapses (as the decimation records them; `projected` is unused: `[0, 0]`).
    pub steps: Vec<Step>,
    /// Why the merge stopped.
    pub stop: StopReason,
    /// Peak value of each surviving component, by its cell id (others 0).
    pub peaks: Vec<f64>,
    /// Initial active cells.
    pub initial_cells: usize,
    /// Initial neighbouring pairs.
    pub initial_pairs: usize,
}

/// A neighbour of a component: the saddle and the portal area between them.
#[derive(Clone, Copy, Debug)]
struct Link {
    saddle: f64,
    area: f64,
}

/// A heap entry; the heap is a max-heap, so `Ord` is reversed to pop the lowest weight.
#[derive(Clone, Copy, Debug)]
struct Entry {
    weight: f64,
    saddle: f64,
    a: u32,
    b: u32,
}

impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    fn cmp(&self, o: &Self) -> Ordering {
        // Lowest weight first, then the highest saddle, then the lowest ids.
        o.weight
            .total_cmp(&self.weight)
            .then(self.saddle.total_cmp(&o.saddle))
            .then(o.a.cmp(&self.a))
            .then(o.b.cmp(&self.b))
    }
}

/// Floor of saddles, so weights stay finite.
const TINY: f64 = 1e-300;

fn weight(pa: f64, pb: f64, s: f64) -> f64 {
    pa.min(pb) / s.max(TINY)
}

/// Merges the active cells of `cx` by the persistence of `field` (module docs) until
/// `stop` holds: `threshold:R` stops when the lowest weight is `>= R`, `cells:N` at `N`
/// cells, `none` when no pair is left.
pub fn merge(cx: &CellComplex, field: &CellField, stop: StopRule) -> Merge {
    let n = cx.cells.len();
    let f = &field.value;
    let mut alive = vec![false; n];
    let mut peak = vec![0.0f64; n];
    let mut links: Vec<BTreeMap<u32, Link>> = vec![BTreeMap::new(); n];
    let mut cells = 0usize;
    for (id, _) in cx.active_cells() {
        alive[id.idx()] = true;
        peak[id.idx()] = f[id.idx()];
        cells += 1;
    }
    for (k, p) in cx.portals.iter().enumerate() {
        let [a, b] = p.cells;
        if !(alive[a.idx()] && alive[b.idx()]) || a == b {
            continue;
        }
        let s = field.passage[k];
        for (x, y) in [(a, b), (b, a)] {
            let l = links[x.idx()].entry(y.0).or_insert(Link { saddle: 0.0, area: 0.0 });
            l.saddle = l.saddle.max(s);
            l.area += p.area;
        }
    }
    let initial_pairs = links.iter().map(|m| m.len()).sum::<usize>() / 2;
    let mut heap = BinaryHeap::with_capacity(initial_pairs * 2);
    for (a, m) in links.iter().enumerate() {
        for (&b, l) in m {
            if (a as u32) < b {
                heap.push(Entry {
                    weight: weight(peak[a], peak[b as usize], l.saddle),
                    saddle: l.saddle,
                    a: a as u32,
                    b,
                });
            }
        }
    }
    let mut steps = Vec::new();
    let reason = loop {
        if let StopRule::Cells(target) = stop
            && cells <= target
        {
            break StopReason::Cells { target };
        }
        let Some(e) = heap.pop() else {
            break StopReason::Exhausted;
        };
        let (a, b) = (e.a as usize, e.b as usize);
        // Stale entries: a side merged away, or the weight or saddle changed since.
        if !(alive[a] && alive[b]) {
            continue;
        }
        let Some(l) = links[a].get(&e.b).copied() else {
            continue;
        };
        let w = weight(peak[a], peak[b], l.saddle);
        if w.to_bits() != e.weight.to_bits() || l.saddle.to_bits() != e.saddle.to_bits() {
            continue;
        }
        if let StopRule::Threshold(r) = stop
            && w >= r
        {
            break StopReason::Threshold {
                threshold: r,
                next_weight: w,
            };
        }
        // Collapse b into a (a < b: the survivor keeps the lower id).
        let (pa, pb) = (peak[a], peak[b]);
        alive[b] = false;
        cells -= 1;
        let mb = std::mem::take(&mut links[b]);
        let mut ma = std::mem::take(&mut links[a]);
        ma.remove(&e.b);
        // Pairs whose weight may change: every neighbour of the side with the lower peak
        // (its partner's peak rises to the higher one), and shared neighbours (saddle).
        let mut touched: Vec<u32> = Vec::new();
        for (&k, lk) in &mb {
            if k as usize == a {
                continue;
            }
            let m = &mut links[k as usize];
            m.remove(&e.b);
            let entry = ma.entry(k).or_insert(Link { saddle: 0.0, area: 0.0 });
            let merged = Link {
                saddle: entry.saddle.max(lk.saddle),
                area: entry.area + lk.area,
            };
            *entry = merged;
            m.insert(e.a, merged);
            if pb <= pa {
                touched.push(k);
            }
        }
        if pa < pb {
            touched.extend(ma.keys().copied());
        }
        peak[a] = pa.max(pb);
        peak[b] = 0.0;
        steps.push(Step {
            a: CellId(e.a),
            b: CellId(e.b),
            weight: w,
            cells_remaining: cells,
            portal_area: l.area,
            projected: [0.0, 0.0],
        });
        touched.sort_unstable();
        touched.dedup();
        for k in touched {
            let lk = ma[&k];
            let (x, y) = if (a as u32) < k { (a as u32, k) } else { (k, a as u32) };
            heap.push(Entry {
                weight: weight(peak[a], peak[k as usize], lk.saddle),
                saddle: lk.saddle,
                a: x,
                b: y,
            });
        }
        links[a] = ma;
    };
    Merge {
        steps,
        stop: reason,
        peaks: peak,
        initial_cells: cx.active_cells().count(),
        initial_pairs,
    }
}
