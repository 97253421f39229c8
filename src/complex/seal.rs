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
//!   the size joins the inside to the outside: the region stays whole and its leak is
//!   reported as without sealing (qbsp's path and pointfile).
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

/// The sealing size, the clearance field of the model, and memoised portal widths.
pub(super) struct Sealer {
    size: f64,
    field: ClearanceField,
    widths: HashMap<usize, (f64, [f64; 3])>,
}

impl Sealer {
    pub(super) fn new(model: &Model, size: f64) -> Sealer {
        let polys: Vec<Vec<[f64; 3]>> = model
            .polygons
            .iter()
            .map(|p| p.verts.iter().map(|v| model.vertices[v.idx()]).collect())
            .collect();
        Sealer {
            size,
            field: ClearanceField::from_polygons(polys.iter().map(|v| v.as_slice())),
            widths: HashMap::new(),
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

    fn portal_width(&mut self, cx: &CellComplex, k: usize) -> (f64, [f64; 3]) {
        if let Some(&w) = self.widths.get(&k) {
            return w;
        }
        let w = self.width(&cx.portals[k].pieces);
        self.widths.insert(k, w);
        w
    }

    /// Splits a leaking region (see the module docs); `None` when sealing does not stop
    /// the leak (the outside part faces an occluder).
    pub(super) fn split_region(
        &mut self,
        cx: &CellComplex,
        members: &[CellId],
        adj: &[Vec<(CellId, usize)>],
        hull_open: &HashMap<CellId, (Vec<ConvexPolygon>, [f64; 3])>,
    ) -> Option<RegionSplit> {
        // Hull openings: wide ones seed the outside part, narrow ones are sealed.
        let mut narrow_hull: HashMap<CellId, Raw> = HashMap::new();
        let mut outside: HashSet<CellId> = HashSet::new();
        let mut queue = VecDeque::new();
        for &c in members {
            let Some((pieces, q)) = hull_open.get(&c) else {
                continue;
            };
            let (w, p) = if pieces.is_empty() {
                (2.0 * self.field.distance(*q), *q)
            } else {
                self.width(pieces)
            };
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
            return None;
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
                        let (width, point) = self.portal_width(cx, k);
                        raw.push(Raw {
                            width,
                            point,
                            area: cx.portals[k].area,
                            inside: c,
                            outside: m,
                        });
                    }
                }
            }
        }
        split.sealed = group(raw, self.size);
        Some(split)
    }
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

impl CellComplex {
    /// Seals openings narrower than `size` (model units) in leaking regions: redoes the
    /// exterior removal (stage 6) with such openings closed, as described in the module
    /// docs of `complex::seal`, and returns the sealed openings (one per hole). Leaks that
    /// need a wider opening stay in [`CellComplex::leaks`]. Does nothing (and returns
    /// nothing) when the complex has no leak or `size` is not positive.
    pub fn seal_holes(&mut self, model: &Model, size: f64) -> Vec<SealedOpening> {
        if self.leaks.is_empty() || size.is_nan() || size <= 0.0 {
            return Vec::new();
        }
        let t0 = Instant::now();
        for c in &mut self.cells {
            c.exterior = false;
        }
        self.build_graph();
        self.stats.exterior_regions = 0;
        self.stats.interior_regions = 0;
        let mut sealer = Sealer::new(model, size);
        let sealed = self.remove_exterior_with(Some(&mut sealer));
        self.stats.openings_sealed = sealed.len();
        self.stats
            .timings
            .push(("sealing holes".into(), t0.elapsed().as_secs_f64()));
        sealed
    }
}
