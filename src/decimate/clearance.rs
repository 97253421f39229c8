//! The `clearance` merge: rooms without an oracle, by a scale-free merge of cells along the
//! clearance field.
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
//! ([`ClearanceField`], exact up to rounding; the polygons are the complex's occluders,
//! i.e. the model's polygons as placed on cell boundaries). A cell's value `f(c)` is the
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
//! half of the ground-truth suite (`src/suite/`).
//!
//! The weight formula is the heuristic's ([`Clearance`](super::heuristic::Clearance));
//! this file keeps the field and the engine, which maintains each component's peak and
//! its saddles instead of projected areas.

use std::cmp::Ordering;
use std::collections::{BTreeMap, BinaryHeap};
use std::time::Instant;

use super::heuristic::{PairContext, sanitize};
use super::{Decimation, DecimationStats, Settings, Step, StopReason, StopRule};
use crate::base::vec::lerp;
use crate::complex::CellComplex;
use crate::geom::ClearanceField;
use crate::ids::CellId;

/// The default stop ratio (`threshold:R` of the `clearance` heuristic): a pass must be
/// narrower than `1 / R` of the smaller of the two rooms it joins to keep them apart.
pub const DEFAULT_RATIO: f64 = 1.8;

/// The clearance field sampled on the cell complex (see the module docs).
#[derive(Clone, Debug)]
pub struct CellField {
    /// Peak value `f(c)` by cell id: the highest clearance among the cell's samples (0
    /// for cells that are not active).
    pub value: Vec<f64>,
    /// Passage value by portal (index into `CellComplex::portals`): the lowest clearance
    /// along the best sampled path from one cell's best sample through the portal to the
    /// other's.
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
    lerp(&a, &b, 0.5)
}

impl CellField {
    /// The field of the active cells of `cx`: distances to the occluders of its live
    /// patches (the model's polygons, as placed).
    pub fn new(cx: &CellComplex) -> Self {
        let field = ClearanceField::from_polygons(
            cx.patches
                .iter()
                .filter(|p| p.alive)
                .flat_map(|p| p.occluders.iter().map(|o| o.polygon.verts.as_slice())),
        );
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
            value[i] = if bv.is_finite() { bv.max(0.0) } else { 0.0 };
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
                        // Upper bound first: a path is never higher than any of its points.
                        if field.distance(y) <= s {
                            continue;
                        }
                        s = s.max(segment_min(&field, xa, y).min(segment_min(&field, y, xb)));
                    }
                }
                if s.is_finite() { s } else { 0.0 }
            })
            .collect();
        CellField { value, passage }
    }
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

/// Per-component state.
#[derive(Clone, Debug, Default)]
struct Comp {
    alive: bool,
    peak: f64,
    volume: f64,
    pieces: usize,
    links: BTreeMap<u32, Link>,
}

/// Runs the clearance merge on the active cells of `cx` (the `clearance` heuristic's
/// engine; `settings.estimator` is not used).
pub(crate) fn run(cx: &CellComplex, settings: &Settings, progress: &mut dyn FnMut(usize, usize)) -> Decimation {
    let t0 = Instant::now();
    let h = settings.heuristic.heuristic();
    let field = CellField::new(cx);
    let n = cx.cells.len();
    let mut comps: Vec<Comp> = vec![Comp::default(); n];
    let mut cells = 0usize;
    let mut stats = DecimationStats::default();
    for (id, c) in cx.active_cells() {
        let k = &mut comps[id.idx()];
        k.alive = true;
        k.peak = field.value[id.idx()];
        k.volume = c.poly.volume();
        k.pieces = 1;
        cells += 1;
    }
    for (k, p) in cx.portals.iter().enumerate() {
        let [a, b] = p.cells;
        if !(comps[a.idx()].alive && comps[b.idx()].alive) || a == b {
            continue;
        }
        let s = field.passage[k];
        for (x, y) in [(a, b), (b, a)] {
            let l = comps[x.idx()]
                .links
                .entry(y.0)
                .or_insert(Link { saddle: 0.0, area: 0.0 });
            l.saddle = l.saddle.max(s);
            l.area += p.area;
        }
    }
    stats.initial_cells = cells;
    stats.initial_pairs = comps.iter().map(|c| c.links.len()).sum::<usize>() / 2;
    stats.regions = regions(&comps);
    let weigh = |x: &Comp, y: &Comp, l: &Link| {
        sanitize(h.weight(&PairContext {
            portal_area: l.area,
            projected: [0.0, 0.0],
            volumes: [x.volume, y.volume],
            pieces: [x.pieces, y.pieces],
            peaks: [x.peak, y.peak],
            saddle: l.saddle,
        }))
    };
    let mut heap = BinaryHeap::with_capacity(stats.initial_pairs * 2);
    for (a, c) in comps.iter().enumerate() {
        for (&b, l) in &c.links {
            if (a as u32) < b {
                stats.weights_computed += 1;
                heap.push(Entry {
                    weight: weigh(c, &comps[b as usize], l),
                    saddle: l.saddle,
                    a: a as u32,
                    b,
                });
            }
        }
    }
    stats.init_seconds = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let mut steps = Vec::new();
    let stop = loop {
        if let StopRule::Cells(target) = settings.stop
            && cells <= target
        {
            break StopReason::Cells { target };
        }
        let Some(e) = heap.pop() else {
            break StopReason::Exhausted;
        };
        let (a, b) = (e.a as usize, e.b as usize);
        // Stale entries: a side merged away, or the weight or saddle changed since.
        if !(comps[a].alive && comps[b].alive) {
            continue;
        }
        let Some(l) = comps[a].links.get(&e.b).copied() else {
            continue;
        };
        if l.saddle.to_bits() != e.saddle.to_bits() || weigh(&comps[a], &comps[b], &l).to_bits() != e.weight.to_bits() {
            continue;
        }
        let w = e.weight;
        if let StopRule::Threshold(r) = settings.stop
            && w >= r
        {
            break StopReason::Threshold {
                threshold: r,
                next_weight: w,
            };
        }
        // Collapse b into a (a < b: the survivor keeps the lower id).
        let (pa, pb) = (comps[a].peak, comps[b].peak);
        let cb = std::mem::take(&mut comps[b]);
        let mut ca = std::mem::take(&mut comps[a]);
        ca.links.remove(&e.b);
        cells -= 1;
        // Pairs whose weight may change: every neighbour of the side with the lower peak
        // (its partner's peak rises to the higher one), and every neighbour of b (saddle,
        // volume); with the volumes and piece counts in the context, all of them.
        let mut touched: Vec<u32> = Vec::new();
        for (&k, lk) in &cb.links {
            if k as usize == a {
                continue;
            }
            let m = &mut comps[k as usize].links;
            m.remove(&e.b);
            let entry = ca.links.entry(k).or_insert(Link { saddle: 0.0, area: 0.0 });
            *entry = Link {
                saddle: entry.saddle.max(lk.saddle),
                area: entry.area + lk.area,
            };
            m.insert(e.a, *entry);
        }
        let changed_volume = h.uses_volume();
        if pa < pb || changed_volume {
            touched.extend(ca.links.keys().copied());
        } else {
            touched.extend(cb.links.keys().copied().filter(|&k| k as usize != a));
        }
        ca.peak = pa.max(pb);
        ca.volume += cb.volume;
        ca.pieces += cb.pieces;
        ca.alive = true;
        steps.push(Step {
            a: CellId(e.a),
            b: CellId(e.b),
            weight: w,
            cells_remaining: cells,
            portal_area: l.area,
            projected: [0.0, 0.0],
        });
        progress(steps.len(), cells);
        comps[a] = ca;
        touched.sort_unstable();
        touched.dedup();
        for k in touched {
            let lk = comps[a].links[&k];
            let (x, y) = if (a as u32) < k { (a as u32, k) } else { (k, a as u32) };
            stats.weights_computed += 1;
            heap.push(Entry {
                weight: weigh(&comps[x as usize], &comps[y as usize], &lk),
                saddle: lk.saddle,
                a: x,
                b: y,
            });
        }
    };
    stats.steps = steps.len();
    stats.collapse_seconds = t1.elapsed().as_secs_f64();
    let partition = Decimation::replay(cx, &steps).expect("the merge records live pairs, lower id first");
    Decimation {
        settings: *settings,
        steps,
        stop,
        stats,
        partition,
    }
}

/// Connected regions of the component graph.
fn regions(comps: &[Comp]) -> usize {
    let mut seen = vec![false; comps.len()];
    let mut count = 0;
    let mut stack = Vec::new();
    for s in 0..comps.len() {
        if !comps[s].alive || seen[s] {
            continue;
        }
        count += 1;
        seen[s] = true;
        stack.push(s);
        while let Some(x) = stack.pop() {
            for &y in comps[x].links.keys() {
                if !seen[y as usize] {
                    seen[y as usize] = true;
                    stack.push(y as usize);
                }
            }
        }
    }
    count
}
