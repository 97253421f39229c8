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
//! the lower peak (≥ 1 up to sampling: a path is never higher than its ends). The lowest
//! weight is collapsed first (ties: the higher saddle first, then, at weight 1, the pair
//! whose higher peak is higher — a cell with two ways up joins the higher neighbour,
//! whatever the tetrahedra's numbering ([`KeyLayout`]) — then the cell ids), as in the thesis's
//! bottom-up decimation, and each collapse's weight is
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
//! **Aperture gate** (the `aperture` heuristic, [`ApertureGate`]). In buildings the
//! largest empty ball of a room is bounded by the ceiling, so a door 2.1 m high and wide
//! has a pass of about 1.05 against room peaks of 1.3–1.7: wide openings and small rooms
//! (stairwells, corridors) join at a persistence below any stop that keeps the rest
//! together. What still tells them apart is the *area*: the opening is a small part of
//! the room's cross-section. When a pair of persistence ≥ `from` pops, and both components
//! hold at least `ball` times their largest empty ball (so they are rooms, not pieces of
//! the region around a peak), the saddle is first refined
//! ([`CellField::refined_passage`] on every portal between them: more, still real, paths;
//! the pair is weighed again); then the pair is kept apart if the smaller of the two
//! components' projected sections on the portal plane (2D hull of the 3D hull) is at least
//! `ratio` times the portal area, and (with `slices`) so is the smaller of their largest
//! cuts parallel to the portal plane: a long component cut obliquely (a corridor of a
//! few large faces) projects far wider than it is, its parallel cuts do not. A kept pair
//! is weighed again when either side grows. With the gate, a pair that would stop a
//! threshold run (weight ≥ the threshold) has its saddle refined the same way first, and
//! stops the run only if it still weighs that much: the pass is a lower bound from a few
//! straight paths, loose on large cells by an amount that depends on the tetrahedra
//! (rotated, a generated building's pass between two halves of a room was sampled too low
//! to ever pop), so the stop judges the best bound the gate would judge.
//!
//! **Clean-up** (`dominance`). Leaks (noise, marching-cubes caverns) open the solid and
//! the exterior to the merge: slabs and pockets whose largest empty ball is tiny next to
//! the rooms', kept apart by the same persistence that keeps rooms apart. When the merge
//! stops, a component whose peak is below `dominance` times a neighbour's is absorbed into
//! its dominating neighbour across the largest portal, lowest peak first. A ratio of
//! radii, so still scale-free. With `slab`, so is a component whose peak is below
//! `slab_peak` times a neighbour's and whose section projected on the plane of their
//! portals is below `slab` times the portals' area: a slab of leaked solid along a wall,
//! or a pocket behind one of its own faces (the gate's test of a room behind an opening,
//! failed). The pass is a
//! function of the stopped merge's components, so a run to the end applies it to a copy
//! of the state where the stopped run stops (one pass for the weight curve).
//! Both tests are ratios (areas, volumes), so the gate is scale-free. With a `cells:N`
//! stop the gate is off (that stop asks for N cells). The opening the sections are
//! compared with is the portals' vector area ([`ApertureGate::vector_opening`]); a pair
//! it would keep apart is judged again against the portals' shadow (the area they cover
//! on the portal plane, [`ApertureGate::shadow_opening`]), since a sum of signed areas
//! cancels on an interface that wraps around one side.
//!
//! **Boundaries** ([`ApertureGate::tunnels`]). Along a tunnel of nearly uniform width
//! the field has no sharp pass, so where two rooms' fronts meet is decided by the order
//! of the collapses at weight about 1, which follows the tetrahedra (the thesis caverns
//! rotated 7°/8°/9° put 4 of 7 portals elsewhere). At a threshold stop, each boundary of
//! the stopped groups is moved to the least-area cut between the two groups' cores
//! ([`tunnel_labels`]) and the merge runs again, constrained to the moved groups; the
//! record (steps, weight curve) is the second run's, so `replay` still rebuilds it.
//!
//! The weight formula is the heuristic's ([`Clearance`](super::heuristic::Clearance));
//! this file keeps the field and the engine, which maintains each component's peak and
//! its saddles instead of projected areas.

use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};
use std::sync::atomic::{AtomicU32, AtomicU64, AtomicUsize, Ordering as AtomicOrdering};
use std::time::Instant;

use rayon::prelude::*;

use super::MEAN_NORMAL_REL;
use super::heap4::RunHeap;
use super::heuristic::{PairContext, sanitize};
use super::hull3::Hull3;
use super::project::{Frame, P2, hull2, hull2_into, polygon_area, union_area};
use super::{Decimation, DecimationStats, Settings, Step, StopReason, StopRule};
use crate::base::hash::FxBuild;
use crate::base::mem::{prefetch, prefetch_all};
use crate::base::vec::{lerp, norm, normalize};
use crate::complex::{Cell, CellComplex};
use crate::geom::ClearanceField;
use crate::ids::CellId;
use thin_vec::ThinVec;

/// The default stop ratio (`threshold:R` of the `clearance` heuristic): a pass must be
/// narrower than `1 / R` of the smaller of the two rooms it joins to keep them apart.
pub const DEFAULT_RATIO: f64 = 1.8;

/// The `aperture` heuristic's gate (chosen on the tune half of the suite, `examples/diag_rooms.rs`):
/// a pair (at any persistence: `from` 0) whose components each hold twice their largest
/// empty ball is kept apart when the smaller section is at least 1.5 times the opening (projected,
/// then confirmed by the largest of 5 parallel cuts); at the end, a component whose peak
/// is below 0.15 of a neighbour's is absorbed into it. The opening is the portals' vector
/// area, and the stopped boundaries are moved to the least-area cuts between the rooms.
///
/// **Why `from` is 0** (session 25; it was 1.1). Two rooms joined through an opening as
/// high as the smaller room's largest empty ball (a corridor's open side, an archway up to
/// its ceiling) have a persistence of about 1, and the estimate of it depends on the
/// samples, i.e. on the tetrahedra: on a generated building (`tessellated`, seed 6) the
/// corridor's pass was estimated at 0.55 unmoved (persistence 1.91: above the stop, kept)
/// and 0.96 rotated by 7°/8°/9° (persistence 1.09: below 1.1, so merged ungated), and the
/// rotation lost two rooms. A cutoff on so uncertain a value made the gate's decision
/// depend on the motion; the gate now judges every pair of room-sized components by their
/// sections, whatever the persistence. Measured on the tune half of `bench accuracy`
/// (rooms and doors unchanged) and the stress table's tune seeds (1, and 4 and 6: the five
/// rigid-motion and noise rows of tessellated-6 now keep its rooms; no row lost rooms).
///
/// **Why `core_cut`** (session 35). A pair the sections would join is judged again on the
/// least-area cut between the two components' cores when that cut is narrower than their
/// interface ([`core_cut`]). Under a random rotation of a generated building
/// (`greedy` seed 0, rotations 1 and 3) a room's component grew through its door into the
/// corridor before the corridor's own component reached the door; they met across the
/// corridor's section (vector area 8.3), the room's partial section (11.96) was below 1.5
/// times that, and the room was lost, while the unmoved model met at the door (4.0) and
/// kept it. The cut between the cores is the door whatever the order of collapses. Chosen
/// on the tune seeds (stress seeds 1, 4, 6: 2 more rooms isolated, no row lost one; the
/// accuracy suite's tune half: all 33 cases unchanged). Reported (session 35,
/// `results/stress/session35/`): on the six stress sets the rigid-motion and shuffle rows
/// whose rooms differ from the unmoved model went from 4 to 1 of 550 and 16 rows gained
/// rooms, none lost any; under vertex noise the core cut keeps more small components apart
/// (final portals over the 300 noise rows 6,364 -> 6,981); on the accuracy suite's report
/// half one case of 33 lost a room (`rotated-3-greedy`: room 6 split in two, 10 -> 9 of
/// 10), the 60 held-out cases are unchanged. Pairs whose lower peak is below the
/// clean-up's `dominance` times the higher are not judged again (the clean-up absorbs such
/// a component anyway): on a 69k-cell real level this skips most judgements of a large
/// component against its one-cell fragments.
pub const DEFAULT_APERTURE: ApertureGate = ApertureGate {
    from: 0.0,
    ratio: 1.5,
    ball: 2.0,
    dominance: 0.15,
    slices: 5,
    slab: SLAB,
    slab_peak: 0.5,
    vector_opening: true,
    shadow_opening: true,
    tunnels: true,
    core_cut: true,
};

/// The clean-up's slab ratio ([`ApertureGate::slab`]) of [`DEFAULT_APERTURE`].
const SLAB: f64 = 1.5;

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
    /// The lowest positive and the highest `value` (1, 1 when none is positive): the
    /// range of the merge's tie-break ([`KeyLayout`]).
    pub range: [f64; 2],
    /// The distance field itself. (A cell's best sample, where `value` was found, is not
    /// stored — 32 bytes per cell id, 74 MB for a million triangles — but found again
    /// where needed, from the same queries: [`CellField::best_of`].)
    field: ClearanceField,
}

/// The lowest clearance on the segment `p..q` (which lies in free space), by marching:
/// a step is a quarter of the clearance where it starts (the field is 1-Lipschitz, so the
/// minimum is missed by at most that), and at least 1/64 of the segment. `dp` is the
/// clearance at `p` (same bits as `field.distance(p)`). The marching stops at the first
/// sample at or below `floor`: the result is exact when above `floor`, else some value at
/// or below `floor` (callers that only take a maximum with `floor` need no more). Each
/// sample's query is bounded by the previous sample's clearance plus the step (the field
/// is 1-Lipschitz), which prunes the search without changing its answer, and stops at the
/// first triangle at or below `floor` ([`ClearanceField::distance_above`]).
///
/// `dq` is the clearance at `q` when the caller knows it (NaN when not): exact, or an
/// answer of `distance_above(q, f, ·)` with `f <= floor`. The last sample is `q` itself
/// (bit for bit, not `p + (q - p)`, which may round off it); its query is skipped for `dq`
/// (as is any earlier sample that rounds onto `q`), which is what
/// the query would answer (the same bits when above `floor`; at or below `floor` both
/// stop the marching with a value at or below `floor`).
fn segment_min_from(field: &ClearanceField, p: [f64; 3], dp: f64, q: [f64; 3], dq: f64, floor: f64) -> f64 {
    let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let mut t = 0.0;
    let mut best = f64::INFINITY;
    let mut c = dp;
    loop {
        best = best.min(c);
        if t >= 1.0 || len == 0.0 || best <= floor {
            return best;
        }
        let t2 = (t + (0.25 * c / len).max(1.0 / 64.0)).min(1.0);
        // The last sample is `q` itself, bit for bit (`p + (q - p)` may round off it).
        let x = if t2 >= 1.0 {
            q
        } else {
            [p[0] + d[0] * t2, p[1] + d[1] * t2, p[2] + d[2] * t2]
        };
        c = if !dq.is_nan() && x.map(f64::to_bits) == q.map(f64::to_bits) {
            dq
        } else {
            field.distance_above(x, floor, c + (t2 - t) * len)
        };
        t = t2;
    }
}

/// Sorts by clearance, highest first (stable); a NaN, which no `<=` test skips, counts as
/// the highest.
fn highest_first<T>(v: &mut [T], clearance: impl Fn(&T) -> f64) {
    let key = |d: f64| if d.is_nan() { f64::INFINITY } else { d };
    v.sort_by(|p, q| key(clearance(q)).total_cmp(&key(clearance(p))));
}

fn mid(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    lerp(&a, &b, 0.5)
}

/// The best sample of a cell: (its clearance, as `ClearanceField::distance` returned it;
/// the sample). The first of the highest, in [`cell_samples`]' order.
fn best_sample(field: &ClearanceField, cell: &Cell) -> (f64, [f64; 3]) {
    let samples = cell_samples(cell);
    let (mut bv, mut bp) = (f64::NEG_INFINITY, samples[0]);
    // The first sample is the centroid; the others' queries are bounded by its clearance
    // plus the way from it (1-Lipschitz; the bound does not change the answer).
    let (g, dg) = (samples[0], field.distance(samples[0]));
    for x in samples {
        let d = if x == g {
            dg
        } else {
            // Only a value above the best so far matters (`d > bv`).
            field.distance_above(x, bv, dg + dist(g, x))
        };
        if d > bv {
            (bv, bp) = (d, x);
        }
    }
    (bv, bp)
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm(&[b[0] - a[0], b[1] - a[1], b[2] - a[2]])
}

/// A portal's passage value (see [`CellField::passage`]) between the best samples `xa`
/// (clearance `da`) and `xb` of its cells.
fn portal_passage(
    field: &ClearanceField,
    pieces: &[crate::geom::ConvexPolygon],
    (da, xa): (f64, [f64; 3]),
    (db, xb): (f64, [f64; 3]),
) -> f64 {
    let mut s = 0.0f64;
    // The first leg starts at `xa`, so it is never above `da` (its marching's first sample
    // is `da` itself), and the second ends at `xb`, so it is never above `db` (its last
    // sample is `xb` itself, answered by `db`): no later path can raise `s` once
    // `s >= min(da, db)`, and the remaining samples are not queried
    // (`passage_stops_at_the_first_cells_clearance`).
    let top = da.min(db);
    for piece in pieces {
        if s >= top {
            break;
        }
        let m = piece.centroid();
        // Only values above `s` matter (a value at or below it is skipped, and `s` only
        // rises), so the queries stop at the first triangle at or below `s`; `dm` is then
        // still an upper bound of the centroid's clearance.
        let dm = field.distance_above(m, s, f64::INFINITY);
        // Each leg only matters above `s` (the result is `max(s, min(legs))`).
        let pass = |y: [f64; 3], dy: f64, s: f64| {
            let first = segment_min_from(field, xa, da, y, dy, s);
            if first <= s {
                return s;
            }
            s.max(first.min(segment_min_from(field, y, dy, xb, db, s)))
        };
        // The centroid first when it could end the search (its clearance reaches `top`):
        // then the others are not asked. Otherwise it is sorted with them.
        let first = dm >= top;
        if first {
            s = pass(m, dm, s);
            if s >= top {
                break;
            }
        }
        // The other samples' clearances (bounded by the piece centroid's plus the way from
        // it; exact above the `s` they were asked with, which later values of `s` only
        // exceed), highest first: `s` is the maximum over the samples of the lower of
        // their two legs, every term above `s` exact, so the order does not change its
        // bits; highest first, it rises early and the rest stop at the first sample at
        // or below it.
        let mut ys: Vec<([f64; 3], f64)> = (!first)
            .then_some((m, dm))
            .into_iter()
            .chain(piece.verts.iter().map(|&v| {
                let y = mid(m, v);
                (
                    y,
                    if y == m {
                        dm
                    } else {
                        field.distance_above(y, s, dm + dist(m, y))
                    },
                )
            }))
            .collect();
        highest_first(&mut ys, |y| y.1);
        for (y, dy) in ys {
            if dy <= s {
                break;
            }
            s = pass(y, dy, s);
            if s >= top {
                break;
            }
        }
    }
    if s.is_finite() { s } else { 0.0 }
}

impl CellField {
    /// The field of the active cells of `cx`: distances to the occluders of its live
    /// patches (the model's polygons, as placed). Cells and portals are evaluated in
    /// parallel (rayon); each value is computed by one thread in a fixed order, so the
    /// field does not depend on the number of threads.
    pub fn new(cx: &CellComplex) -> Self {
        let field = ClearanceField::from_polygons(
            cx.patches
                .iter()
                .filter(|p| p.alive)
                .flat_map(|p| p.occluders.iter().map(|o| o.polygon.verts.as_slice())),
        );
        // (raw clearance of the best sample, the sample) per cell; inactive cells (0, origin).
        let peaks: Vec<(f64, [f64; 3])> = cx
            .cells
            .par_iter()
            .with_min_len(256)
            .map(|c| {
                if c.active() {
                    best_sample(&field, c)
                } else {
                    (0.0, [0.0; 3])
                }
            })
            .collect();
        let passage = cx
            .portals
            .par_iter()
            .with_min_len(256)
            .map(|p| {
                let [a, b] = p.cells;
                if !(cx.cells[a.idx()].active() && cx.cells[b.idx()].active()) {
                    return 0.0;
                }
                portal_passage(&field, &p.pieces, peaks[a.idx()], peaks[b.idx()])
            })
            .collect();
        let value: Vec<f64> = peaks
            .iter()
            .map(|&(bv, _)| if bv.is_finite() { bv.max(0.0) } else { 0.0 })
            .collect();
        let range = value_range(&value);
        CellField {
            value,
            passage,
            range,
            field,
        }
    }

    /// The best sample of an active cell: (its clearance, as the field returned it, before
    /// `value`'s clamping; the sample, where `value` was found).
    pub fn best_of(&self, cell: &Cell) -> (f64, [f64; 3]) {
        best_sample(&self.field, cell)
    }
}

/// The lowest positive and the highest of `values` (`[1, 1]` when none is positive).
fn value_range(values: &[f64]) -> [f64; 2] {
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for &v in values {
        if v > 0.0 {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    if lo.is_finite() { [lo, hi] } else { [1.0, 1.0] }
}

/// Samples of a convex cell: its centroid, and the midpoints from it to each vertex and
/// each face centroid (the samples its peak is taken over).
fn cell_samples(cell: &Cell) -> Vec<[f64; 3]> {
    let g = cell.centroid();
    let mut samples = vec![g];
    samples.extend(cell.vertices().into_iter().map(|v| mid(g, v)));
    samples.extend(cell.faces().iter().map(|f| mid(g, f.centroid())));
    samples
}

impl CellField {
    /// A finer lower bound of the pass through portal `k` (of `cx.portals`) than
    /// `passage[k]`: paths from each side's best sample, straight to any sample of that
    /// cell, straight to any of more samples of the portal (also the points a quarter of
    /// the way from each vertex to the centroid, and the edge midpoints), and on the same
    /// way to the other side's best sample. Every such path lies in the two convex cells,
    /// so the value is still the lowest clearance along a real path (never above the true
    /// pass); it is at least `passage[k]`.
    pub fn refined_passage(&self, cx: &CellComplex, k: usize) -> f64 {
        let p = &cx.portals[k];
        let [a, b] = p.cells;
        let s0 = self.passage[k];
        // Per side, the best first leg to each cell sample (with the clearance at its end).
        // A leg at or below `s0` never counts (`s` only rises from `s0`), so its marching
        // may stop there. The legs start at the cell's best sample: the first of the
        // highest clearances at its samples, the very value and sample `best_sample` finds
        // (its bounded queries give the bits of these).
        //
        // Only a sample's clearance above `s0` matters: a leg ending at or below it is at
        // or below it, and `s0` is every floor below. So the queries stop at `s0`
        // (`distance_above`: exact above it, else a value at or below it) and are bounded
        // by the centroid's (the first sample's) clearance plus the way from it (the field
        // is 1-Lipschitz; the bound does not change the answer). The first of the highest
        // is the same sample when the highest is above `s0`; when it is not, neither
        // answer's `top` is above `s0`, and both return below.
        let clearances = |xs: &[[f64; 3]]| -> (Vec<f64>, f64, [f64; 3]) {
            let (g, dg) = (xs[0], self.field.distance(xs[0]));
            let ds: Vec<f64> = xs
                .iter()
                .map(|&x| {
                    if x == g {
                        dg
                    } else {
                        self.field.distance_above(x, s0, dg + dist(g, x))
                    }
                })
                .collect();
            let (mut d, mut best) = (f64::NEG_INFINITY, xs[0]);
            for (&x, &dx) in xs.iter().zip(&ds) {
                if dx > d {
                    (d, best) = (dx, x);
                }
            }
            (ds, d, best)
        };
        // Every leg starts at its side's best sample (its first marching sample is that
        // clearance), so a side's value is never above it, and no path raises `s` past the
        // lower of the two: once there, nothing more is queried (the same bits) — nor is
        // the second cell's sampled when the first's best is already at or below `s0`.
        let done = || if s0.is_finite() { s0 } else { self.passage[k] };
        let sa = cell_samples(&cx.cells[a.idx()]);
        let ca = clearances(&sa);
        if s0 >= ca.1 {
            return done();
        }
        let sb = cell_samples(&cx.cells[b.idx()]);
        let cb = clearances(&sb);
        let top = ca.1.min(cb.1);
        if s0 >= top {
            return done();
        }
        // Each side's legs, marched when first needed and kept: (the cell sample, its
        // clearance, the leg's value or NaN until marched), in decreasing order of the
        // sample's clearance (a NaN, which no test below skips, first). A leg is never
        // above the clearance at its end (its last sample), so once that is at or below
        // the floor, neither it nor any later leg can count. A side's value is the maximum
        // over its legs of the lower of the leg and the way on from its end; every such
        // term above the floor is exact (a leg or way marched against a floor is exact
        // when above it, else at or below it; a leg is marched against `s`, which only
        // rises from one portal sample to the next), so the maximum's bits do not depend
        // on the order or on when a leg was marched.
        let legs = |xs: &[[f64; 3]], ds: &[f64]| -> Vec<([f64; 3], f64, std::cell::Cell<f64>)> {
            let mut v: Vec<_> = xs
                .iter()
                .zip(ds)
                .map(|(&x, &dx)| (x, dx, std::cell::Cell::new(f64::NAN)))
                .collect();
            highest_first(&mut v, |l| l.1);
            v
        };
        let (la, lb) = (legs(&sa, &ca.0), legs(&sb, &cb.0));
        // Values at or below `floor` only matter as such (callers take `max(floor, ·)`).
        let side = |legs: &[([f64; 3], f64, std::cell::Cell<f64>)],
                    (_, d, best): &(Vec<f64>, f64, [f64; 3]),
                    y: [f64; 3],
                    dy: f64,
                    floor: f64| {
            let mut v = f64::NEG_INFINITY;
            for (x, dx, l) in legs {
                let f = v.max(floor);
                if *dx <= f {
                    break;
                }
                let mut lv = l.get();
                if lv.is_nan() {
                    // Against the side's floor (`s`, which only rises), not `f`: a later
                    // portal sample's loop starts again from `s`.
                    lv = segment_min_from(&self.field, *best, *d, *x, *dx, floor);
                    l.set(lv);
                }
                if lv <= f {
                    continue;
                }
                v = v.max(lv.min(segment_min_from(&self.field, *x, *dx, y, dy, f)));
            }
            v
        };
        // One portal sample `y` (clearance `dy`): the best path through it, if above `s`.
        let through = |y: [f64; 3], dy: f64, s: f64| {
            if dy <= s {
                return s;
            }
            let va = side(&la, &ca, y, dy, s);
            if va <= s {
                return s;
            }
            s.max(va.min(side(&lb, &cb, y, dy, s)))
        };
        let mut s = s0;
        for piece in &p.pieces {
            if s >= top {
                break;
            }
            let m = piece.centroid();
            let n = piece.verts.len();
            // The piece centroid first when it could end the search (its clearance
            // reaches `top`). The other samples' clearances are bounded by the centroid's
            // plus the way from it (1-Lipschitz) and asked only above `s` (exact above it,
            // and `s` only rises); they are tried highest first, as in `portal_passage`:
            // `s` is the maximum over the samples of their paths' values, each exact above
            // `s`, so the order does not change its bits, and the first sample at or below
            // `s` ends the piece.
            let dm = self.field.distance(m);
            let first = dm >= top;
            if first {
                s = through(m, dm, s);
                if s >= top {
                    break;
                }
            }
            let mut ys: Vec<([f64; 3], f64)> = Vec::with_capacity(1 + 3 * n);
            if !first {
                ys.push((m, dm));
            }
            for (i, &v) in piece.verts.iter().enumerate() {
                for y in [
                    mid(m, v),
                    lerp(&v, &m, 0.25),
                    lerp(&m, &mid(v, piece.verts[(i + 1) % n]), 0.75),
                ] {
                    let dy = if y == m {
                        dm
                    } else {
                        self.field.distance_above(y, s, dm + dist(m, y))
                    };
                    ys.push((y, dy));
                }
            }
            highest_first(&mut ys, |y| y.1);
            for (y, dy) in ys {
                if dy <= s {
                    break;
                }
                s = through(y, dy, s);
                if s >= top {
                    break;
                }
            }
        }
        if s.is_finite() { s } else { self.passage[k] }
    }
}

/// A neighbour of a component: the saddle, the portal area between them, and the portals'
/// area vector (oriented from the component that holds the link to the neighbour).
#[derive(Clone, Copy, Debug)]
struct Link {
    saddle: f64,
    area: f64,
    av: [f64; 3],
    /// The area of the largest portal piece: its plane (its centroid, and its normal in
    /// `av`'s orientation) is the portal plane when the area vector degenerates. The plane
    /// is not stored (56 bytes in every link) but recomputed from the piece
    /// when a frame is needed ([`Link::frame`]): the same calls on the same piece, so the
    /// same bits.
    largest_area: f64,
    /// The largest piece's portal (index into `CellComplex::portals`), or `u32::MAX` (no
    /// piece of positive area: the plane `z = 0`, normal `+z`).
    largest_portal: u32,
    /// Bits 0..30: the largest piece's index in its portal. [`FLIP`]: whether its normal
    /// is negated (the link seen from the portal's second cell's side; negation is exact,
    /// so this is the stored normal's bits). [`REFINED`]: whether the saddle is already
    /// the refined one ([`CellField::refined_passage`]) of this portal set. Packed so that
    /// a link is 64 bytes, not 72 (`components_are_compact`).
    bits: u32,
    /// The weight of this pair's entry in the merge's heap, with this link's saddle, while
    /// that entry has not been popped (NaN: none; weights are never NaN). A push of the same key would only add a duplicate (see
    /// `run_inner`'s `requeue`), so it is skipped.
    queued: f64,
}

impl Link {
    /// The area of the opening this portal set spans: the norm of its vector area (the
    /// area of its projection on the plane of its mean normal; for an interface spanning
    /// a planar rim, the rim's area however the faces fold), or the summed area when the
    /// vector area degenerates (the same rule as [`Link::frame`]'s normal).
    fn opening(&self) -> f64 {
        let l = norm(&self.av);
        if l > MEAN_NORMAL_REL * self.area && l.is_finite() {
            l.min(self.area)
        } else {
            self.area
        }
    }
}

impl Link {
    const EMPTY: Link = Link {
        saddle: 0.0,
        area: 0.0,
        av: [0.0; 3],
        largest_area: 0.0,
        largest_portal: u32::MAX,
        bits: 0,
        queued: f64::NAN,
    };

    /// A link whose largest piece is piece `i` of portal `k` (`i` below 2^30: a portal's
    /// pieces are the patches two cells share).
    fn with_largest(self, k: u32, i: u32) -> Link {
        debug_assert!(i < REFINED);
        Link {
            largest_portal: k,
            bits: i | (self.bits & (FLIP | REFINED)),
            ..self
        }
    }

    /// (portal, piece) of the largest piece, if any.
    fn largest_at(&self) -> Option<(u32, u32)> {
        (self.largest_portal != u32::MAX).then_some((self.largest_portal, self.bits & !(FLIP | REFINED)))
    }

    fn largest_flip(&self) -> bool {
        self.bits & FLIP != 0
    }

    fn refined(&self) -> bool {
        self.bits & REFINED != 0
    }

    /// The link seen from the other side.
    fn reversed(&self) -> Link {
        let n = |v: [f64; 3]| [-v[0], -v[1], -v[2]];
        Link {
            av: n(self.av),
            bits: self.bits ^ FLIP,
            ..*self
        }
    }

    /// The union of two portal sets towards the same neighbour.
    fn fuse(&self, o: &Link) -> Link {
        let saddle = self.saddle.max(o.saddle);
        Link {
            saddle,
            area: self.area + o.area,
            av: [self.av[0] + o.av[0], self.av[1] + o.av[1], self.av[2] + o.av[2]],
            largest_area: if o.largest_area > self.largest_area {
                o.largest_area
            } else {
                self.largest_area
            },
            // The larger's piece and flip; not refined.
            largest_portal: if o.largest_area > self.largest_area {
                o.largest_portal
            } else {
                self.largest_portal
            },
            bits: if o.largest_area > self.largest_area {
                o.bits & !REFINED
            } else {
                self.bits & !REFINED
            },
            // This pair's queued entry keeps its key if the saddle keeps its bits.
            queued: if saddle.to_bits() == self.saddle.to_bits() {
                self.queued
            } else {
                f64::NAN
            },
        }
    }

    /// The portal plane's frame (the decimation's rule: the area-weighted mean normal, or
    /// the largest piece's normal when the mean degenerates).
    fn frame(&self, cx: &CellComplex) -> Frame {
        let (normal, centroid) = self.largest_plane(cx);
        let l = norm(&self.av);
        let n = if l > MEAN_NORMAL_REL * self.area && l.is_finite() {
            [self.av[0] / l, self.av[1] / l, self.av[2] / l]
        } else {
            normal
        };
        Frame::new(n, centroid)
            .or_else(|| Frame::new([0.0, 0.0, 1.0], centroid))
            .expect("unit z frame")
    }

    /// The largest piece's normal (in `av`'s orientation) and centroid.
    fn largest_plane(&self, cx: &CellComplex) -> ([f64; 3], [f64; 3]) {
        let (normal, centroid) = match self.largest_at() {
            None => ([0.0, 0.0, 1.0], [0.0; 3]),
            Some((k, i)) => {
                let q = &cx.portals[k as usize].pieces[i as usize];
                (q.normal(), q.centroid())
            }
        };
        if self.largest_flip() {
            ([-normal[0], -normal[1], -normal[2]], centroid)
        } else {
            (normal, centroid)
        }
    }
}

/// The refined passages ([`CellField::refined_passage`]) computed so far in a decimation, by
/// portal (NaN: not yet). The gate refines every portal between a pair's components when it
/// pops, and a pair of grown components again, so most portals between two rooms are asked
/// for many times, and the second pass of a moved run asks for the first's again; the value
/// depends on the field and the portal only, so a stored one has the bits of a new one.
///
/// The values are atomics so that the groups of a constrained pass ([`run_grouped`]) can
/// share it: each writes only the portals between its own cells (relaxed loads and stores
/// compile to plain moves).
struct RefinedCache {
    value: Vec<AtomicU64>,
    /// Values taken from the cache (for tests).
    hits: AtomicUsize,
    /// Core-cut judgements already made ([`CoreCuts`]).
    core_cuts: CoreCuts,
}

impl RefinedCache {
    fn new(cx: &CellComplex) -> Self {
        RefinedCache {
            value: (0..cx.portals.len())
                .map(|_| AtomicU64::new(f64::NAN.to_bits()))
                .collect(),
            hits: AtomicUsize::new(0),
            core_cuts: CoreCuts::new(cx.cells.len()),
        }
    }
    fn get(&self, k: usize) -> f64 {
        f64::from_bits(self.value[k].load(AtomicOrdering::Relaxed))
    }
    fn set(&self, k: usize, v: f64) {
        self.value[k].store(v.to_bits(), AtomicOrdering::Relaxed);
    }
    #[cfg(test)]
    fn hits(&self) -> usize {
        self.hits.load(AtomicOrdering::Relaxed)
    }
}

/// What [`core_cut`] returns: the cut's portals, their link, the cells on its two sides.
type CoreCut = (Vec<u32>, Link, [Vec<u32>; 2]);

/// The gate's core-cut judgements already made in one decimation, by their inputs.
/// [`core_judgement`] is a function of the two components' member lists (in order: they
/// number the flow network's nodes), the pair's saddle, opening and peaks, and the gate;
/// and the same pair is often judged again on the same members: by the constrained pass
/// ([`run_grouped`]), which repeats within each group the first pass's merges below the
/// threshold, and by groups merged again up to another group's stop (on a real level,
/// `oa_thor`, 8,787 of 110,293 core cuts, walking 5.1M of the 11.1M cells the cuts walk).
/// An entry keeps its inputs and is used only when they are equal (the hash only finds
/// the bucket), so a stored judgement is a new one's. (The complex, the field and the
/// cells' portal lists are the same for every merge of a decimation: each merge lists
/// every portal between two active cells, in portal order.) Pairs of fewer than
/// [`CoreCuts::MIN_CELLS`] cells are judged again (they are cheap), and storing stops once
/// the entries hold `budget` member ids.
struct CoreCuts {
    map: std::sync::Mutex<HashMap<u64, Vec<CoreEntry>, FxBuild>>,
    /// Member ids the entries may still hold.
    budget: AtomicUsize,
    /// Judgements taken from the cache (for tests).
    hits: AtomicUsize,
}

/// One stored judgement: its inputs and its result.
struct CoreEntry {
    a: Vec<u32>,
    b: Vec<u32>,
    /// Bits of the saddle, the opening and the two peaks.
    bits: [u64; 4],
    gate: ApertureGate,
    kept: bool,
}

impl CoreCuts {
    /// Pairs of fewer cells are judged again rather than stored.
    const MIN_CELLS: usize = 64;

    /// A cache that holds at most 16 member ids per cell of the complex (64 bytes per
    /// cell, beside the run's ~1.4 KB per active cell at its peak).
    fn new(cells: usize) -> Self {
        CoreCuts {
            map: std::sync::Mutex::new(HashMap::default()),
            budget: AtomicUsize::new(16 * cells),
            hits: AtomicUsize::new(0),
        }
    }

    fn hash(a: &[u32], b: &[u32], bits: [u64; 4]) -> u64 {
        use std::hash::BuildHasher;
        FxBuild::default().hash_one((a, b, bits))
    }

    /// The stored judgement of these inputs, if any.
    fn get(&self, a: &[u32], b: &[u32], bits: [u64; 4], gate: &ApertureGate) -> Option<bool> {
        let h = Self::hash(a, b, bits);
        let kept = {
            let map = self.map.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            map.get(&h)?
                .iter()
                .find(|e| e.bits == bits && e.gate == *gate && e.a == a && e.b == b)
                .map(|e| e.kept)
        };
        if kept.is_some() {
            self.hits.fetch_add(1, AtomicOrdering::Relaxed);
        }
        kept
    }

    /// Stores the judgement of these inputs, while the budget lasts.
    fn put(&self, a: &[u32], b: &[u32], bits: [u64; 4], gate: &ApertureGate, kept: bool) {
        let ids = a.len() + b.len();
        if ids < Self::MIN_CELLS
            || self
                .budget
                .fetch_update(AtomicOrdering::Relaxed, AtomicOrdering::Relaxed, |left| {
                    left.checked_sub(ids)
                })
                .is_err()
        {
            return;
        }
        let e = CoreEntry {
            a: a.to_vec(),
            b: b.to_vec(),
            bits,
            gate: *gate,
            kept,
        };
        let h = Self::hash(a, b, bits);
        let mut map = self.map.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        map.entry(h).or_default().push(e);
    }
}

/// What a core-cut judgement asks: whether the least-area cut between the cores of the
/// pair `(a, b)` of `comps` (its `saddle`, and `open` the opening its sections were
/// compared with) keeps the pair apart under `gate`.
#[derive(Clone, Copy)]
struct CoreQuestion<'a> {
    cx: &'a CellComplex,
    field: &'a CellField,
    cell_portals: &'a CellPortals,
    comps: &'a [Comp],
    pair: (usize, usize),
    saddle: f64,
    open: f64,
    gate: &'a ApertureGate,
}

/// [`core_judgement`] through the cache (`None`: always judge); a new judgement is stored
/// when `store`.
fn core_judgement_cached(q: &CoreQuestion<'_>, cache: Option<(&CoreCuts, bool)>) -> bool {
    let (comps, (a, b)) = (q.comps, q.pair);
    let judge = || core_judgement(q);
    let Some((cache, store)) = cache else {
        return judge();
    };
    let (ma, mb): (&[u32], &[u32]) = (&comps[a].members, &comps[b].members);
    if ma.len() + mb.len() < CoreCuts::MIN_CELLS {
        return judge();
    }
    let bits = [
        q.saddle.to_bits(),
        q.open.to_bits(),
        comps[a].peak.to_bits(),
        comps[b].peak.to_bits(),
    ];
    if let Some(kept) = cache.get(ma, mb, bits, q.gate) {
        return kept;
    }
    let kept = judge();
    if store {
        cache.put(ma, mb, bits, q.gate, kept);
    }
    kept
}

/// The gate's judgement on the least-area cut between the cores of the pair (see
/// [`CoreQuestion`]): whether it keeps the pair apart. Only a cut narrower than `open`
/// can: its two sides are then judged as the gate judges two components (each holds its
/// peak's ball twice over, and each section is at least `ratio` times the cut's opening).
fn core_judgement(q: &CoreQuestion<'_>) -> bool {
    let CoreQuestion {
        cx,
        field,
        cell_portals,
        comps,
        pair: (a, b),
        saddle,
        open,
        gate: g,
    } = *q;
    let Some((portals, cl, sides)) = core_cut(cx, field, cell_portals, comps, a, b, saddle) else {
        return false;
    };
    let narrower = if g.vector_opening { cl.opening() } else { cl.area };
    // (Not narrower, or an opening that is NaN: the cut keeps nothing apart.)
    if narrower.partial_cmp(&open) != Some(Ordering::Less) {
        return false;
    }
    // The two sides of the cut judged as the gate judges two
    // components: each holds its peak's ball twice over, and each
    // section is at least `ratio` times the cut's opening.
    let f2 = cl.frame(cx);
    let target = g.ratio * narrower;
    // The sides have no cached hulls and are judged once: their
    // projected section is the 2D hull of their projected vertices
    // and their extent along the normal their vertices' (building a
    // 3D hull for each was a fifth of the decimation on a real level).
    let volume = |cells: &[u32]| -> f64 { cells.iter().map(|&c| cx.cell_volume(CellId(c))).sum() };
    let mut k2 = g.holds_ball(comps[a].peak, volume(&sides[0])) && g.holds_ball(comps[b].peak, volume(&sides[1]));
    let mut q = (0.0, 0.0);
    if k2 {
        q = (projected(cx, &sides[0], &f2), projected(cx, &sides[1], &f2));
        k2 = q.0.min(q.1) >= target;
    }
    // The sides' parallel cuts, each summed only until it decides (a
    // second target resumes the sums).
    let mut memos: [Option<(SliceMemo, (f64, f64))>; 2] = [None, None];
    let mut cut_side = |i: usize, target: f64| {
        let (memo, extent) = memos[i].get_or_insert_with(|| fresh_memo(cx, &sides[i], &f2));
        memo.extend(cx, &sides[i], &f2, *extent, g.slices, target)
    };
    let mut sliced = |target: f64| {
        let s0 = cut_side(0, target);
        let s1 = if s0 >= target {
            cut_side(1, target)
        } else {
            f64::INFINITY
        };
        (s0, s1)
    };
    if k2 && g.slices > 0 {
        q = sliced(target);
        k2 = q.0.min(q.1) >= target;
    }
    if k2 && g.vector_opening && g.shadow_opening {
        let t2 = g.ratio * shadow(cx, &portals, &f2);
        if g.slices > 0 && q.0.min(q.1) < t2 {
            q = sliced(t2);
        }
        k2 = q.0.min(q.1) >= t2;
    }
    k2
}

/// An upper bound of [`CellField::refined_passage`] of portal `k`: the lower of its two
/// cells' peaks (every path it samples starts at one cell's best sample and ends at the
/// other's, so none is higher than either), `+inf` where a peak was clamped (a cell whose
/// `value` is 0 may have a raw peak that is not finite).
fn refined_bound(field: &CellField, cx: &CellComplex, k: u32) -> f64 {
    let [a, b] = cx.portals[k as usize].cells;
    let (va, vb) = (field.value[a.idx()], field.value[b.idx()]);
    if va > 0.0 && vb > 0.0 {
        va.min(vb)
    } else {
        f64::INFINITY
    }
}

/// [`Link::bits`]: the largest piece's normal is negated.
const FLIP: u32 = 1 << 31;
/// [`Link::bits`]: the saddle is the refined one.
const REFINED: u32 = 1 << 30;

/// A heap entry; the heap is a max-heap, so `Ord` is reversed to pop the lowest weight.
#[derive(Clone, Copy, Debug)]
struct Entry {
    weight: f64,
    saddle: f64,
    /// At weight 1, the higher of the two components' peaks when the pair was weighed,
    /// quantized; else 0 ([`KeyLayout::key_top`]): the tie-break before the ids.
    top: u64,
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
        // Lowest weight first, then the highest saddle, then the highest top, then the
        // lowest ids.
        o.weight
            .total_cmp(&self.weight)
            .then(self.saddle.total_cmp(&o.saddle))
            .then(self.top.cmp(&o.top))
            .then(o.a.cmp(&self.a))
            .then(o.b.cmp(&self.b))
    }
}

/// How a [`Key`]'s last word holds the tie-break and the ids: `id` bits per id (enough
/// for every cell id of the complex, so a group's local ids and the complex's share the
/// layout and compare alike), the quantized top in the `64 - 2 * id` bits above them.
///
/// **Why the top** (at weight 1 only: [`KeyLayout::key_top`]). Pairs of equal weight and
/// saddle are common: a cell that is not a local maximum joins a neighbour at weight
/// exactly 1 with its own peak as the saddle, and with two such neighbours the tie
/// decides which room it joins. Broken by the ids alone, the choice follows the
/// tetrahedra's numbering, which moves with the model
/// (scaled by 10^6, a generated two-storey building isolated 5 of 7 rooms where the
/// model as given isolated 7, because a piece between a pillar and a wide opening went
/// to the other room). The higher neighbour's peak is a length of the model, so the
/// tie-break is the same under rotations, offsets and scales (up to rounding): the cell
/// joins the neighbour whose peak is highest, the steepest way up the clearance field.
/// Quantized over the field's range of peaks into the bits the ids leave (20 at a
/// million triangles: relative steps of 2^-13 when the peaks span a factor 64), so a key
/// stays three words (24 bytes; a fourth word cost 28 MiB at a million triangles, beside
/// a 2 GiB goal); tops within a step fall back to the ids.
#[derive(Clone, Copy, Debug)]
struct KeyLayout {
    id: u32,
    /// `total_bits` of the lowest positive peak: tops at or below it quantize to 0.
    base: u64,
    /// Right shift of a top's `total_bits` above `base`, so that the highest peak fits.
    shift: u32,
}

impl KeyLayout {
    /// The layout for cell ids `0..cells` and peaks in `range` (lowest positive, highest:
    /// [`CellField::range`]).
    fn of(cells: usize, range: [f64; 2]) -> Self {
        let max = cells.saturating_sub(1).max(1) as u64;
        let id = (64 - max.leading_zeros()).min(32);
        let base = total_bits(range[0]);
        let span = total_bits(range[1]).saturating_sub(base);
        let top_bits = 64 - 2 * id;
        // The least shift that brings the span below 2^top_bits.
        let shift = if top_bits == 0 {
            64
        } else {
            (64 - span.leading_zeros()).saturating_sub(top_bits)
        };
        KeyLayout { id, base, shift }
    }

    /// The tie-break of an entry of weight `w`: the quantized top at weight exactly 1,
    /// where ties are systematic (a cell that is not a local maximum joins with its own
    /// peak as the saddle), else 0: an exact tie above 1 is a coincidence of symmetric
    /// geometry, left to the ids, and a pair above 1 need not be pushed again when a
    /// merge raises its top (on a real level, `oasago1`, pushing every such pair anew made
    /// the collapses 2.7 -> 16.0 s).
    fn key_top(self, w: f64, peak: f64) -> u64 {
        if w == 1.0 { self.top(peak) } else { 0 }
    }

    /// Bits of the quantized top (0 when the ids take the whole word).
    fn top_bits(self) -> u32 {
        64 - 2 * self.id
    }

    /// The top's quantization: its `total_cmp` order above the lowest peak, shifted to
    /// fit the bits left (monotone; NaN and tops above the range saturate).
    fn top(self, peak: f64) -> u64 {
        match self.top_bits() {
            0 => 0,
            t => {
                let q = total_bits(peak).saturating_sub(self.base) >> self.shift.min(63);
                q.min((1u64 << t) - 1)
            }
        }
    }
}

/// An [`Entry`] as the heap stores it: three integers whose lexicographic order is
/// `Entry`'s (`Key::of` is one to one and order-preserving, `entry` its inverse, for
/// entries whose ids and top fit the layout; `heap_keys_order_and_decode_as_entries`),
/// so a comparison is three integer compares instead of a chain of `total_cmp`s.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Key(u64, u64, u64);

/// `f64::total_cmp`'s order as an unsigned integer's (and back: the map is an involution
/// up to the sign bit's flip).
fn total_bits(x: f64) -> u64 {
    let b = x.to_bits() as i64;
    ((b ^ ((((b >> 63) as u64) >> 1) as i64)) as u64) ^ (1 << 63)
}

fn from_total_bits(u: u64) -> f64 {
    let t = (u ^ (1 << 63)) as i64;
    f64::from_bits((t ^ ((((t >> 63) as u64) >> 1) as i64)) as u64)
}

impl Key {
    /// Greater pops first: the lower weight, then the higher saddle, then the higher top,
    /// then the lower ids.
    fn of(e: Entry, lay: KeyLayout) -> Key {
        let ids = ((e.a as u64) << lay.id) | e.b as u64;
        let low = !ids & low_mask(2 * lay.id);
        let top = if lay.top_bits() == 0 { 0 } else { e.top << (2 * lay.id) };
        Key(!total_bits(e.weight), total_bits(e.saddle), top | low)
    }

    fn entry(self, lay: KeyLayout) -> Entry {
        let ids = !self.2 & low_mask(2 * lay.id);
        Entry {
            weight: self.weight(),
            saddle: from_total_bits(self.1),
            top: if lay.top_bits() == 0 { 0 } else { self.2 >> (2 * lay.id) },
            a: (ids >> lay.id) as u32,
            b: (ids & low_mask(lay.id)) as u32,
        }
    }

    fn weight(self) -> f64 {
        from_total_bits(!self.0)
    }
}

/// The lowest `n` bits set (`n <= 64`).
fn low_mask(n: u32) -> u64 {
    if n >= 64 { u64::MAX } else { (1u64 << n) - 1 }
}

/// Per-component state (72 bytes: one per cell id, so 2.3 million of them for a million
/// triangles; `components_are_compact`).
#[derive(Clone, Debug, Default)]
struct Comp {
    peak: f64,
    volume: f64,
    /// Active cells merged into the component; 0 for a component that is not alive (an
    /// inactive cell's, or one merged away).
    pieces: u32,
    links: Links,
    /// The complex cells in the component (kept only when the aperture is needed).
    members: Members,
    /// The 3D convex hull of the members' vertices, built when first needed, with the
    /// cells absorbed since whose vertices it does not hold yet ([`LazyHull`]).
    /// (Boxed: most components never need one, and `Comp` is allocated for every cell.)
    hull: Option<Box<LazyHull>>,
    /// The group of a constrained run ([`run_inner`]'s `labels`; 0 without).
    label: u32,
}

impl Comp {
    fn alive(&self) -> bool {
        self.pieces > 0
    }
}

/// A component's cells: one held inline (every component starts as one cell, and most
/// are merged away as one: no heap block for them), more in a [`ThinVec`] (its length
/// and capacity in the heap block). 16 bytes; derefs to the slice of ids.
#[derive(Clone, Debug, Default)]
enum Members {
    /// Not tracked, or merged away.
    #[default]
    Empty,
    One(u32),
    Many(ThinVec<u32>),
}

impl From<Vec<u32>> for Members {
    fn from(v: Vec<u32>) -> Self {
        Members::Many(v.into())
    }
}

impl std::ops::Deref for Members {
    type Target = [u32];
    fn deref(&self) -> &[u32] {
        match self {
            Members::Empty => &[],
            Members::One(x) => std::slice::from_ref(x),
            Members::Many(v) => v,
        }
    }
}

impl<'a> IntoIterator for &'a Members {
    type Item = &'a u32;
    type IntoIter = std::slice::Iter<'a, u32>;
    fn into_iter(self) -> Self::IntoIter {
        self.iter()
    }
}

impl Members {
    fn vec(&mut self) -> &mut ThinVec<u32> {
        if !matches!(self, Members::Many(_)) {
            *self = Members::Many(self.iter().copied().collect());
        }
        match self {
            Members::Many(v) => v,
            _ => unreachable!("made a vector above"),
        }
    }
    #[cfg(test)]
    fn push(&mut self, x: u32) {
        self.vec().push(x);
    }
    /// Appends `o`'s ids (in their order) and empties it.
    fn append(&mut self, o: &mut Members) {
        let o = std::mem::take(o);
        if !o.is_empty() {
            self.vec().extend_from_slice(&o);
        }
    }
}

/// A component's neighbours, sorted by id, each with the slot of their pair's link in the
/// [`LinkStore`]: the subset of `BTreeMap<u32, _>`'s interface the merge uses, in a flat
/// vector (a B-tree node holds eleven entries, for components that mostly have three or
/// four neighbours). Iteration is in key order, as the map's.
#[derive(Clone, Debug, Default)]
struct Links(Vec<(u32, u32)>);

impl Links {
    fn find(&self, k: u32) -> Result<usize, usize> {
        self.0.binary_search_by_key(&k, |e| e.0)
    }
    fn len(&self) -> usize {
        self.0.len()
    }
    /// The slot of the link towards `k`, if linked.
    fn slot(&self, k: u32) -> Option<u32> {
        self.find(k).ok().map(|i| self.0[i].1)
    }
    /// Links `k` through `slot` (replacing its slot if already linked).
    fn insert(&mut self, k: u32, slot: u32) {
        match self.find(k) {
            Ok(i) => self.0[i].1 = slot,
            Err(i) => self.0.insert(i, (k, slot)),
        }
    }
    /// Unlinks `k`; gives its slot.
    fn remove(&mut self, k: u32) -> Option<u32> {
        self.find(k).ok().map(|i| self.0.remove(i).1)
    }
    fn keys(&self) -> impl Iterator<Item = &u32> + '_ {
        self.0.iter().map(|e| &e.0)
    }
}

/// The links of all components: one [`Link`] per linked pair, held as seen from the
/// pair's lower id, instead of a copy in each component (80 bytes per copy; a million
/// triangles have about 2.6 million pairs). The higher id reads it
/// [`reversed`](Link::reversed), which negates the orientation (exact), so it sees the
/// bits its own copy held, up to the sign of zero components of `av` (which no value
/// depends on: they enter only norms, products and comparisons). Slots of links fused
/// away are reused.
#[derive(Clone, Debug, Default)]
struct LinkStore {
    links: Vec<Link>,
    free: Vec<u32>,
}

impl LinkStore {
    fn with_capacity(n: usize) -> Self {
        LinkStore {
            links: Vec::with_capacity(n),
            free: Vec::new(),
        }
    }
    /// The link in `slot` as seen from `from` towards `to`.
    fn get(&self, slot: u32, from: u32, to: u32) -> Link {
        let l = self.links[slot as usize];
        if from < to { l } else { l.reversed() }
    }
    /// Stores `l`, seen from `from` towards `to`, in `slot`.
    fn set(&mut self, slot: u32, from: u32, to: u32, l: Link) {
        self.links[slot as usize] = if from < to { l } else { l.reversed() };
    }
    /// The link in `slot`, for the fields that do not depend on the side (`saddle`,
    /// `area`, `queued`, `refined`).
    fn at(&mut self, slot: u32) -> &mut Link {
        &mut self.links[slot as usize]
    }
    /// A new slot holding `l`, seen from `from` towards `to`.
    fn add(&mut self, from: u32, to: u32, l: Link) -> u32 {
        let slot = match self.free.pop() {
            Some(s) => s,
            None => {
                self.links.push(Link::EMPTY);
                (self.links.len() - 1) as u32
            }
        };
        self.set(slot, from, to, l);
        slot
    }
    fn release(&mut self, slot: u32) {
        self.free.push(slot);
    }
}

/// How many neighbours ahead the merge's loops over a component's links ask for the
/// cache lines they will read (a few misses in flight at once; a whole list of a large
/// component's thousands of links would evict its own first lines).
const AHEAD: usize = 16;

/// Hints the component of the `i`-th neighbour in `ks` (its link list's header) and their
/// link, if there is such a neighbour.
#[inline(always)]
fn hint_link(comps: &[Comp], store: &LinkStore, ks: &[(u32, u32)], i: usize) {
    if let Some(&(k, sk)) = ks.get(i) {
        prefetch_all(&comps[k as usize].links);
        prefetch_all(&store.links[sk as usize]);
    }
}

/// Hints the first entries of the `i`-th neighbour's link list (its header, hinted
/// earlier by [`hint_link`], is read here).
#[inline(always)]
fn hint_list(comps: &[Comp], ks: &[(u32, u32)], i: usize) {
    if let Some(first) = ks.get(i).and_then(|&(k, _)| comps[k as usize].links.0.first()) {
        prefetch(first);
    }
}

/// Collapses `b` into `a` in the link graph: drops their link, and moves each other link
/// of `b` to `a`, fused with `a`'s own link to the same neighbour (`Link::fuse`, `a`'s
/// side first) where it has one. `ca` and `cb` are the two components, taken out of
/// `comps`.
fn merge_links(comps: &mut [Comp], store: &mut LinkStore, ca: &mut Comp, cb: &Comp, a: u32, b: u32) {
    if let Some(s) = ca.links.remove(b) {
        store.release(s);
    }
    // The neighbours are random ids: their components and links are asked for `AHEAD`
    // neighbours ahead, their link lists half as far (hints only; nothing below depends
    // on them), so that their cache misses overlap instead of coming one after another.
    let ks = &cb.links.0;
    for i in 0..AHEAD {
        hint_link(comps, store, ks, i);
    }
    for i in 0..AHEAD / 2 {
        hint_list(comps, ks, i);
    }
    for (i, &(k, sk)) in ks.iter().enumerate() {
        hint_link(comps, store, ks, i + AHEAD);
        hint_list(comps, ks, i + AHEAD / 2);
        if k == a {
            continue;
        }
        let m = &mut comps[k as usize].links;
        m.remove(b);
        let lk = store.get(sk, b, k);
        match ca.links.slot(k) {
            Some(sa) => {
                let fused = store.get(sa, a, k).fuse(&lk);
                store.set(sa, a, k, fused);
                store.release(sk);
            }
            None => {
                store.set(sk, a, k, Link::EMPTY.fuse(&lk));
                ca.links.insert(k, sk);
                m.insert(a, sk);
            }
        }
    }
}

/// The aperture gate of a persistence merge: a pair whose persistence is at least `from`
/// is kept apart when the smaller of the two components' projected sections on the
/// portal plane is at least `ratio` times the portal area (the opening is a small part of
/// the room's cross-section, as a door is; see [`ApertureGate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ApertureGate {
    /// Persistence from which the gate applies (below it, merges are not gated).
    pub from: f64,
    /// Section-to-opening ratio at or above which a pair is kept apart.
    pub ratio: f64,
    /// The gate applies only when each component's volume is at least `ball` times the
    /// volume of its largest empty ball (radius = its peak): a component that cannot hold
    /// its own inscribed ball is a piece of the region around its peak, not yet a room.
    pub ball: f64,
    /// Dominance ratio of the final clean-up pass (0: off). When the merge stops, a
    /// component whose peak is below `dominance` times a neighbour's is absorbed into
    /// the dominating neighbour across the largest portal area, lowest peak first, until
    /// none is left: a component whose largest empty ball is that much smaller than its
    /// neighbour's is a pocket, sliver or slab of leaked solid, not a room of its own. A
    /// ratio of two radii: scale-free. The pass runs after the merge (whose rooms are
    /// then whole: during the merge a room's fragments have low peaks too), and its steps
    /// are recorded after the merge's, with the peak ratio as their weight.
    pub dominance: f64,
    /// Sections by slicing (0: by projection): when the projected sections would keep a
    /// pair apart, each side's section is taken again as the largest of `slices` cuts of
    /// the component parallel to the portal plane, evenly spaced across its extent along
    /// the normal (a long component cut obliquely projects far wider than it is; its
    /// parallel cuts do not). A cut lies inside its projection, so slicing only ever
    /// joins more.
    pub slices: usize,
    /// Slab ratio of the final clean-up pass (0: off): a component whose projected
    /// section on the plane of its portals towards a neighbour whose peak is above its own
    /// by `1 / slab_peak` is below `slab` times their area is absorbed there as well (after
    /// the merge, with the dominance rule). A room
    /// behind an opening has a section several times the opening's area (the gate keeps
    /// such pairs apart at `ratio`); a slab of leaked solid or exterior along a wall, or a
    /// pocket behind one of its own faces, has about the portal's: ratios of areas, so
    /// scale-free.
    pub slab: f64,
    /// The slab rule applies only towards a neighbour whose peak is above the component's
    /// by `1 / slab_peak` (a pair of comparable rooms joined by a wide tunnel, whose
    /// interface of tetrahedron faces zigzags across it and sums to more than the
    /// section, is not a slab and its rooms).
    pub slab_peak: f64,
    /// Whether the opening the sections are compared with is the portals' *vector* area
    /// (the norm of the sum of their area-weighted normals, [`Link::opening`]) rather than
    /// the sum of their areas. The tetrahedra's faces that make up the interface between
    /// two components zigzag across a doorway, and their summed area exceeds the doorway's
    /// (by 1.3–2.8 times on the suite's wide openings); the vector area of any surface
    /// spanning a planar rim is the rim's area, whatever the surface's folds, so it
    /// measures the opening itself and does not depend on the tetrahedralization.
    pub vector_opening: bool,
    /// Whether a pair the vector opening would keep apart is judged again against the
    /// *shadow* of its portals: the area of the union of the pieces projected on the
    /// portal plane. The vector area is the rim's area only for a surface spanning a rim;
    /// an interface that wraps around one side (two pieces of one room, one cupped in the
    /// other's faces) cancels in the sum and reads as a small opening (6.8 of 67 on a
    /// rotated generated building), though its shadow is large. The shadow is at least the
    /// vector area (the norm of a sum of projected areas is at most the area they cover),
    /// and it is the rim's area for a zigzag spanning a planar rim, so this only joins
    /// pairs whose interface covers more than its signed sum says.
    pub shadow_opening: bool,
    /// Whether the boundaries between the stopped merge's components are moved to the
    /// narrowest section between them ([`tunnel_labels`]) and the merge is run again
    /// within the moved groups. Along a tunnel of nearly uniform width the field has no
    /// sharp pass, so where two rooms' fronts meet is decided by the order of collapses at
    /// weight about 1, i.e. by the tetrahedra; the least-area cut between the rooms' cores
    /// is a property of the space (and of the faces available to it).
    pub tunnels: bool,
    /// Whether a pair the sections would join is judged again against the least-area cut
    /// between the two components' cores ([`core_cut`]) when that cut is narrower than
    /// their interface: a component that grew through a door meets its neighbour away
    /// from the door, across the wider space beyond, and the interface then measures that
    /// space, not the opening between the rooms (how far a component has grown depends on
    /// the order of collapses, i.e. on the tetrahedra).
    pub core_cut: bool,
}

impl ApertureGate {
    /// Whether a component of this peak and volume is big enough to be gated.
    fn holds_ball(&self, peak: f64, volume: f64) -> bool {
        volume >= self.ball * 4.0 / 3.0 * std::f64::consts::PI * peak.powi(3)
    }
}

/// One pair the merge looked at (a collapse, or a pair the gate kept apart), for
/// diagnostics ([`trace`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceStep {
    /// The two components (smallest cell ids).
    pub a: CellId,
    /// The second component.
    pub b: CellId,
    /// The persistence `min(peaks) / saddle`.
    pub weight: f64,
    /// The peaks.
    pub peaks: [f64; 2],
    /// The saddle.
    pub saddle: f64,
    /// The portal area between them.
    pub portal_area: f64,
    /// The portals' vector area ([`ApertureGate::vector_opening`]).
    pub opening: f64,
    /// The components' projected areas on the portal plane (2D hull of the 3D hull).
    pub projected: [f64; 2],
    /// The volumes.
    pub volumes: [f64; 2],
    /// Whether the gate kept them apart (no collapse).
    pub kept: bool,
}

/// Runs the clearance merge on the active cells of `cx` (the `clearance` heuristic's
/// engine; `settings.estimator` is not used).
pub(crate) fn run(cx: &CellComplex, settings: &Settings, progress: &mut dyn FnMut(usize, usize)) -> Decimation {
    // A stop at a number of cells asks for that many: the gate, which may keep more, is off.
    let gate = settings
        .heuristic
        .heuristic()
        .aperture_gate()
        .filter(|_| !matches!(settings.stop, StopRule::Cells(_)));
    run_moved(cx, settings, gate, None, progress)
}

/// The merge, then (with a gate that moves boundaries and a `threshold` stop) the merge
/// again within the groups [`tunnel_labels`] gives, if they differ from the first's.
fn run_moved(
    cx: &CellComplex,
    settings: &Settings,
    gate: Option<ApertureGate>,
    mut trace: Option<&mut Vec<TraceStep>>,
    progress: &mut dyn FnMut(usize, usize),
) -> Decimation {
    // The reported times cover the whole decimation: the field and the first pass's weights
    // in `init_seconds`; the first pass's collapses, the moved boundaries and the second
    // pass's collapses in `collapse_seconds` (the second pass's weights are added to the
    // first's), so `run`'s stage lines add up to the decimation's time.
    let t = Instant::now();
    let field = CellField::new(cx);
    let field_seconds = t.elapsed().as_secs_f64();
    let refined = RefinedCache::new(cx);
    let mut first = run_inner(
        cx,
        &field,
        &refined,
        settings,
        gate,
        trace.as_deref_mut(),
        None,
        None,
        progress,
    );
    first.stats.init_seconds += field_seconds;
    let StopReason::Threshold { next_weight, .. } = first.stop else {
        return first;
    };
    if !gate.is_some_and(|g| g.tunnels) {
        return first;
    }
    let t = Instant::now();
    let Some(labels) = tunnel_labels(cx, &field, &first.partition) else {
        return first;
    };
    let label_seconds = t.elapsed().as_secs_f64();
    // Only the first pass's counters are kept: its steps and partition are freed before the
    // second pass allocates its own.
    let first_stats = std::mem::take(&mut first.stats);
    drop(first);
    if let Some(t) = trace.as_deref_mut() {
        t.clear();
    }
    // Without a trace, the groups merge on every core (the same result).
    let grouped = match (gate, trace.is_none()) {
        (Some(g), true) => run_grouped(
            cx,
            &field,
            &refined,
            settings,
            g,
            (&labels, next_weight),
            first_stats.regions,
            progress,
        ),
        _ => None,
    };
    let mut second = match grouped {
        Some(d) => d,
        None => run_inner(
            cx,
            &field,
            &refined,
            settings,
            gate,
            trace,
            None,
            Some((&labels, next_weight)),
            progress,
        ),
    };
    second.stats.init_seconds += first_stats.init_seconds;
    second.stats.collapse_seconds += first_stats.collapse_seconds + label_seconds;
    second
}

/// The run to the end (stop `none`) and, from the same pass, the run stopped at
/// `threshold:r` (a prefix of it up to the first pair popped at or above `r`, which
/// is where the stopped run would have stopped, followed by the clean-up pass applied to a
/// copy of the components there; same steps, stop reason and counters). With a gate that
/// moves boundaries, the pass runs twice when the first one's stopped groups move: the
/// second keeps to the moved groups until the cut, then goes on freely to the end.
pub(crate) fn run_to_end_and_cut(
    cx: &CellComplex,
    settings: &Settings,
    r: f64,
    progress: &mut dyn FnMut(usize, usize),
) -> (Decimation, Decimation) {
    let full_settings = Settings {
        stop: StopRule::None,
        ..*settings
    };
    let gate = settings.heuristic.heuristic().aperture_gate();
    let field = CellField::new(cx);
    let refined = RefinedCache::new(cx);
    // One pass to the end, cut where `threshold:r` stops: (stopped, full, next weight).
    let pass = |labels: Option<(&[u32], f64)>, progress: &mut dyn FnMut(usize, usize)| {
        let mut cut = None;
        let full = run_inner(
            cx,
            &field,
            &refined,
            &full_settings,
            gate,
            None,
            Some((r, &mut cut)),
            labels,
            progress,
        );
        let next = cut.as_ref().map(|c: &super::Cut| c.next_weight);
        (full.cut(cx, settings, cut), full, next)
    };
    let (stopped, full, next) = pass(None, progress);
    let (Some(next), true) = (next, gate.is_some_and(|g| g.tunnels)) else {
        return (stopped, full);
    };
    let Some(labels) = tunnel_labels(cx, &field, &stopped.partition) else {
        return (stopped, full);
    };
    // The first pass's results are replaced: freed before the second pass allocates.
    drop((stopped, full));
    let (stopped, full, _) = pass(Some((&labels, next)), &mut |_, _| {});
    (stopped, full)
}

/// The merge with `gate` (overriding the heuristic's), recording every pair it looks at
/// with the components' projected sections (slow: for diagnostics). With boundaries moved,
/// the record is the second pass's.
pub fn trace(cx: &CellComplex, settings: &Settings, gate: Option<ApertureGate>) -> (Decimation, Vec<TraceStep>) {
    let mut t = Vec::new();
    let d = run_moved(cx, settings, gate, Some(&mut t), &mut |_, _| {});
    (d, t)
}

/// The groups of a stopped merge with each boundary moved to the narrowest section between
/// the two groups (`None` when no cell moves). For each pair of neighbouring groups
/// `(i, j)` (in order of their ids, each seeing the moves of the pairs before it): the
/// *cores* are the cells of each group whose field value is at least the geometric mean
/// of the pair's saddle (the highest passage between them) and the lower of their peaks;
/// the boundary becomes the minimum cut, by portal area, between the cores of `i` and
/// those of `j` through the other cells of the two groups (the cells reachable from `i`'s
/// cores in the residual graph of a maximum flow join `i`, those that reach `j`'s cores
/// join `j`, any other — between two cuts of least area — the group of the higher peak). A ratio of two field values of the model picks
/// the cores, and the cut is the least-area surface the complex offers between them,
/// whatever the order in which the merge reached it: a tunnel's boundary lands at its
/// narrowest section.
pub fn tunnel_labels(cx: &CellComplex, field: &CellField, part: &super::Partition) -> Option<Vec<u32>> {
    let n = cx.cells.len();
    let mut label = vec![u32::MAX; n];
    let mut members: Vec<Vec<u32>> = vec![Vec::new(); part.len()];
    for (i, c) in part.cells.iter().enumerate() {
        for p in &c.pieces {
            label[p.idx()] = i as u32;
            members[i].push(p.0);
        }
    }
    let peak: Vec<f64> = members
        .iter()
        .map(|m| m.iter().map(|&c| field.value[c as usize]).fold(0.0, f64::max))
        .collect();
    let cell_portals = CellPortals::new(cx, |k| {
        let [a, b] = cx.portals[k].cells;
        a != b && label[a.idx()] != u32::MAX && label[b.idx()] != u32::MAX
    });
    // Each portal's two cells and area, compact (16 B instead of a portal with its pieces):
    // the loop below reads them for every portal of every cell of both groups of a pair.
    let ends: Vec<(u32, u32, f64)> = cx
        .portals
        .iter()
        .map(|p| (p.cells[0].0, p.cells[1].0, p.area))
        .collect();
    let pairs: Vec<(u32, u32, f64)> = part
        .portals(cx)
        .iter()
        .filter_map(|mp| {
            let (i, j) = (part.cell_of(mp.cells[0])?, part.cell_of(mp.cells[1])?);
            let s = mp.portals.iter().map(|&k| field.passage[k]).fold(0.0, f64::max);
            Some((i.min(j) as u32, i.max(j) as u32, s))
        })
        .collect();
    let mut moved = false;
    // The flow node of each cell of the current pair's two groups (`u32::MAX`: none; reset
    // after each pair). Shared by the pairs of a wave: each writes and reads only its own
    // groups' cells (a neighbour is read only when its label is one of the pair's).
    let node: Vec<AtomicU32> = (0..n).map(|_| AtomicU32::new(u32::MAX)).collect();
    let get = |c: u32| node[c as usize].load(AtomicOrdering::Relaxed);
    let put = |c: u32, v: u32| node[c as usize].store(v, AtomicOrdering::Relaxed);
    // Pair `(i, j)` sees the moves of every earlier pair that shares a group with it, so
    // it runs in the wave after the last of them; the pairs of one wave share no group and
    // run on every core, their moves applied after the wave in the pairs' order: the moves
    // of the pairs in order, one at a time.
    let mut last = vec![0usize; members.len()];
    let mut waves: Vec<Vec<(u32, u32, f64)>> = Vec::new();
    for (i, j, saddle) in pairs {
        let w = last[i as usize].max(last[j as usize]);
        if w == waves.len() {
            waves.push(Vec::new());
        }
        waves[w].push((i, j, saddle));
        last[i as usize] = w + 1;
        last[j as usize] = w + 1;
    }
    // The new members of `i` and `j` (`None`: the pair moves nothing).
    let cut = |i: u32, j: u32, saddle: f64, members: &[Vec<u32>], label: &[u32]| -> Option<[Vec<u32>; 2]> {
        let level = (saddle * peak[i as usize].min(peak[j as usize])).sqrt();
        if !(level.is_finite() && level > 0.0) {
            return None;
        }
        // Nodes 0 (source: i's cores) and 1 (sink: j's cores), then the other cells.
        let mut cells: Vec<u32> = Vec::new();
        let mut cores = [false; 2];
        for &g in &[i, j] {
            for &c in &members[g as usize] {
                if field.value[c as usize] >= level {
                    put(c, (g == j) as u32);
                    cores[(g == j) as usize] = true;
                } else {
                    put(c, 2 + cells.len() as u32);
                    cells.push(c);
                }
            }
        }
        let reset = || {
            for &g in &[i, j] {
                for &c in &members[g as usize] {
                    put(c, u32::MAX);
                }
            }
        };
        if !(cores[0] && cores[1]) || cells.is_empty() {
            reset();
            return None;
        }
        let m = 2 + cells.len();
        // Each portal between two flow nodes, once (from its lower cell), both ends in the
        // pair; its area is the capacity.
        let mut edges: Vec<(u32, u32, f64)> = Vec::new();
        for &g in &[i, j] {
            for &c in &members[g as usize] {
                for &k in cell_portals.of(c as usize) {
                    let (a, b, area) = ends[k as usize];
                    let o = if a == c { b } else { a };
                    if label[o as usize] != i && label[o as usize] != j {
                        continue;
                    }
                    let (x, y) = (get(c), get(o));
                    if x == u32::MAX || y == u32::MAX {
                        continue;
                    }
                    if c > o || x == y {
                        continue;
                    }
                    edges.push((x, y, area));
                }
            }
        }
        // The cells the source's cores reach in the residual graph, and those that reach
        // the sink's (the same sets for every maximum flow).
        let (reach, to_sink) = super::flow::FlowNet::new(m, edges).min_cut(0, 1);
        // Cells between the least and the largest minimum cut (a tie: a tunnel of uniform
        // section) join the group of the higher peak (then the larger volume, then the
        // lower id): not the group they came from, which the collapse order chose.
        let volume = |g: u32| -> f64 { members[g as usize].iter().map(|&c| cx.cell_volume(CellId(c))).sum() };
        let tie = match peak[i as usize].total_cmp(&peak[j as usize]) {
            Ordering::Greater => 0,
            Ordering::Less => 1,
            Ordering::Equal => (volume(j) > volume(i)) as usize,
        };
        let mut next: [Vec<u32>; 2] = [Vec::new(), Vec::new()];
        for &g in &[i, j] {
            for &c in &members[g as usize] {
                let x = get(c) as usize;
                let side = if x < 2 {
                    x
                } else if reach[x] {
                    0
                } else if to_sink[x] {
                    1
                } else {
                    tie
                };
                next[side].push(c);
            }
        }
        reset();
        Some(next)
    };
    for wave in waves {
        let cuts: Vec<Option<[Vec<u32>; 2]>> = wave
            .par_iter()
            .map(|&(i, j, saddle)| cut(i, j, saddle, &members, &label))
            .collect();
        for (&(i, j, _), next) in wave.iter().zip(cuts) {
            let Some([a, b]) = next else { continue };
            for (side, cells) in [(i, &a), (j, &b)] {
                for &c in cells {
                    moved |= label[c as usize] != side;
                    label[c as usize] = side;
                }
            }
            members[i as usize] = a;
            members[j as usize] = b;
        }
    }
    moved.then_some(label)
}

/// The two components of a pair, the one with fewer members first (the side whose members
/// are walked to find the portals between them).
fn smaller_first(comps: &[Comp], a: usize, b: usize) -> (usize, usize) {
    if comps[a].members.len() <= comps[b].members.len() {
        (a, b)
    } else {
        (b, a)
    }
}

/// The least-area cut between the cores of neighbouring components `a` and `b` (local
/// ids), as its portals and their link seen from `a`'s
/// side; `None` when a side has no core. A side's core is the region of its cells whose
/// field value is at least the geometric mean of the pair's saddle and the lower peak,
/// connected (through such cells of the side) to a cell at the side's peak; the cut is
/// the minimum cut by portal area between the two cores through the two components'
/// other cells (the least one: the cells the first core reaches in the residual graph
/// of a maximum flow, [`super::flow`]). Unlike the cores [`tunnel_labels`] takes (every
/// cell above the level), a side's high cells that are not connected to its peak (a
/// part of the corridor a room's component grew into) are not its core.
fn core_cut(
    cx: &CellComplex,
    field: &CellField,
    cell_portals: &CellPortals,
    comps: &[Comp],
    a: usize,
    b: usize,
    saddle: f64,
) -> Option<CoreCut> {
    let (ca, cb) = (&comps[a], &comps[b]);
    let level = (saddle * ca.peak.min(cb.peak)).sqrt();
    if !(level.is_finite() && level > 0.0) {
        return None;
    }
    let cells: Vec<u32> = ca.members.iter().chain(cb.members.iter()).copied().collect();
    let na = ca.members.len();
    let index: HashMap<u32, u32, FxBuild> = cells.iter().enumerate().map(|(i, &c)| (c, i as u32)).collect();
    let value = |i: usize| field.value[cells[i] as usize];
    // The neighbours of each cell among the pair's cells, with the portal between them, in
    // `cell_portals` order: gathered once (`adj[start[i]..start[i + 1]]`), since the
    // cores, the edges and the cut's portals each walk them.
    let mut start: Vec<u32> = Vec::with_capacity(cells.len() + 1);
    let mut adj: Vec<(u32, u32)> = Vec::new();
    start.push(0);
    for &c in &cells {
        for &k in cell_portals.of(c as usize) {
            let [x, y] = cx.portals[k as usize].cells;
            let o = if x.0 == c { y.0 } else { x.0 };
            if let Some(&j) = index.get(&o) {
                adj.push((j, k));
            }
        }
        start.push(adj.len() as u32);
    }
    drop(index);
    let (adj_ref, start_ref) = (&adj, &start);
    let neighbours = move |i: usize| {
        adj_ref[start_ref[i] as usize..start_ref[i + 1] as usize]
            .iter()
            .map(|&(j, k)| (j as usize, k))
    };
    // Flow nodes: 0 the source (a's core), 1 the sink (b's core), 2.. the other cells.
    let mut node = vec![u32::MAX; cells.len()];
    for (side, range, peak) in [(0u32, 0..na, ca.peak), (1, na..cells.len(), cb.peak)] {
        let mut stack: Vec<usize> = range
            .clone()
            .filter(|&i| value(i).to_bits() == peak.to_bits() && value(i) >= level)
            .collect();
        if stack.is_empty() {
            return None;
        }
        for &i in &stack {
            node[i] = side;
        }
        while let Some(i) = stack.pop() {
            for (j, _) in neighbours(i) {
                if range.contains(&j) && node[j] == u32::MAX && value(j) >= level {
                    node[j] = side;
                    stack.push(j);
                }
            }
        }
    }
    let mut m = 2u32;
    for x in node.iter_mut().filter(|x| **x == u32::MAX) {
        *x = m;
        m += 1;
    }
    let mut edges = Vec::new();
    for i in 0..cells.len() {
        for (j, k) in neighbours(i) {
            if cells[i] < cells[j] && node[i] != node[j] {
                edges.push((node[i], node[j], cx.portals[k as usize].area));
            }
        }
    }
    let (reach, to_sink) = super::flow::FlowNet::new(m as usize, edges).min_cut(0, 1);
    // The cells on either side of the cut (of the least one and of the largest one).
    let mut sides: [Vec<u32>; 2] = [Vec::new(), Vec::new()];
    for (i, &c) in cells.iter().enumerate() {
        let x = node[i] as usize;
        if reach[x] {
            sides[0].push(c);
        } else if to_sink[x] {
            sides[1].push(c);
        }
    }
    let mut portals = Vec::new();
    let mut link = Link::EMPTY;
    for i in 0..cells.len() {
        if !reach[node[i] as usize] {
            continue;
        }
        for (j, k) in neighbours(i) {
            if !reach[node[j] as usize] {
                let pl = portal_link(cx, field, k as usize);
                let pl = if cx.portals[k as usize].cells[0].0 == cells[i] {
                    pl
                } else {
                    pl.reversed()
                };
                link = link.fuse(&pl);
                portals.push(k);
            }
        }
    }
    Some((portals, link, sides))
}

/// The portals between the component whose members are `members` and the component
/// `other` (local ids, `owner` the union-find of the merge), in the members' order.
fn portals_between<I: Ids>(
    cx: &CellComplex,
    cell_portals: &CellPortals,
    ids: I,
    owner: &mut [u32],
    members: &[u32],
    other: usize,
) -> Vec<u32> {
    let mut between = Vec::new();
    for &m in members {
        for &k in cell_portals.of(m as usize) {
            let [x, y] = cx.portals[k as usize].cells;
            let o = if x.0 == m { y.0 } else { x.0 };
            if ids.local(o).is_some_and(|o| find(owner, o) as usize == other) {
                between.push(k);
            }
        }
    }
    between
}

/// The shadow of portals on `frame`'s plane: the area of the union of their pieces,
/// projected ([`union_area`], exact up to rounding).
fn shadow(cx: &CellComplex, portals: &[u32], frame: &Frame) -> f64 {
    let polys: Vec<Vec<P2>> = portals
        .iter()
        .flat_map(|&k| cx.portals[k as usize].pieces.iter())
        .map(|piece| {
            let mut q: Vec<P2> = piece.verts.iter().map(|v| frame.project(v)).collect();
            if polygon_area(&q) < 0.0 {
                q.reverse();
            }
            q
        })
        .collect();
    let a = union_area(&polys);
    if a.is_finite() { a.max(0.0) } else { 0.0 }
}

/// A component's hull and the member cells whose vertices it does not hold yet: a merge
/// with a component that has no hull only records the other side's cells, and the next
/// [`section`] inserts their vertices. A computed hull is never dropped: a large component
/// absorbing a piece whose hull was never needed used to lose its own, and the next
/// [`section`] rebuilt it from every member's vertices, so a big hall merging thousands of
/// small pieces between gated pops was quadratic (a 20×20 m low room of 2,892 polygons:
/// 24 s of collapses, 81% in `Hull3::new`); inserting at the merge instead cost the 1M
/// building's collapses about 10% (components that are never gated again).
#[derive(Clone, Debug, Default)]
struct LazyHull {
    hull: Hull3,
    pending: Vec<u32>,
    /// The parallel cuts of the last few frames the gate judged the component on
    /// ([`SliceMemo`]; kept here because only components with a hull are ever cut).
    slices: Vec<SliceMemo>,
}

/// What [`sliced_section`] learnt about a component along one frame, for the next
/// judgement on the same frame (a kept pair is judged again every time either side grows:
/// on a real level a 20k–80k-cell component was cut along one frame 953 times, growing by a
/// cell or two between judgements, and recomputing every member's heights and cuts was
/// most of the run).
///
/// Valid for the first `ranges.len()` members as listed at the judgement; members are only
/// ever appended after them ([`Comp::absorb_members`] moves the memo of the list that stays
/// first and drops the other), so later judgements extend it with the new members only.
/// Every value is the one the plain computation gives: a cut's sum continues in the
/// members' order from where it stopped (the same additions), and the per-member ranges
/// only decide which members are skipped, so they are kept in `f32` rounded outwards (a
/// member visited needlessly adds exactly 0). A judgement that only needs to know whether
/// a cut reaches a given area may stop summing early: then `ranges` and `summed` cover a
/// prefix of the members, and the next judgement continues from it.
#[derive(Clone, Debug, Default)]
struct SliceMemo {
    /// The frame's normal, axes and origin, as bits.
    frame: [u64; 12],
    /// The first members' (lowest, highest) vertex height, rounded outwards;
    /// (-inf, inf) when a height is NaN (never skipped).
    ranges: Vec<(f32, f32)>,
    /// The cuts' partial sums over the first `summed` members (`summed <= ranges.len()`),
    /// at the heights given by `cut_at` (the extent and the number of cuts they were taken
    /// for).
    sums: Vec<f64>,
    summed: usize,
    cut_at: (u64, u64, usize),
}

/// Frames a component's [`SliceMemo`]s are kept for (the least recently used is dropped).
const SLICE_MEMO_FRAMES: usize = 16;

/// Components with fewer members have their cuts computed afresh at each judgement (cheap,
/// and most components never reach this size).
const SLICE_MEMO_MEMBERS: usize = 1024;

/// The hull of two merged components, each given as (its hull if computed, its members):
/// both hulls merged (the other's pending cells carried over), or the one hull with the
/// other side's cells pending, or none when neither was computed. The hull of the union
/// either way once flushed (the same extreme points; [`Hull3`] keeps coplanar extras,
/// which change no projection).
fn merged_hull(a: (Option<Box<LazyHull>>, &[u32]), b: (Option<Box<LazyHull>>, &[u32])) -> Option<Box<LazyHull>> {
    match (a, b) {
        ((Some(mut x), _), (Some(y), _)) => {
            x.hull.insert_all(&y.hull);
            x.pending.extend_from_slice(&y.pending);
            Some(x)
        }
        ((Some(mut x), _), (None, ms)) | ((None, ms), (Some(mut x), _)) => {
            x.pending.extend_from_slice(ms);
            Some(x)
        }
        _ => None,
    }
}

impl Comp {
    /// Takes `o`'s members (the longer list keeps its allocation) and its hull
    /// ([`merged_hull`]).
    fn absorb_members(&mut self, o: &mut Comp) {
        // The list that stays first keeps its cuts' memos (the other's are no prefix).
        let first = if self.members.len() < o.members.len() {
            &mut o.hull
        } else {
            &mut self.hull
        };
        let memos = first
            .as_mut()
            .map(|h| std::mem::take(&mut h.slices))
            .unwrap_or_default();
        self.hull = merged_hull((self.hull.take(), &self.members), (o.hull.take(), &o.members));
        if let Some(h) = self.hull.as_mut() {
            h.slices = memos;
        }
        if self.members.len() < o.members.len() {
            std::mem::swap(&mut self.members, &mut o.members);
        }
        self.members.append(&mut o.members);
    }
}

/// The component's 3D hull, built or brought up to date with the members absorbed since
/// ([`LazyHull`]).
fn flushed_hull<'a>(cx: &CellComplex, c: &'a mut Comp) -> &'a Hull3 {
    let vertices = |ms: &[u32]| -> Vec<[f64; 3]> { ms.iter().flat_map(|&m| cx.cells[m as usize].vertices()).collect() };
    let lazy = c.hull.get_or_insert_with(|| {
        Box::new(LazyHull {
            hull: Hull3::new(&vertices(&c.members)),
            pending: Vec::new(),
            slices: Vec::new(),
        })
    });
    if !lazy.pending.is_empty() {
        let pending = std::mem::take(&mut lazy.pending);
        lazy.hull.insert_points(&vertices(&pending));
    }
    &lazy.hull
}

/// The projected area of a component on `frame` (2D convex hull of its 3D hull).
fn section(cx: &CellComplex, c: &mut Comp, frame: &Frame) -> f64 {
    let hull = flushed_hull(cx, c);
    let a = polygon_area(&hull2(hull.pts.iter().map(|p| frame.project(p)).collect::<Vec<P2>>()));
    if a.is_finite() { a.max(0.0) } else { 0.0 }
}

/// The area of the 2D hull of `cells`' vertices projected on `frame` (the projected
/// section of a set of cells that has no cached hull).
fn projected(cx: &CellComplex, cells: &[u32], frame: &Frame) -> f64 {
    let pts: Vec<P2> = cells
        .iter()
        .flat_map(|&m| cx.cells[m as usize].vertices())
        .map(|p| frame.project(&p))
        .collect();
    let a = polygon_area(&hull2(pts));
    if a.is_finite() { a.max(0.0) } else { 0.0 }
}

/// A memo for cutting `cells` along `frame` that has every member's range already, and
/// the cells' extent along the normal (their vertices' lowest and highest height): for a
/// set of cells that has no cached hull, whose ranges give the extent (one pass over the
/// members for both).
fn fresh_memo(cx: &CellComplex, cells: &[u32], frame: &Frame) -> (SliceMemo, (f64, f64)) {
    let mut memo = SliceMemo::default();
    let mut extent = (f64::INFINITY, f64::NEG_INFINITY);
    for r in member_ranges(cx, cells, frame) {
        extent = (extent.0.min(r.0), extent.1.max(r.1));
        memo.ranges.push(outward(r));
    }
    (memo, extent)
}

/// The component's extent along `frame`'s normal: the lowest and highest height of its
/// hull's points. The hull ([`Hull3`], exact orientation tests) holds every extreme point
/// of the members' vertices, so this is their extent without visiting every member (a
/// member vertex inside the hull could only exceed it by the heights' rounding, at a tie).
fn extent(hull: &Hull3, frame: &Frame) -> (f64, f64) {
    hull.pts.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
        let h = height(frame, p);
        (lo.min(h), hi.max(h))
    })
}

/// The largest of `k` cuts of a component by planes parallel to `frame`'s, at heights
/// `(i + 1/2) / k` of its extent along the normal ([`extent`], `i = 0..k`): the summed
/// areas of the members' convex cuts (the members are disjoint, so the sum is the cut's
/// area).
///
/// A member whose vertices all lie on one side of a cut's plane (by the test
/// [`cut_area`] makes for each edge, `height - t < 0`, which is monotone in the height)
/// has no crossing edge and adds exactly 0 there, so it is skipped: each member's height
/// range is taken once, and a cut visits only the members it crosses
/// (`sliced_section_skips_only_members_that_add_nothing` compares with the plain sum).
#[cfg(test)]
fn sliced_section(cx: &CellComplex, c: &mut Comp, frame: &Frame, k: usize) -> f64 {
    sliced_section_reaching(cx, c, frame, k, f64::INFINITY, SLICE_MEMO_MEMBERS)
}

/// [`sliced_section`] for a decision against `target`: the largest cut when it is below
/// `target`, else a value at or above `target` (a cut's sum in the members' order, stopped
/// once it reaches `target`: its terms are areas, never negative, so the full sum is at
/// least as large). `f64::INFINITY` gives the largest cut. Memoized ([`SliceMemo`]) for a
/// component of `memo_from` or more members; a smaller one is cut with a fresh memo that
/// is not kept (the same value either way).
fn sliced_section_reaching(
    cx: &CellComplex,
    c: &mut Comp,
    frame: &Frame,
    k: usize,
    target: f64,
    memo_from: usize,
) -> f64 {
    let (lo, hi) = extent(flushed_hull(cx, c), frame);
    let Comp { members, hull, .. } = c;
    let key = [frame.n, frame.u, frame.v, frame.o].concat();
    let key: [u64; 12] = std::array::from_fn(|i| key[i].to_bits());
    let mut store = hull
        .as_mut()
        .filter(|_| members.len() >= memo_from)
        .map(|h| &mut h.slices);
    let found = store
        .as_mut()
        .and_then(|s| s.iter().position(|m| m.frame == key).map(|i| s.remove(i)));
    let mut memo = found.unwrap_or_else(|| SliceMemo {
        frame: key,
        ..SliceMemo::default()
    });
    let value = memo.extend(cx, members, frame, (lo, hi), k, target);
    if let Some(s) = store {
        s.insert(0, memo);
        s.truncate(SLICE_MEMO_FRAMES);
    }
    value
}

/// Members summed at least per step of [`SliceMemo::extend`] between looks at the target
/// (the step grows with what was summed; the sums do not depend on it).
const SLICE_STEP: usize = 256;

impl SliceMemo {
    /// Brings the cuts' sums at `extent` forward through `members` (taking the members'
    /// ranges as it goes; the sums redone from the first member when the extent or the
    /// number of cuts changed) until one reaches `target` or every member is summed, and
    /// returns the largest. Each cut's area is summed by one task in the members' order,
    /// so the value depends neither on the thread count nor on where a step ends; many
    /// members' cuts run in parallel.
    fn extend(
        &mut self,
        cx: &CellComplex,
        members: &[u32],
        frame: &Frame,
        (lo, hi): (f64, f64),
        k: usize,
        target: f64,
    ) -> f64 {
        if hi.partial_cmp(&lo) != Some(Ordering::Greater) || k == 0 {
            return 0.0;
        }
        let cut_at = (lo.to_bits(), hi.to_bits(), k);
        if self.cut_at != cut_at || self.sums.len() != k {
            self.cut_at = cut_at;
            self.sums = vec![0.0; k];
            self.summed = 0;
        }
        loop {
            let best = self.sums.iter().copied().fold(0.0, f64::max);
            if best >= target || self.summed >= members.len() {
                return best;
            }
            let from = self.summed;
            let end = if target == f64::INFINITY {
                members.len()
            } else {
                (from + SLICE_STEP.max(from / 2)).min(members.len())
            };
            if self.ranges.len() < end {
                let fresh = member_ranges(cx, &members[self.ranges.len()..end], frame);
                self.ranges.extend(fresh.into_iter().map(outward));
            }
            let (todo, ranges) = (&members[from..end], &self.ranges[from..end]);
            let slice = |(i, &start): (usize, &f64)| {
                let t = lo + (hi - lo) * (i as f64 + 0.5) / k as f64;
                let (mut pts, mut hull) = (Vec::new(), Vec::new());
                let mut sum = start;
                for (&m, &(a, b)) in todo.iter().zip(ranges) {
                    if f64::from(b) < t || f64::from(a) >= t {
                        continue;
                    }
                    sum += cut_area_with(&cx.cells[m as usize], frame, t, &mut pts, &mut hull);
                }
                sum
            };
            self.sums = if todo.len() >= PARALLEL_MEMBERS {
                self.sums.par_iter().enumerate().with_max_len(1).map(slice).collect()
            } else {
                self.sums.iter().enumerate().map(slice).collect()
            };
            self.summed = end;
        }
    }
}

/// Each member's (lowest, highest) vertex height, and whether a height is NaN (then it is
/// never skipped). A tetrahedron's vertices are its four corners (its faces, built on the
/// stack, list each three times); many members in parallel, in their order.
fn member_ranges(cx: &CellComplex, members: &[u32], frame: &Frame) -> Vec<(f64, f64, bool)> {
    let range = |&m: &u32| {
        let (mut lo, mut hi, mut nan) = (f64::INFINITY, f64::NEG_INFINITY, false);
        let mut see = |v: &[f64; 3]| {
            let h = height(frame, v);
            lo = lo.min(h);
            hi = hi.max(h);
            nan |= h.is_nan();
        };
        let cell = &cx.cells[m as usize];
        match cell.tet_shape() {
            Some(t) => t.corners.iter().for_each(&mut see),
            None => cell.faces().iter().flat_map(|f| f.verts.iter()).for_each(&mut see),
        }
        (lo, hi, nan)
    };
    if members.len() >= PARALLEL_MEMBERS {
        members.par_iter().with_min_len(256).map(range).collect()
    } else {
        members.iter().map(range).collect()
    }
}

/// A member's height range in `f32`, rounded outwards (-inf, inf when a height is NaN):
/// a member skipped by it is skipped by the exact range.
fn outward((lo, hi, nan): (f64, f64, bool)) -> (f32, f32) {
    if nan {
        return (f32::NEG_INFINITY, f32::INFINITY);
    }
    let (mut a, mut b) = (lo as f32, hi as f32);
    if f64::from(a) > lo {
        a = a.next_down();
    }
    if f64::from(b) < hi {
        b = b.next_up();
    }
    (a, b)
}

/// Components with at least this many cells have their gate's geometry (parallel cuts,
/// refined passages) computed on several threads; smaller ones on one (the values are the
/// same either way).
const PARALLEL_MEMBERS: usize = 2048;

/// Signed height of `p` above `frame`'s plane.
fn height(frame: &Frame, p: &[f64; 3]) -> f64 {
    let d = [p[0] - frame.o[0], p[1] - frame.o[1], p[2] - frame.o[2]];
    d[0] * frame.n[0] + d[1] * frame.n[1] + d[2] * frame.n[2]
}

/// The area of the cut of a convex polyhedron by the plane at height `t` above `frame`'s
/// (0 when the plane misses it): the 2D hull of its edges' crossings.
#[cfg(test)]
fn cut_area(cell: &Cell, frame: &Frame, t: f64) -> f64 {
    cut_area_with(cell, frame, t, &mut Vec::new(), &mut Vec::new())
}

/// [`cut_area`] with scratch buffers for the crossings and their hull (same value).
fn cut_area_with(cell: &Cell, frame: &Frame, t: f64, pts: &mut Vec<P2>, hull: &mut Vec<P2>) -> f64 {
    pts.clear();
    hull.clear();
    for f in cell.faces().iter() {
        let n = f.verts.len();
        for j in 0..n {
            let (p, q) = (f.verts[j], f.verts[(j + 1) % n]);
            let (hp, hq) = (height(frame, &p) - t, height(frame, &q) - t);
            if (hp < 0.0) != (hq < 0.0) {
                let s = hp / (hp - hq);
                pts.push(frame.project(&lerp(&p, &q, s)));
            }
        }
    }
    if pts.len() < 3 {
        return 0.0;
    }
    hull2_into(pts, hull);
    let a = polygon_area(hull);
    if a.is_finite() { a.max(0.0) } else { 0.0 }
}

/// The merge. With `labels` (a group per cell, and the first pass's next weight), a pair
/// of components of different groups is never collapsed while the run is *constrained*:
/// until it stops (a `threshold` stop: at the first pair of one group at or above it, or
/// with the first pass's next weight when only pairs across groups are left) or, in a run
/// to the end, until the cut is recorded (then every pair is weighed again).
#[allow(clippy::too_many_arguments)]
fn run_inner(
    cx: &CellComplex,
    field: &CellField,
    refined_cache: &RefinedCache,
    settings: &Settings,
    gate: Option<ApertureGate>,
    trace: Option<&mut Vec<TraceStep>>,
    cut: Option<(f64, &mut Option<super::Cut>)>,
    labels: Option<(&[u32], f64)>,
    progress: &mut dyn FnMut(usize, usize),
) -> Decimation {
    let scope = Scope {
        ids: AllCells,
        portals: None,
        cell_portals: None,
        cap: usize::MAX,
    };
    let m = merge(
        cx,
        field,
        refined_cache,
        settings,
        gate,
        trace,
        cut,
        labels,
        scope,
        None,
        progress,
    );
    finish(cx, settings, gate, m, progress)
}

/// The clean-up on a merge's state where it stopped, then the record replayed.
fn finish(
    cx: &CellComplex,
    settings: &Settings,
    gate: Option<ApertureGate>,
    m: Merged,
    progress: &mut dyn FnMut(usize, usize),
) -> Decimation {
    let Merged {
        mut comps,
        mut store,
        mut steps,
        stop,
        mut stats,
        mut cells,
        constrained,
        t1,
    } = m;
    if let Some(g) = gate {
        clean_up(
            cx,
            &mut comps,
            &mut store,
            &g,
            constrained,
            &mut steps,
            &mut cells,
            progress,
        );
    }
    stats.steps = steps.len();
    stats.collapse_seconds = t1.elapsed().as_secs_f64();
    // The merge's state is freed before the replay allocates the partition.
    drop((comps, store));
    let partition = Decimation::replay(cx, &steps).expect("the merge records live pairs, lower id first");
    Decimation {
        settings: *settings,
        steps,
        stop,
        stats,
        partition,
    }
}

/// The cell ids a merge works on: every cell of the complex ([`AllCells`]), or one group's
/// cells under local ids ([`GroupCells`]). Local ids follow the complex's in order, so
/// every comparison of ids (the survivor, the queue's ties, the side a link is seen from)
/// is the same under both.
trait Ids: Copy + Sync {
    /// How many cells (local ids `0..len`).
    fn count(self, cx: &CellComplex) -> usize;
    /// The complex cell of local id `l`.
    fn global(self, l: u32) -> u32;
    /// The local id of complex cell `g`, if it is in scope.
    fn local(self, g: u32) -> Option<u32>;
}

#[derive(Clone, Copy)]
struct AllCells;

impl Ids for AllCells {
    fn count(self, cx: &CellComplex) -> usize {
        cx.cells.len()
    }
    fn global(self, l: u32) -> u32 {
        l
    }
    fn local(self, g: u32) -> Option<u32> {
        Some(g)
    }
}

/// One group's cells (increasing), with every cell's group and local id.
#[derive(Clone, Copy)]
struct GroupCells<'a> {
    group: u32,
    cells: &'a [u32],
    group_of: &'a [u32],
    local_of: &'a [u32],
}

impl Ids for GroupCells<'_> {
    fn count(self, _: &CellComplex) -> usize {
        self.cells.len()
    }
    fn global(self, l: u32) -> u32 {
        self.cells[l as usize]
    }
    fn local(self, g: u32) -> Option<u32> {
        (self.group_of[g as usize] == self.group).then(|| self.local_of[g as usize])
    }
}

/// Where a merge works: its cells, the portals between them (`None`: every portal of the
/// complex), and the complex portals of each cell when the caller has built them.
#[derive(Clone, Copy)]
struct Scope<'a, I: Ids> {
    ids: I,
    portals: Option<&'a [u32]>,
    cell_portals: Option<&'a CellPortals>,
    /// Stop once this many pops are recorded in `events` (a group merged again up to where
    /// another group's stop cut it: [`run_grouped`]).
    cap: usize,
}

/// A merge's state where it stopped (for the clean-up), its record and its counters.
struct Merged {
    comps: Vec<Comp>,
    store: LinkStore,
    steps: Vec<Step>,
    stop: StopReason,
    stats: DecimationStats,
    cells: usize,
    constrained: bool,
    /// When the collapses began.
    t1: Instant,
}

/// A pop of a group's merge that orders it among the other groups' ([`run_grouped`]): one
/// after which the group's queue changed (a refined saddle pushed again, a collapse), or
/// the one that stopped it; under the complex's ids.
#[derive(Clone, Copy, Debug)]
struct Event {
    key: Key,
    kind: EventKind,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum EventKind {
    Refine,
    Collapse,
    Stop,
}

/// The link of portal `k` alone, seen from its first cell towards its second.
fn portal_link(cx: &CellComplex, field: &CellField, k: usize) -> Link {
    let p = &cx.portals[k];
    let mut l = Link {
        saddle: field.passage[k],
        area: p.area,
        ..Link::EMPTY
    };
    for (i, q) in p.pieces.iter().enumerate() {
        // `area()` and `normal()` of the one area vector (the same bits as each).
        let av = q.area_vector();
        let (qa, qn) = (norm(&av), normalize(&av));
        l.av = [l.av[0] + qa * qn[0], l.av[1] + qa * qn[1], l.av[2] + qa * qn[2]];
        if qa > l.largest_area {
            l = l.with_largest(k as u32, i as u32);
            l.largest_area = qa;
        }
    }
    l
}

/// Links `a` and `b` with `l` (seen from `a`), fused after their link if they have one.
fn add_link(comps: &mut [Comp], store: &mut LinkStore, a: u32, b: u32, l: &Link) {
    match comps[a as usize].links.slot(b) {
        Some(s) => {
            let fused = store.get(s, a, b).fuse(l);
            store.set(s, a, b, fused);
        }
        None => {
            let s = store.add(a, b, Link::EMPTY.fuse(l));
            comps[a as usize].links.insert(b, s);
            comps[b as usize].links.insert(a, s);
        }
    }
}

/// The merge of [`run_inner`] on `scope`'s cells, up to where it stops (before the
/// clean-up). With `events`, the pops that order it among other groups' are recorded.
#[allow(clippy::too_many_arguments)]
fn merge<I: Ids>(
    cx: &CellComplex,
    field: &CellField,
    refined_cache: &RefinedCache,
    settings: &Settings,
    gate: Option<ApertureGate>,
    mut trace: Option<&mut Vec<TraceStep>>,
    mut cut: Option<(f64, &mut Option<super::Cut>)>,
    labels: Option<(&[u32], f64)>,
    scope: Scope<'_, I>,
    mut events: Option<&mut Vec<Event>>,
    progress: &mut dyn FnMut(usize, usize),
) -> Merged {
    let t0 = Instant::now();
    let h = settings.heuristic.heuristic();
    let sections = gate.is_some() || trace.is_some();
    let ids = scope.ids;
    let n = ids.count(cx);
    let mut comps: Vec<Comp> = vec![Comp::default(); n];
    let mut stats = DecimationStats::default();
    // Each active cell's component on every core (a split cell's volume is a polyhedron's
    // moment), each by one thread; the count of active cells.
    let mut cells: usize = comps
        .par_iter_mut()
        .with_min_len(1024)
        .enumerate()
        .map(|(l, k)| {
            let id = ids.global(l as u32);
            if !cx.cells[id as usize].active() {
                return 0;
            }
            k.peak = field.value[id as usize];
            k.volume = cx.cell_volume(CellId(id));
            k.pieces = 1;
            k.label = labels.map_or(0, |(lb, _)| lb[id as usize]);
            if sections {
                k.members = Members::One(id);
            }
            1
        })
        .sum();
    // The scope's portals between two live cells, as local ids.
    let all_portals = if scope.portals.is_none() { cx.portals.len() } else { 0 };
    let live = |comps: &[Comp], k: usize| -> Option<(u32, u32)> {
        let [a, b] = cx.portals[k].cells;
        let (a, b) = (ids.local(a.0)?, ids.local(b.0)?);
        (comps[a as usize].alive() && comps[b as usize].alive() && a != b).then_some((a, b))
    };
    // The scope's `i`-th portal (its list, or every portal of the complex).
    let portal_at = |i: usize| scope.portals.map_or(i, |list| list[i] as usize);
    let scope_portals = scope.portals.map_or(all_portals, <[u32]>::len);
    // Each scope portal's two live cells (`NONE` when not live), on every core: both loops
    // below read them in order (a portal is a large record; this is 8 bytes).
    const NONE: (u32, u32) = (u32::MAX, u32::MAX);
    let ends: Vec<(u32, u32)> = (0..scope_portals)
        .into_par_iter()
        .with_min_len(4096)
        .map(|i| live(&comps, portal_at(i)).unwrap_or(NONE))
        .collect();
    // Each component's links sized at once (its portals bound its neighbours), instead of
    // grown by insertions: the same links, without the reallocations.
    let mut degree = vec![0u32; n];
    for &(a, b) in ends.iter().filter(|&&e| e != NONE) {
        degree[a as usize] += 1;
        degree[b as usize] += 1;
    }
    for (k, &d) in comps.iter_mut().zip(&degree) {
        if d > 0 {
            k.links.0.reserve_exact(d as usize);
        }
    }
    let mut store = LinkStore::with_capacity(degree.iter().map(|&d| d as usize).sum::<usize>() / 2);
    drop(degree);
    // The links in the portals' order; each chunk's links made on every core first (a
    // chunk at a time: a few MB, not a link per portal held at once).
    const CHUNK: usize = 1 << 16;
    for (c, chunk) in ends.chunks(CHUNK).enumerate() {
        let links: Vec<Link> = chunk
            .par_iter()
            .with_min_len(1024)
            .enumerate()
            .map(|(j, &e)| {
                if e == NONE {
                    Link::EMPTY
                } else {
                    portal_link(cx, field, portal_at(c * CHUNK + j))
                }
            })
            .collect();
        for (&(a, b), l) in chunk.iter().zip(&links) {
            if (a, b) != NONE {
                add_link(&mut comps, &mut store, a, b, l);
            }
        }
    }
    drop(ends);
    // The complex portals of each cell and the component of each cell (union-find), for
    // the gate's refined saddles.
    // (Those are listed beside the first weighing, below.)
    let own_needed = gate.is_some() && scope.cell_portals.is_none();
    let mut owner: Vec<u32> = Vec::new();
    if gate.is_some() {
        owner = (0..n as u32).collect();
    }
    // The keys' layout: from the complex's cell count, so a group's keys and the whole
    // complex's compare alike.
    let lay = KeyLayout::of(cx.cells.len(), field.range);
    // A popped entry's key under the complex's ids (for `events`).
    let global_key = |e: Entry| {
        Key::of(
            Entry {
                a: ids.global(e.a),
                b: ids.global(e.b),
                ..e
            },
            lay,
        )
    };
    stats.initial_cells = cells;
    stats.initial_pairs = comps.iter().map(|c| c.links.len()).sum::<usize>() / 2;
    let weigh = |x: &Comp, y: &Comp, l: &Link| {
        sanitize(h.weight(&PairContext {
            portal_area: l.area,
            projected: [0.0, 0.0],
            volumes: [x.volume, y.volume],
            pieces: [x.pieces as usize, y.pieces as usize],
            peaks: [x.peak, y.peak],
            saddle: l.saddle,
        }))
    };
    // Pushes pair `a < b` (a link of both) with weight `w`, unless its entry of the same
    // key is still in the heap. Proof that skipping such a push leaves every decision
    // unchanged: it would only add a second copy of an entry already there, and copies of
    // one key pop consecutively (a key is unique to its pair). The first copy popped is
    // either stale (then so is the second), or collapses the pair (the second is stale:
    // `b` is dead), or refines its saddle (a new saddle makes the second stale; the same
    // saddle gives the same key, pushed again), or keeps it apart or skips it across
    // groups, which changes no state the second copy could see (the gate's hull is cached
    // by the first), so the second is kept or skipped again. The only other push between
    // them is the cut's `push_all`, which pushes the popped pair again (its `queued` was
    // cleared at the pop). The counters count weighings, which still happen. With a trace
    // every push happens (the trace records each copy's visit).
    let dedup = trace.is_none();
    // Marks pair `a < b` queued with key (`w`, `saddle`) and gives the entry to push, or
    // `None` when the same key is still queued (see above).
    let mark = |store: &mut LinkStore, slot: u32, a: u32, b: u32, w: f64, saddle: f64, top: f64| -> Option<Entry> {
        let la = store.at(slot);
        if dedup && la.queued.to_bits() == w.to_bits() {
            return None;
        }
        la.queued = w;
        Some(Entry {
            weight: w,
            saddle,
            top: lay.key_top(w, top),
            a,
            b,
        })
    };
    // `force`: push even when an entry of the same weight is queued (its top is stale: a
    // side's peak rose; the stale entry is skipped at its pop).
    let requeue = |store: &mut LinkStore,
                   heap: &mut RunHeap<Key>,
                   (slot, a, b): (u32, u32, u32),
                   (w, saddle, top): (f64, f64, f64),
                   force: bool| {
        if force {
            store.at(slot).queued = f64::NAN;
        }
        if let Some(e) = mark(store, slot, a, b, w, saddle, top) {
            heap.push(Key::of(e, lay));
        }
    };
    // Every live pair: at the start, and again after a constrained stretch (whose pairs
    // across groups were dropped from the heap). Only live components have links. The
    // entries are added at once, sorted into the queue's run ([`RunHeap`]): its layout
    // differs from pushing one by one, its pops do not (a pop returns the greatest entry,
    // and equal entries are the same bits).
    let push_all = |comps: &[Comp], store: &mut LinkStore, heap: &mut RunHeap<Key>, stats: &mut DecimationStats| {
        let mut bulk = Vec::with_capacity(stats.initial_pairs);
        for a in 0..comps.len() {
            if !comps[a].alive() {
                continue;
            }
            for &(b, slot) in &comps[a].links.0 {
                if (a as u32) < b {
                    let l = store.links[slot as usize];
                    stats.weights_computed += 1;
                    let w = weigh(&comps[a], &comps[b as usize], &l);
                    if let Some(e) = mark(
                        store,
                        slot,
                        a as u32,
                        b,
                        w,
                        l.saddle,
                        comps[a].peak.max(comps[b as usize].peak),
                    ) {
                        bulk.push(Key::of(e, lay));
                    }
                }
            }
        }
        heap.extend_bulk(bulk);
    };
    let mut heap = RunHeap::with_capacity(stats.initial_pairs);
    // The regions (a serial flood over the links) and the cells' portals beside the first
    // weighing, which reads the same components.
    let ((r, own_portals), ()) = rayon::join(
        || {
            let own = if own_needed {
                CellPortals::new(cx, |k| live(&comps, k).is_some())
            } else {
                CellPortals {
                    start: vec![0],
                    portals: Vec::new(),
                }
            };
            (regions(&comps), own)
        },
        || push_all(&comps, &mut store, &mut heap, &mut stats),
    );
    stats.regions = r;
    let cell_portals = scope.cell_portals.unwrap_or(&own_portals);
    stats.init_seconds = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    // At most one collapse per cell but the last (exact capacity: a grown vector holds up
    // to twice its length; pages of the reserve never used are never touched).
    let mut steps = Vec::with_capacity(cells.saturating_sub(1));
    // The stopped run's clean-up, on a copy of the state where it stops.
    let cut_here = |comps: &[Comp],
                    store: &LinkStore,
                    cells: usize,
                    steps: usize,
                    w: f64,
                    stats: &DecimationStats,
                    constrained: bool| {
        let mut cleanup = Vec::new();
        if let Some(g) = gate {
            let (mut copy, mut links, mut left) = (comps.to_vec(), store.clone(), cells);
            clean_up(
                cx,
                &mut copy,
                &mut links,
                &g,
                constrained,
                &mut cleanup,
                &mut left,
                &mut |_, _| {},
            );
        }
        super::Cut {
            steps,
            next_weight: w,
            weights_computed: stats.weights_computed,
            reweighs_skipped: stats.reweighs_skipped,
            collapse_seconds: t1.elapsed().as_secs_f64(),
            cleanup,
        }
    };
    let mut constrained = labels.is_some();
    let stop = loop {
        #[cfg(test)]
        queue_audit::check(&comps, &store, &heap, lay);
        if events.as_ref().is_some_and(|ev| ev.len() >= scope.cap) {
            break StopReason::Exhausted;
        }
        if let StopRule::Cells(target) = settings.stop
            && cells <= target
        {
            break StopReason::Cells { target };
        }
        let Some(e) = heap.pop().map(|k| k.entry(lay)) else {
            if !constrained {
                break StopReason::Exhausted;
            }
            // Only pairs across groups are left: where the first pass stopped.
            let next = labels.map_or(f64::NAN, |(_, w)| w);
            if let StopRule::Threshold(r) = settings.stop {
                break StopReason::Threshold {
                    threshold: r,
                    next_weight: next,
                };
            }
            if let Some((_, c)) = cut.as_mut()
                && c.is_none()
            {
                **c = Some(cut_here(&comps, &store, cells, steps.len(), next, &stats, true));
            }
            constrained = false;
            push_all(&comps, &mut store, &mut heap, &mut stats);
            continue;
        };
        let (a, b) = (e.a as usize, e.b as usize);
        // Stale entries: a side merged away, or the weight or saddle changed since.
        if !(comps[a].alive() && comps[b].alive()) {
            continue;
        }
        let Some(slot) = comps[a].links.slot(e.b) else {
            continue;
        };
        let l = store.links[slot as usize];
        if l.saddle.to_bits() != e.saddle.to_bits()
            || weigh(&comps[a], &comps[b], &l).to_bits() != e.weight.to_bits()
            || lay.key_top(e.weight, comps[a].peak.max(comps[b].peak)) != e.top
        {
            continue;
        }
        // This pair's entry has left the heap.
        store.at(slot).queued = f64::NAN;
        if constrained && comps[a].label != comps[b].label {
            // Across groups: weighed again when a side changes, or after the constraint.
            continue;
        }
        let w = e.weight;
        // The pair that would stop a threshold run (or mark a run to the end's cut): its pass
        // is refined first, as a gated pair's is, so that the stop judges the best lower
        // bound of the pass rather than one that depends on how the tetrahedra sample it.
        let stop_r = match (settings.stop, cut.as_ref()) {
            (StopRule::Threshold(r), _) => Some(r),
            (_, Some((r, c))) if c.is_none() => Some(*r),
            _ => None,
        };
        let pre_refine = gate.is_some() && !l.refined() && stop_r.is_some_and(|r| w >= r);
        if let StopRule::Threshold(r) = settings.stop
            && w >= r
            && !pre_refine
        {
            if let Some(ev) = events.as_deref_mut() {
                ev.push(Event {
                    key: global_key(e),
                    kind: EventKind::Stop,
                });
            }
            break StopReason::Threshold {
                threshold: r,
                next_weight: w,
            };
        }
        // Where a `threshold:r` run would have stopped (the run goes on to the end).
        if let Some((r, c)) = cut.as_mut()
            && c.is_none()
            && w >= *r
            && !pre_refine
        {
            **c = Some(cut_here(&comps, &store, cells, steps.len(), w, &stats, constrained));
            if constrained {
                constrained = false;
                push_all(&comps, &mut store, &mut heap, &mut stats);
            }
        }
        let gated = gate.filter(|g| {
            w >= g.from && g.holds_ball(comps[a].peak, comps[a].volume) && g.holds_ball(comps[b].peak, comps[b].volume)
        });
        if (gated.is_some() || pre_refine) && !l.refined() {
            // Before the gate decides, the best lower bound of the pass we can afford:
            // refined passages of every portal between the two components.
            let (small, other) = smaller_first(&comps, a, b);
            // The portals between them, in the members' order; their refined passages are
            // independent (in parallel for a large component) and taken by `max`, whose
            // value does not depend on the order.
            let between = portals_between(cx, cell_portals, ids, &mut owner, &comps[small].members, other);
            // A portal's refined passage is a function of the field and the portal only, so
            // it is computed once per decimation ([`RefinedCache`]; not with a trace, whose
            // engine is the reference the cache is tested against).
            let cache = refined_cache;
            let refine = |&k: &u32| {
                let known = cache.get(k as usize);
                if dedup && !known.is_nan() {
                    known
                } else {
                    field.refined_passage(cx, k as usize)
                }
            };
            // A refined passage is never above its portal's bound ([`refined_bound`]), so
            // a portal whose bound is at or below the highest pass found so far cannot
            // raise it and is not refined: portals in decreasing order of bound, refined
            // (in parallel chunks for a large set) until the pass reaches the next bound.
            // The maximum, whatever the order, has the bits of refining them all.
            let mut order: Vec<(f64, u32)> = between.iter().map(|&k| (refined_bound(field, cx, k), k)).collect();
            order.sort_unstable_by(|x, y| y.0.total_cmp(&x.0).then(x.1.cmp(&y.1)));
            // One at a time, or a few per thread for a large set (the pass is checked
            // against the bounds between chunks only; the chunk size does not change it).
            let parallel = between.len() >= PARALLEL_MEMBERS / 64;
            let chunk = if parallel { 4 * rayon::current_num_threads() } else { 1 };
            let mut s2 = l.saddle;
            let mut at = 0;
            while at < order.len() && order[at].0 > s2 {
                let end = order[at..]
                    .iter()
                    .take(chunk)
                    .position(|&(b, _)| s2 >= b)
                    .map_or((at + chunk).min(order.len()), |p| at + p);
                let ks: Vec<u32> = order[at..end].iter().map(|&(_, k)| k).collect();
                let refined: Vec<f64> = if parallel && ks.len() > 1 {
                    ks.par_iter().map(refine).collect()
                } else {
                    ks.iter().map(refine).collect()
                };
                for ((&k, &v), &(b, _)) in ks.iter().zip(&refined).zip(&order[at..end]) {
                    debug_assert!(v <= b || v.is_nan(), "refined passage {v} above its bound {b}");
                    if dedup && !refined_cache.get(k as usize).is_nan() {
                        refined_cache.hits.fetch_add(1, AtomicOrdering::Relaxed);
                    }
                    refined_cache.set(k as usize, v);
                    s2 = s2.max(v);
                }
                at = end;
            }
            let mut l2 = l;
            l2.saddle = s2;
            l2.bits |= REFINED;
            l2.queued = f64::NAN;
            *store.at(slot) = l2;
            stats.weights_computed += 1;
            let w2 = weigh(&comps[a], &comps[b], &l2);
            requeue(
                &mut store,
                &mut heap,
                (slot, e.a, e.b),
                (w2, l2.saddle, comps[a].peak.max(comps[b].peak)),
                false,
            );
            if let Some(ev) = events.as_deref_mut() {
                ev.push(Event {
                    key: global_key(e),
                    kind: EventKind::Refine,
                });
            }
            continue;
        }
        if gated.is_some() || trace.is_some() {
            let frame = l.frame(cx);
            let mut pa = section(cx, &mut comps[a], &frame);
            let mut pb = section(cx, &mut comps[b], &frame);
            // The opening the sections are compared with.
            let opening = |g: &ApertureGate| if g.vector_opening { l.opening() } else { l.area };
            let mut kept = gated.is_some_and(|g| pa.min(pb) >= g.ratio * opening(&g));
            // Cuts parallel to the portal, the smaller projection first; summed only until
            // they decide, unless the trace records their values.
            let traced = trace.is_some();
            let cut = |comps: &mut [Comp], frame: &Frame, (pa, pb): (f64, f64), decide: f64, g: &ApertureGate| {
                let (first, second) = if pa <= pb { (a, b) } else { (b, a) };
                let target = if traced { f64::INFINITY } else { decide };
                let s1 = sliced_section_reaching(cx, &mut comps[first], frame, g.slices, target, SLICE_MEMO_MEMBERS);
                let s2 = if s1 >= decide {
                    sliced_section_reaching(cx, &mut comps[second], frame, g.slices, target, SLICE_MEMO_MEMBERS)
                } else {
                    f64::INFINITY
                };
                if first == a { (s1, s2) } else { (s2, s1) }
            };
            if let Some(g) = gated.filter(|g| kept && g.slices > 0) {
                (pa, pb) = cut(&mut comps, &frame, (pa, pb), g.ratio * opening(&g), &g);
                kept = pa.min(pb) >= g.ratio * opening(&g);
            }
            if let Some(g) = gated.filter(|g| kept && g.vector_opening && g.shadow_opening) {
                // The vector area may cancel on an interface that wraps around one side:
                // judged again against the pieces' shadow on the portal plane (at least
                // the vector area, so this only ever joins).
                let (small, other) = smaller_first(&comps, a, b);
                let between = portals_between(cx, cell_portals, ids, &mut owner, &comps[small].members, other);
                let target = g.ratio * shadow(cx, &between, &frame);
                if g.slices > 0 && !traced && pa.min(pb) < target {
                    // The cuts were summed only as far as the opening needed: carried on
                    // (from where they stopped) as far as the shadow needs.
                    (pa, pb) = cut(&mut comps, &frame, (pa, pb), target, &g);
                }
                kept = pa.min(pb) >= target;
            }
            // A component whose peak is below `dominance` times its neighbour's is absorbed
            // by the clean-up whatever the merge keeps apart: not judged again.
            let comparable =
                |g: &ApertureGate| comps[a].peak.min(comps[b].peak) >= g.dominance * comps[a].peak.max(comps[b].peak);
            if let Some(g) = gated.filter(|g| !kept && g.core_cut && comparable(g)) {
                // The interface of two components that are still growing may lie away from
                // the opening between them (one grew through a door into the corridor
                // beyond): judged again on the least-area cut between their cores.
                let q = CoreQuestion {
                    cx,
                    field,
                    cell_portals,
                    comps: &comps,
                    pair: (a, b),
                    saddle: l.saddle,
                    open: opening(&g),
                    gate: &g,
                };
                kept = core_judgement_cached(
                    &q,
                    // Stored while below the threshold: the part of a run to the end
                    // that the constrained pass repeats.
                    dedup.then_some((&refined_cache.core_cuts, stop_r.is_some_and(|r| w < r))),
                );
            }
            if let Some(t) = trace.as_deref_mut() {
                t.push(TraceStep {
                    a: CellId(ids.global(e.a)),
                    b: CellId(ids.global(e.b)),
                    weight: w,
                    peaks: [comps[a].peak, comps[b].peak],
                    saddle: l.saddle,
                    portal_area: l.area,
                    opening: l.opening(),
                    projected: [pa, pb],
                    volumes: [comps[a].volume, comps[b].volume],
                    kept,
                });
            }
            if kept {
                // Kept apart until one side changes (then the pair is weighed again).
                continue;
            }
        }
        // Collapse b into a (a < b: the survivor keeps the lower id).
        let (pa, pb) = (comps[a].peak, comps[b].peak);
        let mut cb = std::mem::take(&mut comps[b]);
        let mut ca = std::mem::take(&mut comps[a]);
        merge_links(&mut comps, &mut store, &mut ca, &cb, e.a, e.b);
        cells -= 1;
        // Pairs whose weight may change: every neighbour of the side with the lower peak
        // (its partner's peak rises to the higher one), and every neighbour of b (saddle,
        // volume); with the volumes and piece counts in the context, or a gate (whose
        // sections grew), all of them. Either set is a list of keys in increasing order,
        // weighed below, once `ca` is back in place.
        // The survivor's peak rose: its pairs with a new top (the tie-break) are pushed
        // anew whatever is queued (the old entries are stale at their pop).
        let rose = pa < pb;
        let all = rose || h.uses_volume() || gate.is_some();
        ca.peak = pa.max(pb);
        ca.volume += cb.volume;
        ca.pieces += cb.pieces;
        if gate.is_some() {
            owner[b] = a as u32;
        }
        if sections {
            ca.absorb_members(&mut cb);
        }
        if let Some(ev) = events.as_deref_mut() {
            ev.push(Event {
                key: global_key(e),
                kind: EventKind::Collapse,
            });
        }
        steps.push(Step {
            a: CellId(ids.global(e.a)),
            b: CellId(ids.global(e.b)),
            weight: w,
            cells_remaining: cells,
            portal_area: l.area,
            projected: [0.0, 0.0],
        });
        progress(steps.len(), cells);
        comps[a] = ca;
        if all {
            // Every link of the survivor, in its order (no sorted key list).
            // (The neighbours' components and the links `AHEAD` ahead, as hints: random
            // ids.)
            let hint = |comps: &[Comp], store: &LinkStore, i: usize| {
                if let Some(&(k, slot)) = comps[a].links.0.get(i) {
                    prefetch_all(&comps[k as usize]);
                    prefetch_all(&store.links[slot as usize]);
                }
            };
            for i in 0..AHEAD {
                hint(&comps, &store, i);
            }
            for i in 0..comps[a].links.len() {
                hint(&comps, &store, i + AHEAD);
                let (k, slot) = comps[a].links.0[i];
                let lk = store.links[slot as usize];
                let (x, y) = if (a as u32) < k { (a as u32, k) } else { (k, a as u32) };
                stats.weights_computed += 1;
                let w = weigh(&comps[x as usize], &comps[y as usize], &lk);
                let top = comps[x as usize].peak.max(comps[y as usize].peak);
                // A new top unless the neighbour's peak is at least the old one's.
                let pk = comps[k as usize].peak;
                let force = rose && w == 1.0 && lay.top(pa.max(pk)) != lay.top(pb.max(pk));
                requeue(&mut store, &mut heap, (slot, x, y), (w, lk.saddle, top), force);
            }
        } else {
            for &k in cb.links.keys().filter(|&&k| k as usize != a) {
                let slot = comps[a].links.slot(k).expect("a linked neighbour");
                let lk = store.links[slot as usize];
                let (x, y) = if (a as u32) < k { (a as u32, k) } else { (k, a as u32) };
                stats.weights_computed += 1;
                let w = weigh(&comps[x as usize], &comps[y as usize], &lk);
                let top = comps[x as usize].peak.max(comps[y as usize].peak);
                requeue(&mut store, &mut heap, (slot, x, y), (w, lk.saddle, top), false);
            }
        }
    };
    drop((heap, own_portals, owner));
    Merged {
        comps,
        store,
        steps,
        stop,
        stats,
        cells,
        constrained,
        t1,
    }
}

/// The constrained pass of a threshold run ([`run_inner`] with `labels`), one group per
/// task (rayon), with the serial pass's result (`None` without a threshold stop or with a
/// label out of range: the caller then runs the serial pass).
///
/// While the pass is constrained, a pair across groups is popped only to be skipped: no
/// collapse or refined saddle crosses a group's boundary, and no weight of a pair in one
/// group reads another group's state. So each group's merge is a function of its own cells
/// and links: it runs on its own (local ids, its own queue, [`GroupCells`]), recording the
/// pops after which its queue changed (a refined saddle pushed again, a collapse) and the
/// pop that stopped it ([`Event`]). The serial pass's one queue pops the greatest entry of
/// all groups, which is the greatest of the group whose own greatest is greatest; so its
/// pops are the groups' sequences merged by taking, each time, the group whose next pop
/// has the greatest key (keys name their pair, so no two groups tie). The pops that are not
/// recorded (stale entries, pairs across groups, pairs kept apart) push nothing, so the
/// group's next recorded pop has a key no greater than theirs and dropping them changes no
/// choice of the merge. The collapses, in that order, give the record (`cells_remaining`
/// counts all groups) and are replayed on the links across groups, which the counters
/// (every link of a survivor is weighed again) and the clean-up's state need; then the
/// clean-up runs on the assembled state as in the serial pass. When a group stops (a pair at
/// or above the threshold) before other groups' last recorded pops, the serial pass stops
/// every group there: those groups are merged again, each up to its pops taken so far.
#[allow(clippy::too_many_arguments)]
fn run_grouped(
    cx: &CellComplex,
    field: &CellField,
    refined_cache: &RefinedCache,
    settings: &Settings,
    gate: ApertureGate,
    labels: (&[u32], f64),
    regions: usize,
    progress: &mut dyn FnMut(usize, usize),
) -> Option<Decimation> {
    let t0 = Instant::now();
    let StopRule::Threshold(r) = settings.stop else {
        return None;
    };
    let (label, next) = labels;
    let n = cx.cells.len();
    // Whether each cell is active, read once on every core: the passes below scan every
    // cell and every portal's two cells, and a `Cell` is large (each scan streamed all of
    // them: 15% of this function's samples at 1M).
    let act: Vec<bool> = cx.cells.par_iter().with_min_len(4096).map(|c| c.active()).collect();
    let active = |c: usize| act[c];
    if (0..n).any(|c| active(c) && label[c] as usize >= n) {
        return None;
    }
    // The groups' cells, in increasing order (a counting sort by label).
    let groups = (0..n)
        .filter(|&c| active(c))
        .map(|c| label[c] as usize + 1)
        .max()
        .unwrap_or(0);
    let mut start = vec![0u32; groups + 1];
    for c in (0..n).filter(|&c| active(c)) {
        start[label[c] as usize + 1] += 1;
    }
    for g in 0..groups {
        start[g + 1] += start[g];
    }
    let mut fill = start.clone();
    let mut members = vec![0u32; start[groups] as usize];
    let (mut group_of, mut local_of) = (vec![u32::MAX; n], vec![u32::MAX; n]);
    for c in (0..n).filter(|&c| active(c)) {
        let g = label[c] as usize;
        members[fill[g] as usize] = c as u32;
        local_of[c] = fill[g] - start[g];
        group_of[c] = g as u32;
        fill[g] += 1;
    }
    // The live portals: within a group (by group, in order) or across groups (in order).
    let live = |k: usize| {
        let [a, b] = cx.portals[k].cells;
        a != b && active(a.idx()) && active(b.idx())
    };
    let mut pstart = vec![0u32; groups + 1];
    let mut across: Vec<u32> = Vec::new();
    for (k, p) in cx.portals.iter().enumerate().filter(|&(k, _)| live(k)) {
        let [a, b] = p.cells.map(|c| group_of[c.idx()]);
        if a == b {
            pstart[a as usize + 1] += 1;
        } else {
            across.push(k as u32);
        }
    }
    for g in 0..groups {
        pstart[g + 1] += pstart[g];
    }
    let mut pfill = pstart.clone();
    let mut within = vec![0u32; pstart[groups] as usize];
    for (k, p) in cx.portals.iter().enumerate().filter(|&(k, _)| live(k)) {
        let [a, b] = p.cells.map(|c| group_of[c.idx()]);
        if a == b {
            within[pfill[a as usize] as usize] = k as u32;
            pfill[a as usize] += 1;
        }
    }
    drop((fill, pfill));
    let cell_portals = CellPortals::new(cx, live);
    let init_seconds = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();

    // Each group's merge, on every core.
    /// A live component where a group stopped: its cell, state and links to higher cells.
    type Survivor = (u32, Comp, Vec<(u32, Link)>);
    struct GroupRun {
        events: Vec<Event>,
        steps: Vec<Step>,
        /// The live components where it stopped.
        survivors: Vec<Survivor>,
        initial_pairs: usize,
        weights: u64,
    }
    // Group `g`'s merge, up to its `cap`-th recorded pop.
    let run_group = |g: usize, cap: usize| {
        let cells = &members[start[g] as usize..start[g + 1] as usize];
        let scope = Scope {
            ids: GroupCells {
                group: g as u32,
                cells,
                group_of: &group_of,
                local_of: &local_of,
            },
            portals: Some(&within[pstart[g] as usize..pstart[g + 1] as usize]),
            cell_portals: Some(&cell_portals),
            cap,
        };
        let mut events = Vec::new();
        let m = merge(
            cx,
            field,
            refined_cache,
            settings,
            Some(gate),
            None,
            None,
            None,
            scope,
            Some(&mut events),
            &mut |_, _| {},
        );
        let store = m.store;
        let survivors = m
            .comps
            .into_iter()
            .enumerate()
            .filter(|(_, c)| c.alive())
            .map(|(l, mut c)| {
                let links = std::mem::take(&mut c.links)
                    .0
                    .into_iter()
                    .filter(|&(k, _)| (l as u32) < k)
                    .map(|(k, slot)| (cells[k as usize], store.get(slot, l as u32, k)))
                    .collect();
                c.label = g as u32;
                (cells[l], c, links)
            })
            .collect();
        GroupRun {
            events,
            steps: m.steps,
            survivors,
            initial_pairs: m.stats.initial_pairs,
            weights: m.stats.weights_computed,
        }
    };
    let mut runs: Vec<GroupRun> = (0..groups).into_par_iter().map(|g| run_group(g, usize::MAX)).collect();

    // The links across groups, as the serial pass builds them (portal order).
    let mut comps: Vec<Comp> = vec![Comp::default(); n];
    let mut store = LinkStore::default();
    for &k in &across {
        let [a, b] = cx.portals[k as usize].cells;
        add_link(&mut comps, &mut store, a.0, b.0, &portal_link(cx, field, k as usize));
    }
    drop(across);
    let cross_pairs = store.links.len();
    // Whether each component has links across groups (a neighbour's links only move from
    // the merged component to the survivor, so only the pair's flags change).
    let mut crossing: Vec<bool> = comps.iter().map(|c| c.links.len() > 0).collect();
    let mut stats = DecimationStats {
        initial_cells: (0..n).filter(|&c| active(c)).count(),
        initial_pairs: cross_pairs + runs.iter().map(|g| g.initial_pairs).sum::<usize>(),
        ..DecimationStats::default()
    };
    // The regions of the portal graph, which the first pass counted on the same cells.
    stats.regions = regions;
    // Every pair is weighed at the start; the groups counted theirs.
    stats.weights_computed = cross_pairs as u64 + runs.iter().map(|g| g.weights).sum::<u64>();

    // The groups' pops merged as the serial queue pops them.
    let mut heads: BinaryHeap<(Key, usize)> = runs
        .iter()
        .enumerate()
        .filter_map(|(g, run)| run.events.first().map(|e| (e.key, g)))
        .collect();
    let (mut at, mut step_at) = (vec![0usize; runs.len()], vec![0usize; runs.len()]);
    let mut cells = stats.initial_cells;
    let mut steps = Vec::with_capacity(runs.iter().map(|g| g.steps.len()).sum());
    let mut stop = StopReason::Threshold {
        threshold: r,
        next_weight: next,
    };
    while let Some((key, g)) = heads.pop() {
        let run = &runs[g];
        let e = run.events[at[g]];
        at[g] += 1;
        match e.kind {
            EventKind::Stop => {
                stop = StopReason::Threshold {
                    threshold: r,
                    next_weight: key.weight(),
                };
                break;
            }
            EventKind::Refine => {}
            EventKind::Collapse => {
                let s = run.steps[step_at[g]];
                step_at[g] += 1;
                let (a, b) = (s.a.0, s.b.0);
                // Most collapses are inside a room, between components without links
                // across groups: merging their (empty) links changes nothing, and the
                // dense flags spare reading the two components (random accesses into a
                // vector of every cell's).
                if crossing[a as usize] || crossing[b as usize] {
                    let cb = std::mem::take(&mut comps[b as usize]);
                    let mut ca = std::mem::take(&mut comps[a as usize]);
                    merge_links(&mut comps, &mut store, &mut ca, &cb, a, b);
                    // The survivor's links across groups are weighed again too.
                    stats.weights_computed += ca.links.len() as u64;
                    crossing[a as usize] = ca.links.len() > 0;
                    crossing[b as usize] = false;
                    comps[a as usize] = ca;
                }
                cells -= 1;
                steps.push(Step {
                    cells_remaining: cells,
                    ..s
                });
                progress(steps.len(), cells);
            }
        }
        if let Some(e) = run.events.get(at[g]) {
            heads.push((e.key, g));
        }
    }
    // A group stopped before other groups' last recorded pops, where the serial pass stops
    // them all: those groups are merged again up to the pops taken (stale, skipped or kept
    // pops after a group's last recorded one change nothing), on every core.
    let cut: Vec<usize> = (0..runs.len()).filter(|&g| at[g] < runs[g].events.len()).collect();
    let again: Vec<(usize, GroupRun)> = cut.par_iter().map(|&g| (g, run_group(g, at[g]))).collect();
    for (g, run) in again {
        stats.weights_computed -= runs[g].weights;
        stats.weights_computed += run.weights;
        runs[g] = run;
    }
    drop((within, cell_portals, group_of, local_of, members));
    // The state where the pass stopped: each survivor's own state and links within its
    // group, beside its links across groups.
    for run in runs {
        for (c, comp, links) in run.survivors {
            let cross = std::mem::take(&mut comps[c as usize].links);
            comps[c as usize] = Comp { links: cross, ..comp };
            for (k, l) in links {
                let s = store.add(c, k, l);
                comps[c as usize].links.insert(k, s);
                comps[k as usize].links.insert(c, s);
            }
        }
    }
    stats.init_seconds = init_seconds;
    let m = Merged {
        comps,
        store,
        steps,
        stop,
        stats,
        cells,
        constrained: true,
        t1,
    };
    Some(finish(cx, settings, Some(gate), m, progress))
}

/// The clean-up pass (see [`ApertureGate::dominance`] and [`ApertureGate::slab`]), a
/// function of the stopped merge's components only (their peaks, portals and members),
/// so a run to the end can apply it to a copy of the state where a stopped run stops
/// (`Cut::cleanup`). While some live component is *absorbable* — its peak is below
/// `dominance` times a neighbour's, or (with `slab`) its peak is below `slab_peak` times a
/// neighbour's and its projected section on the plane of their portals is below `slab`
/// times their area — a slab or pocket lying along that portal, the gate's own test of a
/// room behind an opening failed — the lowest such component (ties: lowest id) is absorbed into the
/// qualifying neighbour across the largest portal area (ties: lowest id); each absorption
/// is recorded as a step (survivor: the lower id) whose weight is the peak ratio.
#[allow(clippy::too_many_arguments)]
fn clean_up(
    cx: &CellComplex,
    comps: &mut [Comp],
    store: &mut LinkStore,
    g: &ApertureGate,
    constrained: bool,
    steps: &mut Vec<Step>,
    cells: &mut usize,
    progress: &mut dyn FnMut(usize, usize),
) {
    if g.dominance <= 0.0 && g.slab <= 0.0 {
        return;
    }
    // Components known not to be absorbable (until they or a neighbour change).
    let mut settled = vec![false; comps.len()];
    // The live components, in id order: found once (an absorption only ever kills one),
    // not by a scan of every cell's slot per absorption (on a 1.88M-cell level with
    // thousands of absorptions that scan was a quarter of the decimation's samples).
    let mut live: Vec<u32> = (0..comps.len() as u32).filter(|&i| comps[i as usize].alive()).collect();
    loop {
        live.retain(|&i| comps[i as usize].alive());
        let mut order: Vec<u32> = live.iter().copied().filter(|&i| !settled[i as usize]).collect();
        order.sort_by(|&x, &y| {
            comps[x as usize]
                .peak
                .total_cmp(&comps[y as usize].peak)
                .then(x.cmp(&y))
        });
        // The lowest absorbable component, its chosen neighbour and the peak ratio.
        let mut pick: Option<(u32, u32, f64)> = None;
        for &i in &order {
            let links: Vec<(u32, Link)> = comps[i as usize]
                .links
                .0
                .iter()
                .map(|&(j, slot)| (j, store.get(slot, i, j)))
                .collect();
            let peak = comps[i as usize].peak;
            let mut best: Option<(f64, u32)> = None;
            for (j, l) in links {
                let o = &comps[j as usize];
                if !o.alive()
                    || o.peak <= 0.0
                    || peak > o.peak
                    || best.is_some_and(|(a, _)| l.area <= a)
                    || (constrained && o.label != comps[i as usize].label)
                {
                    continue;
                }
                let dominated = peak < g.dominance * o.peak;
                let slab = g.slab > 0.0
                    && peak < g.slab_peak * o.peak
                    && section(cx, &mut comps[i as usize], &l.frame(cx)) < g.slab * l.area;
                if dominated || slab {
                    best = Some((l.area, j));
                }
            }
            match best {
                Some((_, j)) => {
                    pick = Some((i, j, peak / comps[j as usize].peak));
                    break;
                }
                None => settled[i as usize] = true,
            }
        }
        let Some((x, y, w)) = pick else {
            return;
        };
        let (a, b) = (x.min(y), x.max(y));
        let l = store.links[comps[a as usize].links.slot(b).expect("a linked neighbour") as usize];
        let mut cb = std::mem::take(&mut comps[b as usize]);
        let mut ca = std::mem::take(&mut comps[a as usize]);
        merge_links(comps, store, &mut ca, &cb, a, b);
        settled[a as usize] = false;
        for &k in ca.links.keys() {
            settled[k as usize] = false;
        }
        ca.peak = ca.peak.max(cb.peak);
        ca.volume += cb.volume;
        ca.pieces += cb.pieces;
        ca.absorb_members(&mut cb);
        comps[a as usize] = ca;
        *cells -= 1;
        steps.push(Step {
            a: CellId(a),
            b: CellId(b),
            weight: w,
            cells_remaining: *cells,
            portal_area: l.area,
            projected: [0.0, 0.0],
        });
        progress(steps.len(), *cells);
    }
}

/// The portals of each cell, in compressed rows (one offset per cell and one flat list,
/// instead of a vector per cell): row `c` lists the portals `k` (increasing) for which
/// `keep(k)` holds and `c` is one of the portal's two cells: the order of pushing the
/// portals, in order, to each of their cells' lists.
struct CellPortals {
    start: Vec<u32>,
    portals: Vec<u32>,
}

impl CellPortals {
    fn new(cx: &CellComplex, keep: impl Fn(usize) -> bool) -> Self {
        let n = cx.cells.len();
        let mut start = vec![0u32; n + 1];
        for (k, p) in cx.portals.iter().enumerate() {
            if keep(k) {
                start[p.cells[0].idx() + 1] += 1;
                start[p.cells[1].idx() + 1] += 1;
            }
        }
        for c in 0..n {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut portals = vec![0u32; start[n] as usize];
        for (k, p) in cx.portals.iter().enumerate() {
            if keep(k) {
                for c in p.cells {
                    portals[fill[c.idx()] as usize] = k as u32;
                    fill[c.idx()] += 1;
                }
            }
        }
        CellPortals { start, portals }
    }

    fn of(&self, c: usize) -> &[u32] {
        &self.portals[self.start[c] as usize..self.start[c + 1] as usize]
    }
}

/// The component of cell `x` (union-find with path halving).
fn find(owner: &mut [u32], mut x: u32) -> u32 {
    while owner[x as usize] != x {
        owner[x as usize] = owner[owner[x as usize] as usize];
        x = owner[x as usize];
    }
    x
}

/// Connected regions of the component graph.
fn regions(comps: &[Comp]) -> usize {
    let mut seen = vec![false; comps.len()];
    let mut count = 0;
    let mut stack = Vec::new();
    for s in 0..comps.len() {
        if !comps[s].alive() || seen[s] {
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

/// Test-only audit of `requeue`'s bookkeeping (switched on per thread by the tests): a
/// link's `queued` weight, when set, names an entry of the heap with that pair, weight and
/// saddle, so skipping a push of that key never loses the pair.
#[cfg(test)]
mod queue_audit {
    use super::{Comp, Key, KeyLayout, LinkStore, RunHeap};
    use std::cell::Cell;

    thread_local! {
        pub static ON: Cell<bool> = const { Cell::new(false) };
        static POPS: Cell<u64> = const { Cell::new(0) };
    }

    /// Every 64th pop (a whole-heap check at every pop made the test take minutes): a
    /// wrong mark stays until its pair is weighed anew, so it is still seen.
    pub fn check(comps: &[Comp], store: &LinkStore, heap: &RunHeap<Key>, lay: KeyLayout) {
        if !ON.with(Cell::get) || !POPS.with(|p| p.replace(p.get() + 1)).is_multiple_of(64) {
            return;
        }
        let queued: std::collections::HashSet<(u32, u32, u64, u64, u64)> = heap
            .iter()
            .map(|k| k.entry(lay))
            .map(|e| (e.a, e.b, e.weight.to_bits(), e.saddle.to_bits(), e.top))
            .collect();
        for (a, c) in comps.iter().enumerate() {
            if !c.alive() {
                continue;
            }
            for &(b, slot) in &c.links.0 {
                let l = store.links[slot as usize];
                if (a as u32) < b && !l.queued.is_nan() {
                    let top = lay.key_top(l.queued, c.peak.max(comps[b as usize].peak));
                    assert!(
                        queued.contains(&(a as u32, b, l.queued.to_bits(), l.saddle.to_bits(), top)),
                        "pair ({a}, {b}) marked queued at {} with no such entry in the heap",
                        l.queued
                    );
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The field as first written (one unbounded query per sample, every segment marched
    /// to its end, one thread): the reference the fast field must equal bit for bit.
    fn reference(cx: &CellComplex) -> (Vec<f64>, Vec<f64>, Vec<[f64; 3]>) {
        fn seg(field: &ClearanceField, p: [f64; 3], q: [f64; 3]) -> f64 {
            let d = [q[0] - p[0], q[1] - p[1], q[2] - p[2]];
            let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let mut t = 0.0;
            let mut best = f64::INFINITY;
            loop {
                // The last sample is `q` itself.
                let x = if t >= 1.0 {
                    q
                } else {
                    [p[0] + d[0] * t, p[1] + d[1] * t, p[2] + d[2] * t]
                };
                let c = field.distance(x);
                best = best.min(c);
                if t >= 1.0 || len == 0.0 {
                    return best;
                }
                t = (t + (0.25 * c / len).max(1.0 / 64.0)).min(1.0);
            }
        }
        let field = ClearanceField::from_polygons(
            cx.patches
                .iter()
                .filter(|p| p.alive)
                .flat_map(|p| p.occluders.iter().map(|o| o.polygon.verts.as_slice())),
        );
        let mut value = vec![0.0; cx.cells.len()];
        let mut best = vec![[0.0; 3]; cx.cells.len()];
        for (id, c) in cx.active_cells() {
            let samples = cell_samples(c);
            let (mut bv, mut bp) = (f64::NEG_INFINITY, samples[0]);
            for x in samples {
                let d = field.distance(x);
                if d > bv {
                    (bv, bp) = (d, x);
                }
            }
            value[id.idx()] = if bv.is_finite() { bv.max(0.0) } else { 0.0 };
            best[id.idx()] = bp;
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
                        if field.distance(y) <= s {
                            continue;
                        }
                        s = s.max(seg(&field, xa, y).min(seg(&field, y, xb)));
                    }
                }
                if s.is_finite() { s } else { 0.0 }
            })
            .collect();
        (value, passage, best)
    }

    fn segment_min(field: &ClearanceField, p: [f64; 3], q: [f64; 3]) -> f64 {
        segment_min_from(field, p, field.distance(p), q, f64::NAN, f64::NEG_INFINITY)
    }

    /// `refined_passage` as first written (every leg marched to its end).
    fn reference_refined(f: &CellField, cx: &CellComplex, k: usize) -> f64 {
        let p = &cx.portals[k];
        let [a, b] = p.cells;
        let (sa, sb) = (cell_samples(&cx.cells[a.idx()]), cell_samples(&cx.cells[b.idx()]));
        let (ba, bb) = (f.best_of(&cx.cells[a.idx()]).1, f.best_of(&cx.cells[b.idx()]).1);
        let leg = |best: [f64; 3], xs: &[[f64; 3]]| -> Vec<([f64; 3], f64)> {
            xs.iter().map(|&x| (x, segment_min(&f.field, best, x))).collect()
        };
        let (la, lb) = (leg(ba, &sa), leg(bb, &sb));
        let side = |legs: &[([f64; 3], f64)], y: [f64; 3], floor: f64| {
            let mut v = f64::NEG_INFINITY;
            for &(x, l) in legs {
                if l <= v.max(floor) {
                    continue;
                }
                v = v.max(l.min(segment_min(&f.field, x, y)));
            }
            v
        };
        let mut s = f.passage[k];
        for piece in &p.pieces {
            let m = piece.centroid();
            let n = piece.verts.len();
            let mut ys = vec![m];
            for (i, &v) in piece.verts.iter().enumerate() {
                ys.push(mid(m, v));
                ys.push(lerp(&v, &m, 0.25));
                ys.push(lerp(&m, &mid(v, piece.verts[(i + 1) % n]), 0.75));
            }
            for y in ys {
                if f.field.distance(y) <= s {
                    continue;
                }
                let va = side(&la, y, s);
                if va <= s {
                    continue;
                }
                s = s.max(va.min(side(&lb, y, s)));
            }
        }
        if s.is_finite() { s } else { f.passage[k] }
    }

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    fn complexes() -> Vec<(String, CellComplex)> {
        let mut out = Vec::new();
        for name in ["four_room_distorted", "caverns", "noisy"] {
            let tm = crate::generate::thesis::by_name(name).unwrap();
            let m = crate::model::from_soup(tm.name, tm.soup.vertices.clone(), tm.soup.polygons.clone()).unwrap();
            out.push((name.to_string(), crate::pipeline::complex_of(&m).unwrap()));
        }
        let (soup, _) = crate::generate::scenes::room_grid(2, 2, 8);
        let m = crate::model::from_soup("rooms 2x2", soup.vertices, soup.polygons).unwrap();
        out.push(("rooms 2x2".into(), crate::pipeline::complex_of(&m).unwrap()));
        out
    }

    #[test]
    fn fast_field_equals_the_reference_bit_for_bit() {
        for (name, cx) in complexes() {
            let f = CellField::new(&cx);
            let (value, passage, best) = reference(&cx);
            assert_eq!(bits(&f.value), bits(&value), "{name}: cell values");
            assert_eq!(bits(&f.passage), bits(&passage), "{name}: passages");
            for (id, c) in cx.active_cells() {
                assert_eq!(f.best_of(c).1, best[id.idx()], "{name}: best sample of {id:?}");
            }
            assert!(f.passage.iter().any(|&s| s > 0.0), "{name}: some portal has a pass");
            // Refined passages too, on every portal between active cells.
            let mut checked = 0;
            for (k, p) in cx.portals.iter().enumerate() {
                let [a, b] = p.cells;
                if !(cx.cells[a.idx()].active() && cx.cells[b.idx()].active()) || k % 3 != 0 {
                    continue;
                }
                let (got, want) = (f.refined_passage(&cx, k), reference_refined(&f, &cx, k));
                assert_eq!(got.to_bits(), want.to_bits(), "{name}: refined passage of portal {k}");
                checked += 1;
            }
            assert!(checked > 0, "{name}");
        }
    }

    #[test]
    fn passage_stops_at_the_first_cells_clearance() {
        // `portal_passage` stops once the pass reaches the first cell's clearance (no path
        // can rise above it); the reference above marches every sample, so the test above
        // fails if the stop is taken too early. Here: the stop is reached on these models.
        for (name, cx) in complexes() {
            let f = CellField::new(&cx);
            let stopped = cx
                .portals
                .iter()
                .enumerate()
                .filter(|(k, p)| {
                    let a = p.cells[0].idx();
                    cx.cells[a].active() && f.passage[*k] > 0.0 && f.passage[*k] >= f.best_of(&cx.cells[a]).0
                })
                .count();
            assert!(
                stopped > 0,
                "{name}: no portal's pass reaches its first cell's clearance"
            );
        }
    }

    #[test]
    fn a_refined_pass_is_never_above_its_bound() {
        // The gate skips refining a portal whose `refined_bound` is at or below the pass
        // found so far, which gives the bits of refining every portal only if no refined
        // passage exceeds its bound. Here: on every active portal of the test complexes,
        // and the bound is tight (reached) on some.
        for (name, cx) in complexes() {
            let f = CellField::new(&cx);
            let (mut checked, mut tight) = (0, 0);
            for (k, p) in cx.portals.iter().enumerate() {
                let [a, b] = p.cells.map(|c| c.idx());
                if !(cx.cells[a].active() && cx.cells[b].active()) {
                    continue;
                }
                let (r, bound) = (f.refined_passage(&cx, k), refined_bound(&f, &cx, k as u32));
                assert!(r <= bound, "{name}: portal {k} refined {r} above its bound {bound}");
                checked += 1;
                tight += usize::from(r == bound);
            }
            assert!(
                checked > 0 && tight > 0,
                "{name}: {checked} portals, {tight} at their bound"
            );
        }
    }

    #[test]
    fn a_pass_is_never_above_either_cells_clearance() {
        // A path's lowest point is never above its ends: the marching lands on each leg's
        // end bit for bit, so not even a rounding of `p + (q - p)` lifts a pass above the
        // second cell's clearance (it did by an ulp on four_room_distorted and caverns), and
        // the passage may stop at the lower of the two clearances. Here: the bound holds
        // for every portal, and the stop at the second cell is reached.
        for (name, cx) in complexes() {
            let f = CellField::new(&cx);
            let mut at_second = 0;
            for (k, p) in cx.portals.iter().enumerate() {
                let [a, b] = p.cells.map(|c| c.idx());
                if !(cx.cells[a].active() && cx.cells[b].active()) {
                    continue;
                }
                let (da, db) = (f.best_of(&cx.cells[a]).0, f.best_of(&cx.cells[b]).0);
                assert!(
                    f.passage[k] <= da.min(db),
                    "{name}: portal {k} pass above a cell's clearance"
                );
                let r = f.refined_passage(&cx, k);
                assert!(
                    r <= da.min(db),
                    "{name}: portal {k} refined pass above a cell's clearance"
                );
                if f.passage[k] > 0.0 && f.passage[k] >= db && db < da {
                    at_second += 1;
                }
            }
            assert!(at_second > 0, "{name}: no pass stops at the second cell's clearance");
        }
    }

    #[test]
    fn grouped_pass_equals_the_serial_pass() {
        // The constrained second pass merged per group on every core makes the serial
        // pass's steps (ids, weights, cells left, areas), stop, counters and partition,
        // also where a group stops first and cuts the others short (they are merged again).
        use crate::decimate::HeuristicKind;
        let (mut grouped, mut cut_short) = (0, 0);
        for (name, cx) in complexes() {
            for r in [DEFAULT_RATIO, 1.25, 3.0] {
                let settings = Settings {
                    heuristic: HeuristicKind::Aperture,
                    stop: StopRule::Threshold(r),
                    ..Settings::default()
                };
                let gate = settings.heuristic.heuristic().aperture_gate().unwrap();
                let field = CellField::new(&cx);
                let cache = RefinedCache::new(&cx);
                let serial = |labels, progress: &mut dyn FnMut(usize, usize)| {
                    run_inner(&cx, &field, &cache, &settings, Some(gate), None, None, labels, progress)
                };
                let first = serial(None, &mut |_, _| {});
                let StopReason::Threshold { next_weight, .. } = first.stop else {
                    continue;
                };
                let Some(labels) = tunnel_labels(&cx, &field, &first.partition) else {
                    continue;
                };
                let labels = (labels.as_slice(), next_weight);
                let mut seen = Vec::new();
                let regions = first.stats.regions;
                let got = run_grouped(&cx, &field, &cache, &settings, gate, labels, regions, &mut |d, l| {
                    seen.push((d, l))
                })
                .expect("a threshold stop and labels of the complex's groups");
                grouped += 1;
                let mut told = Vec::new();
                let want = serial(Some(labels), &mut |d, l| told.push((d, l)));
                let steps = |d: &Decimation| -> Vec<(u32, u32, u64, usize, u64)> {
                    d.steps
                        .iter()
                        .map(|s| {
                            (
                                s.a.0,
                                s.b.0,
                                s.weight.to_bits(),
                                s.cells_remaining,
                                s.portal_area.to_bits(),
                            )
                        })
                        .collect()
                };
                assert_eq!(steps(&got), steps(&want), "{name} at {r}: steps");
                assert_eq!(got.stop, want.stop, "{name} at {r}: stop");
                let counters = |d: &Decimation| DecimationStats {
                    init_seconds: 0.0,
                    collapse_seconds: 0.0,
                    ..d.stats.clone()
                };
                assert_eq!(counters(&got), counters(&want), "{name} at {r}: counters");
                assert_eq!(got.partition, want.partition, "{name} at {r}: partition");
                assert_eq!(seen, told, "{name} at {r}: progress");
                // A group's pair at or above the threshold stopped the pass (not the first
                // pass's next weight, given when only pairs across groups are left).
                if let StopReason::Threshold { next_weight: w, .. } = got.stop
                    && w.to_bits() != next_weight.to_bits()
                {
                    cut_short += 1;
                }
            }
        }
        assert!(
            grouped >= 10 && cut_short >= 1,
            "grouped {grouped}, cut short {cut_short}"
        );
    }

    #[test]
    fn refined_passages_are_reused_and_equal_new_ones() {
        // A second pass with the first's cache (as a moved run's second pass has) takes
        // every refined passage it asks for from the cache, and makes the same steps as
        // the first, which computed them; the stored values are the field's.
        use crate::decimate::HeuristicKind;
        let mut hits = 0;
        for (name, cx) in complexes() {
            let settings = Settings {
                heuristic: HeuristicKind::Aperture,
                stop: StopRule::Threshold(DEFAULT_RATIO),
                ..Settings::default()
            };
            let gate = settings.heuristic.heuristic().aperture_gate();
            let field = CellField::new(&cx);
            let cache = RefinedCache::new(&cx);
            let key = |d: &Decimation| -> Vec<(u32, u32, u64)> {
                d.steps.iter().map(|s| (s.a.0, s.b.0, s.weight.to_bits())).collect()
            };
            let run =
                |cache: &RefinedCache| run_inner(&cx, &field, cache, &settings, gate, None, None, None, &mut |_, _| {});
            let known = |cache: &RefinedCache| (0..cx.portals.len()).filter(|&k| !cache.get(k).is_nan()).count();
            let cold = run(&cache);
            let before = cache.hits();
            let stored = known(&cache);
            let warm = run(&cache);
            assert_eq!(key(&cold), key(&warm), "{name}: steps");
            assert_eq!(known(&cache), stored, "{name}");
            for k in 0..cx.portals.len() {
                let v = cache.get(k);
                if !v.is_nan() {
                    assert_eq!(
                        v.to_bits(),
                        field.refined_passage(&cx, k).to_bits(),
                        "{name}: portal {k}"
                    );
                }
            }
            hits += cache.hits() - before;
        }
        assert!(hits > 0, "no refined passage was taken from the cache");
    }

    #[test]
    fn cell_portals_in_rows_list_each_cells_portals_in_order() {
        let (_, cx) = complexes().pop().unwrap();
        let keep = |k: usize| k % 3 != 1;
        let rows = CellPortals::new(&cx, keep);
        let mut want: Vec<Vec<u32>> = vec![Vec::new(); cx.cells.len()];
        for (k, p) in cx.portals.iter().enumerate() {
            if keep(k) {
                want[p.cells[0].idx()].push(k as u32);
                want[p.cells[1].idx()].push(k as u32);
            }
        }
        assert!(want.iter().any(|w| w.len() > 1));
        for (c, w) in want.iter().enumerate() {
            assert_eq!(rows.of(c), w.as_slice(), "cell {c}");
        }
    }

    #[test]
    fn components_are_compact() {
        // One component per cell id and one link per pair: their sizes are the merge's
        // memory at a million triangles (2.3 million ids, 2.6 million pairs).
        assert_eq!(std::mem::size_of::<Members>(), 16);
        assert_eq!(std::mem::size_of::<Comp>(), 72);
        assert_eq!(std::mem::size_of::<Link>(), 64);
        let l = Link::EMPTY.with_largest(3, 5);
        assert_eq!(l.largest_at(), Some((3, 5)));
        assert!(!l.largest_flip() && !l.refined());
        let mut r = l.reversed();
        r.bits |= REFINED;
        assert_eq!(r.largest_at(), Some((3, 5)));
        assert!(r.largest_flip() && r.refined());
        assert!(!r.fuse(&Link::EMPTY).refined() && r.fuse(&Link::EMPTY).largest_flip());
        assert_eq!(Link::EMPTY.largest_at(), None);
        let mut m = Members::One(7);
        assert_eq!(&*m, &[7]);
        m.append(&mut Members::One(3));
        m.append(&mut vec![5, 1].into());
        assert_eq!(&*m, &[7, 3, 5, 1], "appended in order");
        let mut c = Comp::default();
        assert!(!c.alive());
        c.pieces = 1;
        assert!(c.alive());
    }

    #[test]
    fn a_links_plane_is_its_largest_pieces_and_turns_with_it() {
        let (_, cx) = complexes().pop().unwrap();
        let (k, p) = cx
            .portals
            .iter()
            .enumerate()
            .find(|(_, p)| p.pieces.iter().any(|q| q.area() > 0.0))
            .expect("a portal");
        let i = (0..p.pieces.len())
            .max_by(|&x, &y| p.pieces[x].area().total_cmp(&p.pieces[y].area()))
            .unwrap();
        let q = &p.pieces[i];
        let l = Link {
            largest_area: q.area(),
            ..Link::EMPTY
        }
        .with_largest(k as u32, i as u32);
        let n = q.normal();
        assert_eq!(l.largest_plane(&cx), (n, q.centroid()));
        assert_eq!(l.reversed().largest_plane(&cx), ([-n[0], -n[1], -n[2]], q.centroid()));
        assert_eq!(l.reversed().reversed().largest_plane(&cx), (n, q.centroid()));
        // Without a piece: the plane z = 0, normal +z (negated from the other side).
        assert_eq!(Link::EMPTY.largest_plane(&cx), ([0.0, 0.0, 1.0], [0.0; 3]));
        let r = Link::EMPTY.reversed().largest_plane(&cx).0;
        assert_eq!(r.map(f64::to_bits), [-0.0f64, -0.0, -1.0].map(f64::to_bits));
        // A fused link keeps the larger piece (the first on a tie).
        let small = Link {
            largest_area: 0.5 * q.area(),
            ..Link::EMPTY
        };
        assert_eq!(small.fuse(&l.reversed()).largest_plane(&cx).0, [-n[0], -n[1], -n[2]]);
        assert_eq!(l.fuse(&l.reversed()).largest_plane(&cx).0, n);
    }

    #[test]
    fn field_does_not_depend_on_the_thread_count() {
        let (_, cx) = complexes().pop().unwrap();
        let on = |n: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap();
            pool.install(|| CellField::new(&cx))
        };
        let (one, three) = (on(1), on(3));
        assert_eq!(bits(&one.value), bits(&three.value));
        assert_eq!(bits(&one.passage), bits(&three.passage));
        for (_, c) in cx.active_cells() {
            assert_eq!(one.best_of(c), three.best_of(c));
        }
    }

    /// The merge skips a push whose identical entry is still queued (`requeue`); with a
    /// trace it pushes every time. Both must make the same decisions.
    /// `Key` orders as `Entry` and decodes to the same bits (weights and saddles with
    /// signs, zeros, infinities, NaNs, ties).
    #[test]
    fn heap_keys_order_and_decode_as_entries() {
        let mut rng = crate::base::rng::SplitMix64(9);
        let pool = [
            0.0,
            -0.0,
            1.0,
            1.0 + f64::EPSILON,
            0.5,
            2.0,
            -1.0,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MIN_POSITIVE,
            1e300,
        ];
        let pick = |rng: &mut crate::base::rng::SplitMix64| {
            if rng.unit() < 0.5 {
                pool[(rng.unit() * pool.len() as f64) as usize % pool.len()]
            } else {
                (rng.unit() - 0.3) * 4.0
            }
        };
        // Layouts of few and of many cells (32-bit ids: no room for the top).
        for cells in [2usize, 5, 1 << 20, 2_306_001, 1 << 31, u32::MAX as usize + 1] {
            let lay = KeyLayout::of(cells, [0.25, 4.0]);
            let max = (cells - 1) as u32;
            let id = |rng: &mut crate::base::rng::SplitMix64| [0, 1, max / 2, max][(rng.unit() * 4.0) as usize % 4];
            let es: Vec<Entry> = (0..300)
                .map(|_| Entry {
                    weight: pick(&mut rng),
                    saddle: pick(&mut rng),
                    top: lay.top(pick(&mut rng)),
                    a: id(&mut rng),
                    b: id(&mut rng),
                })
                .collect();
            for x in &es {
                let d = Key::of(*x, lay).entry(lay);
                assert_eq!(
                    (d.weight.to_bits(), d.saddle.to_bits(), d.top, d.a, d.b),
                    (x.weight.to_bits(), x.saddle.to_bits(), x.top, x.a, x.b)
                );
                for y in &es {
                    assert_eq!(Key::of(*x, lay).cmp(&Key::of(*y, lay)), x.cmp(y), "{x:?} vs {y:?}");
                }
            }
        }
        // The quantized top is monotone, and at a million triangles' layout, with peaks
        // over a factor 64, keeps relative steps of 2^-13 apart.
        let lay = KeyLayout::of(2_306_001, [0.05, 3.2]);
        assert_eq!(lay.top_bits(), 20);
        assert!(lay.top(1.0) < lay.top(1.0 + 1.0 / 8192.0));
        assert!(lay.top(0.5) < lay.top(1.0) && lay.top(1.0) <= lay.top(1.0 + f64::EPSILON));
        assert_eq!(lay.top(0.0), 0);
        assert_eq!(lay.top(0.05), 0);
        assert!(lay.top(3.2) < 1 << 20 && lay.top(f64::NAN) == (1 << 20) - 1);
        // Only weight-1 entries carry it.
        assert_eq!(lay.key_top(1.0, 2.0), lay.top(2.0));
        assert_eq!(lay.key_top(1.0 + f64::EPSILON, 2.0), 0);
    }

    #[test]
    fn skipping_duplicate_pushes_changes_no_step() {
        use crate::decimate::HeuristicKind;
        let mut steps = 0;
        // Also audit the bookkeeping behind the skip after every pop (`queue_audit`): the
        // steps alone do not show a lost pair on models where no kept pair is decided anew.
        super::queue_audit::ON.with(|on| on.set(true));
        for (name, cx) in complexes() {
            for stop in [StopRule::Threshold(DEFAULT_RATIO), StopRule::None] {
                let settings = Settings {
                    heuristic: HeuristicKind::Aperture,
                    stop,
                    ..Settings::default()
                };
                let fast = run(&cx, &settings, &mut |_, _| {});
                let (every, _) = trace(&cx, &settings, settings.heuristic.heuristic().aperture_gate());
                let key = |d: &Decimation| -> Vec<(u32, u32, u64)> {
                    d.steps.iter().map(|s| (s.a.0, s.b.0, s.weight.to_bits())).collect()
                };
                assert_eq!(key(&fast), key(&every), "{name}, {stop:?}: steps");
                assert_eq!(fast.stats.weights_computed, every.stats.weights_computed, "{name}");
                assert_eq!(format!("{:?}", fast.stop), format!("{:?}", every.stop), "{name}");
                steps += fast.steps.len();
            }
        }
        assert!(steps > 1000, "{steps}");
    }

    /// `sliced_section` as first written (every member cut at every height, the plain sum),
    /// at the extent of the hull of the members' vertices, built afresh.
    fn reference_sliced(cx: &CellComplex, c: &Comp, frame: &Frame, k: usize) -> f64 {
        let vertices: Vec<[f64; 3]> = c
            .members
            .iter()
            .flat_map(|&m| cx.cells[m as usize].vertices())
            .collect();
        let (lo, hi) = extent(&Hull3::new(&vertices), frame);
        if hi.partial_cmp(&lo) != Some(Ordering::Greater) || k == 0 {
            return 0.0;
        }
        (0..k)
            .map(|i| {
                let t = lo + (hi - lo) * (i as f64 + 0.5) / k as f64;
                c.members
                    .iter()
                    .map(|&m| cut_area(&cx.cells[m as usize], frame, t))
                    .sum::<f64>()
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn sliced_section_skips_only_members_that_add_nothing() {
        let mut compared = 0;
        for (name, cx) in complexes() {
            let active: Vec<u32> = cx.active_cells().map(|(id, _)| id.0).collect();
            // The whole complex, and runs of consecutive cells (pieces of it).
            let mut groups = vec![active.clone()];
            groups.extend(active.chunks(active.len() / 5 + 1).map(<[u32]>::to_vec));
            for (gi, members) in groups.into_iter().enumerate() {
                let mut c = Comp {
                    members: members.into(),
                    ..Comp::default()
                };
                for (fi, n) in [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.3, -0.5, 0.81], [-0.7, 0.1, 0.2]]
                    .into_iter()
                    .enumerate()
                {
                    let o = cx.cells[c.members[0] as usize].centroid();
                    let frame = Frame::new(crate::base::vec::normalize(&n), o).unwrap();
                    for k in [1, 5, 7] {
                        let (got, want) = (
                            sliced_section(&cx, &mut c, &frame, k),
                            reference_sliced(&cx, &c, &frame, k),
                        );
                        assert_eq!(
                            got.to_bits(),
                            want.to_bits(),
                            "{name}: group {gi}, frame {fi}, {k} slices"
                        );
                        compared += (got > 0.0) as usize;
                    }
                }
            }
        }
        assert!(compared > 20, "{compared}");
    }

    /// Two 4 x 4 x 3 rooms (x in [0, 4] and [4.5, 8.5]) joined by a door 1 wide and 2
    /// high through a wall 0.5 thick: the model, its complex and field, and its active
    /// cells split at x = 5.5 (the first room, the door and the first metre of the second
    /// room; the rest of the second room).
    fn rooms_through_a_door() -> (crate::model::Model, CellComplex, CellField, Vec<u32>, Vec<u32>) {
        let (soup, _) = crate::generate::scenes::room_grid(2, 1, 8);
        let m = crate::model::from_soup("rooms 2x1", soup.vertices, soup.polygons).unwrap();
        let cx = crate::pipeline::complex_of(&m).unwrap();
        let field = CellField::new(&cx);
        let x = |c: u32| m.to_user(cx.cells[c as usize].centroid())[0];
        let active: Vec<u32> = cx.active_cells().map(|(id, _)| id.0).collect();
        let (near, far): (Vec<u32>, Vec<u32>) = active.iter().partition(|&&c| x(c) < 5.5);
        (m, cx, field, near, far)
    }

    /// A component of `members` as the merge starts one (its peak the highest member's).
    fn comp_of(cx: &CellComplex, field: &CellField, members: Vec<u32>) -> Comp {
        Comp {
            peak: members.iter().map(|&c| field.value[c as usize]).fold(0.0, f64::max),
            volume: members.iter().map(|&c| cx.cell_volume(CellId(c))).sum(),
            pieces: members.len() as u32,
            members: members.into(),
            ..Comp::default()
        }
    }

    #[test]
    fn stored_core_judgements_are_taken_only_for_equal_inputs_and_equal_new_ones() {
        // The two rooms of the door test, the first grown a metre into the second.
        let (_, cx, field, near, far) = rooms_through_a_door();
        let comp = |members: Vec<u32>| comp_of(&cx, &field, members);
        assert!(near.len() + far.len() >= CoreCuts::MIN_CELLS);
        let cell_portals = CellPortals::new(&cx, |_| true);
        let g = crate::decimate::HeuristicKind::Aperture
            .heuristic()
            .aperture_gate()
            .expect("aperture has a gate");
        let cache = CoreCuts::new(cx.cells.len());
        let hits = || cache.hits.load(AtomicOrdering::Relaxed);
        let comps = [comp(near.clone()), comp(far.clone())];
        let base = CoreQuestion {
            cx: &cx,
            field: &field,
            cell_portals: &cell_portals,
            comps: &comps,
            pair: (0, 1),
            saddle: 0.5,
            open: 12.0,
            gate: &g,
        };
        let fresh = |comps: &[Comp], saddle: f64, open: f64| {
            core_judgement(&CoreQuestion {
                comps,
                saddle,
                open,
                ..base
            })
        };
        let cached = |comps: &[Comp], saddle: f64, open: f64, store: bool| {
            let q = CoreQuestion {
                comps,
                saddle,
                open,
                ..base
            };
            core_judgement_cached(&q, Some((&cache, store)))
        };
        // The door (opening 2) is narrower than the second room's section (12): kept; not
        // narrower than an opening of 1: not kept by the cut.
        assert!(fresh(&comps, 0.5, 12.0));
        assert!(!fresh(&comps, 0.5, 1.0));
        // Not stored when told not to; stored, then taken, when told to.
        assert!(cached(&comps, 0.5, 12.0, false));
        assert_eq!(hits(), 0);
        assert!(cached(&comps, 0.5, 12.0, true));
        assert_eq!(hits(), 0);
        assert!(cached(&comps, 0.5, 12.0, true));
        assert_eq!(hits(), 1);
        // Another opening, saddle or member order (the flow network's node numbers) is
        // another input: judged anew.
        assert!(!cached(&comps, 0.5, 1.0, true));
        assert_eq!(cached(&comps, 0.4, 12.0, true), fresh(&comps, 0.4, 12.0));
        let mut rev = near;
        rev.reverse();
        let turned = [comp(rev), comp(far)];
        assert_eq!(cached(&turned, 0.5, 12.0, true), fresh(&turned, 0.5, 12.0));
        assert_eq!(hits(), 1);
        // As is another gate.
        let other = ApertureGate { ratio: 100.0, ..g };
        let q = CoreQuestion { gate: &other, ..base };
        assert_eq!(core_judgement_cached(&q, Some((&cache, true))), core_judgement(&q));
        assert_eq!(hits(), 1);
        // An exhausted budget stores nothing more.
        let small = CoreCuts::new(0);
        small.put(&comps[0].members, &comps[1].members, [0; 4], &g, true);
        assert!(small.get(&comps[0].members, &comps[1].members, [0; 4], &g).is_none());
    }

    #[test]
    fn the_core_cut_of_a_component_grown_through_a_door_is_the_door() {
        // Two 4 x 4 x 3 rooms (x in [0, 4] and [4.5, 8.5]) joined by a door 1 wide and 2
        // high through a wall 0.5 thick. Component `a` is the first room, the door and the
        // first metre of the second room; `b` the rest of the second room. Their interface
        // is the second room's section (12); the least cut between their cores is the door.
        let (m, cx, field, near, far) = rooms_through_a_door();
        let x = |c: u32| m.to_user(cx.cells[c as usize].centroid())[0];
        let comp = |members: Vec<u32>| comp_of(&cx, &field, members);
        let comps = [comp(near), comp(far)];
        let cell_portals = CellPortals::new(&cx, |_| true);
        // The pass through the door: half its width.
        let (portals, link, sides) = core_cut(&cx, &field, &cell_portals, &comps, 0, 1, 0.5).expect("both cores");
        let area = link.opening();
        assert!((1.9..2.1).contains(&area), "the cut's opening {area}, the door's 2");
        for &k in &portals {
            let g = m.to_user(cx.portals[k as usize].pieces[0].centroid());
            assert!((4.0..=4.5).contains(&g[0]), "a cut portal at x = {}", g[0]);
        }
        // Each side holds a room's volume (48), `a`'s side without the metre it grew into
        // the second room, `b`'s with it.
        let volume = |cells: &[u32]| -> f64 { cells.iter().map(|&c| cx.cell_volume(CellId(c))).sum() };
        let (va, vb) = (volume(&sides[0]), volume(&sides[1]));
        assert!((46.0..50.0).contains(&va) && (46.0..50.0).contains(&vb), "{va} {vb}");
        // The interface between the components is the second room's section (portal
        // areas: at least its vector area).
        let between: Vec<u32> = comps[0]
            .members
            .iter()
            .flat_map(|&c| cell_portals.of(c as usize).iter().copied())
            .filter(|&k| {
                let [p, q] = cx.portals[k as usize].cells;
                (x(p.0) < 5.5) != (x(q.0) < 5.5)
            })
            .collect();
        let interface: f64 = between.iter().map(|&k| cx.portals[k as usize].area).sum();
        assert!(interface > 11.0, "{interface}");
    }

    #[test]
    fn memoized_cuts_equal_fresh_ones_as_a_component_grows() {
        // A component grown by absorbing runs of cells (absorbing and absorbed in turn, so
        // the memo travels with the list that stays first and is dropped with the other),
        // judged on frames taken in turn from more than the memo keeps, with the number of
        // cuts changing: every value equal to the plain sum's bits, and every decision
        // against a target (summed only until it decides) the plain sum's.
        let (mut compared, mut stopped) = (0, 0);
        for (name, cx) in complexes() {
            let active: Vec<u32> = cx.active_cells().map(|(id, _)| id.0).collect();
            let frames: Vec<Frame> = (0..SLICE_MEMO_FRAMES + 4)
                .map(|i| {
                    let a = i as f64 * 0.7;
                    let o = cx.cells[active[(i * 37) % active.len()] as usize].centroid();
                    Frame::new(normalize(&[a.cos(), a.sin(), 0.3 - 0.1 * i as f64]), o).unwrap()
                })
                .collect();
            let mut c = Comp {
                members: vec![active[0]].into(),
                ..Comp::default()
            };
            let (mut next, mut step, mut judged) = (1, 0usize, 0usize);
            while next < active.len() {
                // Runs of 1-6 cells, and now and then one longer than the component.
                let run = if step % 10 == 9 {
                    c.members.len() + 1
                } else {
                    1 + step % 6
                };
                step += 1;
                let end = (next + run).min(active.len());
                let mut o = Comp {
                    members: active[next..end].to_vec().into(),
                    ..Comp::default()
                };
                if step % 5 == 3 {
                    // The run's own hull, and a memo of its own that must not survive
                    // when it is absorbed after the longer list.
                    section(&cx, &mut o, &frames[0]);
                    sliced_section_reaching(&cx, &mut o, &frames[0], 5, f64::INFINITY, 1);
                }
                if step % 2 == 0 {
                    c.absorb_members(&mut o);
                } else {
                    o.absorb_members(&mut c);
                    c = o;
                }
                next = end;
                for _ in 0..3 {
                    // Mostly three frames again and again, now and then one of the others
                    // (more of them than the memo keeps); now and then another cut count.
                    let f = if judged % 7 == 6 {
                        3 + (judged / 7) % (frames.len() - 3)
                    } else {
                        judged % 3
                    };
                    let (frame, k) = (&frames[f], if judged % 11 == 10 { 7 } else { 5 });
                    judged += 1;
                    section(&cx, &mut c, frame);
                    let want = reference_sliced(&cx, &c, frame, k);
                    // Mostly decisions (summed until they decide, leaving the memo part
                    // way through the members), now and then the value itself.
                    let target = match judged % 5 {
                        0 => want * 0.25,
                        1 => want,
                        2 => want.next_up(),
                        3 => want * 0.9,
                        _ => f64::INFINITY,
                    };
                    let got = sliced_section_reaching(&cx, &mut c, frame, k, target, 1);
                    let at = format!("{name}: {} members, judgement {judged}", c.members.len());
                    assert_eq!(got >= target, want >= target, "{at}: decision at {target}");
                    if got < target {
                        assert_eq!(got.to_bits(), want.to_bits(), "{at}: value below {target}");
                        compared += (got > 0.0) as usize;
                    } else {
                        stopped += (got < want) as usize;
                    }
                }
            }
            let memos = c.hull.as_ref().map_or(0, |h| h.slices.len());
            assert!((1..=SLICE_MEMO_FRAMES).contains(&memos), "{name}: {memos} memos");
        }
        assert!(compared > 100, "{compared}");
        assert!(stopped > 20, "{stopped} decisions stopped before the last member");
    }

    use crate::geom::ConvexPolyhedron;

    #[test]
    fn cut_area_of_a_box_is_its_section_at_any_height_and_zero_outside() {
        let b = Cell::new(
            ConvexPolyhedron::cuboid(&[0.0, 0.0, 0.0], &[4.0, 2.0, 1.0]),
            None,
            false,
        );
        let along_x = Frame::new([1.0, 0.0, 0.0], [0.0; 3]).unwrap();
        for t in [0.5, 2.0, 3.9] {
            assert!((cut_area(&b, &along_x, t) - 2.0).abs() < 1e-12, "t = {t}");
        }
        assert_eq!(cut_area(&b, &along_x, 4.5), 0.0);
        assert_eq!(cut_area(&b, &along_x, -0.5), 0.0);
        // An oblique cut of the long box is wider than its section (1/cos 45°), and far
        // smaller than the box's projection on that plane.
        let d = std::f64::consts::FRAC_1_SQRT_2;
        let oblique = Frame::new([d, d, 0.0], [0.0; 3]).unwrap();
        let a = cut_area(&b, &oblique, 2.0 * d);
        assert!((a - 2.0 * std::f64::consts::SQRT_2).abs() < 1e-9, "{a}");
    }

    /// The partition of the active cells of `cx` into the connected parts of `group`'s
    /// classes (recorded as collapses, survivors the lower ids, and replayed).
    fn partition_of(cx: &CellComplex, group: impl Fn(CellId) -> usize) -> super::super::Partition {
        let mut owner: Vec<u32> = (0..cx.cells.len() as u32).collect();
        let mut left = cx.active_cells().count();
        let mut steps = Vec::new();
        for p in &cx.portals {
            let [a, b] = p.cells;
            if a == b || !cx.cells[a.idx()].active() || !cx.cells[b.idx()].active() || group(a) != group(b) {
                continue;
            }
            let (ra, rb) = (find(&mut owner, a.0), find(&mut owner, b.0));
            if ra == rb {
                continue;
            }
            let (x, y) = (ra.min(rb), ra.max(rb));
            owner[y as usize] = x;
            left -= 1;
            steps.push(Step {
                a: CellId(x),
                b: CellId(y),
                weight: 1.0,
                cells_remaining: left,
                portal_area: p.area,
                projected: [0.0, 0.0],
            });
        }
        super::super::Decimation::replay(cx, &steps).expect("collapses of live components")
    }

    #[test]
    fn tunnel_labels_move_a_boundary_to_the_least_area_cut_and_keep_the_rooms() {
        // Two 4 × 4 × 3 rooms joined through a 1 m thick wall by a 1 × 2 door corridor
        // (x ∈ [4, 5]); the boundary placed by the cells' centroids at several x.
        let s = crate::generate::scenes::two_rooms();
        let m = crate::model::from_soup("two rooms", s.vertices, s.polygons).unwrap();
        let cx = crate::pipeline::complex_of(&m).unwrap();
        let x = |c: CellId| cx.cells[c.idx()].centroid()[0];
        let area = |p: &super::super::Partition| p.portals(&cx).iter().map(|mp| mp.area).sum::<f64>();
        let field = CellField::new(&cx);
        let mut moves = 0;
        for at in [4.1, 4.3, 4.5, 4.7, 4.9, 5.1, 5.3] {
            let part = partition_of(&cx, |c| (x(c) >= at) as usize);
            if part.len() != 2 {
                continue;
            }
            let Some(labels) = tunnel_labels(&cx, &field, &part) else {
                continue;
            };
            moves += 1;
            let moved = partition_of(&cx, |c| labels[c.idx()] as usize);
            assert_eq!(moved.len(), 2, "at {at}: two connected groups");
            // Every cell of either room keeps its side; the new boundary is no larger than
            // the old one, and no smaller than the door's section (1 × 2).
            for (id, _) in cx.active_cells() {
                if x(id) < 4.0 {
                    assert_eq!(labels[id.idx()], 0, "at {at}: cell {id:?} of the first room");
                } else if x(id) > 5.0 {
                    assert_eq!(labels[id.idx()], 1, "at {at}: cell {id:?} of the second room");
                }
            }
            let (before, after) = (area(&part), area(&moved));
            assert!(
                after <= before * (1.0 + 1e-12) && after >= 2.0 * (1.0 - 1e-9),
                "at {at}: {before} -> {after}"
            );
            // Moved again, it stays (the least-area cut is a fixed point).
            assert!(tunnel_labels(&cx, &field, &moved).is_none(), "at {at}");
        }
        assert!(moves > 0, "some boundary moved");
    }

    fn comp(peak: f64) -> Comp {
        Comp {
            peak,
            volume: 1.0,
            pieces: 1,
            ..Comp::default()
        }
    }

    /// Links pair `x < y` through a new slot holding `l` (seen from `x`).
    fn link_pair(comps: &mut [Comp], store: &mut LinkStore, x: u32, y: u32, l: Link) {
        let s = store.add(x, y, l);
        comps[x as usize].links.insert(y, s);
        comps[y as usize].links.insert(x, s);
    }

    /// Runs the clean-up on `comps` (`cells` live) unconstrained: (its steps, cells left).
    fn clean(
        cx: &CellComplex,
        comps: &mut [Comp],
        store: &mut LinkStore,
        g: &ApertureGate,
        cells: usize,
    ) -> (Vec<Step>, usize) {
        let (mut steps, mut cells) = (Vec::new(), cells);
        clean_up(cx, comps, store, g, false, &mut steps, &mut cells, &mut |_, _| {});
        (steps, cells)
    }

    #[test]
    fn clean_up_absorbs_dominated_components_lowest_first_across_the_largest_portal() {
        // 0 and 1 are rooms (peaks 1.0 and 0.9); 2 (peak 0.1) touches both, with the larger
        // portal towards 1; 3 (peak 0.01) touches only 2.
        let mut comps = vec![comp(1.0), comp(0.9), comp(0.1), comp(0.01)];
        let mut store = LinkStore::default();
        for (x, y, area) in [(0, 1, 1.0), (0, 2, 0.5), (1, 2, 2.0), (2, 3, 0.3)] {
            link_pair(&mut comps, &mut store, x, y, Link { area, ..Link::EMPTY });
        }
        let (_, cx) = complexes().pop().unwrap();
        let g = ApertureGate {
            dominance: 0.15,
            slab: 0.0,
            ..DEFAULT_APERTURE
        };
        let (steps, cells) = clean(&cx, &mut comps, &mut store, &g, 4);
        let pairs: Vec<(u32, u32)> = steps.iter().map(|s| (s.a.0, s.b.0)).collect();
        // 3 first (lowest peak; its only neighbour 2 dominates it), then 2 into 1.
        assert_eq!(pairs, vec![(2, 3), (1, 2)]);
        assert_eq!(cells, 2);
        assert!(comps[0].alive() && comps[1].alive() && !comps[2].alive() && !comps[3].alive());
        assert!((steps[0].weight - 0.1).abs() < 1e-12);
        // The rooms are not dominated (0.9 > 0.15 · 1.0): both stay.
        assert_eq!(comps[1].links.keys().copied().collect::<Vec<_>>(), vec![0]);
    }

    #[test]
    fn clean_up_absorbs_a_slab_along_its_portal_and_keeps_a_room_behind_an_opening() {
        // Components 1 and 2 are single cells of a real complex (peaks 0.4, not dominated by
        // 0's 1.0, but below half of it); 1's portal towards 0 is far larger than its
        // section on the portal's plane (a slab along a wall), 2's far smaller (a room
        // behind an opening).
        let (_, cx) = complexes().pop().unwrap();
        let ids: Vec<u32> = cx.active_cells().map(|(id, _)| id.0).take(3).collect();
        let link = |area: f64| Link {
            area,
            av: [0.0, 0.0, area],
            largest_area: area,
            ..Link::EMPTY
        };
        let mut comps = vec![comp(1.0), comp(0.4), comp(0.4)];
        for (k, c) in comps.iter_mut().enumerate() {
            c.members.push(ids[k]);
        }
        let mut store = LinkStore::default();
        for (x, y, area) in [(0u32, 1u32, 1e6), (0, 2, 1e-9)] {
            link_pair(&mut comps, &mut store, x, y, link(area));
        }
        let (steps, _) = clean(&cx, &mut comps, &mut store, &DEFAULT_APERTURE, 3);
        let pairs: Vec<(u32, u32)> = steps.iter().map(|s| (s.a.0, s.b.0)).collect();
        assert_eq!(pairs, vec![(0, 1)]);
        assert!((steps[0].weight - 0.4).abs() < 1e-12);
        assert_eq!(comps[0].members.len(), 2, "the slab's cells joined");
        // Without the slab rule, or with peaks of comparable rooms, nothing is absorbed.
        for (g, p) in [
            (
                ApertureGate {
                    slab: 0.0,
                    ..DEFAULT_APERTURE
                },
                0.4,
            ),
            (DEFAULT_APERTURE, 0.9),
        ] {
            let mut fresh = vec![comp(1.0), comp(p), comp(p)];
            for (k, c) in fresh.iter_mut().enumerate() {
                c.members.push(ids[k]);
            }
            let mut store = LinkStore::default();
            for (x, y, area) in [(0u32, 1u32, 1e6), (0, 2, 1e-9)] {
                link_pair(&mut fresh, &mut store, x, y, link(area));
            }
            assert!(clean(&cx, &mut fresh, &mut store, &g, 3).0.is_empty());
        }
    }
}
