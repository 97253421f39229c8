//! Sealing narrow openings of leaking regions (Umbra's "smallest hole"; issue 16, "Leaky
//! real levels").
//!
//! A level exported from a game often has small openings to the outside (gaps between
//! meshes, slits under a sky brush). Through one, the exterior flood fill joins the inside
//! to the outside, and the whole region is kept as a leak. [`CellComplex::seal_holes`]
//! redoes the exterior removal with openings narrower than a given size treated as closed:
//!
//! - The **width** of an opening (a portal between two cells, or the uncovered part of a
//!   cell's hull faces) is twice the largest distance to the model's polygons over sample
//!   points of it (the centroid and a barycentric grid of step 1/4 over its fan triangles):
//!   the diameter of the largest ball centred on the opening that touches no polygon, up
//!   to the sampling (so it can underestimate, never overestimate, a sampled width).
//! - Only **leaking regions** are touched. In one, the *outside part* is what the hull's
//!   wide openings reach through wide portals. If the outside part faces no occluder, it is
//!   removed as exterior, the rest of the region (joined again through every portal, narrow
//!   or not, so narrow passages between rooms stay open) is kept or removed by the usual
//!   rule, and the narrow openings between the kept part and the outside part (and the
//!   kept part's narrow hull openings) are reported as [`SealedOpening`]s, grouped into
//!   holes by proximity. If the outside part faces an occluder, some opening wider than
//!   the size joins the inside to the outside, or the outside sees fragments of walls'
//!   fronts through cracks narrower than the size (vertex noise on a model with
//!   T-junctions opens a crack along each of them, on both sides of every wall). The
//!   region is then split into components over the wide portals and each kept by the
//!   side of the walls it mostly sees, as for cracks (below), provided the removed
//!   components see less front area than the kept ones; otherwise the region stays
//!   whole and its leak is reported as without sealing (qbsp's path and pointfile).
//!
//! **Cracks, with no size given** ([`CellComplex::seal_cracks_auto`], `run`'s default):
//! the leaks of closed models (noisy walls, marching-tetrahedra caverns; issue 15) run
//! through portals lying on a wall, within rounding of its plane, that the wall's
//! occluders leave uncovered (nearly coplanar neighbours share one support plane, and a
//! neighbour's occluder is not attached there). Their width is below the sliver width
//! ([`crate::Tolerances::sliver_width`], the portal graph's own crack threshold; 2–4e-5
//! on the suite's leaks, at diagonals of about 25). With those closed, the region falls
//! into components; the outside part is not defined from the hull here, because a noisy
//! wall's other side can touch small fragments of its front (a cell behind one triangle
//! and in front of its neighbour): a component is kept when most of the occluder area
//! its cells touch faces it ([`FRONT_SHARE`]), so the outside and the inside of walls go
//! and rooms stay. A kept component reaching the hull through a wider opening is a real
//! leak, reported as without sealing.
//!
//! Sealing removes cells and portals but never splits or changes a cell, so the
//! complex's invariants ([`CellComplex::validate`]) hold as before.

use super::{CellComplex, HULL};
use crate::geom::ConvexPolygon;
use crate::geom::clearance::ClearanceField;
use crate::ids::CellId;
use crate::model::Model;
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, HashSet, VecDeque};
use std::time::Instant;

/// An opening sealed by [`CellComplex::seal_holes`]: one hole, made of one or more portals
/// (or hull openings) closer together than the sealing size.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SealedOpening {
    /// The point of the opening farthest from the model's polygons (among samples).
    pub point: [f64; 3],
    /// Estimated width: twice the clearance at `point` (below the sealing size).
    pub width: f64,
    /// Total area of the sealed portal pieces.
    pub area: f64,
    /// Sealed portals (and hull openings) in this hole.
    pub portals: usize,
    /// A kept cell on the inner side of the widest of them.
    pub inside: CellId,
    /// The cell on its outer side, removed as exterior ([`HULL`] for a hull opening).
    pub outside: CellId,
}

/// A raw sealed portal or hull opening, before grouping.
struct Raw {
    width: f64,
    point: [f64; 3],
    area: f64,
    inside: CellId,
    outside: CellId,
}

/// How a leaking region was split.
pub(super) struct RegionSplit {
    pub(super) exterior: Vec<CellId>,
    pub(super) exterior_regions: usize,
    pub(super) interior_regions: usize,
    pub(super) sealed: Vec<SealedOpening>,
}

/// The sealing size, how a leaking region is split, the clearance field of the model, and
/// memoised portal widths.
pub(super) struct Sealer {
    size: f64,
    /// [`CellComplex::seal_cracks_auto`]'s split (components over wide portals, kept by
    /// the occluder side they mostly see) instead of [`CellComplex::seal_holes`]'s (the
    /// outside part reached from wide hull openings).
    components: bool,
    field: ClearanceField,
    widths: HashMap<usize, (f64, [f64; 3])>,
}

impl Sealer {
    fn with_split(model: &Model, size: f64, components: bool) -> Sealer {
        let polys: Vec<Vec<[f64; 3]>> = model
            .polygons
            .iter()
            .map(|p| p.verts.iter().map(|v| model.vertices[v.idx()]).collect())
            .collect();
        Sealer {
            size,
            components,
            field: ClearanceField::from_polygons(polys.iter().map(|v| v.as_slice())),
            widths: HashMap::new(),
        }
    }

    pub(super) fn new(model: &Model, size: f64) -> Sealer {
        Sealer::with_split(model, size, false)
    }

    /// The width of a hull opening of a cell: over its open `pieces` ([`Self::width`]), or,
    /// when the opening has no pieces (a flat cell's face on the hull), twice the clearance
    /// at its point `q`.
    fn hull_width(&self, pieces: &[ConvexPolygon], q: &[f64; 3]) -> (f64, [f64; 3]) {
        if pieces.is_empty() {
            (2.0 * self.field.distance(*q), *q)
        } else {
            self.width(pieces)
        }
    }

    /// Twice the largest sampled clearance over `pieces`, and where; stops early once the
    /// opening is known to be at least the sealing size wide.
    fn width(&self, pieces: &[ConvexPolygon]) -> (f64, [f64; 3]) {
        let mut best = (0.0, pieces.first().map_or([0.0; 3], |p| p.centroid()));
        let try_point = |p: [f64; 3], best: &mut (f64, [f64; 3])| {
            let w = 2.0 * self.field.distance(p);
            if w > best.0 {
                *best = (w, p);
            }
            best.0 >= self.size
        };
        for q in pieces {
            let c = q.centroid();
            if try_point(c, &mut best) {
                return best;
            }
            let n = q.verts.len();
            for i in 0..n {
                let (a, b) = (q.verts[i], q.verts[(i + 1) % n]);
                for i1 in 0..=4u32 {
                    for i2 in 0..=(4 - i1) {
                        let i0 = 4 - i1 - i2;
                        if i0 == 4 || i1 == 4 {
                            continue; // the centroid, done; vertex `a`, the previous `b`
                        }
                        let (w0, w1, w2) = (i0 as f64 / 4.0, i1 as f64 / 4.0, i2 as f64 / 4.0);
                        let p = [0, 1, 2].map(|k| w0 * c[k] + w1 * a[k] + w2 * b[k]);
                        if try_point(p, &mut best) {
                            return best;
                        }
                    }
                }
            }
        }
        best
    }

    /// The sealed-opening record of portal `k` between kept cell `inside` and `outside`.
    fn portal_raw(&mut self, cx: &CellComplex, k: usize, inside: CellId, outside: CellId) -> Raw {
        let (width, point) = self.portal_width(cx, k);
        Raw {
            width,
            point,
            area: cx.portals[k].area,
            inside,
            outside,
        }
    }

    fn portal_width(&mut self, cx: &CellComplex, k: usize) -> (f64, [f64; 3]) {
        if let Some(&w) = self.widths.get(&k) {
            return w;
        }
        let w = self.width(&cx.portals[k].pieces);
        self.widths.insert(k, w);
        w
    }

    /// Whether portal `k` is narrower than the sealing size.
    fn narrow(&mut self, cx: &CellComplex, k: usize) -> bool {
        self.portal_width(cx, k).0 < self.size
    }

    /// Splits a leaking region (see the module docs); `None` when sealing does not stop
    /// the leak (the outside part faces an occluder).
    pub(super) fn split_region(
        &mut self,
        cx: &CellComplex,
        members: &[CellId],
        adj: &super::graph::Adjacency,
        hull_open: &HashMap<CellId, (Vec<ConvexPolygon>, [f64; 3])>,
    ) -> Option<RegionSplit> {
        if self.components {
            return self.split_components(cx, members, adj, hull_open, false);
        }
        // Hull openings: wide ones seed the outside part, narrow ones are sealed.
        let mut narrow_hull: HashMap<CellId, Raw> = HashMap::new();
        let mut outside: HashSet<CellId> = HashSet::new();
        let mut queue = VecDeque::new();
        for &c in members {
            let Some((pieces, q)) = hull_open.get(&c) else {
                continue;
            };
            let (w, p) = self.hull_width(pieces, q);
            if w >= self.size {
                if outside.insert(c) {
                    queue.push_back(c);
                }
            } else {
                let area = pieces.iter().map(|p| p.area()).sum();
                narrow_hull.insert(
                    c,
                    Raw {
                        width: w,
                        point: p,
                        area,
                        inside: c,
                        outside: HULL,
                    },
                );
            }
        }
        // The outside part: through wide portals only.
        while let Some(c) = queue.pop_front() {
            for &(m, k) in &adj[c.idx()] {
                if !outside.contains(&m) && self.portal_width(cx, k).0 >= self.size {
                    outside.insert(m);
                    queue.push_back(m);
                }
            }
        }
        if outside.iter().any(|&c| cx.faces_occluder(c)) {
            // The outside part touches an occluder: either a wide opening joins it to a
            // room, or it sees fragments of walls' fronts through cracks narrower than
            // the size (noise on a model with T-junctions opens such cracks along every
            // T-junction, on both sides of each wall). Decide by the sides the
            // components over wide portals mostly see, as for cracks, as long as the
            // fronts seen from the removed components are less than those kept.
            return self.split_components(cx, members, adj, hull_open, true);
        }
        let mut split = RegionSplit {
            exterior: outside.iter().copied().collect(),
            exterior_regions: usize::from(!outside.is_empty()),
            interior_regions: 0,
            sealed: Vec::new(),
        };
        split.exterior.sort_unstable();
        // The rest, joined through every portal.
        let mut seen: HashSet<CellId> = outside.clone();
        let mut raw = Vec::new();
        for &s in members {
            if !seen.insert(s) {
                continue;
            }
            let mut sub = vec![s];
            let mut i = 0;
            while i < sub.len() {
                let c = sub[i];
                i += 1;
                for &(m, _) in &adj[c.idx()] {
                    if seen.insert(m) {
                        sub.push(m);
                    }
                }
            }
            if !sub.iter().any(|&c| cx.faces_occluder(c)) {
                split.exterior_regions += 1;
                split.exterior.extend(sub);
                continue;
            }
            split.interior_regions += 1;
            for &c in &sub {
                if let Some(r) = narrow_hull.remove(&c) {
                    raw.push(r);
                }
                for &(m, k) in &adj[c.idx()] {
                    if outside.contains(&m) {
                        raw.push(self.portal_raw(cx, k, c, m));
                    }
                }
            }
        }
        split.sealed = group(raw, self.size);
        Some(split)
    }
}

impl Sealer {
    /// [`CellComplex::seal_cracks_auto`]'s split of a leaking region: its components with
    /// narrow portals closed. A component is kept when it faces an occluder and more than
    /// half of the (non-sliver) occluder area its cells touch faces it
    /// ([`FRONT_SHARE`]); the others are exterior (the outside, the inside of walls, and
    /// the wall's other side reached through a crack, which may touch a few fragments of
    /// a noisy wall's front). Kept components are joined again through every portal
    /// (narrow passages between rooms stay open). `None` when a kept component still
    /// reaches the hull through a wide opening (a real leak, reported as without
    /// sealing). With `fragments_only` ([`CellComplex::seal_holes`]' fallback), also
    /// `None` when the removed components see at least as much front area as the kept
    /// ones (the fronts the outside sees must be fragments seen through cracks, not a
    /// room joined to it by a wider opening).
    fn split_components(
        &mut self,
        cx: &CellComplex,
        members: &[CellId],
        adj: &super::graph::Adjacency,
        hull_open: &HashMap<CellId, (Vec<ConvexPolygon>, [f64; 3])>,
        fragments_only: bool,
    ) -> Option<RegionSplit> {
        // Components over wide portals, in member order (deterministic).
        let mut comp: HashMap<CellId, usize> = HashMap::new();
        let mut comps: Vec<Vec<CellId>> = Vec::new();
        for &s in members {
            if comp.contains_key(&s) {
                continue;
            }
            let id = comps.len();
            comp.insert(s, id);
            let mut sub = vec![s];
            let mut i = 0;
            while i < sub.len() {
                let c = sub[i];
                i += 1;
                for &(m, k) in &adj[c.idx()] {
                    if !comp.contains_key(&m) && !self.narrow(cx, k) {
                        comp.insert(m, id);
                        sub.push(m);
                    }
                }
            }
            comps.push(sub);
        }
        let (mut kept_front, mut removed_front) = (0.0, 0.0);
        let kept: Vec<bool> = comps
            .iter()
            .map(|cs| {
                let (front, back) = cs.iter().fold((0.0, 0.0), |(f, b), &c| {
                    let (f1, b1) = faced_areas(cx, c);
                    (f + f1, b + b1)
                });
                let keep = cs.iter().any(|&c| cx.faces_occluder(c)) && front > FRONT_SHARE * (front + back);
                if keep {
                    kept_front += front;
                } else {
                    removed_front += front;
                }
                keep
            })
            .collect();
        // With a size given, the fronts seen from removed components must be fragments
        // (seen through cracks): a room joined to the outside by an opening wider than
        // the size must not go with the outside.
        if fragments_only && removed_front >= kept_front {
            return None;
        }
        // Hull openings of kept components: a wide one is a real leak, narrow ones are
        // sealed.
        let mut raw = Vec::new();
        for (id, cs) in comps.iter().enumerate() {
            if !kept[id] {
                continue;
            }
            for &c in cs {
                let Some((pieces, q)) = hull_open.get(&c) else {
                    continue;
                };
                let (w, p) = self.hull_width(pieces, q);
                if w >= self.size {
                    return None;
                }
                raw.push(Raw {
                    width: w,
                    point: p,
                    area: pieces.iter().map(|p| p.area()).sum(),
                    inside: c,
                    outside: HULL,
                });
            }
        }
        let mut split = RegionSplit {
            exterior: Vec::new(),
            exterior_regions: 0,
            interior_regions: 0,
            sealed: Vec::new(),
        };
        // Kept cells joined through every portal; the (narrow) portals from them to
        // exterior cells are the sealed openings.
        let mut seen: HashSet<CellId> = HashSet::new();
        for (id, cs) in comps.iter().enumerate() {
            if !kept[id] {
                split.exterior_regions += 1;
                split.exterior.extend(cs.iter().copied());
                continue;
            }
            if !seen.insert(cs[0]) {
                continue;
            }
            split.interior_regions += 1;
            let mut sub = vec![cs[0]];
            let mut i = 0;
            while i < sub.len() {
                let c = sub[i];
                i += 1;
                for &(m, k) in &adj[c.idx()] {
                    if kept[comp[&m]] {
                        if seen.insert(m) {
                            sub.push(m);
                        }
                    } else {
                        raw.push(self.portal_raw(cx, k, c, m));
                    }
                }
            }
        }
        split.exterior.sort_unstable();
        // Openings within a hundred sealing sizes of each other are one hole.
        split.sealed = group(raw, 100.0 * self.size);
        Some(split)
    }
}

/// The occluder area cell `c` sees from the front and from the back (slivers skipped).
fn faced_areas(cx: &CellComplex, c: CellId) -> (f64, f64) {
    let cell = &cx.cells[c.idx()];
    let (mut front, mut back) = (0.0, 0.0);
    for &t in cell.tags() {
        let p = &cx.patches[t as usize];
        let side = if p.cells[0] == c { 0 } else { 1 };
        for o in &p.occluders {
            if super::graph::is_sliver(&o.polygon, &cx.tol) {
                continue;
            }
            if o.faces == side {
                front += o.polygon.area();
            } else {
                back += o.polygon.area();
            }
        }
    }
    (front, back)
}

/// Groups raw openings into holes: two are in one hole when their points are closer than
/// `size` (single linkage). Sorted by position.
fn group(raw: Vec<Raw>, size: f64) -> Vec<SealedOpening> {
    let n = raw.len();
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], mut i: usize) -> usize {
        while p[i] != i {
            p[i] = p[p[i]];
            i = p[i];
        }
        i
    }
    for i in 0..n {
        for j in i + 1..n {
            let d = crate::base::vec::sub(&raw[i].point, &raw[j].point);
            if crate::base::vec::dot(&d, &d) < size * size {
                let (a, b) = (find(&mut parent, i), find(&mut parent, j));
                parent[a.max(b)] = a.min(b);
            }
        }
    }
    let mut groups: HashMap<usize, SealedOpening> = HashMap::new();
    for i in 0..n {
        let r = &raw[i];
        let g = find(&mut parent, i);
        let e = groups.entry(g).or_insert(SealedOpening {
            point: r.point,
            width: r.width,
            area: 0.0,
            portals: 0,
            inside: r.inside,
            outside: r.outside,
        });
        e.area += r.area;
        e.portals += 1;
        if r.width > e.width {
            e.width = r.width;
            e.point = r.point;
            e.inside = r.inside;
            e.outside = r.outside;
        }
    }
    let mut out: Vec<SealedOpening> = groups.into_values().collect();
    out.sort_by(|a, b| a.point.partial_cmp(&b.point).unwrap_or(std::cmp::Ordering::Equal));
    out
}

/// [`CellComplex::seal_cracks_auto`]: a component of a leaking region is kept when more
/// than this share of the occluder area its cells touch faces it (a room sees the walls'
/// fronts, the other side of a wall their backs; a crack does not change that).
pub const FRONT_SHARE: f64 = 0.5;

impl CellComplex {
    /// Seals the **cracks** of leaking regions, with no size given (`run`'s default,
    /// `--seal-holes auto`): stage 6 again with every opening narrower than the sliver
    /// width ([`crate::Tolerances::sliver_width`], the width below which the portal graph
    /// already drops a portal piece as a crack) closed. Such an opening is a portal lying
    /// on a wall, within rounding of it, that the wall's occluders do not cover. The
    /// leaking region's components over the other portals are kept when they face
    /// occluders and mostly their fronts ([`FRONT_SHARE`]), else removed as exterior; kept
    /// components are joined again through every portal. The openings sealed between kept
    /// and removed cells are returned (one per hole) and counted in
    /// `stats.openings_sealed`. A region whose kept part still reaches the hull through a
    /// wider opening stays a leak, reported as before. Does nothing without a leak.
    pub fn seal_cracks_auto(&mut self, model: &Model) -> Vec<SealedOpening> {
        if self.leaks.is_empty() {
            return Vec::new();
        }
        let sealer = Sealer::with_split(model, self.tol.sliver_width(), true);
        let sealed = self.reseal(Some(sealer), "sealing cracks (auto)");
        if self.stats.interior_regions == 0 {
            // The pass kept no region at all: the leaking regions' components each saw
            // as much of walls' backs as of fronts, so it could not tell rooms from the
            // outside (a noisy open building whose rooms reach the outside through 4 cm
            // gaps: single walls, each seen from both sides). Removing them all left `run`
            // with no cells and a warning about the faces' winding; the leaks are
            // reported as without sealing instead.
            self.reseal(None, "sealing cracks (auto): undone, nothing kept");
            return Vec::new();
        }
        sealed
    }

    /// Stage 6 again from a clean graph with `sealer` closing the openings it judges
    /// narrow (`None`: none, the plain exterior removal); counts and times the sealed
    /// openings under `stage`.
    fn reseal(&mut self, mut sealer: Option<Sealer>, stage: &str) -> Vec<SealedOpening> {
        let t0 = Instant::now();
        for c in &mut self.cells {
            c.exterior = false;
        }
        self.build_graph();
        self.stats.exterior_regions = 0;
        self.stats.interior_regions = 0;
        let sealed = self.remove_exterior_with(sealer.as_mut());
        self.stats.openings_sealed = sealed.len();
        self.stats.timings.push((stage.into(), t0.elapsed().as_secs_f64()));
        sealed
    }

    /// Seals openings narrower than `size` (model units) in leaking regions: redoes the
    /// exterior removal (stage 6) with such openings closed, as described in the module
    /// docs of `complex::seal`, and returns the sealed openings (one per hole). Leaks that
    /// need a wider opening stay in [`CellComplex::leaks`]. Does nothing (and returns
    /// nothing) when the complex has no leak or `size` is not positive.
    pub fn seal_holes(&mut self, model: &Model, size: f64) -> Vec<SealedOpening> {
        if self.leaks.is_empty() || size.is_nan() || size <= 0.0 {
            return Vec::new();
        }
        self.reseal(Some(Sealer::new(model, size)), "sealing holes")
    }
}
